//! nerfstudio's `camera_path.json`, as its viewer writes it (`nerfstudio/viewer/render_panel.py`)
//! and `ns-render camera-path` reads it (`get_path_from_json` in
//! `nerfstudio/cameras/camera_paths.py`, `_render_trajectory_video` in `scripts/render.py`):
//!
//! - `camera_path`: one entry per rendered frame, `camera_to_world` a 4×4 matrix flattened row by
//!   row (translation in the last column), OpenGL's camera (it looks down its local −Z with +Y
//!   up: the viewer turns viser's OpenCV camera 180° about X before writing it), and `fov` the
//!   vertical field of view in degrees. Its `aspect` is not what ns-render uses: the picture is
//!   `render_width` × `render_height` with square pixels (fx = fy), so the window's aspect is
//!   theirs. `render_time` is a dynamic scene's time (0 to 1), not the frame's: ignored.
//! - The world is Z-up: nerfstudio's data parsers turn the capture so that its mean up is +Z
//!   (`auto_orient_and_center_poses`, method "up", the default), and the viewer shows it so.
//! - Frame i is shown at i · `seconds` / frames (ns-render's rate is frames / `seconds`), or at
//!   i / `fps` in a file without `seconds`.
//! - `camera_type` "perspective" (or none, as ns-render assumes); fisheye, equirectangular and
//!   the stereo panoramas have no window to give and are refused.

use glam::{DMat4, DVec2};
use serde::Deserialize;

use super::{Sample, Source, Up};

/// The fields campath reads (the file has more: keyframes, smoothness, crop).
#[derive(Deserialize)]
struct CameraPath {
    camera_path: Vec<Frame>,
    render_width: f64,
    render_height: f64,
    fps: Option<f64>,
    seconds: Option<f64>,
    camera_type: Option<String>,
}

#[derive(Deserialize)]
struct Frame {
    camera_to_world: Vec<f64>,
    fov: f64,
}

/// Whether `bytes` is a nerfstudio camera path: a JSON object with `camera_path` (campath's own
/// JSON is an array).
pub fn is_camera_path(bytes: &[u8]) -> bool {
    // A map, not a struct: serde reads a struct from an array too.
    type Probe = std::collections::HashMap<String, serde::de::IgnoredAny>;
    serde_json::from_slice::<Probe>(bytes).is_ok_and(|map| map.contains_key("camera_path"))
}

/// The camera of a nerfstudio camera path.
pub fn read(bytes: &[u8], camera: Option<&str>) -> Result<Source, String> {
    if let Some(name) = camera {
        return Err(format!(
            "a nerfstudio camera path holds one camera, unnamed: leave out --camera {name:?}"
        ));
    }
    let path: CameraPath =
        serde_json::from_slice(bytes).map_err(|e| format!("not nerfstudio's camera path: {e}"))?;
    match path.camera_type.as_deref() {
        None | Some("perspective") => {}
        Some(other) => {
            return Err(format!(
                "camera_type {other:?}: campath's camera is perspective, and reads only \
                 \"perspective\" camera paths"
            ))
        }
    }
    let (width, height) = (path.render_width, path.render_height);
    let size = |x: f64| x >= 1.0 && x <= f64::from(u32::MAX) && x.fract() == 0.0;
    if !(size(width) && size(height)) {
        return Err(format!(
            "render_width {width} and render_height {height}: not a picture's size in pixels"
        ));
    }
    let count = path.camera_path.len();
    if count == 0 {
        return Err("camera_path is empty: no frames".into());
    }
    // ns-render's rate: frames over seconds; the viewer's `fps` where seconds are missing.
    let fps = match (path.seconds, path.fps) {
        (Some(s), _) => count as f64 / s,
        (None, Some(f)) => f,
        (None, None) => return Err("neither seconds nor fps: the frames have no times".into()),
    };
    if !(fps.is_finite() && fps > 0.0) {
        return Err(format!(
            "seconds {:?} and fps {:?} give no frame rate",
            path.seconds, path.fps
        ));
    }
    let mut samples = Vec::with_capacity(count);
    for (i, frame) in path.camera_path.iter().enumerate() {
        let at = |message: String| format!("camera_path[{i}]: {message}");
        let m: [f64; 16] = frame.camera_to_world.as_slice().try_into().map_err(|_| {
            at(format!(
                "camera_to_world has {} numbers, not 16 (a 4×4 matrix, row by row)",
                frame.camera_to_world.len()
            ))
        })?;
        if !(frame.fov > 0.0 && frame.fov < 180.0) {
            return Err(at(format!(
                "fov {}°: a vertical field of view is between 0° and 180°",
                frame.fov
            )));
        }
        let tall = 2.0 * libm::tan(frame.fov.to_radians() / 2.0);
        let window = DVec2::new(tall * width / height, tall);
        let time = match path.seconds {
            Some(s) => i as f64 * s / count as f64,
            None => i as f64 / fps,
        };
        // Row by row in the file; glam's matrices are column by column.
        let m = DMat4::from_cols_array(&m).transpose();
        samples.push(Sample::of_matrix(time, m, Up::Z, window, DVec2::ZERO).map_err(at)?);
    }
    Ok(Source {
        samples,
        // The rate the samples are at, so that the file's frame k is the path's frame k.
        fps: Some(fps),
        size: Some((width as u32, height as u32)),
        camera: "camera".into(),
        view_distance: None,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn campaths_own_json_is_not_a_camera_path() {
        assert!(!is_camera_path(b"[{\"frame\": 0}]"));
        assert!(is_camera_path(b"{\"camera_path\": []}"));
    }

    #[test]
    fn other_camera_types_are_refused() {
        let text = br#"{"camera_path": [], "render_width": 4, "render_height": 3,
            "seconds": 1, "camera_type": "fisheye"}"#;
        let e = read(text, None).unwrap_err();
        assert!(e.contains("fisheye"), "{e}");
    }
}
