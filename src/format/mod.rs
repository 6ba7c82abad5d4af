//! The keyframe file as written: RON types that mirror the text, with every optional field an
//! `Option`, and the sphere files it names (PLY, CSV). Nothing here is checked;
//! [`crate::document`] turns these into domain types. This is the only module that knows RON.

use serde::Deserialize;

mod pieces;
mod quick;
pub mod sphere_files;

use crate::mode::Mode;
use std::path::Path;

use crate::error::{Error, Result};

/// `(x, y, z)` in world units (or linear RGB for colours).
pub type Triple = (f64, f64, f64);
/// `(a, b)`: a window's (width, height) or a COP's (u, v).
pub type Pair = (f64, f64);

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields, rename = "file")]
pub struct FileSpec {
    pub frames: Option<u64>,
    pub fps: Option<f64>,
    #[serde(default)]
    pub image: ImageSpec,
    pub camera: CameraSpec,
    #[serde(default)]
    pub animate: Vec<TrackSpec>,
    #[serde(default)]
    pub scene: SceneSpec,
}

#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields, rename = "image")]
pub struct ImageSpec {
    pub width: Option<u32>,
    pub height: Option<u32>,
    pub samples: Option<u32>,
    pub adaptive: Option<bool>,
}

#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields, rename = "camera")]
pub struct CameraSpec {
    pub vrp: Option<Triple>,
    pub vpn: Option<Triple>,
    pub tp: Option<Triple>,
    pub vuv: Option<Triple>,
    pub cop: Option<Triple>,
    pub window: Option<Pair>,
    pub hfov: Option<f64>,
    pub vfov: Option<f64>,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
pub enum InterpolationSpec {
    Step,
    Linear,
    Cosine,
    CatmullRom,
    Monotone,
    Centripetal,
}

/// How an Observer path is timed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
pub enum SpeedSpec {
    /// Each key is reached at its time.
    Keyed,
    /// Constant speed along the path from the first key's time to the last.
    Uniform,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields, rename = "key")]
pub struct KeySpec<V> {
    pub t: f64,
    pub value: V,
    pub interpolation: Option<InterpolationSpec>,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields, rename = "animate")]
pub enum TrackSpec {
    Observer {
        keys: Vec<KeySpec<Triple>>,
        interpolation: Option<InterpolationSpec>,
        speed: Option<SpeedSpec>,
        arc_samples: Option<u32>,
    },
    LookAround {
        keys: Vec<KeySpec<Triple>>,
        interpolation: Option<InterpolationSpec>,
    },
    Track {
        keys: Vec<KeySpec<Triple>>,
        interpolation: Option<InterpolationSpec>,
    },
    Zoom {
        keys: Vec<KeySpec<f64>>,
        interpolation: Option<InterpolationSpec>,
    },
    Distort {
        keys: Vec<KeySpec<Pair>>,
        interpolation: Option<InterpolationSpec>,
    },
}

impl TrackSpec {
    /// The mode this track animates.
    pub fn mode(&self) -> Mode {
        match self {
            TrackSpec::Observer { .. } => Mode::Observer,
            TrackSpec::LookAround { .. } => Mode::LookAround,
            TrackSpec::Track { .. } => Mode::Track,
            TrackSpec::Zoom { .. } => Mode::Zoom,
            TrackSpec::Distort { .. } => Mode::Distort,
        }
    }
}

#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields, rename = "scene")]
pub struct SceneSpec {
    pub background: Option<Triple>,
    pub ambient: Option<f64>,
    #[serde(default)]
    pub lights: Vec<LightSpec>,
    #[serde(default)]
    pub spheres: Vec<SphereSpec>,
    /// PLY or CSV files of more spheres, relative to the keyframe file; their spheres follow
    /// `spheres`, file by file.
    #[serde(default)]
    pub sphere_files: Vec<String>,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields, rename = "light")]
pub struct LightSpec {
    pub direction: Triple,
    pub color: Option<Triple>,
    pub shadows: Option<bool>,
}

#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, rename = "sphere")]
pub struct SphereSpec {
    pub center: Triple,
    pub radius: f64,
    pub color: Option<Triple>,
}

/// Parses RON text. Optional fields may be written bare (`tp: (0.0, 0.0, 0.0)`), without `Some`.
/// A long `spheres` list is parsed in pieces in parallel (`pieces.rs`), its plain pieces
/// without RON (`quick.rs`), on one thread as on several; the result, and any error, is the
/// same as RON's on the whole text.
pub fn parse(path: &Path, text: &str) -> Result<FileSpec> {
    if let Some(spec) = pieces::parse(text, pieces::PIECE_BYTES) {
        return Ok(spec);
    }
    options().from_str(text).map_err(|e| Error::Parse {
        path: path.to_path_buf(),
        line: e.span.start.line,
        col: e.span.start.col,
        message: e.code.to_string(),
    })
}

/// RON as campath reads it.
fn options() -> ron::Options {
    ron::Options::default().with_default_extension(ron::extensions::Extensions::IMPLICIT_SOME)
}

/// Reads and parses a keyframe file.
pub fn read(path: &Path) -> Result<FileSpec> {
    let text = std::fs::read_to_string(path).map_err(Error::read(path.to_path_buf()))?;
    parse(path, &text)
}
