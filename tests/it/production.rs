//! Production use: atomic frames, resume after SIGKILL, shards and merge, progress, refusing
//! absurd requests and foreign folders.

use crate::common::{campath, frame_lines, frame_stamps, stderr, stdout};
use std::collections::BTreeMap;
use std::path::Path;
use std::process::Command;
use std::time::Duration;

/// 48 frames that take a moment each in a debug build.
const LONG: &str = "(
    frames: 48, fps: 24.0,
    image: (width: 240, height: 135, samples: 2),
    camera: (vrp: (0.0, 2.0, -8.0), tp: (0.0, 0.0, 0.0), window: (1.6, 0.9)),
    animate: [Observer(keys: [(t: 0.0, value: (0.0, 2.0, -8.0)), (t: 1.0, value: (6.0, 3.0, -3.0)), (t: 2.0, value: (0.0, 2.0, 6.0))])],
    scene: (ambient: 0.1, lights: [(direction: (-1.0, -2.0, 1.0))],
            spheres: [(center: (0.0, 0.0, 0.0), radius: 1.0, color: (0.9, 0.2, 0.2)), (center: (0.0, -101.0, 0.0), radius: 100.0, color: (0.5, 0.5, 0.5)),
                      (center: (2.0, 0.0, 1.0), radius: 0.6, color: (0.2, 0.8, 0.3))]),
)";

fn setup() -> tempfile::TempDir {
    let tmp = tempfile::tempdir().unwrap();
    std::fs::write(tmp.path().join("long.ron"), LONG).unwrap();
    tmp
}

/// [`LONG`] at `size` (`width: W, height: H`).
fn sized(size: &str) -> String {
    let text = LONG.replace("width: 240, height: 135", size);
    assert_ne!(text, LONG);
    text
}

/// [`LONG`] at 64×36, for the tests that kill no render part-way: what they check does not
/// depend on the size.
fn small() -> String {
    sized("width: 64, height: 36")
}

/// A folder with [`small`] as `long.ron`.
fn setup_small() -> tempfile::TempDir {
    let tmp = tempfile::tempdir().unwrap();
    std::fs::write(tmp.path().join("long.ron"), small()).unwrap();
    tmp
}

/// A folder with [`LONG`] at 160×90 as `long.ron`, for the tests that kill a render part-way:
/// they wait for frames to be listed before they kill, so frames need only take a moment.
fn setup_killable() -> tempfile::TempDir {
    let tmp = tempfile::tempdir().unwrap();
    std::fs::write(tmp.path().join("long.ron"), sized("width: 160, height: 90")).unwrap();
    tmp
}

fn read(path: &Path) -> String {
    std::fs::read_to_string(path).unwrap_or_default()
}

/// Every frame_*.png under its final name decodes in full, and every manifest line names such a
/// frame with its pixels' hash.
fn assert_consistent(dir: &Path) {
    let mut pngs = 0;
    for e in std::fs::read_dir(dir).unwrap().flatten() {
        let name = e.file_name().to_string_lossy().into_owned();
        if name.starts_with("frame_") && name.ends_with(".png") {
            image::open(e.path()).unwrap_or_else(|err| panic!("{name} is partial: {err}"));
            pngs += 1;
        }
    }
    for line in frame_lines(&read(&dir.join("hashes.txt"))) {
        let cols: Vec<&str> = line.split(' ').collect();
        let [frame, hash, key] = cols[..] else {
            continue; // a torn last line, dropped on resume
        };
        if hash.len() != 64 || key.len() != 64 {
            continue;
        }
        let png = dir.join(format!("frame_{:04}.png", frame.parse::<u64>().unwrap()));
        let raw = image::open(&png)
            .unwrap_or_else(|e| panic!("{} listed but unreadable: {e}", png.display()))
            .to_rgb8()
            .into_raw();
        assert_eq!(campath::frame_hash(&raw), hash, "frame {frame}");
    }
    assert!(pngs <= 48);
}

