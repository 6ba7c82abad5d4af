//! Blender, for real: the script of `campath path --format blender`, run headless, gives a
//! camera that projects test points where campath's does (to 0.01 px at every frame, distort
//! included), and the glTF of `--format gltf`, imported by Blender's own importer, puts the camera
//! where campath puts it (to 1e-5). Both are Z-up: campath's (x, y, z) is Blender's (x, −z, y),
//! the glTF importer's convention, converted here by [`z_up`] and [`from_z_up`]. Both number
//! campath's frame k as Blender's frame k + N (`--first-frame N`). The script's scene has
//! campath's motion blur: on with the shutter and centred on the frame where the file has it,
//! off where not.

use std::path::PathBuf;
use std::process::Command;

use campath::document::Document;
use glam::DVec3;

use crate::common::{
    blender_lacks_module, campath, cloud, cloud_export, cloud_sample, export_edge_shots, need_part,
    need_tool, reach_of_views, root, shutter_ends, stderr, EXAMPLES,
};

/// Runs every job in one Blender process: build the shot from the script and record
/// `world_to_camera_view` of the points at every frame; then import the glTF and record the
/// camera's world matrix at every frame.
const CHECK: &str = r#"
import bpy, json, sys
import numpy
if not hasattr(numpy, "bool"):
    numpy.bool = bool  # Debian's Blender 3.4 glTF importer predates NumPy 1.24
from bpy_extras.object_utils import world_to_camera_view
from mathutils import Vector
jobs = json.load(open(sys.argv[sys.argv.index("--") + 1]))
for job in jobs:
    bpy.ops.wm.read_factory_settings(use_empty=True)
    exec(compile(open(job["script"]).read(), job["script"], "exec"), {"__name__": "__main__"})
    scene = bpy.context.scene
    camera = scene.camera
    positions = [s.motion_blur_position for s in (scene.render, getattr(scene, "cycles", None), getattr(scene, "eevee", None))
                 if s is not None and hasattr(s, "motion_blur_position")]
    blur = {"use": scene.render.use_motion_blur, "shutter": scene.render.motion_blur_shutter, "positions": positions}
    projections = []
    frames = [scene.frame_start, scene.frame_end]
    for frame in range(scene.frame_start, scene.frame_end + 1):
        scene.frame_set(frame)
        projections.append([list(world_to_camera_view(scene, camera, Vector(p))) for p in job["points"]])
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.import_scene.gltf(filepath=job["glb"])
    scene = bpy.context.scene
    camera = [o for o in bpy.data.objects if o.type == "CAMERA"][0]
    poses = []
    for frame in range(frames[0], frames[0] + len(projections)):
        scene.frame_set(frame)
        m = camera.matrix_world
        poses.append([[m[r][c] for c in range(4)] for r in range(3)])
    json.dump({"projections": projections, "poses": poses, "blur": blur, "frames": frames}, open(job["out"], "w"))
"#;

