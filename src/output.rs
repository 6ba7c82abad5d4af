//! The frame sink: frame hashes, PNG files and the hashes.txt manifest.
//!
//! The frame hash is the SHA-256 of the frame's raw 8-bit RGB pixels, row-major, top row first:
//! anyone can recompute it from the PNG with any image library.

use sha2::{Digest, Sha256};
use std::fmt::Write as _;
use std::io::BufWriter;
use std::path::{Path, PathBuf};

use crate::error::{Error, Result};
use crate::render::Raster;

/// Lower-case hex SHA-256 of raw RGB8 pixels.
pub fn frame_hash(pixels: &[u8]) -> String {
    let digest = Sha256::digest(pixels);
    let mut hex = String::with_capacity(64);
    for b in digest {
        write!(hex, "{b:02x}").expect("writing to a String cannot fail");
    }
    hex
}

/// Digits of zero padding for frame numbers: enough for `frames − 1`, at least 4.
pub fn pad_width(frames: u64) -> usize {
    frames.saturating_sub(1).to_string().len().max(4)
}

/// `dir/frame_0042.png`, padded for `frames` frames.
pub fn frame_path(dir: &Path, frame: u64, frames: u64) -> PathBuf {
    dir.join(format!(
        "frame_{frame:0width$}.png",
        width = pad_width(frames)
    ))
}

/// PNG compression: a trade of encoding time against file size.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, clap::ValueEnum)]
pub enum Compression {
    /// Fastest encoding, larger files (the default).
    #[default]
    Fast,
    /// zlib's default level.
    Default,
    /// Smallest files, slowest encoding.
    Best,
}

/// Writes RGB8 pixels as an 8-bit sRGB PNG.
pub fn write_png(
    path: &Path,
    pixels: &[u8],
    raster: Raster,
    compression: Compression,
) -> Result<()> {
    use image::codecs::png::{CompressionType, FilterType, PngEncoder};
    use image::ImageEncoder;
    let (level, filter) = match compression {
        Compression::Fast => (CompressionType::Fast, FilterType::Adaptive),
        Compression::Default => (CompressionType::Default, FilterType::Adaptive),
        Compression::Best => (CompressionType::Best, FilterType::Adaptive),
    };
    let file = std::fs::File::create(path).map_err(|source| Error::Write {
        path: path.to_path_buf(),
        source,
    })?;
    PngEncoder::new_with_quality(BufWriter::new(file), level, filter)
        .write_image(
            pixels,
            raster.width,
            raster.height,
            image::ExtendedColorType::Rgb8,
        )
        .map_err(|source| Error::Encode {
            path: path.to_path_buf(),
            source,
        })
}

/// One `<frame index> <sha256 hex>` line.
pub fn hash_line(frame: u64, hash: &str) -> String {
    format!("{frame} {hash}")
}

/// Parses a hashes.txt: one `<frame index> <sha256 hex>` per line; blank lines are skipped.
pub fn parse_hashes(path: &Path, text: &str) -> Result<Vec<(u64, String)>> {
    let mut out = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let line = line.trim();
        if line.is_empty() {
            continue;
        }
        let bad = |what: &str| Error::Golden {
            path: path.to_path_buf(),
            message: format!(
                "line {}: {what}: expected `<frame index> <sha256 hex>`, got {line:?}",
                i + 1
            ),
        };
        let mut parts = line.split_whitespace();
        let frame = parts
            .next()
            .and_then(|f| f.parse::<u64>().ok())
            .ok_or_else(|| bad("bad frame index"))?;
        let hash = parts.next().ok_or_else(|| bad("missing hash"))?;
        if hash.len() != 64
            || !hash.bytes().all(|b| b.is_ascii_hexdigit())
            || parts.next().is_some()
        {
            return Err(bad("bad hash"));
        }
        out.push((frame, hash.to_ascii_lowercase()));
    }
    Ok(out)
}

/// Writes a PNG under a temporary name beside `path` and renames it into place, so a render
/// killed at any moment leaves no partial PNG under a final name.
pub fn write_png_atomic(
    path: &Path,
    pixels: &[u8],
    raster: Raster,
    compression: Compression,
) -> Result<()> {
    let tmp = tmp_path(path);
    write_png(&tmp, pixels, raster, compression)?;
    std::fs::rename(&tmp, path).map_err(|source| Error::Write {
        path: path.to_path_buf(),
        source,
    })
}

fn tmp_path(path: &Path) -> PathBuf {
    let mut name = path.file_name().unwrap_or_default().to_os_string();
    name.push(".tmp");
    path.with_file_name(name)
}

/// Writes `text` to `path` through a temporary file and a rename.
pub fn write_atomic(path: &Path, text: &str) -> Result<()> {
    let tmp = tmp_path(path);
    let err = |source| Error::Write {
        path: path.to_path_buf(),
        source,
    };
    std::fs::write(&tmp, text).map_err(err)?;
    std::fs::rename(&tmp, path).map_err(err)
}

