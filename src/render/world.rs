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
#[derive(Debug, Clone, Copy)]
struct Node {
    lo: DVec3,
    hi: DVec3,
    start: u32,
    count: u32,
}

/// A scene ready to render: its spheres in a hierarchy and its lights' shadow grids.
pub struct SceneIndex<'a> {
    pub scene: &'a Scene,
    nodes: Vec<Node>,
    order: Vec<u32>,
    /// Per light: its shadow grid, None when it casts no shadows (or nothing could cast them).
    pub shadows: Vec<Option<ShadowGrid>>,
}

impl<'a> SceneIndex<'a> {
    pub fn new(scene: &'a Scene) -> SceneIndex<'a> {
        let mut order: Vec<u32> = (0..scene.spheres.len() as u32).collect();
        let mut nodes = Vec::with_capacity(2 * scene.spheres.len() / LEAF + 1);
        if !order.is_empty() {
            build(scene, &mut nodes, &mut order, 0);
        }
        let shadows = scene
            .lights
            .iter()
            .map(|l| {
                (l.shadows && scene.spheres.len() > 1)
                    .then(|| ShadowGrid::build(&scene.spheres, -l.direction_world))
            })
            .collect();
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

/// Builds the subtree of `order[start..]` (the slice given) at the end of `nodes`.
fn build(scene: &Scene, nodes: &mut Vec<Node>, order: &mut [u32], start: usize) {
    let sphere = |i: u32| &scene.spheres[i as usize];
    let mut lo = DVec3::splat(f64::INFINITY);
    let mut hi = DVec3::splat(f64::NEG_INFINITY);
    let mut clo = lo;
    let mut chi = hi;
    for &i in order.iter() {
        let s = sphere(i);
        lo = lo.min(s.center_world - s.radius);
        hi = hi.max(s.center_world + s.radius);
        clo = clo.min(s.center_world);
        chi = chi.max(s.center_world);
    }
    let me = nodes.len();
    nodes.push(Node {
        lo,
        hi,
        start: start as u32,
        count: order.len() as u32,
    });
    if order.len() <= LEAF {
        return;
    }
    // Split at the median centre along the widest spread of centres; ties by index, so the
    // tree is the same on every run.
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
    build(scene, nodes, left, start);
    let right_node = nodes.len() as u32;
    build(scene, nodes, right, start + mid);
    nodes[me].start = right_node;
    nodes[me].count = 0;
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