#[test]
#[ignore = "needs blender with numpy"]
fn blender_sees_what_campath_renders() {
    // Debian's blender does not pull in NumPy, which its glTF importer needs.
    need_part("blender", "blender", |b| {
        blender_lacks_module(b, "numpy", "python3-numpy")
    });
    let tmp = tempfile::tempdir().unwrap();
    // Every example, and the observer at 640×480 (another aspect than the 16:9 film back that
    // Blender's .chan importer assumes).
    let observer = std::fs::read_to_string(root().join("animations/observer.ron")).unwrap();
    let four_three = observer.replace("width: 640, height: 360", "width: 640, height: 480");
    assert_ne!(four_three, observer);
    std::fs::write(tmp.path().join("observer_4_3.ron"), four_three).unwrap();
    // And the observer 2e6 from the origin, written relative to a point near it (`--origin`):
    // in f32 without it, Blender's camera would be pixels off.
    std::fs::write(tmp.path().join("observer_far.ron"), far_away(&observer)).unwrap();
    let mut names: Vec<&str> = EXAMPLES.to_vec();
    // And the track example numbered from 1001, a studio's first frame: the script's scene
    // frames and the glTF's times (in Blender's importer) both start there.
    // And a rolled camera, which the script and the glTF must carry.
    names.extend(["observer_4_3", "observer_far", "track_1001", "roll"]);
    let file_of = |name: &str| match name {
        "observer_4_3" | "observer_far" => tmp.path().join(format!("{name}.ron")),
        "track_1001" => root().join("animations/track.ron"),
        "roll" => root().join("tests/data/roll.ron"),
        _ => root().join(format!("animations/{name}.ron")),
    };
    let first_of = |name: &str| match name {
        "track_1001" => 1001,
        _ => 0,
    };
    let origin_of = |name: &str| match name {
        "observer_far" => DVec3::new(FAR, 1.0, -3.0),
        _ => DVec3::ZERO,
    };
    let doc_of = |name: &str| campath::document::Document::load(&file_of(name)).unwrap();
    let (mut jobs, mut points_of) = (Vec::new(), Vec::new());
    for name in &names {
        let file = file_of(name);
        let script = tmp.path().join(format!("{name}.py"));
        let glb = tmp.path().join(format!("{name}.glb"));
        let o = origin_of(name);
        let origin = format!("{},{},{}", o.x, o.y, o.z);
        for (format, out) in [("blender", &script), ("gltf", &glb)] {
            let o = campath(
                tmp.path(),
                &[
                    "path",
                    file.to_str().unwrap(),
                    "--format",
                    format,
                    "--out",
                    out.to_str().unwrap(),
                    "--origin",
                    &origin,
                    "--first-frame",
                    &first_of(name).to_string(),
                ],
                &[],
            );
            assert!(o.status.success(), "{}", stderr(&o));
            assert!(!stderr(&o).contains("warning"), "{name}: {}", stderr(&o));
        }
        // Test points: each small sphere's centre, and points a unit away from it, in
        // campath's world.
        let doc = doc_of(name);
        let points: Vec<DVec3> = doc
            .scene()
            .spheres
            .iter()
            .filter(|s| s.radius < 50.0)
            .flat_map(|s| {
                [DVec3::ZERO, DVec3::X, DVec3::NEG_Y, DVec3::Z].map(|d| s.center_world + d)
            })
            .collect();
        // Blender's are where the files put them: relative to the origin, Z-up.
        let blender: Vec<[f64; 3]> = points.iter().map(|&p| z_up(p - o).to_array()).collect();
        jobs.push(serde_json::json!({
            "script": script, "glb": glb, "points": blender,
            "out": tmp.path().join(format!("{name}.json")),
        }));
        points_of.push(points);
    }
    run_blender(tmp.path(), CHECK, &jobs);

    for (name, points) in names.iter().zip(&points_of) {
        let doc = doc_of(name);
        let origin = origin_of(name);
        let result: serde_json::Value = serde_json::from_str(
            &std::fs::read_to_string(tmp.path().join(format!("{name}.json"))).unwrap(),
        )
        .unwrap();
        // campath's frame k is the scene's frame k + N.
        let (first, frames) = (first_of(name), doc.animation().frames);
        assert_eq!(
            result["frames"],
            serde_json::json!([first, first + frames - 1]),
            "{name}"
        );
        let blur = &result["blur"];
        match doc.motion_blur() {
            Some(b) => {
                assert_eq!(blur["use"], true, "{name}: {blur}");
                let shutter = blur["shutter"].as_f64().unwrap();
                assert!((shutter - b.shutter).abs() < 1e-6, "{name}: {blur}");
                let positions = blur["positions"].as_array().unwrap();
                assert!(!positions.is_empty(), "{name}: {blur}");
                assert!(positions.iter().all(|p| p == "CENTER"), "{name}: {blur}");
                eprintln!("blender {name}: motion blur {blur}");
            }
            None => assert_eq!(blur["use"], false, "{name}: {blur}"),
        }
        let (w, h) = (doc.raster().width as f64, doc.raster().height as f64);
        let mut worst = (0.0f64, 0.0f64);
        let mut compared = 0;
        for (k, item) in doc.cameras().enumerate() {
            let cam = item.unwrap().1;
            // campath's projection: through the COP onto the view plane n = 0, window to pixels.
            for (i, &p) in points.iter().enumerate() {
                let v = cam.world_to_view().transform_point3(p);
                let c = cam.cop_view;
                if v.z - c.z < 0.5 {
                    continue; // behind or close to the COP
                }
                let s = -c.z / (v.z - c.z);
                let (x, y) = (c.x + (v.x - c.x) * s, c.y + (v.y - c.y) * s);
                let px = (x + cam.window.x / 2.0) / cam.window.x * w;
                let py = (cam.window.y / 2.0 - y) / cam.window.y * h;
                if !(0.0..=w).contains(&px) || !(0.0..=h).contains(&py) {
                    continue; // the points the frame shows
                }
                let b = &result["projections"][k][i];
                let (bx, by) = (
                    b[0].as_f64().unwrap() * w,
                    (1.0 - b[1].as_f64().unwrap()) * h,
                );
                worst.0 = worst.0.max((px - bx).abs().max((py - by).abs()));
                compared += 1;
            }
            // The imported glTF camera, in Blender's Z-up world.
            let m = &result["poses"][k];
            let col = |c: usize| {
                let g = |r: usize| m[r][c].as_f64().unwrap();
                from_z_up(DVec3::new(g(0), g(1), g(2)))
            };
            let b = cam.basis;
            for (got, want) in [
                (col(3), cam.cop_world() - origin),
                (col(0), b.u),
                (col(1), b.v),
                (col(2), -b.n),
            ] {
                worst.1 = worst
                    .1
                    .max((got - want).abs().max_element() / want.length().max(1.0));
            }
        }
        eprintln!(
            "blender {name}: {compared} projections, worst {:.2e} px; glTF camera worst {:.1e}",
            worst.0, worst.1
        );
        assert!(compared > 100, "{name}: {compared}");
        assert!(
            worst.0 < 0.01,
            "{name}: Blender's projection is {} px off",
            worst.0
        );
        assert!(
            worst.1 < 1e-5,
            "{name}: the imported glTF camera is {} off",
            worst.1
        );
    }
}

