//! The ray caster: one frame of RGB8 pixels from a camera and a scene.
//!
//! Following the notes' "Tradeoff" (far fewer spheres than rays), the spheres and lights are
//! moved into view coordinates once per frame and every ray is cast in view coordinates from the
//! COP. That work is camera-relative in f64, so a scene far from the world origin keeps its
//! precision. Ray directions depend only on the COP, the window and the raster, so they are
//! computed once and reused while those stay fixed.
//!
//! Render does no file I/O.

use glam::{DVec2, DVec3};
use rayon::prelude::*;
use std::sync::{Arc, OnceLock};

use crate::camera::{window_point, Camera};
pub use crate::raster::Raster;
use crate::raster::MAX_SAMPLES;
use crate::scene::{Scene, Sphere};

mod bins;
pub mod key;
mod lanes;
mod packet;
mod rows;
mod shadows;
mod tiles;
mod world;

pub use packet::Simd;
use packet::{RowJob, LANES};
pub use world::SceneIndex;

use rows::rows_in_order;
use shadows::FrameShadows;
use tiles::TileBins;

/// Largest number of sample directions kept in memory (96 MB); past it, directions are
/// normalised on the fly from the cached per-column and per-row offsets, to the same bits.
const CACHED_DIRECTIONS: usize = 1 << 22;

/// Ray directions in view coordinates, for one COP, window and raster. Sample (sx, sy) of pixel
/// (i, j) leaves the COP towards window point (xs[i·s + sx], ys[j·s + sy]) relative to the COP,
/// at depth dz; `dirs` holds the unit directions themselves (row-major pixels, each with its s×s
/// samples row-major) while they fit in [`CACHED_DIRECTIONS`].
struct RayTable {
    cop_view: DVec3,
    window: DVec2,
    raster: Raster,
    xs: Vec<f64>,
    ys: Vec<f64>,
    dz: f64,
    dirs: Option<Vec<DVec3>>,
}

impl RayTable {
    /// The table, with the directions cached when `cache` (the scalar and multi-sample paths
    /// read them; packets of single samples compute their own).
    fn new(cop_view: DVec3, window: DVec2, raster: Raster, cache: bool) -> RayTable {
        let limit = if cache { CACHED_DIRECTIONS } else { 0 };
        RayTable::with_cache_limit(cop_view, window, raster, limit)
    }

    fn with_cache_limit(cop_view: DVec3, window: DVec2, raster: Raster, limit: usize) -> RayTable {
        let s = raster.samples as usize;
        let size = (raster.width, raster.height);
        let offset = |k: usize| (k / s) as f64 + ((k % s) as f64 + 0.5) / s as f64;
        let xs = (0..raster.width as usize * s)
            .map(|k| window_point(window, size, offset(k), 0.0).x - cop_view.x)
            .collect();
        let ys = (0..raster.height as usize * s)
            .map(|k| window_point(window, size, 0.0, offset(k)).y - cop_view.y)
            .collect();
        let mut table = RayTable {
            cop_view,
            window,
            raster,
            xs,
            ys,
            dz: -cop_view.z,
            dirs: None,
        };
        let per_row = raster.width as usize * s * s;
        if per_row * raster.height as usize <= limit {
            let mut dirs = vec![DVec3::ZERO; per_row * raster.height as usize];
            dirs.par_chunks_mut(per_row)
                .enumerate()
                .for_each(|(j, row)| {
                    for (i, pixel) in row.chunks_exact_mut(s * s).enumerate() {
                        table.compute(i, j, pixel);
                    }
                });
            table.dirs = Some(dirs);
        }
        table
    }

    /// Computes pixel (i, j)'s s×s unit directions into `out`.
    #[inline]
    fn compute(&self, i: usize, j: usize, out: &mut [DVec3]) {
        let s = self.raster.samples as usize;
        for (k, d) in out.iter_mut().enumerate() {
            let (sy, sx) = (k / s, k % s);
            *d = DVec3::new(self.xs[i * s + sx], self.ys[j * s + sy], self.dz).normalize();
        }
    }

    /// Pixel (i, j)'s s×s unit directions: from the cache, or computed into `scratch`.
    #[inline]
    fn pixel<'a>(&'a self, i: usize, j: usize, scratch: &'a mut [DVec3]) -> &'a [DVec3] {
        let s2 = (self.raster.samples * self.raster.samples) as usize;
        match &self.dirs {
            Some(dirs) => {
                let start = (j * self.raster.width as usize + i) * s2;
                &dirs[start..start + s2]
            }
            None => {
                self.compute(i, j, &mut scratch[..s2]);
                &scratch[..s2]
            }
        }
    }

