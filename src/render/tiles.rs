//! Screen tiles: each tile lists the spheres whose projection can cover it, nearest first, so a
//! primary ray tests only those and stops once no remaining sphere can be nearer than its hit.
//! Spheres wholly behind the COP are culled. A sphere the COP's plane cuts projects without
//! bound: when the COP is inside it, it goes into every tile; when outside (a ground seen from
//! above it), into the tiles whose rays can meet it, at the nearest hit they can have there.

use glam::{DVec2, DVec3};
use rayon::prelude::*;

use super::bins::Bins;
use super::lanes::{ForLanes, Lanes, LANES};
use super::rays::RayTable;
use super::simd::Isa;
use super::sort::{index_bits, sort_by_high_bits, PARALLEL};
use super::view::{Ranks, Reach, ViewColumns};
use crate::raster::Raster;

/// Tile side in pixels.
pub const TILE: usize = 16;

/// Pixel rectangle (inclusive) a sphere's projection may cover.
#[cfg(test)]
#[derive(Debug, Clone, Copy, PartialEq)]
enum Footprint {
    Culled,
    Everywhere,
    Pixels {
        i0: usize,
        i1: usize,
        j0: usize,
        j1: usize,
    },
}

/// Slopes a = x/z of the two lines through the origin tangent to the circle (x, z, r), for
/// z > r: the roots of a²(z² − r²) − 2a·x·z + x² − r² = 0.
#[cfg(test)]
fn tangent_slopes(x: f64, z: f64, r: f64) -> (f64, f64) {
    let root = r * (x * x + z * z - r * r).sqrt();
    let den = z * z - r * r;
    ((x * z - root) / den, (x * z + root) / den)
}

/// The exact bounds of a sphere's projection through the COP onto the view plane, widened by a
/// pixel so that rounding never drops a covered sample: one sphere at a time, the oracle of
/// [`Footprints`], which does the same operations eight spheres at a time.
#[cfg(test)]
fn footprint(s: &Reach, cop: DVec3, window: DVec2, raster: Raster) -> Footprint {
    let p = -s.f; // centre relative to the COP
    if p.z <= -s.radius {
        return Footprint::Culled;
    }
    if p.z <= s.radius {
        return Footprint::Everywhere;
    }
    let d = -cop.z;
    let (ax0, ax1) = tangent_slopes(p.x, p.z, s.radius);
    let (ay0, ay1) = tangent_slopes(p.y, p.z, s.radius);
    let (w, h) = (raster.width as f64, raster.height as f64);
    // Window x → pixel column, window y → pixel row (rows grow downwards).
    let col = |a: f64| (cop.x + d * a + window.x * 0.5) / window.x * w;
    let row = |a: f64| (window.y * 0.5 - (cop.y + d * a)) / window.y * h;
    let (x0, x1) = (col(ax0) - 1.0, col(ax1) + 1.0);
    let (y0, y1) = (row(ay1) - 1.0, row(ay0) + 1.0);
    if !(x1 >= 0.0 && y1 >= 0.0 && x0 < w && y0 < h) {
        // Off screen (also catches NaN from a degenerate window).
        return if x0.is_nan() || y0.is_nan() {
            Footprint::Everywhere
        } else {
            Footprint::Culled
        };
    }
    // Clamped to [0, n − 1] first, then truncated: the floor of the value (the same as
    // flooring first, without a call to floor for each of the four).
    let clamp = |v: f64, n: f64| v.max(0.0).min(n - 1.0) as usize;
    Footprint::Pixels {
        i0: clamp(x0, w),
        i1: clamp(x1, w),
        j0: clamp(y0, h),
        j1: clamp(y1, h),
    }
}

/// The spheres' pixel rectangles, eight at a time: for sphere k, the inclusive rectangle
/// `[i0, i1, j0, j1]` its projection may cover, `[1, 0, 1, 0]` when it is culled (wholly behind
/// the COP, or off screen), every pixel when it has no bounds (the COP's plane cuts it, or the
/// window is degenerate). Each lane does the operations of the one-sphere form in the tests,
/// in its order, so every instruction path gives its bits. No closures: each step is inlined
/// into the instruction set's function.
struct Footprints<'a> {
    spheres: &'a ViewColumns,
    /// The index of the first sphere of `rects`.
    first: usize,
    rects: &'a mut [[u16; 4]],
    /// The spheres without bounds, in order.
    unbounded: &'a mut Vec<u32>,
    cop: DVec3,
    window: DVec2,
    raster: Raster,
}

/// Lanes `at..at + LANES` of `column`, the last of `n` repeated past it.
#[inline(always)]
fn lanes_at<V: Lanes>(tok: V::Token, column: &[f64], at: usize, n: usize) -> V {
    let mut x = [0.0; LANES];
    for (l, x) in x.iter_mut().enumerate() {
        *x = column[at + l.min(n - 1)];
    }
    V::load(tok, &x)
}

/// The slopes a = x/z of the two lines through the origin tangent to the circles (x, z, r),
/// lane by lane, for z > r: the roots of a²(z² − r²) − 2a·x·z + x² − r² = 0.
#[inline(always)]
fn tangent_slopes_lanes<V: Lanes>(x: V, z: V, r: V) -> (V, V) {
    let root = r.mul(x.mul(x).add(z.mul(z)).sub(r.mul(r)).sqrt());
    let den = z.mul(z).sub(r.mul(r));
    (x.mul(z).sub(root).div(den), x.mul(z).add(root).div(den))
}

