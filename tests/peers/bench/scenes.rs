//! The generated benchmark scenes: fly-throughs over fields of spheres and dense clusters, from
//! a fixed-seed SplitMix64 stream (the same every run), written as keyframe files.

use std::fmt::Write as _;

use campath::internals::SplitMix;

/// One benchmark scene.
#[derive(Debug, Clone, serde::Serialize)]
pub struct BenchScene {
    pub name: String,
    pub layout: Layout,
    pub width: u32,
    pub height: u32,
    pub samples: u32,
    pub spheres: usize,
    pub frames: u64,
    /// The spheres (all but the ground) in a binary PLY beside the keyframe file, instead of
    /// inline.
    pub ply: bool,
    /// That PLY in f32 with byte colours (19 bytes a sphere, not 56), as particle data usually
    /// comes; its RON twin then differs, so POV-Ray is not set against it.
    pub float: bool,
}

/// How a scene's spheres are laid out and seen.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
pub enum Layout {
    /// Resting on the ground over a field whose side grows with √N, flown through.
    Fly,
    /// A dense cluster in a 20 × 6 × 20 box, orbited from about 20 units.
    Cluster,
    /// Resting on the ground over a field whose side grows with √N, flown over looking down
    /// steeply: every frame sees a patch of the same size, whatever N.
    Patch,
    /// The cluster's density in a box whose floor grows with N (20·√(N/1000) a side, 6 high),
    /// orbited from the same distance to its nearest face.
    BigCluster,
    /// N spheres in the cluster's 20 × 6 × 20 box, radii scaled by (1000/N)^⅓, so the box
    /// holds the same volume of spheres at every N; orbited as the cluster is.
    Dense,
}

/// The scenes of the benchmark table.
pub fn scenes() -> Vec<BenchScene> {
    vec![
        BenchScene {
            name: "cluster1000".into(),
            layout: Layout::Cluster,
            width: 1920,
            height: 1080,
            samples: 1,
            spheres: 1000,
            frames: 8,
            ply: false,
            float: false,
        },
        BenchScene {
            name: "fly100".into(),
            layout: Layout::Fly,
            width: 1920,
            height: 1080,
            samples: 1,
            spheres: 100,
            frames: 48,
            ply: false,
            float: false,
        },
        BenchScene {
            name: "fly1000".into(),
            layout: Layout::Fly,
            width: 1920,
            height: 1080,
            samples: 1,
            spheres: 1000,
            frames: 48,
            ply: false,
            float: false,
        },
        BenchScene {
            name: "fly10000".into(),
            layout: Layout::Fly,
            width: 1920,
            height: 1080,
            samples: 1,
            spheres: 10_000,
            frames: 48,
            ply: false,
            float: false,
        },
        BenchScene {
            name: "small".into(),
            layout: Layout::Fly,
            width: 640,
            height: 360,
            samples: 4,
            spheres: 10,
            frames: 48,
            ply: false,
            float: false,
        },
    ]
}

/// A generated sphere.
struct Ball {
    center: [f64; 3],
    radius: f64,
    color: [f64; 3],
}

/// A layout's part of a scene file.
struct Parts {
    /// Said after the sphere count in the file's first line.
    description: &'static str,
    /// The `camera` section.
    camera: String,
    /// The `animate` list.
    animate: String,
    /// The spheres after the ground.
    spheres: Vec<Ball>,
}

/// A scene's files: the keyframe file, and its sphere file when [`BenchScene::ply`] (written
/// as `NAME.ply` beside it).
pub struct SceneFiles {
    pub ron: String,
    pub ply: Option<Vec<u8>>,
}

