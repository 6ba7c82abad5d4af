//! The file's `animate` section: one track per mode (Roll included), each with keys whose times strictly
//! increase; two tracks that set the same camera parameter conflict.

use glam::{DVec2, DVec3};

use super::Checker;
use crate::format::{EaseSpec, KeySpec, SpeedSpec, TrackSpec, Triple};
use crate::keyframes::{
    DirectionTrack, Ease, Interpolation, Key, Keyable, PathTrack, Track, UniformSpeed,
};

/// The checked tracks, at most one per mode.
#[derive(Default)]
pub(super) struct Tracks {
    pub observer: Option<PathTrack>,
    pub look_around: Option<DirectionTrack>,
    pub track: Option<Track<DVec3>>,
    pub zoom: Option<Track<f64>>,
    pub distort: Option<Track<DVec2>>,
    pub roll: Option<Track<f64>>,
}

impl Tracks {
    /// The time of the last key of any track, 0 without tracks.
    pub fn last_key_time(&self) -> f64 {
        fn end<V>(keys: &[Key<V>]) -> f64 {
            keys.last().map_or(0.0, |k| k.t)
        }
        [
            self.observer.as_ref().map(|t| end(t.keys())),
            self.look_around.as_ref().map(|t| end(t.keys())),
            self.track.as_ref().map(|t| end(t.keys())),
            self.zoom.as_ref().map(|t| end(t.keys())),
            self.distort.as_ref().map(|t| end(t.keys())),
            self.roll.as_ref().map(|t| end(t.keys())),
        ]
        .into_iter()
        .flatten()
        .fold(0.0, f64::max)
    }
}