/// `(v.max(0.0).min(n − 1.0)) as u16` per lane: the floor of v clamped to a side of n pixels.
#[inline(always)]
fn clamp_lanes<V: Lanes>(tok: V::Token, v: V, n: u32) -> [i32; LANES] {
    v.max(V::splat(tok, 0.0))
        .min(V::splat(tok, n as f64 - 1.0))
        .to_i32(n as i32 - 1)
}

impl ForLanes for Footprints<'_> {
    type Output = ();

    #[inline(always)]
    fn run<V: Lanes>(self, tok: V::Token) {
        let Footprints {
            spheres,
            first,
            rects,
            unbounded,
            cop,
            window,
            raster,
        } = self;
        let (w, h) = (raster.width as f64, raster.height as f64);
        let all = [0, (raster.width - 1) as u16, 0, (raster.height - 1) as u16];
        let (zero, one) = (V::splat(tok, 0.0), V::splat(tok, 1.0));
        let (d, cop_x, cop_y) = (
            V::splat(tok, -cop.z),
            V::splat(tok, cop.x),
            V::splat(tok, cop.y),
        );
        let (half_x, wide) = (V::splat(tok, window.x * 0.5), V::splat(tok, window.x));
        let (half_y, high) = (V::splat(tok, window.y * 0.5), V::splat(tok, window.y));
        let (ws, hs) = (V::splat(tok, w), V::splat(tok, h));
        let view_cop = spheres.cop.to_array().map(|x| V::splat(tok, x));
        for (c, out) in rects.chunks_mut(LANES).enumerate() {
            let (at, n) = (first + c * LANES, out.len());
            // The centre relative to the COP: −f, f = COP − centre.
            let centre = |a: usize| lanes_at::<V>(tok, &spheres.center[a], at, n);
            let px = view_cop[0].sub(centre(0)).neg();
            let py = view_cop[1].sub(centre(1)).neg();
            let pz = view_cop[2].sub(centre(2)).neg();
            let r = lanes_at::<V>(tok, &spheres.radius, at, n);
            let culled = pz.le(r.neg());
            let cut = !culled & pz.le(r);
            let (ax0, ax1) = tangent_slopes_lanes(px, pz, r);
            let (ay0, ay1) = tangent_slopes_lanes(py, pz, r);
            // Window x → pixel column, window y → pixel row (rows grow downwards).
            let x0 = cop_x.add(d.mul(ax0)).add(half_x).div(wide).mul(ws).sub(one);
            let x1 = cop_x.add(d.mul(ax1)).add(half_x).div(wide).mul(ws).add(one);
            let y0 = half_y.sub(cop_y.add(d.mul(ay1))).div(high).mul(hs).sub(one);
            let y1 = half_y.sub(cop_y.add(d.mul(ay0))).div(high).mul(hs).add(one);
            let on_screen = x1.ge(zero) & y1.ge(zero) & x0.lt(ws) & y0.lt(hs);
            // Off screen, or NaN from a degenerate window (which has no bounds).
            let nan = !x0.eq(x0) | !y0.eq(y0);
            let unbound = cut | (!culled & !cut & !on_screen & nan);
            let bounded = !culled & !cut & on_screen;
            // Clamped first, then truncated: the floor of the value.
            let (i0, i1) = (
                clamp_lanes(tok, x0, raster.width),
                clamp_lanes(tok, x1, raster.width),
            );
            let (j0, j1) = (
                clamp_lanes(tok, y0, raster.height),
                clamp_lanes(tok, y1, raster.height),
            );
            for (l, rect) in out.iter_mut().enumerate() {
                *rect = if bounded >> l & 1 == 1 {
                    // Each in 0 ..= its side − 1, so each fits.
                    [i0[l] as u16, i1[l] as u16, j0[l] as u16, j1[l] as u16]
                } else if unbound >> l & 1 == 1 {
                    unbounded.push((at + l) as u32);
                    all
                } else {
                    [1, 0, 1, 0]
                };
            }
        }
    }
}

/// A sphere without screen bounds whose outside the COP is in (a ground, seen from above it),
/// placed tile by tile. A tile's rays (every sample of its pixels, from the ray table) lie
/// between four planes through the COP, one per edge: the sphere is met by none of them when it
/// lies wholly outside one plane, and no nearer than where the part of it inside a plane begins.
/// Those bounds depend on a tile's column or row alone.
struct Wide {
    index: u32,
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
}

