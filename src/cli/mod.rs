//! The `campath` command line: clap definitions with typed option values, and the dispatch to the
//! verbs (render, merge, hash, verify, path, check) and the tooling (preview, plot, report,
//! bench). Binary-only: the library never imports clap, indicatif or plotters.

mod args;
mod chart;
mod error;
mod failures;
mod junit;
mod man;
mod path;
mod plot;
mod preview;
mod progress;
mod report;
mod review;
pub(crate) mod stats;
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

use crate::document::Document;
use crate::output::lock::{Claim, FolderLock};
use crate::output::{check, folder_of, pictures, Use, LOCK};
use crate::Error;
use args::{at_least_one, default_out_dir, FrameSpec, NoWait, Shot, StatsJson};
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
    Preview {
        #[command(flatten)]
        shot: Shot,
        /// Output folder [default: out/<file stem>/].
        #[arg(long)]
        out: Option<PathBuf>,
        /// Width of each small frame in pixels, up to the file's width [default: 240, or the
        /// file's width if smaller].
        #[arg(long)]
        width: Option<u32>,
        /// Frames on the contact sheet, spread evenly, up to the file's frame count [default: 12,
        /// or every frame if fewer].
        #[arg(long)]
        count: Option<u64>,
    },
    /// Draw the camera path from above and from the side, with keyframes, targets, frustums
    /// and spheres.
    Plot {
        #[command(flatten)]
        shot: Shot,
        /// Where the PNG goes [default: out/<file stem>/plot.png].
        #[arg(long)]
        out: Option<PathBuf>,
        /// A frustum every N frames, N ≥ 1 [default: about eight along the path].
        #[arg(long, value_parser = at_least_one)]
        every: Option<u64>,
    },
    /// Combine the shard manifests hashes.part-K-of-N.txt in DIR into DIR/hashes.txt, or refuse
    /// naming what is missing.
    Merge {
        /// The output folder the shards rendered into.
        dir: PathBuf,
        #[command(flatten)]
        no_wait: NoWait,
    },
    /// Print `<frame> <sha256>` per frame without writing images.
    Hash {
        #[command(flatten)]
        shot: Shot,
        #[arg(long)]
        frames: Option<FrameSpec>,
        /// Also print the timing summary to standard error.
        #[arg(long)]
        stats: bool,
        #[command(flatten)]
        stats_json: StatsJson,
    },
    /// Check every shot (*.ron) under DIR against its golden NAME.golden/hashes.txt beside it;
    /// one line per shot and a summary; exit 1 when any differs or has no golden, 2 when a shot
    /// cannot be checked.
    Test(suite::TestArgs),
    /// Compare fresh renders with golden hashes; exit 1 naming every frame that differs.
    Verify(verify::VerifyArgs),
    /// Print the evaluated camera per frame (CSV, JSON, .chan for Nuke and Blender), or the
    /// whole shot as glTF, a Blender script or an OpenUSD stage.
    Path {
        #[command(flatten)]
        shot: Shot,
        /// [default: from --out's extension (.csv, .json, .chan, .gltf, .glb, .py, .usda), else csv]
        #[arg(long, value_parser = args::path_format())]
        format: Option<crate::export::PathFormat>,
        /// Write to this file instead of standard output (glTF: binary when it ends in .glb; USD:
        /// .usda or .usd).
        #[arg(long)]
        out: Option<PathBuf>,
        /// Write every place relative to this point of campath's world (glTF and Blender keep
        /// places in f32: a shot far from the origin needs one near it).
        #[arg(long, value_name = "X,Y,Z", value_parser = args::point, allow_hyphen_values = true)]
        origin: Option<glam::DVec3>,
    },
    /// Validate a file, report every problem, and evaluate every frame's camera.
    Check {
        #[command(flatten)]
        shot: Shot,
        /// Exit 1 when there are warnings about the motion (jumps, the COP inside a sphere, a
        /// target at the camera, the up vector flipping).
        #[arg(long)]
        strict: bool,
    },
    /// Error against run time: every accuracy setting against a 16×16-sample reference.
    Report {
        #[command(flatten)]
        shot: Shot,
        /// The frame to measure [default: the middle frame].
        #[arg(long)]
        frame: Option<u64>,
        /// Timed renders per setting (the median is reported).
        #[arg(long, default_value_t = 3, value_parser = clap::value_parser!(u64).range(1..=1000))]
        runs: u64,
        /// Where the log-log plot goes [default: out/<file stem>/report.png].
        #[arg(long)]
        plot: Option<PathBuf>,
    },
    /// Render the sequence (keeping the frames still valid) and encode it with ffmpeg: H.264 MP4,
    /// or with --lossless an FFV1 RGB Matroska file whose frames hash to hashes.txt. Ctrl-C
    /// during the encode removes the partial video (exit 130).
    Video(video::VideoArgs),
    /// Re-render a small preview on every save of FILE, with a page (preview.html) that shows
    /// it and reloads its pictures; Ctrl-C stops.
    Watch {
        #[command(flatten)]
        shot: Shot,
        /// Where the preview and its page go [default: out/<file stem>-watch/].
        #[arg(long)]
        out: Option<PathBuf>,
        /// Width of the small frames in pixels [default: 240, or the file's width if smaller];
        /// a width above the file's (which a save may change) gives the file's, and says so.
        #[arg(long, value_parser = clap::value_parser!(u32).range(1..=16384))]
        width: Option<u32>,
        #[command(flatten)]
        no_wait: NoWait,
    },
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

