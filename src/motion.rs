//! Motion that looks wrong, found before anything is rendered: `campath check` warns about it.
//!
//! The checks read the evaluated cameras only (no pixels) and say which frames and which
//! quantity. The thresholds, stated in docs/format.md ("Warnings"):
//!
//! - **A jump in speed or turn rate.** The eye (the COP in world) moves at speed sₖ between frames
//!   k and k+1, and the view (the VPN) turns at rate ωₖ. A change |sₖ₊₁ − sₖ| is a jump when it
//!   exceeds [`JUMP_FACTOR`] times the shot's median change, [`SPEED_FLOOR`] of the median
//!   speed and [`PEAK_FLOOR`] of the fastest (for turning, [`TURN_FLOOR`] of the median rate,
//!   [`PEAK_FLOOR`] of the fastest, and at least [`TURN_MIN_DEG_S`]): a Step key, a kink
//!   between linear keys, a spline overshooting between uneven keys. A speed jump names the
//!   fix for a path that stops dead at its ends: constant speed with eased ends.
//! - **The COP inside a sphere**: the frame is a wall of the sphere's colour.
//! - **A target close to the camera**: the target point nearer the VRP than [`NEAR_TARGET`] of
//!   their median distance over the shot, where the view direction TP − VRP turns unstable.
//! - **The up vector flipping**: v turning more than 90° between consecutive frames.

use glam::DVec3;

use crate::camera::Camera;
use crate::document::Document;
use crate::error::Result;
use crate::frames::{list_frames, median};
use crate::keyframes::PathTrack;
use crate::scene::Spheres;

/// A change this many times the shot's median change is a jump (with the floors below).
pub const JUMP_FACTOR: f64 = 8.0;
/// A speed jump must also exceed this fraction of the shot's median speed.
pub const SPEED_FLOOR: f64 = 0.5;
/// Any jump must also exceed this fraction of the shot's fastest rate (rounding is not motion).
pub const PEAK_FLOOR: f64 = 0.01;
/// A turn-rate jump must also exceed this fraction of the shot's median turn rate …
pub const TURN_FLOOR: f64 = 0.5;
/// … and this many degrees per second.
pub const TURN_MIN_DEG_S: f64 = 5.0;
/// What a speed jump's warning suggests, unless the path is already eased.
pub const EASE_FIX: &str = "; to fly the path at constant speed, starting and stopping softly, \
     give the Observer track speed: Uniform, ease: (start: 1.0, end: 1.0)";
/// A target nearer the VRP than this fraction of their median distance is too close.
pub const NEAR_TARGET: f64 = 0.02;

/// What a warning is about.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Quantity {
    /// The eye's speed, world units per second.
    Speed,
    /// How fast the VPN turns, degrees per second.
    TurnRate,
    /// The COP inside a sphere.
    CopInsideSphere,
    /// The target point at the VRP.
    TargetNearCamera,
    /// The up vector turning more than 90° between frames.
    UpFlip,
}

/// Motion that looks wrong, at some frames.
#[derive(Debug, Clone, PartialEq)]
pub struct Warning {
    /// What the warning is about.
    pub quantity: Quantity,
    /// The frames concerned, in order.
    pub frames: Vec<u64>,
    /// What looks wrong, with the numbers.
    pub message: String,
}

impl std::fmt::Display for Warning {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let s = if self.frames.len() == 1 { "" } else { "s" };
        let frames = list_frames(&self.frames);
        write!(f, "frame{s} {frames}: {}", self.message)
    }
}

/// Consecutive runs of indices.
fn runs(indices: &[usize]) -> Vec<Vec<usize>> {
    let mut out: Vec<Vec<usize>> = Vec::new();
    for &i in indices {
        match out.last_mut() {
            Some(run) if run.last() == Some(&(i - 1)) => run.push(i),
            _ => out.push(vec![i]),
        }
    }
    out
}

/// The warnings of a document's path, by quantity and then by frame. A frame whose camera is
/// undefined is an error, as in [`Document::check_path`].
pub fn warnings(doc: &Document) -> Result<Vec<Warning>> {
    let cameras: Vec<Camera> = doc
        .cameras()
        .map(|c| c.map(|(_, cam)| cam))
        .collect::<Result<_>>()?;
    let fps = doc.animation.fps;
    let mut out = Vec::new();
    if cameras.len() >= 3 {
        let eyes: Vec<DVec3> = cameras.iter().map(Camera::cop_world).collect();
        let speed: Vec<f64> = eyes
            .windows(2)
            .map(|w| (w[1] - w[0]).length() * fps)
            .collect();
        let turn: Vec<f64> = cameras
            .windows(2)
            .map(|w| angle_deg(w[0].basis.n, w[1].basis.n) * fps)
            .collect();
        let eased = matches!(&doc.animation.observer, Some(PathTrack::Uniform(u)) if u.is_eased());
        let fix = match eased {
            true => "",
            false => EASE_FIX,
        };
        jumps(&mut out, Quantity::Speed, &speed, fix);
        jumps(&mut out, Quantity::TurnRate, &turn, "");
    }
    inside_spheres(&mut out, doc, &cameras);
    near_target(&mut out, doc);
    for k in (1..cameras.len()).filter(|&k| cameras[k - 1].basis.v.dot(cameras[k].basis.v) < 0.0) {
        out.push(Warning {
            quantity: Quantity::UpFlip,
            frames: vec![k as u64 - 1, k as u64],
            message: format!(
                "the up vector flips: v turns {:.0}° from frame {} to {k}",
                angle_deg(cameras[k - 1].basis.v, cameras[k].basis.v),
                k - 1
            ),
        });
    }
    Ok(out)
}

