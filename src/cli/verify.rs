//! `campath verify`: fresh renders against golden hashes, for people and for CI. A JUnit report
//! with one test case per frame; the differing frames saved; and, when the golden side is a
//! folder of frames, a difference image per failing frame with its changed-pixel count and
//! largest level difference.

use std::collections::BTreeMap;
use std::io::Write;
use std::path::{Path, PathBuf};

use super::args::Shot;
use super::error::{CliError, Result};
use super::failures;
use super::junit;
use crate::document::Document;
use crate::frames::{compare_each, list_first, list_frames, Difference};
use crate::golden::Golden;
use crate::key::VERSION;
use crate::output::{frame_path, pad_width, write_png, Compression, HASHES};
use crate::testing::pictures::{difference, pixels_of as golden_pixels, PixelDiff};
use crate::testing::{golden_dir, shell_word, Options, Update};
use crate::Error;

/// The options of `campath verify`.
#[derive(clap::Args)]
pub struct VerifyArgs {
    #[command(flatten)]
    pub shot: Shot,
    /// A hashes.txt, or a folder of golden frames with their hashes.txt (then each failing
    /// frame gets a difference image in --save-failures).
    pub golden: PathBuf,
    /// Also write a JUnit XML report, one test case per frame (for CI).
    #[arg(long, value_name = "PATH")]
    pub junit: Option<PathBuf>,
    /// Save the frames that differ here as PNGs (and, against a folder of golden frames,
    /// frame_NNNN.diff.png: changed pixels in magenta over the dimmed golden frame).
    #[arg(long, value_name = "DIR")]
    pub save_failures: Option<PathBuf>,
    /// When GOLDEN is the shot's own (NAME.golden beside NAME.ron) and frames differ, write
    /// the pending golden NAME.golden.new for `campath review` (the default, as
    /// CAMPATH_UPDATE=new; under CI the default is --no-pending).
    #[arg(long, conflicts_with = "no_pending")]
    pub pending: bool,
    /// Write no pending golden.
    #[arg(long)]
    pub no_pending: bool,
}

/// The folders a command must not write into: a golden folder, or the folder of a golden
/// `hashes.txt` (which may hold golden frames too).
pub fn golden_folders(golden: &Golden) -> Vec<PathBuf> {
    let mut folders = vec![golden.path.clone()];
    match &golden.dir {
        Some(dir) => folders.push(dir.clone()),
        None if golden.path.file_name().is_some_and(|n| n == HASHES) => {
            folders.extend(golden.path.parent().map(Path::to_path_buf));
        }
        None => {}
    }
    folders
}

