//! Hidden spheres culled before a frame's columns: the spheres that may own a pixel, found by
//! a walk of the scene's hierarchy per screen tile, nearest first, against a bound on each
//! pixel's nearest hit.
//!
//! Past a few spheres a pixel, most spheres inside the view pyramid are hidden behind others
//! (in the dense cluster of ten million, one in forty owns a pixel at 640×360), and moving
//! them into view coordinates, sorting and binning them costs more than every ray. Here each
//! tile of [`CULL_TILE`]² pixels walks the hierarchy from the root, the nearer child first,
//! and keeps a leaf's sphere where its pixels' rays can meet it nearer than the bound; a
//! sphere kept lowers the bound (`far`) of each pixel whose ray meets it for sure, to the far
//! end of where that hit can lie. A subtree or sphere is passed only when no pixel it can
//! cover could see it: its least distance from the COP is beyond the largest bound among those
//! pixels. So the spheres kept hold every pixel's nearest hit and any tied with it, and the
//! frame rendered from them is the frame rendered from every sphere in view, byte for byte:
//! the search takes a pixel's nearest sphere, ties by its order, from whatever list holds it.
//!
//! A frame's walk starts from bounds already lowered (`Seeds`): each tile keeps the spheres
//! whose hits held its pixels' bounds when its last walk ended, and lowers its bounds with them
//! first. Lowering by any sphere of the scene leaves a bound no nearer than the pixel's nearest
//! hit, so seeds from another frame, camera or raster (or none) leave the frame as it is; from
//! a frame close by they hold the bounds near their end from the start (ten million spheres
//! orbited 1.7° a frame: about half as many spheres kept; 9.6° a frame: 7–8% fewer).
//!
//! Nothing here is compared to decide a pixel: every test is a bound widened by far more than
//! its rounding (see [`Slack`]), so it errs on the side of keeping. The walk runs only at one
//! sample a pixel, where a pixel's ray is the one through its centre.

// `!(a > b)` is meant: a NaN takes the branch that keeps (or does not lower a bound).
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use glam::DVec3;
use rayon::prelude::*;
use std::sync::atomic::{AtomicU64, Ordering};

use super::lanes::{dot, prefetch, splat3, ForLanes, Lanes, LANES};
use super::rays::RayTable;
use super::simd::Isa;
use super::tree::{shape_inner, Shape};
use super::world::SceneIndex;
use crate::camera::Camera;

/// Side in pixels of a culling tile: its pixels' bounds are its walk's state (192 KB, on the
/// heap, in the second-level cache). Each tile walks the hierarchy's upper levels again, and
/// starts from its own seeds: against tiles of 64, tiles of 128 culled ten million spheres at
/// 640×360 in 141 ms a frame, not 151, and at 1080p in 514 ms, not 548; a million at 640×360
/// in 52–55 ms, not 56–57, and at 1080p as fast (docs/performance.md). Tiles of 32 were slower
/// everywhere.
pub const CULL_TILE: usize = 128;

/// Side in pixels of a block of a tile, whose largest bound the tests read.
const BLOCK: usize = 4;
const BLOCKS: usize = CULL_TILE / BLOCK;

/// A rectangle of at most this many pixels reads their bounds, a larger one its blocks'.
const PIXELS_READ: usize = 16;

/// Relative allowance on every bound: rounding in the walk's f64 (and in the f32 boxes,
/// already rounded outward) is below 10⁻¹⁵ of the coordinates, this is 10⁻⁶.
const SLACK: f64 = 1e-6;

/// The frame's geometry as the walk reads it.
struct View<'a> {
    camera: &'a Camera,
    cop_world: DVec3,
    table: &'a RayTable,
    /// Each pixel's ray as a unit vector, one column per coordinate ([`RayTable::units`]).
    units: &'a [Vec<f64>; 3],
    /// Window width and height over the raster's, for window coordinates to pixels.
    px_per_x: f64,
    px_per_y: f64,
    /// The absolute part of every allowance: 10⁻⁶ of the camera's coordinates.
    slack: f64,
}

/// A rectangle of pixels, inclusive: columns x0..=x1, rows y0..=y1.
#[derive(Clone, Copy)]
struct Rect {
    x0: usize,
    x1: usize,
    y0: usize,
    y1: usize,
}

