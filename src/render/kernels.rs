//! The packet kernels: the nearest hit of a packet of primary rays, and its shading (the
//! lights, the shadow rays through `shadows/`, the clamp). The renderer's only copy of each.
//!
//! Each lane does exactly the operations, in exactly the order, of the plain one-ray-at-a-time
//! oracle in the tests (tests/it/reference.rs): the same dot products, the same stable roots,
//! the same tests. Only the control flow differs — branches become 8-bit lane masks, and a
//! packet leaves the sorted candidate list once every lane would have left it. IEEE addition,
//! multiplication, division and square root are correctly rounded at every vector width, Rust
//! never fuses a multiply and an add on its own, and nothing here uses an approximate
//! reciprocal, so every instruction path gives the same bits.

use glam::DVec3;

use super::lanes::{dot, splat3, InBounds, Lanes, LANES};
use super::shadows::{Hints, NO_HINT};
use super::view::{c_of, ViewColumns, ViewLight};
use crate::scene::Spheres;

/// The frame's scene as the packets shade it: the spheres and lights in view coordinates.
pub(super) struct Shading<'a> {
    pub(super) spheres: &'a ViewColumns,
    /// The scene's spheres by rank, the columns' `id`: a hit sphere's colour.
    pub(super) scene: &'a Spheres,
    pub(super) lights: &'a [ViewLight<'a>],
    pub(super) ambient: f64,
    pub(super) background: DVec3,
}

/// Per lane of a packet: whether it hit (a mask), which sphere, and where.
pub(super) type Found<V> = (u8, <V as Lanes>::Index, V);

impl Shading<'_> {
    /// The nearest hit in front of the COP, among `candidates` (sphere indices, nearest possible
    /// hit first), for two packets (directions `d`, `covers(k, packet)`) at once; the search
    /// stops once no candidate left can be nearer. Each packet does exactly what it would
    /// alone: it passes a sphere that does not cover it, and stops for good at the first one
    /// none of its lanes would test; a packet not `live` takes no part. A lane takes part in a candidate while the one-ray search would still be
    /// running; it may also test a sphere that its tile placed by a bound of its own, below
    /// spheres with a larger `min_dist` (a ground, `tiles.rs`), after the one-ray search has
    /// stopped — a hit there is no nearer than that bound, so the answer is the same.
    #[inline(always)]
    pub(super) fn nearest_packets<V: Lanes>(
        &self,
        d: &[[V; 3]; 2],
        candidates: &[u32],
        covers: impl Fn(u32, usize) -> bool,
        mut live: [bool; 2],
    ) -> [Found<V>; 2] {
        let tok = d[0][0].token();
        let zero = V::splat(tok, 0.0);
        let mut hit = [0u8; 2];
        let mut index = [V::index(tok, 0); 2];
        let mut best = [V::splat(tok, f64::INFINITY); 2];
        let s = self.spheres;
        for &k in candidates {
            let j = k as usize;
            let min_dist = V::splat(tok, s.min_dist[j]);
            let mut active = [0u8; 2];
            for q in 0..2 {
                if live[q] && covers(k, q) {
                    // Lanes still searching: no hit yet, or this sphere might be nearer.
                    active[q] = !hit[q] | !min_dist.ge(best[q]);
                    live[q] = active[q] != 0;
                }
            }
            if !(live[0] | live[1]) {
                break;
            }
            if active[0] | active[1] == 0 {
                continue;
            }
            let (fs, r) = (s.f_at(j), s.radius[j]);
            let f = splat3::<V>(tok, fs);
            let (c, radius2, k) = (
                V::splat(tok, c_of(fs, r)),
                V::splat(tok, r * r),
                V::index(tok, k as u64),
            );
            for q in 0..2 {
                // The smallest t > 0 with |f + t·d| = r, lane by lane, in the numerically
                // stable form (Haines et al., "Precision Improvements for Ray/Sphere
                // Intersection", Ray Tracing Gems ch. 7): the discriminant from |f − (f·d)d|²
                // instead of b² − c, and the root q = −(b + sign(b)√Δ) with the other root c/q,
                // so neither root is the difference of two nearly equal numbers. No branch past
                // the discriminant when no lane meets the sphere: the roots cost less than the
                // mispredicted branches.
                let d = &d[q];
                let b = dot(&f, d);
                let g = [
                    f[0].sub(d[0].mul(b)),
                    f[1].sub(d[1].mul(b)),
                    f[2].sub(d[2].mul(b)),
                ];
                let disc = radius2.sub(dot(&g, &g));
                let meets = active[q] & !disc.lt(zero);
                let root_q = b.add(disc.sqrt().copysign(b)).neg();
                let (t0, t1) = (c.div(root_q), root_q);
                let lt = t0.lt(t1);
                let near = V::blend(lt, t1, t0);
                let far = V::blend(lt, t0, t1);
                let (near_ahead, far_ahead) = (near.gt(zero), far.gt(zero));
                let t = V::blend(near_ahead, far, near);
                let root = !root_q.eq(zero) & (near_ahead | far_ahead);
                let take = meets & root & (!hit[q] | t.lt(best[q]));
                best[q] = V::blend(take, best[q], t);
                index[q] = V::index_blend(take, index[q], k);
                hit[q] |= take;
            }
        }
        [(hit[0], index[0], best[0]), (hit[1], index[1], best[1])]
    }

    /// The linear colours (r, g and b lanes) for a packet with a hit: the ambient plus each
    /// light facing the point and not blocked, times the sphere's colour, clamped; background
    /// where a lane missed, with the shadow rays of each light cast as one packet
    /// (the first [`HINTED_LIGHTS`] lights' with the row's or band's `hints`, see [`occluded`]).
    #[inline(always)]
    pub(super) fn shade_packet<V: Lanes, const SEEN: bool>(
        &self,
        d: &[V; 3],
        hit: u8,
        index: V::Index,
        t: V,
        hints: &mut Hints,
    ) -> ([V; 3], [u32; LANES]) {
        let tok = t.token();
        let mut lights = [0u32; LANES];
        let (zero, one) = (V::splat(tok, 0.0), V::splat(tok, 1.0));
        let fields = SphereLanes::<V>::new(tok, self.spheres, hit, index);
        let mut light = [V::splat(tok, self.ambient); 3];
        if !self.lights.is_empty() {
            let c = fields.vec3(tok, |c| &c.center);
            // f = COP − centre, the subtraction `ViewSphere::in_view` does.
            let cop = splat3::<V>(tok, self.spheres.cop);
            let f = [cop[0].sub(c[0]), cop[1].sub(c[1]), cop[2].sub(c[2])];
            let r = fields.field(tok, |c| &c.radius);
            // The hit relative to the centre, rel = f + d·t, has length r: normal = rel / r,
            // point = centre + rel.
            let rel = [
                f[0].add(d[0].mul(t)),
                f[1].add(d[1].mul(t)),
                f[2].add(d[2].mul(t)),
            ];
            let normal = [rel[0].div(r), rel[1].div(r), rel[2].div(r)];
            let point = [c[0].add(rel[0]), c[1].add(rel[1]), c[2].add(rel[2])];
            for (n, l) in self.lights.iter().enumerate() {
                let facing = dot(&normal, &splat3(tok, l.to_light));
                let mut lit = hit & !facing.le(zero);
                if let Some(grid) = &l.shadows {
                    if lit != 0 {
                        let mut none = NO_HINT;
                        let hint = hints.get_mut(n).unwrap_or(&mut none);
                        lit &= !grid.occluded(&point, fields.ids(tok), lit, hint);
                    }
                }
                let color = l.color.to_array();
                for a in 0..3 {
                    let add = light[a].add(V::splat(tok, color[a]).mul(facing));
                    light[a] = V::blend(lit, light[a], add);
                }
                if SEEN {
                    // `Seen`'s light bits: which lights reach each lane's point.
                    for (k, bits) in lights.iter_mut().enumerate() {
                        *bits |= ((lit >> k & 1) as u32) << n.min(31);
                    }
                }
            }
        }
        let color = fields.colors(tok, self.scene);
        let background = self.background.to_array();
        let flat = self.lights.is_empty();
        let mut out = [zero; 3];
        for a in 0..3 {
            // Clamp to [0, 1] as glam does (max, then min), or only to 1 for a flat scene (no
            // lights: the ambient alone).
            let c = color[a].mul(light[a]);
            let c = if flat {
                c.min(one)
            } else {
                c.max(zero).min(one)
            };
            out[a] = V::blend(hit, V::splat(tok, background[a]), c);
        }
        (out, lights)
    }
}

