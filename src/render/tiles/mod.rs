//! Screen tiles: each tile lists the spheres whose projection can cover it, nearest first, so a
//! primary ray tests only those and stops once no remaining sphere can be nearer than its hit.
//! Spheres wholly behind the COP are culled. A sphere the COP's plane cuts projects without
//! bound: when the COP is inside it, it goes into every tile; when outside (a ground seen from
//! above it), into the tiles whose rays can meet it, at the nearest hit they can have there.
//!
//! This file bins the spheres into the tiles; the spheres' pixel rectangles are found in
//! `footprints.rs`, the bounds of a sphere without them in `ground.rs`, the order every tile
//! lists its spheres in in `order.rs`.

mod footprints;
mod ground;
mod order;

use rayon::prelude::*;

use super::bins::Bins;
use super::rays::RayTable;
use super::simd::Isa;
use super::sort::{on_pool, PARALLEL};
use super::view::{Ranks, ViewColumns};
use crate::raster::Raster;
use footprints::Footprints;
use ground::Wide;
use order::search_order;

pub use super::rays::TILE;

/// Side in pixels of a tile at one sample a pixel from a quarter of a sphere a pixel
/// ([`DENSE`]): a packet reads its tile's list up to its hits, passing the spheres that do not
/// cover it, and among many small spheres a quarter of the tile is a quarter of the list.
/// Below that, the larger tile's fewer lists cost less to build than they save
/// (docs/performance.md). A band's column of packets, [`HALF`](super::rays::HALF) pixels wide
/// and four rows high, lies in one tile.
pub const DENSE_TILE: usize = 8;

/// Pixels a sphere of the frame's columns, at most, at which a frame at one sample a pixel
/// takes [`DENSE_TILE`]: a quarter of a sphere a pixel, or more.
const DENSE: usize = 4;

const _: () = assert!(
    TILE.is_multiple_of(DENSE_TILE)
        && DENSE_TILE.is_multiple_of(4) // a band's rows (`BAND`, drivers.rs)
        && DENSE_TILE.is_multiple_of(super::rays::HALF)
);

/// Per-tile sphere lists, nearest possible hit first, and each sphere's pixel rectangle.
pub struct TileBins {
    bins: Bins,
    /// Per sphere, the inclusive pixel rectangle (i0, i1, j0, j1) its projection may cover
    /// (a side is at most `MAX_SIDE`, 16,384 pixels: 8 bytes a sphere).
    rects: Vec<[u16; 4]>,
    /// log2 of the tiles' side in pixels ([`TILE`] or [`DENSE_TILE`]).
    shift: u32,
}

/// The side of a frame's tiles: [`DENSE_TILE`] at one sample a pixel with at least a quarter
/// of a sphere a pixel, [`TILE`] otherwise. Which it is changes no pixel: a ray takes its
/// nearest sphere, ties by scene order, from whatever list holds it.
fn tile_side(spheres: usize, raster: Raster) -> usize {
    let pixels = raster.width as usize * raster.height as usize;
    match raster.samples == 1 && spheres.saturating_mul(DENSE) >= pixels {
        true => DENSE_TILE,
        false => TILE,
    }
}

impl TileBins {
    /// The tiles' lists of `spheres`, whose ranks `ranks` takes back to scene indices for the
    /// ties, in tiles of [`tile_side`].
    pub fn build(
        isa: Isa,
        spheres: &ViewColumns,
        ranks: Ranks,
        table: &RayTable,
        raster: Raster,
    ) -> TileBins {
        let side = tile_side(spheres.len(), raster);
        TileBins::build_in(isa, spheres, ranks, table, raster, side)
    }

