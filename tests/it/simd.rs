//! Every instruction path gives the oracle's bytes (`reference.rs`, every sphere for every ray,
//! one ray at a time): the examples and the stability catalogue (tests/data and the
//! far-from-the-origin scenes), frame by frame, at one sample per pixel and at s×s samples,
//! adaptive or not.

use std::path::Path;

use crate::common::{example, root, EXAMPLES};
use campath::camera::{Basis, Camera};
use campath::document::Document;
use campath::internals::{Renderer, SceneIndex, Simd};
use campath::raster::Raster;
use campath::scene::{Light, Scene, Sphere};
use glam::{DVec2, DVec3};

/// Frames 0, middle and last of `doc` through every path this CPU runs, each against the oracle;
/// the number of frames compared.
fn same_bytes_on_every_path(name: &str, doc: &Document) -> usize {
    let last = doc.animation().frames - 1;
    let mut compared = 0;
    for frame in [0, last / 2, last] {
        let camera = doc.camera(frame).unwrap();
        let reference = crate::reference::render(&camera, doc.scene(), *doc.raster());
        for simd in Simd::ALL {
            let Some(mut r) = Renderer::with_simd(simd) else {
                continue;
            };
            let pixels = r.render(&camera, doc.scene(), *doc.raster());
            let differ = pixels
                .chunks(3)
                .zip(reference.chunks(3))
                .filter(|(a, b)| a != b)
                .count();
            assert_eq!(
                differ,
                0,
                "{name} frame {frame}, {}: {differ} pixels differ",
                simd.name()
            );
        }
        compared += 1;
    }
    compared
}

/// The width of the examples and the catalogue against the oracle: 320 in a release build
/// (`.ci/run` runs these tests in release, natively and on aarch64); 160 in a debug build, where
/// the oracle's every-sphere-every-ray casts take most of `cargo test`'s time.
const WIDTH: u32 = if cfg!(debug_assertions) { 160 } else { 320 };

fn one_sample(doc: Document, max_width: u32) -> Document {
    let mut raster = Raster {
        samples: 1,
        adaptive: false,
        ..*doc.raster()
    };
    if raster.width > max_width {
        raster.height = (raster.height * max_width / raster.width).max(1);
        raster.width = max_width;
    }
    doc.with_raster(raster).unwrap()
}

#[test]
fn paths_this_cpu_runs_are_listed() {
    let paths: Vec<&str> = Simd::ALL
        .iter()
        .filter(|s| s.supported())
        .map(|s| s.name())
        .collect();
    eprintln!("instruction paths on this CPU: {}", paths.join(", "));
    assert!(Simd::Baseline.supported());
    assert_eq!("scalar".parse::<Simd>(), Ok(Simd::Baseline));
    assert!(Simd::fastest().supported());
}

#[test]
fn examples_give_the_same_bytes_on_every_path() {
    let mut frames = 0;
    for name in EXAMPLES {
        frames += same_bytes_on_every_path(name, &one_sample(example(name), WIDTH));
    }
    assert_eq!(frames, 3 * EXAMPLES.len());
}

#[test]
fn stability_catalogue_gives_the_same_bytes_on_every_path() {
    let mut files = 0;
    let mut entries: Vec<_> = std::fs::read_dir(root().join("tests/data"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "ron"))
        .collect();
    entries.sort();
    for path in entries {
        // Files that must fail to load or to evaluate are the error catalogue, not pictures.
        let Ok(doc) = Document::load(&path) else {
            continue;
        };
        if doc.check_path().is_err() {
            continue;
        }
        let name = path.file_stem().unwrap().to_string_lossy().into_owned();
        same_bytes_on_every_path(&name, &one_sample(doc, WIDTH));
        files += 1;
    }
    assert!(files >= 20, "only {files} catalogue files rendered");
    for offset in [0.0, 1e6, 1e8] {
        let text = crate::extreme::far_scene(offset);
        let doc = Document::from_str(Path::new("far.ron"), &text).unwrap();
        same_bytes_on_every_path(&format!("far {offset:e}"), &one_sample(doc, WIDTH));
    }
}

