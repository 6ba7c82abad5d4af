//! The exports agree: campath's frame k is frame k + N (`--first-frame N`) in every format, the
//! CSV and JSON name the COP's space, and no export writes `-0`.

use base64::Engine as _;
use campath::document::Document;

use crate::common::{campath, root, stderr, stdout};

/// The motion-blur example: with the shutter's ends keyed too (−S/2 and N − 1 + S/2).
const BLURRED: &str = "animations/motion_blur.ron";

/// `path FILE --format F` with more arguments: its standard output, having succeeded.
fn export(file: &str, format: &str, more: &[&str]) -> String {
    let args = [&["path", file, "--format", format][..], more].concat();
    let o = campath(&root(), &args, &[]);
    assert!(o.status.success(), "{args:?}: {}", stderr(&o));
    stdout(&o)
}

/// The numbers at the start of each entry of a USD attribute's `timeSamples`.
fn usd_times(usda: &str, attribute: &str) -> Vec<f64> {
    let start = usda.find(&format!("{attribute}.timeSamples = {{")).unwrap();
    let body = &usda[start..];
    let body = &body[body.find('\n').unwrap() + 1..body.find("\n        }").unwrap()];
    (body.lines())
        .map(|l| l.trim().split(':').next().unwrap().parse().unwrap())
        .collect()
}

/// The scene frames of the Blender script's `FRAMES`, each row's first number.
fn blender_frames(script: &str) -> Vec<f64> {
    let body = script.split("\nFRAMES = [\n").nth(1).unwrap();
    let body = &body[..body.find("\n]").unwrap()];
    (body.lines())
        .map(|l| l.trim_start_matches([' ', '(']).split(',').next().unwrap())
        .map(|n| n.parse().unwrap())
        .collect()
}

/// The glTF's camera sampler times, from the file's own buffer.
fn gltf_times(text: &str) -> (serde_json::Value, Vec<f64>) {
    let gltf: serde_json::Value = serde_json::from_str(text).unwrap();
    let uri = gltf["buffers"][0]["uri"].as_str().unwrap();
    let data = uri.split_once("base64,").unwrap().1;
    let buffer = base64::engine::general_purpose::STANDARD
        .decode(data)
        .unwrap();
    let input = gltf["animations"][0]["samplers"][0]["input"]
        .as_u64()
        .unwrap();
    let times = crate::gltf::floats(&gltf, &buffer, input as usize);
    (gltf, times)
}

