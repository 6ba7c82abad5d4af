//! `campath watch`: a save re-renders the preview, a broken save shows its error and keeps the
//! watcher and the last good preview, Ctrl-C exits 0, and the page shows the pictures in headless
//! Chromium. Nothing here is timed: each wait is for an event, with a limit only so that a
//! watch that never answers fails the test instead of hanging it.

use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use crate::common::{does_not_run, need_part};

const FILE: &str = "(frames: 6, fps: 6.0, image: (width: 64, height: 36),
    camera: (vrp: (0.0, 1.0, -6.0), tp: (0.0, 0.0, 0.0), window: (1.6, 0.9)),
    animate: [Observer(keys: [(t: 0.0, value: (0.0, 1.0, -6.0)), (t: 1.0, value: (2.0, 1.0, -5.0))])],
    scene: (lights: [(direction: (-1.0, -2.0, 1.0))], spheres: [(center: (0.0, 0.0, 0.0), radius: 1.0, color: (0.9, 0.2, 0.2))]))";

/// How long a wait for the watch goes on before the test fails: far past any answer on a
/// loaded machine, for a watch that never answers.
const PATIENCE: Duration = Duration::from_secs(120);

/// The page's status, once `status.js` says `want` holds for it.
fn wait_status(dir: &Path, want: impl Fn(&serde_json::Value) -> bool) -> serde_json::Value {
    let started = Instant::now();
    loop {
        if let Ok(text) = std::fs::read_to_string(dir.join("status.js")) {
            let json = text
                .trim()
                .trim_start_matches("window.campathStatus = ")
                .trim_end_matches(';');
            if let Ok(v) = serde_json::from_str::<serde_json::Value>(json) {
                if want(&v) {
                    return v;
                }
            }
        }
        assert!(
            started.elapsed() < PATIENCE,
            "no such status within {PATIENCE:?}"
        );
        std::thread::sleep(Duration::from_millis(20));
    }
}

#[test]
fn a_save_updates_the_preview_and_a_broken_save_keeps_watching() {
    let tmp = tempfile::tempdir().unwrap();
    std::fs::write(tmp.path().join("w.ron"), FILE).unwrap();
    let page = tmp.path().join("page");
    let mut child = Command::new(env!("CARGO_BIN_EXE_campath"))
        .current_dir(tmp.path())
        .args(["watch", "w.ron", "--out", "page", "--width", "48"])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    wait_status(&page, |s| s["good"] == 1);
    let first = std::fs::read(page.join("first.png")).unwrap();

    // A save: the sphere turns blue.
    std::fs::write(
        tmp.path().join("w.ron"),
        FILE.replace("color: (0.9, 0.2, 0.2)", "color: (0.2, 0.2, 0.9)"),
    )
    .unwrap();
    wait_status(&page, |s| s["good"] == 2);
    assert_ne!(std::fs::read(page.join("first.png")).unwrap(), first);

    // A save in two steps, the file emptied and written 100 ms later (as some editors save):
    // the empty file is never shown as an error.
    let green = FILE.replace("color: (0.9, 0.2, 0.2)", "color: (0.2, 0.9, 0.2)");
    let mut f = std::fs::File::create(tmp.path().join("w.ron")).unwrap();
    std::thread::sleep(Duration::from_millis(100));
    std::io::Write::write_all(&mut f, green.as_bytes()).unwrap();
    drop(f);
    let s = wait_status(&page, |s| {
        s["good"].as_u64() > Some(2) && s["good"] == s["version"]
    });
    assert!(s["error"].is_null(), "{s}");
    let good = s["good"].clone();

    // A broken save: the error is shown, the last good preview stays, the watcher runs on.
    std::fs::write(
        tmp.path().join("w.ron"),
        "(frames: 6,\n  camera: (vpn: (0.0, 0.0 1.0)))",
    )
    .unwrap();
    let s = wait_status(&page, |s| !s["error"].is_null());
    assert_eq!(s["good"], good);
    assert!(s["error"].as_str().unwrap().contains("w.ron:2:"), "{s}");
    std::thread::sleep(Duration::from_millis(200));
    assert!(child.try_wait().unwrap().is_none(), "the watcher stopped");

    // A save narrower than --width: the preview takes the file's width, and says so.
    std::fs::write(
        tmp.path().join("w.ron"),
        FILE.replace("width: 64, height: 36", "width: 40, height: 36"),
    )
    .unwrap();
    wait_status(&page, |s| s["error"].is_null());
    let png = image::open(page.join("first.png")).unwrap();
    assert_eq!((png.width(), png.height()), (40, 36));

    // Ctrl-C ends it with status 0.
    ctrl_c(&child);
    let o = child.wait_with_output().unwrap();
    assert_eq!(o.status.code(), Some(0));
    let said = String::from_utf8_lossy(&o.stdout);
    let lines: Vec<&str> = said.lines().filter(|l| l.starts_with("updated")).collect();
    assert!(!lines[1].contains("px wide"), "{said}");
    assert!(
        lines[lines.len() - 1].ends_with(" ms (40 px wide, the file's width: --width 48 is wider)"),
        "{said}"
    );
    // The broken save's error alone was reported.
    let errors = String::from_utf8_lossy(&o.stderr);
    assert_eq!(errors.matches("campath: error").count(), 1, "{errors}");
}

