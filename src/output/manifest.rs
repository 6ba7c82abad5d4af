//! The grammar of the manifests of an output folder (`hashes.txt` for a whole run,
//! `hashes.part-K-of-N.txt` for shard K of N) and of goldens, and the writer of a run's manifest.
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

use std::collections::BTreeMap;
use std::fmt;
use std::fs::File;
use std::io::{Read, Write};
use std::ops::Range;
use std::path::{Path, PathBuf};

use super::{digits, write_atomic};
use crate::document::MAX_FRAMES;
use crate::error::{Error, Result};
use crate::frames::Shard;
use crate::hash::FrameHash;
use crate::key::{FrameKey, VERSION};

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
    pub sequence: FrameHash,
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
            sequence: fields.get("sequence")?.parse().ok()?,
        })
    }
}

const COMPLETE: &str = "# complete";

const RENDERER: &str = "# campath renderer ";

/// The renderer version a `# campath renderer N` line names.
fn parse_renderer(line: &str) -> Option<u32> {
    digits(line.strip_prefix(RENDERER)?.trim())
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

/// The text after an editor's byte order mark, if it begins with one: every reader of a manifest
/// reads past it here.
fn without_bom(text: &str) -> &str {
    text.strip_prefix('\u{feff}').unwrap_or(text)
}

/// The first `n` lines of the file at `path` that are not blank, trimmed, past a byte order
/// mark; only its first 4 KiB are read (someone's large file is not read whole to tell).
fn head(path: &Path, n: usize) -> Vec<String> {
    let mut bytes = Vec::new();
    let read = File::open(path).and_then(|f| f.take(4096).read_to_end(&mut bytes));
    let text = String::from_utf8_lossy(&bytes[..read.unwrap_or(0)]);
    without_bom(&text)
        .lines()
        .map(str::trim)
        .filter(|l| !l.is_empty())
        .take(n)
        .map(str::to_string)
        .collect()
}

/// Whether the file at `path` begins as every manifest campath writes does, with `# campath`:
/// someone's `hashes.txt` of checksums does not.
pub(crate) fn begins_as_campaths(path: &Path) -> bool {
    head(path, 1)
        .first()
        .is_some_and(|l| l.starts_with("# campath"))
}

/// Whether the manifest at `path` begins as a golden campath wrote: its renderer line, then a
/// frame without a key (an output folder's frames have keys).
pub(crate) fn begins_as_golden(path: &Path) -> bool {
    match &head(path, 2)[..] {
        [renderer, frame] => {
            parse_renderer(renderer).is_some() && parse_entry(frame).is_ok_and(|e| e.key.is_none())
        }
        _ => false,
    }
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
    let key = parts.next().map(|k| k.parse().map(FrameKey));
    let key = key.transpose().map_err(|_| "bad key")?;
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
        for (i, line) in without_bom(text).lines().enumerate() {
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
                if !m.entries.is_empty() || m.renderer.is_some() || m.header.is_some() {
                    return Err(bad("a renderer line that is not the first line"));
                }
                m.renderer =
                    Some(parse_renderer(line).ok_or_else(|| {
                        bad("bad renderer line: expected `# campath renderer N`")
                    })?);
            } else if line.starts_with("# campath part=") {
                if !m.entries.is_empty() || m.header.is_some() {
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
        for line in without_bom(&text).lines() {
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
        let renderer = self.renderer.map(|r| format!("{RENDERER}{r}"));
        let header = self.header.as_ref().map(PartHeader::to_string);
        let frames = entries.iter().map(|e| e.to_string());
        let complete = self.complete.then(|| COMPLETE.to_string());
        let head = renderer.into_iter().chain(header);
        let lines = head.chain(frames).chain(complete);
        lines.map(|l| l + "\n").collect()
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

/// Writes a run's manifest so that it lists only complete frames, whenever the run stops:
/// first whole, with the frames the run keeps; then a line per frame, appended once its PNG has
/// its name; at last whole again, sorted (a shard's marked complete).
pub(crate) struct Writer {
    path: PathBuf,
    file: File,
    manifest: Manifest,
    entries: BTreeMap<u64, Entry>,
}

impl Writer {
    /// Writes `manifest` at `path` (through a temporary file) and opens it to append to.
    pub(crate) fn create(path: PathBuf, mut manifest: Manifest) -> Result<Writer> {
        write_atomic(&path, manifest.text())?;
        let file = File::options()
            .append(true)
            .open(&path)
            .map_err(Error::write(&path))?;
        // The frame lines are kept once, by frame, until `finish` writes them back.
        let entries = std::mem::take(&mut manifest.entries)
            .into_iter()
            .map(|e| (e.frame, e))
            .collect();
        Ok(Writer {
            path,
            file,
            manifest,
            entries,
        })
    }

    /// Appends a frame's line: the whole line in one write, so a run killed meanwhile leaves no
    /// torn line (`writeln!` would write it piece by piece).
    pub(crate) fn append(&mut self, entry: Entry) -> Result<()> {
        self.file
            .write_all(format!("{entry}\n").as_bytes())
            .map_err(Error::write(&self.path))?;
        self.entries.insert(entry.frame, entry);
        Ok(())
    }

    /// Writes the manifest whole again, sorted, marked `# complete` if `complete`; returns it.
    pub(crate) fn finish(mut self, complete: bool) -> Result<Manifest> {
        self.manifest.entries = self.entries.into_values().collect();
        self.manifest.complete = complete;
        write_atomic(&self.path, self.manifest.text())?;
        Ok(self.manifest)
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
        assert_eq!(m.entries[1].key, Some(FrameKey(k.parse().unwrap())));
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
        assert!(begins_as_golden(&golden));
        // The mark on a line of its own, as a golden: what parses as one is guarded as one.
        let alone = format!("\u{feff}\r\n# campath renderer 7\r\n3 {h}\r\n");
        std::fs::write(&golden, &alone).unwrap();
        assert!(begins_as_golden(&golden));
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
            sequence: "0f".repeat(32).parse().unwrap(),
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
}
