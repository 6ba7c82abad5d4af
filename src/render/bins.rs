//! Items binned into a grid of cells, in compressed rows: the one binning structure of screen
//! tiles (primary rays) and of the shadow grid (shadow rays), made by the counting sort.

use std::ops::Range;
use std::sync::atomic::AtomicU32;

use super::sort::{self, Scatter};

/// Cell k's items are `items[offsets[k]..offsets[k + 1]]`, in the order they were binned.
pub struct Bins {
    /// Cells per row.
    width: usize,
    offsets: Vec<u32>,
    items: Vec<u32>,
}

/// An inclusive rectangle of cells: (x0, x1, y0, y1).
pub type CellRect = (usize, usize, usize, usize);

impl Bins {
    /// No cells.
    pub fn empty() -> Bins {
        Bins::build((0, 0), &[], 1, |_| None)
    }

    /// Bins the items `order` into a `dims.0` × `dims.1` grid, every cell listing its items in
    /// that order: `order[i]` goes into every cell of `rect_at(i)` (None: into none; by
    /// position, so that the rectangles are read in sequence). On the rayon pool, `chunk` items
    /// a task: each task counts its items' cells over the whole grid (a grid's worth of u32), so
    /// for many items over a small grid (a frame's screen tiles, a dense scene's shadow grid).
    /// `rect_at` is called twice per item, so it must be pure.
    pub fn build(
        dims: (usize, usize),
        order: &[u32],
        chunk: usize,
        rect_at: impl Fn(usize) -> Option<CellRect> + Sync,
    ) -> Bins {
        let chunk = chunk.max(1);
        let grid = Grid {
            width: dims.0,
            order,
            rect_at,
            tasks: order.len().div_ceil(chunk),
            items: |t: usize| t * chunk..((t + 1) * chunk).min(order.len()),
            rows: |_| 0..dims.1,
        };
        grid.build(dims.1)
    }

    /// [`Bins::build`] in bands of rows: each band reads every item's rectangle and writes
    /// only its own rows' cells. For grids of many more cells than items (a shadow grid of
    /// small discs far apart), where a task's counts of the whole grid would outweigh the items.
    pub fn build_in_bands(
        dims: (usize, usize),
        order: &[u32],
        rect_at: impl Fn(usize) -> Option<CellRect> + Sync,
    ) -> Bins {
        let height = dims.1;
        let bands = (rayon::current_num_threads() * 2).clamp(1, height.max(1));
        let rows_per = height.div_ceil(bands).max(1);
        let grid = Grid {
            width: dims.0,
            order,
            rect_at,
            tasks: bands,
            items: |_| 0..order.len(),
            rows: |b: usize| (b * rows_per).min(height)..((b + 1) * rows_per).min(height),
        };
        grid.build(height)
    }

    /// Rewrites every cell's items in place with `edit`, given a scratch value of `init`'s (one
    /// a task), the cell (x, y) and its items: it may reorder them and drop some, leaving the
    /// ones to keep first, and returns how many it keeps. The cells are edited on the rayon
    /// pool, each by one call, then closed up in order.
    pub fn edit_cells<S>(
        &mut self,
        init: impl Fn() -> S + Sync + Send,
        edit: impl Fn(&mut S, (usize, usize), &mut [u32]) -> usize + Sync + Send,
    ) {
        use rayon::prelude::*;
        let width = self.width;
        let mut cells: Vec<&mut [u32]> = Vec::with_capacity(self.offsets.len());
        let mut rest = &mut self.items[..];
        for w in self.offsets.windows(2) {
            let (cell, after) = rest.split_at_mut((w[1] - w[0]) as usize);
            cells.push(cell);
            rest = after;
        }
        let kept: Vec<usize> = cells
            .into_par_iter()
            .enumerate()
            .with_min_len(64)
            .map_init(init, |scratch, (k, items)| {
                let kept = edit(scratch, (k % width, k / width), items);
                assert!(kept <= items.len(), "a cell gained items");
                kept
            })
            .collect();
        let (mut start, mut write) = (0, 0);
        for (k, kept) in kept.into_iter().enumerate() {
            let end = self.offsets[k + 1] as usize;
            // Cells before this one only shrank, so the write never passes the read.
            if write != start {
                self.items.copy_within(start..start + kept, write);
            }
            self.offsets[k] = write as u32;
            write += kept;
            start = end;
        }
        *self.offsets.last_mut().expect("one offset past the cells") = write as u32;
        self.items.truncate(write);
    }

