//! A scene indexed once, in world coordinates, for every frame: a bounding volume hierarchy over
//! the spheres, so that a frame moves into view coordinates only the spheres inside its view
//! pyramid (O(visible + log N)), and a shadow grid per shadow-casting light.
//!
//! The culling only drops spheres that no pixel's ray can meet: the pyramid through the window's
//! edges holds every ray (they pass through pixel centres, half a pixel inside), and the tests
//! are widened by far more than their rounding. Frames are byte-identical to casting against
//! every sphere.

use glam::{DVec2, DVec3};
use std::sync::{Arc, OnceLock};

use super::shadows::{
    big_radius, f32_down, f32_up, prefetch_sphere, Casters, Hierarchy, ShadowGrid,
};
use super::sort::{index_bits, sort_by_high_bits, PARALLEL};
use super::tree::{Node, Order, Shape, F32_EPS, F32_TINY};
use super::view::{Ranks, PREFETCH_AHEAD};
use crate::camera::Camera;
use crate::raster::Raster;
use crate::scene::{Light, Scene, Sphere, Spheres};

/// Spheres a pixel (of a frame at one sample a pixel, of a scene larger than the index's whole
/// copy along the curve) from which a frame keeps only the spheres that may own a pixel, found
/// by a walk of the hierarchy per tile (`cull.rs`), instead of every sphere in view. The dense
/// cluster, 2 cores, leaves of 32, median frames of five processes, not culled → culled: at 4.8
/// a pixel (ten million at 1080p) 881 → 772 ms, and the peak 1638 → 1223 MB (the spheres in
/// view are not all moved into columns). Since each tile's walk starts from the last frame's
/// seeds, at 4.3 (a million at 640×360) 74.3 → 65.3 ms (8 frames) and 75.2 → 58.0 ms (40),
/// at 2.8 (800×450) 67.6 → 64.1 ms but the first frame 240 → 292 ms, and at 1.9 (960×540)
/// 86.5 → 110.8 ms (docs/performance.md): 4 culls the first and not the others.
pub const CULL_RATIO: f64 = 4.0;

/// Spheres a pixel from which a renderer's first frame culls: its walk has no seeds to start
/// from, and it makes the walk's shapes. At a million and 640×360 (4.3 a pixel) that first
/// frame culled took 300 → 351 ms; the second culls from [`CULL_RATIO`] without seeds (about
/// what the columns it spares save), and every later one with them.
pub const FIRST_CULL_RATIO: f64 = 4.5;

/// Spheres per leaf, in a scene copied whole along its curve (see [`SceneIndex`]).
const LEAF: usize = 4;

/// Spheres per leaf in a larger scene, whose node visits (a read from all over the tree each,
/// a rectangle and its largest bound) cost the walk of hidden spheres (`cull.rs`) more than a
/// leaf's shapes side by side, tested eight at a time in lanes and every line asked for at
/// once. At ten million spheres and 640×360 a frame's walk took 296 ms with leaves of 4, 221
/// ms with 32 (the nodes 20 MB instead of 160); with the walk's lanes, frames of 128 against
/// 32 took 87.0 against 94.1 ms there, 324 against 375 ms at 1080p, a million's culled frames
/// as long or shorter and its frames not culled within 4% (three runs of five longer); 256
/// gained no more (docs/performance.md).
const LEAF_LARGE: usize = 128;

/// A scene ready to render: its spheres in a hierarchy and its lights' shadow grids.
///
/// The renderer numbers the spheres by their *rank*. The index holds a copy of the spheres
/// along the hierarchy's Morton curve, and a rank is a place on it: a frame's reads of the
/// spheres (into view coordinates, for shadow rays, for colours, and of the walk's shapes)
/// then fall near each other in memory, not all over the scene. Up to `CURVE_COPY_MAX` spheres
/// the copy is whole (56 bytes a sphere, read without unpacking); past it, packed spheres are
/// copied packed (20 bytes), and whole ones (a file of f64 values) are not copied, a rank then
/// being the scene index. Where the scene's order decides (which of two equally near spheres a
/// ray sees), `Ranks::scene_index` gives it back.
pub struct SceneIndex<'a> {
    /// The scene indexed.
    pub scene: &'a Scene,
    /// The spheres by rank when that is not the scene's order, with each one's scene index.
    curve: Option<(Spheres, Vec<u32>)>,
    /// Whether the scene is past the copy of whole spheres (`CURVE_COPY_MAX`): its leaves are
    /// larger, its frames may cull, and its shadow grids may wait for a frame.
    large: bool,
    nodes: Vec<Node>,
    /// Each sphere in the hierarchy's order as f32 (see [`Shape`]): what the walk of hidden
    /// spheres (`cull.rs`) reads, a leaf's spheres side by side. A copy whose every sphere is
    /// f32 values is its own shapes; otherwise they are made by the first frame that culls (16
    /// bytes a sphere), so that a scene whose frames never cull does not pay for them.
    shapes: OnceLock<Vec<Shape>>,
    /// The ranks of the spheres in the hierarchy's order, which its leaves index (and the
    /// shadow grids' cells, by position): over a copy, the positions.
    order: Order,
    /// Per light: its shadow grid (of positions in `order`), None when it casts no shadows (or
    /// nothing could cast them). Built beside the hierarchy, unless the index was made to wait
    /// ([`SceneIndex::for_frames_of`]): then when a frame first asks for it
    /// ([`SceneIndex::shadow_grid`]), a renderer's first frame taking its shadow rays through
    /// the hierarchy instead (`Renderer::prepare`).
    shadows: Vec<Option<OnceLock<ShadowGrid>>>,
}

