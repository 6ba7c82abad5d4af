//! Shadow rays towards a directional light, binned in the light's own projection.
//!
//! Every shadow ray runs parallel to the light, so projected along it each ray is a single
//! point, and only spheres whose projected disc holds that point can block it. Discs are binned
//! into a uniform grid over the plane orthogonal to the light; a query looks at one cell. Spheres
//! much larger than the typical one (a ground sphere) are kept in a list tested for every ray,
//! so they do not inflate the grid.

use glam::{DVec2, DVec3};

use super::bins::Bins;
use super::packet::{Lanes, Mask, LANES};
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
        match self.cell_of(point) {
            Some((x, y)) => self.bins.cell(x, y).iter().any(blocks),
            None => false,
        }
    }

    /// The grid cell holding `point`'s projection, None outside the grid.
    #[inline(always)]
    fn cell_of(&self, point: DVec3) -> Option<(usize, usize)> {
        let q = (DVec2::new(point.dot(self.axes.0), point.dot(self.axes.1)) - self.origin)
            * self.inv_cell;
        // Outside the grid no binned disc holds the point (the far edges belong to the last cells).
        if !(q.x >= 0.0 && q.y >= 0.0 && q.x <= self.dims.0 as f64 && q.y <= self.dims.1 as f64) {
            return None;
        }
        // Truncation is floor for these non-negative values, without a libm call.
        Some((
            (q.x as usize).min(self.dims.0 - 1),
            (q.y as usize).min(self.dims.1 - 1),
        ))
    }
}

impl ShadowGrid {
    /// `occluded` for a packet of points (x, y and z lanes) on spheres `own`, for the lanes set
    /// in `need`: which of them the light does not reach. Each lane's tests are
    /// [`blocks_ray`]'s; whether any sphere blocks a ray does not depend on the order of the
    /// tests, so lanes sharing a grid cell test its spheres together.
    #[inline(always)]
    pub fn occluded_packet(
        &self,
        spheres: &[ViewSphere],
        point: &[Lanes; 3],
        own: &[u32; LANES],
        need: Mask,
    ) -> Mask {
        let mut blocked = [false; LANES];
        let dir = self.to_light;
        // Tests sphere k against the lanes in `lanes`; false once all of them are blocked.
        let test = |k: u32, lanes: &Mask, blocked: &mut Mask| {
            let s = &spheres[k as usize];
            for l in 0..LANES {
                let f = [
                    point[0][l] - s.center.x,
                    point[1][l] - s.center.y,
                    point[2][l] - s.center.z,
                ];
                let c = (f[0] * f[0] + f[1] * f[1]) + f[2] * f[2] - s.radius2;
                let b = (f[0] * dir.x + f[1] * dir.y) + f[2] * dir.z;
                let g = [f[0] - dir.x * b, f[1] - dir.y * b, f[2] - dir.z * b];
                let g2 = (g[0] * g[0] + g[1] * g[1]) + g[2] * g[2];
                let hit = (c <= 0.0) | ((b < 0.0) & (g2 <= s.radius2));
                blocked[l] |= lanes[l] & (own[l] != k) & hit;
            }
            (0..LANES).any(|l| lanes[l] & !blocked[l])
        };
        for &k in &self.always {
            if !test(k, &need, &mut blocked) {
                return blocked;
            }
        }
        if self.dims.0 == 0 {
            return blocked;
        }
        // Each pending lane's cell, as in `occluded`.
        let mut cell = [usize::MAX; LANES];
        for l in 0..LANES {
            if need[l] && !blocked[l] {
                let p = DVec3::new(point[0][l], point[1][l], point[2][l]);
                if let Some((x, y)) = self.cell_of(p) {
                    cell[l] = y * self.dims.0 + x;
                }
            }
        }
        for l in 0..LANES {
            let here = cell[l];
            if here == usize::MAX {
                continue;
            }
            let mut lanes = [false; LANES];
            for m in l..LANES {
                lanes[m] = cell[m] == here;
                if lanes[m] {
                    cell[m] = usize::MAX;
                }
            }
            for &k in self.bins.cell(here % self.dims.0, here / self.dims.0) {
                if !test(k, &lanes, &mut blocked) {
                    break;
                }
            }
        }
        blocked
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