#[test]
fn every_format_numbers_campaths_frame_k_as_k_plus_the_first_frame() {
    let doc = Document::load(&root().join(BLURRED)).unwrap();
    let (frames, fps) = (doc.animation().frames, doc.animation().fps);
    let half = doc.motion_blur().unwrap().shutter / 2.0;
    for first in [0u64, 1, 1001] {
        let n = first.to_string();
        let more = ["--first-frame", n.as_str()];
        let numbers: Vec<u64> = (first..first + frames).collect();
        let f = first as f64;
        // The keyed times of the formats that key the shutter's ends: N − S/2 to N + frames − 1 + S/2.
        let mut keyed: Vec<f64> = numbers.iter().map(|&k| k as f64).collect();
        keyed.insert(0, f - half);
        keyed.push(f + (frames - 1) as f64 + half);

        // CSV: `frame` is k + N, `t` stays k / fps.
        let csv = export(BLURRED, "csv", &more);
        let rows: Vec<Vec<f64>> = (csv.lines().skip(1))
            .map(|l| l.split(',').map(|c| c.parse().unwrap()).collect())
            .collect();
        let got: Vec<u64> = rows.iter().map(|r| r[0] as u64).collect();
        assert_eq!(got, numbers, "CSV from {first}");
        for (k, row) in rows.iter().enumerate() {
            assert_eq!(row[1], k as f64 / fps, "CSV from {first}: t of frame {k}");
        }
        // JSON: the same, as an array of frames.
        let json: serde_json::Value =
            serde_json::from_str(&export(BLURRED, "json", &more)).unwrap();
        let got: Vec<u64> = (json.as_array().unwrap().iter())
            .map(|o| o["frame"].as_u64().unwrap())
            .collect();
        assert_eq!(got, numbers, "JSON from {first}");
        // .chan: the first column.
        let chan = export(BLURRED, "chan", &more);
        let got: Vec<u64> = (chan.lines())
            .map(|l| l.split('\t').next().unwrap().parse().unwrap())
            .collect();
        assert_eq!(got, numbers, ".chan from {first}");
        // USD: the stage's range, every time sample, and what the layer says.
        let usda = export(BLURRED, "usd", &more);
        let last = first + frames - 1;
        assert!(
            usda.contains(&format!("\n    startTimeCode = {first}\n")),
            "{usda}"
        );
        assert!(
            usda.contains(&format!("\n    endTimeCode = {last}\n")),
            "{usda}"
        );
        assert!(usda.contains(&format!("int firstFrame = {first}\n")));
        assert!(usda.contains(&format!("\"Time code k + {first} is campath frame k")));
        for attribute in ["xformOp:translate", "xformOp:orient", "focalLength"] {
            assert_eq!(
                usd_times(&usda, attribute),
                keyed,
                "USD {attribute} from {first}"
            );
        }
        // The shutter is relative to the frame: the same for every first frame.
        assert!(usda.contains("double shutter:open = -0.25\n"), "{usda}");
        // glTF: times (k + N) / fps, and the first frame in asset.extras.
        let (gltf, times) = gltf_times(&export(BLURRED, "gltf", &more));
        assert_eq!(gltf["asset"]["extras"]["campath_first_frame"], first);
        assert_eq!(times.len() as u64, frames);
        for (k, t) in times.iter().enumerate() {
            let want = (k as f64 + f) / fps;
            assert!((t - want).abs() <= 1e-6 * want.max(1.0), "glTF {k}: {t}");
        }
        // Blender: the scene's frames and every key, and the header says so.
        let script = export(BLURRED, "blender", &more);
        assert!(script.contains(&format!("\nFIRST_FRAME, LAST_FRAME = {first}, {last}\n")));
        assert!(script.contains(&format!("(campath path --first-frame {first})")));
        assert_eq!(blender_frames(&script), keyed, "Blender from {first}");
    }
}

#[test]
fn a_first_frame_below_zero_or_past_the_formats_is_refused() {
    for args in [
        &["path", BLURRED, "--first-frame", "-1"][..],
        &["path", BLURRED, "--first-frame=-1"],
        &["path", BLURRED, "--first-frame", "1.5"],
        &["path", BLURRED, "--first-frame", "10000001"],
        // Blender's last frame is 1,048,574.
        &[
            "path",
            BLURRED,
            "--format",
            "blender",
            "--first-frame",
            "1048530",
        ],
    ] {
        let o = campath(&root(), args, &[]);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {}", stderr(&o));
        assert!(o.stdout.is_empty(), "{args:?}");
    }
    // The last that Blender keeps: 48 frames up to 1,048,574.
    export(BLURRED, "blender", &["--first-frame", "1048527"]);
}

#[test]
fn csv_and_json_name_the_cops_space() {
    let csv = export(BLURRED, "csv", &[]);
    assert_eq!(
        csv.lines().next().unwrap(),
        "frame,t,vrp_x,vrp_y,vrp_z,u_x,u_y,u_z,v_x,v_y,v_z,n_x,n_y,n_z,\
         cop_world_x,cop_world_y,cop_world_z,window_w,window_h"
    );
    let text = export(BLURRED, "json", &[]);
    // The fields in the order they are written.
    let line = text.lines().nth(1).unwrap();
    let at = |key: &str| line.find(&format!("\"{key}\":")).unwrap_or(usize::MAX);
    let order = ["frame", "t", "vrp", "u", "v", "n", "cop_world", "window"].map(at);
    assert!(order.windows(2).all(|w| w[0] < w[1]), "{line}");
    assert!(!line.contains("\"cop\":"), "{line}");
    let json: serde_json::Value = serde_json::from_str(&text).unwrap();
    assert_eq!(json[0].as_object().unwrap().len(), 8, "{line}");
    // The COP in world coordinates: VRP + n · cop_n for the example's COP on the VPN.
    let doc = Document::load(&root().join(BLURRED)).unwrap();
    let cam = doc.camera(0).unwrap();
    let want = cam.vrp_world + cam.basis.n * cam.cop_view.z;
    for i in 0..3 {
        let got = json[0]["cop_world"][i].as_f64().unwrap();
        assert!((got - want[i]).abs() < 1e-12, "{got} against {want}");
    }
}