impl<'a> View<'a> {
    fn new(camera: &'a Camera, table: &'a RayTable) -> View<'a> {
        let cop_world = camera.cop_world();
        let raster = table.raster;
        View {
            camera,
            cop_world,
            table,
            units: table.units(),
            px_per_x: raster.width as f64 / camera.window.x,
            px_per_y: raster.height as f64 / camera.window.y,
            slack: SLACK
                * (cop_world.abs().max_element()
                    + camera.vrp_world.abs().max_element()
                    + camera.cop_view.abs().max_element()
                    + camera.window.max_element()),
        }
    }

    /// The pixels of `tile` whose rays may meet the view-coordinate box centre `c` ± `e`
    /// (widened), or None; the whole tile when the box reaches the COP's plane.
    fn rect(&self, c: DVec3, e: DVec3, tile: Rect) -> Option<Rect> {
        let cop = self.camera.cop_view;
        let pad = e + DVec3::splat(self.slack + SLACK * c.abs().max_element());
        let (lo, hi) = (c - pad - cop, c + pad - cop);
        if hi.z < 0.0 {
            // Wholly behind the COP: every ray leaves it forward (its direction's n is the
            // window's distance, over the ray's length).
            return None;
        }
        if !(lo.z > 0.0) || !lo.is_finite() || !hi.is_finite() {
            // Behind, across or at the COP's plane (or beyond f64): every pixel.
            return Some(tile);
        }
        let dz = self.table.dz;
        // The least and most of a / z and b / z for a ≤ b and z in [lo.z, hi.z] (both > 0):
        // the lower end over the far plane when it is positive, over the near one otherwise,
        // and the upper end the other way about.
        let span = |a: f64, b: f64| {
            let mn = if a >= 0.0 { a / hi.z } else { a / lo.z };
            let mx = if b >= 0.0 { b / lo.z } else { b / hi.z };
            (mn * dz, mx * dz)
        };
        let (wx0, wx1) = span(lo.x, hi.x);
        let (wy0, wy1) = span(lo.y, hi.y);
        let w = self.camera.window;
        // Pixel positions less a half: pixel k's centre is at k (the box's widening, far
        // above these operations' rounding, keeps every centre a ray to the box can pass).
        let (px0, px1) = (
            (cop.x + wx0 + w.x * 0.5) * self.px_per_x - 0.5,
            (cop.x + wx1 + w.x * 0.5) * self.px_per_x - 0.5,
        );
        let (py0, py1) = (
            (w.y * 0.5 - cop.y - wy1) * self.px_per_y - 0.5,
            (w.y * 0.5 - cop.y - wy0) * self.px_per_y - 0.5,
        );
        if !(px0.is_finite() && px1.is_finite() && py0.is_finite() && py1.is_finite()) {
            return Some(tile);
        }
        // The whole pixels from a up to b, in the tile's t0..=t1 (without `f64::floor`, a
        // call into libm on the baseline path).
        let clip = |a: f64, b: f64, t0: usize, t1: usize| {
            let a = a.max(t0 as f64);
            let b = b.min(t1 as f64);
            if !(a <= b) {
                return None;
            }
            let (i, j) = (a as usize, b as usize);
            let i = if (i as f64) < a { i + 1 } else { i };
            (i <= j).then_some((i, j))
        };
        let (x0, x1) = clip(px0, px1, tile.x0, tile.x1)?;
        let (y0, y1) = clip(py0, py1, tile.y0, tile.y1)?;
        Some(Rect { x0, x1, y0, y1 })
    }

    /// A leaf's sphere in view coordinates: its centre and outer radius, the COP less the
    /// centre, their distance and the allowance on bounds at that distance.
    fn measure(&self, shape: &Shape) -> (DVec3, f64, DVec3, f64, f64) {
        let c = DVec3::new(shape[0] as f64, shape[1] as f64, shape[2] as f64);
        let center = self.camera.point_to_view(c);
        let r = shape[3] as f64;
        let f = self.camera.cop_view - center;
        let dist = f.length();
        let slack = self.slack + SLACK * (dist + r + center.abs().max_element());
        (center, r, f, dist, slack)
    }

    /// `near_box` of node `j` of `index`'s hierarchy, whose own children (or every line of its
    /// spheres' shapes) are asked for now: the walk is bound by their reads, and one of a
    /// node's two children is next.
    fn near_child(&self, index: &SceneIndex, j: u32) -> f64 {
        let (nodes, shapes, _) = index.tree();
        let child = &nodes[j as usize];
        if child.count == 0 {
            prefetch(&nodes[j as usize + 1]);
            prefetch(&nodes[child.start as usize]);
        } else {
            // Four shapes a 64-byte line, and the last, which may begin another line.
            let leaf = &shapes[child.start as usize..][..child.count as usize];
            for shape in leaf.iter().step_by(4).chain(leaf.last()) {
                prefetch(shape);
            }
        }
        let [lo, hi] = child.bounds();
        self.near_box(lo, hi)
    }

    /// No ray from the COP meets the world box (lo, hi) nearer than this.
    fn near_box(&self, lo: DVec3, hi: DVec3) -> f64 {
        let p = self.cop_world;
        let gap = (lo - p).max(p - hi).max(DVec3::ZERO);
        gap.length() - self.slack - SLACK * (lo.abs().max(hi.abs()).max_element())
    }
}

/// What the lanes found of up to eight spheres of a leaf ([`Octet::test`]), as bits of lanes.
struct Found {
    /// Spheres that may be nearer than the leaf's bound, whose rectangle the lanes leave to
    /// [`View::rect`]: at or behind the COP's plane, or beyond f64.
    whole: u8,
    /// Spheres that may be nearer than the leaf's bound and whose pixels in the tile are
    /// `x` and `y` (first and last column, first and last row), at least one of each.
    open: u8,
    near: [f64; LANES],
    x: [[i32; LANES]; 2],
    y: [[i32; LANES]; 2],
}

/// A tile's view of the frame in lanes: [`View::measure`] and [`View::rect`] for eight spheres
/// at once, operation for operation (the whole pixels by `ceil` and `floor`, which give the
/// scalar clip's), so each lane holds the very values the scalar code finds.
struct Octet<V: Lanes> {
    tok: V::Token,
    vrp: [V; 3],
    basis: [[V; 3]; 3],
    cop: [V; 3],
    slack: V,
    relative: V,
    dz: V,
    /// The window's half width, and its half height less the COP's v.
    half_w: V,
    top: V,
    px_per: [V; 2],
    /// The tile's first and last column and row.
    tile: [[V; 2]; 2],
}

impl<V: Lanes> Octet<V> {
    #[inline(always)]
    fn frame(tok: V::Token, view: &View, tile: Rect) -> Octet<V> {
        let camera = view.camera;
        let b = &camera.basis;
        let w = camera.window;
        Octet {
            tok,
            vrp: splat3(tok, camera.vrp_world),
            basis: [splat3(tok, b.u), splat3(tok, b.v), splat3(tok, b.n)],
            cop: splat3(tok, camera.cop_view),
            slack: V::splat(tok, view.slack),
            relative: V::splat(tok, SLACK),
            dz: V::splat(tok, view.table.dz),
            half_w: V::splat(tok, w.x * 0.5),
            top: V::splat(tok, w.y * 0.5 - camera.cop_view.y),
            px_per: [V::splat(tok, view.px_per_x), V::splat(tok, view.px_per_y)],
            tile: [
                [V::splat(tok, tile.x0 as f64), V::splat(tok, tile.x1 as f64)],
                [V::splat(tok, tile.y0 as f64), V::splat(tok, tile.y1 as f64)],
            ],
        }
    }