#[test]
fn a_killed_render_leaves_whole_frames_and_resumes_to_the_same_hashes() {
    let tmp = setup_killable();
    let whole = campath(
        tmp.path(),
        &["render", "long.ron", "--out", "whole", "--quiet"],
        &[],
    );
    assert!(whole.status.success(), "{}", stderr(&whole));
    let expected = read(&tmp.path().join("whole/hashes.txt"));
    assert_eq!(frame_lines(&expected).len(), 48);

    // Kill at fixed delays, and once as soon as the manifest lists a few more frames, so that
    // there is always something to resume from however fast the machine is.
    for (delay_ms, until_listed) in [(150u64, 0usize), (0, 5), (400, 0)] {
        let mut child = Command::new(env!("CARGO_BIN_EXE_campath"))
            .current_dir(tmp.path())
            .args(["render", "long.ron", "--out", "killed", "--quiet"])
            .spawn()
            .unwrap();
        std::thread::sleep(Duration::from_millis(delay_ms));
        let listed = || frame_lines(&read(&tmp.path().join("killed/hashes.txt"))).len();
        let before = listed();
        for _ in 0..2000 {
            if until_listed == 0 || listed() >= (before + until_listed).min(47) {
                break;
            }
            std::thread::sleep(Duration::from_millis(5));
        }
        child.kill().unwrap(); // SIGKILL
        child.wait().unwrap();
        assert_consistent(&tmp.path().join("killed"));
    }
    let resumed = campath(tmp.path(), &["render", "long.ron", "--out", "killed"], &[]);
    assert!(resumed.status.success(), "{}", stderr(&resumed));
    assert!(
        stdout(&resumed).contains(" kept") && !stdout(&resumed).contains("; 0 kept"),
        "the kills left no frame to resume from: {}",
        stdout(&resumed)
    );
    assert_eq!(read(&tmp.path().join("killed/hashes.txt")), expected);
    assert_consistent(&tmp.path().join("killed"));
    // A complete folder renders nothing again; --force renders everything.
    let again = campath(tmp.path(), &["render", "long.ron", "--out", "killed"], &[]);
    assert!(
        stdout(&again).contains("rendered 0 frame(s)") && stdout(&again).contains("48 kept"),
        "{}",
        stdout(&again)
    );
    let forced = campath(
        tmp.path(),
        &["render", "long.ron", "--out", "killed", "--force"],
        &[],
    );
    assert!(
        stdout(&forced).contains("rendered 48 frame(s)")
            && stdout(&forced).contains("0 kept")
            && stdout(&forced).contains("48 --force"),
        "{}",
        stdout(&forced)
    );
    assert_eq!(read(&tmp.path().join("killed/hashes.txt")), expected);
}

#[test]
fn a_damaged_frame_is_rendered_again() {
    let tmp = setup_small();
    let args = [
        "render", "long.ron", "--out", "o", "--frames", "0..4", "--quiet",
    ];
    assert!(campath(tmp.path(), &args, &[]).status.success());
    let expected = read(&tmp.path().join("o/hashes.txt"));
    std::fs::write(tmp.path().join("o/frame_0002.png"), b"not a png").unwrap();
    let again = campath(
        tmp.path(),
        &["render", "long.ron", "--out", "o", "--frames", "0..4"],
        &[],
    );
    assert!(
        stdout(&again).contains("rendered 1 frame(s)")
            && stdout(&again).contains("3 kept")
            && stdout(&again).contains("1 missing or damaged on disk"),
        "{}",
        stdout(&again)
    );
    assert_eq!(read(&tmp.path().join("o/hashes.txt")), expected);
}

fn shard(tmp: &Path, k: u64) -> Command {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_campath"));
    cmd.current_dir(tmp).args([
        "render",
        "long.ron",
        "--out",
        "farm",
        "--quiet",
        "--shard",
        &format!("{k}/3"),
    ]);
    cmd
}

