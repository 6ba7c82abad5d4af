//! The spheres' footprints: the pixel rectangle each one's projection may cover, eight spheres
//! at a time (`Footprints`, a `ForLanes` work), and the one-sphere oracle they are tested
//! against.

use glam::{DVec2, DVec3};

use super::super::lanes::{ForLanes, Lanes, LANES};
use super::super::view::ViewColumns;
use crate::raster::Raster;

/// The spheres' pixel rectangles, eight at a time: for sphere k, the inclusive rectangle
/// `[i0, i1, j0, j1]` its projection may cover, `[1, 0, 1, 0]` when it is culled (wholly behind
/// the COP, or off screen), every pixel when it has no bounds (the COP's plane cuts it, or the
/// window is degenerate). Each lane does the operations of the one-sphere form in the tests,
/// in its order, so every instruction path gives its bits. No closures: each step is inlined
/// into the instruction set's function.
pub(super) struct Footprints<'a> {
    pub(super) spheres: &'a ViewColumns,
    /// The index of the first sphere of `rects`.
    pub(super) first: usize,
    pub(super) rects: &'a mut [[u16; 4]],
    /// The spheres without bounds, in order.
    pub(super) unbounded: &'a mut Vec<u32>,
    pub(super) cop: DVec3,
    pub(super) window: DVec2,
    pub(super) raster: Raster,
}

/// Lanes `at..at + LANES` of `column`, the last of `n` repeated past it.
#[inline(always)]
fn lanes_at<V: Lanes>(tok: V::Token, column: &[f64], at: usize, n: usize) -> V {
    let mut x = [0.0; LANES];
    for (l, x) in x.iter_mut().enumerate() {
        *x = column[at + l.min(n - 1)];
    }
    V::load(tok, &x)
}

/// The slopes a = x/z of the two lines through the origin tangent to the circles (x, z, r),
/// lane by lane, for z > r: the roots of a²(z² − r²) − 2a·x·z + x² − r² = 0.
#[inline(always)]
fn tangent_slopes_lanes<V: Lanes>(x: V, z: V, r: V) -> (V, V) {
    let root = r.mul(x.mul(x).add(z.mul(z)).sub(r.mul(r)).sqrt());
    let den = z.mul(z).sub(r.mul(r));
    (x.mul(z).sub(root).div(den), x.mul(z).add(root).div(den))
}

/// `(v.max(0.0).min(n − 1.0)) as u16` per lane: the floor of v clamped to a side of n pixels.
#[inline(always)]
fn clamp_lanes<V: Lanes>(tok: V::Token, v: V, n: u32) -> [i32; LANES] {
    v.max(V::splat(tok, 0.0))
        .min(V::splat(tok, n as f64 - 1.0))
        .to_i32(n as i32 - 1)
}

