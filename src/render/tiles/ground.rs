//! Spheres without screen bounds that the COP is outside of (a ground seen from above it):
//! the tiles whose rays can meet one, and the nearest hit they can have there.

use glam::DVec3;

use super::super::rays::RayTable;
use super::super::view::Reach;
use crate::raster::Raster;

/// A sphere without screen bounds whose outside the COP is in (a ground, seen from above it),
/// placed tile by tile. A tile's rays (every sample of its pixels, from the ray table) lie
/// between four planes through the COP, one per edge: the sphere is met by none of them when it
/// lies wholly outside one plane, and no nearer than where the part of it inside a plane begins.
/// Those bounds depend on a tile's column or row alone.
pub(super) struct Wide {
    pub(super) index: u32,
    /// Centre − COP, its length, and the radius.
    p: DVec3,
    dist: f64,
    radius: f64,
    /// |p| − r: no ray meets the sphere nearer.
    min_dist: f64,
    /// Per tile column, then per tile row: the nearest the tiles' rays can meet the sphere, or
    /// None when they cannot.
    columns: Vec<Option<f64>>,
    rows: Vec<Option<f64>>,
    /// The tiles' side in pixels.
    side: usize,
}

impl Wide {
    /// The sphere `index`, reaching as `s` does, in tiles of `side` pixels.
    pub(super) fn new(
        index: u32,
        s: &Reach,
        table: &RayTable,
        raster: Raster,
        side: usize,
    ) -> Option<Wide> {
        let p = -s.f;
        let (d, r, dz) = (p.length(), s.radius, table.dz);
        if !(d > r && d.is_finite() && dz > 0.0) {
            return None;
        }
        // Rounding allowance: far above the error of a computed hit or plane distance.
        let slack = 1e-9 * (d + r);
        // The part of the sphere inside the plane with unit outward normal n (a half-space
        // through the COP): None when the centre is further out than r; otherwise its nearest
        // point, no nearer than √(d² − h²) − √(r² − h²) for the centre h outside (d − r when
        // inside), which grows with h.
        let inside = |n: DVec3| -> Option<f64> {
            let h = n.normalize().dot(p);
            if h > r + slack {
                return None;
            }
            let h = (h - slack).clamp(0.0, r);
            Some(((d - h) * (d + h)).sqrt() - ((r - h) * (r + h)).sqrt() - slack)
        };
        let edges =
            |n: u32| (0..(n as usize).div_ceil(side)).map(move |t| samples(t, n, raster, side));
        // A column's rays have x/z between its first and last samples' (xs grow); a row's
        // have y/z between its last and first samples' (ys shrink).
        let both = |a: Option<f64>, b: Option<f64>| Some(a?.max(b?));
        let columns = edges(raster.width)
            .map(|(i0, i1)| {
                let (x0, x1) = (table.xs[i0], table.xs[i1]);
                both(
                    inside(DVec3::new(-dz, 0.0, x0)),
                    inside(DVec3::new(dz, 0.0, -x1)),
                )
            })
            .collect();
        let rows = edges(raster.height)
            .map(|(j0, j1)| {
                let (y0, y1) = (table.ys[j0], table.ys[j1]);
                both(
                    inside(DVec3::new(0.0, dz, -y0)),
                    inside(DVec3::new(0.0, -dz, y1)),
                )
            })
            .collect();
        Some(Wide {
            index,
            p,
            dist: d,
            radius: r,
            min_dist: s.min_dist,
            columns,
            rows,
            side,
        })
    }

    /// A lower bound on where a ray of tile (tx, ty) meets the sphere, or None when none can:
    /// from the tile's column and row, then from its cone (made once a tile, in `cone`, for
    /// the spheres that its column and row do not rule out).
    pub(super) fn nearest(
        &self,
        tx: usize,
        ty: usize,
        cone: &mut Option<Option<TileCone>>,
        table: &RayTable,
        raster: Raster,
    ) -> Option<f64> {
        let near = self.columns[tx]?.max(self.rows[ty]?).max(self.min_dist);
        match cone.get_or_insert_with(|| TileCone::new(table, raster, self.side, tx, ty)) {
            Some(cone) => Some(near.max(self.in_cone(cone)?)),
            None => Some(near),
        }
    }

    /// A lower bound on where a ray of `cone` meets the sphere, or None when none can: rays
    /// meet it within the angle α (sin α = r/d) of its centre, and the nearer the further
    /// they are from it. Each allowance is far above rounding, on the side of keeping it.
    fn in_cone(&self, cone: &TileCone) -> Option<f64> {
        let (d, r) = (self.dist, self.radius);
        // The smallest angle φ between a ray of the cone and the centre: the angle γ to the
        // axis less the half-angle β, as cos(γ − β), or 0 inside the cone.
        let cos_g = (cone.axis.dot(self.p) / d).clamp(-1.0, 1.0);
        let cos_b = cone.cos_half;
        let cos_phi = if cos_g >= cos_b {
            1.0
        } else {
            let sin = |c: f64| (1.0 - c * c).max(0.0).sqrt();
            (cos_g * cos_b + sin(cos_g) * sin(cos_b) + 1e-12).min(1.0)
        };
        // Along a ray at angle φ, p·u = d·cos φ, and the sphere is met at
        // t = p·u − √(r² − d² + (p·u)²), which shrinks as p·u grows. Near tangency a computed
        // hit is only good to about √(10⁻¹⁶·d²) = 10⁻⁸·d (the rounding of the square root's
        // argument), so the bound keeps √(10⁻¹² d²) = 10⁻⁶·d below the exact one there.
        let pu = d * cos_phi;
        let disc = (r - d) * (r + d) + pu * pu;
        if pu <= 0.0 || disc < -1e-12 * d * d {
            return None;
        }
        Some(pu - (disc + 1e-12 * d * d).max(0.0).sqrt() - 1e-9 * (d + r))
    }
}

