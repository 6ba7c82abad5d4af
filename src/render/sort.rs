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
    bits: u32,
}

impl Scatter for Digits<'_> {
    type Item = u64;

    fn buckets(&self, _: usize) -> Range<usize> {
        0..1 << self.bits
    }

    #[inline(always)]
    fn each(&self, t: usize, mut put: impl FnMut(Range<usize>, u64)) {
        let end = ((t + 1) * self.chunk).min(self.keys.len());
        for x in &self.keys[t * self.chunk..end] {
            let x = u64::get(x);
            let d = (x >> self.shift) as usize & ((1 << self.bits) - 1);
            put(d..d + 1, x);
        }
    }
}

/// `keys` sorted by their bits from `low` up, equal ones kept in their order.
///
/// A radix sort of 11-bit digits, least significant first, a pass skipped where every key has
/// the same digit; from [`PARALLEL`] keys each pass runs on the pool in chunks. From
/// [`SPLIT_FROM`] keys whose bits from `low` up differ in more than one digit's width, one pass
/// first splits them on the digit of their highest differing bits, and each part is then
/// sorted on its own on the pool ([`sort_part`]): the parts fit the caches, where every pass
/// over the whole of ten million keys goes to memory (docs/performance.md).
pub fn sort_by_high_bits(keys: Vec<u64>, low: u32) -> Vec<u64> {
    let n = keys.len();
    if n < SPLIT_FROM || low >= u64::BITS {
        return sort_by_digits(keys, low);
    }
    // The bits at or above `top` are the same in every key.
    let first = keys[0];
    let differ = keys
        .par_iter()
        .with_min_len(PARALLEL)
        .fold(|| 0, |d, &x| d | (x ^ first) >> low << low)
        .reduce(|| 0, |a, b| a | b);
    let top = u64::BITS - differ.leading_zeros();
    if top <= low + DIGIT {
        return sort_by_digits(keys, low);
    }
    // One pass on the digit just below `top`, into parts that hold the same bits from there up.
    let split = top - SPLIT_DIGIT;
    let chunk = n.div_ceil(2 * rayon::current_num_threads()).max(PARALLEL);
    let from: Vec<AtomicU64> = keys.into_iter().map(AtomicU64::new).collect();
    let pass = Digits {
        keys: &from,
        chunk,
        shift: split,
        bits: SPLIT_DIGIT,
    };
    let counts = count(&pass, n.div_ceil(chunk), 1 << SPLIT_DIGIT);
    let offsets = counts.offsets.clone();
    let to = slots::<u64>(n);
    scatter(&pass, counts, &to);
    drop(from);
    let mut sorted: Vec<u64> = to.into_iter().map(AtomicU64::into_inner).collect();
    let mut parts = Vec::with_capacity(offsets.len());
    let mut rest = &mut sorted[..];
    for w in offsets.windows(2) {
        let (part, after) = rest.split_at_mut((w[1] - w[0]) as usize);
        parts.push(part);
        rest = after;
    }
    parts
        .into_par_iter()
        .with_max_len(1)
        .for_each_init(Vec::new, |scratch, part| {
            sort_part(part, scratch, low, split)
        });
    sorted
}

/// Keys from which [`sort_by_high_bits`] splits them first.
const SPLIT_FROM: usize = 1 << 16;

/// The bits of the digit that splits: 1,024 parts, of about ten thousand keys (80 KB) each at
/// ten million. Of 8, 10 and 11 bits, 10 sorted ten million keys soonest.
const SPLIT_DIGIT: u32 = 10;

/// The bits of a digit of [`sort_part`]: three passes for the 28 bits below the split of ten
/// million spheres' curve keys, not four of 8 bits (a quarter sooner).
const PART_DIGIT: u32 = 10;

/// Up to this many keys, a part is sorted by insertion.
const PART_INSERTION: usize = 32;

/// `part` sorted by its bits from `low` below `high` (every key's bits from `high` up are the
/// same), equal ones kept in their order, by the radix sort of [`PART_DIGIT`]-bit digits in
/// `scratch`; a part too large for the caches as the whole sort is.
fn sort_part(part: &mut [u64], scratch: &mut Vec<u64>, low: u32, high: u32) {
    let n = part.len();
    if n >= SPLIT_FROM {
        let sorted = sort_by_high_bits(part.to_vec(), low);
        part.copy_from_slice(&sorted);
        return;
    }
    if n <= PART_INSERTION {
        for i in 1..n {
            let x = part[i];
            let mut j = i;
            while j > 0 && part[j - 1] >> low > x >> low {
                part[j] = part[j - 1];
                j -= 1;
            }
            part[j] = x;
        }
        return;
    }
    scratch.clear();
    scratch.resize(n, 0);
    let (mut from, mut to) = (&mut *part, &mut scratch[..]);
    let mut in_scratch = false;
    for shift in (low..high).step_by(PART_DIGIT as usize) {
        let mask = (1u64 << PART_DIGIT.min(high - shift)) - 1;
        let digit = |x: u64| (x >> shift & mask) as usize;
        let mut starts = [0usize; 1 << PART_DIGIT];
        for &x in from.iter() {
            starts[digit(x)] += 1;
        }
        if starts.contains(&n) {
            continue;
        }
        let mut total = 0;
        for s in &mut starts {
            (*s, total) = (total, total + *s);
        }
        for &x in from.iter() {
            let d = digit(x);
            to[starts[d]] = x;
            starts[d] += 1;
        }
        std::mem::swap(&mut from, &mut to);
        in_scratch = !in_scratch;
    }
    if in_scratch {
        part.copy_from_slice(scratch);
    }
}

