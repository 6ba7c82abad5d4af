//! The oracle: a deliberately plain ray caster that the renderer must match byte for byte.
//!
//! It tests every sphere for every ray, one ray at a time, in scene order, with no tiles, no
//! shadow grid, no packets and no table of sRGB buckets, so it shares none of the renderer's
//! acceleration and none of its control flow. What it does share is the arithmetic the renderer
//! promises (ARCHITECTURE.md, "the bytes"): view coordinates relative to the VRP, the stable
//! sphere root, the shading sum in light order, the sample average in sample order, and the
//! nearest 8-bit sRGB level. Written for clarity, not speed: it is only run on small rasters.

use glam::DVec3;

use campath::camera::{window_point, Camera};
use campath::internals::srgb_decode;
use campath::raster::Raster;
use campath::scene::{Scene, Sphere};

/// A sphere moved into view coordinates (VRP subtracted first, as the camera does it).
struct Ball {
    center: DVec3,
    radius: f64,
    color: DVec3,
}

/// What one sample saw: the sphere's index and the lights that reach its point, or nothing.
/// Adaptive sampling refines a pixel whose four corners saw different things.
#[derive(PartialEq, Clone, Copy)]
enum Seen {
    Background,
    Sphere { index: usize, lights: u32 },
}

/// Renders `scene` through `camera` into RGB8, row-major, top row first.
pub fn render(camera: &Camera, scene: &Scene, raster: Raster) -> Vec<u8> {
    let balls: Vec<Ball> = scene
        .spheres
        .iter()
        .map(|s: Sphere| Ball {
            center: camera.point_to_view(s.center_world),
            radius: s.radius,
            color: s.color,
        })
        .collect();
    // The linear value at which each level past 0 begins: the midpoint between two levels.
    let thresholds: Vec<f64> = (0..255)
        .map(|k| srgb_decode((k as f64 + 0.5) / 255.0))
        .collect();
    let s = raster.samples as usize;
    let mut out = Vec::with_capacity(raster.frame_bytes());
    for j in 0..raster.height as usize {
        for i in 0..raster.width as usize {
            // Sample (sx, sy) of pixel (i, j) aims at (i + (sx + ½)/s, j + (sy + ½)/s).
            let sample = |k: usize| {
                let px = i as f64 + ((k % s) as f64 + 0.5) / s as f64;
                let py = j as f64 + ((k / s) as f64 + 0.5) / s as f64;
                let size = (raster.width, raster.height);
                let d = (window_point(camera.window, size, px, py) - camera.cop_view).normalize();
                shade(camera, scene, &balls, d)
            };
            let color = if raster.adaptive && s >= 2 {
                let corners = [0, s - 1, s * (s - 1), s * s - 1].map(sample);
                if corners.iter().all(|c| c.1 == corners[0].1) {
                    (((corners[0].0 + corners[1].0) + corners[2].0) + corners[3].0) / 4.0
                } else {
                    let mut sum = DVec3::ZERO;
                    for k in 0..s * s {
                        sum += sample(k).0;
                    }
                    sum / (s * s) as f64
                }
            } else {
                let mut sum = DVec3::ZERO;
                for k in 0..s * s {
                    sum += sample(k).0;
                }
                sum / (s * s) as f64
            };
            out.extend(color.to_array().map(|x| srgb_level(&thresholds, x)));
        }
    }
    out
}

/// The colour seen from the COP along unit direction `d`, and what was seen.
fn shade(camera: &Camera, scene: &Scene, balls: &[Ball], d: DVec3) -> (DVec3, Seen) {
    let origin = camera.cop_view;
    let mut nearest: Option<(usize, f64)> = None;
    for (k, b) in balls.iter().enumerate() {
        if let Some(t) = hit(origin, d, b) {
            if nearest.is_none_or(|(_, best)| t < best) {
                nearest = Some((k, t));
            }
        }
    }
    let Some((index, t)) = nearest else {
        return (scene.background, Seen::Background);
    };
    let ball = &balls[index];
    // The hit relative to the centre, from the COP's offset, so no large coordinate is lost.
    let rel = (origin - ball.center) + d * t;
    let normal = rel / ball.radius;
    let point = ball.center + rel;
    let mut light = DVec3::splat(scene.ambient);
    let mut lights = 0u32;
    for (n, l) in scene.lights.iter().enumerate() {
        let to_light = -camera.basis.to_view(l.direction_world);
        let facing = normal.dot(to_light);
        if facing <= 0.0 {
            continue;
        }
        let blocked = |(o, other): (usize, &Ball)| o != index && blocks(other, point, to_light);
        if l.shadows && balls.iter().enumerate().any(blocked) {
            continue;
        }
        light += l.color * facing;
        lights |= 1 << n.min(31);
    }
    let color = ball.color * light;
    // With no lights the colour is ambient alone, only ever capped at 1.
    let color = if scene.lights.is_empty() {
        color.min(DVec3::ONE)
    } else {
        color.clamp(DVec3::ZERO, DVec3::ONE)
    };
    (color, Seen::Sphere { index, lights })
}

/// The nearest t > 0 at which the ray origin + t·d meets `ball`. The stable form (Ray Tracing
/// Gems ch. 7): the discriminant from |f − (f·d)d|², one root q = −(b + sign(b)·√Δ), the other
/// c/q.
fn hit(origin: DVec3, d: DVec3, ball: &Ball) -> Option<f64> {
    let f = origin - ball.center;
    let r2 = ball.radius * ball.radius;
    let b = f.dot(d);
    let disc = r2 - (f - d * b).length_squared();
    if disc < 0.0 {
        return None;
    }
    let q = -(b + disc.sqrt().copysign(b));
    if q == 0.0 {
        return None;
    }
    let c = f.length_squared() - r2;
    let (near, far) = if c / q < q { (c / q, q) } else { (q, c / q) };
    [near, far].into_iter().find(|t| *t > 0.0)
}

/// Whether `ball` blocks the ray from `point` along unit `dir` (t > 0): the point is inside it,
/// or the sphere lies ahead and the ray passes within its radius.
fn blocks(ball: &Ball, point: DVec3, dir: DVec3) -> bool {
    let f = point - ball.center;
    let r2 = ball.radius * ball.radius;
    if f.length_squared() - r2 <= 0.0 {
        return true;
    }
    let b = f.dot(dir);
    b < 0.0 && (f - dir * b).length_squared() <= r2
}

/// The nearest 8-bit sRGB level of linear `x`: how many levels' midpoints, decoded to linear
/// (`thresholds`), lie at or below it (so values outside [0, 1] clamp; NaN is level 0).
fn srgb_level(thresholds: &[f64], x: f64) -> u8 {
    thresholds.iter().filter(|t| **t <= x).count() as u8
}
