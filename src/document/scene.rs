//! The file's `scene` section: background, ambient term, lights and spheres.

use glam::DVec3;

use super::Checker;
use crate::format::{self, LightSpec, SphereSpec};
use crate::scene::{Light, Scene, Sphere};

impl Checker {
    pub(super) fn scene(&mut self, spec: &format::SceneSpec) -> Option<Scene> {
        let background = match spec.background {
            Some(b) => self.color("scene.background", b),
            None => Some(DVec3::ZERO),
        };
        let ambient = self.ambient(spec);
        let lights: Vec<Light> = (spec.lights.iter().enumerate())
            .filter_map(|(i, l)| self.light(&format!("scene.lights[{i}]"), l))
            .collect();
        let spheres: Vec<Sphere> = (spec.spheres.iter().enumerate())
            .filter_map(|(i, s)| self.sphere(&format!("scene.spheres[{i}]"), s))
            .collect();
        Some(Scene {
            background: background?,
            ambient: ambient?,
            lights,
            spheres,
        })
    }

    /// ≥ 0; without lights, ambient alone lights the scene, so the default is flat colours.
    fn ambient(&mut self, spec: &format::SceneSpec) -> Option<f64> {
        let Some(a) = spec.ambient else {
            return Some(if spec.lights.is_empty() { 1.0 } else { 0.1 });
        };
        let a = self.finite("scene.ambient", a)?;
        if a >= 0.0 {
            Some(a)
        } else {
            self.problem("scene.ambient", format!("must be ≥ 0, got {a}"));
            None
        }
    }

    fn light(&mut self, field: &str, l: &LightSpec) -> Option<Light> {
        let dir = self.direction(&format!("{field}.direction"), l.direction);
        let color = match l.color {
            Some(c) => {
                let c = self.triple(&format!("{field}.color"), c)?;
                if c.cmpge(DVec3::ZERO).all() {
                    Some(c)
                } else {
                    self.problem(format!("{field}.color"), "components must be ≥ 0");
                    None
                }
            }
            None => Some(DVec3::ONE),
        };
        Some(Light {
            direction_world: dir?.normalize(),
            color: color?,
            shadows: l.shadows.unwrap_or(true),
        })
    }

    fn sphere(&mut self, field: &str, s: &SphereSpec) -> Option<Sphere> {
        let center = self.triple(&format!("{field}.center"), s.center);
        let radius = self.positive(&format!("{field}.radius"), s.radius);
        let color = match s.color {
            Some(c) => self.color(&format!("{field}.color"), c),
            None => Some(DVec3::ONE),
        };
        Some(Sphere {
            center_world: center?,
            radius: radius?,
            color: color?,
        })
    }
}
