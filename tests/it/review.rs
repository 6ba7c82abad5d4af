//! Pending goldens and `campath review`: a review on a terminal, key by key; an accept killed
//! at any moment leaves a whole golden; shots with a tolerance; goldens whose shot is gone; and
//! the small pictures a golden keeps of its frames.

use std::collections::BTreeMap;
use std::io::{Read, Write};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use crate::common::{campath, root, stderr, stdout};

/// A shot of `frames` frames of `width`×`height` whose first sphere has colour `red`, and a
/// top-level `extra` (such as a tolerance).
fn shot_sized(frames: u64, (width, height): (u32, u32), red: &str, extra: &str) -> String {
    format!(
        "(frames: {frames}, fps: 4.0, image: (width: {width}, height: {height}),{extra}
    camera: (vrp: (0.0, 1.0, -6.0), tp: (0.0, 0.0, 0.0), window: (1.6, 0.9)),
    animate: [Observer(keys: [(t: 0.0, value: (0.0, 1.0, -6.0)), (t: 1.0, value: (2.0, 1.0, -5.0))])],
    scene: (lights: [(direction: (-1.0, -2.0, 1.0))], spheres: [
        (center: (0.0, 0.0, 0.0), radius: 1.0, color: ({red}, 0.2, 0.2)),
        (center: (1.5, -0.5, 1.0), radius: 0.6, color: (0.2, 0.3, 0.9))]))"
    )
}

/// [`shot_sized`] at 40×24.
fn shot(frames: u64, red: &str) -> String {
    shot_sized(frames, (40, 24), red, "")
}

/// Every file of a folder (not its subfolders), by name, with its bytes; empty when the folder
/// is not there.
fn files(dir: &Path) -> BTreeMap<String, Vec<u8>> {
    let entries = std::fs::read_dir(dir).into_iter().flatten().flatten();
    entries
        .filter(|e| e.file_type().is_ok_and(|t| t.is_file()))
        .map(|e| {
            let name = e.file_name().to_string_lossy().into_owned();
            (name, std::fs::read(e.path()).unwrap())
        })
        .collect()
}

/// What a golden of hashes and small pictures holds once `pending` is accepted: its hashes.txt
/// and small pictures, without its full frames and difference images.
fn accepted(pending: &BTreeMap<String, Vec<u8>>) -> BTreeMap<String, Vec<u8>> {
    let kept = |n: &String| n == "hashes.txt" || n.starts_with("thumb_");
    (pending.iter().filter(|(n, _)| kept(n)))
        .map(|(n, b)| (n.clone(), b.clone()))
        .collect()
}

/// Whether two folders' files are the same, naming the files that differ when not.
fn same_files(a: &BTreeMap<String, Vec<u8>>, b: &BTreeMap<String, Vec<u8>>) -> Result<(), String> {
    let differ: Vec<&String> = (a.keys().chain(b.keys()))
        .filter(|n| a.get(*n) != b.get(*n))
        .collect();
    match differ.is_empty() {
        true => Ok(()),
        false => Err(format!("these files differ: {differ:?}")),
    }
}

/// Runs `campath test ARGS` in `dir` and checks its exit status.
fn test(dir: &Path, args: &[&str], code: i32) -> String {
    let o = campath(dir, &[&["test"][..], args].concat(), &[]);
    let text = format!("{}{}", stdout(&o), stderr(&o));
    assert_eq!(o.status.code(), Some(code), "test {args:?}: {text}");
    text
}

/// A pseudo-terminal: the master end to read and write, the terminal end to hand to a child.
struct Pty {
    master: std::fs::File,
    terminal: std::fs::File,
}

fn pty() -> Pty {
    use rustix::pty::{grantpt, openpt, ptsname, unlockpt, OpenptFlags};
    let master = openpt(OpenptFlags::RDWR | OpenptFlags::NOCTTY | OpenptFlags::CLOEXEC).unwrap();
    grantpt(&master).unwrap();
    unlockpt(&master).unwrap();
    let name = ptsname(&master, Vec::new()).unwrap();
    let terminal = std::fs::OpenOptions::new()
        .read(true)
        .write(true)
        .open(name.to_str().unwrap())
        .unwrap();
    Pty {
        master: std::fs::File::from(master),
        terminal,
    }
}

/// Waits until `seen` holds `count` times `what`, or panics after a minute with what it holds.
fn wait_for(seen: &Mutex<Vec<u8>>, what: &str, count: usize) {
    let start = Instant::now();
    loop {
        let text = String::from_utf8_lossy(&seen.lock().unwrap()).into_owned();
        if text.matches(what).count() >= count {
            return;
        }
        assert!(
            start.elapsed() < Duration::from_secs(60),
            "no {what:?} ×{count}: {text}"
        );
        std::thread::sleep(Duration::from_millis(20));
    }
}

/// Three shots with goldens of hashes and small pictures, each changed since: three pending
/// goldens.
fn three_pending(t: &Path) {
    std::fs::create_dir_all(t.join("shots")).unwrap();
    for (name, red) in [("a", "0.9"), ("b", "0.5"), ("c", "0.7")] {
        std::fs::write(t.join(format!("shots/{name}.ron")), shot(3, red)).unwrap();
    }
    test(t, &["--update"], 0);
    for (name, red) in [("a", "0.8"), ("b", "0.4"), ("c", "0.6")] {
        std::fs::write(t.join(format!("shots/{name}.ron")), shot(3, red)).unwrap();
    }
    let out = test(t, &[], 1);
    assert!(out.contains("3 pending golden(s) written"), "{out}");
}