/// campath's point (x, y, z) in Blender's Z-up world, as Blender's glTF importer places a
/// Y-up file: (x, −z, y).
fn z_up(p: DVec3) -> DVec3 {
    DVec3::new(p.x, -p.z, p.y)
}

/// Blender's point back in campath's Y-up world: the inverse of [`z_up`].
fn from_z_up(p: DVec3) -> DVec3 {
    DVec3::new(p.x, p.z, -p.y)
}

/// How far `far_away` moves a shot along x.
const FAR: f64 = 2.0e6;

/// `text` (a keyframe file) with every keyed value and sphere centre moved `FAR` along x.
fn far_away(text: &str) -> String {
    let mut out = String::new();
    let mut rest = text;
    while let Some(at) = ["value: (", "center: ("]
        .iter()
        .filter_map(|tag| rest.find(tag).map(|i| i + tag.len()))
        .min()
    {
        let (head, tail) = rest.split_at(at);
        let end = tail.find(',').unwrap();
        let x: f64 = tail[..end].trim().parse().unwrap();
        out.push_str(head);
        out.push_str(&format!("{:?}", x + FAR));
        rest = &tail[end..];
    }
    out.push_str(rest);
    out
}

/// Without `--origin`, the far shot's exports warn that f32 moves the camera (USD for Blender's
/// importer), and name an origin near it; with it, they do not (Blender's check of that is
/// above). An origin past f32's range is refused; CSV says it cannot record one.
#[test]
fn a_shot_far_from_the_origin_is_warned_of_and_kept_by_an_origin_near_it() {
    let tmp = tempfile::tempdir().unwrap();
    let observer = std::fs::read_to_string(root().join("animations/observer.ron")).unwrap();
    std::fs::write(tmp.path().join("far.ron"), far_away(&observer)).unwrap();
    for format in ["gltf", "blender"] {
        let o = campath(tmp.path(), &["path", "far.ron", "--format", format], &[]);
        assert!(o.status.success(), "{}", stderr(&o));
        let e = stderr(&o);
        assert!(e.contains("keeps places in f32"), "{e}");
        assert!(e.contains("--origin 2000000,2,-6 (the middle"), "{e}");
        let o = campath(
            tmp.path(),
            &[
                "path",
                "far.ron",
                "--format",
                format,
                "--origin=2000000,2,-6",
            ],
            &[],
        );
        assert!(
            o.status.success() && !stderr(&o).contains("warning"),
            "{}",
            stderr(&o)
        );
    }
    // USD keeps f64, but Blender's USD importer rounds to f32: a warning of its own.
    let o = campath(tmp.path(), &["path", "far.ron", "--format", "usd"], &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("USD keeps f64, but Blender's USD importer keeps places in f32"),
        "{}",
        stderr(&o)
    );
    // An origin that puts places past f32's range is refused before anything is written; the
    // formats that cannot record an origin say so.
    for (format, out) in [("gltf", "x.glb"), ("blender", "x.py")] {
        let o = campath(
            tmp.path(),
            &[
                "path",
                "far.ron",
                "--format",
                format,
                "--origin=-1e300,0,0",
                "--out",
                out,
            ],
            &[],
        );
        assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
        assert!(
            stderr(&o).contains("lies past f32's range"),
            "{}",
            stderr(&o)
        );
        assert!(!tmp.path().join(out).exists());
    }
    let o = campath(
        tmp.path(),
        &[
            "path",
            "far.ron",
            "--format",
            "csv",
            "--origin",
            "2000000,2,-6",
        ],
        &[],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("CSV has no place to record --origin"),
        "{}",
        stderr(&o)
    );
    // The examples, near the origin: no warning.
    for name in EXAMPLES {
        let file = root().join(format!("animations/{name}.ron"));
        let o = campath(
            tmp.path(),
            &["path", file.to_str().unwrap(), "--format", "gltf"],
            &[],
        );
        assert!(
            o.status.success() && !stderr(&o).contains("warning"),
            "{name}: {}",
            stderr(&o)
        );
    }
}

