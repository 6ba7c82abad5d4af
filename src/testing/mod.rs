//! Frame-hash tests of shots, for `campath test` and for Rust tests ([`assert_shot`]).
//!
//! A shot is a keyframe file `NAME.ron`; its golden is the folder `NAME.golden/` beside it,
//! holding `hashes.txt` (see [`crate::golden`]), a small picture of every frame and, optionally,
//! the full frames. A shot passes when every frame of its animation renders to the golden hash
//! (or, where the shot states a tolerance, within it of the golden frame), and the golden lists
//! no frame the animation does not have. A failing shot leaves a pending golden
//! `NAME.golden.new/` to look at and accept ([`Update`]).

use std::path::{Path, PathBuf};

/// What a frame-hash test needs, from one place.
pub use crate::document::Document;
pub use crate::frames::{hashes, render_frame, Difference};
pub use crate::golden::Golden;
pub use crate::hash::{frame_hash, FrameHash};

use crate::error::{Error, Result};
use crate::frames::{list_frames, past_end, stream_frames, FrameSet};
use crate::golden;
use crate::key::VERSION;
use crate::output::{frame_path, png_hash, write_png, Compression, HASHES};

mod pending;
pub mod pictures;

use std::collections::BTreeMap;

pub use crate::document::Tolerance;
pub use pending::{accept, golden_dir, load_pending, pending_dir, reject};
pub(crate) use pending::{stem_of_golden, thumbs_in};
pub use pictures::PixelDiff;

use pending::{clear_left, diff_path, install_golden, lock_shot, staging_dir, swap_in, thumb_path};
use pictures::{changed_over, difference, pixels_of, thumbnail};

/// The environment variable that says what a failing shot writes: [`Update`].
pub const UPDATE_VAR: &str = "CAMPATH_UPDATE";

/// What a run writes for a shot that fails, as `INSTA_UPDATE` says it for insta's snapshots.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
#[non_exhaustive]
pub enum Update {
    /// Nothing: compare only.
    #[default]
    No,
    /// A pending golden `NAME.golden.new/` beside the golden, to look at and accept or reject
    /// with `campath review`; the golden is left as it is.
    New,
    /// The golden itself: the run approves what it renders.
    Always,
}

impl Update {
    /// The values [`Update::parse`] knows, for messages.
    pub const VALUES: &str = "no, new or always";

    /// `no`, `new` or `always`, and the values an earlier campath read: `0` (no), `1` (always)
    /// and `frames` (always, and the golden keeps every frame). Returns the mode and whether
    /// the golden is to keep every frame.
    pub fn parse(value: &str) -> Option<(Update, bool)> {
        Some(match value {
            "no" | "0" => (Update::No, false),
            "new" => (Update::New, false),
            "always" | "1" => (Update::Always, false),
            "frames" => (Update::Always, true),
            _ => return None,
        })
    }

    /// [`UPDATE_VAR`] when it is set and not empty; else `no` under CI (`CI` set and not
    /// empty), else `new`. A value it does not know is an error naming the values.
    pub fn from_env() -> std::result::Result<(Update, bool), String> {
        let set = |name: &str| std::env::var_os(name).filter(|v| !v.is_empty());
        match set(UPDATE_VAR) {
            Some(v) => v.to_str().and_then(Update::parse).ok_or_else(|| {
                let v = v.to_string_lossy();
                format!(
                    "{UPDATE_VAR}={v}: it takes {} (unset: new, or no under CI)",
                    Update::VALUES
                )
            }),
            None if set("CI").is_some() => Ok((Update::No, false)),
            None => Ok((Update::New, false)),
        }
    }
}

/// How a shot compares with its golden.
#[derive(Debug, Clone, PartialEq, Eq)]
#[non_exhaustive]
pub enum Verdict {
    /// Every frame renders to its golden hash, or within the shot's tolerance of its golden
    /// picture (and the golden's frames, if it keeps them, are the pictures its hashes name).
    Passed,
    /// Some frames differ (listed in [`ShotRun::differ`]).
    Differ,
    /// Every frame renders to its golden hash, but golden frames the golden keeps are missing or
    /// are not the pictures of their hashes (listed in [`ShotRun::stale`]).
    StaleFrames,
    /// The shot has no golden yet.
    NoGolden,
    /// Frames differ, and the golden names another renderer version than this campath's: the
    /// difference may be the renderer's rather than the shot's. A golden from a newer renderer
    /// is never overwritten.
    OtherRenderer(u32),
}

