//! The file's `camera` section and timing: VRP, VUV, COP, where the camera points, the window,
//! the frame count and rate; with the tracks, the checked [`Animation`].

use glam::{DVec2, DVec3};

use super::tracks::Tracks;
use super::{Checker, MAX_FRAMES};
use crate::animation::{Animation, Pointing};
use crate::camera::window_extent;
use crate::format::{CameraSpec, FileSpec};
use crate::mode::Mode;
use crate::raster::Raster;

impl Checker {
    pub(super) fn animation(
        &mut self,
        spec: &FileSpec,
        raster: Option<&Raster>,
    ) -> Option<Animation> {
        let fps = spec.fps.map_or(Some(24.0), |f| self.positive("fps", f));
        let cam = &spec.camera;
        let vrp = (cam.vrp).map_or(Some(DVec3::ZERO), |v| self.triple("camera.vrp", v));
        let vuv = (cam.vuv).map_or(Some(DVec3::Y), |v| self.direction("camera.vuv", v));
        let cop = self.cop(cam);
        let roll = (cam.roll).map_or(Some(0.0), |deg| self.finite("camera.roll", deg));
        let tracks = self.tracks(&spec.animate, vuv.unwrap_or(DVec3::Y));
        let setter = spec
            .animate
            .iter()
            .enumerate()
            .find(|(_, t)| matches!(t.mode(), Mode::LookAround | Mode::Track))
            .map(|(i, t)| (format!("animate[{i}] ({})", t.mode()), t.mode()));
        let pointing = self.pointing(cam, setter);
        let window = self.window(cam, cop, raster);
        let frames = self.frames(spec.frames, fps, &tracks);
        Some(Animation {
            frames: frames?,
            fps: fps?,
            vrp: vrp?,
            pointing: pointing?,
            vuv: vuv?,
            cop: cop?,
            window: window?,
            observer: tracks.observer,
            look_around: tracks.look_around,
            track: tracks.track,
            zoom: tracks.zoom,
            distort: tracks.distort,
            roll: roll?,
            roll_track: tracks.roll,
        })
    }

    /// The COP in view coordinates, behind the view plane (n < 0).
    fn cop(&mut self, cam: &CameraSpec) -> Option<DVec3> {
        let Some(c) = cam.cop else {
            return Some(DVec3::new(0.0, 0.0, -1.0));
        };
        let c = self.triple("camera.cop", c)?;
        let n = c.z;
        let message = || format!("the COP's n must be < 0 (behind the view plane), got {n}");
        self.ensure("camera.cop", c.z < 0.0, c, message)
    }

    /// A VPN or a target point, not both; neither when a track (`setter`: its field and mode)
    /// sets the view direction at every frame, since the track would override them.
    fn pointing(&mut self, cam: &CameraSpec, setter: Option<(String, Mode)>) -> Option<Pointing> {
        if let Some((track, mode)) = &setter {
            let what = match mode {
                Mode::Track => "the view direction (towards its targets)",
                _ => "the view direction",
            };
            for (field, given) in [("camera.vpn", cam.vpn), ("camera.tp", cam.tp)] {
                if given.is_some() {
                    let message = format!(
                        "{track} sets {what} at every frame, so this would be ignored; remove it"
                    );
                    self.problem(field, message);
                }
            }
            return (cam.vpn.is_none() && cam.tp.is_none()).then_some(Pointing::Vpn(DVec3::Z));
        }
        match (cam.vpn, cam.tp) {
            (Some(_), Some(_)) => {
                self.problem(
                    "camera",
                    "give vpn (a direction) or tp (a target point), not both",
                );
                None
            }
            (Some(v), None) => self.direction("camera.vpn", v).map(Pointing::Vpn),
            (None, Some(t)) => self.triple("camera.tp", t).map(Pointing::Target),
            (None, None) => {
                self.problem("camera", "needs vpn (view direction) or tp (target point), or a LookAround or Track animation");
                None
            }
        }
    }

    /// 1 to [`MAX_FRAMES`]; by default enough frames to reach the last key.
    fn frames(&mut self, frames: Option<i64>, fps: Option<f64>, tracks: &Tracks) -> Option<u64> {
        match frames {
            Some(f) if f < 1 || f as u64 > MAX_FRAMES => {
                self.problem("frames", format!("must lie in 1..={MAX_FRAMES}, got {f}"));
                None
            }
            Some(f) => Some(f as u64),
            None => fps.map(|fps| {
                let end = tracks.last_key_time();
                ((end * fps).floor() as u64)
                    .saturating_add(1)
                    .min(MAX_FRAMES)
            }),
        }
    }

    fn window(
        &mut self,
        cam: &CameraSpec,
        cop: Option<DVec3>,
        raster: Option<&Raster>,
    ) -> Option<DVec2> {
        let aspect = raster.map(|r| r.width as f64 / r.height as f64);
        match (cam.window, cam.hfov, cam.vfov) {
            (Some(w), None, None) => {
                let w = self.pair("camera.window", w)?;
                let message = || format!("width and height must be > 0, got ({}, {})", w.x, w.y);
                self.ensure("camera.window", w.x > 0.0 && w.y > 0.0, w, message)
            }
            (Some(_), _, _) => {
                self.problem(
                    "camera",
                    "give window or a field of view (hfov, vfov), not both",
                );
                None
            }
            (None, h, v) => {
                // The notes' "Field of View": the window at the COP's distance from the view plane.
                let d = -cop?.z;
                let h = h.and_then(|h| self.fov("camera.hfov", h).map(|h| window_extent(h, d)));
                let v = v.and_then(|v| self.fov("camera.vfov", v).map(|v| window_extent(v, d)));
                let aspect = aspect?;
                match (cam.hfov.is_some(), cam.vfov.is_some()) {
                    (true, true) => Some(DVec2::new(h?, v?)),
                    (true, false) => h.map(|h| DVec2::new(h, h / aspect)),
                    (false, true) => v.map(|v| DVec2::new(v * aspect, v)),
                    // Default: a window one unit high with the image's aspect.
                    (false, false) => Some(DVec2::new(aspect, 1.0)),
                }
            }
        }
    }
}