    /// The spheres of `group` (one to eight) measured, tested against the leaf's `bound` and
    /// given their rectangles in the tile.
    #[inline(always)]
    fn test(&self, group: &[Shape], bound: f64) -> Found {
        let tok = self.tok;
        let [x, y, z, r] = match <&[Shape; LANES]>::try_from(group) {
            Ok(eight) => V::columns(tok, eight),
            Err(_) => {
                let mut some = [[0.0; 4]; LANES];
                some[..group.len()].copy_from_slice(group);
                V::columns(tok, &some)
            }
        };
        let valid = (u16::MAX >> (16 - group.len())) as u8;
        let zero = V::splat(tok, 0.0);
        let world = [x.sub(self.vrp[0]), y.sub(self.vrp[1]), z.sub(self.vrp[2])];
        let c = [
            dot(&world, &self.basis[0]),
            dot(&world, &self.basis[1]),
            dot(&world, &self.basis[2]),
        ];
        let f = [
            self.cop[0].sub(c[0]),
            self.cop[1].sub(c[1]),
            self.cop[2].sub(c[2]),
        ];
        let dist = dot(&f, &f).sqrt();
        let m = c[0].abs().max(c[1].abs()).max(c[2].abs());
        let slack = self.slack.add(self.relative.mul(dist.add(r).add(m)));
        let near = dist.sub(r).sub(slack);
        let beyond = near.gt(V::splat(tok, bound));
        // View::rect with e = r in every coordinate.
        let pad = r.add(self.slack.add(self.relative.mul(m)));
        let lo = [
            c[0].sub(pad).sub(self.cop[0]),
            c[1].sub(pad).sub(self.cop[1]),
            c[2].sub(pad).sub(self.cop[2]),
        ];
        let hi = [
            c[0].add(pad).sub(self.cop[0]),
            c[1].add(pad).sub(self.cop[1]),
            c[2].add(pad).sub(self.cop[2]),
        ];
        let ahead = lo[2].gt(zero)
            & finite(lo[0], zero)
            & finite(lo[1], zero)
            & finite(lo[2], zero)
            & finite(hi[0], zero)
            & finite(hi[1], zero)
            & finite(hi[2], zero);
        // The least of a / z over z in [lo.z, hi.z] (both > 0 where it counts) and the most of
        // b / z, in window units; then pixel positions less a half.
        // Each end's divisor chosen first, then one division, as `View::rect`'s `span` does.
        let (lz, hz) = (lo[2], hi[2]);
        let wx0 = lo[0].div(V::blend(lo[0].ge(zero), lz, hz)).mul(self.dz);
        let wy0 = lo[1].div(V::blend(lo[1].ge(zero), lz, hz)).mul(self.dz);
        let wx1 = hi[0].div(V::blend(hi[0].ge(zero), hz, lz)).mul(self.dz);
        let wy1 = hi[1].div(V::blend(hi[1].ge(zero), hz, lz)).mul(self.dz);
        let half = V::splat(tok, 0.5);
        let [ppx, ppy] = self.px_per;
        let px0 = self.cop[0].add(wx0).add(self.half_w).mul(ppx).sub(half);
        let px1 = self.cop[0].add(wx1).add(self.half_w).mul(ppx).sub(half);
        let py0 = self.top.sub(wy1).mul(ppy).sub(half);
        let py1 = self.top.sub(wy0).mul(ppy).sub(half);
        let decided =
            ahead & finite(px0, zero) & finite(px1, zero) & finite(py0, zero) & finite(py1, zero);
        let [[tx0, tx1], [ty0, ty1]] = self.tile;
        // The whole pixels from the least to the most, in the tile. `ceil` and `floor` hold
        // for lanes in [0, 2⁵¹]; a lane beyond lies past the tile, and `over` leaves it closed.
        let (x0, x1) = (ceil(px0.max(tx0)), floor(px1.min(tx1)));
        let (y0, y1) = (ceil(py0.max(ty0)), floor(py1.min(ty1)));
        let over = x0.le(x1) & y0.le(y1);
        let kept = valid & !beyond;
        // In the tile's range in every lane (a NaN gives the tile's end), as `to_i32` needs.
        let whole = |v: V, t0: V, t1: V| v.max(t0).min(t1).to_i32(i32::MAX);
        Found {
            whole: kept & !decided,
            open: kept & decided & over,
            near: near.store(),
            x: [whole(x0, tx0, tx1), whole(x1, tx0, tx1)],
            y: [whole(y0, ty0, ty1), whole(y1, ty0, ty1)],
        }
    }
}

/// 2⁵²: from it up, every f64 is a whole number.
const WHOLE: f64 = 4_503_599_627_370_496.0;

/// The nearest whole number to each lane in [0, 2⁵¹], by adding and taking away 2⁵² (without
/// `f64::round` and its kin, calls into libm on the baseline path).
#[inline(always)]
fn nearest<V: Lanes>(v: V) -> V {
    let whole = V::splat(v.token(), WHOLE);
    v.add(whole).sub(whole)
}

/// The least whole number not below each lane in [0, 2⁵¹]: the nearest, one more where that
/// is below the lane.
#[inline(always)]
fn ceil<V: Lanes>(v: V) -> V {
    let n = nearest(v);
    V::blend(n.lt(v), n, n.add(V::splat(v.token(), 1.0)))
}

/// The greatest whole number not above each lane in [0, 2⁵¹]: the nearest, one less where
/// that is above the lane.
#[inline(always)]
fn floor<V: Lanes>(v: V) -> V {
    let n = nearest(v);
    V::blend(n.gt(v), n, n.sub(V::splat(v.token(), 1.0)))
}

/// Lanes holding a finite value (`zero` in every lane).
#[inline(always)]
fn finite<V: Lanes>(v: V, zero: V) -> u8 {
    v.sub(v).eq(zero)
}

/// The spheres a tile's walk keeps, as bits over the hierarchy's order.
struct Kept(Vec<AtomicU64>);

impl Kept {
    fn set(&self, at: usize) {
        // Read first: a sphere many tiles keep (a ground) is written once, not by every tile.
        let (word, bit) = (&self.0[at / 64], 1 << (at % 64));
        if word.load(Ordering::Relaxed) & bit == 0 {
            word.fetch_or(bit, Ordering::Relaxed);
        }
    }
}