    fn fits(&self, cop_view: DVec3, window: DVec2, raster: Raster) -> bool {
        // Adaptive sampling does not change the directions.
        let same = |a: Raster, b: Raster| {
            a.width == b.width && a.height == b.height && a.samples == b.samples
        };
        self.cop_view == cop_view && self.window == window && same(self.raster, raster)
    }
}

/// A sphere in view coordinates, with the terms every primary ray shares.
// C layout: packets read its fields by offset (`lanes.rs`).
#[derive(Debug, Clone, Copy)]
#[repr(C)]
struct ViewSphere {
    center: DVec3,
    radius: f64,
    radius2: f64,
    /// COP − centre.
    f: DVec3,
    /// |f|² − r².
    c: f64,
    /// |f| − r: no primary ray meets the sphere nearer than this.
    min_dist: f64,
    color: DVec3,
    /// The sphere's index in the scene.
    id: u32,
}

impl ViewSphere {
    /// The unit normal and the point where the primary ray along unit `d` meets the sphere at
    /// distance `t`. The hit relative to the centre, f + t·d, has length r; the normal is that
    /// over r.
    #[inline(always)]
    fn surface(&self, d: DVec3, t: f64) -> (DVec3, DVec3) {
        let rel = self.f + d * t;
        (rel / self.radius, self.center + rel)
    }

    /// `sphere` moved camera-relative into view coordinates: the VRP is subtracted first, so a
    /// scene far from the origin keeps its precision.
    fn new(camera: &Camera, sphere: &Sphere, id: u32) -> ViewSphere {
        let center = camera.point_to_view(sphere.center_world);
        let f = camera.cop_view - center;
        let radius2 = sphere.radius * sphere.radius;
        ViewSphere {
            center,
            radius: sphere.radius,
            radius2,
            f,
            c: f.length_squared() - radius2,
            min_dist: f.length() - sphere.radius,
            color: sphere.color,
            id,
        }
    }
}

/// A light in view coordinates.
struct ViewLight<'a> {
    /// Unit vector from a surface towards the light: −direction.
    to_light: DVec3,
    color: DVec3,
    /// Spheres binned for this light's shadow rays; None when the light casts no shadows.
    shadows: Option<FrameShadows<'a>>,
}

/// Renders frames, keeping the ray table between frames.
pub struct Renderer {
    table: Option<Arc<RayTable>>,
    simd: Simd,
}

impl Default for Renderer {
    fn default() -> Renderer {
        Renderer::new()
    }
}

impl Renderer {
    /// A renderer on the fastest instruction path this CPU runs.
    pub fn new() -> Renderer {
        Renderer {
            table: None,
            simd: Simd::detect(),
        }
    }

    /// A renderer on instruction path `simd`, None if this CPU cannot run it. Every path gives
    /// the same bytes.
    pub fn with_simd(simd: Simd) -> Option<Renderer> {
        simd.supported().then(|| Renderer {
            simd,
            ..Renderer::new()
        })
    }

    /// The instruction path in use.
    pub fn simd(&self) -> Simd {
        self.simd
    }

    /// Renders one frame to RGB8, row-major, top row first. Each row is rendered by one task into
    /// its own slice, so the bytes do not depend on the thread count.
    pub fn render(&mut self, camera: &Camera, scene: &Scene, raster: Raster) -> Vec<u8> {
        self.render_indexed(camera, &SceneIndex::new(scene), raster)
    }

    /// [`Renderer::render`] with the scene indexed once for many frames: a frame then costs
    /// O(visible spheres + log N) before its rays.
    pub fn render_indexed(
        &mut self,
        camera: &Camera,
        index: &SceneIndex,
        raster: Raster,
    ) -> Vec<u8> {
        let mut pixels = Vec::new();
        self.render_indexed_into(camera, index, raster, &mut pixels, &mut |_| {});
        pixels
    }

    /// [`Renderer::render_indexed`] into `pixels`, every byte of which is written, whatever it
    /// held: a frame buffer can be reused without the cost of fresh zeroed pages. A buffer of
    /// another length is replaced by a fresh one. `in_order` sees the frame's rows once each, in
    /// order, as they are finished.
    pub fn render_indexed_into(
        &mut self,
        camera: &Camera,
        index: &SceneIndex,
        raster: Raster,
        pixels: &mut Vec<u8>,
        in_order: &mut (dyn FnMut(&[u8]) + Send),
    ) {
        self.prepare(camera, index, raster)
            .render_into(pixels, in_order);
    }

