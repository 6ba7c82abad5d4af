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
//! Nothing here is compared to decide a pixel: every test is a bound widened by far more than
//! its rounding (see [`Slack`]), so it errs on the side of keeping. The walk runs only at one
//! sample a pixel, where a pixel's ray is the one through its centre.

// `!(a > b)` is meant: a NaN takes the branch that keeps (or does not lower a bound).
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use glam::DVec3;
use rayon::prelude::*;
use std::sync::atomic::{AtomicU64, Ordering};

use super::lanes::prefetch;
use super::rays::RayTable;
use super::world::{shape_inner, SceneIndex};
use crate::camera::Camera;

/// Side in pixels of a culling tile: its pixels' bounds are its walk's state (32 KB, in the
/// first-level cache). Each tile walks the hierarchy's upper levels again: tiles of 32 pixels
/// culled ten million spheres at 640×360 in 170–195 ms a frame, of 64 in 130–160 ms, of 128
/// (blocks of 8) in 155–195 ms.
pub const CULL_TILE: usize = 64;

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
    /// Each pixel's ray direction as a unit vector, row by row: `DVec3::normalize` of
    /// (xs[x], ys[y], dz), found once a frame rather than once a sphere and pixel.
    units: Vec<DVec3>,
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
        let units = table
            .ys
            .par_iter()
            .flat_map_iter(|&y| {
                table
                    .xs
                    .iter()
                    .map(move |&x| DVec3::new(x, y, table.dz).normalize())
            })
            .collect();
        View {
            camera,
            cop_world,
            table,
            units,
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

    /// No ray from the COP meets the world box (lo, hi) nearer than this.
    fn near_box(&self, lo: DVec3, hi: DVec3) -> f64 {
        let p = self.cop_world;
        let gap = (lo - p).max(p - hi).max(DVec3::ZERO);
        gap.length() - self.slack - SLACK * (lo.abs().max(hi.abs()).max_element())
    }
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
    pub(super) fn unhidden(&self, camera: &Camera, table: &RayTable) -> Vec<u32> {
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
        (0..tiles).into_par_iter().with_max_len(1).for_each(|t| {
            let (tx, ty) = (t % across * CULL_TILE, t / across * CULL_TILE);
            let tile = Rect {
                x0: tx,
                x1: (tx + CULL_TILE).min(w) - 1,
                y0: ty,
                y1: (ty + CULL_TILE).min(h) - 1,
            };
            self.walk(&view, tile, &kept);
        });
        let mut out = Vec::new();
        for (k, word) in kept.0.iter().enumerate() {
            let mut bits = word.load(Ordering::Relaxed);
            while bits != 0 {
                let at = k * 64 + bits.trailing_zeros() as usize;
                out.push(order[at]);
                bits &= bits - 1;
            }
        }
        out
    }

    /// One tile's walk: see the module's documentation.
    fn walk(&self, view: &View, tile: Rect, kept: &Kept) {
        let (nodes, shapes, _) = self.tree();
        let camera = view.camera;
        let cop = camera.cop_view;
        let basis = &camera.basis;
        // Each pixel's bound: no nearer sphere than its nearest hit lies beyond it; and the
        // largest in each block of BLOCK² pixels, which a rectangle's test reads.
        let mut far = [f64::INFINITY; CULL_TILE * CULL_TILE];
        let mut block = [f64::INFINITY; BLOCKS * BLOCKS];
        let at = |x: usize, y: usize| (y - tile.y0) * CULL_TILE + (x - tile.x0);
        let blocks = |r: Rect| {
            let (bx0, bx1) = ((r.x0 - tile.x0) / BLOCK, (r.x1 - tile.x0) / BLOCK);
            let (by0, by1) = ((r.y0 - tile.y0) / BLOCK, (r.y1 - tile.y0) / BLOCK);
            (bx0, bx1, by0, by1)
        };
        let most = |far: &[f64], block: &[f64], r: Rect| {
            let mut m = f64::NEG_INFINITY;
            if (r.x1 - r.x0 + 1) * (r.y1 - r.y0 + 1) <= PIXELS_READ {
                for y in r.y0..=r.y1 {
                    for x in r.x0..=r.x1 {
                        m = m.max(far[at(x, y)]);
                    }
                }
                return m;
            }
            let (bx0, bx1, by0, by1) = blocks(r);
            for by in by0..=by1 {
                for bx in bx0..=bx1 {
                    m = m.max(block[by * BLOCKS + bx]);
                }
            }
            m
        };
        let abs_rows = [basis.u.abs(), basis.v.abs(), basis.n.abs()];
        let w = view.table.raster.width as usize;
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
            let bound = most(&far, &block, rect);
            if near > bound {
                continue;
            }
            if node.count == 0 {
                // The nearer child on top.
                let (a, b) = (k + 1, node.start);
                // Each child's own children (or spheres) asked for now: the walk is bound by
                // their reads, and one of the two is popped next.
                let near_of = |j: u32| {
                    let child = &nodes[j as usize];
                    if child.count == 0 {
                        prefetch(&nodes[j as usize + 1]);
                        prefetch(&nodes[child.start as usize]);
                    } else {
                        prefetch(&shapes[child.start as usize]);
                    }
                    let [lo, hi] = child.bounds();
                    view.near_box(lo, hi)
                };
                let (na, nb) = (near_of(a), near_of(b));
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
            for (j, shape) in shapes[first..first + node.count as usize]
                .iter()
                .enumerate()
            {
                // The sphere lies inside the ball of radius r and holds the ball of radius
                // `inner` around `center`.
                let c = DVec3::new(shape[0] as f64, shape[1] as f64, shape[2] as f64);
                let center = camera.point_to_view(c);
                let r = shape[3] as f64;
                let f = cop - center;
                let dist = f.length();
                let slack = view.slack + SLACK * (dist + r + center.abs().max_element());
                if dist - r - slack > bound {
                    continue;
                }
                let Some(rect) = view.rect(center, DVec3::splat(r), tile) else {
                    continue;
                };
                if dist - r - slack > most(&far, &block, rect) {
                    continue;
                }
                let inner = shape_inner(shape);
                kept.set(first + j);
                // Where this sphere is met for sure, the pixel's nearest hit is no farther
                // than the far end of where this hit can lie.
                let mut lowered = false;
                let (r2, sure) = (
                    inner * inner,
                    1e-3 * inner * inner + 1e-12 * f.length_squared(),
                );
                // Only from a COP clearly outside the sphere: from inside it (or within rounding
                // of its surface) the search takes the far root, however soon the ray enters
                // the inner ball.
                if !(inner > 0.0) || !(dist - r > slack) {
                    continue;
                }
                for y in rect.y0..=rect.y1 {
                    for x in rect.x0..=rect.x1 {
                        let d = view.units[y * w + x];
                        let b = f.dot(d);
                        let g = f - d * b;
                        let disc = r2 - g.length_squared();
                        if !(disc > sure) {
                            continue;
                        }
                        let t = -b - disc.sqrt();
                        if t > slack {
                            let p = &mut far[at(x, y)];
                            *p = p.min(t + slack);
                            lowered = true;
                        }
                    }
                }
                if lowered {
                    // The blocks the sphere's pixels lie in, found again: a block's largest
                    // bound can only have fallen.
                    let (bx0, bx1, by0, by1) = blocks(rect);
                    for by in by0..=by1 {
                        for bx in bx0..=bx1 {
                            let (x0, y0) = (tile.x0 + bx * BLOCK, tile.y0 + by * BLOCK);
                            let mut m = f64::NEG_INFINITY;
                            for y in y0..(y0 + BLOCK).min(tile.y1 + 1) {
                                for x in x0..(x0 + BLOCK).min(tile.x1 + 1) {
                                    m = m.max(far[at(x, y)]);
                                }
                            }
                            block[by * BLOCKS + bx] = m;
                        }
                    }
                }
            }
        }
    }
}
