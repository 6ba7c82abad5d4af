//! The fewest keys that reproduce a source's camera: a keyframe file whose camera, at every
//! sample's time, puts the points the source's camera sees within a tolerance of the pixels
//! where the source puts them.
//!
//! **The keys.** Each sample is campath's camera in the form the file keys: the VRP one unit of
//! the first sample's view in front of the eye (the window is the first sample's field of view
//! at that distance), the VPN, the roll about it from the notes' basis with VUV = +y (continued
//! over the pole as campath continues it), the COP's n where the field of view changes (Zoom) and
//! its (u, v) where the lens shifts (Distort). Every track is Catmull-Rom through keys at sample
//! times: Observer, LookAround, and Roll, Zoom and Distort where they change; a value that does
//! not change is the camera's.
//!
//! **The error.** At a sample, the source's picture is sampled at its corners, its edges' middles
//! and its centre, each at distances from the eye of `near`, 4 × `near`, 16 × `near` and
//! infinity; each point is projected by the fitted camera at that time, and the error is the
//! greatest distance from where the source has it, in pixels of the file's image. A rotation
//! or a lens error moves far and near points alike; a position error moves the near ones most.
//!
//! **The search.** The first and last samples are keys; then, while a sample is off by more than
//! the tolerance, the worst sample between each two keys becomes a key; then each inner key
//! whose removal keeps every sample within the tolerance is removed. With a key at every sample
//! the fit is exact at the samples, so the search ends.

use std::fmt::Write as _;
use std::path::Path;

use glam::{DVec2, DVec3};

use super::{Sample, Source};
use crate::animation::Animation;
use crate::camera::{Basis, Camera};
use crate::document::Document;
use crate::keyframes::{Interpolation, Key, Track};

/// What the fit aims at.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Options {
    /// The largest error allowed at any sample, pixels.
    pub tolerance: f64,
    /// The picture's size in pixels.
    pub size: (u32, u32),
    /// Frames per second of the file.
    pub fps: f64,
    /// The nearest distance from the eye, world units, at which the picture must hold.
    pub near: f64,
}

/// The default tolerance, pixels.
pub const TOLERANCE: f64 = 0.05;

/// A fitted keyframe file.
#[derive(Debug, Clone, PartialEq)]
pub struct Fitted {
    /// The keyframe file's text, without a scene.
    pub text: String,
    /// The number of key times.
    pub keys: usize,
    /// The tracks the file has, by name.
    pub tracks: Vec<&'static str>,
    /// The greatest error at any sample, pixels, and the time of that sample, seconds.
    pub worst: (f64, f64),
}

/// A sample in the form the file keys it.
#[derive(Debug, Clone, Copy)]
struct Keyed {
    time: f64,
    vrp: DVec3,
    vpn: DVec3,
    roll: f64,
    cop: DVec3,
}

/// The file's view up vector: +y, unless the first sample looks along it, when it is that
/// sample's own up.
fn vuv(first: &Sample) -> DVec3 {
    match first.basis.n.cross(DVec3::Y).length() > 1e-6 {
        true => DVec3::Y,
        false => first.basis.v,
    }
}

