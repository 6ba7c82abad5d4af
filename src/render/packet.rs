//! Ray packets: [`LANES`] neighbouring pixels of a row cast together, primary and shadow rays
//! alike, and the choice of CPU instructions that runs them.
//!
//! Each lane does exactly the operations, in exactly the order, of the one-ray-at-a-time code in
//! `mod.rs` and `shadows.rs`: the same dot products, the same stable roots, the same tests. Only
//! the control flow differs — branches become per-lane masks, and a packet leaves the sorted
//! candidate list once every lane would have left it. IEEE addition, multiplication, division
//! and square root are correctly rounded at every vector width, Rust never fuses a multiply and
//! an add on its own, and nothing here uses an approximate reciprocal, so every [`Simd`] path
//! gives the scalar path's bits. The lane loops over fixed-size arrays are vectorised by the
//! compiler for the instruction set each entry point enables.

use super::tiles::TileBins;
use super::{RayTable, Shading, SrgbEncoder};

/// Rays per packet: a whole AVX-512 register, two AVX2 ones or four SSE2 ones of f64. Divides
/// the tile side, so a packet never straddles two tiles.
pub const LANES: usize = 8;

pub type Lanes = [f64; LANES];
pub type Mask = [bool; LANES];

/// Pixels of a row whose directions are computed together; a multiple of [`LANES`].
pub(super) const STRETCH: usize = 32 * LANES;

/// How the renderer casts its rays. Every choice gives the same bytes; they differ in speed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Simd {
    /// One ray at a time, with branches (the reference).
    Scalar,
    /// Packets with the target's baseline vectors (SSE2 on x86-64).
    Baseline,
    /// Packets compiled for AVX2.
    Avx2,
    /// Packets compiled for AVX-512F.
    Avx512,
}

impl Simd {
    /// Every path, slowest first.
    pub const ALL: [Simd; 4] = [Simd::Scalar, Simd::Baseline, Simd::Avx2, Simd::Avx512];

    /// Whether this CPU can run the path.
    pub fn supported(self) -> bool {
        match self {
            Simd::Scalar | Simd::Baseline => true,
            #[cfg(target_arch = "x86_64")]
            Simd::Avx2 => std::arch::is_x86_feature_detected!("avx2"),
            #[cfg(target_arch = "x86_64")]
            Simd::Avx512 => std::arch::is_x86_feature_detected!("avx512f"),
            #[cfg(not(target_arch = "x86_64"))]
            Simd::Avx2 | Simd::Avx512 => false,
        }
    }

    /// The fastest path this CPU runs.
    pub fn fastest() -> Simd {
        *Simd::ALL
            .iter()
            .rev()
            .find(|s| s.supported())
            .unwrap_or(&Simd::Scalar)
    }

    /// The path named by the environment variable `CAMPATH_SIMD` (`scalar`, `sse2`, `avx2`,
    /// `avx512`) when this CPU runs it, otherwise the fastest. The choice never changes the
    /// bytes; it is there to check exactly that, and to measure each path.
    pub fn detect() -> Simd {
        match Simd::from_env() {
            Some(Ok(s)) if s.supported() => s,
            _ => Simd::fastest(),
        }
    }

    /// `CAMPATH_SIMD` read and parsed, None when unset. An unknown name or a path this CPU
    /// cannot run is an error, for the command line to report.
    pub fn from_env() -> Option<Result<Simd, String>> {
        let name = std::env::var("CAMPATH_SIMD").ok()?;
        Some(name.parse::<Simd>().and_then(|s| {
            if s.supported() {
                Ok(s)
            } else {
                Err(format!("this CPU cannot run the {} path", s.name()))
            }
        }))
    }

    pub fn name(self) -> &'static str {
        match self {
            Simd::Scalar => "scalar",
            Simd::Baseline if cfg!(target_arch = "x86_64") => "sse2",
            Simd::Baseline => "baseline",
            Simd::Avx2 => "avx2",
            Simd::Avx512 => "avx512",
        }
    }
}

impl std::str::FromStr for Simd {
    type Err = String;

    fn from_str(s: &str) -> Result<Simd, String> {
        Simd::ALL
            .into_iter()
            .find(|p| p.name() == s)
            .ok_or_else(|| {
                let names: Vec<&str> = Simd::ALL.iter().map(|p| p.name()).collect();
                format!(
                    "unknown instruction path {s:?}: one of {}",
                    names.join(", ")
                )
            })
    }
}

/// What one row needs: the scene in view coordinates, the ray table and the tiles.
pub struct RowJob<'a> {
    pub ctx: &'a Shading<'a>,
    pub table: &'a RayTable,
    pub bins: &'a TileBins,
    pub encode: &'a SrgbEncoder,
    /// The background's sRGB levels.
    pub background: [u8; 3],
}

