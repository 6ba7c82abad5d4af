//! A frame's rows on the thread pool, passed on in order while later rows render.
//!
//! The rows go in bands of a few rows (the renderer's packets span rows), the last band of a
//! frame holding what is left. Threads claim bands in order from one counter. A thread that
//! finishes a band hands on every finished band that extends the finished prefix, so a
//! consumer of the rows (the frame's SHA-256, which is sequential) runs beside the rendering
//! instead of after it, on the same threads: a frame costs its rendering and its hashing spread
//! over the cores, not their sum on one of them, and the frame is never read again from memory
//! after it is rendered.
//!
//! The bands go into a buffer of whole bands: the frame, or a ring of fewer bands (band b in
//! slot b mod the slot count), which a run that only hashes its frames uses so as not to touch
//! a frame's worth of memory. A band is rendered into its slot only once the band that held the
//! slot before has been handed on; a thread waiting for that hands bands on itself.
//!
//! Which thread hands a band on, and when, varies from run to run; what is handed on does not.
//! Every row is handed on exactly once, in row order, before [`rows_in_order`] returns.

use std::sync::atomic::{fence, AtomicBool, AtomicUsize, Ordering};
use std::sync::{Mutex, PoisonError, TryLockError};

use rayon::prelude::*;

/// One slot of the buffer: its bytes, and which band they hold finished (band + 1; 0 for
/// none).
struct Slot<'p> {
    bytes: Mutex<&'p mut [u8]>,
    done: AtomicUsize,
}

/// The consumer and the first band it has not seen.
struct Prefix<'s> {
    next: usize,
    in_order: &'s mut (dyn FnMut(&[u8]) + Send),
}

/// The shared state of one frame's bands.
struct Rows<'p, 's> {
    slots: Vec<Slot<'p>>,
    bands: Bands,
    prefix: Mutex<Prefix<'s>>,
    /// Bands handed on so far (the prefix's `next`, readable without its lock).
    handed: AtomicUsize,
    /// A band's rendering panicked: the bands after it will never be handed on, so no thread
    /// waits for them (the panic reaches the caller through the pool).
    panicked: AtomicBool,
}

/// How a frame's rows go in bands: `rows` rows of `row_bytes` each, `band` rows a band, the
/// last band what is left.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Bands {
    pub(crate) row_bytes: usize,
    pub(crate) rows: usize,
    pub(crate) band: usize,
}

impl Bands {
    fn count(&self) -> usize {
        self.rows.div_ceil(self.band)
    }

