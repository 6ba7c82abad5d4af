//! Exact sRGB quantisation: linear [0, 1] to the nearest 8-bit level, a packet of lanes at a
//! time, through a table of buckets and the thresholds between levels.

use std::sync::OnceLock;

use super::lanes::{Lanes, Portable, LANES};
use super::rays::HALF;

/// Exact sRGB quantisation: the linear value at which each 8-bit level begins.
pub struct SrgbEncoder {
    /// `thresholds[k]` is the linear value whose encoding is level k + ½; the last entry is a
    /// sentinel above 1.
    thresholds: [f64; 256],
    /// `buckets[b]`: the level of the linear value b / BUCKETS, plus [`SPLIT`] when a threshold
    /// falls inside the bucket (values in it are that level or the next).
    buckets: Box<[u16; BUCKETS + 1]>,
}

/// Buckets of the linear range, a power of two so that x·BUCKETS is exact and its floor is the
/// bucket of x. Consecutive thresholds are at least 1/(255·12.92) ≈ 3.0e-4 apart (the linear
/// toe is the steepest part), far more than a bucket's 1.5e-5: a bucket holds at most one
/// threshold, and only 255 of the 65,536 hold one, so nearly every value is looked up with no
/// comparison at all.
const BUCKETS: usize = 1 << 16;

/// The flag of a bucket that a threshold splits.
const SPLIT: u16 = 0x100;

impl SrgbEncoder {
    fn new() -> SrgbEncoder {
        let mut thresholds = [f64::INFINITY; 256];
        for (k, t) in thresholds.iter_mut().take(255).enumerate() {
            *t = srgb_decode((k as f64 + 0.5) / 255.0);
        }
        let mut buckets = Box::new([0u16; BUCKETS + 1]);
        let mut level = 0;
        for (b, entry) in buckets.iter_mut().enumerate() {
            // The level of b / BUCKETS: the thresholds at or below it.
            let start = b as f64 / BUCKETS as f64;
            while thresholds[level] <= start {
                level += 1;
            }
            let end = (b + 1) as f64 / BUCKETS as f64;
            let split = thresholds[level] < end && b < BUCKETS;
            *entry = level as u16 | if split { SPLIT } else { 0 };
        }
        SrgbEncoder {
            thresholds,
            buckets,
        }
    }

    /// Linear [0, 1] to the nearest 8-bit sRGB level (values outside are clamped): the level
    /// whose threshold interval holds the value, exactly. One value through the lanes' encoder
    /// (`encode_into`), the one copy of the rule; for values outside the packets (the
    /// background's levels, once a frame).
    pub fn encode(&self, linear: f64) -> u8 {
        let mut rgb = [0u8; 3 * LANES];
        self.encode_into(Portable::splat((), linear), &mut rgb, 0);
        rgb[0]
    }

    /// The level of `x` from its bucket's entry: the bucket's level, or the next one when x
    /// is at or above the threshold that splits the bucket.
    #[inline(always)]
    fn finish(&self, entry: u16, x: f64) -> u8 {
        let level = entry as u8;
        if entry & SPLIT == 0 {
            level
        } else {
            level + (x >= self.thresholds[level as usize]) as u8
        }
    }
}

/// The shared encoder; built once with libm, so it is the same on every platform.
pub fn srgb_encoder() -> &'static SrgbEncoder {
    static ENCODER: OnceLock<SrgbEncoder> = OnceLock::new();
    ENCODER.get_or_init(SrgbEncoder::new)
}

/// sRGB transfer function, encoded [0, 1] to linear [0, 1] (IEC 61966-2-1).
pub fn srgb_decode(e: f64) -> f64 {
    if e <= 0.04045 {
        e / 12.92
    } else {
        libm::pow((e + 0.055) / 1.055, 2.4)
    }
}

impl SrgbEncoder {
    /// [`SrgbEncoder::encode`] of every lane, written to channel `a` of eight RGB pixels:
    /// clamp and bucket on whole lanes, then a table read per value, and a comparison only for
    /// values in a bucket that a threshold splits.
    #[inline(always)]
    pub(super) fn encode_into<V: Lanes>(&self, linear: V, rgb: &mut [u8; 3 * LANES], a: usize) {
        let (upper, lower) = rgb.split_at_mut(3 * HALF);
        let half = "half a packet";
        let (upper, lower) = (upper.try_into().expect(half), lower.try_into().expect(half));
        self.encode_halves(linear, upper, lower, a)
    }