impl RowJob<'_> {
    /// Renders row `j` (one sample per pixel) into `row` (RGB8) in packets, with the
    /// instructions of `simd`, which must be [`Simd::supported`] and not `Scalar`.
    pub fn row(&self, simd: Simd, j: usize, row: &mut [u8]) {
        match simd {
            #[cfg(target_arch = "x86_64")]
            // SAFETY: the caller checked `Simd::supported`, so the CPU has AVX2.
            Simd::Avx2 => unsafe { self.row_avx2(j, row) },
            #[cfg(target_arch = "x86_64")]
            // SAFETY: the caller checked `Simd::supported`, so the CPU has AVX-512F.
            Simd::Avx512 => unsafe { super::avx512::row(self, j, row) },
            _ => self.row_packets(j, row),
        }
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn row_avx2(&self, j: usize, row: &mut [u8]) {
        self.row_packets(j, row)
    }

    #[inline(always)]
    fn row_packets(&self, j: usize, row: &mut [u8]) {
        let width = row.len() / 3;
        // Directions for a stretch of the row first: one loop of independent square roots and
        // divisions, kept out of each packet's chain of dependent work.
        let mut dirs = [[0.0; STRETCH]; 3];
        for (p, out) in row.chunks_mut(3 * LANES).enumerate() {
            let i0 = p * LANES;
            let n = (width - i0).min(LANES);
            let at = i0 % STRETCH;
            if at == 0 {
                self.directions(i0, (width - i0).min(STRETCH), j, &mut dirs);
            }
            let lane = |a: usize| -> Lanes { dirs[a][at..at + LANES].try_into().unwrap() };
            let d = [lane(0), lane(1), lane(2)];
            let candidates = self.bins.at(i0, j);
            let covers = |k: u32| self.bins.covers(k, i0, i0 + n - 1, j);
            let (hit, index, t) = self.ctx.nearest_packet(&d, candidates, covers);
            if !any(&hit) {
                // All background (sky): the frame's background levels, already encoded.
                for px in out.chunks_exact_mut(3) {
                    px.copy_from_slice(&self.background);
                }
                continue;
            }
            let colors = self.ctx.shade_packet(&d, hit, &index, &t);
            // Plain calls, not `array::map`: its closure is not inlined into this function and
            // loses the instruction set it was compiled for.
            let enc = self.encode;
            let levels = [
                enc.encode_lanes(&colors[0]),
                enc.encode_lanes(&colors[1]),
                enc.encode_lanes(&colors[2]),
            ];
            for (l, px) in out.chunks_exact_mut(3).enumerate() {
                px.copy_from_slice(&[levels[0][l], levels[1][l], levels[2][l]]);
            }
        }
    }

    /// Unit directions of pixels i0..i0 + n of row j, normalised exactly as `DVec3::normalize`
    /// does (v · (1 / √(v·v))), into `d`'s x, y and z rows; entries past `n` repeat the last
    /// pixel.
    #[inline(always)]
    fn directions(&self, i0: usize, n: usize, j: usize, d: &mut [[f64; STRETCH]; 3]) {
        let t = self.table;
        let mut x = [t.xs[i0 + n - 1]; STRETCH];
        x[..n].copy_from_slice(&t.xs[i0..i0 + n]);
        let (y, z) = (t.ys[j], t.dz);
        for l in 0..STRETCH {
            let recip = 1.0 / ((x[l] * x[l] + y * y) + z * z).sqrt();
            d[0][l] = x[l] * recip;
            d[1][l] = y * recip;
            d[2][l] = z * recip;
        }
    }
}

