//! The catalogue of stiff and extreme cases (files in tests/data/). Each case is measured against
//! an independent value: a closed form, or the f64 reference caster below, written here apart
//! from campath's renderer. Run with `--nocapture` to see the measured numbers that
//! docs/numerics.md reports (`cargo test --test it extreme:: -- --nocapture`).

use campath::testing::Update;
use std::path::Path;

use campath::camera::Camera;
use campath::document::Document;
use campath::frames::hashes;
use campath::internals::Renderer;
use campath::Error;
use glam::DVec3;

fn load(name: &str) -> Document {
    Document::load(&crate::common::root().join("tests/data").join(name))
        .unwrap_or_else(|e| panic!("{e}"))
}

fn load_err(name: &str) -> String {
    match Document::load(&crate::common::root().join("tests/data").join(name))
        .and_then(|d| d.check_path().map(|_| d))
    {
        Ok(_) => panic!("{name} must be refused"),
        Err(e) => {
            assert!(
                matches!(e, Error::Invalid { .. } | Error::Frame { .. }),
                "{name}: {e}"
            );
            e.to_string()
        }
    }
}

fn cameras(doc: &Document) -> Vec<Camera> {
    doc.cameras().map(|r| r.unwrap().1).collect()
}

// ---------------------------------------------------------------------------------------------
// The f64 reference caster: world-space rays from the COP, relative to the VRP, with the
// geometric hit test |L × d| ≤ r. Returns per pixel 0 for background or 1 + sphere index.

fn reference_ids(doc: &Document, cam: &Camera) -> Vec<usize> {
    let (w, h) = (doc.raster().width as usize, doc.raster().height as usize);
    let b = cam.basis;
    let c = cam.cop_view;
    let cop_rel = b.u * c.x + b.v * c.y + b.n * c.z;
    let mut out = Vec::with_capacity(w * h);
    for j in 0..h {
        for i in 0..w {
            let x = (i as f64 + 0.5) / w as f64 * cam.window.x - cam.window.x / 2.0;
            let y = cam.window.y / 2.0 - (j as f64 + 0.5) / h as f64 * cam.window.y;
            let d = (b.u * x + b.v * y - cop_rel).normalize();
            let mut best = (0usize, f64::INFINITY);
            for (k, s) in doc.scene().spheres.iter().enumerate() {
                let l = (s.center_world - cam.vrp_world) - cop_rel;
                let d2 = l.cross(d).length_squared();
                let r2 = s.radius * s.radius;
                if d2 > r2 {
                    continue;
                }
                let tca = l.dot(d);
                let thc = (r2 - d2).sqrt();
                let t = if tca - thc > 0.0 {
                    tca - thc
                } else {
                    tca + thc
                };
                if t > 0.0 && t < best.1 {
                    best = (k + 1, t);
                }
            }
            out.push(best.0);
        }
    }
    out
}

/// campath's picture of a flat scene, as sphere ids by colour (each sphere has its own).
fn our_ids(doc: &Document, cam: &Camera) -> Vec<usize> {
    let pixels = Renderer::new().render(cam, doc.scene(), *doc.raster());
    let enc = campath::internals::srgb_encoder();
    let colors: Vec<[u8; 3]> = doc
        .scene()
        .spheres
        .iter()
        .map(|s| {
            [
                enc.encode(s.color.x),
                enc.encode(s.color.y),
                enc.encode(s.color.z),
            ]
        })
        .collect();
    pixels
        .chunks(3)
        .map(|p| colors.iter().position(|c| c == p).map_or(0, |k| k + 1))
        .collect()
}

