//! Shadow rays towards a directional light, binned in the light's own projection.
//!
//! Every shadow ray runs parallel to the light, so projected along it each ray is a single
//! point, and only spheres whose projected disc holds that point can block it. Discs are binned
//! into a uniform grid over the plane orthogonal to the light; a query looks at the few cells
//! under a small square about its point (a packet of queries, at the cells of all of them). Spheres
//! much larger than the typical one (a ground sphere) are kept in a list tested for every ray,
//! so they do not inflate the grid.

use glam::{DVec2, DVec3};
use rayon::prelude::*;

use std::sync::Arc;

use super::bins::{Bins, CellRect};
use super::lanes::prefetch;
use super::simd::Isa;
use super::sort::{sort_by_high_bits, PARALLEL};

use super::tree::{Node, Order, Shape};
use crate::camera::Camera;
use crate::scene::{Slot, Spheres};

mod occlusion;

/// A scene's spheres binned for one light direction, in world coordinates: built once per
/// scene and light, used by every frame.
pub struct ShadowGrid {
    /// Orthonormal axes of the projection plane (world).
    axes: (DVec3, DVec3),
    origin: DVec2,
    inv_cell: f64,
    dims: (usize, usize),
    bins: Bins,
    /// Spheres tested for every ray.
    always: Vec<u32>,
    /// The largest |coordinate| + radius of any sphere: the scale of the rounding bound.
    extent: f64,
    /// Unit vector towards the light (world).
    to_light: DVec3,
    /// The ranks of the spheres in the hierarchy's order: the grid numbers a sphere by its
    /// *position* there, which its cells list and its discs are stored by, so that the discs a
    /// cell lists (spheres near each other) lie near each other in memory, whatever the scene's
    /// order.
    order: Order,
    /// Each sphere's top and its disc on the grid's plane ([`Disc`]), by position.
    discs: Vec<Disc>,
}

/// What a shadow packet reads of a binned sphere before it tests it, all rounded outward to
/// f32 (16 bytes a sphere; the centre and radius it tests are the sphere's own, in f64).
///
/// - `top`: how far its highest point lies towards the light (c·to_light + r), rounded up
///   ([`f32_up`]). A sphere can block only a ray that starts below its top, so every cell
///   lists its spheres highest (rounded) top first, and a shadow packet stops reading a cell
///   at the first one below all its open lanes (`walk` in `occlusion.rs`). Never below the
///   sphere's own top, the stop skips only spheres that cannot block.
/// - `x`, `y`, `r`: its disc on the grid's plane, the centre relative to the grid's origin
///   and the radius widened by the centre's rounding ([`Disc::new`]), so that it holds the
///   exact disc. A ray runs parallel to the light, so a sphere can block it only if its point
///   falls in the sphere's disc: the walk passes a sphere whose disc misses every open lane
///   (widened by the lane's allowance) without moving it into view coordinates or testing it.
///   In a dense cluster two in three of the spheres above a point miss it so (a cell is as
///   wide as a median disc).
#[derive(Clone, Copy, Debug)]
#[repr(C, align(16))]
struct Disc {
    top: f32,
    x: f32,
    y: f32,
    r: f32,
}

impl Disc {
    /// The disc of centre `c` (on the grid's plane, relative to its origin) and `radius`, and
    /// `top`. An f32 centre lies within 2⁻²⁴ of its coordinates' sizes from the f64 one: the
    /// radius grows by four times that (a margin), is rounded up, and then goes one f32 step
    /// further (more than any growth the f64 sum lost, and than a subnormal centre's rounding).
    /// A centre beyond f32's range is infinite, and so is its radius.
    fn new(c: DVec2, radius: f64, top: f64) -> Disc {
        let rounding = match c.abs().max_element() < f32::MAX as f64 {
            true => (c.x.abs() + c.y.abs()) * (1.0 / (1u64 << 22) as f64),
            false => f64::INFINITY,
        };
        Disc {
            top: f32_up(top),
            x: c.x as f32,
            y: c.y as f32,
            r: f32_up(radius + rounding).next_up(),
        }
    }
}