#[test]
fn rows_that_end_inside_a_packet_give_the_same_bytes_on_every_path() {
    // Widths that end a row inside a packet (4 columns at one sample a pixel), or after one,
    // or inside a tile, or inside a stretch of 64 columns; at s×s samples, inside a pair of
    // packets of a row.
    for width in [1, 5, 8, 9, 13, 16, 23, 260, 280, 333] {
        let doc = one_sample(example(EXAMPLES[0]), 320)
            .resized(width, 24)
            .unwrap();
        same_bytes_on_every_path(&format!("{} at width {width}", EXAMPLES[0]), &doc);
    }
}

#[test]
fn frames_that_end_inside_a_band_give_the_same_bytes_on_every_path() {
    // One sample a pixel goes in bands of 4 rows (packets of 4 × 2 pixels): heights that end a
    // frame inside a band or inside one of its packets, or after a band; widths that end a row
    // inside a packet.
    for height in [1, 2, 3, 5, 6, 7, 9, 18, 31] {
        for width in [7, 30] {
            let doc = one_sample(example(EXAMPLES[0]), 320)
                .resized(width, height)
                .unwrap();
            let what = format!("{} at {width}×{height}", EXAMPLES[0]);
            same_bytes_on_every_path(&what, &doc);
        }
    }
}

#[test]
fn several_samples_a_pixel_give_the_same_bytes_on_every_path() {
    // s×s samples go in packets of samples, pixels in groups of 4 up to 8×8, of 2 up to 11×11
    // and alone above; adaptive sampling casts a tile's corners together, then the other
    // samples of its disagreeing pixels, as many pixels a cast as fit. Widths end inside a
    // group or a tile; 7×7 and 10×10 make an odd number of packets.
    for (name, samples, width) in [
        (EXAMPLES[0], 2, 97),
        (EXAMPLES[1], 3, 45),
        (EXAMPLES[2], 4, 33),
        (EXAMPLES[3], 5, 17),
        (EXAMPLES[4], 2, 9),
        (EXAMPLES[5], 8, 14),
        (EXAMPLES[0], 7, 21),
        (EXAMPLES[1], 10, 19),
        (EXAMPLES[2], 16, 6),
    ] {
        for adaptive in [false, true] {
            let doc = one_sample(example(name), width);
            let raster = Raster {
                samples,
                adaptive,
                ..*doc.raster()
            };
            let doc = doc.with_raster(raster).unwrap();
            let how = if adaptive { ", adaptive" } else { "" };
            same_bytes_on_every_path(&format!("{name} at {samples}×{samples}{how}"), &doc);
        }
    }
}

/// `n` spheres seeded by `seed` in the box `lo`..`lo + size`, radii `r0`..`r0 + dr`, over a
/// ground sphere of radius `ground` touching y = 0.
fn field(
    seed: u64,
    n: usize,
    lo: DVec3,
    size: DVec3,
    (r0, dr): (f64, f64),
    ground: f64,
) -> Vec<Sphere> {
    let mut gen = campath::internals::SplitMix(seed);
    let mut spheres: Vec<Sphere> = (0..n)
        .map(|_| {
            let mut r = || gen.unit();
            Sphere {
                center_world: lo + DVec3::new(r() * size.x, r() * size.y, r() * size.z),
                radius: r0 + r() * dr,
                color: DVec3::new(r(), r(), r()),
            }
        })
        .collect();
    spheres.push(Sphere {
        center_world: DVec3::new(0.0, -ground, 0.0),
        radius: ground,
        color: DVec3::splat(0.6),
    });
    spheres
}

/// Every path this CPU runs renders `camera`'s frame of `scene` with the oracle's bytes.
fn every_path_gives_the_oracle_bytes(camera: &Camera, scene: &Scene, raster: Raster, what: &str) {
    let slow = crate::reference::render(camera, scene, raster);
    for simd in Simd::ALL.into_iter().filter(|s| s.supported()) {
        let fast = Renderer::with_simd(simd)
            .unwrap()
            .render(camera, scene, raster);
        let differ = fast.iter().zip(&slow).filter(|(a, b)| a != b).count();
        let name = simd.name();
        assert_eq!(differ, 0, "{what}, {name}: {differ} bytes differ");
    }
}

