//! The `campath` command: parses arguments, runs a verb from [`campath::commands`], prints the
//! error chain and exits 2 on bad input, 1 on other failures.

use clap::{Parser, Subcommand};
use std::io::{IsTerminal, Write};
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use campath::commands;
use campath::document::Document;
use campath::frames::FrameSet;
use campath::manifest::Shard;
use campath::output::Compression;
use campath::sequence::{self, Event, RenderOptions};
use campath::Error;

#[derive(Parser)]
#[command(
    name = "campath",
    version,
    about = "Animate a general UVN camera from a RON keyframe file and ray cast spheres"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Render frames to DIR/frame_NNNN.png and DIR/hashes.txt.
    Render {
        file: PathBuf,
        /// Output folder [default: out/<file stem>/].
        #[arg(long)]
        out: Option<PathBuf>,
        /// Frames to render: A..B (B excluded), A.., ..B, A..=B or K.
        #[arg(long)]
        frames: Option<String>,
        /// PNG compression: fast (default), default, or best (smallest files).
        #[arg(long, value_enum, default_value_t)]
        compression: Compression,
        /// Render only frames k with k mod N = K, into hashes.part-K-of-N.txt (see `merge`).
        #[arg(long, value_name = "K/N")]
        shard: Option<Shard>,
        /// Render every frame again, even those unchanged and complete in the output folder.
        #[arg(long)]
        force: bool,
        /// Print nothing.
        #[arg(long, short)]
        quiet: bool,
    },
    /// Write a contact sheet (preview.png) and an animated GIF (preview.gif) at a small size.
    Preview {
        file: PathBuf,
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
        file: PathBuf,
        /// Where the PNG goes [default: out/<file stem>/plot.png].
        #[arg(long)]
        out: Option<PathBuf>,
        /// A frustum every N frames, N ≥ 1 [default: about eight along the path].
        #[arg(long, value_parser = at_least_one)]
        every: Option<u64>,
    },
    /// Combine the shard manifests hashes.part-K-of-N.txt in DIR into DIR/hashes.txt.
    Merge { dir: PathBuf },
    /// Print `<frame> <sha256>` per frame without writing images.
    Hash {
        file: PathBuf,
        #[arg(long)]
        frames: Option<String>,
        /// Also print the timing summary to standard error.
        #[arg(long)]
        stats: bool,
    },
    /// Compare fresh renders with a hashes.txt; exit 1 naming every frame that differs.
    Verify { file: PathBuf, golden: PathBuf },
    /// Print the evaluated camera per frame: CSV, JSON, or .chan for Nuke and Blender.
    Path {
        file: PathBuf,
        #[arg(long, value_enum, default_value_t)]
        format: campath::export::PathFormat,
    },
    /// Validate a file, report every problem, and evaluate every frame's camera.
    Check { file: PathBuf },
    /// Error against run time: every accuracy setting against a 16×16-sample reference.
    Report {
        file: PathBuf,
        /// The frame to measure [default: the middle frame].
        #[arg(long)]
        frame: Option<u64>,
        /// Timed renders per setting (the median is reported).
        #[arg(long, default_value_t = 3)]
        runs: usize,
        /// Where the log-log plot goes [default: out/<file stem>/report.png].
        #[arg(long)]
        plot: Option<PathBuf>,
    },
    /// Time generated fly-through scenes in campath and in POV-Ray 3.7; print a table.
    Bench {
        /// Where the scene files and renders go.
        #[arg(long, default_value = "out/bench")]
        out: PathBuf,
        /// Frames POV-Ray renders per scene (0 skips POV-Ray).
        #[arg(long, default_value_t = 4)]
        pov_frames: u64,
        /// Only these scenes (fly100, fly1000, fly10000, small), comma-separated.
        #[arg(long, value_delimiter = ',')]
        scenes: Vec<String>,
    },
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let stdout = std::io::stdout();
    let mut out = stdout.lock();
    match run(cli.command, &mut out) {
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
            ExitCode::from(if e.is_bad_input() { 2 } else { 1 })
        }
    }
}

fn frames(doc: &Document, spec: Option<&str>) -> Result<std::ops::Range<u64>, Error> {
    match spec {
        Some(s) => commands::parse_frames(s, doc.animation.frames),
        None => Ok(0..doc.animation.frames),
    }
}

