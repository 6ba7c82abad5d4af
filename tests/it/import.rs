//! `campath import` against campath's own exports: every example and 50 generated shots (with
//! roll, distort, zoom and eased paths) go out with `path` as CSV, JSON, USD or GLB (the formats
//! that keep the whole camera; GLB has no lens shift, so shots with Distort go out as USD), come
//! back as keys with `import`, and go out again; every frame's camera reprojects within the
//! tolerance of the original's (`fit::error`: the original's picture at its corners, edges and centre, at 1,
//! 4 and 16 units and at infinity, projected by the imported camera).

use std::path::Path;

use campath::document::Document;
use campath::import::fit::{self, Options};
use campath::import::Sample;
use campath::internals::SplitMix;

use crate::common::{campath, root, stderr, stdout, EXAMPLES};

/// The worst reprojection error over `original`'s frames of the shot `back` imported from it,
/// pixels of `back`'s image.
fn worst_error(original: &Document, back: &Document) -> (f64, u64) {
    let options = Options {
        tolerance: fit::TOLERANCE,
        size: (back.raster().width, back.raster().height),
        fps: back.animation().fps,
        near: 1.0,
    };
    assert_eq!(back.animation().frames, original.animation().frames);
    let pairs = original.cameras().zip(back.cameras());
    let mut worst = (0.0, 0);
    for (a, b) in pairs {
        let ((frame, a), (_, b)) = (a.unwrap(), b.unwrap());
        let e = fit::error(
            &Sample::of_camera(original.animation().time(frame), &a),
            &b,
            &options,
        );
        if e > worst.0 {
            worst = (e, frame);
        }
    }
    worst
}

/// `path --format FORMAT`, then `import`, in `dir`: the imported document and its key count.
fn round_trip(dir: &Path, name: &str, text: &str, format: &str) -> (Document, Document, usize) {
    let shot = dir.join(format!("{name}.ron"));
    std::fs::write(&shot, text).unwrap();
    let export = format!("{name}.{format}");
    let o = campath(
        dir,
        &["path", &format!("{name}.ron"), "--out", &export],
        &[],
    );
    assert_eq!(o.status.code(), Some(0), "{name}: {}", stderr(&o));
    let back = format!("{name}.back.ron");
    let o = campath(dir, &["import", &export, "--out", &back], &[]);
    assert_eq!(o.status.code(), Some(0), "{name}: {}", stderr(&o));
    let said = stdout(&o);
    let keys: usize = said
        .split(" as ")
        .nth(1)
        .and_then(|s| s.split(' ').next())
        .and_then(|n| n.parse().ok())
        .unwrap_or_else(|| panic!("{name}: no key count in {said:?}"));
    let original = Document::load(&shot).unwrap();
    let imported = Document::load(&dir.join(&back)).unwrap_or_else(|e| panic!("{name}: {e}"));
    (original, imported, keys)
}

#[test]
fn every_example_comes_back_from_csv_json_usd_and_glb_within_the_tolerance() {
    let tmp = tempfile::tempdir().unwrap();
    for name in EXAMPLES {
        let text = std::fs::read_to_string(root().join(format!("animations/{name}.ron"))).unwrap();
        for format in ["csv", "json", "usda", "glb"] {
            if format == "glb" && text.contains("Distort(") {
                continue;
            }
            let (original, back, keys) = round_trip(tmp.path(), name, &text, format);
            let (worst, frame) = worst_error(&original, &back);
            println!("{name} ({format}): {keys} keys, worst {worst:.2e} px at frame {frame}");
            assert!(
                worst <= fit::TOLERANCE,
                "{name} ({format}): {worst} px at frame {frame}"
            );
        }
    }
}

