//! The file's `scene` section: background, ambient term, lights and spheres.
//!
//! A sphere file's spheres are checked on the rayon pool as they are read, straight into the
//! scene's vector (never held as [`SphereSpec`]s first); the inline ones are checked in place,
//! each [`SphereSpec`] turned into its [`Sphere`] in the memory it held. A sphere that fails is
//! noted, and its problems are named afterwards, in file order, as the checker names any
//! field's.

use glam::DVec3;
use rayon::iter::IndexedParallelIterator;
use std::fmt;
use std::path::Path;
use std::sync::{Mutex, PoisonError};

use super::{Checker, SphereFile};
use crate::format::sphere_files::Sink;
use crate::format::sphere_files::{self, FileProblem, Listing};
use crate::format::{
    self, ColorBySpec, LightSpec, Pair, PlainSphere, RadiusBySpec, SphereFileSpec, SphereSpec,
};
use crate::scene::{Light, Scene, Sphere, Spheres};

impl Checker {
    /// The scene, and the sphere files it names (read relative to `folder`) with how many
    /// spheres each gave.
    pub(super) fn scene(
        &mut self,
        spec: &mut format::SceneSpec,
        folder: &Path,
    ) -> (Option<Scene>, Vec<SphereFile>) {
        let background =
            (spec.background).map_or(Some(DVec3::ZERO), |b| self.color("scene.background", b));
        let ambient = self.ambient(spec);
        let lights: Vec<Light> = (spec.lights.iter().enumerate())
            .filter_map(|(i, l)| self.light(&format!("scene.lights[{i}]"), l))
            .collect();
        // The inline spheres checked in place, in the memory their specs held (a `Sphere` is no
        // larger): no second list of fresh pages, no first one to hand back. Then packed, or
        // kept as they are.
        let refused = Refused::default();
        let inline = std::mem::take(&mut spec.spheres);
        let mut inline: Vec<Sphere> = (inline.into_iter().enumerate())
            .map(|(i, s)| refused.check(i, &s))
            .collect();
        // The room past the last sphere held the specs' tails: handed back (8 MB at a million).
        inline.shrink_to_fit();
        let mut spheres = Spheres::new();
        let place = |i: usize, s: Sphere| inline[i] = s;
        refused.name(self, Origin::Inline, place, &[], |_, _| {});
        spheres.append(inline);
        let mut files = Vec::with_capacity(spec.sphere_files.len());
        for (k, file) in spec.sphere_files.iter().enumerate() {
            let name = &file.path;
            let path = folder.join(name);
            if !self.sphere_file(k, file) {
                // Rules that are wrong read nothing: the file's spheres would be wrong too.
                continue;
            }
            let refused = Refused::default();
            let start = spheres.len();
            let listing = sphere_files::read(
                &path,
                file,
                &mut Packing(&mut spheres, Vec::new()),
                |i, s| refused.check(i, s),
            );
            let origin = Origin::File(k, name, &listing);
            let form = |checker: &mut Checker, e: &FileProblem| {
                let at = e.at.map_or(String::new(), |at| format!(": {at}"));
                let field = format!("scene.sphere_files[{k}] ({name}{at})");
                checker.problem(field, e.message.clone());
            };
            let problems = &listing.problems;
            let place = |i: usize, s: Sphere| spheres.set(start + i, s);
            refused.name(self, origin, place, problems, form);
            files.push(SphereFile {
                name: name.clone(),
                path,
                spheres: listing.count,
                listing,
            });
        }
        let scene = match (background, ambient) {
            (Some(background), Some(ambient)) => Some(Scene {
                background,
                ambient,
                lights,
                spheres,
            }),
            _ => None,
        };
        (scene, files)
    }