/// For every job: build the shot from the script, then record the camera's field of view, lens
/// and clipping range, and at each of the job's scene frames (fractional: the shutter's ends)
/// its position, lens and shift.
const CHECK_EDGES: &str = r#"
import bpy, json, math, sys
jobs = json.load(open(sys.argv[sys.argv.index("--") + 1]))
for job in jobs:
    bpy.ops.wm.read_factory_settings(use_empty=True)
    exec(compile(open(job["script"]).read(), job["script"], "exec"), {"__name__": "__main__"})
    scene = bpy.context.scene
    camera = scene.camera
    data = camera.data
    result = {"angle_x": data.angle_x, "sensor": data.sensor_width, "clip": [data.clip_start, data.clip_end], "ends": []}
    for f in job["frames"]:
        whole = math.floor(f)
        scene.frame_set(whole, subframe=f - whole)
        result["ends"].append({"position": list(camera.matrix_world.translation), "lens": data.lens,
                               "shift": [data.shift_x, data.shift_y]})
    json.dump(result, open(job["out"], "w"))
"#;

/// The Blender script keeps cameras that Blender's limits would change: a 176° field of view
/// (a lens under Blender's least, 1 mm, on a 36 mm sensor), a camera 1.8e6 from its spheres
/// and a sphere 0.2 in front of the eye (the clipping range), and a blurred shot's camera where
/// the first frame's shutter opens and the last's closes (the motion-blur example, and one frame
/// that zooms and shifts in its shutter), there as campath's.
#[test]
#[ignore = "needs blender"]
fn blender_keeps_wide_far_near_and_blurred_cameras() {
    need_tool("blender", "blender");
    let tmp = tempfile::tempdir().unwrap();
    let shots = export_edge_shots(tmp.path(), "py");
    let jobs = edge_jobs(tmp.path(), &shots);
    run_blender(tmp.path(), CHECK_EDGES, &jobs);
    assert_edges(&shots, &jobs);
}

/// The same in Blender 5 (PyPI's bpy), whose actions keep their F-curves in slots.
#[test]
#[ignore = "needs Python with bpy (CAMPATH_PYTHON)"]
fn blender_5_builds_the_same_cameras_from_the_script() {
    crate::usd::need_module("bpy", "bpy");
    let tmp = tempfile::tempdir().unwrap();
    let shots = export_edge_shots(tmp.path(), "py");
    let jobs = edge_jobs(tmp.path(), &shots);
    std::fs::write(tmp.path().join("check.py"), CHECK_EDGES).unwrap();
    std::fs::write(
        tmp.path().join("jobs.json"),
        serde_json::to_string(&jobs).unwrap(),
    )
    .unwrap();
    let o = Command::new(crate::usd::python())
        .current_dir(tmp.path())
        .args(["check.py", "--", "jobs.json"])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert_edges(&shots, &jobs);
}

