//! Frame-hash tests of shots, for `campath test` and for Rust tests ([`assert_shot`]).
//!
//! A shot is a keyframe file `NAME.ron`; its golden is the folder `NAME.golden/` beside it,
//! holding `hashes.txt` (see [`crate::golden`]) and, optionally, the golden frames. A shot passes
//! when every frame of its animation renders to the golden hash, and the golden lists no frame
//! the animation does not have.

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

/// The environment variable that makes [`assert_shot`] write the golden instead of comparing.
pub const UPDATE_VAR: &str = "CAMPATH_UPDATE";

/// The golden folder of a shot: `shots/a/orbit.ron` → `shots/a/orbit.golden`.
pub fn golden_dir(shot: &Path) -> PathBuf {
    // The stem as it is (a name that is not UTF-8 stays apart from others).
    let mut name = shot.file_stem().unwrap_or_default().to_os_string();
    name.push(".golden");
    shot.with_file_name(name)
}

/// How a shot compares with its golden.
#[derive(Debug, Clone, PartialEq, Eq)]
#[non_exhaustive]
pub enum Verdict {
    /// Every frame renders to its golden hash (and the golden's frames, if it keeps them, are
    /// the pictures its hashes name).
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
    /// Frames that match their golden hash while the golden keeps frames, but whose golden
    /// picture is missing or hashes otherwise.
    pub stale: Vec<u64>,
    /// Whether the golden was written by this run ([`Options::update`]).
    pub updated: bool,
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

    /// One line saying how the shot compares, without the shot's name: `passed (24 frames)`,
    /// `3 of 24 frame(s) differ: 4, 5, 6`, `no golden (…/hashes.txt)`, or the renderer's note.
    pub fn summary(&self) -> String {
        let golden_file = golden_dir(&self.shot).join(HASHES);
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
            Verdict::Passed => return format!("passed ({} frames)", self.frames),
            Verdict::NoGolden => format!("no golden ({})", golden_file.display()),
            Verdict::Differ => differ(),
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
            format!("{what}; golden written ({})", golden_file.display())
        } else {
            what
        }
    }
}

/// Why a golden from another renderer may differ, and what to do, for `verify`'s report.
pub fn renderer_note(golden: &Path, renderer: u32) -> String {
    if renderer < VERSION {
        format!(
            "note: {} was made by campath renderer {renderer}, and this campath is renderer \
             {VERSION}: its pictures changed, not necessarily the shot. If the new frames are \
             right, approve them: `campath test --update`, or render into the golden again.",
            golden.display()
        )
    } else {
        format!(
            "note: {} was made by campath renderer {renderer}, newer than this campath's \
             renderer {VERSION}: update campath.",
            golden.display()
        )
    }
}

/// Options of [`run_shot`].
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Options {
    /// Write the golden of a shot that differs or has none: `hashes.txt`, and the frames that
    /// differ when the golden folder holds frames. A passing golden is left untouched, and a
    /// golden from a newer renderer is never overwritten.
    pub update: bool,
    /// With `update`, write every frame's PNG into the golden too, even where it kept only
    /// hashes before.
    pub keep_frames: bool,
    /// With `update`, the shot's folder was just cleared by [`clear_left_approvals`] (once for
    /// a folder of shots): [`Shot::open`] does not list it again for the shot's own.
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
    pub golden_frames: std::collections::BTreeMap<u64, PathBuf>,
    /// Held while a run may write the golden: an advisory lock on the shot file, so two
    /// approvals of one shot take turns.
    _lock: Option<std::fs::File>,
}

impl Shot {
    /// Loads the shot file and its golden. A file that does not load, or a golden that does not
    /// parse, is an error.
    pub fn load(path: &Path) -> Result<Shot> {
        Shot::open(path, Options::default())
    }

