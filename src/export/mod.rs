//! The evaluated camera path for other tools: CSV, JSON, and the `.chan` camera-channel text
//! that Nuke and Blender import; the whole shot as glTF, a Blender script or an OpenUSD stage.

pub mod blender;
mod gaps;
pub mod gltf;
pub mod povray;
pub mod usd;

use std::io::Write;

use glam::{DQuat, DVec3};

use crate::camera::{Basis, Camera};
use crate::document::Document;
use crate::error::{Error, Result};
use crate::scene::Spheres;

/// From this many spheres on, the USD and glTF exports write the spheres as instances of one
/// sphere (a `PointInstancer`; one node with `EXT_mesh_gpu_instancing`) instead of a prim or a
/// node each. Below it every reader takes the file as it always has, one that knows neither
/// the `PointInstancer` nor the extension (which the file then requires) included, and a prim
/// or a node a sphere costs little (about 400 bytes); at 200,000 spheres it cost 76 MB of USD
/// and 69 MB of glTF. The Blender script instances at any count.
pub const INSTANCED_FROM: usize = 1000;

/// What the camera is exported as (`campath path --format`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[non_exhaustive]
pub enum PathFormat {
    /// frame, t, VRP, u, v, n, COP in world (`cop_world_*`), window (one row per frame, after a
    /// header line).
    #[default]
    Csv,
    /// An array of per-frame objects with the same fields.
    Json,
    /// `frame tx ty tz rx ry rz vfov`: position of the COP, rotation in degrees (ZXY order),
    /// vertical field of view in degrees. For Nuke and Blender.
    Chan,
    /// The whole shot as glTF 2.0: the animated camera, the spheres and the lights (binary GLB
    /// when asked for).
    Gltf,
    /// A Python script for Blender that builds the whole shot: camera (with lens shift for an
    /// off-axis COP), render size and rate, spheres and lights.
    Blender,
    /// The whole shot as an OpenUSD stage (USDA text): the camera with lens shift for an
    /// off-axis COP, the spheres and the lights.
    Usd,
}

impl PathFormat {
    /// Every format, in the order `--help` lists them.
    pub const ALL: [PathFormat; 6] = [
        PathFormat::Csv,
        PathFormat::Json,
        PathFormat::Chan,
        PathFormat::Gltf,
        PathFormat::Blender,
        PathFormat::Usd,
    ];

    /// The format's name on the command line: `csv`, `json`, `chan`, `gltf`, `blender`, `usd`.
    pub fn name(self) -> &'static str {
        self.names().0
    }

    /// What the format is called in messages.
    pub fn title(self) -> &'static str {
        self.names().1
    }

    /// The format's name on the command line and what it is called in messages.
    fn names(self) -> (&'static str, &'static str) {
        match self {
            PathFormat::Csv => ("csv", "CSV"),
            PathFormat::Json => ("json", "JSON"),
            PathFormat::Chan => ("chan", ".chan"),
            PathFormat::Gltf => ("gltf", "glTF"),
            PathFormat::Blender => ("blender", "Blender Python"),
            PathFormat::Usd => ("usd", "USD"),
        }
    }

    /// The extensions of the format's files, for messages: `.gltf or .glb` for glTF.
    pub fn extensions(self) -> &'static str {
        match self {
            PathFormat::Csv => ".csv",
            PathFormat::Json => ".json",
            PathFormat::Chan => ".chan",
            PathFormat::Gltf => ".gltf or .glb",
            PathFormat::Blender => ".py",
            PathFormat::Usd => ".usda or .usd",
        }
    }

    /// The format a file name's extension says, if it says one (`.glb` is glTF).
    pub fn of_extension(path: &std::path::Path) -> Option<PathFormat> {
        let ext = path.extension()?.to_str()?.to_ascii_lowercase();
        Some(match ext.as_str() {
            "csv" => PathFormat::Csv,
            "json" => PathFormat::Json,
            "chan" => PathFormat::Chan,
            "gltf" | "glb" => PathFormat::Gltf,
            "py" => PathFormat::Blender,
            "usda" | "usd" => PathFormat::Usd,
            _ => return None,
        })
    }
}