/// Fits `source` with the fewest keys it can: see the module's documentation.
pub fn fit(source: &Source, options: &Options) -> Result<Fitted, String> {
    let samples = &source.samples;
    let distance = source.view_distance.filter(|d| *d > 0.0).unwrap_or(1.0);
    let window = samples[0].window * distance;
    let keyed = keyed(samples, window)?;
    // A value needs a track where holding the first sample's moves the picture by more than a
    // tenth of the tolerance (a source's f32 rounding does not): a roll turns the corners, half
    // the diagonal from the centre; a zoom scales the picture about its centre; a shift moves it.
    let (w, h) = (f64::from(options.size.0), f64::from(options.size.1));
    let reach = 0.5 * w.hypot(h);
    let changes =
        |moves: &dyn Fn(&Keyed) -> f64| keyed.iter().any(|k| moves(k) > 0.1 * options.tolerance);
    let first = keyed[0];
    let tracks = Tracks {
        roll: changes(&|k| (k.roll - first.roll).abs().to_radians() * reach),
        zoom: changes(&|k| (k.cop.z / first.cop.z - 1.0).abs() * reach),
        distort: changes(&|k| {
            (k.cop - first.cop).truncate().length() / k.cop.z.abs() * w / (window.x / distance)
        }),
        target: target(&keyed, samples, options),
        vuv: vuv(&samples[0]),
    };
    let n = samples.len();
    let mut keys: Vec<usize> = if n == 1 { vec![0] } else { vec![0, n - 1] };
    keys.extend(knots(&keyed));
    keys.sort_unstable();
    keys.dedup();
    // The file with keys at `keys`: the `pinned` samples' through their values, the others'
    // by least squares (`fitted`); or all through their samples.
    let text = |keys: &[usize], fitted: bool, pinned: &[bool]| {
        let values = match fitted {
            true => least_squares(&keyed, keys, pinned),
            false => keys.iter().map(|&i| keyed[i]).collect(),
        };
        file(&keyed, &values, &tracks, window, options)
    };
    let within = |e: &[f64]| e.iter().all(|&x| x <= options.tolerance);
    let (mut fitted, mut pinned) = (true, vec![false; n]);
    let mut errors = errors_of(&text(&keys, fitted, &pinned), samples, options)?;
    // Every span between two keys with a sample off by more than the tolerance and half the
    // worst error (its keys' samples included) is halved; where none can be (keys a sample
    // apart), the keys of the spans still off pass through their samples.
    loop {
        // Only the spans near the worst: least squares spreads one span's misfit over its
        // neighbours, which a key in that span takes back.
        let worst = errors.iter().copied().fold(0.0, f64::max);
        let bar = options.tolerance.max(0.5 * worst);
        let added: Vec<usize> = (keys.windows(2))
            .filter(|w| w[1] - w[0] >= 2 && errors[w[0]..=w[1]].iter().any(|&e| e > bar))
            .map(|w| (w[0] + w[1]) / 2)
            .collect();
        if added.is_empty() {
            let mut more = false;
            for w in keys.windows(2) {
                let off = !within(&errors[w[0]..=w[1]]);
                if off && (!pinned[w[0]] || !pinned[w[1]]) {
                    (pinned[w[0]], pinned[w[1]], more) = (true, true, true);
                }
            }
            if !more {
                break;
            }
        }
        keys.extend(added);
        keys.sort_unstable();
        errors = errors_of(&text(&keys, fitted, &pinned), samples, options)?;
    }
    if !within(&errors) {
        // Least squares cannot reach the tolerance: a key at every sample, through it.
        (keys, fitted) = ((0..n).collect(), false);
        errors = errors_of(&text(&keys, fitted, &pinned), samples, options)?;
    }
    // Each inner key in turn is removed where every sample stays within the tolerance.
    let mut k = 1;
    while k + 1 < keys.len() && within(&errors) {
        let mut fewer = keys.clone();
        fewer.remove(k);
        let e = errors_of(&text(&fewer, fitted, &pinned), samples, options)?;
        if within(&e) {
            (keys, errors) = (fewer, e);
        } else {
            k += 1;
        }
    }
    let (worst, at) = (errors.iter().enumerate())
        .map(|(i, &e)| (e, samples[i].time))
        .fold((0.0, samples[0].time), |a, b| if b.0 > a.0 { b } else { a });
    let mut names = vec!["Observer"];
    if tracks.target.is_none() {
        names.push("LookAround");
    }
    for (on, name) in [
        (tracks.roll, "Roll"),
        (tracks.zoom, "Zoom"),
        (tracks.distort, "Distort"),
    ] {
        if on {
            names.push(name);
        }
    }
    Ok(Fitted {
        text: text(&keys, fitted, &pinned),
        keys: keys.len(),
        tracks: names,
        worst: (worst, at),
    })
}