#[test]
/// A field of 300 spheres over a ground sphere, under two shadowing lights, seen from outside,
/// from inside (the COP off the axis) and from just above the ground: the tiles and the shadow
/// grid change no byte of the oracle's, at one sample, 2×2 and 3×3.
fn tiles_and_shadow_grid_give_the_oracle_bytes() {
    let (lo, size) = (DVec3::new(-20.0, 0.0, -20.0), DVec3::new(40.0, 6.0, 40.0));
    let spheres = field(7, 300, lo, size, (0.2, 1.5), 1000.0);
    let scene = Scene {
        background: DVec3::new(0.1, 0.1, 0.2),
        ambient: 0.1,
        lights: vec![
            Light {
                direction_world: DVec3::new(-1.0, -2.0, 1.0).normalize(),
                color: DVec3::splat(0.8),
                shadows: true,
            },
            Light {
                direction_world: DVec3::new(1.0, -0.3, 0.2).normalize(),
                color: DVec3::splat(0.3),
                shadows: true,
            },
        ],
        spheres: spheres.into(),
    };
    let raster = Raster {
        width: 96,
        height: 64,
        samples: 2,
        adaptive: false,
    };
    let cameras = [
        // Outside the field, looking in.
        (
            DVec3::new(0.0, 8.0, -40.0),
            DVec3::new(0.0, -0.2, 1.0),
            DVec3::new(0.0, 0.0, -1.0),
        ),
        // Inside the field, off-axis COP, spheres on all sides and behind.
        (
            DVec3::new(1.0, 2.0, 0.0),
            DVec3::new(1.0, -0.1, 0.3),
            DVec3::new(0.3, -0.2, -0.8),
        ),
        // Inside the ground sphere's neighbourhood, looking down.
        (
            DVec3::new(-5.0, 0.5, 3.0),
            DVec3::new(0.2, -1.0, 0.1),
            DVec3::new(0.0, 0.0, -1.5),
        ),
    ];
    // Every path but `Scalar` casts one sample, and 2×2 or 3×3 samples averaged, in packets.
    let one = Raster {
        samples: 1,
        ..raster
    };
    let three = Raster {
        samples: 3,
        ..raster
    };
    for (k, (vrp, vpn, cop)) in cameras.into_iter().enumerate() {
        let camera = Camera {
            vrp_world: vrp,
            basis: Basis::from_vpn_vuv(vpn, DVec3::Y).unwrap(),
            cop_view: cop,
            window: DVec2::new(1.5, 1.0),
        };
        for raster in [raster, one, three] {
            let what = format!("camera {k}, {raster:?}");
            every_path_gives_the_oracle_bytes(&camera, &scene, raster, &what);
        }
    }
}

/// `spheres` under one shadowing light from above, as the dense clusters have it.
fn under_one_light(spheres: Vec<Sphere>) -> Scene {
    Scene {
        background: DVec3::new(0.1, 0.1, 0.2),
        ambient: 0.1,
        lights: vec![Light {
            direction_world: DVec3::new(-0.6, -1.0, 0.4).normalize(),
            color: DVec3::splat(0.9),
            shadows: true,
        }],
        spheres: spheres.into(),
    }
}

