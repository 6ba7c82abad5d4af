//! An output folder is written by one run at a time: advisory locks (the operating system's
//! `flock`, through std's [`File::lock`]) on files inside the folder.
//!
//! - `campath.lock`, the folder's lock: a whole run (render, video, watch, merge) holds it
//!   exclusively; a shard holds it shared, so the shards of one run go side by side while no
//!   whole run meets any of them.
//! - `campath.shards-of-N.lock`: held shared by every running shard of N. A shard of another
//!   count M waits until it could take it exclusively, because shards of different counts render
//!   the same frames.
//! - `campath.gate.lock`: held by a starting shard while it looks for shards of other counts and
//!   takes its own count's lock, so that two shards of different counts cannot both pass.
//! - `campath.part-K-of-N.lock`: held exclusively by shard K/N, which owns its part file.
//!
//! Every run takes the folder's lock first and the others only while holding it, and a whole run
//! removes the other lock files it finds, since nobody else can hold them then.
//!
//! The operating system drops a lock when its process ends, however it ends, so a killed run
//! never blocks a later one. `campath.lock` also lists the runs holding it (process id, claim and
//! command line), for the message of a run that has to wait; that text is read only for
//! messages and never decides anything.

use std::fs::{File, OpenOptions, TryLockError};
use std::io::{Seek, Write};
use std::path::{Path, PathBuf};

use super::{remove_if_there, Refusal, LOCK as FILE_NAME};
use crate::error::{Error, Result};
use crate::frames::Shard;

const GATE: &str = "campath.gate.lock";

/// Tries, 10 ms apart, that a run which must not wait gives a lock no live run records
/// holding ([`take`]).
const UNRECORDED_TRIES: usize = 30;

/// Whether campath writes a lock file of this name into an output folder.
pub(crate) fn is_lock_file(name: &str) -> bool {
    name.starts_with("campath.") && name.ends_with(".lock")
}

/// What a run writes in a folder.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Claim {
    /// The whole folder: a render without `--shard` (with or without `--frames`), `video`,
    /// `watch`, `merge`.
    Whole,
    /// Its frames and its part file only; other shards of the same count run beside it.
    Shard(Shard),
}

impl std::fmt::Display for Claim {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Claim::Whole => write!(f, "whole"),
            Claim::Shard(s) => write!(f, "shard {s}"),
        }
    }
}

/// What to do when another run holds what this run needs.
pub enum Wait<'a> {
    /// Refuse at once with [`Error::Busy`].
    No,
    /// Wait for it, after calling this with the [`Error::Busy`] a refusal would have returned
    /// (which names the runs in the way).
    Yes(&'a mut dyn FnMut(&Error)),
}

/// The locks a run holds on its output folder, released when dropped (or when the process
/// ends). Only [`FolderLock::acquire`] makes one, so a function that takes `&FolderLock` runs
/// with the folder to itself (or, for a shard, its part of it).
#[derive(Debug)]
pub struct FolderLock {
    dir: PathBuf,
    claim: Claim,
    folder: File,
    /// The count's and the part's locks of a shard.
    held: Vec<File>,
}

/// A run that holds `campath.lock`, as it recorded itself:
/// `<pid>\t<claim>\t<host>\t<command line>`.
struct Holder {
    line: String,
    pid: u32,
    claim: String,
    host: String,
    command: String,
}

impl Holder {
    fn parse(line: &str) -> Option<Holder> {
        let mut cols = line.splitn(4, '\t');
        Some(Holder {
            line: line.to_string(),
            pid: cols.next()?.parse().ok()?,
            claim: cols.next()?.to_string(),
            host: cols.next()?.to_string(),
            command: cols.next()?.to_string(),
        })
    }
}

/// This machine's name, where the platform tells (Linux), to tell holders on shared storage
/// apart.
fn host() -> String {
    std::fs::read_to_string("/proc/sys/kernel/hostname")
        .map(|h| h.trim().to_string())
        .unwrap_or_default()
}

fn holder_line(claim: Claim) -> String {
    // A command line that is not UTF-8 is named as well as it can be.
    let command: Vec<String> = std::env::args_os()
        .map(|a| a.to_string_lossy().into_owned())
        .collect();
    let (pid, host) = (std::process::id(), host());
    format!("{pid}\t{claim}\t{host}\t{}", command.join(" "))
}

