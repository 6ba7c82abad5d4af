//! Helpers shared by the integration tests.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use campath::document::Document;

/// The examples in animations/, by file stem.
pub const EXAMPLES: [&str; 8] = [
    "observer",
    "look_around",
    "track",
    "zoom",
    "distort",
    "flythrough",
    "dolly_zoom",
    "motion_blur",
];

/// The repository root.
pub fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// Loads `animations/<name>.ron`.
pub fn example(name: &str) -> Document {
    Document::load(&root().join("animations").join(format!("{name}.ron"))).unwrap()
}

/// Checks RON text as if it were the file `test.ron`.
pub fn doc(text: &str) -> Document {
    Document::from_str(Path::new("test.ron"), text).unwrap_or_else(|e| panic!("{e}"))
}

/// Runs the campath binary in `dir` with `args` and optional environment.
pub fn campath(dir: &Path, args: &[&str], env: &[(&str, &str)]) -> Output {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_campath"));
    // What a failing shot writes is each test's to say, not the environment's.
    cmd.current_dir(dir)
        .args(args)
        .env_remove("CAMPATH_UPDATE")
        .env_remove("CI");
    for (k, v) in env {
        cmd.env(k, v);
    }
    cmd.output().expect("campath runs")
}

/// Headless Chromium, quiet and offline, with its profile in `profile` and then `args`.
pub fn chromium(profile: &Path, args: &[&str]) -> Output {
    Command::new("chromium")
        .args([
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--no-first-run",
            "--disable-background-networking",
            "--disable-component-update",
            "--disable-sync",
        ])
        .arg(format!("--user-data-dir={}", profile.display()))
        .args(args)
        .output()
        .expect("chromium runs")
}

