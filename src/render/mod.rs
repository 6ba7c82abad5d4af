//! The ray caster: one frame of RGB8 pixels from a camera and a scene.
//!
//! Following the notes' "Tradeoff" (far fewer spheres than rays), the spheres and lights are
//! moved into view coordinates once per frame and every ray is cast in view coordinates from the
//! COP. That work is camera-relative in f64, so a scene far from the world origin keeps its
//! precision. Ray directions depend only on the COP, the window and the raster, so their offsets
//! are computed once and reused while those stay fixed.
//!
//! Every step (the hit, the shading, the shadow rays, adaptive sampling, the sRGB levels) is
//! written once, in packets (`packet.rs`); the plain one-ray-at-a-time oracle they are compared
//! with, pixel for pixel, lives in the tests (tests/it/reference.rs).
//!
//! Render does no file I/O.

use glam::{DVec2, DVec3};
use std::sync::{Arc, OnceLock};

use crate::camera::{window_point, Camera};
pub use crate::raster::Raster;
use crate::scene::{Scene, Sphere};

mod bins;
pub mod key;
mod lanes;
#[cfg(test)]
mod oracle;
mod packet;
mod rows;
mod shadows;
mod tiles;
mod world;

use lanes::{Isa, Lanes};
pub use packet::Simd;
use packet::{RowJob, LANES};
pub use world::SceneIndex;

use rows::rows_in_order;
use shadows::FrameShadows;
use tiles::TileBins;

/// Ray directions in view coordinates, for one COP, window and raster. Sample (sx, sy) of pixel
/// (i, j) leaves the COP towards window point (xs[i·s + sx], ys[j·s + sy]) relative to the COP,
/// at depth dz; the packets normalise that offset (`packet::unit`).
struct RayTable {
    cop_view: DVec3,
    window: DVec2,
    raster: Raster,
    xs: Vec<f64>,
    ys: Vec<f64>,
    dz: f64,
}

impl RayTable {
    fn new(cop_view: DVec3, window: DVec2, raster: Raster) -> RayTable {
        let s = raster.samples as usize;
        let size = (raster.width, raster.height);
        let offset = |k: usize| (k / s) as f64 + ((k % s) as f64 + 0.5) / s as f64;
        let xs = (0..raster.width as usize * s)
            .map(|k| window_point(window, size, offset(k), 0.0).x - cop_view.x)
            .collect();
        let ys = (0..raster.height as usize * s)
            .map(|k| window_point(window, size, 0.0, offset(k)).y - cop_view.y)
            .collect();
        RayTable {
            cop_view,
            window,
            raster,
            xs,
            ys,
            dz: -cop_view.z,
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
#[derive(Debug, Clone, Copy)]
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

/// The fields of the frame's view spheres that a packet whose lanes hit several spheres reads
/// lane by lane (`Lanes::gather`): one slice per field, in the order of the spheres.
struct ViewColumns {
    f: [Vec<f64>; 3],
    center: [Vec<f64>; 3],
    radius: Vec<f64>,
    color: [Vec<f64>; 3],
    /// The spheres' indices in the scene.
    id: Vec<u64>,
}

impl ViewColumns {
    fn new(spheres: &[ViewSphere]) -> ViewColumns {
        let column = |f: &dyn Fn(&ViewSphere) -> f64| spheres.iter().map(f).collect::<Vec<_>>();
        let xyz =
            |f: &dyn Fn(&ViewSphere) -> DVec3| [0, 1, 2].map(|a| column(&|s: &ViewSphere| f(s)[a]));
        ViewColumns {
            f: xyz(&|s| s.f),
            center: xyz(&|s| s.center),
            radius: column(&|s| s.radius),
            color: xyz(&|s| s.color),
            id: spheres.iter().map(|s| s.id as u64).collect(),
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
    /// `simd`'s instruction set, with the proof that this CPU runs it.
    isa: Isa,
}

impl Default for Renderer {
    fn default() -> Renderer {
        Renderer::new()
    }
}

impl Renderer {
    /// A renderer on the fastest instruction path this CPU runs.
    pub fn new() -> Renderer {
        let simd = Simd::detect();
        Renderer {
            table: None,
            simd,
            isa: simd.isa().expect("Simd::detect picks a path this CPU runs"),
        }
    }

    /// A renderer on instruction path `simd`, None if this CPU cannot run it. Every path gives
    /// the same bytes.
    pub fn with_simd(simd: Simd) -> Option<Renderer> {
        Some(Renderer {
            table: None,
            simd,
            isa: simd.isa()?,
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
        let table = match &self.table {
            Some(t) if t.fits(camera.cop_view, camera.window, raster) => Arc::clone(t),
            _ => Arc::new(RayTable::new(camera.cop_view, camera.window, raster)),
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
            isa: self.isa,
            raster,
            table,
            columns: ViewColumns::new(&spheres),
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
    isa: Isa,
    raster: Raster,
    table: Arc<RayTable>,
    spheres: Vec<ViewSphere>,
    columns: ViewColumns,
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
            columns: &self.columns,
            lights: &self.lights,
            ambient: self.ambient,
            background: self.background,
        };
        let adaptive = raster.adaptive && raster.samples >= 2;
        let width = raster.width as usize;
        let encode = srgb_encoder();
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
        let isa = self.isa;
        let render = |j, row: &mut [u8]| job.row(isa, j, row);
        rows_in_order(buffer, width * 3, rows, render, in_order);
    }
}

/// The frame's scene as the packets shade it: the spheres and lights in view coordinates.
struct Shading<'a> {
    spheres: &'a [ViewSphere],
    columns: &'a ViewColumns,
    lights: &'a [ViewLight<'a>],
    ambient: f64,
    background: DVec3,
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
    /// whose threshold interval holds the value, exactly. One value through the lanes' encoder
    /// (`encode_into`), the one copy of the rule; for values outside the packets (the
    /// background's levels, once a frame).
    pub fn encode(&self, linear: f64) -> u8 {
        let mut rgb = [0u8; 3 * LANES];
        self.encode_into(lanes::Portable::splat((), linear), &mut rgb, 0);
        rgb[0]
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
}
