//! A checked keyframe file: `format`'s raw types turned into domain types, with every
//! problem collected and named by its field. Nothing past this module sees an unchecked value.

mod camera;
mod image;
mod scene;
mod tracks;

use glam::{DVec2, DVec3};
use std::fmt;
use std::path::{Path, PathBuf};

use crate::animation::{Animation, Exposure, FrameError, Pointing};
use crate::camera::{Camera, CameraError};
use crate::error::{Error, Problem, Problems, Result};
use crate::format::sphere_files::Listing;
use crate::format::{self, FileSpec, Pair, Triple};
use crate::raster::{MotionBlur, Raster};
use crate::scene::Scene;

/// Largest frame count.
pub const MAX_FRAMES: u64 = 10_000_000;

/// A loaded, checked keyframe file (its fields are described at their accessors).
#[derive(Debug, Clone)]
pub struct Document {
    pub(crate) path: PathBuf,
    pub(crate) raster: Raster,
    pub(crate) motion_blur: Option<MotionBlur>,
    pub(crate) animation: Animation,
    pub(crate) scene: Scene,
    /// The sphere files the scene names, in order, with how many spheres each gave.
    pub(crate) sphere_files: Vec<SphereFile>,
    /// How far a frame-hash test lets a frame stray from its golden frame (`test`), if at all.
    pub(crate) tolerance: Option<Tolerance>,
}

/// A shot's tolerance (`test: (max_pixels: N, max_level: L)`): a frame whose hash differs
/// passes when at most `max_pixels` of its pixels have a channel more than `max_level` levels
/// from the golden frame's.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Tolerance {
    /// Pixels that may differ by more than `max_level`.
    pub max_pixels: u64,
    /// Levels of 255 a channel may differ by and count as unchanged.
    pub max_level: u8,
}

/// A sphere file of the scene and how many spheres it gave.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SphereFile {
    /// As the keyframe file names it.
    pub name: String,
    /// Where it was read from: relative to the keyframe file's folder.
    pub path: PathBuf,
    /// How many spheres it gave.
    pub spheres: usize,
    /// Where each of its spheres is in it.
    pub listing: Listing,
}

impl Document {
    /// Where it was read from, for messages.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Image size and sampling.
    pub fn raster(&self) -> &Raster {
        &self.raster
    }

    /// Shutter motion blur (`image.motion_blur`), if any.
    pub fn motion_blur(&self) -> Option<MotionBlur> {
        self.motion_blur
    }

    /// The camera and its tracks, with the frame count and rate.
    pub fn animation(&self) -> &Animation {
        &self.animation
    }

    /// The spheres and lights.
    pub fn scene(&self) -> &Scene {
        &self.scene
    }

    /// The shot's tolerance in frame-hash tests, if it states one.
    pub fn tolerance(&self) -> Option<Tolerance> {
        self.tolerance
    }

    /// The same shot rendered at `width` × `height` pixels (a smaller frame for a quick test),
    /// checked as the file's `image` is: refused, naming the field, outside the limits.
    pub fn resized(self, width: u32, height: u32) -> Result<Document> {
        let raster = Raster {
            width,
            height,
            ..self.raster
        };
        self.with_raster(raster)
    }

    /// The same shot with another image size and sampling, checked as the file's `image` is.
    pub fn with_raster(mut self, raster: Raster) -> Result<Document> {
        let problems = image::raster_problems(raster);
        if !problems.is_empty() {
            return Err(Error::Invalid {
                path: self.path,
                problems: Problems(problems),
            });
        }
        self.raster = raster;
        Ok(self)
    }

    /// Where the scene's sphere `i` (the inline spheres first, then each file's, as the renderer
    /// counts them) is written: `scene.spheres[3]`, or `scene.sphere_files[0] (cloud.ply:
    /// vertex 3)`.
    pub fn sphere_place(&self, i: usize) -> String {
        let in_files: usize = self.sphere_files.iter().map(|f| f.spheres).sum();
        let mut first = self.scene.spheres.len().saturating_sub(in_files);
        if i < first {
            return format!("scene.spheres[{i}]");
        }
        for (k, file) in self.sphere_files.iter().enumerate() {
            if i - first < file.spheres {
                let at = file.listing.location(i - first);
                return format!("scene.sphere_files[{k}] ({}: {at})", file.name);
            }
            first += file.spheres;
        }
        format!("the scene's sphere {i} (counted from 0)")
    }

    /// Reads, parses and checks a keyframe file.
    pub fn load(path: &Path) -> Result<Document> {
        Document::from_spec(path, format::read(path)?)
    }

    /// Parses and checks RON text; `path` is only used in messages.
    pub fn from_str(path: &Path, text: &str) -> Result<Document> {
        Document::from_spec(path, format::parse(path, text)?)
    }

