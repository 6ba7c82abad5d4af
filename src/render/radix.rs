//! A radix sort of 64-bit keys by their high bits, on the pool for many keys: each frame's
//! search order of the spheres in view (`tiles.rs`) and the shadow grid's order of tops
//! (`shadows/`). A key is a value's high bits above an index in its low bits, so the sort
//! orders indices by value, ties by index.

use rayon::prelude::*;

/// Keys from which each pass runs on the pool.
pub const PARALLEL: usize = 1 << 14;

/// The low bits an index below `n` takes (0 for `n` ≤ 1).
pub fn index_bits(n: usize) -> u32 {
    usize::BITS - n.saturating_sub(1).leading_zeros()
}

/// The bits of a radix sort's digit.
const DIGIT: u32 = 11;

/// `keys` sorted by their bits from `low` up, equal ones kept in their order: a radix sort of
/// 11-bit digits, least significant first, a pass skipped where every key has the same digit.
/// From [`PARALLEL`] keys each pass runs on the pool in chunks: each chunk counts its digits,
/// then writes its keys to its own slots of each digit's range (after the chunks before it),
/// so the result is the one pass on one thread gives.
pub fn sort_by_high_bits(keys: Vec<u64>, low: u32) -> Vec<u64> {
    use std::sync::atomic::{AtomicU64, Ordering::Relaxed};
    const BUCKETS: usize = 1 << DIGIT;
    let n = keys.len();
    let chunk = if n >= PARALLEL {
        n.div_ceil(2 * rayon::current_num_threads()).max(PARALLEL)
    } else {
        n.max(1)
    };
    let mut from: Vec<AtomicU64> = keys.into_iter().map(AtomicU64::new).collect();
    let mut to: Vec<AtomicU64> = Vec::new();
    for shift in (low..u64::BITS).step_by(DIGIT as usize) {
        let digit = |x: &AtomicU64| (x.load(Relaxed) >> shift) as usize & (BUCKETS - 1);
        let counts: Vec<Vec<u32>> = from
            .par_chunks(chunk)
            .map(|keys| {
                let mut counts = vec![0u32; BUCKETS];
                for x in keys {
                    counts[digit(x)] += 1;
                }
                counts
            })
            .collect();
        let mut total = vec![0usize; BUCKETS];
        for counts in &counts {
            for (t, &c) in total.iter_mut().zip(counts) {
                *t += c as usize;
            }
        }
        if total.contains(&n) {
            continue;
        }
        // Each chunk's first slot for each digit.
        let mut starts = counts;
        let mut at = 0u32;
        for d in 0..BUCKETS {
            for chunk in starts.iter_mut() {
                let count = chunk[d];
                chunk[d] = at;
                at += count;
            }
        }
        if to.is_empty() {
            // Zeroed on the pool: every core faults in its share of the fresh pages.
            to = (0..n)
                .into_par_iter()
                .with_min_len(PARALLEL)
                .map(|_| AtomicU64::new(0))
                .collect();
        }
        // Every slot is written by exactly one chunk: relaxed stores, read after the join.
        from.par_chunks(chunk)
            .zip(starts)
            .for_each(|(keys, mut at)| {
                for x in keys {
                    let d = digit(x);
                    to[at[d] as usize].store(x.load(Relaxed), Relaxed);
                    at[d] += 1;
                }
            });
        std::mem::swap(&mut from, &mut to);
    }
    drop(to);
    from.into_iter().map(AtomicU64::into_inner).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Against a stable sort on the same bits: seeded keys with many equal high bits, below and
    /// above [`PARALLEL`] keys, on pools of one to three threads, for several widths of the low
    /// part (passes skipped and not).
    #[test]
    fn sorts_as_a_stable_sort_of_the_high_bits() {
        let mut rng = crate::splitmix::SplitMix(0x5a4d);
        for n in [0, 1, 2, 100, 3 * PARALLEL + 17] {
            for low in [0, 1, 20, 32, 53, 63] {
                let keys: Vec<u64> = (0..n)
                    .map(|k| {
                        let value =
                            ((rng.unit() * 50.0) as u64).wrapping_mul(0x0123_4567_89ab_cdef);
                        value << low | k as u64 & ((1u64 << low) - 1)
                    })
                    .collect();
                let mut want = keys.clone();
                want.sort_by_key(|&x| x >> low);
                for threads in 1..=3 {
                    let pool = rayon::ThreadPoolBuilder::new()
                        .num_threads(threads)
                        .build()
                        .unwrap();
                    let got = pool.install(|| sort_by_high_bits(keys.clone(), low));
                    assert!(got == want, "{n} keys, low {low}, {threads} threads");
                }
            }
        }
    }

    #[test]
    fn index_bits_hold_every_index() {
        assert_eq!([0, 1, 2, 3, 4, 5].map(index_bits), [0, 0, 1, 2, 2, 3]);
        assert_eq!(index_bits(1 << 20), 20);
        assert_eq!(index_bits((1 << 20) + 1), 21);
    }
}
