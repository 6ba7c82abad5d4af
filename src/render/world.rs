//! A scene indexed once, in world coordinates, for every frame: a bounding volume hierarchy over
//! the spheres, so that a frame moves into view coordinates only the spheres inside its view
//! pyramid (O(visible + log N)), and a shadow grid per shadow-casting light.
//!
//! The culling only drops spheres that no pixel's ray can meet: the pyramid through the window's
//! edges holds every ray (they pass through pixel centres, half a pixel inside), and the tests
//! are widened by far more than their rounding. Frames are byte-identical to casting against
//! every sphere.

use glam::{DVec2, DVec3};

use super::shadows::ShadowGrid;
use crate::camera::Camera;
use crate::scene::Scene;

/// Spheres per leaf.
const LEAF: usize = 4;

/// A node's box; a leaf (`count` > 0) holds `order[start..start + count]`, an inner node has its
/// children at its own index + 1 and at `start`.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Node {
    lo: DVec3,
    hi: DVec3,
    start: u32,
    count: u32,
}

/// A scene ready to render: its spheres in a hierarchy and its lights' shadow grids.
pub struct SceneIndex<'a> {
    /// The scene indexed.
    pub scene: &'a Scene,
    nodes: Vec<Node>,
    order: Vec<u32>,
    /// Per light: its shadow grid, None when it casts no shadows (or nothing could cast them).
    pub shadows: Vec<Option<ShadowGrid>>,
}

