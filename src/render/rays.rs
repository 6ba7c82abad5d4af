//! Ray directions: the table of a frame's window offsets, and their unit vectors in packets.

use glam::{DVec2, DVec3};
use rayon::prelude::*;
use std::sync::OnceLock;

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
    /// At one sample a pixel, the column positions of each packet of [`HALF`] columns × 2 rows:
    /// columns HALF·c .. HALF·(c + 1) (the last column repeated past the row's end), twice.
    pub(super) packet_xs: Vec<[f64; LANES]>,
    pub(super) ys: Vec<f64>,
    pub(super) dz: f64,
    /// At one sample a pixel, each pixel's ray as a unit vector (see [`RayTable::units`]),
    /// made by the first frame that culls with this table and kept while the table is.
    units: OnceLock<[Vec<f64>; 3]>,
}

impl RayTable {
    pub(super) fn new(cop_view: DVec3, window: DVec2, raster: Raster) -> RayTable {
        let s = raster.samples as usize;
        let size = (raster.width, raster.height);
        let offset = |k: usize| (k / s) as f64 + ((k % s) as f64 + 0.5) / s as f64;
        let xs: Vec<f64> = (0..raster.width as usize * s)
            .map(|k| window_point(window, size, offset(k), 0.0).x - cop_view.x)
            .collect();
        let packet_xs = match s {
            1 => (0..xs.len().div_ceil(HALF))
                .map(|c| std::array::from_fn(|l| xs[(c * HALF + l % HALF).min(xs.len() - 1)]))
                .collect(),
            _ => Vec::new(),
        };
        let ys = (0..raster.height as usize * s)
            .map(|k| window_point(window, size, 0.0, offset(k)).y - cop_view.y)
            .collect();
        RayTable {
            cop_view,
            window,
            raster,
            xs,
            packet_xs,
            ys,
            dz: -cop_view.z,
            units: OnceLock::new(),
        }
    }

    /// Each pixel's ray direction at one sample a pixel as a unit vector, row by row, one
    /// column per coordinate: `DVec3::normalize` of (xs[x], ys[y], dz), what the walk of
    /// hidden spheres (`cull.rs`) reads for every sphere and pixel. [`LANES`] zeros follow the
    /// last pixel, so eight lanes load from any pixel. Made on the pool the first time it is
    /// asked for, each column in place.
    pub(super) fn units(&self) -> &[Vec<f64>; 3] {
        self.units.get_or_init(|| {
            let (w, dz) = (self.xs.len(), self.dz);
            let mut units = [0; 3].map(|_| vec![0.0; w * self.ys.len() + LANES]);
            let [ux, uy, uz] = &mut units;
            let rows = ux.par_chunks_mut(w).zip(uy.par_chunks_mut(w));
            let rows = rows.zip(uz.par_chunks_mut(w)).zip(&self.ys);
            rows.for_each(|(((ux, uy), uz), &y)| {
                for (i, &x) in self.xs.iter().enumerate() {
                    let d = DVec3::new(x, y, dz).normalize();
                    (ux[i], uy[i], uz[i]) = (d.x, d.y, d.z);
                }
            });
            units
        })
    }

    pub(super) fn fits(&self, cop_view: DVec3, window: DVec2, raster: Raster) -> bool {
        // Adaptive sampling does not change the directions.
        let same = |a: Raster, b: Raster| {
            a.width == b.width && a.height == b.height && a.samples == b.samples
        };
        self.cop_view == cop_view && self.window == window && same(self.raster, raster)
    }
}

/// Side in pixels of a screen tile (`tiles/`), inside which a row's pixels are cast together.
pub const TILE: usize = 16;

/// Columns of a packet at one sample a pixel; its lanes 0..HALF are one row, HALF..LANES the
/// next.
pub(super) const HALF: usize = LANES / 2;

/// The unit vectors along (x, y, z) per lane, given yy = y² and zz = z² (found once for many
/// packets, as a band's for its upper and lower packets), normalised exactly as
/// `DVec3::normalize` does: v · (1 / √((x² + y²) + z²)).
#[inline(always)]
pub(super) fn unit<V: Lanes>(x: V, y: V, z: V, yy: V, zz: V) -> [V; 3] {
    let tok = x.token();
    let r = V::splat(tok, 1.0).div(x.mul(x).add(yy).add(zz).sqrt());
    [x.mul(r), y.mul(r), z.mul(r)]
}