    /// Everything frame `camera` needs before its rays: the spheres in view moved into view
    /// coordinates, the lights' shadow work, the tile lists. A run prepares the next frame
    /// while this one's rows render.
    pub fn prepare<'a>(
        &mut self,
        camera: &Camera,
        index: &'a SceneIndex,
        raster: Raster,
    ) -> PreparedFrame<'a> {
        let scene = index.scene;
        // Every path but `Scalar` casts in packets, whatever the sampling.
        let packets = self.simd != Simd::Scalar;
        let table = match &self.table {
            Some(t) if t.fits(camera.cop_view, camera.window, raster) => Arc::clone(t),
            _ => Arc::new(RayTable::new(
                camera.cop_view,
                camera.window,
                raster,
                !packets,
            )),
        };
        self.table = Some(Arc::clone(&table));
        let spheres: Vec<ViewSphere> = index
            .visible(camera)
            .into_iter()
            .map(|k| ViewSphere::new(camera, &scene.spheres[k as usize], k))
            .collect();
        // Shadow work only for lights that cast shadows and scenes with something to cast them.
        let shadowed = index.shadows.iter().any(Option::is_some);
        let centers: Option<Arc<[(DVec3, f64)]>> =
            (shadowed && scene.spheres.len() <= shadows::ALL_CENTERS).then(|| {
                let center = |s| shadows::view_center(camera, s);
                scene.spheres.iter().map(center).collect()
            });
        let lights: Vec<ViewLight> = scene
            .lights
            .iter()
            .zip(&index.shadows)
            .map(|(l, grid)| {
                let to_light = -camera.basis.to_view(l.direction_world);
                ViewLight {
                    to_light,
                    color: l.color,
                    shadows: grid.as_ref().map(|g| {
                        let all = centers.clone();
                        FrameShadows::new(g, camera, &scene.spheres, all, to_light)
                    }),
                }
            })
            .collect();
        let bins = TileBins::build(&spheres, &table, raster);
        PreparedFrame {
            simd: self.simd,
            raster,
            table,
            spheres,
            lights,
            bins,
            ambient: scene.ambient,
            background: scene.background,
        }
    }
}

/// Rows in the ring of [`PreparedFrame::render_through`]: enough that rendering seldom waits
/// for the rows ahead to be handed on, few enough to stay in the caches (368 KB at 1920 wide).
pub const RING_ROWS: usize = 64;

/// A frame made ready for its rays by [`Renderer::prepare`].
pub struct PreparedFrame<'a> {
    simd: Simd,
    raster: Raster,
    table: Arc<RayTable>,
    spheres: Vec<ViewSphere>,
    lights: Vec<ViewLight<'a>>,
    bins: TileBins,
    ambient: f64,
    background: DVec3,
}