    /// [`TileBins::build`] in tiles of `side` pixels, [`TILE`] or (at one sample a pixel)
    /// [`DENSE_TILE`].
    fn build_in(
        isa: Isa,
        spheres: &ViewColumns,
        ranks: Ranks,
        table: &RayTable,
        raster: Raster,
        side: usize,
    ) -> TileBins {
        assert!(
            side == TILE || (side == DENSE_TILE && raster.samples == 1),
            "tiles of {side} pixels at {} samples a side",
            raster.samples
        );
        let shift = side.trailing_zeros();
        let (cop, window) = (table.cop_view, table.window);
        let tiles_x = (raster.width as usize).div_ceil(side);
        let tiles_y = (raster.height as usize).div_ceil(side);
        assert!(
            raster.width.max(raster.height) <= 1 << 16,
            "a raster side of at most 65,536 pixels"
        );
        // The order every tile searches its spheres in, first (its sort's buffers are freed
        // before the rectangles are written); then each sphere's pixel rectangle, eight at a
        // time, and the spheres without bounds.
        let n = spheres.len();
        let order = search_order(spheres, ranks);
        let mut rects = vec![[0u16; 4]; n];
        let prints = |first: usize, rects: &mut [[u16; 4]]| {
            let mut unbounded = Vec::new();
            isa.run(Footprints {
                spheres,
                first,
                rects,
                unbounded: &mut unbounded,
                cop,
                window,
                raster,
            });
            unbounded
        };
        let chunks = rects.chunks_mut(PARALLEL).collect();
        let unbounded = on_pool(chunks, |c, rects| prints(c * PARALLEL, rects)).concat();
        // Spheres without bounds that the COP is outside of (a ground, seen from above it) are
        // placed tile by tile, once the others are binned: left out where no ray of the tile
        // meets them, and ordered by the nearest hit a ray of the tile can have.
        let wide: Vec<Wide> = unbounded
            .into_iter()
            .filter_map(|k| Wide::new(k, &spheres.reach(k as usize), table, raster, side))
            .collect();
        let dims = (tiles_x, tiles_y);
        let cells = |rect: [u16; 4]| {
            let [i0, i1, j0, j1] = rect.map(|v| v as usize);
            (i0 <= i1).then_some((i0 >> shift, i1 >> shift, j0 >> shift, j1 >> shift))
        };
        // Binned in the search order, every tile lists its spheres in it: no tile sorts.
        let mut bins = if n >= PARALLEL {
            // The rectangles in that order first, so that the two passes of the binning read
            // them in sequence; a task per quarter of the spheres or per PARALLEL, whichever
            // is more.
            let sorted: Vec<[u16; 4]> = order.par_iter().map(|&k| rects[k as usize]).collect();
            let chunk = n.div_ceil(4).max(PARALLEL);
            Bins::build(dims, &order, chunk, |i| cells(sorted[i]))
        } else {
            Bins::build(dims, &order, n, |i| cells(rects[order[i] as usize]))
        };
        drop(order);
        let id = |k: u32| ranks.scene_index(spheres.id[k as usize] as u32);
        let before = |a: (f64, u32), b: (f64, u32)| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1));
        if !wide.is_empty() {
            // They were binned into every tile; each tile's list is merged anew from its other
            // spheres and the wide ones that its rays can meet, by their bounds there.
            let is_wide = |k: u32| wide.iter().any(|w| w.index == k);
            let scratch = || Vec::<(f64, u32, u32)>::with_capacity(wide.len());
            bins.edit_cells(scratch, |keyed, (tx, ty), items| {
                keyed.clear();
                let mut cone = None;
                keyed.extend(wide.iter().filter_map(|w| {
                    let bound = w.nearest(tx, ty, &mut cone, table, raster)?;
                    Some((bound, id(w.index), w.index))
                }));
                keyed.sort_unstable_by(|&a, &b| before((a.0, a.1), (b.0, b.1)));
                // The others, in their order, to the front; then each wide sphere the tile
                // keeps into its place among them (the slots the wide ones held make room).
                let mut n = 0;
                for i in 0..items.len() {
                    if !is_wide(items[i]) {
                        items[n] = items[i];
                        n += 1;
                    }
                }
                // A wide sphere already put back counts at its min_dist here, below its bound
                // for the tile but not below an earlier one in `keyed`, so the order searched
                // stays sorted.
                for &(bound, w_id, w) in &*keyed {
                    let at = items[..n].partition_point(|&k| {
                        // The scene index read only when the distances tie (a random read
                        // saved at each step of every tile's search).
                        let d = spheres.min_dist[k as usize].total_cmp(&bound);
                        d.then_with(|| id(k).cmp(&w_id)).is_lt()
                    });
                    items.copy_within(at..n, at + 1);
                    items[at] = w;
                    n += 1;
                }
                n
            });
        }
        TileBins { bins, rects, shift }
    }

    /// The tiles' side in pixels.
    #[cfg(test)]
    pub fn side(&self) -> usize {
        1 << self.shift
    }

    /// The spheres that can cover pixel (i, j), nearest first.
    #[inline]
    pub fn at(&self, i: usize, j: usize) -> &[u32] {
        self.bins.cell(i >> self.shift, j >> self.shift)
    }

    /// Whether sphere k's projection may cover a pixel of rows j0..=j1 in columns i0..=i1.
    #[inline(always)]
    pub fn covers(&self, k: u32, (i0, i1): (usize, usize), (j0, j1): (usize, usize)) -> bool {
        let [x0, x1, y0, y1] = self.rects[k as usize].map(u32::from);
        let (i0, i1, j0, j1) = (i0 as u32, i1 as u32, j0 as u32, j1 as u32);
        i1 >= x0 && i0 <= x1 && j1 >= y0 && j0 <= y1
    }
}