impl Wide {
    fn new(index: u32, s: &Reach, table: &RayTable, raster: Raster) -> Option<Wide> {
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
        let edges = |n: u32| (0..(n as usize).div_ceil(TILE)).map(move |t| samples(t, n, raster));
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
        })
    }

    /// A lower bound on where a ray of tile (tx, ty) meets the sphere, or None when none can:
    /// from the tile's column and row, then from its cone (made once a tile, in `cone`, for
    /// the spheres that its column and row do not rule out).
    fn nearest(
        &self,
        tx: usize,
        ty: usize,
        cone: &mut Option<Option<TileCone>>,
        table: &RayTable,
        raster: Raster,
    ) -> Option<f64> {
        let near = self.columns[tx]?.max(self.rows[ty]?).max(self.min_dist);
        match cone.get_or_insert_with(|| TileCone::new(table, raster, tx, ty)) {
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

/// `x` as a u64 in the order of `f64::total_cmp`: the sign bit flipped for positive values, every
/// bit for negative ones.
fn total_key(x: f64) -> u64 {
    let b = x.to_bits();
    if b >> 63 == 1 {
        !b
    } else {
        b | 1 << 63
    }
}

/// The spheres in view (indices of the columns) in the order every tile searches them: nearest
/// possible hit first (`min_dist`, ordered as `total_cmp` orders the f64), ties by the spheres'
/// scene indices (from their ranks, the columns' `id`, by `ranks`), so the order is total,
/// deterministic and the same whatever order the columns, or the index, hold the spheres in.
/// One radix sort of 8 bytes a sphere ([`sort_by_high_bits`]): the key's high bits above the
/// column index's; then each run of equal high bits (rare: at a million spheres their
/// distances agree to 32 bits of the fraction) by the whole key and the scene index.
fn search_order(spheres: &ViewColumns, ranks: Ranks) -> Vec<u32> {
    let n = spheres.len();
    let key = |k: u32| total_key(spheres.min_dist[k as usize]);
    let low = index_bits(n);
    let pack = |k: u32| key(k) >> low << low | u64::from(k);
    // On the pool from PARALLEL spheres (one task below).
    let keyed: Vec<u64> = (0..n as u32)
        .into_par_iter()
        .with_min_len(PARALLEL)
        .map(pack)
        .collect();
    let keyed = sort_by_high_bits(keyed, low);
    let index = |&x: &u64| (x & ((1u64 << low) - 1)) as u32;
    let mut order: Vec<u32> = keyed.par_iter().with_min_len(PARALLEL).map(index).collect();
    let mut at = 0;
    for run in keyed.chunk_by(|a, b| a >> low == b >> low) {
        if run.len() > 1 {
            let run = &mut order[at..at + run.len()];
            run.sort_unstable_by_key(|&k| {
                (key(k), ranks.scene_index(spheres.id[k as usize] as u32))
            });
        }
        at += run.len();
    }
    order
}

/// The first and last of the ray table's sample positions (in `xs` or `ys`) in tile column or
/// row `t` of an image side of `n` pixels.
fn samples(t: usize, n: u32, raster: Raster) -> (usize, usize) {
    let s = raster.samples as usize;
    (t * TILE * s, ((t + 1) * TILE).min(n as usize) * s - 1)
}

/// The directions of a tile's rays (every sample of its pixels, from the ray table), within a
/// cone: a unit axis and the cosine of the half-angle, widened past rounding.
#[derive(Clone, Copy)]
struct TileCone {
    axis: DVec3,
    cos_half: f64,
}

impl TileCone {
    /// Tile (tx, ty)'s cone, or None when it is 90° wide or more (no bound then).
    fn new(table: &RayTable, raster: Raster, tx: usize, ty: usize) -> Option<TileCone> {
        // Sample positions grow along xs and shrink along ys, so the tile's are between its
        // first and last.
        let (i0, i1) = samples(tx, raster.width, raster);
        let (j0, j1) = samples(ty, raster.height, raster);
        let xs = [table.xs[i0], table.xs[i1]];
        let ys = [table.ys[j0], table.ys[j1]];
        let corners = [
            DVec3::new(xs[0], ys[0], table.dz).normalize(),
            DVec3::new(xs[1], ys[0], table.dz).normalize(),
            DVec3::new(xs[0], ys[1], table.dz).normalize(),
            DVec3::new(xs[1], ys[1], table.dz).normalize(),
        ];
        let axis = (corners[0] + corners[1] + corners[2] + corners[3]).normalize();
        // Directions through the tile's rectangle of the view plane make a convex set, so every
        // one is within the largest angle to a corner.
        let cos_half = corners.iter().map(|c| axis.dot(*c)).fold(1.0, f64::min) - 1e-12;
        (cos_half > 0.0 && axis.is_finite()).then_some(TileCone { axis, cos_half })
    }
}

/// Per-tile sphere lists, nearest possible hit first, and each sphere's pixel rectangle.
pub struct TileBins {
    bins: Bins,
    /// Per sphere, the inclusive pixel rectangle (i0, i1, j0, j1) its projection may cover
    /// (a side is at most `MAX_SIDE`, 16,384 pixels: 8 bytes a sphere).
    rects: Vec<[u16; 4]>,
}

impl TileBins {
    /// The tiles' lists of `spheres`, whose ranks `ranks` takes back to scene indices for the
    /// ties.
    pub fn build(
        isa: Isa,
        spheres: &ViewColumns,
        ranks: Ranks,
        table: &RayTable,
        raster: Raster,
    ) -> TileBins {
        let (cop, window) = (table.cop_view, table.window);
        let tiles_x = (raster.width as usize).div_ceil(TILE);
        let tiles_y = (raster.height as usize).div_ceil(TILE);
        assert!(
            raster.width.max(raster.height) <= 1 << 16,
            "a raster side of at most 65,536 pixels"
        );
        // The order every tile searches its spheres in, first (its sort's buffers are freed
        // before the rectangles are written); then each sphere's pixel rectangle, eight at a
        // time, and the spheres without bounds.
        let n = spheres.len();
        let order = search_order(spheres, ranks);
        let mut rects = vec![[0u16; 4]; n];
        let prints = |first: usize, rects: &mut [[u16; 4]]| {
            let mut unbounded = Vec::new();
            isa.run(Footprints {
                spheres,
                first,
                rects,
                unbounded: &mut unbounded,
                cop,
                window,
                raster,
            });
            unbounded
        };
        let unbounded: Vec<u32> = if n >= PARALLEL {
            let parts: Vec<Vec<u32>> = rects
                .par_chunks_mut(PARALLEL)
                .enumerate()
                .map(|(c, rects)| prints(c * PARALLEL, rects))
                .collect();
            parts.concat()
        } else {
            prints(0, &mut rects)
        };
        // Spheres without bounds that the COP is outside of (a ground, seen from above it) are
        // placed tile by tile, once the others are binned: left out where no ray of the tile
        // meets them, and ordered by the nearest hit a ray of the tile can have.
        let wide: Vec<Wide> = unbounded
            .into_iter()
            .filter_map(|k| Wide::new(k, &spheres.reach(k as usize), table, raster))
            .collect();
        let dims = (tiles_x, tiles_y);
        let cells = |rect: [u16; 4]| {
            let [i0, i1, j0, j1] = rect.map(|v| v as usize);
            (i0 <= i1).then_some((i0 / TILE, i1 / TILE, j0 / TILE, j1 / TILE))
        };
        // Binned in the search order, every tile lists its spheres in it: no tile sorts.
        let mut bins = if n >= PARALLEL {
            // The rectangles in that order first, so that the two passes of the binning read
            // them in sequence; a task per quarter of the spheres or per PARALLEL, whichever
            // is more.
            let sorted: Vec<[u16; 4]> = order.par_iter().map(|&k| rects[k as usize]).collect();
            let chunk = n.div_ceil(4).max(PARALLEL);
            Bins::build(dims, &order, chunk, |i| cells(sorted[i]))
        } else {
            Bins::build(dims, &order, n, |i| cells(rects[order[i] as usize]))
        };
        drop(order);
        let id = |k: u32| ranks.scene_index(spheres.id[k as usize] as u32);
        let before = |a: (f64, u32), b: (f64, u32)| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1));
        if !wide.is_empty() {
            // They were binned into every tile; each tile's list is merged anew from its other
            // spheres and the wide ones that its rays can meet, by their bounds there.
            let is_wide = |k: u32| wide.iter().any(|w| w.index == k);
            let scratch = || Vec::<(f64, u32, u32)>::with_capacity(wide.len());
            bins.edit_cells(scratch, |keyed, (tx, ty), items| {
                keyed.clear();
                let mut cone = None;
                keyed.extend(wide.iter().filter_map(|w| {
                    let bound = w.nearest(tx, ty, &mut cone, table, raster)?;
                    Some((bound, id(w.index), w.index))
                }));
                keyed.sort_unstable_by(|&a, &b| before((a.0, a.1), (b.0, b.1)));
                // The others, in their order, to the front; then each wide sphere the tile
                // keeps into its place among them (the slots the wide ones held make room).
                let mut n = 0;
                for i in 0..items.len() {
                    if !is_wide(items[i]) {
                        items[n] = items[i];
                        n += 1;
                    }
                }
                // A wide sphere already put back counts at its min_dist here, below its bound
                // for the tile but not below an earlier one in `keyed`, so the order searched
                // stays sorted.
                for &(bound, w_id, w) in &*keyed {
                    let at = items[..n].partition_point(|&k| {
                        // The scene index read only when the distances tie (a random read
                        // saved at each step of every tile's search).
                        let d = spheres.min_dist[k as usize].total_cmp(&bound);
                        d.then_with(|| id(k).cmp(&w_id)).is_lt()
                    });
                    items.copy_within(at..n, at + 1);
                    items[at] = w;
                    n += 1;
                }
                n
            });
        }
        TileBins { bins, rects }
    }

    /// The spheres that can cover pixel (i, j), nearest first.
    #[inline]
    pub fn at(&self, i: usize, j: usize) -> &[u32] {
        self.bins.cell(i / TILE, j / TILE)
    }

    /// Whether sphere k's projection may cover a pixel of rows j0..=j1 in columns i0..=i1.
    #[inline(always)]
    pub fn covers(&self, k: u32, (i0, i1): (usize, usize), (j0, j1): (usize, usize)) -> bool {
        let [x0, x1, y0, y1] = self.rects[k as usize].map(u32::from);
        let (i0, i1, j0, j1) = (i0 as u32, i1 as u32, j0 as u32, j1 as u32);
        i1 >= x0 && i0 <= x1 && j1 >= y0 && j0 <= y1
    }
}