impl SceneIndex<'_> {
    /// The ranks of the spheres that may own a pixel of `camera`'s frame at one sample a pixel
    /// (the rays of `table`), in the hierarchy's order: a subset of [`SceneIndex::visible`]
    /// that gives the same frame.
    /// Each tile's walk starts from its `seeds` and leaves its own there for the next frame.
    pub(super) fn unhidden(
        &self,
        isa: Isa,
        camera: &Camera,
        table: &RayTable,
        seeds: &mut Seeds,
    ) -> Vec<u32> {
        let (nodes, _, order) = self.tree();
        if nodes.is_empty() {
            return Vec::new();
        }
        let view = View::new(camera, table);
        let kept = Kept(
            (0..order.len().div_ceil(64))
                .map(|_| AtomicU64::new(0))
                .collect(),
        );
        let raster = table.raster;
        let (w, h) = (raster.width as usize, raster.height as usize);
        let across = w.div_ceil(CULL_TILE);
        let tiles = across * h.div_ceil(CULL_TILE);
        if seeds.0.len() != tiles {
            seeds.0 = vec![Vec::new(); tiles];
        }
        let each = seeds.0.par_iter_mut().enumerate().with_max_len(1);
        each.for_each(|(t, seeds)| {
            let (tx, ty) = (t % across * CULL_TILE, t / across * CULL_TILE);
            let tile = Rect {
                x0: tx,
                x1: (tx + CULL_TILE).min(w) - 1,
                y0: ty,
                y1: (ty + CULL_TILE).min(h) - 1,
            };
            isa.run(Walk {
                index: self,
                view: &view,
                tile,
                kept: &kept,
                seeds,
            });
        });
        let mut out = Vec::new();
        for (k, word) in kept.0.iter().enumerate() {
            let mut bits = word.load(Ordering::Relaxed);
            while bits != 0 {
                let at = k * 64 + bits.trailing_zeros() as usize;
                out.push(order.rank(at));
                bits &= bits - 1;
            }
        }
        out
    }
}

/// Per culling tile, the spheres whose hits held its pixels' bounds when its last walk ended
/// (their positions in the hierarchy's order, ascending), which its next walk lowers its bounds
/// with first. Only how soon the bounds fall depends on them, never the frame (see the
/// module's documentation): a position past the scene's spheres is passed over.
#[derive(Default)]
pub(super) struct Seeds(Vec<Vec<u32>>);

/// One tile's walk (see the module's documentation), written once for every form of lanes and
/// compiled for the frame's instruction set (`Isa::run`): the tile's seeds lower its bounds,
/// then a leaf's spheres are moved into view coordinates, measured and tested against the
/// leaf's bound and the tile eight at a time ([`Octet`]), and only those left take the scalar
/// tests and the pixels.
struct Walk<'a, 'b> {
    index: &'a SceneIndex<'b>,
    view: &'a View<'a>,
    tile: Rect,
    kept: &'a Kept,
    seeds: &'a mut Vec<u32>,
}

impl ForLanes for Walk<'_, '_> {
    type Output = ();

    #[inline(always)]
    fn run<V: Lanes>(self, tok: V::Token) {
        let Walk {
            index,
            view,
            tile,
            kept,
            seeds,
        } = self;
        let (nodes, shapes, _) = index.tree();
        let camera = view.camera;
        let mut bounds = Bounds::new(tile);
        let lanes = Octet::<V>::frame(tok, view, tile);
        let abs_rows = [
            camera.basis.u.abs(),
            camera.basis.v.abs(),
            camera.basis.n.abs(),
        ];
        // The seeds, eight at a time (as a leaf's spheres are); they lower bounds, and the walk
        // decides whether they are kept.
        for chunk in seeds.chunks(LANES) {
            let mut group = [[0.0; 4]; LANES];
            let mut at = [0; LANES];
            let mut n = 0;
            for &k in chunk {
                if let Some(shape) = shapes.get(k as usize) {
                    (group[n], at[n]) = (*shape, k);
                    n += 1;
                }
            }
            if n > 0 {
                let found = lanes.test(&group[..n], f64::INFINITY);
                bounds.take::<V>(tok, view, tile, &group[..n], &found, |l| at[l]);
            }
        }
        let mut stack: Vec<(u32, f64)> = Vec::with_capacity(96);
        let [lo, hi] = nodes[0].bounds();
        stack.push((0, view.near_box(lo, hi)));
        while let Some((k, near)) = stack.pop() {
            let node = &nodes[k as usize];
            let [lo, hi] = node.bounds();
            let (mid, half) = ((lo + hi) * 0.5, (hi - lo) * 0.5);
            let c = camera.point_to_view(mid);
            let e = DVec3::new(
                abs_rows[0].dot(half),
                abs_rows[1].dot(half),
                abs_rows[2].dot(half),
            );
            let Some(rect) = view.rect(c, e, tile) else {
                continue;
            };
            // No pixel that can see into the box has a bound above this one, and bounds only
            // fall: a sphere of a leaf beyond it is passed without its own rectangle.
            let bound = bounds.most::<V>(tok, rect);
            if near > bound {
                continue;
            }
            if node.count == 0 {
                // The nearer child on top.
                let (a, b) = (k + 1, node.start);
                let (na, nb) = (view.near_child(index, a), view.near_child(index, b));
                if na <= nb {
                    stack.push((b, nb));
                    stack.push((a, na));
                } else {
                    stack.push((a, na));
                    stack.push((b, nb));
                }
                continue;
            }
            let first = node.start as usize;
            let leaf = &shapes[first..first + node.count as usize];
            for (g, group) in leaf.chunks(LANES).enumerate() {
                let base = first + g * LANES;
                let found = lanes.test(group, bound);
                let at = |l| (base + l) as u32;
                let mut taken = bounds.take::<V>(tok, view, tile, group, &found, at);
                while taken != 0 {
                    kept.set(base + taken.trailing_zeros() as usize);
                    taken &= taken - 1;
                }
            }
        }
        // The next walk's seeds: this one's owners of the bounds, each once.
        seeds.clear();
        let owners = bounds.owner.iter().copied().filter(|&k| k != NO_OWNER);
        seeds.extend(owners);
        seeds.dedup();
        seeds.sort_unstable();
        seeds.dedup();
    }
}

/// A tile's walk state: each pixel's bound (no sphere nearer than its nearest hit lies
/// beyond it) and the sphere whose hit set it, and the largest bound in each block of BLOCK²
/// pixels, which a rectangle's test reads.
struct Bounds {
    tile: Rect,
    /// [`LANES`] more than the tile's pixels (at +∞, never lowered), so eight lanes load from
    /// any pixel.
    far: Box<[f64; CULL_TILE * CULL_TILE + LANES]>,
    block: [f64; BLOCKS * BLOCKS],
    /// Blocks to find their largest bound again, as bits: set and cleared within a `lower`.
    stale: [u64; BLOCKS * BLOCKS / 64],
    /// Each pixel's bound's sphere (its position in the hierarchy's order), or [`NO_OWNER`].
    owner: Box<[u32; CULL_TILE * CULL_TILE]>,
}

