//! Shutter motion blur (`image.motion_blur`): a blurred frame against renders of the same path
//! at sixteen times the frame rate, a camera that stands still during the shutter, the same
//! bytes on every thread count and instruction path, and the key.

use std::path::Path;

use crate::common::{campath, stderr, stdout};
use campath::document::Document;
use campath::frames::{for_each_frame, keys, FrameSet};
use campath::internals::Wait;
use campath::internals::{lock, render, RenderOptions};
use campath::internals::{Renderer, SceneIndex, Simd};

/// A moving shot: the camera flies past on a spline, turns to follow a moving target and
/// zooms, over spheres with shadows. `{image}` is the image section's extra fields, `{fps}` and
/// `{frames}` the timing; the keys are in seconds, so any frame rate gives the same path. 64×36:
/// 9 bands of 4 rows, more than the most threads the tests render on.
const MOVING: &str = "(
    frames: {frames}, fps: {fps},
    image: (width: 64, height: 36{image}),
    camera: (vuv: (0.0, 1.0, 0.0), hfov: 60.0),
    animate: [
        Observer(keys: [(t: 0.0, value: (-7.0, 2.0, -9.0)), (t: 0.25, value: (-2.0, 1.5, -8.0)),
                        (t: 0.5, value: (4.0, 2.5, -7.0))], interpolation: CatmullRom),
        Track(keys: [(t: 0.0, value: (0.0, 0.0, 0.0)), (t: 0.5, value: (1.5, 0.5, 0.0))]),
        Zoom(keys: [(t: 0.0, value: -1.0), (t: 0.5, value: -1.3)], interpolation: Linear),
    ],
    scene: (
        background: (0.2, 0.3, 0.5), ambient: 0.1,
        lights: [(direction: (-1.0, -2.0, 1.0))],
        spheres: [(center: (0.0, 0.0, 0.0), radius: 1.0, color: (0.9, 0.2, 0.2)),
                  (center: (2.0, 0.3, 1.0), radius: 0.6, color: (0.2, 0.9, 0.3)),
                  (center: (-1.6, -0.4, 0.5), radius: 0.5, color: (0.95, 0.9, 0.2)),
                  (center: (0.8, 1.2, -1.5), radius: 0.3, color: (0.3, 0.4, 0.95)),
                  (center: (0.0, -101.0, 0.0), radius: 100.0, color: (0.8, 0.8, 0.8))],
    ),
)";

/// Frames of the blurred shot at 24 fps: 12 frames reach 0.46 s, inside the path.
const FRAMES: u64 = 12;

fn shot(fps: f64, frames: u64, image: &str) -> Document {
    let text = MOVING
        .replace("{fps}", &format!("{fps:?}"))
        .replace("{frames}", &frames.to_string())
        .replace("{image}", image);
    Document::from_str(Path::new("moving.ron"), &text).unwrap_or_else(|e| panic!("{e}"))
}

/// Every frame of `doc`'s `frames`, in order.
fn frames(doc: &Document, frames: std::ops::Range<u64>) -> Vec<Vec<u8>> {
    let mut out = Vec::new();
    for_each_frame(
        doc,
        &FrameSet::all(frames),
        |_| false,
        |_, _, pixels, _| {
            out.push(pixels.to_vec());
            Ok(())
        },
    )
    .unwrap();
    out
}

/// sRGB level (0–255) to linear light, by the standard's formula (IEC 61966-2-1).
fn decode(level: u8) -> f64 {
    let e = f64::from(level) / 255.0;
    if e <= 0.04045 {
        e / 12.92
    } else {
        ((e + 0.055) / 1.055).powf(2.4)
    }
}

/// Linear light to the nearest sRGB level, by the standard's formula.
fn encode(x: f64) -> u8 {
    let x = x.clamp(0.0, 1.0);
    let e = if x <= 0.0031308 {
        12.92 * x
    } else {
        1.055 * x.powf(1.0 / 2.4) - 0.055
    };
    (e * 255.0).round() as u8
}