#[cfg(test)]
mod tests {
    use super::footprints::tests::{footprint, Footprint};
    use super::*;
    use crate::camera::{Basis, Camera};
    use crate::render::kernels::Shading;
    use crate::render::oracle::{nearest, root};
    use crate::render::view::ViewSphere;
    use crate::scene::{Sphere, Spheres};
    use glam::{DVec2, DVec3};

    /// A tile's list, read as scene indices, does not depend on the order the columns hold the
    /// spheres in: spheres of equal nearest possible hit (copies of one sphere, and a ground)
    /// keep their scene order whichever way the frame lists them, on one thread and on the pool.
    #[test]
    fn tile_lists_follow_the_scene_order_whatever_the_columns_order() {
        let mut gen = crate::splitmix::SplitMix(12);
        let mut spheres: Vec<Sphere> = Vec::new();
        for _ in 0..(PARALLEL / 4 + 50) {
            let mut r = || gen.unit();
            let s = Sphere {
                center_world: DVec3::new(r() * 40.0 - 20.0, r() * 5.0, r() * 40.0),
                radius: 0.2 + r(),
                color: DVec3::ONE,
            };
            // Each sphere four times over: ties in every list it is in.
            spheres.extend([s; 4]);
        }
        spheres.push(Sphere {
            center_world: DVec3::new(0.0, -1e3, 0.0),
            radius: 1e3,
            color: DVec3::ONE,
        });
        let camera = Camera {
            vrp_world: DVec3::new(0.0, 3.0, -25.0),
            basis: Basis::from_vpn_vuv(DVec3::new(0.0, -0.1, 1.0), DVec3::Y).unwrap(),
            cop_view: DVec3::new(0.0, 0.0, -1.0),
            window: DVec2::new(1.6, 0.9),
        };
        let raster = Raster {
            width: 160,
            height: 90,
            samples: 1,
            adaptive: false,
        };
        let table = RayTable::new(camera.cop_view, camera.window, raster);
        let ground = spheres.len() as u32 - 1;
        let ids = |order: &[u32]| {
            let view: Vec<ViewSphere> = order
                .iter()
                .map(|&k| ViewSphere::new(&camera, spheres[k as usize].ball(), k))
                .collect();
            let columns = ViewColumns::new(camera.cop_view, &view);
            let bins = TileBins::build(Isa::Portable, &columns, Ranks::SCENE, &table, raster);
            let mut lists = Vec::new();
            for j in (0..90).step_by(bins.side()) {
                for i in (0..160).step_by(bins.side()) {
                    let list: Vec<(f64, u64)> = bins
                        .at(i, j)
                        .iter()
                        .map(|&k| (columns.min_dist[k as usize], columns.id[k as usize]))
                        .collect();
                    // Nearest possible hit first, ties by scene index; the ground aside (its
                    // place is its bound for the tile).
                    let bounded: Vec<_> = list.iter().filter(|s| s.1 != ground as u64).collect();
                    for w in bounded.windows(2) {
                        let order = w[0].0.total_cmp(&w[1].0).then(w[0].1.cmp(&w[1].1));
                        assert!(order.is_lt(), "{w:?} in tile ({i}, {j})");
                    }
                    lists.push(list.into_iter().map(|s| s.1).collect::<Vec<_>>());
                }
            }
            lists
        };
        // Above PARALLEL spheres (the pool's binning) and below; the ground last.
        for n in [spheres.len() as u32, 1001] {
            assert_eq!(n as usize >= PARALLEL, n != 1001);
            let ids = |order: &[u32]| ids(&[order, &[ground]].concat());
            let forward: Vec<u32> = (0..n - 1).collect();
            let backward: Vec<u32> = (0..n - 1).rev().collect();
            let shuffled: Vec<u32> = (0..n - 1).map(|k| (k * 7919) % (n - 1)).collect();
            let expected = ids(&forward);
            assert!(expected.iter().any(|l| l.len() > 8), "lists with ties");
            assert_eq!(ids(&backward), expected);
            assert_eq!(ids(&shuffled), expected);
        }
    }

