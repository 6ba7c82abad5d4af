//! Frame keys: a SHA-256 of everything that determines a frame's pixels.
//!
//! A frame's pixels are a function of the renderer's code, the raster (size and sampling), the
//! scene and the frame's camera, and of nothing else (no entropy, no thread count). The key
//! hashes exactly those, bit for bit, so two frames with the same key have the same pixels and a
//! frame on disk is still valid exactly when its recorded key equals the key of the file now.
//!
//! Every struct is destructured without `..`, so a field added to any of them does not compile
//! until it is added to the key too.

use sha2::{Digest, Sha256};

use crate::camera::{Basis, Camera};
use crate::hash::FrameHash;
use crate::raster::{MotionBlur, Raster};
use crate::scene::{Light, Scene, Sphere};

/// The renderer's version. Bump it with every change that changes any frame's pixels (the golden
/// test refuses new golden hashes under an old version), so frames rendered by an older campath
/// are never taken for current ones.
pub const VERSION: u32 = 1;

/// The key of one frame: the SHA-256 of the renderer version, raster, scene and camera, written
/// as 64 lower-case hex digits. The same digest type as a frame's hash, keyed apart.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct FrameKey(pub FrameHash);

impl std::fmt::Display for FrameKey {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        self.0.fmt(f)
    }
}

/// The part of every frame key that frames share (renderer version, raster, scene), hashed once.
#[derive(Clone)]
pub struct KeyBase(Sha256);

impl KeyBase {
    /// The part of every frame key that does not change between frames: scene and raster.
    pub fn new(scene: &Scene, raster: Raster) -> KeyBase {
        let mut h = Feed(Sha256::new());
        h.bytes(b"campath frame key");
        h.u64(u64::from(VERSION));
        let Raster {
            width,
            height,
            samples,
            adaptive,
        } = raster;
        for x in [width, height, samples, u32::from(adaptive)] {
            h.u64(u64::from(x));
        }
        let Scene {
            background,
            ambient,
            lights,
            spheres,
        } = scene;
        h.f64s(&background.to_array());
        h.f64(*ambient);
        h.u64(lights.len() as u64);
        for &Light {
            direction_world,
            color,
            shadows,
        } in lights
        {
            h.f64s(&direction_world.to_array());
            h.f64s(&color.to_array());
            h.u64(u64::from(shadows));
        }
        h.u64(spheres.len() as u64);
        // The same bytes as seven `f64`s a sphere, fed a thousand spheres at a time: one
        // update per number cost more than the hash (0.15 s at a million spheres).
        let mut chunk = Vec::with_capacity(56 * 1024);
        let mut all = spheres.iter().peekable();
        while all.peek().is_some() {
            chunk.clear();
            for Sphere {
                center_world,
                radius,
                color,
            } in all.by_ref().take(1024)
            {
                let (c, k) = (center_world, color);
                for x in [c.x, c.y, c.z, radius, k.x, k.y, k.z] {
                    chunk.extend_from_slice(&x.to_bits().to_le_bytes());
                }
            }
            h.bytes(&chunk);
        }
        KeyBase(h.0)
    }

    /// The key of a frame seen through `camera`.
    pub fn key(&self, camera: &Camera) -> FrameKey {
        let mut h = Feed(self.0.clone());
        h.camera(camera);
        FrameKey(FrameHash(h.0.finalize().into()))
    }

    /// The key of a frame with motion blur `blur`, seen through `camera` at the frame's time
    /// and through `times` at its time samples: [`KeyBase::key`]'s bytes, then the tag
    /// `motion blur`, the shutter, the number of time samples and every time sample's camera.
    /// It differs from the key without blur (and from any other setting's) even where the
    /// camera stands still and the pixels are the same.
    pub fn key_blurred(&self, camera: &Camera, blur: MotionBlur, times: &[Camera]) -> FrameKey {
        let mut h = Feed(self.0.clone());
        h.camera(camera);
        h.bytes(b"motion blur");
        let MotionBlur { shutter, samples } = blur;
        h.f64(shutter);
        h.u64(u64::from(samples));
        h.u64(times.len() as u64);
        for c in times {
            h.camera(c);
        }
        FrameKey(FrameHash(h.0.finalize().into()))
    }
}

/// Feeds values to a hasher as fixed-width little-endian bytes (floats by their bits, so −0 and
/// +0 differ and nothing is rounded).
struct Feed(Sha256);