/// The samples where the numbers the keys hold (the VRP, the roll, the COP) pass from one cubic
/// to another: a keyed Catmull-Rom path is a cubic between its keys, so its third differences
/// over samples equally spaced in time are constant there and change across a key. Each run of
/// changes marks one key, at its middle. Paths that are no piecewise cubic (constant speed,
/// directions) change everywhere and give a key or two, which the search keeps or removes.
fn knots(keyed: &[Keyed]) -> Vec<usize> {
    let numbers = |k: &Keyed| [k.vrp.x, k.vrp.y, k.vrp.z, k.roll, k.cop.x, k.cop.y, k.cop.z];
    let n = keyed.len();
    let even = keyed.windows(3).all(|w| {
        let (a, b) = (w[1].time - w[0].time, w[2].time - w[1].time);
        (a - b).abs() <= 1e-9 * a.abs().max(b.abs())
    });
    if n < 5 || !even {
        return Vec::new();
    }
    let rows: Vec<[f64; 7]> = keyed.iter().map(numbers).collect();
    let mut scale = [0.0f64; 7];
    for row in &rows {
        for (s, x) in scale.iter_mut().zip(row) {
            *s = s.max(x.abs());
        }
    }
    let third = |i: usize, c: usize| {
        rows[i + 3][c] - 3.0 * rows[i + 2][c] + 3.0 * rows[i + 1][c] - rows[i][c]
    };
    // Change i: between the third differences at samples i − 1 and i.
    let changes: Vec<bool> = (1..n - 3)
        .map(|i| (0..7).any(|c| (third(i, c) - third(i - 1, c)).abs() > 1e-9 * (scale[c] + 1.0)))
        .collect();
    let mut out = Vec::new();
    let mut i = 0;
    while i < changes.len() {
        if changes[i] {
            let start = i;
            while i < changes.len() && changes[i] {
                i += 1;
            }
            // Changes start..i compare the third differences from samples start ..= i: across
            // a key at sample j they are those from j − 3 to j, so the key is one past the
            // middle of the run.
            out.push((start + 1 + i) / 2 + 1);
        }
        i += 1;
    }
    out.retain(|&k| k > 0 && k < n - 1);
    out
}

/// Which tracks beyond Observer the file needs, and where it looks.
struct Tracks {
    roll: bool,
    zoom: bool,
    distort: bool,
    /// The point every sample looks at, if there is one: the camera's `tp` (look-at), and no
    /// LookAround track.
    target: Option<DVec3>,
    /// The view up vector.
    vuv: DVec3,
}

/// The point every sample's view passes through, within a tenth of the tolerance at infinity,
/// in front of every VRP: the least-squares meeting point of the lines from each VRP along its
/// VPN (a Track To constraint's target, a campath camera's fixed `tp`).
fn target(keyed: &[Keyed], samples: &[Sample], options: &Options) -> Option<DVec3> {
    if keyed.len() < 2 {
        return None;
    }
    let (mut a, mut b) = (glam::DMat3::ZERO, DVec3::ZERO);
    for k in keyed {
        let n = k.vpn;
        let across = glam::DMat3::IDENTITY - glam::DMat3::from_cols(n * n.x, n * n.y, n * n.z);
        a += across;
        b += across * k.vrp;
    }
    if a.determinant().abs() < 1e-12 {
        return None;
    }
    let p = a.inverse() * b;
    let fits = keyed.iter().zip(samples).all(|(k, s)| {
        let to = p - k.vrp;
        let angle = libm::atan2(to.cross(k.vpn).length(), to.dot(k.vpn));
        let px = angle * f64::from(options.size.0) / s.window.x;
        to.dot(k.vpn) > 0.0 && px <= 0.1 * options.tolerance
    });
    (fits && p.is_finite()).then_some(p)
}

/// Every sample in the file's terms, for the window `window` at one unit from the first eye.
fn keyed(samples: &[Sample], window: DVec2) -> Result<Vec<Keyed>, String> {
    let up = vuv(&samples[0]);
    let mut out: Vec<Keyed> = Vec::with_capacity(samples.len());
    let mut previous_up = None;
    for s in samples {
        let d = window.x / s.window.x;
        let height = s.window.y * d;
        if (height / window.y - 1.0).abs() > 1e-9 {
            return Err(format!(
                "at {} s the field of view's aspect is {}, not the first camera's {}: campath's \
                 window keeps its aspect",
                s.time,
                s.window.x / s.window.y,
                window.x / window.y
            ));
        }
        let cop = DVec3::new(-s.shift.x * d, -s.shift.y * d, -d);
        let vrp = s.eye - s.basis.to_world(cop);
        let plain = Basis::following(s.basis.n, up, previous_up)
            .map_err(|e| format!("at {} s: {e}", s.time))?;
        let mut roll = libm::atan2(-s.basis.v.dot(plain.u), s.basis.v.dot(plain.v)).to_degrees();
        if let Some(last) = out.last() {
            roll += 360.0 * ((last.roll - roll) / 360.0).round();
        }
        previous_up = Some(plain.v);
        out.push(Keyed {
            time: s.time,
            vrp,
            vpn: s.basis.n,
            roll: if roll.abs() < 1e-9 { 0.0 } else { roll },
            cop,
        });
    }
    Ok(out)
}