/// The first and last of the ray table's sample positions (in `xs` or `ys`) in tile column or
/// row `t`, of `side` pixels, of an image side of `n` pixels.
fn samples(t: usize, n: u32, raster: Raster, side: usize) -> (usize, usize) {
    let s = raster.samples as usize;
    (t * side * s, ((t + 1) * side).min(n as usize) * s - 1)
}

/// The directions of a tile's rays (every sample of its pixels, from the ray table), within a
/// cone: a unit axis and the cosine of the half-angle, widened past rounding.
#[derive(Clone, Copy)]
pub(super) struct TileCone {
    axis: DVec3,
    cos_half: f64,
}

impl TileCone {
    /// Tile (tx, ty)'s cone, in tiles of `side` pixels, or None when it is 90° wide or more
    /// (no bound then).
    fn new(
        table: &RayTable,
        raster: Raster,
        side: usize,
        tx: usize,
        ty: usize,
    ) -> Option<TileCone> {
        // Sample positions grow along xs and shrink along ys, so the tile's are between its
        // first and last.
        let (i0, i1) = samples(tx, raster.width, raster, side);
        let (j0, j1) = samples(ty, raster.height, raster, side);
        let ([x0, x1], [y0, y1]) = ([table.xs[i0], table.xs[i1]], [table.ys[j0], table.ys[j1]]);
        // Written out: `array::map` is not always inlined into the tiles' code (`.ci/run`).
        let corner = |x: f64, y: f64| DVec3::new(x, y, table.dz).normalize();
        let corners = [
            corner(x0, y0),
            corner(x1, y0),
            corner(x0, y1),
            corner(x1, y1),
        ];
        let axis = (corners[0] + corners[1] + corners[2] + corners[3]).normalize();
        // Directions through the tile's rectangle of the view plane make a convex set, so every
        // one is within the largest angle to a corner.
        let cos_half = corners.iter().map(|c| axis.dot(*c)).fold(1.0, f64::min) - 1e-12;
        (cos_half > 0.0 && axis.is_finite()).then_some(TileCone { axis, cos_half })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::oracle::root;
    use crate::render::tiles::{DENSE_TILE, TILE};
    use crate::render::view::ViewSphere;
    use glam::DVec2;

    /// Near tangency a computed hit is only good to about 10⁻⁸ of the distance, and the bound
    /// stays below it: a huge sphere (radius 10³ to 10⁷, the COP 10⁻⁶ to 10⁻¹⁵ of it above its
    /// surface) that the ray of each tile's corner furthest from its cone's axis touches,
    /// turned a rounding step at a time through tangency. Where the ray meets it, the tile
    /// keeps it, no nearer than the hit.
    #[test]
    fn a_tangent_ray_is_never_nearer_than_its_tiles_bound() {
        let cop = DVec3::new(0.0, 0.0, -1.0);
        let mut hits = 0;
        let cases = [(32, 32, 2.0), (40, 24, 1.6)];
        for ((w, h, across), tile) in cases.into_iter().flat_map(|c| [(c, TILE), (c, DENSE_TILE)]) {
            let window = DVec2::new(across, across * h as f64 / w as f64);
            let raster = Raster {
                width: w,
                height: h,
                samples: 1,
                adaptive: false,
            };
            let table = RayTable::new(cop, window, raster);
            for tx in 0..(w as usize).div_ceil(tile) {
                for ty in 0..(h as usize).div_ceil(tile) {
                    let cone = TileCone::new(&table, raster, tile, tx, ty).unwrap();
                    let (i0, i1) = (tx * tile, ((tx + 1) * tile).min(w as usize) - 1);
                    let (j0, j1) = (ty * tile, ((ty + 1) * tile).min(h as usize) - 1);
                    let mut dir = |(i, j): (usize, usize)| table.direction(i, j, 0);
                    let u = [(i0, j0), (i1, j0), (i0, j1), (i1, j1)]
                        .map(&mut dir)
                        .into_iter()
                        .min_by(|a, b| a.dot(cone.axis).total_cmp(&b.dot(cone.axis)))
                        .unwrap();
                    // In the plane of the axis and u, at right angles to u, away from the axis.
                    let away = (u * u.dot(cone.axis) - cone.axis).normalize();
                    for r in [1e3_f64, 1e5, 1e7] {
                        for above in [1e-6, 1e-9, 1e-12, 1e-15] {
                            let d = r * (1.0 + above);
                            let cos_a = (1.0 - (r / d) * (r / d)).max(0.0).sqrt();
                            for step in -50..=50 {
                                let ca = (cos_a + step as f64 * 2.5e-17 / cos_a).clamp(0.0, 1.0);
                                let center = cop + (u * ca + away * (1.0 - ca * ca).sqrt()) * d;
                                let sphere = ViewSphere::in_view(center, r, cop, 0);
                                let f = sphere.f;
                                let Some(t) = root(f, sphere.c(), r * r, u) else {
                                    continue;
                                };
                                hits += 1;
                                let reach = sphere.reach();
                                let wide = Wide::new(0, &reach, &table, raster, tile).unwrap();
                                let near = wide.nearest(tx, ty, &mut None, &table, raster);
                                let near =
                                    near.expect("a tile whose ray meets the sphere keeps it");
                                assert!(near <= t, "r {r}, {above} above: bound {near} > hit {t}");
                            }
                        }
                    }
                }
            }
        }
        assert!(hits > 1000, "{hits} hits");
    }
}
