//! One ray at a time, for the unit tests: the plain forms that the packet kernels are checked
//! against, written for clarity (the whole-frame oracle is tests/it/reference.rs).

use glam::DVec3;

use super::kernels::Shading;
use super::lanes::{Lanes, Portable};
use super::rays::RayTable;
use super::tiles::TileBins;

impl RayTable {
    /// Sample k (row-major in its s×s grid) of pixel (i, j): the unit direction from the COP
    /// to its window point.
    pub(super) fn direction(&self, i: usize, j: usize, k: usize) -> DVec3 {
        let s = self.raster.samples as usize;
        DVec3::new(self.xs[i * s + k % s], self.ys[j * s + k / s], self.dz).normalize()
    }
}

/// The smallest t > 0 with |f + t·d| = r for unit `d`, where `f` = origin − centre and
/// `c` = |f|² − r²; None if the ray misses or the sphere is behind. The stable form (Ray
/// Tracing Gems ch. 7), as the packets compute it.
pub(super) fn root(f: DVec3, c: f64, radius2: f64, d: DVec3) -> Option<f64> {
    let b = f.dot(d);
    let disc = radius2 - (f - d * b).length_squared();
    if disc < 0.0 {
        return None;
    }
    let q = -(b + disc.sqrt().copysign(b));
    if q == 0.0 {
        return None;
    }
    let (near, far) = if c / q < q { (c / q, q) } else { (q, c / q) };
    [near, far].into_iter().find(|t| *t > 0.0)
}

/// Whether the sphere about view point `center` with squared radius `radius2` blocks the ray
/// from `point` along unit `dir` (t > 0).
pub(super) fn blocks_ray(center: DVec3, radius2: f64, point: DVec3, dir: DVec3) -> bool {
    let f = point - center;
    if f.length_squared() - radius2 <= 0.0 {
        return true;
    }
    let b = f.dot(dir);
    b < 0.0 && (f - dir * b).length_squared() <= radius2
}

/// The packets' nearest hit for the one direction `d` (in every lane) of pixel (i, j), through
/// its tile's list: (sphere index, distance).
pub(super) fn nearest(
    shading: &Shading,
    bins: &TileBins,
    (i, j): (usize, usize),
    d: DVec3,
) -> Option<(usize, f64)> {
    let d = [
        Portable::splat((), d.x),
        Portable::splat((), d.y),
        Portable::splat((), d.z),
    ];
    let covers = |k: u32, _: usize| bins.covers(k, (i, i), (j, j));
    let [(hit, index, t), _] =
        shading.nearest_packets::<Portable>(&[d, d], bins.at(i, j), covers, [true, false]);
    (hit & 1 == 1).then(|| (index[0] as usize, t.store()[0]))
}