impl ShadowGrid {
    /// Bins `spheres` for the light arriving from `to_light` (world, unit), numbering them by
    /// their positions in `order` (ranks, each once).
    pub fn build(spheres: &Spheres, order: Order, to_light: DVec3) -> ShadowGrid {
        debug_assert_eq!(order.len(), spheres.len(), "a position for every sphere");
        let axes = to_light.any_orthonormal_pair();
        let project = |c: DVec3| DVec2::new(c.dot(axes.0), c.dot(axes.1));
        let (big, median) = big_radius(spheres);
        let always: Vec<u32> = (0..spheres.len() as u32)
            .filter(|k| spheres.ball(*k as usize).1 > big)
            .collect();
        // Maxima and minima (exact, so the same in any order), in one pass on the pool: the
        // extent of every sphere, the projected bounds and count of the binned ones.
        let none = || (0.0, DVec2::INFINITY, DVec2::NEG_INFINITY, 0usize);
        let (extent, lo, hi, count) = spheres
            .par_balls()
            .with_min_len(PARALLEL)
            .fold(none, |(extent, lo, hi, n), (center, radius)| {
                let extent = f64::max(extent, center.abs().max_element() + radius);
                if radius > big {
                    return (extent, lo, hi, n);
                }
                let p = project(center);
                (extent, lo.min(p - radius), hi.max(p + radius), n + 1)
            })
            .reduce(none, |a, b| {
                (a.0.max(b.0), a.1.min(b.1), a.2.max(b.2), a.3 + b.3)
            });
        let mut grid = ShadowGrid {
            axes,
            origin: DVec2::ZERO,
            inv_cell: 0.0,
            dims: (0, 0),
            bins: Bins::empty(),
            always,
            extent,
            to_light,
            order,
            discs: Vec::new(),
        };
        if count == 0 {
            return grid;
        }
        (grid.dims, grid.inv_cell) = grid_size(hi - lo, count, median);
        grid.origin = lo;
        // Binned highest top first (equal tops by position), so every cell lists them so: one
        // radix sort of 8 bytes a sphere, its top's order above its position ([`top_order`]),
        // the keys made in position order (so equal tops stay in it). A sphere tested for every
        // ray gets the largest key, and is cut off after the sort. Each binned disc's cells are
        // found in position order and gathered into the sorted order, so that binning reads
        // them in sequence, not the spheres at random. The spheres are read in the hierarchy's
        // order, the one GATHER_AHEAD places on asked for each time.
        let disc_of = |p: usize, k: u32| {
            if p + GATHER_AHEAD < grid.order.len() {
                prefetch_sphere(spheres, grid.order.rank(p + GATHER_AHEAD) as usize);
            }
            let (center, radius) = spheres.ball(k as usize);
            let top = center.dot(to_light) + radius;
            let disc = Disc::new(project(center) - lo, radius, top);
            if radius > big {
                return (disc, (u64::MAX, u64::MAX));
            }
            let cells = cell_key(grid.cell_range(project(center), radius));
            (
                disc,
                (cells, u64::from(!top_order(disc.top)) << 32 | p as u64),
            )
        };
        let (discs, (cells, keys)): (Vec<Disc>, (Vec<u64>, Vec<u64>)) = (0..grid.order.len())
            .into_par_iter()
            .with_min_len(PARALLEL)
            .map(|p| disc_of(p, grid.order.rank(p)))
            .unzip();
        grid.discs = discs;
        let mut keys = sort_by_high_bits(keys, 32);
        keys.truncate(count);
        let sorted_places: Vec<u32> = keys
            .par_iter()
            .with_min_len(PARALLEL)
            .map(|&key| key as u32)
            .collect();
        drop(keys);
        let sorted: Vec<u64> = sorted_places
            .par_iter()
            .with_min_len(PARALLEL)
            .map(|&p| cells[p as usize])
            .collect();
        drop(cells);
        let rect_at = |i: usize| Some(cell_rect(sorted[i]));
        // A quarter of the discs a task (at least PARALLEL), each task counting its own over the
        // whole grid, when the tasks' counts (a grid's worth of u32 each) take no more room
        // than the discs: each disc is read twice, not twice per band of rows. A grid of many
        // more cells than discs (small discs far apart) in bands.
        let (dims, chunk) = (grid.dims, count.div_ceil(4).max(PARALLEL));
        grid.bins = if dims.0 * dims.1 * count.div_ceil(chunk) <= count {
            Bins::build(dims, &sorted_places, chunk, rect_at)
        } else {
            Bins::build_in_bands(dims, &sorted_places, rect_at)
        };
        grid
    }