/// `campath review` on a terminal asks shot by shot and reads one key, without Enter: `a`
/// makes the first shot's pending golden its golden (and no pending golden is left), `r`
/// removes the second's and leaves its golden, `s` leaves the third's golden and pending golden
/// as they were; it exits 0.
#[test]
fn review_on_a_terminal_accepts_rejects_and_skips_key_by_key() {
    let tmp = tempfile::tempdir().unwrap();
    let t = tmp.path();
    three_pending(t);
    let shots = t.join("shots");
    let golden = |n: &str| files(&shots.join(format!("{n}.golden")));
    let pending = |n: &str| files(&shots.join(format!("{n}.golden.new")));
    let (pending_a, golden_b, pending_b) = (pending("a"), golden("b"), pending("b"));
    let (golden_c, pending_c) = (golden("c"), pending("c"));
    assert!(pending_a.contains_key("hashes.txt") && pending_b.contains_key("hashes.txt"));

    let Pty { master, terminal } = pty();
    let mut child = Command::new(env!("CARGO_BIN_EXE_campath"))
        .current_dir(t)
        .args(["review", "shots"])
        .stdin(terminal.try_clone().unwrap())
        .stdout(terminal.try_clone().unwrap())
        .stderr(terminal.try_clone().unwrap())
        .spawn()
        .unwrap();
    let termios_of = master.try_clone().unwrap();
    drop(terminal);
    // Read everything the review writes, so that it never waits on a full terminal.
    let seen = Arc::new(Mutex::new(Vec::new()));
    let reader = {
        let (seen, mut master) = (seen.clone(), master.try_clone().unwrap());
        std::thread::spawn(move || {
            let mut buf = [0u8; 4096];
            while let Ok(n @ 1..) = master.read(&mut buf) {
                seen.lock().unwrap().extend_from_slice(&buf[..n]);
            }
        })
    };
    let mut keys = master;
    // A key is sent once the review asks and reads the terminal key by key.
    let press = |keys: &mut std::fs::File, key: &[u8], nth: usize| {
        wait_for(&seen, "a accept, r reject, s skip, q quit: ", nth);
        let start = Instant::now();
        loop {
            let modes = rustix::termios::tcgetattr(&termios_of).unwrap().local_modes;
            if !modes.contains(rustix::termios::LocalModes::ICANON) {
                break;
            }
            assert!(start.elapsed() < Duration::from_secs(60), "never raw");
            std::thread::sleep(Duration::from_millis(10));
        }
        keys.write_all(key).unwrap();
    };

    press(&mut keys, b"a", 1);
    wait_for(&seen, "accepted: ", 1);
    // a's golden is its pending golden: its hashes and small pictures, every frame's.
    same_files(&golden("a"), &accepted(&pending_a)).unwrap();
    assert_eq!(accepted(&pending_a).len(), 4);
    assert!(!shots.join("a.golden.new").exists());

    press(&mut keys, b"r", 2);
    wait_for(&seen, "rejected: ", 1);
    assert!(!shots.join("b.golden.new").exists());
    same_files(&golden("b"), &golden_b).unwrap();

    press(&mut keys, b"s", 3);
    let status = child.wait().unwrap();
    drop(keys);
    reader.join().unwrap();
    let text = String::from_utf8_lossy(&seen.lock().unwrap()).into_owned();
    assert_eq!(status.code(), Some(0), "{text}");
    assert!(
        text.contains("skipped") && text.contains("1 pending golden(s) left"),
        "{text}"
    );
    // Each shot's differing frames were shown before its question.
    assert!(
        text.contains("3 of 3 frame(s) differ from the golden"),
        "{text}"
    );
    same_files(&golden("c"), &golden_c).unwrap();
    same_files(&pending("c"), &pending_c).unwrap();
    // And what the review did holds: a passes now, b and c still differ.
    let out = test(t, &["--no-pending"], 1);
    assert!(
        out.contains("shots/a.ron: passed")
            && out.contains("shots/b.ron: 3 of 3 frame(s) differ")
            && out.contains("shots/c.ron: 3 of 3 frame(s) differ"),
        "{out}"
    );
}