/// The jobs of [`CHECK_EDGES`] for `shots`: each script, the scene frames of its shutter's ends,
/// and where its result goes.
fn edge_jobs(
    dir: &std::path::Path,
    shots: &[(&'static str, PathBuf, Document)],
) -> Vec<serde_json::Value> {
    shots
        .iter()
        .map(|(name, script, doc)| {
            // Scene frame k is campath frame k (no --first-frame).
            let frames: Vec<f64> = shutter_ends(doc).iter().map(|&(t, _)| t).collect();
            serde_json::json!({
                "script": script, "frames": frames,
                "out": dir.join(format!("{name}.json")),
            })
        })
        .collect()
}

/// What [`CHECK_EDGES`] recorded is campath's camera.
fn assert_edges(shots: &[(&'static str, PathBuf, Document)], jobs: &[serde_json::Value]) {
    // campath's horizontal field of view in radians.
    let angle = |cam: &campath::camera::Camera| 2.0 * (cam.window.x / 2.0 / -cam.cop_view.z).atan();
    let mut ends = 0;
    for ((name, _, doc), job) in shots.iter().zip(jobs) {
        let text = std::fs::read_to_string(job["out"].as_str().unwrap()).unwrap();
        let r: serde_json::Value = serde_json::from_str(&text).unwrap();
        let f = |v: &serde_json::Value| v.as_f64().unwrap();
        // Scene frame 0, campath's frame 0, is the scene's frame after the script.
        let first = doc.camera(0).unwrap();
        let angle_x = f(&r["angle_x"]);
        assert!(
            (angle_x - angle(&first)).abs() < 1e-6 * angle(&first),
            "{name}: Blender's field of view {} against campath's {}",
            angle_x.to_degrees(),
            angle(&first).to_degrees()
        );
        let (near, far) = (f(&r["clip"][0]), f(&r["clip"][1]));
        let (least, furthest) = reach_of_views(doc);
        assert!(
            near < least && far > furthest,
            "{name}: clipping range {near}..{far}, spheres from {least} to {furthest}"
        );
        let sensor = f(&r["sensor"]);
        for (got, (t, cam)) in r["ends"].as_array().unwrap().iter().zip(shutter_ends(doc)) {
            let p = &got["position"];
            let position = from_z_up(DVec3::new(f(&p[0]), f(&p[1]), f(&p[2])));
            let want = cam.cop_world();
            assert!(
                (position - want).abs().max_element() < 1e-6 * want.length().max(1.0),
                "{name} at {t}: Blender's camera at {position}, campath's at {want}"
            );
            let lens_angle = 2.0 * (sensor / 2.0 / f(&got["lens"])).atan();
            assert!(
                (lens_angle - angle(&cam)).abs() < 1e-6 * angle(&cam),
                "{name} at {t}: {got}"
            );
            let shift = [
                -cam.cop_view.x / cam.window.x,
                -cam.cop_view.y / cam.window.x,
            ];
            for (a, b) in got["shift"].as_array().unwrap().iter().zip(shift) {
                assert!((f(a) - b).abs() < 1e-6, "{name} at {t}: {got}");
            }
            ends += 1;
        }
    }
    // The two blurred shots' two ends each.
    assert_eq!(ends, 4);
}

/// Runs `script` in one headless Blender in `dir` (as `check.py`, with the jobs in `jobs.json`
/// after `--`), and fails with Blender's output if it does.
fn run_blender(dir: &std::path::Path, script: &str, jobs: &[serde_json::Value]) {
    std::fs::write(dir.join("check.py"), script).unwrap();
    std::fs::write(dir.join("jobs.json"), serde_json::to_string(jobs).unwrap()).unwrap();
    let o = Command::new("blender")
        .current_dir(dir)
        .args([
            "--background",
            "--factory-startup",
            "--python-exit-code",
            "1",
        ])
        .arg("--python")
        .arg(dir.join("check.py"))
        .arg("--")
        .arg(dir.join("jobs.json"))
        .output()
        .unwrap();
    assert!(
        o.status.success(),
        "blender: {}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
}

/// Runs the cloud's script, timed (Blender's own start aside), then records the camera at every
/// scene frame, the instances the geometry nodes make (each one's place and scale), the cloud's
/// `radius` and `color` attributes at the sampled spheres, what the one material reads, and what
/// the instanced mesh is made of.
const CHECK_CLOUD: &str = r#"
import bpy, json, sys, time
job, = json.load(open(sys.argv[sys.argv.index("--") + 1]))
start = time.perf_counter()
exec(compile(open(job["script"]).read(), job["script"], "exec"), {"__name__": "__main__"})
seconds = time.perf_counter() - start
scene = bpy.context.scene
camera = scene.camera
frames = []
for frame in range(scene.frame_start, scene.frame_end + 1):
    scene.frame_set(frame)
    m = camera.matrix_world
    frames.append({"matrix": [[m[r][c] for c in range(4)] for r in range(3)], "lens": camera.data.lens,
                   "sensor": camera.data.sensor_width})
scene.frame_set(scene.frame_start)
cloud = bpy.data.objects["campath spheres"]
depsgraph = bpy.context.evaluated_depsgraph_get()
instances, meshes = [], {}
for i in depsgraph.object_instances:
    if i.is_instance and i.parent.original == cloud:
        m = i.matrix_world
        instances.append((list(m.translation), list(m.to_scale())))
        data = i.object.data
        if data.name not in meshes:
            # Each instanced mesh once: its vertices, and the materials its faces are in.
            used = {data.materials[p.material_index] for p in data.polygons}
            meshes[data.name] = (len(data.vertices), sorted(m.name if m else "" for m in used))
mesh = cloud.data
sample = job["sample"]
spheres = [{"centre": list(mesh.vertices[i].co), "radius": mesh.attributes["radius"].data[i].value,
            "colour": list(mesh.attributes["color"].data[i].color), "instance": instances[i]} for i in sample]
material = bpy.data.materials["campath spheres"]
reads = [(n.attribute_type, n.attribute_name, [l.to_socket.name for l in n.outputs["Color"].links])
         for n in material.node_tree.nodes if n.type == "ATTRIBUTE"]
json.dump({"seconds": seconds, "frames": frames, "instances": len(instances), "meshes": list(meshes.values()),
           "spheres": spheres, "reads": reads, "objects": len(bpy.data.objects),
           "materials": [m.name for m in bpy.data.materials]}, open(job["out"], "w"))
"#;

/// The Blender script of 100,000 spheres opens in Blender (3.4, Debian's) as one instanced
/// sphere: an instance each, where campath has the sphere, of its radius, its colour in the
/// attribute the one material reads, and the camera campath's at every frame. How long the
/// script takes is printed, not asserted (docs/performance.md has the figures).
#[test]
#[ignore = "needs blender"]
fn blender_opens_100k_spheres_as_instances_where_campath_has_them() {
    need_tool("blender", "blender");
    let tmp = tempfile::tempdir().unwrap();
    let (job, doc) = cloud_job(tmp.path());
    let started = std::time::Instant::now();
    run_blender(tmp.path(), CHECK_CLOUD, std::slice::from_ref(&job));
    let whole = started.elapsed().as_secs_f64();
    assert_cloud("blender 3.4", &job, &doc, whole);
}

/// The same in Blender 5 (PyPI's bpy), whose node groups declare their sockets otherwise.
#[test]
#[ignore = "needs Python with bpy (CAMPATH_PYTHON)"]
fn blender_5_opens_100k_spheres_as_instances_where_campath_has_them() {
    crate::usd::need_module("bpy", "bpy");
    let tmp = tempfile::tempdir().unwrap();
    let (job, doc) = cloud_job(tmp.path());
    std::fs::write(tmp.path().join("check.py"), CHECK_CLOUD).unwrap();
    std::fs::write(tmp.path().join("jobs.json"), format!("[{job}]")).unwrap();
    let started = std::time::Instant::now();
    let o = Command::new(crate::usd::python())
        .current_dir(tmp.path())
        .args(["check.py", "--", "jobs.json"])
        .output()
        .unwrap();
    let whole = started.elapsed().as_secs_f64();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert_cloud("blender 5 (bpy)", &job, &doc, whole);
}

/// The 100,000-sphere cloud's script in `dir`, and the job of [`CHECK_CLOUD`] for it, which
/// reads a list of one job.
fn cloud_job(dir: &std::path::Path) -> (serde_json::Value, Document) {
    let (script, doc) = cloud_export(dir, 100_000, "cloud.py");
    let job = serde_json::json!({
        "script": script, "sample": cloud_sample(doc.scene().spheres.len()),
        "out": dir.join("cloud.json"),
    });
    (job, doc)
}

/// What [`CHECK_CLOUD`] recorded is campath's shot: `whole` the seconds Blender ran in all.
fn assert_cloud(blender: &str, job: &serde_json::Value, doc: &Document, whole: f64) {
    let text = std::fs::read_to_string(job["out"].as_str().unwrap()).unwrap();
    let r: serde_json::Value = serde_json::from_str(&text).unwrap();
    let f = |v: &serde_json::Value| v.as_f64().unwrap();
    let v3 = |v: &serde_json::Value| DVec3::new(f(&v[0]), f(&v[1]), f(&v[2]));
    // A place in Blender's Z-up world, back in campath's.
    let place = |v: &serde_json::Value| from_z_up(v3(v));
    let spheres = &doc.scene().spheres;
    eprintln!(
        "{blender}: {} spheres, the script ran in {:.2} s, Blender in {whole:.2} s in all",
        spheres.len(),
        f(&r["seconds"])
    );
    // One object for the spheres, the camera and a sun; one material for every sphere (beside
    // the factory start-up's own, "Material", "Dots Stroke" and others).
    assert_eq!(r["objects"], 3);
    let materials: Vec<&str> = (r["materials"].as_array().unwrap().iter())
        .filter_map(|m| m.as_str().filter(|&m| m.contains("sphere")))
        .collect();
    assert_eq!(materials, ["campath spheres"]);
    assert_eq!(r["instances"], spheres.len());
    // Every instance is the one smooth sphere of radius 1 (32 × 16: 482 vertices) in the one
    // material, whose base colour is the instance's `color`.
    assert_eq!(r["meshes"], serde_json::json!([[482, ["campath spheres"]]]));
    assert_eq!(
        r["reads"],
        serde_json::json!([["INSTANCER", "color", ["Base Color"]]])
    );
    // f32, as Blender keeps them: to its rounding.
    let close = |a: DVec3, b: DVec3| (a - b).abs().max_element() <= 1e-6 * b.length().max(1.0);
    for (got, i) in r["spheres"]
        .as_array()
        .unwrap()
        .iter()
        .zip(job["sample"].as_array().unwrap())
    {
        let want = spheres.get(i.as_u64().unwrap() as usize);
        let (at, scale) = (place(&got["instance"][0]), v3(&got["instance"][1]));
        assert!(
            close(place(&got["centre"]), want.center_world),
            "sphere {i}: {got}"
        );
        assert!(close(at, want.center_world), "sphere {i}: {got}");
        assert!(close(scale, DVec3::splat(want.radius)), "sphere {i}: {got}");
        assert!((f(&got["radius"]) - want.radius).abs() <= 1e-6 * want.radius);
        assert!(close(v3(&got["colour"]), want.color), "sphere {i}: {got}");
        assert_eq!(got["colour"][3], 1.0);
    }
    // The camera at every scene frame k is campath's frame k: at the COP, with axes u, v, −n
    // (turned Z-up), and the lens that sees the window's width.
    let frames = r["frames"].as_array().unwrap();
    assert_eq!(frames.len() as u64, doc.animation().frames);
    for (k, item) in doc.cameras().enumerate() {
        let cam = item.unwrap().1;
        let m = &frames[k]["matrix"];
        let col = |c: usize| from_z_up(DVec3::new(f(&m[0][c]), f(&m[1][c]), f(&m[2][c])));
        let b = cam.basis;
        for (got, want) in [
            (col(3), cam.cop_world()),
            (col(0), b.u),
            (col(1), b.v),
            (col(2), -b.n),
        ] {
            assert!(
                (got - want).abs().max_element() <= 1e-5 * want.length().max(1.0),
                "{blender} frame {k}: {got} against {want}"
            );
        }
        let lens = f(&frames[k]["lens"]) / f(&frames[k]["sensor"]);
        let want = -cam.cop_view.z / cam.window.x;
        assert!(
            (lens - want).abs() <= 1e-6 * want,
            "frame {k}: {lens} against {want}"
        );
    }
}

/// Runs the cloud's script with `REALIZE = True` and records the one mesh it leaves: its
/// vertices a sphere, its active colour attribute, what Workbench colours by and what the
/// material reads, and for the sampled spheres the mean of their vertices and their colour.
const CHECK_REALIZED: &str = r#"
import bpy, json, sys
job, = json.load(open(sys.argv[sys.argv.index("--") + 1]))
exec(compile(open(job["script"]).read(), job["script"], "exec"), {"__name__": "__main__"})
cloud = bpy.data.objects["campath spheres"]
mesh = cloud.data
each = len(mesh.vertices) // job["count"]
colours = mesh.attributes["color"].data
spheres = []
for i in job["sample"]:
    points = [mesh.vertices[k].co for k in range(i * each, (i + 1) * each)]
    spheres.append({"mean": list(sum(points, points[0] * 0) / each),
                    "colours": [list(colours[k].color) for k in (i * each, (i + 1) * each - 1)]})
material = bpy.data.materials["campath spheres"]
json.dump({"modifiers": len(cloud.modifiers), "vertices": len(mesh.vertices), "each": each,
           "active": mesh.attributes.active_color.name, "workbench": bpy.context.scene.display.shading.color_type,
           "reads": [n.attribute_type for n in material.node_tree.nodes if n.type == "ATTRIBUTE"],
           "spheres": spheres}, open(job["out"], "w"))
"#;

/// `REALIZE = True` (for the Solid view and Workbench, which do not read an instance's colour),
/// in Blender 5 (PyPI's bpy), on 2,000 spheres: one mesh of 12 × 6 spheres (62 vertices each)
/// in place of the modifier, each sphere's vertices about campath's centre and in its colour,
/// which is the active colour attribute that Workbench is set to show.
#[test]
#[ignore = "needs Python with bpy (CAMPATH_PYTHON)"]
fn blender_5_realizes_the_instances_into_one_coloured_mesh() {
    crate::usd::need_module("bpy", "bpy");
    let tmp = tempfile::tempdir().unwrap();
    let ron = cloud(tmp.path(), 2000);
    let o = campath(
        tmp.path(),
        &["path", ron.to_str().unwrap(), "--format", "blender"],
        &[],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let text = String::from_utf8(o.stdout).unwrap();
    assert!(text.contains("\nREALIZE = False\n"));
    let script = tmp.path().join("realized.py");
    std::fs::write(
        &script,
        text.replace("\nREALIZE = False\n", "\nREALIZE = True\n"),
    )
    .unwrap();
    let doc = Document::load(&ron).unwrap();
    let spheres = &doc.scene().spheres;
    let sample = cloud_sample(spheres.len());
    let job = serde_json::json!({
        "script": script, "count": spheres.len(), "sample": sample,
        "out": tmp.path().join("realized.json"),
    });
    std::fs::write(tmp.path().join("check.py"), CHECK_REALIZED).unwrap();
    std::fs::write(tmp.path().join("jobs.json"), format!("[{job}]")).unwrap();
    let o = Command::new(crate::usd::python())
        .current_dir(tmp.path())
        .args(["check.py", "--", "jobs.json"])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let text = std::fs::read_to_string(tmp.path().join("realized.json")).unwrap();
    let r: serde_json::Value = serde_json::from_str(&text).unwrap();
    assert_eq!(r["modifiers"], 0);
    assert_eq!(r["each"], 62);
    assert_eq!(r["vertices"], 62 * spheres.len());
    assert_eq!(r["active"], "color");
    assert_eq!(r["workbench"], "VERTEX");
    assert_eq!(r["reads"], serde_json::json!(["GEOMETRY"]));
    let f = |v: &serde_json::Value| v.as_f64().unwrap();
    let v3 = |v: &serde_json::Value| DVec3::new(f(&v[0]), f(&v[1]), f(&v[2]));
    for (got, &i) in r["spheres"].as_array().unwrap().iter().zip(&sample) {
        let want = spheres.get(i);
        // The UV sphere's vertices are symmetric about its centre but for its poles' rows,
        // which balance too: their mean is the centre, to f32.
        let mean = from_z_up(v3(&got["mean"]));
        assert!(
            (mean - want.center_world).abs().max_element()
                <= 1e-5 * want.center_world.length().max(1.0),
            "sphere {i}: {mean} against {}",
            want.center_world
        );
        for colour in got["colours"].as_array().unwrap() {
            assert!(
                (v3(colour) - want.color).abs().max_element() <= 1e-6,
                "sphere {i}: {colour}"
            );
        }
    }
}