/// A bound no sphere set (+∞).
const NO_OWNER: u32 = u32::MAX;

/// An array of `value`s made on the heap, not on the walk's stack and then moved.
fn filled<T: Copy, const N: usize>(value: T) -> Box<[T; N]> {
    let all: Box<[T]> = vec![value; N].into_boxed_slice();
    all.try_into().unwrap_or_else(|_| unreachable!("N values"))
}

impl Bounds {
    fn new(tile: Rect) -> Bounds {
        Bounds {
            tile,
            far: filled(f64::INFINITY),
            block: [f64::INFINITY; BLOCKS * BLOCKS],
            stale: [0; BLOCKS * BLOCKS / 64],
            owner: filled(NO_OWNER),
        }
    }

    /// The spheres of `group` that `found` leaves and that may be nearer than a bound of
    /// their pixels, as bits of lanes, each lowering the bounds (as sphere `at(lane)`) in the
    /// group's order, as one at a time: each lowers the bounds the next is tested against.
    #[inline(always)]
    fn take<V: Lanes>(
        &mut self,
        tok: V::Token,
        view: &View,
        tile: Rect,
        group: &[Shape],
        found: &Found,
        at: impl Fn(usize) -> u32,
    ) -> u8 {
        let mut taken = 0;
        let mut left = found.whole | found.open;
        while left != 0 {
            let l = left.trailing_zeros() as usize;
            left &= left - 1;
            let shape = &group[l];
            let (rect, near) = if found.whole & (1 << l) != 0 {
                // A rectangle the lanes leave open (the COP's plane, beyond f64): the scalar
                // tests.
                let (center, r, _, dist, slack) = view.measure(shape);
                let Some(rect) = view.rect(center, DVec3::splat(r), tile) else {
                    continue;
                };
                (rect, dist - r - slack)
            } else {
                // Over the tile and perhaps nearer than the bound asked: its pixels.
                let pixels = |ends: &[[i32; LANES]; 2]| (ends[0][l] as usize, ends[1][l] as usize);
                let ((x0, x1), (y0, y1)) = (pixels(&found.x), pixels(&found.y));
                (Rect { x0, x1, y0, y1 }, found.near[l])
            };
            if near > self.most::<V>(tok, rect) {
                continue;
            }
            taken |= 1 << l;
            self.lower::<V>(tok, view, shape, rect, at(l));
        }
        taken
    }

    fn at(&self, x: usize, y: usize) -> usize {
        (y - self.tile.y0) * CULL_TILE + (x - self.tile.x0)
    }

    /// The blocks `r` lies in: first and last column, first and last row.
    fn blocks(&self, r: Rect) -> (usize, usize, usize, usize) {
        let t = self.tile;
        let (bx0, bx1) = ((r.x0 - t.x0) / BLOCK, (r.x1 - t.x0) / BLOCK);
        let (by0, by1) = ((r.y0 - t.y0) / BLOCK, (r.y1 - t.y0) / BLOCK);
        (bx0, bx1, by0, by1)
    }

    /// The largest bound over `r` (or over its blocks, not less). Bounds are compared as
    /// their bits (see [`larger`]).
    #[inline(always)]
    fn most<V: Lanes>(&self, tok: V::Token, r: Rect) -> f64 {
        if r.x1 - r.x0 < 2 && r.y1 - r.y0 < 2 {
            // Up to 2 × 2 pixels: their corners, without a loop's branches.
            let (a, b) = (self.at(r.x0, r.y0), self.at(r.x0, r.y1));
            let (w, far) = (r.x1 - r.x0, &self.far);
            let m = larger(larger(larger(0, far[a]), far[a + w]), far[b]);
            return f64::from_bits(larger(m, far[b + w]));
        }
        if r.x1 - r.x0 < 4 && r.y1 - r.y0 < 4 {
            // Up to 4 × 4 pixels: a row's eight lanes from its first pixel, those past its
            // last set to zero, four rows (the last read again where the rectangle is
            // smaller), without a loop's branches. Bounds are positive and not NaN, so each
            // lane's `max` is `larger`'s.
            let (w, h) = (r.x1 - r.x0, r.y1 - r.y0);
            let (zero, mut m) = (V::splat(tok, 0.0), V::splat(tok, 0.0));
            let columns = (2u8 << w) - 1;
            for j in 0..4 {
                let row = self.at(r.x0, r.y0 + j.min(h));
                let eight: &[f64; LANES] = self.far[row..row + LANES].try_into().expect("8");
                m = m.max(V::blend(columns, zero, V::load(tok, eight)));
            }
            let m = m.store();
            let m = larger(larger(larger(larger(0, m[0]), m[1]), m[2]), m[3]);
            return f64::from_bits(m);
        }
        let mut m = 0;
        if (r.x1 - r.x0 + 1) * (r.y1 - r.y0 + 1) <= PIXELS_READ {
            for y in r.y0..=r.y1 {
                let row = self.at(r.x0, y);
                for &far in &self.far[row..=row + (r.x1 - r.x0)] {
                    m = larger(m, far);
                }
            }
            return f64::from_bits(m);
        }
        let (bx0, bx1, by0, by1) = self.blocks(r);
        for by in by0..=by1 {
            for &block in &self.block[by * BLOCKS + bx0..=by * BLOCKS + bx1] {
                m = larger(m, block);
            }
        }
        f64::from_bits(m)
    }

