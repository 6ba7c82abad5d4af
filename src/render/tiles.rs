//! Screen tiles: each tile lists the spheres whose projection can cover it, nearest first, so a
//! primary ray tests only those and stops once no remaining sphere can be nearer than its hit.
//! Spheres wholly behind the COP are culled; a sphere the COP's plane cuts (or the COP is inside)
//! projects without bound and goes into every tile.

use glam::{DVec2, DVec3};

use super::bins::Bins;
use super::{Raster, ViewSphere};

/// Tile side in pixels.
pub const TILE: usize = 16;

/// Pixel rectangle (inclusive) a sphere's projection may cover.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Footprint {
    Culled,
    Everywhere,
    Pixels {
        i0: usize,
        i1: usize,
        j0: usize,
        j1: usize,
    },
}

/// Slopes a = x/z of the two lines through the origin tangent to the circle (x, z, r), for
/// z > r: the roots of a²(z² − r²) − 2a·x·z + x² − r² = 0.
fn tangent_slopes(x: f64, z: f64, r: f64) -> (f64, f64) {
    let root = r * (x * x + z * z - r * r).sqrt();
    let den = z * z - r * r;
    ((x * z - root) / den, (x * z + root) / den)
}

/// The exact bounds of a sphere's projection through the COP onto the view plane, widened by a
/// pixel so that rounding never drops a covered sample.
fn footprint(s: &ViewSphere, cop: DVec3, window: DVec2, raster: Raster) -> Footprint {
    let p = -s.f; // centre relative to the COP
    if p.z <= -s.radius {
        return Footprint::Culled;
    }
    if p.z <= s.radius {
        return Footprint::Everywhere;
    }
    let d = -cop.z;
    let (ax0, ax1) = tangent_slopes(p.x, p.z, s.radius);
    let (ay0, ay1) = tangent_slopes(p.y, p.z, s.radius);
    let (w, h) = (raster.width as f64, raster.height as f64);
    // Window x → pixel column, window y → pixel row (rows grow downwards).
    let col = |a: f64| (cop.x + d * a + window.x * 0.5) / window.x * w;
    let row = |a: f64| (window.y * 0.5 - (cop.y + d * a)) / window.y * h;
    let (x0, x1) = (col(ax0) - 1.0, col(ax1) + 1.0);
    let (y0, y1) = (row(ay1) - 1.0, row(ay0) + 1.0);
    if !(x1 >= 0.0 && y1 >= 0.0 && x0 < w && y0 < h) {
        // Off screen (also catches NaN from a degenerate window).
        return if x0.is_nan() || y0.is_nan() {
            Footprint::Everywhere
        } else {
            Footprint::Culled
        };
    }
    let clamp = |v: f64, n: f64| v.max(0.0).min(n - 1.0) as usize;
    Footprint::Pixels {
        i0: clamp(x0.floor(), w),
        i1: clamp(x1.floor(), w),
        j0: clamp(y0.floor(), h),
        j1: clamp(y1.floor(), h),
    }
}

/// Per-tile sphere lists, nearest possible hit first, and each sphere's pixel rectangle.
pub struct TileBins {
    bins: Bins,
    /// Per sphere, the inclusive pixel rectangle (i0, i1, j0, j1) its projection may cover.
    rects: Vec<[u32; 4]>,
}

impl TileBins {
    pub fn build(spheres: &[ViewSphere], cop: DVec3, window: DVec2, raster: Raster) -> TileBins {
        let tiles_x = (raster.width as usize).div_ceil(TILE);
        let tiles_y = (raster.height as usize).div_ceil(TILE);
        let prints: Vec<Footprint> = spheres
            .iter()
            .map(|s| footprint(s, cop, window, raster))
            .collect();
        let mut bins = Bins::build((tiles_x, tiles_y), spheres.len(), |k| match prints[k] {
            Footprint::Culled => None,
            Footprint::Everywhere => Some((0, tiles_x - 1, 0, tiles_y - 1)),
            Footprint::Pixels { i0, i1, j0, j1 } => {
                Some((i0 / TILE, i1 / TILE, j0 / TILE, j1 / TILE))
            }
        });
        // Nearest possible hit first; ties by index, so the order is total and deterministic.
        // Sorted tile by tile: one sort of every sphere in view (binned in that order) costs
        // more once hundreds of thousands are in view, its reads scattered over all of them.
        bins.sort_cells(|items| {
            items.sort_unstable_by(|a, b| {
                let (sa, sb) = (&spheres[*a as usize], &spheres[*b as usize]);
                sa.min_dist.total_cmp(&sb.min_dist).then(a.cmp(b))
            })
        });
        let all = [0, raster.width - 1, 0, raster.height - 1];
        let rects = prints
            .iter()
            .map(|p| match *p {
                Footprint::Culled => [1, 0, 1, 0],
                Footprint::Everywhere => all,
                Footprint::Pixels { i0, i1, j0, j1 } => {
                    [i0 as u32, i1 as u32, j0 as u32, j1 as u32]
                }
            })
            .collect();
        TileBins { bins, rects }
    }

    /// The spheres that can cover pixel (i, j), nearest first.
    #[inline]
    pub fn at(&self, i: usize, j: usize) -> &[u32] {
        self.bins.cell(i / TILE, j / TILE)
    }

    /// Whether sphere k's projection may cover a pixel of row j in columns i0..=i1.
    #[inline(always)]
    pub fn covers(&self, k: u32, i0: usize, i1: usize, j: usize) -> bool {
        let [x0, x1, y0, y1] = self.rects[k as usize];
        let (i0, i1, j) = (i0 as u32, i1 as u32, j as u32);
        i1 >= x0 && i0 <= x1 && j >= y0 && j <= y1
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tangent_slopes_touch_the_circle() {
        // Circle at (3, 10) with r = 2: the distance from the centre to each line x = a·z is r.
        let (a0, a1) = tangent_slopes(3.0, 10.0, 2.0);
        for a in [a0, a1] {
            let dist = (3.0 - a * 10.0).abs() / (1.0 + a * a).sqrt();
            assert!((dist - 2.0).abs() < 1e-12);
        }
        assert!(a0 < 0.3 && a1 > 0.3);
    }
}
