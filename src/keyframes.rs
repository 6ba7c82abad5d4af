//! Keyframe tracks: values at times, interpolated with the splines crate.
//!
//! A track holds its first value before its first key and its last value after its last key.
//! Each key chooses how the segment that starts at it is interpolated. Catmull-Rom needs a key on
//! either side of a segment, so the end segments get phantom keys mirrored through the end keys
//! (time and value), which makes the end tangent the end segment's own slope.
//!
//! Direction tracks (VPN) are interpolated on the unit sphere: each segment is evaluated in the
//! tangent plane of its start key (logarithmic map), then mapped back (exponential map), so a
//! direction never passes through the zero vector and a key is hit exactly.

use glam::{DVec2, DVec3};
use splines::{Interpolate, Spline};
use std::ops::{Add, Mul, Sub};

/// How the segment from one key to the next is interpolated; the file names it the same way
/// (`interpolation: Cosine`), so the file's type and this are one.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Deserialize)]
pub enum Interpolation {
    /// Hold the key's value until the next key.
    Step,
    /// Straight line at constant rate.
    Linear,
    /// Ease in and out: the linear blend weighted by (1 − cos πs)/2.
    Cosine,
    /// Cubic through the neighbouring keys (non-uniform Catmull-Rom tangents, scaled by time).
    /// May overshoot the key values where keys are unevenly spaced.
    CatmullRom,
    /// Monotone cubic (Fritsch–Carlson, with the Fritsch–Butland weighted harmonic mean
    /// tangents): each component stays between the segment's two key values, so it never
    /// overshoots, however stiff the timing.
    Monotone,
    /// Centripetal Catmull-Rom (knots spaced by the square root of the chord length): a path
    /// never loops or cusps within a segment. The segment still takes its keys' time.
    Centripetal,
}

/// One key: a value at a time in seconds.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Key<V> {
    /// Seconds.
    pub t: f64,
    /// The value at `t`.
    pub value: V,
    /// Interpolation of the segment from this key to the next.
    pub interpolation: Interpolation,
}

/// A value a track can carry: scalars, pairs and triples of f64.
pub trait Keyable:
    Copy + Add<Output = Self> + Sub<Output = Self> + Mul<f64, Output = Self> + std::fmt::Debug
{
    /// Number of components.
    const DIM: usize;
    /// Component `i`, 0 ≤ i < `DIM`.
    fn component(&self, i: usize) -> f64;
    /// Sets component `i`, 0 ≤ i < `DIM`.
    fn set_component(&mut self, i: usize, x: f64);
    /// Euclidean length.
    fn norm(&self) -> f64;
}

impl Keyable for f64 {
    const DIM: usize = 1;
    fn component(&self, _: usize) -> f64 {
        *self
    }
    fn set_component(&mut self, _: usize, x: f64) {
        *self = x;
    }
    fn norm(&self) -> f64 {
        self.abs()
    }
}

macro_rules! keyable_vector {
    ($t:ty, $dim:expr) => {
        impl Keyable for $t {
            const DIM: usize = $dim;
            fn component(&self, i: usize) -> f64 {
                self[i]
            }
            fn set_component(&mut self, i: usize, x: f64) {
                self[i] = x;
            }
            fn norm(&self) -> f64 {
                self.length()
            }
        }
    };
}
keyable_vector!(DVec2, 2);
keyable_vector!(DVec3, 3);

/// Wrapper that gives splines an [`Interpolate`] whose cosine goes through libm, so that results
/// do not depend on the platform's math library.
#[derive(Debug, Clone, Copy)]
struct Knot<V>(V);

impl<V: Keyable> Interpolate<f64> for Knot<V> {
    fn step(t: f64, threshold: f64, a: Self, b: Self) -> Self {
        if t < threshold {
            a
        } else {
            b
        }
    }

    fn lerp(t: f64, a: Self, b: Self) -> Self {
        Knot(a.0 * (1.0 - t) + b.0 * t)
    }