/// How a differing frame differs from the golden's picture of it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct PictureDiff {
    /// The pixels that changed and the largest change.
    pub diff: PixelDiff,
    /// Counted on the golden's small pictures (it keeps no full frame), not full frames.
    pub small: bool,
}

/// A shot rendered and compared with its golden.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ShotRun {
    /// The shot file.
    pub shot: PathBuf,
    /// The golden as it was before any update.
    pub golden: Option<Golden>,
    /// The animation's frame count.
    pub frames: u64,
    /// Every frame's fresh hash, in order.
    pub fresh: Vec<(u64, FrameHash)>,
    /// The frames that differ, in order (every frame when there is no golden).
    pub differ: Vec<Difference>,
    /// How differing frames differ from the golden's pictures, where it has one.
    pub pictures: BTreeMap<u64, PictureDiff>,
    /// Frames that match their golden hash while the golden keeps frames, but whose golden
    /// picture is missing or hashes otherwise.
    pub stale: Vec<u64>,
    /// The shot's tolerance, if it states one.
    pub tolerance: Option<Tolerance>,
    /// The frames whose hash differs but that passed within the tolerance, with how they
    /// differ from the golden frame.
    pub tolerated: Vec<(u64, PixelDiff)>,
    /// Whether the golden was written by this run ([`Update::Always`]).
    pub updated: bool,
    /// The pending golden this run wrote ([`Update::New`]).
    pub pending: Option<PathBuf>,
}

impl ShotRun {
    /// How the shot compared, before any update.
    pub fn verdict(&self) -> Verdict {
        match &self.golden {
            None => Verdict::NoGolden,
            Some(_) if self.differ.is_empty() && self.stale.is_empty() => Verdict::Passed,
            Some(_) if self.differ.is_empty() => Verdict::StaleFrames,
            Some(g) => g
                .other_renderer()
                .map_or(Verdict::Differ, Verdict::OtherRenderer),
        }
    }

    /// Whether the shot passes, or was approved by this run.
    pub fn ok(&self) -> bool {
        self.updated || self.verdict() == Verdict::Passed
    }

    /// The differing frames' numbers.
    pub fn differing_frames(&self) -> Vec<u64> {
        self.differ.iter().map(|d| d.frame).collect()
    }

    /// One line saying how the shot compares and what the run wrote, without the shot's name:
    /// `passed (24 frames)`, `3 of 24 frame(s) differ: 4, 5, 6; pending golden …`, ….
    pub fn summary(&self) -> String {
        let golden = golden_dir(&self.shot);
        let differ = || {
            // The shot's frames, and any the golden lists past them.
            let past = self
                .golden
                .as_ref()
                .map_or(0, |g| g.hashes.range(self.frames..).count() as u64);
            let of = self.frames + past;
            format!(
                "{} of {of} frame(s) differ: {}",
                self.differ.len(),
                list_frames(&self.differing_frames())
            )
        };
        let what = match self.verdict() {
            Verdict::Passed if self.tolerated.is_empty() => {
                return format!("passed ({} frames)", self.frames)
            }
            Verdict::Passed => {
                let t = self.tolerance.unwrap_or_default();
                let frames: Vec<String> = (self.tolerated.iter().take(4))
                    .map(|(f, d)| format!("frame {f}: {d}"))
                    .collect();
                let more = self.tolerated.len().saturating_sub(4);
                let more = if more > 0 {
                    format!("; {more} more")
                } else {
                    String::new()
                };
                return format!(
                    "passed within tolerance ({} frames; {} within max_pixels: {}, max_level: \
                     {}: {}{more})",
                    self.frames,
                    self.tolerated.len(),
                    t.max_pixels,
                    t.max_level,
                    frames.join("; ")
                );
            }
            Verdict::NoGolden => format!("new shot, no golden yet ({} frames)", self.frames),
            Verdict::Differ => differ(),
            Verdict::StaleFrames if self.updated => format!(
                "the golden now keeps the pictures of frame(s) {}",
                list_frames(&self.stale)
            ),
            Verdict::StaleFrames => format!(
                "every frame matches its hash, but the golden's pictures of frame(s) {} are \
                 missing or are not the pictures of their hashes",
                list_frames(&self.stale)
            ),
            Verdict::OtherRenderer(r) if r < VERSION => format!(
                "golden made by renderer {r}, this campath is renderer {VERSION} (its pictures \
                 changed): {}",
                differ()
            ),
            Verdict::OtherRenderer(r) => format!(
                "golden made by renderer {r}, newer than this campath's renderer {VERSION}: \
                 update campath ({})",
                differ()
            ),
        };
        if self.updated {
            format!("{what}; golden written: {}", golden.display())
        } else if let Some(p) = &self.pending {
            format!("{what}; pending golden: {}", p.display())
        } else {
            what
        }
    }