fn angle_deg(a: DVec3, b: DVec3) -> f64 {
    let c = (a.dot(b) / (a.length() * b.length())).clamp(-1.0, 1.0);
    libm::acos(c).to_degrees()
}

/// Jumps in `rate` (one value between each pair of consecutive frames) of the speed or the
/// turn rate: a change above [`JUMP_FACTOR`] × the median change and the quantity's floors.
fn jumps(out: &mut Vec<Warning>, quantity: Quantity, rate: &[f64], fix: &str) {
    let (name, unit, floor, min) = match quantity {
        Quantity::Speed => ("speed", "units/s", SPEED_FLOOR, 0.0),
        _ => ("turn rate", "°/s", TURN_FLOOR, TURN_MIN_DEG_S),
    };
    let change: Vec<f64> = rate.windows(2).map(|w| (w[1] - w[0]).abs()).collect();
    let typical = median(&change);
    let fastest = rate.iter().copied().fold(0.0, f64::max);
    let threshold = (JUMP_FACTOR * typical)
        .max(floor * median(rate))
        .max(PEAK_FLOOR * fastest)
        .max(min);
    let big: Vec<usize> = (0..change.len())
        .filter(|&i| change[i] > threshold && change[i] > 0.0)
        .collect();
    for run in runs(&big) {
        // Change i is between rate i (frames i, i+1) and rate i+1 (frames i+1, i+2).
        let (first, last) = (run[0], *run.last().expect("a run is not empty"));
        let frames: Vec<u64> = (first as u64 + 1..=last as u64 + 1).collect();
        let (from, to) = (rate[first], rate[last + 1]);
        let peak = run.iter().map(|&i| rate[i + 1]).fold(from, f64::max);
        let (reached, then) = match peak > from.max(to) {
            true => (peak, format!(", then {to:.3}")),
            false => (to, String::new()),
        };
        out.push(Warning {
            quantity,
            frames,
            message: format!(
                "the {name} jumps: {from:.3} → {reached:.3} {unit}{then} (the shot's typical \
                 change between frames is {typical:.3} {unit}){fix}",
            ),
        });
    }
}

fn inside_spheres(out: &mut Vec<Warning>, doc: &Document, cameras: &[Camera]) {
    let eyes: Vec<DVec3> = cameras.iter().map(Camera::cop_world).collect();
    // (frame, sphere)
    let inside: Vec<(usize, usize)> = first_sphere_around(&doc.scene.spheres, &eyes)
        .into_iter()
        .enumerate()
        .filter_map(|(k, sphere)| Some((k, sphere?)))
        .collect();
    let frames: Vec<usize> = inside.iter().map(|(k, _)| *k).collect();
    for run in runs(&frames) {
        let sphere = inside.iter().find(|(k, _)| *k == run[0]).expect("listed").1;
        out.push(Warning {
            quantity: Quantity::CopInsideSphere,
            frames: run.iter().map(|k| *k as u64).collect(),
            message: format!(
                "the COP is inside the sphere {}: the frame is a wall of its colour",
                doc.sphere_place(sphere)
            ),
        });
    }
}

/// For each eye, the first sphere it lies inside, if any. Each sphere tests only
/// the eyes in its slab along x (widened by far more than the rounding of its bounds, so no eye
/// inside is left out): a long shot through a million spheres costs about a search per
/// sphere, not a test per sphere and frame. Chunks of spheres on the pool each keep their
/// first sphere per eye, and the least index wins, whatever the thread count.
fn first_sphere_around(spheres: &Spheres, eyes: &[DVec3]) -> Vec<Option<usize>> {
    use rayon::prelude::*;
    let mut by_x: Vec<(f64, usize)> = eyes.iter().map(|e| e.x).zip(0..).collect();
    by_x.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
    let none = || vec![None; eyes.len()];
    spheres
        .par_balls()
        .enumerate()
        .with_min_len(1 << 12)
        .fold(none, |mut first, (i, (center, r))| {
            let x = center.x;
            let slack = 1e-9 * (x.abs() + r);
            let lo = by_x.partition_point(|e| e.0 < x - r - slack);
            let hi = by_x.partition_point(|e| e.0 <= x + r + slack);
            for &(_, k) in &by_x[lo..hi.max(lo)] {
                if first[k].is_none() && (eyes[k] - center).length_squared() < r * r {
                    first[k] = Some(i);
                }
            }
            first
        })
        .reduce(none, |a, b| {
            a.into_iter()
                .zip(b)
                .map(|(a, b)| match (a, b) {
                    (Some(a), Some(b)) => Some(a.min(b)),
                    (a, b) => a.or(b),
                })
                .collect()
        })
}

