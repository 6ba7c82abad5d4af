//! One output folder, several processes: whole runs take turns (or refuse with `--no-wait`,
//! naming the run in the way), the shards of one count run side by side and exclude everything
//! else, and a killed holder blocks nobody. Real processes throughout.

use std::path::Path;
use std::process::{Child, Command, Output, Stdio};
use std::time::Duration;

use crate::common::{campath, stderr, stdout};

/// 48 small frames: a second or so in a debug build, long enough to be met.
const LONG: &str = "(
    frames: 48, fps: 24.0,
    image: (width: 160, height: 90, samples: 1),
    camera: (vrp: (0.0, 2.0, -8.0), tp: (0.0, 0.0, 0.0), window: (1.6, 0.9)),
    animate: [Observer(keys: [(t: 0.0, value: (0.0, 2.0, -8.0)), (t: 1.0, value: (6.0, 3.0, -3.0)), (t: 2.0, value: (0.0, 2.0, 6.0))])],
    scene: (background: (0.0, 0.0, 0.0), ambient: 0.1, lights: [(direction: (-1.0, -2.0, 1.0))],
            spheres: [(center: (0.0, 0.0, 0.0), radius: 1.0, color: (0.9, 0.2, 0.2)), (center: (0.0, -101.0, 0.0), radius: 100.0, color: (0.5, 0.5, 0.5)),
                      (center: (2.0, 0.0, 1.0), radius: 0.6, color: (0.2, 0.8, 0.3))]),
)";

fn setup() -> tempfile::TempDir {
    let tmp = tempfile::tempdir().unwrap();
    std::fs::write(tmp.path().join("long.ron"), LONG).unwrap();
    // The same shot on another background: every frame differs.
    let other = LONG.replace("background: (0.0, 0.0, 0.0)", "background: (0.1, 0.3, 0.6)");
    assert_ne!(other, LONG);
    std::fs::write(tmp.path().join("other.ron"), other).unwrap();
    // Twice the frames, each six times the work, for shards that must still run while others
    // start.
    let slow = LONG
        .replace("frames: 48, fps: 24.0", "frames: 96, fps: 48.0")
        .replace(
            "width: 160, height: 90, samples: 1",
            "width: 240, height: 135, samples: 2",
        );
    assert_ne!(slow, LONG);
    std::fs::write(tmp.path().join("slow.ron"), slow).unwrap();
    tmp
}

fn spawn(dir: &Path, args: &[&str]) -> Child {
    Command::new(env!("CARGO_BIN_EXE_campath"))
        .current_dir(dir)
        .args(args)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap()
}

/// Waits until `child` has recorded itself in `folder/campath.lock`, that is, holds the folder.
fn wait_until_holding(child: &mut Child, folder: &Path) {
    let mine = format!("{}\t", child.id());
    for _ in 0..3000 {
        let text = std::fs::read_to_string(folder.join("campath.lock")).unwrap_or_default();
        if text.lines().any(|l| l.starts_with(&mine)) {
            return;
        }
        assert!(
            child.try_wait().unwrap().is_none(),
            "pid {} ended before it held {}",
            child.id(),
            folder.display()
        );
        std::thread::sleep(Duration::from_millis(5));
    }
    panic!("pid {} never held {}", child.id(), folder.display());
}

fn finish(child: Child) -> Output {
    let o = child.wait_with_output().unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    o
}

/// `<frame> <hash>` lines of a manifest, without keys or part headers.
fn frames_and_hashes(text: &str) -> Vec<String> {
    text.lines()
        .filter(|l| !l.starts_with('#'))
        .map(|l| l.split(' ').take(2).collect::<Vec<_>>().join(" "))
        .collect()
}

/// The folder holds every frame of `file` and nothing else of note: hashes.txt lists exactly the
/// frames `campath hash` computes (without any folder), every PNG decodes to its listed hash,
/// no temporary file is left, and `verify` passes.
fn assert_whole_render_of(tmp: &Path, file: &str, folder: &str, frames: usize) {
    let dir = tmp.join(folder);
    let hashed = campath(tmp, &["hash", file], &[]);
    assert!(hashed.status.success(), "{}", stderr(&hashed));
    let listed = std::fs::read_to_string(dir.join("hashes.txt")).unwrap();
    assert_eq!(
        frames_and_hashes(&listed),
        frames_and_hashes(&stdout(&hashed))
    );
    assert_eq!(frames_and_hashes(&listed).len(), frames);
    for line in frames_and_hashes(&listed) {
        let (frame, hash) = line.split_once(' ').unwrap();
        let png = dir.join(format!("frame_{:04}.png", frame.parse::<u64>().unwrap()));
        let raw = image::open(&png).unwrap().to_rgb8().into_raw();
        assert_eq!(campath::frame_hash(&raw), hash, "{}", png.display());
    }
    for e in std::fs::read_dir(&dir).unwrap().flatten() {
        let name = e.file_name().to_string_lossy().into_owned();
        assert!(!name.ends_with(".tmp"), "{name} left behind");
    }
    let verified = campath(tmp, &["verify", file, &format!("{folder}/hashes.txt")], &[]);
    assert!(verified.status.success(), "{}", stdout(&verified));
}

