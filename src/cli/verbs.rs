//! The pipeline's verbs on the command line: render, merge, hash and check. Each turns parsed
//! options into library calls and prints what people read.

use std::io::Write;
use std::path::{Path, PathBuf};

use super::args::{default_out_dir, FrameSpec, NoWait, Quiet, Shot, StatsJson};
use super::error::{CliError, Result};
use super::progress::{with_wait, Progress};
use super::stats::{timing_line, Stats};
use crate::document::Document;
use crate::frames::{FrameSet, Shard};
use crate::output::sequence::{self, RenderOptions, RenderSummary};
use crate::output::{Compression, Use, HASHES};
use crate::Error;

/// The options of `campath render`.
#[derive(clap::Args)]
pub struct RenderArgs {
    #[command(flatten)]
    pub shot: Shot,
    /// Output folder [default: out/<file stem>/].
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Frames to render: A..B (B excluded), A.., ..B, A..=B or K.
    #[arg(long)]
    pub frames: Option<FrameSpec>,
    /// PNG compression (the pixels are the same).
    #[arg(long, value_parser = super::args::compression(), default_value = "fast")]
    pub compression: Compression,
    /// Render only frames k with k mod N = K, into hashes.part-K-of-N.txt (see `merge`).
    #[arg(long, value_name = "K/N")]
    pub shard: Option<Shard>,
    /// Render every frame again, even those unchanged and complete in the output folder.
    #[arg(long)]
    pub force: bool,
    #[command(flatten)]
    pub quiet: Quiet,
    #[command(flatten)]
    pub no_wait: NoWait,
    #[command(flatten)]
    pub stats_json: StatsJson,
}

/// `render`'s summary: the timing line, the frames kept, why the others were rendered, and the
/// stale files removed.
fn render_line(doc: &Document, dir: &Path, s: &RenderSummary) -> String {
    let (w, h) = (doc.raster.width, doc.raster.height);
    let detail = format!(" of {w}×{h} to {}", dir.display());
    let mut line = timing_line("rendered", &detail, &s.timing);
    line += &format!("; {} kept (unchanged and complete on disk)", s.kept);
    let r = s.reasons;
    let why: Vec<String> = [
        (r.missing, "new"),
        (r.changed, "input changed"),
        (r.damaged, "missing or damaged on disk"),
        (r.forced, "--force"),
    ]
    .iter()
    .filter(|(n, _)| *n > 0)
    .map(|(n, what)| format!("{n} {what}"))
    .collect();
    if !why.is_empty() {
        line += &format!("; rendered because: {}", why.join(", "));
    }
    if s.removed > 0 {
        line += &format!("; removed {} stale frame file(s)", s.removed);
    }
    line
}

pub fn render(a: RenderArgs, out: &mut dyn Write) -> Result<()> {
    let dir = a.out.unwrap_or_else(|| default_out_dir(&a.shot.file));
    let (quiet, stats_json) = (a.quiet.on, a.stats_json.path.as_deref());
    Stats::check_target(stats_json, Some(&dir))?;
    let doc = Document::load(&a.shot.file)?;
    let set = FrameSet {
        range: FrameSpec::resolve(a.frames, doc.animation.frames)?,
        shard: a.shard,
    };
    let lock = with_wait(a.no_wait.on, quiet, |wait| {
        sequence::lock(&doc, &dir, &set, wait)
    })
    .map_err(|e| e.at("--out", &dir))?;
    let mut progress = Progress::new(quiet);
    let options = RenderOptions {
        compression: a.compression,
        force: a.force,
    };
    let summary = sequence::render(&doc, &lock, &set, options, &mut |e| progress.event(e))?;
    progress.finish();
    Stats::of(&summary.timing, summary.kept).write(stats_json)?;
    if !quiet {
        writeln!(out, "{}", render_line(&doc, &dir, &summary)).map_err(Error::stdout)?;
        if !summary.videos_removed.is_empty() {
            let videos: Vec<String> = (summary.videos_removed.iter())
                .map(|v| v.display().to_string())
                .collect();
            writeln!(
                out,
                "removed {}, made of frames that changed (`campath video` makes it again)",
                videos.join(" and ")
            )
            .map_err(Error::stdout)?;
        }
    }
    Ok(())
}

