//! A frame sequence in an output folder: which frames on disk are still valid for the file as it
//! is now, rendering the rest, and keeping the folder's manifests true.
//!
//! A frame on disk is kept only when a manifest records it with the frame's current
//! [`FrameKey`](crate::key::FrameKey) and its PNG decodes to the recorded pixel hash; every
//! other frame of the run is rendered again. So no frame survives an edit of the file, a
//! different file rendered into the same folder, or a campath whose pictures differ.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

use rayon::prelude::*;
use sha2::{Digest, Sha256};

use super::files::{
    png_hash, remove_if_there as remove, remove_temps_of, temp_of, write_atomic, write_png_atomic,
};
use super::lock::{Claim, FolderLock, Wait};
use super::manifest::{Entry, Manifest, PartHeader, Writer};
use super::{
    check, entries, frame_of, frame_path, manifest_name, pad_width, parts_in, videos, Compression,
    Use, BEFORE_SHARDS, HASHES,
};
use crate::document::Document;
use crate::error::{Error, Result};
use crate::frames::{keys, list_frames, stream_frames, FrameSet, Timing};
use crate::hash::FrameHash;

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
    /// The videos of the folder's frames removed because frames changed (`STEM.mp4`,
    /// `STEM.mkv`).
    pub videos_removed: Vec<PathBuf>,
    /// The manifest as the run left it: every frame of the run, and those outside it still
    /// valid (a whole run's).
    pub manifest: Manifest,
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
    sequence: FrameHash,
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
    let whole = Manifest::read_lenient(&dir.join(HASHES));
    let aside = Manifest::read_lenient(&dir.join(BEFORE_SHARDS));
    let parts = parts_in(dir).unwrap_or_default().into_values();
    let mut lines = whole.entries;
    lines.extend(parts.flat_map(|p| Manifest::read_lenient(&p).entries));
    let mut out: BTreeMap<u64, Vec<Entry>> = BTreeMap::new();
    for e in lines {
        out.entry(e.frame).or_default().push(e);
    }
    let aside = aside.entries.into_iter().map(|e| (e.frame, e)).collect();
    (out, aside)
}

/// The frames on disk under this animation's names, and what a whole run removes: the frame
/// files named for no frame of it (past its end, or padded for another frame count), and files
/// a killed run left under temporary names.
fn frame_files(dir: &Path, total: u64) -> (BTreeSet<u64>, Vec<PathBuf>) {
    let mut files = BTreeSet::new();
    let mut foreign = Vec::new();
    for (name, e) in entries(dir) {
        if let Some((frame, digits)) = frame_of(&name) {
            if frame < total && digits == pad_width(total) {
                files.insert(frame);
            } else {
                foreign.push(e.path());
            }
        } else if temp_of(&name).is_some() {
            // What a run killed while writing left under a temporary name: a whole run, the
            // folder's only writer, removes it.
            foreign.push(e.path());
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
            current.iter().copied().find(|e| e.hash == hash).cloned()
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
    let (mut check, mut outside, mut unsure) = (Vec::new(), Vec::new(), Vec::new());
    for item in keys(doc) {
        let (frame, key) = item?;
        sequence.update(key.to_string().as_bytes());
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
    let unconfirmed = unsure.iter().filter(|(frame, _)| !sure.contains(frame));
    stale.extend(unconfirmed.map(|(frame, _)| frame_path(dir, *frame, total)));
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
        sequence: FrameHash(sequence.finalize().into()),
        kept,
        outside,
        stale,
        replaced,
        reasons,
    })
}

/// Removes the records this run would make false (see [`render`]), and the frame files it renders
/// again, so a run stopped on the way leaves no old picture under a frame's name. Returns the
/// number of frame files of no current frame removed.
fn remove_stale_records(dir: &Path, set: &FrameSet, plan: &Plan) -> Result<u64> {
    if set.shard.is_some() {
        // First: hashes.txt never lists a frame whose picture is gone.
        let whole = dir.join(HASHES);
        match std::fs::rename(&whole, dir.join(BEFORE_SHARDS)) {
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
    for path in parts_in(dir).map_err(Error::read(dir))?.values() {
        remove(path)?;
    }
    remove(&dir.join(BEFORE_SHARDS))?;
    plan.stale.iter().map(|p| remove(p).map(u64::from)).sum()
}

/// Takes the lock of the output folder `dir` for a render of `set` (see `output::lock`), after
/// checking what can be checked without writing: that `dir` may be written (`output::check`), and
/// that every frame's camera is defined. So a refused file or folder leaves nothing behind, not
/// even the folder.
pub fn lock(doc: &Document, dir: &Path, set: &FrameSet, wait: Wait) -> Result<FolderLock> {
    check(dir, Use::Frames)?;
    doc.check_path()?;
    FolderLock::acquire(dir, set.shard.map_or(Claim::Whole, Claim::Shard), wait)
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
    let claim = set.shard.map_or(Claim::Whole, Claim::Shard);
    if lock.claim() != claim {
        return Err(Error::Usage(format!(
            "{}: a render of {claim} needs the folder's lock for it, not for {}",
            dir.display(),
            lock.claim()
        )));
    }
    check(dir, Use::Frames)?;
    let plan = plan(doc, dir, set, options.force)?;
    // The video `video` makes in the folder is made of its frames: a run that changes any
    // removes it first, and what a stopped encode of it left.
    let mut videos_removed = Vec::new();
    if set.count() > plan.kept.len() as u64 || !plan.stale.is_empty() {
        for video in videos(dir, &doc.path) {
            remove_temps_of(&video)?;
            if remove(&video)? {
                videos_removed.push(video);
            }
        }
    }
    let total = doc.animation.frames;
    let manifest = Manifest::new(
        set.shard.map(|shard| PartHeader {
            shard,
            range: set.range.clone(),
            frames: total,
            sequence: plan.sequence,
        }),
        plan.kept.iter().chain(&plan.outside).cloned().collect(),
    );
    // The manifest first, of the pictures that stay: a run stopped at any point after it leaves
    // every kept frame recorded, before the records it replaces and the stale pictures go.
    let mut manifest = Writer::create(dir.join(manifest_name(set.shard)), manifest)?;
    let removed = remove_stale_records(dir, set, &plan)?;
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
            let png = frame_path(dir, frame, total);
            write_png_atomic(&png, pixels, size, options.compression)?;
            let key = Some(*key);
            manifest.append(Entry { frame, hash, key })?;
            progress(Event::Written(frame));
            Ok(())
        },
    )?;
    let manifest = manifest.finish(set.shard.is_some())?;
    // The whole run, checking the frames on disk included.
    timing.wall_secs = started.elapsed().as_secs_f64();
    Ok(RenderSummary {
        timing,
        kept: kept.len() as u64,
        reasons: plan.reasons,
        removed,
        videos_removed,
        manifest,
    })
}

/// Merges the part files in `dir` into `dir/hashes.txt` (see [`super::merge::merge`]), after
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
    let (merged, total) = super::merge::merge(dir)?;
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
                list_frames(&damaged)
            )],
        });
    }
    write_atomic(&dir.join(HASHES), merged.text())?;
    remove(&dir.join(BEFORE_SHARDS))?;
    Ok(merged.entries.len() as u64)
}