    /// A line per differing frame (at most `most`): how its picture differs from the golden's
    /// where a picture allows it, else that the golden keeps hashes only.
    pub fn frame_lines(&self, most: usize) -> Vec<String> {
        let mut lines: Vec<String> = (self.differ.iter().take(most))
            .map(
                |d| match (self.pictures.get(&d.frame), d.expected, d.actual) {
                    (_, _, None) => {
                        format!("frame {}: in the golden, past the animation's end", d.frame)
                    }
                    (_, None, _) => format!("frame {}: not in the golden", d.frame),
                    (Some(p), ..) if p.small => {
                        format!(
                            "frame {}: {} (on the golden's small pictures)",
                            d.frame, p.diff
                        )
                    }
                    (Some(p), ..) => format!("frame {}: {}", d.frame, p.diff),
                    (None, ..) => format!(
                        "frame {}: hash differs (no golden picture to compare)",
                        d.frame
                    ),
                },
            )
            .collect();
        if self.differ.len() > most {
            lines.push(format!("… and {} more frame(s)", self.differ.len() - most));
        }
        lines
    }
}

/// Options of [`run_shot`].
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Options {
    /// What a failing shot writes: nothing, a pending golden, or its golden. A passing golden
    /// is left untouched, and a golden from a newer renderer is never overwritten.
    pub update: Update,
    /// With [`Update::Always`], the golden keeps every frame's PNG too, even where it kept
    /// only hashes and small pictures before.
    pub keep_frames: bool,
    /// The shot's folder was just cleared by [`clear_left_approvals`] (once for a folder of
    /// shots): [`Shot::open`] does not list it again for the shot's own.
    pub swept: bool,
}

/// A shot loaded: its checked document and its golden, if it has one.
#[derive(Debug)]
pub struct Shot {
    /// The shot file.
    pub path: PathBuf,
    /// The shot, checked.
    pub doc: Document,
    /// The golden `hashes.txt` in the shot's [`golden_dir`], when it exists.
    pub golden: Option<Golden>,
    /// The golden frames in the golden folder (whether or not it has `hashes.txt`), by frame.
    pub golden_frames: BTreeMap<u64, PathBuf>,
    /// Held while a run may write the golden or pending golden: an advisory lock on the shot
    /// file, so two runs that write for one shot take turns.
    _lock: Option<std::fs::File>,
}

impl Shot {
    /// Loads the shot file and its golden. A file that does not load, or a golden that does not
    /// parse, is an error.
    pub fn load(path: &Path) -> Result<Shot> {
        Shot::open(path, Options::default())
    }

    /// [`Shot::load`], first taking the shot's lock when the run may write (waiting for
    /// another run writing for the same shot to finish), and clearing what a killed one left
    /// (a check leaves that to [`clear_left_approvals`]).
    pub fn open(path: &Path, options: Options) -> Result<Shot> {
        let lock = if options.update != Update::No {
            let file = lock_shot(path)?;
            // The sweep passes stems that are not UTF-8: those the shot clears itself.
            let swept = options.swept && path.file_stem().is_some_and(|s| s.to_str().is_some());
            if !swept {
                clear_left(path)?;
            }
            Some(file)
        } else {
            None
        };
        let doc = Document::load(path)?;
        let dir = golden_dir(path);
        let golden = Golden::find(&dir)?;
        let golden_frames = crate::output::frames_in(&dir);
        Ok(Shot {
            path: path.to_path_buf(),
            doc,
            golden,
            golden_frames,
            _lock: lock,
        })
    }