    /// Whether a `sphere_files` entry's rules are sound: its radius and colour, its type
    /// tables' radii and colours, its colormap's name, its ranges finite and not empty.
    fn sphere_file(&mut self, k: usize, file: &SphereFileSpec) -> bool {
        let before = self.problems.len();
        let at = |field: &str| format!("scene.sphere_files[{k}].{field}");
        if let Some(r) = file.radius {
            self.positive(&at("radius") as &str, r);
        }
        if let Some(c) = file.color {
            self.color(&at("color") as &str, c);
        }
        let range = |checker: &mut Checker, field: &str, range: Pair| {
            if let Some(r) = checker.pair(field, range) {
                checker.ensure(field, r.x != r.y, (), || {
                    format!("the range's ends must differ, got {range:?}")
                });
            }
        };
        match &file.color_by {
            Some(ColorBySpec::Types { colors, .. }) => {
                for (name, c) in colors {
                    self.color(&at(&format!("color_by.colors[{name:?}]")) as &str, *c);
                }
            }
            Some(ColorBySpec::Colormap { map, range: r, .. }) => {
                if sphere_files::colormap(map).is_none() {
                    let names: Vec<&str> = sphere_files::COLORMAPS.iter().map(|m| m.0).collect();
                    self.problem(
                        at("color_by.map"),
                        format!("no colormap {map:?}: the maps are {}", names.join(", ")),
                    );
                }
                range(self, &at("color_by.range"), *r);
            }
            None => {}
        }
        match &file.radius_by {
            Some(RadiusBySpec::Types { radii, .. }) => {
                for (name, r) in radii {
                    self.positive(&at(&format!("radius_by.radii[{name:?}]")) as &str, *r);
                }
            }
            Some(RadiusBySpec::Range {
                range: r, radii, ..
            }) => {
                range(self, &at("radius_by.range"), *r);
                self.positive(&at("radius_by.radii.0") as &str, radii.0);
                self.positive(&at("radius_by.radii.1") as &str, radii.1);
            }
            None => {}
        }
        self.problems.len() == before
    }

    /// ≥ 0; without lights, ambient alone lights the scene, so the default is flat colours.
    fn ambient(&mut self, spec: &format::SceneSpec) -> Option<f64> {
        let Some(a) = spec.ambient else {
            return Some(if spec.lights.is_empty() { 1.0 } else { 0.1 });
        };
        let a = self.finite("scene.ambient", a)?;
        self.ensure("scene.ambient", a >= 0.0, a, || {
            format!("must be ≥ 0, got {a}")
        })
    }

    fn light(&mut self, field: &str, l: &LightSpec) -> Option<Light> {
        let dir = self.direction(&format!("{field}.direction"), l.direction);
        let color = match l.color {
            Some(c) => {
                let field = format!("{field}.color");
                let c = self.triple(&field, c)?;
                self.ensure(field, c.cmpge(DVec3::ZERO).all(), c, || {
                    "components must be ≥ 0".into()
                })
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
        let color = (s.color).map_or(Some(DVec3::ONE), |c| self.color(field("color"), c));
        Some(Sphere {
            center_world: center?,
            radius: radius?,
            color: color?,
        })
    }
}

/// The scene's spheres as a sphere file's [`Sink`]: each block of a binary PLY packed on the
/// pool as it is read.
struct Packing<'a>(&'a mut Spheres, Vec<Sphere>);

impl Sink<Sphere> for Packing<'_> {
    fn count(&self) -> usize {
        self.0.len()
    }

    fn room(&mut self, n: usize) {
        self.0.reserve(n);
    }

    fn put(&mut self, item: Sphere) {
        self.0.push(item);
    }

    fn put_all(&mut self, items: impl IndexedParallelIterator<Item = Sphere>) {
        self.0.par_extend(items, &mut self.1);
    }

    /// A block of plain rows packed as they are read, where every one passes; else none is
    /// taken, and each goes through the check, which names what is wrong.
    fn put_plain(&mut self, count: usize, row: impl Fn(usize) -> PlainSphere + Sync) -> bool {
        self.0.extend_plain(count, |k| {
            let p = row(k);
            plain_passing(&p).then_some((p.ball, p.levels))
        })
    }
}

/// Whether plain row `p` passes every test of [`passing`] (so its sphere is `p.spec()`'s, as
/// [`Spheres::extend_plain`] packs it): an f32 value that is finite is within ±[`LARGEST`],
/// and a level k / 255 is in [0, 1], so only finite values and a radius above 0 are asked.
///
/// [`LARGEST`]: super::LARGEST
#[inline]
fn plain_passing(p: &PlainSphere) -> bool {
    p.ball.iter().all(|v| v.is_finite()) && p.ball[3] > 0.0
}

/// The spheres that failed their check, noted from the pool's tasks as they were checked.
#[derive(Default)]
struct Refused(Mutex<Vec<(usize, SphereSpec)>>);

