//! The `campath` command line: clap definitions with typed option values, and the dispatch to the
//! verbs (render, merge, hash, verify, path, check) and the tooling (preview, plot, report).
//! Binary-only: the library never imports clap, indicatif or plotters.

mod approve;
mod args;
mod chart;
mod error;
mod failures;
mod import;
mod junit;
mod man;
mod path;
mod plot;
mod preview;
mod progress;
mod report;
mod review;
pub(crate) mod stats;
mod studio;
mod suite;
pub(crate) mod table;
mod verbs;
mod verify;
mod video;
mod watch;

use std::io::Write;
use std::path::PathBuf;
use std::process::ExitCode;

use clap::error::{ContextKind, ErrorKind};
use clap::{Parser, Subcommand};

use crate::Error;
use args::NoWait;
pub use error::Result;

#[derive(Parser)]
#[command(
    name = "campath",
    version,
    about = "Animate a general UVN camera from a RON keyframe file and ray cast spheres"
)]
pub struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Render frames to DIR/frame_NNNN.png and DIR/hashes.txt, keeping the frames still valid.
    Render(verbs::RenderArgs),
    /// Write a contact sheet (preview.png) and an animated GIF (preview.gif) at a small size.
    Preview(preview::PreviewArgs),
    /// Draw the camera path from above and from the side, with keyframes, targets, frustums
    /// and spheres.
    Plot(plot::PlotArgs),
    /// Combine the shard manifests hashes.part-K-of-N.txt in DIR into DIR/hashes.txt, or refuse
    /// naming what is missing.
    Merge {
        /// The output folder the shards rendered into.
        dir: PathBuf,
        #[command(flatten)]
        no_wait: NoWait,
    },
    /// Print `<frame> <sha256>` per frame without writing images.
    Hash(verbs::HashArgs),
    /// Check every shot (*.ron) under DIR against its golden NAME.golden/hashes.txt beside it;
    /// one line per shot and a summary; exit 1 when any differs or has no golden, 2 when a shot
    /// cannot be checked.
    Test(suite::TestArgs),
    /// Compare fresh renders with golden hashes; exit 1 naming every frame that differs.
    Verify(verify::VerifyArgs),
    /// Go through the pending goldens that failing tests left: see how each shot differs,
    /// then accept or reject it (keys on a terminal; --accept or --reject off one).
    Review(approve::ReviewArgs),
    /// Print the evaluated camera per frame (CSV, JSON, .chan for Nuke and Blender), or the
    /// whole shot as glTF, a Blender script or an OpenUSD stage.
    Path(path::PathArgs),
    /// Read a camera another program animated (campath's CSV or JSON, OpenUSD, glTF,
    /// nerfstudio) and write a keyframe file with the fewest keys that reproduce it within
    /// --tolerance pixels.
    Import(import::ImportArgs),
    /// Validate a file, report every problem, and evaluate every frame's camera.
    Check(verbs::CheckArgs),
    /// Error against run time: every accuracy setting against a 16×16-sample reference.
    Report(report::ReportArgs),
    /// Render the sequence (keeping the frames still valid) and encode it with ffmpeg: H.264 MP4,
    /// or with --lossless an FFV1 RGB Matroska file whose frames hash to hashes.txt. Ctrl-C
    /// during the encode removes the partial video (exit 130).
    Video(video::VideoArgs),
    /// Serve a page on 127.0.0.1 to scrub, play and fly the shot and set its keys into FILE,
    /// following FILE's saves; prints the page's address with its token. Ctrl-C stops.
    Studio(studio::StudioArgs),
    /// The studio's page, read-only: follow FILE's saves beside your editor, scrub, play and
    /// fly the shot; never writes. Ctrl-C stops.
    Watch(watch::WatchArgs),
    /// Print a shell completion script: `campath completions bash > /etc/bash_completion.d/campath`.
    Completions {
        #[arg(value_enum)]
        shell: clap_complete::Shell,
    },
    /// Print the manual (roff), every command with its options, exit status, environment and the
    /// file: `campath man > campath.1; man ./campath.1`.
    Man {
        /// Instead, write the manual as DIR/campath.1 and a page per command
        /// (DIR/campath-render.1, …).
        #[arg(long, value_name = "DIR")]
        dir: Option<PathBuf>,
    },
}