    /// Checks a parsed file; the sphere files it names are read relative to `path`'s folder.
    /// Problems are listed in the order of the file's sections (`FileSpec::order`; the
    /// checker's order within a section and where it is unknown).
    pub fn from_spec(path: &Path, spec: FileSpec) -> Result<Document> {
        let mut c = Checker::default();
        let order = spec.order.clone();
        let doc = c.document(path, spec);
        match doc {
            Some(doc) if c.problems.is_empty() => Ok(doc),
            _ => {
                let mut problems = c.problems;
                // By section, then by field within it (`camera.vpn`), as the file writes them.
                let at = |name: &str| order.iter().position(|s| s == name).unwrap_or(usize::MAX);
                problems.sort_by_key(|p| {
                    let mut parts = p.field.split(['.', '[', ' ']);
                    let section = parts.next().unwrap_or("");
                    let field = p.field[section.len()..]
                        .strip_prefix('.')
                        .and_then(|rest| rest.split(['.', '[', ' ']).next())
                        .map_or(usize::MAX, |f| at(&format!("{section}.{f}")));
                    (at(section), field)
                });
                Err(Error::Invalid {
                    path: path.to_path_buf(),
                    problems: Problems(problems),
                })
            }
        }
    }

    /// Every frame's camera, in order, or the first frame where the camera is undefined.
    pub fn cameras(&self) -> impl Iterator<Item = Result<(u64, Camera)>> + '_ {
        self.animation
            .cameras()
            .map(|r| r.map_err(|e| self.frame_error(e)))
    }

    /// The error for a frame (or time sample) where the camera is undefined.
    fn frame_error(&self, e: FrameError) -> Error {
        Error::Frame {
            path: self.path.clone(),
            frame: e.frame,
            time: e.time,
            message: e.cause.to_string(),
        }
    }

    /// Every frame's [`Exposure`], in order: its camera and, with motion blur, the camera at
    /// each of its time samples; or the first frame or time sample where the camera is
    /// undefined (reported at its own time).
    pub fn exposures(&self) -> impl Iterator<Item = Result<(u64, Exposure)>> + '_ {
        self.cameras().map(move |item| {
            let (frame, camera) = item?;
            let Some(blur) = self.motion_blur else {
                return Ok((frame, Exposure::still(camera)));
            };
            let exposure = self.animation.exposure(frame, camera, blur);
            Ok((frame, exposure.map_err(|e| self.frame_error(e))?))
        })
    }

    /// The error for a frame the animation does not have.
    fn no_frame(&self, frame: u64) -> Error {
        Error::Usage(format!(
            "frame {frame}: the animation has frames 0..{}",
            self.animation.frames
        ))
    }

    /// Frame `frame`'s exposure (see [`Document::exposures`]), in O(frame).
    pub fn exposure(&self, frame: u64) -> Result<Exposure> {
        let item = self.exposures().nth(frame as usize);
        Ok(item.ok_or_else(|| self.no_frame(frame))??.1)
    }

    /// Frame `frame`'s camera. The cameras are evaluated in order from frame 0 (the up vector
    /// near the VUV pole continues from the previous frame), so this costs O(frame).
    pub fn camera(&self, frame: u64) -> Result<Camera> {
        let item = self.cameras().nth(frame as usize);
        Ok(item.ok_or_else(|| self.no_frame(frame))??.1)
    }

    /// Evaluates the whole path, reporting the first frame whose camera is undefined.
    /// With motion blur, every time sample's camera too.
    pub fn check_path(&self) -> Result<()> {
        self.exposures().try_for_each(|r| r.map(drop))
    }
}

/// The largest size of any number a scene is given: the renderer squares distances in f64
/// (|COP − centre|², r²), whose range ends near 1.8e308, so coordinates and lengths stay within
/// ±1e150 (a distance of up to 1e151 squares to 1e302). A scene scaled by a power of two within
/// it renders the same bytes (`tests/it/extreme.rs`).
pub const LARGEST: f64 = 1e150;

/// Whether `x` is finite and within ±[`LARGEST`].
fn sized(x: f64) -> bool {
    x.abs() <= LARGEST
}

#[derive(Default)]
struct Checker {
    problems: Vec<Problem>,
}

impl Checker {
    fn problem(&mut self, field: impl fmt::Display, message: impl Into<String>) {
        self.problems.push(Problem::new(field.to_string(), message));
    }

    /// `value` when `ok`; else the problem `message()` at `field`, and None.
    fn ensure<T>(
        &mut self,
        field: impl fmt::Display,
        ok: bool,
        value: T,
        message: impl FnOnce() -> String,
    ) -> Option<T> {
        if !ok {
            self.problem(field, message());
        }
        ok.then_some(value)
    }

    /// `value` when it lies in 1..=`max`; else the problem "`{what}`must lie in 1..=`max``{unit}`,
    /// got `value`" at `field`.
    fn count(
        &mut self,
        field: &str,
        value: i64,
        max: u32,
        (what, unit): (&str, &str),
    ) -> Option<u32> {
        match u32::try_from(value) {
            Ok(n) if (1..=max).contains(&n) => Some(n),
            _ => {
                self.problem(
                    field,
                    format!("{what}must lie in 1..={max}{unit}, got {value}"),
                );
                None
            }
        }
    }

