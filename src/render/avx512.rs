//! The packet path written out in AVX-512F intrinsics: one 8-lane register per packet value and
//! the comparisons kept as 8-bit lane masks, where the compiler's version of the lane loops in
//! `packet.rs` packs `bool` lanes bit by bit and clamps and converts one lane at a time.
//!
//! Every lane does what `packet.rs` (and so the one-ray code) does, in the same order: the same
//! additions, products, divisions and square roots (correctly rounded at any width; no fused
//! multiply-add, no approximate reciprocal); each Rust comparison becomes the predicate with the
//! same answer for NaN (`a >= b` is `_CMP_GE_OQ`, `!(a < b)` is `_CMP_NLT_UQ`); `f64::min` and
//! `max` against a constant become `vminpd`/`vmaxpd` with the variable first, which also return
//! the constant for a NaN. `tests/it/simd.rs` compares this path's bytes with the scalar path's.

use std::arch::x86_64::*;
use std::mem::{offset_of, size_of};

use super::packet::{RowJob, LANES, STRETCH};
use super::shadows::FrameShadows;
use super::tiles::TILE;
use super::{Shading, SrgbEncoder, ViewSphere, BUCKETS};

type V = __m512d;
/// Lane l is bit l.
type M = __mmask8;

const _: () = assert!(LANES == 8 && size_of::<ViewSphere>().is_multiple_of(8));
// Two packets side by side lie in one tile, and a stretch holds whole pairs.
const _: () = assert!(TILE.is_multiple_of(2 * LANES) && STRETCH.is_multiple_of(2 * LANES));