fn near_target(out: &mut Vec<Warning>, doc: &Document) {
    let a = &doc.animation;
    let target = |t: f64| match (&a.track, a.pointing) {
        (Some(track), _) if a.look_around.is_none() => Some(track.sample(t)),
        (None, crate::animation::Pointing::Target(tp)) if a.look_around.is_none() => Some(tp),
        _ => None,
    };
    let distance: Vec<Option<f64>> = (0..a.frames)
        .map(|k| {
            let t = a.time(k);
            let vrp = a.observer.as_ref().map_or(a.vrp, |o| o.sample(t));
            target(t).map(|tp| (tp - vrp).length())
        })
        .collect();
    let known: Vec<f64> = distance.iter().flatten().copied().collect();
    if known.is_empty() {
        return;
    }
    let limit = NEAR_TARGET * median(&known);
    let near: Vec<usize> = (0..distance.len())
        .filter(|&k| distance[k].is_some_and(|d| d < limit))
        .collect();
    for run in runs(&near) {
        let closest = run
            .iter()
            .filter_map(|&k| distance[k])
            .fold(f64::INFINITY, f64::min);
        out.push(Warning {
            quantity: Quantity::TargetNearCamera,
            frames: run.iter().map(|k| *k as u64).collect(),
            message: format!(
                "the target point comes within {closest:.3} units of the VRP (under {:.0}% of \
                 their median distance, {:.3}): the view direction turns unstable",
                NEAR_TARGET * 100.0,
                limit / NEAR_TARGET
            ),
        });
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::Sphere;
    use crate::splitmix::SplitMix;

    /// Whether `eye` lies inside sphere `s`.
    fn is_inside(eye: DVec3, s: &Sphere) -> bool {
        (eye - s.center_world).length_squared() < s.radius * s.radius
    }

    /// The first sphere around each eye, found by testing every sphere against every eye.
    fn every_pair(spheres: &[Sphere], eyes: &[DVec3]) -> Vec<Option<usize>> {
        eyes.iter()
            .map(|&eye| spheres.iter().position(|s| is_inside(eye, s)))
            .collect()
    }

    /// Seeded overlapping spheres (a ground among them) and eyes inside, outside and exactly
    /// on spheres' surfaces, on their slabs' edges, sharing an x, and not a number: the
    /// search by slabs finds what testing every pair finds.
    #[test]
    fn the_first_sphere_around_each_eye_is_the_one_every_pair_finds() {
        let mut rng = SplitMix(0x1ce);
        let mut v = |scale: f64| (rng.unit() - 0.5) * scale;
        let mut spheres: Vec<Sphere> = (0..3000)
            .map(|_| Sphere {
                center_world: DVec3::new(v(20.0), v(6.0), v(20.0)),
                radius: 0.05 + v(1.0).abs(),
                color: DVec3::ONE,
            })
            .collect();
        spheres.insert(
            700,
            Sphere {
                center_world: DVec3::new(0.0, -1e5, 0.0),
                radius: 1e5,
                color: DVec3::ONE,
            },
        );
        let mut eyes: Vec<DVec3> = (0..400)
            .map(|k| DVec3::new(v(22.0), v(8.0), if k % 7 == 0 { 1.5 } else { v(22.0) }))
            .collect();
        for s in spheres.iter().step_by(97) {
            let c = s.center_world;
            eyes.extend([
                c + DVec3::X * s.radius,
                c - DVec3::X * s.radius,
                c + DVec3::Y * s.radius,
                c + DVec3::X * s.radius.next_down(),
                c,
            ]);
        }
        eyes.push(DVec3::NAN);
        let expected = every_pair(&spheres, &eyes);
        assert!(expected.iter().filter(|k| k.is_some()).count() > 100);
        assert!(expected.contains(&Some(700)));
        let packed: Spheres = spheres.iter().copied().collect();
        assert_eq!(first_sphere_around(&packed, &eyes), expected);
        assert_eq!(
            first_sphere_around(&Spheres::new(), &eyes),
            vec![None; eyes.len()]
        );
        assert!(first_sphere_around(&packed, &[]).is_empty());
    }
}
