//! A shot's golden folder and its pending golden, and the moves between them.
//!
//! - `NAME.golden/`: `hashes.txt`, a small picture of every frame (`thumb_NNNN.png`) and,
//!   when the golden keeps them, every frame (`frame_NNNN.png`).
//! - `NAME.golden.new/`: what a failing run found, for `campath review`: `hashes.txt` of every
//!   frame, the full new pictures of the frames that differ, their difference images
//!   (`frame_NNNN.diff.png`) and the small pictures the golden lacks or that changed.
//!
//! Each is written in a hidden folder beside it, `.NAME.golden.update-PID`, and moved into
//! place whole: a golden is swapped with its successor in one rename, so a run killed at any
//! moment leaves the old golden or the new one, never a mix.

use std::collections::BTreeMap;
use std::ffi::OsString;
use std::path::{Path, PathBuf};

use crate::error::{Error, Result};
use crate::golden::Golden;
use crate::output::{frame_path, frames_in, pad_width, HASHES};

/// The golden folder of a shot: `shots/a/orbit.ron` → `shots/a/orbit.golden`.
pub fn golden_dir(shot: &Path) -> PathBuf {
    beside(shot, "", ".golden")
}

/// The pending golden of a shot: `shots/a/orbit.ron` → `shots/a/orbit.golden.new`.
pub fn pending_dir(shot: &Path) -> PathBuf {
    beside(shot, "", ".golden.new")
}

/// The shot's stem of a golden's or pending golden's folder name: `orbit` of `orbit.golden` and
/// of `orbit.golden.new`.
pub(crate) fn stem_of_golden(name: &str) -> Option<&str> {
    (name.strip_suffix(".golden.new")).or_else(|| name.strip_suffix(".golden"))
}

/// `PREFIX STEM SUFFIX` beside the shot; the stem as it is (a name that is not UTF-8 stays
/// apart from others).
fn beside(shot: &Path, prefix: &str, suffix: &str) -> PathBuf {
    let mut name = OsString::from(prefix);
    name.push(shot.file_stem().unwrap_or_default());
    name.push(suffix);
    shot.with_file_name(name)
}

/// `.STEM.golden.update-`: the start of the hidden folders where a golden or pending golden is
/// put together.
fn staging_prefix(shot: &Path) -> OsString {
    let name = beside(shot, ".", ".golden.update-");
    name.file_name().unwrap_or_default().to_os_string()
}

/// A hidden folder of this process beside the shot, for putting a golden together (`what`
/// tells this process's folders apart).
pub(super) fn staging_dir(shot: &Path, what: &str) -> PathBuf {
    let mut name = staging_prefix(shot);
    name.push(format!("{}{what}", std::process::id()));
    shot.with_file_name(name)
}

/// `dir/thumb_0042.png`: the small picture of a frame, padded for `frames` frames.
pub fn thumb_path(dir: &Path, frame: u64, frames: u64) -> PathBuf {
    let width = pad_width(frames);
    dir.join(format!("thumb_{frame:0width$}.png"))
}

/// `dir/frame_0042.diff.png`: a frame's difference image.
pub fn diff_path(dir: &Path, frame: u64, frames: u64) -> PathBuf {
    frame_path(dir, frame, frames).with_extension("diff.png")
}

/// The small pictures `thumb_NNNN.png` in `dir`, by frame.
pub fn thumbs_in(dir: &Path) -> BTreeMap<u64, PathBuf> {
    let of = |name: &str| {
        let number = name.strip_prefix("thumb_")?.strip_suffix(".png")?;
        crate::output::digits(number)
    };
    let all = std::fs::read_dir(dir).into_iter().flatten().flatten();
    all.filter_map(|e| Some((of(e.file_name().to_str()?)?, e.path())))
        .collect()
}