impl Shading<'_> {
    /// `Shading::nearest` for a packet: per lane, whether it hit, which sphere and where. A lane
    /// takes part in a candidate exactly while the one-ray search would still be running.
    // The negated comparisons keep the scalar code's treatment of NaN exactly.
    #[allow(clippy::neg_cmp_op_on_partial_ord)]
    #[inline(always)]
    fn nearest_packet(
        &self,
        d: &[Lanes; 3],
        candidates: &[u32],
        covers: impl Fn(u32) -> bool,
    ) -> (Mask, [u32; LANES], Lanes) {
        let mut hit = [false; LANES];
        let mut index = [u32::MAX; LANES];
        let mut best = [f64::INFINITY; LANES];
        for &k in candidates {
            // A sphere whose projection misses these pixels cannot be hit by their rays. (Passing
            // it before the test below changes nothing: once every lane has stopped, it stays
            // stopped, and the next candidate ends the search.)
            if !covers(k) {
                continue;
            }
            let s = &self.spheres[k as usize];
            let mut active = [false; LANES];
            for l in 0..LANES {
                active[l] = !hit[l] || !(s.min_dist >= best[l]);
            }
            if !any(&active) {
                break;
            }
            let (f, c, r2) = (s.f, s.c, s.radius2);
            let mut b = [0.0; LANES];
            let mut disc = [0.0; LANES];
            let mut meets = [false; LANES];
            for l in 0..LANES {
                b[l] = (f.x * d[0][l] + f.y * d[1][l]) + f.z * d[2][l];
                let g = [
                    f.x - d[0][l] * b[l],
                    f.y - d[1][l] * b[l],
                    f.z - d[2][l] * b[l],
                ];
                disc[l] = r2 - ((g[0] * g[0] + g[1] * g[1]) + g[2] * g[2]);
                meets[l] = active[l] & !(disc[l] < 0.0);
            }
            // Most candidates miss every lane: no square root or division for them.
            if !any(&meets) {
                continue;
            }
            for l in 0..LANES {
                let (b, disc) = (b[l], disc[l]);
                let q = -(b + disc.sqrt().copysign(b));
                let (t0, t1) = (c / q, q);
                let lt = t0 < t1;
                let near = if lt { t0 } else { t1 };
                let far = if lt { t1 } else { t0 };
                let t = if near > 0.0 { near } else { far };
                let root = (q != 0.0) & ((near > 0.0) | (far > 0.0));
                let take = meets[l] & root & (!hit[l] | (t < best[l]));
                best[l] = if take { t } else { best[l] };
                index[l] = if take { k } else { index[l] };
                hit[l] |= take;
            }
        }
        (hit, index, best)
    }

    /// `Shading::shade`'s linear colours (r, g and b lanes) for a packet's hits, background
    /// where a lane missed, with the shadow rays of each light cast as one packet. The caller
    /// writes a packet that hit nothing without it (`RowJob::row_packets`).
    // As in `nearest_packet`; and `max` then `min` is glam's clamp (f64::clamp keeps a NaN).
    #[allow(clippy::neg_cmp_op_on_partial_ord, clippy::manual_clamp)]
    #[inline(always)]
    fn shade_packet(
        &self,
        d: &[Lanes; 3],
        hit: Mask,
        index: &[u32; LANES],
        t: &Lanes,
    ) -> [Lanes; 3] {
        let background = self.background.to_array();
        // Each lane's sphere (the first for a lane that missed; its results are not used).
        let mut own = [0usize; LANES];
        for l in 0..LANES {
            own[l] = if hit[l] { index[l] as usize } else { 0 };
        }
        let sphere = |l: usize| &self.spheres[own[l]];
        let mut light = [[self.ambient; LANES]; 3];
        if !self.lights.is_empty() {
            // ViewSphere::surface, lane by lane: rel = f + d·t, normal = rel / r, point = centre + rel.
            let mut normal = [[0.0; LANES]; 3];
            let mut point = [[0.0; LANES]; 3];
            for l in 0..LANES {
                let s = sphere(l);
                let (f, c, r) = (s.f.to_array(), s.center.to_array(), s.radius);
                for a in 0..3 {
                    let rel = f[a] + d[a][l] * t[l];
                    normal[a][l] = rel / r;
                    point[a][l] = c[a] + rel;
                }
            }
            for l in self.lights {
                let (to, color) = (l.to_light, l.color.to_array());
                let mut facing = [0.0; LANES];
                let mut lit = [false; LANES];
                for k in 0..LANES {
                    facing[k] = (normal[0][k] * to.x + normal[1][k] * to.y) + normal[2][k] * to.z;
                    lit[k] = hit[k] & !(facing[k] <= 0.0);
                }
                if let Some(grid) = &l.shadows {
                    if any(&lit) {
                        let mut ids = [0u32; LANES];
                        for k in 0..LANES {
                            ids[k] = self.spheres[own[k]].id;
                        }
                        let blocked = grid.occluded_packet(&point, &ids, lit);
                        for k in 0..LANES {
                            lit[k] &= !blocked[k];
                        }
                    }
                }
                for a in 0..3 {
                    for k in 0..LANES {
                        let add = light[a][k] + color[a] * facing[k];
                        light[a][k] = if lit[k] { add } else { light[a][k] };
                    }
                }
            }
        }
        let flat = self.lights.is_empty();
        let mut out = [[0.0; LANES]; 3];
        for l in 0..LANES {
            let color = sphere(l).color.to_array();
            for a in 0..3 {
                // Shading::color: clamp to [0, 1], or only to 1 for a flat scene.
                let c = color[a] * light[a][l];
                let c = if flat {
                    c.min(1.0)
                } else {
                    c.max(0.0).min(1.0)
                };
                out[a][l] = if hit[l] { c } else { background[a] };
            }
        }
        out
    }
}

/// Whether any lane is set.
#[inline(always)]
pub fn any(m: &Mask) -> bool {
    m.iter().fold(false, |a, &b| a | b)
}
