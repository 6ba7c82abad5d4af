//! `campath check` warns about motion that looks wrong, naming the frames and the quantity, and
//! `--strict` makes the warnings an exit status; the examples are quiet.

use crate::common::{campath, root, stderr, stdout, EXAMPLES};

fn check(text: &str, strict: bool) -> (Option<i32>, String) {
    let tmp = tempfile::tempdir().unwrap();
    std::fs::write(tmp.path().join("w.ron"), text).unwrap();
    let mut args = vec!["check", "w.ron"];
    if strict {
        args.push("--strict");
    }
    let o = campath(tmp.path(), &args, &[]);
    (o.status.code(), format!("{}{}", stdout(&o), stderr(&o)))
}

const SCENE: &str = "scene: (lights: [(direction: (-1.0, -2.0, 1.0))], spheres: [
    (center: (0.0, 0.0, 0.0), radius: 1.0), (center: (0.0, 0.0, 6.0), radius: 1.5)])";

#[test]
fn a_step_key_is_named_at_its_frame() {
    // The VRP jumps 3 units at t = 1 s, frame 10 at 10 fps: 30 units/s between frames 9 and 10.
    let file = format!(
        "(frames: 20, fps: 10.0, camera: (vrp: (0.0, 0.0, -5.0), vpn: (0.0, 0.0, 1.0)),
         animate: [Observer(keys: [(t: 0.0, value: (0.0, 0.0, -5.0)), (t: 1.0, value: (3.0, 0.0, -5.0))],
             interpolation: Step)], {SCENE})"
    );
    let (code, out) = check(&file, false);
    assert_eq!(code, Some(0), "{out}");
    assert!(
        out.contains("warning: frames 9, 10: the speed jumps: 0.000 → 30.000 units/s, then 0.000"),
        "{out}"
    );
    assert_eq!(check(&file, true).0, Some(1));
}

#[test]
fn the_camera_inside_a_sphere_and_a_target_at_the_camera_are_named() {
    // The eye (the COP, 1 unit behind the VRP) passes through the sphere at the origin: the VRP
    // goes from z = −6 to z = 4 over frames 0 to 20.
    let file = format!(
        "(frames: 21, fps: 10.0, camera: (vrp: (0.0, 0.0, -6.0), vpn: (0.0, 0.0, 1.0)),
         animate: [Observer(keys: [(t: 0.0, value: (0.0, 0.0, -6.0)), (t: 2.0, value: (0.0, 0.0, 4.0))],
             interpolation: Linear)], {SCENE})"
    );
    let (_, out) = check(&file, false);
    // Eye z at frame k: −7 + 0.5k; inside when −1 < z < 1: k = 13, 14, 15.
    assert!(
        out.contains("warning: frames 13, 14, 15: the COP is inside the sphere scene.spheres[0]: "),
        "{out}"
    );
    assert!(!out.contains("speed"), "{out}");

    // A sphere of a file is named by its file and line: the same path through the second
    // sphere of a CSV with a blank line, after an inline sphere far away.
    let tmp = tempfile::tempdir().unwrap();
    std::fs::write(
        tmp.path().join("s.csv"),
        "x,y,z,radius\n0,9,0,0.5\n\n0,0,0,1\n",
    )
    .unwrap();
    let text = file.replace(
        SCENE,
        "scene: (spheres: [(center: (9.0, 0.0, 0.0), radius: 1.0)], sphere_files: [\"s.csv\"])",
    );
    std::fs::write(tmp.path().join("w.ron"), text).unwrap();
    let o = campath(tmp.path(), &["check", "w.ron"], &[]);
    let out = format!("{}{}", stdout(&o), stderr(&o));
    assert!(
        out.contains(
            "warning: frames 13, 14, 15: the COP is inside the sphere \
             scene.sphere_files[0] (s.csv: line 4): "
        ),
        "{out}"
    );

    // A target that passes 0.05 units from the VRP, against a median distance of about 4.
    let file = format!(
        "(frames: 21, fps: 10.0, camera: (vrp: (0.0, 3.0, 0.0)),
         animate: [Track(keys: [(t: 0.0, value: (-4.0, 3.05, -4.0)), (t: 2.0, value: (4.0, 3.05, 4.0))],
             interpolation: Linear)], {SCENE})"
    );
    let (code, out) = check(&file, true);
    assert!(
        out.contains("warning: frame 10: the target point comes within 0.050 units of the VRP"),
        "{out}"
    );
    assert_eq!(code, Some(1));
}

#[test]
fn the_examples_are_quiet() {
    for name in EXAMPLES {
        let file = root().join("animations").join(format!("{name}.ron"));
        let o = campath(&root(), &["check", file.to_str().unwrap(), "--strict"], &[]);
        assert_eq!(o.status.code(), Some(0), "{name}: {}", stdout(&o));
        assert!(!stdout(&o).contains("warning"), "{name}: {}", stdout(&o));
    }
}

/// A smooth path that stops dead at its last key (a second before the shot ends) warns of the
/// jump and names the fix; the same
/// path eased at both ends is quiet under `--strict`, with the target tracked as before.
#[test]
fn a_path_that_stops_dead_names_the_ease_and_the_eased_path_is_quiet() {
    let shot = |timing: &str| {
        format!(
            "(frames: 168, fps: 24.0, camera: (), animate: [
                Observer(keys: [(t: 0.0, value: (-6.0, 1.0, -8.0)), (t: 2.0, value: (0.0, 2.0, -7.0)),
                                (t: 3.0, value: (5.0, 1.5, -4.0)), (t: 6.0, value: (8.0, 1.0, 0.0))]{timing}),
                Track(keys: [(t: 0.0, value: (0.0, 0.0, 0.0))])], {SCENE})"
        )
    };
    let (code, out) = check(&shot(""), false);
    assert_eq!(code, Some(0), "{out}");
    assert!(out.contains("the speed jumps"), "{out}");
    assert!(
        out.contains("give the Observer track speed: Uniform, ease: (start: 1.0, end: 1.0)"),
        "{out}"
    );
    let (code, out) = check(&shot(", speed: Uniform"), false);
    assert!(
        out.contains("the speed jumps") && out.contains("ease:"),
        "{code:?} {out}"
    );
    let (code, out) = check(
        &shot(", speed: Uniform, ease: (start: 1.0, end: 1.5)"),
        true,
    );
    assert_eq!(code, Some(0), "{out}");
    assert!(!out.contains("warning"), "{out}");
}

/// `plot --speed` charts the speed of `tests/data/eased.ron` into the output folder: a PNG of the
/// chart's size, drawn (not blank).
#[test]
fn plot_speed_charts_the_eased_example() {
    let tmp = tempfile::tempdir().unwrap();
    let file = root().join("tests/data/eased.ron");
    let png = tmp.path().join("speed.png");
    let o = campath(
        tmp.path(),
        &[
            "plot",
            file.to_str().unwrap(),
            "--speed",
            "--out",
            "speed.png",
        ],
        &[],
    );
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let image = image::open(&png).unwrap().to_rgb8();
    assert_eq!(image.dimensions(), (900, 420));
    let coloured = image
        .pixels()
        .filter(|p| p[0] != p[1] || p[1] != p[2])
        .count();
    assert!(coloured > 2000, "{coloured} coloured pixels");
}