/// The key values at the samples `keys` whose Catmull-Rom curves come nearest every sample,
/// in the least-squares sense: a Catmull-Rom track is linear in its key values (its end
/// segments' phantom keys too), so each number the keys hold (the VRP's, the roll's, the COP's)
/// is the solution of the normal equations of the samples' weights. Directions keep the
/// samples' own values. A key is where the curve best passes, not always through its sample,
/// which takes far fewer keys than interpolating the samples. The `pinned` samples' keys keep
/// their samples' values, and the others make up the rest.
fn least_squares(keyed: &[Keyed], keys: &[usize], pinned: &[bool]) -> Vec<Keyed> {
    let at: Vec<Keyed> = keys.iter().map(|&i| keyed[i]).collect();
    let m = keys.len();
    // The keys whose values are solved for, and each key's place among them; the rest keep
    // their samples' values.
    let free: Vec<usize> = (0..m).filter(|&j| !pinned[keys[j]]).collect();
    if m < 2 || free.is_empty() {
        return at;
    }
    let mut place = vec![usize::MAX; m];
    for (p, &j) in free.iter().enumerate() {
        place[j] = p;
    }
    // Key j's weight at time t: its unit track's value. A sample between keys s and s + 1 has
    // weight only from keys s − 1 ..= s + 2 (the end segments' phantom keys are made of their
    // end keys), so the normal equations are banded.
    let units: Vec<Track<f64>> = (0..m)
        .map(|j| {
            let keys = (at.iter().enumerate())
                .map(|(l, k)| Key {
                    t: k.time,
                    value: if l == j { 1.0 } else { 0.0 },
                    interpolation: Interpolation::CatmullRom,
                })
                .collect();
            Track::new(keys)
        })
        .collect();
    let near = |t: f64| {
        let s = at.partition_point(|k| k.time <= t);
        s.saturating_sub(3)..(s + 3).min(m)
    };
    let numbers = |k: &Keyed| [k.vrp.x, k.vrp.y, k.vrp.z, k.roll, k.cop.x, k.cop.y, k.cop.z];
    let mut normal = Banded::new(free.len());
    let mut rhs = vec![[0.0; 7]; free.len()];
    for s in keyed {
        let weights: Vec<(usize, f64)> =
            near(s.time).map(|j| (j, units[j].sample(s.time))).collect();
        // What the free keys must make up: the sample less the pinned keys' part.
        let mut y = numbers(s);
        for &(j, w) in weights.iter().filter(|(j, _)| pinned[keys[*j]]) {
            for (y, v) in y.iter_mut().zip(numbers(&at[j])) {
                *y -= w * v;
            }
        }
        let solved_for = || weights.iter().filter(|(j, _)| !pinned[keys[*j]]);
        for &(a, wa) in solved_for() {
            for &(b, wb) in solved_for() {
                normal.add(place[a], place[b], wa * wb);
            }
            for (r, y) in rhs[place[a]].iter_mut().zip(y) {
                *r += wa * y;
            }
        }
    }
    let mut solved: Vec<[f64; 7]> = at.iter().map(numbers).collect();
    for c in 0..7 {
        let column: Vec<f64> = rhs.iter().map(|r| r[c]).collect();
        let solution = normal.clone().solve(column);
        // The COP's n stays behind the view plane, or keeps the samples' values.
        if let Some(x) = solution.filter(|x| c != 6 || x.iter().all(|&n| n < 0.0)) {
            for (&j, x) in free.iter().zip(x) {
                solved[j][c] = x;
            }
        }
    }
    (at.iter().zip(solved))
        .map(|(k, [x, y, z, roll, u, v, n])| Keyed {
            vrp: DVec3::new(x, y, z),
            roll,
            cop: DVec3::new(u, v, n),
            ..*k
        })
        .collect()
}

