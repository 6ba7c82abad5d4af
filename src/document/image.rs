//! The file's `image` section: size and sampling.

use super::Checker;
use crate::error::Problem;
use crate::format;
use crate::raster::{MotionBlur, Raster, MAX_PIXELS, MAX_SAMPLES, MAX_SIDE, MAX_TIME_SAMPLES};

/// The problems an image size and sampling would have as the file's `image`.
pub(super) fn raster_problems(raster: Raster) -> Vec<Problem> {
    let spec = format::ImageSpec {
        width: Some(raster.width.into()),
        height: Some(raster.height.into()),
        samples: Some(raster.samples.into()),
        adaptive: Some(raster.adaptive),
        motion_blur: None,
    };
    let mut checker = Checker::default();
    checker.raster(&spec);
    checker.problems
}

impl Checker {
    pub(super) fn raster(&mut self, image: &format::ImageSpec) -> Option<Raster> {
        let mut ok = true;
        let mut side = |c: &mut Self, field: &str, value: Option<i64>, default: u32| {
            let value = value.unwrap_or(i64::from(default));
            let side = c.count(field, value, MAX_SIDE, ("", " pixels"));
            ok &= side.is_some();
            side.unwrap_or(1)
        };
        let width = side(self, "image.width", image.width, 640);
        let height = side(self, "image.height", image.height, 360);
        if ok && u64::from(width) * u64::from(height) > MAX_PIXELS {
            self.problem(
                "image",
                format!("{width}×{height} exceeds {MAX_PIXELS} pixels per frame"),
            );
            ok = false;
        }
        let samples = image.samples.unwrap_or(1);
        let grid = ("", " (an s×s grid per pixel)");
        let samples = self.count("image.samples", samples, MAX_SAMPLES, grid);
        ok.then_some(Raster {
            width,
            height,
            samples: samples?,
            adaptive: image.adaptive.unwrap_or(false),
        })
    }

    /// `image.motion_blur`, None when the file has none (or it is bad: then a problem names
    /// the field).
    pub(super) fn motion_blur(&mut self, image: &format::ImageSpec) -> Option<MotionBlur> {
        let spec = image.motion_blur.as_ref()?;
        let shutter = self.finite("image.motion_blur.shutter", spec.shutter);
        let shutter = shutter.and_then(|s| {
            let message = || {
                format!("the fraction of the frame interval the shutter is open must lie in (0, 1], got {s}")
            };
            self.ensure("image.motion_blur.shutter", s > 0.0 && s <= 1.0, s, message)
        });
        let per_frame = ("time samples per frame ", "");
        let samples = self.count(
            "image.motion_blur.samples",
            spec.samples,
            MAX_TIME_SAMPLES,
            per_frame,
        );
        Some(MotionBlur {
            shutter: shutter?,
            samples: samples?,
        })
    }
}
