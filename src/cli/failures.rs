//! The folders where `verify --save-failures` and `test --review` put pictures of failures,
//! claimed before anything renders (see [`crate::output::claim_pictures`]), and the pictures:
//! difference images and pixel counts.

use std::path::{Path, PathBuf};

use super::error::{CliError, Result};
use crate::output::lock::FolderLock;
use crate::output::within;

/// Before anything is written: refuses a `--junit` report among the `goldens` or over a file
/// campath did not write, and claims the folder `dir`, named by `option`, for the run's pictures
/// of failures ([`crate::output::claim_pictures`]), waiting for another run that holds it. The
/// report may not lie in that folder: the folder is the run's pictures only, and a report there
/// would be refused as another's file by the next run.
pub fn claim(
    junit: Option<&Path>,
    dir: Option<&Path>,
    option: &str,
    goldens: &[PathBuf],
    ours: impl Fn(&str) -> bool,
) -> Result<Option<FolderLock>> {
    if let Some(path) = junit {
        crate::output::outside_goldens(path, goldens)
            .map_err(|r| CliError::refused("--junit", path, &r))?;
        super::junit::check_target(path)?;
    }
    let Some(dir) = dir else { return Ok(None) };
    if let Some(report) = junit.filter(|r| within(r, dir)) {
        return Err(CliError::Usage(format!(
            "--junit {} is in the {option} folder {}; nothing was written (choose a report path \
             outside it)",
            report.display(),
            dir.display()
        )));
    }
    super::progress::with_wait(false, false, |wait| {
        crate::output::claim_pictures(dir, goldens, ours, wait)
    })
    .map(Some)
    .map_err(|e| e.at(option, dir))
}

/// How a differing frame differs from its golden picture.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct PixelDiff {
    pub changed: u64,
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
pub const CHANGED: [u8; 3] = [255, 0, 255];

/// The difference image (changed pixels in [`CHANGED`] over the golden frame dimmed to a third)
/// and the changed-pixel count and largest per-channel difference.
pub fn difference(golden: &[u8], actual: &[u8]) -> (Vec<u8>, PixelDiff) {
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

/// A golden frame's RGB8 pixels, when it exists, decodes, and has `size`.
pub fn golden_pixels(path: &Path, size: (u32, u32)) -> Option<Vec<u8>> {
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
    }
}