/// Fraction of pixels where campath and the reference see different spheres; also checks that
/// the case is not vacuous (every sphere is seen by the reference).
fn disagreement(name: &str) -> f64 {
    let doc = load(name);
    let cam = cameras(&doc)[0];
    let ours = our_ids(&doc, &cam);
    let theirs = reference_ids(&doc, &cam);
    for k in 1..=doc.scene().spheres.len() {
        assert!(
            theirs.contains(&k),
            "{name}: sphere {} is not in view; the case would be vacuous",
            k - 1
        );
    }
    let differ = ours.iter().zip(&theirs).filter(|(a, b)| a != b).count();
    let frac = differ as f64 / ours.len() as f64;
    eprintln!(
        "{name}: {differ} of {} pixels differ from the f64 reference ({:.4}%)",
        ours.len(),
        frac * 100.0
    );
    frac
}

/// Flat scenes compared sphere by sphere with the reference caster.
const PROJECTIONS: [&str; 10] = [
    "fov_tiny.ron",
    "fov_wide.ron",
    "cop_near.ron",
    "cop_far.ron",
    "off_axis.ron",
    "aspect.ron",
    "one_pixel.ron",
    "column.ron",
    "tiny_sphere.ron",
    "huge_sphere.ron",
];

#[test]
fn extreme_projections_match_the_reference() {
    for name in PROJECTIONS {
        assert!(disagreement(name) <= 0.001, "{name}");
    }
}

#[test]
fn naive_quadratic_fails_where_the_stable_form_holds() {
    // The textbook discriminant b² − c on the tiny sphere, from a COP 1e4 further back: the
    // terms are ~1e16 and r² = 1e-6 drowns. Shows the case is stiff for a naive caster.
    let doc = load("tiny_sphere.ron");
    let s = doc.scene().spheres.get(0);
    let origin = DVec3::new(0.0, 0.0, -1e8); // the camera pulled far back along −n
    let l = s.center_world - origin;
    let d = l.normalize();
    let b = l.dot(d);
    let c = l.length_squared() - s.radius * s.radius;
    let naive_disc = b * b - c;
    let stable_disc = s.radius * s.radius - l.cross(d).length_squared();
    // The exact discriminant along the centre line is r² = 1e-6.
    assert!((stable_disc - 1e-6).abs() < 1e-9, "stable {stable_disc}");
    assert!(
        (naive_disc - 1e-6).abs() > 1e-7,
        "naive {naive_disc} should be visibly wrong here"
    );
}

#[test]
fn grazing_rays_on_a_huge_sphere_do_not_speckle() {
    let doc = load("huge_sphere_lit.ron");
    let cam = cameras(&doc)[0];
    let pixels = Renderer::new().render(&cam, doc.scene(), *doc.raster());
    let ids = reference_ids(&doc, &cam);
    let (w, h) = (doc.raster().width as usize, doc.raster().height as usize);
    let lum = |i: usize, j: usize| pixels[(j * w + i) * 3] as i32;
    // A speckle: a ground pixel more than 8 levels off all four ground neighbours.
    let mut speckles = 0;
    let mut ground = 0;
    for j in 1..h - 1 {
        for i in 1..w - 1 {
            if ids[j * w + i] != 1 {
                continue;
            }
            ground += 1;
            let nb = [(i - 1, j), (i + 1, j), (i, j - 1), (i, j + 1)];
            let ground_nb: Vec<i32> = nb
                .iter()
                .filter(|(a, b)| ids[b * w + a] == 1)
                .map(|&(a, b)| lum(a, b))
                .collect();
            if ground_nb.len() == 4 && ground_nb.iter().all(|v| (v - lum(i, j)).abs() > 8) {
                speckles += 1;
            }
        }
    }
    eprintln!("huge_sphere_lit: {speckles} speckles on {ground} ground pixels");
    assert!(ground > w * h / 4);
    assert_eq!(speckles, 0);
}

// ---------------------------------------------------------------------------------------------
// Far from the origin.