    /// The items of cell (x, y).
    #[inline]
    pub fn cell(&self, x: usize, y: usize) -> &[u32] {
        let k = y * self.width + x;
        &self.items[self.offsets[k] as usize..self.offsets[k + 1] as usize]
    }
}

/// The items of a grid's build, as the counting sort takes them: task t bins the items
/// `items(t)` into the rows `rows(t)`.
struct Grid<'a, R, I, W> {
    width: usize,
    order: &'a [u32],
    rect_at: R,
    tasks: usize,
    items: I,
    rows: W,
}

impl<R, I, W> Grid<'_, R, I, W>
where
    R: Fn(usize) -> Option<CellRect> + Sync,
    I: Fn(usize) -> Range<usize> + Sync,
    W: Fn(usize) -> Range<usize> + Sync,
{
    fn build(self, height: usize) -> Bins {
        let counts = sort::count(&self, self.tasks, self.width * height);
        let offsets = counts.offsets.clone();
        let items = sort::slots::<u32>(offsets[offsets.len() - 1] as usize);
        sort::scatter(&self, counts, &items);
        let items = items.into_iter().map(AtomicU32::into_inner).collect();
        Bins {
            width: self.width,
            offsets,
            items,
        }
    }
}

impl<R, I, W> Scatter for Grid<'_, R, I, W>
where
    R: Fn(usize) -> Option<CellRect> + Sync,
    I: Fn(usize) -> Range<usize> + Sync,
    W: Fn(usize) -> Range<usize> + Sync,
{
    type Item = u32;

    fn buckets(&self, t: usize) -> Range<usize> {
        let rows = (self.rows)(t);
        rows.start * self.width..rows.end * self.width
    }

    #[inline(always)]
    fn each(&self, t: usize, mut put: impl FnMut(Range<usize>, u32)) {
        let (rows, w) = ((self.rows)(t), self.width);
        for i in (self.items)(t) {
            if let Some((x0, x1, y0, y1)) = (self.rect_at)(i) {
                for y in y0.max(rows.start)..=y1.min(rows.end.wrapping_sub(1)) {
                    put(y * w + x0..y * w + x1 + 1, self.order[i]);
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_item_lands_in_exactly_its_cells() {
        // 3×2 cells; item 0 covers the left column, item 1 everything, item 2 nothing, item 3
        // the cell (2, 1).
        let rects = [
            Some((0, 0, 0, 1)),
            Some((0, 2, 0, 1)),
            None,
            Some((2, 2, 1, 1)),
        ];
        let bins = Bins::build((3, 2), &[0, 1, 2, 3], 4, |k| rects[k]);
        assert_eq!(bins.cell(0, 0), [0, 1]);
        assert_eq!(bins.cell(1, 0), [1]);
        assert_eq!(bins.cell(2, 1), [1, 3]);
        assert_eq!(bins.cell(0, 1), [0, 1]);
        // Taken in another order, every cell keeps it.
        let order = [3, 1, 2, 0];
        let bins = Bins::build((3, 2), &order, 4, |i| rects[order[i] as usize]);
        assert_eq!(bins.cell(0, 0), [1, 0]);
        assert_eq!(bins.cell(2, 1), [3, 1]);
        assert_eq!(bins.cell(1, 1), [1]);
        // In bands, the same.
        let banded = Bins::build_in_bands((3, 2), &order, |i| rects[order[i] as usize]);
        assert_eq!((banded.offsets, banded.items), (bins.offsets, bins.items));
    }

    /// `n` seeded rectangles on a `dims` grid, up to `span` cells beyond their first in x and
    /// y; every `none`-th item has none.
    fn seeded_rects(
        seed: u64,
        (w, h): (usize, usize),
        n: usize,
        none: usize,
        span: (usize, usize),
    ) -> Vec<Option<CellRect>> {
        let mut rng = crate::splitmix::SplitMix(seed);
        (0..n)
            .map(|k| {
                let mut r = |n: usize| (rng.unit() * n as f64) as usize;
                let (x0, y0) = (r(w), r(h));
                (k % none != 0).then(|| {
                    let x1 = (x0 + r(span.0)).min(w - 1);
                    (x0, x1, y0, (y0 + r(span.1)).min(h - 1))
                })
            })
            .collect()
    }

    /// Each cell's list, one cell at a time: the items of `order` whose rectangle holds it.
    fn cell_by_cell(
        bins: &Bins,
        (w, h): (usize, usize),
        order: &[u32],
        rects: &[Option<CellRect>],
    ) {
        for (x, y) in (0..h).flat_map(|y| (0..w).map(move |x| (x, y))) {
            let want: Vec<u32> = order
                .iter()
                .filter(|&&k| {
                    rects[k as usize].is_some_and(|(x0, x1, y0, y1)| {
                        (x0..=x1).contains(&x) && (y0..=y1).contains(&y)
                    })
                })
                .copied()
                .collect();
            assert_eq!(bins.cell(x, y), want, "cell ({x}, {y})");
        }
    }

    /// Built a chunk of items a task (chunks of one item to all of them) and in bands of rows
    /// (one row to all rows), on pools of 1 to 3 threads, a seeded grid's cells each list the
    /// items whose rectangles hold them, in order.
    #[test]
    fn bins_in_chunks_and_bands_list_each_cells_items_in_order() {
        for (seed, (w, h), n) in [(5, (37, 23), 3000), (6, (29, 17), 2000)] {
            let rects = seeded_rects(seed, (w, h), n, 7, (4, 5));
            let order: Vec<u32> = (0..n as u32).map(|k| (k * 1013) % n as u32).collect();
            let rect_at = |i: usize| rects[order[i] as usize];
            for threads in 1..=3 {
                let pool = rayon::ThreadPoolBuilder::new()
                    .num_threads(threads)
                    .build()
                    .unwrap();
                let banded = pool.install(|| Bins::build_in_bands((w, h), &order, rect_at));
                cell_by_cell(&banded, (w, h), &order, &rects);
                for chunk in [1, 7, 333, n, 5000] {
                    let chunked = pool.install(|| Bins::build((w, h), &order, chunk, rect_at));
                    assert_eq!(
                        chunked.offsets, banded.offsets,
                        "{threads} threads, {chunk}"
                    );
                    assert_eq!(chunked.items, banded.items, "{threads} threads, {chunk}");
                }
            }
            let empty = Bins::build((w, h), &[], 8, rect_at);
            assert_eq!(empty.items.len(), 0);
            assert_eq!(empty.offsets, vec![0; w * h + 1]);
        }
    }

    #[test]
    fn edited_cells_keep_their_own_items() {
        // 2×2 cells: item 0 everywhere, item 1 in the top row, item 2 in cell (1, 1).
        let rects = [Some((0, 1, 0, 1)), Some((0, 1, 0, 0)), Some((1, 1, 1, 1))];
        let mut bins = Bins::build((2, 2), &[0, 1, 2], 3, |k| rects[k]);
        let seen = std::sync::Mutex::new(Vec::new());
        bins.edit_cells(Vec::<u32>::new, |scratch, (x, y), items| {
            seen.lock().unwrap().push((x, y));
            // Cell (0, 0) drops item 0, cell (1, 0) drops item 1, cell (1, 1) reverses its
            // items (through the scratch).
            match (x, y) {
                (0, 0) | (1, 0) => {
                    let drop = if x == 0 { 0 } else { 1 };
                    let at = items.iter().position(|&k| k == drop).unwrap();
                    items[at..].rotate_left(1);
                    items.len() - 1
                }
                (1, 1) => {
                    scratch.clear();
                    scratch.extend(items.iter().rev());
                    items.copy_from_slice(scratch);
                    items.len()
                }
                _ => items.len(),
            }
        });
        let mut seen = seen.into_inner().unwrap();
        seen.sort_by_key(|&(x, y)| (y, x));
        assert_eq!(seen, [(0, 0), (1, 0), (0, 1), (1, 1)]);
        assert_eq!(bins.cell(0, 0), [1]);
        assert_eq!(bins.cell(1, 0), [0]);
        assert_eq!(bins.cell(0, 1), [0]);
        assert_eq!(bins.cell(1, 1), [2, 0]);
    }
}
