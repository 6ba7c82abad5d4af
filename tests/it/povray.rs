//! Cross-check of the projection against an independent renderer, POV-Ray 3.7.
//!
//! Each random camera (off-axis COPs included) is given to POV-Ray by
//! `campath::export::povray` as explicit vectors: `location` = the COP in world, `direction` =
//! VRP − COP, `right` = w·u, `up` = h·v. Spheres are flat (`ambient 1 diffuse 0`) in colours
//! whose channels are 0 or 1, so every pixel names the sphere it sees, whatever the transfer
//! function. The two renders must agree on the sphere at
//! ≥ 99.9% of pixels. `.ci/run` installs povray.

use std::path::Path;
use std::process::Command;

use campath::document::Document;
use campath::export::povray::Finish;
use campath::internals::Renderer;
use glam::DVec3;

const COLORS: [(f64, f64, f64); 7] = [
    (1.0, 0.0, 0.0),
    (0.0, 1.0, 0.0),
    (0.0, 0.0, 1.0),
    (1.0, 1.0, 0.0),
    (1.0, 0.0, 1.0),
    (0.0, 1.0, 1.0),
    (1.0, 1.0, 1.0),
];

/// Fixed-seed cameras: the same on every run.
struct Rng(campath::internals::SplitMix);

impl Rng {
    fn next(&mut self) -> f64 {
        self.0.unit()
    }
    fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.next()
    }
    fn vec(&mut self, lo: f64, hi: f64) -> DVec3 {
        DVec3::new(self.range(lo, hi), self.range(lo, hi), self.range(lo, hi))
    }
}

fn t3(v: DVec3) -> String {
    format!("({:?}, {:?}, {:?})", v.x, v.y, v.z)
}

/// Index of the colour a pixel shows: 0 background, 1.. the spheres.
fn class(px: &[u8]) -> usize {
    let bits = |c: u8| if c >= 128 { 1.0 } else { 0.0 };
    let rgb = (bits(px[0]), bits(px[1]), bits(px[2]));
    COLORS.iter().position(|c| *c == rgb).map_or(0, |i| i + 1)
}

fn povray(dir: &Path, scene: &str, w: u32, h: u32) -> Vec<u8> {
    let pov = dir.join("scene.pov");
    let png = dir.join("scene.png");
    std::fs::write(&pov, scene).unwrap();
    let out = Command::new("povray")
        .current_dir(dir)
        .arg(format!("+I{}", pov.display()))
        .arg(format!("+O{}", png.display()))
        .args([
            &format!("+W{w}"),
            &format!("+H{h}"),
            "-A",
            "+FN",
            "-D",
            "-V",
            "File_Gamma=1.0",
        ])
        .output()
        .expect("povray must be installed (Debian package povray; .ci/run installs it)");
    assert!(
        out.status.success(),
        "povray failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    image::open(&png).unwrap().to_rgb8().into_raw()
}

#[test]
#[ignore = "needs povray"]
fn projection_matches_povray_on_random_cameras() {
    crate::common::need_tool("povray", "povray");
    let tmp = tempfile::tempdir().unwrap();
    let mut rng = Rng(campath::internals::SplitMix(0x00C0_FFEE));
    let (w, h) = (160u32, 120u32);
    let (mut same, mut total) = (0usize, 0usize);
    for case in 0..24 {
        let spheres: Vec<(DVec3, f64)> = (0..COLORS.len())
            .map(|_| (rng.vec(-3.0, 3.0), rng.range(0.3, 1.4)))
            .collect();
        // A camera outside every sphere, looking roughly at the cluster.
        let vrp = loop {
            let dir = rng.vec(-1.0, 1.0);
            if dir.length() < 0.2 {
                continue;
            }
            let p = dir.normalize() * rng.range(7.0, 12.0);
            if spheres.iter().all(|(c, r)| (p - *c).length() > r + 4.0) {
                break p;
            }
        };
        let vpn = -vrp + rng.vec(-1.0, 1.0);
        let vuv = DVec3::Y + rng.vec(-0.5, 0.5);
        let win_w = rng.range(0.8, 2.0);
        let win = (win_w, win_w * h as f64 / w as f64);
        let d = rng.range(0.7, 3.0);
        // Off-axis for most cases: |u|, |v| up to the window's half size.
        let off = if case % 4 == 0 {
            (0.0, 0.0)
        } else {
            (rng.range(-0.5, 0.5) * win.0, rng.range(-0.5, 0.5) * win.1)
        };
        let cop = DVec3::new(off.0, off.1, -d);
        let sphere_ron: Vec<String> = spheres
            .iter()
            .zip(COLORS)
            .map(|((c, r), col)| format!("(center: {}, radius: {r:?}, color: {col:?})", t3(*c)))
            .collect();
        let ron = format!(
            "(image: (width: {w}, height: {h}), camera: (vrp: {}, vpn: {}, vuv: {}, cop: {}, window: ({:?}, {:?})), scene: (ambient: 1.0, spheres: [{}]))",
            t3(vrp),
            t3(vpn),
            t3(vuv),
            t3(cop),
            win.0,
            win.1,
            sphere_ron.join(", ")
        );
        let doc = Document::from_str(Path::new("random.ron"), &ron).unwrap();
        let cam = doc.cameras().next().unwrap().unwrap().1;
        let ours = Renderer::new().render(&cam, doc.scene(), *doc.raster());

        let pov = campath::export::povray::scene(&doc, Finish::Flat).unwrap();
        let theirs = povray(tmp.path(), &pov, w, h);
        let agree = ours
            .chunks(3)
            .zip(theirs.chunks(3))
            .filter(|(a, b)| class(a) == class(b))
            .count();
        let n = (w * h) as usize;
        let covered = ours.chunks(3).filter(|p| class(p) != 0).count();
        assert!(
            covered > n / 100,
            "case {case}: the spheres cover only {covered} pixels; the test would be vacuous"
        );
        assert!(
            agree as f64 >= 0.999 * n as f64,
            "case {case}: {agree}/{n} pixels agree"
        );
        same += agree;
        total += n;
    }
    eprintln!(
        "POV-Ray agreement: {same}/{total} = {:.5}",
        same as f64 / total as f64
    );
}
