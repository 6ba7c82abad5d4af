//! The notes' five animated cameras ("Animated Cameras"), one per kind of track, and the roll
//! about the view direction: the one list of modes that the format, the checker, the evaluator and the command line all use.

use std::fmt;

/// What a track animates.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Mode {
    /// Observer-cam: the VRP.
    Observer,
    /// Look-around: the VPN.
    LookAround,
    /// Track-cam: the TP, with VPN = TP − VRP at every frame.
    Track,
    /// Zoom: the COP along the VPN (its n).
    Zoom,
    /// Distort: the COP orthogonal to the VPN (its u, v).
    Distort,
    /// Roll: the camera turned about the VPN, in degrees (Blender's roll, Cinemachine's Dutch).
    Roll,
}

impl Mode {
    /// Every mode, in the order the notes list them, then Roll.
    pub const ALL: [Mode; 6] = [
        Mode::Observer,
        Mode::LookAround,
        Mode::Track,
        Mode::Zoom,
        Mode::Distort,
        Mode::Roll,
    ];

    /// The track's name in the keyframe file.
    pub fn name(self) -> &'static str {
        match self {
            Mode::Observer => "Observer",
            Mode::LookAround => "LookAround",
            Mode::Track => "Track",
            Mode::Zoom => "Zoom",
            Mode::Distort => "Distort",
            Mode::Roll => "Roll",
        }
    }

    /// The camera parameter the track sets. Two tracks that set the same one conflict.
    pub fn sets(self) -> &'static str {
        match self {
            Mode::Observer => "the VRP",
            Mode::LookAround | Mode::Track => "the view direction",
            Mode::Zoom => "the COP's n",
            Mode::Distort => "the COP's (u, v)",
            Mode::Roll => "the roll about the VPN",
        }
    }
}

impl fmt::Display for Mode {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}