/// The keyframe file of a scene (and its sphere file): every layout with the same image,
/// ground, light and colours.
pub fn scene_files(s: &BenchScene) -> SceneFiles {
    let Parts {
        description: what,
        camera,
        animate,
        spheres: balls,
    } = match s.layout {
        Layout::Fly => fly(s),
        Layout::Cluster => cluster(s),
        Layout::Patch => patch(s),
        Layout::BigCluster => big_cluster(s),
        Layout::Dense => dense(s),
    };
    let (spheres, files, ply) = if s.ply {
        (
            String::new(),
            format!("\n        sphere_files: [\"{}.ply\"],", s.name),
            Some(if s.float {
                float_ply(&balls)
            } else {
                ply(&balls)
            }),
        )
    } else {
        let mut lines = String::with_capacity(balls.len() * 150);
        for b in &balls {
            let ([x, y, z], r, [cr, cg, cb]) = (b.center, b.radius, b.color);
            let _ = writeln!(
                lines,
                "(center: ({x:?}, {y:?}, {z:?}), radius: {r:?}, color: ({cr:?}, {cg:?}, {cb:?})),"
            );
        }
        (lines, String::new(), None)
    };
    let ron = format!(
        "// campath bench scene {name}: {n} spheres{what}, generated by `campath bench`.
(
    frames: {frames}, fps: 24.0,
    image: (width: {w}, height: {h}, samples: {samples}),
    camera: {camera},
    animate: {animate},
    scene: (
        background: (0.35, 0.45, 0.65), ambient: 0.15,
        lights: [(direction: (-0.6, -1.0, 0.4), color: (0.9, 0.9, 0.85))],
        spheres: [
(center: (0.0, -100000.0, 0.0), radius: 100000.0, color: (0.55, 0.55, 0.5)),
{spheres}        ],{files}
    ),
)
",
        name = s.name,
        n = s.spheres,
        frames = s.frames,
        w = s.width,
        h = s.height,
        samples = s.samples,
    );
    SceneFiles { ron, ply }
}

/// The keyframe file of a scene with its spheres inline.
pub fn scene_ron(s: &BenchScene) -> String {
    scene_files(&BenchScene {
        ply: false,
        float: false,
        ..s.clone()
    })
    .ron
}

/// Balls as a binary little-endian PLY of doubles: the same values as the RON lines.
fn ply(balls: &[Ball]) -> Vec<u8> {
    let mut out = format!(
        "ply\nformat binary_little_endian 1.0\ncomment generated by campath bench\nelement vertex {}\n\
         property double x\nproperty double y\nproperty double z\nproperty double radius\n\
         property double red\nproperty double green\nproperty double blue\nend_header\n",
        balls.len()
    )
    .into_bytes();
    out.reserve(balls.len() * 56);
    for b in balls {
        for v in b.center.iter().chain([&b.radius]).chain(&b.color) {
            out.extend(v.to_le_bytes());
        }
    }
    out
}

/// Balls as a binary little-endian PLY of floats with byte colours: the centres and radii
/// rounded to f32, the colours to the nearest of 256 levels.
fn float_ply(balls: &[Ball]) -> Vec<u8> {
    let mut out = format!(
        "ply\nformat binary_little_endian 1.0\ncomment generated by campath bench\nelement vertex {}\n\
         property float x\nproperty float y\nproperty float z\nproperty float radius\n\
         property uchar red\nproperty uchar green\nproperty uchar blue\nend_header\n",
        balls.len()
    )
    .into_bytes();
    out.reserve(balls.len() * 19);
    for b in balls {
        for v in b.center.iter().chain([&b.radius]) {
            out.extend((*v as f32).to_le_bytes());
        }
        out.extend(b.color.map(|c| (c * 255.0).round() as u8));
    }
    out
}

/// A ball with a colour drawn from `rng`.
fn ball(rng: &mut SplitMix, (x, y, z): (f64, f64, f64), r: f64) -> Ball {
    let color = [
        0.2 + 0.8 * rng.unit(),
        0.2 + 0.8 * rng.unit(),
        0.2 + 0.8 * rng.unit(),
    ];
    Ball {
        center: [x, y, z],
        radius: r,
        color,
    }
}

/// The side of a field holding `n` spheres at the fly-through's density.
fn field_side(n: usize) -> f64 {
    (n as f64).sqrt() * 6.0
}

/// `n` spheres of radius 0.3 to 1.5 resting on the ground over a square field of side
/// [`field_side`], from the stream seeded `seed + n`.
fn field_spheres(seed: u64, n: usize) -> Vec<Ball> {
    let mut rng = SplitMix(seed + n as u64);
    let side = field_side(n);
    (0..n)
        .map(|_| {
            let r = 0.3 + 1.2 * rng.unit();
            let (x, z) = ((rng.unit() - 0.5) * side, (rng.unit() - 0.5) * side);
            ball(&mut rng, (x, r, z), r)
        })
        .collect()
}

/// `n` spheres of radius `scale` × (0.2 to 0.6) in a box `side` × 6 × `side` centred over the
/// origin, from the stream seeded `seed + n`.
fn cluster_spheres(seed: u64, n: usize, side: f64, scale: f64) -> Vec<Ball> {
    let mut rng = SplitMix(seed + n as u64);
    (0..n)
        .map(|_| {
            let r = (0.2 + 0.4 * rng.unit()) * scale;
            let (x, y, z) = (
                (rng.unit() - 0.5) * side,
                r + rng.unit() * (6.0 - 2.0 * r),
                (rng.unit() - 0.5) * side,
            );
            ball(&mut rng, (x, y, z), r)
        })
        .collect()
}

