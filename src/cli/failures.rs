//! The folders where `verify --save-failures` and `test --review` put pictures of failures.
//!
//! Such a folder is claimed before anything renders: it is refused (exit 2, nothing written)
//! when it is a golden folder or lies inside one, or holds anything its command does not write;
//! then the command's own files from an earlier run are removed, so what is left after the run
//! is this run's failures only.

use std::path::{Path, PathBuf};

use super::error::{CliError, Result};
use campath::output::{frame_of, resolved};
use campath::Error;

/// Whether `path` is `dir` or lies inside it.
pub fn within(path: &Path, dir: &Path) -> bool {
    resolved(path).starts_with(resolved(dir))
}

/// Refuses a `--junit` report at `report` that is, or lies inside, the folder `dir` claimed
/// by `option`: the folder is the run's pictures only, and a report there would be refused as
/// another's file by the next run.
pub fn report_apart(report: &Path, dir: &Path, option: &str) -> Result<()> {
    if !within(report, dir) {
        return Ok(());
    }
    Err(CliError::Usage(format!(
        "--junit {} is in the {option} folder {}; nothing was written (choose a report path \
         outside it)",
        report.display(),
        dir.display()
    )))
}

/// Refuses `path` (given as `option`) when it is or lies inside one of `goldens`.
pub fn outside_goldens(path: &Path, option: &str, goldens: &[PathBuf]) -> Result<()> {
    let Some(g) = goldens.iter().find(|g| within(path, g)) else {
        return Ok(());
    };
    let what = if resolved(path) == resolved(g) {
        "is"
    } else {
        "lies inside"
    };
    Err(CliError::Usage(format!(
        "{option} {} {what} the golden {}; nothing was written (choose a path outside it, so \
         the golden stays as it is)",
        path.display(),
        g.display()
    )))
}

/// The mark campath leaves in a folder it claims: only a folder that has it is emptied, so a
/// folder of frames someone keeps is never taken for failure pictures of an earlier run.
pub const MARK: &str = ".campath-failures";

/// Claims `dir` for a command's failure pictures: refuses it when it is or lies inside one of
/// `goldens`, is a file, holds anything whose name `ours` does not accept, or holds anything
/// at all without campath's [`MARK`]; otherwise creates it, removes what an earlier run left
/// there, and marks it.
pub fn claim(
    dir: &Path,
    option: &str,
    goldens: &[PathBuf],
    ours: impl Fn(&str) -> bool,
) -> Result<()> {
    outside_goldens(dir, option, goldens)?;
    if dir.exists() && !dir.is_dir() {
        return Err(CliError::Usage(format!(
            "{option} {} is a file, not a folder",
            dir.display()
        )));
    }
    let entries: Vec<_> = match std::fs::read_dir(dir) {
        Ok(entries) => entries.flatten().collect(),
        Err(_) => Vec::new(),
    };
    let name = |e: &std::fs::DirEntry| e.file_name().to_string_lossy().into_owned();
    let marked = entries.iter().any(|e| name(e) == MARK);
    let foreign: Vec<String> = entries
        .iter()
        .filter(|e| {
            let n = name(e);
            let file = e.file_type().is_ok_and(|t| t.is_file());
            !(file && (n == MARK || (marked && ours(&n))))
        })
        .map(name)
        .collect();
    if !foreign.is_empty() {
        let shown: Vec<&str> = foreign.iter().take(3).map(String::as_str).collect();
        return Err(CliError::Usage(format!(
            "{option} {} holds files campath did not write there ({}{}); nothing was written \
             (choose an empty or new folder: campath marks the folders it writes with {MARK})",
            dir.display(),
            shown.join(", "),
            if foreign.len() > 3 { ", …" } else { "" }
        )));
    }
    std::fs::create_dir_all(dir).map_err(Error::write(dir))?;
    for e in entries.iter().filter(|e| name(e) != MARK) {
        let path = e.path();
        std::fs::remove_file(&path).map_err(Error::write(&path))?;
    }
    let mark = dir.join(MARK);
    std::fs::write(
        &mark,
        "campath writes its failure pictures here, and empties this folder on every run.\n",
    )
    .map_err(Error::write(&mark))?;
    Ok(())
}

/// The files `verify --save-failures` writes: `frame_NNNN.png` and `frame_NNNN.diff.png`.
pub fn is_failure_file(name: &str) -> bool {
    let name = name.strip_suffix(".tmp").unwrap_or(name);
    frame_of(name).is_some()
        || name
            .strip_suffix(".diff.png")
            .is_some_and(|stem| frame_of(&format!("{stem}.png")).is_some())
}

/// How a differing frame differs from its golden picture.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct PixelDiff {
    pub changed: u64,
    pub largest: u8,
}

/// Marks a changed pixel in a difference image; unchanged pixels are the golden frame at a
/// third of its brightness, so they never take this colour.
pub const CHANGED: [u8; 3] = [255, 0, 255];

/// The difference image (changed pixels in [`CHANGED`] over the golden frame dimmed to a third)
/// and the changed-pixel count and largest per-channel difference.
pub fn difference(golden: &[u8], actual: &[u8]) -> (Vec<u8>, PixelDiff) {
    let mut image = Vec::with_capacity(golden.len());
    let mut diff = PixelDiff {
        changed: 0,
        largest: 0,
    };
    for (g, a) in golden.chunks_exact(3).zip(actual.chunks_exact(3)) {
        if g == a {
            image.extend(g.iter().map(|c| c / 3));
        } else {
            diff.changed += 1;
            for (x, y) in g.iter().zip(a) {
                diff.largest = diff.largest.max(x.abs_diff(*y));
            }
            image.extend(CHANGED);
        }
    }
    (image, diff)
}

/// A golden frame's RGB8 pixels, when it exists, decodes, and has `size`.
pub fn golden_pixels(path: &Path, size: (u32, u32)) -> Option<Vec<u8>> {
    let img = image::open(path).ok()?.to_rgb8();
    (img.dimensions() == size).then(|| img.into_raw())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn failure_files_and_containment() {
        for ok in [
            "frame_0001.png",
            "frame_0001.diff.png",
            "frame_12345.png.tmp",
        ] {
            assert!(is_failure_file(ok), "{ok}");
        }
        for no in [
            "hashes.txt",
            "frame_.diff.png",
            "x.diff.png",
            "frame_1.diffpng",
        ] {
            assert!(!is_failure_file(no), "{no}");
        }
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
    fn difference_counts_pixels_not_channels() {
        let golden = [10, 20, 30, 40, 50, 60];
        let actual = [10, 20, 30, 41, 50, 66];
        let (image, d) = difference(&golden, &actual);
        assert_eq!(
            d,
            PixelDiff {
                changed: 1,
                largest: 6
            }
        );
        assert_eq!(image, [3, 6, 10, 255, 0, 255]);
    }
}