    /// Band b's first row and bytes.
    fn of(&self, b: usize) -> (usize, usize) {
        let first = b * self.band;
        (first, self.band.min(self.rows - first) * self.row_bytes)
    }
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

/// Renders the rows of `bands` with `render(first row, band)` on the rayon pool into
/// `buffer`, which holds the frame or a ring of fewer whole bands, and passes each finished
/// band's rows to `in_order` once, in row order, as the finished prefix grows. `in_order` runs
/// on one thread at a time.
///
/// Neither `render` nor `in_order` may wait on the rayon pool (`join`, `par_iter`): a thread
/// waiting there can steal a worker of these rows that has not started, and with a ring that
/// worker can wait for a slot whose band is suspended below it on the same thread — a hang.
/// The renderer's rows and the frame's SHA-256 use no rayon.
pub(crate) fn rows_in_order(
    buffer: &mut [u8],
    bands: Bands,
    render: impl Fn(usize, &mut [u8]) + Sync,
    in_order: &mut (dyn FnMut(&[u8]) + Send),
) {
    let count = bands.count();
    let band_bytes = bands.band * bands.row_bytes;
    assert!(
        buffer.len().is_multiple_of(band_bytes) || buffer.len() == bands.rows * bands.row_bytes,
        "a buffer of whole bands, or the frame"
    );
    let slots: Vec<Slot> = buffer
        .chunks_mut(band_bytes)
        .take(count)
        .map(|bytes| Slot {
            bytes: Mutex::new(bytes),
            done: AtomicUsize::new(0),
        })
        .collect();
    assert!(
        !slots.is_empty() || count == 0,
        "a buffer of at least one band"
    );
    let state = Rows {
        slots,
        bands,
        prefix: Mutex::new(Prefix { next: 0, in_order }),
        handed: AtomicUsize::new(0),
        panicked: AtomicBool::new(false),
    };
    let claimed = AtomicUsize::new(0);
    (0..rayon::current_num_threads())
        .into_par_iter()
        .with_max_len(1)
        .for_each(|_| {
            // A panic anywhere in this thread's bands (rendering or handing on) stops waiters.
            let _guard = PanicGuard(&state.panicked);
            loop {
                let b = claimed.fetch_add(1, Ordering::Relaxed);
                if b >= count {
                    break;
                }
                let slot = &state.slots[b % state.slots.len()];
                // The slot's previous band must be handed on first. It was claimed before this
                // one, so it is done or being rendered; bands before it are being handed on, or
                // this thread hands them on.
                while state.handed.load(Ordering::Acquire) + state.slots.len() <= b {
                    if state.panicked.load(Ordering::SeqCst) {
                        return;
                    }
                    state.hand_on();
                    std::thread::yield_now();
                }
                let (first, bytes) = bands.of(b);
                render(first, &mut lock(&slot.bytes)[..bytes]);
                slot.done.store(b + 1, Ordering::Release);
                // Pairs with the fence in `hand_on`: either this thread takes the prefix below,
                // or the thread that holds it sees this band done after letting go of it.
                fence(Ordering::SeqCst);
                state.hand_on();
            }
        });
    // Every band is done: pass on whatever is left (nothing, by the hand-over above), so the
    // consumer has seen every row whatever the threads did.
    let prefix = state
        .prefix
        .into_inner()
        .unwrap_or_else(PoisonError::into_inner);
    for b in prefix.next..count {
        let slot = &state.slots[b % state.slots.len()];
        assert_eq!(
            slot.done.load(Ordering::Acquire),
            b + 1,
            "band {b} in its slot"
        );
        (prefix.in_order)(&lock(&slot.bytes)[..bands.of(b).1]);
    }
}

impl<'p> Rows<'p, '_> {
    /// The slot of band b if it holds band b finished.
    fn finished(&self, b: usize) -> Option<&Slot<'p>> {
        let slot = self.slots.get(b % self.slots.len().max(1))?;
        (b < self.bands.count() && slot.done.load(Ordering::Acquire) == b + 1).then_some(slot)
    }

    /// Passes on the finished bands after the prefix, unless another thread is doing so.
    fn hand_on(&self) {
        loop {
            let mut p = match self.prefix.try_lock() {
                Ok(p) => p,
                // Poisoned: the consumer panicked, and is not called again; the panic reaches
                // the caller.
                Err(TryLockError::WouldBlock | TryLockError::Poisoned(_)) => return,
            };
            while let Some(slot) = self.finished(p.next) {
                let bytes = self.bands.of(p.next).1;
                (p.in_order)(&lock(&slot.bytes)[..bytes]);
                p.next += 1;
                self.handed.store(p.next, Ordering::Release);
            }
            let next = p.next;
            drop(p);
            // A band finished after the check above, by a thread that found the prefix taken,
            // is seen here (see the fence after a band is done).
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
    fn render_row(j: usize, row: &mut [u8]) {
        let mut x = j as u64 + 1;
        for _ in 0..(j * 7919 % 13) * 2000 {
            x = std::hint::black_box(x.wrapping_mul(6364136223846793005).wrapping_add(1));
        }
        for (i, b) in row.iter_mut().enumerate() {
            *b = (j * 31 + i) as u8;
        }
    }

    /// A band's rows from its first, each by [`render_row`].
    fn render(row_bytes: usize) -> impl Fn(usize, &mut [u8]) + Sync {
        move |first, band| {
            for (r, row) in band.chunks_mut(row_bytes).enumerate() {
                render_row(first + r, row)
            }
        }
    }

    /// Rows 0..rows as [`render_row`] makes them, one at a time, in bands of `band` rows.
    fn expected(rows: usize, row_bytes: usize, band: usize) -> Vec<Vec<u8>> {
        let rows: Vec<Vec<u8>> = (0..rows)
            .map(|j| {
                let mut r = vec![0; row_bytes];
                render_row(j, &mut r);
                r
            })
            .collect();
        rows.chunks(band).map(|b| b.concat()).collect()
    }

    fn pool(threads: usize) -> rayon::ThreadPool {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
    }

    /// What [`rows_in_order`] hands on, band by band, rendering by [`render`] into `buffer`.
    fn handed_on(pool: &rayon::ThreadPool, buffer: &mut [u8], bands: Bands) -> Vec<Vec<u8>> {
        let mut seen = Vec::new();
        pool.install(|| {
            rows_in_order(buffer, bands, render(bands.row_bytes), &mut |r: &[u8]| {
                seen.push(r.to_vec())
            })
        });
        seen
    }

    /// Whole bands, handed on once each, in order, the last one short when the rows are not a
    /// whole number of bands.
    #[test]
    fn every_row_is_handed_on_once_in_order() {
        for threads in [1, 2, 3] {
            let pool = pool(threads);
            for band in [1, 2, 4] {
                for (rows, row_bytes) in [(0, 5), (1, 5), (2, 1), (3, 2), (97, 33), (300, 8)] {
                    let mut pixels = vec![0xa5u8; rows * row_bytes];
                    let bands = Bands {
                        row_bytes,
                        rows,
                        band,
                    };
                    let seen = handed_on(&pool, &mut pixels, bands);
                    let expected = expected(rows, row_bytes, band);
                    let at = format!("{threads} threads, {rows} rows, bands of {band}");
                    assert_eq!(seen, expected, "{at}");
                    assert_eq!(pixels, expected.concat(), "{at}");
                }
            }
        }
    }

    #[test]
    fn a_ring_of_fewer_bands_hands_on_every_row_in_order() {
        for threads in [1, 2, 3] {
            let pool = pool(threads);
            for band in [1, 4] {
                for slots in [1, 2, 3, 7, 24] {
                    let (rows, row_bytes) = (97, 33);
                    let mut ring = vec![0xa5u8; slots * band * row_bytes];
                    let bands = Bands {
                        row_bytes,
                        rows,
                        band,
                    };
                    let seen = handed_on(&pool, &mut ring, bands);
                    let expected = expected(rows, row_bytes, band);
                    let at = format!("{threads} threads, {slots} slots of {band} rows");
                    assert_eq!(seen, expected, "{at}");
                    // Each slot holds the last band that went into it (the last band of the
                    // frame is short: it fills the start of its slot).
                    for (k, slot) in ring.chunks(band * row_bytes).enumerate() {
                        let last = (k..expected.len()).step_by(slots).next_back().unwrap();
                        assert_eq!(&slot[..expected[last].len()], expected[last], "{at}");
                    }
                }
            }
        }
    }

    /// A band that panics, or a consumer that does: the panic reaches the caller, no thread
    /// waits for the bands after it to be handed on, no band after it is handed on, and a
    /// consumer that panicked is not called again.
    #[test]
    fn a_panicking_band_ends_the_frame() {
        for threads in [1, 2, 3, 8] {
            let pool = pool(threads);
            for (slots, bad) in [(2, 5), (1, 0), (1, 19), (20, 1), (20, 19)] {
                let bands = Bands {
                    row_bytes: 4,
                    rows: 39,
                    band: 2,
                };
                let mut ring = vec![0u8; slots * 8];
                let mut seen = 0;
                let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
                    pool.install(|| {
                        let render = |j, band: &mut [u8]| {
                            assert!(j != 2 * bad, "band {bad}");
                            render(4)(j, band)
                        };
                        rows_in_order(&mut ring, bands, render, &mut |_: &[u8]| seen += 1)
                    })
                }));
                let at = format!("{threads} threads, {slots} slots, band {bad}");
                assert!(result.is_err(), "{at}");
                assert!(seen <= bad, "{seen} bands handed on, {at}");
                // The consumer panics on band `bad`.
                let mut calls = 0;
                let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
                    pool.install(|| {
                        rows_in_order(&mut ring, bands, render(4), &mut |_: &[u8]| {
                            calls += 1;
                            assert!(calls != bad + 1, "band {bad}");
                        })
                    })
                }));
                assert!(result.is_err(), "{at}");
                assert_eq!(calls, bad + 1, "{at}");
            }
        }
    }

    /// Short sleeps and yields at random points of the bands and the consumer, so that threads
    /// overtake each other everywhere: every band reaches the consumer whole (each is written
    /// in two steps, a wrong one between), once and in order, and the consumer is never entered
    /// by two threads at once.
    #[test]
    fn bands_arrive_whole_in_order_to_one_consumer_at_a_time() {
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
        let (row_bytes, rows) = (16, 40);
        for threads in [1, 2, 3, 8] {
            let pool = pool(threads);
            for band in [1, 3] {
                let expected = expected(rows, row_bytes, band);
                let bands = Bands {
                    row_bytes,
                    rows,
                    band,
                };
                for slots in [1, 2, 3, 5, 14] {
                    for _ in 0..20 {
                        let mut ring = vec![0u8; slots * band * row_bytes];
                        let inside = std::sync::atomic::AtomicBool::new(false);
                        let mut next = 0;
                        pool.install(|| {
                            let render = |j, band: &mut [u8]| {
                                jitter();
                                band.fill(0xee);
                                jitter();
                                render(row_bytes)(j, band);
                            };
                            rows_in_order(&mut ring, bands, render, &mut |r: &[u8]| {
                                assert!(!inside.swap(true, Ordering::SeqCst), "entered twice");
                                assert_eq!(r, expected[next], "band {next}, {threads} threads");
                                next += 1;
                                jitter();
                                inside.store(false, Ordering::SeqCst);
                            })
                        });
                        assert_eq!(next, expected.len(), "{threads} threads, {slots} slots");
                    }
                }
            }
        }
    }

    /// As the frame loop runs them: the bands in `rayon::join` beside a task that uses the pool
    /// in parallel (the next frame's preparation).
    #[test]
    fn bands_beside_a_parallel_task() {
        use rayon::prelude::*;
        let bands = Bands {
            row_bytes: 8,
            rows: 61,
            band: 4,
        };
        let expected = expected(61, 8, 4);
        for threads in [1, 2, 3, 8] {
            let pool = pool(threads);
            for _ in 0..50 {
                let mut ring = vec![0u8; 3 * 4 * 8];
                let mut seen = Vec::new();
                let ((), sum) = pool.install(|| {
                    rayon::join(
                        || {
                            rows_in_order(&mut ring, bands, render(8), &mut |r: &[u8]| {
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
    fn one_thread_hands_each_band_on_before_rendering_the_next() {
        let pool = pool(1);
        let rendered = AtomicUsize::new(0);
        let mut rendered_when_seen = Vec::new();
        let mut pixels = vec![0u8; 40 * 3];
        let bands = Bands {
            row_bytes: 3,
            rows: 40,
            band: 2,
        };
        pool.install(|| {
            let render = |j, band: &mut [u8]| {
                render(3)(j, band);
                rendered.fetch_add(1, Ordering::SeqCst);
            };
            rows_in_order(&mut pixels, bands, render, &mut |_: &[u8]| {
                rendered_when_seen.push(rendered.load(Ordering::SeqCst))
            })
        });
        assert_eq!(rendered_when_seen, (1..=20).collect::<Vec<_>>());
    }

    /// A ring that is neither whole bands nor the frame is refused.
    #[test]
    #[should_panic(expected = "whole bands")]
    fn a_ring_of_part_bands_is_refused() {
        let bands = Bands {
            row_bytes: 2,
            rows: 10,
            band: 4,
        };
        rows_in_order(&mut [0u8; 12], bands, render(2), &mut |_: &[u8]| {});
    }
}