#[cfg(test)]
mod tests {
    use super::super::kernels::Shading;
    use super::super::oracle::{nearest, root};
    use super::super::simd::Simd;
    use super::super::view::ViewSphere;
    use super::*;
    use crate::camera::{Basis, Camera};
    use crate::scene::Sphere;

    /// The search order is the sort by `min_dist` (as `total_cmp` orders it) and then scene
    /// index, on pools of one to three threads, below and above [`PARALLEL`] spheres: distances
    /// equal, a few ulps apart (equal in the radix sort's bits, told apart after it), far
    /// apart, negative, signed zeros, infinite and not a number; scene indices in another
    /// order than the columns'.
    #[test]
    fn search_order_sorts_by_distance_then_scene_index() {
        let mut rng = crate::splitmix::SplitMix(0x0bde);
        let specials = [
            0.0,
            -0.0,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NAN,
            -f64::NAN,
        ];
        for n in [0, 1, 2, 7, 3000, PARALLEL + 4321] {
            let sphere = ViewSphere::in_view(DVec3::new(0.0, 0.0, 5.0), 1.0, DVec3::ZERO, 0);
            let mut columns = ViewColumns::new(DVec3::ZERO, &vec![sphere; n]);
            for k in 0..n {
                let anchor = [1.0, 7.5, -0.25, 1e-300, 3e5, 19.999][(rng.unit() * 6.0) as usize];
                let mut v = anchor * (1.0 + (rng.unit() * 4.0).floor() * 1e-3);
                for _ in 0..(rng.unit() * 3.0) as usize {
                    v = v.next_up();
                }
                if k % 97 == 0 {
                    v = specials[k / 97 % specials.len()];
                }
                columns.min_dist[k] = v;
                columns.id[k] = (k as u64 * 7919) % n as u64;
            }
            // The ids as scene indices, and as ranks of another order of the scene.
            let other: Vec<u32> = (0..n as u64)
                .map(|r| ((r * 7919 + 3) % n as u64) as u32)
                .collect();
            for ranks in [Ranks::SCENE, Ranks(Some(&other))] {
                let scene = |k: usize| ranks.scene_index(columns.id[k] as u32);
                let mut want: Vec<u32> = (0..n as u32).collect();
                want.sort_by(|&a, &b| {
                    let (a, b) = (a as usize, b as usize);
                    let d = columns.min_dist[a].total_cmp(&columns.min_dist[b]);
                    d.then(scene(a).cmp(&scene(b)))
                });
                for threads in 1..=3 {
                    let pool = rayon::ThreadPoolBuilder::new()
                        .num_threads(threads)
                        .build()
                        .unwrap();
                    let got = pool.install(|| search_order(&columns, ranks));
                    assert!(got == want, "{n} spheres, {threads} threads, {ranks:?}");
                }
            }
        }
    }

