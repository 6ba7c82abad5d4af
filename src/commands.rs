//! The command-line verbs, over a checked [`Document`]. Each writes its report to `out`; main.rs
//! only parses arguments and maps errors to exit statuses.

use std::io::Write;
use std::ops::Range;
use std::path::Path;
use std::sync::Arc;
use std::time::Instant;

use crate::camera::Camera;
use crate::document::Document;
use crate::error::{Error, Result};
use crate::output::{
    frame_hash, frame_path, hash_line, is_ours, manifest_name, manifest_text, parse_hashes,
    read_manifest_lenient, write_atomic, write_png_atomic, Compression,
};
use crate::render::Renderer;

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

/// The frames a run covers: a range, optionally one shard of it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct FrameSet {
    pub range: Range<u64>,
    /// (K, N): only frames k with k mod N = K (interleaved, so every shard gets a share of each
    /// part of the animation).
    pub shard: Option<(u64, u64)>,
}

impl FrameSet {
    pub fn all(range: Range<u64>) -> FrameSet {
        FrameSet { range, shard: None }
    }

    pub fn contains(&self, k: u64) -> bool {
        self.range.contains(&k) && self.shard.is_none_or(|(i, n)| k % n == i)
    }

    pub fn count(&self) -> u64 {
        (self.range.start..self.range.end)
            .filter(|k| self.contains(*k))
            .count() as u64
    }
}

/// Parses `K/N` with 0 ≤ K < N.
pub fn parse_shard(spec: &str) -> Result<(u64, u64)> {
    let bad = || {
        Error::Usage(format!(
            "--shard {spec:?}: expected K/N with 0 ≤ K < N, e.g. 0/4"
        ))
    };
    let (k, n) = spec.split_once('/').ok_or_else(bad)?;
    let (k, n): (u64, u64) = (
        k.trim().parse().map_err(|_| bad())?,
        n.trim().parse().map_err(|_| bad())?,
    );
    if n == 0 || k >= n {
        return Err(bad());
    }
    Ok((k, n))
}

/// How a render reports progress on standard error.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Progress {
    /// Nothing at all, not even the summary.
    Quiet,
    /// A line per finished frame (for logs and pipes).
    Lines,
    /// A progress bar with frames per second and an ETA (for terminals).
    Bar,
}

/// Options of `campath render`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RenderOptions {
    pub compression: Compression,
    /// Render every frame again, even those already complete on disk.
    pub force: bool,
    pub progress: Progress,
}

/// Timing of a run of frames.
#[derive(Debug, Clone, PartialEq)]
pub struct Summary {
    /// Frames delivered.
    pub frames: u64,
    /// Frames whose camera equalled the previous frame's, delivered again without rendering.
    pub reused: u64,
    /// Frames already complete on disk (resumed renders), neither rendered nor delivered.
    pub skipped: u64,
    /// Seconds per frame spent rendering, in frame order.
    pub render_secs: Vec<f64>,
    /// Wall-clock seconds for the whole run, output included.
    pub wall_secs: f64,
}

impl Summary {
    /// Median seconds per rendered frame.
    pub fn median_render_secs(&self) -> f64 {
        median(&self.render_secs)
    }

    /// One line for people, e.g. `rendered 96 frame(s) of 640×360 to out/x in …`: frames,
    /// wall time, median render time and peak memory. `detail` follows the frame count.
    pub fn line(&self, verb: &str, detail: &str) -> String {
        let mut line = format!(
            "{verb} {} frame(s){detail} in {:.2} s ({:.1} ms/frame wall, median render {:.1} ms/frame",
            self.frames,
            self.wall_secs,
            self.wall_secs * 1e3 / self.frames.max(1) as f64,
            self.median_render_secs() * 1e3
        );
        if self.reused > 0 {
            line += &format!(", {} reused", self.reused);
        }
        if self.skipped > 0 {
            line += &format!(", {} already complete", self.skipped);
        }
        if let Some(mb) = peak_memory_mb() {
            line += &format!(", peak memory {mb:.0} MB");
        }
        line + ")"
    }
}

/// The median of `xs` (0 for none).
pub fn median(xs: &[f64]) -> f64 {
    if xs.is_empty() {
        return 0.0;
    }
    let mut v = xs.to_vec();
    v.sort_by(f64::total_cmp);
    let m = v.len() / 2;
    if v.len() % 2 == 1 {
        v[m]
    } else {
        (v[m - 1] + v[m]) * 0.5
    }
}

/// The process's peak resident memory in MB, where the platform tells (Linux's VmHWM).
pub fn peak_memory_mb() -> Option<f64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kb: f64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb / 1024.0)
}