    fn cosine(t: f64, a: Self, b: Self) -> Self {
        let s = (1.0 - libm::cos(t * std::f64::consts::PI)) * 0.5;
        Self::lerp(s, a, b)
    }

    fn cubic_hermite(
        t: f64,
        x: (f64, Self),
        a: (f64, Self),
        b: (f64, Self),
        y: (f64, Self),
    ) -> Self {
        // Hermite basis with Catmull-Rom tangents scaled to the segment's duration.
        let (t2, t3) = (t * t, t * t * t);
        let span = b.0 - a.0;
        let m0 = (b.1 .0 - x.1 .0) * (span / (b.0 - x.0));
        let m1 = (y.1 .0 - a.1 .0) * (span / (y.0 - a.0));
        Knot(
            a.1 .0 * (2.0 * t3 - 3.0 * t2 + 1.0)
                + m0 * (t3 - 2.0 * t2 + t)
                + b.1 .0 * (3.0 * t2 - 2.0 * t3)
                + m1 * (t3 - t2),
        )
    }

    fn quadratic_bezier(t: f64, a: Self, u: Self, b: Self) -> Self {
        let s = 1.0 - t;
        Knot(a.0 * (s * s) + u.0 * (2.0 * s * t) + b.0 * (t * t))
    }

    fn cubic_bezier(t: f64, a: Self, u: Self, v: Self, b: Self) -> Self {
        let s = 1.0 - t;
        Knot(
            a.0 * (s * s * s)
                + u.0 * (3.0 * s * s * t)
                + v.0 * (3.0 * s * t * t)
                + b.0 * (t * t * t),
        )
    }

    fn cubic_bezier_mirrored(t: f64, a: Self, u: Self, v: Self, b: Self) -> Self {
        Self::cubic_bezier(t, a, u, Knot(b.0 + b.0 - v.0), b)
    }
}

fn splines_interpolation<V>(i: Interpolation) -> splines::Interpolation<f64, Knot<V>> {
    match i {
        // The threshold 1 holds the value over the whole segment; the next key starts its own.
        Interpolation::Step => splines::Interpolation::Step(1.0),
        Interpolation::Linear => splines::Interpolation::Linear,
        Interpolation::Cosine => splines::Interpolation::Cosine,
        Interpolation::CatmullRom => splines::Interpolation::CatmullRom,
        // Evaluated from precomputed Bézier control points, never by the spline; Linear keeps
        // the spline's neighbours valid.
        Interpolation::Monotone | Interpolation::Centripetal => splines::Interpolation::Linear,
    }
}

/// The inner Bézier control points of segment i (keys i → i + 1) for a cubic interpolation.
type Controls<V> = (V, V);

/// Fritsch–Carlson monotone tangents per component, in value per second: zero at a local
/// extremum, the Fritsch–Butland weighted harmonic mean of the neighbouring slopes elsewhere, and
/// the end segment's slope at either end. Each tangent lies within [0, 3] times both adjacent
/// slopes, the box where a cubic Hermite segment stays monotone.
fn monotone_tangents<V: Keyable>(keys: &[Key<V>]) -> Vec<V> {
    let n = keys.len();
    let mut out = vec![keys[0].value; n];
    for c in 0..V::DIM {
        let h: Vec<f64> = keys.windows(2).map(|w| w[1].t - w[0].t).collect();
        let slope: Vec<f64> = keys
            .windows(2)
            .zip(&h)
            .map(|(w, h)| (w[1].value.component(c) - w[0].value.component(c)) / h)
            .collect();
        for (k, m) in out.iter_mut().enumerate() {
            let tangent = if k == 0 {
                slope[0]
            } else if k == n - 1 {
                slope[n - 2]
            } else {
                let (d0, d1, h0, h1) = (slope[k - 1], slope[k], h[k - 1], h[k]);
                if d0 * d1 <= 0.0 {
                    0.0
                } else {
                    3.0 * (h0 + h1) / ((2.0 * h1 + h0) / d0 + (h1 + 2.0 * h0) / d1)
                }
            };
            m.set_component(c, tangent);
        }
    }
    out
}