    /// Where sphere `at` is met for sure by a ray of `rect`, that pixel's nearest hit made no
    /// farther than the far end of where the hit can lie (and the sphere its bound's owner):
    /// eight pixels of a row at a time ([`InnerBall::lowers`]).
    #[inline(always)]
    fn lower<V: Lanes>(&mut self, tok: V::Token, view: &View, shape: &Shape, rect: Rect, at: u32) {
        let (_, r, f, dist, slack) = view.measure(shape);
        let inner = shape_inner(shape);
        let (r2, sure) = (
            inner * inner,
            1e-3 * inner * inner + 1e-12 * f.length_squared(),
        );
        // Only from a COP clearly outside the sphere: from inside it (or within rounding of
        // its surface) the search takes the far root, however soon the ray enters the inner
        // ball.
        if !(inner > 0.0) || !(dist - r > slack) {
            return;
        }
        let w = view.table.raster.width as usize;
        let ball = InnerBall::<V>::new(tok, f, r2, sure, slack);
        // A block whose largest bound a pixel held as it fell: only there can the largest
        // have fallen too, and only those blocks are found again.
        let mut stale = false;
        let t = self.tile;
        let [ux, uy, uz] = view.units;
        for y in rect.y0..=rect.y1 {
            for x in (rect.x0..=rect.x1).step_by(LANES) {
                let valid = (u16::MAX >> (16 - (rect.x1 + 1 - x).min(LANES))) as u8;
                let (pixel, u) = (self.at(x, y), y * w + x);
                let eight = |column: &[f64], at: usize| {
                    let values: &[f64; LANES] = column[at..at + LANES].try_into().expect("8");
                    V::load(tok, values)
                };
                let d = [eight(ux, u), eight(uy, u), eight(uz, u)];
                let far = eight(&self.far[..], pixel);
                let (mut lowered, bound) = ball.lowers(d, far);
                lowered &= valid;
                if lowered == 0 {
                    continue;
                }
                // Written back as one row of eight (the rest as they were), which the next
                // sphere's loads take from the store as it is.
                let row: &mut [f64; LANES] =
                    (&mut self.far[pixel..pixel + LANES]).try_into().expect("8");
                *row = V::blend(lowered, far, bound).store();
                let far = far.store();
                while lowered != 0 {
                    let l = lowered.trailing_zeros() as usize;
                    lowered &= lowered - 1;
                    debug_assert!(row[l] > 0.0, "a bound at or below zero");
                    self.owner[pixel + l] = at;
                    let b = (y - t.y0) / BLOCK * BLOCKS + (x + l - t.x0) / BLOCK;
                    if far[l].to_bits() == self.block[b].to_bits() {
                        self.stale[b / 64] |= 1 << (b % 64);
                        stale = true;
                    }
                }
            }
        }
        if stale {
            let (bx0, bx1, by0, by1) = self.blocks(rect);
            for by in by0..=by1 {
                for bx in bx0..=bx1 {
                    let b = by * BLOCKS + bx;
                    if self.stale[b / 64] & 1 << (b % 64) == 0 {
                        continue;
                    }
                    self.stale[b / 64] &= !(1 << (b % 64));
                    self.block[b] = f64::from_bits(self.largest_in_block(bx, by));
                }
            }
        }
        debug_assert!(
            self.blocks_hold_their_largest(rect),
            "a block's largest bound left stale"
        );
    }

    /// Whether each block of `rect` holds the largest bound of its pixels (what `lower`
    /// keeps, finding again only the blocks whose largest fell), bit for bit.
    fn blocks_hold_their_largest(&self, rect: Rect) -> bool {
        let (bx0, bx1, by0, by1) = self.blocks(rect);
        (by0..=by1).all(|by| {
            (bx0..=bx1)
                .all(|bx| self.largest_in_block(bx, by) == self.block[by * BLOCKS + bx].to_bits())
        })
    }

    /// The largest bound of the pixels of block (`bx`, `by`), as its bits.
    fn largest_in_block(&self, bx: usize, by: usize) -> u64 {
        let t = self.tile;
        let (x0, y0) = (t.x0 + bx * BLOCK, t.y0 + by * BLOCK);
        let mut m = 0;
        for y in y0..(y0 + BLOCK).min(t.y1 + 1) {
            let row = self.at(x0, y);
            for &far in &self.far[row..row + (t.x1 + 1 - x0).min(BLOCK)] {
                m = larger(m, far);
            }
        }
        m
    }
}

/// A sphere's inner ball as [`Bounds::lower`] meets it along eight pixels' rays, in every
/// lane: `f`, the COP less its centre; `r2`, its radius squared; `sure`, the least
/// discriminant of a sure hit; `slack`, the allowance at its distance.
struct InnerBall<V> {
    f: [V; 3],
    r2: V,
    sure: V,
    slack: V,
}

impl<V: Lanes> InnerBall<V> {
    #[inline(always)]
    fn new(tok: V::Token, f: DVec3, r2: f64, sure: f64, slack: f64) -> InnerBall<V> {
        InnerBall {
            f: splat3(tok, f),
            r2: V::splat(tok, r2),
            sure: V::splat(tok, sure),
            slack: V::splat(tok, slack),
        }
    }

    /// The lanes whose ray, along unit `d`, gets from a sure hit a bound (the far end of where
    /// the hit can lie) nearer than `far`, the pixel's bound; and those bounds, positive, as
    /// `larger` needs. Each lane does the scalar steps in their order (glam's dot product, no
    /// fused multiply-add), so its bound is the bits a one-ray form finds.
    #[inline(always)]
    fn lowers(&self, d: [V; 3], far: V) -> (u8, V) {
        let b = dot(&self.f, &d);
        // f − d·b, the ray's closest approach to the centre.
        let g = [
            self.f[0].sub(d[0].mul(b)),
            self.f[1].sub(d[1].mul(b)),
            self.f[2].sub(d[2].mul(b)),
        ];
        let disc = self.r2.sub(dot(&g, &g));
        // A negative discriminant's root is NaN, in a lane `disc > sure` leaves. Where it is
        // taken, t > slack ≥ 0, so the bound is positive.
        let t = b.neg().sub(disc.sqrt());
        let bound = t.add(self.slack);
        let lowered = disc.gt(self.sure) & t.gt(self.slack) & bound.lt(far);
        (lowered, bound)
    }
}

/// The larger of `m` (a bound's bits) and `bound`'s bits. Every bound is positive (+∞, or a
/// hit's distance past `slack` plus `slack`, both not NaN) and a positive f64's bits order
/// as its value does, so this is `f64::max` without its handling of NaN: one instruction,
/// not a chain of four through every bound a rectangle reads.
#[inline(always)]
fn larger(m: u64, bound: f64) -> u64 {
    m.max(bound.to_bits())
}