pub fn far_scene(offset: f64) -> String {
    let o =
        |x: f64, y: f64, z: f64| format!("({:?}, {:?}, {:?})", x + offset, y + offset, z + offset);
    format!(
        "(frames: 3, fps: 1.0, image: (width: 160, height: 90, samples: 2),
          camera: (tp: {tp}, cop: (0.0, 0.0, -1.5), window: (1.6, 0.9)),
          animate: [Observer(keys: [(t: 0.0, value: {k0}), (t: 1.0, value: {k1}), (t: 2.0, value: {k2})])],
          scene: (ambient: 0.1, lights: [(direction: (-1.0, -2.0, 1.0))],
                  spheres: [(center: {s0}, radius: 1.0, color: (0.9, 0.2, 0.2)), (center: {s1}, radius: 100.0, color: (0.5, 0.5, 0.5)),
                            (center: {s2}, radius: 0.5, color: (0.2, 0.8, 0.3)), (center: {s3}, radius: 0.01, color: (0.9, 0.9, 0.9))]))",
        tp = o(0.0, 0.0, 0.0),
        k0 = o(0.0, 2.0, -10.0),
        k1 = o(4.0, 3.0, -6.0),
        k2 = o(2.0, 1.5, -4.0),
        s0 = o(0.0, 0.0, 0.0),
        s1 = o(0.0, -101.0, 0.0),
        s2 = o(2.0, 0.0, 1.0),
        s3 = o(-0.5, 1.2, -1.0),
    )
}

/// Every frame of a keyframe file's text, rendered.
fn render_text(text: &str) -> Vec<Vec<u8>> {
    let doc = Document::from_str(Path::new("scene.ron"), text).unwrap();
    let mut r = Renderer::new();
    cameras(&doc)
        .iter()
        .map(|c| r.render(c, doc.scene(), *doc.raster()))
        .collect()
}

#[test]
fn far_from_the_origin_renders_the_same_pixels() {
    let render = |offset: f64| render_text(&far_scene(offset));
    let base = render(0.0);
    for offset in [1e6, 1e7, 1e8] {
        let far = render(offset);
        let (mut off, mut total) = (0, 0);
        for (a, b) in base.iter().zip(&far) {
            for (p, q) in a.chunks(3).zip(b.chunks(3)) {
                total += 1;
                if p.iter().zip(q).any(|(x, y)| x.abs_diff(*y) > 1) {
                    off += 1;
                }
            }
        }
        eprintln!("offset {offset:e}: {off} of {total} pixels differ by more than one level");
        assert!(
            off as f64 <= 0.001 * total as f64,
            "offset {offset:e}: {off}/{total}"
        );
    }
}

/// Three spheres, a shadowing light and a moving camera, with every length times `k`.
fn scaled_scene(k: f64) -> String {
    let p = |x: f64, y: f64, z: f64| format!("({:?}, {:?}, {:?})", x * k, y * k, z * k);
    let l = |x: f64| format!("{:?}", x * k);
    format!(
        "(frames: 2, fps: 1.0, image: (width: 96, height: 54, samples: 2),
          camera: (tp: {tp}, cop: {cop}, window: ({w}, {h})),
          animate: [Observer(keys: [(t: 0.0, value: {k0}), (t: 1.0, value: {k1})])],
          scene: (ambient: 0.1, lights: [(direction: (-1.0, -2.0, 1.0))],
                  spheres: [(center: {s0}, radius: {r0}, color: (0.9, 0.2, 0.2)), (center: {s1}, radius: {r1}, color: (0.5, 0.5, 0.5)),
                            (center: {s2}, radius: {r2}, color: (0.2, 0.8, 0.3))]))",
        tp = p(0.0, 0.0, 0.0),
        cop = p(0.0, 0.0, -1.5),
        w = l(1.6),
        h = l(0.9),
        k0 = p(0.0, 2.0, -10.0),
        k1 = p(4.0, 3.0, -6.0),
        s0 = p(0.0, 0.0, 0.0),
        r0 = l(1.0),
        s1 = p(0.0, -101.0, 0.0),
        r1 = l(100.0),
        s2 = p(2.0, 0.0, 1.0),
        r2 = l(0.5),
    )
}

