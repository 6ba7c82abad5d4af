//! The campath binary end to end, in temporary folders.

use crate::common::{campath, frame_lines, root, stderr, stdout};
use std::path::Path;

const SMALL: &str = "(
    frames: 4, fps: 4.0,
    image: (width: 32, height: 18),
    camera: (vrp: (0.0, 1.0, -6.0), tp: (0.0, 0.0, 0.0), window: (1.6, 0.9)),
    animate: [Observer(keys: [(t: 0.0, value: (0.0, 1.0, -6.0)), (t: 1.0, value: (2.0, 1.0, -5.0))])],
    scene: (lights: [(direction: (-1.0, -2.0, 1.0))], spheres: [(center: (0.0, 0.0, 0.0), radius: 1.0, color: (0.9, 0.2, 0.2))]),
)";

fn write(dir: &Path, name: &str, text: &str) -> String {
    std::fs::write(dir.join(name), text).unwrap();
    name.to_string()
}

/// The first two columns of a manifest (frame and pixel hash), as `campath hash` prints them.
fn frames_and_hashes(manifest: &str) -> String {
    frame_lines(manifest)
        .iter()
        .map(|l| l.split(' ').take(2).collect::<Vec<_>>().join(" ") + "\n")
        .collect()
}

#[test]
fn render_writes_frames_and_hashes_that_match_the_pngs() {
    let tmp = tempfile::tempdir().unwrap();
    let f = write(tmp.path(), "small.ron", SMALL);
    let o = campath(tmp.path(), &["render", &f], &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stdout(&o).contains("rendered 4 frame(s)"), "{}", stdout(&o));
    let dir = tmp.path().join("out/small");
    let manifest = std::fs::read_to_string(dir.join("hashes.txt")).unwrap();
    let lines: Vec<&str> = frame_lines(&manifest);
    assert_eq!(lines.len(), 4);
    for (k, line) in lines.iter().enumerate() {
        // Recompute the hash from the PNG with an image library and an independent SHA-256
        // (the coreutils sha256sum over the raw bytes).
        let png = dir.join(format!("frame_{k:04}.png"));
        let raw = image::open(&png).unwrap().to_rgb8().into_raw();
        assert_eq!(raw.len(), 32 * 18 * 3);
        let rawfile = tmp.path().join("raw.bin");
        std::fs::write(&rawfile, &raw).unwrap();
        let sum = std::process::Command::new("sha256sum")
            .arg(&rawfile)
            .output()
            .unwrap();
        let sum = String::from_utf8(sum.stdout).unwrap();
        let hex = sum.split_whitespace().next().unwrap();
        // `<frame> <pixel hash> <frame key>`.
        let cols: Vec<&str> = line.split(' ').collect();
        assert_eq!(cols[..2], [k.to_string(), hex.to_string()]);
        assert_eq!(cols[2].len(), 64);
    }
    // `hash` prints the same frames and hashes without writing images.
    let h = campath(tmp.path(), &["hash", &f], &[]);
    assert_eq!(stdout(&h), frames_and_hashes(&manifest));
}

