//! A run's numbers: the line people read after a run, and `--stats-json` for other programs
//! (the peers benchmark reads it).

use std::path::Path;

use super::error::{CliError, Result};
use crate::frames::Timing;
use crate::output::Use;

/// A run's numbers, for other programs (`--stats-json`; the peers benchmark reads them).
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Stats {
    /// Frames rendered (or held) and delivered.
    pub frames: u64,
    /// Frames already valid on disk (render only).
    pub kept: u64,
    /// Wall-clock seconds for the whole run, output included.
    pub wall_secs: f64,
    /// `wall_secs` over the frames, in ms.
    pub wall_ms_per_frame: f64,
    /// The median of the frames' render times, in ms.
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
    /// The numbers of a run's timing, with its frames kept on disk.
    pub fn of(t: &Timing, kept: u64) -> Stats {
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
        if let Some(dir) = out.filter(|dir| crate::output::within(path, dir)) {
            return refuse(format!("it is in the --out folder {}", dir.display()));
        }
        crate::output::check(path, Use::File)
            .map_err(|r| CliError::refused("--stats-json", path, &r))?;
        super::args::report_target("--stats-json", path, "run statistics", |b| {
            serde_json::from_slice::<Stats>(b).is_ok()
        })
    }

    /// Writes the numbers as JSON to `path`, if one is given.
    pub fn write(&self, path: Option<&Path>) -> Result<()> {
        let Some(path) = path else { return Ok(()) };
        super::args::create_parent(path)?;
        let text = serde_json::to_string_pretty(self).expect("plain numbers serialise");
        Ok(crate::output::write_atomic(path, &text)?)
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
    let s = Stats::of(t, 0);
    let (frames, secs) = (s.frames, s.wall_secs);
    let mut line = format!("{verb} {frames} frame(s){detail} in {secs:.2} s");
    let (wall, median) = (s.wall_ms_per_frame, s.median_render_ms);
    let notes: Vec<String> = [
        (frames > 0)
            .then(|| format!("{wall:.1} ms/frame wall, median render {median:.1} ms/frame")),
        s.first_frame_ms
            .map(|ms| format!("first frame after {ms:.0} ms")),
        (t.held > 0).then(|| format!("{} held (same camera as the frame before)", t.held)),
        s.peak_memory_mb.map(|mb| format!("peak memory {mb:.0} MB")),
    ]
    .into_iter()
    .flatten()
    .collect();
    if !notes.is_empty() {
        line += &format!(" ({})", notes.join(", "));
    }
    line
}