impl std::str::FromStr for PathFormat {
    type Err = String;

    fn from_str(s: &str) -> std::result::Result<PathFormat, String> {
        PathFormat::ALL
            .into_iter()
            .find(|f| f.name() == s)
            .ok_or_else(|| format!("{s:?} is not a format"))
    }
}

/// Euler angles in degrees (rx, ry, rz) of a camera looking down its local −Z with +Y up, for
/// the ZXY rotation order of Nuke and Blender's importer: R = Ry·Rx·Rz, with R's columns the
/// camera's right (u), up (v) and back (−n) axes in world coordinates.
pub fn chan_rotation(b: &Basis) -> DVec3 {
    let back = -b.n;
    // R[row][col]: column 0 = u, 1 = v, 2 = back.
    let r = |row: usize, col: usize| [b.u, b.v, back][col][row];
    let rx = libm::asin((-r(1, 2)).clamp(-1.0, 1.0));
    let (ry, rz) = if r(1, 2).abs() < 1.0 - 1e-12 {
        (libm::atan2(r(0, 2), r(2, 2)), libm::atan2(r(1, 0), r(1, 1)))
    } else {
        // Looking straight up or down: only ry + rz (or ry − rz) is defined; put it all in ry.
        (libm::atan2(-r(2, 0), r(0, 0)), 0.0)
    };
    DVec3::new(rx, ry, rz) * (180.0 / std::f64::consts::PI)
}

/// Makes consecutive frames' `.chan` angles continuous: of the equivalent Euler triples of a
/// rotation (each angle ± 360°, and (180° − rx, ry + 180°, rz + 180°)), it picks the one nearest
/// the previous frame's, and at the pole, where only ry ∓ rz is defined, it keeps the previous
/// rz. Nuke and Blender interpolate between keys, so a jump of 360° would spin the camera.
#[derive(Debug, Clone, Default)]
pub struct ChanAngles {
    previous: Option<DVec3>,
}

impl ChanAngles {
    /// The angles in degrees of the next frame's basis.
    pub fn next(&mut self, b: &Basis) -> DVec3 {
        let mut r = chan_rotation(b);
        let Some(p) = self.previous else {
            self.previous = Some(r);
            return r;
        };
        if b.n.y.abs() >= 1.0 - 1e-12 {
            // Looking straight up (rx = 90°: only ry − rz is defined) or down (ry + rz).
            r.z = p.z;
            r.y += if r.x > 0.0 { p.z } else { -p.z };
        }
        let near = |a: f64, p: f64| p + (a - p - 360.0 * libm::round((a - p) / 360.0));
        let unwrap = |c: DVec3| DVec3::new(near(c.x, p.x), near(c.y, p.y), near(c.z, p.z));
        let a = unwrap(r);
        let b = unwrap(DVec3::new(180.0 - r.x, r.y + 180.0, r.z + 180.0));
        let step = |c: DVec3| (c - p).abs().max_element();
        let best = if step(b) < step(a) { b } else { a };
        self.previous = Some(best);
        best
    }
}

/// Vertical field of view in radians seen from the COP: the window's height at the COP's
/// distance. Off-axis COPs (distort) have no place in `.chan` or glTF; their v offset is ignored.
fn yfov(cam: &Camera) -> f64 {
    2.0 * libm::atan(cam.window.y * 0.5 / -cam.cop_view.z)
}

