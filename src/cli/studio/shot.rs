//! The shot as the studio holds it: the file's bytes as last read, the document they make (or
//! why they make none), what the page draws of it (as JSON), and a render thread that owns the
//! document's sphere index for as long as the document is current.

use std::sync::mpsc;
use std::sync::Arc;

use glam::DVec3;
use serde_json::{json, Value};

use crate::camera::Camera;
use crate::document::Document;
use crate::raster::Raster;
use crate::render::{Renderer, SceneIndex};
use crate::FrameHash;

/// At most this many spheres are sent to the page's plot; a larger scene sends every k-th.
const PLOT_SPHERES: usize = 20_000;

/// The most the preview cache holds: 256 MiB of pixels (370 frames at 640 × 360).
const CACHE_BYTES: usize = 256 << 20;

/// One render the page asked for.
pub enum Job {
    /// The cameras whose renders the frame averages (one, or a time sample each with motion
    /// blur), at a raster.
    Cameras {
        cameras: Vec<Camera>,
        raster: Raster,
        reply: mpsc::Sender<Arc<Vec<u8>>>,
    },
    /// A frame's own camera at the preview raster: from the cache, which fills from here on.
    Preview {
        frame: u64,
        raster: Raster,
        reply: mpsc::Sender<Arc<Vec<u8>>>,
    },
}

/// The render thread: it owns the sphere index, answers jobs in order, and between them fills
/// a cache of the frames at the last preview raster asked for, from the last frame asked on,
/// so that scrubbing and playing over frames seen or coming is a copy, not a render.
fn render_thread(doc: &Document, cameras: &[Camera], jobs: mpsc::Receiver<Job>) {
    let index = SceneIndex::new(&doc.scene);
    let mut renderer = Renderer::new();
    let mut render = |cameras: &[Camera], raster: Raster| {
        let mut pixels = Vec::new();
        let frame = renderer.prepare_times(cameras, &index, raster);
        frame.render_into(&mut pixels, &mut |_| {});
        renderer.recycle(frame);
        Arc::new(pixels)
    };
    let frames = cameras.len() as u64;
    let mut cache: std::collections::HashMap<u64, Arc<Vec<u8>>> = Default::default();
    let mut cache_raster: Option<Raster> = None;
    let mut next = 0u64;
    loop {
        let room = cache_raster.map_or(0, |r| {
            CACHE_BYTES / (r.width as usize * r.height as usize * 3).max(1)
        });
        let filling = cache_raster.is_some() && cache.len() < room.min(frames as usize);
        let job = if filling {
            match jobs.try_recv() {
                Ok(job) => Some(job),
                Err(mpsc::TryRecvError::Empty) => None,
                Err(mpsc::TryRecvError::Disconnected) => return,
            }
        } else {
            match jobs.recv() {
                Ok(job) => Some(job),
                Err(_) => return,
            }
        };
        match job {
            Some(Job::Cameras {
                cameras,
                raster,
                reply,
            }) => {
                let _ = reply.send(render(&cameras, raster));
            }
            Some(Job::Preview {
                frame,
                raster,
                reply,
            }) => {
                if cache_raster != Some(raster) {
                    cache.clear();
                    cache_raster = Some(raster);
                }
                let pixels = match cache.get(&frame) {
                    Some(p) => Arc::clone(p),
                    None => {
                        let p = render(&cameras[frame as usize..=frame as usize], raster);
                        // Full: the frame that comes last from here on goes.
                        if cache.len() >= room.max(1) {
                            let ahead = |k: &u64| (k + frames - frame) % frames;
                            if let Some(&last) = cache.keys().max_by_key(|k| ahead(k)) {
                                cache.remove(&last);
                            }
                        }
                        cache.insert(frame, Arc::clone(&p));
                        p
                    }
                };
                let _ = reply.send(pixels);
                next = (frame + 1) % frames;
            }
            None => {
                // The next frame not yet cached, from the last one asked for on.
                let Some(raster) = cache_raster else { continue };
                let Some(frame) = (0..frames)
                    .map(|k| (next + k) % frames)
                    .find(|k| !cache.contains_key(k))
                else {
                    continue;
                };
                let p = render(&cameras[frame as usize..=frame as usize], raster);
                cache.insert(frame, p);
                next = (frame + 1) % frames;
            }
        }
    }
}