/// Spheres a ray from which an index for a raster leaves its shadow grids to the second frame
/// ([`SceneIndex::for_frames_of`]): a grid's build grows with the spheres, the walk of the
/// hierarchy for a frame's shadow rays with its rays. The dense cluster, 2 cores, one frame of
/// 640×360: at ten million (43 a ray) the first frame 2374 → 1488 ms, at a million (4.3 a
/// ray) 247 → 392 ms (docs/performance.md).
pub const SHADOW_WALK_RATIO: f64 = 16.0;

/// The most spheres a [`SceneIndex`] copies whole along its curve: 262,144 spheres take 15 MB
/// more. A million would take 56 MB; past it, packed spheres are copied packed (20 bytes a
/// sphere, 200 MB at ten million, which then need no shapes made for the walk).
pub const CURVE_COPY_MAX: usize = 1 << 18;

impl<'a> SceneIndex<'a> {
    /// The hierarchy and the shadow grids, built side by side on the rayon pool (and the
    /// large subtrees too) after the hierarchy's order, by which both number the spheres: the
    /// same index as built on one thread. Over the copy along the curve, the curve's order is
    /// the copy's, and the hierarchy and grids are built over the copy.
    pub fn new(scene: &'a Scene) -> SceneIndex<'a> {
        SceneIndex::copying_up_to(scene, CURVE_COPY_MAX)
    }

    /// [`SceneIndex::new`], copying the spheres whole along the curve when there are at most
    /// `copy_max` of them (the tests take every way for the same scene).
    pub(super) fn copying_up_to(scene: &'a Scene, copy_max: usize) -> SceneIndex<'a> {
        SceneIndex::building(scene, copy_max, false)
    }

    /// [`SceneIndex::new`] for frames of `raster`: in a scene past the copy of whole spheres,
    /// of at least [`SHADOW_WALK_RATIO`] spheres a ray, the shadow grids are left for a
    /// second frame to build (if one comes), and the renderer's first frame walks the
    /// hierarchy for its shadow rays instead. The first frame comes sooner (ten million at
    /// 640×360: 1.9 → 1.2 s), a run of more frames takes about 0.2 s longer
    /// (docs/performance.md).
    pub fn for_frames_of(scene: &'a Scene, raster: Raster) -> SceneIndex<'a> {
        let rays =
            f64::from(raster.width) * f64::from(raster.height) * f64::from(raster.samples).powi(2);
        let n = scene.spheres.len();
        let lazy = n > CURVE_COPY_MAX && n as f64 >= rays * SHADOW_WALK_RATIO;
        SceneIndex::building(scene, CURVE_COPY_MAX, lazy)
    }

    /// The index, copying the spheres whole along the curve when there are at most `copy_max`
    /// of them, packed past it where they are packed; its shadow grids left for a frame to
    /// build when `lazy` and past `copy_max`.
    pub(super) fn building(scene: &'a Scene, copy_max: usize, lazy: bool) -> SceneIndex<'a> {
        use rayon::prelude::*;
        let large = scene.spheres.len() > copy_max;
        let scene_index = curve_order(&scene.spheres);
        let copy = match large {
            // Packed spheres are copied packed; whole ones (a file of doubles) are not copied.
            true => scene.spheres.packed_along(&scene_index),
            false => {
                let copy: Vec<Sphere> = scene_index
                    .par_iter()
                    .with_min_len(PARALLEL)
                    .map(|&k| scene.spheres.get(k as usize))
                    .collect();
                Some(Spheres::wide(copy))
            }
        };
        // Over the copy, the hierarchy's order is the copy's own; without one, the curve's
        // over the scene. The grids number the spheres by it too, so it comes first.
        let n = scene.spheres.len();
        let (curve, order) = match copy {
            Some(copy) => (Some((copy, scene_index)), Order::Positions(n)),
            None => (None, Order::Listed(Arc::new(scene_index))),
        };
        let spheres = curve.as_ref().map_or(&scene.spheres, |(copy, _)| copy);
        let (nodes, shadows) = rayon::join(
            || {
                let leaf = if large { LEAF_LARGE } else { LEAF };
                hierarchy(spheres, &order, leaf)
            },
            || {
                let grid = |l: &Light| {
                    (l.shadows && spheres.len() > 1).then(|| match lazy && large {
                        false => OnceLock::from(ShadowGrid::build(
                            spheres,
                            order.clone(),
                            -l.direction_world,
                        )),
                        true => OnceLock::new(),
                    })
                };
                scene.lights.iter().map(grid).collect()
            },
        );
        SceneIndex {
            scene,
            curve,
            large,
            nodes,
            shapes: OnceLock::new(),
            order,
            shadows,
        }
    }

    /// Whether any light casts shadows.
    pub(super) fn casts_shadows(&self) -> bool {
        self.shadows.iter().any(Option::is_some)
    }

    /// Light `n`'s shadow grid, built now (on the pool) if it is not yet; None when the light
    /// casts no shadows.
    pub(super) fn shadow_grid(&self, n: usize) -> Option<&ShadowGrid> {
        let direction = self.scene.lights[n].direction_world;
        let build = || ShadowGrid::build(self.spheres(), self.order.clone(), -direction);
        self.shadows[n].as_ref().map(|grid| grid.get_or_init(build))
    }

    /// What light `n`'s shadow rays walk in place of its grid: the hierarchy; None when the
    /// light casts no shadows.
    pub(super) fn shadows_through_tree(&self, n: usize) -> Option<Casters<'_>> {
        self.shadows[n].as_ref()?;
        let (nodes, shapes, order) = self.tree();
        let to_light = -self.scene.lights[n].direction_world;
        Some(Casters::Hierarchy(Hierarchy {
            nodes,
            shapes,
            order,
            to_light,
        }))
    }

    /// Whether every light's shadow grid is built: preparing a frame then builds none.
    pub fn shadow_grids_built(&self) -> bool {
        self.shadows
            .iter()
            .flatten()
            .all(|grid| grid.get().is_some())
    }

    /// The spheres by rank.
    pub(super) fn spheres(&self) -> &Spheres {
        match &self.curve {
            Some((copy, _)) => copy,
            None => &self.scene.spheres,
        }
    }

    /// The hierarchy's nodes (the root first), the spheres' shapes and their ranks, both in
    /// its order, which its leaves index. Unless the copy is its own shapes, the first call
    /// makes them, on the pool.
    pub(super) fn tree(&self) -> (&[Node], &[Shape], &Order) {
        use rayon::prelude::*;
        // Spheres copied along the curve as f32 values are their own shapes.
        if let Some(balls) = self.curve.as_ref().and_then(|(copy, _)| copy.f32_balls()) {
            return (&self.nodes, balls, &self.order);
        }
        let shapes = self.shapes.get_or_init(|| {
            let spheres = self.spheres();
            let order = &self.order;
            let n = order.len();
            let mut shapes = vec![[0.0; 4]; n];
            shapes
                .par_chunks_mut(PARALLEL)
                .enumerate()
                .for_each(|(c, shapes)| {
                    for (p, shape) in (c * PARALLEL..).zip(shapes) {
                        // Ranks along the curve read the scene at random: the sphere some way
                        // ahead is asked for now.
                        if p + PREFETCH_AHEAD < n {
                            prefetch_sphere(spheres, order.rank(p + PREFETCH_AHEAD) as usize);
                        }
                        *shape = shape_of(spheres.ball(order.rank(p) as usize));
                    }
                });
            shapes
        });
        (&self.nodes, shapes, &self.order)
    }

    /// Whether frames may cull hidden spheres ([`SceneIndex::unhidden`]): in a scene past the
    /// copy of whole spheres, where the spheres in view are many.
    pub(super) fn can_cull(&self) -> bool {
        self.large
    }

    /// Whether a frame of `raster` culls hidden spheres: at one sample a pixel, where the index
    /// can ([`SceneIndex::can_cull`]), from `ratio` spheres a pixel ([`CULL_RATIO`]; a ratio of
    /// 0 always, an infinite or NaN one never).
    pub(super) fn culls(&self, raster: Raster, ratio: f64) -> bool {
        let pixels = f64::from(raster.width) * f64::from(raster.height);
        raster.samples == 1 && self.can_cull() && self.spheres().len() as f64 >= pixels * ratio
    }

    /// The way from a rank back to the scene's index.
    pub(super) fn ranks(&self) -> Ranks<'_> {
        match &self.curve {
            Some((_, index)) => Ranks(Some(index)),
            None => Ranks::SCENE,
        }
    }

    /// The ranks of the spheres that can meet a ray of `camera`, in the hierarchy's order (along
    /// its Morton curve): spheres near each other on screen are near each other in the frame's
    /// columns, which the rays read at random otherwise. A subtree whose box lies wholly inside
    /// the pyramid gives all its spheres untested (each would pass).
    pub fn visible(&self, camera: &Camera) -> Vec<u32> {
        let planes = Pyramid::new(camera);
        // Room for every sphere: no chain of copies as it grows (room not written to costs no
        // memory).
        let mut out = Vec::with_capacity(self.order.len());
        let mut stack = Vec::with_capacity(64);
        if !self.nodes.is_empty() {
            stack.push((0usize, false));
        }
        while let Some((k, inside)) = stack.pop() {
            let node = &self.nodes[k];
            let inside = inside || {
                let [lo, hi] = node.bounds();
                match planes.box_side(lo, hi) {
                    Side::Outside => continue,
                    Side::Inside => true,
                    Side::Both => false,
                }
            };
            if node.count > 0 {
                let at = node.start as usize..(node.start + node.count) as usize;
                let items = at.map(|p| self.order.rank(p));
                if inside {
                    out.extend(items);
                } else {
                    let spheres = self.spheres();
                    out.extend(items.filter(|&i| {
                        let (center, radius) = spheres.ball(i as usize);
                        planes.meets_sphere(center, radius)
                    }));
                }
            } else {
                // The left child (next in the order) popped first.
                stack.push((node.start as usize, inside));
                stack.push((k + 1, inside));
            }
        }
        out
    }
}

/// Subtrees of at least this many spheres build their two halves in parallel.
const PARALLEL_BUILD: usize = 1 << 16;

/// The most bits per axis of a Morton code.
const MORTON_BITS: u32 = 21;

/// `v` (below 2²¹) with two zero bits after each of its bits.
fn spread3(v: u64) -> u64 {
    let mut x = v & 0x1f_ffff;
    x = (x | x << 32) & 0x001f_0000_0000_ffff;
    x = (x | x << 16) & 0x001f_0000_ff00_00ff;
    x = (x | x << 8) & 0x100f_00f0_0f00_f00f;
    x = (x | x << 4) & 0x10c3_0c30_c30c_30c3;
    x = (x | x << 2) & 0x1249_2492_4924_9249;
    x
}

/// The spheres' indices sorted along a Morton curve of their centres (ties by index): the
/// hierarchy's order. Sorting once costs O(N log N) with sequential reads, where a median
/// split per node read every sphere again at random; the tree only culls, so the curve's
/// splits do as well as the widest axis's. Each key is the code above the index, 8 bytes,
/// sorted by the radix sort: the code gets the bits the index leaves (15 a side up to 2¹⁸
/// spheres, 14 up to 2²¹). The curve spans the centres of the spheres that are not big for
/// the scene (as the shadow grids tell them); a big one (a ground sphere, whose centre lies
/// far below the rest) is clamped onto its faces, so that it does not squeeze the others into
/// a few cells. The curve only orders: any order culls to the same spheres.
fn curve_order(spheres: &Spheres) -> Vec<u32> {
    use rayon::prelude::*;
    let n = spheres.len();
    let low = index_bits(n);
    let bits = ((u64::BITS - low) / 3).min(MORTON_BITS);
    let (big, _) = big_radius(spheres);
    let none = || (DVec3::INFINITY, DVec3::NEG_INFINITY);
    let (clo, chi) = (0..n)
        .into_par_iter()
        .with_min_len(PARALLEL)
        .map(|k| spheres.ball(k))
        .filter(|&(_, radius)| radius <= big)
        .fold(none, |(lo, hi), (center, _)| {
            (lo.min(center), hi.max(center))
        })
        .reduce(none, |a, b| (a.0.min(b.0), a.1.max(b.1)));
    let last = ((1u64 << bits) - 1) as f64;
    let scale = (chi - clo).max_element();
    let inv = if scale > 0.0 { last / scale } else { 0.0 };
    let keys: Vec<u64> = (0..n)
        .into_par_iter()
        .with_min_len(PARALLEL)
        .map(|k| {
            // Clamped as floats (a big sphere's, and NaN from an empty box, to the edge).
            let q = ((spheres.ball(k).0 - clo) * inv)
                .to_array()
                .map(|v| v.max(0.0).min(last) as u64);
            let code = spread3(q[0]) << 2 | spread3(q[1]) << 1 | spread3(q[2]);
            code << low | k as u64
        })
        .collect();
    let mask = (1u64 << low) - 1;
    sort_by_high_bits(keys, low)
        .par_iter()
        .with_min_len(PARALLEL)
        .map(|&key| (key & mask) as u32)
        .collect()
}

/// The hierarchy's nodes (the root first) over `spheres` taken in `order` ([`curve_order`]),
/// split at the median position, level after level, down to at most `leaf` spheres.
fn hierarchy(spheres: &Spheres, order: &Order, leaf: usize) -> Vec<Node> {
    if spheres.is_empty() {
        return Vec::new();
    }
    let empty = Node {
        lo: [0.0; 3],
        hi: [0.0; 3],
        start: 0,
        count: 0,
    };
    let mut nodes = vec![empty; node_count(order.len(), leaf)];
    let tree = Tree {
        spheres,
        order,
        leaf,
    };
    tree.build(&mut nodes, 0, 0, order.len());
    nodes
}

/// The number of nodes of a subtree of `n` spheres, at most `leaf` a leaf.
fn node_count(n: usize, leaf: usize) -> usize {
    if n <= leaf {
        1
    } else {
        1 + node_count(n / 2, leaf) + node_count(n - n / 2, leaf)
    }
}

/// What every subtree's build reads: the spheres, their order and the leaf size.
struct Tree<'a> {
    spheres: &'a Spheres,
    order: &'a Order,
    leaf: usize,
}

impl Tree<'_> {
    /// Builds the subtree of the `len` spheres at `start..` of the order into `nodes`, which
    /// has exactly its [`node_count`] entries and begins at index `base` of the whole tree;
    /// large subtrees build their halves in parallel.
    fn build(&self, nodes: &mut [Node], base: usize, start: usize, len: usize) {
        let (spheres, order) = (self.spheres, self.order);
        if len <= self.leaf {
            // Leaves are made left to right, each reading its spheres from all over the scene
            // (unless they are a copy along the curve): the ones a few leaves on are asked for
            // now, so that their reads overlap this leaf's.
            let ahead = start + PREFETCH_AHEAD;
            for p in ahead..(ahead + len).min(order.len()) {
                prefetch_sphere(spheres, order.rank(p) as usize);
            }
            nodes[0] = leaf(spheres, order, start, len);
            return;
        }
        let mid = len / 2;
        let (me, below) = nodes.split_at_mut(1);
        let (left_nodes, right_nodes) = below.split_at_mut(node_count(mid, self.leaf));
        let right_base = base + 1 + left_nodes.len();
        if len >= PARALLEL_BUILD {
            rayon::join(
                || self.build(left_nodes, base + 1, start, mid),
                || self.build(right_nodes, right_base, start + mid, len - mid),
            );
        } else {
            self.build(left_nodes, base + 1, start, mid);
            self.build(right_nodes, right_base, start + mid, len - mid);
        }
        let (a, b) = (&left_nodes[0], &right_nodes[0]);
        me[0] = Node {
            lo: std::array::from_fn(|i| a.lo[i].min(b.lo[i])),
            hi: std::array::from_fn(|i| a.hi[i].max(b.hi[i])),
            start: right_base as u32,
            count: 0,
        };
    }
}