/// When the process started (first called from `main`): the origin of first-frame latency.
pub fn started() -> std::time::Instant {
    static START: std::sync::OnceLock<std::time::Instant> = std::sync::OnceLock::new();
    *START.get_or_init(std::time::Instant::now)
}

/// Runs the command. Ok(false) means it ran and found a difference (verify): exit 1.
pub fn run(cli: Cli, out: &mut dyn Write) -> Result<bool> {
    if let Some(Err(e)) = crate::render::Simd::from_env() {
        return Err(error::CliError::Usage(format!("CAMPATH_SIMD: {e}")));
    }
    match cli.command {
        Command::Render(a) => verbs::render(a, out)?,
        Command::Preview(a) => preview::run(a, out)?,
        Command::Plot(a) => plot::run(a, out)?,
        Command::Merge { dir, no_wait } => verbs::merge(&dir, no_wait.on, out)?,
        Command::Hash(a) => verbs::hash(a)?,
        Command::Test(a) => return suite::run(a, out),
        Command::Verify(a) => return verify::verify(a, out),
        Command::Review(a) => return approve::run(a, out),
        Command::Path(a) => path::path(a, out)?,
        Command::Import(a) => import::run(a, out)?,
        Command::Check(a) => return verbs::check(a, out),
        Command::Report(a) => report::run(a, out)?,
        Command::Video(a) => video::run(a, out)?,
        Command::Studio(a) => studio::run(a, out)?,
        Command::Watch(a) => watch::run(a, out)?,
        Command::Completions { shell } => {
            let mut cmd = <Cli as clap::CommandFactory>::command();
            // clap_complete panics on a failed write: generate into memory first.
            let mut script = Vec::new();
            clap_complete::generate(shell, &mut cmd, "campath", &mut script);
            out.write_all(&script).map_err(Error::stdout)?;
        }
        Command::Man { dir: None } => man::page(out)?,
        Command::Man { dir: Some(dir) } => {
            for page in man::write_pages(&dir)? {
                writeln!(out, "wrote {}", page.display()).map_err(Error::stdout)?;
            }
        }
    }
    Ok(true)
}

/// The `campath` command: parses the arguments, runs the command, prints the error chain, and
/// exits 2 on bad input, 3 when an outside program is missing or failed, 130 when Ctrl-C stops
/// `video`'s encode, 1 on other failures.
pub fn main() -> ExitCode {
    started();
    let parsed = match Cli::try_parse() {
        Ok(parsed) => parsed,
        Err(e) => return option_error(e),
    };
    let stdout = std::io::stdout();
    let mut out = stdout.lock();
    match run(parsed, &mut out) {
        Ok(true) => ExitCode::SUCCESS,
        Ok(false) => ExitCode::from(1),
        // The reader of standard output went away (`campath path … | head`): end quietly.
        Err(e) if e.is_broken_pipe() => ExitCode::SUCCESS,
        Err(e) => {
            let _ = out.flush();
            eprintln!("campath: error: {e}");
            for s in std::iter::successors(std::error::Error::source(&e), |s| s.source()) {
                eprintln!("  caused by: {s}");
            }
            ExitCode::from(e.exit_status())
        }
    }
}

/// Help and version go to standard output (exit 0), and the help for a missing command to
/// standard error (exit 2); a bad option is printed in campath's own style, `campath: error: …`,
/// with clap's hint, and exits 2, like any other bad input.
fn option_error(e: clap::Error) -> ExitCode {
    match e.kind() {
        // clap's exit status: 0 for help and version, 2 for `campath` alone (a usage error).
        ErrorKind::DisplayHelp
        | ErrorKind::DisplayVersion
        | ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand => {
            let _ = e.print();
            return ExitCode::from(e.exit_code() as u8);
        }
        // The benchmark against POV-Ray left the binary: say where it went.
        ErrorKind::InvalidSubcommand
            if e.get(ContextKind::InvalidSubcommand)
                .is_some_and(|v| v.to_string() == "bench") =>
        {
            eprintln!(
                "campath: error: `campath bench` is now a benchmark of campath's source tree: \
                 cargo bench --features bench --bench peers"
            );
            return ExitCode::from(2);
        }
        _ => {}
    }
    let text = e.render().to_string();
    let text = text.strip_prefix("error: ").unwrap_or(&text);
    eprintln!("campath: error: {}", text.trim_end());
    ExitCode::from(2)
}