/// Centripetal Catmull-Rom tangents at each key, with respect to the knot parameter
/// (Barry–Goldman, as in Yuksel et al., "Parameterization and applications of Catmull-Rom
/// curves", 2011), and the knots themselves. The ends use keys mirrored through the end keys.
fn centripetal_tangents<V: Keyable>(keys: &[Key<V>]) -> (Vec<V>, Vec<f64>) {
    let n = keys.len();
    let p = |i: isize| -> V {
        if i < 0 {
            keys[0].value * 2.0 - keys[1].value
        } else if i as usize >= n {
            keys[n - 1].value * 2.0 - keys[n - 2].value
        } else {
            keys[i as usize].value
        }
    };
    // Knot gaps: sqrt of chord length, floored so that repeated keys do not divide by zero.
    let scale = keys
        .windows(2)
        .map(|w| (w[1].value - w[0].value).norm())
        .fold(0.0, f64::max);
    let floor = (scale * 1e-12).max(1e-300).sqrt();
    let gap = |i: isize| (p(i + 1) - p(i)).norm().sqrt().max(floor);
    let mut knots = vec![0.0; n];
    for i in 1..n {
        knots[i] = knots[i - 1] + gap(i as isize - 1);
    }
    let tangents = (0..n as isize)
        .map(|i| {
            let (g0, g1) = (gap(i - 1), gap(i));
            let (a, b, c) = (p(i - 1), p(i), p(i + 1));
            (b - a) * (1.0 / g0) - (c - a) * (1.0 / (g0 + g1)) + (c - b) * (1.0 / g1)
        })
        .collect();
    (tangents, knots)
}

/// Bézier control points for every segment whose start key asks for a cubic interpolation
/// (empty when none does).
fn cubic_controls<V: Keyable>(keys: &[Key<V>]) -> Vec<Option<Controls<V>>> {
    let monotone = keys
        .iter()
        .any(|k| k.interpolation == Interpolation::Monotone)
        .then(|| monotone_tangents(keys));
    let centripetal = keys
        .iter()
        .any(|k| k.interpolation == Interpolation::Centripetal)
        .then(|| centripetal_tangents(keys));
    if monotone.is_none() && centripetal.is_none() {
        return Vec::new();
    }
    (0..keys.len() - 1)
        .map(|i| {
            let asked = "computed when a key asks for it";
            // The tangents and the segment's span in their parameter (seconds, or knots).
            let (m, span) = match keys[i].interpolation {
                Interpolation::Monotone => {
                    (monotone.as_ref().expect(asked), keys[i + 1].t - keys[i].t)
                }
                Interpolation::Centripetal => {
                    let (m, knots) = centripetal.as_ref().expect(asked);
                    (m, knots[i + 1] - knots[i])
                }
                _ => return None,
            };
            let (a, b) = (keys[i].value, keys[i + 1].value);
            Some((a + m[i] * (span / 3.0), b - m[i + 1] * (span / 3.0)))
        })
        .collect()
}

/// The phantom key beyond `end`: `inner` mirrored through it, in time and value, so that a
/// Catmull-Rom end segment has a neighbour on both sides.
fn mirror<V: Keyable>(end: &Key<V>, inner: &Key<V>) -> Key<V> {
    Key {
        t: 2.0 * end.t - inner.t,
        value: end.value * 2.0 - inner.value,
        interpolation: Interpolation::Linear,
    }
}

/// A checked track: at least one key, times finite and strictly increasing.
#[derive(Debug, Clone)]
pub struct Track<V: Keyable> {
    keys: Vec<Key<V>>,
    spline: Option<Spline<f64, Knot<V>>>,
    /// Per segment: Bézier control points where the segment is Monotone or Centripetal.
    controls: Vec<Option<Controls<V>>>,
}

