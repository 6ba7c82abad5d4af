//! The output folder: every name campath writes into one, the one rule of who may write where,
//! and the run that keeps a folder of frames true.
//!
//! A folder of rendered frames holds `frame_NNNN.png`, its manifest `hashes.txt` (a shard's
//! `hashes.part-K-of-N.txt`, and `hashes.before-shards.txt` while shards run), the lock files
//! `campath.*.lock` ([`lock`]), the video of its frames (`STEM.mp4`, `STEM.mkv`) and the pictures
//! of the other verbs ([`pictures`]). Nothing else spells these names. [`check`] decides whether
//! a path may be written: every verb asks it before it writes anything.
//!
//! - [`files`]: atomic writes and PNG files (imports nothing above it).
//! - [`manifest`]: the manifests' grammar and the writer of a run's manifest.
//! - [`lock`]: one run writes a folder at a time.
//! - [`sequence`]: which frames on disk are still valid, the rest rendered; shard parts merged.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

pub use crate::error::Refusal;
use crate::error::{Error, Result};
use crate::frames::Shard;

mod files;
pub mod lock;
pub mod manifest;
mod merge;
pub mod sequence;

pub use files::{
    encode_png, final_name, folder_of, png_hash, remove_if_there, resolved, temp_beside,
    write_atomic, write_atomic_with, write_png, write_png_atomic, Compression,
};

/// The manifest of a whole run, and the hashes file of a golden.
pub const HASHES: &str = "hashes.txt";

/// Where a shard moves a whole run's `hashes.txt`: it would be stale once the shard renders, but
/// its records (checked against each frame's key and PNG) let later shards keep their frames.
/// `merge` and a whole run remove it.
pub(crate) const BEFORE_SHARDS: &str = "hashes.before-shards.txt";

/// The folder's lock file.
pub const LOCK: &str = "campath.lock";

/// The pictures and pages the other verbs write into an output folder (`out/STEM/` by default).
pub mod pictures {
    /// `preview`'s contact sheet (and an earlier `watch`'s).
    pub const SHEET: &str = "preview.png";
    /// `preview`'s animated GIF.
    pub const GIF: &str = "preview.gif";
    /// `plot`'s picture of the path.
    pub const PLOT: &str = "plot.png";
    /// `plot --speed`'s chart of the eye's speed against time.
    pub const SPEED: &str = "speed.png";
    /// `report`'s chart.
    pub const REPORT: &str = "report.png";
    /// An earlier `watch`'s page (today's is the studio's, served): still campath's name.
    pub const PAGE: &str = "preview.html";
    /// The state an earlier `watch`'s page reloaded.
    pub const STATUS: &str = "status.js";
    /// An earlier `watch`'s first, middle and last frames.
    pub const FRAMES: [&str; 3] = ["first.png", "middle.png", "last.png"];
}

/// The mark an earlier campath left in a folder of failure pictures, where campath's lock file
/// marks it now: read as the lock file is, and removed.
const OLD_FAILURES_MARK: &str = ".campath-failures";

/// Digits of zero padding for frame numbers: enough for `frames − 1`, at least 4.
pub fn pad_width(frames: u64) -> usize {
    frames.saturating_sub(1).to_string().len().max(4)
}

/// `dir/frame_0042.png`, padded for `frames` frames.
pub fn frame_path(dir: &Path, frame: u64, frames: u64) -> PathBuf {
    let width = pad_width(frames);
    dir.join(format!("frame_{frame:0width$}.png"))
}

/// The frame a file name `frame_NNNN.png` holds, and its digits, if it is one.
pub fn frame_of(name: &str) -> Option<(u64, usize)> {
    let number = name.strip_prefix("frame_")?.strip_suffix(".png")?;
    Some((digits(number)?, number.len()))
}

