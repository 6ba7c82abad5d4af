//! Sphere files: spheres kept outside the keyframe file, as PLY (ASCII or binary little-endian),
//! CSV or (extended) XYZ, the forms particle systems, point clouds and molecule tools write;
//! docs/format.md says what each may hold. Columns are found by name ([`look`]), and what a
//! file lacks comes from its entry in the keyframe file.
//!
//! Numbers are read exactly: a `double` in PLY, or a number in CSV (the value `f64::from_str`
//! gives, as RON reads its floats), gives the same bits as the same number in RON. Nothing is
//! checked here beyond the form: each sphere is handed, with its index, to the caller's `make`
//! as it is read ([`crate::document`] checks it there), so a file's spheres are never held
//! twice. A body passes through blocks of [`BLOCK_BYTES`] (`crate::format::blocks`), never held
//! whole: a binary PLY's vertices parsed on the rayon pool straight into the caller's vector,
//! a text body's lines (CSV, ASCII PLY) in pieces on the pool, both handed over in file order.

use std::fs::File;
use std::io::{BufReader, Read};
use std::path::Path;

use rayon::iter::{IndexedParallelIterator, ParallelExtend};

use super::{PlainSphere, SphereFileSpec, SphereSpec};

mod csv;
mod header;
mod listing;
mod look;
mod ply_body;
mod ply_header;
#[cfg(test)]
mod tests;
mod text;
mod xyz;

use listing::listed;
pub use listing::{FileProblem, Listing};
pub use look::{colormap, COLORMAPS};

/// Where a sphere file's spheres go, in file order: a vector, or the scene's packed spheres.
pub trait Sink<T>: Send {
    /// How many it holds.
    fn count(&self) -> usize;
    /// Room for `n` more.
    fn room(&mut self, n: usize);
    /// Appends `item`.
    fn put(&mut self, item: T);
    /// Appends `items`, in order, made on the rayon pool.
    fn put_all(&mut self, items: impl IndexedParallelIterator<Item = T>);
    /// Appends `count` plain rows, `row(k)` the k-th, made on the rayon pool, where the sink
    /// takes them as they are (a binary PLY's block whose rows are all [`PlainSphere`]s):
    /// whether it did. Where not, it holds what it held, and the rows go through `make`.
    fn put_plain(&mut self, count: usize, row: impl Fn(usize) -> PlainSphere + Sync) -> bool {
        let _ = (count, row);
        false
    }
}

impl<T: Send> Sink<T> for Vec<T> {
    fn count(&self) -> usize {
        self.len()
    }

    fn room(&mut self, n: usize) {
        self.reserve(n);
    }

    fn put(&mut self, item: T) {
        self.push(item);
    }

    fn put_all(&mut self, items: impl IndexedParallelIterator<Item = T>) {
        self.par_extend(items);
    }
}

/// The most bytes of a sphere file's body read at a time (a binary PLY's: whole vertices, at
/// least one): a million spheres' 56 MB pass through 4 MiB.
pub const BLOCK_BYTES: usize = 4 << 20;

/// Reads a sphere file, by its extension (`.ply`, `.csv`, `.xyz` or `.extxyz`), as `spec`
/// says, appending `make(i, sphere)` to `out` for each sphere `i` in file order; `make` runs on
/// the rayon pool for a binary PLY.
/// The spheres read stay in `out` whatever the file's problems (the listing's), so their own
/// problems can be named too.
pub fn read<T: Send>(
    path: &Path,
    spec: &SphereFileSpec,
    out: &mut impl Sink<T>,
    make: impl Fn(usize, &SphereSpec) -> T + Sync,
) -> Listing {
    let ext = path
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase());
    listed(out, |out, listing| {
        let mut file = File::open(path)
            .map_err(|e| FileProblem::whole(format!("cannot open {}: {e}", path.display())))?;
        let len = file.metadata().map_err(FileProblem::io)?.len();
        match ext.as_deref() {
            Some("ply") => ply_body::ply_from(BufReader::new(file), len, spec, out, &make, listing),
            Some("csv") => csv::csv_from(BufReader::new(file), spec, out, &make, listing),
            Some("xyz" | "extxyz") => {
                xyz::xyz_from(BufReader::new(file), spec, out, &make, listing)
            }
            _ => {
                // A folder, or a file that cannot be read, is named as such whatever its name.
                file.read(&mut [0]).map_err(FileProblem::io)?;
                Err(FileProblem::whole(
                    "a sphere file is .ply, .csv, .xyz or .extxyz (by its extension)",
                ))
            }
        }
    })
}