/// Every length times a power of two is exact, so a scene scaled by one renders the same
/// bytes: down to lengths whose squares are still normal numbers (the view pyramid's planes
/// once underflowed there and culled every sphere), and up to the largest size a scene may
/// have (1e150: the renderer squares distances). Beyond that the scene is refused, naming the
/// bound, not rendered without its spheres.
#[test]
fn a_scene_scaled_by_a_power_of_two_renders_the_same_bytes() {
    let render = |k: f64| render_text(&scaled_scene(k));
    let base = render(1.0);
    // Not one colour: the spheres are in the picture.
    assert!(base[0].chunks(3).any(|p| p != &base[0][..3]));
    // Down to lengths near 3e-151, whose squares are still normal numbers, and up to 3e147.
    for e in [-500, -300, -100, -40, 40, 100, 300, 490] {
        assert!(render(2f64.powi(e)) == base, "scaled by 2^{e}");
    }
    // 2^500 ≈ 3.3e150.
    let e = Document::from_str(Path::new("scaled.ron"), &scaled_scene(2f64.powi(500)))
        .unwrap_err()
        .to_string();
    assert!(e.contains("within ±1e150"), "{e}");
}

#[test]
fn naive_f32_world_space_loses_the_small_sphere_far_away() {
    // The naive route, f32 world coordinates through the matrix M, puts the 1 cm sphere's centre
    // off by more than its radius at 1e6; campath's camera-relative f64 keeps it to 1e-9.
    let at = |offset: f64| {
        let doc = Document::from_str(Path::new("far.ron"), &far_scene(offset)).unwrap();
        (cameras(&doc)[1], doc.scene().spheres.get(3))
    };
    let (cam0, s0) = at(0.0);
    let exact = cam0.point_to_view(s0.center_world);
    let (cam, s) = at(1e6);
    let ours = cam.point_to_view(s.center_world);
    let naive = cam
        .world_to_view()
        .as_mat4()
        .transform_point3(s.center_world.as_vec3())
        .as_dvec3();
    let (ours_err, naive_err) = ((ours - exact).length(), (naive - exact).length());
    eprintln!("offset 1e6: view-space error of the 1 cm sphere: f64 camera-relative {ours_err:.1e}, naive f32 {naive_err:.1e}");
    assert!(ours_err < 1e-9);
    assert!(naive_err > s.radius);
}

// ---------------------------------------------------------------------------------------------
// The camera at and near the pole (VPN ∥ VUV).

/// Roll change between two frames: v rotated by the smallest rotation taking n_a to n_b, against
/// v_b. Zero for a pure pan or tilt; π for a flip about n.
fn roll_change(a: &Camera, b: &Camera) -> f64 {
    let (na, nb) = (a.basis.n, b.basis.n);
    let axis = na.cross(nb);
    let s = axis.length();
    let c = na.dot(nb);
    let va = a.basis.v;
    let moved = if s < 1e-15 {
        va
    } else {
        let k = axis / s;
        // Rodrigues' rotation by atan2(s, c) about k.
        va * c + k.cross(va) * s + k * k.dot(va) * (1.0 - c)
    };
    moved.dot(b.basis.v).clamp(-1.0, 1.0).acos()
}

fn turn(a: &Camera, b: &Camera) -> f64 {
    a.basis.n.dot(b.basis.n).clamp(-1.0, 1.0).acos()
}

/// The worst roll beyond the turn between consecutive frames of a naive camera: the notes'
/// basis at every frame, without continuity (frames where it is undefined are skipped).
fn naive_flip(doc: &Document) -> f64 {
    let naive: Vec<Camera> = cameras(doc)
        .into_iter()
        .filter_map(|c| {
            let basis =
                campath::camera::Basis::from_vpn_vuv(c.basis.n, doc.animation().vuv).ok()?;
            Some(Camera { basis, ..c })
        })
        .collect();
    naive
        .windows(2)
        .map(|w| roll_change(&w[0], &w[1]) - turn(&w[0], &w[1]))
        .fold(0.0, f64::max)
}

