//! The pictures a frame-hash test leaves to look at: a golden's small picture of each frame,
//! and how a frame differs from its golden picture.

use std::path::Path;

use crate::output::{encode_png, Compression};

/// The longest side of a golden's small picture of a frame, in pixels, when it fits
/// [`THUMB_BYTES`].
pub const THUMB_SIDE: u32 = 160;

/// The most a golden's small picture of a frame costs: bytes of its PNG file. A picture that
/// would cost more is made smaller, by halves, until it fits.
pub const THUMB_BYTES: usize = 12 * 1024;

/// A frame's small picture: its RGB8 pixels, size and PNG file.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Thumb {
    /// RGB8, row by row.
    pub pixels: Vec<u8>,
    /// Width and height.
    pub size: (u32, u32),
    /// The PNG file, at most [`THUMB_BYTES`].
    pub png: Vec<u8>,
}

/// The small picture of a `size` frame's RGB8 `pixels`: each pixel the rounded mean of the
/// box of frame pixels it covers (integers only, so the same bytes on every machine), at most
/// [`THUMB_SIDE`] on its longest side, halved until its PNG fits [`THUMB_BYTES`].
pub fn thumbnail(pixels: &[u8], size: (u32, u32)) -> Thumb {
    let mut side = THUMB_SIDE;
    loop {
        let (w, h) = size;
        let scale = |x: u32| (u64::from(x) * u64::from(side) / u64::from(w.max(h))).max(1) as u32;
        let small = if w.max(h) <= side {
            size
        } else {
            (scale(w), scale(h))
        };
        let pixels = shrink(pixels, size, small);
        let mut png = Vec::new();
        encode_png(
            Path::new("thumbnail"),
            &mut png,
            &pixels,
            small,
            Compression::Best,
        )
        .expect("encoding into memory");
        if png.len() <= THUMB_BYTES || side == 1 {
            return Thumb {
                pixels,
                size: small,
                png,
            };
        }
        side /= 2;
    }
}

/// `pixels` of a `from` picture averaged down to `to`.
pub(crate) fn shrink(pixels: &[u8], from: (u32, u32), to: (u32, u32)) -> Vec<u8> {
    let [w, h, tw, th] = [from.0, from.1, to.0, to.1].map(u64::from);
    let mut out = Vec::with_capacity((tw * th * 3) as usize);
    for ty in 0..th {
        let ys = ty * h / th..(ty + 1) * h / th;
        for tx in 0..tw {
            let xs = tx * w / tw..(tx + 1) * w / tw;
            let mut sum = [0u64; 3];
            for y in ys.clone() {
                let row =
                    &pixels[((y * w + xs.start) * 3) as usize..((y * w + xs.end) * 3) as usize];
                for p in row.chunks_exact(3) {
                    (0..3).for_each(|c| sum[c] += u64::from(p[c]));
                }
            }
            let n = (ys.end - ys.start) * (xs.end - xs.start);
            out.extend(sum.map(|s| ((s + n / 2) / n) as u8));
        }
    }
    out
}

/// How a differing frame differs from its golden picture.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct PixelDiff {
    /// Pixels with any channel changed.
    pub changed: u64,
    /// The largest change of one channel, in levels of 255.
    pub largest: u8,
}

impl std::fmt::Display for PixelDiff {
    fn fmt(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
        let (changed, largest) = (self.changed, self.largest);
        write!(
            f,
            "{changed} pixel(s) changed, largest difference {largest} level(s)"
        )
    }
}

/// Marks a changed pixel in a difference image; unchanged pixels are the golden frame at a
/// third of its brightness, so they never take this colour.
pub(crate) const CHANGED: [u8; 3] = [255, 0, 255];

/// The difference image (changed pixels in [`CHANGED`] over the golden frame dimmed to a third)
/// and the changed-pixel count and largest per-channel difference.
pub(crate) fn difference(golden: &[u8], actual: &[u8]) -> (Vec<u8>, PixelDiff) {
    let mut image = Vec::with_capacity(golden.len());
    let mut diff = PixelDiff::default();
    for (g, a) in golden.chunks_exact(3).zip(actual.chunks_exact(3)) {
        if g == a {
            image.extend(g.iter().map(|c| c / 3));
        } else {
            diff.changed += 1;
            for (x, y) in g.iter().zip(a) {
                diff.largest = diff.largest.max(x.abs_diff(*y));
            }
            image.extend(CHANGED);
        }
    }
    (image, diff)
}

/// Pixels where some channel differs by more than `level`.
pub(crate) fn changed_over(golden: &[u8], actual: &[u8], level: u8) -> u64 {
    let pixels = golden.chunks_exact(3).zip(actual.chunks_exact(3));
    let over = |(g, a): (&[u8], &[u8])| g.iter().zip(a).any(|(x, y)| x.abs_diff(*y) > level);
    pixels.filter(|&p| over(p)).count() as u64
}

/// A picture's RGB8 pixels, when it exists, decodes, and has `size`.
pub(crate) fn pixels_of(path: &Path, size: (u32, u32)) -> Option<Vec<u8>> {
    let img = image::open(path).ok()?.to_rgb8();
    (img.dimensions() == size).then(|| img.into_raw())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn difference_counts_pixels_not_channels() {
        let golden = [10, 20, 30, 40, 50, 60];
        let actual = [10, 20, 30, 41, 50, 66];
        let (image, d) = difference(&golden, &actual);
        assert_eq!(
            d,
            PixelDiff {
                changed: 1,
                largest: 6
            }
        );
        assert_eq!(image, [3, 6, 10, 255, 0, 255]);
        assert_eq!(changed_over(&golden, &actual, 5), 1);
        assert_eq!(changed_over(&golden, &actual, 6), 0);
    }

    #[test]
    fn a_thumbnail_averages_boxes_and_keeps_to_its_budget() {
        // 4×2 → 2×1 at side 2: each output pixel the rounded mean of a 2×2 box.
        let px: Vec<u8> = (0..8u8).flat_map(|i| [i * 10, 0, 255]).collect();
        assert_eq!(shrink(&px, (4, 2), (2, 1)), [25, 0, 255, 45, 0, 255]);
        // A frame of noise does not compress: its picture is halved until it fits.
        let mut x = 1u32;
        let noise: Vec<u8> = (0..640 * 360 * 3)
            .map(|_| {
                x ^= x << 13;
                x ^= x >> 17;
                x ^= x << 5;
                x as u8
            })
            .collect();
        let t = thumbnail(&noise, (640, 360));
        assert!(
            t.png.len() <= THUMB_BYTES && t.size.0 < THUMB_SIDE,
            "{:?}",
            t.size
        );
        assert_eq!(t.size.0 * 9, t.size.1 * 16);
        let flat = thumbnail(&vec![7; 640 * 360 * 3], (640, 360));
        assert_eq!(flat.size, (160, 90));
        assert!(flat.pixels.iter().all(|&c| c == 7));
        assert_eq!(thumbnail(&[1, 2, 3], (1, 1)).size, (1, 1));
    }
}