    /// The cells a disc of `radius` about projected point `c` overlaps, clamped to the grid.
    /// A grid coordinate clamped to [0, last] and then cut to an integer is the clamped floor
    /// of it (NaN gives 0 either way), without a call to `floor` (the libm crate's, in
    /// software, through glam).
    fn cell_range(&self, c: DVec2, radius: f64) -> CellRect {
        let a = (c - radius - self.origin) * self.inv_cell;
        let b = (c + radius - self.origin) * self.inv_cell;
        let clampx = |v: f64| v.max(0.0).min(self.dims.0 as f64 - 1.0) as usize;
        let clampy = |v: f64| v.max(0.0).min(self.dims.1 as f64 - 1.0) as usize;
        (clampx(a.x), clampx(b.x), clampy(a.y), clampy(b.y))
    }
}

/// `v` rounded up to an f32 (towards +∞): the least f32 not below it (a value beyond f32's
/// range becomes infinite). The grid's tops and discs, and the hierarchy's boxes.
pub(super) fn f32_up(v: f64) -> f32 {
    let rounded = v as f32;
    if (rounded as f64) < v {
        rounded.next_up()
    } else {
        rounded
    }
}

/// `v` rounded down to an f32 (towards −∞): never above `v`. The hierarchy's boxes.
pub(super) fn f32_down(v: f64) -> f32 {
    let rounded = v as f32;
    if rounded as f64 > v {
        rounded.next_down()
    } else {
        rounded
    }
}

/// The key of the cell range (x0, x1, y0, y1), 16 bits each (the grid is at most 4096 a side):
/// how the build orders binned discs' cells and a shadow packet groups its lanes.
#[inline(always)]
fn cell_key((x0, x1, y0, y1): CellRect) -> u64 {
    x0 as u64 | (x1 as u64) << 16 | (y0 as u64) << 32 | (y1 as u64) << 48
}

/// The cell range of a [`cell_key`].
#[inline(always)]
fn cell_rect(key: u64) -> CellRect {
    let field = |shift: u32| (key >> shift) as u16 as usize;
    (field(0), field(16), field(32), field(48))
}

/// An f32's bits as an unsigned integer in the order of the values (`f32::total_cmp`'s), for
/// sorting on integer keys.
fn top_order(top: f32) -> u32 {
    let bits = top.to_bits();
    if bits >> 31 == 1 {
        !bits
    } else {
        bits | 1 << 31
    }
}

/// Where a frame's shadow rays look for the spheres that may block them: the light's grid, or,
/// before it is built, the scene's hierarchy ([`Hierarchy`]). Either way every sphere that blocks a
/// ray is tested, so the answers are the same.
#[derive(Clone, Copy)]
pub enum Casters<'a> {
    Grid(&'a ShadowGrid),
    Hierarchy(Hierarchy<'a>),
}

/// The scene's hierarchy as a shadow packet walks it (`occlusion.rs`): its nodes (the root
/// first), the spheres' shapes and ranks in its order, and the unit vector towards the light
/// (world). A renderer's first frame takes its shadow rays through it, so that a scene past the
/// whole copy along the curve shows its first frame without waiting for the grid
/// (docs/performance.md).
#[derive(Clone, Copy)]
pub struct Hierarchy<'a> {
    pub nodes: &'a [Node],
    pub shapes: &'a [Shape],
    pub order: &'a Order,
    pub to_light: DVec3,
}

