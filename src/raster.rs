//! The raster: image size and sampling, and their limits. Checked by [`crate::document`], used by
//! `render`.

/// Largest image side in pixels.
pub const MAX_SIDE: u32 = 16_384;
/// Largest pixel count of one frame.
pub const MAX_PIXELS: u64 = 1 << 26;
/// Largest samples-per-side.
pub const MAX_SAMPLES: u32 = 16;

/// Output size and sampling.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Raster {
    /// Pixels, 1 ..= [`MAX_SIDE`] (the renderer keeps pixel columns and rows in 16 bits, and
    /// panics on a side above 65,536).
    pub width: u32,
    /// Pixels, 1 ..= [`MAX_SIDE`], as `width`.
    pub height: u32,
    /// Samples per pixel side: an s×s grid at fixed positions, averaged.
    pub samples: u32,
    /// With s ≥ 2: trace the grid's four corner samples first, and where they see the same
    /// sphere lit by the same lights (or all the background), average those four and skip the
    /// rest of the grid.
    pub adaptive: bool,
}

impl Raster {
    /// Bytes of one RGB8 frame.
    pub fn frame_bytes(&self) -> usize {
        self.width as usize * self.height as usize * 3
    }
}

/// Largest number of time samples of motion blur.
pub const MAX_TIME_SAMPLES: u32 = 64;

/// Shutter motion blur: each frame is the mean of `samples` renders at times spread over the
/// part of the frame interval that the shutter is open, centred on the frame's time.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MotionBlur {
    /// The fraction of the frame interval the shutter is open, in (0, 1].
    pub shutter: f64,
    /// Time samples per frame, 1 to [`MAX_TIME_SAMPLES`].
    pub samples: u32,
}

impl MotionBlur {
    /// Time sample `j`'s offset from its frame's time, in frames: S·((j + 0.5)/N − 0.5), in
    /// (−S/2, S/2). Time sample j of frame k is at (k + offset(j)) / fps seconds; with N odd
    /// the middle sample's offset is exactly 0 (the frame's own time).
    pub fn offset(&self, j: u32) -> f64 {
        self.shutter * ((f64::from(j) + 0.5) / f64::from(self.samples) - 0.5)
    }

    /// Time sample `j` of frame `frame` at `fps` frames per second, in seconds.
    pub fn time(&self, frame: u64, j: u32, fps: f64) -> f64 {
        (frame as f64 + self.offset(j)) / fps
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn time_samples_are_centred_on_the_frame() {
        let blur = MotionBlur {
            shutter: 0.5,
            samples: 4,
        };
        let offsets: Vec<f64> = (0..4).map(|j| blur.offset(j)).collect();
        assert_eq!(offsets, [-3.0 / 16.0, -1.0 / 16.0, 1.0 / 16.0, 3.0 / 16.0]);
        assert_eq!(blur.time(2, 0, 16.0), (2.0 - 3.0 / 16.0) / 16.0);
        for n in [1, 3, 5, 63] {
            let odd = MotionBlur {
                shutter: 0.7,
                samples: n,
            };
            assert_eq!(odd.offset(n / 2), 0.0, "{n}");
            assert_eq!(odd.time(7, n / 2, 24.0), 7.0 / 24.0, "{n}");
        }
    }
}