impl<'a> SceneIndex<'a> {
    /// The hierarchy and the shadow grids, built side by side on the rayon pool (and the
    /// hierarchy's large subtrees too): the same index as built on one thread.
    pub fn new(scene: &'a Scene) -> SceneIndex<'a> {
        let ((nodes, order), shadows) = rayon::join(
            || hierarchy(scene),
            || {
                scene
                    .lights
                    .iter()
                    .map(|l| {
                        (l.shadows && scene.spheres.len() > 1)
                            .then(|| ShadowGrid::build(&scene.spheres, -l.direction_world))
                    })
                    .collect()
            },
        );
        SceneIndex {
            scene,
            nodes,
            order,
            shadows,
        }
    }

    /// The spheres that can meet a ray of `camera`, in increasing index order.
    pub fn visible(&self, camera: &Camera) -> Vec<u32> {
        let planes = Pyramid::new(camera);
        let mut out = Vec::new();
        let mut stack = Vec::with_capacity(64);
        if !self.nodes.is_empty() {
            stack.push(0usize);
        }
        while let Some(k) = stack.pop() {
            let node = &self.nodes[k];
            if !planes.meets_box(node.lo, node.hi) {
                continue;
            }
            if node.count > 0 {
                let items = &self.order[node.start as usize..(node.start + node.count) as usize];
                for &i in items {
                    let s = &self.scene.spheres[i as usize];
                    if planes.meets_sphere(s.center_world, s.radius) {
                        out.push(i);
                    }
                }
            } else {
                stack.push(node.start as usize);
                stack.push(k + 1);
            }
        }
        out.sort_unstable();
        out
    }
}

/// Subtrees of at least this many spheres build their two halves in parallel.
const PARALLEL_BUILD: usize = 1 << 16;

/// The spheres' centres, one array per axis, and their radii: the median splits read them in
/// the order of `order`, which is random in memory, and a coordinate is 8 bytes of an array
/// where a sphere is 56 bytes of the scene's.
struct Points {
    axes: [Vec<f64>; 3],
    radius: Vec<f64>,
}

impl Points {
    fn center(&self, i: u32) -> DVec3 {
        let i = i as usize;
        DVec3::new(self.axes[0][i], self.axes[1][i], self.axes[2][i])
    }
}

/// The hierarchy's nodes (the root first) and the sphere order its leaves index.
fn hierarchy(scene: &Scene) -> (Vec<Node>, Vec<u32>) {
    let spheres = &scene.spheres;
    let mut order: Vec<u32> = (0..spheres.len() as u32).collect();
    if order.is_empty() {
        return (Vec::new(), order);
    }
    let points = Points {
        axes: [0, 1, 2].map(|a| spheres.iter().map(|s| s.center_world[a]).collect()),
        radius: spheres.iter().map(|s| s.radius).collect(),
    };
    let empty = Node {
        lo: DVec3::ZERO,
        hi: DVec3::ZERO,
        start: 0,
        count: 0,
    };
    let mut nodes = vec![empty; node_count(order.len())];
    build(&points, &mut nodes, 0, &mut order, 0);
    (nodes, order)
}

/// The number of nodes of a subtree of `n` spheres.
fn node_count(n: usize) -> usize {
    if n <= LEAF {
        1
    } else {
        1 + node_count(n / 2) + node_count(n - n / 2)
    }
}

/// Builds the subtree of `order` (at `start..` of the whole order) into `nodes`, which has
/// exactly its [`node_count`] entries and begins at index `base` of the whole tree.
fn build(points: &Points, nodes: &mut [Node], base: usize, order: &mut [u32], start: usize) {
    if order.len() < PARALLEL_BUILD {
        let mut local = Vec::with_capacity(nodes.len());
        build_serial(points, &mut local, order, start);
        assert_eq!(local.len(), nodes.len(), "node_count");
        for (slot, mut node) in nodes.iter_mut().zip(local) {
            if node.count == 0 {
                node.start += base as u32;
            }
            *slot = node;
        }
        return;
    }
    let axis;
    (nodes[0], axis) = node(points, order, start);
    let mid = split(points, order, axis);
    let (left, right) = order.split_at_mut(mid);
    let (_, below) = nodes.split_at_mut(1);
    let (left_nodes, right_nodes) = below.split_at_mut(node_count(mid));
    let right_base = base + 1 + left_nodes.len();
    rayon::join(
        || build(points, left_nodes, base + 1, left, start),
        || build(points, right_nodes, right_base, right, start + mid),
    );
    nodes[0].start = right_base as u32;
    nodes[0].count = 0;
}

/// Builds the subtree of `order[start..]` (the slice given) at the end of `nodes`, its inner
/// nodes indexing their right children from the start of `nodes`.
fn build_serial(points: &Points, nodes: &mut Vec<Node>, order: &mut [u32], start: usize) {
    let me = nodes.len();
    let (node, axis) = node(points, order, start);
    nodes.push(node);
    if order.len() <= LEAF {
        return;
    }
    let mid = split(points, order, axis);
    let (left, right) = order.split_at_mut(mid);
    build_serial(points, nodes, left, start);
    let right_node = nodes.len() as u32;
    build_serial(points, nodes, right, start + mid);
    nodes[me].start = right_node;
    nodes[me].count = 0;
}

/// A leaf over `order` (at `start` of the whole order), with the box of its spheres, and the
/// axis of the widest spread of their centres: one pass over the spheres, in `order`.
fn node(points: &Points, order: &[u32], start: usize) -> (Node, usize) {
    let mut lo = DVec3::splat(f64::INFINITY);
    let mut hi = DVec3::splat(f64::NEG_INFINITY);
    let mut clo = lo;
    let mut chi = hi;
    for &i in order {
        let (c, r) = (points.center(i), points.radius[i as usize]);
        lo = lo.min(c - r);
        hi = hi.max(c + r);
        clo = clo.min(c);
        chi = chi.max(c);
    }
    let spread = chi - clo;
    let axis = if spread.x >= spread.y && spread.x >= spread.z {
        0
    } else if spread.y >= spread.z {
        1
    } else {
        2
    };
    let node = Node {
        lo,
        hi,
        start: start as u32,
        count: order.len() as u32,
    };
    (node, axis)
}

/// Puts the median centre along `axis` at `order.len() / 2`, the smaller before it, and
/// returns that position; ties by index, so the tree is the same on every run.
fn split(points: &Points, order: &mut [u32], axis: usize) -> usize {
    let key = &points.axes[axis];
    let mid = order.len() / 2;
    order.select_nth_unstable_by(mid, |a, b| {
        key[*a as usize].total_cmp(&key[*b as usize]).then(a.cmp(b))
    });
    mid
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
        // Window corners counter-clockwise seen from the COP (looking along +n).
        let corners = [
            DVec2::new(-w, -h),
            DVec2::new(w, -h),
            DVec2::new(w, h),
            DVec2::new(-w, h),
        ]
        .map(|c| DVec3::new(c.x, c.y, 0.0) - cop);
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

    fn meets_box(&self, lo: DVec3, hi: DVec3) -> bool {
        let (mid, half) = ((lo + hi) * 0.5, (hi - lo) * 0.5);
        let rel = mid - self.vrp;
        let slack = self.slack + 1e-9 * (lo.abs().max(hi.abs()).max_element());
        self.planes
            .iter()
            .all(|(m, offset)| rel.dot(*m) + half.dot(m.abs()) - offset >= -slack)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::Sphere;
    use crate::splitmix::SplitMix;

    /// A field of spheres with many equal coordinates (ties broken by index).
    fn scene(n: usize) -> Scene {
        let mut rng = SplitMix(n as u64);
        let spheres = (0..n)
            .map(|k| Sphere {
                center_world: DVec3::new(
                    (rng.unit() * 1000.0).round(),
                    if k % 3 == 0 { 0.0 } else { rng.unit() },
                    rng.unit() * 800.0,
                ),
                radius: 0.1 + rng.unit(),
                color: DVec3::ONE,
            })
            .collect();
        Scene {
            background: DVec3::ZERO,
            ambient: 0.1,
            lights: Vec::new(),
            spheres,
        }
    }

    /// The hierarchy as built before the parallel build: a node, then its left subtree, then
    /// its right one, reading each sphere from the scene.
    fn reference(scene: &Scene, nodes: &mut Vec<Node>, order: &mut [u32], start: usize) {
        let sphere = |i: u32| &scene.spheres[i as usize];
        let (mut lo, mut hi) = (DVec3::INFINITY, DVec3::NEG_INFINITY);
        let (mut clo, mut chi) = (lo, hi);
        for &i in order.iter() {
            let s = sphere(i);
            lo = lo.min(s.center_world - s.radius);
            hi = hi.max(s.center_world + s.radius);
            clo = clo.min(s.center_world);
            chi = chi.max(s.center_world);
        }
        let me = nodes.len();
        let count = order.len() as u32;
        nodes.push(Node {
            lo,
            hi,
            start: start as u32,
            count,
        });
        if order.len() <= LEAF {
            return;
        }
        let spread = chi - clo;
        let axis = if spread.x >= spread.y && spread.x >= spread.z {
            0
        } else if spread.y >= spread.z {
            1
        } else {
            2
        };
        let mid = order.len() / 2;
        order.select_nth_unstable_by(mid, |a, b| {
            let (ca, cb) = (sphere(*a).center_world[axis], sphere(*b).center_world[axis]);
            ca.total_cmp(&cb).then(a.cmp(b))
        });
        let (left, right) = order.split_at_mut(mid);
        reference(scene, nodes, left, start);
        let right_node = nodes.len() as u32;
        reference(scene, nodes, right, start + mid);
        nodes[me].start = right_node;
        nodes[me].count = 0;
    }

    #[test]
    fn the_parallel_build_is_the_serial_one() {
        for n in [1, 4, 5, 1000, PARALLEL_BUILD - 1, 3 * PARALLEL_BUILD + 7] {
            let scene = scene(n);
            let (nodes, order) = hierarchy(&scene);
            // The whole tree on one thread, one node after another, from the scene's spheres.
            let mut serial_order: Vec<u32> = (0..n as u32).collect();
            let mut serial = Vec::new();
            reference(&scene, &mut serial, &mut serial_order, 0);
            assert_eq!(order, serial_order, "{n} spheres");
            assert_eq!(nodes, serial, "{n} spheres");
            assert_eq!(nodes.len(), node_count(n));
            // Every sphere in exactly one leaf, inside its box and every ancestor's.
            let mut seen = vec![0u32; n];
            let mut stack = vec![(0usize, Vec::<usize>::new())];
            while let Some((k, mut path)) = stack.pop() {
                let node = nodes[k];
                path.push(k);
                if node.count > 0 {
                    for &i in &order[node.start as usize..(node.start + node.count) as usize] {
                        seen[i as usize] += 1;
                        let s = &scene.spheres[i as usize];
                        for &a in &path {
                            let (lo, hi) = (nodes[a].lo, nodes[a].hi);
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
}
