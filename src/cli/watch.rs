//! `campath watch`: check the file and re-render a small preview on every save, with a page that
//! shows it and reloads its pictures when they change.
//!
//! The folder holds `preview.png` (contact sheet), `plot.png`, `first.png`, `middle.png`,
//! `last.png`, `preview.html` and `status.js`. The page works from `file://`: every half second
//! it loads `status.js` again (a script, which a local page may load, where it may not fetch),
//! and reloads the pictures when the version of the last good preview changes (versions are
//! numbered within a run, and a run by the time it started, later than the folder's last, so
//! a page left open across a restart, or a folder made again, never keeps a cached picture).
//! An invalid save prints its error, shows it on the page, and leaves the last good preview in
//! place; the error waits until the file has stayed as it is for 0.3 s, so a save in two steps
//! (the file emptied, then written) is not reported between them. The pictures an earlier run
//! left are removed when a run starts: the page shows this run's only.
//!
//! A save is noticed from the file's folder's events and, every 0.1 s, from the file's own
//! state (which file its path resolves to, its size and times): so a folder removed and made
//! again, a link whose target is edited, or a file removed, is noticed too.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc;
use std::time::{Duration, Instant};

use notify::{EventKind, RecursiveMode, Watcher};

use super::args::{default_out_dir, NoWait, Shot};
use super::error::{CliError, Result};
use super::{plot, preview};
use crate::document::Document;
use crate::frames::render_frame;
use crate::output::pictures::{FRAMES, PAGE, PLOT, SHEET, STATUS};
use crate::output::{check, write_atomic, write_png_atomic, Compression, Use};
use crate::Error;

/// What the page reads from `status.js`.
#[derive(serde::Serialize, Default)]
struct Status {
    /// This run's number: the millisecond it started (since 1970), and past the folder's last.
    run: u64,
    /// Counts every check, good or bad.
    version: u64,
    /// The version of the preview on disk (0: none yet).
    good: u64,
    /// The last check's error, if it failed.
    error: Option<String>,
    /// Milliseconds the last good preview took, from the save.
    ms: u64,
    /// The frames shown as first, middle and last.
    frames: [u64; 3],
    /// Whether the watch has stopped (Ctrl-C): the page no longer follows the file.
    stopped: bool,
}

/// The options of `campath watch`.
#[derive(clap::Args)]
pub struct WatchArgs {
    #[command(flatten)]
    pub shot: Shot,
    /// Where the preview and its page go [default: out/<file stem>-watch/].
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Width of the small frames in pixels [default: 240, or the file's width if smaller];
    /// a width above the file's (which a save may change) gives the file's, and says so.
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=16384))]
    pub width: Option<u32>,
    #[command(flatten)]
    pub no_wait: NoWait,
}

