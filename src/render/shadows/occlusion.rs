//! A packet's shadow rays: which of its lanes' points a light does not reach, through the
//! frame's [`FrameShadows`] (a row's hint first, then the grid's cells under the points, or
//! the scene's hierarchy when the grid is not built).

use glam::{DVec3, Vec4};

use super::super::bins::CellRect;
use super::super::lanes::{dot, splat3, ForLanes, Lanes, LANES};
use super::{cell_key, cell_rect, FrameShadows, Hierarchy, NO_HINT};

impl FrameShadows<'_> {
    /// Whether the ray from each view point (on sphere `own`) towards the light meets another
    /// sphere, for the lanes in `need`: which of them the light does not reach. Whether any
    /// sphere blocks a ray does not depend on the order of the tests, so lanes sharing a grid
    /// cell test its spheres together, and `hint`, the last sphere found blocking a ray of an
    /// earlier packet of the row (or [`NO_HINT`]), is tested first: neighbouring points are
    /// mostly in the same sphere's shadow, and a packet that it blocks whole skips the grid. The
    /// hint is cleared when it blocks no lane, and set to each sphere the grid's walk finds
    /// blocking.
    #[inline(always)]
    pub(in crate::render) fn occluded<V: Lanes>(
        &self,
        point: &[V; 3],
        own: V::Index,
        need: u8,
        hint: &mut u32,
    ) -> u8 {
        let sh = self;
        let tok = point[0].token();
        let mut blocked = 0u8;
        for &(k, c, r2) in &sh.always {
            // Lanes on the sphere itself (points on a ground sphere) skip it.
            if need & !V::index_eq(own, V::index(tok, k as u64)) == 0 {
                continue;
            }
            blocked |= need & blocks(sh, point, own, k, c, r2);
            if need & !blocked == 0 {
                return blocked;
            }
        }
        if sh.grid.dims.0 == 0 {
            // No cells: nothing binned, or a frame whose shadow rays walk the hierarchy, out
            // of line (`tree_shadows`), so that every other frame's rows keep their code.
            if sh.tree.is_some() {
                let point = [point[0].store(), point[1].store(), point[2].store()];
                let own = V::index_store(own);
                (blocked, *hint) = tree_shadows(sh, point, own, need, blocked, *hint);
            }
            return blocked;
        }
        if *hint != NO_HINT {
            let (k, c, r2) = sh.blocker(*hint);
            let found = need & !blocked & blocks(sh, point, own, k, c, r2);
            if found == 0 {
                *hint = NO_HINT;
            }
            blocked |= found;
            if need & !blocked == 0 {
                return blocked;
            }
        }
        let (low, q, err) = sh.on_plane(point);
        let inv = V::splat(tok, sh.grid.inv_cell);
        let lo = [q[0].sub(err).mul(inv), q[1].sub(err).mul(inv)];
        let hi = [q[0].add(err).mul(inv), q[1].add(err).mul(inv)];
        // Lanes whose square misses the grid (or is NaN) have no cells; the others' ranges are
        // clamped to it (the far edges belong to the last cells).
        let zero = V::splat(tok, 0.0);
        let (w, h) = sh.grid.dims;
        let on_grid = hi[0].ge(zero) & hi[1].ge(zero);
        let on_grid =
            on_grid & lo[0].le(V::splat(tok, w as f64)) & lo[1].le(V::splat(tok, h as f64));
        let pending = need & !blocked & on_grid;
        if pending == 0 {
            return blocked;
        }
        let (x0, x1) = (cell_index(lo[0], w), cell_index(hi[0], w));
        let (y0, y1) = (cell_index(lo[1], h), cell_index(hi[1], h));
        // The cells of all pending lanes together. Testing a lane against a sphere outside its own
        // cells cannot change its answer: every sphere that blocks its ray is binned in its cells.
        // So when the lanes' cells make a small rectangle, its spheres are tested on all of them.
        let (mut cx, mut cy) = ((i32::MAX, 0), (i32::MAX, 0));
        for l in 0..LANES {
            if pending >> l & 1 == 1 {
                cx = (cx.0.min(x0[l]), cx.1.max(x1[l]));
                cy = (cy.0.min(y0[l]), cy.1.max(y1[l]));
            }
        }
        if (cx.1 - cx.0 + 1) * (cy.1 - cy.0 + 1) <= UNION_CELLS {
            let cells = (cx.0 as usize, cx.1 as usize, cy.0 as usize, cy.1 as usize);
            let (blocked, found) = walk(sh, point, own, (low, q, err), cells, pending, blocked);
            if found != NO_HINT {
                *hint = found;
            }
            return blocked;
        }
        let mut key = [u64::MAX; LANES];
        for l in 0..LANES {
            if pending >> l & 1 == 1 {
                let at = |c: [i32; LANES]| c[l] as usize;
                key[l] = cell_key((at(x0), at(x1), at(y0), at(y1)));
            }
        }
        // Lanes whose squares fall in the same single cell test its spheres together.
        for l in 0..LANES {
            let here = key[l];
            if here == u64::MAX {
                continue;
            }
            let cells = cell_rect(here);
            let single = cells.0 == cells.1 && cells.2 == cells.3;
            let mut lanes = 0u8;
            for (m, other) in key.iter_mut().enumerate().skip(l) {
                if *other == here && (single || m == l) {
                    lanes |= 1 << m;
                    *other = u64::MAX;
                }
            }
            let found;
            (blocked, found) = walk(sh, point, own, (low, q, err), cells, lanes, blocked);
            if found != NO_HINT {
                *hint = found;
            }
        }
        blocked
    }
}

