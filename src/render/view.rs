//! The frame's spheres and lights in view coordinates.

use glam::DVec3;
use rayon::prelude::*;

use super::lanes::prefetch;
use super::shadows::{prefetch_sphere, FrameShadows};
use super::sort::PARALLEL;
use crate::camera::Camera;
use crate::scene::Spheres;

/// A sphere in view coordinates, with the terms every primary ray shares: made one at a time,
/// kept per field in [`ViewColumns`].
#[derive(Debug, Clone, Copy)]
pub(super) struct ViewSphere {
    pub(super) center: DVec3,
    pub(super) radius: f64,
    /// COP − centre (the columns find it from the centre).
    #[cfg(test)]
    pub(super) f: DVec3,
    /// |f| − r: no primary ray meets the sphere nearer than this.
    pub(super) min_dist: f64,
    /// The sphere's rank (see [`Ranks`]).
    pub(super) id: u32,
}

impl ViewSphere {
    /// `sphere` moved camera-relative into view coordinates: the VRP is subtracted first, so a
    /// scene far from the origin keeps its precision.
    pub(super) fn new(camera: &Camera, (center, radius): (DVec3, f64), id: u32) -> ViewSphere {
        let center = camera.point_to_view(center);
        ViewSphere::in_view(center, radius, camera.cop_view, id)
    }

    /// A sphere of centre `center` (view coordinates) seen from `cop_view`.
    pub(super) fn in_view(center: DVec3, radius: f64, cop_view: DVec3, id: u32) -> ViewSphere {
        let f = cop_view - center;
        ViewSphere {
            center,
            radius,
            #[cfg(test)]
            f,
            min_dist: f.length() - radius,
            id,
        }
    }
}

/// c = |f|² − r², which the columns do not keep: the search's term, made by this one function
/// wherever it is needed, so that it is the same bits everywhere.
#[inline(always)]
pub(super) fn c_of(f: DVec3, radius: f64) -> f64 {
    f.length_squared() - radius * radius
}

/// What the screen tiles read of a view sphere: where it lies from the COP, and its size.
#[derive(Debug, Clone, Copy)]
pub(super) struct Reach {
    /// COP − centre.
    pub(super) f: DVec3,
    pub(super) radius: f64,
    /// |f| − r.
    pub(super) min_dist: f64,
}

/// The frame's spheres in view coordinates, one slice per field, in the order of the spheres:
/// the hit search reads a candidate's terms by its index, and a packet whose lanes hit several
/// spheres gathers their fields lane by lane (`Lanes::gather`). Only what the search, the
/// tiles and the shading read, 52 bytes a sphere: f (COP − centre), c = |f|² − r² and r² are
/// found where they are needed, by the operations [`ViewSphere::in_view`] does, and a hit
/// sphere's colour from its code (packed spheres) or from the scene by its rank.
pub(super) struct ViewColumns {
    /// The COP, in view coordinates: f = cop − centre.
    pub(super) cop: DVec3,
    /// No primary ray meets the sphere nearer than this: |f| − r.
    pub(super) min_dist: Vec<f64>,
    pub(super) radius: Vec<f64>,
    /// The centre, moved into view coordinates: what the shading's hit points are made from
    /// (moving it again for each packet it shades would cost fly1000 a tenth of its time).
    pub(super) center: [Vec<f64>; 3],
    /// The spheres' ranks (see [`Ranks`]).
    pub(super) id: Vec<u64>,
    /// Each sphere's colour code, when `coded` ([`Spheres::color_codes`]): a hit's colour is
    /// found from it, not read from the scene by rank at random. Otherwise left unwritten.
    pub(super) color: Vec<u32>,
    /// Whether `color` holds the spheres' codes (packed spheres'), or colours are read by rank.
    pub(super) coded: bool,
}