/// One light's shadow rays in one frame: the scene's grid or hierarchy, the frame's camera, and
/// the light and its always-tested spheres in view coordinates.
pub struct FrameShadows<'a> {
    /// The light's grid, or one of no cells when the hierarchy is walked instead (`tree`).
    grid: &'a ShadowGrid,
    camera: Camera,
    spheres: &'a Spheres,
    /// Unit vector towards the light, view coordinates.
    to_light: DVec3,
    /// The grid's always-tested spheres: (index, centre in view coordinates, r²).
    always: Vec<(u32, DVec3, f64)>,
    /// Every sphere's centre in view coordinates and r², when the frame computed them all
    /// (small scenes); otherwise each blocker is moved into view coordinates when tested.
    centers: Option<Arc<[(DVec3, f64)]>>,
    /// The light's plane (the grid's, or any orthogonal to the light for the hierarchy) from
    /// view coordinates: a point p falls at (p·axes.0 + offset.x, p·axes.1 + offset.y) on it,
    /// relative to the grid's origin (the world's for the hierarchy).
    axes: (DVec3, DVec3),
    offset: DVec2,
    /// The part of the rounding allowance that does not depend on the point.
    slack: f64,
    /// A view point p lies p·up + height towards the light, on the scale of the grid's tops:
    /// a sphere whose top is below that, less the rounding allowance, cannot block its ray.
    /// (Blocking needs the point inside the sphere or the sphere ahead along the ray: either
    /// way (p − c)·to_light ≤ r.)
    up: DVec3,
    height: f64,
    /// The hierarchy, when its walk stands for the grid's, and the instruction set it is run on.
    tree: Option<(Hierarchy<'a>, Isa)>,
    /// The light's plane's axes in world coordinates.
    world_axes: (DVec3, DVec3),
}

/// A grid of no cells, for a frame whose shadow rays walk the hierarchy.
fn no_grid() -> &'static ShadowGrid {
    static NONE: std::sync::OnceLock<ShadowGrid> = std::sync::OnceLock::new();
    NONE.get_or_init(|| ShadowGrid {
        axes: (DVec3::X, DVec3::Y),
        origin: DVec2::ZERO,
        inv_cell: 0.0,
        dims: (0, 0),
        bins: Bins::empty(),
        always: Vec::new(),
        extent: 0.0,
        to_light: DVec3::Z,
        order: Order::Positions(0),
        discs: Vec::new(),
    })
}

/// How many places ahead the grid's build asks for a sphere, reading them in the hierarchy's
/// order.
const GATHER_AHEAD: usize = 16;

/// Scenes up to this many spheres have every centre moved into view coordinates once per frame
/// for the shadow rays; larger ones move only the blockers they test, so that a frame's cost
/// stays with what it sees.
pub const ALL_CENTERS: usize = 1 << 16;

/// Asks for sphere `k`'s centre and radius: a hint ahead of its read, which changes no value.
#[inline(always)]
pub(in crate::render) fn prefetch_sphere(spheres: &Spheres, k: usize) {
    match spheres.slot(k) {
        Slot::Wide(s) => prefetch(s),
        Slot::Packed(ball) => prefetch(ball),
    }
}

/// Sphere `s`'s centre in view coordinates and r², to the bits of `ViewSphere::new`.
#[inline(always)]
pub fn view_center(camera: &Camera, (center, radius): (DVec3, f64)) -> (DVec3, f64) {
    (camera.point_to_view(center), radius * radius)
}

impl<'a> FrameShadows<'a> {
    pub fn new(
        isa: Isa,
        casters: Casters<'a>,
        camera: &Camera,
        spheres: &'a Spheres,
        centers: Option<Arc<[(DVec3, f64)]>>,
        to_light: DVec3,
    ) -> FrameShadows<'a> {
        // The plane's axes and origin, the extent of the scene (the largest |coordinate| +
        // radius of a sphere, or of the hierarchy's root box), the light, the spheres tested
        // for every ray.
        let (world_axes, origin, extent, to_light_world, always) = match casters {
            Casters::Grid(g) => (g.axes, g.origin, g.extent, g.to_light, &g.always[..]),
            Casters::Hierarchy(t) => {
                let extent = t.nodes.first().map_or(0.0, |root| {
                    let [lo, hi] = root.bounds();
                    lo.abs().max(hi.abs()).max_element()
                });
                let axes = t.to_light.any_orthonormal_pair();
                (axes, DVec2::ZERO, extent, t.to_light, &[][..])
            }
        };
        let (grid, tree) = match casters {
            Casters::Grid(grid) => (grid, None),
            Casters::Hierarchy(tree) => (no_grid(), Some((tree, isa))),
        };
        let mut shadows = FrameShadows {
            grid,
            tree,
            camera: *camera,
            spheres,
            to_light,
            always: Vec::new(),
            centers,
            axes: (
                camera.basis.to_view(world_axes.0),
                camera.basis.to_view(world_axes.1),
            ),
            offset: DVec2::new(
                camera.vrp_world.dot(world_axes.0),
                camera.vrp_world.dot(world_axes.1),
            ) - origin,
            world_axes,
            slack: camera.vrp_world.abs().max_element() + extent,
            up: camera.basis.to_view(to_light_world),
            height: camera.vrp_world.dot(to_light_world),
        };
        shadows.always = always.iter().map(|&k| shadows.blocker(k)).collect();
        shadows
    }

    /// Sphere k with its centre in view coordinates and r² ([`view_center`]).
    #[inline(always)]
    fn blocker(&self, k: u32) -> (u32, DVec3, f64) {
        let (c, r2) = match &self.centers {
            Some(all) => all[k as usize],
            None => view_center(&self.camera, self.spheres.ball(k as usize)),
        };
        (k, c, r2)
    }

    /// Asks for the disc of the sphere at position `p` of the grid's order and, as
    /// [`FrameShadows::blocker`] reads them, its centre and radius: a hint ahead of its test,
    /// which changes no value.
    #[inline(always)]
    fn prefetch_blocker(&self, p: u32) {
        prefetch(&self.grid.discs[p as usize]);
        let k = self.grid.order.rank(p as usize);
        match &self.centers {
            Some(all) => prefetch(&all[k as usize]),
            None => prefetch_sphere(self.spheres, k as usize),
        }
    }
}

