//! Shadow rays towards a directional light, binned in the light's own projection.
//!
//! Every shadow ray runs parallel to the light, so projected along it each ray is a single
//! point, and only spheres whose projected disc holds that point can block it. Discs are binned
//! into a uniform grid over the plane orthogonal to the light; a query looks at one cell. Spheres
//! much larger than the typical one (a ground sphere) are kept in a list tested for every ray,
//! so they do not inflate the grid.

use glam::{DVec2, DVec3};

use super::bins::Bins;
use super::ViewSphere;

/// Spheres binned for one light direction, in view coordinates.
pub struct ShadowGrid {
    /// Unit vector towards the light.
    to_light: DVec3,
    /// Orthonormal axes of the projection plane.
    axes: (DVec3, DVec3),
    origin: DVec2,
    inv_cell: f64,
    dims: (usize, usize),
    bins: Bins,
    /// Spheres tested for every ray.
    always: Vec<u32>,
}

impl ShadowGrid {
    pub fn build(spheres: &[ViewSphere], to_light: DVec3) -> ShadowGrid {
        let axes = to_light.any_orthonormal_pair();
        let project = |c: DVec3| DVec2::new(c.dot(axes.0), c.dot(axes.1));
        let big = big_radius(spheres);
        let always: Vec<u32> = (0..spheres.len() as u32)
            .filter(|k| spheres[*k as usize].radius > big)
            .collect();
        let small = || spheres.iter().filter(|s| s.radius <= big);
        let mut lo = DVec2::splat(f64::INFINITY);
        let mut hi = DVec2::splat(f64::NEG_INFINITY);
        for s in small() {
            lo = lo.min(project(s.center) - s.radius);
            hi = hi.max(project(s.center) + s.radius);
        }
        let count = small().count();
        if count == 0 {
            return ShadowGrid {
                to_light,
                axes,
                origin: DVec2::ZERO,
                inv_cell: 0.0,
                dims: (0, 0),
                bins: Bins::build((0, 0), 0, |_| None),
                always,
            };
        }
        let (dims, inv_cell) = grid_size(hi - lo, count);
        let cell_range = |s: &ViewSphere| {
            let c = project(s.center);
            let a = ((c - s.radius - lo) * inv_cell).floor();
            let b = ((c + s.radius - lo) * inv_cell).floor();
            let clampx = |v: f64| v.max(0.0).min(dims.0 as f64 - 1.0) as usize;
            let clampy = |v: f64| v.max(0.0).min(dims.1 as f64 - 1.0) as usize;
            (clampx(a.x), clampx(b.x), clampy(a.y), clampy(b.y))
        };
        let bins = Bins::build(dims, spheres.len(), |k| {
            (spheres[k].radius <= big).then(|| cell_range(&spheres[k]))
        });
        ShadowGrid {
            to_light,
            axes,
            origin: lo,
            inv_cell,
            dims,
            bins,
            always,
        }
    }

    /// Whether the ray from `point` (on sphere `own`) towards the light meets another sphere.
    pub fn occluded(&self, spheres: &[ViewSphere], point: DVec3, own: usize) -> bool {
        let blocks = |k: &u32| {
            let k = *k as usize;
            k != own && blocks_ray(&spheres[k], point, self.to_light)
        };
        if self.always.iter().any(blocks) {
            return true;
        }
        if self.dims.0 == 0 {
            return false;
        }
        let q = (DVec2::new(point.dot(self.axes.0), point.dot(self.axes.1)) - self.origin)
            * self.inv_cell;
        // Outside the grid no binned disc holds the point (the far edges belong to the last cells).
        if !(q.x >= 0.0 && q.y >= 0.0 && q.x <= self.dims.0 as f64 && q.y <= self.dims.1 as f64) {
            return false;
        }
        // Truncation is floor for these non-negative values, without a libm call.
        let (x, y) = (
            (q.x as usize).min(self.dims.0 - 1),
            (q.y as usize).min(self.dims.1 - 1),
        );
        self.bins.cell(x, y).iter().any(blocks)
    }
}

/// Spheres larger than this (16 × the median radius, like a ground sphere) are tested for every
/// ray instead of being binned, so they do not inflate the grid.
fn big_radius(spheres: &[ViewSphere]) -> f64 {
    let mut radii: Vec<f64> = spheres.iter().map(|s| s.radius).collect();
    if radii.is_empty() {
        return f64::INFINITY;
    }
    let mid = radii.len() / 2;
    *radii.select_nth_unstable_by(mid, f64::total_cmp).1 * 16.0
}

/// Cells over an `extent` holding `count` discs: about two cells per disc, at most 1024 a side.
/// Returns the cell counts and 1 / cell size.
fn grid_size(extent: DVec2, count: usize) -> ((usize, usize), f64) {
    let extent = extent.max(DVec2::splat(1e-300));
    let cell = (extent.x * extent.y / (2.0 * count as f64))
        .sqrt()
        .max(extent.x.max(extent.y) / 1024.0);
    let dims = (
        ((extent.x / cell).ceil() as usize).clamp(1, 1024),
        ((extent.y / cell).ceil() as usize).clamp(1, 1024),
    );
    (dims, 1.0 / cell)
}

/// Whether sphere `s` blocks the ray from `point` along unit `dir` (t > 0). A point inside (or
/// on) the sphere is blocked; outside, both roots share a sign, positive exactly when the sphere
/// lies ahead. No epsilon is needed: the caller skips the sphere the point lies on, which, being
/// convex, never shadows its own lit side.
#[inline]
pub fn blocks_ray(s: &ViewSphere, point: DVec3, dir: DVec3) -> bool {
    let f = point - s.center;
    let c = f.length_squared() - s.radius2;
    if c <= 0.0 {
        return true;
    }
    let b = f.dot(dir);
    b < 0.0 && (f - dir * b).length_squared() <= s.radius2
}