#[cfg(test)]
mod tests {
    use super::{ceil, floor, larger, Bounds, InnerBall, Rect, BLOCK, BLOCKS, PIXELS_READ};
    use crate::render::lanes::{ForLanes, Lanes, LANES};
    use crate::render::simd::Simd;
    use glam::DVec3;

    /// `ceil` and `floor` of eight values on a path's lanes.
    struct Whole([f64; LANES]);

    impl ForLanes for Whole {
        type Output = ([f64; LANES], [f64; LANES]);
        fn run<V: Lanes>(self, tok: V::Token) -> Self::Output {
            let v = V::load(tok, &self.0);
            (ceil(v).store(), floor(v).store())
        }
    }

    /// On every path this CPU runs, `ceil` and `floor` are `f64::ceil` and `f64::floor` over
    /// [0, 2⁵¹]: whole numbers, halves (which the nearest rounds to even), one f64 either side
    /// of them, and fractions of every size.
    #[test]
    fn whole_pixels_in_lanes_are_ceil_and_floor() {
        let mut values = vec![0.0, f64::from_bits(1), 0.5, 2f64.powi(51)];
        for k in [
            1.0,
            2.0,
            3.0,
            127.0,
            128.0,
            1919.5,
            1e6,
            2f64.powi(40) + 0.5,
        ] {
            for v in [k, k + 0.5, k - 0.5, k + 0.25, k - 0.75] {
                values.extend([v, v.next_up(), v.next_down()]);
            }
        }
        let mut rng = crate::splitmix::SplitMix(0x00f1_00c5);
        values.extend((0..4000).map(|k| rng.unit() * 10f64.powi(k % 13 - 4)));
        values.retain(|&v| (0.0..=2f64.powi(51)).contains(&v));
        for simd in Simd::ALL.into_iter().filter(|s| s.supported()) {
            let isa = simd.isa().expect("a supported path");
            for chunk in values.chunks(LANES) {
                let mut v = [0.0; LANES];
                v[..chunk.len()].copy_from_slice(chunk);
                let (up, down) = isa.run(Whole(v));
                for l in 0..LANES {
                    assert_eq!(up[l], v[l].ceil(), "{} ceil {}", simd.name(), v[l]);
                    assert_eq!(down[l], v[l].floor(), "{} floor {}", simd.name(), v[l]);
                }
            }
        }
    }

    /// A sphere's inner ball and a pixel's ray as the one-ray form reads them.
    #[derive(Clone, Copy, Debug)]
    struct Ball {
        f: DVec3,
        r2: f64,
        sure: f64,
        slack: f64,
    }

    /// The bound a pixel's ray along unit `d` gets from a sure hit of `s`, if nearer than
    /// `far`: the one-ray form, in glam's f64.
    fn lowers_one(s: Ball, d: DVec3, far: f64) -> Option<f64> {
        let b = s.f.dot(d);
        let g = s.f - d * b;
        let disc = s.r2 - g.length_squared();
        if !(disc > s.sure) {
            return None;
        }
        let t = -b - disc.sqrt();
        (t > s.slack && t + s.slack < far).then_some(t + s.slack)
    }

    /// Eight rays and their pixels' bounds against one ball, on a path's lanes: the bounds of
    /// the lanes lowered, `None` elsewhere.
    struct Lower(Ball, [DVec3; LANES], [f64; LANES]);

    impl ForLanes for Lower {
        type Output = [Option<f64>; LANES];
        fn run<V: Lanes>(self, tok: V::Token) -> Self::Output {
            let Lower(s, d, far) = self;
            let ball = InnerBall::<V>::new(tok, s.f, s.r2, s.sure, s.slack);
            let column = |k: usize| V::load(tok, &d.map(|d| d[k]));
            let d = [column(0), column(1), column(2)];
            let (lowered, bound) = ball.lowers(d, V::load(tok, &far));
            let bound = bound.store();
            std::array::from_fn(|l| (lowered & 1 << l != 0).then_some(bound[l]))
        }
    }

    /// On every path this CPU runs, each lane lowers a pixel's bound to the very bits of the
    /// one-ray form, or leaves it as that form does: seeded balls, and rays that meet a ball,
    /// graze it and miss it, against bounds at +∞, at the bound the hit gives and one f64
    /// either side of it, and anywhere.
    #[test]
    fn the_lanes_lower_every_bound_as_one_ray_does() {
        let mut rng = crate::splitmix::SplitMix(0xb0d5);
        let mut cases = Vec::new();
        for _ in 0..20_000 {
            let dist = 1.0 + 1000.0 * rng.unit();
            let inner = dist * (0.001 + 0.5 * rng.unit());
            let toward = DVec3::new(rng.unit() - 0.5, rng.unit() - 0.5, rng.unit() - 0.5);
            let f = toward.normalize() * dist;
            let s = Ball {
                f,
                r2: inner * inner,
                sure: 1e-3 * inner * inner + 1e-12 * f.length_squared(),
                slack: 1e-6 * dist * rng.unit(),
            };
            // From the COP towards the centre (−f), turned by up to about twice the ball's
            // angular radius.
            let spread = 2.0 * inner / dist * rng.unit();
            let turn = DVec3::new(rng.unit() - 0.5, rng.unit() - 0.5, rng.unit() - 0.5) * spread;
            let d = (-f.normalize() + turn).normalize();
            let mut fars = vec![f64::INFINITY, 2.0 * dist * rng.unit()];
            if let Some(v) = lowers_one(s, d, f64::INFINITY) {
                fars.extend([v, v.next_up(), v.next_down()]);
            }
            cases.extend(fars.into_iter().map(|far| (s, d, far)));
        }
        let mut checked = 0;
        for simd in Simd::ALL.into_iter().filter(|s| s.supported()) {
            let isa = simd.isa().expect("a supported path");
            let (mut lowered, mut kept) = (0, 0);
            // Case k in lane k mod 8, the other lanes other cases' rays and bounds.
            for (k, &(s, d, far)) in cases.iter().enumerate() {
                let mut rays = [DVec3::ZERO; LANES];
                let mut fars = [0.0; LANES];
                for l in 0..LANES {
                    let (_, d, far) = cases[(k + l * 7919) % cases.len()];
                    (rays[l], fars[l]) = (d, far);
                }
                let l = k % LANES;
                (rays[l], fars[l]) = (d, far);
                let got = isa.run(Lower(s, rays, fars));
                for l in 0..LANES {
                    let want = lowers_one(s, rays[l], fars[l]);
                    assert_eq!(
                        got[l],
                        want,
                        "{}: {s:?} d {} far {}",
                        simd.name(),
                        rays[l],
                        fars[l]
                    );
                    lowered += usize::from(want.is_some());
                    kept += usize::from(want.is_none());
                }
                checked += 1;
            }
            assert!(
                lowered > 10_000 && kept > 10_000,
                "{lowered} lowered, {kept} kept"
            );
        }
        assert!(checked >= 40_000, "{checked} cases");
    }