    /// The footprints eight at a time, on every instruction path this CPU runs, are the
    /// one-sphere oracle's: seeded spheres in view, in front, behind, cut by the COP's plane,
    /// off screen on every side, huge and tiny, not a number, and degenerate windows; chunks
    /// that end inside a packet.
    #[test]
    fn footprints_in_packets_are_the_oracles_on_every_path() {
        use crate::splitmix::SplitMix;
        let mut rng = SplitMix(0xf007);
        let mut v = |scale: f64| (rng.unit() - 0.5) * scale;
        let cop = DVec3::new(0.1, -0.05, -1.5);
        let mut spheres: Vec<ViewSphere> = (0..20_000)
            .map(|k| {
                let r = match k % 4 {
                    0 => 1e-3 + v(0.1).abs(),
                    1 => v(4.0).abs(),
                    2 => 50.0 + v(100.0).abs(),
                    _ => 1e-9,
                };
                // Half of them in view, small.
                let (center, r) = if k % 2 == 0 {
                    let z = 2.0 + v(100.0).abs();
                    (DVec3::new(v(1.2) * z, v(0.7) * z, z), r.min(0.05 * z))
                } else {
                    (DVec3::new(v(40.0), v(30.0), v(60.0)), r)
                };
                ViewSphere::in_view(center, r, cop, k)
            })
            .collect();
        let odd = [
            (DVec3::new(0.0, 0.0, -1.5), 0.5),
            (DVec3::new(0.0, -1e5, 10.0), 1e5 - 1.0),
            (DVec3::new(f64::NAN, 0.0, 5.0), 1.0),
            (DVec3::new(0.0, f64::NAN, 5.0), 1.0),
            (DVec3::new(0.8, 0.45, 0.0), 0.01),
            (DVec3::new(1e300, 0.0, 1.0), 1.0),
        ];
        for (k, (center, r)) in odd.into_iter().enumerate() {
            spheres.push(ViewSphere::in_view(center, r, cop, 20_000 + k as u32));
        }
        let columns = ViewColumns::new(cop, &spheres);
        let raster = Raster {
            width: 97,
            height: 61,
            samples: 1,
            adaptive: false,
        };
        let windows = [
            DVec2::new(1.6, 0.9),
            DVec2::new(0.0, 0.9),
            DVec2::new(1.6, 0.0),
        ];
        for window in windows {
            let expected: Vec<([u16; 4], bool)> = spheres
                .iter()
                .map(|s| match footprint(&s.reach(), cop, window, raster) {
                    Footprint::Culled => ([1, 0, 1, 0], false),
                    Footprint::Everywhere => ([0, 96, 0, 60], true),
                    Footprint::Pixels { i0, i1, j0, j1 } => {
                        ([i0 as u16, i1 as u16, j0 as u16, j1 as u16], false)
                    }
                })
                .collect();
            let unbound = expected.iter().filter(|e| e.1).count();
            let culled = expected.iter().filter(|e| e.0 == [1, 0, 1, 0]).count();
            let bounded = expected.len() - unbound - culled;
            assert!(unbound > 3, "spheres without bounds");
            if window.x * window.y > 0.0 {
                assert!(
                    bounded > 1000 && culled > 1000,
                    "{bounded} bounded, {culled} culled"
                );
            }
            for simd in Simd::ALL.into_iter().filter(|s| s.supported()) {
                for chunk in [spheres.len(), 13, 8] {
                    let mut rects = vec![[7u16; 4]; spheres.len()];
                    let mut unbounded = Vec::new();
                    for (c, part) in rects.chunks_mut(chunk).enumerate() {
                        simd.isa().unwrap().run(Footprints {
                            spheres: &columns,
                            first: c * chunk,
                            rects: part,
                            unbounded: &mut unbounded,
                            cop,
                            window,
                            raster,
                        });
                    }
                    let got: Vec<([u16; 4], bool)> = rects
                        .iter()
                        .enumerate()
                        .map(|(k, &r)| (r, unbounded.contains(&(k as u32))))
                        .collect();
                    assert!(got == expected, "{} in chunks of {chunk}", simd.name());
                    assert!(unbounded.is_sorted());
                }
            }
        }
    }