/// Watches the file until Ctrl-C, keeping the preview in the output folder `--width` pixels
/// wide (240 by default), at most the file's width.
pub fn run(a: WatchArgs, out: &mut dyn Write) -> Result<()> {
    let (file, width, no_wait) = (a.shot.file.as_path(), a.width, a.no_wait.on);
    let dir = &a.out.clone().unwrap_or_else(|| {
        let mut dir = default_out_dir(file).into_os_string();
        dir.push("-watch");
        PathBuf::from(dir)
    });
    // The folder, not the file: editors often save by writing a new file and renaming it.
    let folder = match file.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    if !folder.is_dir() {
        return Err(CliError::Usage(format!(
            "{}: no such folder: the file to watch is in a folder that exists",
            folder.display()
        )));
    }
    // The folder is this watch's until it stops; as render's, it holds nothing campath does not
    // write there, and is not a golden.
    check(dir, Use::Frames).map_err(|r| CliError::refused("--out", dir, &r))?;
    let lock = super::progress::lock_whole(dir, no_wait)?;
    let started = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_millis() as u64);
    let run = started.max(last_run(dir).saturating_add(1));
    let name = file.file_name().unwrap_or_default().to_os_string();
    let page_path = dir.join(PAGE);
    write_atomic(&page_path, page(&name.to_string_lossy()))?;

    let stop = super::progress::ctrl_c_flag()?;
    let (tx, rx) = mpsc::channel();
    let mut watcher = notify::recommended_watcher(tx).map_err(|e| watch_error(file, e))?;
    watcher
        .watch(&folder, RecursiveMode::NonRecursive)
        .map_err(|e| watch_error(file, e))?;

    let (file_shown, page_shown) = (file.display(), page_path.display());
    writeln!(out, "watching {file_shown}; open {page_shown}").map_err(Error::stdout)?;
    let mut status = Status {
        run,
        ..Default::default()
    };
    // The last run's pictures go, and the page hears of it, before this run's first.
    for picture in FRAMES.into_iter().chain([SHEET, PLOT]) {
        crate::output::remove_if_there(&dir.join(picture))?;
    }
    write_status(dir, &status)?;
    let mut seen = stamp(file);
    update(
        file,
        dir,
        width,
        Instant::now(),
        &mut status,
        &mut seen,
        &stop,
        out,
    )?;
    while !stop.load(Ordering::SeqCst) {
        let event = rx.recv_timeout(Duration::from_millis(100));
        if matches!(event, Err(mpsc::RecvTimeoutError::Disconnected)) {
            // No events any more: the file's state alone, polled.
            std::thread::sleep(Duration::from_millis(100));
        }
        let saved = Instant::now();
        let ours = event.is_ok_and(|e| {
            e.is_ok_and(|e| {
                matches!(e.kind, EventKind::Create(_) | EventKind::Modify(_))
                    && e.paths.iter().any(|p| p.file_name() == Some(&*name))
            })
        });
        if !ours && stamp(file) == seen {
            continue;
        }
        // A save is often several events: let them settle, then render once.
        std::thread::sleep(Duration::from_millis(30));
        while rx.try_recv().is_ok() {}
        seen = stamp(file);
        if !lock.still_held() {
            let gone = std::io::Error::other(
                "the folder was removed or replaced while watching, and its lock with it: \
                 the watch stops, so no other run shares the folder",
            );
            return Err(Error::write(dir)(gone).into());
        }
        update(file, dir, width, saved, &mut status, &mut seen, &stop, out)?;
        // The events of the saves that update rendered (a save in two steps) are done with; a
        // save since then shows in the file's state.
        while rx.try_recv().is_ok() {}
    }
    // Into the folder only while it is this run's.
    if lock.still_held() {
        status.stopped = true;
        write_status(dir, &status)?;
    }
    writeln!(out, "stopped").map_err(Error::stdout)?;
    Ok(())
}

/// The number of the last run that wrote the folder's `status.js`, or 0.
fn last_run(dir: &Path) -> u64 {
    let text = std::fs::read_to_string(dir.join(STATUS)).unwrap_or_default();
    let json = text
        .trim()
        .strip_prefix("window.campathStatus = ")
        .and_then(|t| t.strip_suffix(';'));
    json.and_then(|j| serde_json::from_str::<serde_json::Value>(j).ok())
        .and_then(|v| v["run"].as_u64())
        .unwrap_or(0)
}

/// What tells the file's versions apart: the file its path resolves to, its size and times,
/// and the link's own when the path is a link. None while nothing is there.
pub(super) fn stamp(file: &Path) -> Option<Vec<i128>> {
    let target = std::fs::metadata(file).ok()?;
    let link = std::fs::symlink_metadata(file).ok()?;
    Some([target, link].iter().flat_map(identity).collect())
}

#[cfg(unix)]
fn identity(m: &std::fs::Metadata) -> [i128; 7] {
    use std::os::unix::fs::MetadataExt;
    let ns = |s: i64, n: i64| i128::from(s) * 1_000_000_000 + i128::from(n);
    [
        m.dev().into(),
        m.ino().into(),
        m.len().into(),
        ns(m.mtime(), m.mtime_nsec()),
        ns(m.ctime(), m.ctime_nsec()),
        m.mode().into(),
        m.nlink().into(),
    ]
}