/// `sphere`'s [`Shape`].
fn shape_of((c, radius): (DVec3, f64)) -> Shape {
    let c32 = c.to_array().map(|v| v as f32);
    // Each coordinate moved by at most half an ulp of itself (or half of F32_TINY), the centre
    // by at most √3 times that: less than `moved`. That, and the radius rounded up, hold the
    // sphere; where the f64 sum lost some of `moved` (a centre far nearer the origin than the
    // radius is long), one f32 step more.
    let moved = F32_EPS * c.abs().max_element() + F32_TINY;
    let r = f32_up(radius + moved);
    let r = if (r as f64) - radius < moved {
        r.next_up()
    } else {
        r
    };
    [
        c32[0],
        c32[1],
        c32[2],
        if r.is_finite() { r } else { f32::INFINITY },
    ]
}

/// A leaf over the `len` spheres at `start..` of `order`, with the box of its spheres.
fn leaf(spheres: &Spheres, order: &Order, start: usize, len: usize) -> Node {
    let mut lo = DVec3::INFINITY;
    let mut hi = DVec3::NEG_INFINITY;
    for p in start..start + len {
        let (center, radius) = spheres.ball(order.rank(p) as usize);
        lo = lo.min(center - radius);
        hi = hi.max(center + radius);
    }
    Node {
        lo: lo.to_array().map(f32_down),
        hi: hi.to_array().map(f32_up),
        start: start as u32,
        count: len as u32,
    }
}