#[test]
fn three_shards_merge_into_a_single_runs_manifest() {
    let tmp = setup_small();
    let single = campath(
        tmp.path(),
        &["render", "long.ron", "--out", "single", "--quiet"],
        &[],
    );
    assert!(single.status.success());
    let children: Vec<_> = (0..3)
        .map(|k| shard(tmp.path(), k).spawn().unwrap())
        .collect();
    for mut c in children {
        assert!(c.wait().unwrap().success());
    }
    let part = read(&tmp.path().join("farm/hashes.part-1-of-3.txt"));
    assert_eq!(frame_lines(&part).len(), 16);
    assert!(part.starts_with(&format!(
        "# campath renderer {}\n# campath part=1/3 range=0..48 frames=48 sequence=",
        campath::RENDERER_VERSION
    )));
    assert!(part.ends_with("# complete\n"));
    assert!(frame_lines(&part).iter().all(|l| l
        .split(' ')
        .next()
        .unwrap()
        .parse::<u64>()
        .unwrap()
        % 3
        == 1));
    let merged = campath(tmp.path(), &["merge", "farm"], &[]);
    assert!(merged.status.success(), "{}", stderr(&merged));
    assert_eq!(
        read(&tmp.path().join("farm/hashes.txt")),
        read(&tmp.path().join("single/hashes.txt"))
    );
    // A missing shard is named, and nothing is written.
    std::fs::remove_file(tmp.path().join("farm/hashes.txt")).unwrap();
    std::fs::remove_file(tmp.path().join("farm/hashes.part-2-of-3.txt")).unwrap();
    let broken = campath(tmp.path(), &["merge", "farm"], &[]);
    assert_eq!(broken.status.code(), Some(2));
    assert!(
        stderr(&broken).contains("shard 2/3 never ran"),
        "{}",
        stderr(&broken)
    );
    assert!(!tmp.path().join("farm/hashes.txt").exists());
    // Parts of another shard count are named with their files.
    std::fs::write(tmp.path().join("farm/hashes.part-0-of-2.txt"), "").unwrap();
    let mixed = campath(tmp.path(), &["merge", "farm"], &[]);
    assert_eq!(mixed.status.code(), Some(2));
    for want in [
        "2 different shard counts",
        "N = 2: hashes.part-0-of-2.txt",
        "N = 3: hashes.part-0-of-3.txt, hashes.part-1-of-3.txt",
    ] {
        assert!(stderr(&mixed).contains(want), "{want}: {}", stderr(&mixed));
    }
}

/// The frame key of each line of a hashes.txt.
fn keys_of(manifest: &str) -> BTreeMap<String, String> {
    frame_lines(manifest)
        .iter()
        .map(|l| {
            let f: Vec<&str> = l.split(' ').collect();
            (
                format!("frame_{:04}.png", f[0].parse::<u64>().unwrap()),
                f[2].to_string(),
            )
        })
        .collect()
}