impl ViewColumns {
    /// `n` spheres of zeros, in fresh memory the kernel hands over zeroed (untouched until
    /// written), with room for `room` (at least `n`).
    fn zeroed(n: usize, room: usize) -> ViewColumns {
        let column = || {
            let mut column = vec![0.0; room.max(n)];
            column.truncate(n);
            column
        };
        let mut id = vec![0; room.max(n)];
        id.truncate(n);
        let mut color = vec![0; room.max(n)];
        color.truncate(n);
        ViewColumns {
            cop: DVec3::ZERO,
            min_dist: column(),
            radius: column(),
            center: [column(), column(), column()],
            id,
            color,
            coded: false,
        }
    }

    /// The spheres `ids` of `spheres`, as `camera` sees them, in the order of `ids`. Each
    /// column is written in place, a chunk at a time on the pool when there are many: no
    /// second copy of the spheres, and the columns' fresh pages faulted in by every core.
    /// `spare`, an earlier frame's columns, is written over when it has room: its pages are
    /// already the process's (at a million spheres, 48 MB a frame the kernel need not fault
    /// in and clear again).
    pub(super) fn of(
        camera: &Camera,
        spheres: &Spheres,
        ids: &[u32],
        spare: Option<ViewColumns>,
    ) -> ViewColumns {
        let n = ids.len();
        let mut columns = match spare {
            Some(mut columns) if columns.id.capacity() >= n => {
                columns.set_len(n);
                columns
            }
            // Room for a quarter more, which costs no memory until written: the next frames
            // mostly see about as many spheres, and write over these instead of fresh pages.
            _ => ViewColumns::zeroed(n, n + n / 4),
        };
        columns.cop = camera.cop_view;
        let codes = spheres.color_codes();
        columns.coded = codes.is_some();
        let ([min_dist, radius, x0, x1, x2], id, color) = columns.columns_mut();
        let fill = |ids: &[u32], out: Chunk| {
            let (min_dist, radius, x0, x1, x2, id, color) = out;
            for (i, &k) in ids.iter().enumerate() {
                // The ids follow the hierarchy, not the scene's order: a sphere some way
                // ahead is asked for now, so that its read overlaps this one's work.
                if let Some(&ahead) = ids.get(i + PREFETCH_AHEAD) {
                    prefetch_sphere(spheres, ahead as usize);
                    if let Some(codes) = codes {
                        prefetch(&codes[ahead as usize]);
                    }
                }
                let s = ViewSphere::new(camera, spheres.ball(k as usize), k);
                min_dist[i] = s.min_dist;
                radius[i] = s.radius;
                (x0[i], x1[i], x2[i]) = (s.center.x, s.center.y, s.center.z);
                id[i] = s.id as u64;
                if let Some(codes) = codes {
                    color[i] = codes[k as usize];
                }
            }
        };
        if n >= PARALLEL {
            (
                min_dist.par_chunks_mut(PARALLEL),
                radius.par_chunks_mut(PARALLEL),
                x0.par_chunks_mut(PARALLEL),
                x1.par_chunks_mut(PARALLEL),
                x2.par_chunks_mut(PARALLEL),
                id.par_chunks_mut(PARALLEL),
                color.par_chunks_mut(PARALLEL),
                ids.par_chunks(PARALLEL),
            )
                .into_par_iter()
                .for_each(|(a, b, c, d, e, id, color, ids)| fill(ids, (a, b, c, d, e, id, color)));
        } else {
            fill(ids, (min_dist, radius, x0, x1, x2, id, color));
        }
        columns
    }

    /// The five f64 columns in the order of the fields (the centre after the radius), the ids
    /// and the colour codes.
    fn columns_mut(&mut self) -> ([&mut Vec<f64>; 5], &mut Vec<u64>, &mut Vec<u32>) {
        let ViewColumns {
            cop: _,
            coded: _,
            min_dist,
            radius,
            center: [x0, x1, x2],
            id,
            color,
        } = self;
        ([min_dist, radius, x0, x1, x2], id, color)
    }

    /// Every column `n` long, in the room it has: the values kept are written over by
    /// [`ViewColumns::of`], any added are zeros.
    fn set_len(&mut self, n: usize) {
        let (floats, id, color) = self.columns_mut();
        for column in floats {
            column.resize(n, 0.0);
        }
        id.resize(n, 0);
        color.resize(n, 0);
    }

