//! nerfstudio's `camera_path.json`.

use super::Source;

/// Whether `bytes` is a nerfstudio camera path (an object with `camera_path`).
pub fn is_camera_path(_bytes: &[u8]) -> bool {
    false
}

/// The camera of a nerfstudio camera path.
pub fn read(_bytes: &[u8], _camera: Option<&str>) -> Result<Source, String> {
    Err("reading nerfstudio's camera paths is not built yet".into())
}