/// Spheres resting on the ground over a square field whose side grows with √N (constant
/// density), and an observer + track fly-through across the field.
fn fly(s: &BenchScene) -> Parts {
    let side = field_side(s.spheres);
    let spheres = field_spheres(0xB3AC_0000, s.spheres);
    let k = |f: f64| f * side;
    let secs = (s.frames - 1) as f64 / 24.0;
    let animate = format!(
        "[
        Observer(keys: [(t: 0.0, value: ({a:?}, 3.0, {b:?})), (t: {t1:?}, value: ({c:?}, 4.0, {d:?})), (t: {t2:?}, value: ({e:?}, 2.5, {f:?}))]),
        Track(keys: [(t: 0.0, value: (0.0, 0.5, 0.0)), (t: {t2:?}, value: ({g:?}, 0.5, {i:?}))]),
    ]",
        a = k(-0.45),
        b = k(-0.45),
        t1 = secs * 0.5,
        c = k(-0.05),
        d = k(-0.15),
        t2 = secs,
        e = k(0.3),
        f = k(0.1),
        g = k(0.2),
        i = k(0.35),
    );
    let camera = "(vrp: (0.0, 3.0, 0.0), cop: (0.0, 0.0, -1.0), hfov: 70.0)";
    Parts {
        description: "",
        camera: camera.into(),
        animate,
        spheres,
    }
}

/// N spheres of radius 0.2 to 0.6 in a 20 × 6 × 20 box, and a camera orbiting a quarter turn at
/// about 20 units while looking at the cluster's centre: (description, camera, tracks, sphere
/// lines).
fn cluster(s: &BenchScene) -> Parts {
    let (camera, animate) = cluster_orbit(s);
    Parts {
        description: " in a dense cluster",
        camera,
        animate,
        spheres: cluster_spheres(0xC1_0000, s.spheres, 20.0, 1.0),
    }
}

/// The cluster's camera and its quarter-turn orbit: (camera, tracks).
fn cluster_orbit(s: &BenchScene) -> (String, String) {
    let secs = (s.frames - 1) as f64 / 24.0;
    let animate = format!(
        "[Observer(keys: [(t: 0.0, value: (-20.0, 8.0, -4.0)), (t: {t1:?}, value: (-14.0, 8.0, -14.0)), (t: {t2:?}, value: (-4.0, 8.0, -20.0))])]",
        t1 = secs * 0.5,
        t2 = secs,
    );
    ("(tp: (0.0, 3.0, 0.0), hfov: 70.0)".into(), animate)
}

/// The dense cluster at N spheres: the cluster's box and orbit, radii scaled by (1000/N)^⅓.
fn dense(s: &BenchScene) -> Parts {
    let (camera, animate) = cluster_orbit(s);
    Parts {
        description: " in a dense cluster, radii scaled by (1000/N)^(1/3)",
        camera,
        animate,
        spheres: cluster_spheres(
            0xDE_0000,
            s.spheres,
            20.0,
            libm::cbrt(1000.0 / s.spheres as f64),
        ),
    }
}

/// Fly-scene spheres over a field of side 6·√N, and a camera 8 units up looking down 45°,
/// travelling 30 units across the middle: (description, camera, tracks, sphere lines).
fn patch(s: &BenchScene) -> Parts {
    let spheres = field_spheres(0xFA7C_0000, s.spheres);
    let secs = (s.frames - 1) as f64 / 24.0;
    // The view's upper edge is 45° − 21.6° below the horizon: no frame sees beyond ~19 units.
    let animate = format!(
        "[Observer(keys: [(t: 0.0, value: (-15.0, 8.0, -8.0)), (t: {secs:?}, value: (15.0, 8.0, -8.0))]),
        Track(keys: [(t: 0.0, value: (-15.0, 0.0, 0.0)), (t: {secs:?}, value: (15.0, 0.0, 0.0))])]"
    );
    let camera = "(vrp: (-15.0, 8.0, -8.0), hfov: 70.0)";
    Parts {
        description: " over a field, seen from above",
        camera: camera.into(),
        animate,
        spheres,
    }
}

