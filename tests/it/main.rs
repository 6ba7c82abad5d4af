//! campath's integration tests, one binary so that the suite links once. Each module is an area;
//! `common` holds the helpers they share.

mod architecture;
#[cfg(feature = "bench")]
mod bench;
mod blender;
mod cli;
mod common;
mod determinism;
mod exports;
mod extreme;
mod fuzz;
mod gltf;
mod golden;
mod import;
mod import_sources;
mod incremental;
mod lock;
mod modes;
mod motion_blur;
mod povray;
mod production;
mod reference;
mod review;
mod simd;
mod sphere_files;
mod studio;
mod suites;
mod usd;
mod video;
mod warnings;
