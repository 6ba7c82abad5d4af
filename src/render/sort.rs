//! The renderer's one counting sort, on the rayon pool, and the size of the pool's tasks.
//!
//! Each task counts its items into buckets, then writes them to its own slots of each bucket,
//! after the slots of the tasks before it, so the result is the one a single pass gives. It
//! makes the grids of `bins.rs` (an item into every cell of its rectangle) and the radix sort
//! of 64-bit keys: each frame's search order of the spheres in view (`tiles/`), the shadow
//! grid's order of tops (`shadows/`) and the scene's curve (`world.rs`). A key is a value's
//! high bits above an index in its low bits, so the radix sort orders indices by value, ties by
//! index.

use rayon::prelude::*;
use std::ops::Range;
use std::sync::atomic::{AtomicU32, AtomicU64, Ordering::Relaxed};

/// Items (spheres, keys) a task takes on the rayon pool, and the fewest from which a step goes
/// to the pool at all: below, waking the pool costs more than it saves.
pub const PARALLEL: usize = 1 << 14;

/// A value the sort moves: written by one task into a slot of a shared buffer, as an atomic
/// with relaxed stores (every slot is written once, and read after the join).
pub trait Item: Copy + Send + Sync {
    type Atomic: Send + Sync;
    fn atomic(self) -> Self::Atomic;
    fn put(slot: &Self::Atomic, x: Self);
    fn get(slot: &Self::Atomic) -> Self;
}

macro_rules! items {
    ($($t:ty: $atomic:ty),*) => {$(
        impl Item for $t {
            type Atomic = $atomic;
            #[inline(always)]
            fn atomic(self) -> $atomic {
                <$atomic>::new(self)
            }
            #[inline(always)]
            fn put(slot: &$atomic, x: $t) {
                slot.store(x, Relaxed)
            }
            #[inline(always)]
            fn get(slot: &$atomic) -> $t {
                slot.load(Relaxed)
            }
        }
    )*};
}
items!(u32: AtomicU32, u64: AtomicU64);

/// What a counting sort sorts, a task at a time.
pub trait Scatter: Sync {
    type Item: Item;

    /// The buckets task `t` puts items into: the counts it keeps. Tasks either share all the
    /// buckets or each have their own (bands of a grid's rows).
    fn buckets(&self, t: usize) -> Range<usize>;

    /// Task `t`'s items in order, each given to `put` with a run of buckets it goes into, inside
    /// [`Scatter::buckets`]. Called twice (to count, then to write), with the same items.
    fn each(&self, t: usize, put: impl FnMut(Range<usize>, Self::Item));
}

/// The first slot of every bucket (and one past the last), and each task's first slot in each
/// of its buckets.
pub struct Counts {
    pub offsets: Vec<u32>,
    starts: Vec<Vec<u32>>,
}

/// Counts the items of `tasks` tasks into `buckets` buckets, each task on the pool.
pub fn count<S: Scatter>(s: &S, tasks: usize, buckets: usize) -> Counts {
    let mut starts: Vec<Vec<u32>> = on_pool(vec![(); tasks], |t, ()| {
        let lo = s.buckets(t).start;
        let mut counts = vec![0u32; s.buckets(t).len()];
        s.each(t, |run, _| {
            for c in &mut counts[run.start - lo..run.end - lo] {
                *c += 1;
            }
        });
        counts
    });
    // Per bucket, the tasks' slots in task order: between two cuts (a task's first or last
    // bucket) the same tasks share every bucket.
    let ranges: Vec<Range<usize>> = (0..tasks).map(|t| s.buckets(t)).collect();
    let mut cuts: Vec<usize> = ranges.iter().flat_map(|r| [r.start, r.end]).collect();
    cuts.extend([0, buckets]);
    cuts.sort_unstable();
    cuts.dedup();
    let mut offsets = Vec::with_capacity(buckets + 1);
    let mut total = 0u32;
    for cut in cuts.windows(2) {
        let sharing: Vec<usize> = (0..tasks)
            .filter(|&t| ranges[t].start <= cut[0] && cut[1] <= ranges[t].end)
            .collect();
        for b in cut[0]..cut[1] {
            offsets.push(total);
            for &t in &sharing {
                let slot = &mut starts[t][b - ranges[t].start];
                let count = *slot;
                *slot = total;
                total += count;
            }
        }
    }
    offsets.push(total);
    Counts { offsets, starts }
}

