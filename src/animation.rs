//! Per-frame cameras: the base camera with its animated tracks applied (the notes' "Animated
//! Cameras"). Frame k is at t = k / fps seconds.
//!
//! | track | animates |
//! |---|---|
//! | observer | VRP |
//! | look-around | VPN |
//! | track | TP; VPN = TP − VRP |
//! | zoom | the COP's n (along VPN) |
//! | distort | the COP's (u, v) (orthogonal to VPN) |
//! | roll | the camera's turn about the VPN, after the up-vector rule |
//!
//! With motion blur a frame also has a camera per time sample ([`Animation::exposure`]).

use glam::{DVec2, DVec3};

use crate::camera::{Basis, Camera, CameraError};
use crate::keyframes::{DirectionTrack, PathTrack, Track};
use crate::mode::Mode;
use crate::raster::MotionBlur;

/// Where the base camera points, when no track sets it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Pointing {
    /// A fixed view plane normal.
    Vpn(DVec3),
    /// A fixed target point (look-at): VPN = TP − VRP at every frame.
    Target(DVec3),
}

/// A checked animation: the base camera, the tracks that override parts of it, and the timing.
#[derive(Debug, Clone)]
pub struct Animation {
    /// Number of frames, ≥ 1.
    pub frames: u64,
    /// Frames per second, > 0.
    pub fps: f64,
    /// The View Reference Point when no Observer track moves it, world units.
    pub vrp: DVec3,
    /// Where the base camera points when no LookAround or Track sets it.
    pub pointing: Pointing,
    /// The View Up Vector (any length ≠ 0).
    pub vuv: DVec3,
    /// COP in view coordinates, n < 0.
    pub cop: DVec3,
    /// Window (width, height) in world units.
    pub window: DVec2,
    /// Animates the VRP.
    pub observer: Option<PathTrack>,
    /// Animates the VPN.
    pub look_around: Option<DirectionTrack>,
    /// Animates the target point (VPN = TP − VRP).
    pub track: Option<Track<DVec3>>,
    /// Animates the COP's n.
    pub zoom: Option<Track<f64>>,
    /// Animates the COP's (u, v).
    pub distort: Option<Track<DVec2>>,
    /// The roll in degrees when no Roll track sets it (0: the notes' basis).
    pub roll: f64,
    /// Animates the roll, degrees.
    pub roll_track: Option<Track<f64>>,
}

/// A frame's cameras: its own, at the frame's time, and with motion blur one per time sample.
#[derive(Debug, Clone, PartialEq)]
pub struct Exposure {
    /// The frame's camera, at t = k / fps.
    pub camera: Camera,
    /// The camera at each time sample, in time order; empty without motion blur.
    pub times: Vec<Camera>,
}

impl Exposure {
    /// A frame without motion blur: its camera alone.
    pub fn still(camera: Camera) -> Exposure {
        Exposure {
            camera,
            times: Vec::new(),
        }
    }

    /// The cameras whose renders the frame averages: the frame's camera alone without motion
    /// blur, or where every time sample's camera equals it (the camera does not move while the
    /// shutter is open: the frame is rendered once, as without blur); else every time sample's.
    pub fn renders(&self) -> &[Camera] {
        if self.times.iter().all(|c| c.same_bits(&self.camera)) {
            std::slice::from_ref(&self.camera)
        } else {
            &self.times
        }
    }
}

/// The camera could not be formed at a frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FrameError {
    /// The frame, from 0.
    pub frame: u64,
    /// Seconds.
    pub time: f64,
    /// Why the camera is undefined there.
    pub cause: CameraError,
}