    /// [`SrgbEncoder::encode_into`] with lanes 0..HALF into `upper` and HALF..LANES into
    /// `lower`: a packet of two rows, straight into its pixels of each.
    #[inline(always)]
    pub(super) fn encode_halves<V: Lanes>(
        &self,
        linear: V,
        upper: &mut [u8; 3 * HALF],
        lower: &mut [u8; 3 * HALF],
        a: usize,
    ) {
        let tok = linear.token();
        let (zero, one) = (V::splat(tok, 0.0), V::splat(tok, 1.0));
        // f64::clamp(0, 1), which keeps a NaN.
        let x = V::blend(linear.lt(zero), linear, zero);
        let x = V::blend(x.gt(one), x, one);
        let bucket = x.mul(V::splat(tok, BUCKETS as f64)).to_i32(BUCKETS as i32);
        let mut any = 0;
        for l in 0..HALF {
            let (up, low) = (
                self.buckets[bucket[l] as usize],
                self.buckets[bucket[HALF + l] as usize],
            );
            upper[3 * l + a] = up as u8;
            lower[3 * l + a] = low as u8;
            any |= up | low;
        }
        if any & SPLIT != 0 {
            let x = x.store();
            for l in 0..HALF {
                let (up, low) = (
                    self.buckets[bucket[l] as usize],
                    self.buckets[bucket[HALF + l] as usize],
                );
                upper[3 * l + a] = self.finish(up, x[l]);
                lower[3 * l + a] = self.finish(low, x[HALF + l]);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn srgb_levels_match_the_formula() {
        let enc = srgb_encoder();
        // Independent: the forward sRGB formula, rounded.
        let forward = |x: f64| {
            let e = if x <= 0.0031308 {
                12.92 * x
            } else {
                1.055 * x.powf(1.0 / 2.4) - 0.055
            };
            (e * 255.0).round() as u8
        };
        for k in 0..=1000 {
            let x = k as f64 / 1000.0;
            assert_eq!(enc.encode(x), forward(x), "x = {x}");
        }
        assert_eq!(enc.encode(0.0), 0);
        assert_eq!(enc.encode(1.0), 255);
        assert_eq!(enc.encode(0.5), 188);
        assert_eq!(enc.encode(-1.0), 0);
        assert_eq!(enc.encode(2.0), 255);
        // Exactly at and just below every threshold, and at both ends of every bucket,
        // against the plain binary search.
        let slow = |x: f64| enc.thresholds.partition_point(|&th| th <= x) as u8;
        for k in 0..255 {
            let t = srgb_decode((k as f64 + 0.5) / 255.0);
            for x in [t, t.next_down(), t.next_up()] {
                assert_eq!(enc.encode(x), slow(x), "x = {x}");
            }
        }
        for b in 0..=BUCKETS {
            let start = b as f64 / BUCKETS as f64;
            for x in [start, start.next_down(), start.next_up()] {
                assert_eq!(enc.encode(x), slow(x.clamp(0.0, 1.0)), "x = {x}");
            }
        }
        // 255 buckets are split, one by each threshold.
        let split = enc.buckets.iter().filter(|&&e| e & SPLIT != 0).count();
        assert_eq!(split, 255);
    }

    /// Eight values at a time, [`SrgbEncoder::encode_into`] is [`SrgbEncoder::encode`], in its
    /// channel and nowhere else: at, just below and just above every threshold (values in split
    /// buckets, mixed with others), at bucket edges, and outside [0, 1] and NaN.
    #[test]
    fn lanes_encode_as_one_value_does() {
        let enc = srgb_encoder();
        let mut xs = vec![
            -1.0,
            -0.0,
            0.0,
            1.0,
            2.0,
            f64::NAN,
            f64::INFINITY,
            1.0f64.next_down(),
        ];
        for k in 0..255 {
            let t = enc.thresholds[k];
            xs.extend([t.next_down(), t, t.next_up(), (k as f64 + 0.3) / 255.0]);
        }
        for b in (0..=BUCKETS).step_by(97) {
            let start = b as f64 / BUCKETS as f64;
            xs.extend([start.next_down(), start, start.next_up()]);
        }
        for (k, lanes) in xs.chunks_exact(LANES).enumerate() {
            let a = k % 3;
            let mut rgb = [7u8; 3 * LANES];
            enc.encode_into(Portable::load((), lanes.try_into().unwrap()), &mut rgb, a);
            for (l, px) in rgb.chunks(3).enumerate() {
                let want: Vec<u8> = (0..3)
                    .map(|c| if c == a { enc.encode(lanes[l]) } else { 7 })
                    .collect();
                assert_eq!(px, want, "{lanes:?}, channel {a}");
            }
        }
    }
}
