//! The manifests of an output folder and their grammar: `hashes.txt` for a whole run,
//! `hashes.part-K-of-N.txt` for shard K of N, and the merge of the parts.
//!
//! Every manifest campath writes starts with a line naming the renderer version that made its
//! pixels ([`VERSION`]), so a golden from another campath says so instead of only failing;
//! files without it (older campaths, hand-written goldens) are read as before.
//!
//! Every frame line is `<frame> <pixel sha256> <frame key>`: the frame index, the SHA-256 of its
//! raw RGB8 pixels (the hash contract) and the [`FrameKey`] of everything that determined them.
//! Golden files written by hand may leave the key out. A part file has a header after the renderer
//! line naming the shard, the frame range, the animation's frame count and the sequence key (a
//! hash of every frame's key), and ends with `# complete` once the shard has finished all its
//! frames:
//!
//! ```text
//! # campath renderer 1
//! # campath part=1/3 range=0..96 frames=96 sequence=<sha256>
//! 1 <sha256> <key>
//! 4 <sha256> <key>
//! # complete
//! ```

use std::collections::{BTreeMap, BTreeSet};
use std::fmt;
use std::ops::Range;
use std::path::{Path, PathBuf};
use std::str::FromStr;

use crate::document::MAX_FRAMES;
use crate::error::{Error, Result};
use crate::hash::FrameHash;
use crate::render::key::{FrameKey, VERSION};

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
    /// Whether frame `frame` is this shard's.
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
    /// The frame index.
    pub frame: u64,
    /// Lower-case hex SHA-256 of the frame's raw RGB8 pixels.
    pub hash: FrameHash,
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
    /// Which shard wrote the part.
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

const RENDERER: &str = "# campath renderer ";

/// The renderer version a `# campath renderer N` line names.
fn parse_renderer(line: &str) -> Option<u32> {
    let n = line.strip_prefix(RENDERER)?.trim();
    if n.is_empty() || !n.bytes().all(|b| b.is_ascii_digit()) {
        return None;
    }
    n.parse().ok()
}

/// A parsed manifest.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Manifest {
    /// The renderer version that made the frames ([`VERSION`] when this campath wrote it); None
    /// in files without the line (older campaths, hand-written goldens).
    pub renderer: Option<u32>,
    /// Present in part files only.
    pub header: Option<PartHeader>,
    /// The frame lines, in the file's order.
    pub entries: Vec<Entry>,
    /// A part file whose shard finished all its frames.
    pub complete: bool,
}

fn is_hex64(s: &str) -> Option<&str> {
    (s.len() == 64 && s.bytes().all(|b| b.is_ascii_hexdigit())).then_some(s)
}

/// Whether the file at `path` begins as every manifest campath writes does, with `# campath`
/// (after an editor's byte order mark): someone's `hashes.txt` of checksums does not. Only its
/// first bytes are read.
pub fn begins_as_campaths(path: &Path) -> bool {
    let mut head = [0u8; 12];
    std::fs::File::open(path)
        .and_then(|mut f| std::io::Read::read(&mut f, &mut head))
        .is_ok_and(|n| {
            let head = &head[..n];
            let head = head.strip_prefix("\u{feff}".as_bytes()).unwrap_or(head);
            head.starts_with(b"# campath")
        })
}

/// Whether the manifest at `path` begins as a golden campath wrote: its renderer line, then a
/// frame without a key (an output folder's frames have keys). Only its first lines are read.
pub fn written_as_golden(path: &Path) -> bool {
    use std::io::{BufRead, BufReader};
    let Ok(file) = std::fs::File::open(path) else {
        return false;
    };
    // An editor's byte order mark goes before anything else is read, as in `Manifest::parse`:
    // a mark on a line of its own leaves a blank line.
    let mut lines = BufReader::new(file)
        .split(b'\n')
        .map_while(std::result::Result::ok)
        .enumerate()
        .map(|(i, l)| match (i, l.strip_prefix("\u{feff}".as_bytes())) {
            (0, Some(rest)) => rest.to_vec(),
            _ => l,
        })
        .filter(|l| !l.trim_ascii().is_empty())
        .take(2)
        .map(|l| String::from_utf8(l).unwrap_or_default());
    let renderer = lines
        .next()
        .is_some_and(|l| parse_renderer(l.trim()).is_some());
    let keyless = lines
        .next()
        .is_some_and(|l| parse_entry(l.trim()).is_ok_and(|e| e.key.is_none()));
    renderer && keyless
}

