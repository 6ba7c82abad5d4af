//! A frame's rows on the thread pool, passed on in order while later rows render.
//!
//! Threads claim rows in order from one counter. A thread that finishes a row hands on every
//! finished row that extends the finished prefix, so a consumer of the rows (the frame's
//! SHA-256, which is sequential) runs beside the rendering instead of after it, on the same
//! threads: a frame costs its rendering and its hashing spread over the cores, not their sum
//! on one of them, and the frame is never read again from memory after it is rendered.
//!
//! Which thread hands a row on, and when, varies from run to run; what is handed on does not.
//! Every row is handed on exactly once, in row order, before [`rows_in_order`] returns.

use std::sync::atomic::{fence, AtomicBool, AtomicUsize, Ordering};
use std::sync::{Mutex, PoisonError, TryLockError};

use rayon::prelude::*;

/// One row of the frame: its bytes, and whether they are final.
struct Row<'p> {
    bytes: Mutex<&'p mut [u8]>,
    done: AtomicBool,
}

/// The consumer and the first row it has not seen.
struct Prefix<'s> {
    next: usize,
    in_order: &'s mut (dyn FnMut(&[u8]) + Send),
}

/// Renders every row of `pixels` (rows of `row_bytes`) with `render(j, row)` on the rayon pool,
/// and passes each finished row to `in_order` once, in row order, as the finished prefix grows.
/// `in_order` runs on one thread at a time.
pub(crate) fn rows_in_order(
    pixels: &mut [u8],
    row_bytes: usize,
    render: impl Fn(usize, &mut [u8]) + Sync,
    in_order: &mut (dyn FnMut(&[u8]) + Send),
) {
    let rows: Vec<Row> = pixels
        .chunks_mut(row_bytes)
        .map(|bytes| Row {
            bytes: Mutex::new(bytes),
            done: AtomicBool::new(false),
        })
        .collect();
    let claimed = AtomicUsize::new(0);
    let prefix = Mutex::new(Prefix { next: 0, in_order });
    let hand_on = || hand_on(&rows, &prefix);
    (0..rayon::current_num_threads())
        .into_par_iter()
        .with_max_len(1)
        .for_each(|_| loop {
            let j = claimed.fetch_add(1, Ordering::Relaxed);
            let Some(row) = rows.get(j) else { break };
            render(j, &mut lock(&row.bytes));
            row.done.store(true, Ordering::Release);
            // Pairs with the fence in `hand_on`: either this thread takes the prefix below, or
            // the thread that holds it sees this row done after letting go of it.
            fence(Ordering::SeqCst);
            hand_on();
        });
    // Every row is done: pass on whatever is left (nothing, by the hand-over above), so the
    // consumer has seen every row whatever the threads did.
    let prefix = prefix.into_inner().unwrap_or_else(PoisonError::into_inner);
    for row in &rows[prefix.next..] {
        (prefix.in_order)(&lock(&row.bytes));
    }
}

/// Passes on the finished rows after the prefix, unless another thread is doing so.
fn hand_on(rows: &[Row], prefix: &Mutex<Prefix>) {
    loop {
        let mut p = match prefix.try_lock() {
            Ok(p) => p,
            Err(TryLockError::WouldBlock) => return,
            Err(TryLockError::Poisoned(e)) => e.into_inner(),
        };
        while let Some(row) = rows.get(p.next).filter(|r| r.done.load(Ordering::Acquire)) {
            (p.in_order)(&lock(&row.bytes));
            p.next += 1;
        }
        let next = p.next;
        drop(p);
        // A row finished after the check above, by a thread that found the prefix taken, is
        // seen here (see the fence after a row is done).
        fence(Ordering::SeqCst);
        if !rows
            .get(next)
            .is_some_and(|r| r.done.load(Ordering::Acquire))
        {
            return;
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
                    rows_in_order(&mut pixels, row_bytes, render, &mut |r: &[u8]| {
                        seen.push(r.to_vec())
                    })
                });
                let expected: Vec<Vec<u8>> = (0..rows)
                    .map(|j| {
                        let mut r = vec![0; row_bytes];
                        render(j, &mut r);
                        r
                    })
                    .collect();
                assert_eq!(seen, expected, "{threads} threads, {rows} rows");
                assert_eq!(pixels, expected.concat(), "{threads} threads, {rows} rows");
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
            rows_in_order(&mut pixels, 3, render, &mut |_: &[u8]| {
                rendered_when_seen.push(rendered.load(Ordering::SeqCst))
            })
        });
        assert_eq!(rendered_when_seen, (1..=40).collect::<Vec<_>>());
    }
}