    /// [`Shot::load`], first taking the shot's lock when `options.update` (waiting for another
    /// approval of the same shot to finish), and clearing what a killed approval left (a check
    /// leaves that to [`clear_left_approvals`]).
    pub fn open(path: &Path, options: Options) -> Result<Shot> {
        let lock = if options.update {
            let file = std::fs::File::open(path).map_err(Error::read(path))?;
            file.lock().map_err(Error::read(path))?;
            // The sweep passes stems that are not UTF-8: those the shot clears itself.
            let swept = options.swept && path.file_stem().is_some_and(|s| s.to_str().is_some());
            if !swept {
                for stale in staging_dirs(path) {
                    std::fs::remove_dir_all(&stale).map_err(Error::write(&stale))?;
                }
            }
            Some(file)
        } else {
            None
        };
        let doc = Document::load(path)?;
        let dir = golden_dir(path);
        let hashes = dir.join(HASHES);
        let golden = hashes.exists().then(|| Golden::load(&dir)).transpose()?;
        let golden_frames = crate::output::frames_in(&dir);
        Ok(Shot {
            path: path.to_path_buf(),
            doc,
            golden,
            golden_frames,
            _lock: lock,
        })
    }

    /// Renders every frame, compares each with the golden, and (with [`Options::update`])
    /// writes the golden where it differs, is missing or keeps stale frames. `each` sees every
    /// differing frame that the animation has, with its fresh RGB8 pixels, as it is found (and
    /// before the golden is updated).
    ///
    /// Frames for the golden are written into a private folder beside it while the shot
    /// renders, moved into the golden once every frame is done, and `hashes.txt` is written
    /// last; a golden left half-way by a killed run keeps stale frames, which the next run
    /// reports.
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
        let keeps_frames = !golden_frames.is_empty();
        let writes_frames = options.update && (options.keep_frames || keeps_frames);
        // A golden that keeps frames, or is to keep them, must hold the pictures its hashes
        // name: a hashes-only golden approved with its frames gets every one.
        let checks_pictures = keeps_frames || writes_frames;
        let staging = staging_dir(&path);
        let mut staged = Vec::new();
        let mut fresh = Vec::with_capacity(total as usize);
        let mut differ = Vec::new();
        let mut stale = Vec::new();
        let result = stream_frames(
            &doc,
            &FrameSet::all(0..total),
            |_| false,
            |frame, _, pixels, hash| {
                fresh.push((frame, hash));
                let expected = golden.as_ref().and_then(|g| g.hash(frame));
                let same = expected == Some(hash);
                let picture_ok = !checks_pictures
                    || golden_frames
                        .get(&frame)
                        .and_then(|p| png_hash(p))
                        .is_some_and(|h| Some(h) == expected);
                if same && !picture_ok {
                    stale.push(frame);
                }
                if writes_frames && !(same && picture_ok) {
                    std::fs::create_dir_all(&staging).map_err(Error::write(&staging))?;
                    let name = frame_path(&staging, frame, total);
                    write_png(&name, pixels, size, Compression::Default)?;
                    staged.push(name);
                }
                if same {
                    return Ok(());
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
            stale,
            updated: false,
        };
        let newer = matches!(run.verdict(), Verdict::OtherRenderer(r) if r > VERSION);
        if !options.update || run.verdict() == Verdict::Passed || newer {
            remove_staging()?;
            return Ok(run);
        }
        std::fs::create_dir_all(&dir).map_err(Error::write(&dir))?;
        // Golden frames the animation no longer has, or named for another frame count.
        for (frame, old) in &golden_frames {
            if *frame >= total || *old != frame_path(&dir, *frame, total) {
                std::fs::remove_file(old).map_err(Error::write(old))?;
            }
        }
        for from in &staged {
            let to = dir.join(from.file_name().expect("a frame file"));
            std::fs::rename(from, &to).map_err(Error::write(&to))?;
        }
        remove_staging()?;
        golden::write(&dir.join(HASHES), &run.fresh)?;
        run.updated = true;
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

/// The private folder where an approval of `shot` writes golden frames before moving them in:
/// hidden, beside the golden, named for this process.
fn staging_dir(shot: &Path) -> PathBuf {
    let mut name = staging_prefix(shot);
    name.push(std::process::id().to_string());
    shot.with_file_name(name)
}

/// `.STEM.golden.update-`, the stem as it is (a name that is not UTF-8 stays apart from others).
fn staging_prefix(shot: &Path) -> std::ffi::OsString {
    let mut name = std::ffi::OsString::from(".");
    name.push(shot.file_stem().unwrap_or_default());
    name.push(".golden.update-");
    name
}

/// Removes, as far as it can, the staging folders that killed approvals left in `folder`:
/// those of shots no approval holds the lock of now. The folder is listed once, so a check of
/// every shot of a folder costs one listing. A check writes nothing it must: a folder that
/// cannot be read or removed is left.
pub fn clear_left_approvals(folder: &Path) {
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
        if std::fs::File::open(&shot).is_ok_and(|f| f.try_lock().is_ok()) {
            let _ = std::fs::remove_dir_all(entry.path());
        }
    }
}

/// Staging folders of `shot` that approvals left (killed before they finished).
fn staging_dirs(shot: &Path) -> Vec<PathBuf> {
    let prefix = staging_prefix(shot);
    let prefix = prefix.as_encoded_bytes();
    let parent = shot
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    std::fs::read_dir(parent)
        .into_iter()
        .flatten()
        .flatten()
        .filter(|e| e.file_name().as_encoded_bytes().starts_with(prefix))
        .map(|e| e.path())
        .collect()
}

/// Renders the shot `shot` and compares every frame with the golden `<stem>.golden/hashes.txt`
/// beside it; panics naming the frames that differ and how to approve them.
///
/// With `CAMPATH_UPDATE=1` in the environment it writes the golden instead (only if the shot
/// differs or has none) and passes; with `CAMPATH_UPDATE=frames` it writes the golden with
/// its frames, to look at before committing it. Any other value but `0` or an empty one is
/// refused (a panic), so a misspelt approval never passes as a check. A golden from a newer
/// renderer is never written.
///
/// ```
/// // tests/shots/orbit.ron, with tests/shots/orbit.golden/hashes.txt beside it.
/// let shot = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/shots/orbit.ron");
/// campath::testing::assert_shot(shot);
/// ```
#[track_caller]
pub fn assert_shot(shot: impl AsRef<Path>) {
    let shot = shot.as_ref();
    let var = std::env::var_os(UPDATE_VAR).unwrap_or_default();
    let (update, keep_frames) = match var.to_str() {
        Some("" | "0") => (false, false),
        Some("1") => (true, false),
        Some("frames") => (true, true),
        _ => panic!(
            "{UPDATE_VAR}={}: set it to 1 to write the golden, or to frames to write it with its \
             frames (to look at); unset, empty or 0 compares",
            var.to_string_lossy()
        ),
    };
    let options = Options {
        update,
        keep_frames,
        swept: false,
    };
    if !update {
        clear_left_approvals(shot.parent().unwrap_or(Path::new(".")));
    }
    let run = match run_shot(shot, options, |_, _| Ok(())) {
        Ok(run) => run,
        Err(e) => panic!("campath shot {}: {e}", shot.display()),
    };
    if run.ok() {
        return;
    }
    let mut message = format!("campath shot {}: {}", shot.display(), run.summary());
    for d in run.differ.iter().take(8) {
        let hash = |h: &Option<FrameHash>| h.map_or_else(|| "none".into(), |h| h.to_string());
        message += &format!(
            "\n  frame {}: golden {}, fresh {}",
            d.frame,
            hash(&d.expected),
            hash(&d.actual)
        );
    }
    let golden = golden_dir(shot);
    message += &match run.verdict() {
        // Never written by this campath: only a newer one can approve it.
        Verdict::OtherRenderer(r) if r > VERSION => format!(
            "\n{} is a newer campath's: update campath to check the shot against it.",
            golden.display()
        ),
        Verdict::NoGolden => format!(
            "\nThe shot has no golden yet: run the test again with {UPDATE_VAR}=frames to \
             write {} with its frames, look at them, and commit it.",
            golden.display()
        ),
        _ => format!(
            "\nIf the change is intended, run the test again with {UPDATE_VAR}=frames to write \
             the golden with its frames (=1: its hashes, and the frames it keeps), look at the \
             frames, and commit {}.",
            golden.display()
        ),
    };
    panic!("{message}");
}
