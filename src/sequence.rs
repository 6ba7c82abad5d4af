//! A frame sequence in an output folder: which frames on disk are still valid for the file as it
//! is now, rendering the rest, and keeping the folder's manifests true.
//!
//! A frame on disk is kept only when a manifest records it with the frame's current
//! [`FrameKey`](crate::render::key::FrameKey) and its PNG decodes to the recorded pixel hash; every
//! other frame of the run is rendered again. So no frame survives an edit of the file, a
//! different file rendered into the same folder, or a campath whose pictures differ.

use std::collections::{BTreeMap, BTreeSet};
use std::fs::OpenOptions;
use std::io::Write;
use std::path::{Path, PathBuf};

use rayon::prelude::*;
use sha2::{Digest, Sha256};

use crate::document::Document;
use crate::error::{Error, Result};
use crate::frames::{keys, stream_frames, FrameSet, Timing};
use crate::lock::{Claim, FolderLock, Wait};
use crate::manifest::{self, Entry, Manifest, PartHeader};
use crate::output::{
    frame_of, frame_path, is_desktop_clutter, is_ours, pad_width, png_hash,
    remove_if_there as remove, resolved, write_atomic, write_png_atomic, Compression,
};

/// Why frames of the run were rendered rather than kept.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Reasons {
    /// Never rendered into this folder (no manifest records the frame).
    pub missing: u64,
    /// Recorded, but for other input: the file, the scene or campath's renderer changed.
    pub changed: u64,
    /// Recorded with the current key, but the PNG is gone or does not decode to its hash.
    pub damaged: u64,
    /// `--force`.
    pub forced: u64,
}

/// What a render did.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct RenderSummary {
    /// Frames rendered, with their times.
    pub timing: Timing,
    /// Frames of the run already complete on disk, neither rendered nor written.
    pub kept: u64,
    /// Why the other frames were rendered.
    pub reasons: Reasons,
    /// Stale frame files removed (from another file or version, or past the animation's end).
    pub removed: u64,
}

/// How a render reports progress, called from the writer thread.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Event {
    /// The run covers `frames` frames, of which `kept` are already complete.
    Start {
        /// Frames of the run.
        frames: u64,
        /// Of those, already complete on disk.
        kept: u64,
    },
    /// A frame's PNG and manifest line are written.
    Written(u64),
}

/// Options of [`render`].
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct RenderOptions {
    /// PNG compression (the pixels are the same).
    pub compression: Compression,
    /// Render every frame of the run again, even those still valid on disk.
    pub force: bool,
}

/// The frames of a run, sorted into kept and to render, before anything is written.
struct Plan {
    /// SHA-256 of every frame's key in order.
    sequence: String,
    /// Frames of the run that are valid on disk.
    kept: Vec<Entry>,
    /// Frames outside the run that are recorded with their current key (whole runs only).
    outside: Vec<Entry>,
    /// Frame files that belong to no frame of the file as it is now (whole runs only).
    stale: Vec<PathBuf>,
    /// Frame files of the run's frames that are not kept: their pictures are of other input,
    /// damaged, or unrecorded, and go before the run renders them again.
    replaced: Vec<PathBuf>,
    reasons: Reasons,
}

/// Every frame line of every manifest in `dir`, by frame: hashes.txt's and the part files', and
/// apart from them those of the hashes.txt a shard moved aside. hashes.txt is read before the
/// file a shard renames it to, so a shard renaming it meanwhile hides neither.
fn recorded(dir: &Path) -> (BTreeMap<u64, Vec<Entry>>, BTreeMap<u64, Entry>) {
    let whole = Manifest::read_lenient(&dir.join(manifest::file_name(None)));
    let aside = Manifest::read_lenient(&dir.join(manifest::BEFORE_SHARDS));
    let parts = manifest::parts_in(dir).unwrap_or_default().into_values();
    let mut out: BTreeMap<u64, Vec<Entry>> = BTreeMap::new();
    for e in whole
        .entries
        .into_iter()
        .chain(parts.flat_map(|p| Manifest::read_lenient(&p).entries))
    {
        out.entry(e.frame).or_default().push(e);
    }
    let aside = aside.entries.into_iter().map(|e| (e.frame, e)).collect();
    (out, aside)
}

