//! A frame's rows on the thread pool, passed on in order while later rows render.
//!
//! Threads claim rows in order from one counter. A thread that finishes a row hands on every
//! finished row that extends the finished prefix, so a consumer of the rows (the frame's
//! SHA-256, which is sequential) runs beside the rendering instead of after it, on the same
//! threads: a frame costs its rendering and its hashing spread over the cores, not their sum
//! on one of them, and the frame is never read again from memory after it is rendered.
//!
//! The rows go into a buffer of whole rows: the frame, or a ring of fewer rows (row j in slot
//! j mod the slot count), which a run that only hashes its frames uses so as not to touch a
//! frame's worth of memory. A row is rendered into its slot only once the row that held the
//! slot before has been handed on; a thread waiting for that hands rows on itself.
//!
//! Which thread hands a row on, and when, varies from run to run; what is handed on does not.
//! Every row is handed on exactly once, in row order, before [`rows_in_order`] returns.

use std::sync::atomic::{fence, AtomicBool, AtomicUsize, Ordering};
use std::sync::{Mutex, PoisonError, TryLockError};

use rayon::prelude::*;

/// One slot of the buffer: its bytes, and which row they hold finished (row + 1; 0 for none).
struct Slot<'p> {
    bytes: Mutex<&'p mut [u8]>,
    done: AtomicUsize,
}

/// The consumer and the first row it has not seen.
struct Prefix<'s> {
    next: usize,
    in_order: &'s mut (dyn FnMut(&[u8]) + Send),
}

/// The shared state of one frame's rows.
struct Rows<'p, 's> {
    slots: Vec<Slot<'p>>,
    rows: usize,
    prefix: Mutex<Prefix<'s>>,
    /// Rows handed on so far (the prefix's `next`, readable without its lock).
    handed: AtomicUsize,
    /// A row's rendering panicked: the rows after it will never be handed on, so no thread
    /// waits for them (the panic reaches the caller through the pool).
    panicked: AtomicBool,
}

/// Marks the rows' state panicked if dropped while its thread unwinds.
struct PanicGuard<'a>(&'a AtomicBool);

impl Drop for PanicGuard<'_> {
    fn drop(&mut self) {
        if std::thread::panicking() {
            self.0.store(true, Ordering::SeqCst);
        }
    }
}

/// Renders rows 0..`rows` (of `row_bytes` each) with `render(j, row)` on the rayon pool into
/// `buffer`, which holds the frame or a ring of fewer rows, and passes each finished row to
/// `in_order` once, in row order, as the finished prefix grows. `in_order` runs on one thread
/// at a time.
///
/// Neither `render` nor `in_order` may wait on the rayon pool (`join`, `par_iter`): a thread
/// waiting there can steal a worker of these rows that has not started, and with a ring that
/// worker can wait for a slot whose row is suspended below it on the same thread — a hang.
/// The renderer's rows and the frame's SHA-256 use no rayon.
pub(crate) fn rows_in_order(
    buffer: &mut [u8],
    row_bytes: usize,
    rows: usize,
    render: impl Fn(usize, &mut [u8]) + Sync,
    in_order: &mut (dyn FnMut(&[u8]) + Send),
) {
    let slots: Vec<Slot> = buffer
        .chunks_exact_mut(row_bytes)
        .take(rows)
        .map(|bytes| Slot {
            bytes: Mutex::new(bytes),
            done: AtomicUsize::new(0),
        })
        .collect();
    assert!(
        !slots.is_empty() || rows == 0,
        "a buffer of at least one row"
    );
    let state = Rows {
        slots,
        rows,
        prefix: Mutex::new(Prefix { next: 0, in_order }),
        handed: AtomicUsize::new(0),
        panicked: AtomicBool::new(false),
    };
    let claimed = AtomicUsize::new(0);
    (0..rayon::current_num_threads())
        .into_par_iter()
        .with_max_len(1)
        .for_each(|_| {
            // A panic anywhere in this thread's rows (rendering or handing on) stops waiters.
            let _guard = PanicGuard(&state.panicked);
            loop {
                let j = claimed.fetch_add(1, Ordering::Relaxed);
                if j >= rows {
                    break;
                }
                let slot = &state.slots[j % state.slots.len()];
                // The slot's previous row must be handed on first. It was claimed before this one,
                // so it is done or being rendered; rows before it are being handed on, or this
                // thread hands them on.
                while state.handed.load(Ordering::Acquire) + state.slots.len() <= j {
                    if state.panicked.load(Ordering::SeqCst) {
                        return;
                    }
                    state.hand_on();
                    std::thread::yield_now();
                }
                render(j, &mut lock(&slot.bytes));
                slot.done.store(j + 1, Ordering::Release);
                // Pairs with the fence in `hand_on`: either this thread takes the prefix below, or
                // the thread that holds it sees this row done after letting go of it.
                fence(Ordering::SeqCst);
                state.hand_on();
            }
        });
    // Every row is done: pass on whatever is left (nothing, by the hand-over above), so the
    // consumer has seen every row whatever the threads did.
    let prefix = state
        .prefix
        .into_inner()
        .unwrap_or_else(PoisonError::into_inner);
    for j in prefix.next..rows {
        let slot = &state.slots[j % state.slots.len()];
        assert_eq!(
            slot.done.load(Ordering::Acquire),
            j + 1,
            "row {j} in its slot"
        );
        (prefix.in_order)(&lock(&slot.bytes));
    }
}