/// No shadow hint (see [`FrameShadows::occluded`]).
pub(super) const NO_HINT: u32 = u32::MAX;

/// The lights whose shadow packets keep a hint along a row or band.
pub(super) const HINTED_LIGHTS: usize = 4;

/// A row's or band's shadow hints, one per light (the first [`HINTED_LIGHTS`]).
pub(super) type Hints = [u32; HINTED_LIGHTS];

/// Spheres larger than the first of these (16 × the median radius, like a ground sphere) are
/// tested for every ray instead of being binned, so they do not inflate the grid; the second is
/// the median radius, of every sphere up to [`MEDIAN_SAMPLE`] of them, else of that many evenly
/// spaced in the scene's order (both only size the grid: every sphere is tested or binned
/// whatever they are, so the answers do not depend on them).
pub(super) fn big_radius(spheres: &Spheres) -> (f64, f64) {
    let step = spheres.len().div_ceil(MEDIAN_SAMPLE).max(1);
    let mut radii: Vec<f64> = (0..spheres.len())
        .step_by(step)
        .map(|k| spheres.ball(k).1)
        .collect();
    if radii.is_empty() {
        return (f64::INFINITY, 0.0);
    }
    let mid = radii.len() / 2;
    let median = *radii.select_nth_unstable_by(mid, f64::total_cmp).1;
    (median * 16.0, median)
}

/// The most radii [`big_radius`] takes the median of.
const MEDIAN_SAMPLE: usize = 1 << 16;

/// The most cells a disc of the median radius may cover: a grid fine enough for eight cells a
/// disc over the whole extent would, in a dense cluster whose discs overlap many deep, bin each
/// disc into a hundred cells (98 M items at 1 M spheres); cells are widened until the median
/// disc covers at most 2 × 2 of them, cells as wide as its diameter (4.1 M items at 1 M
/// spheres, 16 MB). Finer cells list fewer spheres each, but a packet's lanes spread over more
/// of them (docs/performance.md).
const CELLS_A_DISC: f64 = 4.0;

/// Cells over an `extent` holding `count` discs: about eight cells per disc, at most 4096 a side
/// (fewer spheres to test per shadow ray than with two; a shadow packet whose lanes span a few
/// cells walks them once).
/// Cells are no smaller than makes a disc of the `median` radius cover [`CELLS_A_DISC`] of them
/// (about (2r / cell + 1)² cells).
/// Returns the cell counts and 1 / cell size.
fn grid_size(extent: DVec2, count: usize, median: f64) -> ((usize, usize), f64) {
    let extent = extent.max(DVec2::splat(1e-300));
    let cell = (extent.x * extent.y / (8.0 * count as f64))
        .sqrt()
        .max(extent.x.max(extent.y) / 4096.0)
        .max(2.0 * median / (CELLS_A_DISC.sqrt() - 1.0));
    let dims = (
        ((extent.x / cell).ceil() as usize).clamp(1, 4096),
        ((extent.y / cell).ceil() as usize).clamp(1, 4096),
    );
    (dims, 1.0 / cell)
}

