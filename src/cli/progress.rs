//! How a long run speaks while it works: progress on standard error, waiting for another run's
//! folder, and stopping on Ctrl-C.

use std::io::IsTerminal;

use std::path::Path;

use super::error::{CliError, Result};
use crate::output::lock::{Claim, FolderLock, Wait};
use crate::output::sequence::Event;
use crate::Error;

/// How `render` (and `video`) report progress on standard error.
pub enum Progress {
    /// Nothing at all, not even the summary.
    Quiet,
    /// For logs and pipes: a line when the run starts, then one every few seconds, and one at
    /// the end; made at the start.
    Lines(Option<Lines>),
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
            Progress::Lines(None)
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
            Progress::Lines(lines) => {
                eprintln!("{} frame(s) to {verb}, {kept} kept", frames - kept);
                // Seconds between lines: `CAMPATH_PROGRESS_SECS`, 5 by default (0: every frame).
                let secs = std::env::var("CAMPATH_PROGRESS_SECS")
                    .ok()
                    .and_then(|s| s.parse::<f64>().ok())
                    .filter(|s| s.is_finite() && *s >= 0.0)
                    .unwrap_or(5.0);
                let now = std::time::Instant::now();
                *lines = Some(Lines {
                    verb: verb.to_string(),
                    frames,
                    done: kept,
                    to_do: frames - kept,
                    began: now,
                    last: now,
                    every: std::time::Duration::from_secs_f64(secs),
                });
            }
            Progress::Quiet => {}
        }
    }

    pub fn event(&mut self, e: Event) {
        match (self, e) {
            (p, Event::Start { frames, kept }) => p.begin(frames, kept, "render"),
            (Progress::Bar(Some(bar)), Event::Written(_)) => bar.inc(1),
            (Progress::Lines(Some(l)), Event::Written(_)) => {
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
            Progress::Lines(Some(l)) if l.to_do > 0 => eprintln!("{}", l.line()),
            _ => {}
        }
    }
}

/// A flag that Ctrl-C sets from now on, instead of ending the process (`watch`, and `video`'s
/// encode).
pub fn ctrl_c_flag() -> Result<std::sync::Arc<std::sync::atomic::AtomicBool>> {
    use std::sync::atomic::{AtomicBool, Ordering};
    let stop = std::sync::Arc::new(AtomicBool::new(false));
    let flag = std::sync::Arc::clone(&stop);
    ctrlc::set_handler(move || flag.store(true, Ordering::SeqCst))
        .map_err(|e| CliError::Tool("ctrlc", format!("cannot catch Ctrl-C: {e}")))?;
    Ok(stop)
}

/// How a verb waits for its output folder: not at all with `--no-wait` (refusing with exit 2),
/// or after saying which run it waits for (unless quiet).
pub fn with_wait<T>(
    no_wait: bool,
    quiet: bool,
    f: impl FnOnce(Wait) -> crate::Result<T>,
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

/// The lock of the whole folder `dir`, waiting for a run that holds it (see [`with_wait`]).
pub fn lock_whole(dir: &Path, no_wait: bool) -> Result<FolderLock> {
    with_wait(no_wait, false, |wait| {
        FolderLock::acquire(dir, Claim::Whole, wait)
    })
}