/// The number that ASCII digits alone spell (a sign or a space spells none).
pub(crate) fn digits<T: std::str::FromStr>(s: &str) -> Option<T> {
    let all = s.bytes().all(|b| b.is_ascii_digit());
    s.parse().ok().filter(|_| all)
}

/// The frame files `frame_NNNN.png` in `dir`, by frame (empty when there is no such folder).
pub fn frames_in(dir: &Path) -> BTreeMap<u64, PathBuf> {
    let frames = entries(dir).filter_map(|(name, e)| Some((frame_of(&name)?.0, e.path())));
    frames.collect()
}

/// The entries of `dir` with their names (none when it cannot be read).
pub(crate) fn entries(dir: &Path) -> impl Iterator<Item = (String, std::fs::DirEntry)> {
    let all = std::fs::read_dir(dir).into_iter().flatten().flatten();
    all.map(|e| (e.file_name().to_string_lossy().into_owned(), e))
}

/// A failure picture: `frame_NNNN.png` (the new frame) or `frame_NNNN.diff.png` (its
/// difference from the golden).
pub fn is_failure_picture(name: &str) -> bool {
    let name = final_name(name);
    frame_of(name).is_some()
        || name
            .strip_suffix(".diff.png")
            .is_some_and(|stem| frame_of(&format!("{stem}.png")).is_some())
}

/// The manifest of a run: `hashes.txt`, or `hashes.part-K-of-N.txt` for a shard.
pub fn manifest_name(shard: Option<Shard>) -> String {
    match shard {
        None => HASHES.into(),
        Some(s) => format!("hashes.part-{}-of-{}.txt", s.index, s.count),
    }
}

/// The shard whose part file has this name.
pub(crate) fn part_of(name: &str) -> Option<Shard> {
    let (k, n) = name
        .strip_prefix("hashes.part-")?
        .strip_suffix(".txt")?
        .split_once("-of-")?;
    let (index, count) = (digits(k)?, digits(n)?);
    (index < count).then_some(Shard { index, count })
}

/// The part files in `dir`, by shard.
pub(crate) fn parts_in(dir: &Path) -> std::io::Result<BTreeMap<Shard, PathBuf>> {
    Ok(std::fs::read_dir(dir)?
        .flatten()
        .filter_map(|e| Some((part_of(e.file_name().to_str()?)?, e.path())))
        .collect())
}

/// The video `campath video` writes for the keyframe file `file` into its frames folder `dir`:
/// `STEM.mp4`, or `STEM.mkv` (lossless), the stem as it is.
pub fn video_path(dir: &Path, file: &Path, ext: &str) -> PathBuf {
    let mut name = file.file_stem().unwrap_or("video".as_ref()).to_os_string();
    name.push(format!(".{ext}"));
    dir.join(name)
}

/// The videos of `file`'s frames in `dir`.
pub(crate) fn videos(dir: &Path, file: &Path) -> [PathBuf; 2] {
    ["mp4", "mkv"].map(|ext| video_path(dir, file, ext))
}

/// Whether a file of this name is one a desktop leaves in any folder it shows (Finder's
/// `.DS_Store` and `._NAME`, Windows Explorer's `Thumbs.db` and `desktop.ini`, KDE's
/// `.directory`): an output folder may hold them, though campath does not write them.
fn is_desktop_clutter(name: &str) -> bool {
    [".DS_Store", "Thumbs.db", "desktop.ini", ".directory"].contains(&name)
        || name.starts_with("._")
}

/// Whether campath writes files of this name into an output folder.
fn is_ours(name: &str) -> bool {
    use pictures::{FRAMES, GIF, PAGE, PLOT, REPORT, SHEET, SPEED, STATUS};
    let base = final_name(name);
    frame_of(base).is_some()
        || lock::is_lock_file(base)
        || part_of(base).is_some()
        || base.ends_with(".mp4")
        || base.ends_with(".mkv")
        || [HASHES, BEFORE_SHARDS].contains(&base)
        || [SHEET, GIF, PLOT, SPEED, REPORT, PAGE, STATUS].contains(&base)
        || FRAMES.contains(&base)
}