impl<'p> Rows<'p, '_> {
    /// The slot of row j if it holds row j finished.
    fn finished(&self, j: usize) -> Option<&Slot<'p>> {
        let slot = self.slots.get(j % self.slots.len().max(1))?;
        (j < self.rows && slot.done.load(Ordering::Acquire) == j + 1).then_some(slot)
    }

    /// Passes on the finished rows after the prefix, unless another thread is doing so.
    fn hand_on(&self) {
        loop {
            let mut p = match self.prefix.try_lock() {
                Ok(p) => p,
                // Poisoned: the consumer panicked, and is not called again; the panic reaches
                // the caller.
                Err(TryLockError::WouldBlock | TryLockError::Poisoned(_)) => return,
            };
            while let Some(slot) = self.finished(p.next) {
                (p.in_order)(&lock(&slot.bytes));
                p.next += 1;
                self.handed.store(p.next, Ordering::Release);
            }
            let next = p.next;
            drop(p);
            // A row finished after the check above, by a thread that found the prefix taken,
            // is seen here (see the fence after a row is done).
            fence(Ordering::SeqCst);
            if self.finished(next).is_none() {
                return;
            }
        }
    }
}

fn lock<'a, 'p>(bytes: &'a Mutex<&'p mut [u8]>) -> std::sync::MutexGuard<'a, &'p mut [u8]> {
    bytes.lock().unwrap_or_else(PoisonError::into_inner)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Row `j`'s bytes, after an uneven amount of work, so rows finish out of order.
    fn render(j: usize, row: &mut [u8]) {
        let mut x = j as u64 + 1;
        for _ in 0..(j * 7919 % 13) * 2000 {
            x = std::hint::black_box(x.wrapping_mul(6364136223846793005).wrapping_add(1));
        }
        for (i, b) in row.iter_mut().enumerate() {
            *b = (j * 31 + i) as u8;
        }
    }

    #[test]
    fn every_row_is_handed_on_once_in_order() {
        for threads in [1, 2, 3] {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            for (rows, row_bytes) in [(0, 5), (1, 5), (2, 1), (97, 33), (300, 8)] {
                let mut pixels = vec![0xa5u8; rows * row_bytes];
                let mut seen: Vec<Vec<u8>> = Vec::new();
                pool.install(|| {
                    rows_in_order(&mut pixels, row_bytes, rows, render, &mut |r: &[u8]| {
                        seen.push(r.to_vec())
                    })
                });
                let expected = expected(rows, row_bytes);
                assert_eq!(seen, expected, "{threads} threads, {rows} rows");
                assert_eq!(pixels, expected.concat(), "{threads} threads, {rows} rows");
            }
        }
    }

    /// Rows 0..rows as [`render`] makes them, one at a time.
    fn expected(rows: usize, row_bytes: usize) -> Vec<Vec<u8>> {
        (0..rows)
            .map(|j| {
                let mut r = vec![0; row_bytes];
                render(j, &mut r);
                r
            })
            .collect()
    }

    #[test]
    fn a_ring_of_fewer_rows_hands_on_every_row_in_order() {
        for threads in [1, 2, 3] {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            for slots in [1, 2, 3, 7, 96] {
                let (rows, row_bytes) = (97, 33);
                let mut ring = vec![0xa5u8; slots * row_bytes];
                let mut seen: Vec<Vec<u8>> = Vec::new();
                pool.install(|| {
                    rows_in_order(&mut ring, row_bytes, rows, render, &mut |r: &[u8]| {
                        seen.push(r.to_vec())
                    })
                });
                let expected = expected(rows, row_bytes);
                assert_eq!(seen, expected, "{threads} threads, {slots} slots");
                // Each slot holds the last row that went into it.
                for (k, slot) in ring.chunks(row_bytes).enumerate() {
                    let last = (k..rows).step_by(slots).next_back().unwrap();
                    assert_eq!(slot, expected[last], "{threads} threads, {slots} slots");
                }
            }
        }
    }

    /// A row that panics, or a consumer that does: the panic reaches the caller, no thread
    /// waits for the rows after it to be handed on, no row after it is handed on, and a
    /// consumer that panicked is not called again.
    #[test]
    fn a_panicking_row_ends_the_frame() {
        for threads in [1, 2, 3, 8] {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            for (slots, bad) in [(2, 5), (1, 0), (1, 39), (40, 1), (40, 39)] {
                let mut ring = vec![0u8; slots * 4];
                let mut seen = 0;
                let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
                    pool.install(|| {
                        let render = |j, row: &mut [u8]| {
                            assert!(j != bad, "row {bad}");
                            render(j, row)
                        };
                        rows_in_order(&mut ring, 4, 40, render, &mut |_: &[u8]| seen += 1)
                    })
                }));
                let at = format!("{threads} threads, {slots} slots, row {bad}");
                assert!(result.is_err(), "{at}");
                assert!(seen <= bad, "{seen} rows handed on, {at}");
                // The consumer panics on row `bad`.
                let mut calls = 0;
                let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
                    pool.install(|| {
                        rows_in_order(&mut ring, 4, 40, render, &mut |_: &[u8]| {
                            calls += 1;
                            assert!(calls != bad + 1, "row {bad}");
                        })
                    })
                }));
                assert!(result.is_err(), "{at}");
                assert_eq!(calls, bad + 1, "{at}");
            }
        }
    }

    /// Short sleeps and yields at random points of the rows and the consumer, so that threads
    /// overtake each other everywhere: every row reaches the consumer whole (each is written in
    /// two steps, a wrong half between), once and in order, and the consumer is never entered
    /// by two threads at once.
    #[test]
    fn rows_arrive_whole_in_order_to_one_consumer_at_a_time() {
        let stream = AtomicUsize::new(1);
        let jitter = || {
            let x = (stream.fetch_add(1, Ordering::Relaxed) as u64)
                .wrapping_mul(0x9e37_79b9_7f4a_7c15)
                .rotate_left(17);
            match x % 16 {
                0 => std::thread::sleep(std::time::Duration::from_micros(50)),
                1..=3 => std::thread::yield_now(),
                _ => {}
            }
        };
        let row_bytes = 16;
        let rows = 40;
        let expected = expected(rows, row_bytes);
        for threads in [1, 2, 3, 8] {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            for slots in [1, 2, 3, 5, 40] {
                for _ in 0..20 {
                    let mut ring = vec![0u8; slots * row_bytes];
                    let inside = std::sync::atomic::AtomicBool::new(false);
                    let mut next = 0;
                    pool.install(|| {
                        let render = |j, row: &mut [u8]| {
                            jitter();
                            row.fill(0xee);
                            jitter();
                            render(j, row);
                        };
                        rows_in_order(&mut ring, row_bytes, rows, render, &mut |r: &[u8]| {
                            assert!(!inside.swap(true, Ordering::SeqCst), "entered twice");
                            assert_eq!(r, expected[next], "row {next}, {threads} threads");
                            next += 1;
                            jitter();
                            inside.store(false, Ordering::SeqCst);
                        })
                    });
                    assert_eq!(next, rows, "{threads} threads, {slots} slots");
                }
            }
        }
    }

    /// As the frame loop runs them: the rows in `rayon::join` beside a task that uses the pool
    /// in parallel (the next frame's preparation).
    #[test]
    fn rows_beside_a_parallel_task() {
        use rayon::prelude::*;
        let expected = expected(60, 8);
        for threads in [1, 2, 3, 8] {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            for _ in 0..50 {
                let mut ring = vec![0u8; 3 * 8];
                let mut seen = Vec::new();
                let ((), sum) = pool.install(|| {
                    rayon::join(
                        || {
                            rows_in_order(&mut ring, 8, 60, render, &mut |r: &[u8]| {
                                seen.push(r.to_vec())
                            })
                        },
                        || {
                            (0..1000u32)
                                .into_par_iter()
                                .with_max_len(10)
                                .map(|x| {
                                    std::thread::yield_now();
                                    x as u64
                                })
                                .sum::<u64>()
                        },
                    )
                });
                assert_eq!(sum, 499_500);
                assert_eq!(seen, expected, "{threads} threads");
            }
        }
    }

    #[test]
    fn one_thread_hands_each_row_on_before_rendering_the_next() {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .unwrap();
        let rendered = AtomicUsize::new(0);
        let mut rendered_when_seen = Vec::new();
        let mut pixels = vec![0u8; 40 * 3];
        pool.install(|| {
            let render = |j, row: &mut [u8]| {
                render(j, row);
                rendered.fetch_add(1, Ordering::SeqCst);
            };
            rows_in_order(&mut pixels, 3, 40, render, &mut |_: &[u8]| {
                rendered_when_seen.push(rendered.load(Ordering::SeqCst))
            })
        });
        assert_eq!(rendered_when_seen, (1..=40).collect::<Vec<_>>());
    }
}
