//! `cargo bench --features bench --bench peers -- [OPTIONS]`: campath timed against POV-Ray
//! 3.7 (and, on the dense scaling scenes, OVITO 3) on generated scenes, whole processes each. A developer's tool, not part of
//! the `campath` binary; docs/performance.md keeps its tables.
// The unit tests of `bench` run in the `it` test crate (tests/it/bench.rs), which includes the
// module; this target only compiles them.
#![cfg_attr(test, allow(unused))]

mod bench;

use std::path::PathBuf;
use std::process::ExitCode;

use clap::Parser;

/// Time generated scenes in campath, POV-Ray 3.7 and OVITO 3; print a table.
#[derive(Parser)]
#[command(name = "peers")]
struct Args {
    /// Where the scene files and renders go.
    #[arg(long, default_value = "out/bench")]
    out: PathBuf,
    /// Frames POV-Ray renders per scene, and campath with it, from frame 0 (0 skips POV-Ray;
    /// campath then renders every frame).
    #[arg(long, default_value_t = 8)]
    pov_frames: u64,
    /// With --scaling, frames OVITO 3 renders of each dense scene with Tachyon and with OSPRay
    /// (0 skips OVITO; the Python that imports `ovito` is CAMPATH_OVITO_PYTHON, else python3).
    #[arg(long, default_value_t = 0)]
    ovito_frames: u64,
    /// Timed campath processes per scene and output (the median is reported); POV-Ray,
    /// seconds to minutes a scene, runs once.
    #[arg(long, default_value_t = 5, value_parser = clap::value_parser!(u64).range(1..=100))]
    runs: u64,
    /// Only these scenes (of the table, or with --scaling of the scaling scenes),
    /// comma-separated [default: all].
    #[arg(long, value_delimiter = ',')]
    scenes: Vec<String>,
    /// Print the rows as JSON instead of a table.
    #[arg(long)]
    json: bool,
    /// Instead of the POV-Ray table, time the scaling scenes (100 to 1,000,000 spheres; 720p
    /// to 4K), hash-only.
    #[arg(long)]
    scaling: bool,
    /// With --scaling, keep each scene's files (keyframe file, PLY, POV-Ray scene) in --out
    /// after timing it, to run campath on them again.
    #[arg(long)]
    keep: bool,
    /// Passed by `cargo bench` to every bench target; ignored.
    #[arg(long, hide = true)]
    bench: bool,
}

fn main() -> ExitCode {
    let a = Args::parse();
    let out = &mut std::io::stdout().lock();
    let runs = a.runs as usize;
    let options = bench::Options {
        pov_frames: a.pov_frames,
        ovito_frames: a.ovito_frames,
        runs,
        names: &a.scenes,
        json: a.json,
        scaling: a.scaling,
        keep: a.keep,
    };
    match bench::command(&a.out, &options, out) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("peers: error: {e}");
            e.exit_code()
        }
    }
}
