//! A checked keyframe file: [`crate::format`]'s raw types turned into domain types, with every
//! problem collected and named by its field. Nothing past this module sees an unchecked value.

use glam::{DVec2, DVec3};
use std::path::{Path, PathBuf};

use crate::animation::{Animation, Pointing};
use crate::camera::{window_extent, Camera, CameraError};
use crate::error::{Error, Problem, Problems, Result};
use crate::format::{
    self, FileSpec, InterpolationSpec, KeySpec, Pair, SpeedSpec, TrackSpec, Triple,
};
use crate::keyframes::{
    DirectionTrack, Interpolation, Key, Keyable, PathTrack, Track, UniformSpeed,
};
use crate::raster::{Raster, MAX_PIXELS, MAX_SAMPLES, MAX_SIDE};
use crate::scene::{Light, Scene, Sphere};

/// Largest frame count.
pub const MAX_FRAMES: u64 = 10_000_000;

/// A loaded, checked keyframe file.
#[derive(Debug, Clone)]
pub struct Document {
    /// Where it was read from, for messages.
    pub path: PathBuf,
    pub raster: Raster,
    pub animation: Animation,
    pub scene: Scene,
}

impl Document {
    /// Reads, parses and checks a keyframe file.
    pub fn load(path: &Path) -> Result<Document> {
        Document::from_spec(path, format::read(path)?)
    }

    /// Parses and checks RON text; `path` is only used in messages.
    pub fn from_str(path: &Path, text: &str) -> Result<Document> {
        Document::from_spec(path, format::parse(path, text)?)
    }

    pub fn from_spec(path: &Path, spec: FileSpec) -> Result<Document> {
        let mut c = Checker::default();
        let doc = c.document(path, spec);
        match doc {
            Some(doc) if c.problems.is_empty() => Ok(doc),
            _ => Err(Error::Invalid {
                path: path.to_path_buf(),
                problems: Problems(c.problems),
            }),
        }
    }

    /// Every frame's camera, in order, or the first frame where the camera is undefined.
    pub fn cameras(&self) -> impl Iterator<Item = Result<(u64, Camera)>> + '_ {
        self.animation.cameras().map(|r| {
            r.map_err(|e| Error::Frame {
                path: self.path.clone(),
                frame: e.frame,
                time: e.time,
                message: e.cause.to_string(),
            })
        })
    }

    /// Frame `frame`'s camera. The cameras are evaluated in order from frame 0 (the up vector
    /// near the VUV pole continues from the previous frame), so this costs O(frame).
    pub fn camera(&self, frame: u64) -> Result<Camera> {
        match self.cameras().nth(frame as usize) {
            Some(c) => c.map(|(_, camera)| camera),
            None => Err(Error::Usage(format!(
                "frame {frame}: the animation has frames 0..{}",
                self.animation.frames
            ))),
        }
    }

    /// Evaluates the whole path, reporting the first frame whose camera is undefined.
    pub fn check_path(&self) -> Result<()> {
        self.cameras().try_for_each(|r| r.map(drop))
    }
}

#[derive(Default)]
struct Checker {
    problems: Vec<Problem>,
}

impl Checker {
    fn problem(&mut self, field: impl Into<String>, message: impl Into<String>) {
        self.problems.push(Problem::new(field, message));
    }

    fn finite(&mut self, field: &str, x: f64) -> Option<f64> {
        if x.is_finite() {
            Some(x)
        } else {
            self.problem(field, format!("must be a finite number, got {x}"));
            None
        }
    }

    fn triple(&mut self, field: &str, t: Triple) -> Option<DVec3> {
        let v = DVec3::new(t.0, t.1, t.2);
        if v.is_finite() {
            Some(v)
        } else {
            self.problem(field, format!("must be finite numbers, got {t:?}"));
            None
        }
    }

    fn pair(&mut self, field: &str, p: Pair) -> Option<DVec2> {
        let v = DVec2::new(p.0, p.1);
        if v.is_finite() {
            Some(v)
        } else {
            self.problem(field, format!("must be finite numbers, got {p:?}"));
            None
        }
    }

