//! The ray caster: one frame of RGB8 pixels from a camera and a scene.
//!
//! Following the notes' "Tradeoff" (far fewer spheres than rays), the spheres and lights are
//! moved into view coordinates once per frame and every ray is cast in view coordinates from the
//! COP. That work is camera-relative in f64, so a scene far from the world origin keeps its
//! precision. Ray directions depend only on the COP, the window and the raster, so their offsets
//! are computed once and reused while those stay fixed.
//!
//! Every step (the ray directions, the hit, the shading, the shadow rays, adaptive sampling, the
//! sRGB levels) is written once, in packets of `lanes`; the plain one-ray-at-a-time oracle they
//! are compared with, pixel for pixel, lives in the tests (tests/it/reference.rs). This file is
//! the orchestration: a frame prepared (spheres and lights into view coordinates, shadow work,
//! tiles), then its rows handed to the row drivers (`drivers.rs`) on the rayon pool. A frame
//! with motion blur is prepared once per time sample, and each of its rows is the mean of those
//! renders' rows in linear light (`shutter.rs`).
//!
//! Render does no file I/O.

use glam::DVec3;
use std::sync::Arc;

use crate::camera::Camera;
pub use crate::raster::Raster;
use crate::scene::{Scene, Spheres};

mod bins;
mod cull;
mod drivers;
mod kernels;
#[allow(unsafe_code)]
mod lanes;
#[cfg(test)]
mod oracle;
mod rays;
mod rows;
mod shadows;
mod shutter;
#[allow(unsafe_code)]
mod simd;
mod sort;
mod srgb;
mod tiles;
mod tree;
mod view;
mod world;

pub use simd::Simd;
pub use srgb::{srgb_decode, srgb_encoder};
pub use world::SceneIndex;

use drivers::{RowJob, BAND};
use kernels::Shading;
use lanes::LANES;
use rays::RayTable;
use rows::{rows_in_order, Bands};
use shadows::{Casters, FrameShadows};
use simd::Isa;
use tiles::TileBins;
use view::{ViewColumns, ViewLight};
use world::{CULL_RATIO, FIRST_CULL_RATIO};

/// Renders frames, keeping the ray table and the culling walk's seeds between frames, and the
/// view columns of frames handed back ([`Renderer::recycle`]) for the next to write over.
pub struct Renderer {
    table: Option<Arc<RayTable>>,
    simd: Simd,
    /// `simd`'s instruction set, with the proof that this CPU runs it.
    isa: Isa,
    spare: Vec<ViewColumns>,
    /// Spheres a pixel from which a frame culls the hidden ones ([`CULL_RATIO`]), and from
    /// which the renderer's first frame does ([`FIRST_CULL_RATIO`]).
    cull_ratio: f64,
    first_cull_ratio: f64,
    /// Whether a frame was prepared.
    prepared: bool,
    /// What the last frame that culled leaves the next one's walk to start from.
    seeds: cull::Seeds,
}

impl Default for Renderer {
    fn default() -> Renderer {
        Renderer::new()
    }
}

impl Renderer {
    /// A renderer on the fastest instruction path this CPU runs.
    pub fn new() -> Renderer {
        Renderer::with_simd(Simd::detect()).expect("Simd::detect picks a path this CPU runs")
    }