fn run(command: Command, out: &mut dyn Write) -> Result<bool, Error> {
    match command {
        Command::Render {
            file,
            out: dir,
            frames: spec,
            compression,
            shard,
            force,
            quiet,
        } => {
            let doc = Document::load(&file)?;
            let set = FrameSet {
                range: frames(&doc, spec.as_deref())?,
                shard,
            };
            let dir = dir.unwrap_or_else(|| default_out_dir(&file));
            let progress = if quiet {
                Progress::Quiet
            } else if std::io::stderr().is_terminal() {
                Progress::Bar(None)
            } else {
                Progress::Lines
            };
            let options = RenderOptions { compression, force };
            let mut progress = progress;
            let summary = sequence::render(&doc, &dir, &set, options, &mut |e| progress.event(e))?;
            progress.finish();
            if !quiet {
                writeln!(out, "{}", commands::render_line(&doc, &dir, &summary))
                    .map_err(Error::stdout)?;
            }
        }
        Command::Preview {
            file,
            out: dir,
            width,
            count,
        } => {
            let doc = Document::load(&file)?;
            let dir = dir.unwrap_or_else(|| default_out_dir(&file));
            let width = width.unwrap_or(doc.raster.width.min(240));
            let count = count.unwrap_or(doc.animation.frames.min(12));
            let (png, gif) = campath::preview::write(&doc, &dir, width, count)?;
            writeln!(out, "wrote {} and {}", png.display(), gif.display())
                .map_err(Error::stdout)?;
        }
        Command::Plot {
            file,
            out: png,
            every,
        } => {
            let doc = Document::load(&file)?;
            let png = png.unwrap_or_else(|| default_out_dir(&file).join("plot.png"));
            create_parent(&png)?;
            let every = every.unwrap_or((doc.animation.frames / 8).max(1));
            campath::plot::write(&doc, &png, every)?;
            writeln!(out, "wrote {}", png.display()).map_err(Error::stdout)?;
        }
        Command::Merge { dir } => {
            let frames = sequence::merge(&dir)?;
            writeln!(
                out,
                "merged {frames} frame(s) into {}",
                dir.join("hashes.txt").display()
            )
            .map_err(Error::stdout)?;
        }
        Command::Hash {
            file,
            frames: spec,
            stats,
        } => {
            let doc = Document::load(&file)?;
            let range = frames(&doc, spec.as_deref())?;
            let mut lines = std::io::BufWriter::new(std::io::stdout());
            let timing = campath::frames::hash_frames(&doc, range, |frame, hash| {
                writeln!(lines, "{frame} {hash}").map_err(Error::stdout)
            })?;
            lines.flush().map_err(Error::stdout)?;
            if stats {
                eprintln!("{}", commands::timing_line("hashed", "", &timing));
            }
        }
        Command::Verify { file, golden } => {
            let doc = Document::load(&file)?;
            return commands::verify(&doc, &golden, out);
        }
        Command::Path { file, format } => {
            let doc = Document::load(&file)?;
            let dropped = campath::export::write_path(&doc, format, out)?;
            if dropped.off_axis > 0 {
                eprintln!(
                    "campath: note: .chan has no place for an off-axis COP (distort): {} of {} frame(s), \
                     campath frames {}..={} (.chan frames {}..={}), are written as if the COP were on \
                     the VPN, so their pictures are centred; csv and json keep the COP",
                    dropped.off_axis,
                    doc.animation.frames,
                    dropped.first,
                    dropped.last,
                    dropped.first + 1,
                    dropped.last + 1
                );
            }
        }
        Command::Check { file } => commands::check(&Document::load(&file)?, out)?,
        Command::Report {
            file,
            frame,
            runs,
            plot,
        } => {
            let doc = Document::load(&file)?;
            let plot = plot.unwrap_or_else(|| default_out_dir(&file).join("report.png"));
            // Measuring takes a while: find out first that the plot can be written.
            check_writable(&plot)?;
            let frame = frame.unwrap_or(doc.animation.frames / 2);
            let rows = campath::report::renderer_report(&doc, frame, runs.max(1))?;
            writeln!(out, "Renderer, frame {frame} of {}:\n", file.display())
                .map_err(Error::stdout)?;
            write!(out, "{}", campath::report::renderer_table(&rows)).map_err(Error::stdout)?;
            campath::report::plot(&rows, &plot)?;
            writeln!(out, "\nplot: {}", plot.display()).map_err(Error::stdout)?;
            if let Some(path) = campath::report::path_report(&doc) {
                writeln!(
                    out,
                    "\nCamera path, speed: Uniform against a {}-step arc-length table:\n",
                    campath::report::PATH_REFERENCE_SAMPLES
                )
                .map_err(Error::stdout)?;
                write!(out, "{}", campath::report::path_table(&path)).map_err(Error::stdout)?;
            }
        }
        Command::Bench {
            out: dir,
            pov_frames,
            scenes,
        } => {
            let chosen: Vec<_> = campath::bench::SCENES
                .iter()
                .filter(|s| scenes.is_empty() || scenes.iter().any(|n| n == s.name))
                .copied()
                .collect();
            if chosen.is_empty() {
                return Err(Error::Usage(format!(
                    "--scenes: none of {scenes:?} is a bench scene"
                )));
            }
            let rows = campath::bench::run(&dir, pov_frames, &chosen, &mut std::io::stderr())?;
            write!(out, "{}", campath::bench::table(&rows)).map_err(Error::stdout)?;
        }
    }
    Ok(true)
}