/// A random keyframe file: 3 or 4 Observer keys, a Track or a LookAround, and each of Zoom,
/// Distort, Roll and an eased constant speed about half the time.
fn generated(rng: &mut SplitMix) -> String {
    let mut r = |lo: f64, hi: f64| lo + (hi - lo) * rng.unit();
    let frames = 24 + (r(0.0, 25.0) as u64);
    let end = (frames - 1) as f64 / 24.0;
    let times = |n: usize| (0..n).map(move |i| end * i as f64 / (n - 1) as f64);
    let keys = |values: Vec<String>| {
        let n = values.len();
        let rows: Vec<String> = (times(n).zip(values))
            .map(|(t, v)| format!("(t: {t:?}, value: {v})"))
            .collect();
        format!("keys: [{}]", rows.join(", "))
    };
    let mut tracks = Vec::new();
    let n = 3 + (r(0.0, 2.0) as usize);
    let path = (0..n)
        .map(|_| {
            format!(
                "({:?}, {:?}, {:?})",
                r(-5.0, 5.0),
                r(0.5, 3.0),
                r(-12.0, -6.0)
            )
        })
        .collect();
    let eased = match r(0.0, 1.0) < 0.5 {
        true => ", speed: Uniform, ease: (start: 0.3, end: 0.4)",
        false => "",
    };
    tracks.push(format!("Observer({}{eased})", keys(path)));
    if r(0.0, 1.0) < 0.5 {
        let targets = (0..2)
            .map(|_| {
                format!(
                    "({:?}, {:?}, {:?})",
                    r(-2.0, 2.0),
                    r(-1.0, 1.0),
                    r(-1.0, 3.0)
                )
            })
            .collect();
        tracks.push(format!("Track({})", keys(targets)));
    } else {
        let views = (0..3)
            .map(|_| format!("({:?}, {:?}, 1.0)", r(-0.6, 0.6), r(-0.4, 0.4)))
            .collect();
        tracks.push(format!("LookAround({})", keys(views)));
    }
    if r(0.0, 1.0) < 0.5 {
        let n = (0..3).map(|_| format!("{:?}", r(-2.5, -0.8))).collect();
        tracks.push(format!("Zoom({}, interpolation: Monotone)", keys(n)));
    }
    if r(0.0, 1.0) < 0.5 {
        let uv = (0..2)
            .map(|_| format!("({:?}, {:?})", r(-0.5, 0.5), r(-0.5, 0.5)))
            .collect();
        tracks.push(format!("Distort({})", keys(uv)));
    }
    if r(0.0, 1.0) < 0.7 {
        let roll = (0..3).map(|_| format!("{:?}", r(-60.0, 60.0))).collect();
        tracks.push(format!("Roll({})", keys(roll)));
    }
    format!(
        "(frames: {frames}, fps: 24.0, image: (width: 320, height: 180), camera: (cop: (0.0, 0.0, -1.5), window: (1.6, 0.9)), animate: [{}])",
        tracks.join(", ")
    )
}

#[test]
fn fifty_generated_shots_come_back_within_the_tolerance() {
    let tmp = tempfile::tempdir().unwrap();
    let mut rng = SplitMix(56);
    let mut table = Vec::new();
    for i in 0..50 {
        let text = generated(&mut rng);
        let format = match ["csv", "json", "usda", "glb"][i % 4] {
            "glb" if text.contains("Distort(") => "usda",
            format => format,
        };
        let name = format!("shot{i:02}");
        let (original, back, keys) = round_trip(tmp.path(), &name, &text, format);
        let (worst, frame) = worst_error(&original, &back);
        let tracks: Vec<String> = back.animation().tracks().map(|m| m.to_string()).collect();
        table.push(format!(
            "{name} ({format}, {} frames): {keys} keys ({}), worst {worst:.2e} px at frame {frame}",
            original.animation().frames,
            tracks.join(", ")
        ));
        assert!(
            worst <= fit::TOLERANCE,
            "{name}: {worst} px at frame {frame}\n{text}"
        );
    }
    println!("{}", table.join("\n"));
}

/// A campath CSV without one of its columns, or with a row cut short, is refused (exit 2)
/// naming what is missing; so is a name that is no format `import` reads.
#[test]
fn a_source_missing_a_column_is_refused_naming_it() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    let o = campath(
        dir,
        &[
            "import",
            &root()
                .join("tests/data/import/missing_column.csv")
                .to_string_lossy(),
        ],
        &[],
    );
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("no column \"n_y\""), "{}", stderr(&o));
    std::fs::write(dir.join("x.txt"), "").unwrap();
    let o = campath(dir, &["import", "x.txt"], &[]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("name the file so"), "{}", stderr(&o));
}
