//! Each animation mode at its keys and between them, against values computed here from the
//! notes' formulas and the interpolation formulas, not from campath's code.

use crate::common::doc;
use glam::DVec3;

const EPS: f64 = 1e-12;

fn close(a: DVec3, b: DVec3, eps: f64) -> bool {
    (a - b).length() <= eps
}

/// The notes' basis, written out again: n = VPN/|VPN|, u = n×VUV/|n×VUV|, v = u×n.
fn notes_basis(vpn: DVec3, vuv: DVec3) -> (DVec3, DVec3, DVec3) {
    let n = vpn / vpn.length();
    let c = DVec3::new(
        n.y * vuv.z - n.z * vuv.y,
        n.z * vuv.x - n.x * vuv.z,
        n.x * vuv.y - n.y * vuv.x,
    );
    let u = c / c.length();
    let v = DVec3::new(
        u.y * n.z - u.z * n.y,
        u.z * n.x - u.x * n.z,
        u.x * n.y - u.y * n.x,
    );
    (u, v, n)
}

fn file(camera: &str, animate: &str) -> String {
    format!("(frames: 9, fps: 2.0, image: (width: 8, height: 8), camera: ({camera}), animate: [{animate}])")
}

#[test]
fn observer_hits_keys_and_follows_catmull_rom_between() {
    // Uniform keys one second apart: Catmull-Rom tangents are (p[i+1] − p[i−1]) / 2, and the
    // phantom end keys make the end tangents p1 − p0 and p3 − p2.
    let p = [
        DVec3::new(0.0, 0.0, -10.0),
        DVec3::new(4.0, 1.0, -6.0),
        DVec3::new(1.0, 3.0, -2.0),
        DVec3::new(-2.0, 0.0, 0.0),
    ];
    let keys: Vec<String> = p
        .iter()
        .enumerate()
        .map(|(i, v)| format!("(t: {i}.0, value: ({:?}, {:?}, {:?}))", v.x, v.y, v.z))
        .collect();
    let d = doc(&file(
        "vpn: (0.0, 0.0, 1.0)",
        &format!("Observer(keys: [{}])", keys.join(", ")),
    ));
    let tangent = |i: usize| match i {
        0 => p[1] - p[0],
        3 => p[3] - p[2],
        _ => (p[i + 1] - p[i - 1]) * 0.5,
    };
    let hermite = |i: usize, s: f64| {
        let (s2, s3) = (s * s, s * s * s);
        p[i] * (2.0 * s3 - 3.0 * s2 + 1.0)
            + tangent(i) * (s3 - 2.0 * s2 + s)
            + p[i + 1] * (3.0 * s2 - 2.0 * s3)
            + tangent(i + 1) * (s3 - s2)
    };
    for (k, t) in [0.0, 0.25, 0.5, 1.0, 1.3, 2.0, 2.75, 3.0]
        .into_iter()
        .enumerate()
    {
        let cam = d.animation().camera_at(t, None).unwrap();
        let expect = if t >= 3.0 {
            p[3]
        } else {
            hermite(t.floor() as usize, t.fract())
        };
        assert!(
            close(cam.vrp_world, expect, 1e-12),
            "case {k}: t = {t}: {} vs {expect}",
            cam.vrp_world
        );
    }
    // Exactly at the keys, bit for bit.
    for (i, key) in p.iter().enumerate() {
        assert_eq!(
            d.animation().camera_at(i as f64, None).unwrap().vrp_world,
            *key
        );
    }
    // Held before the first key and after the last.
    assert_eq!(d.animation().camera_at(-5.0, None).unwrap().vrp_world, p[0]);
    assert_eq!(d.animation().camera_at(50.0, None).unwrap().vrp_world, p[3]);
    // The pointing stays the notes' basis of the fixed VPN.
    let (u, v, n) = notes_basis(DVec3::Z, DVec3::Y);
    let b = d.animation().camera_at(0.7, None).unwrap().basis;
    assert!(close(b.u, u, EPS) && close(b.v, v, EPS) && close(b.n, n, EPS));
}

