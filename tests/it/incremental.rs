//! Incremental re-render: after an edit, `render` without `--force` gives exactly the folder a
//! fresh render of the edited file gives, and rewrites only the frames the edit touched.

use std::path::Path;

use crate::common::{frame_stamps, root, EXAMPLES};
use campath::document::Document;
use campath::frames::FrameSet;
use campath::internals::Wait;
use campath::internals::{lock, render, RenderOptions, RenderSummary};

/// An example at 32×18, and with 4 time samples where it has motion blur, so that every frame
/// of every example renders quickly (what is kept and rewritten depends on the cameras and the
/// scene, not on the size; 4 time samples still span the shutter).
fn small_example(name: &str) -> String {
    let text = std::fs::read_to_string(root().join(format!("animations/{name}.ron"))).unwrap();
    assert!(text.contains("width: 640, height: 360"), "{name}");
    let small = text.replace("width: 640, height: 360", "width: 32, height: 18");
    if !small.contains("motion_blur") {
        return small;
    }
    let fewer = small.replace(
        "motion_blur: (shutter: 0.5, samples: 16)",
        "motion_blur: (shutter: 0.5, samples: 4)",
    );
    assert_ne!(fewer, small, "{name}");
    fewer
}

fn load(text: &str) -> Document {
    Document::from_str(Path::new("edit.ron"), text).unwrap_or_else(|e| panic!("{e}"))
}

fn render_into(text: &str, dir: &Path) -> RenderSummary {
    let doc = load(text);
    let set = FrameSet::all(0..doc.animation().frames);
    let lock = lock(&doc, dir, &set, Wait::No).unwrap();
    render(&doc, &lock, &set, RenderOptions::default(), &mut |_| {}).unwrap()
}

/// Replaces the first number after byte `at` with `f(number)`.
fn edit_number(text: &str, at: usize, f: impl Fn(f64) -> f64) -> String {
    let start = at
        + text[at..]
            .find(|c: char| c == '-' || c.is_ascii_digit())
            .unwrap();
    let len = text[start..]
        .find(|c: char| !(c == '-' || c == '.' || c.is_ascii_digit()))
        .unwrap();
    let x: f64 = text[start..start + len].parse().unwrap();
    format!("{}{:?}{}", &text[..start], f(x), &text[start + len..])
}

/// The three edits: the last key of the last track, the last sphere's red, the sample count.
fn edits(text: &str) -> Vec<(&'static str, String)> {
    let last_key = edit_number(text, text.rfind("value:").unwrap(), |x| x - 0.25);
    let colour = edit_number(&last_key, last_key.rfind("color: (").unwrap(), |r| {
        if r > 0.5 {
            r - 0.3
        } else {
            r + 0.3
        }
    });
    assert!(colour.contains("samples: 2"));
    let samples = colour.replace("samples: 2", "samples: 1");
    vec![
        ("the last key", last_key),
        ("a sphere's colour", colour),
        ("the sample count", samples),
    ]
}

#[test]
fn every_edit_rerenders_exactly_the_frames_it_touched() {
    let tmp = tempfile::tempdir().unwrap();
    for name in EXAMPLES {
        let dir = tmp.path().join(name);
        let mut text = small_example(name);
        render_into(&text, &dir);
        for (what, edited) in edits(&text) {
            let before = frame_stamps(&dir);
            let summary = render_into(&edited, &dir);
            let fresh = tmp.path().join(format!("{name}-fresh"));
            render_into(&edited, &fresh);
            let read = |d: &Path| std::fs::read_to_string(d.join("hashes.txt")).unwrap();
            assert_eq!(read(&dir), read(&fresh), "{name}, {what}: hashes.txt");
            std::fs::remove_dir_all(&fresh).unwrap();

            // Which frames the edit touched, decided from the cameras alone: a frame is the same
            // when its camera (and with motion blur every time sample's) is bit-for-bit the
            // same and the scene, raster and motion blur did not change.
            let (old, new) = (load(&text), load(&edited));
            let same_world = old.scene() == new.scene()
                && old.raster() == new.raster()
                && old.motion_blur() == new.motion_blur();
            let cameras = |d: &Document| d.exposures().map(|c| c.unwrap().1).collect::<Vec<_>>();
            let untouched: Vec<bool> = cameras(&old)
                .iter()
                .zip(cameras(&new))
                .map(|(a, b)| same_world && *a == b)
                .collect();
            let after = frame_stamps(&dir);
            assert_eq!(before.len(), after.len(), "{name}, {what}");
            for (k, (file, stamp)) in after.iter().enumerate() {
                assert_eq!(
                    before[file] == *stamp,
                    untouched[k],
                    "{name}, {what}: {file} rewritten = {}",
                    before[file] != *stamp
                );
            }
            let kept = untouched.iter().filter(|u| **u).count() as u64;
            assert_eq!(summary.kept, kept, "{name}, {what}");
            assert_eq!(summary.reasons.changed, untouched.len() as u64 - kept);
            if what == "the last key" && !["flythrough", "motion_blur"].contains(&name) {
                // Moving the last key leaves the first segment of these paths alone (the
                // motion blur example's one segment moves frame 0's later time samples).
                assert!(untouched[0], "{name}: frame 0 was rendered again");
            }
            text = edited;
        }
    }
}

#[test]
fn another_file_rendered_into_the_same_folder_replaces_every_frame() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("shot");
    // 72 frames, then 96 (flythrough), then 72 again: frames past the end are removed.
    for name in ["zoom", "flythrough", "observer"] {
        let text = small_example(name);
        let summary = render_into(&text, &dir);
        let fresh = tmp.path().join("fresh");
        render_into(&text, &fresh);
        let read = |d: &Path| std::fs::read_to_string(d.join("hashes.txt")).unwrap();
        assert_eq!(read(&dir), read(&fresh), "{name}");
        let frames = load(&text).animation().frames;
        assert_eq!(summary.kept, 0, "{name}");
        assert_eq!(frame_stamps(&dir).len() as u64, frames, "{name}");
        std::fs::remove_dir_all(&fresh).unwrap();
    }
}

/// A render of an edited file removes the pictures of the frames it renders again before it
/// writes any: when its first frame is written, every frame file in the folder is a frame it
/// kept or that one, so a run stopped there leaves no old picture under a frame's name.
#[test]
fn an_edited_file_leaves_no_old_picture_while_it_renders() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("out");
    let text = small_example("flythrough");
    render_into(&text, &dir);
    for (what, edited) in edits(&text) {
        let before = frame_stamps(&dir);
        let doc = load(&edited);
        let set = FrameSet::all(0..doc.animation().frames);
        let lock = lock(&doc, &dir, &set, Wait::No).unwrap();
        let mut seen = None;
        let summary = render(&doc, &lock, &set, RenderOptions::default(), &mut |e| {
            if let (campath::internals::Event::Written(frame), None) = (e, &seen) {
                seen = Some((frame, frame_stamps(&dir)));
            }
        })
        .unwrap();
        let (first, on_disk) = seen.expect("a frame was rendered");
        let first = format!("frame_{first:04}.png");
        // The kept frames are the files unchanged since the first render.
        let kept: Vec<&String> = on_disk
            .iter()
            .filter(|(name, stamp)| before.get(*name) == Some(stamp))
            .map(|(name, _)| name)
            .collect();
        assert_eq!(kept.len() as u64, summary.kept, "{what}");
        for name in on_disk.keys() {
            assert!(
                kept.contains(&name) || *name == first,
                "{what}: {name} is on disk while {first} is written"
            );
        }
        drop(lock);
        render_into(&text, &dir);
    }
}