#[test]
fn a_second_render_into_the_same_folder_waits_and_names_the_first() {
    let tmp = setup();
    let dir = tmp.path().join("o");
    let mut first = spawn(tmp.path(), &["render", "long.ron", "--out", "o"]);
    wait_until_holding(&mut first, &dir);
    let second = spawn(tmp.path(), &["render", "other.ron", "--out", "o"]);
    let pid = first.id();
    finish(first);
    let second = finish(second);
    let waited = stderr(&second);
    assert!(
        waited.contains("campath: waiting: o is being written by another campath run")
            && waited.contains(&format!("pid {pid}: "))
            && waited.contains("render long.ron --out o"),
        "{waited}"
    );
    // The file that finished last owns the folder, whole.
    assert_whole_render_of(tmp.path(), "other.ron", "o", 48);
}

#[test]
fn three_forced_renders_at_once_take_turns() {
    let tmp = setup();
    let runs: Vec<Child> = (0..3)
        .map(|_| spawn(tmp.path(), &["render", "long.ron", "--out", "o", "--force"]))
        .collect();
    for run in runs {
        let o = finish(run);
        assert!(stdout(&o).contains("48 --force"), "{}", stdout(&o));
    }
    assert_whole_render_of(tmp.path(), "long.ron", "o", 48);
}

#[test]
fn no_wait_refuses_with_exit_2_naming_the_holder() {
    let tmp = setup();
    let dir = tmp.path().join("o");
    let mut first = spawn(tmp.path(), &["render", "long.ron", "--out", "o"]);
    wait_until_holding(&mut first, &dir);
    for args in [
        &["render", "other.ron", "--out", "o", "--no-wait"][..],
        &[
            "render",
            "long.ron",
            "--out",
            "o",
            "--no-wait",
            "--shard",
            "0/2",
        ],
        &["merge", "o", "--no-wait"],
    ] {
        let o = campath(tmp.path(), args, &[]);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {}", stderr(&o));
        let err = stderr(&o);
        assert!(
            err.starts_with("campath: error: o is being written by another campath run (pid ")
                && err.contains(&format!("pid {}: ", first.id()))
                && err.contains("render long.ron --out o)")
                && err.contains("nothing done (without --no-wait, campath waits for it)"),
            "{args:?}: {err}"
        );
    }
    finish(first);
    assert_whole_render_of(tmp.path(), "long.ron", "o", 48);
}