#[test]
fn shards_on_a_finished_folder_render_only_the_frames_an_edit_changed() {
    let tmp = setup_small();
    let farm = tmp.path().join("farm");
    let single = |out: &str| {
        let run = campath(
            tmp.path(),
            &["render", "long.ron", "--out", out, "--quiet"],
            &[],
        );
        assert!(run.status.success(), "{}", stderr(&run));
        read(&tmp.path().join(out).join("hashes.txt"))
    };
    let before = single("farm");
    let long = small();
    // A key after the last: the frames of the last segment change, the others keep their keys.
    let edited = long.replace(
        "(t: 2.0, value: (0.0, 2.0, 6.0))",
        "(t: 2.0, value: (0.0, 2.0, 6.0)), (t: 3.0, value: (-3.0, 2.0, 6.0))",
    );
    assert_ne!(edited, long);
    std::fs::write(tmp.path().join("long.ron"), &edited).unwrap();
    let after = single("single");
    let (old_keys, new_keys) = (keys_of(&before), keys_of(&after));
    let changed: Vec<&String> = new_keys
        .keys()
        .filter(|f| old_keys[*f] != new_keys[*f])
        .collect();
    assert!((12..36).contains(&changed.len()), "{changed:?}");
    let stamps = frame_stamps(&farm);
    // One shard after another, each on the folder the one before it left.
    for k in 0..3 {
        assert!(shard(tmp.path(), k).status().unwrap().success());
        assert!(
            !farm.join("hashes.txt").exists(),
            "a shard leaves no stale hashes.txt"
        );
    }
    let now = frame_stamps(&farm);
    let rewritten: Vec<&String> = now.keys().filter(|f| stamps[*f] != now[*f]).collect();
    assert_eq!(
        rewritten, changed,
        "exactly the changed frames are rendered again"
    );
    let merged = campath(tmp.path(), &["merge", "farm"], &[]);
    assert!(merged.status.success(), "{}", stderr(&merged));
    assert_eq!(read(&farm.join("hashes.txt")), after);
    assert!(!farm.join("hashes.before-shards.txt").exists());
    assert_consistent(&farm);
    // Shards again on the merged folder keep every frame, and a whole run finds nothing to do.
    let stamps = frame_stamps(&farm);
    for k in 0..3 {
        assert!(shard(tmp.path(), k).status().unwrap().success());
    }
    assert_eq!(frame_stamps(&farm), stamps);
    assert!(farm.join("hashes.before-shards.txt").exists());
    single("farm");
    assert_eq!(frame_stamps(&farm), stamps);
    assert_eq!(read(&farm.join("hashes.txt")), after);
    assert!(!farm.join("hashes.before-shards.txt").exists());
    assert!(manifest_parts(&farm).is_empty());

    // Back to the first file in one shard of two, then forward again in a run of one frame:
    // what the shard moved aside names the edited file's pictures, which the shard replaced;
    // none of them is listed as current, and the folder holds no picture it does not list.
    std::fs::write(tmp.path().join("long.ron"), &long).unwrap();
    let half = campath(
        tmp.path(),
        &[
            "render", "long.ron", "--out", "farm", "--quiet", "--shard", "0/2",
        ],
        &[],
    );
    assert!(half.status.success(), "{}", stderr(&half));
    std::fs::write(tmp.path().join("long.ron"), &edited).unwrap();
    let one = campath(
        tmp.path(),
        &[
            "render", "long.ron", "--out", "farm", "--quiet", "--frames", "1",
        ],
        &[],
    );
    assert!(one.status.success(), "{}", stderr(&one));
    assert_consistent(&farm);
    let listed = frame_lines(&read(&farm.join("hashes.txt"))).len();
    assert_eq!(listed, frame_stamps(&farm).len());
    assert!(
        listed < 48,
        "the shard's pictures of the first file are listed"
    );
    single("farm");
    assert_eq!(read(&farm.join("hashes.txt")), after);
}

/// A whole run that cannot write its manifest has removed nothing: the shards' records and
/// every picture are still there, and the next run keeps every frame it did not render.
#[test]
fn a_whole_run_that_cannot_write_its_manifest_removes_nothing() {
    let tmp = setup_small();
    for k in 0..3 {
        assert!(shard(tmp.path(), k).status().unwrap().success());
    }
    let farm = tmp.path().join("farm");
    let stamps = frame_stamps(&farm);
    // hashes.txt cannot be renamed into place: a folder has its name.
    std::fs::create_dir(farm.join("hashes.txt")).unwrap();
    let one = |dir: &Path| {
        campath(
            dir,
            &["render", "long.ron", "--out", "farm", "--frames", "0"],
            &[],
        )
    };
    let failed = one(tmp.path());
    assert_eq!(failed.status.code(), Some(1), "{}", stderr(&failed));
    assert_eq!(manifest_parts(&farm).len(), 3);
    assert_eq!(frame_stamps(&farm), stamps);
    std::fs::remove_dir(farm.join("hashes.txt")).unwrap();
    let again = one(tmp.path());
    assert!(again.status.success(), "{}", stderr(&again));
    assert!(!stdout(&again).contains("stale"), "{}", stdout(&again));
    assert_eq!(frame_stamps(&farm), stamps);
    assert_eq!(frame_lines(&read(&farm.join("hashes.txt"))).len(), 48);
    assert_consistent(&farm);
}

fn manifest_parts(dir: &Path) -> Vec<String> {
    std::fs::read_dir(dir)
        .unwrap()
        .flatten()
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| n.starts_with("hashes.part-"))
        .collect()
}

