//! `campath import`: a camera another program animated, read as samples (`Sample`: where the
//! eye is, which way it looks, its field of view and lens shift, at a time) and fitted with the
//! fewest keys that reproduce every sample within a tolerance in pixels (`fit`).
//!
//! Sources, one file each: campath's own CSV and JSON (`campath.rs`), OpenUSD's text form
//! (`usd.rs`), glTF and GLB (`gltf.rs`) and nerfstudio's `camera_path.json` (`nerfstudio.rs`).
//! Every reader gives campath's axes: Y up, and the camera's u (right), v (up) and n (forward).

use std::path::Path;

use glam::{DMat3, DMat4, DVec2, DVec3};

use crate::camera::{Basis, Camera};
use crate::error::{Error, Result};

mod campath;
pub mod fit;
mod gltf;
mod nerfstudio;
mod usd;

/// One camera of a source, at one time.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sample {
    /// Seconds from the source's start (its first frame or time code 0).
    pub time: f64,
    /// The centre of projection (the eye), world coordinates, campath's axes (Y up).
    pub eye: DVec3,
    /// The camera's right (u), up (v) and forward (n), world, orthonormal.
    pub basis: Basis,
    /// The picture's width and height on the plane one unit in front of the eye: twice the
    /// tangents of the half angles of view, for a centred lens.
    pub window: DVec2,
    /// The picture's centre on that plane, from the forward axis, along u and v: the lens shift.
    pub shift: DVec2,
}

impl Sample {
    /// The sample of campath's camera `cam` at `time` seconds.
    pub fn of_camera(time: f64, cam: &Camera) -> Sample {
        let d = -cam.cop_view.z;
        Sample {
            time,
            eye: cam.cop_world(),
            basis: cam.basis,
            window: cam.window / d,
            shift: -cam.cop_view.truncate() / d,
        }
    }

    /// The sample of a camera whose camera-to-world matrix is `m`, looking down its local −Z
    /// with +Y up (OpenGL's, USD's, glTF's, Blender's and nerfstudio's camera), in a world
    /// whose up axis is `up`. The matrix may scale uniformly (which changes no picture); shear,
    /// a scale that differs between axes, a mirror or a projective row is refused, naming it.
    pub fn of_matrix(
        time: f64,
        m: DMat4,
        up: Up,
        window: DVec2,
        shift: DVec2,
    ) -> std::result::Result<Sample, String> {
        let m = up.to_campath() * m;
        let r = DMat3::from_mat4(m);
        let (x, y, z) = (r.x_axis, r.y_axis, r.z_axis);
        let lengths = [x.length(), y.length(), z.length()];
        let scale = lengths.iter().sum::<f64>() / 3.0;
        if !(m.is_finite() && scale > 0.0) {
            return Err("the camera's transform is not finite, or scales it to nothing".into());
        }
        let row = m.row(3);
        if row != glam::DVec4::new(0.0, 0.0, 0.0, 1.0) {
            return Err(format!(
                "the camera's transform is projective (its last row is {row})"
            ));
        }
        const SLACK: f64 = 1e-6;
        if lengths.iter().any(|l| (l / scale - 1.0).abs() > SLACK) {
            let [a, b, c] = lengths;
            return Err(format!(
                "the camera is scaled unevenly (its axes are scaled {a}, {b}, {c}): campath's \
                 camera has no such distortion"
            ));
        }
        let cosines = [x.dot(y), y.dot(z), z.dot(x)].map(|c| c / (scale * scale));
        if cosines.iter().any(|c| c.abs() > SLACK) {
            return Err(
                "the camera's transform shears it: its axes are not at right angles".into(),
            );
        }
        if r.determinant() < 0.0 {
            return Err("the camera's transform mirrors it".into());
        }
        let (u, v, n) = (x / lengths[0], y / lengths[1], -z / lengths[2]);
        Ok(Sample {
            time,
            eye: m.w_axis.truncate(),
            basis: Basis { u, v, n },
            window,
            shift,
        })
    }
}

/// A source's up axis.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Up {
    /// +Y up, as campath, glTF and USD by default.
    Y,
    /// +Z up, as Blender and a USD stage with `upAxis = "Z"`: its (x, y, z) is campath's
    /// (x, z, −y), the inverse of the Blender script's map.
    Z,
}

impl Up {
    /// The rotation taking the source's world to campath's.
    pub fn to_campath(self) -> DMat4 {
        match self {
            Up::Y => DMat4::IDENTITY,
            Up::Z => DMat4::from_rotation_x(-std::f64::consts::FRAC_PI_2),
        }
    }
}

/// A camera read from a source.
#[derive(Debug, Clone, PartialEq)]
pub struct Source {
    /// The samples, in time order.
    pub samples: Vec<Sample>,
    /// Frames per second, where the source says.
    pub fps: Option<f64>,
    /// The picture's size in pixels, where the source says.
    pub size: Option<(u32, u32)>,
    /// The camera's name or path in the source.
    pub camera: String,
    /// How far in front of the eye the source puts its view plane (campath's own exports: the
    /// COP's distance), where the fitted file's VRP goes; None: one unit.
    pub view_distance: Option<f64>,
}

/// The formats `import` reads.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Format {
    /// campath's `path --format csv`.
    Csv,
    /// campath's `path --format json`, or nerfstudio's `camera_path.json`.
    Json,
    /// OpenUSD's text form.
    Usda,
    /// glTF 2.0, JSON or binary.
    Gltf,
}

impl Format {
    /// The format a file's extension names.
    pub fn of_extension(path: &Path) -> Option<Format> {
        let ext = path.extension()?.to_str()?.to_ascii_lowercase();
        Some(match ext.as_str() {
            "csv" => Format::Csv,
            "json" => Format::Json,
            // A binary `.usd`, `.usdc` or `.usdz` is refused by the USDA reader, with how to
            // convert it.
            "usda" | "usd" | "usdc" | "usdz" => Format::Usda,
            "gltf" | "glb" => Format::Gltf,
            _ => return None,
        })
    }
}

/// Reads `path`'s camera (the one named `camera`, when the source has several).
pub fn read(path: &Path, camera: Option<&str>) -> Result<Source> {
    let bad = |message: String| Error::Import {
        path: path.to_path_buf(),
        message,
    };
    let format = Format::of_extension(path).ok_or_else(|| {
        bad("campath imports .csv and .json (campath's own, or nerfstudio's camera_path.json), .usda, .gltf and .glb: name the file so".into())
    })?;
    let bytes = std::fs::read(path).map_err(Error::read(path))?;
    let source = match format {
        Format::Csv => campath::csv(&bytes, camera),
        Format::Json if nerfstudio::is_camera_path(&bytes) => nerfstudio::read(&bytes, camera),
        Format::Json => campath::json(&bytes, camera),
        Format::Usda => usd::read(&bytes, camera),
        Format::Gltf => gltf::read(&bytes, path, camera),
    }
    .map_err(bad)?;
    if source.samples.is_empty() {
        return Err(bad(format!(
            "the camera {:?} has no samples",
            source.camera
        )));
    }
    Ok(source)
}