/// Each lane's sphere, for reading its fields: one sphere for the whole packet when every lane
/// that hit found the same one (the common case), two at a sphere's edge, otherwise lane by
/// lane (gathers from the fields' slices, which cost far more than two reads and a blend). A
/// lane that missed reads sphere 0 (there is one: some lane hit); its results are never used.
enum SphereLanes<'a, V: Lanes> {
    One(&'a ViewColumns, usize),
    /// The second sphere's lanes, and the indices of the two spheres.
    Two(&'a ViewColumns, u8, usize, usize),
    Each(&'a ViewColumns, InBounds<V::Index>),
}

impl<'a, V: Lanes> SphereLanes<'a, V> {
    #[inline(always)]
    fn new(tok: V::Token, spheres: &'a ViewColumns, hit: u8, index: V::Index) -> Self {
        let lanes = V::index_store(index);
        let k = lanes[hit.trailing_zeros() as usize];
        let rest = hit & !V::index_eq(index, V::index(tok, k));
        if rest == 0 {
            return SphereLanes::One(spheres, k as usize);
        }
        let k2 = lanes[rest.trailing_zeros() as usize];
        let second = V::index_eq(index, V::index(tok, k2));
        if rest & !second == 0 {
            SphereLanes::Two(spheres, second, k as usize, k2 as usize)
        } else {
            let own = V::index_blend(hit, V::index(tok, 0), index);
            let len = spheres.len();
            let own = InBounds::new::<V>(own, len).expect("hits index spheres");
            SphereLanes::Each(spheres, own)
        }
    }

    /// A field of each lane's sphere: `column` of the slices.
    #[inline(always)]
    fn field(&self, tok: V::Token, column: impl Fn(&ViewColumns) -> &[f64]) -> V {
        match *self {
            SphereLanes::One(s, k) => V::splat(tok, column(s)[k]),
            SphereLanes::Two(s, second, a, b) => {
                let c = column(s);
                V::blend(second, V::splat(tok, c[a]), V::splat(tok, c[b]))
            }
            SphereLanes::Each(s, own) => V::gather(column(s), own),
        }
    }

    #[inline(always)]
    fn vec3(&self, tok: V::Token, column: impl Fn(&ViewColumns) -> &[Vec<f64>; 3]) -> [V; 3] {
        [
            self.field(tok, |c| &column(c)[0]),
            self.field(tok, |c| &column(c)[1]),
            self.field(tok, |c| &column(c)[2]),
        ]
    }

    /// Each lane's sphere's colour ([`ViewColumns::color`]).
    #[inline(always)]
    fn colors(&self, tok: V::Token, scene: &Spheres) -> [V; 3] {
        match *self {
            SphereLanes::One(s, k) => splat3(tok, s.color(scene, k)),
            SphereLanes::Two(s, second, a, b) => {
                let (a, b) = (s.color(scene, a), s.color(scene, b));
                [
                    V::blend(second, V::splat(tok, a.x), V::splat(tok, b.x)),
                    V::blend(second, V::splat(tok, a.y), V::splat(tok, b.y)),
                    V::blend(second, V::splat(tok, a.z), V::splat(tok, b.z)),
                ]
            }
            SphereLanes::Each(s, own) => {
                let own = V::index_store(own.within(&s.id));
                let mut lanes = [[0.0; LANES]; 3];
                for (l, &k) in own.iter().enumerate() {
                    let color = s.color(scene, k as usize);
                    (lanes[0][l], lanes[1][l], lanes[2][l]) = (color.x, color.y, color.z);
                }
                [
                    V::load(tok, &lanes[0]),
                    V::load(tok, &lanes[1]),
                    V::load(tok, &lanes[2]),
                ]
            }
        }
    }

    /// The spheres' ranks.
    #[inline(always)]
    fn ids(&self, tok: V::Token) -> V::Index {
        match *self {
            SphereLanes::One(s, k) => V::index(tok, s.id[k]),
            SphereLanes::Two(s, second, a, b) => {
                V::index_blend(second, V::index(tok, s.id[a]), V::index(tok, s.id[b]))
            }
            SphereLanes::Each(s, own) => V::gather_index(&s.id, own),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::lanes::Portable;
    use super::super::view::ViewSphere;
    use super::*;

    /// The packets' nearest hit of one sphere (centre `center`, radius `r`, view coordinates)
    /// by the ray from the origin along unit `d`, in every lane.
    fn hit(center: DVec3, r: f64, d: DVec3) -> Option<f64> {
        let sphere = ViewSphere::in_view(center, r, DVec3::ZERO, 0);
        let columns = ViewColumns::new(DVec3::ZERO, &[sphere]);
        let shading = Shading {
            spheres: &columns,
            scene: &const { Spheres::new() },
            lights: &[],
            ambient: 0.0,
            background: DVec3::ZERO,
        };
        let d = [d.x, d.y, d.z].map(|x| Portable::splat((), x));
        let [(hit, _, t), _] =
            shading.nearest_packets::<Portable>(&[d, d], &[0], |_, _| true, [true, false]);
        let t = t.store();
        assert!(hit == 0 || hit == 0xff, "every lane alike");
        assert!(t.iter().all(|x| x.to_bits() == t[0].to_bits()));
        (hit != 0).then_some(t[0])
    }

    #[test]
    fn roots_match_the_textbook_quadratic() {
        // Unit sphere at (0, 0, 5), ray from the origin along +z: hits at 4 and 6.
        let t = hit(DVec3::new(0.0, 0.0, 5.0), 1.0, DVec3::Z).unwrap();
        assert!((t - 4.0).abs() < 1e-15);
        // From inside: the far root.
        let t = hit(DVec3::new(0.0, 0.0, 0.5), 1.0, DVec3::Z).unwrap();
        assert!((t - 1.5).abs() < 1e-15);
        // Behind: none.
        assert_eq!(hit(DVec3::new(0.0, 0.0, -5.0), 1.0, DVec3::Z), None);
        // Miss.
        assert_eq!(hit(DVec3::new(-2.0, 0.0, 5.0), 1.0, DVec3::Z), None);
    }

    #[test]
    fn stable_roots_keep_a_tiny_sphere_far_away() {
        // r = 1e-3 at distance 1e4 along a slightly oblique ray; the naive b² − c loses every
        // digit of the discriminant here. Closed form: t = D·cosθ − sqrt(r² − D² sin²θ).
        let (dist, offset, r) = (1e4, 0.5e-3, 1e-3_f64);
        let t = hit(DVec3::new(0.0, offset, dist), r, DVec3::Z).unwrap();
        let expect = dist - (r * r - offset * offset).sqrt();
        assert!((t - expect).abs() < 1e-9, "{t} vs {expect}");
    }
}