impl FrameShadows<'_> {
    /// Each point on the light's plane, `q`, widened by the rounding allowance `err` (1e-9 of
    /// the coordinates' scale, far above the rounding by which a view point reaches the grid in
    /// world coordinates, so a point on a cell's edge looks in both cells), and how far it lies
    /// towards the light less the allowance, `low` (`FrameShadows::up`): a sphere whose top is
    /// below this cannot block the lane's ray.
    #[inline(always)]
    fn on_plane<V: Lanes>(&self, point: &[V; 3]) -> (V, [V; 2], V) {
        let tok = point[0].token();
        let (ax, ay) = self.axes;
        let q = [
            dot(point, &splat3(tok, ax)).add(V::splat(tok, self.offset.x)),
            dot(point, &splat3(tok, ay)).add(V::splat(tok, self.offset.y)),
        ];
        let size = point[0].abs().max(point[1].abs()).max(point[2].abs());
        let err = V::splat(tok, 1e-9).mul(V::splat(tok, self.slack).add(size));
        let low = dot(point, &splat3(tok, self.up))
            .add(V::splat(tok, self.height))
            .sub(err);
        (low, q, err)
    }
}

/// `blocked` with the lanes in `lanes` that a sphere of grid cells `cells` blocks added, until
/// every one of them is blocked, and the last sphere found blocking (or [`NO_HINT`]). A cell
/// is read down to the first sphere whose top is below every open lane's `low`; a sphere whose
/// disc misses every open lane's point `q` on the grid's plane, by more than the lane's
/// allowance `err`, is passed untested (see [`super::Disc`]). A function, not a closure, so
/// that it is inlined into the one compiled for the instruction set.
#[inline(always)]
fn walk<V: Lanes>(
    sh: &FrameShadows,
    point: &[V; 3],
    own: V::Index,
    (low, q, err): (V, [V; 2], V),
    (x0, x1, y0, y1): CellRect,
    lanes: u8,
    mut blocked: u8,
) -> (u8, u32) {
    let tok = low.token();
    let mut last = NO_HINT;
    let (discs, order) = (&sh.grid.discs, &sh.grid.order);
    for y in y0..=y1 {
        for x in x0..=x1 {
            let cell = sh.grid.bins.cell(x, y);
            // A cell lists its spheres by their positions in the grid's order.
            for (i, &p) in cell.iter().enumerate() {
                // A cell's spheres lie anywhere in the scene's memory (their discs near each
                // other): the one BLOCKER_AHEAD entries on is asked for now, so that its reads
                // overlap this one's test.
                if let Some(&ahead) = cell.get(i + BLOCKER_AHEAD) {
                    sh.prefetch_blocker(ahead);
                }
                let disc = discs[p as usize];
                let reach = lanes & !blocked & V::splat(tok, disc.top as f64).ge(low);
                if reach == 0 {
                    break;
                }
                // The lanes whose point, within its allowance, falls in the sphere's disc.
                let dx = q[0].sub(V::splat(tok, disc.x as f64));
                let dy = q[1].sub(V::splat(tok, disc.y as f64));
                let r = V::splat(tok, disc.r as f64).add(err);
                let reach = reach & dx.mul(dx).add(dy.mul(dy)).le(r.mul(r));
                if reach == 0 {
                    continue;
                }
                let k = order.rank(p as usize);
                blocked |= blocks_exactly(sh, point, own, k, reach, &mut last);
                if lanes & !blocked == 0 {
                    return (blocked, last);
                }
            }
        }
    }
    (blocked, last)
}