#[cfg(test)]
pub(super) mod tests {
    use super::super::oracle::blocks_ray;
    use super::*;
    use crate::camera::Basis;
    use crate::scene::Sphere;
    use crate::splitmix::SplitMix;
    use glam::DVec2;

    /// A cluster of spheres over a ground sphere, a camera beside it, two slanted lights with
    /// their grids, and 40 view points spread over each sphere (a spiral, the lit side and the
    /// dark) with the sphere each lies on.
    pub(in crate::render) struct Cluster {
        pub spheres: Spheres,
        pub camera: Camera,
        pub lights: Vec<ClusterLight>,
        pub points: Vec<(DVec3, u32)>,
    }

    /// One of [`Cluster`]'s lights: its world direction of travel, its grid, and the unit
    /// vector towards it in view coordinates.
    pub(in crate::render) struct ClusterLight {
        pub direction: DVec3,
        pub grid: ShadowGrid,
        pub to_light: DVec3,
    }

    /// A coordinate of the kind `k % 5` picks, drawn from `gen`: zero, an f32's value, a
    /// subnormal, one beyond f32's range, or one of any size from 10⁻⁸ to 10¹⁶, either sign.
    pub(in crate::render) fn coordinate_of_kind(gen: &mut SplitMix, k: usize) -> f64 {
        match k % 5 {
            0 => 0.0,
            1 => (gen.unit() * 40.0 - 20.0) as f32 as f64,
            2 => 1e-40 * (gen.unit() - 0.5),
            3 => 1e39 * (gen.unit() - 0.5),
            _ => (gen.unit() - 0.5) * 10f64.powf(gen.unit() * 24.0 - 8.0),
        }
    }

    /// The ranks 0..n last first: a grid's order in which no sphere's position is its rank.
    pub(in crate::render) fn reversed(n: usize) -> Order {
        Order::Listed(Arc::new((0..n as u32).rev().collect()))
    }

    pub(in crate::render) fn cluster() -> Cluster {
        seeded_cluster(11, 300, 40)
    }

    /// A [`cluster`] from seed `seed`: `n` spheres in its box over the ground (from sparse to
    /// discs many deep) and `each` view points a sphere.
    pub(in crate::render) fn seeded_cluster(seed: u64, n: usize, each: usize) -> Cluster {
        let mut gen = SplitMix(seed);
        let mut spheres: Vec<Sphere> = (0..n)
            .map(|_| {
                let mut r = || gen.unit();
                Sphere {
                    center_world: DVec3::new(r() * 20.0 - 10.0, r() * 5.0, r() * 20.0 - 10.0),
                    radius: 0.2 + r() * 0.7,
                    color: DVec3::ONE,
                }
            })
            .collect();
        spheres.push(Sphere {
            center_world: DVec3::new(0.0, -10_000.0, 0.0),
            radius: 10_000.0,
            color: DVec3::ONE,
        });
        let camera = Camera {
            vrp_world: DVec3::new(-15.0, 7.0, -9.0),
            basis: Basis::from_vpn_vuv(DVec3::new(1.0, -0.3, 0.6), DVec3::Y).unwrap(),
            cop_view: DVec3::new(0.0, 0.0, -1.2),
            window: DVec2::new(1.6, 0.9),
        };
        let mut points = Vec::new();
        for (own, s) in spheres.iter().enumerate() {
            let center = view_center(&camera, s.ball()).0;
            for k in 0..each {
                let z = 1.0 - 2.0 * (k as f64 + 0.5) / each as f64;
                let a = k as f64 * 2.399963;
                let w = (1.0 - z * z).sqrt();
                let normal = DVec3::new(w * a.cos(), z, w * a.sin());
                points.push((center + normal * s.radius, own as u32));
            }
        }
        let spheres = Spheres::from(spheres);
        let lights = [DVec3::new(-0.6, -1.0, 0.4), DVec3::new(0.9, -0.2, -0.1)]
            .into_iter()
            .map(|direction| {
                let to_light = -direction.normalize();
                ClusterLight {
                    direction,
                    grid: ShadowGrid::build(&spheres, reversed(spheres.len()), to_light),
                    to_light: camera.basis.to_view(to_light),
                }
            })
            .collect();
        Cluster {
            spheres,
            camera,
            lights,
            points,
        }
    }