/// How far from the diagonal the normal equations reach: the weights of a sample are taken
/// from the keys up to three either side of its span, so keys up to five apart share one.
const BAND: usize = 5;

/// A square matrix that is zero more than [`BAND`] places from its diagonal.
#[derive(Clone)]
struct Banded {
    /// Row r holds columns r − BAND ..= r + BAND.
    rows: Vec<[f64; 2 * BAND + 1]>,
}

impl Banded {
    fn new(n: usize) -> Banded {
        Banded {
            rows: vec![[0.0; 2 * BAND + 1]; n],
        }
    }

    fn at(&mut self, r: usize, c: usize) -> &mut f64 {
        &mut self.rows[r][c + BAND - r]
    }

    fn add(&mut self, r: usize, c: usize, x: f64) {
        *self.at(r, c) += x;
    }

    /// The solution of this x = `b` by Gaussian elimination within the band (the normal
    /// equations are symmetric positive definite: no pivoting); None when it is singular.
    fn solve(mut self, mut b: Vec<f64>) -> Option<Vec<f64>> {
        let n = b.len();
        for col in 0..n {
            let pivot = *self.at(col, col);
            if pivot.abs() < 1e-300 {
                return None;
            }
            let last = (col + BAND).min(n - 1);
            for row in col + 1..=last {
                let f = *self.at(row, col) / pivot;
                if f == 0.0 {
                    continue;
                }
                for k in col..=last {
                    let above = *self.at(col, k);
                    *self.at(row, k) -= f * above;
                }
                b[row] -= f * b[col];
            }
        }
        let mut x = vec![0.0; n];
        for row in (0..n).rev() {
            let last = (row + BAND).min(n - 1);
            let rest: f64 = (row + 1..=last).map(|k| *self.at(row, k) * x[k]).sum();
            x[row] = (b[row] - rest) / *self.at(row, row);
        }
        x.iter().all(|v| v.is_finite()).then_some(x)
    }
}

/// A number as the file writes it: the shortest decimal that reads back the same, never −0.
fn num(x: f64) -> String {
    format!("{:?}", x + 0.0)
}

fn triple(v: DVec3) -> String {
    format!("({}, {}, {})", num(v.x), num(v.y), num(v.z))
}

/// The keyframe file with the keys `values`, for the samples `keyed`.
fn file(
    keyed: &[Keyed],
    values: &[Keyed],
    tracks: &Tracks,
    window: DVec2,
    options: &Options,
) -> String {
    let first = &keyed[0];
    let last = keyed[keyed.len() - 1].time;
    // The frames up to the last sample's; one within 10⁻⁴ of a frame counts (glTF keeps its
    // times in f32).
    let frames = ((last * options.fps + 1e-4).floor().max(0.0) as u64) + 1;
    let track = |name: &str, value: &dyn Fn(&Keyed) -> String| {
        let mut s = format!("        {name}(keys: [\n");
        for k in values {
            let _ = writeln!(s, "            (t: {}, value: {}),", num(k.time), value(k));
        }
        s + "        ]),\n"
    };
    let mut animate = track("Observer", &|k| triple(k.vrp));
    let tp = match tracks.target {
        Some(p) => format!(", tp: {}", triple(p)),
        None => {
            animate += &track("LookAround", &|k| triple(k.vpn));
            String::new()
        }
    };
    if tracks.roll {
        animate += &track("Roll", &|k| num(k.roll));
    }
    if tracks.zoom {
        animate += &track("Zoom", &|k| num(k.cop.z));
    }
    if tracks.distort {
        animate += &track("Distort", &|k| {
            format!("({}, {})", num(k.cop.x), num(k.cop.y))
        });
    }
    let roll = match tracks.roll || first.roll == 0.0 {
        true => String::new(),
        false => format!(", roll: {}", num(first.roll)),
    };
    let vuv = match tracks.vuv == DVec3::Y {
        true => String::new(),
        false => format!(", vuv: {}", triple(tracks.vuv)),
    };
    let (w, h) = options.size;
    format!(
        "(\n    frames: {frames}, fps: {fps},\n    image: (width: {w}, height: {h}),\n    \
         camera: (cop: {cop}, window: ({ww}, {wh}){tp}{vuv}{roll}),\n    animate: [\n{animate}    ],\n)\n",
        fps = num(options.fps),
        cop = triple(first.cop),
        ww = num(window.x),
        wh = num(window.y),
    )
}