impl PreparedFrame<'_> {
    /// How many spheres the frame has inside its view pyramid (the rest were culled by the
    /// scene's hierarchy without being moved into view coordinates).
    pub fn in_view(&self) -> usize {
        self.spheres.len()
    }

    /// Renders the frame into `pixels` (see [`Renderer::render_indexed_into`]), each row by one
    /// task into its own slice, so the bytes do not depend on the thread count.
    pub fn render_into(&self, pixels: &mut Vec<u8>, in_order: &mut (dyn FnMut(&[u8]) + Send)) {
        if pixels.len() != self.raster.frame_bytes() {
            // Fresh zeroed pages (calloc), faulted in by the threads that write the rows, not
            // zeroed here on one thread first.
            *pixels = vec![0u8; self.raster.frame_bytes()];
        }
        self.render_rows(pixels, in_order);
    }

    /// Renders the frame's rows through `ring`, a buffer of at most [`RING_ROWS`] rows reused
    /// from row to row, for a consumer that needs each row only once, in order (`in_order`):
    /// the frame's pixels are never all in memory at once.
    pub fn render_through(&self, ring: &mut Vec<u8>, in_order: &mut (dyn FnMut(&[u8]) + Send)) {
        let row_bytes = self.raster.width as usize * 3;
        let bytes = RING_ROWS.min(self.raster.height as usize) * row_bytes;
        if ring.len() != bytes {
            *ring = vec![0u8; bytes];
        }
        self.render_rows(ring, in_order);
    }

    /// Every row, into `buffer` (the frame, or a ring of whole rows).
    fn render_rows(&self, buffer: &mut [u8], in_order: &mut (dyn FnMut(&[u8]) + Send)) {
        let (raster, table, bins) = (self.raster, &*self.table, &self.bins);
        let rows = raster.height as usize;
        let ctx = Shading {
            spheres: &self.spheres,
            lights: &self.lights,
            ambient: self.ambient,
            background: self.background,
        };
        let s2 = (raster.samples * raster.samples) as usize;
        let adaptive = raster.adaptive && raster.samples >= 2;
        let width = raster.width as usize;
        let encode = srgb_encoder();
        if self.simd != Simd::Scalar {
            let job = RowJob {
                ctx: &ctx,
                table,
                bins,
                encode,
                background: [self.background.to_array().map(|c| encode.encode(c)); LANES]
                    .concat()
                    .try_into()
                    .expect("LANES pixels"),
                samples: raster.samples as usize,
                adaptive,
            };
            let simd = self.simd;
            let render = |j, row: &mut [u8]| job.row(simd, j, row);
            rows_in_order(buffer, width * 3, rows, render, in_order);
            return;
        }
        rows_in_order(
            buffer,
            width * 3,
            rows,
            |j, row: &mut [u8]| {
                let mut scratch = [DVec3::ZERO; (MAX_SAMPLES * MAX_SAMPLES) as usize];
                for (i, px) in row.chunks_exact_mut(3).enumerate() {
                    let samples = table.pixel(i, j, &mut scratch);
                    let candidates = bins.at(i, j);
                    let c = if adaptive {
                        ctx.pixel_adaptive(samples, raster.samples as usize, candidates)
                    } else {
                        let mut sum = DVec3::ZERO;
                        for d in samples {
                            sum += ctx.shade(*d, candidates).0;
                        }
                        sum / s2 as f64
                    };
                    px[0] = encode.encode(c.x);
                    px[1] = encode.encode(c.y);
                    px[2] = encode.encode(c.z);
                }
            },
            in_order,
        );
    }
}

struct Shading<'a> {
    spheres: &'a [ViewSphere],
    lights: &'a [ViewLight<'a>],
    ambient: f64,
    background: DVec3,
}

/// What a sample saw: the sphere (or `u64::MAX` for the background) in the high bits and, in
/// the low 32, which lights reach the point. Adaptive sampling compares these.
type Seen = u64;

impl Shading<'_> {
    /// One pixel's s×s `samples` with adaptive refinement: the four corners first, the whole
    /// grid only where they disagree on what they see.
    fn pixel_adaptive(&self, samples: &[DVec3], s: usize, candidates: &[u32]) -> DVec3 {
        let corners = [0, s - 1, s * (s - 1), s * s - 1];
        let shaded = corners.map(|k| self.shade(samples[k], candidates));
        if shaded.iter().all(|(_, seen)| *seen == shaded[0].1) {
            return (shaded[0].0 + shaded[1].0 + shaded[2].0 + shaded[3].0) / 4.0;
        }
        let mut sum = DVec3::ZERO;
        for (k, d) in samples.iter().enumerate() {
            sum += match corners.iter().position(|&c| c == k) {
                Some(n) => shaded[n].0,
                None => self.shade(*d, candidates).0,
            };
        }
        sum / (s * s) as f64
    }

    /// Linear colour seen along unit direction `d` from the COP, among `candidates` (sphere
    /// indices, nearest possible hit first), and what was seen.
    #[inline]
    fn shade(&self, d: DVec3, candidates: &[u32]) -> (DVec3, Seen) {
        let Some((index, t)) = self.nearest(d, candidates) else {
            return (self.background, u64::MAX);
        };
        let s = &self.spheres[index];
        let mut seen = (index as u64) << 32;
        if self.lights.is_empty() {
            // Flat: no normal, no light loop.
            return (self.color(index, DVec3::splat(self.ambient)), seen);
        }
        let (normal, point) = s.surface(d, t);
        let mut light = DVec3::splat(self.ambient);
        for (n, l) in self.lights.iter().enumerate() {
            let facing = normal.dot(l.to_light);
            if facing <= 0.0 {
                continue;
            }
            if let Some(grid) = &l.shadows {
                if grid.occluded(point, s.id) {
                    continue;
                }
            }
            light += l.color * facing;
            seen |= 1 << n.min(31);
        }
        (self.color(index, light), seen)
    }

    /// Sphere `index`'s linear colour under `light` (the ambient plus the lights reaching it).
    #[inline(always)]
    fn color(&self, index: usize, light: DVec3) -> DVec3 {
        let c = self.spheres[index].color * light;
        if self.lights.is_empty() {
            c.min(DVec3::ONE)
        } else {
            c.clamp(DVec3::ZERO, DVec3::ONE)
        }
    }

    /// The nearest hit in front of the COP among `candidates`, as (sphere index, distance). The
    /// candidates come nearest-first, so the search stops once none left can be nearer.
    #[inline]
    fn nearest(&self, d: DVec3, candidates: &[u32]) -> Option<(usize, f64)> {
        let mut best: Option<(usize, f64)> = None;
        for &k in candidates {
            let s = &self.spheres[k as usize];
            if best.is_some_and(|(_, bt)| s.min_dist >= bt) {
                break;
            }
            if let Some(t) = nearest_positive_root(s.f, s.c, s.radius2, d) {
                if best.is_none_or(|(_, bt)| t < bt) {
                    best = Some((k as usize, t));
                }
            }
        }
        best
    }
}