/// The folder of rendered frames that `path` (as it resolves) is or lies inside, if any: the
/// nearest on the way up that holds campath's lock file, or a manifest that begins as
/// campath's do (`# campath`; someone's `hashes.txt` of checksums is not one).
pub fn frames_folder_of(path: &Path) -> Option<PathBuf> {
    resolved(path)
        .ancestors()
        .find(|dir| {
            dir.join(LOCK).is_file()
                || manifest::begins_as_campaths(&dir.join(HASHES))
                || manifest::begins_as_campaths(&dir.join(BEFORE_SHARDS))
        })
        .map(Path::to_path_buf)
}

/// Whether `path` is `dir` or lies inside it, both as they resolve.
pub fn within(path: &Path, dir: &Path) -> bool {
    resolved(path).starts_with(resolved(dir))
}

/// What is to be written at a path.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Use {
    /// A folder of rendered frames (render, video's frames, merge) or of the other verbs'
    /// pictures (preview).
    Frames,
    /// A file of its own: an export, a video named apart from its frames, a run's statistics.
    File,
}

/// Whether `path` may be written as `usage` says, or why not. The one rule of where campath
/// writes:
///
/// - never into a golden (a shot's `NAME.golden`, or a folder whose `hashes.txt` is a golden's)
///   but on approval, which does not ask here;
/// - a folder of frames holds only what campath writes there, and lies inside no other;
/// - a file goes into no folder of rendered frames (the folder's next render would refuse it);
/// - a folder is not a file, and a file is not a folder.
pub fn check(path: &Path, usage: Use) -> std::result::Result<(), Refusal> {
    if let Some(above) = path.ancestors().skip(1).find(|p| p.is_file()) {
        return Err(Refusal::NotAFolder(above.to_path_buf()));
    }
    match usage {
        Use::Frames => {
            a_folder_of_its_own(path)?;
            let names: Vec<String> = entries(path)
                .map(|(name, _)| name)
                .filter(|n| !is_ours(n) && !is_desktop_clutter(n))
                .take(3)
                .collect();
            no_foreign(path, names)
        }
        Use::File => {
            if path.is_dir() {
                return Err(Refusal::NotAFile(path.to_path_buf()));
            }
            golden_of(folder_of(path))?;
            outside_frames(path, Some(folder_of(path)))
        }
    }
}

/// Refuses `dir` for what it holds that campath did not write: `names`, if any.
fn no_foreign(dir: &Path, names: Vec<String>) -> std::result::Result<(), Refusal> {
    match names.is_empty() {
        true => Ok(()),
        false => Err(Refusal::Foreign {
            dir: dir.to_path_buf(),
            names,
        }),
    }
}

/// Refuses `path` when `folder` (as it resolves) is or lies inside a folder of rendered frames.
fn outside_frames(path: &Path, folder: Option<&Path>) -> std::result::Result<(), Refusal> {
    match folder.and_then(frames_folder_of) {
        Some(frames) => Err(Refusal::InFrames {
            path: path.to_path_buf(),
            frames,
        }),
        None => Ok(()),
    }
}

/// Refuses `path` as a folder campath fills: a file, a golden or a folder in one, or a folder
/// inside a folder of rendered frames.
fn a_folder_of_its_own(path: &Path) -> std::result::Result<(), Refusal> {
    if path.exists() && !path.is_dir() {
        return Err(Refusal::NotAFolder(path.to_path_buf()));
    }
    golden_of(path)?;
    outside_frames(path, resolved(path).parent())
}