    /// Renders every frame and compares each with the golden. `each` sees every differing
    /// frame that the animation has, with its fresh RGB8 pixels, as it is found.
    ///
    /// A failing shot then writes what [`Options::update`] says. Either is put together in a
    /// hidden folder beside the golden while the shot renders and moved into place whole once
    /// every frame is done: a pending golden replaces the one before it, never merged with it,
    /// and a golden is swapped with its successor in one step.
    pub fn run(
        self,
        options: Options,
        mut each: impl FnMut(&Difference, &[u8]) -> Result<()> + Send,
    ) -> Result<ShotRun> {
        // The lock stays in `self`, held until the run returns.
        let (path, doc, golden, golden_frames) =
            (self.path, self.doc, self.golden, self.golden_frames);
        let dir = golden_dir(&path);
        let total = doc.animation.frames;
        let size = (doc.raster.width, doc.raster.height);
        let tolerance = doc.tolerance;
        let always = options.update == Update::Always;
        if let (Some(_), Some(g), true) = (tolerance, &golden, golden_frames.is_empty()) {
            if !always {
                let folder = path.parent().filter(|p| !p.as_os_str().is_empty());
                let folder = shell_word(&folder.unwrap_or(Path::new(".")).display().to_string());
                return Err(Error::Usage(format!(
                    "{}: the shot states a tolerance, which compares full frames, and its golden \
                     {} keeps hashes only: approve it again with its frames (`campath test \
                     {folder} --update --keep-frames` approves every failing shot there, or \
                     CAMPATH_UPDATE=frames)",
                    path.display(),
                    g.path.display()
                )));
            }
        }
        let keep_frames = !golden_frames.is_empty() || options.keep_frames || tolerance.is_some();
        let writes = options.update != Update::No;
        let for_review = options.update == Update::New;
        let golden_thumbs = thumbs_in(&dir);
        let staging = staging_dir(&path, "");
        let mut fresh = Vec::with_capacity(total as usize);
        let mut differ = Vec::new();
        let mut pictures = BTreeMap::new();
        let mut stale = Vec::new();
        let mut tolerated = Vec::new();
        let put = |name: PathBuf, pixels: &[u8], size| {
            std::fs::create_dir_all(&staging).map_err(Error::write(&staging))?;
            write_png(&name, pixels, size, Compression::Default)
        };
        let result = stream_frames(
            &doc,
            &FrameSet::all(0..total),
            |_| false,
            |frame, _, pixels, hash| {
                fresh.push((frame, hash));
                let expected = golden.as_ref().and_then(|g| g.hash(frame));
                let same = expected == Some(hash);
                let full = golden_frames.get(&frame);
                let picture_ok = !keep_frames
                    || full
                        .and_then(|p| png_hash(p))
                        .is_some_and(|h| Some(h) == expected);
                if same && !picture_ok {
                    stale.push(frame);
                }
                let golden_full = (!same && expected.is_some())
                    .then(|| full.and_then(|p| pixels_of(p, size)))
                    .flatten();
                if let (Some(t), Some(g)) = (tolerance, &golden_full) {
                    if changed_over(g, pixels, t.max_level) <= t.max_pixels {
                        tolerated.push((frame, difference(g, pixels).1));
                        return Ok(());
                    }
                }
                // A small picture for the golden to be written, or to compare with the golden's.
                let has_thumb = golden_thumbs.contains_key(&frame);
                let needed = if same {
                    writes && !has_thumb
                } else {
                    writes || has_thumb
                };
                let thumb = needed.then(|| thumbnail(pixels, size));
                // Full frames for the golden that keeps them, and for the review of a pending one.
                if (for_review || keep_frames && always) && !(same && picture_ok) {
                    put(frame_path(&staging, frame, total), pixels, size)?;
                }
                if let (true, Some(t)) = (writes, &thumb) {
                    std::fs::create_dir_all(&staging).map_err(Error::write(&staging))?;
                    let name = thumb_path(&staging, frame, total);
                    std::fs::write(&name, &t.png).map_err(Error::write(&name))?;
                }
                if same {
                    return Ok(());
                }
                // How it differs from the golden's picture: its full frame, else its small one.
                let small = || {
                    let t = thumb.as_ref()?;
                    let g = pixels_of(golden_thumbs.get(&frame)?, t.size)?;
                    Some((difference(&g, &t.pixels), t.size, true))
                };
                let compared = (golden_full.as_ref())
                    .map(|g| (difference(g, pixels), size, false))
                    .or_else(small);
                if let Some(((image, diff), at, small)) = compared {
                    let small = small && at != size;
                    pictures.insert(frame, PictureDiff { diff, small });
                    if for_review {
                        put(diff_path(&staging, frame, total), &image, at)?;
                    }
                }
                let d = Difference {
                    frame,
                    expected,
                    actual: Some(hash),
                };
                each(&d, pixels)?;
                differ.push(d);
                Ok(())
            },
        );
        let remove_staging = || match std::fs::remove_dir_all(&staging) {
            Err(e) if e.kind() != std::io::ErrorKind::NotFound => Err(Error::write(&staging)(e)),
            _ => Ok(()),
        };
        if let Err(e) = result {
            remove_staging()?;
            return Err(e);
        }
        if let Some(g) = &golden {
            differ.extend(past_end(&g.hashes, total));
        }
        let mut run = ShotRun {
            shot: path,
            golden,
            frames: total,
            fresh,
            differ,
            pictures,
            stale,
            tolerance,
            tolerated,
            updated: false,
            pending: None,
        };
        let verdict = run.verdict();
        // A newer campath's golden is never written, whatever the verdict.
        let newer = (run.golden.as_ref()).is_some_and(|g| g.renderer.is_some_and(|r| r > VERSION));
        let pending = pending_dir(&run.shot);
        if verdict == Verdict::Passed || newer || !writes {
            remove_staging()?;
            if verdict == Verdict::Passed && writes {
                // What a failing run left is no longer the shot's.
                pending::remove(&run.shot, &pending)?;
            }
            return Ok(run);
        }
        std::fs::create_dir_all(&staging).map_err(Error::write(&staging))?;
        // A frame within the tolerance keeps its golden hash and pictures, as it passed.
        let golden_hash = |f: u64| run.golden.as_ref().and_then(|g| g.hash(f));
        let kept = |&(f, h): &(u64, FrameHash)| {
            let tolerated = run.tolerated.iter().any(|t| t.0 == f);
            (f, golden_hash(f).filter(|_| tolerated).unwrap_or(h))
        };
        let hashes: Vec<(u64, FrameHash)> = run.fresh.iter().map(kept).collect();
        golden::write(&staging.join(HASHES), &hashes)?;
        if always {
            // The pending golden first: left behind, it would undo this approval if accepted.
            pending::remove(&run.shot, &pending)?;
            install_golden(&run.shot, &staging, keep_frames)?;
            run.updated = true;
        } else {
            swap_in(&run.shot, &staging, &pending)?;
            run.pending = Some(pending);
        }
        Ok(run)
    }
}