#[test]
fn frames_option_and_out_option() {
    let tmp = tempfile::tempdir().unwrap();
    let f = write(tmp.path(), "small.ron", SMALL);
    let o = campath(
        tmp.path(),
        &["render", &f, "--out", "elsewhere", "--frames", "1..3"],
        &[],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let mut names: Vec<String> = std::fs::read_dir(tmp.path().join("elsewhere"))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    // The folder's lock file stays, empty, once the run is over (see docs/farms.md).
    assert_eq!(
        names,
        [
            "campath.lock",
            "frame_0001.png",
            "frame_0002.png",
            "hashes.txt"
        ]
    );
    assert_eq!(
        std::fs::read_to_string(tmp.path().join("elsewhere/campath.lock")).unwrap(),
        ""
    );
    let all = stdout(&campath(tmp.path(), &["hash", &f], &[]));
    let part = std::fs::read_to_string(tmp.path().join("elsewhere/hashes.txt")).unwrap();
    let expect: String = all
        .lines()
        .skip(1)
        .take(2)
        .map(|l| l.to_string() + "\n")
        .collect();
    assert_eq!(frames_and_hashes(&part), expect);
    // Out of range.
    let bad = campath(tmp.path(), &["render", &f, "--frames", "2..9"], &[]);
    assert_eq!(bad.status.code(), Some(2));
    assert!(stderr(&bad).contains("frames 0..4"), "{}", stderr(&bad));
}

#[test]
fn verify_names_every_differing_frame() {
    let tmp = tempfile::tempdir().unwrap();
    let f = write(tmp.path(), "small.ron", SMALL);
    let good = stdout(&campath(tmp.path(), &["hash", &f], &[]));
    write(tmp.path(), "good.txt", &good);
    let ok = campath(tmp.path(), &["verify", &f, "good.txt"], &[]);
    assert!(ok.status.success(), "{}{}", stdout(&ok), stderr(&ok));
    let mut lines: Vec<String> = good.lines().map(str::to_string).collect();
    lines[1] = format!("1 {}", "0".repeat(64));
    lines[3] = format!("3 {}", "f".repeat(64));
    write(tmp.path(), "bad.txt", &lines.join("\n"));
    let bad = campath(tmp.path(), &["verify", &f, "bad.txt"], &[]);
    assert_eq!(bad.status.code(), Some(1));
    let out = stdout(&bad);
    assert!(
        out.contains("frame 1:") && out.contains("frame 3:"),
        "{out}"
    );
    assert!(
        !out.contains("frame 0:") && !out.contains("frame 2:"),
        "{out}"
    );
    assert!(
        out.ends_with("2 of 4 frame(s) differ from bad.txt: 1, 3\n"),
        "{out}"
    );
    // A render's hashes.txt, with its key column, is a golden file too.
    let o = campath(tmp.path(), &["render", &f, "--out", "r", "--quiet"], &[]);
    assert!(o.status.success());
    let again = campath(tmp.path(), &["verify", &f, "r/hashes.txt"], &[]);
    assert!(again.status.success(), "{}", stdout(&again));
    assert!(
        !stdout(&again).contains("not checked"),
        "{}",
        stdout(&again)
    );
    // A golden of fewer frames passes on those, and says which frames it left unchecked.
    let short: String = good.lines().take(3).map(|l| l.to_string() + "\n").collect();
    write(tmp.path(), "short.txt", &short);
    let part = campath(tmp.path(), &["verify", &f, "short.txt"], &[]);
    assert!(part.status.success(), "{}", stdout(&part));
    assert_eq!(
        stdout(&part),
        "3 frame(s) match short.txt\n\
         not checked: 1 of the animation's 4 frame(s) are not in the golden: 3\n"
    );
}

#[test]
fn path_prints_one_csv_row_per_frame() {
    let tmp = tempfile::tempdir().unwrap();
    let f = write(tmp.path(), "small.ron", SMALL);
    let o = campath(tmp.path(), &["path", &f], &[]);
    assert!(o.status.success());
    let text = stdout(&o);
    let rows: Vec<&str> = text.lines().collect();
    assert_eq!(rows.len(), 5);
    assert!(rows[0].starts_with("frame,t,vrp_x"));
    let first: Vec<f64> = rows[1].split(',').map(|c| c.parse().unwrap()).collect();
    assert_eq!(first.len(), 19);
    // VRP at frame 0 is the first key; n points from it at the target (0, 0, 0).
    assert_eq!(&first[2..5], &[0.0, 1.0, -6.0]);
    let len = (1.0f64 + 36.0).sqrt();
    assert!(
        (first[11] - 0.0).abs() < 1e-15
            && (first[12] + 1.0 / len).abs() < 1e-15
            && (first[13] - 6.0 / len).abs() < 1e-15
    );
    // COP in world: VRP + n·(−1) for the default COP (0, 0, −1).
    assert!((first[15] - (1.0 + 1.0 / len)).abs() < 1e-15);
}

#[test]
fn check_accepts_every_example() {
    for name in crate::common::EXAMPLES {
        let file = root().join(format!("animations/{name}.ron"));
        let o = campath(&root(), &["check", file.to_str().unwrap()], &[]);
        assert!(o.status.success(), "{name}: {}", stderr(&o));
        assert!(stdout(&o).contains(": ok:"));
    }
}

/// Every `tests/data/bad/NAME.ron` is refused by `check` and `render` with exit status 2, writing
/// nothing, and with every line of `NAME.expected` in the message, in that order (a line
/// `!TEXT`: TEXT must not be in it). A new case is two files.
#[test]
fn bad_input_cases_are_refused_with_their_messages() {
    let dir = root().join("tests/data/bad");
    let mut cases: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .flatten()
        .map(|e| e.path())
        .filter(|p| p.extension().is_some_and(|x| x == "ron"))
        .collect();
    cases.sort();
    assert!(cases.len() >= 7, "{} cases", cases.len());
    for case in cases {
        let name = case.file_name().unwrap().to_str().unwrap().to_string();
        let expected = std::fs::read_to_string(case.with_extension("expected"))
            .unwrap_or_else(|_| panic!("{name} has no .expected file beside it"));
        let tmp = tempfile::tempdir().unwrap();
        std::fs::copy(&case, tmp.path().join(&name)).unwrap();
        // The sphere files the cases name, beside them.
        let files = tmp.path().join("sphere_files");
        std::fs::create_dir(&files).unwrap();
        for f in std::fs::read_dir(dir.join("sphere_files"))
            .unwrap()
            .flatten()
        {
            std::fs::copy(f.path(), files.join(f.file_name())).unwrap();
        }
        for verb in ["check", "render"] {
            let o = campath(tmp.path(), &[verb, &name], &[]);
            let err = stderr(&o);
            assert_eq!(o.status.code(), Some(2), "{name}, {verb}: {err}");
            assert!(!err.contains("panicked"), "{name}: {err}");
            assert!(err.starts_with("campath: error: "), "{name}, {verb}: {err}");
            // Each line in turn, after the one before: problems come in the file's order.
            let mut rest = err.as_str();
            for want in expected.lines().filter(|l| !l.is_empty()) {
                if let Some(absent) = want.strip_prefix('!') {
                    assert!(
                        !err.contains(absent),
                        "{name}, {verb}: {absent:?} must not be in:\n{err}"
                    );
                    continue;
                }
                let at = rest.find(want).unwrap_or_else(|| {
                    panic!(
                        "{name}, {verb}: expected {want:?} (after the lines before it) in:\n{err}"
                    )
                });
                rest = &rest[at + want.len()..];
            }
        }
        assert!(
            !tmp.path().join("out").exists(),
            "{name}: bad input must write nothing"
        );
    }
}

#[test]
fn a_leading_byte_order_mark_is_skipped() {
    let tmp = tempfile::tempdir().unwrap();
    let text = "(camera: (vpn: (0.0, 0.0, 1.0)), frames: 2, image: (width: 8, height: 8))";
    std::fs::write(tmp.path().join("plain.ron"), text).unwrap();
    std::fs::write(tmp.path().join("bom.ron"), format!("\u{feff}{text}")).unwrap();
    assert_eq!(
        std::fs::read(tmp.path().join("bom.ron")).unwrap()[..3],
        [0xEF, 0xBB, 0xBF]
    );
    let plain = campath(tmp.path(), &["hash", "plain.ron"], &[]);
    let bom = campath(tmp.path(), &["hash", "bom.ron"], &[]);
    assert!(bom.status.success(), "{}", stderr(&bom));
    assert_eq!(stdout(&bom), stdout(&plain));
    // Columns on the first line are counted without it, as an editor shows them: "1.0" is the
    // 26th character.
    let bad = "(camera: (vpn: (0.0, 0.0 1.0)))";
    assert_eq!(bad.chars().position(|c| c == '1'), Some(25));
    std::fs::write(tmp.path().join("bad.ron"), format!("\u{feff}{bad}")).unwrap();
    let o = campath(tmp.path(), &["check", "bad.ron"], &[]);
    assert!(stderr(&o).contains("bad.ron:1:26: "), "{}", stderr(&o));
}

#[test]
fn output_paths_say_the_format_and_are_checked_before_any_work() {
    let tmp = tempfile::tempdir().unwrap();
    let f = write(tmp.path(), "small.ron", SMALL);
    // path: the format from the extension when --format is not given.
    for (out, starts) in [
        ("shot.glb", &b"glTF"[..]),
        ("shot.gltf", b"{"),
        ("shot.json", b"["),
        ("shot.csv", b"frame,"),
        ("shot.py", b"#"),
    ] {
        let o = campath(tmp.path(), &["path", &f, "--out", out], &[]);
        assert!(o.status.success(), "{out}: {}", stderr(&o));
        let bytes = std::fs::read(tmp.path().join(out)).unwrap();
        assert!(bytes.starts_with(starts), "{out}: {:?}", &bytes[..8]);
    }
    let py = std::fs::read_to_string(tmp.path().join("shot.py")).unwrap();
    assert!(py.contains("import bpy"), "{py}");
    // A file name with line breaks stays inside the script's first comment line.
    let odd = "shot\nprint(\"from the name\")\n#.ron";
    std::fs::copy(tmp.path().join(&f), tmp.path().join(odd)).unwrap();
    let o = campath(tmp.path(), &["path", odd, "--format", "blender"], &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    let script = stdout(&o);
    assert!(script.lines().all(|l| !l.starts_with("print(")), "{script}");
    assert!(
        script.starts_with("# The campath shot \"shot\\nprint(\\\"from the name\\\")\\n#.ron\""),
        "{script}"
    );
    // Given both, they must agree; nothing is written otherwise.
    std::fs::create_dir(tmp.path().join("clips")).unwrap();
    for (args, want) in [
        (
            &["path", &f, "--format", "csv", "--out", "x.glb"][..],
            "--out x.glb names a glTF file, but --format csv writes CSV",
        ),
        (
            &["path", &f, "--out", "x.fbx"],
            "--out x.fbx: no format is written as .fbx; name the file .csv, .json, .chan, .gltf, \
             .glb, .py or .usda (.usd)",
        ),
        // A name that does not say its format: refused too, with --format or without.
        (
            &["path", &f, "--out", "x.txt"],
            "--out x.txt: no format is written as .txt; name the file .csv, .json, .chan, .gltf, \
             .glb, .py or .usda (.usd)",
        ),
        (
            &["path", &f, "--out", "cameras"],
            "--out cameras: the name has no extension to say its format; name the file .csv, \
             .json, .chan, .gltf, .glb, .py or .usda (.usd)",
        ),
        (
            &["path", &f, "--format", "json", "--out", "x.txt"],
            "--out x.txt: no format is written as .txt; --format json writes .json: name the \
             file so, as campath refuses a name that does not say its format",
        ),
        (
            &["path", &f, "--format", "gltf", "--out", "cameras"],
            "--out cameras: the name has no extension to say its format; --format gltf writes \
             .gltf or .glb: name the file so",
        ),
        (
            &["plot", &f, "--out", "plot.jpg"],
            "--out plot.jpg: plot writes PNG; name it .png",
        ),
        (
            &["report", &f, "--plot", "r.jpg"],
            "--plot r.jpg: the report's plot is PNG; name it .png",
        ),
        (
            &["video", &f, "--lossless", "--out", "shot.mp4"],
            "--out shot.mp4: --lossless writes FFV1 in Matroska; name it .mkv",
        ),
        (
            &["video", &f, "--out", "shot.mkv"],
            "--out shot.mkv: the video is H.264 in MP4 (--lossless: FFV1 in .mkv); name it .mp4",
        ),
        (
            &["video", &f, "--out", "clips"],
            "--out clips is a folder: name the video file",
        ),
    ] {
        let o = campath(tmp.path(), args, &[]);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {}", stderr(&o));
        assert!(stderr(&o).contains(want), "{args:?}: {}", stderr(&o));
    }
    for name in [
        "x.glb", "x.fbx", "x.txt", "cameras", "plot.jpg", "r.jpg", "shot.mp4", "shot.mkv", "out",
    ] {
        assert!(!tmp.path().join(name).exists(), "{name} was written");
    }
    // Not into a folder of rendered frames (its next render would refuse the file).
    let o = campath(tmp.path(), &["render", &f, "--frames", "0", "-q"], &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    for out in ["out/small/cam.usda", "out/small/sub/cam.csv"] {
        let o = campath(tmp.path(), &["path", &f, "--out", out], &[]);
        assert_eq!(o.status.code(), Some(2), "{out}: {}", stderr(&o));
        assert!(
            stderr(&o).contains("is a folder of rendered frames"),
            "{}",
            stderr(&o)
        );
    }
    assert!(!tmp.path().join("out/small/cam.usda").exists());
    assert!(!tmp.path().join("out/small/sub").exists());
    let o = campath(tmp.path(), &["render", &f, "--frames", "0", "-q"], &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    // Nor a render's folder inside another's.
    let o = campath(
        tmp.path(),
        &[
            "render",
            &f,
            "--frames",
            "0",
            "-q",
            "--out",
            "out/small/inner",
        ],
        &[],
    );
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("a folder of rendered frames"),
        "{}",
        stderr(&o)
    );
    assert!(!tmp.path().join("out/small/inner").exists());
    // Someone's hashes.txt of checksums does not make a folder one of rendered frames.
    std::fs::create_dir(tmp.path().join("sums")).unwrap();
    std::fs::write(tmp.path().join("sums/hashes.txt"), "0123abcd  small.ron\n").unwrap();
    let o = campath(tmp.path(), &["path", &f, "--out", "sums/cam.csv"], &[]);
    assert!(o.status.success(), "{}", stderr(&o));
}

#[test]
fn missing_file_is_an_io_error() {
    let tmp = tempfile::tempdir().unwrap();
    let o = campath(tmp.path(), &["check", "nope.ron"], &[]);
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("nope.ron: cannot read"));
    // The cause is printed once.
    assert_eq!(
        stderr(&o).matches("No such file or directory").count(),
        1,
        "{}",
        stderr(&o)
    );
}

#[test]
fn bad_option_values_name_the_allowed_range() {
    let tmp = tempfile::tempdir().unwrap();
    let f = write(tmp.path(), "small.ron", SMALL);
    std::fs::write(tmp.path().join("a-file"), "").unwrap();
    for (args, want) in [
        (
            &["render", &f, "--out", "a-file"][..],
            "a-file is a file, not a folder",
        ),
        (
            &["preview", &f, "--width", "0"],
            "the preview is 1 to 32 pixels wide",
        ),
        (
            &["preview", &f, "--width", "100000"],
            "the preview is 1 to 32 pixels wide",
        ),
        (&["preview", &f, "--count", "0"], "1 to 4 frames"),
        (&["preview", &f, "--count", "5"], "1 to 4 frames"),
        (&["plot", &f, "--every", "0"], "expected a whole number ≥ 1"),
        (
            &["render", &f, "--shard", "3/3"],
            "expected K/N with 0 ≤ K < N",
        ),
        (
            &["report", &f, "--plot", "a-file/report.png"],
            "a-file is a file, not a folder",
        ),
        // Values and options clap refuses read like every other error.
        (
            &["render", &f, "--frames", "x"],
            "invalid value 'x' for '--frames <FRAMES>'",
        ),
        // A frame number past every file's last, not a range one short or "empty".
        (
            &["hash", &f, "--frames", "0..=18446744073709551615"],
            "18446744073709551615 is past every frame (a file has at most 10000000 frames)",
        ),
        (
            &["hash", &f, "--frames", "18446744073709551615"],
            "18446744073709551615 is past every frame",
        ),
        (&["render", &f, "--bogus"], "unexpected argument '--bogus'"),
        (&["bogus"], "unrecognized subcommand 'bogus'"),
    ] {
        let o = campath(tmp.path(), args, &[]);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {}", stderr(&o));
        assert!(stderr(&o).contains(want), "{args:?}: {}", stderr(&o));
        assert!(
            stderr(&o).starts_with("campath: error: ") && !stderr(&o).contains("\nerror:"),
            "{args:?}: one style for every error: {}",
            stderr(&o)
        );
    }
    // Help and version are not errors.
    for args in [&["--help"][..], &["--version"], &["render", "--help"]] {
        let o = campath(tmp.path(), args, &[]);
        assert_eq!(o.status.code(), Some(0), "{args:?}");
        assert!(stderr(&o).is_empty() && !stdout(&o).is_empty(), "{args:?}");
    }
    // No command at all: the help, on standard error, with exit 2.
    let o = campath(tmp.path(), &[], &[]);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        stderr(&o).contains("Usage: campath <COMMAND>") && !stderr(&o).contains("error"),
        "{}",
        stderr(&o)
    );
}

#[test]
fn a_minimal_file_is_a_few_lines() {
    let tmp = tempfile::tempdir().unwrap();
    let f = write(tmp.path(), "min.ron", "(camera: (vrp: (0.0, 0.0, -4.0), tp: (0.0, 0.0, 0.0)),\n scene: (spheres: [(center: (0.0, 0.0, 0.0), radius: 1.0)]))");
    let o = campath(tmp.path(), &["render", &f], &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    let img = image::open(tmp.path().join("out/min/frame_0000.png"))
        .unwrap()
        .to_rgb8();
    assert_eq!(img.dimensions(), (640, 360));
    // Flat white sphere in the middle, black background in the corner.
    assert_eq!(img.get_pixel(320, 180).0, [255, 255, 255]);
    assert_eq!(img.get_pixel(0, 0).0, [0, 0, 0]);
}

#[test]
fn held_frames_are_reused_and_compression_keeps_the_pixels() {
    let tmp = tempfile::tempdir().unwrap();
    // The camera stops at t = 0.5 s: frames 2 and 3 repeat frame 2's camera.
    let held = SMALL.replace(
        "(t: 1.0, value: (2.0, 1.0, -5.0))",
        "(t: 0.5, value: (2.0, 1.0, -5.0))",
    );
    let f = write(tmp.path(), "held.ron", &held);
    let fast = campath(tmp.path(), &["render", &f, "--out", "fast"], &[]);
    assert!(stdout(&fast).contains("1 held"), "{}", stdout(&fast));
    let best = campath(
        tmp.path(),
        &["render", &f, "--out", "best", "--compression", "best"],
        &[],
    );
    assert!(best.status.success(), "{}", stderr(&best));
    let read = |d: &str| std::fs::read_to_string(tmp.path().join(d).join("hashes.txt")).unwrap();
    assert_eq!(read("fast"), read("best"));
    let lines: Vec<String> = frame_lines(&read("fast"))
        .iter()
        .map(|l| l.split(' ').nth(1).unwrap().to_string())
        .collect();
    assert_eq!(lines[2], lines[3]);
    assert_ne!(lines[1], lines[2]);
    // And the same as rendering without reuse: `hash` of frame 3 alone.
    let alone = stdout(&campath(tmp.path(), &["hash", &f, "--frames", "3"], &[]));
    assert_eq!(alone.trim(), format!("3 {}", lines[3]));
}

/// The RMSE (levels) of `report`'s row `label` in its output `text`.
fn rmse_of(text: &str, label: &str) -> f64 {
    let line = text
        .lines()
        .find(|l| l.starts_with(&format!("| {label} |")))
        .unwrap();
    line.split('|').nth(3).unwrap().trim().parse().unwrap()
}

#[test]
fn report_prints_both_tables_and_writes_the_plot() {
    let tmp = tempfile::tempdir().unwrap();
    let f = write(tmp.path(), "small.ron", SMALL);
    let o = campath(
        tmp.path(),
        &["report", &f, "--runs", "1", "--plot", "plot.png"],
        &[],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let text = stdout(&o);
    for row in [
        "| samples 1 |",
        "| samples 8 |",
        "| samples 4, adaptive |",
        "| uniform | 1024 |",
        "| keyed |",
    ] {
        assert!(text.contains(row), "{row} missing from:\n{text}");
    }
    // Samples 8 is closer to the 16×16 reference than samples 1.
    let rmse = |label: &str| rmse_of(&text, label);
    assert!(rmse("samples 8") < rmse("samples 1"));
    // Motion blur's time samples, against 64 of them on a frame where the camera moves: more
    // time samples, less error; and one time sample is the frame without blur.
    for n in [1, 2, 4, 8, 16] {
        let row = format!("| time samples {n} |");
        assert!(text.contains(&row), "{row} missing from:\n{text}");
    }
    assert!(text.contains("Time samples: frame "), "{text}");
    // The instruction paths are rows too, each with samples 1's error exactly (same bytes).
    let baseline = format!(
        "samples 1, f64, {} path",
        campath::internals::Simd::Baseline.name()
    );
    assert_eq!(rmse(&baseline), rmse("samples 1"));
    let plot = image::open(tmp.path().join("plot.png")).unwrap();
    assert_eq!((plot.width(), plot.height()), (900, 600));
    // SMALL's camera looks at its one sphere, whose picture hardly changes as it moves; a
    // camera that slides past it blurs it.
    let sliding = SMALL
        .replace("tp: (0.0, 0.0, 0.0)", "vpn: (0.0, -0.1, 1.0)")
        .replace("width: 32, height: 18", "width: 64, height: 36");
    let f = write(tmp.path(), "sliding.ron", &sliding);
    let o = campath(
        tmp.path(),
        &["report", &f, "--runs", "1", "--plot", "sliding.png"],
        &[],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let text = stdout(&o);
    let rmse = |label: &str| rmse_of(&text, label);
    assert!(rmse("time samples 16") < rmse("time samples 4"), "{text}");
    assert!(rmse("time samples 4") < rmse("time samples 1"), "{text}");
    assert!(rmse("time samples 1") > 1.0, "{text}");
}

#[test]
fn path_exports_json_and_chan() {
    let tmp = tempfile::tempdir().unwrap();
    let f = write(tmp.path(), "small.ron", SMALL);
    let csv = stdout(&campath(tmp.path(), &["path", &f, "--format", "csv"], &[]));
    let json = campath(tmp.path(), &["path", &f, "--format", "json"], &[]);
    assert!(json.status.success(), "{}", stderr(&json));
    let v: serde_json::Value = serde_json::from_str(&stdout(&json)).unwrap();
    let frames = v.as_array().unwrap();
    assert_eq!(frames.len(), 4);
    // The same numbers as the CSV, frame by frame.
    for (row, obj) in csv.lines().skip(1).zip(frames) {
        let cols: Vec<f64> = row.split(',').map(|c| c.parse().unwrap()).collect();
        let vrp: Vec<f64> = obj["vrp"]
            .as_array()
            .unwrap()
            .iter()
            .map(|x| x.as_f64().unwrap())
            .collect();
        assert_eq!(vrp, cols[2..5]);
        assert_eq!(obj["window"][1].as_f64().unwrap(), cols[18]);
    }
    let chan = stdout(&campath(tmp.path(), &["path", &f, "--format", "chan"], &[]));
    let rows: Vec<Vec<f64>> = chan
        .lines()
        .map(|l| l.split('\t').map(|c| c.parse().unwrap()).collect())
        .collect();
    assert_eq!(rows.len(), 4);
    assert_eq!(rows[0].len(), 8);
    // campath's frame 0 is .chan's frame 0 (Nuke's users give --first-frame 1).
    assert_eq!(rows[0][0], 0.0);
    // Translation is the COP; the vertical FOV is 2·atan(0.45 / 1) for window height 0.9 at d = 1.
    let first: Vec<f64> = csv
        .lines()
        .nth(1)
        .unwrap()
        .split(',')
        .map(|c| c.parse().unwrap())
        .collect();
    assert_eq!(rows[0][1..4], first[14..17]);
    assert!((rows[0][7] - 2.0 * 0.45f64.atan().to_degrees()).abs() < 1e-12);
}

/// R = Ry·Rx·Rz from angles in degrees, by matrix products written out here.
fn compose_zxy(deg: [f64; 3]) -> [[f64; 3]; 3] {
    let [x, y, z] = deg.map(f64::to_radians);
    let rx = [
        [1.0, 0.0, 0.0],
        [0.0, x.cos(), -x.sin()],
        [0.0, x.sin(), x.cos()],
    ];
    let ry = [
        [y.cos(), 0.0, y.sin()],
        [0.0, 1.0, 0.0],
        [-y.sin(), 0.0, y.cos()],
    ];
    let rz = [
        [z.cos(), -z.sin(), 0.0],
        [z.sin(), z.cos(), 0.0],
        [0.0, 0.0, 1.0],
    ];
    let mul = |a: [[f64; 3]; 3], b: [[f64; 3]; 3]| {
        let mut m = [[0.0; 3]; 3];
        for (i, row) in m.iter_mut().enumerate() {
            for (j, v) in row.iter_mut().enumerate() {
                *v = (0..3).map(|k| a[i][k] * b[k][j]).sum();
            }
        }
        m
    };
    mul(ry, mul(rx, rz))
}

#[test]
fn chan_angles_are_continuous_and_rebuild_the_camera_axes() {
    let mut files: Vec<String> = crate::common::EXAMPLES
        .iter()
        .map(|n| format!("animations/{n}.ron"))
        .collect();
    for data in ["orbit_pole", "pole_track", "pole_look_around"] {
        files.push(format!("tests/data/{data}.ron"));
    }
    for file in files {
        let chan = campath(&root(), &["path", &file, "--format", "chan"], &[]);
        let csv = stdout(&campath(&root(), &["path", &file], &[]));
        let chan: Vec<Vec<f64>> = stdout(&chan)
            .lines()
            .map(|l| l.split('\t').map(|c| c.parse().unwrap()).collect())
            .collect();
        let csv: Vec<Vec<f64>> = csv
            .lines()
            .skip(1)
            .map(|l| l.split(',').map(|c| c.parse().unwrap()).collect())
            .collect();
        assert_eq!(chan.len(), csv.len(), "{file}");
        for (k, (row, cam)) in chan.iter().zip(&csv).enumerate() {
            if k > 0 {
                for a in 4..7 {
                    let step = (row[a] - chan[k - 1][a]).abs();
                    assert!(
                        step < 180.0,
                        "{file} frame {k}: angle {} steps {step}°",
                        a - 4
                    );
                }
            }
            // The columns of R are u, v and −n (CSV columns 5–7, 8–10, 11–13).
            let r = compose_zxy([row[4], row[5], row[6]]);
            for (col, (start, sign)) in [(5, 1.0), (8, 1.0), (11, -1.0)].into_iter().enumerate() {
                for i in 0..3 {
                    let want = sign * cam[start + i];
                    assert!(
                        (r[i][col] - want).abs() < 1e-9,
                        "{file} frame {k}: R[{i}][{col}] = {} against {want}",
                        r[i][col]
                    );
                }
            }
        }
    }
}

#[test]
fn a_reader_that_goes_away_ends_path_and_hash_quietly() {
    for args in [
        &["path", "tests/data/long.ron"][..],
        &["path", "tests/data/long.ron", "--format", "chan"],
        &["hash", "animations/zoom.ron", "--frames", "0..8"],
    ] {
        let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_campath"))
            .current_dir(root())
            .args(args)
            .stdout(std::process::Stdio::piped())
            .stderr(std::process::Stdio::piped())
            .spawn()
            .unwrap();
        // Read one line, then close the pipe, as `| head -1` does.
        let mut stdout = child.stdout.take().unwrap();
        let mut byte = [0u8; 1];
        while std::io::Read::read(&mut stdout, &mut byte).unwrap() == 1 && byte[0] != b'\n' {}
        drop(stdout);
        let out = child.wait_with_output().unwrap();
        assert!(out.status.success(), "{args:?}: {:?}", out.status);
        assert!(stderr(&out).is_empty(), "{args:?}: {}", stderr(&out));
    }
}

#[test]
fn distort_names_the_frames_whose_cop_chan_drops() {
    let o = campath(
        &root(),
        &["path", "animations/distort.ron", "--format", "chan"],
        &[],
    );
    assert!(o.status.success());
    assert!(
        stderr(&o).contains("71 of 72 frame(s), campath frames 1..=71, are written"),
        "{}",
        stderr(&o)
    );
    let o = campath(
        &root(),
        &[
            "path",
            "animations/distort.ron",
            "--format",
            "chan",
            "--first-frame",
            "1",
        ],
        &[],
    );
    assert!(
        stderr(&o).contains("71 of 72 frame(s), campath frames 1..=71 (.chan frames 2..=72)"),
        "{}",
        stderr(&o)
    );
    let csv = campath(&root(), &["path", "animations/distort.ron"], &[]);
    assert!(stderr(&csv).is_empty());
}

/// The manual's ENVIRONMENT names what decides what a failing frame-hash test writes.
#[test]
fn the_manual_names_the_variables_of_frame_hash_tests() {
    let tmp = tempfile::tempdir().unwrap();
    let man = stdout(&campath(tmp.path(), &["man"], &[]));
    let env = man.split(".SH ENVIRONMENT").nth(1).unwrap_or("");
    let env = env.split(".SH ").next().unwrap_or("");
    for var in ["\\fBCAMPATH_UPDATE\\fR", "\\fBCI\\fR"] {
        assert!(
            env.contains(var),
            "the manual's ENVIRONMENT lacks {var}: {env}"
        );
    }
}

#[test]
fn completions_and_the_manual_come_from_the_clap_definitions() {
    let tmp = tempfile::tempdir().unwrap();
    let verbs = [
        "render", "merge", "preview", "plot", "hash", "verify", "path", "check", "report", "test",
        "review",
    ];
    // The benchmark against POV-Ray is no verb: the refusal says where it is.
    let bench = campath(tmp.path(), &["bench", "--help"], &[]);
    assert_eq!(bench.status.code(), Some(2));
    assert!(
        stderr(&bench).contains("cargo bench --features bench --bench peers"),
        "{}",
        stderr(&bench)
    );
    for shell in ["bash", "zsh", "fish", "powershell"] {
        let o = campath(tmp.path(), &["completions", shell], &[]);
        assert!(o.status.success(), "{shell}: {}", stderr(&o));
        for verb in verbs {
            assert!(stdout(&o).contains(verb), "{shell} completion lacks {verb}");
        }
    }
    // bash itself completes `campath re` to the three verbs that start so.
    let script = stdout(&campath(tmp.path(), &["completions", "bash"], &[]));
    std::fs::write(tmp.path().join("campath.bash"), script).unwrap();
    let o = std::process::Command::new("bash")
        .current_dir(tmp.path())
        .args([
            "-c",
            "source campath.bash; COMP_WORDS=(campath re); COMP_CWORD=1; \
             _campath campath re campath; echo \"${COMPREPLY[@]}\"",
        ])
        .output()
        .unwrap();
    assert_eq!(stdout(&o).trim(), "render review report", "{}", stderr(&o));
    let man = stdout(&campath(tmp.path(), &["man"], &[]));
    assert!(man.contains(".TH campath 1"), "{man}");
    // One page holds everything: every command with its options, exit status, the file.
    for verb in verbs
        .iter()
        .chain(&["video", "watch", "completions", "man"])
    {
        assert!(
            man.contains(&format!(".SS \"campath {verb}\"")),
            "the manual lacks {verb}"
        );
    }
    for want in [
        "\\-\\-no\\-wait",
        "\\-\\-lossless",
        "\\-\\-shard",
        ".SH \"EXIT STATUS\"",
        ".SH ENVIRONMENT",
        "CAMPATH_SIMD",
        ".SH FILES",
    ] {
        assert!(man.contains(want), "the manual lacks {want}");
    }
    // It names no page that is not produced.
    assert!(!man.contains("campath\\-render(1)"), "{man}");
    // --dir writes it and a page per command, the ones its parts point at.
    let o = campath(tmp.path(), &["man", "--dir", "man1"], &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    let page = std::fs::read_to_string(tmp.path().join("man1/campath.1")).unwrap();
    assert_eq!(page, man);
    for verb in verbs {
        let sub = std::fs::read_to_string(tmp.path().join(format!("man1/campath-{verb}.1")))
            .unwrap_or_else(|e| panic!("campath-{verb}.1: {e}"));
        assert!(sub.contains(".TH campath-"), "{sub}");
    }
}

#[test]
fn verify_for_ci_writes_junit_and_difference_images_that_mark_exactly_the_changed_pixels() {
    let tmp = tempfile::tempdir().unwrap();
    let f = write(tmp.path(), "small.ron", SMALL);
    let o = campath(
        tmp.path(),
        &["render", &f, "--out", "golden", "--quiet"],
        &[],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    // One sphere's colour changes.
    let edited = SMALL.replace("color: (0.9, 0.2, 0.2)", "color: (0.2, 0.9, 0.2)");
    assert_ne!(edited, SMALL);
    let e = write(tmp.path(), "edited.ron", &edited);
    let o = campath(
        tmp.path(),
        &[
            "verify",
            &e,
            "golden",
            "--junit",
            "report.xml",
            "--save-failures",
            "fails",
        ],
        &[],
    );
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    // Which frames differ, from `campath hash` and the golden hashes.txt alone.
    let golden = std::fs::read_to_string(tmp.path().join("golden/hashes.txt")).unwrap();
    let fresh = stdout(&campath(tmp.path(), &["hash", &e], &[]));
    let failing: Vec<u64> = frames_and_hashes(&golden)
        .lines()
        .zip(fresh.lines())
        .filter(|(g, f)| g != f)
        .map(|(g, _)| g.split(' ').next().unwrap().parse().unwrap())
        .collect();
    assert!(!failing.is_empty());

    let xml = std::fs::read_to_string(tmp.path().join("report.xml")).unwrap();
    let report = roxmltree::Document::parse(&xml).unwrap();
    let suite = report
        .descendants()
        .find(|n| n.has_tag_name("testsuite"))
        .unwrap();
    assert_eq!(suite.attribute("tests"), Some("4"));
    assert_eq!(
        suite.attribute("failures"),
        Some(&*failing.len().to_string())
    );
    let cases: Vec<_> = suite
        .children()
        .filter(|n| n.has_tag_name("testcase"))
        .collect();
    assert_eq!(cases.len(), 4);
    for (k, case) in cases.iter().enumerate() {
        assert_eq!(case.attribute("name"), Some(&*format!("frame {k}")));
        let failed = case.children().any(|n| n.has_tag_name("failure"));
        assert_eq!(failed, failing.contains(&(k as u64)), "frame {k}");
    }

    for k in failing {
        let rgb = |p: &str| image::open(tmp.path().join(p)).unwrap().to_rgb8();
        let before = rgb(&format!("golden/frame_{k:04}.png"));
        let after = rgb(&format!("fails/frame_{k:04}.png"));
        let diff = rgb(&format!("fails/frame_{k:04}.diff.png"));
        let mut changed = 0;
        for (x, y, px) in diff.enumerate_pixels() {
            let differs = before.get_pixel(x, y) != after.get_pixel(x, y);
            changed += usize::from(differs);
            assert_eq!(px.0 == [255, 0, 255], differs, "frame {k} pixel ({x}, {y})");
        }
        assert!(changed > 0);
        assert!(
            stdout(&o).contains(&format!("frame {k}: expected"))
                && stdout(&o).contains(&format!("{changed} pixel(s) changed")),
            "{}",
            stdout(&o)
        );
    }
}

/// Nothing is written over a golden or another program's files, and such a path is refused
/// (exit 2) before any work: `render`, `merge` and `preview` into a shot's golden or a folder
/// whose hashes.txt names the renderer and lists frames without keys (as goldens do), a folder
/// inside a golden that is a link, `preview` into a folder of other
/// files, `merge` there (which leaves no lock behind), and `--stats-json` over the keyframe file,
/// over a golden's hashes or below a file.
#[test]
fn goldens_and_other_files_are_never_written_over() {
    let tmp = tempfile::tempdir().unwrap();
    let shots = tmp.path().join("shots");
    std::fs::create_dir(&shots).unwrap();
    write(&shots, "a.ron", SMALL);
    let o = campath(tmp.path(), &["test", "shots", "--update"], &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    // A folder of keyless hashes (a golden copied elsewhere), and one of someone's notes.
    let copy = tmp.path().join("golden-copy");
    std::fs::create_dir(&copy).unwrap();
    std::fs::copy(shots.join("a.golden/hashes.txt"), copy.join("hashes.txt")).unwrap();
    let notes = tmp.path().join("notes");
    std::fs::create_dir(&notes).unwrap();
    std::fs::write(notes.join("todo.txt"), "mine").unwrap();
    let snapshot = || {
        let mut files = Vec::new();
        for dir in ["shots", "shots/a.golden", "golden-copy", "notes"] {
            for e in std::fs::read_dir(tmp.path().join(dir)).unwrap().flatten() {
                let bytes = std::fs::read(e.path()).unwrap_or_default();
                files.push((e.path(), bytes));
            }
        }
        files.sort();
        files
    };
    // A golden that is a link to where its frames are kept.
    let store = tmp.path().join("store");
    std::fs::create_dir(&store).unwrap();
    std::fs::copy(shots.join("a.golden/hashes.txt"), store.join("hashes.txt")).unwrap();
    std::fs::write(shots.join("b.ron"), SMALL).unwrap();
    std::os::unix::fs::symlink(&store, shots.join("b.golden")).unwrap();
    let before = snapshot();
    let golden = "a.golden is the golden of ";
    for (args, want) in [
        (
            &["render", "shots/a.ron", "--out", "shots/a.golden"][..],
            golden,
        ),
        (
            &["render", "shots/a.ron", "--out", "shots/a.golden/sub"],
            golden,
        ),
        (
            &["render", "shots/a.ron", "--out", "shots/a.golden/x/../."],
            golden,
        ),
        (
            &["render", "shots/b.ron", "--out", "shots/b.golden/sub"],
            "b.golden is the golden of ",
        ),
        (
            &["render", "shots/a.ron", "--out", "golden-copy"],
            "golden-copy is a golden: its hashes.txt names campath's renderer and lists frames \
             without keys",
        ),
        (&["merge", "shots/a.golden"], golden),
        (
            &["merge", "notes"],
            "notes holds files campath did not write (todo.txt)",
        ),
        (
            &["preview", "shots/a.ron", "--out", "shots/a.golden"],
            golden,
        ),
        (
            &["preview", "shots/a.ron", "--out", "notes"],
            "notes holds files campath did not write (todo.txt)",
        ),
        (
            &["video", "shots/a.ron", "--out", "shots/a.golden/a.mp4"],
            golden,
        ),
        (
            &["hash", "shots/a.ron", "--stats-json", "shots/a.ron"],
            "--stats-json shots/a.ron exists and is not run statistics campath wrote",
        ),
        (
            &[
                "hash",
                "shots/a.ron",
                "--stats-json",
                "shots/a.golden/s.json",
            ],
            golden,
        ),
        (
            &[
                "render",
                "shots/a.ron",
                "--out",
                "out",
                "--stats-json",
                "shots/a.golden/hashes.txt",
            ],
            golden,
        ),
        (
            &[
                "render",
                "shots/a.ron",
                "--out",
                "out",
                "--stats-json",
                "shots/a.ron/s.json",
            ],
            "shots/a.ron is a file, not a folder",
        ),
        (
            &[
                "render",
                "shots/a.ron",
                "--out",
                "out",
                "--stats-json",
                "out/hashes.txt",
            ],
            "it is in the --out folder out",
        ),
    ] {
        let o = campath(tmp.path(), args, &[]);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {}", stderr(&o));
        assert!(stderr(&o).contains(want), "{args:?}: {}", stderr(&o));
        assert_eq!(snapshot(), before, "{args:?} wrote");
        assert!(!tmp.path().join("out").exists(), "{args:?} rendered");
    }
    // From inside the golden, `--out .` is the golden.
    let o = campath(
        &shots.join("a.golden"),
        &["render", "../a.ron", "--out", "."],
        &[],
    );
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert_eq!(snapshot(), before, "--out . wrote");
    // A folder rendered before frame keys (no renderer line, no keys) is rendered again.
    let old = tmp.path().join("old");
    std::fs::create_dir(&old).unwrap();
    let keyless: String = frame_lines(&std::fs::read_to_string(copy.join("hashes.txt")).unwrap())
        .iter()
        .map(|l| format!("{l}\n"))
        .collect();
    std::fs::write(old.join("hashes.txt"), keyless).unwrap();
    let o = campath(
        tmp.path(),
        &["render", "shots/a.ron", "--out", "old", "-q"],
        &[],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    // Statistics campath wrote are written over.
    for _ in 0..2 {
        let o = campath(
            tmp.path(),
            &["hash", "shots/a.ron", "--stats-json", "s/run.json"],
            &[],
        );
        assert!(o.status.success(), "{}", stderr(&o));
    }
}

/// A keyframe file whose name is not UTF-8 renders into a folder of its own name, as it is (not
/// one shared by every such name), and the lock's record of the command line does not fail.
#[test]
fn a_file_name_that_is_not_utf8_renders_into_its_own_folder() {
    use std::os::unix::ffi::OsStrExt;
    let tmp = tempfile::tempdir().unwrap();
    let names = [&b"sh\xff.ron"[..], b"sh\xfe.ron"];
    for name in names {
        let name = std::ffi::OsStr::from_bytes(name);
        std::fs::write(tmp.path().join(name), SMALL).unwrap();
        let o = std::process::Command::new(env!("CARGO_BIN_EXE_campath"))
            .current_dir(tmp.path())
            .arg("render")
            .arg(name)
            .arg("-q")
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", stderr(&o));
    }
    let folders = std::fs::read_dir(tmp.path().join("out")).unwrap().count();
    assert_eq!(folders, names.len());
}
