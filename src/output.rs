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