/// The page in `page` as headless Chromium shows it: how many pixels have a colour.
fn screenshot(tmp: &Path, page: &Path) -> impl Fn([u8; 3]) -> usize {
    let shot = tmp.join("shot.png");
    let url = format!("file://{}", page.join("preview.html").display());
    let o = crate::common::chromium(
        &tmp.join("chrome"),
        &[
            "--window-size=1300,2400",
            "--virtual-time-budget=3000",
            &format!("--screenshot={}", shot.display()),
            &url,
        ],
    );
    let img = image::open(&shot)
        .unwrap_or_else(|e| {
            panic!(
                "no screenshot ({e}): {}",
                String::from_utf8_lossy(&o.stderr)
            )
        })
        .to_rgb8();
    move |rgb: [u8; 3]| img.pixels().filter(|p| p.0 == rgb).count()
}

fn watch(dir: &Path, file: &str) -> std::process::Child {
    Command::new(env!("CARGO_BIN_EXE_campath"))
        .current_dir(dir)
        .args(["watch", file, "--out", "page", "--width", "48"])
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap()
}

/// Sends `child` SIGINT, as Ctrl-C does, through the shell's own `kill` (a machine with only
/// Rust may have no `kill` program).
fn ctrl_c(child: &std::process::Child) {
    let kill = Command::new("sh")
        .args(["-c", &format!("kill -INT {}", child.id())])
        .status()
        .unwrap();
    assert!(kill.success());
}

fn interrupt(child: &mut std::process::Child) {
    ctrl_c(child);
    assert_eq!(child.wait().unwrap().code(), Some(0));
}

/// The file's sphere in colour `k`.
fn coloured(k: u8) -> String {
    FILE.replace("(0.9, 0.2, 0.2)", &format!("(0.9, 0.2, 0.{k})"))
}