/// Refuses `path` when it is, or lies inside, one of `goldens` (as they resolve): the goldens a
/// run compares with, wherever they are.
pub fn outside_goldens(path: &Path, goldens: &[PathBuf]) -> std::result::Result<(), Refusal> {
    match goldens.iter().find(|g| within(path, g)) {
        Some(golden) => Err(Refusal::InGolden {
            path: path.to_path_buf(),
            golden: golden.clone(),
            inside: resolved(path) != resolved(golden),
        }),
        None => Ok(()),
    }
}

/// Claims `dir` for a run's pictures of failures (`verify --save-failures`, `test --review`):
/// refuses it (writing nothing) when it is or lies inside a golden (one of the run's `goldens`
/// or a shot's), lies inside a folder of rendered frames, is a file, or holds anything but
/// campath's lock file and, beside it, pictures whose names `ours` accepts; then takes the
/// folder's lock, which marks the folder as campath's, and removes what an earlier run left, so
/// that the folder holds this run's pictures only.
pub fn claim_pictures(
    dir: &Path,
    goldens: &[PathBuf],
    ours: impl Fn(&str) -> bool,
    wait: lock::Wait,
) -> Result<lock::FolderLock> {
    outside_goldens(dir, goldens)?;
    a_folder_of_its_own(dir)?;
    let listed: Vec<_> = entries(dir).collect();
    let is_mark = |n: &str| n == LOCK || n == OLD_FAILURES_MARK;
    let marked = listed.iter().any(|(n, _)| is_mark(n));
    let mut foreign: Vec<String> = listed
        .into_iter()
        .filter(|(n, e)| {
            let file = e.file_type().is_ok_and(|t| t.is_file());
            !(file && (is_mark(n) || (marked && ours(n))))
        })
        .map(|(n, _)| n)
        .collect();
    if foreign.len() > 3 {
        foreign.truncate(3);
        foreign.push("…".into());
    }
    no_foreign(dir, foreign)?;
    let lock = lock::FolderLock::acquire(dir, lock::Claim::Whole, wait)?;
    // Listed again under the lock: a run this one waited for may have written more since.
    for e in std::fs::read_dir(dir).map_err(Error::read(dir))?.flatten() {
        let n = e.file_name().to_string_lossy().into_owned();
        if n == OLD_FAILURES_MARK || (n != LOCK && ours(&n)) {
            remove_if_there(&e.path())?;
        }
    }
    Ok(lock)
}