    /// Every sample's nearest hit through its tile's list is the nearest of every sphere, with
    /// a ground sphere (radius 10³ and 10⁵) placed tile by tile: left out of tiles above its
    /// horizon, and after nearer spheres where its own hits are further. Cameras level, looking
    /// down with a roll, grazing the ground with the COP off the axis, and looking up.
    #[test]
    fn tiles_find_the_nearest_hit_of_every_sample() {
        let mut gen = crate::splitmix::SplitMix(11);
        let mut spheres: Vec<Sphere> = (0..80)
            .map(|_| {
                let mut r = || gen.unit();
                Sphere {
                    center_world: DVec3::new(r() * 80.0 - 40.0, r() * 5.0, r() * 80.0 - 10.0),
                    radius: 0.3 + r() * 2.0,
                    color: DVec3::ONE,
                }
            })
            .collect();
        let cameras = [
            (
                DVec3::new(0.0, 2.0, -20.0),
                DVec3::Z,
                DVec3::Y,
                DVec3::new(0.0, 0.0, -1.0),
            ),
            (
                DVec3::new(-5.0, 8.0, -30.0),
                DVec3::new(0.2, -0.4, 1.0),
                DVec3::new(0.3, 1.0, 0.0),
                DVec3::new(0.0, 0.0, -1.2),
            ),
            (
                DVec3::new(3.0, 0.05, -25.0),
                DVec3::new(-0.1, 0.0, 1.0),
                DVec3::Y,
                DVec3::new(0.4, 0.03, -0.9),
            ),
            (
                DVec3::new(0.0, 1.0, -20.0),
                DVec3::new(0.0, 1.0, 0.6),
                DVec3::Y,
                -DVec3::Z,
            ),
        ];
        let (mut dropped, mut after) = (0, 0);
        let (mut met, mut close) = (0, 0);
        for radius in [1e3, 1e5] {
            spheres.push(Sphere {
                center_world: DVec3::new(0.0, -radius, 0.0),
                radius,
                color: DVec3::ONE,
            });
            let ground = spheres.len() as u32 - 1;
            for &(vrp, vpn, vuv, cop) in &cameras {
                let camera = Camera {
                    vrp_world: vrp,
                    basis: Basis::from_vpn_vuv(vpn, vuv).unwrap(),
                    cop_view: cop,
                    window: DVec2::new(1.6, 0.9),
                };
                let view: Vec<ViewSphere> = spheres
                    .iter()
                    .enumerate()
                    .map(|(k, s)| ViewSphere::new(&camera, s.ball(), k as u32))
                    .collect();
                let columns = ViewColumns::new(camera.cop_view, &view);
                let shading = unlit(&columns);
                for (samples, side) in [(1, TILE), (1, DENSE_TILE), (3, TILE)] {
                    let raster = Raster {
                        width: 96,
                        height: 72,
                        samples,
                        adaptive: false,
                    };
                    let table = RayTable::new(cop, camera.window, raster);
                    let (ranks, reach) = (Ranks::SCENE, view[ground as usize].reach());
                    let bins =
                        TileBins::build_in(Isa::Portable, &columns, ranks, &table, raster, side);
                    let wide = Wide::new(ground, &reach, &table, raster, side);
                    let g = &view[ground as usize];
                    // Per tile, the ground's bound and its nearest hit by a sample.
                    let across = 96usize.div_ceil(side);
                    let mut bound = vec![(None, f64::INFINITY); across * 72usize.div_ceil(side)];
                    let s2 = (samples * samples) as usize;
                    for j in 0..72 {
                        for i in 0..96 {
                            let list = bins.at(i, j);
                            let (tx, ty) = (i / side, j / side);
                            let tile = &mut bound[ty * across + tx];
                            // With the COP inside the ground, it is in every tile.
                            if i % side == 0 && j % side == 0 {
                                tile.0 = match &wide {
                                    Some(w) => w.nearest(tx, ty, &mut None, &table, raster),
                                    None => Some(g.min_dist),
                                };
                            }
                            for d in (0..s2).map(|k| table.direction(i, j, k)) {
                                if let Some(t) = root(g.f, g.c(), g.radius * g.radius, d) {
                                    tile.1 = tile.1.min(t);
                                }
                            }
                            if i % side == 0 && j % side == 0 {
                                match list.iter().position(|&k| k == ground) {
                                    None => dropped += 1,
                                    Some(at) => after += (at > 0) as usize,
                                }
                            }
                            for d in (0..s2).map(|k| table.direction(i, j, k)) {
                                let mut every: Option<(usize, f64)> = None;
                                for (k, s) in view.iter().enumerate() {
                                    let t = root(s.f, s.c(), s.radius * s.radius, d);
                                    if let Some(t) = t.filter(|&t| every.is_none_or(|b| t < b.1)) {
                                        every = Some((k, t));
                                    }
                                }
                                let fast = nearest(&shading, &bins, (i, j), d);
                                assert_eq!(fast, every, "ground {radius}, pixel ({i}, {j})");
                            }
                        }
                    }
                    // The bound is below every hit of the tile's samples, and not far below the
                    // nearest.
                    for &(near, t) in &bound {
                        if t.is_finite() {
                            let near = near.expect("a tile whose samples meet the ground keeps it");
                            assert!(near <= t, "bound {near} above a hit at {t}");
                            met += 1;
                            close += (t - near < 0.1 * t) as usize;
                        }
                    }
                }
            }
            spheres.pop();
        }
        // The placement was exercised: the ground left out of some tiles, and later than first
        // in others.
        assert!(
            dropped > 20 && after > 20,
            "dropped {dropped}, after {after}"
        );
        // Within 10% of the nearest hit in most tiles.
        assert!(close * 4 > met * 3, "{close} of {met} tiles");
    }

