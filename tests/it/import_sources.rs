//! `campath import`'s source readers, through the library's `campath::import::read`: campath's
//! own USD and glTF exports read back to the document's cameras, a camera animated in Blender
//! and written by Blender's USD exporter read back to Blender's own matrices, a nerfstudio camera
//! path written here from known matrices, and bad sources refused with exit 2.

use std::path::{Path, PathBuf};
use std::process::Command;

use campath::document::Document;
use campath::import::{fit, read, Sample};
use glam::{DMat4, DVec2, DVec3};

use crate::common::{campath, root, stderr, EXAMPLES};
use crate::usd::{need_module, python};

/// The largest difference between two samples' eyes, bases, windows and shifts, each relative
/// to the size of what it measures (at least 1).
fn difference(got: &Sample, want: &Sample, shift: bool) -> f64 {
    let v = |a: DVec3, b: DVec3| (a - b).length() / b.length().max(1.0);
    let w = |a: DVec2, b: DVec2| (a - b).length() / b.length().max(1.0);
    let (g, e) = (got.basis, want.basis);
    let mut d = [
        v(got.eye, want.eye),
        v(g.u, e.u),
        v(g.v, e.v),
        v(g.n, e.n),
        w(got.window, want.window),
    ]
    .into_iter()
    .fold(0.0, f64::max);
    if shift {
        d = d.max(w(got.shift, want.shift));
    }
    d
}

/// Every frame's camera of `doc`, as samples at its time.
fn document_samples(doc: &Document) -> Vec<Sample> {
    doc.cameras()
        .map(|r| {
            let (k, cam) = r.unwrap();
            Sample::of_camera(doc.animation().time(k), &cam)
        })
        .collect()
}