/// The smallest t > 0 with |f + t·d| = r for unit `d`, where `f` = origin − centre and
/// `c` = |f|² − r²; None if the ray misses or the sphere is behind.
///
/// The numerically stable form (Haines et al., "Precision Improvements for Ray/Sphere
/// Intersection", Ray Tracing Gems ch. 7): the discriminant from |f − (f·d)d|² instead of
/// b² − c, and the root q = −(b + sign(b)√Δ) with the other root c/q, so neither root is the
/// difference of two nearly equal numbers.
#[inline]
pub fn nearest_positive_root(f: DVec3, c: f64, radius2: f64, d: DVec3) -> Option<f64> {
    let b = f.dot(d);
    let g = f - d * b;
    let disc = radius2 - g.length_squared();
    if disc < 0.0 {
        return None;
    }
    let q = -(b + disc.sqrt().copysign(b));
    if q == 0.0 {
        return None;
    }
    let (t0, t1) = (c / q, q);
    let (near, far) = if t0 < t1 { (t0, t1) } else { (t1, t0) };
    if near > 0.0 {
        Some(near)
    } else if far > 0.0 {
        Some(far)
    } else {
        None
    }
}

/// Exact sRGB quantisation: the linear value at which each 8-bit level begins.
pub struct SrgbEncoder {
    /// `thresholds[k]` is the linear value whose encoding is level k + ½; the last entry is a
    /// sentinel above 1.
    thresholds: [f64; 256],
    /// `buckets[b]`: the level of the linear value b / BUCKETS, plus [`SPLIT`] when a threshold
    /// falls inside the bucket (values in it are that level or the next).
    buckets: Box<[u16; BUCKETS + 1]>,
}

/// Buckets of the linear range, a power of two so that x·BUCKETS is exact and its floor is the
/// bucket of x. Consecutive thresholds are at least 1/(255·12.92) ≈ 3.0e-4 apart (the linear
/// toe is the steepest part), far more than a bucket's 1.5e-5: a bucket holds at most one
/// threshold, and only 255 of the 65,536 hold one, so nearly every value is looked up with no
/// comparison at all.
const BUCKETS: usize = 1 << 16;

/// The flag of a bucket that a threshold splits.
const SPLIT: u16 = 0x100;

impl SrgbEncoder {
    fn new() -> SrgbEncoder {
        let mut thresholds = [f64::INFINITY; 256];
        for (k, t) in thresholds.iter_mut().take(255).enumerate() {
            *t = srgb_decode((k as f64 + 0.5) / 255.0);
        }
        let mut buckets = Box::new([0u16; BUCKETS + 1]);
        let mut level = 0;
        for (b, entry) in buckets.iter_mut().enumerate() {
            // The level of b / BUCKETS: the thresholds at or below it.
            let start = b as f64 / BUCKETS as f64;
            while thresholds[level] <= start {
                level += 1;
            }
            let end = (b + 1) as f64 / BUCKETS as f64;
            let split = thresholds[level] < end && b < BUCKETS;
            *entry = level as u16 | if split { SPLIT } else { 0 };
        }
        SrgbEncoder {
            thresholds,
            buckets,
        }
    }

    /// Linear [0, 1] to the nearest 8-bit sRGB level (values outside are clamped): the level
    /// whose threshold interval holds the value, exactly.
    #[inline]
    pub fn encode(&self, linear: f64) -> u8 {
        let x = linear.clamp(0.0, 1.0);
        // Truncation is floor here: x ≥ 0. NaN clamps to… NaN, and `as` maps it to bucket 0.
        // The `min` only spares a bounds check: x ≤ 1 already.
        let entry = self.buckets[((x * BUCKETS as f64) as usize).min(BUCKETS)];
        self.finish(entry, x)
    }