/// Off a terminal and without --accept or --reject, review lists the pending goldens and
/// changes nothing; --accept --shot takes one shot, --reject the rest.
#[test]
fn review_off_a_terminal_lists_and_acts_only_when_told() {
    let tmp = tempfile::tempdir().unwrap();
    let t = tmp.path();
    three_pending(t);
    let shots = t.join("shots");
    let before: Vec<_> = ["a", "b", "c"]
        .map(|n| files(&shots.join(format!("{n}.golden"))))
        .into();
    let o = campath(t, &["review", "shots"], &[]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert!(
        stdout(&o).matches("skipped").count() == 3
            && stdout(&o).contains("3 pending golden(s) left"),
        "{}",
        stdout(&o)
    );
    for (n, golden) in ["a", "b", "c"].iter().zip(&before) {
        same_files(&files(&shots.join(format!("{n}.golden"))), golden).unwrap();
        assert!(shots.join(format!("{n}.golden.new")).exists(), "{n}");
    }
    let pending_b = files(&shots.join("b.golden.new"));
    let o = campath(t, &["review", "shots", "--accept", "--shot", "b"], &[]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    same_files(&files(&shots.join("b.golden")), &accepted(&pending_b)).unwrap();
    assert!(shots.join("a.golden.new").exists() && shots.join("c.golden.new").exists());
    let o = campath(t, &["review", "shots", "--reject"], &[]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    for n in ["a", "b", "c"] {
        assert!(!shots.join(format!("{n}.golden.new")).exists(), "{n}");
    }
    same_files(&files(&shots.join("a.golden")), &before[0]).unwrap();
    let out = test(t, &["--no-pending"], 1);
    assert!(out.contains("1 passed, 2 differ"), "{out}");
}

/// An accept killed at 20 moments spread evenly over its run (and a little past it) leaves the
/// golden wholly the old one or wholly the new one, and the next check can always check the
/// shot: it passes or differs (exit 0 or 1), never "could not be checked" (exit 2).
#[test]
fn an_accept_killed_at_any_moment_leaves_the_old_golden_or_the_new() {
    let tmp = tempfile::tempdir().unwrap();
    let t = tmp.path();
    // Many small frames, golden and pending golden keeping every frame: a long accept.
    let pristine = t.join("pristine");
    std::fs::create_dir_all(pristine.join("shots")).unwrap();
    let file = pristine.join("shots/s.ron");
    std::fs::write(&file, shot_sized(200, (16, 9), "0.9", "")).unwrap();
    test(&pristine, &["--update", "--keep-frames"], 0);
    std::fs::write(&file, shot_sized(200, (16, 9), "0.5", "")).unwrap();
    test(&pristine, &["--pending"], 1);
    let old = files(&pristine.join("shots/s.golden"));
    assert!(old.contains_key("frame_0199.png"), "{:?}", old.keys());

    let copy = |to: &Path| {
        let _ = std::fs::remove_dir_all(to);
        let o = Command::new("cp")
            .arg("-a")
            .arg(&pristine)
            .arg(to)
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", stderr(&o));
    };
    let accept = |dir: &Path| {
        Command::new(env!("CARGO_BIN_EXE_campath"))
            .current_dir(dir)
            .args(["review", "shots", "--accept"])
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .unwrap()
    };
    // The new golden, from an accept left to finish; and how long an accept takes.
    let whole = t.join("whole");
    copy(&whole);
    let start = Instant::now();
    assert!(accept(&whole).wait().unwrap().success());
    let took = start.elapsed();
    let new = files(&whole.join("shots/s.golden"));
    assert_ne!(new["hashes.txt"], old["hashes.txt"]);
    assert!(new.contains_key("frame_0199.png") && !new.contains_key("frame_0199.diff.png"));
    eprintln!("an accept of 200 frames took {took:?}");

    let work = t.join("work");
    let mut seen_old_and_new = (0, 0);
    for i in 0..20u32 {
        copy(&work);
        let at = took.mul_f64(1.2) * i / 19;
        let mut child = accept(&work);
        std::thread::sleep(at);
        let _ = child.kill();
        child.wait().unwrap();
        let golden = files(&work.join("shots/s.golden"));
        if golden == old {
            seen_old_and_new.0 += 1;
        } else if golden == new {
            seen_old_and_new.1 += 1;
        } else {
            let differ: Vec<_> = (golden.keys().chain(old.keys()))
                .filter(|k| golden.get(*k) != old.get(*k) && golden.get(*k) != new.get(*k))
                .collect();
            panic!("killed after {at:?}: a golden that is neither: {differ:?}");
        }
        let o = campath(&work, &["test", "--no-pending"], &[]);
        assert!(
            matches!(o.status.code(), Some(0 | 1)),
            "killed after {at:?}: {}{}",
            stdout(&o),
            stderr(&o)
        );
        assert!(
            !stdout(&o).contains("could not be checked"),
            "{}",
            stdout(&o)
        );
        // What the killed accept left is cleared by the next approval, which then passes.
        let o = campath(&work, &["review", "shots", "--accept"], &[]);
        assert!(o.status.success(), "{}", stderr(&o));
        let golden = files(&work.join("shots/s.golden"));
        same_files(&golden, &new).unwrap_or_else(|e| panic!("after {at:?}: {e}"));
        test(&work, &["--no-pending"], 0);
        let hidden: Vec<String> = (std::fs::read_dir(work.join("shots")).unwrap().flatten())
            .map(|e| e.file_name().to_string_lossy().into_owned())
            .filter(|n| n.starts_with('.') || n.ends_with(".golden.new"))
            .collect();
        assert!(hidden.is_empty(), "after {at:?}: left {hidden:?}");
    }
    eprintln!(
        "killed accepts: {} left the old golden, {} the new",
        seen_old_and_new.0, seen_old_and_new.1
    );
}

/// Replaces one pixel of frame 0 of the golden by a colour `by` levels away in red, and its
/// hash in hashes.txt by the hash of the changed picture (so the golden stays whole): the
/// shot's frame 0 then differs from the golden in exactly that pixel.
fn change_one_golden_pixel(golden: &Path, by: u8) {
    change_golden_pixels(golden, 0, 1, by);
}

/// [`change_one_golden_pixel`] for the first `pixels` pixels of row 5 of `frame`.
fn change_golden_pixels(golden: &Path, frame: u64, pixels: u32, by: u8) {
    let png = golden.join(format!("frame_{frame:04}.png"));
    let mut img = image::open(&png).unwrap().to_rgb8();
    let old = campath::frame_hash(img.as_raw()).to_string();
    for x in 0..pixels {
        let p = img.get_pixel_mut(7 + x, 5);
        p.0[0] = if p.0[0] >= 128 {
            p.0[0] - by
        } else {
            p.0[0] + by
        };
    }
    let hash = campath::frame_hash(img.as_raw()).to_string();
    img.save(&png).unwrap();
    let text = std::fs::read_to_string(golden.join("hashes.txt")).unwrap();
    assert!(text.contains(&old), "{text}");
    std::fs::write(golden.join("hashes.txt"), text.replace(&old, &hash)).unwrap();
}

/// A shot with a tolerance: a frame one pixel off its golden frame passes within
/// `max_pixels: 1` and says by how much, fails with `max_pixels: 0`, passes with a `max_level`
/// above the change; a tolerance with a golden of hashes only is refused, saying why.
#[test]
fn a_tolerance_passes_a_frame_within_it_and_no_more() {
    let tmp = tempfile::tempdir().unwrap();
    let t = tmp.path();
    std::fs::create_dir_all(t.join("shots")).unwrap();
    let file = t.join("shots/s.ron");
    let with = |tolerance: &str| {
        let extra = format!("\n    test: {tolerance},");
        std::fs::write(&file, shot_sized(3, (40, 24), "0.9", &extra)).unwrap();
    };
    std::fs::write(&file, shot(3, "0.9")).unwrap();
    test(t, &["--update", "--keep-frames"], 0);
    let golden = t.join("shots/s.golden");
    change_one_golden_pixel(&golden, 40);
    // Checked by pictures, not by campath: the golden and the fresh frame differ in one pixel.
    let o = campath(
        t,
        &["render", "shots/s.ron", "--out", "fresh", "--quiet"],
        &[],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let rgb = |p: PathBuf| image::open(p).unwrap().to_rgb8().into_raw();
    let (g, f) = (
        rgb(golden.join("frame_0000.png")),
        rgb(t.join("fresh/frame_0000.png")),
    );
    let changed = g.chunks(3).zip(f.chunks(3)).filter(|(a, b)| a != b).count();
    assert_eq!(changed, 1);
    let before = files(&golden);

    let out = test(t, &["--no-pending"], 1);
    assert!(
        out.contains("shots/s.ron: 1 of 3 frame(s) differ: 0"),
        "{out}"
    );
    with("(max_pixels: 1)");
    let out = test(t, &["--no-pending"], 0);
    assert!(
        out.contains("shots/s.ron: passed within tolerance (3 frames; 1 within max_pixels: 1, max_level: 0: frame 0: 1 pixel(s) changed, largest difference 40 level(s))"),
        "{out}"
    );
    with("(max_pixels: 0)");
    let out = test(t, &["--no-pending"], 1);
    assert!(out.contains("1 of 3 frame(s) differ: 0"), "{out}");
    with("(max_pixels: 0, max_level: 40)");
    let out = test(t, &["--no-pending"], 0);
    assert!(out.contains("passed within tolerance"), "{out}");
    with("(max_pixels: 0, max_level: 39)");
    test(t, &["--no-pending"], 1);
    // A passing run within tolerance writes nothing.
    with("(max_pixels: 1)");
    test(t, &[], 0);
    same_files(&files(&golden), &before).unwrap();
    assert!(!t.join("shots/s.golden.new").exists());

    // A golden of hashes and small pictures only cannot be checked within a tolerance.
    let other = t.join("other");
    std::fs::create_dir_all(other.join("shots")).unwrap();
    std::fs::write(other.join("shots/s.ron"), shot(3, "0.9")).unwrap();
    test(&other, &["--update"], 0);
    std::fs::write(
        other.join("shots/s.ron"),
        shot_sized(3, (40, 24), "0.9", "\n    test: (max_pixels: 1),"),
    )
    .unwrap();
    let out = test(&other, &["--no-pending"], 2);
    assert!(
        out.contains("shots/s.ron: cannot check: ")
            && out.contains("states a tolerance, which compares full frames")
            && out.contains("keeps hashes only")
            && out.contains("1 of 1 shot(s) could not be checked"),
        "{out}"
    );
    // Approval with the tolerance keeps the frames, and then it can be checked.
    test(&other, &["--update"], 0);
    assert!(other.join("shots/s.golden/frame_0002.png").is_file());
    test(&other, &["--no-pending"], 0);
}

/// `--unreferenced` lists the goldens and pending goldens with no shot beside them, in any
/// subfolder, and removes nothing; `--unreferenced=delete` removes those and only those.
#[test]
fn unreferenced_goldens_are_listed_and_deleted() {
    let tmp = tempfile::tempdir().unwrap();
    let t = tmp.path();
    std::fs::create_dir_all(t.join("shots/sub")).unwrap();
    std::fs::write(t.join("shots/a.ron"), shot(2, "0.9")).unwrap();
    std::fs::write(t.join("shots/sub/b.ron"), shot(2, "0.5")).unwrap();
    std::fs::write(t.join("shots/gone.ron"), shot(2, "0.3")).unwrap();
    std::fs::write(t.join("shots/sub/left.ron"), shot(2, "0.4")).unwrap();
    test(t, &["--update"], 0);
    std::fs::write(t.join("shots/a.ron"), shot(2, "0.8")).unwrap();
    std::fs::write(t.join("shots/sub/left.ron"), shot(2, "0.2")).unwrap();
    test(t, &[], 1);
    assert!(t.join("shots/a.golden.new").is_dir() && t.join("shots/sub/left.golden.new").is_dir());
    std::fs::remove_file(t.join("shots/gone.ron")).unwrap();
    std::fs::remove_file(t.join("shots/sub/left.ron")).unwrap();

    let kept = ["shots/a.golden", "shots/a.golden.new", "shots/sub/b.golden"];
    let gone = [
        "shots/gone.golden",
        "shots/sub/left.golden",
        "shots/sub/left.golden.new",
    ];
    let out = test(t, &["shots", "--unreferenced"], 0);
    let listed: Vec<&str> = out.lines().filter(|l| l.starts_with("shots/")).collect();
    assert_eq!(listed, gone, "{out}");
    assert!(
        out.contains(
            "3 unreferenced golden(s); remove them: `campath test shots --unreferenced=delete`"
        ),
        "{out}"
    );
    for d in kept.iter().chain(&gone) {
        assert!(t.join(d).is_dir(), "{d}");
    }
    let out = test(t, &["shots", "--unreferenced=delete"], 0);
    for d in gone {
        assert!(out.contains(&format!("removed {d}")), "{out}");
        assert!(!t.join(d).exists(), "{d}");
    }
    assert!(out.contains("3 unreferenced golden(s) removed"), "{out}");
    for d in kept {
        assert!(t.join(d).is_dir(), "{d}");
    }
    let out = test(t, &["shots", "--unreferenced"], 0);
    assert!(out.contains("no unreferenced golden"), "{out}");
}

/// The small pictures of a golden keep to their budget: every `thumb_NNNN.png` of the goldens of
/// tests/shots/orbit.ron and of a 640×360 shot is at most `THUMB_BYTES`. Prints the bytes per
/// frame.
#[test]
fn a_goldens_small_pictures_keep_to_their_budget() {
    let tmp = tempfile::tempdir().unwrap();
    let t = tmp.path();
    std::fs::create_dir_all(t.join("shots")).unwrap();
    std::fs::copy(
        root().join("tests/shots/orbit.ron"),
        t.join("shots/orbit.ron"),
    )
    .unwrap();
    let orbit = std::fs::read_to_string(t.join("shots/orbit.ron")).unwrap();
    let wide = orbit.replace("frames: 12,", "frames: 3,").replace(
        "width: 96, height: 54, samples: 2",
        "width: 640, height: 360",
    );
    assert_ne!(wide, orbit);
    std::fs::write(t.join("shots/wide.ron"), wide).unwrap();
    test(t, &["--update"], 0);
    for (name, frames, size) in [("orbit", 12, (96, 54)), ("wide", 3, (640, 360))] {
        let golden = t.join(format!("shots/{name}.golden"));
        let thumbs: BTreeMap<String, Vec<u8>> = files(&golden)
            .into_iter()
            .filter(|(n, _)| n.starts_with("thumb_"))
            .collect();
        assert_eq!(thumbs.len(), frames, "{name}: {:?}", thumbs.keys());
        let mut sizes = Vec::new();
        for (file, bytes) in &thumbs {
            assert!(
                bytes.len() <= campath::testing::pictures::THUMB_BYTES,
                "{name}/{file}: {} bytes",
                bytes.len()
            );
            let img = image::load_from_memory(bytes).unwrap();
            assert!(img.width() <= size.0 && img.width() <= campath::testing::pictures::THUMB_SIDE);
            sizes.push(bytes.len());
        }
        let (w, h) = image::load_from_memory(&thumbs.values().next().unwrap()[..])
            .map(|i| (i.width(), i.height()))
            .unwrap();
        println!(
            "{name} ({}×{}): thumbs {w}×{h}, bytes per frame {sizes:?}, mean {}, max {} (budget {})",
            size.0,
            size.1,
            sizes.iter().sum::<usize>() / sizes.len(),
            sizes.iter().max().unwrap(),
            campath::testing::pictures::THUMB_BYTES
        );
    }
}

/// Added to a copy of a review page: once every picture has loaded, for each frame on the page,
/// its golden and new pictures as Chromium decoded them (sizes, whether each is blank, how much
/// they differ drawn at the golden's size, and their centres' red), and where they lie on the
/// page; written as JSON into `<pre id="probe">`.
const PROBE: &str = r#"<script>
window.addEventListener('load', function () {
  function pixels(img, w, h) {
    var c = document.createElement('canvas');
    c.width = w; c.height = h;
    var g = c.getContext('2d');
    g.imageSmoothingEnabled = true;
    g.drawImage(img, 0, 0, w, h);
    return g.getImageData(0, 0, w, h).data;
  }
  function spread(d) {
    var lo = 255, hi = 0;
    for (var i = 0; i < d.length; i += 4)
      for (var c = 0; c < 3; c++) { lo = Math.min(lo, d[i + c]); hi = Math.max(hi, d[i + c]); }
    return hi - lo;
  }
  var out = [];
  document.querySelectorAll('.frame').forEach(function (f) {
    var golden = f.querySelector('img.golden'), fresh = f.querySelector('img.new');
    var r = { id: f.id, golden: !!golden, fresh: !!fresh };
    if (golden && fresh) {
      r.golden_size = [golden.naturalWidth, golden.naturalHeight];
      r.fresh_size = [fresh.naturalWidth, fresh.naturalHeight];
      var gr = golden.getBoundingClientRect(), fr = fresh.getBoundingClientRect();
      r.golden_box = [gr.left, gr.top, gr.width, gr.height];
      r.fresh_box = [fr.left, fr.top, fr.width, fr.height];
      var w = golden.naturalWidth, h = golden.naturalHeight;
      if (w > 0 && h > 0 && fresh.naturalWidth > 0) {
        var a = pixels(golden, w, h), b = pixels(fresh, w, h);
        r.golden_spread = spread(a);
        r.fresh_spread = spread(b);
        var changed = 0;
        for (var i = 0; i < a.length; i += 4) {
          var d = Math.max(Math.abs(a[i] - b[i]), Math.abs(a[i + 1] - b[i + 1]), Math.abs(a[i + 2] - b[i + 2]));
          if (d > 8) changed++;
        }
        r.changed = changed / (w * h);
        var at = ((h >> 1) * w + (w >> 1)) * 4;
        r.centre_red = [a[at], b[at]];
      }
    }
    out.push(r);
  });
  var how = document.querySelector('.how');
  var pre = document.createElement('pre');
  pre.id = 'probe';
  pre.textContent = JSON.stringify({ frames: out, how: how ? how.textContent : null });
  document.body.appendChild(pre);
});
</script>"#;

/// Loads `page` in headless Chromium with [`PROBE`] added, and returns what it found.
fn probe_in_chromium(page: &Path, profile: &Path) -> serde_json::Value {
    let html = std::fs::read_to_string(page).unwrap();
    let probed = page.with_file_name("probe.html");
    std::fs::write(&probed, html.replace("</body>", &format!("{PROBE}</body>"))).unwrap();
    let url = format!("file://{}", probed.display());
    let o = crate::common::chromium(
        profile,
        &[
            // The probe reads the pictures' pixels, which file:// pages may only do so.
            "--allow-file-access-from-files",
            "--window-size=1400,1000",
            "--virtual-time-budget=5000",
            "--dump-dom",
            &url,
        ],
    );
    let dom = String::from_utf8_lossy(&o.stdout).into_owned();
    let start = dom.find("<pre id=\"probe\">").unwrap_or_else(|| {
        panic!(
            "no probe in the page: {}\n{}",
            &dom[..dom.len().min(800)],
            stderr(&o)
        )
    }) + "<pre id=\"probe\">".len();
    let end = start + dom[start..].find("</pre>").unwrap();
    let json = dom[start..end]
        .replace("&quot;", "\"")
        .replace("&lt;", "<")
        .replace("&gt;", ">")
        .replace("&amp;", "&");
    serde_json::from_str(&json).unwrap_or_else(|e| panic!("{e}: {json}"))
}

/// The review pages of a golden of hashes and small pictures (the default approval), in
/// Chromium: `campath test --review` and `campath review --page` show, for every failing frame,
/// the golden's small picture and the new frame side by side, each decoded, neither blank, and
/// differing where the shot changed (the red sphere at the centre is less red); the page says
/// how to accept.
#[test]
#[ignore = "needs chromium"]
fn the_review_pages_show_the_golden_small_picture_beside_the_new_frame_in_chromium() {
    crate::common::need_part("chromium", "chromium", crate::common::does_not_run);
    let tmp = tempfile::tempdir().unwrap();
    let t = tmp.path();
    std::fs::create_dir_all(t.join("shots")).unwrap();
    let file = t.join("shots/b.ron");
    std::fs::write(&file, shot_sized(3, (320, 180), "0.9", "")).unwrap();
    test(t, &["--update"], 0);
    let golden = t.join("shots/b.golden");
    assert!(!golden.join("frame_0000.png").exists());
    assert!(golden.join("thumb_0000.png").exists());
    std::fs::write(&file, shot_sized(3, (320, 180), "0.3", "")).unwrap();
    test(t, &["--review", "page1"], 1);
    let o = campath(t, &["review", "shots", "--page", "page2"], &[]);
    assert!(o.status.success(), "{}", stderr(&o));

    for (page, profile) in [("page1", "chrome1"), ("page2", "chrome2")] {
        let found = probe_in_chromium(&t.join(page).join("index.html"), &t.join(profile));
        let frames = found["frames"].as_array().unwrap();
        let ids: Vec<&str> = frames.iter().map(|f| f["id"].as_str().unwrap()).collect();
        assert_eq!(ids, ["frame-0", "frame-1", "frame-2"], "{page}: {found}");
        for f in frames {
            let n = |k: &str, i: usize| f[k][i].as_f64().unwrap_or(0.0);
            assert!(
                f["golden"] == true && f["fresh"] == true,
                "{page}: {f}: not both pictures"
            );
            // Decoded: the golden's small picture, the new full frame.
            assert_eq!(
                (n("golden_size", 0), n("golden_size", 1)),
                (160.0, 90.0),
                "{page}: {f}"
            );
            assert_eq!(
                (n("fresh_size", 0), n("fresh_size", 1)),
                (320.0, 180.0),
                "{page}: {f}"
            );
            // Shown, at one place and size, one over the other (the slider shows each half).
            for b in ["golden_box", "fresh_box"] {
                assert!(
                    n(b, 2) > 50.0 && n(b, 3) > 20.0,
                    "{page}: {f}: {b} not shown"
                );
            }
            assert_eq!(f["golden_box"], f["fresh_box"], "{page}: {f}");
            // Neither is blank; they differ, and where the shot changed.
            let spread = |k: &str| f[k].as_f64().unwrap();
            assert!(
                spread("golden_spread") > 40.0 && spread("fresh_spread") > 40.0,
                "{page}: {f}"
            );
            let changed = f["changed"].as_f64().unwrap();
            assert!(changed > 0.02 && changed < 0.9, "{page}: {f}");
            assert!(
                n("centre_red", 0) > n("centre_red", 1) + 60.0,
                "{page}: {f}"
            );
        }
        let how = found["how"].as_str().unwrap();
        assert!(
            how.contains("campath review shots --accept"),
            "{page}: {how}"
        );
    }
}

/// What a failing run writes: `CAMPATH_UPDATE` no (or 0) nothing, new a pending golden,
/// always (or 1) the golden, frames the golden with every frame; `CI` set makes the default
/// nothing, and an empty `CI` does not; `--pending` and `--update` outrank both; a value it
/// does not know is refused naming the values. A pending golden of an earlier run is replaced
/// whole, and a run where the shot passes removes it.
#[test]
fn campath_update_and_ci_decide_what_a_failing_run_writes() {
    let tmp = tempfile::tempdir().unwrap();
    let t = tmp.path();
    std::fs::create_dir_all(t.join("shots")).unwrap();
    let file = t.join("shots/s.ron");
    std::fs::write(&file, shot(3, "0.9")).unwrap();
    test(t, &["--update"], 0);
    let (golden, pending) = (t.join("shots/s.golden"), t.join("shots/s.golden.new"));
    let approved = files(&golden);
    std::fs::write(&file, shot(3, "0.5")).unwrap();
    let run = |args: &[&str], env: &[(&str, &str)], code: i32| {
        let o = campath(t, &[&["test", "shots"][..], args].concat(), env);
        let text = format!("{}{}", stdout(&o), stderr(&o));
        assert_eq!(o.status.code(), Some(code), "{args:?} {env:?}: {text}");
        text
    };
    for env in [
        &[("CAMPATH_UPDATE", "no")][..],
        &[("CAMPATH_UPDATE", "0")],
        &[("CI", "true")],
        &[("CI", "1"), ("CAMPATH_UPDATE", "")],
    ] {
        let out = run(&[], env, 1);
        assert!(
            out.contains("0 pending golden(s) written, 0 approved"),
            "{env:?}: {out}"
        );
        assert!(out.contains("Nothing was written"), "{env:?}: {out}");
        assert!(!pending.exists(), "{env:?}");
        same_files(&files(&golden), &approved).unwrap();
    }
    let out = run(&["--pending"], &[("CI", "true")], 1);
    assert!(out.contains("1 pending golden(s) written"), "{out}");
    std::fs::remove_dir_all(&pending).unwrap();
    for env in [&[("CAMPATH_UPDATE", "new")][..], &[("CI", "")], &[]] {
        let out = run(&[], env, 1);
        assert!(
            out.contains("pending golden: shots/s.golden.new")
                && out.contains("`campath review shots`"),
            "{env:?}: {out}"
        );
        same_files(&files(&golden), &approved).unwrap();
    }
    // An earlier pending golden is replaced whole: nothing of it is left.
    std::fs::write(pending.join("frame_0099.png"), b"of an earlier run").unwrap();
    std::fs::write(&file, shot(3, "0.4")).unwrap();
    run(&[], &[], 1);
    let now = files(&pending);
    assert!(!now.contains_key("frame_0099.png"), "{:?}", now.keys());
    let hashes = std::fs::read_to_string(pending.join("hashes.txt")).unwrap();
    let o = campath(t, &["hash", "shots/s.ron"], &[]);
    for line in crate::common::frame_lines(&stdout(&o)) {
        assert!(hashes.contains(line.trim()), "{line}: {hashes}");
    }
    // A passing run removes it.
    std::fs::write(&file, shot(3, "0.9")).unwrap();
    run(&[], &[], 0);
    assert!(!pending.exists());
    // Approval in place: always, 1, frames (with every frame), --update under CI.
    for (args, env, red, frames) in [
        (&[][..], &[("CAMPATH_UPDATE", "always")][..], "0.71", false),
        (&[], &[("CAMPATH_UPDATE", "1")], "0.72", false),
        (&[], &[("CAMPATH_UPDATE", "frames")], "0.73", true),
        // A golden that keeps its frames keeps them.
        (&["--update"], &[("CI", "true")], "0.74", true),
    ] {
        std::fs::write(&file, shot(3, red)).unwrap();
        let out = run(args, env, 0);
        assert!(
            out.contains("golden written: shots/s.golden") && out.contains("1 approved"),
            "{args:?} {env:?}: {out}"
        );
        assert!(!pending.exists());
        assert_eq!(golden.join("frame_0002.png").is_file(), frames, "{env:?}");
        run(&["--no-pending"], &[], 0);
    }
    let out = run(&[], &[("CAMPATH_UPDATE", "yes")], 2);
    assert!(
        out.contains("CAMPATH_UPDATE=yes: it takes no, new or always"),
        "{out}"
    );
}

/// A shot with a tolerance whose frame 0 passes within it and frame 1 does not: approving it
/// (accepting its pending golden, or `--update`) leaves a golden the next check passes, with a
/// picture of every frame.
#[test]
fn approving_a_shot_with_frames_within_tolerance_keeps_their_pictures() {
    for approve in ["accept", "update"] {
        let tmp = tempfile::tempdir().unwrap();
        let t = tmp.path();
        std::fs::create_dir_all(t.join("shots")).unwrap();
        let file = t.join("shots/s.ron");
        let extra = "\n    test: (max_pixels: 1),";
        std::fs::write(&file, shot_sized(3, (40, 24), "0.9", extra)).unwrap();
        test(t, &["--update"], 0);
        let golden = t.join("shots/s.golden");
        change_golden_pixels(&golden, 0, 1, 40);
        change_golden_pixels(&golden, 1, 20, 40);
        let out = test(t, &["--no-pending"], 1);
        assert!(out.contains("1 of 3 frame(s) differ: 1"), "{out}");
        if approve == "accept" {
            test(t, &[], 1);
            let o = campath(t, &["review", "shots", "--accept"], &[]);
            assert!(o.status.success(), "{}", stderr(&o));
        } else {
            test(t, &["--update"], 0);
        }
        let kept = files(&golden);
        for f in 0..3 {
            for name in [format!("frame_{f:04}.png"), format!("thumb_{f:04}.png")] {
                assert!(
                    kept.contains_key(&name),
                    "{approve}: {name}: {:?}",
                    kept.keys()
                );
            }
        }
        let out = test(t, &["--no-pending"], 0);
        assert!(out.contains("shots/s.ron: passed"), "{approve}: {out}");
    }
}

/// `--unreferenced` searches a folder reached twice through a link once, as `campath test`
/// does: with a link back up the tree, an unreferenced golden is listed once, and
/// `--unreferenced=delete` removes it once and succeeds.
#[test]
fn unreferenced_goldens_are_found_once_through_a_link_back_up_the_tree() {
    let tmp = tempfile::tempdir().unwrap();
    let t = tmp.path();
    std::fs::create_dir_all(t.join("shots/sub")).unwrap();
    std::fs::write(t.join("shots/a.ron"), shot(2, "0.9")).unwrap();
    std::fs::create_dir(t.join("shots/gone.golden")).unwrap();
    std::os::unix::fs::symlink("..", t.join("shots/sub/up")).unwrap();
    let out = test(t, &["shots", "--unreferenced"], 0);
    assert_eq!(out.matches("gone.golden").count(), 1, "{out}");
    assert!(out.contains("1 unreferenced golden(s)"), "{out}");
    let out = test(t, &["shots", "--unreferenced=delete"], 0);
    assert!(out.contains("1 unreferenced golden(s) removed"), "{out}");
    assert!(!t.join("shots/gone.golden").exists());
    assert!(t.join("shots/a.ron").is_file());
}

/// An accept never writes over what it was not made against: a golden from a newer renderer,
/// or a golden that changed after the pending golden was written. A golden kept elsewhere
/// through a link is replaced where it is kept, and the link stays.
#[test]
fn an_accept_refuses_a_newer_or_changed_golden_and_keeps_a_linked_one_in_place() {
    let tmp = tempfile::tempdir().unwrap();
    let t = tmp.path();
    std::fs::create_dir_all(t.join("shots")).unwrap();
    let file = t.join("shots/s.ron");
    let golden = t.join("shots/s.golden");
    std::fs::write(&file, shot(3, "0.9")).unwrap();
    test(t, &["--update"], 0);
    std::fs::write(&file, shot(3, "0.5")).unwrap();
    test(t, &[], 1);
    let pending = files(&t.join("shots/s.golden.new"));

    // A newer renderer's golden.
    let before = files(&golden);
    let text = String::from_utf8(before["hashes.txt"].clone()).unwrap();
    let newer = text.replacen(
        &format!("renderer {}", campath::RENDERER_VERSION),
        &format!("renderer {}", campath::RENDERER_VERSION + 1),
        1,
    );
    std::fs::write(golden.join("hashes.txt"), &newer).unwrap();
    let o = campath(t, &["review", "shots", "--accept"], &[]);
    assert_eq!(o.status.code(), Some(2), "{}", stdout(&o));
    assert!(
        stderr(&o).contains("newer than this campath's"),
        "{}",
        stderr(&o)
    );
    assert_eq!(files(&golden)["hashes.txt"], newer.as_bytes());
    std::fs::write(golden.join("hashes.txt"), &text).unwrap();

    // A golden that changed since: frame 1 approved anew, so the pending golden lacks its
    // picture.
    let changed: String = (text.lines())
        .map(|l| match l.starts_with("1 ") {
            true => format!("1 {}\n", "0".repeat(64)),
            false => format!("{l}\n"),
        })
        .collect();
    std::fs::write(golden.join("hashes.txt"), &changed).unwrap();
    let frame1 = pending.get("thumb_0001.png").cloned();
    std::fs::remove_file(t.join("shots/s.golden.new/thumb_0001.png")).ok();
    let o = campath(t, &["review", "shots", "--accept"], &[]);
    assert_eq!(o.status.code(), Some(2), "{}", stdout(&o));
    assert!(
        stderr(&o).contains("the golden changed after"),
        "{}",
        stderr(&o)
    );
    assert_eq!(files(&golden)["hashes.txt"], changed.as_bytes());
    std::fs::write(golden.join("hashes.txt"), &text).unwrap();
    if let Some(bytes) = frame1 {
        std::fs::write(t.join("shots/s.golden.new/thumb_0001.png"), bytes).unwrap();
    }

    // A linked golden: accepted where it is kept.
    let kept = t.join("kept");
    std::fs::rename(&golden, &kept).unwrap();
    std::os::unix::fs::symlink(&kept, &golden).unwrap();
    let o = campath(t, &["review", "shots", "--accept"], &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(golden.is_symlink());
    same_files(&files(&kept), &accepted(&pending)).unwrap();
    test(t, &["--no-pending"], 0);
}