    fn direction(&mut self, field: &str, t: Triple) -> Option<DVec3> {
        let v = self.triple(field, t)?;
        if v.length() > 0.0 && v.length().is_finite() {
            Some(v)
        } else {
            self.problem(field, "must be a non-zero vector");
            None
        }
    }

    fn color(&mut self, field: &str, t: Triple) -> Option<DVec3> {
        let v = self.triple(field, t)?;
        if v.cmpge(DVec3::ZERO).all() && v.cmple(DVec3::ONE).all() {
            Some(v)
        } else {
            self.problem(
                field,
                format!("linear RGB components must lie in [0, 1], got {t:?}"),
            );
            None
        }
    }

    fn positive(&mut self, field: &str, x: f64) -> Option<f64> {
        let x = self.finite(field, x)?;
        if x > 0.0 {
            Some(x)
        } else {
            self.problem(field, format!("must be greater than 0, got {x}"));
            None
        }
    }

    fn fov(&mut self, field: &str, deg: f64) -> Option<f64> {
        let deg = self.finite(field, deg)?;
        if deg > 0.0 && deg < 180.0 {
            Some(deg)
        } else {
            self.problem(
                field,
                format!("a field of view in degrees must lie in (0, 180), got {deg}"),
            );
            None
        }
    }

    fn document(&mut self, path: &Path, spec: FileSpec) -> Option<Document> {
        let raster = self.raster(&spec.image);
        let scene = self.scene(&spec.scene);
        let animation = self.animation(&spec, raster.as_ref());
        let doc = Document {
            path: path.to_path_buf(),
            raster: raster?,
            animation: animation?,
            scene: scene?,
        };
        // A static camera must be well formed at its first frame; animated ones are checked
        // frame by frame when evaluated.
        if let Err(e) = doc.animation.camera_at(0.0, None) {
            let field = match e {
                CameraError::ZeroVpn if matches!(doc.animation.pointing, Pointing::Target(_)) => {
                    "camera.tp"
                }
                CameraError::ZeroVpn => "camera.vpn",
                CameraError::ZeroVuv => "camera.vuv",
                CameraError::Parallel => "camera.vuv",
                CameraError::CopNotBehind(_) => "camera.cop",
            };
            self.problem(field, format!("at t = 0 s: {e}"));
        }
        Some(doc)
    }

    fn raster(&mut self, image: &format::ImageSpec) -> Option<Raster> {
        let width = image.width.unwrap_or(640);
        let height = image.height.unwrap_or(360);
        let samples = image.samples.unwrap_or(1);
        let mut ok = true;
        for (field, side) in [("image.width", width), ("image.height", height)] {
            if side == 0 || side > MAX_SIDE {
                self.problem(
                    field,
                    format!("must lie in 1..={MAX_SIDE} pixels, got {side}"),
                );
                ok = false;
            }
        }
        if ok && u64::from(width) * u64::from(height) > MAX_PIXELS {
            self.problem(
                "image",
                format!("{width}×{height} exceeds {MAX_PIXELS} pixels per frame"),
            );
            ok = false;
        }
        if samples == 0 || samples > MAX_SAMPLES {
            self.problem(
                "image.samples",
                format!("must lie in 1..={MAX_SAMPLES} (an s×s grid per pixel), got {samples}"),
            );
            ok = false;
        }
        ok.then_some(Raster {
            width,
            height,
            samples,
            adaptive: image.adaptive.unwrap_or(false),
        })
    }