/// Where a box lies against the view pyramid.
enum Side {
    Outside,
    Inside,
    Both,
}

/// The view pyramid from the COP through the window's edges, as four world-space planes
/// (inward normals m, offsets): a world point x is inside when (x − VRP)·m ≥ offset for all.
struct Pyramid {
    vrp: DVec3,
    planes: [(DVec3, f64); 4],
    /// Allowance for rounding: 1e-9 of the coordinates' scale.
    slack: f64,
}

impl Pyramid {
    fn new(camera: &Camera) -> Pyramid {
        let cop = camera.cop_view;
        let (w, h) = (camera.window.x * 0.5, camera.window.y * 0.5);
        // Window corners counter-clockwise seen from the COP (looking along +n), as unit
        // directions: normalising a cross product of the corners themselves squares the square
        // of the scene's lengths, which underflows to zero for lengths near 1e-80.
        let corners = [
            DVec2::new(-w, -h),
            DVec2::new(w, -h),
            DVec2::new(w, h),
            DVec2::new(-w, h),
        ]
        .map(|c| (DVec3::new(c.x, c.y, 0.0) - cop).normalize());
        let centre = -cop;
        let planes = std::array::from_fn(|k| {
            let m = corners[k].cross(corners[(k + 1) % 4]).normalize();
            // Inward: the window's centre is inside.
            let m = if m.dot(centre) < 0.0 { -m } else { m };
            let world = camera.basis.to_world(m);
            (world, cop.dot(m))
        });
        let slack = 1e-9
            * (camera.vrp_world.abs().max_element()
                + cop.abs().max_element()
                + camera.window.max_element());
        Pyramid {
            vrp: camera.vrp_world,
            planes,
            slack,
        }
    }

