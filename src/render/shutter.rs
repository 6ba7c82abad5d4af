//! Motion blur's rows: the mean, in linear light, of a frame's renders at its time samples,
//! quantised to 8-bit sRGB once.
//!
//! Each band of rows is one task's, and its time samples are added in their order (time order), then
//! divided by their number: the bytes do not depend on the thread count, and since every
//! instruction path gives the same linear colours, not on the path either.

use super::drivers::{Pixel, RowJob};
use super::lanes::{Portable, LANES};
use super::simd::Isa;

/// The band of rows from `j` of a frame averaged over `jobs` (one per time sample, in time
/// order) into `band`, RGB8: each time sample's linear colours (its full pixel pattern: s×s
/// samples, adaptive included), summed in order, divided by their number, then the exact sRGB
/// level of the mean (the encoder's packets on the portable lanes: the same levels as one value
/// at a time).
pub fn mean_band(isa: Isa, jobs: &[RowJob], j: usize, band: &mut [u8]) {
    let mut sum = vec![0.0; band.len()];
    let mut linear = vec![0.0; band.len()];
    for job in jobs {
        job.band(isa, j, &mut linear);
        for (s, l) in sum.iter_mut().zip(&linear) {
            *s += l;
        }
    }
    let n = jobs.len() as f64;
    for (means, out) in sum.chunks(3 * LANES).zip(band.chunks_mut(3 * LANES)) {
        let mut pixels = [[0.0; 3]; LANES];
        for (p, px) in pixels.iter_mut().zip(means.chunks_exact(3)) {
            *p = [px[0] / n, px[1] / n, px[2] / n];
        }
        u8::put::<Portable>(&jobs[0], (), &pixels, out);
    }
}