/// Each lane's sphere, for reading its fields: one sphere for the whole packet when every lane
/// that hit found the same one (the common case), otherwise lane by lane. A lane that missed
/// reads some sphere; its results are never used.
enum SphereLanes<'a> {
    One(&'a ViewSphere),
    Each(&'a [ViewSphere], __m512i),
}

impl<'a> SphereLanes<'a> {
    #[inline]
    #[target_feature(enable = "avx512f")]
    fn new(spheres: &'a [ViewSphere], hit: M, index: __m512i) -> SphereLanes<'a> {
        let mut first = [0u64; LANES];
        // SAFETY: `first` holds LANES u64s.
        unsafe { _mm512_storeu_si512(first.as_mut_ptr().cast(), index) };
        let k = first[hit.trailing_zeros() as usize];
        if _mm512_mask_cmpneq_epi64_mask(hit, index, _mm512_set1_epi64(k as i64)) == 0 {
            SphereLanes::One(&spheres[k as usize])
        } else {
            SphereLanes::Each(spheres, _mm512_maskz_mov_epi64(hit, index))
        }
    }

    /// The f64 field at byte `offset` of `ViewSphere`, and the value `one` when all lanes share
    /// a sphere.
    #[inline]
    #[target_feature(enable = "avx512f")]
    fn field(&self, offset: usize, one: impl Fn(&ViewSphere) -> f64) -> V {
        match *self {
            SphereLanes::One(s) => splat(one(s)),
            SphereLanes::Each(spheres, own) => {
                let slot = _mm512_add_epi64(
                    _mm512_mul_epu32(own, _mm512_set1_epi64((size_of::<ViewSphere>() / 8) as i64)),
                    _mm512_set1_epi64((offset / 8) as i64),
                );
                // SAFETY: every lane's `own` indexes `spheres`, and the slot lies inside it.
                unsafe { _mm512_i64gather_pd::<8>(slot, spheres.as_ptr().cast()) }
            }
        }
    }

    #[inline]
    #[target_feature(enable = "avx512f")]
    fn vec3(&self, offset: usize, one: impl Fn(&ViewSphere) -> glam::DVec3) -> [V; 3] {
        [
            self.field(offset, |s| one(s).x),
            self.field(offset + 8, |s| one(s).y),
            self.field(offset + 16, |s| one(s).z),
        ]
    }

    #[inline]
    #[target_feature(enable = "avx512f")]
    fn f(&self) -> [V; 3] {
        self.vec3(offset_of!(ViewSphere, f), |s| s.f)
    }

    #[inline]
    #[target_feature(enable = "avx512f")]
    fn center(&self) -> [V; 3] {
        self.vec3(offset_of!(ViewSphere, center), |s| s.center)
    }

    #[inline]
    #[target_feature(enable = "avx512f")]
    fn color(&self) -> [V; 3] {
        self.vec3(offset_of!(ViewSphere, color), |s| s.color)
    }

    #[inline]
    #[target_feature(enable = "avx512f")]
    fn radius(&self) -> V {
        self.field(offset_of!(ViewSphere, radius), |s| s.radius)
    }

    /// The spheres' scene indices, in 64-bit lanes.
    #[inline]
    #[target_feature(enable = "avx512f")]
    fn ids(&self) -> __m512i {
        match *self {
            SphereLanes::One(s) => _mm512_set1_epi64(s.id as i64),
            SphereLanes::Each(spheres, own) => {
                let bytes = _mm512_add_epi64(
                    _mm512_mul_epu32(own, _mm512_set1_epi64(size_of::<ViewSphere>() as i64)),
                    _mm512_set1_epi64(offset_of!(ViewSphere, id) as i64),
                );
                // SAFETY: every lane's offset is a sphere's `id` field.
                _mm512_cvtepu32_epi64(unsafe {
                    _mm512_i64gather_epi32::<1>(bytes, spheres.as_ptr().cast())
                })
            }
        }
    }
}

#[inline]
#[target_feature(enable = "avx512f")]
fn splat(x: f64) -> V {
    _mm512_set1_pd(x)
}

#[inline]
#[target_feature(enable = "avx512f")]
fn add(a: V, b: V) -> V {
    _mm512_add_pd(a, b)
}

#[inline]
#[target_feature(enable = "avx512f")]
fn sub(a: V, b: V) -> V {
    _mm512_sub_pd(a, b)
}

#[inline]
#[target_feature(enable = "avx512f")]
fn mul(a: V, b: V) -> V {
    _mm512_mul_pd(a, b)
}

/// (a·b for x and y) + z: glam's dot product order.
#[inline]
#[target_feature(enable = "avx512f")]
fn dot(a: &[V; 3], b: &[V; 3]) -> V {
    add(add(mul(a[0], b[0]), mul(a[1], b[1])), mul(a[2], b[2]))
}

/// `a` with the sign of `b` (f64::copysign).
#[inline]
#[target_feature(enable = "avx512f")]
fn copysign(a: V, b: V) -> V {
    let sign = _mm512_set1_epi64(i64::MIN);
    let (a, b) = (_mm512_castpd_si512(a), _mm512_castpd_si512(b));
    _mm512_castsi512_pd(_mm512_or_epi64(
        _mm512_andnot_epi64(sign, a),
        _mm512_and_epi64(sign, b),
    ))
}

/// −a (the sign bit flipped, as Rust's negation).
#[inline]
#[target_feature(enable = "avx512f")]
fn neg(a: V) -> V {
    let sign = _mm512_set1_epi64(i64::MIN);
    _mm512_castsi512_pd(_mm512_xor_epi64(_mm512_castpd_si512(a), sign))
}

/// f64::max(a, b): b where a is NaN, a where b is NaN.
#[inline]
#[target_feature(enable = "avx512f")]
fn max_num(a: V, b: V) -> V {
    let m = _mm512_max_pd(a, b);
    _mm512_mask_blend_pd(_mm512_cmp_pd_mask::<_CMP_UNORD_Q>(b, b), m, a)
}

/// Renders row `j` as `RowJob::row_packets` does, to the same bytes.
///
/// # Safety
/// The CPU must have AVX-512F.
#[target_feature(enable = "avx512f")]
pub unsafe fn row(job: &RowJob, j: usize, row: &mut [u8]) {
    let width = row.len() / 3;
    let t = job.table;
    let (y, z) = (t.ys[j], t.dz);
    let (yy, zz) = (splat(y * y), splat(z * z));
    // A stretch of the row's unit directions, as `RowJob::directions`, computed ahead of its
    // packets: independent square roots and divisions, out of each packet's chain of dependent
    // work. Lanes past the row's end repeat its last pixel.
    let mut dirs = [[_mm512_setzero_pd(); 3]; STRETCH / LANES];
    // Two packets at a time, side by side in one tile: they share its candidates, and their
    // two chains of dependent work interleave.
    for (p, out) in row.chunks_mut(6 * LANES).enumerate() {
        let i0 = p * 2 * LANES;
        if i0.is_multiple_of(STRETCH) {
            for (q, d) in dirs.iter_mut().enumerate() {
                let at = i0 + q * LANES;
                if at >= width {
                    break;
                }
                let mut xs = [t.xs[width - 1]; LANES];
                let m = (width - at).min(LANES);
                xs[..m].copy_from_slice(&t.xs[at..at + m]);
                // SAFETY: `xs` holds LANES f64s.
                let x = unsafe { _mm512_loadu_pd(xs.as_ptr()) };
                let r = _mm512_div_pd(splat(1.0), _mm512_sqrt_pd(add(add(mul(x, x), yy), zz)));
                *d = [mul(x, r), mul(splat(y), r), mul(splat(z), r)];
            }
        }
        let at = i0 % STRETCH / LANES;
        let d = [dirs[at], dirs[at + 1]];
        // Pixels in each packet; the second is empty at the end of a row of an odd packet count.
        let n = [
            (width - i0).min(LANES),
            (width - i0).saturating_sub(LANES).min(LANES),
        ];
        let candidates = job.bins.at(i0, j);
        let covers = |k: u32, q: usize| {
            let first = i0 + q * LANES;
            job.bins.covers(k, first, first + n[q] - 1, j)
        };
        let found = nearest(job.ctx, &d, candidates, covers, [true, n[1] > 0]);
        for (q, out) in out.chunks_mut(3 * LANES).enumerate() {
            let (hit, index, t) = found[q];
            if hit == 0 {
                for px in out.chunks_exact_mut(3) {
                    px.copy_from_slice(&job.background);
                }
                continue;
            }
            let colors = shade(job.ctx, &d[q], hit, index, t);
            let levels = encode(job.encode, &colors);
            for (l, px) in out.chunks_exact_mut(3).enumerate() {
                px.copy_from_slice(&[levels[0][l], levels[1][l], levels[2][l]]);
            }
        }
    }
}

/// `Shading::nearest_packet` for two packets (directions `d`, `covers(k, packet)`) at once:
/// per lane of each, whether it hit, which sphere (64-bit lanes) and where. Each packet does
/// exactly what it would alone: it passes a sphere that does not cover it, and stops for good
/// at the first one none of its lanes would test; a packet not `live` takes no part.
#[inline]
#[target_feature(enable = "avx512f")]
fn nearest(
    ctx: &Shading,
    d: &[[V; 3]; 2],
    candidates: &[u32],
    covers: impl Fn(u32, usize) -> bool,
    mut live: [bool; 2],
) -> [(M, __m512i, V); 2] {
    let zero = _mm512_setzero_pd();
    let mut hit: [M; 2] = [0; 2];
    let mut index = [_mm512_setzero_si512(); 2];
    let mut best = [splat(f64::INFINITY); 2];
    for &k in candidates {
        let s = &ctx.spheres[k as usize];
        let min_dist = splat(s.min_dist);
        let mut active: [M; 2] = [0; 2];
        for q in 0..2 {
            if live[q] && covers(k, q) {
                // Lanes still searching: no hit yet, or this sphere might be nearer.
                active[q] = !hit[q] | !_mm512_cmp_pd_mask::<_CMP_GE_OQ>(min_dist, best[q]);
                live[q] = active[q] != 0;
            }
        }
        if !(live[0] | live[1]) {
            break;
        }
        if active[0] | active[1] == 0 {
            continue;
        }
        let f = [splat(s.f.x), splat(s.f.y), splat(s.f.z)];
        let (c, radius2) = (splat(s.c), splat(s.radius2));
        let k = _mm512_set1_epi64(k as i64);
        for q in 0..2 {
            let d = &d[q];
            let b = dot(&f, d);
            let g = [
                sub(f[0], mul(d[0], b)),
                sub(f[1], mul(d[1], b)),
                sub(f[2], mul(d[2], b)),
            ];
            let disc = sub(radius2, dot(&g, &g));
            // Unlike `nearest_packet`, no branch past the roots when no lane meets the sphere:
            // with whole registers the roots cost less than the mispredicted branches.
            let meets = active[q] & _mm512_cmp_pd_mask::<_CMP_NLT_UQ>(disc, zero);
            let root_q = neg(add(b, copysign(_mm512_sqrt_pd(disc), b)));
            let (t0, t1) = (_mm512_div_pd(c, root_q), root_q);
            let lt = _mm512_cmp_pd_mask::<_CMP_LT_OQ>(t0, t1);
            let near = _mm512_mask_blend_pd(lt, t1, t0);
            let far = _mm512_mask_blend_pd(lt, t0, t1);
            let near_ahead = _mm512_cmp_pd_mask::<_CMP_GT_OQ>(near, zero);
            let far_ahead = _mm512_cmp_pd_mask::<_CMP_GT_OQ>(far, zero);
            let t = _mm512_mask_blend_pd(near_ahead, far, near);
            let root = _mm512_cmp_pd_mask::<_CMP_NEQ_UQ>(root_q, zero) & (near_ahead | far_ahead);
            let take = meets & root & (!hit[q] | _mm512_cmp_pd_mask::<_CMP_LT_OQ>(t, best[q]));
            best[q] = _mm512_mask_blend_pd(take, best[q], t);
            index[q] = _mm512_mask_mov_epi64(index[q], take, k);
            hit[q] |= take;
        }
    }
    [(hit[0], index[0], best[0]), (hit[1], index[1], best[1])]
}

/// `Shading::shade_packet`: linear r, g and b of a packet that hit something.
#[inline]
#[target_feature(enable = "avx512f")]
fn shade(ctx: &Shading, d: &[V; 3], hit: M, index: __m512i, t: V) -> [V; 3] {
    let zero = _mm512_setzero_pd();
    let one = splat(1.0);
    let spheres = ctx.spheres;
    let fields = SphereLanes::new(spheres, hit, index);
    let mut light = [splat(ctx.ambient); 3];
    if !ctx.lights.is_empty() {
        let (f, c, r) = (fields.f(), fields.center(), fields.radius());
        // ViewSphere::surface: rel = f + d·t, normal = rel / r, point = centre + rel.
        let rel = [
            add(f[0], mul(d[0], t)),
            add(f[1], mul(d[1], t)),
            add(f[2], mul(d[2], t)),
        ];
        let normal = [
            _mm512_div_pd(rel[0], r),
            _mm512_div_pd(rel[1], r),
            _mm512_div_pd(rel[2], r),
        ];
        let point = [add(c[0], rel[0]), add(c[1], rel[1]), add(c[2], rel[2])];
        for l in ctx.lights {
            let to = [
                splat(l.to_light.x),
                splat(l.to_light.y),
                splat(l.to_light.z),
            ];
            let facing = dot(&normal, &to);
            let mut lit = hit & _mm512_cmp_pd_mask::<_CMP_NLE_UQ>(facing, zero);
            if let Some(grid) = &l.shadows {
                if lit != 0 {
                    lit &= !occluded(grid, &point, fields.ids(), lit);
                }
            }
            let color = l.color.to_array();
            for a in 0..3 {
                light[a] =
                    _mm512_mask_add_pd(light[a], lit, light[a], mul(splat(color[a]), facing));
            }
        }
    }
    let color = fields.color();
    let background = ctx.background.to_array();
    let flat = ctx.lights.is_empty();
    let mut out = [zero; 3];
    for a in 0..3 {
        // Shading::color: clamp to [0, 1], or only to 1 for a flat scene.
        let c = mul(color[a], light[a]);
        let c = if flat {
            _mm512_min_pd(c, one)
        } else {
            _mm512_min_pd(_mm512_max_pd(c, zero), one)
        };
        out[a] = _mm512_mask_blend_pd(hit, splat(background[a]), c);
    }
    out
}

/// `FrameShadows::occluded_packet`: which of the lanes in `need` (view points `point` on
/// spheres `own`) the light does not reach.
#[inline]
#[target_feature(enable = "avx512f")]
fn occluded(sh: &FrameShadows, point: &[V; 3], own: __m512i, need: M) -> M {
    let mut blocked: M = 0;
    for &(k, c, r2) in &sh.always {
        blocked |= need & blocks(sh, point, own, k, c.to_array(), r2);
        if need & !blocked == 0 {
            return blocked;
        }
    }
    if sh.grid.dims.0 == 0 {
        return blocked;
    }
    // FrameShadows::square on whole lanes.
    let (ax, ay) = sh.axes;
    let q = [
        add(
            dot(point, &[splat(ax.x), splat(ax.y), splat(ax.z)]),
            splat(sh.offset.x),
        ),
        add(
            dot(point, &[splat(ay.x), splat(ay.y), splat(ay.z)]),
            splat(sh.offset.y),
        ),
    ];
    let size = max_num(
        max_num(_mm512_abs_pd(point[0]), _mm512_abs_pd(point[1])),
        _mm512_abs_pd(point[2]),
    );
    let err = mul(splat(1e-9), add(splat(sh.slack), size));
    let inv = splat(sh.grid.inv_cell);
    let mut lo = [[0.0; LANES]; 2];
    let mut hi = [[0.0; LANES]; 2];
    for a in 0..2 {
        // SAFETY: each array holds LANES f64s.
        unsafe {
            _mm512_storeu_pd(lo[a].as_mut_ptr(), mul(sub(q[a], err), inv));
            _mm512_storeu_pd(hi[a].as_mut_ptr(), mul(add(q[a], err), inv));
        }
    }
    sh.cell_groups(&lo, &hi, need & !blocked, |k, lanes| {
        let (k, c, r2) = sh.blocker(k);
        blocked |= lanes & blocks(sh, point, own, k, c.to_array(), r2);
        lanes & !blocked != 0
    });
    blocked
}

/// The lanes whose shadow ray sphere k (centre `c`, r² `r2`, in view coordinates) blocks
/// (`blocks_ray`), leaving out lanes on sphere k itself.
#[inline]
#[target_feature(enable = "avx512f")]
fn blocks(sh: &FrameShadows, point: &[V; 3], own: __m512i, k: u32, c: [f64; 3], r2: f64) -> M {
    let zero = _mm512_setzero_pd();
    let dir = sh.to_light;
    let dir = [splat(dir.x), splat(dir.y), splat(dir.z)];
    let f = [
        sub(point[0], splat(c[0])),
        sub(point[1], splat(c[1])),
        sub(point[2], splat(c[2])),
    ];
    let cc = sub(dot(&f, &f), splat(r2));
    let b = dot(&f, &dir);
    let g = [
        sub(f[0], mul(dir[0], b)),
        sub(f[1], mul(dir[1], b)),
        sub(f[2], mul(dir[2], b)),
    ];
    let g2 = dot(&g, &g);
    let inside = _mm512_cmp_pd_mask::<_CMP_LE_OQ>(cc, zero);
    let ahead =
        _mm512_cmp_pd_mask::<_CMP_LT_OQ>(b, zero) & _mm512_cmp_pd_mask::<_CMP_LE_OQ>(g2, splat(r2));
    (inside | ahead) & _mm512_cmpneq_epi64_mask(own, _mm512_set1_epi64(k as i64))
}

/// `SrgbEncoder::encode_lanes` for the three channels.
#[inline]
#[target_feature(enable = "avx512f")]
fn encode(enc: &SrgbEncoder, linear: &[V; 3]) -> [[u8; LANES]; 3] {
    let (zero, one) = (_mm512_setzero_pd(), splat(1.0));
    let mut out = [[0u8; LANES]; 3];
    for a in 0..3 {
        // f64::clamp(0, 1), which keeps a NaN.
        let x = linear[a];
        let x = _mm512_mask_blend_pd(_mm512_cmp_pd_mask::<_CMP_LT_OQ>(x, zero), x, zero);
        let x = _mm512_mask_blend_pd(_mm512_cmp_pd_mask::<_CMP_GT_OQ>(x, one), x, one);
        // `as i32` maps NaN to 0; the conversion gives i32::MIN for it, which the max lifts.
        let bucket = _mm512_cvttpd_epi32(mul(x, splat(BUCKETS as f64)));
        let bucket = _mm256_min_epi32(
            _mm256_max_epi32(bucket, _mm256_setzero_si256()),
            _mm256_set1_epi32(BUCKETS as i32),
        );
        let mut xs = [0.0; LANES];
        let mut bs = [0i32; LANES];
        // SAFETY: each array holds LANES values of the stored width.
        unsafe {
            _mm512_storeu_pd(xs.as_mut_ptr(), x);
            _mm256_storeu_si256(bs.as_mut_ptr().cast(), bucket);
        }
        for l in 0..LANES {
            let level = enc.first[bs[l] as usize];
            out[a][l] = level + (xs[l] >= enc.thresholds[level as usize]) as u8;
        }
    }
    out
}