/// Removes a folder whole or not at all, as seen from its name: it is renamed out of the way
/// first, so a removal killed half-way leaves only a hidden folder, which the next run of the shot removes.
pub(super) fn remove(shot: &Path, dir: &Path) -> Result<()> {
    let aside = staging_dir(shot, "-removed");
    match std::fs::rename(dir, &aside) {
        Ok(()) => std::fs::remove_dir_all(&aside).map_err(Error::write(&aside)),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(()),
        Err(e) => Err(Error::write(dir)(e)),
    }
}

/// Puts the folder `staged` in the place of `dir` in one step: swapped with it when it exists
/// (the old one then removed), renamed into place when it does not.
pub(super) fn swap_in(shot: &Path, staged: &Path, dir: &Path) -> Result<()> {
    if !dir.exists() {
        return std::fs::rename(staged, dir).map_err(Error::write(dir));
    }
    exchange(shot, staged, dir)?;
    std::fs::remove_dir_all(staged).map_err(Error::write(staged))
}

#[cfg(target_os = "linux")]
fn exchange(_: &Path, a: &Path, b: &Path) -> Result<()> {
    use rustix::fs::{renameat_with, RenameFlags, CWD};
    renameat_with(CWD, a, CWD, b, RenameFlags::EXCHANGE).map_err(|e| Error::write(b)(e.into()))
}

/// Without an atomic exchange: the old folder aside, then the new one in; a run killed
/// between the two leaves the old one hidden, and no golden, until the shot's next run puts
/// it back ([`clear_left`]).
#[cfg(not(target_os = "linux"))]
fn exchange(shot: &Path, a: &Path, b: &Path) -> Result<()> {
    let aside = staging_dir(shot, "-old");
    std::fs::rename(b, &aside).map_err(Error::write(b))?;
    std::fs::rename(a, b).map_err(Error::write(b))?;
    std::fs::rename(&aside, a).map_err(Error::write(a))
}

/// `to` as a second name of `from` where the file system allows it, else a copy.
fn link(from: &Path, to: &Path) -> Result<()> {
    std::fs::hard_link(from, to)
        .or_else(|_| std::fs::copy(from, to).map(|_| ()))
        .map_err(Error::write(to))
}

/// Completes `staged`, which holds the new `hashes.txt` and the pictures that changed, into a
/// whole golden and swaps it in for the shot's golden. A frame's picture the folder lacks is
/// the old golden's, whose hash of that frame is the same. With `keep_frames` the golden keeps
/// every frame; without, only the small pictures. Difference images are left out.
pub(super) fn install_golden(shot: &Path, staged: &Path, keep_frames: bool) -> Result<()> {
    let new = Golden::load(staged)?;
    let total = new.hashes.keys().next_back().map_or(0, |f| f + 1);
    let dir = golden_dir(shot);
    let old = Golden::find(&dir)?;
    let same = |frame: u64| old.as_ref().and_then(|g| g.hash(frame)) == new.hash(frame);
    let (old_frames, old_thumbs) = (frames_in(&dir), thumbs_in(&dir));
    let (frames, thumbs) = (frames_in(staged), thumbs_in(staged));
    for (frame, path) in &frames {
        let diff = diff_path(staged, *frame, total);
        crate::output::remove_if_there(&diff)?;
        if !keep_frames {
            std::fs::remove_file(path).map_err(Error::write(path))?;
        }
    }
    for &frame in new.hashes.keys() {
        let pictures = [(&thumbs, &old_thumbs, thumb_path(staged, frame, total))];
        let full = (&frames, &old_frames, frame_path(staged, frame, total));
        for (staged_ones, old_ones, to) in pictures.into_iter().chain(keep_frames.then_some(full)) {
            if staged_ones.contains_key(&frame) {
                continue;
            }
            match old_ones.get(&frame).filter(|_| same(frame)) {
                Some(from) => link(from, &to)?,
                // Made against a golden that has changed since: its unchanged frames are not.
                None => {
                    return Err(Error::Usage(format!(
                        "{}: the golden changed after this was written, so it lacks frame \
                         {frame}'s picture; nothing was accepted (run the shot's test again)",
                        pending_dir(shot).display()
                    )))
                }
            }
        }
    }
    // A golden kept elsewhere through a link is replaced where it is kept.
    if dir.is_symlink() {
        let target = std::fs::canonicalize(&dir).map_err(Error::read(&dir))?;
        let mut name = OsString::from(".");
        name.push(target.file_name().unwrap_or_default());
        name.push(format!(".update-{}", std::process::id()));
        let beside = target.with_file_name(name);
        std::fs::rename(staged, &beside).map_err(Error::write(&beside))?;
        return swap_in(shot, &beside, &target);
    }
    swap_in(shot, staged, &dir)
}