#[test]
fn interpolation_kinds_between_two_keys() {
    // Two keys, 0 → 10 over 2 s, on the x of the VRP.
    let at = |interp: &str, t: f64| {
        let d = doc(&file(
            "vpn: (0.0, 0.0, 1.0)",
            &format!("Observer(keys: [(t: 0.0, value: (0.0, 0.0, 0.0)), (t: 2.0, value: (10.0, 0.0, 0.0))], interpolation: {interp})"),
        ));
        d.animation().camera_at(t, None).unwrap().vrp_world.x
    };
    assert_eq!(at("Step", 1.99), 0.0);
    assert_eq!(at("Step", 2.0), 10.0);
    assert!((at("Linear", 0.5) - 2.5).abs() < EPS);
    // Cosine: 10 · (1 − cos(π s)) / 2 at s = 1/4.
    let cosine = 10.0 * (1.0 - (std::f64::consts::PI * 0.25).cos()) / 2.0;
    assert!((at("Cosine", 0.5) - cosine).abs() < EPS);
    // Catmull-Rom with two keys and mirrored phantoms is the straight line at constant speed.
    assert!((at("CatmullRom", 0.5) - 2.5).abs() < EPS);
    assert!((at("CatmullRom", 1.5) - 7.5).abs() < EPS);
}

#[test]
fn per_key_interpolation_overrides_the_track() {
    let d = doc(&file(
        "vpn: (0.0, 0.0, 1.0)",
        "Observer(keys: [(t: 0.0, value: (0.0, 0.0, 0.0), interpolation: Step), (t: 1.0, value: (1.0, 0.0, 0.0)), (t: 2.0, value: (3.0, 0.0, 0.0))], interpolation: Linear)",
    ));
    assert_eq!(d.animation().camera_at(0.9, None).unwrap().vrp_world.x, 0.0);
    assert!((d.animation().camera_at(1.5, None).unwrap().vrp_world.x - 2.0).abs() < EPS);
}

#[test]
fn look_around_moves_on_the_great_circle() {
    let d = doc(&file(
        "vrp: (1.0, 2.0, 3.0)",
        "LookAround(keys: [(t: 0.0, value: (0.0, 0.0, 5.0)), (t: 1.0, value: (-2.0, 0.0, 0.0)), (t: 2.0, value: (0.0, 3.0, -3.0))], interpolation: Linear)",
    ));
    let a = &d.animation();
    // At the keys: the normalised key directions (lengths do not matter).
    let keys = [DVec3::Z, -DVec3::X, DVec3::new(0.0, 1.0, -1.0).normalize()];
    for (i, k) in keys.iter().enumerate() {
        let n = a.camera_at(i as f64, None).unwrap().basis.n;
        assert!(close(n, *k, 1e-15), "key {i}: {n}");
    }
    // Linear on the sphere is slerp: at a quarter of the way, the direction is at a quarter of
    // the angle, in the plane of the two keys.
    for (seg, s) in [(0usize, 0.25), (0, 0.5), (1, 0.75)] {
        let (p, q) = (keys[seg], keys[seg + 1]);
        let omega = p.dot(q).acos();
        let expect = (p * ((1.0 - s) * omega).sin() + q * (s * omega).sin()) / omega.sin();
        let n = a.camera_at(seg as f64 + s, None).unwrap().basis.n;
        assert!(
            close(n, expect, 1e-12),
            "segment {seg} at {s}: {n} vs {expect}"
        );
        // Never through the zero vector: unit length throughout.
        assert!((n.length() - 1.0).abs() < 1e-15);
    }
    // The VRP stays.
    assert_eq!(
        a.camera_at(0.5, None).unwrap().vrp_world,
        DVec3::new(1.0, 2.0, 3.0)
    );
}