/// The live holders recorded in `campath.lock`, other than this process.
fn holders(dir: &Path) -> Vec<Holder> {
    let text = std::fs::read_to_string(dir.join(FILE_NAME)).unwrap_or_default();
    let (here, proc) = (host(), Path::new("/proc"));
    // Whether the process still runs, where this host can tell (Linux's /proc, for a holder on
    // this host); any other recorded holder counts as running.
    let alive = |h: &Holder| {
        h.host != here || !proc.join("self").exists() || proc.join(h.pid.to_string()).exists()
    };
    let others = text.lines().filter_map(Holder::parse);
    let others = others.filter(|h| !(h.pid == std::process::id() && h.host == here));
    others.filter(alive).collect()
}

/// [`Error::Busy`] naming the live holders that `which` picks (all, if it picks none).
fn busy(dir: &Path, which: impl Fn(&str) -> bool) -> Error {
    let mut shown = holders(dir);
    if shown.iter().any(|h| which(&h.claim)) {
        shown.retain(|h| which(&h.claim));
    }
    Error::Busy {
        dir: dir.to_path_buf(),
        holders: shown
            .iter()
            .map(|h| {
                let mut who = format!("pid {}", h.pid);
                if h.host != host() {
                    who += &format!(" on {}", h.host);
                }
                if h.claim != "whole" {
                    who += &format!(" ({})", h.claim);
                }
                format!("{who}: {}", h.command)
            })
            .collect(),
    }
}

fn open(path: &Path) -> Result<File> {
    OpenOptions::new()
        .read(true)
        .write(true)
        .create(true)
        .truncate(false)
        .open(path)
        .map_err(Error::write(path))
}

/// Takes a shared or exclusive lock on `file`; when another process holds it, refuses or
/// reports and waits, as `wait` says.
fn take(
    file: &File,
    path: &Path,
    shared: bool,
    wait: &mut Wait,
    refusal: impl Fn() -> Error,
) -> Result<()> {
    let try_lock = || {
        if shared {
            file.try_lock_shared()
        } else {
            file.try_lock()
        }
    };
    match try_lock() {
        Ok(()) => Ok(()),
        Err(TryLockError::WouldBlock) => match wait {
            Wait::No => {
                // A lock no other live run records holding is, for a moment, one this process
                // let go of that a child it is starting still holds: between fork and exec a
                // child has a copy of every descriptor (tests on threads of one process, one
                // spawning a program while another takes a folder again). Tried again for a
                // while before refusing.
                for _ in 0..UNRECORDED_TRIES {
                    if !matches!(refusal(), Error::Busy { holders, .. } if holders.is_empty()) {
                        break;
                    }
                    std::thread::sleep(std::time::Duration::from_millis(10));
                    match try_lock() {
                        Ok(()) => return Ok(()),
                        Err(TryLockError::WouldBlock) => {}
                        Err(TryLockError::Error(e)) => return Err(Error::write(path)(e)),
                    }
                }
                Err(refusal())
            }
            Wait::Yes(report) => {
                report(&refusal());
                if shared {
                    file.lock_shared()
                } else {
                    file.lock()
                }
                .map_err(Error::write(path))
            }
        },
        Err(TryLockError::Error(e)) => Err(Error::write(path)(e)),
    }
}

/// Replaces the holders recorded in `file` with the live ones `keep` picks, plus `own`.
fn record(dir: &Path, mut file: &File, keep: bool, own: Option<&str>) -> Result<()> {
    let kept = if keep { holders(dir) } else { Vec::new() };
    let mut lines: Vec<String> = kept.into_iter().map(|h| h.line + "\n").collect();
    lines.extend(own.map(|own| format!("{own}\n")));
    let text = lines.concat();
    file.set_len(0)
        .and_then(|()| file.rewind())
        .and_then(|()| file.write_all(text.as_bytes()))
        .map_err(Error::write(dir.join(FILE_NAME)))
}

impl FolderLock {
    /// Creates `dir` if needed and takes its lock for `claim`:
    ///
    /// - a whole run waits for every other run in the folder;
    /// - a shard K/N waits for whole runs, for shards of other counts and for another run of
    ///   K/N, and runs beside the other shards of N.
    ///
    /// Refuses a `dir` that is a file. The lock files it leaves are named `campath.*.lock`.
    pub fn acquire(dir: &Path, claim: Claim, mut wait: Wait) -> Result<FolderLock> {
        if dir.exists() && !dir.is_dir() {
            return Err(Refusal::NotAFolder(dir.to_path_buf()).into());
        }
        std::fs::create_dir_all(dir).map_err(Error::write(dir))?;
        let path = dir.join(FILE_NAME);
        let folder = open(&path)?;
        let own = holder_line(claim);
        let held = match claim {
            Claim::Whole => {
                take(&folder, &path, false, &mut wait, || busy(dir, |_| true))?;
                record(dir, &folder, false, Some(&own))?;
                remove_shard_locks(dir)?;
                Vec::new()
            }
            Claim::Shard(shard) => {
                take(&folder, &path, true, &mut wait, || {
                    busy(dir, |c| c == "whole")
                })?;
                let count = lock_count(dir, shard.count, &mut wait, &folder, &own)?;
                let (k, n) = (shard.index, shard.count);
                let part_path = dir.join(format!("campath.part-{k}-of-{n}.lock"));
                let part = open(&part_path)?;
                let mine = Claim::Shard(shard).to_string();
                take(&part, &part_path, false, &mut wait, || {
                    busy(dir, |c| c == mine)
                })?;
                vec![count, part]
            }
        };
        Ok(FolderLock {
            dir: dir.to_path_buf(),
            claim,
            folder,
            held,
        })
    }