    /// A disc's cells are the clamped floors of its edges' grid coordinates (`f64::floor`),
    /// over edges inside, on and beside cell boundaries, off either side, huge and not a
    /// number.
    #[test]
    fn a_discs_cells_are_the_clamped_floors_of_its_edges() {
        let spheres: Spheres = (0..50)
            .map(|k| Sphere {
                center_world: DVec3::new(k as f64 * 0.37, (k % 7) as f64, (k % 5) as f64 * 0.5),
                radius: 0.2,
                color: DVec3::ONE,
            })
            .collect();
        let to_light = DVec3::new(0.2, 1.0, -0.1).normalize();
        let grid = ShadowGrid::build(&spheres, reversed(spheres.len()), to_light);
        let (w, h) = grid.dims;
        assert!(w > 4 && h > 4, "{:?}", grid.dims);
        let cell = 1.0 / grid.inv_cell;
        let floor = |v: f64, n: usize| v.floor().max(0.0).min(n as f64 - 1.0) as usize;
        let mut rng = crate::splitmix::SplitMix(0xce11);
        for k in 0..20_000 {
            let mut at = |n: usize| {
                let u = rng.unit() * 1.4 - 0.2;
                let v = (u * n as f64).round() * cell;
                // On a boundary, an ulp either side of one, or anywhere.
                match k % 4 {
                    0 => v,
                    1 => v.next_up(),
                    2 => v.next_down(),
                    _ => u * n as f64 * cell,
                }
            };
            let c = grid.origin + DVec2::new(at(w), at(h));
            let r = [0.0, 1e-12, 0.3 * cell, 2.5 * cell, 1e300][k % 5];
            let (a, b) = (
                (c - r - grid.origin) * grid.inv_cell,
                (c + r - grid.origin) * grid.inv_cell,
            );
            let want = (floor(a.x, w), floor(b.x, w), floor(a.y, h), floor(b.y, h));
            assert_eq!(grid.cell_range(c, r), want, "{c} {r}");
        }
        let nan = DVec2::new(f64::NAN, 1.0);
        assert_eq!(grid.cell_range(nan, 0.1).0, 0);
    }

    /// A disc holds the exact one: its f32 centre is no farther from the f64 centre than its
    /// radius is beyond the f64 radius (the distance in f64 taken 10⁻¹⁵ larger),
    /// for centres of every size and sign (where one f32 step is many radii), on f32's
    /// values, subnormal, beyond its range, and radii from tiny to huge.
    #[test]
    fn a_disc_holds_the_exact_disc() {
        let mut gen = SplitMix(0xd15c);
        let mut coordinate = |k: usize| coordinate_of_kind(&mut gen, k);
        let mut checked = [0; 2];
        for k in 0..50_000 {
            let c = DVec2::new(coordinate(k), coordinate(k / 5));
            let radius = [1e-30, 1e-6, 0.07, 3.0, 1e300][k % 7 % 5];
            let disc = Disc::new(c, radius, 0.0);
            let moved = (DVec2::new(disc.x as f64, disc.y as f64) - c).length();
            let beyond = disc.r as f64 - radius;
            assert!(
                moved * (1.0 + 1e-15) <= beyond,
                "{c} radius {radius}: moved {moved}, widened {beyond}"
            );
            checked[(moved > radius) as usize] += 1;
        }
        // Centres that f32 moves by more than the radius itself are among them.
        assert!(checked.iter().all(|&n| n > 1000), "{checked:?}");
    }

    /// Every value rounds to the least f32 not below it, over values of every magnitude and
    /// sign, those f32 holds exactly, and those beyond its range; and the tops' integer keys
    /// sort as the values do.
    #[test]
    fn values_round_up_to_the_next_f32() {
        let mut gen = SplitMix(3);
        let mut values: Vec<f64> = (0..20_000)
            .map(|k| {
                let magnitude = 10f64.powf(gen.unit() * 80.0 - 40.0);
                let sign = if k % 2 == 0 { 1.0 } else { -1.0 };
                sign * magnitude
            })
            .collect();
        values.extend([
            0.0,
            -0.0,
            1.0,
            -1.0,
            1.3,
            -1.3,
            1e39,
            -1e39,
            f32::MAX as f64,
        ]);
        values.extend((0..1000).map(|k| (k as f32 * 0.37 - 150.0) as f64));
        for &t in &values {
            let top = f32_up(t);
            assert!(top as f64 >= t, "{t} rounded to {top}");
            // No f32 between: the next one down is below t (there is none below -f32::MAX).
            if top > -f32::MAX {
                assert!((top.next_down() as f64) < t, "{t} rounded to {top}");
            }
        }
        // The integer keys sort as the values do.
        let floats: Vec<f32> = values.iter().map(|&t| t as f32).collect();
        for pair in floats.windows(2) {
            let (a, b) = (pair[0], pair[1]);
            assert_eq!(top_order(a).cmp(&top_order(b)), a.total_cmp(&b), "{a} {b}");
        }
    }