    fn meets_sphere(&self, center: DVec3, radius: f64) -> bool {
        let rel = center - self.vrp;
        let slack = self.slack + 1e-9 * (center.abs().max_element() + radius);
        self.planes
            .iter()
            .all(|(m, offset)| rel.dot(*m) - offset >= -radius - slack)
    }

    /// Whether the box (lo, hi) is wholly outside one plane (no sphere in it can meet a ray),
    /// wholly inside every plane by more than the allowance (every sphere in it passes
    /// [`Pyramid::meets_sphere`]: a sphere in the box has its centre at least its radius
    /// inside), or neither.
    fn box_side(&self, lo: DVec3, hi: DVec3) -> Side {
        let (mid, half) = ((lo + hi) * 0.5, (hi - lo) * 0.5);
        let rel = mid - self.vrp;
        let slack = self.slack + 1e-9 * (lo.abs().max(hi.abs()).max_element());
        let mut inside = true;
        for (m, offset) in &self.planes {
            let (centre, reach) = (rel.dot(*m) - offset, half.dot(m.abs()));
            if centre + reach < -slack {
                return Side::Outside;
            }
            inside &= centre - reach >= slack;
        }
        if inside {
            Side::Inside
        } else {
            Side::Both
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::shadows::tests::coordinate_of_kind;
    use super::super::tree::shape_inner;
    use super::*;
    use crate::camera::Basis;
    use crate::scene::Sphere;
    use crate::splitmix::SplitMix;

    /// A field of spheres with many equal coordinates (equal Morton codes, ties by index), a
    /// few much larger ones, and, at `n` > 2, a ground sphere.
    fn scene(n: usize) -> Scene {
        let mut rng = SplitMix(n as u64);
        let mut spheres: Vec<Sphere> = (0..n)
            .map(|k| Sphere {
                center_world: DVec3::new(
                    (rng.unit() * 100.0).round() - 50.0,
                    if k % 3 == 0 { 0.0 } else { rng.unit() * 10.0 },
                    rng.unit() * 80.0 - 40.0,
                ),
                radius: if k % 97 == 5 { 10.0 } else { 0.05 + rng.unit() },
                color: DVec3::ONE,
            })
            .collect();
        if n > 2 {
            spheres[n / 2] = Sphere {
                center_world: DVec3::new(0.0, -1e5, 0.0),
                radius: 1e5,
                color: DVec3::ONE,
            };
        }
        Scene {
            background: DVec3::ZERO,
            ambient: 0.1,
            lights: Vec::new(),
            spheres: spheres.into(),
        }
    }

    /// An index for a raster leaves the shadow grids unbuilt only in a scene past the copy
    /// along the curve with at least [`SHADOW_WALK_RATIO`] spheres a ray; a frame's ask builds
    /// them.
    #[test]
    fn the_grids_wait_only_with_many_spheres_a_ray() {
        let raster = |width, height, samples| Raster {
            width,
            height,
            samples,
            adaptive: false,
        };
        let lit = |mut scene: Scene| {
            scene.lights = vec![Light {
                direction_world: DVec3::new(-0.6, -1.0, 0.4).normalize(),
                color: DVec3::ONE,
                shadows: true,
            }];
            scene
        };
        let past = lit(scene(CURVE_COPY_MAX + 16));
        let copied = lit(scene(CURVE_COPY_MAX));
        // 2¹⁸ + 16 spheres: 16 a ray exactly at 145×113 (16,385 rays), fewer at 145×114, and
        // at 73×57 with 2×2 samples.
        let lazy = SceneIndex::for_frames_of(&past, raster(145, 113, 1));
        assert!(!lazy.shadow_grids_built());
        assert!(lazy.casts_shadows());
        assert!(lazy.shadow_grid(0).is_some());
        assert!(lazy.shadow_grids_built());
        for r in [raster(145, 114, 1), raster(73, 57, 2)] {
            assert!(
                SceneIndex::for_frames_of(&past, r).shadow_grids_built(),
                "{r:?}"
            );
        }
        assert!(SceneIndex::for_frames_of(&copied, raster(1, 1, 1)).shadow_grids_built());
    }

    #[test]
    fn every_sphere_is_in_one_leaf_inside_its_boxes() {
        let sizes = [
            1,
            4,
            5,
            33,
            1000,
            PARALLEL_BUILD - 1,
            3 * PARALLEL_BUILD + 7,
        ];
        for (n, leaf) in sizes.into_iter().flat_map(|n| [(n, LEAF), (n, LEAF_LARGE)]) {
            let scene = scene(n);
            let order = curve_order(&scene.spheres);
            let nodes = hierarchy(
                &scene.spheres,
                &Order::Listed(Arc::new(order.clone())),
                leaf,
            );
            assert_eq!(nodes.len(), node_count(n, leaf));
            // The same tree on one thread.
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(1)
                .build()
                .unwrap();
            let one = pool.install(|| {
                let order = curve_order(&scene.spheres);
                let listed = Order::Listed(Arc::new(order.clone()));
                (hierarchy(&scene.spheres, &listed, leaf), order)
            });
            assert!(one == (nodes.clone(), order.clone()));
            let mut seen = vec![0u32; n];
            let mut stack = vec![(0usize, Vec::<usize>::new())];
            while let Some((k, mut path)) = stack.pop() {
                let node = nodes[k];
                path.push(k);
                if node.count > 0 {
                    assert!(node.count as usize <= leaf);
                    for &i in &order[node.start as usize..(node.start + node.count) as usize] {
                        seen[i as usize] += 1;
                        let s = scene.spheres.get(i as usize);
                        for &a in &path {
                            let [lo, hi] = nodes[a].bounds();
                            assert!((s.center_world - s.radius).cmpge(lo).all());
                            assert!((s.center_world + s.radius).cmple(hi).all());
                        }
                    }
                } else {
                    stack.push((k + 1, path.clone()));
                    stack.push((node.start as usize, path));
                }
            }
            assert!(seen.iter().all(|&c| c == 1), "{n} spheres");
        }
    }

    /// Frames cull hidden spheres from [`CULL_RATIO`] spheres a pixel up, at one sample a
    /// pixel, in a scene past the copy of whole spheres: over 200 pixels, the least whole
    /// number of spheres at the ratio culls and one fewer does not.
    #[test]
    fn frames_cull_from_the_ratio_at_one_sample_in_a_large_scene() {
        let raster = |samples| Raster {
            width: 20,
            height: 10,
            samples,
            adaptive: false,
        };
        let least = (200.0 * CULL_RATIO).ceil() as usize;
        let (at, below) = (scene(least), scene(least - 1));
        let large = SceneIndex::copying_up_to(&at, 0);
        let copied = SceneIndex::copying_up_to(&at, CURVE_COPY_MAX);
        assert!(large.culls(raster(1), CULL_RATIO));
        assert!(!SceneIndex::copying_up_to(&below, 0).culls(raster(1), CULL_RATIO));
        assert!(!large.culls(raster(2), CULL_RATIO));
        assert!(!copied.culls(raster(1), CULL_RATIO));
        assert!(large.culls(raster(1), 0.0));
        assert!(!large.culls(raster(1), f64::INFINITY));
        assert!(!large.culls(raster(1), f64::NAN));
    }

    /// The culled list is exactly the spheres that pass the pyramid test one by one, for
    /// cameras inside, beside and far from seeded fields of spheres (subtrees wholly inside
    /// the pyramid give theirs untested).
    #[test]
    fn culling_keeps_exactly_the_spheres_the_pyramid_meets() {
        let mut rng = SplitMix(7);
        let mut inside = 0;
        // Past `copy_max`, packed spheres are copied packed and whole ones not at all.
        for (n, copy_max, whole) in [
            (1, 0, false),
            (5, 5, false),
            (1000, 0, false),
            (1000, 0, true),
            (1000, 1000, false),
            (20_000, CURVE_COPY_MAX, false),
        ] {
            let mut scene = scene(n);
            if whole {
                scene.spheres = Spheres::wide(scene.spheres.iter().collect());
            }
            let index = SceneIndex::copying_up_to(&scene, copy_max);
            assert_eq!(index.curve.is_some(), n <= copy_max || !whole);
            assert_eq!(index.can_cull(), n > copy_max);
            for c in 0..12 {
                let mut r = || rng.unit() * 2.0 - 1.0;
                let far = if c % 3 == 0 { 300.0 } else { 30.0 };
                let vrp = DVec3::new(r() * far, r() * 20.0 + 5.0, r() * far);
                let vpn = DVec3::new(r(), r() * 0.5, r());
                let Ok(basis) = Basis::from_vpn_vuv(vpn, DVec3::Y) else {
                    continue;
                };
                let camera = Camera {
                    vrp_world: vrp,
                    basis,
                    cop_view: DVec3::new(r() * 0.3, r() * 0.3, -1.0 - r().abs()),
                    window: DVec2::new(1.0 + r().abs(), 0.6 + r().abs()),
                };
                let planes = Pyramid::new(&camera);
                let every: Vec<u32> = (0..n as u32)
                    .filter(|&k| {
                        let s = scene.spheres.get(k as usize);
                        planes.meets_sphere(s.center_world, s.radius)
                    })
                    .collect();
                let got = index.visible(&camera);
                let ranks = index.ranks();
                let mut sorted: Vec<u32> = got.iter().map(|&r| ranks.scene_index(r)).collect();
                sorted.sort_unstable();
                assert_eq!(sorted, every, "{n} spheres, camera {c}");
                // In the hierarchy's order, each once.
                let mut at = vec![0; n];
                for p in 0..n {
                    let k = index.order.rank(p);
                    at[k as usize] = p;
                }
                assert!(got
                    .windows(2)
                    .all(|w| at[w[0] as usize] < at[w[1] as usize]));
                // Every sphere by rank is its scene sphere.
                for (r, s) in index.spheres().iter().enumerate() {
                    assert!(s == scene.spheres.get(ranks.scene_index(r as u32) as usize));
                }
                inside += index
                    .nodes
                    .iter()
                    .filter(|node| {
                        let [lo, hi] = node.bounds();
                        matches!(planes.box_side(lo, hi), Side::Inside)
                    })
                    .count();
            }
        }
        assert!(inside > 100, "{inside} nodes wholly inside");
    }

    /// The curve's order is the sort by Morton code (bits interleaved one at a time here),
    /// ties by index, of the centres quantised over the box of the spheres that are not big,
    /// a big one clamped onto its faces: with the scene's ground sphere (centre 10⁵ below, in
    /// its middle), spheres sharing cells, and sizes whose index takes 10 to 18 bits (code
    /// bits 18 to 15 a side).
    #[test]
    fn the_curve_orders_by_code_over_the_box_of_the_spheres_not_big() {
        for n in [1, 2, 3, 1000, 20_000, (1 << 18) - 5] {
            let mut scene = scene(n);
            // Pairs of spheres in one cell, or at one centre.
            for k in (0..n).step_by(7).skip(1) {
                let mut s = scene.spheres.get(k);
                s.center_world = scene.spheres.get(k - 1).center_world;
                scene.spheres.set(k, s);
            }
            let spheres = &scene.spheres;
            let bits = ((64 - index_bits(n)) / 3).min(MORTON_BITS);
            let big = big_radius(spheres).0;
            let inner = || spheres.iter().filter(|s| s.radius <= big);
            let lo = inner().fold(DVec3::INFINITY, |lo, s| lo.min(s.center_world));
            let hi = inner().fold(DVec3::NEG_INFINITY, |hi, s| hi.max(s.center_world));
            let last = ((1u64 << bits) - 1) as f64;
            let scale = (hi - lo).max_element();
            let code = |s: &Sphere| {
                let q = ((s.center_world - lo) * (last / scale).min(f64::MAX))
                    .to_array()
                    .map(|v| {
                        if v.is_nan() {
                            0
                        } else {
                            v.clamp(0.0, last) as u64
                        }
                    });
                (0..bits).rev().fold(0u64, |code, b| {
                    (0..3).fold(code, |code, a| code << 1 | (q[a] >> b & 1))
                })
            };
            let mut want: Vec<u32> = (0..n as u32).collect();
            want.sort_by_key(|&k| (code(&spheres.get(k as usize)), k));
            assert!(curve_order(spheres) == want, "{n} spheres");
        }
    }

    /// Past `copy_max`, a packed copy of spheres that are all f32 values is its own shapes (no
    /// more are made), each rank's shape its sphere's values; one f64 value among them, and
    /// every sphere gets its made shape.
    #[test]
    fn a_copy_of_f32_spheres_is_its_own_shapes() {
        let given = scene(3000);
        let rounded: Spheres = given
            .spheres
            .iter()
            .map(|s| Sphere {
                center_world: s.center_world.as_vec3().as_dvec3(),
                radius: f64::from(s.radius as f32),
                color: s.color,
            })
            .collect();
        let mut mixed: Vec<Sphere> = rounded.iter().collect();
        mixed[1234].radius += 1e-12;
        for (spheres, own) in [(rounded, true), (mixed.into(), false)] {
            let scene = Scene {
                spheres,
                ..given.clone()
            };
            let index = SceneIndex::copying_up_to(&scene, 0);
            let (_, shapes, order) = index.tree();
            assert_eq!(index.shapes.get().is_none(), own);
            let ranks = index.ranks();
            for (p, shape) in shapes.iter().enumerate() {
                let k = ranks.scene_index(order.rank(p)) as usize;
                let ball = scene.spheres.ball(k);
                let want = match own {
                    true => [ball.0.x, ball.0.y, ball.0.z, ball.1].map(|v| v as f32),
                    false => shape_of(ball),
                };
                assert_eq!(shape.map(f32::to_bits), want.map(f32::to_bits), "rank {p}");
            }
        }
    }

    /// A sphere's shape within f32's range holds it (its centre no farther from the sphere's
    /// than its radius is beyond the sphere's, the distance in f64 taken 10⁻¹⁵ larger), and
    /// the shape's inner ball lies inside the sphere: over centres of every size and sign, on
    /// f32's values, subnormal and beyond its range, and radii from tiny to huge.
    #[test]
    fn a_shape_holds_its_sphere() {
        let mut rng = SplitMix(0x5a9e);
        let mut coordinate = |k: usize| coordinate_of_kind(&mut rng, k);
        let mut held = 0;
        for k in 0..50_000 {
            let c = DVec3::new(coordinate(k), coordinate(k / 5), coordinate(k / 25));
            let radius = [1e-30, 1e-6, 0.07, 3.0, 0.3f32 as f64, 1e300][k % 11 % 6];
            let shape = shape_of((c, radius));
            // A shape past f32's range holds nothing in particular: its readers test such a
            // sphere by other means.
            if !shape.iter().all(|v| v.is_finite()) {
                continue;
            }
            let (centre, r) = (
                DVec3::new(shape[0].into(), shape[1].into(), shape[2].into()),
                f64::from(shape[3]),
            );
            let moved = (centre - c).length() * (1.0 + 1e-15);
            assert!(moved <= r - radius, "{c} {radius}: {shape:?}");
            let inside = shape_inner(&shape) <= radius - moved;
            assert!(inside, "{c} {radius}: {shape:?}");
            held += 1;
        }
        assert!(held > 30_000, "{held}");
    }

    #[test]
    fn f32_bounds_round_outward() {
        let mut rng = SplitMix(3);
        for k in 0..10_000 {
            let x = (rng.unit() - 0.5) * 10f64.powi(k % 80 - 40);
            for x in [x, -x, 0.0, 1e300, -1e300, f64::MIN_POSITIVE] {
                assert!(f32_down(x) as f64 <= x && f32_up(x) as f64 >= x, "{x}");
                // And by at most one step.
                assert!(f32_down(x).next_up() as f64 >= x || f32_down(x) == f32::MAX);
                assert!(f32_up(x).next_down() as f64 <= x || f32_up(x) == f32::MIN);
            }
        }
    }
}