    /// A renderer on instruction path `simd`, None if this CPU cannot run it. Every path gives
    /// the same bytes.
    pub fn with_simd(simd: Simd) -> Option<Renderer> {
        Some(Renderer {
            table: None,
            simd,
            isa: simd.isa()?,
            spare: Vec::new(),
            cull_ratio: CULL_RATIO,
            first_cull_ratio: FIRST_CULL_RATIO,
            prepared: false,
            seeds: cull::Seeds::default(),
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
    /// order, as they are finished, a band of up to [`BAND`] rows at a call.
    pub fn render_indexed_into(
        &mut self,
        camera: &Camera,
        index: &SceneIndex,
        raster: Raster,
        pixels: &mut Vec<u8>,
        in_order: &mut (dyn FnMut(&[u8]) + Send),
    ) {
        let frame = self.prepare(camera, index, raster);
        frame.render_into(pixels, in_order);
        self.recycle(frame);
    }

    /// Takes back a rendered frame's view columns, for the frames prepared after it to write
    /// over instead of asking the system for fresh memory.
    pub fn recycle(&mut self, frame: PreparedFrame) {
        self.spare
            .extend(frame.times.into_iter().map(|t| t.spheres));
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
        self.prepare_times(std::slice::from_ref(camera), index, raster)
    }

    /// A frame that is the mean of its renders through `cameras` (motion blur: one camera per
    /// time sample, in time order), each prepared as [`Renderer::prepare`] does; with one
    /// camera, exactly that frame. Its rows average the time samples' linear colours in the
    /// order of `cameras` and quantise the mean once. Panics without a camera.
    pub fn prepare_times<'a>(
        &mut self,
        cameras: &[Camera],
        index: &'a SceneIndex,
        raster: Raster,
    ) -> PreparedFrame<'a> {
        assert!(!cameras.is_empty(), "a frame has at least one camera");
        // A renderer's first frame does not wait for the shadow grids: its shadow rays walk
        // the hierarchy, and the next frame builds them.
        let tree_shadows = !self.prepared && !index.shadow_grids_built();
        let times = cameras
            .iter()
            .map(|camera| self.prepare_time(camera, index, raster, tree_shadows))
            .collect();
        PreparedFrame {
            isa: self.isa,
            raster,
            times,
            ambient: index.scene.ambient,
            background: index.scene.background,
        }
    }

    /// One camera's part of a frame: see [`Renderer::prepare`].
    fn prepare_time<'a>(
        &mut self,
        camera: &Camera,
        index: &'a SceneIndex,
        raster: Raster,
        tree_shadows: bool,
    ) -> TimeSample<'a> {
        let scene = index.scene;
        let table = match &self.table {
            Some(t) if t.fits(camera.cop_view, camera.window, raster) => Arc::clone(t),
            _ => Arc::new(RayTable::new(camera.cop_view, camera.window, raster)),
        };
        self.table = Some(Arc::clone(&table));
        // The spheres by rank (see `SceneIndex`), moved into view coordinates straight into
        // their columns.
        let ranked = index.spheres();
        // From `cull_ratio` spheres a pixel (`first_cull_ratio` in the first frame, whose walk
        // has no seeds), only those that may own a pixel (`cull.rs`).
        let ratio = match self.prepared {
            true => self.cull_ratio,
            false => self.first_cull_ratio,
        };
        self.prepared = true;
        let visible = if index.culls(raster, ratio) {
            index.unhidden(self.isa, camera, &table, &mut self.seeds)
        } else {
            index.visible(camera)
        };
        let spheres = ViewColumns::of(camera, ranked, &visible, self.spare.pop());
        drop(visible);
        // Shadow work only for lights that cast shadows and scenes with something to cast them.
        let shadowed = index.casts_shadows();
        let centers: Option<Arc<[(DVec3, f64)]>> =
            (shadowed && ranked.len() <= shadows::ALL_CENTERS).then(|| {
                let center = |k| shadows::view_center(camera, ranked.ball(k));
                (0..ranked.len()).map(center).collect()
            });
        let lights: Vec<ViewLight> = scene
            .lights
            .iter()
            .enumerate()
            .map(|(n, l)| {
                let to_light = -camera.basis.to_view(l.direction_world);
                let casters = match tree_shadows {
                    true => index.shadows_through_tree(n),
                    false => index.shadow_grid(n).map(Casters::Grid),
                };
                ViewLight {
                    to_light,
                    color: l.color,
                    shadows: casters.map(|casters| {
                        let all = centers.clone();
                        FrameShadows::new(self.isa, casters, camera, ranked, all, to_light)
                    }),
                }
            })
            .collect();
        let bins = TileBins::build(self.isa, &spheres, index.ranks(), &table, raster);
        TimeSample {
            ranked,
            table,
            spheres,
            lights,
            bins,
        }
    }
}

/// Rows in the ring of [`PreparedFrame::render_through`], at least: enough that rendering
/// seldom waits for the rows ahead to be handed on, few enough to stay in the caches (368 KB
/// at 1920 wide). With many threads, more ([`ring_rows`]).
pub const RING_ROWS: usize = 64;

/// Bands in the ring per thread of the pool, at least: a thread waits for a slot only when
/// the band that held it is not yet handed on, and a band ahead can be slow.
const RING_BANDS_PER_THREAD: usize = 8;

