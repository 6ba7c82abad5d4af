//! The checked scene: spheres and directional lights in world coordinates. Every value here is
//! finite and in range ([`crate::document`] checks them).

use glam::DVec3;

/// A sphere in world coordinates.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sphere {
    /// World units.
    pub center_world: DVec3,
    /// World units, > 0.
    pub radius: f64,
    /// Linear RGB in [0, 1].
    pub color: DVec3,
}

/// A directional light: parallel rays travelling along `direction_world`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Light {
    /// Unit vector, the way the light travels (a surface facing −direction is fully lit).
    pub direction_world: DVec3,
    /// Linear RGB, ≥ 0.
    pub color: DVec3,
    /// Whether spheres cast hard shadows from this light.
    pub shadows: bool,
}

/// Checked spheres and directional lights.
#[derive(Debug, Clone, PartialEq)]
pub struct Scene {
    /// Linear RGB in [0, 1], seen where no sphere is hit.
    pub background: DVec3,
    /// Ambient term added to every light's contribution, ≥ 0.
    pub ambient: f64,
    /// Directional lights.
    pub lights: Vec<Light>,
    /// The spheres.
    pub spheres: Vec<Sphere>,
}