impl Animation {
    /// The modes this animation has a track for, in the notes' order.
    pub fn tracks(&self) -> impl Iterator<Item = Mode> + '_ {
        Mode::ALL.into_iter().filter(|m| match m {
            Mode::Observer => self.observer.is_some(),
            Mode::LookAround => self.look_around.is_some(),
            Mode::Track => self.track.is_some(),
            Mode::Zoom => self.zoom.is_some(),
            Mode::Distort => self.distort.is_some(),
            Mode::Roll => self.roll_track.is_some(),
        })
    }

    /// Frame time in seconds.
    pub fn time(&self, frame: u64) -> f64 {
        frame as f64 / self.fps
    }

    /// The point the camera looks at in frame `frame`: the Track's, or the fixed target
    /// point; None where it looks along a direction (a LookAround track, or a VPN).
    pub fn target(&self, frame: u64) -> Option<DVec3> {
        if self.look_around.is_some() {
            return None;
        }
        match (&self.track, self.pointing) {
            (Some(track), _) => Some(track.sample(self.time(frame))),
            (None, Pointing::Target(tp)) => Some(tp),
            _ => None,
        }
    }

    /// The roll at `t` seconds, degrees: the Roll track's, or the camera's.
    pub fn roll_at(&self, t: f64) -> f64 {
        self.roll_track.as_ref().map_or(self.roll, |r| r.sample(t))
    }

    /// The up vector `camera` (the camera at `t` seconds) had before its roll: what the next
    /// camera's basis continues from, so that the up-vector rule at the pole does not see the
    /// roll. Without roll it is the camera's v, bit for bit.
    pub fn up_before_roll(&self, camera: &Camera, t: f64) -> DVec3 {
        camera.basis.rolled(-self.roll_at(t)).v
    }

    /// The basis at `t` seconds for the view plane normal `vpn`: the notes' basis, continued
    /// from the previous camera's up before its roll ([`Basis::following`],
    /// [`Animation::up_before_roll`]), then turned by the roll ([`Basis::rolled`]).
    pub fn basis_at(
        &self,
        t: f64,
        vpn: DVec3,
        previous_v: Option<DVec3>,
    ) -> Result<Basis, CameraError> {
        Ok(Basis::following(vpn, self.vuv, previous_v)?.rolled(self.roll_at(t)))
    }

    /// The camera at `t` seconds, continuing from the previous frame's up before its roll
    /// ([`Animation::basis_at`]).
    pub fn camera_at(&self, t: f64, previous_v: Option<DVec3>) -> Result<Camera, CameraError> {
        let vrp = self.observer.as_ref().map_or(self.vrp, |tr| tr.sample(t));
        let vpn = if let Some(look) = &self.look_around {
            look.sample(t)
        } else if let Some(track) = &self.track {
            track.sample(t) - vrp
        } else {
            match self.pointing {
                Pointing::Vpn(vpn) => vpn,
                Pointing::Target(tp) => tp - vrp,
            }
        };
        let mut cop = self.cop;
        if let Some(zoom) = &self.zoom {
            cop.z = zoom.sample(t);
        }
        if let Some(distort) = &self.distort {
            (cop.x, cop.y) = distort.sample(t).into();
        }
        if !(cop.z < 0.0 && cop.is_finite()) {
            return Err(CameraError::CopNotBehind(cop.z));
        }
        Ok(Camera {
            vrp_world: vrp,
            basis: self.basis_at(t, vpn, previous_v)?,
            cop_view: cop,
            window: self.window,
        })
    }

    /// Frame `frame`'s exposure under `blur`, given its camera: the camera at every time sample
    /// ([`MotionBlur::time`]). The up vector continues outwards from the frame's camera as it
    /// does from frame to frame: the time samples after the frame's time each from the one
    /// before it, starting with the frame's camera, and those before it each from the one after
    /// it. A time sample at the frame's own time (the middle one when N is odd) is the frame's
    /// camera.
    pub fn exposure(
        &self,
        frame: u64,
        camera: Camera,
        blur: MotionBlur,
    ) -> Result<Exposure, FrameError> {
        let n = blur.samples;
        let mut times = vec![camera; n as usize];
        // The previous camera's up before its roll, from the camera and its time.
        let up = |(camera, time): (Camera, f64)| self.up_before_roll(&camera, time);
        let at = |j: u32, previous: (Camera, f64)| {
            let time = blur.time(frame, j, self.fps);
            let camera = self.camera_at(time, Some(up(previous)));
            camera
                .map(|c| (c, time))
                .map_err(|cause| FrameError { frame, time, cause })
        };
        // Forwards from the frame's time, then backwards from it.
        let own = (camera, self.time(frame));
        let mut previous = own;
        for j in (0..n).filter(|&j| blur.offset(j) > 0.0) {
            previous = at(j, previous)?;
            times[j as usize] = previous.0;
        }
        let mut previous = own;
        for j in (0..n).rev().filter(|&j| blur.offset(j) < 0.0) {
            previous = at(j, previous)?;
            times[j as usize] = previous.0;
        }
        Ok(Exposure { camera, times })
    }

    /// Every frame's camera, in order. The basis of each frame follows the one before it, so the
    /// path is always evaluated from frame 0; this costs microseconds per frame.
    pub fn cameras(&self) -> impl Iterator<Item = Result<(u64, Camera), FrameError>> + '_ {
        // The previous frame's v; None once a frame has failed, which ends the frames.
        let mut previous = Some(None);
        (0..self.frames).map_while(move |frame| {
            let time = self.time(frame);
            let camera = self.camera_at(time, previous?);
            previous = camera
                .as_ref()
                .ok()
                .map(|c| Some(self.up_before_roll(c, time)));
            Some(match camera {
                Ok(cam) => Ok((frame, cam)),
                Err(cause) => Err(FrameError { frame, time, cause }),
            })
        })
    }
}
