//! The manifests of an output folder and their grammar: `hashes.txt` for a whole run,
//! `hashes.part-K-of-N.txt` for shard K of N, and the merge of the parts.
//!
//! Every frame line is `<frame> <pixel sha256> <frame key>`: the frame index, the SHA-256 of its
//! raw RGB8 pixels (the hash contract) and the [`FrameKey`] of everything that determined them.
//! Golden files written by hand may leave the key out. A part file starts with a header naming
//! the shard, the frame range, the animation's frame count and the sequence key (a hash of every
//! frame's key), and ends with `# complete` once the shard has finished all its frames:
//!
//! ```text
//! # campath part=1/3 range=0..96 frames=96 sequence=<sha256>
//! 1 <sha256> <key>
//! 4 <sha256> <key>
//! # complete
//! ```

use std::collections::BTreeMap;
use std::fmt;
use std::ops::Range;
use std::path::{Path, PathBuf};
use std::str::FromStr;

use crate::error::{Error, Result};
use crate::render::key::FrameKey;

/// Shard K of N: the frames k with k mod N = K (interleaved, so every shard gets a share of the
/// slow and the fast parts of an animation).
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct Shard {
    /// K, 0 ≤ K < N.
    pub index: u64,
    /// N ≥ 1.
    pub count: u64,
}

impl Shard {
    pub fn contains(&self, frame: u64) -> bool {
        frame % self.count == self.index
    }
}

impl fmt::Display for Shard {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}/{}", self.index, self.count)
    }
}

impl FromStr for Shard {
    type Err = String;

    /// `K/N` with 0 ≤ K < N.
    fn from_str(s: &str) -> std::result::Result<Shard, String> {
        let bad = || format!("{s:?}: expected K/N with 0 ≤ K < N, e.g. 0/4");
        let (k, n) = s.split_once('/').ok_or_else(bad)?;
        let (index, count): (u64, u64) = (
            k.trim().parse().map_err(|_| bad())?,
            n.trim().parse().map_err(|_| bad())?,
        );
        if count == 0 || index >= count {
            return Err(bad());
        }
        Ok(Shard { index, count })
    }
}

/// One frame line.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Entry {
    pub frame: u64,
    /// Lower-case hex SHA-256 of the frame's raw RGB8 pixels.
    pub hash: String,
    /// What the pixels were rendered from; absent in hand-written golden files.
    pub key: Option<FrameKey>,
}

impl fmt::Display for Entry {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} {}", self.frame, self.hash)?;
        if let Some(key) = &self.key {
            write!(f, " {key}")?;
        }
        Ok(())
    }
}

/// The header of a part file.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct PartHeader {
    pub shard: Shard,
    /// The run's frame range (`--frames`), shared by every shard of the run.
    pub range: Range<u64>,
    /// The animation's frame count (which fixes the frame files' names).
    pub frames: u64,
    /// SHA-256 of every frame's key in order: equal exactly when the shards rendered the same
    /// file with the same campath.
    pub sequence: String,
}

impl fmt::Display for PartHeader {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "# campath part={} range={}..{} frames={} sequence={}",
            self.shard, self.range.start, self.range.end, self.frames, self.sequence
        )
    }
}

impl PartHeader {
    fn parse(line: &str) -> Option<PartHeader> {
        let rest = line.strip_prefix("# campath ")?;
        let mut fields = BTreeMap::new();
        for field in rest.split_whitespace() {
            let (name, value) = field.split_once('=')?;
            fields.insert(name, value);
        }
        let (a, b) = fields.get("range")?.split_once("..")?;
        Some(PartHeader {
            shard: fields.get("part")?.parse().ok()?,
            range: a.parse().ok()?..b.parse().ok()?,
            frames: fields.get("frames")?.parse().ok()?,
            sequence: is_hex64(fields.get("sequence")?)?.to_string(),
        })
    }
}

const COMPLETE: &str = "# complete";

/// A parsed manifest.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Manifest {
    /// Present in part files only.
    pub header: Option<PartHeader>,
    pub entries: Vec<Entry>,
    /// A part file whose shard finished all its frames.
    pub complete: bool,
}

fn is_hex64(s: &str) -> Option<&str> {
    (s.len() == 64 && s.bytes().all(|b| b.is_ascii_hexdigit())).then_some(s)
}

fn parse_entry(line: &str) -> std::result::Result<Entry, &'static str> {
    let mut parts = line.split_whitespace();
    let frame = parts
        .next()
        .and_then(|f| f.parse::<u64>().ok())
        .ok_or("bad frame index")?;
    let hash = parts.next().and_then(is_hex64).ok_or("bad hash")?;
    let key = match parts.next() {
        None => None,
        Some(k) => Some(FrameKey(is_hex64(k).ok_or("bad key")?.to_ascii_lowercase())),
    };
    if parts.next().is_some() {
        return Err("extra text");
    }
    Ok(Entry {
        frame,
        hash: hash.to_ascii_lowercase(),
        key,
    })
}

