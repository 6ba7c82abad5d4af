//! `campath path --format gltf`: every example passes the Khronos glTF-Validator with no errors
//! and no warnings, and the camera recomputed from the file's own samplers is campath's at every
//! frame.

use std::process::Command;

use base64::Engine as _;
use glam::{DQuat, DVec3};

use crate::common::{
    campath, cloud_sample, does_not_run, need_part, root, stand_in, stderr, stdout, EXAMPLES,
};

/// Validates with the npm package gltf-validator (found through NODE_PATH); fails, saying why,
/// when node or the package is missing.
fn validator_issues(file: &std::path::Path) -> serde_json::Value {
    const SCRIPT: &str = "const v = require('gltf-validator'); const fs = require('fs');
        v.validateBytes(new Uint8Array(fs.readFileSync(process.argv[1])), { maxIssues: 200 })
         .then((r) => console.log(JSON.stringify(r.issues)))
         .catch((e) => { console.error(e); process.exit(2); });";
    let o = Command::new("node").args(["-e", SCRIPT]).arg(file).output();
    match o {
        Ok(o) if o.status.success() => serde_json::from_slice(&o.stdout).unwrap(),
        other => {
            let why = match other {
                Ok(o) => {
                    // Node's first line is where it failed; the error's own line says what.
                    let text = String::from_utf8_lossy(&o.stderr);
                    let mut lines = text.lines().map(str::trim);
                    let first = lines.clone().next().unwrap_or("").to_string();
                    lines
                        .find(|l| l.contains("Error"))
                        .map_or(first, str::to_string)
                }
                Err(e) => e.to_string(),
            };
            panic!("the glTF validator cannot run ({why}): npm install gltf-validator and set NODE_PATH (.ci/run does)");
        }
    }
}

#[test]
#[ignore = "needs node with gltf-validator (NODE_PATH)"]
fn every_example_passes_the_gltf_validator_without_errors_or_warnings() {
    let tmp = tempfile::tempdir().unwrap();
    for name in EXAMPLES {
        let file = format!("animations/{name}.ron");
        for out in [format!("{name}.gltf"), format!("{name}.glb")] {
            let path = tmp.path().join(&out);
            let o = campath(
                &root(),
                &[
                    "path",
                    &file,
                    "--format",
                    "gltf",
                    "--out",
                    path.to_str().unwrap(),
                ],
                &[],
            );
            assert!(o.status.success(), "{}", stderr(&o));
            let issues = validator_issues(&path);
            assert_eq!(issues["numErrors"], 0, "{out}: {issues}");
            assert_eq!(issues["numWarnings"], 0, "{out}: {issues}");
        }
    }
}

/// An accessor's f32 values, read from the file's own buffer.
pub fn floats(gltf: &serde_json::Value, buffer: &[u8], accessor: usize) -> Vec<f64> {
    let a = &gltf["accessors"][accessor];
    assert_eq!(a["componentType"], 5126);
    let view = &gltf["bufferViews"][a["bufferView"].as_u64().unwrap() as usize];
    let start = view["byteOffset"].as_u64().unwrap() as usize;
    let len = view["byteLength"].as_u64().unwrap() as usize;
    buffer[start..start + len]
        .chunks_exact(4)
        .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64)
        .collect()
}

