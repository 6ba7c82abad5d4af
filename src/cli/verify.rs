//! `campath verify`: fresh renders against golden hashes, for people and for CI. A JUnit report
//! with one test case per frame; the differing frames saved; and, when the golden side is a
//! folder of frames, a difference image per failing frame with its changed-pixel count and
//! largest level difference.

use std::fmt::Write as _;
use std::io::Write;
use std::path::{Path, PathBuf};

use super::error::Result;
use campath::document::Document;
use campath::frames::{compare_each, Difference};
use campath::manifest::{list_frames, parse_hashes};
use campath::output::{frame_path, write_png, Compression};
use campath::Error;

/// Marks a changed pixel in a difference image; unchanged pixels are the golden frame at a
/// third of its brightness, so they never take this colour.
pub const CHANGED: [u8; 3] = [255, 0, 255];

/// The options of `campath verify`.
pub struct VerifyArgs {
    pub file: PathBuf,
    /// A hashes.txt, or a folder holding one beside its frames.
    pub golden: PathBuf,
    pub junit: Option<PathBuf>,
    pub save_failures: Option<PathBuf>,
}

/// How a differing frame differs from its golden picture.
struct PixelDiff {
    changed: u64,
    largest: u8,
}

pub fn verify(a: VerifyArgs, out: &mut dyn Write) -> Result<bool> {
    let doc = Document::load(&a.file)?;
    let (hashes, frames_dir) = if a.golden.is_dir() {
        (a.golden.join("hashes.txt"), Some(a.golden.clone()))
    } else {
        (a.golden.clone(), None)
    };
    let text = std::fs::read_to_string(&hashes).map_err(Error::read(&hashes))?;
    let expected = parse_hashes(&hashes, &text)?;
    if expected.is_empty() {
        return Err(Error::Manifest {
            path: hashes,
            message: "lists no frames".into(),
        }
        .into());
    }
    if let Some(dir) = &a.save_failures {
        std::fs::create_dir_all(dir).map_err(Error::write(dir))?;
    }
    let total = doc.animation.frames;
    let size = (doc.raster.width, doc.raster.height);
    let mut pixel_diffs = std::collections::BTreeMap::new();
    let differ = compare_each(&doc, &expected, |d, pixels| {
        let Some(dir) = &a.save_failures else {
            return Ok(());
        };
        write_png(
            &frame_path(dir, d.frame, total),
            pixels,
            size,
            Compression::Fast,
        )?;
        let Some(golden_dir) = &frames_dir else {
            return Ok(());
        };
        let golden = frame_path(golden_dir, d.frame, total);
        let Ok(img) = image::open(&golden) else {
            return Ok(()); // no golden picture to compare with: the hash line says enough
        };
        let golden = img.to_rgb8().into_raw();
        if golden.len() == pixels.len() {
            let (image, diff) = difference(&golden, pixels);
            let name = format!(
                "frame_{:0w$}.diff.png",
                d.frame,
                w = campath::output::pad_width(total)
            );
            write_png(&dir.join(name), &image, size, Compression::Fast)?;
            pixel_diffs.insert(d.frame, diff);
        }
        Ok(())
    })?;
    for d in &differ {
        writeln!(
            out,
            "{}",
            line(d, pixel_diffs.get(&d.frame), &a.golden, total)
        )
        .map_err(Error::stdout)?;
    }
    let summary = if differ.is_empty() {
        format!("{} frame(s) match {}", expected.len(), a.golden.display())
    } else {
        let frames: Vec<u64> = differ.iter().map(|d| d.frame).collect();
        format!(
            "{} of {} frame(s) differ from {}: {}",
            differ.len(),
            expected.len(),
            a.golden.display(),
            list_frames(&frames)
        )
    };
    writeln!(out, "{summary}").map_err(Error::stdout)?;
    if let Some(path) = &a.junit {
        let xml = junit(&a.file, &expected, &differ, &pixel_diffs);
        campath::output::write_atomic(path, &xml)?;
    }
    Ok(differ.is_empty())
}

fn line(d: &Difference, diff: Option<&PixelDiff>, golden: &Path, total: u64) -> String {
    match (&d.actual, diff) {
        (None, _) => format!(
            "frame {}: in {} but the animation has only {total} frames",
            d.frame,
            golden.display()
        ),
        (Some(got), None) => format!("frame {}: expected {}, got {got}", d.frame, d.expected),
        (Some(got), Some(p)) => format!(
            "frame {}: expected {}, got {got}: {} pixel(s) changed, largest difference {} level(s)",
            d.frame, d.expected, p.changed, p.largest
        ),
    }
}

/// The difference image (changed pixels in [`CHANGED`] over the golden frame dimmed to a third)
/// and the changed-pixel count and largest per-channel difference.
fn difference(golden: &[u8], actual: &[u8]) -> (Vec<u8>, PixelDiff) {
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

/// A JUnit XML report: one test suite for the file, one test case per golden frame.
fn junit(
    file: &Path,
    expected: &[(u64, String)],
    differ: &[Difference],
    pixel_diffs: &std::collections::BTreeMap<u64, PixelDiff>,
) -> String {
    let suite = escape(&file.display().to_string());
    let mut xml = String::from("<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n");
    let _ = writeln!(
        xml,
        "<testsuites name=\"campath verify\" tests=\"{}\" failures=\"{}\">",
        expected.len(),
        differ.len()
    );
    let _ = writeln!(
        xml,
        "  <testsuite name=\"{suite}\" tests=\"{}\" failures=\"{}\" errors=\"0\" skipped=\"0\">",
        expected.len(),
        differ.len()
    );
    for (frame, hash) in expected {
        let _ = write!(
            xml,
            "    <testcase classname=\"{suite}\" name=\"frame {frame}\""
        );
        match differ.iter().find(|d| d.frame == *frame) {
            None => xml += "/>\n",
            Some(d) => {
                let got = d.actual.as_deref().unwrap_or("no such frame");
                let mut message = format!("expected {hash}, got {got}");
                if let Some(p) = pixel_diffs.get(frame) {
                    let _ = write!(
                        message,
                        ": {} pixel(s) changed, largest difference {} level(s)",
                        p.changed, p.largest
                    );
                }
                let message = escape(&message);
                let _ = writeln!(
                    xml,
                    ">\n      <failure message=\"{message}\" type=\"hash mismatch\">{message}</failure>\n    </testcase>"
                );
            }
        }
    }
    xml += "  </testsuite>\n</testsuites>\n";
    xml
}

/// Escapes text for an XML attribute or element.
fn escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
        .replace('\'', "&apos;")
}
