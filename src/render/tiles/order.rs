//! The order every tile searches its spheres in: nearest possible hit first, ties by scene
//! index, sorted once a frame.

use rayon::prelude::*;

use super::super::sort::{index_bits, sort_by_high_bits, PARALLEL};
use super::super::view::{Ranks, ViewColumns};

/// `x` as a u64 in the order of `f64::total_cmp`: the sign bit flipped for positive values, every
/// bit for negative ones.
fn total_key(x: f64) -> u64 {
    let b = x.to_bits();
    if b >> 63 == 1 {
        !b
    } else {
        b | 1 << 63
    }
}

/// The spheres in view (indices of the columns) in the order every tile searches them: nearest
/// possible hit first (`min_dist`, ordered as `total_cmp` orders the f64), ties by the spheres'
/// scene indices (from their ranks, the columns' `id`, by `ranks`), so the order is total,
/// deterministic and the same whatever order the columns, or the index, hold the spheres in.
/// One radix sort of 8 bytes a sphere ([`sort_by_high_bits`]): the key's high bits above the
/// column index's; then each run of equal high bits (rare: at a million spheres their
/// distances agree to 32 bits of the fraction) by the whole key and the scene index.
pub(super) fn search_order(spheres: &ViewColumns, ranks: Ranks) -> Vec<u32> {
    let n = spheres.len();
    let key = |k: u32| total_key(spheres.min_dist[k as usize]);
    let low = index_bits(n);
    let pack = |k: u32| key(k) >> low << low | u64::from(k);
    // On the pool from PARALLEL spheres (one task below).
    let keyed: Vec<u64> = (0..n as u32)
        .into_par_iter()
        .with_min_len(PARALLEL)
        .map(pack)
        .collect();
    let keyed = sort_by_high_bits(keyed, low);
    let index = |&x: &u64| (x & ((1u64 << low) - 1)) as u32;
    let mut order: Vec<u32> = keyed.par_iter().with_min_len(PARALLEL).map(index).collect();
    let mut at = 0;
    for run in keyed.chunk_by(|a, b| a >> low == b >> low) {
        if run.len() > 1 {
            let run = &mut order[at..at + run.len()];
            run.sort_unstable_by_key(|&k| {
                (key(k), ranks.scene_index(spheres.id[k as usize] as u32))
            });
        }
        at += run.len();
    }
    order
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::view::ViewSphere;
    use glam::DVec3;

    /// The search order is the sort by `min_dist` (as `total_cmp` orders it) and then scene
    /// index, on pools of one to three threads, below and above [`PARALLEL`] spheres: distances
    /// equal, a few ulps apart (equal in the radix sort's bits, told apart after it), far
    /// apart, negative, signed zeros, infinite and not a number; scene indices in another
    /// order than the columns'.
    #[test]
    fn search_order_sorts_by_distance_then_scene_index() {
        let mut rng = crate::splitmix::SplitMix(0x0bde);
        let specials = [
            0.0,
            -0.0,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NAN,
            -f64::NAN,
        ];
        for n in [0, 1, 2, 7, 3000, PARALLEL + 4321] {
            let sphere = ViewSphere::in_view(DVec3::new(0.0, 0.0, 5.0), 1.0, DVec3::ZERO, 0);
            let mut columns = ViewColumns::new(DVec3::ZERO, &vec![sphere; n]);
            for k in 0..n {
                let anchor = [1.0, 7.5, -0.25, 1e-300, 3e5, 19.999][(rng.unit() * 6.0) as usize];
                let mut v = anchor * (1.0 + (rng.unit() * 4.0).floor() * 1e-3);
                for _ in 0..(rng.unit() * 3.0) as usize {
                    v = v.next_up();
                }
                if k % 97 == 0 {
                    v = specials[k / 97 % specials.len()];
                }
                columns.min_dist[k] = v;
                columns.id[k] = (k as u64 * 7919) % n as u64;
            }
            // The ids as scene indices, and as ranks of another order of the scene.
            let other: Vec<u32> = (0..n as u64)
                .map(|r| ((r * 7919 + 3) % n as u64) as u32)
                .collect();
            for ranks in [Ranks::SCENE, Ranks(Some(&other))] {
                let scene = |k: usize| ranks.scene_index(columns.id[k] as u32);
                let mut want: Vec<u32> = (0..n as u32).collect();
                want.sort_by(|&a, &b| {
                    let (a, b) = (a as usize, b as usize);
                    let d = columns.min_dist[a].total_cmp(&columns.min_dist[b]);
                    d.then(scene(a).cmp(&scene(b)))
                });
                for threads in 1..=3 {
                    let pool = rayon::ThreadPoolBuilder::new()
                        .num_threads(threads)
                        .build()
                        .unwrap();
                    let got = pool.install(|| search_order(&columns, ranks));
                    assert!(got == want, "{n} spheres, {threads} threads, {ranks:?}");
                }
            }
        }
    }

    #[test]
    fn total_keys_order_as_total_cmp() {
        let mut xs = vec![
            0.0,
            -0.0,
            1.0,
            -1.0,
            f64::MIN_POSITIVE,
            -f64::MIN_POSITIVE,
            f64::MAX,
            f64::MIN,
            f64::INFINITY,
            f64::NEG_INFINITY,
            5e-324,
            -5e-324,
            0.1,
            -0.1,
            3.5,
            -3.5,
        ];
        xs.extend((0..1000).map(|k| (k as f64 - 500.0) * 0.37e-3));
        for a in &xs {
            for b in &xs {
                assert_eq!(total_key(*a).cmp(&total_key(*b)), a.total_cmp(b), "{a} {b}");
            }
        }
    }
}
