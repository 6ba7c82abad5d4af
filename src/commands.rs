//! The command-line verbs, over a checked [`Document`]. Each writes its report to `out`; main.rs
//! only parses arguments and maps errors to exit statuses.

use std::io::Write;
use std::ops::Range;
use std::path::Path;

use crate::document::Document;
use crate::error::{Error, Result};
use crate::frames::{hashes, Timing};
use crate::manifest::{list_frames, parse_hashes};
use crate::sequence::RenderSummary;

/// Parses `A..B` (frames A to B − 1), `A..` (A to the end), `..B`, `A..=B` or a single `K`.
pub fn parse_frames(spec: &str, frames: u64) -> Result<Range<u64>> {
    let bad = |why: &str| Error::Usage(format!("--frames {spec:?}: {why}"));
    let num = |s: &str| {
        s.trim()
            .parse::<u64>()
            .map_err(|_| bad("expected A..B, A.., ..B, A..=B or K with whole numbers"))
    };
    let range = if let Some((a, b)) = spec.split_once("..=") {
        let a = if a.is_empty() { 0 } else { num(a)? };
        a..num(b)?.saturating_add(1)
    } else if let Some((a, b)) = spec.split_once("..") {
        let a = if a.is_empty() { 0 } else { num(a)? };
        let b = if b.is_empty() { frames } else { num(b)? };
        a..b
    } else {
        let k = num(spec)?;
        k..k.saturating_add(1)
    };
    if range.start >= range.end {
        return Err(bad("the range is empty"));
    }
    if range.end > frames {
        return Err(bad(&format!("the animation has frames 0..{frames}")));
    }
    Ok(range)
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
pub fn render_line(doc: &Document, dir: &Path, s: &RenderSummary) -> String {
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

/// Compares the frames listed in `golden` (a hashes.txt) with fresh renders. Returns whether all
/// match; writes one line per differing frame and a count.
pub fn verify(doc: &Document, golden: &Path, out: &mut dyn Write) -> Result<bool> {
    let text = std::fs::read_to_string(golden).map_err(Error::read(golden))?;
    let expected = parse_hashes(golden, &text)?;
    let total = doc.animation.frames;
    let Some(last) = expected.iter().map(|(f, _)| *f).max() else {
        return Err(Error::Manifest {
            path: golden.to_path_buf(),
            message: "lists no frames".into(),
        });
    };
    let mut differ = Vec::new();
    for (frame, _) in expected.iter().filter(|(f, _)| *f >= total) {
        writeln!(
            out,
            "frame {frame}: in {} but the animation has only {total} frames",
            golden.display()
        )
        .map_err(Error::stdout)?;
        differ.push(*frame);
    }
    let actual = hashes(doc, 0..(last + 1).min(total))?;
    for (frame, want) in expected.iter().filter(|(f, _)| *f < total) {
        let got = &actual[*frame as usize].1;
        if got != want {
            writeln!(out, "frame {frame}: expected {want}, got {got}").map_err(Error::stdout)?;
            differ.push(*frame);
        }
    }
    if differ.is_empty() {
        writeln!(
            out,
            "{} frame(s) match {}",
            expected.len(),
            golden.display()
        )
    } else {
        writeln!(
            out,
            "{} of {} frame(s) differ from {}: {}",
            differ.len(),
            expected.len(),
            golden.display(),
            list_frames(&differ)
        )
    }
    .map_err(Error::stdout)?;
    Ok(differ.is_empty())
}

/// A one-line summary of a valid file, after evaluating every frame's camera.
pub fn check(doc: &Document, out: &mut dyn Write) -> Result<()> {
    doc.check_path()?;
    let a = &doc.animation;
    let mut tracks = Vec::new();
    for (name, on) in [
        ("Observer", a.observer.is_some()),
        ("LookAround", a.look_around.is_some()),
        ("Track", a.track.is_some()),
        ("Zoom", a.zoom.is_some()),
        ("Distort", a.distort.is_some()),
    ] {
        if on {
            tracks.push(name);
        }
    }
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
    .map_err(Error::stdout)
}
