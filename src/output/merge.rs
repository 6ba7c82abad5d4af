//! The merge of a sharded run's part files into the manifest a single run would have written.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

use super::manifest::{Manifest, PartHeader};
use super::{frame_path, manifest_name, parts_in};
use crate::error::{Error, Result};
use crate::frames::list_frames;
use crate::frames::Shard;

/// Combines the part files in `dir` into the manifest a single run would have written. Refuses,
/// naming what is wrong, unless every shard of one count N is there and complete, all were
/// rendered from the same file and range, every frame of the range is listed exactly once by its
/// own shard, and every listed frame's PNG exists. Returns the manifest and the animation's frame
/// count.
pub(crate) fn merge(dir: &Path) -> Result<(Manifest, u64)> {
    let refuse = |problems: Vec<String>| Error::Merge {
        dir: dir.to_path_buf(),
        problems,
    };
    let parts = parts_in(dir).map_err(Error::read(dir))?;
    let n = shard_count(&parts).map_err(|p| refuse(vec![p]))?;
    let mut problems = Vec::new();
    let mut reference: Option<(String, PartHeader)> = None;
    let mut all = Manifest::default();
    for index in 0..n {
        let shard = Shard { index, count: n };
        let Some(path) = parts.get(&shard) else {
            problems.push(format!(
                "shard {shard} never ran: no {}",
                manifest_name(Some(shard))
            ));
            continue;
        };
        match read_part(shard, dir, path, &mut reference) {
            Ok(part) => {
                // Parts of one sequence share their frame keys, and so their renderer.
                all.renderer = all.renderer.or(part.renderer);
                all.entries.extend(part.entries);
            }
            Err(mut p) => problems.append(&mut p),
        }
    }
    match reference {
        Some((_, header)) if problems.is_empty() => Ok((all, header.frames)),
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
    dir: &Path,
    path: &Path,
    reference: &mut Option<(String, PartHeader)>,
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
        } else if !frame_path(dir, e.frame, header.frames).exists() {
            let png = file_of(&frame_path(dir, e.frame, header.frames));
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
    problems.is_empty().then_some(m).ok_or(problems)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::key::{FrameKey, VERSION};
    use crate::output::manifest::Entry;

    /// Writes part K of 2 over frames 0..4 with the given sequence key and frames.
    fn part(dir: &Path, k: u64, sequence: &str, frames: &[u64], complete: bool) {
        let m = Manifest {
            renderer: Some(VERSION),
            header: Some(PartHeader {
                shard: Shard { index: k, count: 2 },
                range: 0..4,
                frames: 4,
                sequence: sequence.parse().unwrap(),
            }),
            entries: frames
                .iter()
                .map(|f| Entry {
                    frame: *f,
                    hash: "a".repeat(64).parse().unwrap(),
                    key: Some(FrameKey("b".repeat(64).parse().unwrap())),
                })
                .collect(),
            complete,
        };
        std::fs::write(
            dir.join(manifest_name(Some(Shard { index: k, count: 2 }))),
            m.text(),
        )
        .unwrap();
    }

    #[test]
    fn merge_names_every_problem_and_joins_whole_parts() {
        let tmp = tempfile::tempdir().unwrap();
        let dir = tmp.path();
        for f in 0..4 {
            std::fs::write(frame_path(dir, f, 4), "").unwrap();
        }
        let (s1, s2) = ("1".repeat(64), "2".repeat(64));
        part(dir, 0, &s1, &[0, 2], true);
        part(dir, 1, &s1, &[1, 3], true);
        let (merged, frames) = merge(dir).unwrap();
        let text = merged.text();
        assert_eq!(frames, 4);
        assert_eq!(text.lines().count(), 5);
        assert!(text.starts_with(&format!(
            "# campath renderer {VERSION}\n0 {} {}",
            "a".repeat(64),
            "b".repeat(64)
        )));

        // A part from another file, a part with a hole, a missing PNG.
        part(dir, 1, &s2, &[1, 3], true);
        let problems = |r: Result<(Manifest, u64)>| match r {
            Err(Error::Merge { problems, .. }) => problems.join("\n"),
            other => panic!("{other:?}"),
        };
        let p = problems(merge(dir));
        assert!(p.contains("rendered from a different file"), "{p}");
        part(dir, 1, &s1, &[1], true);
        std::fs::remove_file(frame_path(dir, 2, 4)).unwrap();
        let p = problems(merge(dir));
        assert!(
            p.contains("hashes.part-1-of-2.txt: frame(s) 3 are missing"),
            "{p}"
        );
        assert!(
            p.contains("frame 2 is listed but frame_0002.png is missing"),
            "{p}"
        );
        part(dir, 1, &s1, &[1], false);
        let p = problems(merge(dir));
        assert!(
            p.contains(
                "shard 1/2 did not finish: hashes.part-1-of-2.txt lists 1 of its 2 frame(s)"
            ),
            "{p}"
        );
    }
}