impl ForLanes for Footprints<'_> {
    type Output = ();

    #[inline(always)]
    fn run<V: Lanes>(self, tok: V::Token) {
        let Footprints {
            spheres,
            first,
            rects,
            unbounded,
            cop,
            window,
            raster,
        } = self;
        let (w, h) = (raster.width as f64, raster.height as f64);
        let all = [0, (raster.width - 1) as u16, 0, (raster.height - 1) as u16];
        let (zero, one) = (V::splat(tok, 0.0), V::splat(tok, 1.0));
        let (d, cop_x, cop_y) = (
            V::splat(tok, -cop.z),
            V::splat(tok, cop.x),
            V::splat(tok, cop.y),
        );
        let (half_x, wide) = (V::splat(tok, window.x * 0.5), V::splat(tok, window.x));
        let (half_y, high) = (V::splat(tok, window.y * 0.5), V::splat(tok, window.y));
        let (ws, hs) = (V::splat(tok, w), V::splat(tok, h));
        let view_cop = spheres.cop.to_array().map(|x| V::splat(tok, x));
        for (c, out) in rects.chunks_mut(LANES).enumerate() {
            let (at, n) = (first + c * LANES, out.len());
            // The centre relative to the COP: −f, f = COP − centre.
            let centre = |a: usize| lanes_at::<V>(tok, &spheres.center[a], at, n);
            let px = view_cop[0].sub(centre(0)).neg();
            let py = view_cop[1].sub(centre(1)).neg();
            let pz = view_cop[2].sub(centre(2)).neg();
            let r = lanes_at::<V>(tok, &spheres.radius, at, n);
            let culled = pz.le(r.neg());
            let cut = !culled & pz.le(r);
            let (ax0, ax1) = tangent_slopes_lanes(px, pz, r);
            let (ay0, ay1) = tangent_slopes_lanes(py, pz, r);
            // Window x → pixel column, window y → pixel row (rows grow downwards).
            let x0 = cop_x.add(d.mul(ax0)).add(half_x).div(wide).mul(ws).sub(one);
            let x1 = cop_x.add(d.mul(ax1)).add(half_x).div(wide).mul(ws).add(one);
            let y0 = half_y.sub(cop_y.add(d.mul(ay1))).div(high).mul(hs).sub(one);
            let y1 = half_y.sub(cop_y.add(d.mul(ay0))).div(high).mul(hs).add(one);
            let on_screen = x1.ge(zero) & y1.ge(zero) & x0.lt(ws) & y0.lt(hs);
            // Off screen, or NaN from a degenerate window (which has no bounds).
            let nan = !x0.eq(x0) | !y0.eq(y0);
            let unbound = cut | (!culled & !cut & !on_screen & nan);
            let bounded = !culled & !cut & on_screen;
            // Clamped first, then truncated: the floor of the value.
            let (i0, i1) = (
                clamp_lanes(tok, x0, raster.width),
                clamp_lanes(tok, x1, raster.width),
            );
            let (j0, j1) = (
                clamp_lanes(tok, y0, raster.height),
                clamp_lanes(tok, y1, raster.height),
            );
            for (l, rect) in out.iter_mut().enumerate() {
                *rect = if bounded >> l & 1 == 1 {
                    // Each in 0 ..= its side − 1, so each fits.
                    [i0[l] as u16, i1[l] as u16, j0[l] as u16, j1[l] as u16]
                } else if unbound >> l & 1 == 1 {
                    unbounded.push((at + l) as u32);
                    all
                } else {
                    [1, 0, 1, 0]
                };
            }
        }
    }
}

#[cfg(test)]
pub(super) mod tests {
    use super::*;
    use crate::render::simd::Simd;
    use crate::render::view::Reach;
    use crate::render::view::ViewSphere;

    /// Pixel rectangle (inclusive) a sphere's projection may cover.
    #[derive(Debug, Clone, Copy, PartialEq)]
    pub(in crate::render::tiles) enum Footprint {
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
    /// pixel so that rounding never drops a covered sample: one sphere at a time, the oracle of
    /// [`Footprints`], which does the same operations eight spheres at a time.
    pub(in crate::render::tiles) fn footprint(
        s: &Reach,
        cop: DVec3,
        window: DVec2,
        raster: Raster,
    ) -> Footprint {
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
        // Clamped to [0, n − 1] first, then truncated: the floor of the value (the same as
        // flooring first, without a call to floor for each of the four).
        let clamp = |v: f64, n: f64| v.max(0.0).min(n - 1.0) as usize;
        Footprint::Pixels {
            i0: clamp(x0, w),
            i1: clamp(x1, w),
            j0: clamp(y0, h),
            j1: clamp(y1, h),
        }
    }