#[test]
fn the_camera_from_the_files_samplers_is_campaths_at_every_frame() {
    for name in EXAMPLES {
        let file = format!("animations/{name}.ron");
        let text = stdout(&campath(&root(), &["path", &file, "--format", "gltf"], &[]));
        let gltf: serde_json::Value = serde_json::from_str(&text).unwrap();
        let uri = gltf["buffers"][0]["uri"].as_str().unwrap();
        let data = uri
            .strip_prefix("data:application/octet-stream;base64,")
            .unwrap();
        let buffer = base64::engine::general_purpose::STANDARD
            .decode(data)
            .unwrap();
        let anim = &gltf["animations"][0];
        let sampler = |path: &str| {
            let channel = anim["channels"]
                .as_array()
                .unwrap()
                .iter()
                .find(|c| c["target"]["path"] == path && c["target"]["node"] == 0)
                .unwrap();
            &anim["samplers"][channel["sampler"].as_u64().unwrap() as usize]
        };
        let (tr, rot) = (sampler("translation"), sampler("rotation"));
        assert_eq!(tr["interpolation"], "LINEAR");
        let times = floats(&gltf, &buffer, tr["input"].as_u64().unwrap() as usize);
        let translations = floats(&gltf, &buffer, tr["output"].as_u64().unwrap() as usize);
        let rotations = floats(&gltf, &buffer, rot["output"].as_u64().unwrap() as usize);
        let csv = stdout(&campath(&root(), &["path", &file], &[]));
        let close = |a: f64, b: f64, what: &str| {
            assert!(
                (a - b).abs() <= 1e-6 * b.abs().max(1.0),
                "{name} {what}: {a} against {b}"
            );
        };
        let rows: Vec<Vec<f64>> = csv
            .lines()
            .skip(1)
            .map(|l| l.split(',').map(|c| c.parse().unwrap()).collect())
            .collect();
        assert_eq!(times.len(), rows.len());
        for (k, row) in rows.iter().enumerate() {
            close(times[k], row[1], "t");
            for i in 0..3 {
                close(translations[3 * k + i], row[14 + i], "COP");
            }
            let q = DQuat::from_xyzw(
                rotations[4 * k],
                rotations[4 * k + 1],
                rotations[4 * k + 2],
                rotations[4 * k + 3],
            );
            // +X, +Y and −Z of the camera go to u, v and n.
            for (axis, start) in [(DVec3::X, 5), (DVec3::Y, 8), (DVec3::NEG_Z, 11)] {
                let got = q * axis;
                for i in 0..3 {
                    close(got[i], row[start + i], "axis");
                }
            }
        }
    }
}

#[test]
fn the_near_plane_clips_nothing_campath_draws() {
    // A sphere of radius 0.001 whose surface is 0.005 in front of the COP (at z = −1, 1 unit
    // behind the VRP): a fixed near plane of 0.01 hid it.
    let tmp = tempfile::tempdir().unwrap();
    std::fs::write(
        tmp.path().join("small.ron"),
        "(frames: 2, camera: (vrp: (0.0, 0.0, 0.0), vpn: (0.0, 0.0, 1.0)),
          scene: (spheres: [(center: (0.0, 0.0, -0.994), radius: 0.001)]))",
    )
    .unwrap();
    let o = campath(tmp.path(), &["path", "small.ron", "--format", "gltf"], &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    let gltf: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let znear = gltf["cameras"][0]["perspective"]["znear"].as_f64().unwrap();
    assert!(znear > 0.0 && znear <= 0.005, "{znear}");
    assert!(gltf["cameras"][0]["perspective"].get("zfar").is_none());
}

/// The JSON and binary chunks of a `.glb`.
fn glb_chunks(bytes: &[u8]) -> (serde_json::Value, &[u8]) {
    let word = |at: usize| u32::from_le_bytes(bytes[at..at + 4].try_into().unwrap()) as usize;
    assert_eq!(&bytes[..4], b"glTF");
    assert_eq!(word(8), bytes.len());
    let json_len = word(12);
    assert_eq!(&bytes[16..20], b"JSON");
    let json = serde_json::from_slice(&bytes[20..20 + json_len]).unwrap();
    let bin = 20 + json_len;
    assert_eq!(&bytes[bin + 4..bin + 8], b"BIN\0");
    (json, &bytes[bin + 8..bin + 8 + word(bin)])
}