    fn scene(&mut self, spec: &format::SceneSpec) -> Option<Scene> {
        let background = match spec.background {
            Some(b) => self.color("scene.background", b),
            None => Some(DVec3::ZERO),
        };
        // Without lights, ambient alone lights the scene: default to flat colours.
        let default_ambient = if spec.lights.is_empty() { 1.0 } else { 0.1 };
        let ambient = match spec.ambient {
            Some(a) => self.finite("scene.ambient", a).and_then(|a| {
                if a >= 0.0 {
                    Some(a)
                } else {
                    self.problem("scene.ambient", format!("must be ≥ 0, got {a}"));
                    None
                }
            }),
            None => Some(default_ambient),
        };
        let mut lights = Vec::new();
        for (i, l) in spec.lights.iter().enumerate() {
            let dir = self.direction(&format!("scene.lights[{i}].direction"), l.direction);
            let color = match l.color {
                Some(c) => self
                    .triple(&format!("scene.lights[{i}].color"), c)
                    .and_then(|c| {
                        if c.cmpge(DVec3::ZERO).all() {
                            Some(c)
                        } else {
                            self.problem(
                                format!("scene.lights[{i}].color"),
                                "components must be ≥ 0",
                            );
                            None
                        }
                    }),
                None => Some(DVec3::ONE),
            };
            if let (Some(d), Some(color)) = (dir, color) {
                lights.push(Light {
                    direction_world: d.normalize(),
                    color,
                    shadows: l.shadows.unwrap_or(true),
                });
            }
        }
        let mut spheres = Vec::new();
        for (i, s) in spec.spheres.iter().enumerate() {
            let center = self.triple(&format!("scene.spheres[{i}].center"), s.center);
            let radius = self.positive(&format!("scene.spheres[{i}].radius"), s.radius);
            let color = match s.color {
                Some(c) => self.color(&format!("scene.spheres[{i}].color"), c),
                None => Some(DVec3::ONE),
            };
            if let (Some(center_world), Some(radius), Some(color)) = (center, radius, color) {
                spheres.push(Sphere {
                    center_world,
                    radius,
                    color,
                });
            }
        }
        Some(Scene {
            background: background?,
            ambient: ambient?,
            lights,
            spheres,
        })
    }

    fn animation(&mut self, spec: &FileSpec, raster: Option<&Raster>) -> Option<Animation> {
        let fps = match spec.fps {
            Some(f) => self.positive("fps", f),
            None => Some(24.0),
        };
        let cam = &spec.camera;
        let vrp = match cam.vrp {
            Some(v) => self.triple("camera.vrp", v),
            None => Some(DVec3::ZERO),
        };
        let vuv = match cam.vuv {
            Some(v) => self.direction("camera.vuv", v),
            None => Some(DVec3::Y),
        };
        let cop = match cam.cop {
            Some(c) => self.triple("camera.cop", c).and_then(|c| {
                if c.z < 0.0 {
                    Some(c)
                } else {
                    self.problem(
                        "camera.cop",
                        format!(
                            "the COP's n must be < 0 (behind the view plane), got {}",
                            c.z
                        ),
                    );
                    None
                }
            }),
            None => Some(DVec3::new(0.0, 0.0, -1.0)),
        };

        let tracks = self.tracks(&spec.animate, vuv.unwrap_or(DVec3::Y));
        let animated_pointing = tracks.look_around.is_some() || tracks.track.is_some();
        let pointing = match (cam.vpn, cam.tp) {
            (Some(_), Some(_)) => {
                self.problem(
                    "camera",
                    "give vpn (a direction) or tp (a target point), not both",
                );
                None
            }
            (Some(v), None) => self.direction("camera.vpn", v).map(Pointing::Vpn),
            (None, Some(t)) => self.triple("camera.tp", t).map(Pointing::Target),
            (None, None) if animated_pointing => Some(Pointing::Vpn(DVec3::Z)),
            (None, None) => {
                self.problem("camera", "needs vpn (view direction) or tp (target point), or a LookAround or Track animation");
                None
            }
        };

        let window = self.window(cam, cop, raster);

        let frames = match spec.frames {
            Some(0) => {
                self.problem("frames", "must be at least 1");
                None
            }
            Some(f) if f > MAX_FRAMES => {
                self.problem("frames", format!("at most {MAX_FRAMES}, got {f}"));
                None
            }
            Some(f) => Some(f),
            // Enough frames to reach the last key.
            None => fps.map(|fps| {
                let end = tracks.last_key_time();
                ((end * fps).floor() as u64)
                    .saturating_add(1)
                    .min(MAX_FRAMES)
            }),
        };

        Some(Animation {
            frames: frames?,
            fps: fps?,
            vrp: vrp?,
            pointing: pointing?,
            vuv: vuv?,
            cop: cop?,
            window: window?,
            observer: tracks.observer,
            look_around: tracks.look_around,
            track: tracks.track,
            zoom: tracks.zoom,
            distort: tracks.distort,
        })
    }