#[cfg(not(unix))]
fn identity(m: &std::fs::Metadata) -> [i128; 2] {
    let since = |t: std::io::Result<std::time::SystemTime>| {
        t.ok()
            .and_then(|t| t.duration_since(std::time::UNIX_EPOCH).ok())
            .map_or(0, |d| d.as_nanos() as i128)
    };
    [m.len().into(), since(m.modified())]
}

fn watch_error(file: &Path, e: notify::Error) -> CliError {
    CliError::Tool("notify", format!("cannot watch {}: {e}", file.display()))
}

/// How long a file that fails to load must stay as it is before its error is shown: an editor
/// that empties the file and then writes it leaves it unreadable for a moment.
const STILL: Duration = Duration::from_millis(300);

/// Checks the file (as it was at `seen`) and renders the preview; an invalid file is reported,
/// not fatal, once it has been still for [`STILL`] (when it changes, it is rendered again, for
/// at most 2 s, and not after Ctrl-C).
#[allow(clippy::too_many_arguments)]
fn update(
    file: &Path,
    dir: &Path,
    width: Option<u32>,
    saved: Instant,
    status: &mut Status,
    seen: &mut Option<Vec<i128>>,
    stop: &AtomicBool,
    out: &mut dyn Write,
) -> Result<()> {
    status.version += 1;
    let started = Instant::now();
    let mut result = render(file, dir, width);
    while started.elapsed() < Duration::from_secs(2) && !stop.load(Ordering::SeqCst) {
        if !matches!(result, Err(ref e) if !matches!(e, CliError::Campath(Error::Write { .. }))) {
            break;
        }
        let still_since = Instant::now();
        while stamp(file) == *seen && still_since.elapsed() < STILL && !stop.load(Ordering::SeqCst)
        {
            std::thread::sleep(Duration::from_millis(20));
        }
        if stamp(file) == *seen {
            break;
        }
        // Written again: let the writes settle, then render what is there now.
        std::thread::sleep(Duration::from_millis(30));
        *seen = stamp(file);
        result = render(file, dir, width);
    }
    match result {
        Ok((frames, used)) => {
            status.good = status.version;
            status.error = None;
            status.frames = frames;
            status.ms = saved.elapsed().as_millis() as u64;
            let narrower = match width {
                Some(asked) if asked > used => {
                    format!(" ({used} px wide, the file's width: --width {asked} is wider)")
                }
                _ => String::new(),
            };
            writeln!(out, "updated the preview in {} ms{narrower}", status.ms)
                .map_err(Error::stdout)?;
        }
        // I/O trouble in the output folder ends the watch; anything about the file is shown.
        Err(CliError::Campath(e @ Error::Write { .. })) => return Err(e.into()),
        Err(e) => {
            eprintln!("campath: error: {e}");
            status.error = Some(e.to_string());
        }
    }
    write_status(dir, status)
}

fn write_status(dir: &Path, status: &Status) -> Result<()> {
    let json = serde_json::to_string(status).expect("plain values serialise");
    let text = format!("window.campathStatus = {json};\n");
    Ok(write_atomic(&dir.join(STATUS), &text)?)
}

/// The preview of the file as it is now; returns the frames shown as first, middle and last,
/// and the preview's width.
fn render(file: &Path, dir: &Path, width: Option<u32>) -> Result<([u64; 3], u32)> {
    let doc = Document::load(file)?;
    doc.check_path()?;
    let frames = doc.animation.frames;
    let width = width.unwrap_or(240).clamp(1, doc.raster.width);
    preview::write(&doc, dir, width, frames.min(12), false)?;
    plot::write(&doc, &dir.join(PLOT), (frames / 8).max(1))?;
    let small = Document {
        raster: preview::small_raster(&doc, width),
        ..doc.clone()
    };
    let shown = [0, (frames - 1) / 2, frames - 1];
    for (name, frame) in FRAMES.iter().zip(shown) {
        let pixels = render_frame(&small, frame)?;
        let size = (small.raster.width, small.raster.height);
        write_png_atomic(&dir.join(name), &pixels, size, Compression::Fast)?;
    }
    Ok((shown, width))
}