impl<V: Keyable> Track<V> {
    /// `keys` must be non-empty with finite, strictly increasing times and finite values
    /// ([`crate::document`] checks this before calling).
    pub fn new(keys: Vec<Key<V>>) -> Self {
        assert!(!keys.is_empty(), "a track needs a key");
        debug_assert!(keys.windows(2).all(|w| w[0].t < w[1].t));
        // A splines curve with phantom keys mirrored through both ends, given two keys or more.
        let spline = (keys.len() >= 2).then(|| {
            let n = keys.len();
            let key = |k: &Key<V>| {
                splines::Key::new(k.t, Knot(k.value), splines_interpolation(k.interpolation))
            };
            let mut out = vec![key(&mirror(&keys[0], &keys[1]))];
            out.extend(keys.iter().map(key));
            out.push(key(&mirror(&keys[n - 1], &keys[n - 2])));
            Spline::from_vec(out)
        });
        Track {
            controls: cubic_controls(&keys),
            spline,
            keys,
        }
    }

    /// The keys, in time order.
    pub fn keys(&self) -> &[Key<V>] {
        &self.keys
    }

    /// The value at `t` seconds; held constant before the first and after the last key.
    pub fn sample(&self, t: f64) -> V {
        let (first, last) = (&self.keys[0], &self.keys[self.keys.len() - 1]);
        match &self.spline {
            None => first.value,
            Some(_) if t <= first.t => first.value,
            Some(_) if t >= last.t => last.value,
            Some(spline) => {
                let i = self.keys.partition_point(|k| k.t <= t) - 1;
                if let Some(&Some((c1, c2))) = self.controls.get(i) {
                    let (a, b) = (&self.keys[i], &self.keys[i + 1]);
                    let s = (t - a.t) / (b.t - a.t);
                    let (a, c1, c2, b) = (Knot(a.value), Knot(c1), Knot(c2), Knot(b.value));
                    return Knot::cubic_bezier(s, a, c1, c2, b).0;
                }
                spline
                    .sample(t)
                    .expect("phantom keys give every inner segment its neighbours")
                    .0
            }
        }
    }
}

/// A track of unit directions, interpolated on the sphere: segment i (keys i → i + 1) is
/// interpolated in the tangent plane at key i, from the log map of its four neighbouring keys,
/// and mapped back with the exp map.
#[derive(Debug, Clone)]
pub struct DirectionTrack {
    keys: Vec<Key<DVec3>>,
    /// Per segment, the tangent-plane track of its four keys, built once.
    segments: Vec<Track<DVec3>>,
}

impl DirectionTrack {
    /// `keys` as for [`Track::new`], with non-zero values (normalised here). `up` picks the
    /// rotation between opposite directions: about `up`, turning towards `direction × up`.
    pub fn new(mut keys: Vec<Key<DVec3>>, up: DVec3) -> Self {
        assert!(!keys.is_empty(), "a track needs a key");
        for k in &mut keys {
            k.value = k.value.normalize();
        }
        let segments = (0..keys.len().saturating_sub(1))
            .map(|i| Self::segment(&keys, i, up))
            .collect();
        DirectionTrack { keys, segments }
    }

    /// Segment i's keys i − 1 … i + 2 in the tangent plane at key i (phantoms at the ends).
    fn segment(keys: &[Key<DVec3>], i: usize, up: DVec3) -> Track<DVec3> {
        let n = keys.len();
        let base = keys[i].value;
        let local = |j: usize| Key {
            value: log_map(base, keys[j].value, up),
            ..keys[j]
        };
        let window = vec![
            if i > 0 {
                local(i - 1)
            } else {
                mirror(&local(i), &local(i + 1))
            },
            local(i),
            local(i + 1),
            if i + 2 < n {
                local(i + 2)
            } else {
                mirror(&local(i + 1), &local(i))
            },
        ];
        // The window's own phantoms lie outside it, so segment 1 sees exactly these neighbours.
        Track::new(window)
    }