/// `f` of every task, on the pool when there are several: a single task runs on this thread,
/// which may be outside the pool.
pub fn on_pool<A: Send, T: Send>(tasks: Vec<A>, f: impl Fn(usize, A) -> T + Sync) -> Vec<T> {
    if tasks.len() > 1 {
        tasks
            .into_par_iter()
            .enumerate()
            .map(|(t, a)| f(t, a))
            .collect()
    } else {
        tasks.into_iter().map(|a| f(0, a)).collect()
    }
}

/// A buffer of `n` slots for [`scatter`], zeroed on the pool from [`PARALLEL`] slots: every core
/// faults in its share of the fresh pages.
pub fn slots<T: Item + Default>(n: usize) -> Vec<T::Atomic> {
    let zero = |_| T::default().atomic();
    if n >= PARALLEL {
        (0..n)
            .into_par_iter()
            .with_min_len(PARALLEL)
            .map(zero)
            .collect()
    } else {
        (0..n).map(zero).collect()
    }
}

/// Writes every task's items into `to` (at least the counted number of slots), each into its
/// own slots, on the pool.
pub fn scatter<S: Scatter>(s: &S, counts: Counts, to: &[<S::Item as Item>::Atomic]) {
    on_pool(counts.starts, |t, mut at| {
        let lo = s.buckets(t).start;
        s.each(t, |run, x| {
            for slot in &mut at[run.start - lo..run.end - lo] {
                S::Item::put(&to[*slot as usize], x);
                *slot += 1;
            }
        })
    });
}

/// The low bits an index below `n` takes (0 for `n` ≤ 1).
pub fn index_bits(n: usize) -> u32 {
    usize::BITS - n.saturating_sub(1).leading_zeros()
}

/// The bits of a radix sort's digit.
const DIGIT: u32 = 11;

/// A pass of the radix sort: the keys' digit from `shift`, a chunk of keys a task.
struct Digits<'a> {
    keys: &'a [AtomicU64],
    chunk: usize,
    shift: u32,
}

impl Scatter for Digits<'_> {
    type Item = u64;

    fn buckets(&self, _: usize) -> Range<usize> {
        0..1 << DIGIT
    }

    #[inline(always)]
    fn each(&self, t: usize, mut put: impl FnMut(Range<usize>, u64)) {
        let end = ((t + 1) * self.chunk).min(self.keys.len());
        for x in &self.keys[t * self.chunk..end] {
            let x = u64::get(x);
            let d = (x >> self.shift) as usize & ((1 << DIGIT) - 1);
            put(d..d + 1, x);
        }
    }
}

/// `keys` sorted by their bits from `low` up, equal ones kept in their order: a radix sort of
/// 11-bit digits, least significant first, a pass skipped where every key has the same digit.
/// From [`PARALLEL`] keys each pass runs on the pool in chunks.
pub fn sort_by_high_bits(keys: Vec<u64>, low: u32) -> Vec<u64> {
    let n = keys.len();
    let chunk = if n >= PARALLEL {
        n.div_ceil(2 * rayon::current_num_threads()).max(PARALLEL)
    } else {
        n.max(1)
    };
    let mut from: Vec<AtomicU64> = keys.into_iter().map(AtomicU64::new).collect();
    let mut to: Vec<AtomicU64> = Vec::new();
    for shift in (low..u64::BITS).step_by(DIGIT as usize) {
        let pass = Digits {
            keys: &from,
            chunk,
            shift,
        };
        let counts = count(&pass, n.div_ceil(chunk), 1 << DIGIT);
        if counts
            .offsets
            .windows(2)
            .any(|w| (w[1] - w[0]) as usize == n)
        {
            continue;
        }
        if to.is_empty() {
            to = slots::<u64>(n);
        }
        scatter(&pass, counts, &to);
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