/// THE test of motion blur: with `shutter: 0.5, samples: 4`, time sample j of frame k is at
/// (k + (2j − 3)/16) / fps, which is fine frame 16k + 2j − 3 of the same path at 16 × fps. Each
/// blurred frame is the mean in linear light of fine frames 16k−3, 16k−1, 16k+1, 16k+3 (here
/// averaged from their 8-bit levels, so within one level) on at least 99.5% of its pixels; at
/// one sample a pixel and with adaptive 3×3 samples (each time sample takes the full pixel
/// pattern).
#[test]
fn a_blurred_frame_is_the_mean_of_the_fine_frames_at_its_time_samples() {
    for image in [", samples: 1", ", samples: 3, adaptive: true"] {
        let blur = format!("{image}, motion_blur: (shutter: 0.5, samples: 4)");
        let blurred = frames(&shot(24.0, FRAMES, &blur), 1..FRAMES);
        let fine = frames(&shot(24.0 * 16.0, 16 * FRAMES, image), 0..16 * FRAMES);
        let plain = frames(&shot(24.0, FRAMES, image), 1..FRAMES);
        let mut moved = 0;
        for (i, frame) in blurred.iter().enumerate() {
            let k = i + 1;
            let at = [16 * k - 3, 16 * k - 1, 16 * k + 1, 16 * k + 3];
            let pixels = frame.len() / 3;
            let mut within = 0;
            let mut worst = 0;
            for p in 0..pixels {
                let mut ok = true;
                for a in 0..3 {
                    let b = 3 * p + a;
                    let mean = at.iter().map(|&f| decode(fine[f][b])).sum::<f64>() / 4.0;
                    let d = (i32::from(frame[b]) - i32::from(encode(mean))).abs();
                    worst = worst.max(d);
                    ok &= d <= 1;
                }
                within += usize::from(ok);
            }
            assert!(
                within as f64 >= 0.995 * pixels as f64,
                "{image}, frame {k}: {within} of {pixels} pixels within one level (worst {worst})"
            );
            // The blur is there: the frame differs from the one without blur.
            let differ = frame
                .chunks(3)
                .zip(plain[i].chunks(3))
                .filter(|(a, b)| a != b)
                .count();
            assert!(differ > 0, "{image}, frame {k}: no blur");
            moved += usize::from(differ > pixels / 50);
        }
        // Most frames move far enough to blur a fiftieth of their pixels.
        assert!(2 * moved > blurred.len(), "{image}: {moved} frames blurred");
    }
}

/// A shot whose camera holds still from 0 to 0.5 s, then moves: the frames whose shutter lies
/// in the hold render once, with the bytes of the frame without blur; the later ones are blurred.
#[test]
fn a_still_camera_hashes_as_without_blur_and_renders_once() {
    let text = |image: &str| {
        format!(
            "(frames: 20, fps: 24.0, image: (width: 80, height: 45{image}),
            camera: (tp: (0.0, 0.0, 0.0)),
            animate: [Observer(keys: [(t: 0.0, value: (0.0, 1.0, -6.0)), (t: 0.5, value: (0.0, 1.0, -6.0)),
                (t: 1.0, value: (4.0, 1.0, -5.0))], interpolation: Linear)],
            scene: (lights: [(direction: (-1.0, -2.0, 1.0))],
                spheres: [(center: (0.0, 0.0, 0.0), radius: 1.0, color: (0.9, 0.2, 0.2)),
                          (center: (1.5, 0.0, 1.0), radius: 0.5)]))"
        )
    };
    let load = |t: String| Document::from_str(Path::new("still.ron"), &t).unwrap();
    for image in ["", ", samples: 2", ", samples: 4, adaptive: true"] {
        let plain = load(text(image));
        let blurred = load(text(&format!(
            "{image}, motion_blur: (shutter: 1.0, samples: 8)"
        )));
        let with = campath::frames::hashes(&blurred, 0..20).unwrap();
        let without = campath::frames::hashes(&plain, 0..20).unwrap();
        // Frame 12 is at 0.5 s: its shutter runs past the hold.
        for k in 0..20 {
            let exposure = blurred.exposure(k).unwrap();
            let still = k < 12;
            assert_eq!(exposure.times.len(), 8);
            assert_eq!(
                exposure.renders().len(),
                if still { 1 } else { 8 },
                "frame {k}"
            );
            if still {
                assert_eq!(with[k as usize], without[k as usize], "{image}, frame {k}");
            } else {
                assert_ne!(with[k as usize], without[k as usize], "{image}, frame {k}");
            }
        }
    }
}

/// A blurred frame's bytes on one, two and three threads and on every instruction path this
/// CPU runs, at one sample a pixel, at 3×3 and adaptive 4×4 (and hashes through the frame
/// engine against a frame rendered alone).
#[test]
fn blurred_frames_are_the_same_on_every_thread_count_and_path() {
    for image in [
        ", samples: 1",
        ", samples: 3",
        ", samples: 4, adaptive: true",
    ] {
        let doc = shot(
            24.0,
            FRAMES,
            &format!("{image}, motion_blur: (shutter: 0.8, samples: 5)"),
        );
        let index = SceneIndex::new(doc.scene());
        for frame in [0, 6] {
            let exposure = doc.exposure(frame).unwrap();
            assert_eq!(exposure.renders().len(), 5);
            let mut first: Option<Vec<u8>> = None;
            for simd in Simd::ALL.into_iter().filter(|s| s.supported()) {
                for threads in [1, 2, 3] {
                    let pool = rayon::ThreadPoolBuilder::new()
                        .num_threads(threads)
                        .build()
                        .unwrap();
                    let pixels = pool.install(|| {
                        let mut r = Renderer::with_simd(simd).unwrap();
                        let mut pixels = Vec::new();
                        r.prepare_times(exposure.renders(), &index, *doc.raster())
                            .render_into(&mut pixels, &mut |_| {});
                        pixels
                    });
                    match &first {
                        None => first = Some(pixels),
                        Some(f) => assert!(
                            *f == pixels,
                            "{image}, frame {frame}: {} on {threads} thread(s) differs",
                            simd.name()
                        ),
                    }
                }
            }
            let alone = campath::frames::render_frame(&doc, frame).unwrap();
            assert!(first.unwrap() == alone, "{image}, frame {frame}");
        }
    }
}

