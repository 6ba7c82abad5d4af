//! OVITO 3 (PyPI `ovito`) on a bench scene, headless, with its Tachyon and OSPRay renderers, timed
//! as a whole Python process: the peer for particle scenes.
//!
//! The spheres go to OVITO as raw f64 values, and each frame's camera as a perspective viewport:
//! its position the COP, its direction VRP − COP, its up the VUV, its vertical field of view the
//! window's. OVITO's cameras have their COP on the axis, so a scene whose COP is off it is refused.
//! OVITO lights a scene its own way (a light from the camera), so only the geometry and the time
//! compare: `render_ovito.py` renders every frame to a PNG at one sample a pixel, with shadows and
//! without ambient occlusion.

use std::ffi::OsString;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

use super::{BenchError, BenchScene, Result};
use campath::document::Document;
use campath::Error;

/// The script each run of OVITO executes.
const SCRIPT: &str = include_str!("render_ovito.py");

/// The Python that imports `ovito`: `CAMPATH_OVITO_PYTHON`, else `python3`.
pub fn python() -> OsString {
    std::env::var_os("CAMPATH_OVITO_PYTHON").unwrap_or_else(|| "python3".into())
}

/// One of OVITO's renderers.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
pub enum Renderer {
    Tachyon,
    Ospray,
}

impl Renderer {
    fn arg(self) -> &'static str {
        match self {
            Renderer::Tachyon => "tachyon",
            Renderer::Ospray => "ospray",
        }
    }
}

fn tool_error(message: String) -> BenchError {
    BenchError::Tool {
        tool: "ovito",
        message,
    }
}

/// Fails, naming the install, when [`python`] cannot import `ovito`.
pub fn check() -> Result<()> {
    let py = python();
    let run = Command::new(&py)
        .args(["-c", "import ovito.vis"])
        .output()
        .map_err(|e| tool_error(format!("cannot run {}: {e}", py.to_string_lossy())))?;
    if !run.status.success() {
        return Err(tool_error(format!(
            "{} cannot import ovito (pip install ovito==3.17.2, and set CAMPATH_OVITO_PYTHON to that Python): {}",
            py.to_string_lossy(),
            String::from_utf8_lossy(&run.stderr).trim()
        )));
    }
    Ok(())
}

/// The image size, background and first `frames` cameras of `doc`, as `render_ovito.py` reads
/// them: each camera's position (the COP), direction (VRP − COP), up (the VUV) and vertical field
/// of view in radians. A COP off the axis is refused.
pub fn shot(doc: &Document, frames: u64) -> Result<serde_json::Value> {
    let mut cameras = Vec::new();
    for item in doc.cameras().take(frames as usize) {
        let (frame, cam) = item?;
        let cop = cam.cop_view;
        if cop.x != 0.0 || cop.y != 0.0 {
            return Err(BenchError::Usage(format!(
                "{}: frame {frame}'s COP is off the view axis (u {}, v {}), which OVITO's cameras cannot take",
                doc.path().display(),
                cop.x,
                cop.y
            )));
        }
        let (position, direction) = (cam.cop_world(), cam.vrp_world - cam.cop_world());
        let fov = 2.0 * (cam.window.y * 0.5).atan2(-cop.z);
        cameras.push(serde_json::json!({
            "position": position.to_array(),
            "direction": direction.to_array(),
            "up": cam.basis.v.to_array(),
            "fov": fov,
        }));
    }
    let raster = doc.raster();
    Ok(serde_json::json!({
        "width": raster.width,
        "height": raster.height,
        "background": doc.scene().background.to_array(),
        "cameras": cameras,
    }))
}

/// `doc`'s spheres as `render_ovito.py` reads them: x, y, z, radius, r, g, b, little-endian f64.
pub fn sphere_bytes(doc: &Document) -> Vec<u8> {
    let mut bytes = Vec::with_capacity(doc.scene().spheres.len() * 56);
    for s in doc.scene().spheres.iter() {
        let (c, k) = (s.center_world, s.color);
        for v in [c.x, c.y, c.z, s.radius, k.x, k.y, k.z] {
            bytes.extend_from_slice(&v.to_le_bytes());
        }
    }
    bytes
}

/// Where [`time`] writes `renderer`'s frames of scene `name`.
pub fn frames_dir(dir: &Path, name: &str, renderer: Renderer) -> PathBuf {
    dir.join(format!("{name}-{}", renderer.arg()))
}

/// Renders the first `frames` frames of `doc` with each of OVITO's `renderers` into its
/// [`frames_dir`], and returns each one's wall ms per frame of its whole process (start-up,
/// import, reading the spheres and every frame). The spheres and cameras are written once for
/// all of them, and removed after the last, whether it ran or not.
pub fn time(
    dir: &Path,
    s: &BenchScene,
    doc: &Document,
    frames: u64,
    renderers: &[Renderer],
) -> Result<Vec<f64>> {
    let write = |p: &PathBuf, bytes: &[u8]| std::fs::write(p, bytes).map_err(Error::write(p));
    let script = dir.join("render_ovito.py");
    write(&script, SCRIPT.as_bytes())?;
    let spheres = dir.join(format!("{}.ovito.f64", s.name));
    let cameras = dir.join(format!("{}.ovito.json", s.name));
    let shot = shot(doc, frames)?;
    write(&spheres, &sphere_bytes(doc))?;
    let written = write(&cameras, shot.to_string().as_bytes()).map_err(BenchError::from);
    let times = written.and_then(|()| {
        renderers
            .iter()
            .map(|&r| {
                run(
                    &script,
                    [&spheres, &cameras],
                    &frames_dir(dir, &s.name, r),
                    r,
                    frames,
                )
            })
            .collect()
    });
    for path in [&spheres, &cameras] {
        if path.exists() {
            std::fs::remove_file(path).map_err(Error::write(path))?;
        }
    }
    times
}

/// One OVITO process of `script` on the `inputs` (spheres, cameras) with `renderer`, writing
/// into `out` (emptied first): its wall ms per frame.
fn run(
    script: &Path,
    inputs: [&PathBuf; 2],
    out: &Path,
    renderer: Renderer,
    frames: u64,
) -> Result<f64> {
    if out.exists() {
        std::fs::remove_dir_all(out).map_err(Error::write(out))?;
    }
    std::fs::create_dir_all(out).map_err(Error::write(out))?;
    let py = python();
    let started = Instant::now();
    let run = Command::new(&py)
        .arg(script)
        .args(inputs)
        .arg(renderer.arg())
        .arg(out)
        .output()
        .map_err(|e| tool_error(format!("cannot run {}: {e}", py.to_string_lossy())))?;
    let ms = started.elapsed().as_secs_f64() * 1e3 / frames as f64;
    if !run.status.success() {
        return Err(tool_error(format!(
            "{} failed: {}",
            renderer.arg(),
            String::from_utf8_lossy(&run.stderr).trim()
        )));
    }
    Ok(ms)
}
