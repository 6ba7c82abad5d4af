//! The peers benchmark (tests/peers) against the real POV-Ray: one frame of the small scene,
//! campath timed over several processes, and the JSON's numbers checked against each other and
//! against the files both programs wrote. `.ci/run` installs povray. The benchmark's own unit
//! tests run here too.

use serde_json::Value;

use crate::common::need_tool;

#[path = "../peers/bench/mod.rs"]
#[allow(dead_code)]
mod peers;

/// The median of `runs` (the lower middle of an even count), as bench keeps it.
fn median(runs: &[Value]) -> f64 {
    let mut ms: Vec<f64> = runs.iter().map(|v| v.as_f64().unwrap()).collect();
    ms.sort_by(f64::total_cmp);
    ms[(ms.len() - 1) / 2]
}

#[test]
#[ignore = "needs povray"]
fn bench_times_campath_over_several_runs_and_povray_once() {
    need_tool("povray", "povray");
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("bench");
    let mut printed = Vec::new();
    let scenes = ["small".to_string()];
    let options = peers::Options {
        pov_frames: 1,
        ovito_frames: 0,
        runs: 4,
        names: &scenes,
        json: true,
        scaling: false,
        keep: false,
    };
    peers::command(&out, &options, &mut printed).unwrap();
    let json: Value = serde_json::from_slice(&printed).unwrap();
    assert_eq!(json["runs"], 4);
    let rows = json["rows"].as_array().unwrap();
    assert_eq!(rows.len(), 1);
    let row = &rows[0];
    assert_eq!(row["scene"]["name"], "small");
    for kind in ["png", "hash"] {
        let run = &row[kind];
        let runs = run["process_ms_runs"].as_array().unwrap();
        assert_eq!(runs.len(), 4, "{kind}: {run}");
        assert!(
            runs.iter().all(|v| v.as_f64().unwrap() > 0.0),
            "{kind}: {run}"
        );
        assert_eq!(run["process_ms_per_frame"].as_f64().unwrap(), median(runs));
        // Four processes, each timed on its own: their times are not one time repeated.
        let first = runs[0].as_f64().unwrap();
        assert!(
            runs.iter().any(|v| v.as_f64().unwrap() != first),
            "{kind}: {run}"
        );
        // The kept run's own wall time lies inside its process's.
        let own = run["wall_ms_per_frame"].as_f64().unwrap();
        assert!(
            own <= run["process_ms_per_frame"].as_f64().unwrap(),
            "{kind}: {run}"
        );
        // The kept run's own numbers: the one frame POV-Ray renders too.
        assert_eq!(run["frames"], 1, "{kind}: {run}");
        assert!(run["median_render_ms"].as_f64().unwrap() > 0.0);
    }
    // POV-Ray's one run: its time a frame and the frame count, and the frame it wrote.
    let pov = row["pov"].as_array().unwrap();
    assert!(pov[0].as_f64().unwrap() > 0.0);
    assert_eq!(pov[1], 1);
    let pov_frames: Vec<_> = std::fs::read_dir(out.join("small-pov"))
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .collect();
    assert_eq!(pov_frames.len(), 1, "{pov_frames:?}");
    let frame = image::open(out.join("small-pov").join(&pov_frames[0])).unwrap();
    assert_eq!((frame.width(), frame.height()), (640, 360));
    // campath's PNG run wrote frame 0 and its hash.
    let ours = image::open(out.join("small").join("frame_0000.png")).unwrap();
    assert_eq!((ours.width(), ours.height()), (640, 360));
    let hashes = std::fs::read_to_string(out.join("small").join("hashes.txt")).unwrap();
    assert_eq!(hashes.lines().filter(|l| !l.starts_with('#')).count(), 1);
}

/// A camera 8 units from the origin looking down −z through a 1.6 × 0.9 window 1 unit from the
/// COP, over three coloured spheres and a ground sphere; the COP at (`u`, `v`, −1).
fn ovito_shot(u: f64, v: f64) -> campath::document::Document {
    let text = format!(
        "(
    frames: 2, fps: 24.0,
    image: (width: 320, height: 180, samples: 1),
    camera: (vrp: (0.0, 0.0, 7.0), vpn: (0.0, 0.0, -1.0), vuv: (0.0, 1.0, 0.0), cop: ({u:?}, {v:?}, -1.0), window: (1.6, 0.9)),
    scene: (
        background: (0.35, 0.45, 0.65), ambient: 0.15,
        lights: [(direction: (-0.6, -1.0, 0.4), color: (0.9, 0.9, 0.85))],
        spheres: [
            (center: (0.0, 0.0, 0.0), radius: 1.0, color: (1.0, 0.0, 0.0)),
            (center: (2.0, 0.0, 0.0), radius: 0.5, color: (0.0, 1.0, 0.0)),
            (center: (0.0, 1.5, 0.0), radius: 0.3, color: (0.0, 0.0, 1.0)),
            (center: (0.0, -101.0, 0.0), radius: 100.0, color: (0.5, 0.5, 0.5)),
        ],
    ),
)"
    );
    campath::document::Document::from_str(std::path::Path::new("ovito.ron"), &text).unwrap()
}