/// The frames on disk under this animation's names, and the frame files named for no frame of it
/// (past its end, or padded for another frame count).
fn frame_files(dir: &Path, total: u64) -> (BTreeSet<u64>, Vec<PathBuf>) {
    let mut files = BTreeSet::new();
    let mut foreign = Vec::new();
    for e in std::fs::read_dir(dir).into_iter().flatten().flatten() {
        let name = e.file_name().to_string_lossy().into_owned();
        if let Some((frame, digits)) = frame_of(&name) {
            if frame < total && digits == pad_width(total) {
                files.insert(frame);
            } else {
                foreign.push(e.path());
            }
        }
    }
    (files, foreign)
}

/// Of the frames recorded with their current key, those whose PNG decodes to a recorded hash.
/// Decoding is the slow part of a resume, so it runs in parallel.
fn on_disk(dir: &Path, total: u64, check: &[(u64, Vec<&Entry>)]) -> Vec<Entry> {
    check
        .par_iter()
        .filter_map(|(frame, current)| {
            let hash = png_hash(&frame_path(dir, *frame, total))?;
            current
                .iter()
                .find(|e| e.hash == hash)
                .map(|e| (*e).clone())
        })
        .collect()
}

fn plan(doc: &Document, dir: &Path, set: &FrameSet, force: bool) -> Result<Plan> {
    let total = doc.animation.frames;
    let (recorded, aside) = recorded(dir);
    let whole = set.shard.is_none();
    let (files, mut stale) = frame_files(dir, total);
    if !whole {
        stale.clear();
    }
    let mut sequence = Sha256::new();
    let mut reasons = Reasons::default();
    let mut check = Vec::new();
    let mut outside = Vec::new();
    let mut unsure = Vec::new();
    for item in keys(doc) {
        let (frame, key) = item?;
        sequence.update(key.0.as_bytes());
        let is_current = |e: &&Entry| e.key.as_ref() == Some(&key);
        let records: Vec<&Entry> = (recorded.get(&frame).into_iter().flatten())
            .chain(aside.get(&frame))
            .collect();
        let current: Vec<&Entry> = records.iter().copied().filter(is_current).collect();
        if set.contains(frame) {
            if force {
                reasons.forced += 1;
            } else if !current.is_empty() {
                check.push((frame, current));
            } else if records.is_empty() {
                reasons.missing += 1;
            } else {
                reasons.changed += 1;
            }
        } else if whole && files.contains(&frame) {
            // What a shard moved aside may be older than the frame's picture (a later shard
            // may have rendered it again from other input): a frame outside the run that only
            // that file names as current is kept only if its PNG decodes to the record, as a
            // frame of the run is. The other records are of what their run left on disk.
            let trusted = recorded.get(&frame).into_iter().flatten().find(is_current);
            match trusted {
                Some(e) => outside.push(e.clone()),
                None if !current.is_empty() => unsure.push((frame, current)),
                None => stale.push(frame_path(dir, frame, total)),
            }
        }
    }
    let confirmed = on_disk(dir, total, &unsure);
    let sure: BTreeSet<u64> = confirmed.iter().map(|e| e.frame).collect();
    for (frame, _) in &unsure {
        if !sure.contains(frame) {
            stale.push(frame_path(dir, *frame, total));
        }
    }
    outside.extend(confirmed);
    outside.sort_by_key(|e| e.frame);
    let kept = on_disk(dir, total, &check);
    reasons.damaged = check.len() as u64 - kept.len() as u64;
    let valid: BTreeSet<u64> = kept.iter().map(|e| e.frame).collect();
    let replaced = files
        .iter()
        .filter(|&&frame| set.contains(frame) && !valid.contains(&frame))
        .map(|&frame| frame_path(dir, frame, total))
        .collect();
    Ok(Plan {
        sequence: format!("{:x}", sequence.finalize()),
        kept,
        outside,
        stale,
        replaced,
        reasons,
    })
}

