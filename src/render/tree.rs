//! The sphere hierarchy's parts as its readers take them: a node's box, the spheres' order and
//! a sphere's f32 shape. `world.rs` builds them; the walk of hidden spheres (`cull.rs`) and a
//! frame's shadow rays before the light's grid is built (`shadows/`) read them.

use glam::{DVec3, Vec3, Vec4};
use std::sync::Arc;

/// A node's box, in f32 rounded outward from the spheres' f64 bounds; a leaf (`count` > 0)
/// holds the spheres at positions `start..start + count` of the [`Order`], an inner node has
/// its children at its own index + 1 and at `start`. 32 bytes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Node {
    pub(super) lo: [f32; 3],
    pub(super) hi: [f32; 3],
    pub(super) start: u32,
    pub(super) count: u32,
}

impl Node {
    #[inline]
    pub(super) fn bounds(&self) -> [DVec3; 2] {
        // Written out: `array::map` is not always inlined into the walks that call this.
        [
            Vec3::from(self.lo).as_dvec3(),
            Vec3::from(self.hi).as_dvec3(),
        ]
    }
}

/// The ranks of the spheres in the hierarchy's order, which its leaves and the shadow grids'
/// cells give by position: a list, or, over the index's copy along the curve, the positions
/// themselves (no list kept: 40 MB at ten million spheres).
#[derive(Debug, Clone)]
pub(super) enum Order {
    Listed(Arc<Vec<u32>>),
    Positions(usize),
}

impl Order {
    /// How many spheres.
    pub(super) fn len(&self) -> usize {
        match self {
            Order::Listed(ranks) => ranks.len(),
            Order::Positions(n) => *n,
        }
    }

    /// The rank of the sphere at position `p`. Panics past the end.
    #[inline]
    pub(super) fn rank(&self, p: usize) -> u32 {
        match self {
            Order::Listed(ranks) => ranks[p],
            Order::Positions(n) => {
                assert!(p < *n, "position {p} past {n} spheres");
                p as u32
            }
        }
    }
}

/// A sphere in f32, 16 bytes: the centre rounded to nearest and a radius rounded up so that the
/// ball holds the sphere (`[x, y, z, r]`). [`shape_inner`] gives a radius whose ball the
/// sphere holds.
pub(super) type Shape = [f32; 4];

/// Relative rounding of f32, 2⁻²³ (an ulp at 1; half an ulp is the nearest rounding's error).
pub(super) const F32_EPS: f64 = f32::EPSILON as f64;

/// The least f32 above 0, 2⁻¹⁴⁹: below f32's normal range a coordinate moves by up to half of
/// it, whatever its size.
pub(super) const F32_TINY: f64 = 1.401298464324817e-45;

/// A radius around a [`Shape`]'s centre whose ball lies inside the sphere (possibly
/// negative, then no ball): the outer radius less twice every rounding it can hold.
#[inline]
pub(super) fn shape_inner(shape: &Shape) -> f64 {
    let c = Vec4::from(*shape).as_dvec4();
    let r = c.w;
    let scale = c.x.abs().max(c.y.abs()).max(c.z.abs()) + r;
    r - 4.0 * F32_EPS * scale - 4.0 * F32_TINY
}
