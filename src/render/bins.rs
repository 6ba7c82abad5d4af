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

    /// Reorders every cell's items with `sort`.
    pub fn sort_cells(&mut self, mut sort: impl FnMut(&mut [u32])) {
        for k in 0..self.offsets.len() - 1 {
            sort(&mut self.items[self.offsets[k] as usize..self.offsets[k + 1] as usize]);
        }
    }

    /// Rewrites every cell's items in place with `edit`, given the cell (x, y) and its items:
    /// it may reorder them and drop some, leaving the ones to keep first, and returns how many
    /// it keeps.
    pub fn edit_cells(&mut self, mut edit: impl FnMut((usize, usize), &mut [u32]) -> usize) {
        let (mut start, mut write) = (0, 0);
        for k in 0..self.offsets.len() - 1 {
            let end = self.offsets[k + 1] as usize;
            let kept = edit(
                (k % self.width, k / self.width),
                &mut self.items[start..end],
            );
            assert!(kept <= end - start, "a cell gained items");
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
    }

    #[test]
    fn edited_cells_keep_their_own_items() {
        // 2×2 cells: item 0 everywhere, item 1 in the top row, item 2 in cell (1, 1).
        let rects = [Some((0, 1, 0, 1)), Some((0, 1, 0, 0)), Some((1, 1, 1, 1))];
        let mut bins = Bins::build((2, 2), 3, |k| rects[k]);
        let mut seen = Vec::new();
        bins.edit_cells(|(x, y), items| {
            seen.push((x, y));
            // Cell (0, 0) drops item 0, cell (1, 0) drops item 1, cell (1, 1) reverses its
            // items.
            match (x, y) {
                (0, 0) | (1, 0) => {
                    let drop = if x == 0 { 0 } else { 1 };
                    let at = items.iter().position(|&k| k == drop).unwrap();
                    items[at..].rotate_left(1);
                    items.len() - 1
                }
                (1, 1) => {
                    items.reverse();
                    items.len()
                }
                _ => items.len(),
            }
        });
        assert_eq!(seen, [(0, 0), (1, 0), (0, 1), (1, 1)]);
        assert_eq!(bins.cell(0, 0), [1]);
        assert_eq!(bins.cell(1, 0), [0]);
        assert_eq!(bins.cell(0, 1), [0]);
        assert_eq!(bins.cell(1, 1), [2, 0]);
    }
}