/// Writes the `n`-sphere cloud as `.glb` in `dir`; returns its path and its document.
fn cloud_glb(dir: &std::path::Path, n: usize) -> (std::path::PathBuf, campath::document::Document) {
    let ron = crate::common::cloud(dir, n);
    let glb = dir.join(format!("cloud_{n}.glb"));
    let o = campath(
        dir,
        &[
            "path",
            ron.to_str().unwrap(),
            "--out",
            glb.to_str().unwrap(),
        ],
        &[],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    (glb, campath::document::Document::load(&ron).unwrap())
}

/// From [`campath::export::INSTANCED_FROM`] spheres on, one node instances one mesh through
/// `EXT_mesh_gpu_instancing` (required), one TRANSLATION, SCALE and `_COLOR_0` per sphere, read
/// back from the file's own buffer as campath's centre, radius and colour; below it, a node a
/// sphere. 100,000 spheres' `.glb` is at most 8 MB.
#[test]
fn from_the_threshold_the_spheres_are_instances_and_100k_fit_in_8_mb() {
    let tmp = tempfile::tempdir().unwrap();
    let from = campath::export::INSTANCED_FROM;
    for n in [from - 1, from, 100_000] {
        let (glb, doc) = cloud_glb(tmp.path(), n);
        let bytes = std::fs::read(&glb).unwrap();
        let (gltf, buffer) = glb_chunks(&bytes);
        let nodes = gltf["nodes"].as_array().unwrap();
        let instanced: Vec<&serde_json::Value> = nodes
            .iter()
            .filter_map(|node| node["extensions"].get("EXT_mesh_gpu_instancing"))
            .collect();
        // The camera, the light, and one node of every sphere or a node a sphere.
        if n < from {
            assert!(instanced.is_empty());
            assert_eq!(nodes.len(), n + 2);
            assert!(gltf.get("extensionsRequired").is_none());
            continue;
        }
        assert_eq!(nodes.len(), 3);
        assert_eq!(instanced.len(), 1);
        assert_eq!(
            gltf["extensionsRequired"],
            serde_json::json!(["EXT_mesh_gpu_instancing"])
        );
        assert!(gltf["extensionsUsed"]
            .as_array()
            .unwrap()
            .contains(&serde_json::json!("EXT_mesh_gpu_instancing")));
        assert_eq!(gltf["meshes"].as_array().unwrap().len(), 1);
        assert_eq!(gltf["materials"].as_array().unwrap().len(), 1);
        let attribute = |name: &str| {
            let accessor = instanced[0]["attributes"][name].as_u64().unwrap() as usize;
            assert_eq!(gltf["accessors"][accessor]["count"], n);
            assert_eq!(gltf["accessors"][accessor]["type"], "VEC3");
            floats(&gltf, buffer, accessor)
        };
        let (places, scales, colours) = (
            attribute("TRANSLATION"),
            attribute("SCALE"),
            attribute("_COLOR_0"),
        );
        // f32 of campath's f64: to its rounding.
        let close = |a: f64, b: f64| (a - b).abs() <= 1e-6 * b.abs().max(1.0);
        for (i, s) in doc.scene().spheres.iter().enumerate() {
            for k in 0..3 {
                assert!(close(places[3 * i + k], s.center_world[k]), "sphere {i}");
                assert!(close(scales[3 * i + k], s.radius), "sphere {i}");
                assert!(close(colours[3 * i + k], s.color[k]), "sphere {i}");
            }
        }
        if n == 100_000 {
            eprintln!("gltf: 100,000 spheres as .glb: {} bytes", bytes.len());
            assert!(bytes.len() <= 8_000_000, "{} bytes", bytes.len());
        }
    }
}

/// The 100,000-sphere shot, as `.glb` and `.gltf`, passes the Khronos validator with no error
/// and no warning. (It does not know `EXT_mesh_gpu_instancing`, and says so in an info: the
/// three.js check below reads the instances.)
#[test]
#[ignore = "needs node with gltf-validator (NODE_PATH)"]
fn the_100k_instanced_spheres_pass_the_gltf_validator() {
    let tmp = tempfile::tempdir().unwrap();
    let (glb, _) = cloud_glb(tmp.path(), 100_000);
    let gltf = tmp.path().join("cloud.gltf");
    let o = campath(
        tmp.path(),
        &["path", "cloud.ron", "--out", gltf.to_str().unwrap()],
        &[],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    for file in [glb, gltf] {
        let issues = validator_issues(&file);
        assert_eq!(issues["numErrors"], 0, "{}: {issues}", file.display());
        assert_eq!(issues["numWarnings"], 0, "{}: {issues}", file.display());
    }
}

/// Why node cannot load three.js and puppeteer-core (through NODE_PATH), if it cannot.
fn three_missing(node: &str) -> Option<String> {
    let o = Command::new(node)
        .args([
            "-e",
            "require.resolve('three'); require.resolve('puppeteer-core')",
        ])
        .output();
    match o {
        Ok(o) if o.status.success() => None,
        Ok(_) => Some(
            "node cannot find three and puppeteer-core: npm install them and set NODE_PATH".into(),
        ),
        Err(e) => Some(format!("node does not run: {e}")),
    }
}

/// three.js (npm `three`, its GLTFLoader), in headless Chromium, loads the 100,000-sphere `.glb`
/// as one InstancedMesh of 100,000 instances, the sampled ones at campath's centres, of its
/// radii and in its colours.
#[test]
#[ignore = "needs chromium, and node with three and puppeteer-core (NODE_PATH)"]
fn three_js_loads_100k_spheres_as_one_instanced_mesh() {
    need_part("chromium", "chromium", does_not_run);
    need_part("node", "nodejs", three_missing);
    let tmp = tempfile::tempdir().unwrap();
    let (glb, doc) = cloud_glb(tmp.path(), 100_000);
    let spheres = &doc.scene().spheres;
    let sample = cloud_sample(spheres.len());
    let list: Vec<String> = sample.iter().map(usize::to_string).collect();
    let out = tmp.path().join("three.json");
    let o = Command::new("node")
        .arg(root().join("tests/it/three.mjs"))
        .arg(&glb)
        .arg(&out)
        .arg(list.join(","))
        .output()
        .unwrap();
    assert!(
        o.status.success(),
        "three.mjs: {}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
    let r: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap();
    assert!(r.get("error").is_none(), "{r}");
    assert_eq!(r["pageErrors"], serde_json::json!([]));
    assert_eq!(r["counts"], serde_json::json!([spheres.len()]));
    assert_eq!(r["cameras"], 1);
    let v3 = |v: &serde_json::Value| {
        let f = |i: usize| v[i].as_f64().unwrap();
        DVec3::new(f(0), f(1), f(2))
    };
    let close = |a: DVec3, b: DVec3| (a - b).abs().max_element() <= 1e-6 * b.length().max(1.0);
    for (got, &i) in r["instances"].as_array().unwrap().iter().zip(&sample) {
        let want = spheres.get(i);
        assert!(close(v3(&got["place"]), want.center_world), "{i}: {got}");
        assert!(
            close(v3(&got["scale"]), DVec3::splat(want.radius)),
            "{i}: {got}"
        );
        assert!(close(v3(&got["colour"]), want.color), "{i}: {got}");
    }
    eprintln!(
        "three.js r{}: {} instances in one InstancedMesh",
        r["revision"].as_str().unwrap_or("?"),
        r["counts"][0]
    );
}

/// [`three_missing`] tells a node that cannot load the packages from one that can (stand-ins
/// that fail and succeed as `node -e` does), and names what to install.
#[test]
fn a_node_without_three_is_told_apart() {
    let tmp = tempfile::tempdir().unwrap();
    let script = |name: &str, body: &str| stand_in(tmp.path(), name, body);
    let without = script(
        "node-without",
        "echo \"Error: Cannot find module 'three'\" >&2; exit 1",
    );
    let why = three_missing(&without).unwrap();
    assert!(
        why.contains("npm install") && why.contains("NODE_PATH"),
        "{why}"
    );
    assert_eq!(three_missing(&script("node-with", "exit 0")), None);
}
