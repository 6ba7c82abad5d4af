//! Frame-hash tests of shots, for `campath test` and for Rust tests ([`assert_shot`]).
//!
//! A shot is a keyframe file `NAME.ron`; its golden is the folder `NAME.golden/` beside it,
//! holding `hashes.txt` (see [`crate::golden`]) and, optionally, the golden frames. A shot passes
//! when every frame of its animation renders to the golden hash, and the golden lists no frame
//! the animation does not have.

use std::path::{Path, PathBuf};

/// What a frame-hash test needs, from one place.
pub use crate::document::Document;
pub use crate::frames::{hashes, render_frame};
pub use crate::golden::Golden;
pub use crate::output::frame_hash;

use crate::error::{Error, Result};
use crate::frames::{stream_frames, FrameSet};
use crate::golden::{self, HASHES};
use crate::manifest::list_frames;
use crate::output::{frame_path, write_png, Compression};
use crate::render::key::VERSION;

/// The environment variable that makes [`assert_shot`] write the golden instead of comparing.
pub const UPDATE_VAR: &str = "CAMPATH_UPDATE";

/// The golden folder of a shot: `shots/a/orbit.ron` → `shots/a/orbit.golden`.
pub fn golden_dir(shot: &Path) -> PathBuf {
    let stem = shot.file_stem().unwrap_or_default().to_string_lossy();
    shot.with_file_name(format!("{stem}.golden"))
}

/// A frame whose fresh render and golden disagree.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct FrameDiff {
    pub frame: u64,
    /// The golden hash; None when the golden does not list the frame (or there is no golden).
    pub golden: Option<String>,
    /// The fresh hash; None when the animation has no such frame.
    pub fresh: Option<String>,
}

/// How a shot compares with its golden.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Verdict {
    /// Every frame renders to its golden hash.
    Passed,
    /// Some frames differ (listed in [`ShotRun::differ`]).
    Differ,
    /// The shot has no golden yet.
    NoGolden,
    /// Frames differ, and the golden names another renderer version than this campath's: the
    /// difference may be the renderer's rather than the shot's.
    OtherRenderer(u32),
}

/// A shot rendered and compared with its golden.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ShotRun {
    pub shot: PathBuf,
    /// The golden as it was before any update.
    pub golden: Option<Golden>,
    /// The animation's frame count.
    pub frames: u64,
    /// Every frame's fresh hash, in order.
    pub fresh: Vec<(u64, String)>,
    /// The frames that differ, in order (every frame when there is no golden).
    pub differ: Vec<FrameDiff>,
    /// Whether the golden was written by this run ([`Options::update`]).
    pub updated: bool,
}

impl ShotRun {
    pub fn verdict(&self) -> Verdict {
        match &self.golden {
            None => Verdict::NoGolden,
            Some(_) if self.differ.is_empty() => Verdict::Passed,
            Some(g) => g
                .other_renderer()
                .map_or(Verdict::Differ, Verdict::OtherRenderer),
        }
    }

    /// The differing frames' numbers.
    pub fn differing_frames(&self) -> Vec<u64> {
        self.differ.iter().map(|d| d.frame).collect()
    }

    /// One line saying how the shot compares, without the shot's name: `passed (24 frames)`,
    /// `3 of 24 frames differ: 4, 5, 6`, `no golden (…/hashes.txt)`, or the renderer's note.
    pub fn summary(&self) -> String {
        let golden_file = golden_dir(&self.shot).join(HASHES);
        let differ = || {
            let of = self.frames.max(self.fresh.len() as u64);
            format!(
                "{} of {of} frame(s) differ: {}",
                self.differ.len(),
                list_frames(&self.differing_frames())
            )
        };
        if self.updated {
            let what = match self.verdict() {
                Verdict::NoGolden => "no golden".to_string(),
                _ => differ(),
            };
            return format!("{what}; golden written ({})", golden_file.display());
        }
        match self.verdict() {
            Verdict::Passed => format!("passed ({} frames)", self.frames),
            Verdict::NoGolden => format!("no golden ({})", golden_file.display()),
            Verdict::Differ => differ(),
            Verdict::OtherRenderer(r) if r < VERSION => format!(
                "golden made by renderer {r}, this campath is renderer {VERSION} (its pictures \
                 changed): {}",
                differ()
            ),
            Verdict::OtherRenderer(r) => format!(
                "golden made by renderer {r}, newer than this campath's renderer {VERSION}: \
                 update campath; {}",
                differ()
            ),
        }
    }
}

/// Options of [`run_shot`].
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Options {
    /// Write the golden of a shot that differs or has none: `hashes.txt`, and the frames that
    /// differ when the golden folder holds frames. A passing golden is left untouched.
    pub update: bool,
    /// With `update`, write every frame's PNG into the golden too, even where it kept only
    /// hashes before.
    pub keep_frames: bool,
}

/// A shot loaded: its checked document and its golden, if it has one.
#[derive(Debug, Clone)]
pub struct Shot {
    pub path: PathBuf,
    pub doc: Document,
    /// The golden `hashes.txt` in the shot's [`golden_dir`], when it exists.
    pub golden: Option<Golden>,
}

impl Shot {
    /// Loads the shot file and its golden. A file that does not load, or a golden that does not
    /// parse, is an error.
    pub fn load(path: &Path) -> Result<Shot> {
        let doc = Document::load(path)?;
        let dir = golden_dir(path);
        let golden = if dir.join(HASHES).exists() {
            Some(Golden::load(&dir)?)
        } else {
            None
        };
        Ok(Shot {
            path: path.to_path_buf(),
            doc,
            golden,
        })
    }