    /// A tile's list, read as scene indices, does not depend on the order the columns hold the
    /// spheres in: spheres of equal nearest possible hit (copies of one sphere, and a ground)
    /// keep their scene order whichever way the frame lists them, on one thread and on the pool.
    #[test]
    fn tile_lists_follow_the_scene_order_whatever_the_columns_order() {
        let mut gen = crate::splitmix::SplitMix(12);
        let mut spheres: Vec<Sphere> = Vec::new();
        for _ in 0..(PARALLEL / 4 + 50) {
            let mut r = || gen.unit();
            let s = Sphere {
                center_world: DVec3::new(r() * 40.0 - 20.0, r() * 5.0, r() * 40.0),
                radius: 0.2 + r(),
                color: DVec3::ONE,
            };
            // Each sphere four times over: ties in every list it is in.
            spheres.extend([s; 4]);
        }
        spheres.push(Sphere {
            center_world: DVec3::new(0.0, -1e3, 0.0),
            radius: 1e3,
            color: DVec3::ONE,
        });
        let camera = Camera {
            vrp_world: DVec3::new(0.0, 3.0, -25.0),
            basis: Basis::from_vpn_vuv(DVec3::new(0.0, -0.1, 1.0), DVec3::Y).unwrap(),
            cop_view: DVec3::new(0.0, 0.0, -1.0),
            window: DVec2::new(1.6, 0.9),
        };
        let raster = Raster {
            width: 160,
            height: 90,
            samples: 1,
            adaptive: false,
        };
        let table = RayTable::new(camera.cop_view, camera.window, raster);
        let ground = spheres.len() as u32 - 1;
        let ids = |order: &[u32]| {
            let view: Vec<ViewSphere> = order
                .iter()
                .map(|&k| ViewSphere::new(&camera, &spheres[k as usize], k))
                .collect();
            let columns = ViewColumns::new(camera.cop_view, &view);
            let bins = TileBins::build(Isa::Portable, &columns, Ranks::SCENE, &table, raster);
            let mut lists = Vec::new();
            for j in (0..90).step_by(TILE) {
                for i in (0..160).step_by(TILE) {
                    let list: Vec<(f64, u64)> = bins
                        .at(i, j)
                        .iter()
                        .map(|&k| (columns.min_dist[k as usize], columns.id[k as usize]))
                        .collect();
                    // Nearest possible hit first, ties by scene index; the ground aside (its
                    // place is its bound for the tile).
                    let bounded: Vec<_> = list.iter().filter(|s| s.1 != ground as u64).collect();
                    for w in bounded.windows(2) {
                        let order = w[0].0.total_cmp(&w[1].0).then(w[0].1.cmp(&w[1].1));
                        assert!(order.is_lt(), "{w:?} in tile ({i}, {j})");
                    }
                    lists.push(list.into_iter().map(|s| s.1).collect::<Vec<_>>());
                }
            }
            lists
        };
        // Above PARALLEL spheres (the pool's binning) and below; the ground last.
        for n in [spheres.len() as u32, 1001] {
            assert_eq!(n as usize >= PARALLEL, n != 1001);
            let ids = |order: &[u32]| ids(&[order, &[ground]].concat());
            let forward: Vec<u32> = (0..n - 1).collect();
            let backward: Vec<u32> = (0..n - 1).rev().collect();
            let shuffled: Vec<u32> = (0..n - 1).map(|k| (k * 7919) % (n - 1)).collect();
            let expected = ids(&forward);
            assert!(expected.iter().any(|l| l.len() > 8), "lists with ties");
            assert_eq!(ids(&backward), expected);
            assert_eq!(ids(&shuffled), expected);
        }
    }