#[test]
fn a_killed_holder_blocks_nobody() {
    let tmp = setup();
    let dir = tmp.path().join("o");
    let mut first = spawn(tmp.path(), &["render", "other.ron", "--out", "o"]);
    wait_until_holding(&mut first, &dir);
    let pid = first.id();
    first.kill().unwrap(); // SIGKILL: no clean-up runs
    first.wait().unwrap();
    // Its record is still in the lock file; only the operating system's lock counts.
    let left = std::fs::read_to_string(dir.join("campath.lock")).unwrap();
    assert!(left.starts_with(&format!("{pid}\twhole\t")), "{left}");
    let o = campath(
        tmp.path(),
        &["render", "long.ron", "--out", "o", "--no-wait"],
        &[],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(!stderr(&o).contains("waiting"), "{}", stderr(&o));
    assert_whole_render_of(tmp.path(), "long.ron", "o", 48);
    // Done, the run leaves no record behind.
    assert_eq!(
        std::fs::read_to_string(dir.join("campath.lock")).unwrap(),
        ""
    );
}

#[test]
fn shards_of_one_count_run_side_by_side_and_exclude_everything_else() {
    let tmp = setup();
    let dir = tmp.path().join("farm");
    let shard = |k: &'static str| ["render", "slow.ron", "--out", "farm", "--shard", k];
    let mut zero = spawn(tmp.path(), &shard("0/2"));
    wait_until_holding(&mut zero, &dir);
    // Another count, the same part again, a whole run and merge are refused meanwhile.
    let holder = format!("pid {} (shard 0/2): ", zero.id());
    for args in [
        [&shard("0/3")[..], &["--no-wait"]].concat(),
        [&shard("0/2")[..], &["--no-wait"]].concat(),
        vec!["render", "slow.ron", "--out", "farm", "--no-wait"],
        vec!["merge", "farm", "--no-wait"],
    ] {
        let o = campath(tmp.path(), &args, &[]);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {}", stderr(&o));
        assert!(stderr(&o).contains(&holder), "{args:?}: {}", stderr(&o));
    }
    // The other shard of 2 starts beside it without waiting.
    assert!(zero.try_wait().unwrap().is_none(), "shard 0/2 ended early");
    let mut one = spawn(tmp.path(), &[&shard("1/2")[..], &["--no-wait"]].concat());
    wait_until_holding(&mut one, &dir);
    // A shard of another count waits for both, naming them.
    let three = spawn(tmp.path(), &shard("0/3"));
    let one_holder = format!("pid {} (shard 1/2): ", one.id());
    finish(zero);
    finish(one);
    let three = finish(three);
    for want in [
        "campath: waiting: farm is being written",
        &holder,
        &one_holder,
    ] {
        assert!(stderr(&three).contains(want), "{want}: {}", stderr(&three));
    }
    // The shards of 2 merge into the whole (shard 0/3 re-rendered none of their frames).
    assert!(
        stdout(&three).contains("rendered 0 frame(s)"),
        "{}",
        stdout(&three)
    );
    std::fs::remove_file(dir.join("hashes.part-0-of-3.txt")).unwrap();
    let merged = campath(tmp.path(), &["merge", "farm"], &[]);
    assert!(merged.status.success(), "{}", stderr(&merged));
    assert_whole_render_of(tmp.path(), "slow.ron", "farm", 96);
}

/// A run killed while writing a frame leaves it under a temporary name; the next whole run,
/// the folder's only writer, removes it (and a shard, which shares the folder, leaves it).
#[test]
fn a_whole_run_removes_what_a_killed_run_left_under_temporary_names() {
    let tmp = setup();
    let dir = tmp.path().join("o");
    std::fs::create_dir_all(&dir).unwrap();
    let left = [
        ".frame_0003.png.aZ09xy.tmp",
        ".frame_0500.png.000000.tmp",
        ".hashes.txt.q1w2e3.tmp",
    ];
    for name in left {
        std::fs::write(dir.join(name), "half a picture").unwrap();
    }
    let shard = campath(
        tmp.path(),
        &["render", "long.ron", "--out", "o", "--shard", "0/2"],
        &[],
    );
    assert!(shard.status.success(), "{}", stderr(&shard));
    assert!(left.iter().all(|n| dir.join(n).exists()));
    let o = campath(tmp.path(), &["render", "long.ron", "--out", "o"], &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(left.iter().all(|n| !dir.join(n).exists()), "{}", stdout(&o));
    assert_whole_render_of(tmp.path(), "long.ron", "o", 48);
}

/// A lock that no live run records holding and that is let go of within moments (a child this
/// process was starting held a copy of its descriptor until it ran its program) is taken by a
/// run that must not wait, not refused; held on, it is refused, naming nobody.
#[test]
fn a_lock_no_run_records_is_tried_again_before_a_refusal() {
    use campath::document::Document;
    use campath::frames::FrameSet;
    use campath::internals::{lock, Wait};
    let tmp = setup();
    let dir = tmp.path().join("unrecorded");
    std::fs::create_dir_all(&dir).unwrap();
    let doc = Document::from_str(Path::new("long.ron"), LONG).unwrap();
    let set = FrameSet::all(0..doc.animation().frames);
    let hold = || {
        let file = std::fs::OpenOptions::new()
            .read(true)
            .write(true)
            .create(true)
            .truncate(false)
            .open(dir.join("campath.lock"))
            .unwrap();
        file.lock().unwrap();
        file
    };
    let held = hold();
    let letting_go = std::thread::spawn(move || {
        std::thread::sleep(Duration::from_millis(60));
        drop(held);
    });
    let taken = lock(&doc, &dir, &set, Wait::No);
    letting_go.join().unwrap();
    assert!(taken.is_ok(), "{:?}", taken.err());
    drop(taken);
    let _held = hold();
    match lock(&doc, &dir, &set, Wait::No) {
        Err(campath::Error::Busy { holders, .. }) => assert!(holders.is_empty(), "{holders:?}"),
        other => panic!("{:?}", other.err()),
    }
}