#[test]
fn up_vector_carries_on_over_the_pole() {
    for name in ["pole_track.ron", "pole_look_around.ron"] {
        let doc = load(name);
        let cams = cameras(&doc);
        assert_eq!(cams.len(), 49);
        // The case passes through the pole exactly.
        assert!(
            cams.iter()
                .any(|c| c.basis.n.cross(doc.animation().vuv).length() < 1e-12),
            "{name}"
        );
        let mut worst: f64 = 0.0;
        for (k, w) in cams.windows(2).enumerate() {
            for v in [w[1].basis.u, w[1].basis.v, w[1].basis.n] {
                assert!(
                    v.is_finite() && (v.length() - 1.0).abs() < 1e-12,
                    "{name} frame {}",
                    k + 1
                );
            }
            let excess = roll_change(&w[0], &w[1]) - turn(&w[0], &w[1]);
            worst = worst.max(excess);
            assert!(
                excess <= 1e-9,
                "{name}: frame {k}→{}: roll {} vs turn {}",
                k + 1,
                roll_change(&w[0], &w[1]),
                turn(&w[0], &w[1])
            );
        }
        let naive = naive_flip(&doc);
        eprintln!("{name}: worst roll beyond the turn {worst:.2e} rad; the notes' basis per frame flips by {naive:.3} rad");
        assert!(naive > 2.5, "{name}: a naive camera should flip here");
    }
}

#[test]
fn static_camera_along_vuv_is_an_error() {
    for name in ["pole_static.ron", "pole_static_near.ron"] {
        let e = load_err(name);
        assert!(
            e.contains(name)
                && e.contains("camera.vuv")
                && e.contains("parallel")
                && e.contains("t = 0 s"),
            "{e}"
        );
    }
}