#[test]
fn track_points_at_the_target_from_the_moving_vrp() {
    let d = doc(&file(
        "",
        "Observer(keys: [(t: 0.0, value: (0.0, 2.0, -10.0)), (t: 4.0, value: (8.0, 2.0, -2.0))], interpolation: Linear), \
         Track(keys: [(t: 0.0, value: (0.0, 0.0, 0.0)), (t: 4.0, value: (4.0, 0.0, 4.0))], interpolation: Linear)",
    ));
    for t in [0.0, 1.0, 2.5, 4.0] {
        let cam = d.animation().camera_at(t, None).unwrap();
        let vrp = DVec3::new(0.0, 2.0, -10.0) + DVec3::new(8.0, 0.0, 8.0) * (t / 4.0);
        let tp = DVec3::new(4.0, 0.0, 4.0) * (t / 4.0);
        let (u, v, n) = notes_basis(tp - vrp, DVec3::Y);
        assert!(close(cam.vrp_world, vrp, 1e-12));
        assert!(
            close(cam.basis.n, n, 1e-12)
                && close(cam.basis.u, u, 1e-12)
                && close(cam.basis.v, v, 1e-12)
        );
    }
}

#[test]
fn static_target_point_is_look_at() {
    let d = doc(&file("vrp: (3.0, 4.0, 5.0), tp: (0.0, 0.0, 0.0)", ""));
    let cam = d.animation().camera_at(0.0, None).unwrap();
    let (u, v, n) = notes_basis(-DVec3::new(3.0, 4.0, 5.0), DVec3::Y);
    assert!(close(cam.basis.n, n, EPS) && close(cam.basis.u, u, EPS) && close(cam.basis.v, v, EPS));
}

#[test]
fn zoom_moves_the_cop_along_vpn_and_distort_across_it() {
    let d = doc(&file(
        "vrp: (0.0, 0.0, -5.0), vpn: (0.0, 0.0, 1.0), cop: (0.1, 0.2, -1.0)",
        "Zoom(keys: [(t: 0.0, value: -1.0), (t: 2.0, value: -3.0)], interpolation: Linear), \
         Distort(keys: [(t: 0.0, value: (0.0, 0.0)), (t: 2.0, value: (0.8, -0.4))], interpolation: Linear)",
    ));
    for t in [0.0, 0.5, 1.0, 2.0] {
        let cam = d.animation().camera_at(t, None).unwrap();
        let s = t / 2.0;
        let cop = DVec3::new(0.8 * s, -0.4 * s, -1.0 - 2.0 * s);
        assert!(close(cam.cop_view, cop, 1e-15), "t = {t}: {}", cam.cop_view);
        // In world: VRP + u·cu + v·cv + n·cn, with u = −x, v = y, n = z for this camera.
        let world = DVec3::new(0.0, 0.0, -5.0) + DVec3::new(-cop.x, cop.y, cop.z);
        assert!(close(cam.cop_world(), world, 1e-15));
    }
}

#[test]
fn frame_times_are_k_over_fps() {
    let d = doc(&file(
        "vpn: (0.0, 0.0, 1.0)",
        "Observer(keys: [(t: 0.0, value: (0.0, 0.0, 0.0)), (t: 4.0, value: (4.0, 0.0, 0.0))], interpolation: Linear)",
    ));
    let xs: Vec<f64> = d.cameras().map(|r| r.unwrap().1.vrp_world.x).collect();
    assert_eq!(xs.len(), 9);
    for (k, x) in xs.iter().enumerate() {
        assert!((x - k as f64 / 2.0).abs() < EPS);
    }
}

#[test]
fn frames_default_to_reaching_the_last_key() {
    let d = doc("(fps: 10.0, camera: (vpn: (0.0, 0.0, 1.0)), animate: [Zoom(keys: [(t: 0.0, value: -1.0), (t: 2.5, value: -2.0)])])");
    assert_eq!(d.animation().frames, 26);
    let d = doc("(camera: (vpn: (0.0, 0.0, 1.0)))");
    assert_eq!(d.animation().frames, 1);
}

