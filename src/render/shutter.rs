//! Motion blur's rows: the mean, in linear light, of a frame's renders at its time samples,
//! quantised to 8-bit sRGB once.
//!
//! Each band of rows is one task's, and its time samples are added in their order (time order), then
//! divided by their number: the bytes do not depend on the thread count, and since every
//! instruction path gives the same linear colours, not on the path either.

use super::drivers::RowJob;
use super::lanes::{Lanes, Portable, LANES};
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
    let encode = jobs[0].encode;
    for (means, out) in sum.chunks(3 * LANES).zip(band.chunks_mut(3 * LANES)) {
        let mut rgb = [0u8; 3 * LANES];
        for a in 0..3 {
            let mut channel = [0.0; LANES];
            for (c, px) in channel.iter_mut().zip(means.chunks_exact(3)) {
                *c = px[a] / n;
            }
            encode.encode_into(Portable::load((), &channel), &mut rgb, a);
        }
        out.copy_from_slice(&rgb[..out.len()]);
    }
}