/// The clipping range (near, far) of a reader's camera that takes the places of `cams`:
/// campath clips nothing in front of the COP, so neither may the reader. Far reaches past every
/// sphere from every COP (through a sphere about the whole scene), with half as much again.
/// Near is a depth along the view direction, as readers measure it: half the least depth a
/// sphere can show at, at most far / 10⁶ (a scene without spheres) and at least far / 10¹² (a
/// COP on a surface). A sphere's surface lies at least its gap g from the COP (from outside or
/// inside it), and a point seen at most α off the view direction (α at the window's furthest
/// corner) lies at a depth of at least g · cos α. Readers keep both in f32: far is at most
/// f32's largest value.
pub(crate) fn clipping_range(spheres: &Spheres, cams: &[Camera]) -> (f64, f64) {
    use rayon::prelude::*;
    let (lo, hi) = spheres.iter().fold(
        (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
        |(lo, hi), s| (lo.min(s.center_world), hi.max(s.center_world)),
    );
    let centre = if spheres.is_empty() {
        DVec3::ZERO
    } else {
        (lo + hi) * 0.5
    };
    let radius = spheres
        .iter()
        .map(|s| (s.center_world - centre).length() + s.radius)
        .fold(0.0, f64::max);
    // Each camera's COP, and the cosine of its widest angle off the view direction.
    let views: Vec<(DVec3, f64)> = cams
        .iter()
        .map(|cam| (cam.cop_world(), widest_cos(cam)))
        .collect();
    let far = views
        .iter()
        .map(|(cop, _)| (*cop - centre).length() + radius)
        .fold(1.0, f64::max)
        * 1.5;
    // The least depth, on the pool: each camera's least gap, through a tree of the spheres
    // (the minimum over every camera and sphere; a minimum is the same in any order, and a
    // product with cos ≥ 0 keeps the order of the gaps).
    let gaps = gaps::Gaps::new(spheres);
    let depth = views
        .par_iter()
        .with_min_len(64)
        .map(|(cop, cos)| gaps.least(*cop) * cos)
        .reduce(|| f64::INFINITY, f64::min);
    // Readers keep both in f32: a scene beyond its range is clipped at its largest value.
    let far = far.min(f64::from(f32::MAX));
    ((depth * 0.5).min(far * 1e-6).max(far * 1e-12), far)
}

/// The times at which a reader's camera is keyed, in frames, with campath's camera there: every
/// frame, and with motion blur also where the first frame's shutter opens (−S/2) and where the
/// last frame's closes (N − 1 + S/2), so that a reader blurring those frames does not hold the
/// camera still over their outer halves (a one-frame shot included). The up vector continues
/// outwards from the frame's camera, as in an exposure. An end where the camera is undefined
/// is left out.
pub(crate) fn keyed_cameras(doc: &Document) -> Result<Vec<(f64, Camera)>> {
    let mut keys: Vec<(f64, Camera)> = (doc.cameras())
        .map(|item| item.map(|(frame, cam)| (frame as f64, cam)))
        .collect::<Result<_>>()?;
    let Some(blur) = doc.motion_blur else {
        return Ok(keys);
    };
    let half = blur.shutter / 2.0;
    let fps = doc.animation.fps;
    let end = |(frame, cam): (f64, Camera), at: f64| {
        let up = doc.animation.up_before_roll(&cam, frame / fps);
        let camera = doc.animation.camera_at(at / fps, Some(up)).ok()?;
        Some((at, camera))
    };
    let (first, last) = (keys[0], keys[keys.len() - 1]);
    if let Some(open) = end(first, first.0 - half) {
        keys.insert(0, open);
    }
    if let Some(close) = end(last, last.0 + half) {
        keys.push(close);
    }
    Ok(keys)
}

/// One frame of `--format json`: the CSV's fields, vectors as arrays; `campath import` reads
/// it back (and an earlier campath's `cop`, which was the COP in world too).
#[derive(serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct JsonFrame {
    pub frame: u64,
    pub t: f64,
    pub vrp: [f64; 3],
    pub u: [f64; 3],
    pub v: [f64; 3],
    pub n: [f64; 3],
    #[serde(alias = "cop")]
    pub cop_world: [f64; 3],
    pub window: [f64; 2],
}