/// The shot's pending golden, when it has one (its `hashes.txt` parses).
pub fn load_pending(shot: &Path) -> Result<Option<Golden>> {
    Golden::find(&pending_dir(shot))
}

/// Accepts the shot's pending golden: it becomes the golden, whole, under the shot's lock.
/// The golden keeps full frames when it kept them before or the shot states a tolerance.
/// With `seen`, the pending golden is accepted only if it still holds those hashes (another
/// run may have replaced it since it was shown). Returns false when the shot has no pending
/// golden.
pub fn accept(shot: &Path, seen: Option<&Golden>) -> Result<bool> {
    let _lock = lock_shot(shot)?;
    clear_left(shot)?;
    let pending = pending_dir(shot);
    let Some(now) = load_pending(shot)? else {
        return Ok(false);
    };
    if seen.is_some_and(|s| s.hashes != now.hashes) {
        return Err(Error::Usage(format!(
            "{} changed while it was shown (another run wrote it); nothing was accepted: \
             review it again",
            pending.display()
        )));
    }
    let golden = golden_dir(shot);
    let old = Golden::find(&golden)?;
    if let Some(r) = old
        .and_then(|g| g.renderer)
        .filter(|r| *r > crate::key::VERSION)
    {
        return Err(Error::Usage(format!(
            "{} was made by campath renderer {r}, newer than this campath's: update campath; \
             nothing was accepted",
            golden.display()
        )));
    }
    let keep_frames = !frames_in(&golden_dir(shot)).is_empty()
        || crate::document::Document::load(shot).is_ok_and(|d| d.tolerance().is_some());
    let staged = staging_dir(shot, "-accept");
    std::fs::create_dir(&staged).map_err(Error::write(&staged))?;
    for e in std::fs::read_dir(&pending)
        .map_err(Error::read(&pending))?
        .flatten()
    {
        link(&e.path(), &staged.join(e.file_name()))?;
    }
    install_golden(shot, &staged, keep_frames)?;
    remove(shot, &pending)?;
    Ok(true)
}

/// Rejects the shot's pending golden: it is removed, under the shot's lock. Returns false
/// when the shot has none.
pub fn reject(shot: &Path) -> Result<bool> {
    let _lock = lock_shot(shot)?;
    clear_left(shot)?;
    let pending = pending_dir(shot);
    let there = pending.exists();
    remove(shot, &pending)?;
    Ok(there)
}

/// The shot's lock: an advisory lock on the shot file, waited for.
pub(crate) fn lock_shot(path: &Path) -> Result<std::fs::File> {
    let file = std::fs::File::open(path).map_err(Error::read(path))?;
    file.lock().map_err(Error::read(path))?;
    Ok(file)
}

/// Removes the hidden folders of `shot` that killed runs left; the caller holds its lock.
pub(super) fn clear_left(shot: &Path) -> Result<()> {
    // A golden moved aside by an approval killed before its successor moved in goes back.
    let golden = golden_dir(shot);
    if !golden.exists() {
        let aside = staging_dirs(shot).into_iter().find(|d| {
            d.as_os_str().as_encoded_bytes().ends_with(b"-old") && d.join(HASHES).exists()
        });
        if let Some(aside) = aside {
            std::fs::rename(&aside, &golden).map_err(Error::write(&golden))?;
        }
    }
    for stale in staging_dirs(shot) {
        std::fs::remove_dir_all(&stale).map_err(Error::write(&stale))?;
    }
    Ok(())
}

/// The hidden folders of `shot` that killed runs left.
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