#[test]
fn invalid_vectors_are_clear_errors() {
    for (name, expect) in [
        ("zero_vpn.ron", &["camera.vpn", "non-zero"][..]),
        (
            "tp_equals_vrp.ron",
            &["camera.tp", "TP equals VRP", "t = 0 s"],
        ),
        ("zero_vuv.ron", &["camera.vuv", "non-zero"]),
        ("nonfinite.ron", &["camera.vrp", "inf", "camera.vpn", "NaN"]),
        (
            "tp_crosses_vrp.ron",
            &["frame 12", "t = 0.5 s", "TP equals VRP"],
        ),
    ] {
        let e = load_err(name);
        assert!(e.contains(name), "{e}");
        for x in expect {
            assert!(e.contains(x), "{name}: expected {x:?} in {e}");
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Keyframes.

/// Largest excursion of a sampled scalar beyond the key values of the segment it is in.
fn overshoot(keys: &[(f64, f64)], sample: impl Fn(f64) -> f64) -> f64 {
    let mut worst: f64 = 0.0;
    for w in keys.windows(2) {
        let (lo, hi) = (w[0].1.min(w[1].1), w[0].1.max(w[1].1));
        for k in 0..=2000 {
            let t = w[0].0 + (w[1].0 - w[0].0) * k as f64 / 2000.0;
            let x = sample(t);
            assert!(x.is_finite());
            worst = worst.max(lo - x).max(x - hi);
        }
    }
    worst
}

fn with_interpolation(name: &str, interp: &str) -> Document {
    let text =
        std::fs::read_to_string(crate::common::root().join("tests/data").join(name)).unwrap();
    let text = text.replace(
        "interpolation: Monotone",
        &format!("interpolation: {interp}"),
    );
    Document::from_str(Path::new(name), &text).unwrap()
}

#[test]
fn stiff_zoom_keys_overshoot_only_without_monotone() {
    let keys = [(0.0, -1.0), (1.0, -1.0), (1.000001, -5.0), (2.0, -5.0)];
    let zoom = |d: &Document| {
        let a = d.animation().clone();
        move |t: f64| a.camera_at(t, None).map(|c| c.cop_view.z).unwrap()
    };
    let mono = overshoot(&keys, zoom(&load("stiff_keys.ron")));
    let cr = overshoot(
        &keys,
        zoom(&with_interpolation("stiff_keys.ron", "CatmullRom")),
    );
    eprintln!("stiff_keys: overshoot Monotone {mono:.3e}, CatmullRom {cr:.4}");
    assert!(mono <= 1e-12);
    // Closed form for Catmull-Rom: the segment [0, 1] from −1 to −1 with end tangent
    // −4 / (1 + 1e-6) s⁻¹ peaks at s = 2/3 with 4/27 of that tangent.
    let expect = 4.0 / 1.000001 * 4.0 / 27.0;
    assert!((cr - expect).abs() < 1e-3, "{cr} vs {expect}");
    // The frames never see a NaN, and the keys are hit.
    let d = load("stiff_keys.ron");
    assert_eq!(d.animation().camera_at(1.0, None).unwrap().cop_view.z, -1.0);
    assert_eq!(
        d.animation().camera_at(1.000001, None).unwrap().cop_view.z,
        -5.0
    );
    d.check_path().unwrap();
}

#[test]
fn uneven_keys_overshoot_only_without_monotone() {
    let pos = [
        DVec3::new(0.0, 0.0, 0.0),
        DVec3::new(1.0, 2.0, 0.0),
        DVec3::new(3.0, 2.5, 0.0),
        DVec3::new(3.5, 2.6, 0.0),
    ];
    let times = [0.0, 1.0, 1.01, 2.01];
    for interp in ["Monotone", "CatmullRom"] {
        let d = with_interpolation("uneven_keys.ron", interp);
        let mut worst: f64 = 0.0;
        for axis in 0..2 {
            let keys: Vec<(f64, f64)> =
                times.iter().zip(&pos).map(|(t, p)| (*t, p[axis])).collect();
            let a = d.animation().clone();
            worst = worst.max(overshoot(&keys, move |t| {
                a.camera_at(t, None).unwrap().vrp_world[axis]
            }));
        }
        eprintln!("uneven_keys: overshoot {interp} {worst:.4}");
        if interp == "Monotone" {
            assert!(worst <= 1e-12);
        } else {
            assert!(
                worst > 0.01,
                "Catmull-Rom is expected to overshoot on these keys"
            );
        }
    }
}

/// Whether a 2-D polyline crosses itself (segments that are not neighbours intersect).
fn self_intersects(pts: &[(f64, f64)]) -> bool {
    let cross = |o: (f64, f64), a: (f64, f64), b: (f64, f64)| {
        (a.0 - o.0) * (b.1 - o.1) - (a.1 - o.1) * (b.0 - o.0)
    };
    for i in 0..pts.len() - 1 {
        for j in i + 2..pts.len() - 1 {
            let (a, b, c, d) = (pts[i], pts[i + 1], pts[j], pts[j + 1]);
            let d1 = cross(c, d, a);
            let d2 = cross(c, d, b);
            let d3 = cross(a, b, c);
            let d4 = cross(a, b, d);
            if d1 * d2 < 0.0 && d3 * d4 < 0.0 {
                return true;
            }
        }
    }
    false
}

#[test]
fn centripetal_path_never_loops_within_a_segment() {
    for (interp, loops) in [("Centripetal", false), ("CatmullRom", true)] {
        let text = std::fs::read_to_string(crate::common::root().join("tests/data/loop_path.ron"))
            .unwrap();
        let d = Document::from_str(
            Path::new("loop_path.ron"),
            &text.replace("Centripetal", interp),
        )
        .unwrap();
        for seg in 0..3 {
            let pts: Vec<(f64, f64)> = (0..=400)
                .map(|k| {
                    let p = d
                        .animation()
                        .camera_at(seg as f64 + k as f64 / 400.0, None)
                        .unwrap()
                        .vrp_world;
                    (p.x, p.y)
                })
                .collect();
            let got = self_intersects(&pts);
            eprintln!("loop_path: {interp} segment {seg}: loops {got}");
            if seg == 1 {
                assert_eq!(got, loops, "{interp}");
            } else if interp == "Centripetal" {
                assert!(!got);
            }
        }
    }
    // Keys are hit exactly.
    let d = load("loop_path.ron");
    assert_eq!(
        d.animation().camera_at(2.0, None).unwrap().vrp_world,
        DVec3::new(1.0, 0.0, 0.0)
    );
}

#[test]
fn degenerate_tracks_have_defined_behaviour() {
    assert!(load_err("equal_times.ron").contains("keys[2].t: key times must strictly increase"));
    assert!(load_err("unsorted_times.ron").contains("keys[1].t: key times must strictly increase"));
    assert!(load_err("empty_track.ron").contains("keys: a track needs at least one key"));
    let d = load("single_key.ron");
    for cam in cameras(&d) {
        assert_eq!(cam.vrp_world, DVec3::new(1.0, 2.0, 3.0));
    }
}

#[test]
fn opposite_vpn_keys_turn_about_v() {
    let d = load("opposite_vpn.ron");
    let cams = cameras(&d);
    let v0 = cams[0].basis.v;
    let u0 = cams[0].basis.u;
    for c in &cams {
        assert!(c.basis.n.is_finite());
        // The turn is about v: n stays orthogonal to the first frame's v.
        assert!(c.basis.n.dot(v0).abs() < 1e-12);
    }
    // Halfway, the camera looks along the first frame's u (it turns right).
    let mid = d.animation().camera_at(0.5, None).unwrap().basis.n;
    assert!((mid - u0).length() < 1e-12, "{mid} vs {u0}");
    assert!((cams[24].basis.n - DVec3::new(0.0, 0.0, -1.0)).length() < 1e-12);
}

#[test]
fn vpn_keys_of_mixed_lengths_behave_as_normalised() {
    let a = cameras(&load("mixed_lengths.ron"));
    let b = cameras(&load("unit_lengths.ron"));
    let worst = a
        .iter()
        .zip(&b)
        .map(|(x, y)| (x.basis.n - y.basis.n).length())
        .fold(0.0, f64::max);
    eprintln!("mixed_lengths: worst direction difference {worst:.1e}");
    assert!(worst < 1e-14);
}

#[test]
fn a_long_animation_evaluates_every_frame() {
    let d = load("long.ron");
    let mut n = 0u64;
    for item in d.cameras() {
        let (_, c) = item.unwrap();
        assert!(c.vrp_world.is_finite() && c.basis.n.is_finite());
        n += 1;
    }
    assert_eq!(n, 100_000);
}

// ---------------------------------------------------------------------------------------------
// Determinism of the catalogue's pictures.

/// The catalogue's rendered cases beyond [`PROJECTIONS`].
const ALSO_RENDERED: [&str; 3] = [
    "huge_sphere_lit.ron",
    "pole_track.ron",
    "pole_look_around.ron",
];

fn catalogue_hashes() -> String {
    let mut out = String::new();
    for name in PROJECTIONS.iter().chain(&ALSO_RENDERED) {
        let d = load(name);
        for (frame, hash) in hashes(&d, 0..d.animation().frames.min(3)).unwrap() {
            out += &format!("{name} {frame} {hash}\n");
        }
    }
    out
}

#[test]
fn catalogue_hashes_match_golden_at_one_and_two_threads() {
    let run = |threads: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(catalogue_hashes)
    };
    let one = run(1);
    assert_eq!(run(2), one);
    let path = crate::common::root().join("tests/golden/extreme.txt");
    // As campath::testing::assert_hashes, for lines that name the catalogue's file too.
    let (update, _) = Update::from_env().unwrap();
    if update == Update::Always {
        std::fs::write(&path, &one).unwrap();
    }
    let golden = std::fs::read_to_string(&path).unwrap_or_default();
    if one != golden {
        let pending = path.with_extension("txt.new");
        if update == Update::New {
            std::fs::write(&pending, &one).unwrap();
        }
        panic!(
            "catalogue frames differ from tests/golden/extreme.txt; under CAMPATH_UPDATE=new \
             (the default outside CI) the fresh lines are in {}: compare, and accept with mv; \
             CAMPATH_UPDATE=always rewrites it",
            pending.display()
        );
    }
}
