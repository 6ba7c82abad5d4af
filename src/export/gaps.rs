//! The least gap from a point to any sphere's surface, `min | |p − c| − r |` over the scene,
//! for the clipping range of every exported camera: a tree of boxes over the centres, so that a
//! camera costs about log N spheres, not N (20,000 cameras of a million spheres: minutes →
//! seconds). The answer is the same value, bit for bit, as the minimum over every sphere: a
//! sphere's gap is computed by the same operations, and a box is passed only when every sphere
//! in it lies further than the least gap so far by far more than rounding.

use glam::DVec3;

use crate::scene::Spheres;

/// Spheres a leaf holds at most.
const LEAF: usize = 8;

/// A box of centres and the range of their radii; its spheres are `order[start..end]`, split
/// between two children unless it is a leaf.
#[derive(Debug, Clone, Copy)]
struct Node {
    lo: DVec3,
    hi: DVec3,
    r: (f64, f64),
    start: u32,
    end: u32,
    /// The first child's index (the second follows it), or 0 for a leaf.
    first: u32,
}

/// The spheres' centres and radii in a tree of boxes, split at the median of the longest side.
pub(crate) struct Gaps {
    nodes: Vec<Node>,
    /// The centres and radii, in the tree's order.
    spheres: Vec<(DVec3, f64)>,
}

/// A sphere's gap from `p`: the distance from `p` to its surface, from outside or inside.
#[inline]
fn gap(p: DVec3, (c, r): (DVec3, f64)) -> f64 {
    ((p - c).length() - r).abs()
}

impl Gaps {
    pub(crate) fn new(spheres: &Spheres) -> Gaps {
        let mut gaps = Gaps {
            nodes: Vec::with_capacity(2 * spheres.len().div_ceil(LEAF)),
            spheres: spheres.iter().map(|s| (s.center_world, s.radius)).collect(),
        };
        if !gaps.spheres.is_empty() {
            gaps.nodes.push(gaps.node(0, gaps.spheres.len()));
            gaps.split(0);
        }
        gaps
    }

    /// The box of `spheres[start..end]`.
    fn node(&self, start: usize, end: usize) -> Node {
        let mut node = Node {
            lo: DVec3::splat(f64::INFINITY),
            hi: DVec3::splat(f64::NEG_INFINITY),
            r: (f64::INFINITY, f64::NEG_INFINITY),
            start: start as u32,
            end: end as u32,
            first: 0,
        };
        for &(c, r) in &self.spheres[start..end] {
            (node.lo, node.hi) = (node.lo.min(c), node.hi.max(c));
            node.r = (node.r.0.min(r), node.r.1.max(r));
        }
        node
    }

    /// Splits node `at` and its children down to leaves (a stack, not recursion: a tree of
    /// equal centres is as deep as it is long).
    fn split(&mut self, at: usize) {
        let mut todo = vec![at];
        while let Some(at) = todo.pop() {
            let Node {
                lo, hi, start, end, ..
            } = self.nodes[at];
            let (start, end) = (start as usize, end as usize);
            if end - start <= LEAF {
                continue;
            }
            let axis = (hi - lo).max_position();
            let mid = (start + end) / 2;
            self.spheres[start..end]
                .select_nth_unstable_by(mid - start, |a, b| a.0[axis].total_cmp(&b.0[axis]));
            let first = self.nodes.len();
            self.nodes[at].first = first as u32;
            let (a, b) = (self.node(start, mid), self.node(mid, end));
            self.nodes.extend([a, b]);
            todo.extend([first, first + 1]);
        }
    }

    /// A bound below the gap from `p` of every sphere in `node`, less an allowance far above
    /// the rounding of the gaps and of the bound (10⁻⁹ of the distances involved).
    fn below(node: &Node, p: DVec3) -> f64 {
        let near = (node.lo - p).max(p - node.hi).max(DVec3::ZERO).length();
        let far = (p - node.lo).abs().max((node.hi - p).abs()).length();
        let (r0, r1) = node.r;
        let bound = (near - r1).max(r0 - far).max(0.0);
        bound - 1e-9 * (far + r1)
    }

    /// The least gap from `p` to any sphere's surface (infinite without spheres): the value of
    /// `gap` folded by `f64::min` over every sphere.
    pub(crate) fn least(&self, p: DVec3) -> f64 {
        let mut best = f64::INFINITY;
        if self.nodes.is_empty() {
            return best;
        }
        let mut stack = vec![0usize];
        while let Some(at) = stack.pop() {
            let node = &self.nodes[at];
            if Gaps::below(node, p) > best {
                continue;
            }
            if node.first == 0 {
                for &s in &self.spheres[node.start as usize..node.end as usize] {
                    best = best.min(gap(p, s));
                }
                continue;
            }
            // The nearer child last, so that it is taken first.
            let (a, b) = (node.first as usize, node.first as usize + 1);
            let (na, nb) = (
                Gaps::below(&self.nodes[a], p),
                Gaps::below(&self.nodes[b], p),
            );
            stack.extend(if na <= nb { [b, a] } else { [a, b] });
        }
        best
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::Sphere;
    use crate::splitmix::SplitMix;

    fn sphere(c: DVec3, r: f64) -> Sphere {
        Sphere {
            center_world: c,
            radius: r,
            color: DVec3::ONE,
        }
    }

    /// Against every sphere, bit for bit: random clusters of every size (a leaf, a few levels,
    /// many), points outside, inside and on spheres, spheres of one centre (a tree as deep as
    /// can be), huge and tiny radii, a scene far from the origin.
    #[test]
    fn the_least_gap_is_the_minimum_over_every_sphere() {
        let mut rng = SplitMix(7);
        let mut u = |a: f64, b: f64| a + (b - a) * rng.unit();
        for (n, offset, spread) in [
            (1, 0.0, 1.0),
            (5, 0.0, 1.0),
            (9, 0.0, 10.0),
            (200, 0.0, 10.0),
            (3000, 2.0e6, 50.0),
            (3000, 0.0, 1e-3),
        ] {
            let mut spheres: Vec<Sphere> = (0..n)
                .map(|_| {
                    let c = DVec3::new(u(-1.0, 1.0), u(-1.0, 1.0), u(-1.0, 1.0)) * spread;
                    sphere(c + DVec3::splat(offset), u(0.0, 0.2) * spread)
                })
                .collect();
            spheres.push(sphere(DVec3::new(0.0, -1e5, 0.0) + offset, 1e5));
            spheres.extend((0..40).map(|_| sphere(DVec3::splat(offset), 0.5 * spread)));
            let gaps = Gaps::new(&spheres.iter().copied().collect());
            let mut points: Vec<DVec3> = (0..300)
                .map(|_| DVec3::new(u(-2.0, 2.0), u(-2.0, 2.0), u(-2.0, 2.0)) * spread)
                .map(|p| p + DVec3::splat(offset))
                .collect();
            points.extend(spheres.iter().take(20).map(|s| s.center_world));
            points.extend(
                spheres
                    .iter()
                    .take(20)
                    .map(|s| s.center_world + DVec3::X * s.radius),
            );
            for p in points {
                let every = spheres
                    .iter()
                    .map(|s| gap(p, (s.center_world, s.radius)))
                    .fold(f64::INFINITY, f64::min);
                assert_eq!(gaps.least(p).to_bits(), every.to_bits(), "{n} spheres, {p}");
            }
        }
        assert_eq!(Gaps::new(&Spheres::new()).least(DVec3::ONE), f64::INFINITY);
    }
}