#[test]
fn dolly_zoom_example_keeps_the_subject_scale() {
    // The subject (origin) projects with scale d / (D + d): D its depth in front of the view
    // plane, d the COP's distance behind it. The example keeps that at 1/4 on every frame.
    let d = crate::common::example("dolly_zoom");
    let mut frames = 0;
    for item in d.cameras() {
        let (_, cam) = item.unwrap();
        let depth = (DVec3::ZERO - cam.vrp_world).dot(cam.basis.n);
        let dist = -cam.cop_view.z;
        let scale = dist / (depth + dist);
        assert!((scale - 0.25).abs() < 1e-12, "scale {scale}");
        frames += 1;
    }
    assert_eq!(frames, 72);
}

#[test]
fn uniform_speed_moves_at_constant_speed_along_the_same_path() {
    // A straight path with keys crowded at the start: keyed timing races then crawls; uniform
    // timing moves 10 units in 2 s at 5 units/s. Chord sums are exact on straight segments.
    let keys = "[(t: 0.0, value: (0.0, 0.0, 0.0)), (t: 0.1, value: (1.0, 0.0, 0.0)), (t: 2.0, value: (10.0, 0.0, 0.0))]";
    let d = doc(&file(
        "vpn: (0.0, 0.0, 1.0)",
        &format!("Observer(keys: {keys}, interpolation: Linear, speed: Uniform, arc_samples: 8)"),
    ));
    for t in [0.0, 0.05, 0.5, 1.0, 1.7, 2.0, 3.0] {
        let x = d.animation().camera_at(t, None).unwrap().vrp_world.x;
        let expect = 5.0 * t.min(2.0);
        assert!((x - expect).abs() < 1e-12, "t = {t}: {x} vs {expect}");
    }
}

#[test]
fn uniform_speed_error_falls_with_the_table_step_squared() {
    // A curved Catmull-Rom path: the distance covered per frame is nearly constant, and the
    // position error against a fine table falls about 16× per 4× resolution.
    let keys = "[(t: 0.0, value: (0.0, 0.0, 0.0)), (t: 0.3, value: (4.0, 0.0, 1.0)), (t: 2.0, value: (5.0, 0.0, 6.0)), (t: 4.0, value: (0.0, 0.0, 8.0))]";
    let at = |samples: u32| {
        let d = doc(&format!(
            "(frames: 97, fps: 24.0, camera: (vpn: (0.0, 0.0, 1.0)), animate: [Observer(keys: {keys}, speed: Uniform, arc_samples: {samples})])"
        ));
        d.cameras()
            .map(|r| r.unwrap().1.vrp_world)
            .collect::<Vec<DVec3>>()
    };
    let fine = at(1 << 16);
    let steps: Vec<f64> = fine.windows(2).map(|w| (w[1] - w[0]).length()).collect();
    let mean = steps.iter().sum::<f64>() / steps.len() as f64;
    for s in &steps {
        assert!((s - mean).abs() < 1e-2 * mean, "step {s} vs mean {mean}");
    }
    let err = |samples| {
        at(samples)
            .iter()
            .zip(&fine)
            .map(|(a, b)| (*a - *b).length())
            .fold(0.0, f64::max)
    };
    let (e16, e64) = (err(16), err(64));
    assert!(e64 < e16 / 8.0, "{e16} then {e64}");
    // The keyed path, for contrast, is far from constant speed on these keys.
    let keyed = doc(&format!("(frames: 97, fps: 24.0, camera: (vpn: (0.0, 0.0, 1.0)), animate: [Observer(keys: {keys})])"));
    let p: Vec<DVec3> = keyed.cameras().map(|r| r.unwrap().1.vrp_world).collect();
    let ksteps: Vec<f64> = p.windows(2).map(|w| (w[1] - w[0]).length()).collect();
    let spread = ksteps.iter().cloned().fold(0.0, f64::max)
        / ksteps.iter().cloned().fold(f64::INFINITY, f64::min);
    assert!(spread > 3.0, "keyed spread {spread}");
}

