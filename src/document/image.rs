//! The file's `image` section: size and sampling.

use super::Checker;
use crate::format;
use crate::raster::{Raster, MAX_PIXELS, MAX_SAMPLES, MAX_SIDE};

impl Checker {
    pub(super) fn raster(&mut self, image: &format::ImageSpec) -> Option<Raster> {
        let width = image.width.unwrap_or(640);
        let height = image.height.unwrap_or(360);
        let samples = image.samples.unwrap_or(1);
        let mut ok = true;
        for (field, side) in [("image.width", width), ("image.height", height)] {
            if side == 0 || side > MAX_SIDE {
                self.problem(
                    field,
                    format!("must lie in 1..={MAX_SIDE} pixels, got {side}"),
                );
                ok = false;
            }
        }
        if ok && u64::from(width) * u64::from(height) > MAX_PIXELS {
            self.problem(
                "image",
                format!("{width}×{height} exceeds {MAX_PIXELS} pixels per frame"),
            );
            ok = false;
        }
        if samples == 0 || samples > MAX_SAMPLES {
            self.problem(
                "image.samples",
                format!("must lie in 1..={MAX_SAMPLES} (an s×s grid per pixel), got {samples}"),
            );
            ok = false;
        }
        ok.then_some(Raster {
            width,
            height,
            samples,
            adaptive: image.adaptive.unwrap_or(false),
        })
    }
}