/// `campath import SOURCE --out imported.ron` in `dir`, as a user runs it: the worst
/// reprojection error (`fit::error`, pixels of the imported file's image) of the imported
/// file's camera at each frame against `want`'s sample at that frame's time, the frame, and the
/// key count the command printed.
fn imported(dir: &Path, source: &Path, want: &[Sample], tolerance: f64) -> (f64, u64, String) {
    let out = dir.join("imported.ron");
    let (source, out_arg) = (source.to_str().unwrap(), out.to_str().unwrap());
    let tolerance = tolerance.to_string();
    let args = [
        "import",
        source,
        "--out",
        out_arg,
        "--tolerance",
        &tolerance,
    ];
    let o = campath(dir, &args, &[]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let doc = Document::load(&out).unwrap();
    let options = fit::Options {
        tolerance: fit::TOLERANCE,
        size: (doc.raster().width, doc.raster().height),
        fps: doc.animation().fps,
        near: 1.0,
    };
    let mut worst = (0.0, 0);
    for item in doc.cameras() {
        let (k, cam) = item.unwrap();
        let t = doc.animation().time(k);
        let w = want
            .iter()
            .find(|w| (w.time - t).abs() < 1e-9)
            .unwrap_or_else(|| panic!("no source camera at frame {k} ({t} s)"));
        let e = fit::error(w, &cam, &options);
        if e > worst.0 {
            worst = (e, k);
        }
    }
    (worst.0, worst.1, crate::common::stdout(&o))
}

/// The worst difference between `want` and the samples of `got` at the same times, to 10 µs
/// (glTF keeps times in f32; a source may have more samples: USD's shutter ends).
fn worst(got: &[Sample], want: &[Sample], shift: bool, what: &str) -> f64 {
    let mut worst = 0.0f64;
    for w in want {
        let g = got
            .iter()
            .find(|g| (g.time - w.time).abs() < 1e-5)
            .unwrap_or_else(|| panic!("{what}: no sample at {} s", w.time));
        worst = worst.max(difference(g, w, shift));
    }
    worst
}

#[test]
fn campaths_own_usd_and_gltf_read_back_to_the_documents_cameras() {
    let tmp = tempfile::tempdir().unwrap();
    let (mut usd_worst, mut usd_lens_worst, mut gltf_worst) = (0.0f64, 0.0f64, 0.0f64);
    for name in EXAMPLES {
        let ron = root().join(format!("animations/{name}.ron"));
        let doc = Document::load(&ron).unwrap();
        let want = document_samples(&doc);
        for (format, ext) in [("usd", "usda"), ("gltf", "gltf"), ("gltf", "glb")] {
            let out = tmp.path().join(format!("{name}.{ext}"));
            let o = campath(
                tmp.path(),
                &["path", ron.to_str().unwrap(), "--format", format, "--out"]
                    .into_iter()
                    .chain([out.to_str().unwrap()])
                    .collect::<Vec<_>>(),
                &[],
            );
            assert!(o.status.success(), "{name}.{ext}: {}", stderr(&o));
            let source = read(&out, None).unwrap_or_else(|e| panic!("{name}.{ext}: {e}"));
            let what = format!("{name}.{ext}");
            if ext == "usda" {
                // Places and turns are double3 and quatd, exact to f64's rounding; the lens is
                // float, as USD's schema has it.
                let exact: Vec<Sample> = want
                    .iter()
                    .map(|w| {
                        let g = source
                            .samples
                            .iter()
                            .find(|g| (g.time - w.time).abs() < 1e-9);
                        Sample {
                            window: g.map_or(w.window, |g| g.window),
                            shift: g.map_or(w.shift, |g| g.shift),
                            ..*w
                        }
                    })
                    .collect();
                let d = worst(&source.samples, &exact, true, &what);
                assert!(d < 1e-9, "{what}: the camera differs by {d:e}");
                usd_worst = usd_worst.max(d);
                let d = worst(&source.samples, &want, true, &what);
                assert!(d < 1e-6, "{what}: the lens differs by {d:e}");
                usd_lens_worst = usd_lens_worst.max(d);
                assert_eq!(source.fps, Some(doc.animation().fps));
                assert_eq!(source.size, Some((doc.raster().width, doc.raster().height)));
            } else {
                // glTF keeps f32, and has no lens shift (distort's is dropped).
                let d = worst(&source.samples, &want, false, &what);
                assert!(d < 1e-6, "{what}: differs by {d:e}");
                gltf_worst = gltf_worst.max(d);
                assert_eq!(source.fps, Some(doc.animation().fps), "{what}");
                assert_eq!(source.samples.len(), want.len(), "{what}");
            }
        }
    }
    eprintln!(
        "worst relative difference: USD camera {usd_worst:e}, USD lens {usd_lens_worst:e}, \
         glTF {gltf_worst:e}"
    );
}

#[test]
fn truncated_exports_are_errors_not_panics() {
    let tmp = tempfile::tempdir().unwrap();
    let ron = root().join("animations/zoom.ron");
    for (format, ext) in [("usd", "usda"), ("gltf", "gltf"), ("gltf", "glb")] {
        let out = tmp.path().join(format!("whole.{ext}"));
        let args = ["path", ron.to_str().unwrap(), "--format", format, "--out"];
        let o = campath(
            tmp.path(),
            &[&args[..], &[out.to_str().unwrap()]].concat(),
            &[],
        );
        assert!(o.status.success(), "{}", stderr(&o));
        let bytes = std::fs::read(&out).unwrap();
        let cut = tmp.path().join(format!("cut.{ext}"));
        let step = (bytes.len() / 150).max(1);
        for end in (0..bytes.len()).step_by(step) {
            std::fs::write(&cut, &bytes[..end]).unwrap();
            let r = std::panic::catch_unwind(|| read(&cut, None));
            assert!(
                matches!(r, Ok(Err(_))),
                "{ext} cut at {end} of {}: {:?}",
                bytes.len(),
                r.map(|r| r.map(|s| s.samples.len()))
            );
        }
    }
}

/// A camera looking along `forward` with `up` above it, at `eye`, as a camera-to-world matrix
/// (its −Z forward, +Y up), in any world.
fn look(eye: DVec3, forward: DVec3, up: DVec3) -> DMat4 {
    let back = -forward.normalize();
    let right = up.cross(back).normalize();
    let above = back.cross(right);
    DMat4::from_cols(
        right.extend(0.0),
        above.extend(0.0),
        back.extend(0.0),
        eye.extend(1.0),
    )
}

/// Z-up (x, y, z) as campath's (x, z, −y).
fn from_z_up(p: DVec3) -> DVec3 {
    DVec3::new(p.x, p.z, -p.y)
}

#[test]
fn a_nerfstudio_camera_path_reads_back_to_its_matrices() {
    let (width, height, seconds) = (640.0, 360.0, 2.5);
    let frames: Vec<(DMat4, f64)> = (0..30)
        .map(|i| {
            let a = i as f64 * 0.2;
            let eye = DVec3::new(3.0 * a.cos(), 3.0 * a.sin(), 1.0 + 0.1 * a);
            let m = look(eye, DVec3::new(0.0, 0.0, 0.5) - eye, DVec3::Z);
            (m, 40.0 + i as f64)
        })
        .collect();
    let camera_path: Vec<serde_json::Value> = frames
        .iter()
        .map(|(m, fov)| {
            // Row by row, as nerfstudio flattens it.
            let rows: Vec<f64> = (0..4).flat_map(|r| m.row(r).to_array()).collect();
            serde_json::json!({"camera_to_world": rows, "fov": fov, "aspect": width / height})
        })
        .collect();
    let json = serde_json::json!({
        "camera_type": "perspective", "render_width": width, "render_height": height,
        "fps": 12, "seconds": seconds, "is_cycle": false, "smoothness_value": 0.5,
        "keyframes": [], "camera_path": camera_path,
    });
    let tmp = tempfile::tempdir().unwrap();
    let file = tmp.path().join("camera_path.json");
    std::fs::write(&file, serde_json::to_vec_pretty(&json).unwrap()).unwrap();
    let source = read(&file, None).unwrap();
    assert_eq!(source.size, Some((640, 360)));
    assert_eq!(source.fps, Some(12.0));
    assert_eq!(source.samples.len(), frames.len());
    let mut worst = 0.0f64;
    let mut wanted = Vec::new();
    for (i, ((m, fov), got)) in frames.iter().zip(&source.samples).enumerate() {
        let tall = 2.0 * (fov.to_radians() / 2.0).tan();
        let col = |k: usize| from_z_up(m.col(k).truncate());
        let want = Sample {
            time: i as f64 / 12.0,
            eye: col(3),
            basis: campath::camera::Basis {
                u: col(0),
                v: col(1),
                n: -col(2),
            },
            window: DVec2::new(tall * width / height, tall),
            shift: DVec2::ZERO,
        };
        assert!(
            (got.time - want.time).abs() < 1e-12,
            "frame {i}: {}",
            got.time
        );
        worst = worst.max(difference(got, &want, true));
        wanted.push(want);
    }
    assert!(worst < 1e-12, "worst difference {worst:e}");
    eprintln!("nerfstudio: worst relative difference {worst:e}");
    // And `campath import` keys it within the tolerance at every frame.
    let (error, frame, said) = imported(tmp.path(), &file, &wanted, fit::TOLERANCE);
    eprintln!("nerfstudio imported: {said}worst {error:.2e} px at frame {frame}");
    assert!(error <= fit::TOLERANCE, "{error} px at frame {frame}");
}

#[test]
#[ignore = "needs Python with bpy (CAMPATH_PYTHON)"]
fn a_camera_made_in_blender_reads_back_to_blenders_matrices() {
    need_module("bpy", "bpy");
    let tmp = tempfile::tempdir().unwrap();
    let script = root().join("tests/data/import/blender_camera.py");
    let o = Command::new(python())
        .arg(&script)
        .arg(tmp.path())
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    let reference: serde_json::Value =
        serde_json::from_slice(&std::fs::read(tmp.path().join("reference.json")).unwrap()).unwrap();
    let source = read(&tmp.path().join("camera.usda"), None).unwrap();
    let fps = reference["fps"].as_f64().unwrap();
    assert_eq!(source.fps, Some(fps));
    let number = |v: &serde_json::Value| v.as_f64().unwrap();
    let pair = |v: &serde_json::Value| DVec2::new(number(&v[0]), number(&v[1]));
    let (resolution, pixel) = (
        pair(&reference["resolution"]),
        pair(&reference["pixel_aspect"]),
    );
    let sensor = pair(&reference["sensor"]);
    let (wide, high) = (resolution.x * pixel.x, resolution.y * pixel.y);
    let fit = reference["sensor_fit"].as_str().unwrap();
    let frames = reference["frames"].as_array().unwrap();
    let first = number(&frames[0]["frame"]);
    let mut worst = 0.0f64;
    let mut wanted = Vec::new();
    for frame in frames {
        let f = number(&frame["frame"]);
        let m: Vec<f64> = (frame["matrix_world"].as_array().unwrap().iter())
            .map(number)
            .collect();
        let m = DMat4::from_cols_slice(&m).transpose();
        let lens = number(&frame["lens"]);
        // Blender's window (its `sensor_fit`): the sensor's width across the wider side (AUTO),
        // across the width (HORIZONTAL), or its height up the height (VERTICAL).
        let horizontal = fit == "HORIZONTAL" || (fit == "AUTO" && wide >= high);
        let window = match (horizontal, fit) {
            (true, _) => DVec2::new(sensor.x / lens, sensor.x / lens * high / wide),
            (false, "AUTO") => DVec2::new(sensor.x / lens * wide / high, sensor.x / lens),
            (false, _) => DVec2::new(sensor.y / lens * wide / high, sensor.y / lens),
        };
        // Blender's shift is in units of the window's larger side.
        let shift = pair(&frame["shift"]) * window.max_element();
        let col = |k: usize| from_z_up(m.col(k).truncate());
        let scale = |k: usize| col(k).length();
        let want = Sample {
            time: (f - first) / fps,
            eye: col(3),
            basis: campath::camera::Basis {
                u: col(0) / scale(0),
                v: col(1) / scale(1),
                n: -col(2) / scale(2),
            },
            window,
            shift,
        };
        let got = source
            .samples
            .iter()
            .find(|s| (s.time - want.time).abs() < 1e-9)
            .unwrap_or_else(|| panic!("no sample at frame {f}"));
        worst = worst.max(difference(got, &want, true));
        wanted.push(want);
    }
    eprintln!(
        "Blender: worst relative difference {worst:e} over {} frames",
        frames.len()
    );
    assert!(worst < 1e-6, "worst difference {worst:e}");
    // And `campath import` keys it so that at every frame campath's camera reprojects within
    // the tolerance of Blender's matrices.
    let camera = tmp.path().join("camera.usda");
    let (error, frame, said) = imported(tmp.path(), &camera, &wanted, fit::TOLERANCE);
    eprintln!("Blender imported: {said}worst {error:.2e} px at frame {frame}");
    assert!(error <= fit::TOLERANCE, "{error} px at frame {frame}");
}

/// A rolled, off-axis, zooming shot (tests/data/roll.ron) through campath's USD and back with
/// `import --tolerance 0.01`: at every frame the imported camera reprojects within 0.01 px of
/// the original, roll included.
#[test]
fn a_rolled_shot_comes_back_from_usd_within_a_hundredth_of_a_pixel() {
    let tmp = tempfile::tempdir().unwrap();
    let shot = root().join("tests/data/roll.ron");
    let want = document_samples(&Document::load(&shot).unwrap());
    let file = tmp.path().join("roll.usda");
    let (shot_arg, file_arg) = (shot.to_str().unwrap(), file.to_str().unwrap());
    let o = campath(tmp.path(), &["path", shot_arg, "--out", file_arg], &[]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let (error, frame, said) = imported(tmp.path(), &file, &want, 0.01);
    eprintln!("roll from USD: {said}worst {error:.2e} px at frame {frame}");
    assert!(error <= 0.01, "{error} px at frame {frame}");
    assert!(said.contains("Roll"), "{said}");
}

/// The bad sources under tests/data/import, each with what its message must say.
const BAD: [(&str, &str); 5] = [
    ("no_camera.usda", "no Camera prim"),
    (
        "two_cameras.usda",
        "several Camera prims: /shot/left, /shot/right",
    ),
    ("scaled_camera.usda", "scaled unevenly"),
    ("truncated.glb", "not a whole GLB"),
    ("missing_column.csv", "no column \"n_y\""),
];

#[test]
fn bad_sources_exit_2_naming_the_problem() {
    let tmp = tempfile::tempdir().unwrap();
    for (file, message) in BAD {
        let path: PathBuf = root().join("tests/data/import").join(file);
        let o = campath(
            tmp.path(),
            &["import", path.to_str().unwrap(), "--out", "out.ron"],
            &[],
        );
        let e = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "{file}: {e}");
        assert!(
            e.contains(message),
            "{file}: {e:?} does not say {message:?}"
        );
        assert!(!Path::new(&tmp.path().join("out.ron")).exists(), "{file}");
    }
}

#[test]
fn a_camera_is_chosen_by_name_or_path() {
    let path = root().join("tests/data/import/two_cameras.usda");
    for name in ["right", "/shot/right"] {
        let source = read(&path, Some(name)).unwrap();
        assert_eq!(source.camera, "/shot/right");
    }
    let e = read(&path, Some("middle")).unwrap_err().to_string();
    assert!(e.contains("/shot/left, /shot/right"), "{e}");
}