    /// Sphere `k`'s colour, from its code or read from `scene` by its rank (`scene` is the
    /// one the columns were made of).
    #[inline(always)]
    pub(super) fn color(&self, scene: &Spheres, k: usize) -> DVec3 {
        match self.coded {
            true => scene.color_of_code(self.color[k]),
            false => scene.color(self.id[k] as usize),
        }
    }

    /// What the tiles read of sphere `k`.
    pub(super) fn reach(&self, k: usize) -> Reach {
        Reach {
            f: self.f_at(k),
            radius: self.radius[k],
            min_dist: self.min_dist[k],
        }
    }

    /// How many spheres.
    pub(super) fn len(&self) -> usize {
        self.id.len()
    }

    /// Sphere `k`'s f: COP − centre, the subtraction [`ViewSphere::new`] does.
    #[inline(always)]
    pub(super) fn f_at(&self, k: usize) -> DVec3 {
        self.cop - DVec3::new(self.center[0][k], self.center[1][k], self.center[2][k])
    }
}

/// The way from a sphere's rank (the columns' `id`) back to its scene index: the renderer
/// numbers the spheres as its `SceneIndex` holds them, which may be another order than the
/// scene's.
#[derive(Debug, Clone, Copy)]
pub struct Ranks<'a>(pub(super) Option<&'a [u32]>);

impl Ranks<'_> {
    /// Ranks that are scene indices.
    pub const SCENE: Ranks<'static> = Ranks(None);

    /// The scene index of the sphere of `rank`.
    #[inline]
    pub fn scene_index(self, rank: u32) -> u32 {
        match self.0 {
            Some(index) => index[rank as usize],
            None => rank,
        }
    }
}

/// How far ahead [`ViewColumns::of`] (and the hierarchy's leaves) ask for the spheres they
/// will read.
pub(super) const PREFETCH_AHEAD: usize = 16;

/// One chunk of each column, in [`ViewColumns`]'s order of fields (the centre after the
/// radius), for [`ViewColumns::of`] to fill.
type Chunk<'a> = (
    &'a mut [f64],
    &'a mut [f64],
    &'a mut [f64],
    &'a mut [f64],
    &'a mut [f64],
    &'a mut [u64],
    &'a mut [u32],
);

/// A light in view coordinates.
pub(super) struct ViewLight<'a> {
    /// Unit vector from a surface towards the light: −direction.
    pub(super) to_light: DVec3,
    pub(super) color: DVec3,
    /// Spheres binned for this light's shadow rays; None when the light casts no shadows.
    pub(super) shadows: Option<FrameShadows<'a>>,
}

#[cfg(test)]
mod tests {
    use super::*;

    impl ViewSphere {
        /// |f|² − r², as the search finds it from f.
        pub(in crate::render) fn c(&self) -> f64 {
            c_of(self.f, self.radius)
        }

        /// What the tiles read of it.
        pub(in crate::render) fn reach(&self) -> Reach {
            Reach {
                f: self.f,
                radius: self.radius,
                min_dist: self.min_dist,
            }
        }
    }

    impl ViewColumns {
        /// `spheres`, seen from `cop`, one slice per field.
        pub(in crate::render) fn new(cop: DVec3, spheres: &[ViewSphere]) -> ViewColumns {
            let mut columns = ViewColumns::zeroed(0, 0);
            columns.cop = cop;
            columns.extend(spheres);
            columns
        }

        /// `spheres` after the ones held: each seen from the columns' COP.
        pub(in crate::render) fn extend(&mut self, spheres: &[ViewSphere]) {
            for s in spheres {
                let bits = |v: DVec3| v.to_array().map(f64::to_bits);
                assert!(
                    bits(s.f) == bits(self.cop - s.center),
                    "a sphere seen from another COP"
                );
                self.min_dist.push(s.min_dist);
                self.radius.push(s.radius);
                for a in 0..3 {
                    self.center[a].push(s.center[a]);
                }
                self.id.push(s.id as u64);
                self.color.push(0);
            }
        }
    }
}
