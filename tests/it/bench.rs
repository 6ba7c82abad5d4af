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