#[test]
fn merge_refuses_while_a_killed_shard_is_unfinished() {
    let tmp = setup_killable();
    let single = campath(
        tmp.path(),
        &["render", "long.ron", "--out", "single", "--quiet"],
        &[],
    );
    assert!(single.status.success());
    for k in [0, 2] {
        assert!(shard(tmp.path(), k).status().unwrap().success());
    }
    // Shard 1 is killed once it has listed a few frames.
    let part = tmp.path().join("farm/hashes.part-1-of-3.txt");
    let mut child = shard(tmp.path(), 1).spawn().unwrap();
    for _ in 0..4000 {
        if frame_lines(&read(&part)).len() >= 3 {
            break;
        }
        std::thread::sleep(Duration::from_millis(5));
    }
    child.kill().unwrap(); // SIGKILL
    child.wait().unwrap();
    let listed = frame_lines(&read(&part)).len();
    assert!((3..16).contains(&listed), "shard 1 listed {listed} frames");
    let refused = campath(tmp.path(), &["merge", "farm"], &[]);
    assert_eq!(refused.status.code(), Some(2), "{}", stdout(&refused));
    let want = format!(
        "shard 1/3 did not finish: hashes.part-1-of-3.txt lists {listed} of its 16 frame(s)"
    );
    assert!(stderr(&refused).contains(&want), "{}", stderr(&refused));
    assert!(!tmp.path().join("farm/hashes.txt").exists());
    // Run again with the same arguments: it resumes, and the merge is a single run's manifest.
    assert!(shard(tmp.path(), 1).status().unwrap().success());
    let merged = campath(tmp.path(), &["merge", "farm"], &[]);
    assert!(merged.status.success(), "{}", stderr(&merged));
    assert_eq!(
        read(&tmp.path().join("farm/hashes.txt")),
        read(&tmp.path().join("single/hashes.txt"))
    );
    // A frame damaged after its shard finished: merge names it and writes nothing.
    std::fs::remove_file(tmp.path().join("farm/hashes.txt")).unwrap();
    std::fs::write(tmp.path().join("farm/frame_0004.png"), b"not a png").unwrap();
    let damaged = campath(tmp.path(), &["merge", "farm"], &[]);
    assert_eq!(damaged.status.code(), Some(2));
    assert!(
        stderr(&damaged).contains("frame(s) 4 do not decode to their recorded hashes"),
        "{}",
        stderr(&damaged)
    );
    assert!(!tmp.path().join("farm/hashes.txt").exists());
}

#[test]
fn progress_lines_off_a_terminal_and_quiet_prints_nothing() {
    let tmp = setup_small();
    // Off a terminal: a line at the start, one every few seconds, one at the end (so a CI log
    // of 48 frames holds a handful of lines, not 48).
    let started = std::time::Instant::now();
    let o = campath(tmp.path(), &["render", "long.ron", "--out", "a"], &[]);
    let secs = started.elapsed().as_secs_f64();
    assert!(o.status.success(), "{}", stderr(&o));
    let err = stderr(&o);
    let lines: Vec<&str> = err.lines().collect();
    assert_eq!(lines[0], "48 frame(s) to render, 0 kept", "{err}");
    let last = lines.last().unwrap();
    assert!(
        last.starts_with("48/48 frame(s), 48 of 48 to render done in "),
        "{last}"
    );
    assert!(
        lines.len() <= 2 + (secs / 5.0).ceil() as usize,
        "{} lines in {secs:.1} s: {}",
        lines.len(),
        stderr(&o)
    );
    // CAMPATH_PROGRESS_SECS sets the interval: 0 gives a line per frame.
    let o = campath(
        tmp.path(),
        &["render", "long.ron", "--out", "b", "--frames", "0..3"],
        &[("CAMPATH_PROGRESS_SECS", "0")],
    );
    let err = stderr(&o);
    let lines: Vec<&str> = err.lines().collect();
    assert_eq!(lines.len(), 4, "{err}");
    for (line, done) in lines[1..].iter().zip(1..) {
        assert!(
            line.starts_with(&format!(
                "{done}/3 frame(s), {done} of 3 to render done in "
            )),
            "{line}"
        );
    }
    let q = campath(
        tmp.path(),
        &[
            "render", "long.ron", "--out", "c", "--frames", "0..3", "--quiet",
        ],
        &[],
    );
    assert!(q.status.success());
    assert!(stdout(&q).is_empty() && stderr(&q).is_empty());
}