/// [`Shot::open`] and [`Shot::run`].
pub fn run_shot(
    shot: &Path,
    options: Options,
    each: impl FnMut(&Difference, &[u8]) -> Result<()> + Send,
) -> Result<ShotRun> {
    Shot::open(shot, options)?.run(options, each)
}

/// Removes, as far as it can, the hidden folders that killed runs left in `folder` while
/// putting a golden together: those of shots no run holds the lock of now. The folder is
/// listed once, so a check of every shot of a folder costs one listing. A check writes nothing
/// it must: a folder that cannot be read or removed is left.
pub(crate) fn clear_left_approvals(folder: &Path) {
    let folder = Some(folder).filter(|f| !f.as_os_str().is_empty());
    let folder = folder.unwrap_or(Path::new("."));
    for entry in std::fs::read_dir(folder).into_iter().flatten().flatten() {
        let name = entry.file_name();
        let bytes = name.as_encoded_bytes();
        let at = bytes.windows(15).position(|w| w == b".golden.update-");
        // The shot's stem lies between the dot and `.golden.update-` (a stem that is not
        // UTF-8 is left to its next approval).
        let stem = at.filter(|&at| at >= 2 && bytes[0] == b'.');
        let Some(Ok(stem)) = stem.map(|at| std::str::from_utf8(&bytes[1..at])) else {
            continue;
        };
        let shot = folder.join(format!("{stem}.ron"));
        // Held while it removes, so no run starts writing for the shot meanwhile.
        let Ok(lock) = std::fs::File::open(&shot) else {
            continue;
        };
        if lock.try_lock().is_ok() && golden_dir(&shot).exists() {
            let _ = std::fs::remove_dir_all(entry.path());
        }
    }
}