impl Checker {
    pub(super) fn tracks(&mut self, specs: &[TrackSpec], vuv: DVec3) -> Tracks {
        let mut out = Tracks::default();
        let mut seen: Vec<(&'static str, usize)> = Vec::new();
        for (i, spec) in specs.iter().enumerate() {
            let field = format!("animate[{i}] ({})", spec.mode());
            let sets = spec.mode().sets();
            if let Some((_, j)) = seen.iter().find(|(s, _)| *s == sets) {
                let message = format!(
                    "conflicts with animate[{j}] ({}): both set {sets}; keep one",
                    specs[*j].mode()
                );
                self.problem(field, message);
                continue;
            }
            seen.push((sets, i));
            self.track(&field, spec, vuv, &mut out);
        }
        out
    }

    /// Checks one track into its slot of `out`.
    fn track(&mut self, field: &str, spec: &TrackSpec, vuv: DVec3, out: &mut Tracks) {
        match spec {
            TrackSpec::Observer {
                keys,
                interpolation,
                speed,
                arc_samples,
                ease,
            } => {
                let timing = (*speed, *arc_samples, *ease);
                out.observer = self.observer(field, keys, *interpolation, timing)
            }
            TrackSpec::Track {
                keys,
                interpolation,
            } => {
                out.track = self
                    .keys(field, keys, *interpolation, |c, f, v| c.triple(f, *v))
                    .map(Track::new)
            }
            TrackSpec::LookAround {
                keys,
                interpolation,
            } => {
                out.look_around = self
                    .keys(field, keys, *interpolation, |c, f, v| c.direction(f, *v))
                    .map(|k| DirectionTrack::new(k, vuv));
            }
            TrackSpec::Zoom {
                keys,
                interpolation,
            } => {
                out.zoom = self
                    .keys(field, keys, *interpolation, |c, f, n| c.cop_n(f, *n))
                    .map(Track::new);
            }
            TrackSpec::Distort {
                keys,
                interpolation,
            } => {
                out.distort = self
                    .keys(field, keys, *interpolation, |c, f, v| c.pair(f, *v))
                    .map(Track::new);
            }
            TrackSpec::Roll {
                keys,
                interpolation,
            } => {
                out.roll = self
                    .keys(field, keys, *interpolation, |c, f, deg| c.finite(f, *deg))
                    .map(Track::new);
            }
        }
    }

    fn observer(
        &mut self,
        field: &str,
        keys: &[KeySpec<Triple>],
        interpolation: Option<Interpolation>,
        (speed, arc_samples, ease): (Option<SpeedSpec>, Option<i64>, Option<EaseSpec>),
    ) -> Option<PathTrack> {
        let samples = arc_samples.unwrap_or(i64::from(UniformSpeed::DEFAULT_SAMPLES));
        let samples = self.count(&format!("{field}.arc_samples"), samples, 1 << 20, ("", ""));
        if arc_samples.is_some() && speed != Some(SpeedSpec::Uniform) {
            self.problem(
                format!("{field}.arc_samples"),
                "only applies with speed: Uniform",
            );
        }
        let ease = ease.and_then(|e| self.ease(&format!("{field}.ease"), e, speed));
        let track = Track::new(self.keys(field, keys, interpolation, |c, f, v| c.triple(f, *v))?);
        let samples = samples?;
        let Some(SpeedSpec::Uniform) = speed else {
            return Some(PathTrack::Keyed(track));
        };
        let keys = track.keys();
        let duration = keys[keys.len() - 1].t - keys[0].t;
        let ease = match ease {
            Some(ease) if !ease.fits(duration) => {
                let message = format!(
                    "start + end is {} s, longer than the path's {duration} s from its first key \
                     to its last: shorten them",
                    ease.start + ease.end
                );
                self.problem(format!("{field}.ease"), message);
                return None;
            }
            ease => ease.unwrap_or(Ease::NONE),
        };
        Some(PathTrack::Uniform(
            UniformSpeed::new(track, samples).eased(ease),
        ))
    }

    /// An Observer's ease: each end ≥ 0 seconds, and only with constant speed.
    fn ease(&mut self, field: &str, e: EaseSpec, speed: Option<SpeedSpec>) -> Option<Ease> {
        if speed != Some(SpeedSpec::Uniform) {
            let message = "only applies with speed: Uniform (constant speed between the eases)";
            self.problem(field.to_string(), message);
            return None;
        }
        let mut end = |name: &str, x: Option<f64>| {
            let f = format!("{field}.{name}");
            let x = self.finite(&f, x.unwrap_or(0.0))?;
            self.ensure(&f, x >= 0.0, x, || format!("seconds ≥ 0, got {x}"))
        };
        let (start, end) = (end("start", e.start), end("end", e.end));
        Some(Ease {
            start: start?,
            end: end?,
        })
    }

    /// A Zoom key: the COP's n, < 0.
    fn cop_n(&mut self, field: &str, n: f64) -> Option<f64> {
        let n = self.finite(field, n)?;
        self.ensure(field, n < 0.0, n, || {
            format!("the COP's n must be < 0, got {n}")
        })
    }

    pub(super) fn keys<S, V: Keyable>(
        &mut self,
        field: &str,
        keys: &[KeySpec<S>],
        track_interpolation: Option<Interpolation>,
        mut value: impl FnMut(&mut Self, &str, &S) -> Option<V>,
    ) -> Option<Vec<Key<V>>> {
        if keys.is_empty() {
            self.problem(format!("{field}.keys"), "a track needs at least one key");
            return None;
        }
        let default = track_interpolation.unwrap_or(Interpolation::CatmullRom);
        let mut out = Vec::with_capacity(keys.len());
        let mut ok = true;
        for (k, key) in keys.iter().enumerate() {
            let f = format!("{field}.keys[{k}]");
            let t = self.finite(&format!("{f}.t"), key.t);
            let v = value(self, &format!("{f}.value"), &key.value);
            match (t, v) {
                (Some(t), Some(value)) => out.push(Key {
                    t,
                    value,
                    interpolation: key.interpolation.unwrap_or(default),
                }),
                _ => ok = false,
            }
        }
        if ok {
            for (k, w) in out.windows(2).enumerate() {
                if w[1].t <= w[0].t {
                    self.problem(
                        format!("{field}.keys[{}].t", k + 1),
                        format!(
                            "key times must strictly increase: {} s follows {} s",
                            w[1].t, w[0].t
                        ),
                    );
                    ok = false;
                }
            }
        }
        ok.then_some(out)
    }
}