    /// Over seeded clusters from sparse to dense, every cell lists its spheres highest top
    /// first, each top at or above the sphere's own (c·to_light + r in f64), and every sphere
    /// not tested for every ray is in the cell under its centre.
    #[test]
    fn cells_list_their_spheres_highest_top_first() {
        for (seed, n) in [(3, 150), (5, 700), (7, 1500)] {
            let c = seeded_cluster(seed, n, 0);
            for light in &c.lights {
                let grid = &light.grid;
                let to_light = -light.direction.normalize();
                for (p, &Disc { top, .. }) in grid.discs.iter().enumerate() {
                    let s = c.spheres.get(grid.order.rank(p) as usize);
                    assert!(top as f64 >= s.center_world.dot(to_light) + s.radius);
                }
                let mut listed = vec![false; c.spheres.len()];
                for y in 0..grid.dims.1 {
                    for x in 0..grid.dims.0 {
                        let cell = grid.bins.cell(x, y);
                        highest_top_first(grid, cell);
                        let (ax, ay) = grid.axes;
                        for k in cell.iter().map(|&p| grid.order.rank(p as usize)) {
                            let p = c.spheres.get(k as usize).center_world;
                            let at =
                                (DVec2::new(p.dot(ax), p.dot(ay)) - grid.origin) * grid.inv_cell;
                            listed[k as usize] |=
                                at.x.floor() as usize == x && at.y.floor() as usize == y;
                        }
                    }
                }
                for (k, s) in c.spheres.iter().enumerate() {
                    let binned = !grid.always.contains(&(k as u32));
                    assert_eq!(listed[k], binned, "sphere {k}, radius {}", s.radius);
                }
            }
        }
    }

    /// Asserts that `cell` lists its spheres highest top first, equal tops by position; returns
    /// how many equal tops it holds.
    fn highest_top_first(grid: &ShadowGrid, cell: &[u32]) -> usize {
        let mut ties = 0;
        for pair in cell.windows(2) {
            let [a, b] = [pair[0], pair[1]].map(|k| grid.discs[k as usize].top);
            assert!(
                a > b || (a == b && pair[0] < pair[1]),
                "{pair:?}: {a} before {b}"
            );
            ties += usize::from(a == b);
        }
        ties
    }

    /// Spheres with equal tops (a cluster's first 300 spheres, then all of them again) are
    /// listed by their positions in the grid's order (here the ranks last first).
    #[test]
    fn equal_tops_are_listed_by_position() {
        let c = seeded_cluster(11, 300, 0);
        let spheres: Spheres = c.spheres.iter().take(300).chain(&c.spheres).collect();
        let to_light = -DVec3::new(-0.6, -1.0, 0.4).normalize();
        let grid = ShadowGrid::build(&spheres, reversed(spheres.len()), to_light);
        let (w, h) = grid.dims;
        let ties: usize = (0..w * h)
            .map(|k| highest_top_first(&grid, grid.bins.cell(k % w, k / w)))
            .sum();
        assert!(ties >= 300, "{ties} equal tops");
    }

    impl Cluster {
        /// Whether any sphere but `own` blocks the ray from `point` towards the light
        /// (`to_light`, view coordinates).
        pub(in crate::render) fn any_blocker(
            &self,
            to_light: DVec3,
            (point, own): (DVec3, u32),
        ) -> bool {
            self.spheres.iter().enumerate().any(|(o, other)| {
                let (c, r2) = view_center(&self.camera, other.ball());
                o as u32 != own && blocks_ray(c, r2, point, to_light)
            })
        }
    }
}