/// OVITO's viewport is the notes' camera: position the COP, direction VRP − COP, up the VUV,
/// vertical field of view 2·atan(half the window's height over the COP's distance); the spheres
/// go as seven f64 values each; a COP off the axis is refused, naming the frame.
#[test]
fn ovito_gets_the_cop_the_axis_and_the_windows_field_of_view() {
    let shot = peers::ovito::shot(&ovito_shot(0.0, 0.0), 8).unwrap();
    assert_eq!(
        (shot["width"].clone(), shot["height"].clone()),
        (320.into(), 180.into())
    );
    let cameras = shot["cameras"].as_array().unwrap();
    assert_eq!(cameras.len(), 2);
    let v = |c: &Value, k: &str| -> Vec<f64> {
        c[k].as_array()
            .unwrap()
            .iter()
            .map(|x| x.as_f64().unwrap())
            .collect()
    };
    assert_eq!(v(&cameras[0], "position"), [0.0, 0.0, 8.0]);
    assert_eq!(v(&cameras[0], "direction"), [0.0, 0.0, -1.0]);
    assert_eq!(v(&cameras[0], "up"), [0.0, 1.0, 0.0]);
    let fov = cameras[0]["fov"].as_f64().unwrap();
    // 2·atan(0.45), from Python's math.atan.
    assert!((fov - 0.845_707_852_265_881_4).abs() < 1e-12, "{fov}");
    let bytes = peers::ovito::sphere_bytes(&ovito_shot(0.0, 0.0));
    assert_eq!(bytes.len(), 4 * 7 * 8);
    let at = |k: usize| f64::from_le_bytes(bytes[k * 8..k * 8 + 8].try_into().unwrap());
    assert_eq!(
        [7, 8, 9, 10, 11, 12, 13].map(at),
        [2.0, 0.0, 0.0, 0.5, 0.0, 1.0, 0.0]
    );
    let refused = peers::ovito::shot(&ovito_shot(0.1, 0.0), 8).unwrap_err();
    assert!(
        refused
            .to_string()
            .contains("frame 0's COP is off the view axis"),
        "{refused}"
    );
}

/// Each pixel of an RGB8 image: whether it differs from the top-left (background) pixel.
fn not_background(rgb: &[u8]) -> Vec<bool> {
    let bg = &rgb[..3];
    rgb.chunks(3)
        .map(|p| p.iter().zip(bg).any(|(a, b)| a.abs_diff(*b) > 6))
        .collect()
}

/// Each pixel: whether it is red (the large sphere), whatever the shading.
fn red(rgb: &[u8]) -> Vec<bool> {
    rgb.chunks(3)
        .map(|p| p[0] > 40 && p[0] as u32 > 2 * (p[1] as u32 + p[2] as u32))
        .collect()
}

/// The count and centroid of a mask `width` pixels wide.
fn centroid(mask: &[bool], width: usize) -> (usize, f64, f64) {
    let (mut n, mut x, mut y) = (0, 0.0, 0.0);
    for (k, _) in mask.iter().enumerate().filter(|(_, m)| **m) {
        n += 1;
        x += (k % width) as f64;
        y += (k / width) as f64;
    }
    (n, x / n as f64, y / n as f64)
}

/// OVITO's Tachyon and OSPRay see the scene where campath does: the pixels that are not sky agree
/// (the horizon and the spheres' edges), and the large red sphere has campath's area and
/// centre, within a pixel.
#[test]
#[ignore = "needs OVITO (PyPI ovito, CAMPATH_OVITO_PYTHON)"]
fn ovito_renders_campaths_geometry() {
    let tmp = tempfile::tempdir().unwrap();
    let doc = ovito_shot(0.0, 0.0);
    let ours = campath::frames::render_frame(&doc, 0).unwrap();
    let scene = peers::scaling_scenes().into_iter().next().unwrap();
    let scene = peers::BenchScene {
        name: "geometry".into(),
        ..scene
    };
    peers::ovito::check().unwrap();
    let renderers = [
        peers::ovito::Renderer::Tachyon,
        peers::ovito::Renderer::Ospray,
    ];
    let times = peers::ovito::time(tmp.path(), &scene, &doc, 1, &renderers).unwrap();
    // The spheres and cameras handed to OVITO are gone after its runs.
    assert!(!tmp.path().join("geometry.ovito.f64").exists());
    for (renderer, ms) in renderers.into_iter().zip(times) {
        assert!(ms > 0.0);
        let dir = peers::ovito::frames_dir(tmp.path(), "geometry", renderer);
        let theirs = image::open(dir.join("0000.png")).unwrap().to_rgb8();
        assert_eq!(theirs.dimensions(), (320, 180), "{renderer:?}");
        let theirs = theirs.into_raw();
        let (a, b) = (not_background(&ours), not_background(&theirs));
        let agree = a.iter().zip(&b).filter(|(x, y)| x == y).count() as f64 / a.len() as f64;
        let (n, x, y) = centroid(&red(&ours), 320);
        let (m, u, v) = centroid(&red(&theirs), 320);
        eprintln!("{renderer:?}: {ms:.0} ms, {agree:.4} agree; red {n} at ({x:.2}, {y:.2}), theirs {m} at ({u:.2}, {v:.2})");
        assert!(agree > 0.99, "{renderer:?}: {agree}");
        assert!(
            (n as f64 / m as f64 - 1.0).abs() < 0.03,
            "{renderer:?}: {n} {m}"
        );
        assert!((x - u).abs() < 1.0 && (y - v).abs() < 1.0, "{renderer:?}");
    }
}
