//! Golden hashes: what a frame-hash test compares fresh renders with.
//!
//! A golden is a `hashes.txt` (the manifest grammar), either alone or in a
//! folder beside the golden frames it lists (`frame_NNNN.png`). Campath writes it with a first
//! line naming its renderer version, so a golden made by a campath whose pictures differ is
//! reported as such rather than as a broken shot.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use crate::error::{Error, Result};
use crate::hash::FrameHash;
use crate::key::VERSION;
pub use crate::output::manifest::parse_hashes;
use crate::output::manifest::{Entry, Manifest};
use crate::output::{frames_in, write_atomic, HASHES};

/// A golden: frame hashes, where they came from, and the folder of golden frames if any.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Golden {
    /// The hashes file.
    pub path: PathBuf,
    /// The folder holding `hashes.txt`, when the golden was given as a folder.
    pub dir: Option<PathBuf>,
    /// The renderer version named in the file's first line; None for files without it.
    pub renderer: Option<u32>,
    /// Lower-case hex SHA-256 of each listed frame's RGB8 pixels, by frame.
    pub hashes: BTreeMap<u64, FrameHash>,
}

impl Golden {
    /// Reads a golden: a folder holding `hashes.txt`, or a hashes file itself. A golden that
    /// lists a frame twice with different hashes, or lists no frame, is refused.
    pub fn load(path: &Path) -> Result<Golden> {
        let (file, dir) = if path.is_dir() {
            (path.join(HASHES), Some(path.to_path_buf()))
        } else {
            (path.to_path_buf(), None)
        };
        let bad = |message: String| Error::Manifest {
            path: file.clone(),
            message,
        };
        let bytes = std::fs::read(&file).map_err(Error::read(&file))?;
        let text = String::from_utf8(bytes).map_err(|e| {
            let at = e.utf8_error().valid_up_to();
            let line = e.as_bytes()[..at].iter().filter(|&&b| b == b'\n').count() + 1;
            bad(format!("line {line}: not UTF-8 text"))
        })?;
        let m = Manifest::parse(&file, &text)?;
        let mut hashes = BTreeMap::new();
        for e in m.entries {
            if hashes.insert(e.frame, e.hash).is_some_and(|h| h != e.hash) {
                return Err(bad(format!(
                    "frame {} is listed twice with different hashes",
                    e.frame
                )));
            }
        }
        if hashes.is_empty() {
            return Err(bad("lists no frames".into()));
        }
        Ok(Golden {
            path: file,
            dir,
            renderer: m.renderer,
            hashes,
        })
    }

    /// [`Golden::load`] of a golden folder, or None when it holds no `hashes.txt`.
    pub fn find(dir: &Path) -> Result<Option<Golden>> {
        dir.join(HASHES)
            .exists()
            .then(|| Golden::load(dir))
            .transpose()
    }

    /// The golden hash of `frame`, if the golden lists it.
    pub fn hash(&self, frame: u64) -> Option<FrameHash> {
        self.hashes.get(&frame).copied()
    }

    /// `(frame, hash)` pairs in frame order, as [`crate::frames::compare`] takes them.
    pub fn pairs(&self) -> Vec<(u64, FrameHash)> {
        self.hashes.iter().map(|(f, h)| (*f, *h)).collect()
    }

    /// Whether the golden was made by another renderer version than this campath's: its pixels
    /// may differ for that reason alone. Goldens that name no renderer are taken as current.
    pub fn other_renderer(&self) -> Option<u32> {
        self.renderer.filter(|r| *r != VERSION)
    }

    /// The golden frames beside the hashes, by frame (empty for a hashes file alone).
    pub fn frames(&self) -> BTreeMap<u64, PathBuf> {
        self.dir.as_deref().map(frames_in).unwrap_or_default()
    }
}

/// The text of a golden `hashes.txt` for these `(frame, hash)` pairs, naming this campath's
/// renderer. Frame keys are left out: a golden changes only when pixels change.
pub fn text(hashes: &[(u64, FrameHash)]) -> String {
    Manifest::new(
        None,
        hashes
            .iter()
            .map(|(frame, hash)| Entry {
                frame: *frame,
                hash: *hash,
                key: None,
            })
            .collect(),
    )
    .text()
}

/// Writes a golden `hashes.txt` (through a temporary file and a rename) for these pairs.
pub fn write(path: &Path, hashes: &[(u64, FrameHash)]) -> Result<()> {
    write_atomic(path, text(hashes))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_golden_loads_from_its_folder_or_file_and_names_its_renderer() {
        let tmp = tempfile::tempdir().unwrap();
        let (a, b): (FrameHash, FrameHash) = (
            "a".repeat(64).parse().unwrap(),
            "b".repeat(64).parse().unwrap(),
        );
        write(&tmp.path().join(HASHES), &[(2, b), (0, a)]).unwrap();
        let text = std::fs::read_to_string(tmp.path().join(HASHES)).unwrap();
        assert_eq!(
            text,
            format!("# campath renderer {VERSION}\n0 {a}\n2 {b}\n")
        );
        std::fs::write(tmp.path().join("frame_0002.png"), "").unwrap();
        let g = Golden::load(tmp.path()).unwrap();
        assert_eq!(g.renderer, Some(VERSION));
        assert_eq!(g.other_renderer(), None);
        assert_eq!(g.hash(2), Some(b));
        assert_eq!(g.hash(1), None);
        assert_eq!(g.frames().keys().copied().collect::<Vec<_>>(), [2]);
        let file = Golden::load(&tmp.path().join(HASHES)).unwrap();
        assert_eq!((file.dir, file.hashes), (None, g.hashes));

        std::fs::write(
            tmp.path().join(HASHES),
            format!("# campath renderer 99\n0 {a}\n"),
        )
        .unwrap();
        assert_eq!(Golden::load(tmp.path()).unwrap().other_renderer(), Some(99));
        std::fs::write(tmp.path().join(HASHES), format!("0 {a}\n0 {b}\n")).unwrap();
        assert!(Golden::load(tmp.path()).is_err());
        std::fs::write(tmp.path().join(HASHES), "\n").unwrap();
        assert!(Golden::load(tmp.path()).is_err());
    }
}
