//! campath: animates the general UVN camera of the lecture notes from a RON keyframe file and
//! ray casts each frame against spheres.
//!
//! The pipeline, one module per stage: [`format`](mod@format) (RON file) → [`document`] (checked values) →
//! [`keyframes`] (tracks) → [`animation`] (per-frame [`camera`]) → [`render`] (ray caster over the
//! [`scene`]) → [`output`] (PNG, hashes). [`commands`] ties them together for the binary.

pub mod animation;
pub mod bench;
pub mod camera;
pub mod commands;
pub mod document;
pub mod error;
pub mod export;
pub mod format;
pub mod frames;
pub mod keyframes;
pub mod manifest;
pub mod output;
pub mod plot;
pub mod preview;
pub mod render;
pub mod report;
pub mod scene;
pub mod sequence;

pub use error::{Error, Result};