/// Refuses a path that is not a folder, a golden folder, or a folder that holds anything
/// campath does not write there.
pub fn check_folder(dir: &Path) -> Result<()> {
    if dir.exists() && !dir.is_dir() {
        return Err(Error::Usage(format!(
            "{} is a file, not a folder: --out names the folder the frames go into",
            dir.display()
        )));
    }
    if let Some(why) = golden_of(dir) {
        return Err(Error::Usage(format!(
            "{why}, written only on approval (`campath test --update`); nothing was written \
             (choose another folder than {})",
            dir.display()
        )));
    }
    // Nor inside another folder of rendered frames: that one would then hold a folder campath
    // did not write there, and its next render would refuse it.
    if let Some(outer) = resolved(dir).parent().and_then(frames_folder_of) {
        return Err(Error::Usage(format!(
            "{} lies inside {}, a folder of rendered frames; nothing was written (choose a \
             folder outside it)",
            dir.display(),
            outer.display()
        )));
    }
    let Ok(entries) = std::fs::read_dir(dir) else {
        return Ok(());
    };
    let foreign: Vec<String> = entries
        .flatten()
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| !is_ours(n) && !is_desktop_clutter(n))
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

/// Why writing at `path` would write into a golden, if it would: `path` (as it resolves, links
/// and `..` followed) is or lies inside a shot's golden (`NAME.golden` beside `NAME.ron`), or is
/// a folder whose `hashes.txt` names campath's renderer and lists frames without keys, as the
/// goldens campath writes do (an output folder's frames have keys; one from before frame keys
/// names no renderer, and is rendered again).
pub fn golden_of(path: &Path) -> Option<String> {
    let real = resolved(path);
    // The folders on the way as written, too: a golden may itself be a link (`NAME.golden` to
    // where the frames are kept).
    let written = std::path::absolute(path).unwrap_or_else(|_| path.to_path_buf());
    for folder in real.ancestors().chain(written.ancestors()) {
        if folder.extension().is_some_and(|e| e == "golden") {
            let ron = folder.with_extension("ron");
            if ron.is_file() {
                return Some(format!(
                    "{} is the golden of {}",
                    folder.display(),
                    ron.display()
                ));
            }
        }
    }
    manifest::written_as_golden(&real.join(manifest::file_name(None))).then(|| {
        format!(
            "{} is a golden: its hashes.txt names campath's renderer and lists frames without keys",
            path.display()
        )
    })
}

/// The folder of rendered frames that `path` (as it resolves) is or lies inside, if any: the
/// nearest on the way up that holds campath's lock file, or a manifest that begins as
/// campath's do (`# campath`; someone's `hashes.txt` of checksums is not one).
pub fn frames_folder_of(path: &Path) -> Option<PathBuf> {
    resolved(path)
        .ancestors()
        .find(|dir| {
            dir.join(crate::lock::FILE_NAME).is_file()
                || manifest::begins_as_campaths(&dir.join(manifest::file_name(None)))
                || manifest::begins_as_campaths(&dir.join(manifest::BEFORE_SHARDS))
        })
        .map(Path::to_path_buf)
}

/// The video `campath video` writes for the keyframe file `file` into its frames folder `dir`:
/// `STEM.mp4`, or `STEM.mkv` (lossless), the stem as it is.
pub fn video_path(dir: &Path, file: &Path, ext: &str) -> PathBuf {
    let mut name = file.file_stem().unwrap_or("video".as_ref()).to_os_string();
    name.push(format!(".{ext}"));
    dir.join(name)
}