    /// Every sample's nearest hit through its tile's list is the nearest of every sphere, with
    /// a ground sphere (radius 10³ and 10⁵) placed tile by tile: left out of tiles above its
    /// horizon, and after nearer spheres where its own hits are further. Cameras level, looking
    /// down with a roll, grazing the ground with the COP off the axis, and looking up.
    #[test]
    fn tiles_find_the_nearest_hit_of_every_sample() {
        let mut gen = crate::splitmix::SplitMix(11);
        let mut spheres: Vec<Sphere> = (0..80)
            .map(|_| {
                let mut r = || gen.unit();
                Sphere {
                    center_world: DVec3::new(r() * 80.0 - 40.0, r() * 5.0, r() * 80.0 - 10.0),
                    radius: 0.3 + r() * 2.0,
                    color: DVec3::ONE,
                }
            })
            .collect();
        let cameras = [
            (
                DVec3::new(0.0, 2.0, -20.0),
                DVec3::Z,
                DVec3::Y,
                DVec3::new(0.0, 0.0, -1.0),
            ),
            (
                DVec3::new(-5.0, 8.0, -30.0),
                DVec3::new(0.2, -0.4, 1.0),
                DVec3::new(0.3, 1.0, 0.0),
                DVec3::new(0.0, 0.0, -1.2),
            ),
            (
                DVec3::new(3.0, 0.05, -25.0),
                DVec3::new(-0.1, 0.0, 1.0),
                DVec3::Y,
                DVec3::new(0.4, 0.03, -0.9),
            ),
            (
                DVec3::new(0.0, 1.0, -20.0),
                DVec3::new(0.0, 1.0, 0.6),
                DVec3::Y,
                -DVec3::Z,
            ),
        ];
        let (mut dropped, mut after) = (0, 0);
        let (mut met, mut close) = (0, 0);
        for radius in [1e3, 1e5] {
            spheres.push(Sphere {
                center_world: DVec3::new(0.0, -radius, 0.0),
                radius,
                color: DVec3::ONE,
            });
            let ground = spheres.len() as u32 - 1;
            for &(vrp, vpn, vuv, cop) in &cameras {
                let camera = Camera {
                    vrp_world: vrp,
                    basis: Basis::from_vpn_vuv(vpn, vuv).unwrap(),
                    cop_view: cop,
                    window: DVec2::new(1.6, 0.9),
                };
                let view: Vec<ViewSphere> = spheres
                    .iter()
                    .enumerate()
                    .map(|(k, s)| ViewSphere::new(&camera, s, k as u32))
                    .collect();
                let columns = ViewColumns::new(camera.cop_view, &view);
                let shading = unlit(&columns);
                for samples in [1, 3] {
                    let raster = Raster {
                        width: 96,
                        height: 72,
                        samples,
                        adaptive: false,
                    };
                    let table = RayTable::new(cop, camera.window, raster);
                    let bins =
                        TileBins::build(Isa::Portable, &columns, Ranks::SCENE, &table, raster);
                    let wide = Wide::new(ground, &view[ground as usize].reach(), &table, raster);
                    let g = &view[ground as usize];
                    // Per tile, the ground's bound and its nearest hit by a sample.
                    let mut bound = vec![(None, f64::INFINITY); 6 * 5];
                    let s2 = (samples * samples) as usize;
                    for j in 0..72 {
                        for i in 0..96 {
                            let list = bins.at(i, j);
                            let (tx, ty) = (i / TILE, j / TILE);
                            let tile = &mut bound[ty * 6 + tx];
                            // With the COP inside the ground, it is in every tile.
                            if i % TILE == 0 && j % TILE == 0 {
                                tile.0 = match &wide {
                                    Some(w) => w.nearest(tx, ty, &mut None, &table, raster),
                                    None => Some(g.min_dist),
                                };
                            }
                            for d in (0..s2).map(|k| table.direction(i, j, k)) {
                                if let Some(t) = root(g.f, g.c, g.radius * g.radius, d) {
                                    tile.1 = tile.1.min(t);
                                }
                            }
                            if i % TILE == 0 && j % TILE == 0 {
                                match list.iter().position(|&k| k == ground) {
                                    None => dropped += 1,
                                    Some(at) => after += (at > 0) as usize,
                                }
                            }
                            for d in (0..s2).map(|k| table.direction(i, j, k)) {
                                let mut every: Option<(usize, f64)> = None;
                                for (k, s) in view.iter().enumerate() {
                                    let t = root(s.f, s.c, s.radius * s.radius, d);
                                    if let Some(t) = t.filter(|&t| every.is_none_or(|b| t < b.1)) {
                                        every = Some((k, t));
                                    }
                                }
                                let fast = nearest(&shading, &bins, (i, j), d);
                                assert_eq!(fast, every, "ground {radius}, pixel ({i}, {j})");
                            }
                        }
                    }
                    // The bound is below every hit of the tile's samples, and not far below the
                    // nearest.
                    for &(near, t) in &bound {
                        if t.is_finite() {
                            let near = near.expect("a tile whose samples meet the ground keeps it");
                            assert!(near <= t, "bound {near} above a hit at {t}");
                            met += 1;
                            close += (t - near < 0.1 * t) as usize;
                        }
                    }
                }
            }
            spheres.pop();
        }
        // The placement was exercised: the ground left out of some tiles, and later than first
        // in others.
        assert!(
            dropped > 20 && after > 20,
            "dropped {dropped}, after {after}"
        );
        // Within 10% of the nearest hit in most tiles.
        assert!(close * 4 > met * 3, "{close} of {met} tiles");
    }