#[test]
fn arc_samples_needs_uniform_speed() {
    let e = campath::document::Document::from_str(
        std::path::Path::new("t.ron"),
        "(camera: (vpn: (0.0, 0.0, 1.0)), animate: [Observer(keys: [(t: 0.0, value: (0.0, 0.0, 0.0))], arc_samples: 8)])",
    )
    .unwrap_err()
    .to_string();
    assert!(
        e.contains("arc_samples: only applies with speed: Uniform"),
        "{e}"
    );
}

/// The scene the roll tests look at: spheres of three colours off the axis, so that a turn of
/// the picture moves every one of them.
const ROLL_SCENE: &str =
    "scene: (ambient: 0.2, lights: [(direction: (-1.0, -1.0, 1.0))], spheres: [
    (center: (0.0, 0.0, 6.0), radius: 1.0, color: (0.9, 0.2, 0.2)),
    (center: (1.6, 0.7, 7.0), radius: 0.6, color: (0.2, 0.9, 0.2)),
    (center: (-1.2, -0.9, 5.0), radius: 0.4, color: (0.2, 0.2, 0.9))])";

/// A Roll track renders every frame with the pixels of the same camera with its up vector
/// turned instead. Looking along +z with VUV = +y, u = −x and v = +y; turned θ counterclockwise
/// as seen from behind the camera, v becomes (sin θ, cos θ, 0), which is the VUV of a still
/// camera whose notes' basis is the rolled one. θ is 15° a frame, exact in binary.
#[test]
fn a_roll_renders_the_pixels_of_the_up_vector_turned_by_its_angle() {
    let image = "image: (width: 64, height: 48, samples: 2)";
    let rolled = doc(&format!(
        "(frames: 9, fps: 4.0, {image}, camera: (vpn: (0.0, 0.0, 1.0)),
          animate: [Roll(keys: [(t: 0.0, value: 0.0), (t: 2.0, value: 120.0)], interpolation: Linear)],
          {ROLL_SCENE})"
    ));
    let mut differing = Vec::new();
    for frame in 0..9u64 {
        let theta = (15.0 * frame as f64).to_radians();
        let (s, c) = (theta.sin(), theta.cos());
        let turned = doc(&format!(
            "(frames: 1, {image}, camera: (vpn: (0.0, 0.0, 1.0), vuv: ({s:?}, {c:?}, 0.0)), {ROLL_SCENE})"
        ));
        let cam = rolled.camera(frame).unwrap();
        assert!(
            close(cam.basis.v, DVec3::new(s, c, 0.0), 1e-15),
            "frame {frame}"
        );
        assert!(
            close(cam.basis.u, DVec3::new(-c, s, 0.0), 1e-15),
            "frame {frame}"
        );
        let (a, b) = (
            campath::frames::render_frame(&rolled, frame).unwrap(),
            campath::frames::render_frame(&turned, 0).unwrap(),
        );
        if a != b {
            differing.push(frame);
        }
    }
    assert!(differing.is_empty(), "frames {differing:?} differ");
    // The picture does turn: the frames at 0° and 90° differ.
    assert_ne!(
        campath::frames::render_frame(&rolled, 0).unwrap(),
        campath::frames::render_frame(&rolled, 6).unwrap()
    );
}

