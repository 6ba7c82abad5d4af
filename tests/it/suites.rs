//! Frame-hash test suites: `campath test` over a folder of shots, pending goldens, approval
//! with `--update`,
//! JUnit, the review page in a real browser, goldens that name their renderer, a verify that
//! never harms a golden, and `campath::testing::assert_shot` from a cargo project of its own.

use std::collections::BTreeMap;
use std::os::unix::fs::MetadataExt;
use std::path::{Path, PathBuf};
use std::process::Command;

use crate::common::{campath, does_not_run, frame_lines, need_part, root, stderr, stdout};

/// A shot of `frames` frames at 40×24 whose first sphere has colour `red`.
fn shot(frames: u64, red: &str) -> String {
    format!(
        "(frames: {frames}, fps: 4.0, image: (width: 40, height: 24),
    camera: (vrp: (0.0, 1.0, -6.0), tp: (0.0, 0.0, 0.0), window: (1.6, 0.9)),
    animate: [Observer(keys: [(t: 0.0, value: (0.0, 1.0, -6.0)), (t: 1.0, value: (2.0, 1.0, -5.0))])],
    scene: (lights: [(direction: (-1.0, -2.0, 1.0))], spheres: [
        (center: (0.0, 0.0, 0.0), radius: 1.0, color: ({red}, 0.2, 0.2)),
        (center: (1.5, -0.5, 1.0), radius: 0.6, color: (0.2, 0.3, 0.9))]))"
    )
}

/// Three shots, one in a subfolder.
fn shots(dir: &Path) {
    std::fs::create_dir_all(dir.join("shots/sub")).unwrap();
    std::fs::write(dir.join("shots/a.ron"), shot(4, "0.9")).unwrap();
    std::fs::write(dir.join("shots/b.ron"), shot(5, "0.5")).unwrap();
    std::fs::write(dir.join("shots/sub/c.ron"), shot(3, "0.7")).unwrap();
}