/// Renders the frames of `set` to PNGs in `dir`, with their manifest (hashes.txt, or
/// hashes.part-K-of-N.txt for a shard).
///
/// - Nothing is written before the whole path is checked, and never into a folder that holds
///   files campath did not write.
/// - Each PNG is written under a temporary name and renamed into place; its manifest line is
///   appended after that, so the manifest lists only complete frames, even after SIGKILL.
/// - A frame whose PNG exists and decodes to pixels with the manifest's hash is kept (resume),
///   unless `force`.
/// - PNG encoding runs on its own thread while the next frame renders.
pub fn render(
    doc: &Document,
    dir: &Path,
    set: &FrameSet,
    options: RenderOptions,
    out: &mut dyn Write,
) -> Result<Summary> {
    doc.check_path()?;
    check_folder(dir)?;
    std::fs::create_dir_all(dir).map_err(|source| Error::Write {
        path: dir.to_path_buf(),
        source,
    })?;
    let total = doc.animation.frames;
    let manifest_path = dir.join(manifest_name(set.shard));
    // Complete frames from an earlier run: the manifest's entries whose PNG still hashes to them.
    let mut done = if options.force {
        std::collections::BTreeMap::new()
    } else {
        read_manifest_lenient(&manifest_path)
    };
    done.retain(|frame, hash| {
        set.contains(*frame) && png_hash(&frame_path(dir, *frame, total)).as_ref() == Some(hash)
    });
    // Start the manifest clean (no torn line), then append as frames complete.
    write_atomic(&manifest_path, &manifest_text(&done))?;
    let mut manifest = std::fs::OpenOptions::new()
        .append(true)
        .open(&manifest_path)
        .map_err(|source| Error::Write {
            path: manifest_path.clone(),
            source,
        })?;

    let todo = set.count();
    let bar = match options.progress {
        Progress::Bar => {
            let bar = indicatif::ProgressBar::new(todo);
            bar.set_style(
                indicatif::ProgressStyle::with_template(
                    "{bar:40} {pos}/{len} frames, {per_sec}, ETA {eta}",
                )
                .expect("the template is valid"),
            );
            bar.inc(done.len() as u64);
            Some(bar)
        }
        _ => None,
    };
    let lines = options.progress == Progress::Lines;
    let started = Instant::now();
    let summary = stream_frames(
        doc,
        set,
        |frame| done.contains_key(&frame),
        |frame, pixels| {
            write_png_atomic(
                &frame_path(dir, frame, total),
                pixels,
                doc.raster,
                options.compression,
            )?;
            writeln!(manifest, "{}", hash_line(frame, &frame_hash(pixels))).map_err(|source| {
                Error::Write {
                    path: manifest_path.clone(),
                    source,
                }
            })?;
            if let Some(bar) = &bar {
                bar.inc(1);
            }
            if lines {
                eprintln!("frame {frame} done");
            }
            Ok(())
        },
    )?;
    if let Some(bar) = bar {
        bar.finish_and_clear();
    }
    // The final manifest: sorted, exactly this run's complete frames.
    let mut entries = read_manifest_lenient(&manifest_path);
    entries.retain(|frame, _| set.contains(*frame));
    write_atomic(&manifest_path, &manifest_text(&entries))?;
    let summary = Summary {
        wall_secs: started.elapsed().as_secs_f64(),
        ..summary
    };
    if options.progress != Progress::Quiet {
        let detail = format!(
            " of {}×{} to {}",
            doc.raster.width,
            doc.raster.height,
            dir.display()
        );
        let _ = writeln!(out, "{}", summary.line("rendered", &detail));
    }
    Ok(summary)
}

/// The hash of a PNG's RGB8 pixels, or None if it is missing or does not decode.
fn png_hash(path: &Path) -> Option<String> {
    let img = image::open(path).ok()?.to_rgb8();
    Some(frame_hash(img.as_raw()))
}

/// Refuses a folder that holds anything campath does not write there.
fn check_folder(dir: &Path) -> Result<()> {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return Ok(());
    };
    let foreign: Vec<String> = entries
        .flatten()
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| !is_ours(n))
        .take(3)
        .collect();
    if foreign.is_empty() {
        Ok(())
    } else {
        Err(Error::Usage(format!(
            "{} holds files campath did not write ({}); choose another --out so nothing is clobbered",
            dir.display(),
            foreign.join(", ")
        )))
    }
}

