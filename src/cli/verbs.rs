//! The pipeline's verbs on the command line: render, merge, hash, path and check. Each
//! turns parsed options into library calls and prints what people read.

use std::io::{IsTerminal, Write};
use std::path::{Path, PathBuf};

use super::args::FrameSpec;
use super::error::{CliError, Result};
use campath::document::Document;
use campath::export::PathFormat;
use campath::frames::{FrameSet, Timing};
use campath::lock::{Claim, FolderLock, Wait};
use campath::manifest::Shard;
use campath::sequence::{self, Event, RenderOptions, RenderSummary};
use campath::Error;

/// A run's numbers, for other programs (`--stats-json`; `campath bench` reads them).
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Stats {
    /// Frames rendered (or held) and delivered.
    pub frames: u64,
    /// Frames already valid on disk (render only).
    pub kept: u64,
    pub wall_secs: f64,
    pub wall_ms_per_frame: f64,
    pub median_render_ms: f64,
    /// Peak resident memory of the process, where the platform tells.
    pub peak_memory_mb: Option<f64>,
    /// From the process's start to the first frame delivered: loading, checking, indexing the
    /// scene and rendering one frame.
    pub first_frame_ms: Option<f64>,
    /// The most spheres any rendered frame had inside its view.
    #[serde(default)]
    pub max_in_view: usize,
}

impl Stats {
    fn of(t: &Timing, kept: u64) -> Stats {
        Stats {
            frames: t.frames,
            kept,
            wall_secs: t.wall_secs,
            wall_ms_per_frame: t.wall_secs * 1e3 / t.frames.max(1) as f64,
            median_render_ms: t.median_render_secs() * 1e3,
            peak_memory_mb: peak_memory_mb(),
            first_frame_ms: t
                .first_frame_at
                .map(|at| (at - super::started()).as_secs_f64() * 1e3),
            max_in_view: t.max_in_view,
        }
    }

    /// Refuses (exit 2, before any work) a `--stats-json` path that is a folder, lies under a
    /// file, in a golden or in the run's output folder `out` (whose files are the frames and
    /// their manifests only), or is a file other than run statistics campath wrote: it never
    /// overwrites a keyframe file, a golden's hashes or anything else.
    pub fn check_target(path: Option<&Path>, out: Option<&Path>) -> Result<()> {
        let Some(path) = path else { return Ok(()) };
        let refuse = |why: String| {
            Err(CliError::Usage(format!(
                "--stats-json {}: {why}; nothing was done (choose another path)",
                path.display()
            )))
        };
        if let Some(dir) = out.filter(|dir| super::failures::within(path, dir)) {
            return refuse(format!("it is in the --out folder {}", dir.display()));
        }
        if let Some(why) = path.parent().and_then(sequence::golden_of) {
            return refuse(why);
        }
        super::args::no_file_above(path)?;
        super::args::report_target("--stats-json", path, "run statistics", |b| {
            serde_json::from_slice::<Stats>(b).is_ok()
        })
    }

    fn write(&self, path: Option<&Path>) -> Result<()> {
        let Some(path) = path else { return Ok(()) };
        super::args::create_parent(path)?;
        let text = serde_json::to_string_pretty(self).expect("plain numbers serialise");
        Ok(campath::output::write_atomic(path, &text)?)
    }
}

/// The process's peak resident memory in MB, where the platform tells (Linux's VmHWM).
pub fn peak_memory_mb() -> Option<f64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kb: f64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb / 1024.0)
}

/// One line for people, e.g. `rendered 96 frame(s) of 640×360 to out/x in …`: frames, wall
/// time, median render time, held frames and peak memory. `detail` follows the frame count.
pub fn timing_line(verb: &str, detail: &str, t: &Timing) -> String {
    let mut line = format!(
        "{verb} {} frame(s){detail} in {:.2} s",
        t.frames, t.wall_secs
    );
    let mut notes = Vec::new();
    if t.frames > 0 {
        notes.push(format!(
            "{:.1} ms/frame wall, median render {:.1} ms/frame",
            t.wall_secs * 1e3 / t.frames as f64,
            t.median_render_secs() * 1e3
        ));
    }
    if let Some(at) = t.first_frame_at {
        let ms = (at - super::started()).as_secs_f64() * 1e3;
        notes.push(format!("first frame after {ms:.0} ms"));
    }
    if t.held > 0 {
        notes.push(format!("{} held (same camera as the frame before)", t.held));
    }
    if let Some(mb) = peak_memory_mb() {
        notes.push(format!("peak memory {mb:.0} MB"));
    }
    if !notes.is_empty() {
        line += &format!(" ({})", notes.join(", "));
    }
    line
}

