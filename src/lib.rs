//! campath: animates the general UVN camera of the lecture notes from a RON keyframe file and
//! ray casts each frame against spheres.
//!
//! The pipeline, one module per stage: `format` (the RON file) → [`document`]
//! (checked values) → `keyframes` (tracks) → [`animation`] (per-frame [`camera`]) →
//! `render` (ray caster over the [`scene`]) → [`frames`] (frames in order, with their keys) →
//! `output` (the output folder: PNGs, manifests, locks, who may write where), with
//! [`export`] for other programs. The `campath` command line is built on top of it; a Rust
//! program or test that uses the library alone depends on
//! `campath = { default-features = false }` and pulls in no command-line crate.
//!
//! A frame-hash test in one line is [`assert_shot!`]: a shot file against its golden folder
//! beside it; a failure leaves a pending golden for `campath review`. By hand, in a few lines:
//! load a file, evaluate frame 12's camera, render and hash its pixels, and compare with a
//! `hashes.txt`:
//!
//! ```
//! use campath::document::Document;
//! use campath::frames::{compare, hashes, render_frame};
//! use campath::golden::parse_hashes;
//! use campath::frame_hash;
//! use std::path::Path;
//!
//! let file = Path::new(env!("CARGO_MANIFEST_DIR")).join("animations/zoom.ron");
//! let doc = Document::load(&file)?.resized(64, 36)?; // smaller, for a quick test
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

// The public surface: a shot's document, its cameras, its frames and their hashes, goldens and
// frame-hash tests, and the exports. The rest is the crate's own.
pub mod animation;
pub mod camera;
pub mod document;
pub mod export;
pub mod frames;
pub mod golden;
pub mod import;
pub mod raster;
pub mod scene;
pub mod testing;

pub(crate) mod error;
pub(crate) mod format;
mod hash;
pub(crate) mod key;
pub(crate) mod keyframes;
pub(crate) mod mode;
pub(crate) mod motion;
pub(crate) mod output;
pub(crate) mod render;
pub(crate) mod splitmix;

#[cfg(feature = "cli")]
mod cli;

pub use error::{Error, Problem, Problems, Refusal, Result};
pub use hash::{frame_hash, FrameHash, FrameHasher};
pub use key::VERSION as RENDERER_VERSION;

/// The `campath` command line (feature `cli`): what the binary runs.
#[cfg(feature = "cli")]
#[doc(hidden)]
pub fn run_cli() -> std::process::ExitCode {
    cli::main()
}

/// What campath's own integration tests reach below the public surface: the renderer's paths,
/// the output folder, the generated scenes; and what the peers benchmark reads of the command line. Not an API: it changes with any release.
#[doc(hidden)]
pub mod internals {
    #[cfg(feature = "cli")]
    pub use crate::cli::{stats::Stats, table::Table};
    pub use crate::error::PROBLEMS_SHOWN;
    pub use crate::format::sphere_files::BLOCK_BYTES;
    pub use crate::motion::warnings;
    pub use crate::output::lock::Wait;
    pub use crate::output::manifest::parse_hashes;
    pub use crate::output::sequence::{lock, render, Event, RenderOptions, RenderSummary};
    pub use crate::render::{srgb_decode, srgb_encoder, Renderer, SceneIndex, Simd};
    pub use crate::splitmix::SplitMix;
}