/// The lanes of `lanes` whose rays sphere `k` blocks, tested exactly ([`blocks`]), with `last`
/// set to `k` when it blocks any: both walks' last step.
#[inline(always)]
fn blocks_exactly<V: Lanes>(
    sh: &FrameShadows,
    point: &[V; 3],
    own: V::Index,
    k: u32,
    lanes: u8,
    last: &mut u32,
) -> u8 {
    let (k, c, r2) = sh.blocker(k);
    let found = lanes & blocks(sh, point, own, k, c, r2);
    if found != 0 {
        *last = k;
    }
    found
}

/// The lanes whose coordinate `q` may lie within `e` of `p`, widened by each lane's allowance
/// `err` (NaN sums leave a lane in). A function, not a closure: a closure over lanes is not
/// always inlined into the instruction path's code, and its intrinsics are then calls.
#[inline(always)]
fn within<V: Lanes>(q: V, p: f64, e: f64, err: V) -> u8 {
    let tok = q.token();
    !q.sub(V::splat(tok, p)).abs().gt(V::splat(tok, e).add(err))
}

/// [`TreeShadows`] run on the frame's instruction set: the lanes blocked and the hint after
/// it. Called from the rows' code, never inlined into it: the walk and its dispatch would
/// change how the rows are compiled (small scenes' frames were 8–13% slower with it inlined).
#[cold]
#[inline(never)]
fn tree_shadows(
    sh: &FrameShadows,
    point: [[f64; LANES]; 3],
    own: [u64; LANES],
    need: u8,
    blocked: u8,
    hint: u32,
) -> (u8, u32) {
    let Some((tree, isa)) = sh.tree else {
        return (blocked, hint);
    };
    isa.run(TreeShadows {
        sh,
        tree,
        point,
        own,
        need,
        blocked,
        hint,
    })
}

/// A packet's shadow rays through the hierarchy, as work for `Isa::run`: its points, the
/// spheres they lie on, the lanes to answer, those already blocked and the row's hint. Gives
/// the lanes blocked and the hint after it: the hint first, as [`FrameShadows::occluded`]
/// tests it, then [`tree_walk`].
struct TreeShadows<'a, 'b> {
    sh: &'a FrameShadows<'b>,
    tree: Hierarchy<'b>,
    point: [[f64; LANES]; 3],
    own: [u64; LANES],
    need: u8,
    blocked: u8,
    hint: u32,
}

impl ForLanes for TreeShadows<'_, '_> {
    type Output = (u8, u32);