/// The manifest name of a run: `hashes.txt`, or `hashes.part-K-of-N.txt` for shard K of N.
pub fn manifest_name(shard: Option<(u64, u64)>) -> String {
    match shard {
        None => "hashes.txt".into(),
        Some((k, n)) => format!("hashes.part-{k}-of-{n}.txt"),
    }
}

/// Whether campath writes files of this name into an output folder.
pub fn is_ours(name: &str) -> bool {
    let digits = |s: &str| !s.is_empty() && s.bytes().all(|b| b.is_ascii_digit());
    let frame = |s: &str| {
        s.strip_prefix("frame_")
            .and_then(|s| s.strip_suffix(".png"))
            .is_some_and(digits)
    };
    let part = |s: &str| {
        s.strip_prefix("hashes.part-")
            .and_then(|s| s.strip_suffix(".txt"))
            .and_then(|s| s.split_once("-of-"))
            .is_some_and(|(k, n)| digits(k) && digits(n))
    };
    let base = name.strip_suffix(".tmp").unwrap_or(name);
    frame(base)
        || part(base)
        || [
            "hashes.txt",
            "report.png",
            "preview.png",
            "preview.gif",
            "plot.png",
        ]
        .contains(&base)
}

/// Reads a manifest that a killed render may have left: lines that do not parse (a torn last
/// line) are dropped, and a later line for a frame replaces an earlier one.
pub fn read_manifest_lenient(path: &Path) -> std::collections::BTreeMap<u64, String> {
    let text = std::fs::read_to_string(path).unwrap_or_default();
    text.lines()
        .filter_map(|l| parse_hashes(path, l).ok())
        .flatten()
        .collect()
}

/// Sorted `<frame> <hash>` lines.
pub fn manifest_text(entries: &std::collections::BTreeMap<u64, String>) -> String {
    entries
        .iter()
        .map(|(f, h)| hash_line(*f, h) + "\n")
        .collect()
}

/// Combines the shard manifests `hashes.part-K-of-N.txt` in `dir` into the text of a single
/// run's hashes.txt. Every part of one N must be there, and no frame may have two hashes.
pub fn merge_parts(dir: &Path) -> Result<String> {
    let entries = std::fs::read_dir(dir).map_err(|source| Error::Read {
        path: dir.to_path_buf(),
        source,
    })?;
    let mut parts: Vec<(u64, u64, PathBuf)> = Vec::new();
    for e in entries.flatten() {
        let name = e.file_name().to_string_lossy().into_owned();
        if let Some((k, n)) = name
            .strip_prefix("hashes.part-")
            .and_then(|s| s.strip_suffix(".txt"))
            .and_then(|s| s.split_once("-of-"))
        {
            if let (Ok(k), Ok(n)) = (k.parse(), n.parse()) {
                parts.push((k, n, e.path()));
            }
        }
    }
    parts.sort();
    let bad = |message: String| Error::Golden {
        path: dir.to_path_buf(),
        message,
    };
    let Some(&(_, n, _)) = parts.first() else {
        return Err(bad("holds no hashes.part-K-of-N.txt to merge".into()));
    };
    if parts.iter().any(|p| p.1 != n) {
        return Err(bad("holds parts of different shard counts".into()));
    }
    let have: Vec<u64> = parts.iter().map(|p| p.0).collect();
    let missing: Vec<u64> = (0..n).filter(|k| !have.contains(k)).collect();
    if !missing.is_empty() {
        return Err(bad(format!("shard(s) {missing:?} of {n} are missing")));
    }
    let mut all = std::collections::BTreeMap::new();
    for (_, _, path) in &parts {
        let text = std::fs::read_to_string(path).map_err(|source| Error::Read {
            path: path.clone(),
            source,
        })?;
        for (frame, hash) in parse_hashes(path, &text)? {
            if let Some(other) = all.insert(frame, hash.clone()) {
                if other != hash {
                    return Err(bad(format!("frame {frame} has two different hashes")));
                }
            }
        }
    }
    Ok(manifest_text(&all))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hash_of_known_bytes() {
        // SHA-256("abc") from FIPS 180-2, appendix B.1.
        assert_eq!(
            frame_hash(b"abc"),
            "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad"
        );
    }

    #[test]
    fn padding_fits_the_frame_count() {
        assert_eq!(pad_width(1), 4);
        assert_eq!(pad_width(10_000), 4);
        assert_eq!(pad_width(10_001), 5);
        assert_eq!(
            frame_path(Path::new("o"), 7, 96),
            Path::new("o/frame_0007.png")
        );
    }

    #[test]
    fn hashes_round_trip_and_reject_junk() {
        let h = "ab".repeat(32);
        let text = format!("{}\n\n{}\n", hash_line(0, &h), hash_line(12, &h));
        let parsed = parse_hashes(Path::new("g"), &text).unwrap();
        assert_eq!(parsed, vec![(0, h.clone()), (12, h.clone())]);
        assert!(parse_hashes(Path::new("g"), "x abc").is_err());
        assert!(parse_hashes(Path::new("g"), "1 abc").is_err());
    }
}