/// A roll composes with the up-vector rule at the pole: looking around through the zenith
/// (where the notes' basis is undefined and v is carried over the pole) with a fixed roll of 30°,
/// every frame's basis is the unrolled shot's turned by 30°, on both sides of the pole.
#[test]
fn a_roll_is_the_same_turn_on_both_sides_of_the_pole() {
    let shot = |camera: &str| {
        doc(&format!(
            "(frames: 49, fps: 24.0, image: (width: 32, height: 18), camera: (vrp: (0.0, 0.0, 0.0){camera}),
              animate: [LookAround(keys: [(t: 0.0, value: (0.0, 0.0, 1.0)), (t: 1.0, value: (0.0, 1.0, 0.0)),
                                          (t: 2.0, value: (0.0, 0.0, -1.0))], interpolation: Linear)],
              {ROLL_SCENE})"
        ))
    };
    let (plain, rolled) = (shot(""), shot(", roll: 30.0"));
    let (s, c) = (30f64.to_radians().sin(), 30f64.to_radians().cos());
    let pairs = plain.cameras().zip(rolled.cameras());
    for (frame, (a, b)) in pairs.enumerate() {
        let (a, b) = (a.unwrap().1.basis, b.unwrap().1.basis);
        assert!(close(b.n, a.n, 0.0), "frame {frame}");
        assert!(
            close(b.u, a.u * c + a.v * s, 1e-14),
            "frame {frame}: {b:?} against {a:?}"
        );
        assert!(
            close(b.v, a.v * c - a.u * s, 1e-14),
            "frame {frame}: {b:?} against {a:?}"
        );
    }
    // Without a roll, the camera is the notes' basis bit for bit: a roll of 0 changes nothing.
    let zero = shot(", roll: 0.0");
    assert!(zero
        .cameras()
        .zip(plain.cameras())
        .all(|(a, b)| a.unwrap().1.same_bits(&b.unwrap().1)));
}

/// The length an eased constant-speed path covers, written out from the speed profile: the
/// speed rises along smoothstep 3y² − 2y³ over the first `a` seconds, holds V, and falls back
/// over the last `b`; V·(T − (a + b)/2) is the whole length `length`.
fn eased_distance(x: f64, duration: f64, a: f64, b: f64, length: f64) -> f64 {
    let v = length / (duration - (a + b) / 2.0);
    // ∫₀ʸ 3s² − 2s³ ds = y³ − y⁴/2.
    let ramp = |y: f64| y.powi(3) - y.powi(4) / 2.0;
    if x < a {
        v * a * ramp(x / a)
    } else if x > duration - b {
        length - v * b * ramp((duration - x) / b)
    } else {
        v * (a / 2.0 + x - a)
    }
}

/// `speed: Uniform, ease: (start, end)` on a straight path whose keys are unevenly spaced (a
/// keyed path would crawl for 5 s and then leap 9 units in one): the camera is where the eased
/// speed profile puts it at every frame, starts and ends at rest, passes the inner keys without
/// slowing, and its speed changes by less than 1% of its top speed between frames.
#[test]
fn an_eased_path_starts_and_stops_softly_at_constant_speed_between() {
    let d = doc(
        "(fps: 60.0, image: (width: 8, height: 8), camera: (vpn: (0.0, 0.0, 1.0)), animate: [
            Observer(keys: [(t: 0.0, value: (0.0, 0.0, 0.0)), (t: 5.0, value: (1.0, 0.0, 0.0)),
                            (t: 6.0, value: (10.0, 0.0, 0.0)), (t: 10.0, value: (12.0, 0.0, 0.0))],
                     interpolation: Linear, speed: Uniform, ease: (start: 3.0, end: 3.0))])",
    );
    let x: Vec<f64> = d.cameras().map(|c| c.unwrap().1.vrp_world.x).collect();
    assert_eq!(x.len(), 601);
    for (k, &got) in x.iter().enumerate() {
        let want = eased_distance(k as f64 / 60.0, 10.0, 3.0, 3.0, 12.0);
        assert!((got - want).abs() < 1e-9, "frame {k}: {got} against {want}");
    }
    let speed: Vec<f64> = x.windows(2).map(|w| (w[1] - w[0]) * 60.0).collect();
    let top = 12.0 / (10.0 - 3.0);
    assert!(
        speed[0] < 0.001 * top && speed[599] < 0.001 * top,
        "{speed:?}"
    );
    for (k, w) in speed.windows(2).enumerate() {
        assert!(
            (w[1] - w[0]).abs() < 0.01 * top,
            "frames {k}..{}: {w:?}",
            k + 2
        );
    }
    // The cruise, through the keys at 5 s and 6 s, is at V.
    for s in &speed[185..415] {
        assert!((s - top).abs() < 1e-6 * top, "{s} against {top}");
    }
}