/// Every number in `text` that is a negative zero (`-0`, `-0.0`, `-0e0`): a `-` before a digit,
/// not inside a word or a number, whose number is 0.
fn negative_zeros(text: &str) -> Vec<String> {
    let b = text.as_bytes();
    let mut found = Vec::new();
    for i in 0..b.len().saturating_sub(1) {
        let before = i.checked_sub(1).map(|j| b[j]);
        let inside = before.is_some_and(|c| c.is_ascii_alphanumeric() || c == b'.' || c == b'_');
        if b[i] != b'-' || !b[i + 1].is_ascii_digit() || inside {
            continue;
        }
        let end = (i + 1..b.len())
            .find(|&j| {
                !(b[j].is_ascii_digit()
                    || b".eE".contains(&b[j])
                    || (b"+-".contains(&b[j]) && b"eE".contains(&b[j - 1])))
            })
            .unwrap_or(b.len());
        let number = &text[i..end];
        if number.parse::<f64>().is_ok_and(|x| x == 0.0) {
            found.push(number.to_string());
        }
    }
    found
}

#[test]
fn no_export_writes_a_negative_zero() {
    assert_eq!(negative_zeros("a -0 b"), ["-0"]);
    assert_eq!(negative_zeros("[-0.0,1]"), ["-0.0"]);
    assert!(negative_zeros("x-0 1-0 -0.5 -1 e-0 -0.01 2e-05").is_empty());
    // A camera at the origin looking down −z: u is (1, −0, 0) in f64, and more zeros follow
    // (the rotation, the lens shift of a COP on the VPN); each printed `-0` before.
    let tmp = tempfile::tempdir().unwrap();
    let shot = tmp.path().join("down_z.ron");
    std::fs::write(
        &shot,
        "(frames: 2, fps: 24.0, image: (width: 64, height: 36),
          camera: (vrp: (0.0, 0.0, 0.0), vpn: (0.0, 0.0, -1.0), cop: (0.0, 0.0, -1.0), window: (1.6, 0.9)),
          scene: (spheres: [(center: (0.0, 0.0, -5.0), radius: 1.0, color: (1.0, 0.5, 0.2))],
                  lights: [(direction: (0.0, -1.0, 0.0))]))",
    )
    .unwrap();
    let doc = Document::load(&shot).unwrap();
    let b = doc.camera(0).unwrap().basis;
    let zeros = [b.u, b.v, b.n].map(|a| {
        a.to_array()
            .iter()
            .any(|x| *x == 0.0 && x.is_sign_negative())
    });
    assert!(zeros.contains(&true), "{b:?}: no −0 to write");
    let file = shot.to_str().unwrap();
    for format in ["csv", "json", "chan", "gltf", "blender", "usd"] {
        for first in ["0", "3"] {
            let text = export(file, format, &["--first-frame", first]);
            assert_eq!(
                negative_zeros(&text),
                Vec::<String>::new(),
                "{format}: {text}"
            );
        }
    }
    // The .glb's JSON chunk.
    let glb = tmp.path().join("down_z.glb");
    let o = campath(
        tmp.path(),
        &["path", file, "--out", glb.to_str().unwrap()],
        &[],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let bytes = std::fs::read(&glb).unwrap();
    let length = u32::from_le_bytes(bytes[12..16].try_into().unwrap()) as usize;
    let json = String::from_utf8(bytes[20..20 + length].to_vec()).unwrap();
    assert_eq!(negative_zeros(&json), Vec::<String>::new(), "{json}");
}