/// Watch follows the file through a link, through its folder removed and made again, and past
/// a desktop's `.DS_Store` in its output folder; a preview waits for it; a new run shows none
/// of the last run's pictures; and a watch whose folder is removed stops, naming it.
#[test]
fn watch_follows_the_file_however_it_is_replaced_and_never_shares_its_folder() {
    let tmp = tempfile::tempdir().unwrap();
    let t = tmp.path();
    let page = t.join("page");
    std::fs::create_dir_all(t.join("real")).unwrap();
    std::fs::create_dir_all(t.join("shots")).unwrap();
    std::fs::write(t.join("real/w.ron"), coloured(1)).unwrap();
    std::os::unix::fs::symlink("../real/w.ron", t.join("shots/w.ron")).unwrap();
    let mut child = watch(t, "shots/w.ron");
    let s = wait_status(&page, |s| s["good"] == 1);
    let first = s["run"].as_u64().unwrap();
    // The link's target edited in place.
    std::fs::write(t.join("real/w.ron"), coloured(2)).unwrap();
    wait_status(&page, |s| s["good"] == 2);
    // The target's folder removed and made again.
    std::fs::remove_dir_all(t.join("real")).unwrap();
    wait_status(&page, |s| s["version"] == 3);
    std::fs::create_dir_all(t.join("real")).unwrap();
    std::fs::write(t.join("real/w.ron"), coloured(3)).unwrap();
    let s = wait_status(&page, |s| s["good"] == 4);
    assert!(s["error"].is_null(), "{s}");
    // A desktop's clutter in the output folder is no reason to stop.
    std::fs::write(page.join(".DS_Store"), "x").unwrap();
    std::fs::write(t.join("real/w.ron"), coloured(4)).unwrap();
    let s = wait_status(&page, |s| s["good"] == 5);
    assert!(s["error"].is_null(), "{s}");
    // A preview into the folder waits for the watch.
    std::fs::write(t.join("p.ron"), coloured(5)).unwrap();
    let mut preview = Command::new(env!("CARGO_BIN_EXE_campath"))
        .current_dir(t)
        .args(["preview", "p.ron", "--out", "page"])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    std::thread::sleep(Duration::from_millis(1500));
    assert!(
        preview.try_wait().unwrap().is_none(),
        "preview did not wait"
    );
    preview.kill().unwrap();
    preview.wait().unwrap();
    assert!(!page.join("preview.gif").exists());
    interrupt(&mut child);

    let s = wait_status(&page, |s| s["stopped"] == true);
    assert_eq!(s["good"], 5);

    // The next run, of a file that does not load: no picture of the last run is shown.
    std::fs::write(t.join("bad.ron"), "(frames: 6,").unwrap();
    let mut child = watch(t, "bad.ron");
    // Runs are numbered by the millisecond they start, later than the folder's last.
    let later = |s: &serde_json::Value, than: u64| s["run"].as_u64().is_some_and(|r| r > than);
    let s = wait_status(&page, |s| later(s, first));
    let second = s["run"].as_u64().unwrap();
    assert_eq!(s["good"], 0);
    assert!(!page.join("first.png").exists() && !page.join("plot.png").exists());
    interrupt(&mut child);

    // The output folder removed while watching: the next save stops the watch, naming it.
    let mut child = watch(t, "shots/w.ron");
    wait_status(&page, |s| later(s, second) && s["good"] == 1);
    std::fs::remove_dir_all(&page).unwrap();
    std::fs::write(t.join("real/w.ron"), coloured(6)).unwrap();
    let started = Instant::now();
    while child.try_wait().unwrap().is_none() {
        assert!(started.elapsed() < PATIENCE, "the watch went on");
        std::thread::sleep(Duration::from_millis(50));
    }
    let out = child.wait_with_output().unwrap();
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("removed or replaced while watching"), "{err}");

    // A file in a folder that does not exist: refused, nothing written.
    let o = Command::new(env!("CARGO_BIN_EXE_campath"))
        .current_dir(t)
        .args(["watch", "nowhere/w.ron", "--out", "other"])
        .output()
        .unwrap();
    assert_eq!(
        o.status.code(),
        Some(2),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    assert!(!t.join("other").exists());
}

/// The page in headless Chromium: a broken save shows the error banner over the last good
/// preview's plot; the next run, of a file that does not load, shows the banner and no picture
/// of the last run.
#[test]
#[ignore = "needs chromium"]
fn chromium_shows_the_plot_the_error_banner_and_no_picture_of_the_last_run() {
    need_part("chromium", "chromium", does_not_run);
    let tmp = tempfile::tempdir().unwrap();
    let t = tmp.path();
    let page = t.join("page");
    std::fs::write(t.join("w.ron"), FILE).unwrap();
    let mut child = watch(t, "w.ron");
    let first = wait_status(&page, |s| s["good"] == 1)["run"]
        .as_u64()
        .unwrap();
    std::fs::write(
        t.join("w.ron"),
        "(frames: 6,\n  camera: (vpn: (0.0, 0.0 1.0)))",
    )
    .unwrap();
    wait_status(&page, |s| !s["error"].is_null());
    let count = screenshot(t, &page);
    // The plot's blue VRP path and the error banner of the broken save are on the page.
    assert!(count([0, 0, 255]) > 100, "the plot is not shown");
    assert!(count([176, 0, 32]) > 1000, "the error banner is not shown");
    interrupt(&mut child);
    wait_status(&page, |s| s["stopped"] == true);

    std::fs::write(t.join("bad.ron"), "(frames: 6,").unwrap();
    let mut child = watch(t, "bad.ron");
    wait_status(&page, |s| s["run"].as_u64().is_some_and(|r| r > first));
    let count = screenshot(t, &page);
    assert_eq!(count([0, 0, 255]), 0, "a plot is shown");
    assert!(count([176, 0, 32]) > 1000, "the error banner is not shown");
    interrupt(&mut child);
}