#[test]
fn a_folder_with_other_files_is_never_clobbered() {
    let tmp = setup_small();
    std::fs::create_dir(tmp.path().join("mine")).unwrap();
    std::fs::write(tmp.path().join("mine/notes.txt"), "keep").unwrap();
    let o = campath(tmp.path(), &["render", "long.ron", "--out", "mine"], &[]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("notes.txt"), "{}", stderr(&o));
    let names: Vec<_> = std::fs::read_dir(tmp.path().join("mine"))
        .unwrap()
        .flatten()
        .map(|e| e.file_name())
        .collect();
    assert_eq!(names, ["notes.txt"]);
}

#[test]
fn absurd_requests_are_refused_before_allocating() {
    let tmp = tempfile::tempdir().unwrap();
    for (text, expect) in [
        (
            "(image: (width: 100000, height: 100000), camera: (vpn: (0.0, 0.0, 1.0)))",
            "image.width",
        ),
        (
            "(frames: 1000000000, camera: (vpn: (0.0, 0.0, 1.0)))",
            "frames: must lie in 1..=10000000, got 1000000000",
        ),
    ] {
        std::fs::write(tmp.path().join("absurd.ron"), text).unwrap();
        let o = campath(tmp.path(), &["render", "absurd.ron"], &[]);
        assert_eq!(o.status.code(), Some(2));
        assert!(stderr(&o).contains(expect), "{}", stderr(&o));
        assert!(!tmp.path().join("out").exists());
    }
}

/// The frame hash of the 60×34 tile at `(x0, y0)` of a contact sheet.
fn tile_hash(sheet: &image::RgbImage, (x0, y0): (u32, u32)) -> campath::FrameHash {
    let mut tile = Vec::new();
    for y in y0..y0 + 34 {
        for x in x0..x0 + 60 {
            tile.extend(sheet.get_pixel(x, y).0);
        }
    }
    campath::frame_hash(&tile)
}

/// Every frame of a GIF, decoded.
fn gif_frames(path: &Path) -> Vec<image::Frame> {
    use image::AnimationDecoder;
    let file = std::io::BufReader::new(std::fs::File::open(path).unwrap());
    let decoder = image::codecs::gif::GifDecoder::new(file).unwrap();
    decoder.into_frames().collect_frames().unwrap()
}