/// `(frame, hash)` of a shot, from `campath hash` (not from `test`).
fn hashed(dir: &Path, file: &str) -> Vec<(u64, String)> {
    let o = campath(dir, &["hash", file], &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    parse(&stdout(&o))
}

fn parse(text: &str) -> Vec<(u64, String)> {
    frame_lines(text)
        .iter()
        .filter(|l| !l.trim().is_empty())
        .map(|l| {
            let mut it = l.split(' ');
            (
                it.next().unwrap().parse().unwrap(),
                it.next().unwrap().to_string(),
            )
        })
        .collect()
}

/// Every file under `dir` with its bytes, inode and modification time.
fn snapshot(dir: &Path) -> BTreeMap<PathBuf, (Vec<u8>, u64, i64, i64)> {
    let mut out = BTreeMap::new();
    for e in std::fs::read_dir(dir).unwrap().flatten() {
        let m = e.metadata().unwrap();
        if m.is_file() {
            out.insert(
                e.path(),
                (
                    std::fs::read(e.path()).unwrap(),
                    m.ino(),
                    m.mtime(),
                    m.mtime_nsec(),
                ),
            );
        }
    }
    out
}

/// The frames whose fresh hash differs from the golden's, the lists in frame order.
fn differing(fresh: &[(u64, String)], golden: &[(u64, String)]) -> Vec<u64> {
    fresh
        .iter()
        .zip(golden)
        .filter(|(f, g)| f != g)
        .map(|(f, _)| f.0)
        .collect()
}

#[test]
fn a_suite_fails_without_goldens_is_approved_and_then_catches_one_changed_shot() {
    let tmp = tempfile::tempdir().unwrap();
    let t = tmp.path();
    shots(t);

    // Compare only: every shot is new, and nothing is written.
    let o = campath(t, &["test", "--no-pending"], &[]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert_eq!(
        stdout(&o).matches(": new shot, no golden yet (").count(),
        3,
        "{}",
        stdout(&o)
    );
    assert!(
        stdout(&o).contains("3 shot(s): 0 passed, 0 differ, 3 new; 0 pending golden(s) written"),
        "{}",
        stdout(&o)
    );
    for name in ["shots/a", "shots/b", "shots/sub/c"] {
        assert!(!t.join(format!("{name}.golden")).exists(), "{name}");
        assert!(!t.join(format!("{name}.golden.new")).exists(), "{name}");
    }
    // By default each new shot leaves a pending golden, and no golden.
    let o = campath(t, &["test"], &[]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(
        stdout(&o).contains("3 new; 3 pending golden(s) written, 0 approved")
            && stdout(&o).contains("campath review shots"),
        "{}",
        stdout(&o)
    );
    for (shot, name) in [
        ("shots/a.ron", "shots/a"),
        ("shots/b.ron", "shots/b"),
        ("shots/sub/c.ron", "shots/sub/c"),
    ] {
        assert!(
            stdout(&o).contains(&format!("{shot}: new shot, no golden yet ("))
                && stdout(&o).contains(&format!("pending golden: {name}.golden.new")),
            "{}",
            stdout(&o)
        );
        assert!(!t.join(format!("{name}.golden")).exists(), "{name}");
        let text =
            std::fs::read_to_string(t.join(format!("{name}.golden.new/hashes.txt"))).unwrap();
        assert_eq!(parse(&text), hashed(t, shot), "{name}");
    }

    let o = campath(t, &["test", "--update"], &[]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert!(
        stdout(&o).contains("0 pending golden(s) written, 3 approved"),
        "{}",
        stdout(&o)
    );
    // Approval takes the place of the pending goldens.
    for name in ["shots/a", "shots/b", "shots/sub/c"] {
        assert!(!t.join(format!("{name}.golden.new")).exists(), "{name}");
    }
    for (shot, golden) in [
        ("shots/a.ron", "shots/a.golden"),
        ("shots/b.ron", "shots/b.golden"),
        ("shots/sub/c.ron", "shots/sub/c.golden"),
    ] {
        let text = std::fs::read_to_string(t.join(golden).join("hashes.txt")).unwrap();
        assert!(
            text.starts_with(&format!(
                "# campath renderer {}\n",
                campath::RENDERER_VERSION
            )),
            "{text}"
        );
        assert_eq!(parse(&text), hashed(t, shot), "{golden}");
    }
    let o = campath(t, &["test", "shots", "--jobs", "1"], &[]);
    assert_eq!(o.status.code(), Some(0), "{}", stdout(&o));
    assert_eq!(
        stdout(&o).matches(": passed (").count(),
        3,
        "{}",
        stdout(&o)
    );

    // b keeps its frames in its golden, for the review page.
    std::fs::remove_dir_all(t.join("shots/b.golden")).unwrap();
    let o = campath(t, &["test", "--update", "--keep-frames"], &[]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let golden_b = t.join("shots/b.golden");
    assert!(golden_b.join("frame_0004.png").exists());

    // b changes: only it fails, with exit 1, and each of its differing frames its own case.
    std::fs::write(t.join("shots/b.ron"), shot(5, "0.6")).unwrap();
    let fresh = hashed(t, "shots/b.ron");
    let golden = parse(&std::fs::read_to_string(golden_b.join("hashes.txt")).unwrap());
    let failing = differing(&fresh, &golden);
    assert!(!failing.is_empty());
    let before_a = snapshot(&t.join("shots/a.golden"));
    let before_c = snapshot(&t.join("shots/sub/c.golden"));
    let o = campath(
        t,
        &[
            "test",
            "shots",
            "--junit",
            "report.xml",
            "--review",
            "review",
            "--jobs",
            "3",
        ],
        &[],
    );
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    let out = stdout(&o);
    assert!(out.contains(&format!(
        "shots/b.ron: {} of 5 frame(s) differ",
        failing.len()
    )));
    assert_eq!(out.matches(": passed (").count(), 2, "{out}");
    // The failing run leaves b's golden as it was, and a pending golden of the new frames.
    assert!(out.contains("pending golden: shots/b.golden.new"), "{out}");
    let pending = t.join("shots/b.golden.new");
    assert_eq!(
        parse(&std::fs::read_to_string(pending.join("hashes.txt")).unwrap()),
        fresh
    );
    for k in &failing {
        assert!(
            pending.join(format!("frame_{k:04}.png")).is_file(),
            "frame {k}"
        );
        assert!(
            pending.join(format!("frame_{k:04}.diff.png")).is_file(),
            "frame {k}"
        );
    }
    assert_eq!(
        parse(&std::fs::read_to_string(golden_b.join("hashes.txt")).unwrap()),
        golden
    );

    let xml = std::fs::read_to_string(t.join("report.xml")).unwrap();
    let report = roxmltree::Document::parse(&xml).unwrap();
    let suites: Vec<_> = report
        .descendants()
        .filter(|n| n.has_tag_name("testsuite"))
        .collect();
    assert_eq!(suites.len(), 3);
    for s in &suites {
        let name = s.attribute("name").unwrap();
        let cases: Vec<_> = s
            .children()
            .filter(|n| n.has_tag_name("testcase"))
            .collect();
        let failed: Vec<u64> = cases
            .iter()
            .filter(|c| c.children().any(|n| n.has_tag_name("failure")))
            .map(|c| c.attribute("name").unwrap()[6..].parse().unwrap())
            .collect();
        if name.ends_with("b.ron") {
            assert_eq!(cases.len(), 5);
            assert_eq!(failed, failing, "{xml}");
        } else {
            assert!(failed.is_empty(), "{name}");
        }
    }

    // The review page names every failing frame (Chromium loads it in
    // `the_review_page_shows_every_picture_and_the_differences_in_chromium`).
    let html = std::fs::read_to_string(t.join("review/index.html")).unwrap();
    for k in &failing {
        assert!(html.contains(&format!("id=\"frame-{k}\"")), "frame {k}");
    }

    // Approving rewrites b's golden only: a's and c's files are not touched.
    let o = campath(t, &["test", "--update"], &[]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert!(
        stdout(&o).contains("0 pending golden(s) written, 1 approved"),
        "{}",
        stdout(&o)
    );
    assert!(!t.join("shots/b.golden.new").exists());
    assert_eq!(snapshot(&t.join("shots/a.golden")), before_a);
    assert_eq!(snapshot(&t.join("shots/sub/c.golden")), before_c);
    let text = std::fs::read_to_string(golden_b.join("hashes.txt")).unwrap();
    assert_eq!(parse(&text), fresh);
    // Its frames too, with their hashes.
    for (frame, hash) in &fresh {
        let png = golden_b.join(format!("frame_{frame:04}.png"));
        let pixels = image::open(&png).unwrap().to_rgb8().into_raw();
        assert_eq!(&campath::frame_hash(&pixels), hash, "frame {frame}");
    }
    assert_eq!(campath(t, &["test"], &[]).status.code(), Some(0));
}

/// The review page, in a real browser: every picture loads, and the differences show.
#[test]
#[ignore = "needs chromium"]
fn the_review_page_shows_every_picture_and_the_differences_in_chromium() {
    need_part("chromium", "chromium", does_not_run);
    let tmp = tempfile::tempdir().unwrap();
    let t = tmp.path();
    std::fs::create_dir_all(t.join("shots")).unwrap();
    std::fs::write(t.join("shots/b.ron"), shot(5, "0.5")).unwrap();
    let o = campath(t, &["test", "--update", "--keep-frames"], &[]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let golden = parse(&std::fs::read_to_string(t.join("shots/b.golden/hashes.txt")).unwrap());
    std::fs::write(t.join("shots/b.ron"), shot(5, "0.6")).unwrap();
    let failing = differing(&hashed(t, "shots/b.ron"), &golden);
    assert!(!failing.is_empty());
    let o = campath(t, &["test", "--review", "review"], &[]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    let page = t.join("review/index.html");
    let url = format!("file://{}", page.display());
    let chromium = |extra: &[&str]| {
        let args = [&["--virtual-time-budget=3000"][..], extra, &[&url]].concat();
        crate::common::chromium(&t.join("chrome"), &args)
    };
    let dom = String::from_utf8_lossy(&chromium(&["--dump-dom"]).stdout).into_owned();
    // Golden, new and difference for every failing frame.
    let want = 3 * failing.len();
    assert!(
        dom.contains(&format!("data-images=\"{want}\" data-loaded=\"{want}\"")),
        "{}",
        &dom[..dom.len().min(600)]
    );
    // The slider starts half way: the new frame is clipped to the right half.
    assert!(
        dom.contains("clip-path: inset(0px 0px 0px 50%)"),
        "no slider"
    );
    let shot_png = t.join("page.png");
    let o = chromium(&[
        "--window-size=1200,900",
        &format!("--screenshot={}", shot_png.display()),
    ]);
    let img = image::open(&shot_png)
        .unwrap_or_else(|e| panic!("no screenshot ({e}): {}", stderr(&o)))
        .to_rgb8();
    let magenta = img.pixels().filter(|p| p.0 == [255, 0, 255]).count();
    assert!(
        magenta > 50,
        "the difference image is not shown ({magenta} px)"
    );
}

#[test]
fn a_golden_from_another_renderer_says_so_and_a_bad_shot_does_not_stop_the_others() {
    let tmp = tempfile::tempdir().unwrap();
    let t = tmp.path();
    shots(t);
    assert!(campath(t, &["test", "--update"], &[]).status.success());
    // a's golden from "renderer 0", with one frame's pixels different.
    let path = t.join("shots/a.golden/hashes.txt");
    let text = std::fs::read_to_string(&path).unwrap();
    let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
    lines[0] = "# campath renderer 0".into();
    lines[2] = format!("1 {}", "0".repeat(64));
    std::fs::write(&path, lines.join("\n") + "\n").unwrap();
    // c's golden names renderer 0 too, but its frames still match: it passes.
    let c = t.join("shots/sub/c.golden/hashes.txt");
    let text = std::fs::read_to_string(&c).unwrap();
    std::fs::write(
        &c,
        text.replace(
            &format!("renderer {}", campath::RENDERER_VERSION),
            "renderer 0",
        ),
    )
    .unwrap();
    // And a shot that does not load.
    std::fs::write(t.join("shots/broken.ron"), "(frames: 3, camera: (").unwrap();

    let o = campath(t, &["test", "--junit", "j.xml"], &[]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    let out = stdout(&o);
    assert!(
        out.contains(&format!(
            "shots/a.ron: golden made by renderer 0, this campath is renderer {}",
            campath::RENDERER_VERSION
        )) && out.contains("1 of 4 frame(s) differ: 1"),
        "{out}"
    );
    assert!(out.contains("shots/broken.ron: cannot check: "), "{out}");
    assert!(out.contains("shots/b.ron: passed"), "{out}");
    assert!(out.contains("shots/sub/c.ron: passed"), "{out}");
    assert!(
        stderr(&o).contains("1 of 4 shot(s) could not be checked"),
        "{}",
        stderr(&o)
    );
    let xml = std::fs::read_to_string(t.join("j.xml")).unwrap();
    let report = roxmltree::Document::parse(&xml).unwrap();
    assert!(report.descendants().any(|n| n.has_tag_name("error")));

    // verify says the same of the renderer.
    let o = campath(t, &["verify", "shots/a.ron", "shots/a.golden"], &[]);
    assert_eq!(o.status.code(), Some(1));
    assert!(
        stdout(&o).contains("was made by campath renderer 0"),
        "{}",
        stdout(&o)
    );

    // Nothing to check is bad input, not a pass.
    std::fs::create_dir(t.join("empty")).unwrap();
    assert_eq!(campath(t, &["test", "empty"], &[]).status.code(), Some(2));
    assert_eq!(campath(t, &["test", "nowhere"], &[]).status.code(), Some(2));
}

#[test]
fn verify_never_harms_a_golden() {
    let tmp = tempfile::tempdir().unwrap();
    let t = tmp.path();
    std::fs::write(t.join("s.ron"), shot(4, "0.9")).unwrap();
    let o = campath(t, &["render", "s.ron", "--out", "golden", "--quiet"], &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    std::fs::create_dir(t.join("other")).unwrap();
    std::fs::write(t.join("other/notes.txt"), "mine").unwrap();
    std::fs::write(t.join("s.ron"), shot(4, "0.5")).unwrap();
    let before = snapshot(&t.join("golden"));
    for (golden, option, dir, why) in [
        ("golden", "--save-failures", "golden", "is the golden"),
        (
            "golden",
            "--save-failures",
            "golden/failures",
            "lies inside the golden",
        ),
        (
            "golden",
            "--save-failures",
            "./x/../golden/.",
            "is the golden",
        ),
        (
            "golden/hashes.txt",
            "--save-failures",
            "golden",
            "is the golden",
        ),
        (
            "golden",
            "--save-failures",
            "other",
            "holds files campath did not write",
        ),
        (
            "golden",
            "--junit",
            "golden/report.xml",
            "lies inside the golden",
        ),
        (
            "golden/hashes.txt",
            "--junit",
            "golden/hashes.txt",
            "is the golden",
        ),
    ] {
        let o = campath(t, &["verify", "s.ron", golden, option, dir], &[]);
        assert_eq!(o.status.code(), Some(2), "{option} {dir}: {}", stderr(&o));
        assert!(stderr(&o).contains(why), "{option} {dir}: {}", stderr(&o));
        assert_eq!(snapshot(&t.join("golden")), before, "{option} {dir}");
    }
    assert_eq!(std::fs::read(t.join("other/notes.txt")).unwrap(), b"mine");
    assert!(!t.join("golden/failures").exists());

    // Failures go to their own folder, with pixel counts from the golden frames.
    let o = campath(
        t,
        &["verify", "s.ron", "golden", "--save-failures", "fails"],
        &[],
    );
    assert_eq!(o.status.code(), Some(1));
    let saved = std::fs::read_dir(t.join("fails")).unwrap().count();
    assert!(saved >= 2, "{saved}");
    for line in stdout(&o).lines().filter(|l| l.starts_with("frame ")) {
        let k: u64 = line[6..line.find(':').unwrap()].parse().unwrap();
        let rgb = |p: &str| image::open(t.join(p)).unwrap().to_rgb8().into_raw();
        let (g, n) = (
            rgb(&format!("golden/frame_{k:04}.png")),
            rgb(&format!("fails/frame_{k:04}.png")),
        );
        let changed = g.chunks(3).zip(n.chunks(3)).filter(|(a, b)| a != b).count();
        assert!(changed > 0);
        assert!(
            line.contains(&format!(": {changed} pixel(s) changed")),
            "{line}"
        );
    }
    assert_eq!(snapshot(&t.join("golden")), before);
    // A passing verify clears the earlier failures: only campath's lock file, its mark, is left.
    std::fs::write(t.join("s.ron"), shot(4, "0.9")).unwrap();
    let o = campath(
        t,
        &["verify", "s.ron", "golden", "--save-failures", "fails"],
        &[],
    );
    assert_eq!(o.status.code(), Some(0), "{}", stdout(&o));
    let left: Vec<_> = std::fs::read_dir(t.join("fails"))
        .unwrap()
        .flatten()
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .collect();
    assert_eq!(left, ["campath.lock"]);
}

#[test]
fn the_repositorys_own_shots_pass() {
    let o = campath(&root(), &["test", "tests/shots"], &[]);
    assert_eq!(o.status.code(), Some(0), "{}{}", stdout(&o), stderr(&o));
    assert_eq!(
        stdout(&o).matches(": passed (").count(),
        5,
        "{}",
        stdout(&o)
    );
}

/// A cargo project of its own depends on campath by path without the command line and uses
/// `campath::assert_shot!`: without a golden it fails and writes a pending golden;
/// `campath review --accept` makes it pass; after a change to the shot it fails naming the
/// frames and `campath review`, its golden's bytes unchanged and the pending golden holding the
/// differing frames; under CI nothing is written; `CAMPATH_UPDATE=always` rewrites the golden,
/// a value it does not know fails naming the values, and run from another folder
/// (`--manifest-path`) it finds the shot. It builds campath and its dependencies again (minutes
/// on a fresh machine), so `.ci/run` runs it.
#[test]
#[ignore = "builds campath in a cargo project of its own; .ci/run runs it"]
fn assert_shot_in_a_cargo_project_of_its_own() {
    let tmp = tempfile::tempdir().unwrap();
    let p = tmp.path().join("user");
    std::fs::create_dir_all(p.join("tests")).unwrap();
    std::fs::write(
        p.join("Cargo.toml"),
        format!(
            "[package]\nname = \"user\"\nversion = \"0.1.0\"\nedition = \"2021\"\n\n\
             [dev-dependencies]\ncampath = {{ path = {:?}, default-features = false }}\n",
            root().display().to_string()
        ),
    )
    .unwrap();
    std::fs::create_dir_all(p.join("src")).unwrap();
    std::fs::write(p.join("src/lib.rs"), "").unwrap();
    std::fs::write(
        p.join("tests/frames.rs"),
        "#[test]\nfn the_shot_looks_as_approved() {\n    \
         campath::assert_shot!(\"shots/fly.ron\");\n}\n",
    )
    .unwrap();
    std::fs::create_dir_all(p.join("shots")).unwrap();
    std::fs::write(p.join("shots/fly.ron"), shot(4, "0.9")).unwrap();
    // The same versions as campath's own build, and its target folder, so that nothing is
    // fetched and little is compiled again.
    std::fs::copy(root().join("Cargo.lock"), p.join("Cargo.lock")).unwrap();
    let target = root().join("target/assert-shot");
    let cargo_in = |dir: &Path, extra: &[&str], env: &[(&str, &str)]| {
        let mut c = Command::new(env!("CARGO"));
        c.current_dir(dir)
            .args(["test", "--offline", "--quiet"])
            .args(extra)
            .env("CARGO_TARGET_DIR", &target)
            .env_remove("CAMPATH_UPDATE")
            .env_remove("CI");
        for (k, v) in env {
            c.env(k, v);
        }
        let o = c.output().unwrap();
        let text = format!("{}{}", stdout(&o), stderr(&o));
        (o.status.success(), text)
    };
    let cargo = |env: &[(&str, &str)]| cargo_in(&p, &[], env);
    let golden = p.join("shots/fly.golden");
    let pending = p.join("shots/fly.golden.new");

    let (ok, text) = cargo(&[]);
    assert!(!ok, "passed without a golden: {text}");
    assert!(
        text.contains("no golden yet") && text.contains("campath review"),
        "{text}"
    );
    assert!(!golden.exists());
    let written = std::fs::read_to_string(pending.join("hashes.txt")).unwrap();
    assert_eq!(parse(&written), hashed(&p, "shots/fly.ron"));
    let (ok, text) = cargo(&[("CAMPATH_UPDATE", "yes")]);
    assert!(
        !ok && text.contains("CAMPATH_UPDATE=yes: it takes no, new or always"),
        "{text}"
    );

    let o = campath(&p, &["review", "shots", "--accept"], &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(!pending.exists());
    let text = std::fs::read_to_string(golden.join("hashes.txt")).unwrap();
    assert_eq!(parse(&text), hashed(&p, "shots/fly.ron"));
    let (ok, text) = cargo(&[]);
    assert!(ok, "{text}");

    // A change: the test fails, the golden stays, the pending golden holds what differs.
    std::fs::write(p.join("shots/fly.ron"), shot(4, "0.4")).unwrap();
    let bytes = |dir: &Path| {
        let mut all: Vec<(String, Vec<u8>)> = (std::fs::read_dir(dir).unwrap().flatten())
            .map(|e| {
                let name = e.file_name().to_string_lossy().into_owned();
                (name, std::fs::read(e.path()).unwrap())
            })
            .collect();
        all.sort();
        all
    };
    let before = bytes(&golden);
    let (ok, text) = cargo(&[]);
    assert!(!ok, "passed after a change: {text}");
    assert!(
        text.contains("4 of 4 frame(s) differ: 0, 1, 2, 3")
            && text.contains("pixel(s) changed")
            && text.contains("campath review ")
            && text.contains("fly.golden.new"),
        "{text}"
    );
    assert_eq!(bytes(&golden), before);
    let fresh = hashed(&p, "shots/fly.ron");
    let written = std::fs::read_to_string(pending.join("hashes.txt")).unwrap();
    assert_eq!(parse(&written), fresh);
    for f in 0..4 {
        assert!(pending.join(format!("frame_{f:04}.png")).is_file(), "{f}");
        assert!(
            pending.join(format!("frame_{f:04}.diff.png")).is_file(),
            "{f}"
        );
    }

    // Under CI nothing is written.
    std::fs::remove_dir_all(&pending).unwrap();
    let (ok, text) = cargo(&[("CI", "true")]);
    assert!(!ok && text.contains("Nothing was written"), "{text}");
    assert!(!pending.exists());
    assert_eq!(bytes(&golden), before);

    // CAMPATH_UPDATE=always approves in place.
    let (ok, text) = cargo(&[("CAMPATH_UPDATE", "always")]);
    assert!(ok, "{text}");
    let text = std::fs::read_to_string(golden.join("hashes.txt")).unwrap();
    assert_eq!(parse(&text), fresh);
    assert!(!pending.exists());

    // From another folder, the shot is the crate's.
    let manifest = p.join("Cargo.toml");
    let (ok, text) = cargo_in(
        tmp.path(),
        &["--manifest-path", manifest.to_str().unwrap()],
        &[],
    );
    assert!(ok, "{text}");
    std::fs::write(p.join("shots/fly.ron"), shot(4, "0.9")).unwrap();
    let (ok, text) = cargo_in(
        tmp.path(),
        &["--manifest-path", manifest.to_str().unwrap()],
        &[],
    );
    assert!(!ok && text.contains("4 of 4 frame(s) differ"), "{text}");
    assert!(!tmp.path().join("shots").exists());

    // The library alone: no command-line crate was built for it.
    let deps = std::fs::read_dir(target.join("debug/deps")).unwrap();
    let names: Vec<String> = deps
        .flatten()
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .collect();
    assert!(
        !names.iter().any(|n| n.starts_with("libclap")),
        "clap was built"
    );
}

#[test]
fn stale_golden_frames_newer_goldens_and_unkind_paths_are_caught() {
    let tmp = tempfile::tempdir().unwrap();
    let t = tmp.path();
    shots(t);
    let o = campath(t, &["test", "--update", "--keep-frames"], &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    let golden_a = t.join("shots/a.golden");

    // A golden frame gone, or another frame's picture in its place: the golden is stale.
    std::fs::remove_file(golden_a.join("frame_0002.png")).unwrap();
    std::fs::copy(
        golden_a.join("frame_0000.png"),
        golden_a.join("frame_0001.png"),
    )
    .unwrap();
    let o = campath(t, &["test"], &[]);
    assert_eq!(o.status.code(), Some(1), "{}", stdout(&o));
    assert!(
        stdout(&o).contains("the golden's pictures of frame(s) 1, 2 are missing"),
        "{}",
        stdout(&o)
    );
    // Approval repairs them, and leaves nothing else in or beside the golden.
    assert!(campath(t, &["test", "--update"], &[]).status.success());
    assert_eq!(campath(t, &["test"], &[]).status.code(), Some(0));
    let beside: Vec<String> = std::fs::read_dir(t.join("shots"))
        .unwrap()
        .flatten()
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| n.starts_with('.'))
        .collect();
    assert!(beside.is_empty(), "{beside:?}");
    let mut in_golden: Vec<String> = std::fs::read_dir(&golden_a)
        .unwrap()
        .flatten()
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .collect();
    in_golden.sort();
    assert_eq!(
        in_golden,
        [
            "frame_0000.png",
            "frame_0001.png",
            "frame_0002.png",
            "frame_0003.png",
            "hashes.txt",
            "thumb_0000.png",
            "thumb_0001.png",
            "thumb_0002.png",
            "thumb_0003.png"
        ]
    );

    // What a killed approval left beside the golden is cleared by the next check, but not
    // while an approval of the shot holds its lock.
    let left = t.join("shots/.a.golden.update-4242");
    std::fs::create_dir(&left).unwrap();
    std::fs::write(left.join("frame_0000.png"), b"half").unwrap();
    let approval = std::fs::File::open(t.join("shots/a.ron")).unwrap();
    approval.lock().unwrap();
    assert_eq!(
        campath(t, &["test", "--no-pending"], &[]).status.code(),
        Some(0)
    );
    assert!(left.exists());
    drop(approval);
    assert_eq!(
        campath(t, &["test", "--no-pending"], &[]).status.code(),
        Some(0)
    );
    assert!(!left.exists());
    // An approval clears it too (the folder swept once, not once a shot), also for a shot whose
    // name is not UTF-8 (which the sweep passes).
    std::fs::create_dir(&left).unwrap();
    #[cfg(unix)]
    let odd = {
        use std::os::unix::ffi::OsStrExt;
        let shots = t.join("shots");
        std::fs::copy(
            shots.join("a.ron"),
            shots.join(std::ffi::OsStr::from_bytes(b"o\xff.ron")),
        )
        .unwrap();
        let odd = shots.join(std::ffi::OsStr::from_bytes(b".o\xff.golden.update-4242"));
        std::fs::create_dir(&odd).unwrap();
        odd
    };
    assert!(campath(t, &["test", "--update"], &[]).status.success());
    assert!(!left.exists());
    #[cfg(unix)]
    {
        assert!(!odd.exists());
        use std::os::unix::ffi::OsStrExt;
        let shots = t.join("shots");
        std::fs::remove_file(shots.join(std::ffi::OsStr::from_bytes(b"o\xff.ron"))).unwrap();
        std::fs::remove_dir_all(shots.join(std::ffi::OsStr::from_bytes(b"o\xff.golden"))).unwrap();
    }

    // hashes.txt lost beside old frames: approval writes both anew.
    std::fs::write(t.join("shots/a.ron"), shot(4, "0.3")).unwrap();
    std::fs::remove_file(golden_a.join("hashes.txt")).unwrap();
    assert!(campath(t, &["test", "--update"], &[]).status.success());
    let o = campath(t, &["verify", "shots/a.ron", "shots/a.golden"], &[]);
    assert_eq!(o.status.code(), Some(0), "{}", stdout(&o));
    assert_eq!(campath(t, &["test"], &[]).status.code(), Some(0));

    // Two approvals of the same shots at once take turns and leave a whole golden.
    std::fs::write(t.join("shots/b.ron"), shot(5, "0.1")).unwrap();
    let spawn = || {
        Command::new(env!("CARGO_BIN_EXE_campath"))
            .current_dir(t)
            .args(["test", "--update", "--keep-frames"])
            .stdout(std::process::Stdio::piped())
            .stderr(std::process::Stdio::piped())
            .spawn()
            .unwrap()
    };
    let (p, q) = (spawn(), spawn());
    for c in [p, q] {
        let o = c.wait_with_output().unwrap();
        assert!(o.status.success(), "{}", stderr(&o));
    }
    assert_eq!(campath(t, &["test"], &[]).status.code(), Some(0));

    // A golden from a newer renderer is never overwritten by an older one.
    let path = t.join("shots/sub/c.golden/hashes.txt");
    let text = std::fs::read_to_string(&path).unwrap();
    let newer = text.replacen(
        &format!("renderer {}", campath::RENDERER_VERSION),
        "renderer 99",
        1,
    );
    let mut lines: Vec<&str> = newer.lines().collect();
    let zero = format!("0 {}", "0".repeat(64));
    lines[1] = &zero;
    std::fs::write(&path, lines.join("\n") + "\n").unwrap();
    let before = std::fs::read(&path).unwrap();
    let o = campath(t, &["test", "--update", "--junit", "j.xml"], &[]);
    assert_eq!(o.status.code(), Some(1), "{}", stdout(&o));
    assert!(
        stdout(&o).contains("newer than this campath's renderer"),
        "{}",
        stdout(&o)
    );
    assert_eq!(std::fs::read(&path).unwrap(), before);
    // The report agrees with the exit status: c's frame 0 fails, nothing else.
    let xml = std::fs::read_to_string(t.join("j.xml")).unwrap();
    assert!(xml.contains("failures=\"1\""), "{xml}");

    // --junit never overwrites a shot; --save-failures never empties a folder it did not mark.
    let shot_before = std::fs::read(t.join("shots/a.ron")).unwrap();
    let o = campath(t, &["test", "--junit", "shots/a.ron"], &[]);
    assert_eq!(o.status.code(), Some(2));
    assert_eq!(std::fs::read(t.join("shots/a.ron")).unwrap(), shot_before);
    std::fs::create_dir(t.join("mine")).unwrap();
    std::fs::copy(
        golden_a.join("frame_0000.png"),
        t.join("mine/frame_0000.png"),
    )
    .unwrap();
    let o = campath(
        t,
        &[
            "verify",
            "shots/b.ron",
            "shots/a.golden",
            "--save-failures",
            "mine",
        ],
        &[],
    );
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(t.join("mine/frame_0000.png").exists());

    // A link back up the tree does not make shots run twice.
    std::os::unix::fs::symlink("..", t.join("shots/sub/up")).unwrap();
    let o = campath(t, &["test"], &[]);
    assert_eq!(
        stdout(&o).matches("shots/a.ron").count(),
        1,
        "{}",
        stdout(&o)
    );
    // A linked file has its golden beside it, and is a shot of its own.
    std::os::unix::fs::symlink("a.ron", t.join("shots/z.ron")).unwrap();
    let o = campath(t, &["test"], &[]);
    assert!(
        stdout(&o).contains("shots/z.ron: new shot, no golden yet"),
        "{}",
        stdout(&o)
    );
    // Two shots whose goldens are one folder: refused before anything renders.
    std::os::unix::fs::symlink("a.golden", t.join("shots/z.golden")).unwrap();
    std::fs::remove_file(t.join("shots/z.ron")).unwrap();
    std::fs::write(t.join("shots/z.ron"), shot(4, "0.1")).unwrap();
    let o = campath(t, &["test"], &[]);
    assert_eq!(o.status.code(), Some(2), "{}", stdout(&o));
    assert!(
        stderr(&o).contains("have one golden") && stderr(&o).contains("a.golden"),
        "{}",
        stderr(&o)
    );
}

/// Unkind goldens and report paths, each refused with exit 2 before anything renders: a
/// `--junit` report in the `--save-failures` or `--review` folder, a golden listing a frame
/// index past every file's last (10⁷ frames; u64::MAX overflowed), a golden that is not UTF-8
/// (named by line), and `--save-failures` into a golden through a folder not made yet and a link
/// (`new/../link/f`).
#[test]
fn unkind_goldens_and_report_paths_are_refused_before_any_work() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    std::fs::create_dir(dir.join("shots")).unwrap();
    std::fs::write(dir.join("shots/a.ron"), shot(3, "0.9")).unwrap();
    let o = campath(dir, &["test", "shots", "--update"], &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    std::fs::write(dir.join("shots/a.ron"), shot(3, "0.5")).unwrap();
    std::os::unix::fs::symlink(dir.join("shots/a.golden"), dir.join("link")).unwrap();
    let golden = std::fs::read_to_string(dir.join("shots/a.golden/hashes.txt")).unwrap();
    let hash = frame_lines(&golden)[0]
        .split(' ')
        .nth(1)
        .unwrap()
        .to_string();
    for (args, want) in [
        (
            &[
                "verify",
                "shots/a.ron",
                "shots/a.golden",
                "--junit",
                "f",
                "--save-failures",
                "f",
            ][..],
            "--junit f is in the --save-failures folder f",
        ),
        (
            &["test", "shots", "--junit", "r/j.xml", "--review", "r"],
            "--junit r/j.xml is in the --review folder r",
        ),
        (
            &[
                "verify",
                "shots/a.ron",
                "shots/a.golden",
                "--save-failures",
                "new/../link/f",
            ],
            "--save-failures new/../link/f lies inside the golden shots/a.golden",
        ),
    ] {
        let o = campath(dir, args, &[]);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {}", stderr(&o));
        assert!(stderr(&o).contains(want), "{args:?}: {}", stderr(&o));
        for left in ["f", "r", "new", "shots/a.golden/f"] {
            assert!(!dir.join(left).exists(), "{args:?} made {left}");
        }
    }
    for (lines, want) in [
        (
            format!("{golden}18446744073709551615 {hash}\n"),
            "line 5: a frame index of 10000000 or more",
        ),
        (
            format!("{golden}10000000 {hash}\n"),
            "line 5: a frame index of 10000000 or more",
        ),
    ] {
        std::fs::write(dir.join("g.txt"), &lines).unwrap();
        let o = campath(dir, &["verify", "shots/a.ron", "g.txt"], &[]);
        assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
        assert!(stderr(&o).contains(want), "{}", stderr(&o));
    }
    std::fs::write(dir.join("g.txt"), b"# campath renderer 1\n0 caf\xe9\n").unwrap();
    let o = campath(dir, &["verify", "shots/a.ron", "g.txt"], &[]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("g.txt: line 2: not UTF-8 text"),
        "{}",
        stderr(&o)
    );
}

/// Approving with frames (`--keep-frames`, `CAMPATH_UPDATE=frames`) a golden that kept its
/// hashes alone writes every frame, not only those that differ, so the next check passes; a
/// passing golden of hashes alone gains its frames too.
#[test]
fn approving_frames_into_a_golden_of_hashes_writes_every_frame() {
    let tmp = tempfile::tempdir().unwrap();
    let t = tmp.path();
    let golden = t.join("shots/a.golden");
    let frames = || {
        (0..6)
            .filter(|f| golden.join(format!("frame_{f:04}.png")).is_file())
            .count()
    };
    let test = |args: &[&str]| {
        let o = campath(t, &[&["test", "shots"][..], args].concat(), &[]);
        assert!(o.status.success(), "{args:?}: {}{}", stdout(&o), stderr(&o));
    };
    std::fs::create_dir_all(t.join("shots")).unwrap();
    std::fs::write(t.join("shots/a.ron"), shot(4, "0.9")).unwrap();
    test(&["--update"]);
    assert_eq!(frames(), 0);
    test(&["--update", "--keep-frames"]);
    assert_eq!(frames(), 4);
    test(&[]);
    // Hashes alone again, and a fifth frame: the first four are the same.
    for f in 0..4 {
        std::fs::remove_file(golden.join(format!("frame_{f:04}.png"))).unwrap();
    }
    std::fs::write(t.join("shots/a.ron"), shot(5, "0.9")).unwrap();
    test(&["--update", "--keep-frames"]);
    assert_eq!(frames(), 5);
    test(&[]);
}
