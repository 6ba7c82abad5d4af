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
    /// The keyframe file's text (without a scene).
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

/// The view up vector of the file.
const VUV: DVec3 = DVec3::Y;

/// Fits `source` with the fewest keys it can: see the module's documentation.
pub fn fit(source: &Source, options: &Options) -> Result<Fitted, String> {
    let samples = &source.samples;
    let window = samples[0].window;
    let keyed = keyed(samples, window)?;
    let changes = |f: &dyn Fn(&Keyed) -> Vec<f64>| {
        let first = f(&keyed[0]);
        keyed.iter().any(|k| f(k) != first)
    };
    let tracks = Tracks {
        roll: changes(&|k| vec![k.roll]),
        zoom: changes(&|k| vec![k.cop.z]),
        distort: changes(&|k| vec![k.cop.x, k.cop.y]),
    };
    let n = samples.len();
    let mut keys: Vec<usize> = if n == 1 { vec![0] } else { vec![0, n - 1] };
    let text = |keys: &[usize]| file(&keyed, keys, &tracks, window, options);
    let mut errors = errors_of(&text(&keys), samples, options)?;
    loop {
        let mut added = Vec::new();
        for w in keys.windows(2) {
            let worst = (w[0] + 1..w[1]).max_by(|&a, &b| errors[a].total_cmp(&errors[b]));
            if let Some(i) = worst.filter(|&i| errors[i] > options.tolerance) {
                added.push(i);
            }
        }
        if added.is_empty() {
            break;
        }
        keys.extend(added);
        keys.sort_unstable();
        errors = errors_of(&text(&keys), samples, options)?;
    }
    // Each inner key, from the one whose neighbours lie closest: removed if every sample stays
    // within the tolerance.
    let mut k = 1;
    while k + 1 < keys.len() {
        let mut fewer = keys.clone();
        fewer.remove(k);
        let e = errors_of(&text(&fewer), samples, options)?;
        if e.iter().all(|&x| x <= options.tolerance) {
            (keys, errors) = (fewer, e);
        } else {
            k += 1;
        }
    }
    let (worst, at) = (errors.iter().enumerate())
        .map(|(i, &e)| (e, samples[i].time))
        .fold((0.0, samples[0].time), |a, b| if b.0 > a.0 { b } else { a });
    let mut names = vec!["Observer", "LookAround"];
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
        text: text(&keys),
        keys: keys.len(),
        tracks: names,
        worst: (worst, at),
    })
}

/// Which tracks beyond Observer and LookAround the file needs.
struct Tracks {
    roll: bool,
    zoom: bool,
    distort: bool,
}

/// Every sample in the file's terms, for the window `window` at one unit from the first eye.
fn keyed(samples: &[Sample], window: DVec2) -> Result<Vec<Keyed>, String> {
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
        let plain = Basis::following(s.basis.n, VUV, previous_up)
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

/// A number as the file writes it: the shortest decimal that reads back the same, never −0.
fn num(x: f64) -> String {
    format!("{:?}", x + 0.0)
}

fn triple(v: DVec3) -> String {
    format!("({}, {}, {})", num(v.x), num(v.y), num(v.z))
}

/// The keyframe file with keys at the samples `keys`.
fn file(
    keyed: &[Keyed],
    keys: &[usize],
    tracks: &Tracks,
    window: DVec2,
    options: &Options,
) -> String {
    let first = &keyed[0];
    let last = keyed[keyed.len() - 1].time;
    let frames = ((last * options.fps + 1e-9).floor().max(0.0) as u64) + 1;
    let track = |name: &str, value: &dyn Fn(&Keyed) -> String| {
        let mut s = format!("        {name}(keys: [\n");
        for &i in keys {
            let k = &keyed[i];
            let _ = writeln!(s, "            (t: {}, value: {}),", num(k.time), value(k));
        }
        s + "        ]),\n"
    };
    let mut animate = track("Observer", &|k| triple(k.vrp));
    animate += &track("LookAround", &|k| triple(k.vpn));
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
    let (w, h) = options.size;
    format!(
        "(\n    frames: {frames}, fps: {fps},\n    image: (width: {w}, height: {h}),\n    \
         camera: (cop: {cop}, window: ({ww}, {wh}){roll}),\n    animate: [\n{animate}    ],\n",
        fps = num(options.fps),
        cop = triple(first.cop),
        ww = num(window.x),
        wh = num(window.y),
    )
}

/// Each sample's error, pixels, under the file `text` (without its closing parenthesis).
fn errors_of(text: &str, samples: &[Sample], options: &Options) -> Result<Vec<f64>, String> {
    let doc = Document::from_str(Path::new("import.ron"), &format!("{text})"))
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