/// The key covers the setting: every frame's key differs between no blur and each setting,
/// still frames included; and a folder rendered without blur is rendered again with it.
#[test]
fn the_key_changes_with_the_setting() {
    let settings = [
        "",
        ", motion_blur: (shutter: 0.5, samples: 4)",
        ", motion_blur: (shutter: 0.75, samples: 4)",
        ", motion_blur: (shutter: 0.5, samples: 5)",
        ", motion_blur: (shutter: 1.0, samples: 1)",
    ];
    let all: Vec<Vec<String>> = settings
        .iter()
        .map(|s| {
            keys(&shot(24.0, 4, s))
                .map(|k| k.unwrap().1.to_string())
                .collect::<Vec<_>>()
        })
        .collect();
    for (a, keys_a) in all.iter().enumerate() {
        for (b, keys_b) in all.iter().enumerate().skip(a + 1) {
            for (frame, (x, y)) in keys_a.iter().zip(keys_b).enumerate() {
                let (sa, sb) = (settings[a], settings[b]);
                assert_ne!(x, y, "frame {frame}: {sa:?} and {sb:?}");
            }
        }
    }
    // Without blur the key is the one without the field (the same bytes as before it existed).
    let absent = MOVING
        .replace("{fps}", "24.0")
        .replace("{frames}", "4")
        .replace("{image}", "");
    let absent = Document::from_str(Path::new("moving.ron"), &absent).unwrap();
    let plain: Vec<String> = keys(&absent).map(|k| k.unwrap().1.to_string()).collect();
    assert_eq!(plain, all[0]);
    // Rendered into a folder without blur, then with: every frame again.
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("out");
    for (setting, kept) in [(settings[0], 0), (settings[0], 4), (settings[1], 0)] {
        let doc = shot(24.0, 4, setting);
        let set = FrameSet::all(0..4);
        let lock = lock(&doc, &dir, &set, Wait::No).unwrap();
        let summary = render(&doc, &lock, &set, RenderOptions::default(), &mut |_| {}).unwrap();
        assert_eq!(summary.kept, kept, "{setting:?}");
    }
}

/// With motion blur every time sample's camera is checked: a camera that passes through its
/// target between frames is an error naming the frame and the time sample's time.
#[test]
fn a_camera_undefined_at_a_time_sample_is_an_error_naming_it() {
    let text = |image: &str| {
        format!(
            "(frames: 2, fps: 1.0, image: (width: 8, height: 8{image}),
            camera: (tp: (0.0, 0.0, 0.0)),
            animate: [Observer(keys: [(t: 0.0, value: (0.0, 0.0, -1.0)), (t: 1.0, value: (0.0, 0.0, 3.0))],
                interpolation: Linear)],
            scene: (spheres: [(center: (0.0, 2.0, 0.0), radius: 1.0)]))"
        )
    };
    // Frames at 0 and 1 s; time samples at ±0.25 s, and at 0.25 s the VRP is the target.
    let plain = Document::from_str(Path::new("z.ron"), &text("")).unwrap();
    plain.check_path().unwrap();
    let blur = ", motion_blur: (shutter: 1.0, samples: 2)";
    let blurred = Document::from_str(Path::new("z.ron"), &text(blur)).unwrap();
    let err = blurred.check_path().unwrap_err().to_string();
    assert!(err.contains("frame 0 (t = 0.25 s)"), "{err}");
}

/// `path` reports frame times with motion blur as without: the same CSV, one row a frame.
#[test]
fn path_reports_frame_times() {
    let tmp = tempfile::tempdir().unwrap();
    let text = |image: &str| {
        MOVING
            .replace("{fps}", "24.0")
            .replace("{frames}", "6")
            .replace("{image}", image)
    };
    std::fs::write(tmp.path().join("plain.ron"), text("")).unwrap();
    let blur = ", motion_blur: (shutter: 1.0, samples: 3)";
    std::fs::write(tmp.path().join("blur.ron"), text(blur)).unwrap();
    let csv = |f: &str| {
        let o = campath(tmp.path(), &["path", f], &[]);
        assert!(o.status.success(), "{}", stderr(&o));
        stdout(&o)
    };
    let plain = csv("plain.ron");
    assert_eq!(plain.lines().count(), 7);
    assert_eq!(csv("blur.ron"), plain);
}