/// Refuses `path` when it (as it resolves, links and `..` followed) is or lies inside a shot's
/// golden (`NAME.golden` beside `NAME.ron`) or pending golden (`NAME.golden.new`), or is a folder whose `hashes.txt` is a golden's.
pub fn golden_of(path: &Path) -> std::result::Result<(), Refusal> {
    let real = resolved(path);
    // The folders on the way as written, too: a golden may itself be a link (`NAME.golden` to
    // where the frames are kept).
    let written = std::path::absolute(path).unwrap_or_else(|_| path.to_path_buf());
    for folder in real.ancestors().chain(written.ancestors()) {
        // A golden, or a pending golden (`NAME.golden.new`).
        let golden = match folder.extension().is_some_and(|e| e == "new") {
            true => folder.with_extension(""),
            false => folder.to_path_buf(),
        };
        if golden.extension().is_some_and(|e| e == "golden") {
            let shot = golden.with_extension("ron");
            if shot.is_file() {
                return Err(Refusal::Golden {
                    golden: folder.to_path_buf(),
                    shot,
                });
            }
        }
    }
    match manifest::begins_as_golden(&real.join(HASHES)) {
        true => Err(Refusal::GoldenHashes(path.to_path_buf())),
        false => Ok(()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_parse_only_when_well_formed() {
        assert_eq!(pad_width(1), 4);
        assert_eq!(pad_width(10_000), 4);
        assert_eq!(pad_width(10_001), 5);
        assert_eq!(
            frame_path(Path::new("o"), 7, 96),
            Path::new("o/frame_0007.png")
        );
        assert_eq!(frame_of("frame_00012.png"), Some((12, 5)));
        assert_eq!(frame_of("frame_.png"), None);
        assert_eq!(frame_of("frame_12.png.tmp"), None);
        assert_eq!(
            part_of("hashes.part-2-of-5.txt"),
            Some(Shard { index: 2, count: 5 })
        );
        for bad in [
            "hashes.part-5-of-5.txt",
            "hashes.part--of-5.txt",
            "hashes.part-1-of-0.txt",
            "hashes.txt",
        ] {
            assert_eq!(part_of(bad), None, "{bad}");
        }
        for ok in [
            "frame_0001.png",
            "frame_0001.diff.png",
            "frame_12345.png.tmp",
        ] {
            assert!(is_failure_picture(ok), "{ok}");
        }
        for no in [
            "hashes.txt",
            "frame_.diff.png",
            "x.diff.png",
            "frame_1.diffpng",
        ] {
            assert!(!is_failure_picture(no), "{no}");
        }
    }

    #[test]
    fn containment_follows_links_and_dots() {
        let tmp = tempfile::tempdir().unwrap();
        let g = tmp.path().join("golden");
        std::fs::create_dir(&g).unwrap();
        assert!(within(&g, &g));
        assert!(within(&g.join("a/../b/new"), &g));
        assert!(within(&tmp.path().join("x/../golden/./y"), &g));
        assert!(!within(&tmp.path().join("golden2"), &g));
        assert!(!within(tmp.path(), &g));
        // A link to the golden reached back through a folder not made yet.
        #[cfg(unix)]
        {
            std::os::unix::fs::symlink(&g, tmp.path().join("link")).unwrap();
            assert!(within(&tmp.path().join("new/../link/f"), &g));
            assert!(within(&tmp.path().join("new/a/../../link"), &g));
        }
    }

    #[test]
    fn a_folder_of_frames_holds_only_what_campath_writes() {
        let tmp = tempfile::tempdir().unwrap();
        let out = tmp.path().join("out");
        assert_eq!(check(&out, Use::Frames), Ok(()));
        std::fs::create_dir(&out).unwrap();
        for name in [
            "frame_0001.png",
            HASHES,
            LOCK,
            "x.mp4",
            ".DS_Store",
            pictures::PLOT,
        ] {
            std::fs::write(out.join(name), "").unwrap();
        }
        assert_eq!(check(&out, Use::Frames), Ok(()));
        std::fs::write(out.join("notes.txt"), "").unwrap();
        assert_eq!(
            check(&out, Use::Frames),
            Err(Refusal::Foreign {
                dir: out.clone(),
                names: vec!["notes.txt".into()]
            })
        );
        // A file into it, or a folder of frames inside it, is refused; beside it is not.
        let in_frames = |path: PathBuf| Refusal::InFrames {
            path,
            frames: resolved(&out),
        };
        for file in [out.join("cameras.csv"), out.join("sub/x.csv")] {
            assert_eq!(check(&file, Use::File), Err(in_frames(file.clone())));
        }
        let sub = out.join("sub");
        assert_eq!(check(&sub, Use::Frames), Err(in_frames(sub.clone())));
        assert_eq!(check(&tmp.path().join("cameras.csv"), Use::File), Ok(()));
        assert_eq!(
            check(&out.join("notes.txt/x"), Use::File),
            Err(Refusal::NotAFolder(out.join("notes.txt")))
        );
        assert_eq!(check(&out, Use::File), Err(Refusal::NotAFile(out.clone())));
        // A golden beside its shot.
        let golden = tmp.path().join("a.golden");
        std::fs::create_dir(&golden).unwrap();
        assert_eq!(check(&golden, Use::Frames), Ok(()));
        std::fs::write(tmp.path().join("a.ron"), "").unwrap();
        assert!(check(&golden, Use::Frames).unwrap_err().is_golden());
        assert!(check(&golden.join("x.csv"), Use::File)
            .unwrap_err()
            .is_golden());
    }
}