/// A valid document and what the page needs of it.
pub struct Good {
    pub doc: Arc<Document>,
    /// Every frame's camera, in order.
    pub cameras: Vec<Camera>,
    /// What the page draws: tracks, keys, warnings, path, spheres (JSON).
    pub json: Value,
    /// Hands renders to the thread that owns the sphere index; dropped with the document,
    /// which ends the thread.
    jobs: mpsc::Sender<Job>,
}

impl Good {
    /// Checks the document's path, evaluates every frame's camera and the warnings, and starts
    /// its render thread (which indexes the spheres before its first render).
    pub fn new(doc: Document) -> crate::Result<Good> {
        doc.check_path()?;
        let cameras: Vec<Camera> = doc
            .cameras()
            .map(|c| c.map(|(_, cam)| cam))
            .collect::<crate::Result<_>>()?;
        let warnings = crate::motion::warnings(&doc)?;
        let json = describe(&doc, &cameras, &warnings);
        let doc = Arc::new(doc);
        let (jobs, rx) = mpsc::channel::<Job>();
        let owned = Arc::clone(&doc);
        let frame_cameras = cameras.clone();
        std::thread::Builder::new()
            .name("studio-render".into())
            .spawn(move || render_thread(&owned, &frame_cameras, rx))
            .map_err(crate::Error::write("<render thread>"))?;
        Ok(Good {
            doc,
            cameras,
            json,
            jobs,
        })
    }

    /// The RGB8 pixels of `cameras` (averaged, as a frame with motion blur is) at `raster`.
    pub fn render(&self, cameras: Vec<Camera>, raster: Raster) -> Option<Arc<Vec<u8>>> {
        let (reply, answer) = mpsc::channel();
        let job = Job::Cameras {
            cameras,
            raster,
            reply,
        };
        self.jobs.send(job).ok()?;
        answer.recv().ok()
    }

    /// Frame `frame`'s own camera at the preview `raster` (one sample, no motion blur), from
    /// the render thread's cache when it has it.
    pub fn preview(&self, frame: u64, raster: Raster) -> Option<Arc<Vec<u8>>> {
        let (reply, answer) = mpsc::channel();
        self.jobs
            .send(Job::Preview {
                frame,
                raster,
                reply,
            })
            .ok()?;
        answer.recv().ok()
    }

    /// Frame `frame`'s camera with the page's flown parts put in its place: the VRP, the VPN
    /// and the COP (view coordinates). The up vector continues from the frame's own camera, as
    /// it does from frame to frame.
    pub fn flown(
        &self,
        frame: u64,
        vrp: Option<DVec3>,
        vpn: Option<DVec3>,
        cop: Option<DVec3>,
    ) -> Result<Camera, String> {
        let base = self.cameras[frame as usize];
        let vpn = vpn.unwrap_or(base.basis.n);
        let a = &self.doc.animation;
        let t = a.time(frame);
        let basis =
            (a.basis_at(t, vpn, Some(a.up_before_roll(&base, t)))).map_err(|e| e.to_string())?;
        let cop = cop.unwrap_or(base.cop_view);
        if !(cop.z < 0.0 && cop.is_finite()) {
            return Err(format!("the COP's n is {}, not < 0", cop.z));
        }
        Ok(Camera {
            vrp_world: vrp.unwrap_or(base.vrp_world),
            basis,
            cop_view: cop,
            window: base.window,
        })
    }
}

/// The raster of the page's preview: `width` pixels wide (at most the file's), the file's
/// aspect, one sample a pixel.
pub fn preview_raster(doc: &Document, width: u32) -> Raster {
    crate::cli::preview::small_raster(doc, width)
}