impl Refused {
    /// Sphere `s` (number `index`) checked; or, when it fails, noted here, and a stand-in in
    /// its place until [`Checker::sphere`] names its problems.
    fn check(&self, index: usize, s: &SphereSpec) -> Sphere {
        if let Some(sphere) = passing(s) {
            return sphere;
        }
        let mut refused = self.0.lock().unwrap_or_else(PoisonError::into_inner);
        refused.push((index, s.clone()));
        Sphere {
            center_world: DVec3::ZERO,
            radius: 1.0,
            color: DVec3::ONE,
        }
    }

    /// Names the refused spheres' problems, by index, and among them in file order the file's
    /// own (`form`, each after the spheres read before it, named by `name_form`); `place(i,
    /// sphere)` puts sphere `i` in its place. A sphere the checker passes after all takes its place, so the
    /// scene never depends on [`passing`] agreeing with the checker, only the speed does.
    fn name(
        self,
        checker: &mut Checker,
        origin: Origin,
        mut place: impl FnMut(usize, Sphere),
        form: &[(usize, FileProblem)],
        name_form: impl Fn(&mut Checker, &FileProblem),
    ) {
        let mut refused = self.0.into_inner().unwrap_or_else(PoisonError::into_inner);
        refused.sort_unstable_by_key(|(i, _)| *i);
        let mut form = form.iter().peekable();
        for (i, s) in refused {
            while let Some((_, e)) = form.next_if(|(before, _)| *before <= i) {
                name_form(checker, e);
            }
            if let Some(sphere) = checker.sphere(origin, i, &s) {
                place(i, sphere);
            }
        }
        for (_, e) in form {
            name_form(checker, e);
        }
    }
}

/// Sphere `s` when it passes every test of [`Checker::sphere`] (without naming anything, for
/// the pool's tasks): centre and radius finite and within ±1e150 (`LARGEST`), radius > 0,
/// colour in [0, 1] or white.
#[inline]
fn passing(s: &SphereSpec) -> Option<Sphere> {
    let center = DVec3::from(s.center);
    let color = s.color.map_or(DVec3::ONE, DVec3::from);
    let good = [s.center.0, s.center.1, s.center.2, s.radius]
        .into_iter()
        .all(super::sized)
        && s.radius > 0.0
        && color.cmpge(DVec3::ZERO).all()
        && color.cmple(DVec3::ONE).all();
    good.then_some(Sphere {
        center_world: center,
        radius: s.radius,
        color,
    })
}

/// Where a sphere was written: inline, or in a sphere file.
#[derive(Clone, Copy)]
enum Origin<'a> {
    Inline,
    /// The file's place in `sphere_files`, its name as the keyframe file gives it, and its
    /// listing (for its spheres' locations).
    File(usize, &'a str, &'a Listing),
}

/// Field `field` of sphere `index` (`scene.spheres[3].radius`, or
/// `scene.sphere_files[0] (cloud.ply: vertex 3): radius`, as the file's own problems are named),
/// spelled out only when a problem names it: a file of a million spheres is checked without
/// formatting four million paths.
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
            Origin::File(k, name, listing) => {
                let at = listing.location(self.index);
                write!(f, "scene.sphere_files[{k}] ({name}: {at}): {}", self.field)
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

    /// The pool's quick test passes a sphere exactly when the checker does, to the same
    /// sphere: every mix of edge values in each field.
    #[test]
    fn passing_agrees_with_the_checker() {
        let edges = [
            0.0,
            -0.0,
            1.0,
            -1.0,
            0.5,
            1.0 + f64::EPSILON,
            f64::MIN_POSITIVE / 2.0,
            f64::MAX,
            super::super::LARGEST,
            -f64::from_bits(super::super::LARGEST.to_bits() + 1),
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NAN,
        ];
        let mut seen = [0; 2];
        for &a in &edges {
            for &b in &edges {
                for color in [None, Some((a, 0.5, b)), Some((1.0, b, a))] {
                    let s = SphereSpec {
                        center: (a, 1.0, b),
                        radius: b,
                        color,
                    };
                    let mut checker = Checker::default();
                    let checked = checker.sphere(Origin::Inline, 0, &s);
                    assert_eq!(passing(&s), checked, "{s:?}");
                    assert_eq!(checked.is_some(), checker.problems.is_empty(), "{s:?}");
                    seen[usize::from(checked.is_some())] += 1;
                }
            }
        }
        assert!(seen[0] > 0 && seen[1] > 0, "{seen:?}");
    }
}