    fn finite(&mut self, field: impl fmt::Display + Copy, x: f64) -> Option<f64> {
        let message = || format!("must be a finite number within ±{LARGEST:e}, got {x:?}");
        self.ensure(field, sized(x), x, message)
    }

    fn triple(&mut self, field: impl fmt::Display + Copy, t: Triple) -> Option<DVec3> {
        let ok = [t.0, t.1, t.2].into_iter().all(sized);
        let message = || format!("must be finite numbers within ±{LARGEST:e}, got {t:?}");
        self.ensure(field, ok, DVec3::new(t.0, t.1, t.2), message)
    }

    fn pair(&mut self, field: &str, p: Pair) -> Option<DVec2> {
        let ok = sized(p.0) && sized(p.1);
        let message = || format!("must be finite numbers within ±{LARGEST:e}, got {p:?}");
        self.ensure(field, ok, DVec2::new(p.0, p.1), message)
    }

    fn direction(&mut self, field: &str, t: Triple) -> Option<DVec3> {
        let v = self.triple(field, t)?;
        let ok = v.length() > 0.0 && v.length().is_finite();
        self.ensure(field, ok, v, || "must be a non-zero vector".into())
    }

    fn color(&mut self, field: impl fmt::Display + Copy, t: Triple) -> Option<DVec3> {
        let v = self.triple(field, t)?;
        let ok = v.cmpge(DVec3::ZERO).all() && v.cmple(DVec3::ONE).all();
        let message = || format!("linear RGB components must lie in [0, 1], got {t:?}");
        self.ensure(field, ok, v, message)
    }

    fn positive(&mut self, field: impl fmt::Display + Copy, x: f64) -> Option<f64> {
        let x = self.finite(field, x)?;
        self.ensure(field, x > 0.0, x, || {
            format!("must be greater than 0, got {x}")
        })
    }

    fn fov(&mut self, field: &str, deg: f64) -> Option<f64> {
        let deg = self.finite(field, deg)?;
        let message = || format!("a field of view in degrees must lie in (0, 180), got {deg}");
        self.ensure(field, deg > 0.0 && deg < 180.0, deg, message)
    }

    fn document(&mut self, path: &Path, mut spec: FileSpec) -> Option<Document> {
        let raster = self.raster(&spec.image);
        let motion_blur = self.motion_blur(&spec.image);
        let folder = path.parent().unwrap_or(Path::new(""));
        let (scene, sphere_files) = self.scene(&mut spec.scene, folder);
        let animation = self.animation(&spec, raster.as_ref());
        let doc = Document {
            path: path.to_path_buf(),
            raster: raster?,
            motion_blur,
            animation: animation?,
            scene: scene?,
            sphere_files,
            tolerance: self.tolerance(spec.test.as_ref()),
        };
        // A static camera must be well formed at its first frame; animated ones are checked
        // frame by frame when evaluated.
        if let Err(e) = doc.animation.camera_at(0.0, None) {
            if let (CameraError::ZeroVpn, Some(field)) = (e, track_at_zero(&spec)) {
                self.problem(
                    field,
                    "at t = 0 s: the target equals the VRP, so the camera has no view direction; move the target or the VRP",
                );
                return Some(doc);
            }
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
}

impl Checker {
    fn tolerance(&mut self, spec: Option<&format::TestSpec>) -> Option<Tolerance> {
        let spec = spec?;
        let max_pixels = spec.max_pixels.unwrap_or(0);
        let max_level = spec.max_level.unwrap_or(0);
        let pixels = u64::try_from(max_pixels).ok();
        let level = u8::try_from(max_level).ok();
        if pixels.is_none() {
            self.problem(
                "test.max_pixels",
                format!("a pixel count must be 0 or more, got {max_pixels}"),
            );
        }
        if level.is_none() {
            self.problem(
                "test.max_level",
                format!("a level must lie in 0..=255, got {max_level}"),
            );
        }
        Some(Tolerance {
            max_pixels: pixels?,
            max_level: level?,
        })
    }
}

/// The field that holds the target of `spec`'s Track at t = 0, if it has a Track: its key at
/// t = 0, or its first key if that comes later (the track holds it until then), or the track.
fn track_at_zero(spec: &FileSpec) -> Option<String> {
    spec.animate.iter().enumerate().find_map(|(i, t)| match t {
        format::TrackSpec::Track { keys, .. } => {
            let field = format!("animate[{i}] ({})", t.mode());
            Some(match keys.iter().position(|k| k.t == 0.0) {
                Some(k) => format!("{field}.keys[{k}]"),
                None if keys.first().is_some_and(|k| k.t > 0.0) => format!("{field}.keys[0]"),
                None => field,
            })
        }
        _ => None,
    })
}