/// Removes the records this run would make false: the frame files of the run's frames that it
/// renders again (so a run stopped on the way leaves no old picture under a frame's name); a
/// shard moves hashes.txt aside to [`manifest::BEFORE_SHARDS`] (`merge` writes hashes.txt
/// again; the shards still to run keep their frames by it); a whole run removes the part files,
/// that file, and the frame files of no current frame. Returns the number of frame files of no
/// current frame removed.
fn remove_stale_records(dir: &Path, set: &FrameSet, plan: &Plan) -> Result<u64> {
    if set.shard.is_some() {
        // First: hashes.txt never lists a frame whose picture is gone.
        let whole = dir.join(manifest::file_name(None));
        match std::fs::rename(&whole, dir.join(manifest::BEFORE_SHARDS)) {
            Err(e) if e.kind() != std::io::ErrorKind::NotFound => {
                return Err(Error::write(&whole)(e))
            }
            _ => {}
        }
    }
    for path in &plan.replaced {
        remove(path)?;
    }
    if set.shard.is_some() {
        return Ok(0);
    }
    for path in manifest::parts_in(dir)?.values() {
        remove(path)?;
    }
    remove(&dir.join(manifest::BEFORE_SHARDS))?;
    let mut removed = 0;
    for path in &plan.stale {
        removed += u64::from(remove(path)?);
    }
    Ok(removed)
}

/// Takes the lock of the output folder `dir` for a render of `set` (see [`crate::lock`]), after
/// checking what can be checked without writing: that `dir` holds nothing campath did not
/// write, and that every frame's camera is defined. So a refused file or folder leaves nothing
/// behind, not even the folder.
pub fn lock(doc: &Document, dir: &Path, set: &FrameSet, wait: Wait) -> Result<FolderLock> {
    check_folder(dir)?;
    doc.check_path()?;
    FolderLock::acquire(dir, Claim::of(set.shard), wait)
}