/// The page: the pictures, the file's error if the last save was invalid, and the polling.
fn page(name: &str) -> String {
    let name = name
        .replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;");
    format!(
        r#"<!doctype html>
<html lang="en">
<head>
<meta charset="utf-8">
<title>campath watch: {name}</title>
<style>
  body {{ font-family: sans-serif; margin: 1em 2em; background: #f6f6f6; color: #222; }}
  h1 {{ font-size: 1.4em; }} h2 {{ font-size: 1.1em; margin-top: 1.5em; }}
  .row {{ display: flex; gap: 1em; flex-wrap: wrap; }}
  figure {{ margin: 0; }} figcaption {{ font-size: 0.9em; color: #555; }}
  img {{ max-width: 100%; border: 1px solid #ccc; background: #fff; }}
  img:not([src]) {{ display: none; }}
  #error {{ display: none; background: #b00020; color: #fff; padding: 0.6em 1em; white-space: pre-wrap; font-family: monospace; }}
  #status {{ color: #555; }}
</style>
</head>
<body>
<h1>campath watch: {name}</h1>
<p id="status">waiting for the first preview…</p>
<div id="error"></div>
<h2>First, middle and last frame</h2>
<div class="row">
  <figure><img data-src="first.png" alt="first frame"><figcaption id="cap-first">first frame</figcaption></figure>
  <figure><img data-src="middle.png" alt="middle frame"><figcaption id="cap-middle">middle frame</figcaption></figure>
  <figure><img data-src="last.png" alt="last frame"><figcaption id="cap-last">last frame</figcaption></figure>
</div>
<h2>Contact sheet</h2>
<img data-src="preview.png" alt="contact sheet">
<h2>Camera path</h2>
<img data-src="plot.png" alt="camera path from above and from the side">
<script>
  let shown = "";
  function apply(s) {{
    const error = document.getElementById("error");
    error.style.display = s.error ? "block" : "none";
    const kept = s.good === 0 ? "The file is invalid; there is no preview of it yet.\n"
      : "The last save is invalid; showing the last good preview.\n";
    error.textContent = s.error ? kept + s.error : "";
    const stopped = s.stopped ? " (the watch has stopped: saves are no longer followed)" : "";
    if (s.good === 0) {{
      document.getElementById("status").textContent = "no preview yet" + stopped;
      shown = "";
      document.querySelectorAll("img[data-src]").forEach(img => img.removeAttribute("src"));
      ["first", "middle", "last"].forEach(k =>
        document.getElementById("cap-" + k).textContent = k + " frame");
      return;
    }}
    document.getElementById("status").textContent =
      "preview " + s.good + ", rendered " + s.ms + " ms after the save" + stopped;
    ["first", "middle", "last"].forEach((k, i) =>
      document.getElementById("cap-" + k).textContent = k + " frame (" + s.frames[i] + ")");
    const version = s.run + "." + s.good;
    if (version !== shown) {{
      shown = version;
      document.querySelectorAll("img[data-src]").forEach(img => img.src = img.dataset.src + "?v=" + version);
    }}
  }}
  function poll() {{
    const script = document.createElement("script");
    script.src = "status.js?t=" + Date.now();
    script.onload = () => {{ script.remove(); if (window.campathStatus) apply(window.campathStatus); }};
    script.onerror = () => script.remove();
    document.head.appendChild(script);
  }}
  poll();
  setInterval(poll, 500);
</script>
</body>
</html>
"#
    )
}