/// `keys` sorted by their bits from `low` up, equal ones kept in their order: a radix sort of
/// 11-bit digits, least significant first, a pass skipped where every key has the same digit.
/// From [`PARALLEL`] keys each pass runs on the pool in chunks.
fn sort_by_digits(keys: Vec<u64>, low: u32) -> Vec<u64> {
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
            bits: DIGIT,
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
                sorts_as_a_stable_sort(&keys, low, &format!("{n} keys, low {low}"));
            }
        }
    }

    /// `sort_by_high_bits(keys, low)` on pools of one to three threads gives the standard
    /// library's stable sort of the bits above `low`.
    fn sorts_as_a_stable_sort(keys: &[u64], low: u32, what: &str) {
        let mut want = keys.to_vec();
        want.sort_by_key(|&x| x.checked_shr(low).unwrap_or(0));
        for threads in 1..=3 {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            let got = pool.install(|| sort_by_high_bits(keys.to_vec(), low));
            assert!(got == want, "{what}, {threads} threads");
        }
    }

    /// Past [`SPLIT_FROM`] keys, where one pass splits them first: values of every width (a
    /// split on high bits, on low ones, none), many equal, parts of every size from one key
    /// to more than [`SPLIT_FROM`] (split again), on pools of one to three threads, against a
    /// stable sort.
    #[test]
    fn sorts_split_keys_as_a_stable_sort_of_the_high_bits() {
        let mut rng = crate::splitmix::SplitMix(0x5b17);
        let n = SPLIT_FROM + SPLIT_FROM / 3;
        for (low, bits) in [
            (0u32, 64u32),
            (17, 47),
            (17, 20),
            (17, 12),
            (30, 5),
            (40, 24),
        ] {
            // A value of `bits` bits; one key in a hundred anywhere in them, the rest in their
            // lowest 20 (one part after the first split, of more than SPLIT_FROM keys).
            let value = |rng: &mut crate::splitmix::SplitMix| {
                let wide = (rng.unit() * 2f64.powi(bits.min(52) as i32)) as u64;
                let wide = wide << bits.saturating_sub(52) | (rng.unit() * 4096.0) as u64;
                let narrow = (rng.unit() * 2f64.powi(bits.min(20) as i32)) as u64;
                let v = if rng.unit() < 0.01 { wide } else { narrow };
                v & (u64::MAX >> (64 - bits))
            };
            let keys: Vec<u64> = (0..n)
                .map(|k| {
                    let v = value(&mut rng);
                    let index = if low == 0 {
                        0
                    } else {
                        k as u64 & ((1u64 << low) - 1)
                    };
                    v.checked_shl(low).unwrap_or(0) | index
                })
                .collect();
            sorts_as_a_stable_sort(&keys, low, &format!("low {low}, {bits} bits"));
        }
    }

    /// A part, by insertion up to [`PART_INSERTION`] keys and by its radix sort past that, of
    /// few values (many equal) between `low` and `high`, against a stable sort.
    #[test]
    fn a_part_sorts_as_a_stable_sort_of_its_bits() {
        let mut rng = crate::splitmix::SplitMix(0x9a27);
        let mut scratch = Vec::new();
        for n in 0..=3 * PART_INSERTION {
            for (low, high) in [(0u32, 64u32), (5, 40), (20, 23)] {
                let top = 0xabcd_u64.checked_shl(high).unwrap_or(0);
                let keys: Vec<u64> = (0..n)
                    .map(|k| {
                        let value = (rng.unit() * 6.0) as u64 * 0x0f0f_0f0f_0f0f_0f0f;
                        let value = value.checked_shl(low).unwrap_or(0) & (u64::MAX >> (64 - high));
                        top | value >> low << low | k as u64 & ((1u64 << low) - 1)
                    })
                    .collect();
                let mut want = keys.clone();
                want.sort_by_key(|&x| x.checked_shr(low).unwrap_or(0));
                let mut got = keys.clone();
                sort_part(&mut got, &mut scratch, low, high);
                assert!(got == want, "{n} keys, bits {low} to {high}");
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