const _: () = assert!(RING_ROWS.is_multiple_of(BAND));

/// The rows of [`PreparedFrame::render_through`]'s ring for a pool of `threads` and a frame
/// `height` rows high: whole bands, or the frame if it is shorter.
pub fn ring_rows(threads: usize, height: u32) -> usize {
    RING_ROWS
        .max(RING_BANDS_PER_THREAD * BAND * threads)
        .min(height as usize)
}

/// A frame made ready for its rays by [`Renderer::prepare`] or [`Renderer::prepare_times`].
pub struct PreparedFrame<'a> {
    isa: Isa,
    raster: Raster,
    /// The scene seen by each camera of the frame: one, or one per time sample.
    times: Vec<TimeSample<'a>>,
    ambient: f64,
    background: DVec3,
}

/// The scene as one camera of a frame sees it, ready for its rays.
struct TimeSample<'a> {
    /// The scene's spheres by rank, which the columns' and shadow grids' indices are.
    ranked: &'a Spheres,
    table: Arc<RayTable>,
    spheres: ViewColumns,
    lights: Vec<ViewLight<'a>>,
    bins: TileBins,
}

impl PreparedFrame<'_> {
    /// How many spheres the frame has inside its view pyramid (the rest were culled by the
    /// scene's hierarchy without being moved into view coordinates); with several time
    /// samples, the most any of them has.
    pub fn in_view(&self) -> usize {
        self.times
            .iter()
            .map(|t| t.spheres.len())
            .max()
            .unwrap_or(0)
    }

    /// How many view spheres the frame holds, over all its time samples: what its view data's
    /// memory grows with.
    pub fn view_spheres(&self) -> usize {
        self.times.iter().map(|t| t.spheres.len()).sum()
    }

    /// How many renders the frame averages: 1, or its time samples.
    pub fn renders(&self) -> usize {
        self.times.len()
    }

    /// Renders the frame into `pixels` (see [`Renderer::render_indexed_into`]), each band of
    /// rows by one task into its own slice, so the bytes do not depend on the thread count.
    pub fn render_into(&self, pixels: &mut Vec<u8>, in_order: &mut (dyn FnMut(&[u8]) + Send)) {
        if pixels.len() != self.raster.frame_bytes() {
            // Fresh zeroed pages (calloc), faulted in by the threads that write the rows, not
            // zeroed here on one thread first.
            *pixels = vec![0u8; self.raster.frame_bytes()];
        }
        self.render_rows(pixels, in_order);
    }

    /// Renders the frame's rows through `ring`, a buffer of a few whole bands ([`ring_rows`])
    /// reused from band to band, for a consumer that needs each row only once, in order
    /// (`in_order`): the frame's pixels are never all in memory at once.
    pub fn render_through(&self, ring: &mut Vec<u8>, in_order: &mut (dyn FnMut(&[u8]) + Send)) {
        let row_bytes = self.raster.width as usize * 3;
        let bytes = ring_rows(rayon::current_num_threads(), self.raster.height) * row_bytes;
        if ring.len() != bytes {
            *ring = vec![0u8; bytes];
        }
        self.render_rows(ring, in_order);
    }

    /// Every row, into `buffer` (the frame, or a ring of whole bands).
    fn render_rows(&self, buffer: &mut [u8], in_order: &mut (dyn FnMut(&[u8]) + Send)) {
        let raster = self.raster;
        let rows = raster.height as usize;
        let width = raster.width as usize;
        let contexts: Vec<Shading> = self
            .times
            .iter()
            .map(|t| Shading {
                spheres: &t.spheres,
                scene: t.ranked,
                lights: &t.lights,
                ambient: self.ambient,
                background: self.background,
            })
            .collect();
        let encode = srgb_encoder();
        let level = self.background.to_array().map(|c| encode.encode(c));
        let background = [level; LANES].concat().try_into().expect("LANES pixels");
        let jobs: Vec<RowJob> = self
            .times
            .iter()
            .zip(&contexts)
            .map(|(t, ctx)| RowJob {
                ctx,
                table: &t.table,
                bins: &t.bins,
                encode,
                background,
                samples: raster.samples as usize,
                adaptive: raster.adaptive && raster.samples >= 2,
            })
            .collect();
        let isa = self.isa;
        let bands = Bands {
            row_bytes: width * 3,
            rows,
            band: BAND,
        };
        let render = |j, band: &mut [u8]| match &jobs[..] {
            [job] => job.band(isa, j, band),
            _ => shutter::mean_band(isa, &jobs, j, band),
        };
        rows_in_order(buffer, bands, render, in_order);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::Basis;
    use crate::scene::Light;
    use crate::scene::{Scene, Sphere, Spheres};
    use glam::DVec2;

    /// `spheres` under one shadowed light.
    fn lit(spheres: Vec<Sphere>) -> Scene {
        Scene {
            background: DVec3::new(0.2, 0.3, 0.5),
            ambient: 0.1,
            lights: vec![Light {
                direction_world: DVec3::new(-1.0, -2.0, 1.0).normalize(),
                color: DVec3::splat(0.8),
                shadows: true,
            }],
            spheres: spheres.into(),
        }
    }

    /// Frames prepared over an earlier frame's columns are the frames prepared in fresh ones,
    /// as the camera moves in and out of the spheres and its COP moves.
    #[test]
    fn frames_written_over_recycled_columns_are_the_frames_rendered_fresh() {
        let spheres = (0..60)
            .map(|k| Sphere {
                center_world: DVec3::new((k % 10) as f64 - 4.5, (k / 10) as f64 * 0.8, 0.0),
                radius: 0.3 + 0.01 * k as f64,
                color: DVec3::new(0.2 + 0.01 * k as f64, 0.5, 0.9 - 0.01 * k as f64),
            })
            .collect();
        let scene = lit(spheres);
        // From afar (every sphere in view), close up (a few), and afar again; the COP moved
        // (zoom, distort) between frames, from which the columns find f.
        let at = |z: f64, (x, y, n): (f64, f64, f64)| Camera {
            vrp_world: DVec3::new(0.3, 2.0, z),
            basis: Basis::from_vpn_vuv(DVec3::Z, DVec3::Y).unwrap(),
            cop_view: DVec3::new(x, y, n),
            window: DVec2::new(1.6, 0.9),
        };
        let cameras = [
            at(-14.0, (0.0, 0.0, -1.5)),
            at(-1.5, (0.0, 0.0, -1.5)),
            at(-1.0, (0.2, -0.1, -1.2)),
            at(-16.0, (-0.3, 0.1, -2.0)),
            at(-1.5, (0.1, 0.2, -1.5)),
        ];
        let raster = Raster {
            width: 96,
            height: 54,
            samples: 1,
            adaptive: false,
        };
        let index = SceneIndex::new(&scene);
        let in_view: Vec<usize> = cameras.iter().map(|c| index.visible(c).len()).collect();
        assert!(in_view[0] == 60 && in_view[1] < 20, "{in_view:?}");
        let mut reused = Renderer::new();
        for camera in &cameras {
            let fresh = Renderer::new().render_indexed(camera, &index, raster);
            assert!(reused.render_indexed(camera, &index, raster) == fresh);
            assert_eq!(reused.spare.len(), 1);
        }
    }

    /// Spheres numbered along the index's curve (its copy, whole or packed, see `SceneIndex`)
    /// give the frames of spheres numbered as in the scene, on every instruction path, and a
    /// ray that meets two spheres at the same distance sees the one first in the scene,
    /// whichever comes first on the curve: two equal spheres mirrored about the view axis meet
    /// the middle column's rays at the same distance (where they overlap), listed in both
    /// orders; and a seeded cluster.
    #[test]
    fn spheres_by_rank_render_the_frames_of_the_scenes_order() {
        let (red, green) = (DVec3::new(0.9, 0.1, 0.1), DVec3::new(0.1, 0.9, 0.1));
        let twin = |x: f64, color| Sphere {
            center_world: DVec3::new(x, 0.0, 0.0),
            radius: 0.8,
            color,
        };
        let mut rng = crate::splitmix::SplitMix(41);
        let cluster: Vec<Sphere> = (0..400)
            .map(|_| {
                let mut v = || rng.unit() * 2.0 - 1.0;
                Sphere {
                    center_world: DVec3::new(v() * 3.0, v(), v() * 3.0),
                    radius: 0.1 + 0.3 * v().abs(),
                    color: DVec3::new(v().abs(), v().abs(), v().abs()),
                }
            })
            .collect();
        // Each scene, the colour its middle pixel shows (if a tie decides it), and whether the
        // curve takes its spheres in another order (the twins left to right).
        let scenes = [
            (vec![twin(0.5, red), twin(-0.5, green)], Some(red), true),
            (vec![twin(-0.5, green), twin(0.5, red)], Some(green), false),
            (cluster, None, true),
        ];
        let camera = Camera {
            vrp_world: DVec3::new(0.0, 0.0, -5.0),
            basis: Basis::from_vpn_vuv(DVec3::Z, DVec3::Y).unwrap(),
            cop_view: DVec3::new(0.0, 0.0, -1.5),
            window: DVec2::new(1.6, 0.9),
        };
        // An odd width: the middle column's rays run in the plane x = 0.
        let raster = Raster {
            width: 65,
            height: 37,
            samples: 1,
            adaptive: false,
        };
        for (spheres, first, reordered) in scenes {
            let scene = lit(spheres.clone());
            let whole = lit(Vec::new());
            let whole = Scene {
                spheres: Spheres::wide(spheres),
                ..whole
            };
            // Copied whole, copied packed (past `copy_max`), and not copied (whole spheres past
            // it: a rank is the scene index).
            let copied = SceneIndex::copying_up_to(&scene, usize::MAX);
            let packed = SceneIndex::copying_up_to(&scene, 0);
            let in_place = SceneIndex::copying_up_to(&whole, 0);
            let ranks = |index: &SceneIndex| -> Vec<u32> {
                (0..scene.spheres.len() as u32)
                    .map(|r| index.ranks().scene_index(r))
                    .collect()
            };
            assert_eq!(ranks(&copied).windows(2).any(|w| w[0] > w[1]), reordered);
            assert_eq!(ranks(&packed), ranks(&copied));
            assert!(ranks(&in_place).windows(2).all(|w| w[0] < w[1]));
            for simd in Simd::ALL.into_iter().filter(|s| s.supported()) {
                let mut r = Renderer::with_simd(simd).unwrap();
                let frame = r.render_indexed(&camera, &copied, raster);
                assert!(frame == r.render_indexed(&camera, &packed, raster));
                assert!(frame == r.render_indexed(&camera, &in_place, raster));
                if let Some(color) = first {
                    // The middle pixel is the first sphere's: its colour's strongest channel.
                    let at = (18 * 65 + 32) * 3;
                    let (pixel, strongest) =
                        (&frame[at..at + 3], if color.x > 0.5 { 0 } else { 1 });
                    assert!(pixel[strongest] > pixel[1 - strongest], "{pixel:?}");
                }
            }
        }
    }

    /// Frames that keep only the spheres that may own a pixel (`cull.rs`) are the frames of
    /// every sphere in view, on every instruction path: a dense cluster on a ground seen from
    /// outside, from inside (spheres around, behind and holding the COP), through a shifted and
    /// a zoomed COP; twins at the same place (ties); the cluster a million times smaller, a
    /// million times larger, a million units from the origin, among f32's subnormals and past
    /// f32's range; each kept whole or packed (copied along the curve, an f32 sphere its own
    /// shape); rasters whose tiles end inside them. Each path's culling renderer renders
    /// them all in turn, so every walk starts from the seeds of another scene, camera or raster;
    /// each shot from outside is rendered twice, the second from its own seeds. And the walk
    /// does cull: outside the cluster it keeps a fraction, and from its own seeds fewer.
    #[test]
    fn frames_of_the_unhidden_spheres_are_the_frames_of_every_sphere_in_view() {
        let mut rng = crate::splitmix::SplitMix(58);
        let mut cluster: Vec<Sphere> = (0..6000)
            .map(|_| {
                let mut v = || rng.unit() * 2.0 - 1.0;
                Sphere {
                    center_world: DVec3::new(v() * 4.0, v() + 1.2, v() * 4.0),
                    radius: 0.05 + 0.1 * v().abs(),
                    color: DVec3::new(v().abs(), v().abs(), v().abs()),
                }
            })
            .collect();
        // Twins: the same sphere twice, and one at its place with another colour.
        for k in 0..40 {
            let mut twin = cluster[k * 7];
            cluster.push(twin);
            twin.color = DVec3::new(0.9, 0.1, 0.1);
            cluster.push(twin);
        }
        // Small buried spheres below the horizon of the COP that starts inside the ground.
        for k in 0..60 {
            cluster.push(Sphere {
                center_world: DVec3::new(
                    (k % 10) as f64 * 0.2 - 1.0,
                    -0.05 * (2.0 + (k / 10) as f64) - 0.01,
                    2.0 + (k / 10) as f64,
                ),
                radius: 0.04,
                color: DVec3::new(0.1, 0.3, 0.9),
            });
        }
        let with_ground = |spheres: &[Sphere], scale: f64, offset: DVec3| {
            let mut all: Vec<Sphere> = spheres
                .iter()
                .map(|s| Sphere {
                    center_world: s.center_world * scale + offset,
                    radius: s.radius * scale,
                    color: s.color,
                })
                .collect();
            all.push(Sphere {
                center_world: DVec3::new(0.0, -1000.0, 0.0) * scale + offset,
                radius: 1000.0 * scale,
                color: DVec3::new(0.5, 0.5, 0.45),
            });
            lit(all)
        };
        let camera = |vrp: DVec3, vpn: DVec3, cop: DVec3, scale: f64, offset: DVec3| Camera {
            vrp_world: vrp * scale + offset,
            basis: Basis::from_vpn_vuv(vpn, DVec3::Y).unwrap(),
            cop_view: cop * scale,
            window: DVec2::new(1.6, 0.9) * scale,
        };
        let outside = (DVec3::new(-3.0, 2.5, -9.0), DVec3::new(0.3, -0.15, 1.0));
        let inside = (DVec3::new(0.2, 1.1, -0.3), DVec3::new(-0.4, 0.1, 1.0));
        // The COP half a thousandth inside the ground, within the f32 shape's rounding of its
        // surface, looking a little down at small buried spheres: the ground's hit is its far
        // side, and the buried spheres are nearer.
        let (vpn, cop_world) = (DVec3::new(0.0, -0.05, 1.0), DVec3::new(0.0, -5e-4, 0.0));
        let buried = (cop_world + vpn.normalize(), vpn);
        let shots = [
            (buried, DVec3::new(0.0, 0.0, -1.0)),
            (outside, DVec3::new(0.0, 0.0, -1.5)),
            (outside, DVec3::new(0.5, -0.3, -1.2)),
            (outside, DVec3::new(0.0, 0.0, -6.0)),
            (inside, DVec3::new(0.0, 0.0, -1.0)),
            (inside, DVec3::new(-0.3, 0.2, -0.4)),
        ];
        let rasters = [(97, 61), (200, 140), (33, 17)].map(|(width, height)| Raster {
            width,
            height,
            samples: 1,
            adaptive: false,
        });
        // Each scene's spheres as given (their colours not levels: kept whole, not copied
        // along the curve); rounded to f32 values and levels (copied packed, each sphere its own
        // shape); or so rounded but for the ground's radius (packed, the copy's shapes made).
        #[derive(PartialEq)]
        enum Form {
            Given,
            F32,
            Mixed,
        }
        // Beside the everyday scales: f32's subnormals (the walk's shapes lose their digits)
        // and past f32's range (its shapes are infinite).
        let places = [
            (1.0, DVec3::ZERO, Form::Given),
            (1.0, DVec3::ZERO, Form::F32),
            (1.0, DVec3::ZERO, Form::Mixed),
            (1e-6, DVec3::ZERO, Form::Given),
            (1e6, DVec3::ZERO, Form::Given),
            (1.0, DVec3::new(1e6, -3e5, 2e6), Form::Given),
            (1.0, DVec3::new(1e6, -3e5, 2e6), Form::Mixed),
            (1e-41, DVec3::ZERO, Form::Given),
            (1e-41, DVec3::ZERO, Form::F32),
            (1e40, DVec3::ZERO, Form::Given),
        ];
        let mut culled = Vec::new();
        let mut seeded = Vec::new();
        let mut culling: Vec<Renderer> = Simd::ALL
            .into_iter()
            .filter_map(Renderer::with_simd)
            .collect();
        for renderer in &mut culling {
            (renderer.cull_ratio, renderer.first_cull_ratio) = (0.0, 0.0);
        }
        for (scale, offset, form) in places {
            let mut scene = with_ground(&cluster, scale, offset);
            if form != Form::Given {
                let level = |c: DVec3| (c * 255.0).round() / 255.0;
                let last = scene.spheres.len() - 1;
                let rounded = scene.spheres.iter().enumerate().map(|(k, s)| Sphere {
                    center_world: s.center_world.as_vec3().as_dvec3(),
                    radius: match form == Form::Mixed && k == last {
                        true => s.radius * (1.0 + 1e-12),
                        false => f64::from(s.radius as f32),
                    },
                    color: level(s.color),
                });
                scene.spheres = rounded.collect();
            }
            let packed = scene.spheres.color_codes().is_some();
            let f32s = scene.spheres.f32_balls().is_some();
            assert_eq!((packed, f32s), (form != Form::Given, form == Form::F32));
            // Past the copy of whole spheres: the index that culls.
            let index = SceneIndex::copying_up_to(&scene, 0);
            assert!(index.can_cull());
            // The same scene with its grid left unbuilt: a renderer's first frame walks the
            // hierarchy for its shadow rays, until a second frame builds the grid.
            let waiting = SceneIndex::building(&scene, 0, true);
            for ((vrp, vpn), cop) in shots {
                let camera = camera(vrp, vpn, cop, scale, offset);
                for raster in rasters {
                    for kept in &mut culling {
                        let simd = kept.simd();
                        let mut all = Renderer::with_simd(simd).unwrap();
                        (all.cull_ratio, all.first_cull_ratio) = (f64::INFINITY, f64::INFINITY);
                        let every = all.render_indexed(&camera, &index, raster);
                        let at = format!("{} at {scale}, {offset}, {cop}, {raster:?}", simd.name());
                        let mut first = Renderer::with_simd(simd).unwrap();
                        let walked = first.render_indexed(&camera, &waiting, raster);
                        assert!(walked == every, "{at}, shadow rays through the hierarchy");
                        let render = |kept: &mut Renderer| {
                            let frame = kept.prepare(&camera, &index, raster);
                            let n = frame.in_view();
                            let mut pixels = Vec::new();
                            frame.render_into(&mut pixels, &mut |_| {});
                            assert!(pixels == every, "{at}, kept {n}");
                            n
                        };
                        let n = render(kept);
                        if vrp == outside.0 {
                            let everyday =
                                scale == 1.0 && offset == DVec3::ZERO && form == Form::Given;
                            seeded.push((n, render(kept), everyday));
                        }
                        if scale == 1.0 && offset == DVec3::ZERO && vrp == outside.0 {
                            culled.push((n, index.visible(&camera).len()));
                        }
                    }
                }
            }
            // Only first frames came from it: its grid is not built. A renderer's second frame
            // builds it, and is still the same frame.
            assert!(!waiting.shadow_grids_built());
            let ((vrp, vpn), cop) = shots[1];
            let camera = camera(vrp, vpn, cop, scale, offset);
            let mut all = Renderer::new();
            (all.cull_ratio, all.first_cull_ratio) = (f64::INFINITY, f64::INFINITY);
            let every = all.render_indexed(&camera, &index, rasters[0]);
            let mut twice = Renderer::new();
            for _ in 0..2 {
                assert!(twice.render_indexed(&camera, &waiting, rasters[0]) == every);
            }
            assert!(waiting.shadow_grids_built());
        }
        // Seen from outside, much of the cluster is hidden: at most half of it is kept, at
        // the smallest raster a tenth.
        assert!(culled.iter().all(|&(n, every)| n * 2 < every), "{culled:?}");
        assert!(
            culled.iter().any(|&(n, every)| n * 10 < every),
            "{culled:?}"
        );
        // A walk from its own frame's seeds starts from that walk's last bounds: it keeps no
        // more, and at the everyday scale a fifth fewer over the shots from outside (past
        // f32's range and among its subnormals the shapes cull nothing).
        assert!(seeded.iter().all(|&(n, again, _)| again <= n), "{seeded:?}");
        let (n, again) = seeded
            .iter()
            .filter(|s| s.2)
            .fold((0, 0), |(n, a), &(k, b, _)| (n + k, a + b));
        assert!(again * 5 <= n * 4, "{seeded:?}");
    }

    /// A renderer's first frame culls from [`FIRST_CULL_RATIO`] spheres a pixel, every later
    /// one from [`CULL_RATIO`]: between the two, the first frame keeps every sphere in view
    /// and the second fewer, with the same bytes.
    #[test]
    fn the_first_frame_culls_from_its_own_ratio() {
        let mut rng = crate::splitmix::SplitMix(4);
        let cluster: Vec<Sphere> = (0..3000)
            .map(|_| {
                let mut v = || rng.unit() * 2.0 - 1.0;
                Sphere {
                    center_world: DVec3::new(v(), v(), v()),
                    radius: 0.1,
                    color: DVec3::new(v().abs(), 0.5, 0.5),
                }
            })
            .collect();
        let scene = lit(cluster);
        let index = SceneIndex::copying_up_to(&scene, 0);
        // 3000 spheres over 700 pixels: 4.29 a pixel.
        let raster = Raster {
            width: 35,
            height: 20,
            samples: 1,
            adaptive: false,
        };
        let ratio = 3000.0 / 700.0;
        assert!((CULL_RATIO..FIRST_CULL_RATIO).contains(&ratio));
        let camera = looking_at_the_origin();
        let every = index.visible(&camera).len();
        let mut renderer = Renderer::new();
        let mut all = Renderer::new();
        all.cull_ratio = f64::INFINITY;
        let expected = all.render_indexed(&camera, &index, raster);
        for first in [true, false] {
            let frame = renderer.prepare(&camera, &index, raster);
            assert_eq!(
                frame.in_view() == every,
                first,
                "{} of {every}",
                frame.in_view()
            );
            let mut pixels = Vec::new();
            frame.render_into(&mut pixels, &mut |_| {});
            assert!(pixels == expected);
        }
    }

    /// A camera 4 units from the origin along −z, a little above it, looking along +z.
    fn looking_at_the_origin() -> Camera {
        Camera {
            vrp_world: DVec3::new(0.0, 0.5, -4.0),
            basis: Basis::from_vpn_vuv(DVec3::Z, DVec3::Y).unwrap(),
            cop_view: DVec3::new(0.0, 0.0, -1.5),
            window: DVec2::new(1.6, 0.9),
        }
    }

    /// Through the ring of [`ring_rows`], a hash-only run's, the consumer is handed every
    /// row of the frame rendered whole, in order: heights that end inside a band, at the ring's
    /// size and past it, with a band's last rows in the ring's first slot, on every path and
    /// kind of sampling.
    #[test]
    fn the_ring_hands_on_the_frame_rendered_whole() {
        let scene = lit(vec![
            Sphere {
                center_world: DVec3::ZERO,
                radius: 1.0,
                color: DVec3::new(0.9, 0.4, 0.1),
            },
            Sphere {
                center_world: DVec3::new(0.8, 0.9, -0.4),
                radius: 0.4,
                color: DVec3::new(0.2, 0.7, 0.3),
            },
        ]);
        let camera = looking_at_the_origin();
        let index = SceneIndex::new(&scene);
        for height in [1, 3, 6, 63, 64, 65, 67, 130] {
            for (samples, adaptive) in [(1, false), (2, true)] {
                let raster = Raster {
                    width: 37,
                    height,
                    samples,
                    adaptive,
                };
                for simd in Simd::ALL.into_iter().filter(|s| s.supported()) {
                    let mut r = Renderer::with_simd(simd).unwrap();
                    let whole = r.render_indexed(&camera, &index, raster);
                    let frame = r.prepare(&camera, &index, raster);
                    let (mut ring, mut seen) = (Vec::new(), Vec::new());
                    frame
                        .render_through(&mut ring, &mut |rows: &[u8]| seen.extend_from_slice(rows));
                    let at = format!("height {height}, {samples} samples, {}", simd.name());
                    let rows = ring_rows(rayon::current_num_threads(), height);
                    assert_eq!(ring.len(), rows * 37 * 3, "{at}");
                    assert!(seen == whole, "{at}: the ring's rows differ");
                }
            }
        }
    }

    /// A reused frame buffer keeps none of its old bytes: rendered over a buffer of 0xa5 (or
    /// of the wrong size), every path and kind of sampling gives the fresh frame.
    #[test]
    fn a_reused_buffer_is_overwritten_everywhere() {
        let scene = lit(vec![Sphere {
            center_world: DVec3::ZERO,
            radius: 1.0,
            color: DVec3::new(0.9, 0.4, 0.1),
        }]);
        let camera = looking_at_the_origin();
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
}