pub fn stdout(o: &Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

pub fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// The frame lines of a manifest: every line but the `#` lines (renderer, part header,
/// `# complete`).
pub fn frame_lines(text: &str) -> Vec<&str> {
    text.lines().filter(|l| !l.starts_with('#')).collect()
}

/// Fails the test unless the outside program `program` is on PATH. A test that needs one is
/// marked `#[ignore = "needs PROGRAM"]`, so `cargo test` lists it as ignored with that reason;
/// `cargo test -- --include-ignored` (`.ci/run`, which installs the programs) runs it, and there
/// a missing program fails it.
pub fn need_tool(program: &str, package: &str) {
    let found = Command::new(program)
        .arg("--version")
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .status()
        .is_ok();
    assert!(
        found,
        "{program} is not on PATH (Debian package {package}); .ci/run installs it"
    );
}

/// [`need_tool`], and fails the test unless `program` has the part the test needs, as `probe`
/// says: `probe` runs it and returns why the part is missing, if it is.
pub fn need_part(program: &str, package: &str, probe: impl Fn(&str) -> Option<String>) {
    need_tool(program, package);
    if let Some(why) = probe(program) {
        panic!("{why}; .ci/run installs it");
    }
}

/// Why `blender` (a path or a name on PATH) cannot import the Python module `module` into its
/// own Python, or None if it can. Blender brings its own Python, or uses the system's (Debian);
/// either may lack a module that Blender's add-ons (the glTF importer: NumPy) need.
pub fn blender_lacks_module(blender: &str, module: &str, package: &str) -> Option<String> {
    let o = Command::new(blender)
        .args([
            "--background",
            "--factory-startup",
            "--python-exit-code",
            "1",
            "--python-expr",
            &format!("import {module}"),
        ])
        .output();
    match o {
        Ok(o) if o.status.success() => None,
        Ok(o) => {
            let text = String::from_utf8_lossy(&o.stderr) + String::from_utf8_lossy(&o.stdout);
            let error = text
                .lines()
                .find(|l| l.contains("Error"))
                .unwrap_or("")
                .trim()
                .to_string();
            Some(format!(
                "Blender's Python cannot import {module} ({error}; Debian package {package})"
            ))
        }
        Err(e) => Some(format!("{blender} does not run: {e}")),
    }
}

/// Why `program` (a path or a name on PATH) is there but does not run: `--version` fails, as
/// with Ubuntu's `chromium` stub that asks for the snap, or a binary missing a shared library.
pub fn does_not_run(program: &str) -> Option<String> {
    match Command::new(program).arg("--version").output() {
        Ok(o) if o.status.success() => None,
        Ok(o) => Some(format!(
            "{program} is on PATH but `{program} --version` fails ({}): {}",
            o.status,
            String::from_utf8_lossy(&o.stderr)
                .lines()
                .chain(String::from_utf8_lossy(&o.stdout).lines())
                .next()
                .unwrap_or("")
                .trim()
        )),
        Err(e) => Some(format!("{program} does not run: {e}")),
    }
}

/// Why `ffmpeg` (a path or a name on PATH) has no encoder `encoder`, or None if it has.
pub fn ffmpeg_lacks_encoder(ffmpeg: &str, encoder: &str) -> Option<String> {
    let o = Command::new(ffmpeg)
        .args(["-hide_banner", "-encoders"])
        .output();
    match o {
        Ok(o)
            if String::from_utf8_lossy(&o.stdout)
                .lines()
                .any(|l| l.split_whitespace().nth(1) == Some(encoder)) =>
        {
            None
        }
        Ok(_) => Some(format!(
            "{ffmpeg} has no {encoder} encoder (a build without it; Debian's ffmpeg has it)"
        )),
        Err(e) => Some(format!("{ffmpeg} does not run: {e}")),
    }
}

#[test]
fn a_program_present_without_the_part_a_check_needs_is_told_apart() {
    // Stand-ins that answer the probes as the real programs do: Blender exits 1 on a failed
    // import under --python-exit-code 1, ffmpeg lists encoders in columns after a flags column.
    let tmp = tempfile::tempdir().unwrap();
    let script = |name: &str, body: &str| stand_in(tmp.path(), name, body);
    let without = script(
        "blender-without",
        "echo \"ModuleNotFoundError: No module named 'numpy'\" >&2; exit 1",
    );
    let with = script("blender-with", "exit 0");
    let why = blender_lacks_module(&without, "numpy", "python3-numpy").unwrap();
    assert!(
        why.contains("cannot import numpy (ModuleNotFoundError: No module named 'numpy'")
            && why.contains("python3-numpy"),
        "{why}"
    );
    assert_eq!(blender_lacks_module(&with, "numpy", "python3-numpy"), None);
    let encoders = script(
        "ffmpeg-encoders",
        "echo ' V....D libx264rgb  libx264 RGB'; echo ' V.S... ffv1  FFmpeg video codec #1'",
    );
    assert_eq!(ffmpeg_lacks_encoder(&encoders, "ffv1"), None);
    assert!(ffmpeg_lacks_encoder(&encoders, "libx264").is_some());
    let stub = script(
        "chromium-stub",
        "echo \"Command '/usr/bin/chromium' requires the chromium snap to be installed.\"; exit 1",
    );
    let why = does_not_run(&stub).unwrap();
    assert!(why.contains("requires the chromium snap"), "{why}");
    assert_eq!(does_not_run(&with), None);
}

/// The shots that try the exports' clipping range, lens and shutter ends (`tests/data`): a
/// camera 1.8e6 from its spheres, a sphere 0.2 in front of the eye over a huge ground (ahead,
/// and 70° off the view direction in a 150° view), a 176° field of view, and one blurred frame
/// that zooms and shifts during its shutter.
pub const EXPORT_EDGES: [&str; 5] = [
    "export_far",
    "export_near",
    "export_near_wide",
    "export_wide",
    "export_blur_one_frame",
];

/// One shot of [`EXPORT_EDGES`] and the motion-blur example, exported into `dir` by
/// `campath path --out NAME.EXT`: (name, the exported file, the shot's document).
pub fn export_edge_shots(dir: &Path, ext: &str) -> Vec<(&'static str, PathBuf, Document)> {
    let mut names: Vec<&'static str> = EXPORT_EDGES.to_vec();
    names.push("motion_blur");
    names
        .into_iter()
        .map(|name| {
            let file = match name {
                "motion_blur" => root().join("animations/motion_blur.ron"),
                _ => root().join(format!("tests/data/{name}.ron")),
            };
            let out = dir.join(format!("{name}.{ext}"));
            let (f, o) = (file.to_str().unwrap(), out.to_str().unwrap());
            let run = campath(dir, &["path", f, "--out", o], &[]);
            assert!(run.status.success(), "{name}: {}", stderr(&run));
            (name, out, Document::load(&file).unwrap())
        })
        .collect()
}

/// What a reader's clipping range must hold: the least depth along the view direction at which
/// any frame shows a point of a sphere, and the furthest any sphere reaches from any frame's
/// COP. The depth is found from points spread over each sphere's surface (a Fibonacci spiral of
/// 4096), each kept where it falls in the frame's window seen from the COP.
pub fn reach_of_views(doc: &Document) -> (f64, f64) {
    const POINTS: usize = 4096;
    let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
    let (mut least, mut furthest) = (f64::INFINITY, 0.0f64);
    for item in doc.cameras() {
        let cam = item.unwrap().1;
        let (c, half) = (cam.cop_view, cam.window * 0.5);
        for s in &doc.scene().spheres {
            furthest = furthest.max((cam.cop_world() - s.center_world).length() + s.radius);
            for i in 0..POINTS {
                let y = 1.0 - 2.0 * (i as f64 + 0.5) / POINTS as f64;
                let ring = (1.0 - y * y).sqrt();
                let a = golden * i as f64;
                let on = glam::DVec3::new(ring * a.cos(), y, ring * a.sin());
                let v = cam.point_to_view(s.center_world + on * s.radius);
                let depth = v.z - c.z;
                if depth <= 0.0 {
                    continue;
                }
                // Where the point falls on the view plane, seen from the COP.
                let t = -c.z / depth;
                let (x, y) = (c.x + (v.x - c.x) * t, c.y + (v.y - c.y) * t);
                if x.abs() <= half.x && y.abs() <= half.y {
                    least = least.min(depth);
                }
            }
        }
    }
    assert!(
        least.is_finite(),
        "{}: no sphere in view",
        doc.path().display()
    );
    (least, furthest)
}

/// With motion blur, campath's camera where the first frame's shutter opens and where the last
/// frame's closes, with those times in frames (−S/2 and N − 1 + S/2); none without.
pub fn shutter_ends(doc: &Document) -> Vec<(f64, campath::camera::Camera)> {
    let Some(blur) = doc.motion_blur() else {
        return Vec::new();
    };
    let a = doc.animation();
    let last = a.frames - 1;
    [
        (0, -blur.shutter / 2.0),
        (last, last as f64 + blur.shutter / 2.0),
    ]
    .into_iter()
    .map(|(frame, at)| {
        let cam = doc.camera(frame).unwrap();
        let end = a.camera_at(at / a.fps, Some(cam.basis.v)).unwrap();
        (at, end)
    })
    .collect()
}

/// Each frame file's inode and modification time, by name: a frame written again (temporary
/// file and rename) has a new inode.
pub fn frame_stamps(dir: &Path) -> std::collections::BTreeMap<String, (u64, i64, i64)> {
    use std::os::unix::fs::MetadataExt;
    std::fs::read_dir(dir)
        .unwrap()
        .flatten()
        .filter(|e| e.file_name().to_string_lossy().starts_with("frame_"))
        .map(|e| {
            let m = e.metadata().unwrap();
            let name = e.file_name().to_string_lossy().into_owned();
            (name, (m.ino(), m.mtime(), m.mtime_nsec()))
        })
        .collect()
}

/// The spheres of the instanced exports' checks: `n` of them in cloud.csv beside a copy of
/// tests/data/cloud.ron in `dir` (whose path this returns), by the formula of
/// tests/data/cloud.py: the R3 low-discrepancy sequence places them in a cube (side 100 at
/// 100,000), each coloured by its place (red along x, green along y, blue along z), radii 0.2
/// to 0.5. No entropy: the same file on every run.
pub fn cloud(dir: &Path, n: usize) -> PathBuf {
    use std::fmt::Write as _;
    // The plastic number's generalisation for three dimensions (Roberts 2018).
    const G: f64 = 1.2207440846057596;
    let a = [1.0 / G, 1.0 / (G * G), 1.0 / (G * G * G)];
    let side = 100.0 * libm::cbrt(n as f64 / 1e5);
    let mut csv = String::from("x,y,z,radius,r,g,b\n");
    for i in 0..n {
        let u = a.map(|a| (0.5 + a * i as f64) % 1.0);
        let radius = 0.2 + 0.3 * ((0.5 + 0.6180339887498949 * i as f64) % 1.0);
        let [x, y, z] = u.map(|c| (c - 0.5) * side);
        let [r, g, b] = u;
        let _ = writeln!(csv, "{x:.4},{y:.4},{z:.4},{radius:.4},{r:.4},{g:.4},{b:.4}");
    }
    std::fs::write(dir.join("cloud.csv"), csv).unwrap();
    let ron = dir.join("cloud.ron");
    std::fs::copy(root().join("tests/data/cloud.ron"), &ron).unwrap();
    ron
}

/// The `n`-sphere [`cloud`] in `dir` written by `campath path` to `dir/name` (its extension
/// names the format), and the cloud's document.
pub fn cloud_export(dir: &Path, n: usize, name: &str) -> (PathBuf, Document) {
    let ron = cloud(dir, n);
    let out = dir.join(name);
    let o = campath(
        dir,
        &[
            "path",
            ron.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ],
        &[],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    (out, Document::load(&ron).unwrap())
}

/// An executable shell script in `dir` with `body`, standing in for a program a probe runs:
/// its path.
pub fn stand_in(dir: &Path, name: &str, body: &str) -> String {
    use std::os::unix::fs::PermissionsExt;
    let path = dir.join(name);
    std::fs::write(&path, format!("#!/bin/sh\n{body}\n")).unwrap();
    std::fs::set_permissions(&path, std::fs::Permissions::from_mode(0o755)).unwrap();
    path.to_str().unwrap().to_string()
}

/// 100 indices spread over `n` spheres, the first and the last included: the ones whose
/// instances the checks compare with campath's.
pub fn cloud_sample(n: usize) -> Vec<usize> {
    (0..100).map(|k| k * (n - 1) / 99).collect()
}