/// `render`'s summary: the timing line, the frames kept, why the others were rendered, and the
/// stale files removed.
fn render_line(doc: &Document, dir: &Path, s: &RenderSummary) -> String {
    let detail = format!(
        " of {}×{} to {}",
        doc.raster.width,
        doc.raster.height,
        dir.display()
    );
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

/// How `render` (and `video`) report progress on standard error.
pub enum Progress {
    /// Nothing at all, not even the summary.
    Quiet,
    /// For logs and pipes: a line when the run starts, then one every few seconds, and one at
    /// the end.
    Lines(Lines),
    /// A progress bar with frames per second and an ETA (for terminals), made at the start.
    Bar(Option<indicatif::ProgressBar>),
}

/// What [`Progress::Lines`] keeps between lines.
pub struct Lines {
    verb: String,
    /// Frames of the run, and those done (kept or written).
    frames: u64,
    done: u64,
    /// Frames to render (or encode) at the start, and when the work began.
    to_do: u64,
    began: std::time::Instant,
    last: std::time::Instant,
    every: std::time::Duration,
}

/// Seconds between progress lines off a terminal: `CAMPATH_PROGRESS_SECS`, 5 by default (0:
/// a line per frame).
fn progress_interval() -> std::time::Duration {
    let secs = std::env::var("CAMPATH_PROGRESS_SECS")
        .ok()
        .and_then(|s| s.parse::<f64>().ok())
        .filter(|s| s.is_finite() && *s >= 0.0)
        .unwrap_or(5.0);
    std::time::Duration::from_secs_f64(secs)
}

impl Lines {
    fn line(&self) -> String {
        let secs = self.began.elapsed().as_secs_f64();
        let worked = self.done + self.to_do - self.frames;
        format!(
            "{}/{} frame(s), {worked} of {} to {} done in {secs:.1} s ({:.1} frames/s)",
            self.done,
            self.frames,
            self.to_do,
            self.verb,
            worked as f64 / secs.max(1e-9)
        )
    }
}

impl Progress {
    pub fn new(quiet: bool) -> Progress {
        if quiet {
            Progress::Quiet
        } else if std::io::stderr().is_terminal() {
            Progress::Bar(None)
        } else {
            let now = std::time::Instant::now();
            Progress::Lines(Lines {
                verb: String::new(),
                frames: 0,
                done: 0,
                to_do: 0,
                began: now,
                last: now,
                every: progress_interval(),
            })
        }
    }

    /// A run of `frames` frames begins, `kept` of them already done; `verb` says what is done
    /// to the others ("render", "encode").
    pub fn begin(&mut self, frames: u64, kept: u64, verb: &str) {
        match self {
            Progress::Bar(bar) => {
                let style = indicatif::ProgressStyle::with_template(&format!(
                    "{{bar:40}} {{pos}}/{{len}} frames to {verb}, {{rate}}, ETA {{eta}}"
                ))
                .expect("the template is valid")
                .with_key(
                    "rate",
                    |s: &indicatif::ProgressState, w: &mut dyn std::fmt::Write| {
                        let _ = write!(w, "{:.1} frames/s", s.per_sec());
                    },
                );
                let b = indicatif::ProgressBar::new(frames).with_style(style);
                b.inc(kept);
                *bar = Some(b);
            }
            Progress::Lines(l) => {
                eprintln!("{} frame(s) to {verb}, {kept} kept", frames - kept);
                let now = std::time::Instant::now();
                l.verb = verb.to_string();
                (l.frames, l.done, l.to_do) = (frames, kept, frames - kept);
                (l.began, l.last) = (now, now);
            }
            Progress::Quiet => {}
        }
    }

    pub fn event(&mut self, e: Event) {
        match (self, e) {
            (p, Event::Start { frames, kept }) => p.begin(frames, kept, "render"),
            (Progress::Bar(Some(bar)), Event::Written(_)) => bar.inc(1),
            (Progress::Lines(l), Event::Written(_)) => {
                l.done += 1;
                if l.last.elapsed() >= l.every && l.done < l.frames {
                    l.last = std::time::Instant::now();
                    eprintln!("{}", l.line());
                }
            }
            _ => {}
        }
    }

    pub fn finish(self) {
        match self {
            Progress::Bar(Some(bar)) => bar.finish_and_clear(),
            Progress::Lines(l) if l.to_do > 0 => eprintln!("{}", l.line()),
            _ => {}
        }
    }
}

/// The options of `campath render`.
pub struct RenderArgs {
    pub file: PathBuf,
    pub dir: PathBuf,
    pub frames: Option<FrameSpec>,
    pub shard: Option<Shard>,
    pub options: RenderOptions,
    pub quiet: bool,
    /// Refuse instead of waiting when another run writes the folder.
    pub no_wait: bool,
    pub stats_json: Option<PathBuf>,
}

/// A flag that Ctrl-C sets from now on, instead of ending the process (`watch`, and `video`'s
/// encode).
pub fn ctrl_c_flag() -> Result<std::sync::Arc<std::sync::atomic::AtomicBool>> {
    use std::sync::atomic::{AtomicBool, Ordering};
    let stop = std::sync::Arc::new(AtomicBool::new(false));
    let flag = std::sync::Arc::clone(&stop);
    ctrlc::set_handler(move || flag.store(true, Ordering::SeqCst)).map_err(|e| CliError::Tool {
        tool: "ctrlc",
        package: "campath",
        message: format!("cannot catch Ctrl-C: {e}"),
    })?;
    Ok(stop)
}

/// How a verb waits for its output folder: not at all with `--no-wait` (refusing with exit 2),
/// or after saying which run it waits for (unless quiet).
pub fn with_wait<T>(
    no_wait: bool,
    quiet: bool,
    f: impl FnOnce(Wait) -> campath::Result<T>,
) -> Result<T> {
    if no_wait {
        return f(Wait::No).map_err(|e| match e {
            e @ Error::Busy { .. } => CliError::Usage(format!(
                "{e}; nothing done (without --no-wait, campath waits for it)"
            )),
            e => e.into(),
        });
    }
    let mut report = |e: &Error| {
        if !quiet {
            eprintln!("campath: waiting: {e}");
        }
    };
    Ok(f(Wait::Yes(&mut report))?)
}

pub fn render(a: RenderArgs, out: &mut dyn Write) -> Result<()> {
    Stats::check_target(a.stats_json.as_deref(), Some(&a.dir))?;
    let doc = Document::load(&a.file)?;
    let set = FrameSet {
        range: FrameSpec::resolve(a.frames, doc.animation.frames)?,
        shard: a.shard,
    };
    let lock = with_wait(a.no_wait, a.quiet, |wait| {
        sequence::lock(&doc, &a.dir, &set, wait)
    })?;
    let mut progress = Progress::new(a.quiet);
    let summary = sequence::render(&doc, &lock, &set, a.options, &mut |e| progress.event(e))?;
    progress.finish();
    Stats::of(&summary.timing, summary.kept).write(a.stats_json.as_deref())?;
    if !a.quiet {
        writeln!(out, "{}", render_line(&doc, &a.dir, &summary)).map_err(Error::stdout)?;
    }
    Ok(())
}

pub fn merge(dir: &Path, no_wait: bool, out: &mut dyn Write) -> Result<()> {
    // Merge writes into a folder of shard renders; it makes none.
    if !dir.is_dir() {
        return Err(CliError::Usage(format!(
            "{}: no such folder of shard renders",
            dir.display()
        )));
    }
    // As render: a golden or a folder of other files is refused before the lock is taken.
    sequence::check_folder(dir)?;
    let lock = with_wait(no_wait, false, |wait| {
        FolderLock::acquire(dir, Claim::Whole, wait)
    })?;
    let frames = sequence::merge(&lock)?;
    writeln!(
        out,
        "merged {frames} frame(s) into {}",
        dir.join("hashes.txt").display()
    )
    .map_err(Error::stdout)?;
    Ok(())
}

pub fn hash(
    file: &Path,
    frames: Option<FrameSpec>,
    stats: bool,
    stats_json: Option<&Path>,
) -> Result<()> {
    Stats::check_target(stats_json, None)?;
    let doc = Document::load(file)?;
    let range = FrameSpec::resolve(frames, doc.animation.frames)?;
    let mut lines = std::io::BufWriter::new(std::io::stdout());
    let timing = campath::frames::hash_frames(&doc, range, |frame, hash| {
        writeln!(lines, "{frame} {hash}").map_err(Error::stdout)
    })?;
    lines.flush().map_err(Error::stdout)?;
    if stats {
        eprintln!("{}", timing_line("hashed", "", &timing));
    }
    Stats::of(&timing, 0).write(stats_json)
}

/// `campath path`: the evaluated camera per frame (or the whole shot as glTF) on standard
/// output, or into `file_out` (binary glTF when it ends in `.glb`).
pub fn path(
    file: &Path,
    format: PathFormat,
    file_out: Option<&Path>,
    origin: glam::DVec3,
    out: &mut dyn Write,
) -> Result<()> {
    // Not into a golden or a folder of rendered frames: the next render there would refuse
    // the folder for holding a file campath did not write.
    if let Some(target) = file_out {
        let parent = target.parent().unwrap_or(Path::new(""));
        let why = campath::sequence::golden_of(parent).or_else(|| {
            campath::sequence::frames_folder_of(parent)
                .map(|dir| format!("{} is a folder of rendered frames", dir.display()))
        });
        if let Some(why) = why {
            return Err(CliError::Usage(format!(
                "--out {}: {why}; nothing was written (put the export outside it)",
                target.display()
            )));
        }
    }
    if format == PathFormat::Usd {
        if let Some(ext) = file_out.and_then(|p| p.extension()) {
            if !ext.eq_ignore_ascii_case("usda") && !ext.eq_ignore_ascii_case("usd") {
                return Err(CliError::Usage(format!(
                    "campath writes USD's text form: name the file .usda (or .usd), not .{}; \
                     OpenUSD converts it, e.g. in Python: pxr.Sdf.Layer.FindOrOpen(\"shot.usda\").Export(\"shot.usdc\")",
                    ext.to_string_lossy()
                )));
            }
        }
    }
    let doc = Document::load(file)?;
    let frames = doc.animation.frames;
    let glb =
        file_out.is_some_and(|p| p.extension().is_some_and(|e| e.eq_ignore_ascii_case("glb")));
    // Before anything is written: places that f32 cannot hold are refused, and a reader that
    // keeps f32 (glTF, Blender, Blender's USD importer) is warned of rounding.
    if matches!(
        format,
        PathFormat::Gltf | PathFormat::Blender | PathFormat::Usd
    ) {
        let f32_file = format != PathFormat::Usd;
        if let Some(place) = f32_file
            .then(|| campath::export::past_f32(&doc, origin))
            .flatten()
        {
            return Err(CliError::Usage(format!(
                "{place} lies past f32's range (±3.4e38){}, which {} keeps; nothing was written",
                if origin == glam::DVec3::ZERO {
                    String::new()
                } else {
                    " relative to --origin".to_string()
                },
                format.title()
            )));
        }
        f32_warning(&doc, format, origin)?;
    } else if origin != glam::DVec3::ZERO {
        eprintln!(
            "campath: note: {} has no place to record --origin: its places are relative to \
             ({}, {}, {}) without saying so",
            format.title(),
            origin.x,
            origin.y,
            origin.z
        );
    }
    let dropped = match file_out {
        Some(path) => {
            super::args::create_parent(path)?;
            campath::output::write_atomic_with(path, |file| {
                campath::export::write_path(&doc, format, glb, origin, file)
            })?
        }
        None => campath::export::write_path(&doc, format, glb, origin, out)?,
    };
    if dropped.off_axis > 0 {
        let (off_axis, first, last) = (dropped.off_axis, dropped.first, dropped.last);
        let which = match format {
            PathFormat::Chan => format!(
                ", campath frames {first}..={last} (.chan frames {}..={}),",
                first + 1,
                last + 1
            ),
            _ => String::new(),
        };
        eprintln!(
            "campath: note: {} has no place for an off-axis COP (distort): {off_axis} of {frames} \
             frame(s){which} are written as if the COP were on the VPN, so their pictures are \
             centred; csv, json, blender and usd keep the COP",
            format.title()
        );
    }
    Ok(())
}

/// Warns when glTF or Blender (or Blender's USD importer), keeping places in f32, would move
/// the camera's picture by a quarter of a pixel or more (a shot far from the origin), and
/// names an origin that keeps it near zero.
fn f32_warning(doc: &Document, format: PathFormat, origin: glam::DVec3) -> Result<()> {
    const MOST_PX: f64 = 0.25;
    let Some(shift) = campath::export::f32_shift(doc, origin)? else {
        return Ok(());
    };
    if shift.px < MOST_PX {
        return Ok(());
    }
    let m = shift.middle;
    let better = campath::export::f32_shift(doc, m)?.map_or(0.0, |s| s.px);
    let hint = if better < MOST_PX {
        format!(
            "--origin {},{},{} (the middle of the camera's path) writes every place relative to \
             it (about {better:.1e} px)",
            m.x, m.y, m.z
        )
    } else {
        "the camera's path is too long for f32 at this scale: write the shot in parts, each \
         with an --origin near it, or read the USD with OpenUSD, which keeps f64"
            .to_string()
    };
    let keeps = match format {
        PathFormat::Usd => "USD keeps f64, but Blender's USD importer keeps places in f32",
        _ => "keeps places in f32",
    };
    let title = match format {
        PathFormat::Usd => String::new(),
        _ => format!("{} ", format.title()),
    };
    eprintln!(
        "campath: warning: {title}{keeps}: this far from the origin, rounding moves the camera \
         by {:.1e} at frame {}, about {:.1} px on the nearest sphere; {hint}",
        shift.units, shift.frame, shift.px
    );
    Ok(())
}

/// A one-line summary of a valid file, after evaluating every frame's camera.
/// `campath check`: Ok(false) under `--strict` when there are warnings (exit 1).
pub fn check(file: &Path, strict: bool, out: &mut dyn Write) -> Result<bool> {
    let doc = Document::load(file)?;
    doc.check_path()?;
    let a = &doc.animation;
    let tracks: Vec<&str> = a.tracks().map(|m| m.name()).collect();
    writeln!(
        out,
        "{}: ok: {} frame(s) at {} fps, {}×{} with {}×{} samples, {} sphere(s), {} light(s), tracks: {}",
        doc.path.display(),
        a.frames,
        a.fps,
        doc.raster.width,
        doc.raster.height,
        doc.raster.samples,
        doc.raster.samples,
        doc.scene.spheres.len(),
        doc.scene.lights.len(),
        if tracks.is_empty() { "none".to_string() } else { tracks.join(", ") }
    )
    .map_err(Error::stdout)?;
    for f in &doc.sphere_files {
        writeln!(out, "  {}: {} sphere(s)", f.name, f.spheres).map_err(Error::stdout)?;
    }
    if let Some(blur) = doc.motion_blur {
        writeln!(
            out,
            "  motion blur: shutter open {} of each frame interval, {} time sample(s) a frame",
            blur.shutter, blur.samples
        )
        .map_err(Error::stdout)?;
    }
    let warnings = campath::motion::warnings(&doc)?;
    for w in &warnings {
        writeln!(out, "warning: {w}").map_err(Error::stdout)?;
    }
    Ok(!strict || warnings.is_empty())
}

impl From<std::convert::Infallible> for CliError {
    fn from(e: std::convert::Infallible) -> Self {
        match e {}
    }
}
