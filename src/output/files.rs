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
        ["fast", "default", "best"][self as usize]
    }
}

/// Writes `width`×`height` RGB8 pixels as an 8-bit sRGB PNG.
pub fn write_png(
    path: &Path,
    pixels: &[u8],
    size: (u32, u32),
    compression: Compression,
) -> Result<()> {
    let file = std::fs::File::create(path).map_err(Error::write(path))?;
    encode_png(path, file, pixels, size, compression)
}

/// Writes a PNG under a temporary name beside `path` and renames it into place, so a render
/// killed at any moment leaves no partial PNG under a final name.
pub fn write_png_atomic(
    path: &Path,
    pixels: &[u8],
    size: (u32, u32),
    compression: Compression,
) -> Result<()> {
    through_temp(path, |file| {
        encode_png(path, file, pixels, size, compression)
    })
}

/// Encodes the PNG of `path` into `file`.
pub fn encode_png(
    path: &Path,
    file: impl std::io::Write,
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
    let mut out = BufWriter::new(file);
    PngEncoder::new_with_quality(&mut out, level, filter)
        .write_image(pixels, width, height, image::ExtendedColorType::Rgb8)
        .map_err(Error::encode(path))?;
    // Flushed here, not on drop, which would pass over a failed write (a full disk) and let a
    // cut-off PNG be renamed into place.
    std::io::Write::flush(&mut out).map_err(Error::write(path))
}

/// The hash of a PNG's RGB8 pixels, or None if it is missing or does not decode.
pub fn png_hash(path: &Path) -> Option<FrameHash> {
    let img = image::open(path).ok()?.to_rgb8();
    Some(FrameHash::of(img.as_raw()))
}

/// A new empty file beside `path` under a temporary name of its own, `.NAME.XXXXXX.tmp`, so
/// that two writers of one path never share one; renamed into place by `persist`, and
/// dropped unrenamed it is removed. Its permissions are a plain new file's.
pub fn temp_beside(path: &Path) -> Result<tempfile::NamedTempFile> {
    let mut prefix = std::ffi::OsString::from(".");
    prefix.push(path.file_name().unwrap_or_default());
    prefix.push(".");
    let mut builder = tempfile::Builder::new();
    builder.prefix(&prefix).suffix(TMP);
    #[cfg(unix)]
    builder.permissions(std::os::unix::fs::PermissionsExt::from_mode(0o666));
    builder
        .tempfile_in(folder_of(path))
        .map_err(Error::write(path))
}

/// Writes `path` through a [`temp_beside`] file that `fill` writes, renamed into place: the
/// file appears whole or not at all, and on any failure the temporary file is removed.
fn through_temp<T>(path: &Path, fill: impl FnOnce(&mut std::fs::File) -> Result<T>) -> Result<T> {
    let mut tmp = temp_beside(path)?;
    let value = fill(tmp.as_file_mut())?;
    tmp.persist(path).map_err(|e| Error::write(path)(e.error))?;
    Ok(value)
}

/// The ending of a file written under a temporary name.
const TMP: &str = ".tmp";

/// The name a temporary file stands for: `NAME` of `.NAME.XXXXXX.tmp`, or of an earlier
/// campath's `NAME.tmp`; None for a name that is not a temporary one.
pub fn temp_of(name: &str) -> Option<&str> {
    let stem = name.strip_suffix(TMP)?;
    let unique = stem
        .strip_prefix('.')
        .and_then(|s| s.rsplit_once('.'))
        .filter(|(_, random)| {
            random.len() == 6 && random.bytes().all(|b| b.is_ascii_alphanumeric())
        });
    Some(unique.map_or(stem, |(name, _)| name))
}

/// The final name of a file campath may have left under a temporary name: [`temp_of`], or the
/// name itself.
pub fn final_name(name: &str) -> &str {
    temp_of(name).unwrap_or(name)
}

/// Removes what writes of `path` left under temporary names.
pub fn remove_temps_of(path: &Path) -> Result<()> {
    let Some(name) = path.file_name().and_then(|n| n.to_str()) else {
        return Ok(());
    };
    let entries = std::fs::read_dir(folder_of(path)).into_iter().flatten();
    for e in entries.flatten() {
        if e.file_name().to_str().and_then(temp_of) == Some(name) {
            remove_if_there(&e.path())?;
        }
    }
    Ok(())
}

/// Writes `bytes` (text or not) to `path` through a temporary file and a rename; on a
/// failure the temporary file is removed.
pub fn write_atomic(path: &Path, bytes: impl AsRef<[u8]>) -> Result<()> {
    write_atomic_with(path, |out| {
        out.write_all(bytes.as_ref()).map_err(Error::stdout)
    })
}