impl Feed {
    fn bytes(&mut self, b: &[u8]) {
        self.0.update(b);
    }
    fn u64(&mut self, x: u64) {
        self.0.update(x.to_le_bytes());
    }
    fn f64(&mut self, x: f64) {
        self.0.update(x.to_bits().to_le_bytes());
    }
    fn f64s(&mut self, xs: &[f64]) {
        for &x in xs {
            self.f64(x);
        }
    }
    fn camera(&mut self, camera: &Camera) {
        let Camera {
            vrp_world,
            basis: Basis { u, v, n },
            cop_view,
            window,
        } = *camera;
        for p in [vrp_world, u, v, n, cop_view] {
            self.f64s(&p.to_array());
        }
        self.f64s(&window.to_array());
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::{DVec2, DVec3};

    fn scene() -> Scene {
        Scene {
            background: DVec3::new(0.1, 0.2, 0.3),
            ambient: 0.1,
            lights: vec![Light {
                direction_world: DVec3::NEG_Y,
                color: DVec3::ONE,
                shadows: true,
            }],
            spheres: crate::scene::Spheres::from(vec![Sphere {
                center_world: DVec3::ZERO,
                radius: 1.0,
                color: DVec3::new(0.9, 0.2, 0.2),
            }]),
        }
    }

    fn camera() -> Camera {
        Camera {
            vrp_world: DVec3::new(0.0, 0.0, -4.0),
            basis: Basis {
                u: DVec3::NEG_X,
                v: DVec3::Y,
                n: DVec3::Z,
            },
            cop_view: DVec3::new(0.0, 0.0, -1.0),
            window: DVec2::new(1.6, 0.9),
        }
    }

    const RASTER: Raster = Raster {
        width: 64,
        height: 36,
        samples: 1,
        adaptive: false,
    };

    #[test]
    fn the_key_is_the_sha256_of_the_documented_byte_layout() {
        // The same layout written out by hand: tag, version, raster, scene, camera.
        let mut bytes: Vec<u8> = b"campath frame key".to_vec();
        let u = |b: &mut Vec<u8>, x: u64| b.extend_from_slice(&x.to_le_bytes());
        let f = |b: &mut Vec<u8>, x: f64| b.extend_from_slice(&x.to_bits().to_le_bytes());
        u(&mut bytes, VERSION as u64);
        for x in [64, 36, 1, 0] {
            u(&mut bytes, x);
        }
        for x in [0.1, 0.2, 0.3, 0.1] {
            f(&mut bytes, x);
        }
        u(&mut bytes, 1);
        for x in [0.0, -1.0, 0.0, 1.0, 1.0, 1.0] {
            f(&mut bytes, x);
        }
        u(&mut bytes, 1);
        u(&mut bytes, 1);
        for x in [0.0, 0.0, 0.0, 1.0, 0.9, 0.2, 0.2] {
            f(&mut bytes, x);
        }
        for x in [
            0.0, 0.0, -4.0, -1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, -1.0, 1.6, 0.9,
        ] {
            f(&mut bytes, x);
        }
        let want = format!("{:x}", Sha256::digest(&bytes));
        assert_eq!(
            KeyBase::new(&scene(), RASTER).key(&camera()).to_string(),
            want
        );
    }

    #[test]
    fn every_input_changes_the_key() {
        let base = KeyBase::new(&scene(), RASTER).key(&camera());
        let mut s = scene();
        let mut first = s.spheres.get(0);
        first.color.x = 0.8;
        s.spheres.set(0, first);
        assert_ne!(KeyBase::new(&s, RASTER).key(&camera()), base);
        let mut s = scene();
        s.lights[0].shadows = false;
        assert_ne!(KeyBase::new(&s, RASTER).key(&camera()), base);
        let r = Raster {
            samples: 2,
            ..RASTER
        };
        assert_ne!(KeyBase::new(&scene(), r).key(&camera()), base);
        let mut c = camera();
        c.vrp_world.z = f64::from_bits((-4.0f64).to_bits() + 1); // one ulp
        assert_ne!(KeyBase::new(&scene(), RASTER).key(&c), base);
        let mut c = camera();
        c.basis.u.y = -0.0;
        assert_ne!(KeyBase::new(&scene(), RASTER).key(&c), base);
    }

    /// Motion blur: the key without blur, then the tag, the setting and the time samples'
    /// cameras, written out by hand; each part of the setting changes it.
    #[test]
    fn the_blurred_key_covers_the_setting_and_the_time_samples() {
        let base = KeyBase::new(&scene(), RASTER);
        let (cam, blur) = (
            camera(),
            MotionBlur {
                shutter: 0.5,
                samples: 2,
            },
        );
        let mut moved = camera();
        moved.vrp_world.x = 0.25;
        let times = [cam, moved];
        let mut plain = Feed(base.0.clone());
        plain.camera(&cam);
        let mut bytes = Feed(plain.0.clone());
        bytes.bytes(b"motion blur");
        bytes.f64(0.5);
        bytes.u64(2);
        bytes.u64(2);
        bytes.camera(&cam);
        bytes.camera(&moved);
        let want = format!("{:x}", bytes.0.finalize());
        let key = base.key_blurred(&cam, blur, &times);
        assert_eq!(key.to_string(), want);
        assert_ne!(key, base.key(&cam));
        let other = |b: MotionBlur, t: &[Camera]| base.key_blurred(&cam, b, t);
        let wider = MotionBlur {
            shutter: 0.75,
            ..blur
        };
        assert_ne!(other(wider, &times), key);
        let more = MotionBlur { samples: 3, ..blur };
        assert_ne!(other(more, &[cam, cam, moved]), key);
        assert_ne!(other(blur, &[cam, cam]), key);
        // Still: the setting alone still changes the key.
        assert_ne!(other(blur, &[cam, cam]), base.key(&cam));
    }
}
