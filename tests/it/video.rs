//! `campath video`: the lossless video decodes (by ffmpeg) to exactly the frames of hashes.txt;
//! ffprobe reads the default MP4's frame count, rate and duration; without ffmpeg the error names
//! the package.

use std::path::{Path, PathBuf};
use std::process::Command;

use crate::common::{
    campath, ffmpeg_lacks_encoder, frame_lines, need_part, need_tool, root, stderr,
};
use campath::frame_hash;

/// The zoom example at 96×54 (odd-free) or 95×53 (odd sides, which H.264 pads).
fn example(dir: &Path, size: &str) -> String {
    let text = std::fs::read_to_string(root().join("animations/zoom.ron")).unwrap();
    std::fs::write(
        dir.join("zoom.ron"),
        text.replace("width: 640, height: 360", size),
    )
    .unwrap();
    "zoom.ron".into()
}

#[test]
#[ignore = "needs ffmpeg"]
fn the_lossless_video_decodes_to_the_frames_of_hashes_txt() {
    need_part("ffmpeg", "ffmpeg", |f| ffmpeg_lacks_encoder(f, "ffv1"));
    let tmp = tempfile::tempdir().unwrap();
    let f = example(tmp.path(), "width: 96, height: 54");
    let o = campath(tmp.path(), &["video", &f, "--lossless", "--quiet"], &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    let mkv = tmp.path().join("out/zoom/zoom.mkv");
    let raw = Command::new("ffmpeg")
        .args(["-v", "error", "-i"])
        .arg(&mkv)
        .args(["-f", "rawvideo", "-pix_fmt", "rgb24", "-"])
        .output()
        .unwrap();
    assert!(
        raw.status.success(),
        "{}",
        String::from_utf8_lossy(&raw.stderr)
    );
    let manifest = std::fs::read_to_string(tmp.path().join("out/zoom/hashes.txt")).unwrap();
    let want: Vec<&str> = frame_lines(&manifest)
        .iter()
        .map(|l| l.split(' ').nth(1).unwrap())
        .collect();
    let got: Vec<String> = raw
        .stdout
        .chunks(96 * 54 * 3)
        .map(|p| frame_hash(p).to_string())
        .collect();
    assert_eq!(want.len(), 72);
    assert_eq!(got, want);
    // A second run keeps every frame and encodes again.
    let o = campath(tmp.path(), &["video", &f, "--lossless"], &[]);
    assert!(o.status.success(), "{}", stderr(&o));
}

#[test]
#[ignore = "needs ffmpeg"]
fn the_default_mp4_has_the_right_frames_rate_and_duration() {
    need_part("ffmpeg", "ffmpeg", |f| ffmpeg_lacks_encoder(f, "libx264"));
    need_tool("ffprobe", "ffmpeg");
    let tmp = tempfile::tempdir().unwrap();
    let f = example(tmp.path(), "width: 95, height: 53");
    // A name that begins with `-` is a file to ffmpeg, not an option.
    let o = campath(
        tmp.path(),
        &["video", &f, "--quiet", "--out=-clip.mp4"],
        &[],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    std::fs::rename(tmp.path().join("-clip.mp4"), tmp.path().join("clip.mp4")).unwrap();
    let probe = Command::new("ffprobe")
        .args(["-v", "error", "-select_streams", "v:0", "-count_frames"])
        .args([
            "-show_entries",
            "stream=nb_read_frames,r_frame_rate,width,height,pix_fmt,codec_name,\
             color_range,color_space,color_primaries,color_transfer",
        ])
        .args(["-show_entries", "format=duration", "-of", "json"])
        .arg(tmp.path().join("clip.mp4"))
        .output()
        .unwrap();
    let v: serde_json::Value = serde_json::from_slice(&probe.stdout).unwrap();
    let s = &v["streams"][0];
    assert_eq!(s["codec_name"], "h264");
    assert_eq!(s["pix_fmt"], "yuv420p");
    assert_eq!(s["nb_read_frames"], "72");
    assert_eq!(s["r_frame_rate"], "24/1");
    // Tagged as what it is: BT.709's matrix and primaries in limited range, sRGB levels.
    assert_eq!(
        [
            &s["color_range"],
            &s["color_space"],
            &s["color_primaries"],
            &s["color_transfer"]
        ],
        ["tv", "bt709", "bt709", "iec61966-2-1"]
    );
    assert_eq!(
        (s["width"].as_u64(), s["height"].as_u64()),
        (Some(96), Some(54))
    );
    let duration: f64 = v["format"]["duration"].as_str().unwrap().parse().unwrap();
    assert!((duration - 3.0).abs() < 0.05, "duration {duration}");
    // No temporary file is left beside it.
    assert_eq!(temps_of(tmp.path(), "-clip.mp4"), Vec::<PathBuf>::new());

    // Decoded by the matrix it is tagged with, frame 0 is the PNG's levels within H.264's
    // loss: within 2.5 levels on average in each channel (a small frame, mostly edges), and
    // closer than by BT.601's matrix (which the video once used, untagged).
    let png = image::open(tmp.path().join("out/zoom/frame_0000.png"))
        .unwrap()
        .to_rgb8();
    let error = |matrix: &str| -> [f64; 3] {
        let o = Command::new("ffmpeg")
            .args(["-v", "error", "-i"])
            .arg(tmp.path().join("clip.mp4"))
            .args(["-frames:v", "1", "-vf"])
            .arg(format!(
                "scale=in_color_matrix={matrix}:in_range=tv:out_range=pc:\
                 flags=accurate_rnd+full_chroma_int,crop=95:53:0:0,format=rgb24"
            ))
            .args(["-f", "rawvideo", "-pix_fmt", "rgb24", "-"])
            .output()
            .unwrap();
        assert_eq!(o.stdout.len(), png.as_raw().len(), "{}", stderr(&o));
        let mut sums = [0.0; 3];
        for (i, (a, b)) in o.stdout.iter().zip(png.as_raw()).enumerate() {
            sums[i % 3] += (f64::from(*a) - f64::from(*b)).abs();
        }
        sums.map(|s| s / (95.0 * 53.0))
    };
    let (bt709, bt601) = (error("bt709"), error("bt601"));
    for c in 0..3 {
        assert!(bt709[c] < 2.5 && bt709[c] < bt601[c], "{bt709:?} {bt601:?}");
    }
}

#[test]
fn without_ffmpeg_the_error_names_the_package() {
    let tmp = tempfile::tempdir().unwrap();
    let f = example(tmp.path(), "width: 32, height: 18");
    let o = campath(tmp.path(), &["video", &f], &[("PATH", "/nonexistent")]);
    assert_eq!(o.status.code(), Some(3), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("Debian package ffmpeg"),
        "{}",
        stderr(&o)
    );
    assert!(!tmp.path().join("out").exists(), "nothing rendered");
}

#[test]
#[ignore = "needs ffmpeg"]
fn a_killed_encode_leaves_no_video_under_its_final_name() {
    need_part("ffmpeg", "ffmpeg", |f| ffmpeg_lacks_encoder(f, "libx264"));
    let tmp = tempfile::tempdir().unwrap();
    // One sample a pixel: a quick render (this test also runs unoptimised), then an encode that
    // lasts well past the moment ffmpeg opens its output.
    let f = example(tmp.path(), "width: 320, height: 180");
    let text = std::fs::read_to_string(tmp.path().join(&f)).unwrap();
    assert!(text.contains("samples: 2"), "the example's sampling moved");
    std::fs::write(
        tmp.path().join(&f),
        text.replace("samples: 2", "samples: 1"),
    )
    .unwrap();
    let mut child = Command::new(env!("CARGO_BIN_EXE_campath"))
        .current_dir(tmp.path())
        .args(["video", &f, "--quiet"])
        .spawn()
        .unwrap();
    // Killed while ffmpeg writes: once its output has bytes under the temporary name (not the
    // empty probe that checks the folder is writable before the render).
    let folder = tmp.path().join("out/zoom");
    let partial = || temps_of(&folder, "zoom.mp4");
    let encoding = || {
        partial()
            .iter()
            .any(|p| p.metadata().is_ok_and(|m| m.len() > 0))
    };
    let started = std::time::Instant::now();
    while !encoding() {
        assert!(
            child.try_wait().unwrap().is_none(),
            "campath finished before its encode could be killed"
        );
        assert!(started.elapsed().as_secs() < 120, "no encode began");
        std::thread::sleep(std::time::Duration::from_millis(1));
    }
    child.kill().unwrap(); // SIGKILL
    child.wait().unwrap();
    std::thread::sleep(std::time::Duration::from_millis(300)); // ffmpeg sees its input end
    assert!(!tmp.path().join("out/zoom/zoom.mp4").exists());
    // What the stopped encode left goes with the frames it was made of: a render that changes
    // them removes it.
    assert_eq!(partial().len(), 1);
    let text = std::fs::read_to_string(tmp.path().join(&f)).unwrap();
    let edited = text.replacen("fps: 24.0", "fps: 25.0", 1);
    assert_ne!(edited, text, "the example's rate moved");
    std::fs::write(tmp.path().join(&f), edited).unwrap();
    let o = campath(tmp.path(), &["render", &f, "--quiet"], &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(partial(), Vec::<PathBuf>::new());
    // Stopped by Ctrl-C (sent to campath alone, ffmpeg left to end on its input): exit 130,
    // and nothing of the encode is left.
    for signal in ["-INT"] {
        let mut child = Command::new(env!("CARGO_BIN_EXE_campath"))
            .current_dir(tmp.path())
            .args(["video", &f, "--quiet"])
            .stderr(std::process::Stdio::piped())
            .spawn()
            .unwrap();
        let started = std::time::Instant::now();
        while !encoding() {
            assert!(
                child.try_wait().unwrap().is_none(),
                "finished before {signal}"
            );
            assert!(started.elapsed().as_secs() < 120, "no encode began");
            std::thread::sleep(std::time::Duration::from_millis(1));
        }
        let sent = Command::new("kill")
            .args([signal, &child.id().to_string()])
            .status()
            .unwrap();
        assert!(sent.success());
        let o = child.wait_with_output().unwrap();
        assert_eq!(o.status.code(), Some(130), "{signal}: {}", stderr(&o));
        assert!(
            stderr(&o).contains("the partial video was removed"),
            "{}",
            stderr(&o)
        );
        assert_eq!(partial(), Vec::<PathBuf>::new(), "{signal}");
        assert!(!tmp.path().join("out/zoom/zoom.mp4").exists(), "{signal}");
    }
    // Run again: it completes.
    let o = campath(tmp.path(), &["video", &f, "--quiet"], &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(tmp.path().join("out/zoom/zoom.mp4").exists());
}

/// The video `video` writes into the frames folder (`STEM.mp4`) is made of its frames: an edit
/// that renders any frame again removes it before the frames change (so a stopped run leaves no
/// stale video under its name), while another video there (someone's `ref.mp4`) is left alone.
/// In the frames folder a video takes the file's name (another, or a folder made there for it,
/// is refused before anything is made), and `--lossless` above 1000 fps (Matroska's millisecond
/// timestamps) is refused.
#[test]
#[ignore = "needs ffmpeg"]
fn a_video_never_outlives_its_frames_and_never_clutters_their_folder() {
    need_part("ffmpeg", "ffmpeg", |f| ffmpeg_lacks_encoder(f, "libx264"));
    let tmp = tempfile::tempdir().unwrap();
    let f = example(tmp.path(), "width: 32, height: 18");
    let run = |args: &[&str]| campath(tmp.path(), args, &[]);
    let o = run(&["video", &f, "-q"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let video = tmp.path().join("out/zoom/zoom.mp4");
    let other = tmp.path().join("out/zoom/ref.mp4");
    std::fs::write(&other, "someone's").unwrap();
    assert!(video.exists());
    // Nothing changed: the video stays.
    let o = run(&["render", &f, "-q"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(video.exists());
    // An edit renders frames again: the video goes first, the other stays.
    let text = std::fs::read_to_string(tmp.path().join(&f)).unwrap();
    let edited = text.replacen("ambient: 0.12", "ambient: 0.5", 1);
    assert_ne!(edited, text);
    std::fs::write(tmp.path().join(&f), edited).unwrap();
    let o = run(&["render", &f, "-q"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        !video.exists(),
        "the video of the old frames is still there"
    );
    assert_eq!(std::fs::read_to_string(&other).unwrap(), "someone's");
    for (args, want) in [
        (
            &["video", &f, "--out", "out/zoom/sub/clip.mp4"][..],
            "in the frames folder out/zoom the video is out/zoom/zoom.mp4",
        ),
        (
            &["video", &f, "--out", "out/zoom/CLIP.MP4"],
            "in the frames folder out/zoom the video is out/zoom/zoom.mp4",
        ),
        (
            &["video", &f, "--lossless", "--out", "fast.mkv"],
            "at most 1000 fps",
        ),
    ] {
        if args.contains(&"--lossless") {
            let fast = text.replacen("fps: 24.0", "fps: 2000.0", 1);
            assert_ne!(fast, text);
            std::fs::write(tmp.path().join(&f), fast).unwrap();
        }
        let o = run(args);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {}", stderr(&o));
        assert!(stderr(&o).contains(want), "{args:?}: {}", stderr(&o));
    }
    assert!(!tmp.path().join("out/zoom/sub").exists());
    assert!(!tmp.path().join("out/zoom/CLIP.MP4").exists());
    assert!(!tmp.path().join("fast.mkv").exists());
}

/// A video goes into its own frames folder or outside any: `--out` in another render's frames
/// folder (or a folder inside it) is refused before anything is rendered, as a video there
/// would pass for that render's own.
#[test]
fn a_video_stays_out_of_other_renders() {
    let tmp = tempfile::tempdir().unwrap();
    let f = example(tmp.path(), "width: 16, height: 10");
    let text = std::fs::read_to_string(tmp.path().join(&f)).unwrap();
    std::fs::write(tmp.path().join("track.ron"), &text).unwrap();
    let run = |args: &[&str]| campath(tmp.path(), args, &[]);
    let o = run(&["render", "track.ron", "-q"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let listing = || {
        let mut names: Vec<_> = std::fs::read_dir(tmp.path().join("out/track"))
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        names.sort();
        names
    };
    let before = listing();
    for out in ["out/track/track.mp4", "out/track/sub/clip.mp4"] {
        let o = run(&["video", &f, "-q", "--out", out]);
        assert_eq!(o.status.code(), Some(2), "{out}: {}", stderr(&o));
        assert!(
            stderr(&o).contains("is the frames folder of another render"),
            "{out}: {}",
            stderr(&o)
        );
    }
    assert_eq!(listing(), before);
    assert!(!tmp.path().join("out/zoom").exists(), "nothing rendered");
}

/// An NTSC rate is stored as its exact fraction.
#[test]
#[ignore = "needs ffmpeg"]
fn ntsc_rates_are_stored_as_their_exact_fractions() {
    need_part("ffmpeg", "ffmpeg", |f| ffmpeg_lacks_encoder(f, "libx264"));
    need_tool("ffprobe", "ffmpeg");
    let tmp = tempfile::tempdir().unwrap();
    let f = example(tmp.path(), "width: 16, height: 10");
    let text = std::fs::read_to_string(tmp.path().join(&f)).unwrap();
    let run = |args: &[&str]| campath(tmp.path(), args, &[]);
    for (fps, want) in [
        ("23.976", "24000/1001"),
        ("29.97", "30000/1001"),
        ("12.5", "25/2"),
    ] {
        let edited = text.replacen("fps: 24.0", &format!("fps: {fps}"), 1);
        assert_ne!(edited, text, "the example's rate moved");
        std::fs::write(tmp.path().join(&f), edited).unwrap();
        let o = run(&["video", &f, "-q", "--out", "clip.mp4"]);
        assert!(o.status.success(), "{}", stderr(&o));
        let probe = Command::new("ffprobe")
            .args(["-v", "error", "-select_streams", "v:0"])
            .args(["-show_entries", "stream=r_frame_rate", "-of", "csv=p=0"])
            .arg(tmp.path().join("clip.mp4"))
            .output()
            .unwrap();
        assert_eq!(String::from_utf8_lossy(&probe.stdout).trim(), want, "{fps}");
    }
}

/// The temporary files that writes of `name` in `dir` leave: `.NAME.XXXXXX.tmp`.
fn temps_of(dir: &Path, name: &str) -> Vec<PathBuf> {
    let prefix = format!(".{name}.");
    // No folder yet: none.
    let mut found: Vec<PathBuf> = (std::fs::read_dir(dir).into_iter().flatten())
        .map(|e| e.unwrap().path())
        .filter(|p| {
            let n = p.file_name().unwrap().to_str().unwrap();
            n.starts_with(&prefix) && n.ends_with(".tmp")
        })
        .collect();
    found.sort();
    found
}