/// Each sample's error, pixels, under the file `text`.
fn errors_of(text: &str, samples: &[Sample], options: &Options) -> Result<Vec<f64>, String> {
    let doc = Document::from_str(Path::new("import.ron"), text)
        .map_err(|e| format!("the fitted file does not check: {e}"))?;
    let a: &Animation = &doc.animation;
    let mut previous = None;
    let mut out = Vec::with_capacity(samples.len());
    for s in samples {
        let cam = a
            .camera_at(s.time, previous)
            .map_err(|e| format!("the fitted camera at {} s: {e}", s.time))?;
        previous = Some(a.up_before_roll(&cam, s.time));
        out.push(error(s, &cam, options));
    }
    Ok(out)
}

/// The reprojection error of `cam` against the sample `s`, pixels: see the module's
/// documentation.
pub fn error(s: &Sample, cam: &Camera, options: &Options) -> f64 {
    let fitted = Sample::of_camera(s.time, cam);
    let (w, h) = (f64::from(options.size.0), f64::from(options.size.1));
    let mut worst: f64 = 0.0;
    for gx in [-1.0, 0.0, 1.0] {
        for gy in [-1.0, 0.0, 1.0] {
            let on = s.shift + DVec2::new(gx, gy) * s.window * 0.5;
            let dir = s.basis.n + s.basis.u * on.x + s.basis.v * on.y;
            let source = DVec2::new((gx * 0.5 + 0.5) * w, (0.5 - gy * 0.5) * h);
            for depth in [1.0, 4.0, 16.0, f64::INFINITY] {
                let rel = match depth.is_finite() {
                    true => s.eye + dir * (depth * options.near) - fitted.eye,
                    false => dir,
                };
                let view = fitted.basis.to_view(rel);
                if view.z <= 0.0 {
                    return f64::INFINITY;
                }
                let at = DVec2::new(view.x, view.y) / view.z - fitted.shift;
                let px = DVec2::new(
                    (at.x / fitted.window.x + 0.5) * w,
                    (0.5 - at.y / fitted.window.y) * h,
                );
                worst = worst.max((px - source).length());
            }
        }
    }
    worst
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `error` against a value worked out by hand: a camera moved forward by δ along its view
    /// enlarges a point at depth z about the centre by z / (z − δ); the corners, half the
    /// diagonal out, at the nearest depth (`near`) move the most, and points at infinity not
    /// at all.
    #[test]
    fn the_error_of_a_camera_moved_forward_is_the_corners_enlargement_at_the_nearest_depth() {
        let basis = Basis::from_vpn_vuv(DVec3::new(0.3, -0.2, 1.0), DVec3::Y).unwrap();
        let source = Camera {
            vrp_world: DVec3::new(1.0, 2.0, 3.0),
            basis,
            cop_view: DVec3::new(0.0, 0.0, -1.5),
            window: DVec2::new(1.6, 0.9),
        };
        let delta = 1e-3;
        let moved = Camera {
            vrp_world: source.vrp_world + basis.n * delta,
            ..source
        };
        let options = Options {
            tolerance: TOLERANCE,
            size: (1920, 1080),
            fps: 24.0,
            near: 2.0,
        };
        let got = error(&Sample::of_camera(0.0, &source), &moved, &options);
        let want = (2.0 / (2.0 - delta) - 1.0) * 0.5 * 1920f64.hypot(1080.0);
        assert!((got - want).abs() < 1e-9 * want, "{got} against {want}");
        // The same camera is off by rounding only.
        assert!(error(&Sample::of_camera(0.0, &source), &source, &options) < 1e-9);
    }
}