/// Runs the command. Ok(false) means it ran and found a difference (verify): exit 1.
/// When the process started (first called from `main`): the origin of first-frame latency.
pub fn started() -> std::time::Instant {
    static START: std::sync::OnceLock<std::time::Instant> = std::sync::OnceLock::new();
    *START.get_or_init(std::time::Instant::now)
}

pub fn run(cli: Cli, out: &mut dyn Write) -> Result<bool> {
    if let Some(Err(e)) = crate::render::Simd::from_env() {
        return Err(error::CliError::Usage(format!("CAMPATH_SIMD: {e}")));
    }
    match cli.command {
        Command::Render(a) => verbs::render(a, out)?,
        Command::Preview {
            shot: Shot { file },
            out: dir,
            width,
            count,
        } => {
            let doc = Document::load(&file)?;
            let dir = dir.unwrap_or_else(|| default_out_dir(&file));
            let width = width.unwrap_or(doc.raster.width.min(240));
            let count = count.unwrap_or(doc.animation.frames.min(12));
            preview::check(&doc, width, count)?;
            doc.check_path()?;
            // As render: a golden or a folder of other files is refused, and a folder is
            // written by one run at a time.
            check(&dir, Use::Frames).map_err(|r| error::CliError::refused("--out", &dir, &r))?;
            let _lock = progress::with_wait(false, false, |wait| {
                FolderLock::acquire(&dir, Claim::Whole, wait)
            })?;
            let (png, gif) = preview::write(&doc, &dir, width, count, true)?;
            let gif = gif.expect("asked for the GIF");
            writeln!(out, "wrote {} and {}", png.display(), gif.display())
                .map_err(Error::stdout)?;
        }
        Command::Plot {
            shot: Shot { file },
            out: png,
            every,
        } => {
            let png = png.unwrap_or_else(|| default_out_dir(&file).join(pictures::PLOT));
            args::check_extension("--out", &png, &["png"], "plot writes PNG")?;
            let doc = Document::load(&file)?;
            args::check_writable(&png)?;
            let every = every.unwrap_or((doc.animation.frames / 8).max(1));
            // Into a folder campath's runs write (one with their lock file), as one of them.
            let folder = folder_of(&png);
            let _lock = match folder.join(LOCK).is_file() {
                true => Some(progress::with_wait(false, false, |wait| {
                    FolderLock::acquire(folder, Claim::Whole, wait)
                })?),
                false => None,
            };
            plot::write(&doc, &png, every)?;
            writeln!(out, "wrote {}", png.display()).map_err(Error::stdout)?;
        }
        Command::Merge { dir, no_wait } => verbs::merge(&dir, no_wait.on, out)?,
        Command::Hash {
            shot: Shot { file },
            frames,
            stats,
            stats_json,
        } => verbs::hash(&file, frames, stats, stats_json.path.as_deref())?,
        Command::Test(a) => return suite::run(a, out),
        Command::Verify(a) => return verify::verify(a, out),
        Command::Path {
            shot: Shot { file },
            format,
            out: file_out,
            origin,
        } => {
            let format = args::resolve_format(format, file_out.as_deref())?;
            let origin = origin.unwrap_or_default();
            path::path(&file, format, file_out.as_deref(), origin, out)?
        }
        Command::Check {
            shot: Shot { file },
            strict,
        } => return verbs::check(&file, strict, out),
        Command::Report {
            shot: Shot { file },
            frame,
            runs,
            plot,
        } => {
            let plot = plot.unwrap_or_else(|| default_out_dir(&file).join(pictures::REPORT));
            args::check_extension("--plot", &plot, &["png"], "the report's plot is PNG")?;
            report::run(&file, frame, runs as usize, &plot, out)?
        }
        Command::Video(a) => video::run(a, out)?,
        Command::Watch {
            shot: Shot { file },
            out: dir,
            width,
            no_wait,
        } => {
            let dir = dir.unwrap_or_else(|| {
                let mut dir = default_out_dir(&file).into_os_string();
                dir.push("-watch");
                PathBuf::from(dir)
            });
            watch::run(&file, &dir, width, no_wait.on, out)?
        }
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
            let mut source = std::error::Error::source(&e);
            while let Some(s) = source {
                eprintln!("  caused by: {s}");
                source = s.source();
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
        ErrorKind::DisplayHelp | ErrorKind::DisplayVersion => {
            let _ = e.print();
            return ExitCode::SUCCESS;
        }
        // `campath` alone: the help, on standard error, as a usage error.
        ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand => {
            let _ = e.print();
            return ExitCode::from(2);
        }
        // The benchmark against POV-Ray left the binary: say where it went.
        ErrorKind::InvalidSubcommand
            if e.get(ContextKind::InvalidSubcommand)
                .map(|v| v.to_string())
                .as_deref()
                == Some("bench") =>
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