/// Renders the frames of `set` to PNGs in the locked folder (see [`lock`]) with their manifest:
/// hashes.txt, or hashes.part-K-of-N.txt for a shard (marked complete when the shard has
/// finished).
///
/// - `lock` must be the folder's lock for `set` (a whole run's, or the shard's); so no other
///   run writes the same files meanwhile.
/// - Nothing is written before every frame's camera is checked, and never into a folder that
///   holds files campath did not write.
/// - A frame of the run is kept when a manifest records it with its current key and its PNG
///   decodes to the recorded hash (unless `force`); every other frame is rendered.
/// - The run's manifest is written first, listing the frames it keeps; then the records it
///   makes false go: a whole run removes the part files and the frame files that belong to no
///   frame of the file as it is now; a shard moves hashes.txt aside (`merge` writes it again
///   from the parts), where the shards after it still read it.
/// - Each PNG is written under a temporary name and renamed into place; its manifest line is
///   appended after that, so the manifest lists only complete frames, even after SIGKILL.
/// - PNG encoding runs on its own thread while the next frame renders.
pub fn render(
    doc: &Document,
    lock: &FolderLock,
    set: &FrameSet,
    options: RenderOptions,
    progress: &mut (dyn FnMut(Event) + Send),
) -> Result<RenderSummary> {
    let started = std::time::Instant::now();
    let dir = lock.dir();
    if lock.claim() != Claim::of(set.shard) {
        return Err(Error::Usage(format!(
            "{}: a render of {} needs the folder's lock for it, not for {}",
            dir.display(),
            Claim::of(set.shard),
            lock.claim()
        )));
    }
    check_folder(dir)?;
    let plan = plan(doc, dir, set, options.force)?;
    // The video `video` makes in the folder is made of its frames: a run that changes any
    // removes it first, and what a stopped encode of it left.
    if set.count() > plan.kept.len() as u64 || !plan.stale.is_empty() {
        for ext in ["mp4", "mkv", "mp4.tmp", "mkv.tmp"] {
            remove(&video_path(dir, &doc.path, ext))?;
        }
    }
    let total = doc.animation.frames;
    let manifest_path = dir.join(manifest::file_name(set.shard));
    let mut manifest = Manifest::new(
        set.shard.map(|shard| PartHeader {
            shard,
            range: set.range.clone(),
            frames: total,
            sequence: plan.sequence.clone(),
        }),
        plan.kept.iter().chain(&plan.outside).cloned().collect(),
    );
    // The manifest first, of the pictures that stay: a run stopped at any point after it leaves
    // every kept frame recorded, before the records it replaces and the stale pictures go.
    write_atomic(&manifest_path, manifest.text())?;
    let removed = remove_stale_records(dir, set, &plan)?;
    let mut file = OpenOptions::new()
        .append(true)
        .open(&manifest_path)
        .map_err(Error::write(&manifest_path))?;
    let kept: BTreeSet<u64> = plan.kept.iter().map(|e| e.frame).collect();
    progress(Event::Start {
        frames: set.count(),
        kept: kept.len() as u64,
    });
    let size = (doc.raster.width, doc.raster.height);
    let mut timing = stream_frames(
        doc,
        set,
        |frame| kept.contains(&frame),
        |frame, key, pixels, hash| {
            write_png_atomic(
                &frame_path(dir, frame, total),
                pixels,
                size,
                options.compression,
            )?;
            let entry = Entry {
                frame,
                hash,
                key: Some(key.clone()),
            };
            // The whole line in one write: `writeln!` would write it piece by piece, and a
            // run killed between two pieces would leave a torn line behind.
            let line = format!("{entry}\n");
            file.write_all(line.as_bytes())
                .map_err(Error::write(&manifest_path))?;
            progress(Event::Written(frame));
            Ok(())
        },
    )?;
    // The final manifest: sorted, one line per frame, and complete.
    let mut entries = BTreeMap::new();
    for e in Manifest::read_lenient(&manifest_path).entries {
        entries.insert(e.frame, e);
    }
    manifest.entries = entries.into_values().collect();
    manifest.complete = set.shard.is_some();
    write_atomic(&manifest_path, manifest.text())?;
    // The whole run, checking the frames on disk included.
    timing.wall_secs = started.elapsed().as_secs_f64();
    Ok(RenderSummary {
        timing,
        kept: kept.len() as u64,
        reasons: plan.reasons,
        removed,
    })
}

/// Merges the part files in `dir` into `dir/hashes.txt` (see [`manifest::merge`]), after
/// checking that every listed frame's PNG decodes to its recorded hash (in parallel); returns
/// the number of frames. Writes nothing when the parts do not make a whole, true sequence.
///
/// `lock` must be a whole run's lock of the folder: no shard writes its part meanwhile.
pub fn merge(lock: &FolderLock) -> Result<u64> {
    let dir = lock.dir();
    if lock.claim() != Claim::Whole {
        return Err(Error::Usage(format!(
            "{}: merge needs the whole folder's lock, not {}'s",
            dir.display(),
            lock.claim()
        )));
    }
    let (text, total) = manifest::merge(dir, |frame, total| frame_path(dir, frame, total))?;
    let merged = Manifest::parse(&dir.join(manifest::file_name(None)), &text)?;
    let mut damaged: Vec<u64> = merged
        .entries
        .par_iter()
        .filter(|e| png_hash(&frame_path(dir, e.frame, total)).as_ref() != Some(&e.hash))
        .map(|e| e.frame)
        .collect();
    damaged.sort_unstable();
    if !damaged.is_empty() {
        return Err(Error::Merge {
            dir: dir.to_path_buf(),
            problems: vec![format!(
                "frame(s) {} do not decode to their recorded hashes (damaged or overwritten since): \
                 run their shards again",
                manifest::list_frames(&damaged)
            )],
        });
    }
    write_atomic(&dir.join(manifest::file_name(None)), &text)?;
    remove(&dir.join(manifest::BEFORE_SHARDS))?;
    Ok(merged.entries.len() as u64)
}
