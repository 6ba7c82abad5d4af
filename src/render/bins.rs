//! Items binned into a grid of cells, in compressed rows: the one binning structure of screen
//! tiles (primary rays) and of the shadow grid (shadow rays).

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
    /// Bins items `0..n` into a `dims.0` × `dims.1` grid: item k goes into every cell of
    /// `rect(k)` (None: into none). `rect` is called twice per item, so it must be pure.
    pub fn build(dims: (usize, usize), n: usize, rect: impl Fn(usize) -> Option<CellRect>) -> Bins {
        Bins::build_in_order(dims, 0..n, rect)
    }

    /// [`Bins::build_in_order`] on the rayon pool, in bands of rows: each band reads every
    /// item's rectangle and writes only its own rows' cells, so the bins are those built on one
    /// thread. For grids of many more cells than items (a shadow grid of small discs far
    /// apart), where a task's counts of [`Bins::build_in_chunks`] would outweigh the items.
    /// `rect_at(i)` is the rectangle of item `order[i]` (by position, so that the bands read
    /// the rectangles in sequence, not at random).
    pub fn build_in_bands(
        dims: (usize, usize),
        order: &[u32],
        rect_at: impl Fn(usize) -> Option<CellRect> + Sync,
    ) -> Bins {
        use rayon::prelude::*;
        let (width, height) = dims;
        let bands = (rayon::current_num_threads() * 2).clamp(1, height.max(1));
        let rows_per = height.div_ceil(bands).max(1);
        let band_rows = |b: usize| (b * rows_per).min(height)..((b + 1) * rows_per).min(height);
        // Per band, its cells' counts.
        let counts: Vec<Vec<u32>> = (0..bands)
            .into_par_iter()
            .map(|b| {
                let rows = band_rows(b);
                let mut counts = vec![0u32; rows.len() * width];
                for (x0, x1, y0, y1) in (0..order.len()).filter_map(&rect_at) {
                    for y in y0.max(rows.start)..=y1.min(rows.end.wrapping_sub(1)) {
                        let row = (y - rows.start) * width;
                        for c in &mut counts[row + x0..=row + x1] {
                            *c += 1;
                        }
                    }
                }
                counts
            })
            .collect();
        let mut offsets = Vec::with_capacity(width * height + 1);
        let mut total = 0u32;
        let mut band_starts = Vec::with_capacity(bands + 1);
        for c in counts.iter() {
            band_starts.push(total as usize);
            for &n in c {
                offsets.push(total);
                total += n;
            }
        }
        band_starts.push(total as usize);
        offsets.push(total);
        drop(counts);
        let mut items = vec![0u32; total as usize];
        let mut slices = Vec::with_capacity(bands);
        let mut rest = &mut items[..];
        for b in 0..bands {
            let (mine, after) = rest.split_at_mut(band_starts[b + 1] - band_starts[b]);
            slices.push((b, mine));
            rest = after;
        }
        slices.into_par_iter().for_each(|(b, mine)| {
            let rows = band_rows(b);
            let base = band_starts[b] as u32;
            let cells = rows.start * width..rows.end * width;
            let mut fill: Vec<u32> = offsets[cells].iter().map(|&o| o - base).collect();
            for (i, &k) in order.iter().enumerate() {
                if let Some((x0, x1, y0, y1)) = rect_at(i) {
                    for y in y0.max(rows.start)..=y1.min(rows.end.wrapping_sub(1)) {
                        let row = (y - rows.start) * width;
                        for slot in &mut fill[row + x0..=row + x1] {
                            mine[*slot as usize] = k;
                            *slot += 1;
                        }
                    }
                }
            }
        });
        Bins {
            width,
            offsets,
            items,
        }
    }

    /// [`Bins::build`] with the items taken in the order of `order`, which every cell's list
    /// keeps.
    pub fn build_in_order(
        dims: (usize, usize),
        order: impl Iterator<Item = usize> + Clone,
        rect: impl Fn(usize) -> Option<CellRect>,
    ) -> Bins {
        let width = dims.0;
        let cells = dims.0 * dims.1;
        let mut counts = vec![0u32; cells];
        for (x0, x1, y0, y1) in order.clone().filter_map(&rect) {
            for y in y0..=y1 {
                for c in &mut counts[y * width + x0..=y * width + x1] {
                    *c += 1;
                }
            }
        }
        let mut offsets = Vec::with_capacity(cells + 1);
        let mut total = 0u32;
        for c in &counts {
            offsets.push(total);
            total += c;
        }
        offsets.push(total);
        let mut fill = offsets.clone();
        let mut items = vec![0u32; total as usize];
        for k in order {
            if let Some((x0, x1, y0, y1)) = rect(k) {
                for y in y0..=y1 {
                    for slot in &mut fill[y * width + x0..=y * width + x1] {
                        items[*slot as usize] = k as u32;
                        *slot += 1;
                    }
                }
            }
        }
        Bins {
            width,
            offsets,
            items,
        }
    }

    /// [`Bins::build_in_order`] on the rayon pool, `chunk` items of `order` a task: each task
    /// counts its items' cells, and fills its own slots of every cell (after the slots of the
    /// tasks before it), so the bins are those built on one thread. For many items over a
    /// small grid (a frame's screen tiles, a dense scene's shadow grid): each task's counts
    /// are a grid's worth of u32. `rect_at(i)` is the rectangle of item `order[i]` (by
    /// position, read in sequence), called twice per item, so it must be pure.
    pub fn build_in_chunks(
        dims: (usize, usize),
        order: &[u32],
        chunk: usize,
        rect_at: impl Fn(usize) -> Option<CellRect> + Sync,
    ) -> Bins {
        use rayon::prelude::*;
        use std::sync::atomic::{AtomicU32, Ordering::Relaxed};
        let width = dims.0;
        let cells = dims.0 * dims.1;
        let (n, chunk) = (order.len(), chunk.max(1));
        let range = |c: usize| c * chunk..((c + 1) * chunk).min(n);
        let counts: Vec<Vec<u32>> = (0..n.div_ceil(chunk))
            .into_par_iter()
            .map(|c| {
                let mut counts = vec![0u32; cells];
                for (x0, x1, y0, y1) in range(c).filter_map(&rect_at) {
                    for y in y0..=y1 {
                        for k in &mut counts[y * width + x0..=y * width + x1] {
                            *k += 1;
                        }
                    }
                }
                counts
            })
            .collect();
        // Per cell, the tasks' slots in task order; each task's count turned into its first
        // slot in the cell.
        let mut starts = counts;
        let mut offsets = Vec::with_capacity(cells + 1);
        let mut total = 0u32;
        for cell in 0..cells {
            offsets.push(total);
            for task in starts.iter_mut() {
                let count = task[cell];
                task[cell] = total;
                total += count;
            }
        }
        offsets.push(total);
        // Every slot is written by exactly one task: relaxed stores, read after the join. The
        // zeros are written on the pool, so that every core faults in its share of the fresh
        // pages (16 MB for the PLY million's shadow grid: 10.7 -> 4.8 ms).
        let items: Vec<AtomicU32> = (0..total)
            .into_par_iter()
            .with_min_len(ZEROS_A_TASK)
            .map(|_| AtomicU32::new(0))
            .collect();
        starts
            .into_par_iter()
            .enumerate()
            .for_each(|(c, mut fill)| {
                for i in range(c) {
                    if let Some((x0, x1, y0, y1)) = rect_at(i) {
                        for y in y0..=y1 {
                            for slot in &mut fill[y * width + x0..=y * width + x1] {
                                items[*slot as usize].store(order[i], Relaxed);
                                *slot += 1;
                            }
                        }
                    }
                }
            });
        Bins {
            width,
            offsets,
            items: items.into_iter().map(AtomicU32::into_inner).collect(),
        }
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

/// The least slots a task of [`Bins::build_in_chunks`] zeroes.
const ZEROS_A_TASK: usize = 1 << 16;

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
        let bins = Bins::build((3, 2), 4, |k| rects[k]);
        assert_eq!(bins.cell(0, 0), [0, 1]);
        assert_eq!(bins.cell(1, 0), [1]);
        assert_eq!(bins.cell(2, 1), [1, 3]);
        assert_eq!(bins.cell(0, 1), [0, 1]);
        // Taken in another order, every cell keeps it.
        let bins = Bins::build_in_order((3, 2), [3, 1, 2, 0].into_iter(), |k| rects[k]);
        assert_eq!(bins.cell(0, 0), [1, 0]);
        assert_eq!(bins.cell(2, 1), [3, 1]);
        assert_eq!(bins.cell(1, 1), [1]);
        // In bands, the same.
        let order = [3, 1, 2, 0];
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

    /// Built in bands of rows on pools of 1 to 3 threads (bands of one row to all rows), a
    /// seeded grid's bins are those built in one pass.
    #[test]
    fn bins_built_in_bands_are_the_same() {
        let (w, h) = (37, 23);
        let rects = seeded_rects(5, (w, h), 3000, 7, (4, 5));
        let order: Vec<u32> = (0..3000u32).map(|k| (k * 1013) % 3000).collect();
        let one = Bins::build_in_order((w, h), order.iter().map(|&k| k as usize), |k| rects[k]);
        for threads in 1..=3 {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            let rect_at = |i: usize| rects[order[i] as usize];
            let banded = pool.install(|| Bins::build_in_bands((w, h), &order, rect_at));
            assert_eq!(banded.offsets, one.offsets);
            assert_eq!(banded.items, one.items);
        }
    }

    /// Built a chunk of items a task on pools of 1 to 3 threads (chunks of one item to all of
    /// them), a seeded grid's bins are those built in one pass, in the same order.
    #[test]
    fn bins_built_in_chunks_are_the_same() {
        let (w, h) = (29, 17);
        let rects = seeded_rects(6, (w, h), 2000, 5, (4, 3));
        let order: Vec<u32> = (0..2000u32).map(|k| (k * 1013) % 2000).collect();
        let one = Bins::build_in_order((w, h), order.iter().map(|&k| k as usize), |k| rects[k]);
        let rect_at = |i: usize| rects[order[i] as usize];
        for threads in 1..=3 {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            for chunk in [1, 7, 333, 2000, 5000] {
                let chunked =
                    pool.install(|| Bins::build_in_chunks((w, h), &order, chunk, rect_at));
                assert_eq!(
                    chunked.offsets, one.offsets,
                    "{threads} threads, chunks of {chunk}"
                );
                assert_eq!(
                    chunked.items, one.items,
                    "{threads} threads, chunks of {chunk}"
                );
            }
        }
        let empty = Bins::build_in_chunks((w, h), &[], 8, rect_at);
        assert_eq!(empty.items.len(), 0);
        assert_eq!(empty.offsets, vec![0; w * h + 1]);
    }

    #[test]
    fn edited_cells_keep_their_own_items() {
        // 2×2 cells: item 0 everywhere, item 1 in the top row, item 2 in cell (1, 1).
        let rects = [Some((0, 1, 0, 1)), Some((0, 1, 0, 0)), Some((1, 1, 1, 1))];
        let mut bins = Bins::build((2, 2), 3, |k| rects[k]);
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