/// The CSV's header: campath frame k is `frame` k + N (`--first-frame N`) and `t` its time
/// k / fps; every place and direction is in world coordinates, and the COP's columns say so
/// because the keyframe file's `cop` is in view coordinates.
pub(crate) const CSV_HEADER: &str =
    "frame,t,vrp_x,vrp_y,vrp_z,u_x,u_y,u_z,v_x,v_y,v_z,n_x,n_y,n_z,\
                              cop_world_x,cop_world_y,cop_world_z,window_w,window_h";

/// The most `--first-frame` takes: campath's own most frames, so that a frame's number stays
/// below 2·10⁷, exact in every format that keeps it in f64 (USD) or as an integer (CSV, JSON,
/// `.chan`). Blender keeps frames to [`BLENDER_LAST_FRAME`].
pub const MAX_FIRST_FRAME: u64 = crate::document::MAX_FRAMES;

/// The last frame a Blender scene can have (its `MAXFRAME`): a script whose last frame lies past
/// it is refused, as Blender would cut the scene short.
pub const BLENDER_LAST_FRAME: u64 = 1_048_574;

/// Frames whose camera a format could not carry whole.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Dropped {
    /// Frames with an off-axis COP (distort) written as if the COP were on the VPN (`.chan` and
    /// glTF have no place for it).
    pub off_axis: u64,
    /// The first and last such frame (numbered from 0, as in campath).
    pub first: u64,
    /// The last such frame.
    pub last: u64,
}

/// `cam` with its places relative to `origin` (`campath path --origin`): the VRP, and so the
/// COP, less `origin` (the same camera when `origin` is zero).
pub(crate) fn relative(mut cam: Camera, origin: DVec3) -> Camera {
    cam.vrp_world -= origin;
    cam
}

/// Each camera's [`gltf::camera_rotation`], of q and −q (the same rotation) the one nearest the
/// one before, so that a reader's interpolation between samples turns the short way.
pub(crate) fn rotations(cams: &[Camera]) -> Vec<DQuat> {
    let mut out: Vec<DQuat> = Vec::with_capacity(cams.len());
    for cam in cams {
        let q = gltf::camera_rotation(cam);
        out.push(match out.last() {
            Some(p) if p.dot(q) < 0.0 => -q,
            _ => q,
        });
    }
    out
}

/// A rotation taking −Z to the unit vector `d`.
pub(crate) fn aim_negative_z(d: DVec3) -> DQuat {
    DQuat::from_rotation_arc(DVec3::NEG_Z, d.normalize())
}

/// `x` with −0 made +0 (−0 + 0 = +0; every other value unchanged): every number an export
/// writes as text passes through it, so none prints `-0`, which a reader comparing text or
/// signs would take for a value apart from 0. A value rounded to f32 passes after the
/// rounding, which can make −0 of a tiny negative number.
pub(crate) fn unsigned_zero<T: std::ops::Add<Output = T> + From<f32>>(x: T) -> T {
    x + T::from(0.0)
}

/// [`unsigned_zero`] of each coordinate.
pub(crate) fn unsigned_zeros(v: DVec3) -> DVec3 {
    DVec3::from(v.to_array().map(unsigned_zero))
}

/// `(x, y, z)`, each as Rust's `{:?}` writes it (USDA's `double3`, a Python tuple).
pub(crate) fn triple(v: DVec3) -> String {
    let v = unsigned_zeros(v);
    format!("({:?}, {:?}, {:?})", v.x, v.y, v.z)
}

/// `(w, x, y, z)`, the real part first, as USD and Blender write a quaternion.
pub(crate) fn quat_wxyz(q: DQuat) -> String {
    let [x, y, z, w] = q.to_array().map(unsigned_zero);
    format!("({w:?}, {x:?}, {y:?}, {z:?})")
}