impl Manifest {
    /// Parses a manifest strictly: every line must be a frame line, the part header (first), or
    /// `# complete` (last); blank lines are skipped.
    pub fn parse(path: &Path, text: &str) -> Result<Manifest> {
        let mut m = Manifest::default();
        for (i, line) in text.lines().enumerate() {
            let line = line.trim();
            let bad = |what: &str| Error::Manifest {
                path: path.to_path_buf(),
                message: format!(
                    "line {}: {what}: expected `<frame> <sha256 hex> [<key>]`, got {line:?}",
                    i + 1
                ),
            };
            if line.is_empty() {
                continue;
            }
            if m.complete {
                return Err(bad("text after `# complete`"));
            }
            if line == COMPLETE {
                m.complete = true;
            } else if line.starts_with('#') {
                if i > 0 || m.header.is_some() {
                    return Err(bad("a header that is not on the first line"));
                }
                m.header = Some(PartHeader::parse(line).ok_or_else(|| bad("bad part header"))?);
            } else {
                m.entries.push(parse_entry(line).map_err(bad)?);
            }
        }
        Ok(m)
    }

    /// Reads a manifest that a killed run may have left: a missing file is empty, and lines that
    /// do not parse (a torn last line) are dropped.
    pub fn read_lenient(path: &Path) -> Manifest {
        let text = std::fs::read_to_string(path).unwrap_or_default();
        let mut m = Manifest::default();
        for (i, line) in text.lines().enumerate() {
            let line = line.trim();
            if line == COMPLETE {
                m.complete = true;
            } else if i == 0 && line.starts_with('#') {
                m.header = PartHeader::parse(line);
            } else if let Ok(e) = parse_entry(line) {
                m.entries.push(e);
            }
        }
        m
    }

    /// The file's text: header, frame lines sorted by frame, and `# complete` if complete.
    pub fn text(&self) -> String {
        let mut entries: Vec<&Entry> = self.entries.iter().collect();
        entries.sort_by_key(|e| e.frame);
        let mut text = String::new();
        if let Some(h) = &self.header {
            text += &format!("{h}\n");
        }
        for e in entries {
            text += &format!("{e}\n");
        }
        if self.complete {
            text += COMPLETE;
            text.push('\n');
        }
        text
    }
}

/// Parses a hashes.txt (or a golden file) into `(frame, hash)` pairs.
pub fn parse_hashes(path: &Path, text: &str) -> Result<Vec<(u64, String)>> {
    Ok(Manifest::parse(path, text)?
        .entries
        .into_iter()
        .map(|e| (e.frame, e.hash))
        .collect())
}

/// The manifest of a run: `hashes.txt`, or `hashes.part-K-of-N.txt` for a shard.
pub fn file_name(shard: Option<Shard>) -> String {
    match shard {
        None => "hashes.txt".into(),
        Some(s) => format!("hashes.part-{}-of-{}.txt", s.index, s.count),
    }
}

/// The shard whose part file has this name.
pub fn part_of(name: &str) -> Option<Shard> {
    let (k, n) = name
        .strip_prefix("hashes.part-")?
        .strip_suffix(".txt")?
        .split_once("-of-")?;
    let digits = |s: &str| !s.is_empty() && s.bytes().all(|b| b.is_ascii_digit());
    if !digits(k) || !digits(n) {
        return None;
    }
    format!("{k}/{n}").parse().ok()
}

/// The part files in `dir`, by shard.
pub fn parts_in(dir: &Path) -> Result<BTreeMap<Shard, PathBuf>> {
    let entries = std::fs::read_dir(dir).map_err(Error::read(dir.to_path_buf()))?;
    Ok(entries
        .flatten()
        .filter_map(|e| Some((part_of(e.file_name().to_str()?)?, e.path())))
        .collect())
}