    /// The footprints eight at a time, on every instruction path this CPU runs, are the
    /// one-sphere oracle's: seeded spheres in view, in front, behind, cut by the COP's plane,
    /// off screen on every side, huge and tiny, not a number, and degenerate windows; chunks
    /// that end inside a packet.
    #[test]
    fn footprints_in_packets_are_the_oracles_on_every_path() {
        use crate::splitmix::SplitMix;
        let mut rng = SplitMix(0xf007);
        let mut v = |scale: f64| (rng.unit() - 0.5) * scale;
        let cop = DVec3::new(0.1, -0.05, -1.5);
        let mut spheres: Vec<ViewSphere> = (0..20_000)
            .map(|k| {
                let r = match k % 4 {
                    0 => 1e-3 + v(0.1).abs(),
                    1 => v(4.0).abs(),
                    2 => 50.0 + v(100.0).abs(),
                    _ => 1e-9,
                };
                // Half of them in view, small.
                let (center, r) = if k % 2 == 0 {
                    let z = 2.0 + v(100.0).abs();
                    (DVec3::new(v(1.2) * z, v(0.7) * z, z), r.min(0.05 * z))
                } else {
                    (DVec3::new(v(40.0), v(30.0), v(60.0)), r)
                };
                ViewSphere::in_view(center, r, cop, k)
            })
            .collect();
        let odd = [
            (DVec3::new(0.0, 0.0, -1.5), 0.5),
            (DVec3::new(0.0, -1e5, 10.0), 1e5 - 1.0),
            (DVec3::new(f64::NAN, 0.0, 5.0), 1.0),
            (DVec3::new(0.0, f64::NAN, 5.0), 1.0),
            (DVec3::new(0.8, 0.45, 0.0), 0.01),
            (DVec3::new(1e300, 0.0, 1.0), 1.0),
        ];
        for (k, (center, r)) in odd.into_iter().enumerate() {
            spheres.push(ViewSphere::in_view(center, r, cop, 20_000 + k as u32));
        }
        let columns = ViewColumns::new(cop, &spheres);
        let raster = Raster {
            width: 97,
            height: 61,
            samples: 1,
            adaptive: false,
        };
        let windows = [
            DVec2::new(1.6, 0.9),
            DVec2::new(0.0, 0.9),
            DVec2::new(1.6, 0.0),
        ];
        for window in windows {
            let expected: Vec<([u16; 4], bool)> = spheres
                .iter()
                .map(|s| match footprint(&s.reach(), cop, window, raster) {
                    Footprint::Culled => ([1, 0, 1, 0], false),
                    Footprint::Everywhere => ([0, 96, 0, 60], true),
                    Footprint::Pixels { i0, i1, j0, j1 } => {
                        ([i0 as u16, i1 as u16, j0 as u16, j1 as u16], false)
                    }
                })
                .collect();
            let unbound = expected.iter().filter(|e| e.1).count();
            let culled = expected.iter().filter(|e| e.0 == [1, 0, 1, 0]).count();
            let bounded = expected.len() - unbound - culled;
            assert!(unbound > 3, "spheres without bounds");
            if window.x * window.y > 0.0 {
                assert!(
                    bounded > 1000 && culled > 1000,
                    "{bounded} bounded, {culled} culled"
                );
            }
            for simd in Simd::ALL.into_iter().filter(|s| s.supported()) {
                for chunk in [spheres.len(), 13, 8] {
                    let mut rects = vec![[7u16; 4]; spheres.len()];
                    let mut unbounded = Vec::new();
                    for (c, part) in rects.chunks_mut(chunk).enumerate() {
                        simd.isa().unwrap().run(Footprints {
                            spheres: &columns,
                            first: c * chunk,
                            rects: part,
                            unbounded: &mut unbounded,
                            cop,
                            window,
                            raster,
                        });
                    }
                    let got: Vec<([u16; 4], bool)> = rects
                        .iter()
                        .enumerate()
                        .map(|(k, &r)| (r, unbounded.contains(&(k as u32))))
                        .collect();
                    assert!(got == expected, "{} in chunks of {chunk}", simd.name());
                    assert!(unbounded.is_sorted());
                }
            }
        }
    }

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