    /// The primary-ray search over `spheres`, with no lights.
    fn unlit(spheres: &ViewColumns) -> Shading<'_> {
        static NONE: Spheres = Spheres::new();
        Shading {
            spheres,
            scene: &NONE,
            lights: &[],
            ambient: 0.0,
            background: DVec3::ZERO,
        }
    }

    /// A sphere given in view coordinates, as `ViewSphere::new` makes it.
    fn in_view(center: DVec3, r: f64, cop: DVec3) -> ViewSphere {
        ViewSphere::in_view(center, r, cop, 0)
    }

    /// A sphere without screen bounds that a ray at a tile's edge or corner barely enters
    /// (10⁻⁶ of its radius deep) stays in the tile's list, and the ray finds it: for every
    /// tile, edge and corner, with one sample a pixel and 3×3, and the COP off the axis.
    #[test]
    fn a_grazing_hit_keeps_a_wide_sphere_in_its_tile() {
        let (cop, window) = (DVec3::new(0.2, -0.1, -1.0), DVec2::new(1.6, 1.0));
        let r = 1e4;
        for (samples, side) in [(1, TILE), (1, DENSE_TILE), (3, TILE)] {
            let raster = Raster {
                width: 40,
                height: 24,
                samples,
                adaptive: false,
            };
            let table = RayTable::new(cop, window, raster);
            let s = samples as usize;
            let (across, down) = (40usize.div_ceil(side), 24usize.div_ceil(side));
            for (tx, ty) in (0..across).flat_map(|tx| (0..down).map(move |ty| (tx, ty))) {
                let (i0, j0) = (tx * side, ty * side);
                let (i1, j1) = (((tx + 1) * side).min(40) - 1, ((ty + 1) * side).min(24) - 1);
                // The middle sample of each edge and each corner sample (samples are row-major
                // in a pixel), and the way out of the tile there: columns grow along x, rows
                // downwards.
                let (mid_i, mid_j) = ((i0 + i1) / 2, (j0 + j1) / 2);
                let edges = [
                    ((i0, mid_j), s / 2 * s, -DVec3::X),
                    ((i1, mid_j), s / 2 * s + s - 1, DVec3::X),
                    ((mid_i, j0), s / 2, DVec3::Y),
                    ((mid_i, j1), (s - 1) * s + s / 2, -DVec3::Y),
                    ((i0, j0), 0, DVec3::new(-1.0, 1.0, 0.0)),
                    ((i1, j0), s - 1, DVec3::new(1.0, 1.0, 0.0)),
                    ((i0, j1), (s - 1) * s, DVec3::new(-1.0, -1.0, 0.0)),
                    ((i1, j1), s * s - 1, DVec3::new(1.0, -1.0, 0.0)),
                ];
                for ((i, j), k, out) in edges {
                    let d = table.direction(i, j, k);
                    let n = (out - d * d.dot(out)).normalize();
                    let sphere = in_view(cop + d * 50.0 + n * (r * (1.0 - 1e-6)), r, cop);
                    let f = sphere.f;
                    let view = [sphere];
                    assert_eq!(
                        footprint(&sphere.reach(), cop, window, raster),
                        Footprint::Everywhere
                    );
                    let columns = ViewColumns::new(cop, &view);
                    let ranks = Ranks::SCENE;
                    let bins =
                        TileBins::build_in(Isa::Portable, &columns, ranks, &table, raster, side);
                    let shading = unlit(&columns);
                    let t = root(f, sphere.c(), sphere.radius * sphere.radius, d);
                    assert!(t.is_some(), "the ray meets the sphere");
                    let found = nearest(&shading, &bins, (i, j), d);
                    assert_eq!(
                        found,
                        t.map(|t| (0, t)),
                        "tile ({tx}, {ty}), pixel ({i}, {j})"
                    );
                }
            }
        }
    }

    /// A wide sphere goes into a tile's list at its bound there, and a sphere whose `min_dist`
    /// is that bound exactly goes before or after it by their scene indices, whichever order
    /// the ranks and the columns hold them in.
    #[test]
    fn a_wide_sphere_tied_with_another_is_placed_by_scene_index() {
        let (cop, window) = (DVec3::new(0.1, 0.05, -1.0), DVec2::new(1.6, 1.0));
        let raster = Raster {
            width: 40,
            height: 24,
            samples: 1,
            adaptive: false,
        };
        let table = RayTable::new(cop, window, raster);
        // A ground far below the middle of the view, and a small sphere in front of it.
        let r = 1e4;
        let ground = in_view(DVec3::new(0.0, -r - 3.0, 20.0), r, cop);
        let small = in_view(DVec3::new(0.0, -3.5, 10.0), 0.5, cop);
        let (tx, ty) = (1, 1);
        let wide = Wide::new(0, &ground.reach(), &table, raster, TILE).expect("the COP is outside");
        let bound = (wide.nearest(tx, ty, &mut None, &table, raster))
            .expect("the tile's rays meet the ground");
        for (ground_id, small_id) in [(0, 1), (1, 0)] {
            for ranks in [None, Some(vec![1, 0])] {
                let mut columns = ViewColumns::new(cop, &[ground, small]);
                columns.id = vec![ground_id, small_id];
                columns.min_dist[1] = bound;
                let ranks = Ranks(ranks.as_deref());
                let bins = TileBins::build(Isa::Portable, &columns, ranks, &table, raster);
                let list = bins.at(tx * TILE, ty * TILE);
                let scene = |k: u32| ranks.scene_index(columns.id[k as usize] as u32);
                let want: Vec<u32> = if scene(0) < scene(1) {
                    vec![0, 1]
                } else {
                    vec![1, 0]
                };
                assert_eq!(list, want, "ids {ground_id}, {small_id}, {ranks:?}");
            }
        }
    }
}