    /// The folder.
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// Whether the folder still holds the lock file this run locked: false once the folder
    /// was removed or replaced (a new `campath.lock` there is no lock of this run's, and
    /// another run may take it).
    pub fn still_held(&self) -> bool {
        let now = std::fs::metadata(self.dir.join(FILE_NAME));
        now.and_then(|now| Ok(same_file(&now, &self.folder.metadata()?)))
            .unwrap_or(false)
    }

    /// What this run may write.
    pub fn claim(&self) -> Claim {
        self.claim
    }
}

/// Under the gate: waits until no shard of another count runs, then takes this count's lock
/// (shared) and records this run in `campath.lock`.
fn lock_count(dir: &Path, count: u64, wait: &mut Wait, folder: &File, own: &str) -> Result<File> {
    let gate_path = dir.join(GATE);
    let gate = open(&gate_path)?;
    // A starting shard holds the gate for a moment only, unless it waits for another count: so
    // a shard that must not wait still tries for a while (shards of one array job start at
    // once), and refuses only a gate held longer.
    let held_elsewhere = || matches!(gate.try_lock(), Err(TryLockError::WouldBlock));
    for _ in (0..200).take_while(|_| held_elsewhere()) {
        std::thread::sleep(std::time::Duration::from_millis(10));
    }
    take(&gate, &gate_path, false, wait, || {
        busy(dir, |c| c.starts_with("shard"))
    })?;
    for other in std::fs::read_dir(dir).map_err(Error::read(dir))?.flatten() {
        let name = other.file_name().to_string_lossy().into_owned();
        let n = name
            .strip_prefix("campath.shards-of-")
            .and_then(|n| n.strip_suffix(".lock")?.parse::<u64>().ok());
        let Some(n) = n.filter(|&n| n != count) else {
            continue;
        };
        let file = open(&other.path())?;
        let suffix = format!("/{n}");
        take(&file, &other.path(), false, wait, || {
            busy(dir, |c| c.starts_with("shard") && c.ends_with(&suffix))
        })?;
    }
    let count_path = dir.join(format!("campath.shards-of-{count}.lock"));
    let file = open(&count_path)?;
    // Only shards of this count hold it now, and only shared: never blocks.
    file.lock_shared().map_err(Error::write(&count_path))?;
    record(dir, folder, true, Some(own))?;
    Ok(file)
}

/// Whether two files' metadata are of one file (as far as the platform tells).
fn same_file(a: &std::fs::Metadata, b: &std::fs::Metadata) -> bool {
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt;
        (a.dev(), a.ino()) == (b.dev(), b.ino())
    }
    #[cfg(not(unix))]
    {
        a.len() == b.len() && a.modified().ok() == b.modified().ok()
    }
}

/// A whole run, holding the folder exclusively, removes the shard lock files: nobody holds them.
fn remove_shard_locks(dir: &Path) -> Result<()> {
    for e in std::fs::read_dir(dir).map_err(Error::read(dir))?.flatten() {
        let name = e.file_name().to_string_lossy().into_owned();
        if is_lock_file(&name) && name != FILE_NAME {
            remove_if_there(&e.path())?;
        }
    }
    Ok(())
}

impl Drop for FolderLock {
    fn drop(&mut self) {
        // The count's and the part's locks go first: a starting shard may hold the gate while
        // it waits for this count to end.
        self.held.clear();
        let _ = match self.claim {
            Claim::Whole => record(&self.dir, &self.folder, false, None),
            Claim::Shard(_) => match open(&self.dir.join(GATE)) {
                Ok(gate) if gate.try_lock().is_ok() => record(&self.dir, &self.folder, true, None),
                _ => Ok(()),
            },
        };
    }
}
