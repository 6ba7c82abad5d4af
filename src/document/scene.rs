//! The file's `scene` section: background, ambient term, lights and spheres.

use glam::DVec3;
use std::fmt;

use super::{Checker, ReadFile};
use crate::format::sphere_files::Spheres;
use crate::format::{self, LightSpec, SphereSpec};
use crate::scene::{Light, Scene, Sphere};

impl Checker {
    pub(super) fn scene(&mut self, spec: &format::SceneSpec, files: &[ReadFile]) -> Option<Scene> {
        let background = match spec.background {
            Some(b) => self.color("scene.background", b),
            None => Some(DVec3::ZERO),
        };
        let ambient = self.ambient(spec);
        let lights: Vec<Light> = (spec.lights.iter().enumerate())
            .filter_map(|(i, l)| self.light(&format!("scene.lights[{i}]"), l))
            .collect();
        let mut spheres: Vec<Sphere> = (spec.spheres.iter().enumerate())
            .filter_map(|(i, s)| self.sphere(Origin::Inline, i, s))
            .collect();
        for (k, file) in files.iter().enumerate() {
            match &file.spheres {
                Ok(read) => {
                    let origin = Origin::File(&file.name, read);
                    spheres.extend(
                        (read.spheres.iter().enumerate())
                            .filter_map(|(i, s)| self.sphere(origin, i, s)),
                    );
                }
                Err(e) => {
                    let at = e.at.map_or(String::new(), |at| format!(": {at}"));
                    self.problem(
                        format!("scene.sphere_files[{k}] ({}{at})", file.name),
                        e.message.clone(),
                    );
                }
            }
        }
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

    fn sphere(&mut self, origin: Origin, index: usize, s: &SphereSpec) -> Option<Sphere> {
        let field = |field| SphereField {
            origin,
            index,
            field,
        };
        let center = self.triple(field("center"), s.center);
        let radius = self.positive(field("radius"), s.radius);
        let color = match s.color {
            Some(c) => self.color(field("color"), c),
            None => Some(DVec3::ONE),
        };
        Some(Sphere {
            center_world: center?,
            radius: radius?,
            color: color?,
        })
    }
}

/// Where a sphere was written: inline, or in a sphere file.
#[derive(Clone, Copy)]
enum Origin<'a> {
    Inline,
    /// The file's name as the keyframe file gives it, and its spheres (for their locations).
    File(&'a str, &'a Spheres),
}

/// Field `field` of sphere `index` (`scene.spheres[3].radius`, or `cloud.ply: vertex 3:
/// radius`), spelled out only when a problem names it: a file of a million spheres is checked
/// without formatting four million paths.
#[derive(Clone, Copy)]
struct SphereField<'a> {
    origin: Origin<'a>,
    index: usize,
    field: &'static str,
}

impl fmt::Display for SphereField<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.origin {
            Origin::Inline => write!(f, "scene.spheres[{}].{}", self.index, self.field),
            Origin::File(name, spheres) => {
                write!(
                    f,
                    "{name}: {}: {}",
                    spheres.location(self.index),
                    self.field
                )
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A bad sphere's problems name its own fields, at its own index, in order.
    #[test]
    fn sphere_problems_name_the_sphere_and_field() {
        let mut checker = Checker::default();
        let good = SphereSpec {
            center: (1.0, 2.0, 3.0),
            radius: 1.0,
            color: None,
        };
        assert!(checker.sphere(Origin::Inline, 0, &good).is_some());
        let bad = SphereSpec {
            center: (f64::NAN, 0.0, 0.0),
            radius: -1.0,
            color: Some((0.5, 2.0, 0.5)),
        };
        assert!(checker.sphere(Origin::Inline, 12, &bad).is_none());
        let fields: Vec<&str> = checker.problems.iter().map(|p| p.field.as_str()).collect();
        assert_eq!(
            fields,
            [
                "scene.spheres[12].center",
                "scene.spheres[12].radius",
                "scene.spheres[12].color"
            ]
        );
    }
}