/// How `render` reports progress on standard error.
enum Progress {
    /// Nothing at all, not even the summary.
    Quiet,
    /// A line per finished frame (for logs and pipes).
    Lines,
    /// A progress bar with frames per second and an ETA (for terminals), made at the start.
    Bar(Option<indicatif::ProgressBar>),
}

impl Progress {
    fn event(&mut self, e: Event) {
        match (self, e) {
            (Progress::Bar(bar), Event::Start { frames, kept }) => {
                let b = indicatif::ProgressBar::new(frames);
                b.set_style(
                    indicatif::ProgressStyle::with_template(
                        "{bar:40} {pos}/{len} frames, {rate}, ETA {eta}",
                    )
                    .expect("the template is valid")
                    .with_key(
                        "rate",
                        |s: &indicatif::ProgressState, w: &mut dyn std::fmt::Write| {
                            let _ = write!(w, "{:.1} frames/s", s.per_sec());
                        },
                    ),
                );
                b.inc(kept);
                *bar = Some(b);
            }
            (Progress::Bar(Some(bar)), Event::Written(_)) => bar.inc(1),
            (Progress::Lines, Event::Start { frames, kept }) => {
                eprintln!("{} frame(s) to render, {kept} kept", frames - kept)
            }
            (Progress::Lines, Event::Written(frame)) => eprintln!("frame {frame} done"),
            _ => {}
        }
    }

    fn finish(self) {
        if let Progress::Bar(Some(bar)) = self {
            bar.finish_and_clear();
        }
    }
}

/// A whole number ≥ 1.
fn at_least_one(s: &str) -> Result<u64, String> {
    match s.parse::<u64>() {
        Ok(n) if n >= 1 => Ok(n),
        _ => Err("expected a whole number ≥ 1".into()),
    }
}

/// Creates the folder `file` will be written into and checks that a file can be written there.
fn check_writable(file: &Path) -> Result<(), Error> {
    create_parent(file)?;
    let mut probe = file.as_os_str().to_owned();
    probe.push(".tmp");
    std::fs::write(&probe, b"").map_err(Error::write(file))?;
    std::fs::remove_file(&probe).map_err(Error::write(file))
}

/// Creates the folder a file will be written into.
fn create_parent(file: &Path) -> Result<(), Error> {
    if let Some(file) = file.ancestors().skip(1).find(|p| p.is_file()) {
        return Err(Error::Usage(format!(
            "{} is a file, not a folder",
            file.display()
        )));
    }
    match file.parent() {
        Some(dir) if !dir.as_os_str().is_empty() => {
            std::fs::create_dir_all(dir).map_err(Error::write(dir.to_path_buf()))
        }
        _ => Ok(()),
    }
}

/// `out/<file stem>/`, relative to the working directory.
fn default_out_dir(file: &Path) -> PathBuf {
    let stem = file
        .file_stem()
        .map_or_else(|| "render".into(), |s| s.to_string_lossy().into_owned());
    Path::new("out").join(stem)
}
