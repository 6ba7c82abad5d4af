//! Files written whole or not at all, and PNG files. Imports nothing above it.

use std::io::BufWriter;
use std::path::{Path, PathBuf};

use crate::error::{Error, Result};
use crate::hash::FrameHash;

/// PNG compression: a trade of encoding time against file size. The pixels are the same.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Compression {
    /// Fastest encoding, larger files (the default).
    #[default]
    Fast,
    /// zlib's default level.
    Default,
    /// Smallest files, slowest encoding.
    Best,
}

impl Compression {
    /// Every level, fastest first.
    pub const ALL: [Compression; 3] = [Compression::Fast, Compression::Default, Compression::Best];

    /// The level's name on the command line: `fast`, `default`, `best`.
    pub fn name(self) -> &'static str {
        match self {
            Compression::Fast => "fast",
            Compression::Default => "default",
            Compression::Best => "best",
        }
    }
}

impl std::str::FromStr for Compression {
    type Err = String;

    fn from_str(s: &str) -> std::result::Result<Compression, String> {
        Compression::ALL
            .into_iter()
            .find(|c| c.name() == s)
            .ok_or_else(|| format!("{s:?} is not a compression level"))
    }
}

/// Writes `width`×`height` RGB8 pixels as an 8-bit sRGB PNG.
pub fn write_png(
    path: &Path,
    pixels: &[u8],
    (width, height): (u32, u32),
    compression: Compression,
) -> Result<()> {
    use image::codecs::png::{CompressionType, FilterType, PngEncoder};
    use image::ImageEncoder;
    // Fast: the Paeth filter on every row, not a trial of each filter per row, which costs
    // more time than it saves bytes (docs/performance.md).
    let (level, filter) = match compression {
        Compression::Fast => (CompressionType::Fast, FilterType::Paeth),
        Compression::Default => (CompressionType::Default, FilterType::Adaptive),
        Compression::Best => (CompressionType::Best, FilterType::Adaptive),
    };
    let file = std::fs::File::create(path).map_err(Error::write(path))?;
    PngEncoder::new_with_quality(BufWriter::new(file), level, filter)
        .write_image(pixels, width, height, image::ExtendedColorType::Rgb8)
        .map_err(Error::encode(path))
}

/// Writes a PNG under a temporary name beside `path` and renames it into place, so a render
/// killed at any moment leaves no partial PNG under a final name.
pub fn write_png_atomic(
    path: &Path,
    pixels: &[u8],
    size: (u32, u32),
    compression: Compression,
) -> Result<()> {
    let tmp = tmp_path(path);
    let written = write_png(&tmp, pixels, size, compression)
        .and_then(|()| std::fs::rename(&tmp, path).map_err(Error::write(path)));
    if written.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    written
}

/// The hash of a PNG's RGB8 pixels, or None if it is missing or does not decode.
pub fn png_hash(path: &Path) -> Option<FrameHash> {
    let img = image::open(path).ok()?.to_rgb8();
    Some(FrameHash::of(img.as_raw()))
}

/// Where a file is written before it is renamed into place: `NAME.tmp` beside it.
pub fn tmp_path(path: &Path) -> PathBuf {
    let mut name = path.file_name().unwrap_or_default().to_os_string();
    name.push(".tmp");
    path.with_file_name(name)
}

/// Writes `bytes` (text or not) to `path` through a temporary file and a rename; on a
/// failure the temporary file is removed.
pub fn write_atomic(path: &Path, bytes: impl AsRef<[u8]>) -> Result<()> {
    let tmp = tmp_path(path);
    let err = Error::write(path);
    let written = std::fs::write(&tmp, bytes).and_then(|()| std::fs::rename(&tmp, path));
    if written.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    written.map_err(err)
}

/// Writes `path` through a temporary file and a rename, as `write` streams into it (buffered):
/// the file appears whole or not at all. A failure of `write` to write (reported as one to
/// standard output, [`Error::stdout`]) names `path`; on any failure the temporary file is
/// removed.
pub fn write_atomic_with<T>(
    path: &Path,
    write: impl FnOnce(&mut dyn std::io::Write) -> Result<T>,
) -> Result<T> {
    let tmp = tmp_path(path);
    let result = std::fs::File::create(&tmp)
        .map_err(Error::write(path))
        .and_then(|file| {
            let mut out = std::io::BufWriter::new(file);
            let value = write(&mut out).map_err(|e| match e {
                Error::Write { path: p, cause } if p.as_os_str() == "<stdout>" => {
                    Error::write(path)(cause)
                }
                e => e,
            })?;
            out.into_inner()
                .map_err(|e| e.into_error())
                .and_then(|_| std::fs::rename(&tmp, path))
                .map_err(Error::write(path))?;
            Ok(value)
        });
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result
}

/// Removes the file at `path` if there is one: whether there was.
pub fn remove_if_there(path: &Path) -> Result<bool> {
    match std::fs::remove_file(path) {
        Ok(()) => Ok(true),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(false),
        Err(e) => Err(Error::write(path)(e)),
    }
}

/// `path` made absolute and free of `.` and `..`, with symbolic links resolved as far as it
/// exists (the rest need not exist yet): component by component, each prefix that exists taken
/// to its real path, so a `..` leaves the real folder (a link's target, not the link's), and a
/// `..` after a folder not made yet (`new/../link`) takes it back, as it will be a real folder.
pub fn resolved(path: &Path) -> PathBuf {
    use std::path::Component;
    // An empty path (the parent of a bare file name) is the current folder.
    let path = match path.as_os_str().is_empty() {
        true => Path::new("."),
        false => path,
    };
    let absolute = std::path::absolute(path).unwrap_or_else(|_| path.to_path_buf());
    let mut out = PathBuf::new();
    for c in absolute.components() {
        match c {
            Component::CurDir => {}
            Component::ParentDir => {
                out.pop();
            }
            c => {
                out.push(c);
                if let Ok(real) = out.canonicalize() {
                    out = real;
                }
            }
        }
    }
    out
}
