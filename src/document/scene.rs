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
            .filter_map(|(i, s)| {
                plain_sphere(s).or_else(|| self.sphere(&format!("scene.spheres[{i}]"), s))
            })
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

/// The sphere, when every value of it passes `Checker::sphere`'s checks (finite centre, finite
/// radius above 0, colour finite and in [0, 1]): the common case, checked without naming its
/// fields, which a file of a million spheres would otherwise format four million times.
fn plain_sphere(s: &SphereSpec) -> Option<Sphere> {
    let triple = |t: format::Triple| DVec3::new(t.0, t.1, t.2);
    let center = triple(s.center);
    let color = s.color.map_or(DVec3::ONE, triple);
    let ok = center.is_finite()
        && s.radius.is_finite()
        && s.radius > 0.0
        && color.is_finite()
        && color.cmpge(DVec3::ZERO).all()
        && color.cmple(DVec3::ONE).all();
    ok.then_some(Sphere {
        center_world: center,
        radius: s.radius,
        color,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The shortcut takes exactly the spheres that the field-by-field checks pass, with their
    /// values, and leaves every other one to them (and their messages).
    #[test]
    fn plain_spheres_are_the_ones_the_checks_pass() {
        let (nan, inf) = (f64::NAN, f64::INFINITY);
        let centers = [
            (1.0, -2.0, 3.0),
            (0.0, 0.0, -0.0),
            (nan, 0.0, 0.0),
            (0.0, inf, 0.0),
        ];
        let radii = [1.0, 5e-324, 1e300, 0.0, -0.0, -1.0, nan, inf];
        let colors = [
            None,
            Some((0.0, 0.5, 1.0)),
            Some((1.0, 1.0, 1.0)),
            Some((1.0000000000000002, 0.5, 0.5)),
            Some((0.5, -0.0, 0.5)),
            Some((0.5, -1e-300, 0.5)),
            Some((0.5, 0.5, nan)),
        ];
        let (mut taken, mut left) = (0, 0);
        for center in centers {
            for radius in radii {
                for color in colors {
                    let s = SphereSpec {
                        center,
                        radius,
                        color,
                    };
                    let mut checker = Checker::default();
                    let checked = checker.sphere("s", &s);
                    let plain = plain_sphere(&s);
                    if checker.problems.is_empty() {
                        assert_eq!(plain, checked, "{s:?}");
                        assert!(plain.is_some());
                        taken += 1;
                    } else {
                        assert_eq!(plain, None, "{s:?}");
                        left += 1;
                    }
                }
            }
        }
        assert!(taken > 10 && left > 100, "{taken} taken, {left} left");
    }
}