/// Renders the shot `shot` and compares every frame with the golden `NAME.golden/` beside it;
/// panics saying which frames differ, how, where the pending golden is, and the `campath
/// review` command that accepts it. A relative path is taken from the working directory;
/// [`assert_shot!`](crate::assert_shot!) takes it from the calling crate's folder.
///
/// [`UPDATE_VAR`] says what a failing shot writes ([`Update::from_env`]): by default a pending
/// golden `NAME.golden.new/` (nothing under CI); `always` approves in place and passes. A
/// value it does not know is refused (a panic), so a misspelt approval never passes as a
/// check. A golden from a newer renderer is never written.
///
/// ```
/// // tests/shots/orbit.ron, with tests/shots/orbit.golden/ beside it.
/// let shot = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/shots/orbit.ron");
/// campath::testing::assert_shot(shot);
/// ```
#[track_caller]
pub fn assert_shot(shot: impl AsRef<Path>) {
    let shot = shot.as_ref();
    slow_build_note();
    let (update, keep_frames) = Update::from_env().unwrap_or_else(|e| panic!("{e}"));
    let options = Options {
        update,
        keep_frames,
        swept: false,
    };
    if update == Update::No {
        clear_left_approvals(shot.parent().unwrap_or(Path::new(".")));
    }
    let run = match run_shot(shot, options, |_, _| Ok(())) {
        Ok(run) => run,
        Err(e) => panic!("campath shot {}: {e}", shot.display()),
    };
    if run.ok() {
        // What was approved, or let through, is said; a plain pass is not.
        if run.updated || !run.tolerated.is_empty() {
            eprintln!("campath shot {}: {}", shot.display(), run.summary());
        }
        return;
    }
    let mut message = format!("campath shot {}: {}", shot.display(), run.summary());
    let new = run.verdict() == Verdict::NoGolden;
    for line in run.frame_lines(8).into_iter().filter(|_| !new) {
        message += &format!("\n  {line}");
    }
    let folder = shot.parent().filter(|p| !p.as_os_str().is_empty());
    let review = format!(
        "campath review {}",
        shell_word(&folder.unwrap_or(Path::new(".")).display().to_string())
    );
    message += &match (run.verdict(), &run.pending) {
        // Never written by this campath: only a newer one can approve it.
        (Verdict::OtherRenderer(r), _) if r > VERSION => format!(
            "\n{} is a newer campath's: update campath to check the shot against it.",
            golden_dir(shot).display()
        ),
        (_, Some(_)) => format!(
            "\nThe pending golden holds the new hashes, the new frames that differ and their \
             difference images. Look, then accept or reject: {review}"
        ),
        _ => format!(
            "\nNothing was written ({UPDATE_VAR}=no, or CI is set). Run the test with \
             {UPDATE_VAR}=new to write a pending golden, then: {review}"
        ),
    };
    panic!("{message}");
}