    /// The keys, in time order.
    pub fn keys(&self) -> &[Key<DVec3>] {
        &self.keys
    }

    /// The unit direction at `t` seconds, held before the first and after the last key.
    pub fn sample(&self, t: f64) -> DVec3 {
        let keys = &self.keys;
        let n = keys.len();
        if n == 1 || t <= keys[0].t {
            return keys[0].value;
        }
        if t >= keys[n - 1].t {
            return keys[n - 1].value;
        }
        // Segment i covers [t_i, t_{i+1}).
        let i = keys.partition_point(|k| k.t <= t) - 1;
        exp_map(keys[i].value, self.segments[i].sample(t))
    }
}

/// Logarithmic map of the unit sphere at `p`: the tangent vector at `p` whose direction points
/// along the great circle to `q` and whose length is the angle in radians. For `q = −p` the
/// great circle is the one about `up` (turning towards `p × up`), or any one if `up` ∥ `p`.
pub fn log_map(p: DVec3, q: DVec3, up: DVec3) -> DVec3 {
    let c = p.dot(q);
    let w = q - p * c;
    let s = w.length();
    let angle = libm::atan2(s, c);
    if s > 1e-300 && angle < std::f64::consts::PI - 1e-12 {
        return w * (angle / s);
    }
    if c > 0.0 {
        return DVec3::ZERO;
    }
    let side = p.cross(up);
    let tangent = if side.length() > 1e-12 {
        side.normalize()
    } else {
        p.any_orthonormal_vector()
    };
    tangent * angle
}

/// Exponential map of the unit sphere at `p`: walks `|w|` radians from `p` along `w`.
pub fn exp_map(p: DVec3, w: DVec3) -> DVec3 {
    let angle = w.length();
    if angle == 0.0 {
        return p;
    }
    (p * libm::cos(angle) + w * (libm::sin(angle) / angle)).normalize()
}

/// A position track re-timed to constant speed: between its first and last key times the
/// camera covers equal path length in equal time, along the same curve. Arc length comes from a
/// table of the curve sampled at `samples_per_segment` equal time steps per key segment (chord
/// sums); a time maps to its arc length, the table is searched, and the curve parameter is
/// interpolated linearly within the table step. Keys are passed through, no longer at their
/// times. The error falls with the square of the table step (README shows the measured table).
#[derive(Debug, Clone)]
pub struct UniformSpeed {
    track: Track<DVec3>,
    /// How the speed rises from rest and falls back to it; none by default.
    ease: Ease,
    /// Track times of the table's samples, increasing.
    times: Vec<f64>,
    /// Arc length from the first key to each sample, non-decreasing.
    lengths: Vec<f64>,
}

impl UniformSpeed {
    /// Default table resolution.
    pub const DEFAULT_SAMPLES: u32 = 256;

    /// Re-times `track` to constant speed with an arc-length table of `samples_per_segment` steps per key segment.
    pub fn new(track: Track<DVec3>, samples_per_segment: u32) -> UniformSpeed {
        let n = samples_per_segment.max(1) as usize;
        let keys = track.keys();
        let mut times = vec![keys[0].t];
        for w in keys.windows(2) {
            for k in 1..=n {
                times.push(w[0].t + (w[1].t - w[0].t) * (k as f64 / n as f64));
            }
        }
        let (mut total, mut prev) = (0.0, track.sample(times[0]));
        let lengths = times
            .iter()
            .map(|&t| {
                let p = track.sample(t);
                total += (p - prev).length();
                prev = p;
                total
            })
            .collect();
        UniformSpeed {
            track,
            ease: Ease::NONE,
            times,
            lengths,
        }
    }

    /// The same path starting from rest and coming to rest: see [`Ease`]. The caller has
    /// checked that the ease fits the keys' time ([`Ease::fits`]).
    pub fn eased(self, ease: Ease) -> UniformSpeed {
        UniformSpeed { ease, ..self }
    }