    /// The primary-ray search over `spheres`, with no lights.
    fn unlit(spheres: &ViewColumns) -> Shading<'_> {
        Shading {
            spheres,
            scene: &[],
            lights: &[],
            ambient: 0.0,
            background: DVec3::ZERO,
        }
    }

    /// A sphere given in view coordinates, as `ViewSphere::new` makes it.
    fn in_view(center: DVec3, r: f64, cop: DVec3) -> ViewSphere {
        ViewSphere::in_view(center, r, cop, 0)
    }

    /// A sphere without screen bounds that a ray at a tile's edge or corner barely enters
    /// (10⁻⁶ of its radius deep) stays in the tile's list, and the ray finds it: for every
    /// tile, edge and corner, with one sample a pixel and 3×3, and the COP off the axis.
    #[test]
    fn a_grazing_hit_keeps_a_wide_sphere_in_its_tile() {
        let (cop, window) = (DVec3::new(0.2, -0.1, -1.0), DVec2::new(1.6, 1.0));
        let r = 1e4;
        for samples in [1, 3] {
            let raster = Raster {
                width: 40,
                height: 24,
                samples,
                adaptive: false,
            };
            let table = RayTable::new(cop, window, raster);
            let s = samples as usize;
            for (tx, ty) in (0..3).flat_map(|tx| (0..2).map(move |ty| (tx, ty))) {
                let (i0, j0) = (tx * TILE, ty * TILE);
                let (i1, j1) = (((tx + 1) * TILE).min(40) - 1, ((ty + 1) * TILE).min(24) - 1);
                // The middle sample of each edge and each corner sample (samples are row-major
                // in a pixel), and the way out of the tile there: columns grow along x, rows
                // downwards.
                let (mid_i, mid_j) = ((i0 + i1) / 2, (j0 + j1) / 2);
                let edges = [
                    ((i0, mid_j), s / 2 * s, -DVec3::X),
                    ((i1, mid_j), s / 2 * s + s - 1, DVec3::X),
                    ((mid_i, j0), s / 2, DVec3::Y),
                    ((mid_i, j1), (s - 1) * s + s / 2, -DVec3::Y),
                    ((i0, j0), 0, DVec3::new(-1.0, 1.0, 0.0)),
                    ((i1, j0), s - 1, DVec3::new(1.0, 1.0, 0.0)),
                    ((i0, j1), (s - 1) * s, DVec3::new(-1.0, -1.0, 0.0)),
                    ((i1, j1), s * s - 1, DVec3::new(1.0, -1.0, 0.0)),
                ];
                for ((i, j), k, out) in edges {
                    let d = table.direction(i, j, k);
                    let n = (out - d * d.dot(out)).normalize();
                    let sphere = in_view(cop + d * 50.0 + n * (r * (1.0 - 1e-6)), r, cop);
                    let f = sphere.f;
                    let view = [sphere];
                    assert_eq!(
                        footprint(&sphere.reach(), cop, window, raster),
                        Footprint::Everywhere
                    );
                    let columns = ViewColumns::new(cop, &view);
                    let bins =
                        TileBins::build(Isa::Portable, &columns, Ranks::SCENE, &table, raster);
                    let shading = unlit(&columns);
                    let t = root(f, sphere.c, sphere.radius * sphere.radius, d);
                    assert!(t.is_some(), "the ray meets the sphere");
                    let found = nearest(&shading, &bins, (i, j), d);
                    assert_eq!(
                        found,
                        t.map(|t| (0, t)),
                        "tile ({tx}, {ty}), pixel ({i}, {j})"
                    );
                }
            }
        }
    }

    /// A wide sphere goes into a tile's list at its bound there, and a sphere whose `min_dist`
    /// is that bound exactly goes before or after it by their scene indices, whichever order
    /// the ranks and the columns hold them in.
    #[test]
    fn a_wide_sphere_tied_with_another_is_placed_by_scene_index() {
        let (cop, window) = (DVec3::new(0.1, 0.05, -1.0), DVec2::new(1.6, 1.0));
        let raster = Raster {
            width: 40,
            height: 24,
            samples: 1,
            adaptive: false,
        };
        let table = RayTable::new(cop, window, raster);
        // A ground far below the middle of the view, and a small sphere in front of it.
        let r = 1e4;
        let ground = in_view(DVec3::new(0.0, -r - 3.0, 20.0), r, cop);
        let small = in_view(DVec3::new(0.0, -3.5, 10.0), 0.5, cop);
        let (tx, ty) = (1, 1);
        let wide = Wide::new(0, &ground.reach(), &table, raster).expect("the COP is outside");
        let bound = (wide.nearest(tx, ty, &mut None, &table, raster))
            .expect("the tile's rays meet the ground");
        for (ground_id, small_id) in [(0, 1), (1, 0)] {
            for ranks in [None, Some(vec![1, 0])] {
                let mut columns = ViewColumns::new(cop, &[ground, small]);
                columns.id = vec![ground_id, small_id];
                columns.min_dist[1] = bound;
                let ranks = Ranks(ranks.as_deref());
                let bins = TileBins::build(Isa::Portable, &columns, ranks, &table, raster);
                let list = bins.at(tx * TILE, ty * TILE);
                let scene = |k: u32| ranks.scene_index(columns.id[k as usize] as u32);
                let want: Vec<u32> = if scene(0) < scene(1) {
                    vec![0, 1]
                } else {
                    vec![1, 0]
                };
                assert_eq!(list, want, "ids {ground_id}, {small_id}, {ranks:?}");
            }
        }
    }

    /// Near tangency a computed hit is only good to about 10⁻⁸ of the distance, and the bound
    /// stays below it: a huge sphere (radius 10³ to 10⁷, the COP 10⁻⁶ to 10⁻¹⁵ of it above its
    /// surface) that the ray of each tile's corner furthest from its cone's axis touches,
    /// turned a rounding step at a time through tangency. Where the ray meets it, the tile
    /// keeps it, no nearer than the hit.
    #[test]
    fn a_tangent_ray_is_never_nearer_than_its_tiles_bound() {
        let cop = DVec3::new(0.0, 0.0, -1.0);
        let mut hits = 0;
        for (w, h, side) in [(32, 32, 2.0), (40, 24, 1.6)] {
            let window = DVec2::new(side, side * h as f64 / w as f64);
            let raster = Raster {
                width: w,
                height: h,
                samples: 1,
                adaptive: false,
            };
            let table = RayTable::new(cop, window, raster);
            for tx in 0..(w as usize).div_ceil(TILE) {
                for ty in 0..(h as usize).div_ceil(TILE) {
                    let cone = TileCone::new(&table, raster, tx, ty).unwrap();
                    let (i0, i1) = (tx * TILE, ((tx + 1) * TILE).min(w as usize) - 1);
                    let (j0, j1) = (ty * TILE, ((ty + 1) * TILE).min(h as usize) - 1);
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
                                let sphere = in_view(center, r, cop);
                                let f = sphere.f;
                                let Some(t) = root(f, sphere.c, r * r, u) else {
                                    continue;
                                };
                                hits += 1;
                                let wide = Wide::new(0, &sphere.reach(), &table, raster).unwrap();
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

    #[test]
    fn total_keys_order_as_total_cmp() {
        let mut xs = vec![
            0.0,
            -0.0,
            1.0,
            -1.0,
            f64::MIN_POSITIVE,
            -f64::MIN_POSITIVE,
            f64::MAX,
            f64::MIN,
            f64::INFINITY,
            f64::NEG_INFINITY,
            5e-324,
            -5e-324,
            0.1,
            -0.1,
            3.5,
            -3.5,
        ];
        xs.extend((0..1000).map(|k| (k as f64 - 500.0) * 0.37e-3));
        for a in &xs {
            for b in &xs {
                assert_eq!(total_key(*a).cmp(&total_key(*b)), a.total_cmp(b), "{a} {b}");
            }
        }
    }

    #[test]
    fn tangent_slopes_touch_the_circle() {
        // Circle at (3, 10) with r = 2: the distance from the centre to each line x = a·z is r.
        let (a0, a1) = tangent_slopes(3.0, 10.0, 2.0);
        for a in [a0, a1] {
            let dist = (3.0 - a * 10.0).abs() / (1.0 + a * a).sqrt();
            assert!((dist - 2.0).abs() < 1e-12);
        }
        assert!(a0 < 0.3 && a1 > 0.3);
    }
}
