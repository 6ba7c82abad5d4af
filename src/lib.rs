//! campath: animates the general UVN camera of the lecture notes from a RON keyframe file and
//! ray casts each frame against spheres.
//!
//! The pipeline, one module per stage: [`format`](mod@format) (the RON file) → [`document`]
//! (checked values) → [`keyframes`] (tracks) → [`animation`] (per-frame [`camera`]) →
//! [`render`] (ray caster over the [`scene`]) → [`frames`] (frames in order, with their keys) →
//! [`output`], [`manifest`] and [`sequence`] (PNGs, hashes, manifests, an output folder), with
//! [`export`] for other programs. The `campath` command line is built on top of it; a Rust
//! program or test that uses the library alone depends on
//! `campath = { default-features = false }` and pulls in no command-line crate.
//!
//! A frame-hash test in one line is [`testing::assert_shot`]: a shot file against its golden
//! folder beside it, approved with `CAMPATH_UPDATE=1`. By hand, in a few lines: load a file, evaluate frame 12's camera, render and hash
//! its pixels, and compare with a `hashes.txt`:
//!
//! ```
//! use campath::document::Document;
//! use campath::frames::{compare, hashes, render_frame};
//! use campath::manifest::parse_hashes;
//! use campath::output::frame_hash;
//! use std::path::Path;
//!
//! let file = Path::new(env!("CARGO_MANIFEST_DIR")).join("animations/zoom.ron");
//! let mut doc = Document::load(&file)?;
//! doc.raster.width = 64; // smaller, for a quick test
//! doc.raster.height = 36;
//!
//! let camera = doc.camera(12)?;
//! assert!(camera.cop_view.z < 0.0);
//! let pixels = render_frame(&doc, 12)?;
//! assert_eq!(pixels.len(), 64 * 36 * 3);
//! let hash = frame_hash(&pixels);
//!
//! // A hashes.txt is `<frame> <sha256> [<key>]` per line; here, one written by hand.
//! let golden = parse_hashes(Path::new("hashes.txt"), &format!("12 {hash}\n"))?;
//! assert!(compare(&doc, &golden)?.is_empty());
//! assert_eq!(hashes(&doc, 12..13)?, golden);
//! # Ok::<(), campath::Error>(())
//! ```

#![deny(missing_docs)]
#![deny(unsafe_code, clippy::undocumented_unsafe_blocks)]

pub mod animation;
pub mod camera;
pub mod document;
pub mod error;
pub mod export;
pub mod format;
pub mod frames;
pub mod golden;
pub mod hash;
pub mod keyframes;
pub mod lock;
pub mod manifest;
pub mod mode;
pub mod motion;
pub mod output;
pub mod raster;
pub mod render;
pub mod scene;
pub mod sequence;
pub mod splitmix;
pub mod testing;

pub use error::{Error, Result};