// The message of a frame index out of range names the bound.
const _: () = assert!(MAX_FRAMES == 10_000_000);

fn parse_entry(line: &str) -> std::result::Result<Entry, &'static str> {
    let mut parts = line.split_whitespace();
    let frame = parts
        .next()
        .and_then(|f| f.parse::<u64>().ok())
        .ok_or("bad frame index")?;
    if frame >= MAX_FRAMES {
        return Err("a frame index of 10000000 or more (a file has at most 10000000 frames)");
    }
    let hash: FrameHash = parts
        .next()
        .and_then(|h| h.parse().ok())
        .ok_or("bad hash")?;
    let key = match parts.next() {
        None => None,
        Some(k) => Some(FrameKey(is_hex64(k).ok_or("bad key")?.to_ascii_lowercase())),
    };
    if parts.next().is_some() {
        return Err("extra text");
    }
    Ok(Entry { frame, hash, key })
}

impl Manifest {
    /// A new manifest of frames rendered by this campath: it names [`VERSION`].
    pub fn new(header: Option<PartHeader>, entries: Vec<Entry>) -> Manifest {
        Manifest {
            renderer: Some(VERSION),
            header,
            entries,
            complete: false,
        }
    }

    /// Parses a manifest strictly: every line must be a frame line, the renderer line (first),
    /// the part header (first after it), or `# complete` (last); blank lines are skipped, and so
    /// is a byte order mark before the first line (an editor's).
    pub fn parse(path: &Path, text: &str) -> Result<Manifest> {
        let mut m = Manifest::default();
        // Lines before the first frame line, the renderer line and the part header among them.
        let mut leading = true;
        let text = text.strip_prefix('\u{feff}').unwrap_or(text);
        for (i, line) in text.lines().enumerate() {
            let line = line.trim();
            let bad = |what: &str| Error::Manifest {
                path: path.to_path_buf(),
                message: format!("line {}: {what}, got {line:?}", i + 1),
            };
            let bad_frame =
                |what: &str| bad(&format!("{what}: expected `<frame> <sha256 hex> [<key>]`"));
            if line.is_empty() {
                continue;
            }
            if m.complete {
                return Err(bad("text after `# complete`, which ends a part file"));
            }
            if line == COMPLETE {
                m.complete = true;
            } else if line.starts_with(RENDERER) {
                if !leading || m.renderer.is_some() || m.header.is_some() {
                    return Err(bad("a renderer line that is not the first line"));
                }
                m.renderer =
                    Some(parse_renderer(line).ok_or_else(|| {
                        bad("bad renderer line: expected `# campath renderer N`")
                    })?);
            } else if line.starts_with("# campath part=") {
                if !leading || m.header.is_some() {
                    return Err(bad("a part header that is not at the top"));
                }
                m.header = Some(PartHeader::parse(line).ok_or_else(|| {
                    bad("bad part header: expected `# campath part=K/N range=A..B frames=F sequence=<sha256 hex>`")
                })?);
            } else if line.starts_with('#') {
                return Err(bad(
                    "a `#` line campath does not know (a manifest holds no comments; remove it: \
                     campath's `#` lines are `# campath renderer N`, a shard's `# campath \
                     part=K/N …` header and `# complete`)",
                ));
            } else {
                leading = false;
                m.entries.push(parse_entry(line).map_err(bad_frame)?);
            }
        }
        Ok(m)
    }