/// Whether `cam`'s COP is off the VPN (distort), which `.chan` and glTF cannot carry.
fn off_axis(cam: &Camera) -> bool {
    cam.cop_view.x != 0.0 || cam.cop_view.y != 0.0
}

/// How far keeping places in f32 (glTF, Blender) moves the camera's picture: see [`f32_shift`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct F32Shift {
    /// The most, in pixels.
    pub px: f64,
    /// The frame where it is the most (with motion blur, a shutter's end may be a fraction
    /// before the first frame or after the last).
    pub frame: f64,
    /// How far f32 moves the COP there, in world units.
    pub units: f64,
    /// The middle of the COPs' bounds, each coordinate rounded to a whole number: an origin
    /// that keeps the camera near zero.
    pub middle: DVec3,
}

/// The most that keeping the camera's place in f32 (glTF, Blender) moves its picture, in
/// pixels: over the frames, the distance from the COP (relative to `origin`) to its nearest
/// f32, seen from the nearest depth a sphere can show at (each camera's least gap times the
/// cosine of its widest angle, as `clipping_range` finds it), at every time a reader keys
/// (`keyed_cameras`: with motion blur also the shutter's ends). An estimate: the spheres'
/// own places are rounded too, and a reader's f32 arithmetic adds to it. None without
/// spheres.
pub fn f32_shift(doc: &Document, origin: DVec3) -> Result<Option<F32Shift>> {
    if doc.scene.spheres.is_empty() {
        return Ok(None);
    }
    let gaps = gaps::Gaps::new(&doc.scene.spheres);
    let mut worst = F32Shift {
        px: 0.0,
        frame: 0.0,
        units: 0.0,
        middle: DVec3::ZERO,
    };
    let (mut lo, mut hi) = (DVec3::INFINITY, DVec3::NEG_INFINITY);
    for (frame, cam) in keyed_cameras(doc)? {
        (lo, hi) = (lo.min(cam.cop_world()), hi.max(cam.cop_world()));
        let cop = relative(cam, origin).cop_world();
        let kept = DVec3::from(cop.to_array().map(|x| f64::from(x as f32)));
        let depth = gaps.least(cam.cop_world()) * widest_cos(&cam);
        // A point at depth z moves by e·d/z on the view plane, d the COP's distance to it.
        let d = -cam.cop_view.z;
        let units = (kept - cop).length();
        let px = units * d / depth / cam.window.x * doc.raster.width as f64;
        // A COP on a sphere's surface (depth 0) sees any move as infinite: no measure there.
        if px.is_finite() && px > worst.px {
            (worst.px, worst.frame, worst.units) = (px, frame, units);
        }
    }
    // + 0: never −0 in the origin named.
    worst.middle = ((lo + hi) * 0.5).round() + DVec3::ZERO;
    Ok(Some(worst))
}

/// The first place written relative to `origin` that f32 cannot hold (past ±3.4·10³⁸): a
/// frame's camera or a sphere, named as the file names it. Checked before a format that keeps
/// f32 (or is read so) writes anything.
pub fn past_f32(doc: &Document, origin: DVec3) -> Option<String> {
    past_f32_in(doc, PathFormat::Gltf, origin)
}

/// [`past_f32`] for the places `format` keeps in f32: glTF and Blender every place, USD the
/// instanced spheres' (a `PointInstancer`'s positions are f32; the camera and `Sphere` prims
/// are f64), the others none.
pub fn past_f32_in(doc: &Document, format: PathFormat, origin: DVec3) -> Option<String> {
    let past = |p: DVec3| p.abs().max_element() > f64::from(f32::MAX);
    let (cameras, spheres) = match format {
        PathFormat::Gltf | PathFormat::Blender => (true, true),
        PathFormat::Usd => (false, doc.scene.spheres.len() >= INSTANCED_FROM),
        _ => (false, false),
    };
    if cameras {
        for (frame, cam) in doc.cameras().flatten() {
            if past(relative(cam, origin).cop_world()) {
                return Some(format!("frame {frame}'s COP"));
            }
        }
    }
    if !spheres {
        return None;
    }
    doc.scene
        .spheres
        .iter()
        .position(|s| past(s.center_world - origin))
        .map(|i| format!("the centre of {}", doc.sphere_place(i)))
}