pub fn verify(a: VerifyArgs, out: &mut dyn Write) -> Result<bool> {
    let doc = Document::load(&a.shot.file)?;
    let golden = Golden::load(&a.golden)?;
    // Every refusal comes before anything is written or removed.
    let goldens = golden_folders(&golden);
    // The folder of failure pictures is this run's until it ends.
    let _claimed = failures::claim(
        a.junit.as_deref(),
        a.save_failures.as_deref(),
        "--save-failures",
        &goldens,
        crate::output::is_failure_picture,
    )?;
    let total = doc.animation.frames;
    let size = (doc.raster.width, doc.raster.height);
    let golden_frames = golden.frames();
    let mut pixel_diffs = BTreeMap::new();
    let differ = compare_each(&doc, &golden.pairs(), |d, pixels| {
        // The golden frame is read before anything is written.
        let diff = golden_frames
            .get(&d.frame)
            .and_then(|path| golden_pixels(path, size))
            .map(|golden| difference(&golden, pixels));
        if let Some((_, p)) = &diff {
            pixel_diffs.insert(d.frame, *p);
        }
        let Some(dir) = &a.save_failures else {
            return Ok(());
        };
        let path = frame_path(dir, d.frame, total);
        write_png(&path, pixels, size, Compression::Fast)?;
        if let Some((image, _)) = diff {
            let name = format!("frame_{:0w$}.diff.png", d.frame, w = pad_width(total));
            write_png(&dir.join(name), &image, size, Compression::Fast)?;
        }
        Ok(())
    })?;
    for d in &differ {
        let line = line(d, pixel_diffs.get(&d.frame), &a.golden, total);
        writeln!(out, "{line}").map_err(Error::stdout)?;
    }
    let (listed, file) = (golden.hashes.len(), a.golden.display());
    let summary = if differ.is_empty() {
        format!("{listed} frame(s) match {file}")
    } else {
        let frames: Vec<u64> = differ.iter().map(|d| d.frame).collect();
        let (n, shown) = (differ.len(), list_frames(&frames));
        format!("{n} of {listed} frame(s) differ from {file}: {shown}")
    };
    writeln!(out, "{summary}").map_err(Error::stdout)?;
    if let Some(note) = unchecked(&golden, total) {
        writeln!(out, "{note}").map_err(Error::stdout)?;
    }
    if let (Some(r), false) = (golden.other_renderer(), differ.is_empty()) {
        writeln!(out, "{}", renderer_note(&golden.path, r)).map_err(Error::stdout)?;
    }
    if let Some(path) = &a.junit {
        let mut suite = junit::Suite::new(&a.shot.file.display().to_string());
        for (frame, hash) in &golden.hashes {
            let failure = differ.iter().find(|d| d.frame == *frame).map(|d| {
                let got = d
                    .actual
                    .map_or_else(|| "no such frame".to_string(), |h| h.to_string());
                let pixels = pixels_changed(pixel_diffs.get(frame));
                format!("expected {hash}, got {got}{pixels}")
            });
            suite.case(&format!("frame {frame}"), failure);
        }
        junit::write(path, "campath verify", &[suite])?;
    }
    let own = crate::output::resolved(&golden_dir(&a.shot.file));
    let pending = match (a.pending, a.no_pending) {
        (true, _) => true,
        (_, true) => false,
        _ => Update::from_env().map_err(CliError::Usage)?.0 == Update::New,
    };
    if pending && !differ.is_empty() && goldens.iter().any(|g| crate::output::resolved(g) == own) {
        let options = Options {
            update: Update::New,
            ..Options::default()
        };
        let run = crate::testing::run_shot(&a.shot.file, options, |_, _| Ok(()))?;
        if let Some(p) = &run.pending {
            let folder = a.shot.file.parent().filter(|p| !p.as_os_str().is_empty());
            let folder = shell_word(&folder.unwrap_or(Path::new(".")).display().to_string());
            let line = format!(
                "pending golden: {}; look, then accept or reject: `campath review {folder}`",
                p.display()
            );
            writeln!(out, "{line}").map_err(Error::stdout)?;
        }
    }
    Ok(differ.is_empty())
}

/// Why a golden from another renderer may differ, and what to do, for `verify`'s report.
fn renderer_note(golden: &Path, renderer: u32) -> String {
    if renderer < VERSION {
        format!(
            "note: {} was made by campath renderer {renderer}, and this campath is renderer \
             {VERSION}: its pictures changed, not necessarily the shot. If the new frames are \
             right, approve them: `campath review` after a check writes the pending golden, or \
             `campath test --update` in the shot's folder.",
            golden.display()
        )
    } else {
        format!(
            "note: {} was made by campath renderer {renderer}, newer than this campath's \
             renderer {VERSION}: update campath.",
            golden.display()
        )
    }
}

/// The frames of the animation that the golden does not list, which verify does not check (a
/// golden of a few frames is allowed; a golden cut short, such as an unfinished render's folder,
/// should not pass unnoticed).
fn unchecked(golden: &Golden, total: u64) -> Option<String> {
    let listed = golden.hashes.range(..total).count() as u64;
    let missing = total - listed;
    if missing == 0 {
        return None;
    }
    let unlisted = (0..total).filter(|f| !golden.hashes.contains_key(f));
    let shown = list_first(unlisted, missing);
    Some(format!(
        "not checked: {missing} of the animation's {total} frame(s) are not in the golden: {shown}"
    ))
}

/// What a differing frame's pixels changed, after its hashes: empty without a golden picture.
fn pixels_changed(p: Option<&PixelDiff>) -> String {
    p.map_or_else(String::new, |p| format!(": {p}"))
}

fn line(d: &Difference, diff: Option<&PixelDiff>, golden: &Path, total: u64) -> String {
    // The golden hash (verify compares only the frames its golden lists).
    let expected = d.expected.map_or_else(|| "none".into(), |h| h.to_string());
    let (frame, golden, pixels) = (d.frame, golden.display(), pixels_changed(diff));
    match &d.actual {
        None => format!("frame {frame}: in {golden} but the animation has only {total} frames"),
        Some(got) => format!("frame {frame}: expected {expected}, got {got}{pixels}"),
    }
}