/// Compares `fresh` `(frame, hash)` pairs with the hashes file `golden` (the grammar of
/// `hashes.txt`), for goldens of hashes that a test computes itself. [`UPDATE_VAR`] works as
/// for [`assert_shot`]: on a difference, `new` (the default outside CI) writes the fresh
/// hashes to `GOLDEN.new` beside it, to compare and accept with `mv`; `always` writes
/// `golden` and passes; `no` writes nothing. Panics naming each frame that differs.
#[track_caller]
pub fn assert_hashes(golden: impl AsRef<Path>, fresh: &[(u64, FrameHash)]) {
    let golden = golden.as_ref();
    let (update, _) = Update::from_env().unwrap_or_else(|e| panic!("{e}"));
    let text = std::fs::read_to_string(golden).ok();
    let want = text
        .as_deref()
        .map(|t| crate::output::manifest::parse_hashes(golden, t));
    let want = match want.transpose() {
        Ok(w) => w,
        Err(e) => panic!("{e}"),
    };
    let mut pending = golden.as_os_str().to_os_string();
    pending.push(".new");
    let pending = PathBuf::from(pending);
    let lines: Vec<String> = match &want {
        None => vec![format!("{} does not exist yet", golden.display())],
        Some(want) => {
            let got: BTreeMap<u64, FrameHash> = fresh.iter().copied().collect();
            let want: BTreeMap<u64, FrameHash> = want.iter().copied().collect();
            let frames: std::collections::BTreeSet<u64> =
                want.keys().chain(got.keys()).copied().collect();
            let hash = |h: Option<&FrameHash>| h.map_or("none".to_string(), |h| h.to_string());
            (frames.into_iter())
                .filter(|f| want.get(f) != got.get(f))
                .map(|f| {
                    format!(
                        "frame {f}: golden {}, fresh {}",
                        hash(want.get(&f)),
                        hash(got.get(&f))
                    )
                })
                .collect()
        }
    };
    let text: String = fresh.iter().map(|(f, h)| format!("{f} {h}\n")).collect();
    let write = |path: &Path| {
        crate::output::write_atomic(path, &text).unwrap_or_else(|e| panic!("{e}"));
    };
    if lines.is_empty() {
        let _ = std::fs::remove_file(&pending);
        return;
    }
    let next = match update {
        Update::Always => return write(golden),
        Update::New => {
            write(&pending);
            format!(
                "the fresh hashes are in {p}: compare, and accept with `mv {p} {g}`",
                p = shell_word(&pending.display().to_string()),
                g = shell_word(&golden.display().to_string())
            )
        }
        Update::No => format!("nothing was written ({UPDATE_VAR}=no, or CI is set)"),
    };
    panic!(
        "{} differs:\n  {}\n{next}; {UPDATE_VAR}=always rewrites it",
        golden.display(),
        lines.join("\n  ")
    );
}

/// [`assert_shot`] with `shot` taken from the folder of the crate whose test calls it:
/// `campath::assert_shot!("shots/orbit.ron")` checks `CARGO_MANIFEST_DIR/shots/orbit.ron`,
/// whatever the working directory.
#[macro_export]
macro_rules! assert_shot {
    ($shot:expr) => {
        $crate::testing::assert_shot(::std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join($shot))
    };
}

/// Once per test binary, under a build that does not optimise campath: the line of
/// `Cargo.toml` that does (the bytes are the same; the renders some 30× faster).
fn slow_build_note() {
    static ONCE: std::sync::Once = std::sync::Once::new();
    if env!("CAMPATH_OPT_LEVEL") == "0" {
        ONCE.call_once(|| {
            eprintln!(
                "campath: this build renders shots unoptimised, about 50× slower; add to \
                 Cargo.toml: [profile.dev.package.campath] opt-level = 3"
            )
        });
    }
}

/// The path `word` as one word of a POSIX shell command that campath reads as a path: as it is
/// when it holds only characters no shell treats specially, else in single quotes (a `'` inside
/// as `'\''`); after `./` when it starts with `-`, which would read as an option. So a printed
/// command can be pasted.
pub(crate) fn shell_word(word: &str) -> String {
    let word = match word.starts_with('-') {
        true => format!("./{word}"),
        false => word.to_string(),
    };
    let plain = |c: char| c.is_ascii_alphanumeric() || "_-./+:=,@%".contains(c);
    if !word.is_empty() && word.chars().all(plain) {
        return word;
    }
    format!("'{}'", word.replace('\'', "'\\''"))
}

#[cfg(test)]
mod tests {
    use super::shell_word;

    #[test]
    fn printed_paths_are_one_shell_word() {
        assert_eq!(shell_word("shots/a-b_c.d"), "shots/a-b_c.d");
        assert_eq!(shell_word("my shots"), "'my shots'");
        assert_eq!(shell_word("ünï cødé"), "'ünï cødé'");
        assert_eq!(shell_word("it's"), "'it'\\''s'");
        assert_eq!(shell_word(""), "''");
        assert_eq!(shell_word("-shots"), "./-shots");
    }

    #[test]
    fn update_values_are_instas_and_the_earlier_ones() {
        use super::Update;
        assert_eq!(Update::parse("new"), Some((Update::New, false)));
        assert_eq!(Update::parse("no"), Some((Update::No, false)));
        assert_eq!(Update::parse("0"), Some((Update::No, false)));
        assert_eq!(Update::parse("always"), Some((Update::Always, false)));
        assert_eq!(Update::parse("1"), Some((Update::Always, false)));
        assert_eq!(Update::parse("frames"), Some((Update::Always, true)));
        assert_eq!(Update::parse("yes"), None);
    }
}