    /// Renders every frame, compares each with the golden, and (with [`Options::update`])
    /// writes the golden where it differs or is missing. `each` sees every differing frame that
    /// the animation has, with its fresh RGB8 pixels, as it is found (and before the golden is
    /// updated).
    pub fn run(
        self,
        options: Options,
        mut each: impl FnMut(&FrameDiff, &[u8]) -> Result<()> + Send,
    ) -> Result<ShotRun> {
        let Shot { path, doc, golden } = self;
        let dir = golden_dir(&path);
        let total = doc.animation.frames;
        let size = (doc.raster.width, doc.raster.height);
        // When the golden keeps frames (or is to keep them), the frames it lacks are written
        // under temporary names while the shot renders, and renamed into place with the hashes
        // once every frame is done and the shot needs its golden written.
        let golden_frames = golden.as_ref().map(|g| g.frames()).unwrap_or_default();
        let writes_frames = options.update && (options.keep_frames || !golden_frames.is_empty());
        let mut staged = Vec::new();
        let mut fresh = Vec::with_capacity(total as usize);
        let mut differ = Vec::new();
        stream_frames(
            &doc,
            &FrameSet::all(0..total),
            |_| false,
            |frame, _, pixels, hash| {
                fresh.push((frame, hash.to_string()));
                let expected = golden.as_ref().and_then(|g| g.hash(frame));
                let same = expected == Some(hash);
                if writes_frames && (!same || !golden_frames.contains_key(&frame)) {
                    let path = frame_path(&dir, frame, total);
                    let tmp = staged_path(&path);
                    std::fs::create_dir_all(&dir).map_err(Error::write(&dir))?;
                    write_png(&tmp, pixels, size, Compression::Default)?;
                    staged.push((tmp, path));
                }
                if same {
                    return Ok(());
                }
                let d = FrameDiff {
                    frame,
                    golden: expected.map(str::to_string),
                    fresh: Some(hash.to_string()),
                };
                each(&d, pixels)?;
                differ.push(d);
                Ok(())
            },
        )?;
        if let Some(g) = &golden {
            differ.extend(g.hashes.range(total..).map(|(frame, hash)| FrameDiff {
                frame: *frame,
                golden: Some(hash.clone()),
                fresh: None,
            }));
        }
        let mut run = ShotRun {
            shot: path,
            golden,
            frames: total,
            fresh,
            differ,
            updated: false,
        };
        if !options.update || run.verdict() == Verdict::Passed {
            for (tmp, _) in &staged {
                std::fs::remove_file(tmp).map_err(Error::write(tmp))?;
            }
            return Ok(run);
        }
        std::fs::create_dir_all(&dir).map_err(Error::write(&dir))?;
        for (tmp, path) in &staged {
            std::fs::rename(tmp, path).map_err(Error::write(path))?;
        }
        // Golden frames the animation no longer has.
        for (frame, path) in &golden_frames {
            if *frame >= total {
                std::fs::remove_file(path).map_err(Error::write(path))?;
            }
        }
        golden::write(&dir.join(HASHES), &run.fresh)?;
        run.updated = true;
        Ok(run)
    }
}

/// [`Shot::load`] and [`Shot::run`].
pub fn run_shot(
    shot: &Path,
    options: Options,
    each: impl FnMut(&FrameDiff, &[u8]) -> Result<()> + Send,
) -> Result<ShotRun> {
    Shot::load(shot)?.run(options, each)
}

fn staged_path(path: &Path) -> PathBuf {
    let mut name = path.file_name().unwrap_or_default().to_os_string();
    name.push(".tmp");
    path.with_file_name(name)
}

/// Renders the shot `shot` and compares every frame with the golden `<stem>.golden/hashes.txt`
/// beside it; panics naming the frames that differ and how to approve them.
///
/// With `CAMPATH_UPDATE=1` in the environment it writes the golden instead (only if the shot
/// differs or has none) and passes: run it once so, look at the frames, and commit the golden.
///
/// ```
/// // tests/shots/orbit.ron, with tests/shots/orbit.golden/hashes.txt beside it.
/// let shot = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/shots/orbit.ron");
/// campath::testing::assert_shot(shot);
/// ```
#[track_caller]
pub fn assert_shot(shot: impl AsRef<Path>) {
    let shot = shot.as_ref();
    let update = std::env::var_os(UPDATE_VAR).is_some_and(|v| v == "1");
    let options = Options {
        update,
        keep_frames: false,
    };
    let run = match run_shot(shot, options, |_, _| Ok(())) {
        Ok(run) => run,
        Err(e) => panic!("campath shot {}: {e}", shot.display()),
    };
    if run.updated || run.verdict() == Verdict::Passed {
        return;
    }
    let mut message = format!("campath shot {}: {}", shot.display(), run.summary());
    for d in run.differ.iter().take(8) {
        let hash = |h: &Option<String>| h.clone().unwrap_or_else(|| "none".into());
        message += &format!(
            "\n  frame {}: golden {}, fresh {}",
            d.frame,
            hash(&d.golden),
            hash(&d.fresh)
        );
    }
    message += &format!(
        "\nIf the change is intended, run the test again with {UPDATE_VAR}=1 to write the \
         golden, look at the frames, and commit {}.",
        golden_dir(shot).display()
    );
    panic!("{message}");
}