    /// Reads a manifest that a killed run may have left: a missing file is empty, and lines that
    /// do not parse (a torn last line) are dropped.
    pub fn read_lenient(path: &Path) -> Manifest {
        let text = std::fs::read_to_string(path).unwrap_or_default();
        let mut m = Manifest::default();
        for line in text.trim_start_matches('\u{feff}').lines() {
            let line = line.trim();
            if line == COMPLETE {
                m.complete = true;
            } else if line.starts_with(RENDERER) {
                m.renderer = m.renderer.or(parse_renderer(line));
            } else if line.starts_with('#') {
                m.header = m.header.take().or_else(|| PartHeader::parse(line));
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
        if let Some(r) = self.renderer {
            text += &format!("{RENDERER}{r}\n");
        }
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
pub fn parse_hashes(path: &Path, text: &str) -> Result<Vec<(u64, FrameHash)>> {
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

/// Where a shard moves a whole run's `hashes.txt`: it would be stale once the shard renders, but
/// its records (checked against each frame's key and PNG) let later shards keep their frames.
/// `merge` and a whole run remove it.
pub const BEFORE_SHARDS: &str = "hashes.before-shards.txt";

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
/// frame's PNG for an animation of `frames` frames. Returns the text and the animation's frame
/// count.
pub fn merge(dir: &Path, frame_file: impl Fn(u64, u64) -> PathBuf) -> Result<(String, u64)> {
    let refuse = |problems: Vec<String>| Error::Merge {
        dir: dir.to_path_buf(),
        problems,
    };
    let parts = parts_in(dir)?;
    let n = shard_count(&parts).map_err(|p| refuse(vec![p]))?;
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
        match read_part(shard, path, &mut reference, &frame_file) {
            Ok(part) => {
                // Parts of one sequence share their frame keys, and so their renderer.
                all.renderer = all.renderer.or(part.renderer);
                all.entries.extend(part.entries);
            }
            Err(mut p) => problems.append(&mut p),
        }
    }
    match reference {
        Some((_, header)) if problems.is_empty() => Ok((all.text(), header.frames)),
        _ => Err(refuse(problems)),
    }
}

fn file_of(path: &Path) -> String {
    path.file_name()
        .unwrap_or_default()
        .to_string_lossy()
        .into_owned()
}

/// The one shard count N of the parts, or why there is none.
fn shard_count(parts: &BTreeMap<Shard, PathBuf>) -> std::result::Result<u64, String> {
    let mut by_count: BTreeMap<u64, Vec<String>> = BTreeMap::new();
    for (shard, path) in parts {
        by_count.entry(shard.count).or_default().push(file_of(path));
    }
    match by_count.len() {
        0 => Err("holds no hashes.part-K-of-N.txt to merge".into()),
        1 => Ok(*by_count.keys().next().expect("one count")),
        k => {
            let groups: Vec<String> = by_count
                .iter()
                .map(|(n, files)| format!("N = {n}: {}", files.join(", ")))
                .collect();
            Err(format!(
                "holds parts of {k} different shard counts ({}); remove the parts of the run you do not want",
                groups.join("; ")
            ))
        }
    }
}

/// Shard `shard`'s part file, checked: its header (against the first part's, `reference`), its
/// completion, and its frames. Returns the part, or every problem found.
fn read_part(
    shard: Shard,
    path: &Path,
    reference: &mut Option<(String, PartHeader)>,
    frame_file: impl Fn(u64, u64) -> PathBuf,
) -> std::result::Result<Manifest, Vec<String>> {
    let m = Manifest::read_lenient(path);
    let file = file_of(path);
    let Some(header) = m.header.clone() else {
        return Err(vec![format!(
            "{file} has no part header (written by an older campath?): run shard {shard} again"
        )]);
    };
    if header.shard != shard {
        return Err(vec![format!(
            "{file} names shard {} in its header",
            header.shard
        )]);
    }
    let expected = || header.range.clone().filter(|k| shard.contains(*k));
    if !m.complete {
        return Err(vec![format!(
            "shard {shard} did not finish: {file} lists {} of its {} frame(s); run it again",
            m.entries.len(),
            expected().count()
        )]);
    }
    match reference {
        Some((first, h))
            if (&h.range, h.frames, &h.sequence)
                != (&header.range, header.frames, &header.sequence) =>
        {
            return Err(vec![format!(
                "{file} was rendered from a different file, campath or frame range than {first} \
                 (range {}..{} of {} frames against {}..{} of {}): render the stale shard again",
                header.range.start,
                header.range.end,
                header.frames,
                h.range.start,
                h.range.end,
                h.frames
            )]);
        }
        Some(_) => {}
        None => *reference = Some((file.clone(), header.clone())),
    }
    let mut problems = Vec::new();
    let mut listed = BTreeSet::new();
    for e in &m.entries {
        if e.key.is_none() || !header.range.contains(&e.frame) || !shard.contains(e.frame) {
            problems.push(format!("{file}: frame {} does not belong here", e.frame));
        } else if !listed.insert(e.frame) {
            problems.push(format!("{file}: frame {} is listed twice", e.frame));
        } else if !frame_file(e.frame, header.frames).exists() {
            let png = file_of(&frame_file(e.frame, header.frames));
            problems.push(format!(
                "{file}: frame {} is listed but {png} is missing",
                e.frame
            ));
        }
    }
    let missing: Vec<u64> = expected().filter(|k| !listed.contains(k)).collect();
    if !missing.is_empty() {
        problems.push(format!(
            "{file}: frame(s) {} are missing",
            list_frames(&missing)
        ));
    }
    if problems.is_empty() {
        Ok(m)
    } else {
        Err(problems)
    }
}

/// `1, 4, 7` for a few frames, `1, 4, 7, … (40 in all)` for many.
pub fn list_frames(frames: &[u64]) -> String {
    list_first(frames.iter().copied(), frames.len() as u64)
}

/// [`list_frames`] of `count` frames, which `frames` yields (only the first are taken).
pub fn list_first(frames: impl Iterator<Item = u64>, count: u64) -> String {
    const SHOWN: usize = 8;
    let shown: Vec<String> = frames.take(SHOWN).map(|f| f.to_string()).collect();
    if count > SHOWN as u64 {
        format!("{}, … ({count} in all)", shown.join(", "))
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
    fn an_editors_byte_order_mark_is_read_past_and_comments_are_named() {
        let h = "ab".repeat(32);
        let text = format!("\u{feff}# campath renderer 7\r\n3 {h}\r\n");
        let m = Manifest::parse(Path::new("g"), &text).unwrap();
        assert_eq!((m.renderer, m.entries.len()), (Some(7), 1));
        let dir = tempfile::tempdir().unwrap();
        let golden = dir.path().join("hashes.txt");
        std::fs::write(&golden, &text).unwrap();
        assert!(written_as_golden(&golden));
        // The mark on a line of its own, as a golden: what parses as one is guarded as one.
        let alone = format!("\u{feff}\r\n# campath renderer 7\r\n3 {h}\r\n");
        std::fs::write(&golden, &alone).unwrap();
        assert!(written_as_golden(&golden));
        assert_eq!(Manifest::parse(Path::new("g"), &alone).unwrap(), m);
        std::fs::write(&golden, &text).unwrap();
        assert_eq!(Manifest::read_lenient(&golden), m);
        for (text, line) in [
            (format!("# made by hand\n3 {h}\n"), 1),
            (format!("3 {h}\n# a note\n"), 2),
        ] {
            let e = Manifest::parse(Path::new("g"), &text)
                .unwrap_err()
                .to_string();
            assert!(
                e.contains(&format!(
                    "line {line}: a `#` line campath does not know (a manifest holds no comments; remove it"
                )),
                "{e}"
            );
        }
        let e = Manifest::parse(Path::new("g"), &format!("\u{feff}x {h}\n")).unwrap_err();
        assert!(
            e.to_string().contains(
                "line 1: bad frame index: expected `<frame> <sha256 hex> [<key>]`, got \"x"
            ),
            "{e}"
        );
    }

    #[test]
    fn the_renderer_line_is_read_kept_and_optional() {
        let h = "ab".repeat(32);
        let m = Manifest::parse(Path::new("g"), &format!("# campath renderer 7\n3 {h}\n")).unwrap();
        assert_eq!(m.renderer, Some(7));
        assert_eq!(m.text(), format!("# campath renderer 7\n3 {h}\n"));
        let old = Manifest::parse(Path::new("g"), &format!("3 {h}\n")).unwrap();
        assert_eq!(old.renderer, None);
        for bad in [
            format!("3 {h}\n# campath renderer 1\n"),
            "# campath renderer x\n".to_string(),
            "# campath renderer 1\n# campath renderer 1\n".to_string(),
        ] {
            assert!(Manifest::parse(Path::new("g"), &bad).is_err(), "{bad}");
        }
        assert_eq!(Manifest::new(None, vec![]).renderer, Some(VERSION));
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
            complete: true,
            ..Manifest::new(Some(header), vec![])
        };
        let text = m.text();
        assert!(text.starts_with(&format!(
            "# campath renderer {VERSION}\n# campath part=1/3 range=2..40 frames=96 sequence=0f0f"
        )));
        assert!(text.ends_with("# complete\n"));
        assert_eq!(Manifest::parse(Path::new("p"), &text).unwrap(), m);
        assert_eq!(
            Manifest::read_lenient(Path::new("/nonexistent")),
            Manifest::default()
        );
    }

    /// Writes part K of 2 over frames 0..4 with the given sequence key and frames.
    fn part(dir: &Path, k: u64, sequence: &str, frames: &[u64], complete: bool) {
        let m = Manifest {
            renderer: Some(VERSION),
            header: Some(PartHeader {
                shard: Shard { index: k, count: 2 },
                range: 0..4,
                frames: 4,
                sequence: sequence.into(),
            }),
            entries: frames
                .iter()
                .map(|f| Entry {
                    frame: *f,
                    hash: "a".repeat(64).parse().unwrap(),
                    key: Some(FrameKey("b".repeat(64))),
                })
                .collect(),
            complete,
        };
        std::fs::write(
            dir.join(file_name(Some(Shard { index: k, count: 2 }))),
            m.text(),
        )
        .unwrap();
    }

    #[test]
    fn merge_names_every_problem_and_joins_whole_parts() {
        let tmp = tempfile::tempdir().unwrap();
        let dir = tmp.path();
        let png = |f: u64, _| dir.join(format!("f{f}.png"));
        for f in 0..4 {
            std::fs::write(png(f, 4), "").unwrap();
        }
        let (s1, s2) = ("1".repeat(64), "2".repeat(64));
        part(dir, 0, &s1, &[0, 2], true);
        part(dir, 1, &s1, &[1, 3], true);
        let (text, frames) = merge(dir, png).unwrap();
        assert_eq!(frames, 4);
        assert_eq!(text.lines().count(), 5);
        assert!(text.starts_with(&format!(
            "# campath renderer {VERSION}\n0 {} {}",
            "a".repeat(64),
            "b".repeat(64)
        )));

        // A part from another file, a part with a hole, a missing PNG.
        part(dir, 1, &s2, &[1, 3], true);
        let problems = |r: Result<(String, u64)>| match r {
            Err(Error::Merge { problems, .. }) => problems.join("\n"),
            other => panic!("{other:?}"),
        };
        let p = problems(merge(dir, png));
        assert!(p.contains("rendered from a different file"), "{p}");
        part(dir, 1, &s1, &[1], true);
        std::fs::remove_file(png(2, 4)).unwrap();
        let p = problems(merge(dir, png));
        assert!(
            p.contains("hashes.part-1-of-2.txt: frame(s) 3 are missing"),
            "{p}"
        );
        assert!(p.contains("frame 2 is listed but f2.png is missing"), "{p}");
        part(dir, 1, &s1, &[1], false);
        let p = problems(merge(dir, png));
        assert!(
            p.contains(
                "shard 1/2 did not finish: hashes.part-1-of-2.txt lists 1 of its 2 frame(s)"
            ),
            "{p}"
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