/// N spheres at the cluster's density (1000 per 20 × 6 × 20) in a box 20·√(N/1000) a side,
/// orbited as the cluster is, from the same distance to the box's nearest corner.
fn big_cluster(s: &BenchScene) -> Parts {
    let side = 20.0 * (s.spheres as f64 / 1000.0).sqrt();
    let spheres = cluster_spheres(0xB1C1_0000, s.spheres, side, 1.0);
    let secs = (s.frames - 1) as f64 / 24.0;
    let h = side * 0.5;
    let animate = format!(
        "[Observer(keys: [(t: 0.0, value: ({a:?}, 8.0, {b:?})), (t: {t1:?}, value: ({c:?}, 8.0, {c:?})), (t: {secs:?}, value: ({b:?}, 8.0, {a:?}))])]",
        a = -h - 10.0,
        b = -h + 6.0,
        c = -h - 7.0,
        t1 = secs * 0.5,
    );
    let camera = format!("(tp: ({:?}, 3.0, {:?}), hfov: 70.0)", -h + 10.0, -h + 10.0);
    Parts {
        description: " in a dense cluster",
        camera,
        animate,
        spheres,
    }
}

/// The scaling scenes: sphere counts 100 … 1,000,000 at 1920×1080 for the sparse field seen
/// from above and the growing dense cluster, then 1280×720 and 3840×2160 at 1000 spheres; and
/// the dense cluster at 1,000, 100,000 and 1,000,000 spheres (the last two also from binary PLY).
pub fn scaling_scenes() -> Vec<BenchScene> {
    let scene = |layout: Layout, spheres: usize, (width, height): (u32, u32)| {
        let kind = if layout == Layout::Patch {
            "patch"
        } else {
            "bigcluster"
        };
        BenchScene {
            name: format!("{kind}{spheres}-{height}p"),
            layout,
            width,
            height,
            samples: 1,
            spheres,
            frames: 8,
            ply: false,
            float: false,
        }
    };
    let mut out = Vec::new();
    for layout in [Layout::Patch, Layout::BigCluster] {
        for n in [100, 1_000, 10_000, 100_000, 1_000_000] {
            out.push(scene(layout, n, (1920, 1080)));
        }
        for size in [(1280, 720), (3840, 2160)] {
            out.push(scene(layout, 1000, size));
        }
    }
    // The dense cluster against POV-Ray: 4 frames at 1080p, 100,000 and the million also from
    // binary PLY.
    for (n, ply) in [
        (1_000, false),
        (100_000, false),
        (100_000, true),
        (1_000_000, false),
        (1_000_000, true),
    ] {
        out.push(BenchScene {
            name: format!("dense{n}{}", if ply { "-ply" } else { "" }),
            layout: Layout::Dense,
            width: 1920,
            height: 1080,
            samples: 1,
            spheres: n,
            frames: 4,
            ply,
            float: false,
        });
    }
    // Past a million, from binary PLY only (a RON file of ten million spheres is 700 MB), at
    // 1080p and at the studio's 640×360, 8 frames; and the PLY million at 640×360. POV-Ray is
    // not run on these (`twin_pov` finds no RON twin).
    for (n, (width, height)) in [
        (1_000_000, (640, 360)),
        (10_000_000, (1920, 1080)),
        (10_000_000, (640, 360)),
    ] {
        let size = if height == 1080 {
            String::new()
        } else {
            format!("-{height}p")
        };
        out.push(BenchScene {
            name: format!("dense{n}-ply{size}"),
            layout: Layout::Dense,
            width,
            height,
            samples: 1,
            spheres: n,
            frames: 8,
            ply: true,
            float: true,
        });
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use campath::document::Document;

    /// A scene's spheres from its binary PLY are the spheres of its inline RON, bit for bit.
    #[test]
    fn the_ply_scene_is_the_ron_scene() {
        let tmp = tempfile::tempdir().unwrap();
        let mut s = scaling_scenes()
            .into_iter()
            .find(|s| s.name == "dense1000000-ply")
            .unwrap();
        s.spheres = 300;
        let files = scene_files(&s);
        std::fs::write(
            tmp.path().join(format!("{}.ply", s.name)),
            files.ply.unwrap(),
        )
        .unwrap();
        let from_ply = Document::from_str(&tmp.path().join("a.ron"), &files.ron).unwrap();
        let inline = Document::from_str(&tmp.path().join("b.ron"), &scene_ron(&s)).unwrap();
        assert_eq!(from_ply.scene(), inline.scene());
        assert_eq!(from_ply.scene().spheres.len(), 301);
    }
}
