//! `campath path --format gltf`: every example passes the Khronos glTF-Validator with no errors
//! and no warnings, and the camera recomputed from the file's own samplers is campath's at every
//! frame.

use std::process::Command;

use base64::Engine as _;
use glam::{DQuat, DVec3};

use crate::common::{campath, root, stderr, stdout, EXAMPLES};

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
fn floats(gltf: &serde_json::Value, buffer: &[u8], accessor: usize) -> Vec<f64> {
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