fn triple(v: DVec3) -> [f64; 3] {
    [v.x, v.y, v.z]
}

/// The page's picture of the shot, as JSON.
fn describe(doc: &Document, cameras: &[Camera], warnings: &[crate::motion::Warning]) -> Value {
    let a = &doc.animation;
    let keys = |mode: crate::mode::Mode| -> Vec<Value> {
        let times_values: Vec<(f64, Value)> = match mode {
            crate::mode::Mode::Observer => a
                .observer
                .iter()
                .flat_map(|t| t.keys())
                .map(|k| (k.t, json!(triple(k.value))))
                .collect(),
            crate::mode::Mode::LookAround => a
                .look_around
                .iter()
                .flat_map(|t| t.keys())
                .map(|k| (k.t, json!(triple(k.value))))
                .collect(),
            crate::mode::Mode::Track => a
                .track
                .iter()
                .flat_map(|t| t.keys())
                .map(|k| (k.t, json!(triple(k.value))))
                .collect(),
            crate::mode::Mode::Zoom => a
                .zoom
                .iter()
                .flat_map(|t| t.keys())
                .map(|k| (k.t, json!(k.value)))
                .collect(),
            crate::mode::Mode::Distort => a
                .distort
                .iter()
                .flat_map(|t| t.keys())
                .map(|k| (k.t, json!([k.value.x, k.value.y])))
                .collect(),
            crate::mode::Mode::Roll => a
                .roll_track
                .iter()
                .flat_map(|t| t.keys())
                .map(|k| (k.t, json!(k.value)))
                .collect(),
        };
        times_values
            .into_iter()
            .map(|(t, value)| json!({"t": t, "frame": t * a.fps, "value": value}))
            .collect()
    };
    let tracks: Vec<Value> = crate::mode::Mode::ALL
        .iter()
        .map(|&m| json!({"mode": m.name(), "sets": m.sets(), "present": a.tracks().any(|t| t == m), "keys": keys(m)}))
        .collect();
    let frames: Vec<Value> = cameras
        .iter()
        .enumerate()
        .map(|(k, c)| {
            json!({
                "vrp": triple(c.vrp_world),
                "u": triple(c.basis.u),
                "v": triple(c.basis.v),
                "n": triple(c.basis.n),
                "cop": triple(c.cop_view),
                "eye": triple(c.cop_world()),
                "tp": a.target(k as u64).map(triple),
                "roll": a.roll_at(a.time(k as u64)),
            })
        })
        .collect();
    let warnings: Vec<Value> = warnings
        .iter()
        .map(|w| json!({"frames": w.frames, "text": w.to_string()}))
        .collect();
    let spheres = &doc.scene.spheres;
    let every = spheres.len().div_ceil(PLOT_SPHERES).max(1);
    let shown: Vec<[f64; 7]> = spheres
        .iter()
        .step_by(every)
        .map(|s| {
            let c = s.center_world;
            let srgb = |x: f64| f64::from(crate::render::srgb_encoder().encode(x));
            [
                c.x,
                c.y,
                c.z,
                s.radius,
                srgb(s.color.x),
                srgb(s.color.y),
                srgb(s.color.z),
            ]
        })
        .collect();
    let r = doc.raster;
    json!({
        "frames": a.frames,
        "fps": a.fps,
        "width": r.width,
        "height": r.height,
        "samples": r.samples,
        "motion_blur": doc.motion_blur.is_some(),
        "window": [a.window.x, a.window.y],
        "vuv": triple(a.vuv),
        "tracks": tracks,
        "warnings": warnings,
        "cameras": frames,
        "spheres": {"count": spheres.len(), "every": every, "shown": shown},
        "background": triple(doc.scene.background),
    })
}

/// A fingerprint of the file's bytes: what the page names when it asks for a write, so a file
/// changed since the page loaded it is never written over.
pub fn fingerprint(bytes: &[u8]) -> String {
    FrameHash::of(bytes).to_string()
}