    /// Eight shapes as a path's lanes read them, one array per number.
    struct Columns([[f32; 4]; LANES]);

    impl ForLanes for Columns {
        type Output = [[f64; LANES]; 4];
        fn run<V: Lanes>(self, tok: V::Token) -> Self::Output {
            let [x, y, z, r] = V::columns(tok, &self.0);
            [x.store(), y.store(), z.store(), r.store()]
        }
    }

    /// On every path this CPU runs, a group's shapes reach the lanes as each number converted
    /// by itself: row l's kth in lane l of the kth, bit for bit (signed zeros, subnormals,
    /// the largest f32, infinities).
    #[test]
    fn shapes_reach_the_lanes_as_each_number_converted() {
        let mut rng = crate::splitmix::SplitMix(0xc01);
        let special = [
            0.0,
            -0.0,
            f32::from_bits(1),
            -f32::MIN_POSITIVE,
            f32::MAX,
            f32::INFINITY,
            f32::NEG_INFINITY,
        ];
        for case in 0..1000 {
            let mut rows = [[0.0f32; 4]; LANES];
            for (i, v) in rows.iter_mut().flatten().enumerate() {
                *v = match (i + case) % 11 {
                    k if k < special.len() => special[k],
                    _ => ((rng.unit() - 0.5) * 1e6) as f32,
                };
            }
            let want: [[f64; LANES]; 4] = std::array::from_fn(|k| rows.map(|row| row[k].into()));
            for simd in Simd::ALL.into_iter().filter(|s| s.supported()) {
                let got = simd.isa().expect("a supported path").run(Columns(rows));
                let bits = |c: [[f64; LANES]; 4]| c.map(|c| c.map(f64::to_bits));
                assert_eq!(bits(got), bits(want), "{}: {rows:?}", simd.name());
            }
        }
    }

    /// `Bounds::most` of a rectangle on a path's lanes.
    struct Most<'a>(&'a Bounds, Rect);

    impl ForLanes for Most<'_> {
        type Output = f64;
        fn run<V: Lanes>(self, tok: V::Token) -> f64 {
            self.0.most::<V>(tok, self.1)
        }
    }

    /// On every path this CPU runs, `Bounds::most` over every rectangle of up to 6 × 6 pixels
    /// of an edge tile (5 × 7 blocks, the last ones cut by the raster), at every offset in a
    /// block: the largest of its pixels' bounds up to `PIXELS_READ` pixels, its blocks' beyond,
    /// whatever its shape.
    #[test]
    fn the_largest_bound_of_a_rectangle_is_its_pixels_or_its_blocks() {
        let tile = Rect {
            x0: 256,
            x1: 256 + 17,
            y0: 128,
            y1: 128 + 26,
        };
        let mut bounds = Bounds::new(tile);
        let mut rng = crate::splitmix::SplitMix(0x0b10c);
        for y in tile.y0..=tile.y1 {
            for x in tile.x0..=tile.x1 {
                let at = bounds.at(x, y);
                bounds.far[at] = match rng.unit() {
                    u if u < 0.1 => f64::INFINITY,
                    u => 1.0 + 100.0 * u,
                };
            }
        }
        let (bx1, by1) = ((tile.x1 - tile.x0) / BLOCK, (tile.y1 - tile.y0) / BLOCK);
        for by in 0..=by1 {
            for bx in 0..=bx1 {
                bounds.block[by * BLOCKS + bx] = f64::from_bits(bounds.largest_in_block(bx, by));
            }
        }
        let mut checked = 0;
        for y0 in tile.y0..=tile.y1 {
            for x0 in tile.x0..=tile.x1 {
                for y1 in y0..=(y0 + 5).min(tile.y1) {
                    for x1 in x0..=(x0 + 5).min(tile.x1) {
                        let r = Rect { x0, x1, y0, y1 };
                        let (mut pixels, mut blocks) = (0.0f64, 0.0f64);
                        for y in y0..=y1 {
                            for x in x0..=x1 {
                                pixels = pixels.max(bounds.far[bounds.at(x, y)]);
                                let b = (y - tile.y0) / BLOCK * BLOCKS + (x - tile.x0) / BLOCK;
                                blocks = blocks.max(bounds.block[b]);
                            }
                        }
                        let small = (x1 - x0 + 1) * (y1 - y0 + 1) <= PIXELS_READ;
                        let want = if small { pixels } else { blocks };
                        for simd in Simd::ALL.into_iter().filter(|s| s.supported()) {
                            let isa = simd.isa().expect("a supported path");
                            let got = isa.run(Most(&bounds, r));
                            let name = simd.name();
                            assert_eq!(got, want, "{name}: {x0}..={x1} × {y0}..={y1}");
                            checked += 1;
                        }
                    }
                }
            }
        }
        assert!(checked > 10_000, "{checked} rectangles");
    }

    /// Over the bounds the walk holds (positive: subnormal, normal, the largest finite, +∞),
    /// the larger of two bits is the bits of `f64::max`.
    #[test]
    fn larger_bits_are_the_larger_bound() {
        let mut values = vec![
            f64::from_bits(1),
            f64::MIN_POSITIVE,
            f64::MAX,
            f64::INFINITY,
        ];
        values.extend((-1074..=1023).step_by(7).map(|e| 2f64.powi(e)));
        values.extend((1..=40).map(|k| 1.0 + f64::from(k) * f64::EPSILON));
        values.extend((1..=40).map(|k| 1e6 * f64::from(k) / 7.0));
        for &a in &values {
            for &b in &values {
                assert_eq!(f64::from_bits(larger(a.to_bits(), b)), a.max(b), "{a} {b}");
            }
        }
    }
}