    /// How the path starts and ends.
    pub fn ease(&self) -> Ease {
        self.ease
    }

    /// Whether the path starts or ends softly ([`Ease`]).
    pub fn is_eased(&self) -> bool {
        self.ease != Ease::NONE
    }

    /// Path length in world units (the table's chord sum).
    pub fn length(&self) -> f64 {
        self.lengths[self.lengths.len() - 1]
    }

    /// The position at `t` seconds; held before the first and after the last key time.
    pub fn sample(&self, t: f64) -> DVec3 {
        let (t0, t1) = (self.times[0], self.times[self.times.len() - 1]);
        if t <= t0 || t >= t1 || self.length() == 0.0 {
            return self.track.sample(t0.max(t.min(t1)));
        }
        let s = match self.ease == Ease::NONE {
            true => self.length() * ((t - t0) / (t1 - t0)),
            false => self.length() * self.ease.fraction(t - t0, t1 - t0),
        };
        let i = self
            .lengths
            .partition_point(|&l| l <= s)
            .clamp(1, self.lengths.len() - 1);
        let (l0, l1) = (self.lengths[i - 1], self.lengths[i]);
        let frac = if l1 > l0 { (s - l0) / (l1 - l0) } else { 0.0 };
        self.track
            .sample(self.times[i - 1] + (self.times[i] - self.times[i - 1]) * frac)
    }
}

/// The start and end of a constant-speed path, eased: over its first `start` seconds the speed
/// rises from rest to the cruising speed V, and over its last `end` seconds it falls back to
/// rest, each along smoothstep, V·(3y² − 2y³) for y from 0 to 1 of the ease. Speed and
/// acceleration are continuous everywhere (the path is C², where its curve is), the inner keys
/// are passed without a stop, and V = L / (T − (start + end)/2) for a path of length L over T
/// seconds. With no ease the speed is L / T throughout, as before.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ease {
    /// Seconds from rest to the cruising speed, ≥ 0.
    pub start: f64,
    /// Seconds from the cruising speed to rest, ≥ 0.
    pub end: f64,
}

impl Ease {
    /// Constant speed from the first key's time to the last.
    pub const NONE: Ease = Ease {
        start: 0.0,
        end: 0.0,
    };

    /// Whether both eases fit in a path of `duration` seconds.
    pub fn fits(self, duration: f64) -> bool {
        self.start + self.end <= duration
    }

    /// The fraction of the path's length covered `x` seconds into a path of `duration`
    /// seconds: 0 at 0, 1 at `duration`, increasing between.
    pub fn fraction(self, x: f64, duration: f64) -> f64 {
        // The length smoothstep's speed covers over y of an ease: ∫₀ʸ 3s² − 2s³ ds.
        let covered = |y: f64| y * y * y * (1.0 - 0.5 * y);
        let (a, b) = (self.start, self.end);
        let cruise = duration - 0.5 * (a + b);
        let distance = if x < a {
            a * covered(x / a)
        } else if x > duration - b {
            cruise - b * covered((duration - x) / b)
        } else {
            x - 0.5 * a
        };
        (distance / cruise).clamp(0.0, 1.0)
    }
}

/// A VRP track: keyed, or re-timed to constant speed.
#[derive(Debug, Clone)]
pub enum PathTrack {
    /// Each key reached at its time.
    Keyed(Track<DVec3>),
    /// Constant speed from the first key's time to the last.
    Uniform(UniformSpeed),
}

impl PathTrack {
    /// The position at `t` seconds.
    pub fn sample(&self, t: f64) -> DVec3 {
        match self {
            PathTrack::Keyed(track) => track.sample(t),
            PathTrack::Uniform(u) => u.sample(t),
        }
    }

    /// The keys of the path, in time order.
    pub fn keys(&self) -> &[Key<DVec3>] {
        match self {
            PathTrack::Keyed(track) => track.keys(),
            PathTrack::Uniform(u) => u.track.keys(),
        }
    }
}