    /// The level of `x` from its bucket's entry: the bucket's level, or the next one when x
    /// is at or above the threshold that splits the bucket.
    #[inline(always)]
    fn finish(&self, entry: u16, x: f64) -> u8 {
        let level = entry as u8;
        if entry & SPLIT == 0 {
            level
        } else {
            level + (x >= self.thresholds[level as usize]) as u8
        }
    }
}

/// The shared encoder; built once with libm, so it is the same on every platform.
pub fn srgb_encoder() -> &'static SrgbEncoder {
    static ENCODER: OnceLock<SrgbEncoder> = OnceLock::new();
    ENCODER.get_or_init(SrgbEncoder::new)
}

/// sRGB transfer function, encoded [0, 1] to linear [0, 1] (IEC 61966-2-1).
pub fn srgb_decode(e: f64) -> f64 {
    if e <= 0.04045 {
        e / 12.92
    } else {
        libm::pow((e + 0.055) / 1.055, 2.4)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::Basis;
    use crate::scene::Light;

    /// Renders with every sphere tested for every ray (primary and shadow), in index order.
    fn brute_force(camera: &Camera, scene: &Scene, raster: Raster) -> Vec<u8> {
        let mut r = Renderer::with_simd(Simd::Scalar).unwrap();
        let fast = r.render(camera, scene, raster);
        let table = r.table.take().unwrap();
        let dirs = table.dirs.clone().unwrap();
        let spheres: Vec<ViewSphere> = scene
            .spheres
            .iter()
            .enumerate()
            .map(|(k, s)| ViewSphere::new(camera, s, k as u32))
            .collect();
        let enc = srgb_encoder();
        let s2 = (raster.samples * raster.samples) as usize;
        let mut out = Vec::with_capacity(fast.len());
        for samples in dirs.chunks(s2) {
            let mut sum = DVec3::ZERO;
            for d in samples {
                let mut best: Option<(usize, f64)> = None;
                for (k, s) in spheres.iter().enumerate() {
                    if let Some(t) = nearest_positive_root(s.f, s.c, s.radius2, *d) {
                        if best.is_none_or(|(_, bt)| t < bt) {
                            best = Some((k, t));
                        }
                    }
                }
                sum += match best {
                    None => scene.background,
                    Some((k, t)) => {
                        let s = &spheres[k];
                        let rel = s.f + *d * t;
                        let normal = rel / s.radius;
                        let point = s.center + rel;
                        let mut light = DVec3::splat(scene.ambient);
                        for l in &scene.lights {
                            let to_light = -camera.basis.to_view(l.direction_world);
                            let facing = normal.dot(to_light);
                            let shadowed = l.shadows
                                && spheres.iter().enumerate().any(|(o, os)| {
                                    o != k
                                        && shadows::blocks_ray(
                                            os.center, os.radius2, point, to_light,
                                        )
                                });
                            if facing > 0.0 && !shadowed {
                                light += l.color * facing;
                            }
                        }
                        (s.color * light).clamp(DVec3::ZERO, DVec3::ONE)
                    }
                };
            }
            let c = sum / s2 as f64;
            out.extend([enc.encode(c.x), enc.encode(c.y), enc.encode(c.z)]);
        }
        out
    }

    #[test]
    fn uncached_directions_are_the_cached_bits() {
        let raster = Raster {
            width: 37,
            height: 23,
            samples: 3,
            adaptive: false,
        };
        let (cop, window) = (DVec3::new(0.3, -0.2, -1.7), DVec2::new(1.9, 1.1));
        let cached = RayTable::with_cache_limit(cop, window, raster, usize::MAX);
        let computed = RayTable::with_cache_limit(cop, window, raster, 0);
        assert!(cached.dirs.is_some() && computed.dirs.is_none());
        let mut a = [DVec3::ZERO; 9];
        let mut b = [DVec3::ZERO; 9];
        for j in 0..23 {
            for i in 0..37 {
                let x = cached.pixel(i, j, &mut a).to_vec();
                assert_eq!(x, computed.pixel(i, j, &mut b));
                // And the notes' pixel formula, sample by sample.
                for (k, d) in x.iter().enumerate() {
                    let px = i as f64 + ((k % 3) as f64 + 0.5) / 3.0;
                    let py = j as f64 + ((k / 3) as f64 + 0.5) / 3.0;
                    let expect = (window_point(window, (37, 23), px, py) - cop).normalize();
                    assert_eq!(*d, expect);
                }
            }
        }
    }

    #[test]
    fn tiles_and_shadow_grid_give_the_brute_force_bytes() {
        let mut gen = crate::splitmix::SplitMix(7);
        let mut spheres: Vec<Sphere> = (0..300)
            .map(|_| {
                let mut r = || gen.unit();
                Sphere {
                    center_world: DVec3::new(r() * 40.0 - 20.0, r() * 6.0, r() * 40.0 - 20.0),
                    radius: 0.2 + r() * 1.5,
                    color: DVec3::new(r(), r(), r()),
                }
            })
            .collect();
        spheres.push(Sphere {
            center_world: DVec3::new(0.0, -1000.0, 0.0),
            radius: 1000.0,
            color: DVec3::splat(0.6),
        });
        let scene = Scene {
            background: DVec3::new(0.1, 0.1, 0.2),
            ambient: 0.1,
            lights: vec![
                Light {
                    direction_world: DVec3::new(-1.0, -2.0, 1.0).normalize(),
                    color: DVec3::splat(0.8),
                    shadows: true,
                },
                Light {
                    direction_world: DVec3::new(1.0, -0.3, 0.2).normalize(),
                    color: DVec3::splat(0.3),
                    shadows: true,
                },
            ],
            spheres,
        };
        let raster = Raster {
            width: 96,
            height: 64,
            samples: 2,
            adaptive: false,
        };
        let cameras = [
            // Outside the field, looking in.
            (
                DVec3::new(0.0, 8.0, -40.0),
                DVec3::new(0.0, -0.2, 1.0),
                DVec3::new(0.0, 0.0, -1.0),
            ),
            // Inside the field, off-axis COP, spheres on all sides and behind.
            (
                DVec3::new(1.0, 2.0, 0.0),
                DVec3::new(1.0, -0.1, 0.3),
                DVec3::new(0.3, -0.2, -0.8),
            ),
            // Inside the ground sphere's neighbourhood, looking down.
            (
                DVec3::new(-5.0, 0.5, 3.0),
                DVec3::new(0.2, -1.0, 0.1),
                DVec3::new(0.0, 0.0, -1.5),
            ),
        ];
        // Every path but `Scalar` casts one sample, and 2×2 or 3×3 samples averaged, in packets.
        let one = Raster {
            samples: 1,
            ..raster
        };
        let three = Raster {
            samples: 3,
            ..raster
        };
        for (k, (vrp, vpn, cop)) in cameras.into_iter().enumerate() {
            let camera = Camera {
                vrp_world: vrp,
                basis: Basis::from_vpn_vuv(vpn, DVec3::Y).unwrap(),
                cop_view: cop,
                window: DVec2::new(1.5, 1.0),
            };
            for raster in [raster, one, three] {
                let slow = brute_force(&camera, &scene, raster);
                for simd in Simd::ALL.into_iter().filter(|s| s.supported()) {
                    let fast = Renderer::with_simd(simd)
                        .unwrap()
                        .render(&camera, &scene, raster);
                    let differ = fast.iter().zip(&slow).filter(|(a, b)| a != b).count();
                    let name = simd.name();
                    assert_eq!(
                        differ, 0,
                        "camera {k}, {raster:?}, {name}: {differ} bytes differ"
                    );
                }
            }
        }
    }

    /// A reused frame buffer keeps none of its old bytes: rendered over a buffer of 0xa5 (or
    /// of the wrong size), every path and kind of sampling gives the fresh frame.
    #[test]
    fn a_reused_buffer_is_overwritten_everywhere() {
        let scene = Scene {
            background: DVec3::new(0.2, 0.3, 0.5),
            ambient: 0.1,
            lights: vec![Light {
                direction_world: DVec3::new(-1.0, -2.0, 1.0).normalize(),
                color: DVec3::splat(0.8),
                shadows: true,
            }],
            spheres: vec![Sphere {
                center_world: DVec3::ZERO,
                radius: 1.0,
                color: DVec3::new(0.9, 0.4, 0.1),
            }],
        };
        let camera = Camera {
            vrp_world: DVec3::new(0.0, 0.5, -4.0),
            basis: Basis::from_vpn_vuv(DVec3::Z, DVec3::Y).unwrap(),
            cop_view: DVec3::new(0.0, 0.0, -1.5),
            window: DVec2::new(1.6, 0.9),
        };
        let index = SceneIndex::new(&scene);
        for (samples, adaptive) in [(1, false), (3, false), (4, true)] {
            // 261 pixels a row: a stretch, and packets, end inside the row.
            let raster = Raster {
                width: 261,
                height: 7,
                samples,
                adaptive,
            };
            for simd in Simd::ALL.into_iter().filter(|s| s.supported()) {
                let mut r = Renderer::with_simd(simd).unwrap();
                let fresh = r.render_indexed(&camera, &index, raster);
                for mut buffer in [vec![0xa5; fresh.len()], vec![0xa5; 5], Vec::new()] {
                    let mut seen = Vec::new();
                    let mut in_order = |row: &[u8]| seen.extend_from_slice(row);
                    r.render_indexed_into(&camera, &index, raster, &mut buffer, &mut in_order);
                    assert!(buffer == fresh, "{} {raster:?}", simd.name());
                    assert!(seen == fresh, "{} {raster:?}", simd.name());
                }
            }
        }
    }

    #[test]
    fn srgb_levels_match_the_formula() {
        let enc = srgb_encoder();
        // Independent: the forward sRGB formula, rounded.
        let forward = |x: f64| {
            let e = if x <= 0.0031308 {
                12.92 * x
            } else {
                1.055 * x.powf(1.0 / 2.4) - 0.055
            };
            (e * 255.0).round() as u8
        };
        for k in 0..=1000 {
            let x = k as f64 / 1000.0;
            assert_eq!(enc.encode(x), forward(x), "x = {x}");
        }
        assert_eq!(enc.encode(0.0), 0);
        assert_eq!(enc.encode(1.0), 255);
        assert_eq!(enc.encode(0.5), 188);
        assert_eq!(enc.encode(-1.0), 0);
        assert_eq!(enc.encode(2.0), 255);
        // Exactly at and just below every threshold, and at both ends of every bucket,
        // against the plain binary search.
        let slow = |x: f64| enc.thresholds.partition_point(|&th| th <= x) as u8;
        for k in 0..255 {
            let t = srgb_decode((k as f64 + 0.5) / 255.0);
            for x in [t, t.next_down(), t.next_up()] {
                assert_eq!(enc.encode(x), slow(x), "x = {x}");
            }
        }
        for b in 0..=BUCKETS {
            let start = b as f64 / BUCKETS as f64;
            for x in [start, start.next_down(), start.next_up()] {
                assert_eq!(enc.encode(x), slow(x.clamp(0.0, 1.0)), "x = {x}");
            }
        }
        // 255 buckets are split, one by each threshold.
        let split = enc.buckets.iter().filter(|&&e| e & SPLIT != 0).count();
        assert_eq!(split, 255);
    }

    #[test]
    fn roots_match_the_textbook_quadratic() {
        // Unit sphere at (0, 0, 5), ray from the origin along +z: hits at 4 and 6.
        let f = DVec3::new(0.0, 0.0, -5.0);
        let t = nearest_positive_root(f, f.length_squared() - 1.0, 1.0, DVec3::Z).unwrap();
        assert!((t - 4.0).abs() < 1e-15);
        // From inside: the far root.
        let f = DVec3::new(0.0, 0.0, -0.5);
        let t = nearest_positive_root(f, f.length_squared() - 1.0, 1.0, DVec3::Z).unwrap();
        assert!((t - 1.5).abs() < 1e-15);
        // Behind: none.
        let f = DVec3::new(0.0, 0.0, 5.0);
        assert_eq!(
            nearest_positive_root(f, f.length_squared() - 1.0, 1.0, DVec3::Z),
            None
        );
        // Miss.
        let f = DVec3::new(2.0, 0.0, -5.0);
        assert_eq!(
            nearest_positive_root(f, f.length_squared() - 1.0, 1.0, DVec3::Z),
            None
        );
    }

    #[test]
    fn stable_roots_keep_a_tiny_sphere_far_away() {
        // r = 1e-3 at distance 1e4 along a slightly oblique ray; the naive b² − c loses every
        // digit of the discriminant here. Closed form: t = D·cosθ − sqrt(r² − D² sin²θ).
        let dist = 1e4;
        let offset = 0.5e-3;
        let f = DVec3::new(0.0, -offset, -dist);
        let d = DVec3::Z;
        let r: f64 = 1e-3;
        let t = nearest_positive_root(f, f.length_squared() - r * r, r * r, d).unwrap();
        let expect = dist - (r * r - offset * offset).sqrt();
        assert!((t - expect).abs() < 1e-9, "{t} vs {expect}");
    }
}