/// Renders the frames of `set` in order and calls `sink` with each frame's RGB8 pixels; frames
/// for which `done` says true are passed over without rendering. A frame whose camera equals the
/// previous rendered frame's is not rendered again.
pub fn for_each_frame(
    doc: &Document,
    set: &FrameSet,
    mut done: impl FnMut(u64) -> bool,
    mut sink: impl FnMut(u64, &Arc<Vec<u8>>) -> Result<()>,
) -> Result<Summary> {
    let started = Instant::now();
    let mut renderer = Renderer::new();
    let mut previous: Option<(Camera, Arc<Vec<u8>>)> = None;
    let mut summary = Summary {
        frames: 0,
        reused: 0,
        skipped: 0,
        render_secs: Vec::new(),
        wall_secs: 0.0,
    };
    for item in doc.cameras() {
        let (frame, camera) = item?;
        if frame >= set.range.end {
            break;
        }
        if !set.contains(frame) {
            continue;
        }
        if done(frame) {
            summary.skipped += 1;
            continue;
        }
        let pixels = match previous.take() {
            Some((cam, pixels)) if cam == camera => {
                summary.reused += 1;
                pixels
            }
            _ => {
                let t = Instant::now();
                let pixels = Arc::new(renderer.render(&camera, &doc.scene, doc.raster));
                summary.render_secs.push(t.elapsed().as_secs_f64());
                pixels
            }
        };
        sink(frame, &pixels)?;
        summary.frames += 1;
        previous = Some((camera, pixels));
    }
    summary.wall_secs = started.elapsed().as_secs_f64();
    Ok(summary)
}

/// The `<frame> <sha256>` lines of `frames`, without writing images.
pub fn hashes(doc: &Document, frames: Range<u64>) -> Result<Vec<(u64, String)>> {
    Ok(hash_frames(doc, frames, |_, _| ())?.0)
}

/// Renders `frames` and hashes each on its own thread while the next renders (SHA-256 is
/// sequential within a frame); `each` sees every (frame, hash) in order, as it is ready.
pub fn hash_frames(
    doc: &Document,
    frames: Range<u64>,
    mut each: impl FnMut(u64, &str) + Send,
) -> Result<(Vec<(u64, String)>, Summary)> {
    let mut out = Vec::new();
    let summary = stream_frames(
        doc,
        &FrameSet::all(frames),
        |_| false,
        |frame, pixels| {
            let hash = frame_hash(pixels);
            each(frame, &hash);
            out.push((frame, hash));
            Ok(())
        },
    )?;
    Ok((out, summary))
}

/// [`for_each_frame`] with `consume` on a second thread, so a frame is written or hashed while
/// the next one renders. At most one frame waits between them: memory stays flat in the number
/// of frames. The first error of either side is returned.
pub fn stream_frames(
    doc: &Document,
    set: &FrameSet,
    done: impl FnMut(u64) -> bool,
    mut consume: impl FnMut(u64, &[u8]) -> Result<()> + Send,
) -> Result<Summary> {
    std::thread::scope(|scope| {
        let (tx, rx) = std::sync::mpsc::sync_channel::<(u64, Arc<Vec<u8>>)>(1);
        let consumer = scope.spawn(move || -> Result<()> {
            for (frame, pixels) in rx {
                consume(frame, &pixels)?;
            }
            Ok(())
        });
        let rendered = for_each_frame(doc, set, done, |frame, pixels| {
            // A failed send means the consumer stopped on an error: stop rendering too; the
            // consumer's error is the one reported.
            tx.send((frame, Arc::clone(pixels)))
                .map_err(|_| Error::Usage("the frame consumer stopped".into()))
        });
        drop(tx);
        consumer
            .join()
            .expect("the frame consumer does not panic")?;
        rendered
    })
}

/// Compares the frames listed in `golden` (a hashes.txt) with fresh renders. Returns whether all
/// match, and writes one line per differing frame.
pub fn verify(doc: &Document, golden: &Path, out: &mut dyn Write) -> Result<bool> {
    let text = std::fs::read_to_string(golden).map_err(|source| Error::Read {
        path: golden.to_path_buf(),
        source,
    })?;
    let expected = parse_hashes(golden, &text)?;
    let total = doc.animation.frames;
    let Some(last) = expected.iter().map(|(f, _)| *f).max() else {
        return Err(Error::Golden {
            path: golden.to_path_buf(),
            message: "lists no frames".into(),
        });
    };
    let mut ok = true;
    for (frame, _) in expected.iter().filter(|(f, _)| *f >= total) {
        let _ = writeln!(
            out,
            "frame {frame}: in {} but the animation has only {total} frames",
            golden.display()
        );
        ok = false;
    }
    let actual = hashes(doc, 0..(last + 1).min(total))?;
    for (frame, want) in expected.iter().filter(|(f, _)| *f < total) {
        let got = &actual[*frame as usize].1;
        if got != want {
            let _ = writeln!(out, "frame {frame}: expected {want}, got {got}");
            ok = false;
        }
    }
    if ok {
        let _ = writeln!(
            out,
            "{} frame(s) match {}",
            expected.len(),
            golden.display()
        );
    }
    Ok(ok)
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
    let _ = writeln!(
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
    );
    Ok(())
}