/// Combines the part files in `dir` into the text of the hashes.txt a single run would have
/// written. Refuses, naming what is wrong, unless every shard of one count N is there and
/// complete, all were rendered from the same file and range, every frame of the range is listed
/// exactly once by its own shard, and every listed frame's PNG exists. `frame_file` names a
/// frame's PNG for an animation of `frames` frames.
pub fn merge(dir: &Path, frame_file: impl Fn(u64, u64) -> PathBuf) -> Result<String> {
    let parts = parts_in(dir)?;
    let refuse = |problems: Vec<String>| Error::Merge {
        dir: dir.to_path_buf(),
        problems,
    };
    let name = |p: &Path| {
        p.file_name()
            .unwrap_or_default()
            .to_string_lossy()
            .into_owned()
    };
    let mut by_count: BTreeMap<u64, Vec<String>> = BTreeMap::new();
    for (shard, path) in &parts {
        by_count.entry(shard.count).or_default().push(name(path));
    }
    let Some(&n) = by_count.keys().next() else {
        return Err(refuse(vec![
            "holds no hashes.part-K-of-N.txt to merge".into()
        ]));
    };
    if by_count.len() > 1 {
        let groups = by_count
            .iter()
            .map(|(n, files)| format!("N = {n}: {}", files.join(", ")))
            .collect::<Vec<_>>();
        return Err(refuse(vec![format!(
            "holds parts of {} different shard counts ({}); remove the parts of the run you do not want",
            by_count.len(),
            groups.join("; ")
        )]));
    }
    let mut problems = Vec::new();
    let mut reference: Option<(String, PartHeader)> = None;
    let mut all = Manifest::default();
    for index in 0..n {
        let shard = Shard { index, count: n };
        let Some(path) = parts.get(&shard) else {
            problems.push(format!(
                "shard {shard} never ran: no {}",
                file_name(Some(shard))
            ));
            continue;
        };
        let m = Manifest::read_lenient(path);
        let file = name(path);
        let Some(header) = m.header.clone() else {
            problems.push(format!(
                "{file} has no part header (written by an older campath?): run shard {shard} again"
            ));
            continue;
        };
        if header.shard != shard {
            problems.push(format!("{file} names shard {} in its header", header.shard));
            continue;
        }
        if !m.complete {
            problems.push(format!(
                "shard {shard} did not finish: {file} lists {} of its {} frame(s); run it again",
                m.entries.len(),
                header.range.clone().filter(|k| shard.contains(*k)).count()
            ));
            continue;
        }
        match &reference {
            Some((first, h))
                if (&h.range, h.frames, &h.sequence)
                    != (&header.range, header.frames, &header.sequence) =>
            {
                problems.push(format!(
                    "{file} was rendered from a different file, campath or frame range than {first} \
                     (range {}..{} of {} frames against {}..{} of {}): render the stale shard again",
                    header.range.start, header.range.end, header.frames, h.range.start, h.range.end, h.frames
                ));
                continue;
            }
            Some(_) => {}
            None => reference = Some((file.clone(), header.clone())),
        }
        let mut listed = BTreeMap::new();
        for e in &m.entries {
            if e.key.is_none() || !header.range.contains(&e.frame) || !shard.contains(e.frame) {
                problems.push(format!("{file}: frame {} does not belong here", e.frame));
            } else if listed.insert(e.frame, ()).is_some() {
                problems.push(format!("{file}: frame {} is listed twice", e.frame));
            } else if !frame_file(e.frame, header.frames).exists() {
                problems.push(format!(
                    "{file}: frame {} is listed but {} is missing",
                    e.frame,
                    name(&frame_file(e.frame, header.frames))
                ));
            }
        }
        let missing: Vec<u64> = header
            .range
            .clone()
            .filter(|k| shard.contains(*k) && !listed.contains_key(k))
            .collect();
        if !missing.is_empty() {
            problems.push(format!(
                "{file}: frame(s) {} are missing",
                list_frames(&missing)
            ));
        }
        all.entries.extend(m.entries);
    }
    if problems.is_empty() {
        Ok(all.text())
    } else {
        Err(refuse(problems))
    }
}

/// `1, 4, 7` for a few frames, `1, 4, 7, … (40 in all)` for many.
pub fn list_frames(frames: &[u64]) -> String {
    const SHOWN: usize = 8;
    let shown: Vec<String> = frames.iter().take(SHOWN).map(u64::to_string).collect();
    if frames.len() > SHOWN {
        format!("{}, … ({} in all)", shown.join(", "), frames.len())
    } else {
        shown.join(", ")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frame_lines_round_trip_and_junk_is_refused() {
        let h = "ab".repeat(32);
        let k = "cd".repeat(32);
        let text = format!("0 {h}\n\n12 {h} {k}\n");
        let m = Manifest::parse(Path::new("g"), &text).unwrap();
        assert_eq!(m.entries.len(), 2);
        assert_eq!(m.entries[0].key, None);
        assert_eq!(m.entries[1].key, Some(FrameKey(k.clone())));
        assert_eq!(m.text(), format!("0 {h}\n12 {h} {k}\n"));
        for junk in [
            "x abc",
            "1 abc",
            &format!("1 {h} {h} x"),
            &format!("1 {h} zz"),
        ] {
            assert!(Manifest::parse(Path::new("g"), junk).is_err(), "{junk}");
        }
    }

    #[test]
    fn part_headers_and_completion_round_trip() {
        let header = PartHeader {
            shard: Shard { index: 1, count: 3 },
            range: 2..40,
            frames: 96,
            sequence: "0f".repeat(32),
        };
        let m = Manifest {
            header: Some(header),
            entries: vec![],
            complete: true,
        };
        let text = m.text();
        assert!(text.starts_with("# campath part=1/3 range=2..40 frames=96 sequence=0f0f"));
        assert!(text.ends_with("# complete\n"));
        assert_eq!(Manifest::parse(Path::new("p"), &text).unwrap(), m);
        assert_eq!(
            Manifest::read_lenient(Path::new("/nonexistent")),
            Manifest::default()
        );
    }

    #[test]
    fn shard_names_parse_only_when_well_formed() {
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
        assert!("3/2".parse::<Shard>().is_err());
        assert!("0/0".parse::<Shard>().is_err());
        assert_eq!("1/4".parse::<Shard>(), Ok(Shard { index: 1, count: 4 }));
    }
}