    fn window(
        &mut self,
        cam: &format::CameraSpec,
        cop: Option<DVec3>,
        raster: Option<&Raster>,
    ) -> Option<DVec2> {
        let aspect = raster.map(|r| r.width as f64 / r.height as f64);
        match (cam.window, cam.hfov, cam.vfov) {
            (Some(w), None, None) => {
                let w = self.pair("camera.window", w)?;
                if w.x > 0.0 && w.y > 0.0 {
                    Some(w)
                } else {
                    self.problem(
                        "camera.window",
                        format!("width and height must be > 0, got ({}, {})", w.x, w.y),
                    );
                    None
                }
            }
            (Some(_), _, _) => {
                self.problem(
                    "camera",
                    "give window or a field of view (hfov, vfov), not both",
                );
                None
            }
            (None, h, v) => {
                // The notes' "Field of View": the window at the COP's distance from the view plane.
                let d = -cop?.z;
                let h = h.and_then(|h| self.fov("camera.hfov", h).map(|h| window_extent(h, d)));
                let v = v.and_then(|v| self.fov("camera.vfov", v).map(|v| window_extent(v, d)));
                let aspect = aspect?;
                match (cam.hfov.is_some(), cam.vfov.is_some()) {
                    (true, true) => Some(DVec2::new(h?, v?)),
                    (true, false) => h.map(|h| DVec2::new(h, h / aspect)),
                    (false, true) => v.map(|v| DVec2::new(v * aspect, v)),
                    // Default: a window one unit high with the image's aspect.
                    (false, false) => Some(DVec2::new(aspect, 1.0)),
                }
            }
        }
    }

