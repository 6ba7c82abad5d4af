//! The raster: image size and sampling, and their limits. Checked by [`crate::document`], used by
//! [`crate::render`].

/// Largest image side in pixels.
pub const MAX_SIDE: u32 = 16_384;
/// Largest pixel count of one frame.
pub const MAX_PIXELS: u64 = 1 << 26;
/// Largest samples-per-side.
pub const MAX_SAMPLES: u32 = 16;

/// Output size and sampling.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Raster {
    /// Pixels, ≥ 1.
    pub width: u32,
    /// Pixels, ≥ 1.
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