/// The cosine of the widest angle off the view direction at which `cam` sees: at the window's
/// furthest corner from the COP's foot.
fn widest_cos(cam: &Camera) -> f64 {
    let (c, half) = (cam.cop_view, cam.window * 0.5);
    let corner = glam::DVec2::new(
        (half.x - c.x).abs().max((half.x + c.x).abs()),
        (half.y - c.y).abs().max((half.y + c.y).abs()),
    );
    let d = -c.z;
    d / (d * d + corner.length_squared()).sqrt()
}

/// Writes the shot in `format` (glTF as binary GLB when `glb`), campath frame k numbered
/// k + `first_frame` in every format (`campath path --first-frame`); says which frames lost
/// part of their camera on the way. The per-frame formats stream a frame at a time.
pub fn write_path(
    doc: &Document,
    format: PathFormat,
    glb: bool,
    origin: DVec3,
    first_frame: u64,
    out: &mut dyn Write,
) -> Result<Dropped> {
    let whole = |bytes: &[u8], off_axis: u64, out: &mut dyn Write| {
        out.write_all(bytes).map_err(Error::stdout)?;
        out.flush().map_err(Error::stdout)?;
        Ok(Dropped {
            off_axis,
            ..Dropped::default()
        })
    };
    match format {
        PathFormat::Csv | PathFormat::Json | PathFormat::Chan => {}
        PathFormat::Gltf => {
            let off_axis = gltf::write(doc, origin, first_frame, glb, out)?;
            return whole(&[], off_axis, out);
        }
        PathFormat::Blender => {
            let script = blender::script(doc, origin, first_frame)?;
            return whole(script.as_bytes(), 0, out);
        }
        PathFormat::Usd => return whole(usd::usda(doc, origin, first_frame)?.as_bytes(), 0, out),
    }
    let mut out = std::io::BufWriter::new(out);
    let mut dropped = Dropped::default();
    let mut angles = ChanAngles::default();
    let frames = doc.animation.frames;
    // JSON stays an array of frames (each its `frame` number), and `.chan` has no header: a
    // line Nuke's reader might not skip.
    let header = match format {
        PathFormat::Csv => format!("{CSV_HEADER}\n"),
        PathFormat::Json => "[\n".to_string(),
        _ => String::new(),
    };
    out.write_all(header.as_bytes()).map_err(Error::stdout)?;
    for item in doc.cameras() {
        let (frame, cam) = item?;
        let cam = relative(cam, origin);
        let t = doc.animation.time(frame);
        let number = frame + first_frame;
        let line = match format {
            PathFormat::Csv => csv_row(number, t, &cam),
            PathFormat::Json => {
                let comma = if frame + 1 < frames { "," } else { "" };
                format!("  {}{comma}", json_row(number, t, &cam))
            }
            _ => {
                if off_axis(&cam) {
                    if dropped.off_axis == 0 {
                        dropped.first = frame;
                    }
                    dropped.off_axis += 1;
                    dropped.last = frame;
                }
                chan_row(number, &cam, angles.next(&cam.basis))
            }
        };
        writeln!(out, "{line}").map_err(Error::stdout)?;
    }
    if format == PathFormat::Json {
        writeln!(out, "]").map_err(Error::stdout)?;
    }
    out.flush().map_err(Error::stdout)?;
    Ok(dropped)
}