    fn tracks(&mut self, specs: &[TrackSpec], vuv: DVec3) -> Tracks {
        let mut out = Tracks::default();
        let mut seen: Vec<(&'static str, usize)> = Vec::new();
        for (i, spec) in specs.iter().enumerate() {
            let field = format!("animate[{i}] ({})", spec.mode());
            // Two tracks that set the same camera parameter conflict.
            let sets = spec.mode().sets();
            if let Some((_, j)) = seen.iter().find(|(s, _)| *s == sets) {
                self.problem(
                    field.clone(),
                    format!(
                        "conflicts with animate[{j}] ({}): both set {sets}; keep one",
                        specs[*j].mode()
                    ),
                );
                continue;
            }
            seen.push((sets, i));
            match spec {
                TrackSpec::Observer {
                    keys,
                    interpolation,
                    speed,
                    arc_samples,
                } => {
                    let samples = arc_samples.unwrap_or(UniformSpeed::DEFAULT_SAMPLES);
                    if samples == 0 || samples > 1 << 20 {
                        self.problem(
                            format!("{field}.arc_samples"),
                            format!("must lie in 1..={}, got {samples}", 1 << 20),
                        );
                    }
                    if arc_samples.is_some() && *speed != Some(SpeedSpec::Uniform) {
                        self.problem(
                            format!("{field}.arc_samples"),
                            "only applies with speed: Uniform",
                        );
                    }
                    out.observer = self
                        .keys(&field, keys, *interpolation, |c, f, v| c.triple(f, *v))
                        .map(Track::new)
                        .map(|track| match speed {
                            Some(SpeedSpec::Uniform) => {
                                PathTrack::Uniform(UniformSpeed::new(track, samples))
                            }
                            _ => PathTrack::Keyed(track),
                        });
                }
                TrackSpec::Track {
                    keys,
                    interpolation,
                } => {
                    out.track = self
                        .keys(&field, keys, *interpolation, |c, f, v| c.triple(f, *v))
                        .map(Track::new);
                }
                TrackSpec::LookAround {
                    keys,
                    interpolation,
                } => {
                    out.look_around = self
                        .keys(&field, keys, *interpolation, |c, f, v| c.direction(f, *v))
                        .map(|k| DirectionTrack::new(k, vuv));
                }
                TrackSpec::Zoom {
                    keys,
                    interpolation,
                } => {
                    out.zoom = self
                        .keys(&field, keys, *interpolation, |c, f, v| {
                            let n = c.finite(f, *v)?;
                            if n < 0.0 {
                                Some(n)
                            } else {
                                c.problem(f, format!("the COP's n must be < 0, got {n}"));
                                None
                            }
                        })
                        .map(Track::new);
                }
                TrackSpec::Distort {
                    keys,
                    interpolation,
                } => {
                    out.distort = self
                        .keys(&field, keys, *interpolation, |c, f, v| c.pair(f, *v))
                        .map(Track::new);
                }
            }
        }
        out
    }

    fn keys<S, V: Keyable>(
        &mut self,
        field: &str,
        keys: &[KeySpec<S>],
        track_interpolation: Option<InterpolationSpec>,
        mut value: impl FnMut(&mut Self, &str, &S) -> Option<V>,
    ) -> Option<Vec<Key<V>>> {
        if keys.is_empty() {
            self.problem(format!("{field}.keys"), "a track needs at least one key");
            return None;
        }
        let default = track_interpolation.unwrap_or(InterpolationSpec::CatmullRom);
        let mut out = Vec::with_capacity(keys.len());
        let mut ok = true;
        for (k, key) in keys.iter().enumerate() {
            let f = format!("{field}.keys[{k}]");
            let t = self.finite(&format!("{f}.t"), key.t);
            let v = value(self, &format!("{f}.value"), &key.value);
            match (t, v) {
                (Some(t), Some(value)) => out.push(Key {
                    t,
                    value,
                    interpolation: interpolation(key.interpolation.unwrap_or(default)),
                }),
                _ => ok = false,
            }
        }
        if ok {
            for (k, w) in out.windows(2).enumerate() {
                if w[1].t <= w[0].t {
                    self.problem(
                        format!("{field}.keys[{}].t", k + 1),
                        format!(
                            "key times must strictly increase: {} s follows {} s",
                            w[1].t, w[0].t
                        ),
                    );
                    ok = false;
                }
            }
        }
        ok.then_some(out)
    }
}

fn interpolation(spec: InterpolationSpec) -> Interpolation {
    match spec {
        InterpolationSpec::Step => Interpolation::Step,
        InterpolationSpec::Linear => Interpolation::Linear,
        InterpolationSpec::Cosine => Interpolation::Cosine,
        InterpolationSpec::CatmullRom => Interpolation::CatmullRom,
        InterpolationSpec::Monotone => Interpolation::Monotone,
        InterpolationSpec::Centripetal => Interpolation::Centripetal,
    }
}

#[derive(Default)]
struct Tracks {
    observer: Option<PathTrack>,
    look_around: Option<DirectionTrack>,
    track: Option<Track<DVec3>>,
    zoom: Option<Track<f64>>,
    distort: Option<Track<DVec2>>,
}

impl Tracks {
    /// The time of the last key of any track, 0 without tracks.
    fn last_key_time(&self) -> f64 {
        fn end<V>(keys: &[Key<V>]) -> f64 {
            keys.last().map_or(0.0, |k| k.t)
        }
        [
            self.observer.as_ref().map(|t| end(t.keys())),
            self.look_around.as_ref().map(|t| end(t.keys())),
            self.track.as_ref().map(|t| end(t.keys())),
            self.zoom.as_ref().map(|t| end(t.keys())),
            self.distort.as_ref().map(|t| end(t.keys())),
        ]
        .into_iter()
        .flatten()
        .fold(0.0, f64::max)
    }
}
