//! The frame's spheres and lights in view coordinates.

use glam::DVec3;

use super::shadows::FrameShadows;
use crate::camera::Camera;
use crate::scene::Sphere;

/// A sphere in view coordinates, with the terms every primary ray shares: made one at a time,
/// kept per field in [`ViewColumns`].
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

/// The frame's spheres in view coordinates, one slice per field, in the order of the spheres:
/// the hit search reads a candidate's terms by its index, and a packet whose lanes hit several
/// spheres gathers their fields lane by lane (`Lanes::gather`).
pub(super) struct ViewColumns {
    /// No primary ray meets the sphere nearer than this: |f| − r.
    pub(super) min_dist: Vec<f64>,
    /// COP − centre.
    pub(super) f: [Vec<f64>; 3],
    /// |f|² − r².
    pub(super) c: Vec<f64>,
    pub(super) radius2: Vec<f64>,
    pub(super) center: [Vec<f64>; 3],
    pub(super) radius: Vec<f64>,
    pub(super) color: [Vec<f64>; 3],
    /// The spheres' indices in the scene.
    pub(super) id: Vec<u64>,
}

impl ViewColumns {
    /// `spheres`, one slice per field.
    #[cfg(test)]
    pub(super) fn new(spheres: &[ViewSphere]) -> ViewColumns {
        let mut columns = ViewColumns::with_capacity(spheres.len());
        columns.extend(spheres);
        columns
    }

    /// No spheres yet, room for `n`.
    pub(super) fn with_capacity(n: usize) -> ViewColumns {
        let column = || Vec::with_capacity(n);
        ViewColumns {
            min_dist: column(),
            f: [column(), column(), column()],
            c: column(),
            radius2: column(),
            center: [column(), column(), column()],
            radius: column(),
            color: [column(), column(), column()],
            id: Vec::with_capacity(n),
        }
    }

    /// `spheres` after the ones held.
    pub(super) fn extend(&mut self, spheres: &[ViewSphere]) {
        for s in spheres {
            self.min_dist.push(s.min_dist);
            self.c.push(s.c);
            self.radius2.push(s.radius2);
            self.radius.push(s.radius);
            for a in 0..3 {
                self.f[a].push(s.f[a]);
                self.center[a].push(s.center[a]);
                self.color[a].push(s.color[a]);
            }
            self.id.push(s.id as u64);
        }
    }

    /// Sphere `k`, whole.
    pub(super) fn sphere(&self, k: usize) -> ViewSphere {
        let xyz = |c: &[Vec<f64>; 3]| DVec3::new(c[0][k], c[1][k], c[2][k]);
        ViewSphere {
            center: xyz(&self.center),
            radius: self.radius[k],
            radius2: self.radius2[k],
            f: xyz(&self.f),
            c: self.c[k],
            min_dist: self.min_dist[k],
            color: xyz(&self.color),
            id: self.id[k] as u32,
        }
    }

    /// How many spheres.
    pub(super) fn len(&self) -> usize {
        self.id.len()
    }

    /// Sphere `k`'s f (COP − centre).
    #[inline(always)]
    pub(super) fn f_at(&self, k: usize) -> DVec3 {
        DVec3::new(self.f[0][k], self.f[1][k], self.f[2][k])
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
