//! The frame's spheres and lights in view coordinates.

use glam::DVec3;

use super::shadows::FrameShadows;
use crate::camera::Camera;
use crate::scene::Sphere;

/// A sphere in view coordinates, with the terms every primary ray shares.
#[derive(Debug, Clone, Copy)]
pub(super) struct ViewSphere {
    pub(super) center: DVec3,
    pub(super) radius: f64,
    pub(super) radius2: f64,
    /// COP − centre.
    pub(super) f: DVec3,
    /// |f|² − r².
    pub(super) c: f64,
    /// |f| − r: no primary ray meets the sphere nearer than this.
    pub(super) min_dist: f64,
    pub(super) color: DVec3,
    /// The sphere's index in the scene.
    pub(super) id: u32,
}

impl ViewSphere {
    /// `sphere` moved camera-relative into view coordinates: the VRP is subtracted first, so a
    /// scene far from the origin keeps its precision.
    pub(super) fn new(camera: &Camera, sphere: &Sphere, id: u32) -> ViewSphere {
        let center = camera.point_to_view(sphere.center_world);
        ViewSphere::in_view(center, sphere.radius, camera.cop_view, sphere.color, id)
    }

    /// A sphere of centre `center` (view coordinates) seen from `cop_view`.
    pub(super) fn in_view(
        center: DVec3,
        radius: f64,
        cop_view: DVec3,
        color: DVec3,
        id: u32,
    ) -> ViewSphere {
        let f = cop_view - center;
        let radius2 = radius * radius;
        ViewSphere {
            center,
            radius,
            radius2,
            f,
            c: f.length_squared() - radius2,
            min_dist: f.length() - radius,
            color,
            id,
        }
    }
}

/// The fields of the frame's view spheres that a packet whose lanes hit several spheres reads
/// lane by lane (`Lanes::gather`): one slice per field, in the order of the spheres.
pub(super) struct ViewColumns {
    pub(super) f: [Vec<f64>; 3],
    pub(super) center: [Vec<f64>; 3],
    pub(super) radius: Vec<f64>,
    pub(super) color: [Vec<f64>; 3],
    /// The spheres' indices in the scene.
    pub(super) id: Vec<u64>,
}

impl ViewColumns {
    pub(super) fn new(spheres: &[ViewSphere]) -> ViewColumns {
        let column = |f: &dyn Fn(&ViewSphere) -> f64| spheres.iter().map(f).collect::<Vec<_>>();
        let xyz =
            |f: &dyn Fn(&ViewSphere) -> DVec3| [0, 1, 2].map(|a| column(&|s: &ViewSphere| f(s)[a]));
        ViewColumns {
            f: xyz(&|s| s.f),
            center: xyz(&|s| s.center),
            radius: column(&|s| s.radius),
            color: xyz(&|s| s.color),
            id: spheres.iter().map(|s| s.id as u64).collect(),
        }
    }
}

/// A light in view coordinates.
pub(super) struct ViewLight<'a> {
    /// Unit vector from a surface towards the light: −direction.
    pub(super) to_light: DVec3,
    pub(super) color: DVec3,
    /// Spheres binned for this light's shadow rays; None when the light casts no shadows.
    pub(super) shadows: Option<FrameShadows<'a>>,
}