#[test]
fn preview_writes_a_contact_sheet_of_small_renders_and_a_gif() {
    let tmp = setup();
    let o = campath(
        tmp.path(),
        &[
            "preview", "long.ron", "--out", "p", "--width", "60", "--count", "6",
        ],
        &[],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    // 240×135 shrinks to 60×34; six tiles in two rows of four columns, 2 px apart, each with a
    // 16 px band under it for its frame number.
    let sheet = image::open(tmp.path().join("p/preview.png"))
        .unwrap()
        .to_rgb8();
    assert_eq!(sheet.dimensions(), (4 * 60 + 3 * 2, 2 * (34 + 16) + 2));
    // The bands hold dark text (the frame numbers) on white.
    for (x0, y0) in [(0, 34), (62, 34), (0, 86)] {
        let dark = (x0..x0 + 60)
            .flat_map(|x| (y0..y0 + 16).map(move |y| (x, y)))
            .filter(|&(x, y)| sheet.get_pixel(x, y).0.iter().all(|&c| c < 128))
            .count();
        assert!(dark > 5, "no frame number under the tile at ({x0}, {y0})");
    }
    // The first tile is frame 0 rendered at 60×34 with one sample.
    let small = campath::raster::Raster {
        width: 60,
        height: 34, // 135 · 60 / 240 = 33.75, rounded
        samples: 1,
        adaptive: false,
    };
    let doc = campath::document::Document::load(&tmp.path().join("long.ron"))
        .unwrap()
        .with_raster(small)
        .unwrap();
    let frame0 = campath::frames::hashes(&doc, 0..1).unwrap();
    assert_eq!(tile_hash(&sheet, (0, 0)), frame0[0].1);
    // The GIF holds every frame of the 48.
    let frames = gif_frames(&tmp.path().join("p/preview.gif"));
    assert_eq!(frames.len(), 48);
    assert_eq!(frames[0].buffer().dimensions(), (60, 34));
    // Its delays keep the file's pace: 48 frames at 24 fps in 200 centiseconds.
    let centis = |f: &image::Frame| {
        let (n, d) = f.delay().numer_denom_ms();
        assert_eq!((n * 100) % (d * 1000), 0, "{n}/{d} ms");
        n / d / 10
    };
    assert!(frames.iter().all(|f| (4..=5).contains(&centis(f))));
    assert_eq!(frames.iter().map(centis).sum::<u32>(), 200);

    // At 60 fps every other frame: no frame shorter than 2 centiseconds, and the same pace;
    // the sheet's last tile is still the last frame, though the frames between are not
    // rendered.
    std::fs::write(
        tmp.path().join("fast.ron"),
        LONG.replace("fps: 24.0", "fps: 60.0"),
    )
    .unwrap();
    let o = campath(
        tmp.path(),
        &[
            "preview", "fast.ron", "--out", "f", "--width", "60", "--count", "6",
        ],
        &[],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let frames = gif_frames(&tmp.path().join("f/preview.gif"));
    assert_eq!(frames.len(), 24);
    assert!(frames.iter().all(|f| (3..=4).contains(&centis(f))));
    assert_eq!(frames.iter().map(centis).sum::<u32>(), 80);
    let sheet = image::open(tmp.path().join("f/preview.png"))
        .unwrap()
        .to_rgb8();
    let fast = campath::document::Document::load(&tmp.path().join("fast.ron")).unwrap();
    let doc = fast.with_raster(small).unwrap();
    let last = campath::frames::hashes(&doc, 47..48).unwrap();
    // The sixth tile: second row, second column.
    assert_eq!(tile_hash(&sheet, (60 + 2, 34 + 16 + 2)), last[0].1);

    // Tiles narrower than their frame numbers: each slot is widened to its number, and no
    // number runs into the gap between slots.
    let o = campath(
        tmp.path(),
        &[
            "preview", "long.ron", "--out", "t", "--width", "3", "--count", "6",
        ],
        &[],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let sheet = image::open(tmp.path().join("t/preview.png"))
        .unwrap()
        .to_rgb8();
    let slot = (sheet.width() - 3 * 2) / 4;
    assert!(slot > 6, "{slot}");
    for row in 0..2 {
        let band = row * (2 + 16 + 2) + 2..row * (2 + 16 + 2) + 2 + 16;
        let ink = |x: u32| {
            band.clone()
                .any(|y| sheet.get_pixel(x, y).0.iter().all(|&c| c < 160))
        };
        let slots = if row == 0 { 4 } else { 2 };
        for k in 0..slots {
            let x0 = k * (slot + 2);
            assert!(
                (x0..x0 + slot).any(ink),
                "no number in slot {k} of row {row}"
            );
            if k + 1 < slots {
                assert!(
                    !(x0 + slot..x0 + slot + 2).any(ink),
                    "slot {k} of row {row}"
                );
            }
        }
    }
}

#[test]
fn plot_draws_the_path_from_above_and_from_the_side() {
    let tmp = setup();
    let o = campath(
        tmp.path(),
        &["plot", "long.ron", "--out", "plot.png", "--every", "12"],
        &[],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let img = image::open(tmp.path().join("plot.png")).unwrap().to_rgb8();
    assert_eq!(img.dimensions(), (1400, 700));
    // The blue VRP path appears in both panels (above the legend strip, the bottom 70 px);
    // the red keyframe dots too.
    for (x0, x1) in [(0, 700), (700, 1400)] {
        let count = |rgb: [u8; 3]| {
            (x0..x1)
                .flat_map(|x| (0..img.height() - 70).map(move |y| (x, y)))
                .filter(|&(x, y)| img.get_pixel(x, y).0 == rgb)
                .count()
        };
        assert!(count([0, 0, 255]) > 50, "no path in panel {x0}..{x1}");
        assert!(count([255, 0, 0]) > 20, "no keyframes in panel {x0}..{x1}");
    }
}

#[test]
fn a_terminal_gets_a_progress_bar() {
    // `script` (util-linux) gives the render a pseudo-terminal.
    let tmp = setup();
    let cmd = format!("{} render long.ron --out t", env!("CARGO_BIN_EXE_campath"));
    let o = Command::new("script")
        .current_dir(tmp.path())
        .args(["-qec", &cmd, "/dev/null"])
        .output()
        .expect("script (util-linux) runs");
    assert!(o.status.success());
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(
        text.contains("/48 frames to render,") && text.contains("ETA"),
        "{text}"
    );
    assert!(
        !text.contains("frame 0 done"),
        "a terminal gets the bar, not lines"
    );
}

#[test]
fn the_plot_from_above_agrees_with_the_frames_left_and_right() {
    // A camera looking along +z with VUV = +y sees −x on its right (u = n × VUV): the magenta
    // sphere at x = −3 is on the right of its frames, and must be right of the path in the plot.
    let tmp = tempfile::tempdir().unwrap();
    std::fs::write(
        tmp.path().join("side.ron"),
        "(frames: 3, image: (width: 64, height: 36), camera: (vpn: (0.0, 0.0, 1.0), window: (4.0, 2.25)),
          animate: [Observer(keys: [(t: 0.0, value: (0.0, 0.0, -10.0)), (t: 0.1, value: (0.0, 0.0, -8.0))], interpolation: Linear)],
          scene: (spheres: [(center: (-3.0, 0.0, 0.0), radius: 1.0, color: (1.0, 0.0, 1.0))]))",
    )
    .unwrap();
    let o = campath(
        tmp.path(),
        &["render", "side.ron", "--frames", "0", "--quiet"],
        &[],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let frame = image::open(tmp.path().join("out/side/frame_0000.png"))
        .unwrap()
        .to_rgb8();
    let lit: Vec<u32> = frame
        .enumerate_pixels()
        .filter(|(_, _, p)| p.0 != [0, 0, 0])
        .map(|(x, _, _)| x)
        .collect();
    assert!(
        !lit.is_empty() && lit.iter().all(|x| *x > 32),
        "the sphere is right of centre"
    );
    let o = campath(tmp.path(), &["plot", "side.ron", "--out", "plot.png"], &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    let plot = image::open(tmp.path().join("plot.png")).unwrap().to_rgb8();
    let mean_x = |rgb: [u8; 3]| {
        let xs: Vec<u32> = (0..700)
            .flat_map(|x| (0..630).map(move |y| (x, y)))
            .filter(|&(x, y)| plot.get_pixel(x, y).0 == rgb)
            .map(|(x, _)| x)
            .collect();
        assert!(xs.len() > 10, "{rgb:?} not drawn in the top view");
        xs.iter().sum::<u32>() as f64 / xs.len() as f64
    };
    assert!(
        mean_x([255, 0, 255]) > mean_x([0, 0, 255]) + 50.0,
        "sphere right of the path"
    );
    let path_x = mean_x([0, 0, 255]);

    // A sphere under a pixel across is drawn too, as a dot of its colour at its place.
    let text = std::fs::read_to_string(tmp.path().join("side.ron")).unwrap();
    let tiny = text.replace("radius: 1.0", "radius: 0.004");
    assert_ne!(tiny, text);
    std::fs::write(tmp.path().join("side.ron"), tiny).unwrap();
    let o = campath(tmp.path(), &["plot", "side.ron", "--out", "tiny.png"], &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    let plot = image::open(tmp.path().join("tiny.png")).unwrap().to_rgb8();
    let dots: Vec<u32> = (0..700)
        .flat_map(|x| (0..630).map(move |y| (x, y)))
        .filter(|&(x, y)| plot.get_pixel(x, y).0 == [255, 0, 255])
        .map(|(x, _)| x)
        .collect();
    assert!(
        (1..=4).contains(&dots.len()),
        "{} magenta pixels",
        dots.len()
    );
    assert!(dots.iter().all(|&x| f64::from(x) > path_x + 50.0));
}