/// `number` (the frame's number in the file), t, VRP, u, v, n, the COP in world coordinates,
/// the window.
fn csv_row(number: u64, t: f64, cam: &Camera) -> String {
    let (b, cop, vrp) = (cam.basis, cam.cop_world(), cam.vrp_world);
    let mut line = format!("{number},{}", unsigned_zero(t));
    for v in [vrp, b.u, b.v, b.n, cop].map(unsigned_zeros) {
        line += &format!(",{},{},{}", v.x, v.y, v.z);
    }
    let w = cam.window.to_array().map(unsigned_zero);
    line + &format!(",{},{}", w[0], w[1])
}

/// The CSV's fields as one JSON object.
fn json_row(number: u64, t: f64, cam: &Camera) -> String {
    let world = |v: DVec3| unsigned_zeros(v).to_array();
    let row = JsonFrame {
        frame: number,
        t: unsigned_zero(t),
        vrp: world(cam.vrp_world),
        u: world(cam.basis.u),
        v: world(cam.basis.v),
        n: world(cam.basis.n),
        cop_world: world(cam.cop_world()),
        window: cam.window.to_array().map(unsigned_zero),
    };
    serde_json::to_string(&row).expect("finite numbers serialise")
}

/// `number tx ty tz rx ry rz vfov`, `number` the frame's number in the file.
fn chan_row(number: u64, cam: &Camera, r: DVec3) -> String {
    let (cop, fov) = (cam.cop_world(), yfov(cam).to_degrees());
    let fields = [cop.x, cop.y, cop.z, r.x, r.y, r.z, fov].map(|x| unsigned_zero(x).to_string());
    format!("{number}\t{}", fields.join("\t"))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// R = Ry·Rx·Rz composed from the angles by matrix products written out here.
    fn compose(deg: DVec3) -> [[f64; 3]; 3] {
        let (x, y, z) = (deg.x.to_radians(), deg.y.to_radians(), deg.z.to_radians());
        let rx = [
            [1.0, 0.0, 0.0],
            [0.0, x.cos(), -x.sin()],
            [0.0, x.sin(), x.cos()],
        ];
        let ry = [
            [y.cos(), 0.0, y.sin()],
            [0.0, 1.0, 0.0],
            [-y.sin(), 0.0, y.cos()],
        ];
        let rz = [
            [z.cos(), -z.sin(), 0.0],
            [z.sin(), z.cos(), 0.0],
            [0.0, 0.0, 1.0],
        ];
        let mul = |a: [[f64; 3]; 3], b: [[f64; 3]; 3]| {
            let mut m = [[0.0; 3]; 3];
            for (i, row) in m.iter_mut().enumerate() {
                for (j, v) in row.iter_mut().enumerate() {
                    *v = (0..3).map(|k| a[i][k] * b[k][j]).sum();
                }
            }
            m
        };
        mul(ry, mul(rx, rz))
    }

    #[test]
    fn chan_angles_rebuild_the_camera_axes() {
        for (vpn, vuv) in [
            (DVec3::new(0.3, -0.2, 1.0), DVec3::Y),
            (DVec3::new(-1.0, 0.5, -0.3), DVec3::Y),
            (DVec3::new(0.0, 0.0, -1.0), DVec3::new(0.2, 1.0, 0.0)),
            (DVec3::new(0.1, -3.0, 0.2), DVec3::Z),
        ] {
            let b = Basis::from_vpn_vuv(vpn, vuv).unwrap();
            let m = compose(chan_rotation(&b));
            for (col, axis) in [b.u, b.v, -b.n].into_iter().enumerate() {
                for row in 0..3 {
                    assert!(
                        (m[row][col] - axis[row]).abs() < 1e-12,
                        "{vpn}: R[{row}][{col}]"
                    );
                }
            }
        }
        // The default camera looking down −Z has no rotation.
        let b = Basis::from_vpn_vuv(-DVec3::Z, DVec3::Y).unwrap();
        assert!(chan_rotation(&b).length() < 1e-12);
    }
}
