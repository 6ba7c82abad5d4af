//! Ray directions: the table of a frame's window offsets, and their unit vectors in packets.

use glam::{DVec2, DVec3};

use super::lanes::{Lanes, LANES};
use crate::camera::window_point;
use crate::raster::Raster;

/// Ray directions in view coordinates, for one COP, window and raster. Sample (sx, sy) of pixel
/// (i, j) leaves the COP towards window point (xs[i·s + sx], ys[j·s + sy]) relative to the COP,
/// at depth dz; the packets normalise that offset ([`unit`]).
pub(super) struct RayTable {
    pub(super) cop_view: DVec3,
    pub(super) window: DVec2,
    pub(super) raster: Raster,
    pub(super) xs: Vec<f64>,
    pub(super) ys: Vec<f64>,
    pub(super) dz: f64,
}

impl RayTable {
    pub(super) fn new(cop_view: DVec3, window: DVec2, raster: Raster) -> RayTable {
        let s = raster.samples as usize;
        let size = (raster.width, raster.height);
        let offset = |k: usize| (k / s) as f64 + ((k % s) as f64 + 0.5) / s as f64;
        let xs = (0..raster.width as usize * s)
            .map(|k| window_point(window, size, offset(k), 0.0).x - cop_view.x)
            .collect();
        let ys = (0..raster.height as usize * s)
            .map(|k| window_point(window, size, 0.0, offset(k)).y - cop_view.y)
            .collect();
        RayTable {
            cop_view,
            window,
            raster,
            xs,
            ys,
            dz: -cop_view.z,
        }
    }

    pub(super) fn fits(&self, cop_view: DVec3, window: DVec2, raster: Raster) -> bool {
        // Adaptive sampling does not change the directions.
        let same = |a: Raster, b: Raster| {
            a.width == b.width && a.height == b.height && a.samples == b.samples
        };
        self.cop_view == cop_view && self.window == window && same(self.raster, raster)
    }
}

/// The unit directions of the packet of row pixels `at..at + LANES` (column positions `xs`,
/// the row's `y` and the view plane's `z`, with `yy` = y² and `zz` = z² in every lane),
/// normalised exactly as `DVec3::normalize` does (v · (1 / √(v·v))). Lanes past the row's end
/// repeat its last pixel. A plain function, not a closure: a closure is not inlined into the
/// row function compiled for the instruction set (1.5× the time, measured).
#[inline(always)]
pub(super) fn row_direction<V: Lanes>(
    xs: &[f64],
    at: usize,
    y: f64,
    z: f64,
    yy: V,
    zz: V,
) -> [V; 3] {
    let tok = yy.token();
    let width = xs.len();
    let x = if at + LANES <= width {
        V::load(tok, xs[at..at + LANES].try_into().expect("LANES values"))
    } else {
        let mut v = [xs[width - 1]; LANES];
        v[..width - at].copy_from_slice(&xs[at..width]);
        V::load(tok, &v)
    };
    unit(x, V::splat(tok, y), V::splat(tok, z), yy, zz)
}

/// The unit vectors along (x, y, z) per lane, given yy = y² and zz = z² (a row's are the same in
/// every packet), normalised exactly as `DVec3::normalize` does: v · (1 / √((x² + y²) + z²)).
#[inline(always)]
pub(super) fn unit<V: Lanes>(x: V, y: V, z: V, yy: V, zz: V) -> [V; 3] {
    let tok = x.token();
    let r = V::splat(tok, 1.0).div(x.mul(x).add(yy).add(zz).sqrt());
    [x.mul(r), y.mul(r), z.mul(r)]
}