pub fn merge(dir: &Path, no_wait: bool, out: &mut dyn Write) -> Result<()> {
    // Merge writes into a folder of shard renders; it makes none.
    if !dir.is_dir() {
        let message = format!("{}: no such folder of shard renders", dir.display());
        return Err(CliError::Usage(message));
    }
    // As render: a golden or a folder of other files is refused before the lock is taken.
    crate::output::check(dir, Use::Frames).map_err(|r| CliError::refused("DIR", dir, &r))?;
    let lock = super::progress::lock_whole(dir, no_wait)?;
    let (frames, hashes) = (sequence::merge(&lock)?, dir.join(HASHES));
    writeln!(out, "merged {frames} frame(s) into {}", hashes.display()).map_err(Error::stdout)?;
    Ok(())
}

/// The options of `campath hash`.
#[derive(clap::Args)]
pub struct HashArgs {
    #[command(flatten)]
    pub shot: Shot,
    #[arg(long)]
    pub frames: Option<FrameSpec>,
    /// Also print the timing summary to standard error.
    #[arg(long)]
    pub stats: bool,
    #[command(flatten)]
    pub stats_json: StatsJson,
}

pub fn hash(a: HashArgs) -> Result<()> {
    let stats_json = a.stats_json.path.as_deref();
    Stats::check_target(stats_json, None)?;
    let doc = Document::load(&a.shot.file)?;
    let range = FrameSpec::resolve(a.frames, doc.animation.frames)?;
    let mut lines = std::io::BufWriter::new(std::io::stdout());
    let timing = crate::frames::hash_frames(&doc, range, |frame, hash| {
        writeln!(lines, "{frame} {hash}").map_err(Error::stdout)
    })?;
    lines.flush().map_err(Error::stdout)?;
    if a.stats {
        eprintln!("{}", timing_line("hashed", "", &timing));
    }
    Stats::of(&timing, 0).write(stats_json)
}

/// The options of `campath check`.
#[derive(clap::Args)]
pub struct CheckArgs {
    #[command(flatten)]
    pub shot: Shot,
    /// Exit 1 when there are warnings about the motion (jumps, the COP inside a sphere, a
    /// target at the camera, the up vector flipping).
    #[arg(long)]
    pub strict: bool,
}

/// A one-line summary of a valid file, after evaluating every frame's camera.
/// `campath check`: Ok(false) under `--strict` when there are warnings (exit 1).
pub fn check(c: CheckArgs, out: &mut dyn Write) -> Result<bool> {
    let doc = Document::load(&c.shot.file)?;
    doc.check_path()?;
    let a = &doc.animation;
    let tracks: Vec<&str> = a.tracks().map(|m| m.name()).collect();
    let tracks = (!tracks.is_empty()).then(|| tracks.join(", "));
    let (w, h, s) = (doc.raster.width, doc.raster.height, doc.raster.samples);
    let (spheres, lights) = (doc.scene.spheres.len(), doc.scene.lights.len());
    writeln!(
        out,
        "{}: ok: {} frame(s) at {} fps, {w}×{h} with {s}×{s} samples, {spheres} sphere(s), {lights} light(s), tracks: {}",
        doc.path.display(),
        a.frames,
        a.fps,
        tracks.as_deref().unwrap_or("none")
    )
    .map_err(Error::stdout)?;
    for f in &doc.sphere_files {
        let ignored = &f.listing.ignored;
        let past = match ignored.is_empty() {
            true => String::new(),
            false => {
                let names: Vec<String> = ignored.iter().map(|n| format!("{n:?}")).collect();
                format!(" (columns read past: {})", names.join(", "))
            }
        };
        writeln!(out, "  {}: {} sphere(s){past}", f.name, f.spheres).map_err(Error::stdout)?;
    }
    if let Some(blur) = doc.motion_blur {
        writeln!(
            out,
            "  motion blur: shutter open {} of each frame interval, {} time sample(s) a frame",
            blur.shutter, blur.samples
        )
        .map_err(Error::stdout)?;
    }
    let warnings = crate::motion::warnings(&doc)?;
    for w in &warnings {
        writeln!(out, "warning: {w}").map_err(Error::stdout)?;
    }
    Ok(!c.strict || warnings.is_empty())
}