    #[inline(always)]
    fn run<V: Lanes>(self, tok: V::Token) -> (u8, u32) {
        let TreeShadows {
            sh,
            tree,
            need,
            mut blocked,
            mut hint,
            ..
        } = self;
        let point = self.point.map(|a| V::load(tok, &a));
        let mut own = V::index(tok, self.own[0]);
        for (l, &k) in self.own.iter().enumerate().skip(1) {
            own = V::index_blend(1 << l, own, V::index(tok, k));
        }
        if hint != NO_HINT {
            let (k, c, r2) = sh.blocker(hint);
            let found = need & !blocked & blocks(sh, &point, own, k, c, r2);
            if found == 0 {
                hint = NO_HINT;
            }
            blocked |= found;
            if need & !blocked == 0 {
                return (blocked, hint);
            }
        }
        let plane = sh.on_plane(&point);
        let (blocked, found) = tree_walk(sh, &tree, &point, own, plane, need & !blocked, blocked);
        if found != NO_HINT {
            hint = found;
        }
        (blocked, hint)
    }
}

/// `blocked` with the lanes in `lanes` that a sphere of the scene's hierarchy blocks added,
/// until every one of them is blocked, and the last sphere found blocking (or [`NO_HINT`]): the
/// grid's walk ([`walk`]) over the hierarchy's boxes and shapes instead of its cells.
///
/// A sphere can block a lane's ray only if the lane's point `q` on the light's plane falls in
/// its disc and the lane lies below its top (`low`, less the allowance `err`). The lanes' points,
/// each widened by its allowance, make a rectangle on the plane: a node is passed when the
/// projection of its box (its centre's, widened by the box's half sides along each axis) misses
/// that rectangle or its top is below every lane, a shape when its disc (centre and radius in
/// f32, holding the sphere) misses every open lane's point, or its top is below it. Both hold
/// the exact sphere, and the allowances are those of the grid's walk, far above these sums'
/// rounding. Every test is written to pass a node or shape only when it surely misses: a box
/// or shape past f32's range (infinite or NaN sums) is walked or tested. The spheres left are
/// tested exactly ([`blocks`]).
#[inline(always)]
fn tree_walk<V: Lanes>(
    sh: &FrameShadows,
    tree: &Hierarchy,
    point: &[V; 3],
    own: V::Index,
    (low, q, err): (V, [V; 2], V),
    lanes: u8,
    mut blocked: u8,
) -> (u8, u32) {
    let tok = low.token();
    let mut last = NO_HINT;
    if tree.nodes.is_empty() {
        return (blocked, last);
    }
    let (qx, qy, lows, errs) = (q[0].store(), q[1].store(), low.store(), err.store());
    // The rectangle of the lanes' points with their allowances, and the lowest of them.
    let (mut x0, mut x1, mut y0, mut y1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
    let mut lowest = f64::MAX;
    for l in 0..LANES {
        if lanes >> l & 1 == 1 {
            x0 = x0.min(qx[l] - errs[l]);
            x1 = x1.max(qx[l] + errs[l]);
            y0 = y0.min(qy[l] - errs[l]);
            y1 = y1.max(qy[l] + errs[l]);
            lowest = lowest.min(lows[l]);
        }
    }
    let (ax, ay) = sh.world_axes;
    let up = tree.to_light;
    // Where a box or ball of centre `c` and half sides (or radius along every axis) `h` lies
    // on each axis of the plane and along the light: centre and half width.
    let reach = |c: DVec3, h: DVec3| {
        [
            (c.dot(ax), h.dot(ax.abs())),
            (c.dot(ay), h.dot(ay.abs())),
            (c.dot(up), h.dot(up.abs())),
        ]
    };
    // Whether it surely misses every lane: wholly beside the rectangle, or below every lane.
    let misses = |[(px, ex), (py, ey), (pt, et)]: [(f64, f64); 3]| {
        px + ex < x0 || px - ex > x1 || py + ey < y0 || py - ey > y1 || pt + et < lowest
    };
    // Each level halves its node's spheres: at most 32 levels for u32 ranks, and at most one
    // node more waiting than levels walked.
    let mut stack = [0u32; 64];
    let mut depth = 1;
    while depth > 0 {
        depth -= 1;
        let at = stack[depth];
        let node = &tree.nodes[at as usize];
        let [lo, hi] = node.bounds();
        let [(px, ex), (py, ey), (pt, et)] = reach((lo + hi) * 0.5, (hi - lo) * 0.5);
        if misses([(px, ex), (py, ey), (pt, et)]) {
            continue;
        }
        // Lane by lane: an open lane whose point (within its allowance) may fall in the box's
        // projection and lies below its top.
        let open = lanes & !blocked & within(q[0], px, ex, err) & within(q[1], py, ey, err);
        if open & !V::splat(tok, pt + et).lt(low) == 0 {
            continue;
        }
        if node.count == 0 {
            // Both children; the one at `start` is walked second.
            stack[depth] = node.start;
            stack[depth + 1] = at + 1;
            depth += 2;
            continue;
        }
        let start = node.start as usize;
        let end = start + node.count as usize;
        for (p, shape) in (start..end).zip(&tree.shapes[start..end]) {
            let k = tree.order.rank(p);
            let s = Vec4::from(*shape).as_dvec4();
            let (c, r) = (s.truncate(), s.w);
            let [(px, _), (py, _), (pt, _)] = reach(c, DVec3::ZERO);
            if misses([(px, r), (py, r), (pt, r)]) {
                continue;
            }
            // The open lanes not below its top, whose point, within its allowance, may fall in
            // its disc (NaN sums leave a lane open).
            let dx = q[0].sub(V::splat(tok, px));
            let dy = q[1].sub(V::splat(tok, py));
            let rr = V::splat(tok, r).add(err);
            let open = lanes & !blocked & !V::splat(tok, pt + r).lt(low);
            let open = open & !dx.mul(dx).add(dy.mul(dy)).gt(rr.mul(rr));
            if open == 0 {
                continue;
            }
            blocked |= blocks_exactly(sh, point, own, k, open, &mut last);
            if lanes & !blocked == 0 {
                return (blocked, last);
            }
        }
    }
    (blocked, last)
}

/// How many entries of a cell ahead `walk` asks for a sphere (the walk mostly stops within a
/// few entries).
const BLOCKER_AHEAD: usize = 2;

/// The most grid cells that a shadow packet walks for all its lanes together.
const UNION_CELLS: i32 = 4;

/// `(v.max(0.0) as usize).min(n - 1)` per lane, for lanes that are not NaN: the cell of a
/// grid coordinate, clamped to a side of `n` cells.
#[inline(always)]
fn cell_index<V: Lanes>(v: V, n: usize) -> [i32; LANES] {
    let tok = v.token();
    let last = n as i32 - 1;
    // Clamped as floats first, so that no lane is out of the conversion's range.
    v.max(V::splat(tok, 0.0))
        .min(V::splat(tok, last as f64))
        .to_i32(last)
}

/// The lanes whose shadow ray sphere k (centre `c`, r² `r2`, in view coordinates) blocks,
/// leaving out lanes on sphere k itself. A point inside (or on) the sphere is blocked; outside,
/// both roots share a sign, positive exactly when the sphere lies ahead. No epsilon is needed:
/// a point's own sphere, being convex, never shadows its own lit side.
#[inline(always)]
fn blocks<V: Lanes>(
    sh: &FrameShadows,
    point: &[V; 3],
    own: V::Index,
    k: u32,
    c: glam::DVec3,
    r2: f64,
) -> u8 {
    let tok = point[0].token();
    let (zero, r2) = (V::splat(tok, 0.0), V::splat(tok, r2));
    let dir = splat3::<V>(tok, sh.to_light);
    let f = [
        point[0].sub(V::splat(tok, c.x)),
        point[1].sub(V::splat(tok, c.y)),
        point[2].sub(V::splat(tok, c.z)),
    ];
    let cc = dot(&f, &f).sub(r2);
    let b = dot(&f, &dir);
    // Neither inside nor ahead on any lane (a ground below every point): no root to look at.
    if cc.le(zero) | b.lt(zero) == 0 {
        return 0;
    }
    let g = [
        f[0].sub(dir[0].mul(b)),
        f[1].sub(dir[1].mul(b)),
        f[2].sub(dir[2].mul(b)),
    ];
    let g2 = dot(&g, &g);
    let hit = cc.le(zero) | (b.lt(zero) & g2.le(r2));
    hit & !V::index_eq(own, V::index(tok, k as u64))
}

#[cfg(test)]
mod tests {
    use super::super::super::lanes::Portable;
    use super::super::super::oracle::blocks_ray;
    use super::super::super::simd::Isa;
    use super::super::super::world::SceneIndex;
    use super::super::tests::{cluster, reversed, seeded_cluster};
    use super::super::Casters;
    use super::super::{view_center, ShadowGrid};
    use super::*;
    use crate::camera::{Basis, Camera};
    use crate::scene::{Light, Scene, Sphere, Spheres};
    use glam::{DVec2, DVec3};

    /// Up to eight (view point, own sphere) pairs as a packet: the points, their spheres and
    /// the lanes in use (the last pair repeated in the rest).
    fn packet(lanes: &[(DVec3, u32)]) -> ([Portable; 3], [u64; LANES], u8) {
        let mut xyz = [[0.0; LANES]; 3];
        let mut own = [0u64; LANES];
        for l in 0..LANES {
            let (point, o) = lanes[l.min(lanes.len() - 1)];
            for a in 0..3 {
                xyz[a][l] = point[a];
            }
            own[l] = o as u64;
        }
        let need = (0xffu16 >> (LANES - lanes.len())) as u8;
        (xyz.map(|a| Portable::load((), &a)), own, need)
    }

    /// A shadow packet's answer per lane is the one-ray answer of testing every sphere: eight
    /// points at a time from spheres next to each other in the list, so that a packet's lanes
    /// lie on different spheres and in cells near or far apart (the union walk and the walks
    /// per group of lanes), with the light's tops cutting each cell short; without a hint, and
    /// with the hint carried from packet to packet as along a row (some packets answered by
    /// the hint alone, some in part, some not at all).
    #[test]
    fn shadow_packets_find_every_blocker() {
        let c = cluster();
        let centers: std::sync::Arc<[_]> = c
            .spheres
            .iter()
            .map(|s| view_center(&c.camera, s.ball()))
            .collect();
        // Neighbouring points of a sphere (lanes in one cell or a few), and every 7th point
        // (lanes on different spheres, cells far apart).
        let picked = [1, 7].map(|n| c.points.iter().step_by(n).copied().collect::<Vec<_>>());
        for light in &c.lights {
            for all in [None, Some(centers.clone())] {
                let frame = FrameShadows::new(
                    Isa::Portable,
                    Casters::Grid(&light.grid),
                    &c.camera,
                    &c.spheres,
                    all,
                    light.to_light,
                );
                let mut hint = NO_HINT;
                let mut hinted = [0; 3];
                for (p, lanes) in picked.iter().flat_map(|p| p.chunks(LANES)).enumerate() {
                    let (point, own, need) = packet(lanes);
                    let got = frame.occluded::<Portable>(&point, own, need, &mut NO_HINT.clone());
                    let before = hint;
                    let with_hint = frame.occluded::<Portable>(&point, own, need, &mut hint);
                    assert_eq!(with_hint, got, "packet {p} with hint {before}");
                    if before != NO_HINT {
                        let (k, center, r2) = frame.blocker(before);
                        let by_hint = need & blocks(&frame, &point, own, k, center, r2);
                        hinted[(by_hint != 0) as usize + (by_hint == need) as usize] += 1;
                    }
                    for (l, &lane) in lanes.iter().enumerate() {
                        let every = c.any_blocker(light.to_light, lane);
                        let direction = light.direction;
                        assert_eq!(
                            got >> l & 1 == 1,
                            every,
                            "packet {p}, lane {l}, {direction}"
                        );
                    }
                }
                // Packets whose hint blocked none of their lanes, some, and all.
                assert!(hinted.iter().all(|&n| n > 0), "{hinted:?}");
            }
        }
    }

    /// Over seeded clusters from sparse to discs many deep (cells of many spheres whose tops
    /// lie close together), every lane of a packet through the grid, its hint carried along,
    /// answers as testing every sphere does.
    #[test]
    fn shadow_packets_match_every_sphere_over_seeded_clusters() {
        for (seed, n) in [(3, 150), (5, 700), (7, 1500)] {
            let c = seeded_cluster(seed, n, 4);
            for light in &c.lights {
                let frame = FrameShadows::new(
                    Isa::Portable,
                    Casters::Grid(&light.grid),
                    &c.camera,
                    &c.spheres,
                    None,
                    light.to_light,
                );
                let mut hint = NO_HINT;
                let mut shadowed = 0;
                for (p, lanes) in c.points.chunks(LANES).enumerate() {
                    let (point, own, need) = packet(lanes);
                    let got = frame.occluded::<Portable>(&point, own, need, &mut hint);
                    for (l, &lane) in lanes.iter().enumerate() {
                        let every = c.any_blocker(light.to_light, lane);
                        assert_eq!(
                            got >> l & 1 == 1,
                            every,
                            "seed {seed}, packet {p}, lane {l}"
                        );
                        shadowed += every as usize;
                    }
                }
                // Both answers occur.
                assert!(shadowed > 0 && shadowed < c.points.len(), "{shadowed}");
            }
        }
    }

    /// Points on the edges of other spheres' shadows (on the rim as seen along the light, a
    /// hair inside and outside it, and inside a sphere next to its rim) are answered as testing
    /// every sphere does, near the origin, in a scene 2·10⁶ wide (where rounding a centre to
    /// f32 moves it by up to 0.125, most of the smallest radius), and 10¹² and 10¹⁵ off it
    /// (where only the lanes' allowance covers the rounding between view and world
    /// coordinates): the discs and their allowances never pass a sphere that blocks.
    #[test]
    fn shadow_edges_are_found_near_and_far_from_the_origin() {
        let mut rng = crate::splitmix::SplitMix(0xed9e);
        for (offset, spread, radius) in [
            (0.0, 20.0, 0.5),
            (0.0, 2e6, 0.3),
            (1e12, 20.0, 0.5),
            (-1e15, 5.0, 0.5),
        ] {
            let mut unit = || rng.unit();
            let groups: Vec<DVec3> = (0..8)
                .map(|_| DVec3::new(unit() * spread, unit() * spread * 0.2, unit() * spread))
                .collect();
            let spheres: Spheres = (0..300)
                .map(|k| Sphere {
                    center_world: DVec3::splat(offset)
                        + groups[k % 8]
                        + DVec3::new(unit() * 6.0, unit() * 3.0, unit() * 6.0),
                    radius: radius * (0.5 + unit()),
                    color: DVec3::ONE,
                })
                .collect();
            let direction = DVec3::new(unit() - 0.5, -1.0, unit() - 0.5).normalize();
            let camera = Camera {
                vrp_world: DVec3::splat(offset) + groups[0] + DVec3::new(-15.0, 7.0, -9.0),
                basis: Basis::from_vpn_vuv(DVec3::new(1.0, -0.3, 0.6), DVec3::Y).unwrap(),
                cop_view: DVec3::new(0.0, 0.0, -1.2),
                window: DVec2::new(1.6, 0.9),
            };
            let grid = ShadowGrid::build(&spheres, reversed(spheres.len()), -direction);
            let to_light = -camera.basis.to_view(direction);
            // The grid's walk, and the hierarchy's of the same spheres (kept whole, not copied
            // along the curve, so that ranks are the spheres' indices).
            let scene = Scene {
                background: DVec3::ZERO,
                ambient: 0.0,
                lights: vec![Light {
                    direction_world: direction,
                    color: DVec3::ONE,
                    shadows: true,
                }],
                spheres: Spheres::wide(spheres.iter().collect()),
            };
            let index = SceneIndex::building(&scene, 0, true);
            let casters = [Casters::Grid(&grid), index.shadows_through_tree(0).unwrap()];
            let frames = casters
                .map(|c| FrameShadows::new(Isa::Portable, c, &camera, &spheres, None, to_light));
            let centers: Vec<(DVec3, f64)> = spheres
                .iter()
                .map(|s| view_center(&camera, s.ball()))
                .collect();
            // Below each sphere, on its shadow's edge and a hair either side of it, and inside it
            // next to its rim; the point's own sphere is none of them.
            let mut points = Vec::new();
            for (&(c, _), s) in centers.iter().zip(&spheres) {
                for j in 0..12 {
                    let across =
                        to_light.cross(DVec3::new(unit() - 0.5, unit() - 0.5, unit() - 0.5));
                    let at = [
                        1.0,
                        1.0 - 1e-15,
                        1.0 + 1e-15,
                        1.0 - 1e-12,
                        1.0 - 1e-9,
                        1.0 + 1e-9,
                    ][j % 6];
                    let rim = c + across.normalize() * (s.radius * at);
                    let along = match j < 10 {
                        true => -s.radius * (1.0 + 3.0 * unit()),
                        false => s.radius * 1e-9 * (unit() - 0.5),
                    };
                    points.push((rim + to_light * along, spheres.len() as u32));
                }
            }
            for (frame, through) in frames.iter().zip(["grid", "hierarchy"]) {
                let mut shadowed = 0;
                for lanes in points.chunks(LANES) {
                    let (point, own, need) = packet(lanes);
                    let got = frame.occluded::<Portable>(&point, own, need, &mut NO_HINT.clone());
                    for (l, &(p, _)) in lanes.iter().enumerate() {
                        let every = centers
                            .iter()
                            .any(|&(c, r2)| blocks_ray(c, r2, p, to_light));
                        assert_eq!(
                            got >> l & 1 == 1,
                            every,
                            "{through}: offset {offset:e}, spread {spread:e}, {p}"
                        );
                        shadowed += every as usize;
                    }
                }
                assert!(
                    shadowed > 100 && shadowed < points.len() - 100,
                    "{shadowed}"
                );
            }
        }
    }

    /// A point just below a sphere's top, inside it, is in its shadow, though the top rounded
    /// to the nearest f32 would lie below the point (by more than the query's allowance): the
    /// grid's tops are rounded up.
    #[test]
    fn a_top_rounded_to_f32_still_shadows_the_point_below_it() {
        let to_light = DVec3::Y;
        // A top 0.45 of an f32 step (2^-14 near 1000) above an f32.
        let top = 1000.25 + 0.45 * (1.0 / 16384.0);
        let blocker = Sphere {
            center_world: DVec3::new(0.3, 1000.0, 0.2),
            radius: top - 1000.0,
            color: DVec3::ONE,
        };
        let point_world = DVec3::new(0.3, top - 1e-6, 0.2);
        assert!((top as f32 as f64) < point_world.y - 1e-5);
        let own = Sphere {
            center_world: point_world - DVec3::Y * 0.05,
            radius: 0.05,
            color: DVec3::ONE,
        };
        let spheres = Spheres::from(vec![blocker, own]);
        let camera = Camera {
            vrp_world: DVec3::new(0.0, 1000.0, -5.0),
            basis: Basis::from_vpn_vuv(DVec3::Z, DVec3::Y).unwrap(),
            cop_view: DVec3::new(0.0, 0.0, -1.2),
            window: DVec2::new(1.6, 0.9),
        };
        let grid = ShadowGrid::build(&spheres, reversed(spheres.len()), to_light);
        let to_light_view = camera.basis.to_view(to_light);
        let frame = FrameShadows::new(
            Isa::Portable,
            Casters::Grid(&grid),
            &camera,
            &spheres,
            None,
            to_light_view,
        );
        let (point, own, need) = packet(&[(camera.point_to_view(point_world), 1)]);
        let got = frame.occluded::<Portable>(&point, own, need, &mut NO_HINT.clone());
        assert_eq!(got, need);
    }
}