/// Writes `path` through a temporary file and a rename, as `write` streams into it (buffered):
/// the file appears whole or not at all. A failure of `write` to write (reported as one to
/// standard output, [`Error::stdout`]) names `path`; on any failure the temporary file is
/// removed.
pub fn write_atomic_with<T>(
    path: &Path,
    write: impl FnOnce(&mut dyn std::io::Write) -> Result<T>,
) -> Result<T> {
    through_temp(path, |file| {
        let mut out = BufWriter::new(file);
        let value = write(&mut out).map_err(|e| match e {
            Error::Write { path: p, cause } if p.as_os_str() == "<stdout>" => {
                Error::write(path)(cause)
            }
            e => e,
        })?;
        out.into_inner()
            .map_err(|e| Error::write(path)(e.into_error()))?;
        Ok(value)
    })
}

/// Removes the file at `path` if there is one: whether there was.
pub fn remove_if_there(path: &Path) -> Result<bool> {
    match std::fs::remove_file(path) {
        Ok(()) => Ok(true),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(false),
        Err(e) => Err(Error::write(path)(e)),
    }
}

/// The folder a file at `path` goes into (`.` for a bare name).
pub fn folder_of(path: &Path) -> &Path {
    let parent = path.parent().filter(|p| !p.as_os_str().is_empty());
    parent.unwrap_or(Path::new("."))
}

/// `path` made absolute and free of `.` and `..`, with symbolic links resolved as far as it
/// exists (the rest need not exist yet): component by component, each prefix that exists taken
/// to its real path, so a `..` leaves the real folder (a link's target, not the link's), and a
/// `..` after a folder not made yet (`new/../link`) takes it back, as it will be a real folder.
pub fn resolved(path: &Path) -> PathBuf {
    use std::path::Component;
    // An empty path (the parent of a bare file name) is the current folder.
    let path = Some(path).filter(|p| !p.as_os_str().is_empty());
    let path = path.unwrap_or(Path::new("."));
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

#[cfg(test)]
mod tests {
    use super::*;

    /// A temporary name stands for its file, this campath's form and an earlier one's; other
    /// names stand for none.
    #[test]
    fn a_temporary_name_gives_back_its_file() {
        assert_eq!(
            temp_of(".frame_0001.png.aZ09xy.tmp"),
            Some("frame_0001.png")
        );
        assert_eq!(temp_of(".hashes.txt.000000.tmp"), Some("hashes.txt"));
        assert_eq!(temp_of("frame_0001.png.tmp"), Some("frame_0001.png"));
        assert_eq!(temp_of("frame_0001.png"), None);
        assert_eq!(final_name("frame_0001.png"), "frame_0001.png");
        // Not six letters and digits: the older form, a dot-file's name.
        assert_eq!(temp_of(".a.b-c.tmp"), Some(".a.b-c"));
    }

    /// Two writers of one path each write their own temporary file: the file is one writer's
    /// bytes whole, and nothing is left beside it.
    #[test]
    fn writes_of_one_path_do_not_share_a_temporary_file() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("a.txt");
        let (a, b) = (temp_beside(&path).unwrap(), temp_beside(&path).unwrap());
        assert_ne!(a.path(), b.path());
        let name = a.path().file_name().unwrap().to_str().unwrap().to_string();
        assert_eq!(temp_of(&name), Some("a.txt"), "{name}");
        std::fs::write(a.path(), "first").unwrap();
        std::fs::write(b.path(), "second").unwrap();
        a.persist(&path).unwrap();
        assert_eq!(std::fs::read_to_string(&path).unwrap(), "first");
        drop(b);
        write_atomic(&path, "third").unwrap();
        assert_eq!(std::fs::read_to_string(&path).unwrap(), "third");
        let names: Vec<_> = std::fs::read_dir(dir.path()).unwrap().collect();
        assert_eq!(names.len(), 1);
    }

    /// A file written whole has a plain new file's permissions, not a temporary file's 0600.
    #[cfg(unix)]
    #[test]
    fn a_file_written_whole_has_a_new_files_permissions() {
        use std::os::unix::fs::PermissionsExt;
        let dir = tempfile::tempdir().unwrap();
        let (plain, whole) = (dir.path().join("plain"), dir.path().join("whole"));
        std::fs::write(&plain, "x").unwrap();
        write_atomic(&whole, "x").unwrap();
        let mode = |p: &Path| std::fs::metadata(p).unwrap().permissions().mode() & 0o777;
        assert_eq!(mode(&whole), mode(&plain));
    }

    /// What writes of a file left under temporary names is removed, and nothing else.
    #[test]
    fn the_temporary_files_of_a_path_are_removed() {
        let dir = tempfile::tempdir().unwrap();
        let video = dir.path().join("zoom.mp4");
        let left = temp_beside(&video).unwrap().keep().unwrap().1;
        std::fs::write(dir.path().join("zoom.mp4.tmp"), "").unwrap();
        std::fs::write(dir.path().join("other.mp4.tmp"), "").unwrap();
        remove_temps_of(&video).unwrap();
        assert!(!left.exists());
        assert!(!dir.path().join("zoom.mp4.tmp").exists());
        assert!(dir.path().join("other.mp4.tmp").exists());
        remove_temps_of(&video).unwrap();
    }
}