/// A field of small spheres in frames a few rows high and a few columns wide, so that sphere
/// edges cross the packets of a band's last rows: every path, on pools of 1 and 3 threads,
/// gives the oracle's bytes whole (`render`) and through the ring of a hash-only run
/// (`render_through`: short last bands in the ring's first slots).
#[test]
fn short_frames_of_small_spheres_give_the_oracle_bytes_whole_and_through_the_ring() {
    let (lo, size) = (DVec3::new(-6.0, 0.0, -6.0), DVec3::new(12.0, 3.0, 12.0));
    let spheres = field(11, 400, lo, size, (0.05, 0.3), 1000.0);
    let scene = under_one_light(spheres);
    let camera = Camera {
        vrp_world: DVec3::new(-9.0, 4.0, -9.0),
        basis: Basis::from_vpn_vuv(DVec3::new(1.0, -0.3, 1.0), DVec3::Y).unwrap(),
        cop_view: DVec3::new(0.0, 0.0, -1.2),
        window: DVec2::new(1.5, 1.0),
    };
    let index = SceneIndex::new(&scene);
    let mut shapes = Vec::new();
    for width in [5, 67] {
        for height in [1, 2, 3, 5, 6, 7, 66, 67, 131] {
            shapes.push((width, height));
        }
    }
    for (width, height) in shapes {
        let raster = Raster {
            width,
            height,
            samples: 1,
            adaptive: false,
        };
        let slow = crate::reference::render(&camera, &scene, raster);
        let edges = slow.chunks(3).filter(|p| *p != slow[..3].as_ref()).count();
        for threads in [1, 3] {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            for simd in Simd::ALL.into_iter().filter(|s| s.supported()) {
                let at = format!("{width}×{height}, {threads} threads, {}", simd.name());
                let mut r = Renderer::with_simd(simd).unwrap();
                let (whole, ringed) = pool.install(|| {
                    let whole = r.render_indexed(&camera, &index, raster);
                    let mut seen = Vec::new();
                    let mut ring = vec![0x5a; 5];
                    r.prepare(&camera, &index, raster)
                        .render_through(&mut ring, &mut |rows: &[u8]| seen.extend_from_slice(rows));
                    (whole, seen)
                });
                assert!(whole == slow, "{at}: the frame differs from the oracle's");
                assert!(
                    ringed == slow,
                    "{at}: the ring's rows differ from the oracle's"
                );
            }
        }
        assert!(
            height < 60 || edges > 100,
            "{width}×{height}: {edges} pixels not the first's"
        );
    }
}

/// A dense cluster of 20,000 small spheres over a ground sphere, with one shadowing light: the
/// scale at which a frame prepares on the rayon pool (over 16,384 spheres in view), the shadow
/// grid widens its cells to the discs (their projections overlap many deep), and shadow rays
/// move only the blockers they test into view coordinates. Seen from outside (every sphere in
/// view, the hierarchy's subtrees wholly inside the pyramid) and from inside the cluster (most
/// culled): every path gives the oracle's bytes.
#[test]
fn a_dense_cluster_of_20000_spheres_gives_the_oracle_bytes() {
    let (lo, size) = (DVec3::new(-10.0, 0.0, -10.0), DVec3::new(20.0, 6.0, 20.0));
    let spheres = field(20_000, 20_000, lo, size, (0.05, 0.15), 10_000.0);
    let scene = under_one_light(spheres);
    let raster = Raster {
        width: 48,
        height: 32,
        samples: 1,
        adaptive: false,
    };
    let cameras = [
        (DVec3::new(-30.0, 12.0, -6.0), DVec3::new(1.0, -0.35, 0.2)),
        (DVec3::new(0.5, 3.0, 0.5), DVec3::new(0.6, -0.2, 1.0)),
    ];
    for (k, (vrp, vpn)) in cameras.into_iter().enumerate() {
        let camera = Camera {
            vrp_world: vrp,
            basis: Basis::from_vpn_vuv(vpn, DVec3::Y).unwrap(),
            cop_view: DVec3::new(0.0, 0.0, -1.2),
            window: DVec2::new(1.5, 1.0),
        };
        let index = SceneIndex::new(&scene);
        let in_view = Renderer::new().prepare(&camera, &index, raster).in_view();
        assert!(
            (k == 0) == (in_view > 19_000),
            "camera {k}: {in_view} spheres in view"
        );
        every_path_gives_the_oracle_bytes(&camera, &scene, raster, &format!("camera {k}"));
    }
}
