//! Eight f64 lanes and 8-bit lane masks (lane l is bit l), in three forms: one AVX-512
//! register, two AVX2 registers, and plain arrays for every other target (the compiler
//! vectorises them for SSE2). The packet code in `packet.rs` is written once against
//! [`Lanes`].
//!
//! Every operation is the IEEE operation Rust's scalar code does, correctly rounded at any width:
//! no fused multiply-add, no approximate reciprocal or square root. Comparisons are ordered
//! (false for NaN), as Rust's; the code negates a mask where the scalar code negates a
//! comparison.
//!
//! The x86 forms call intrinsics from methods without `#[target_feature]`: they are inlined into
//! the row functions compiled for AVX-512F or AVX2 (`RowJob::row_avx512` and the like), which
//! the dispatcher enters only after checking the CPU, and are used nowhere else (`Zmm` and
//! `Ymm2` are private to the renderer). A closure between the two (`array::map`, a callback)
//! may be left out of line and compiled without the instruction set, which turns every
//! intrinsic in it into a call: no closure in the packet code calls one.

// The portable lane loops index their arrays by lane, as the compiler vectorises them best.
#![allow(clippy::needless_range_loop)]

use super::packet::LANES;
use super::ViewSphere;

/// Eight lanes of f64 and a matching set of eight 64-bit sphere indices.
pub(super) trait Lanes: Copy {
    type Index: Copy;

    fn splat(x: f64) -> Self;
    fn load(x: &[f64; LANES]) -> Self;
    fn store(self) -> [f64; LANES];
    fn add(self, b: Self) -> Self;
    fn sub(self, b: Self) -> Self;
    fn mul(self, b: Self) -> Self;
    fn div(self, b: Self) -> Self;
    fn sqrt(self) -> Self;
    /// −self: the sign bit flipped.
    fn neg(self) -> Self;
    /// f64::copysign.
    fn copysign(self, sign: Self) -> Self;
    fn abs(self) -> Self;
    /// f64::min (a NaN operand gives the other).
    fn min(self, b: Self) -> Self;
    /// f64::max (a NaN operand gives the other).
    fn max(self, b: Self) -> Self;
    fn lt(self, b: Self) -> u8;
    fn le(self, b: Self) -> u8;
    fn gt(self, b: Self) -> u8;
    fn ge(self, b: Self) -> u8;
    fn eq(self, b: Self) -> u8;
    /// Lanes of `b` where `m` is set, of `a` elsewhere.
    fn blend(m: u8, a: Self, b: Self) -> Self;
    /// `(self as i32).clamp(0, max)` per lane, for lanes in [0, max] or NaN (which gives 0).
    fn to_i32(self, max: i32) -> [i32; LANES];

    fn index(k: u64) -> Self::Index;
    fn index_blend(m: u8, a: Self::Index, b: Self::Index) -> Self::Index;
    fn index_eq(a: Self::Index, b: Self::Index) -> u8;
    fn index_store(a: Self::Index) -> [u64; LANES];
    /// The f64 at byte `offset` of each lane's sphere `spheres[own]`.
    fn gather(spheres: &[ViewSphere], own: Self::Index, offset: usize) -> Self;
    /// Each lane's sphere's `id`.
    fn gather_ids(spheres: &[ViewSphere], own: Self::Index) -> Self::Index;
}

/// Plain arrays, for the baseline path and targets without an x86 form.
#[derive(Clone, Copy)]
pub(super) struct Portable([f64; LANES]);

impl Portable {
    #[inline(always)]
    fn map(self, f: impl Fn(f64) -> f64) -> Portable {
        let mut out = [0.0; LANES];
        for l in 0..LANES {
            out[l] = f(self.0[l]);
        }
        Portable(out)
    }

    #[inline(always)]
    fn zip(self, b: Portable, f: impl Fn(f64, f64) -> f64) -> Portable {
        let mut out = [0.0; LANES];
        for l in 0..LANES {
            out[l] = f(self.0[l], b.0[l]);
        }
        Portable(out)
    }

    #[inline(always)]
    fn test(self, b: Portable, f: impl Fn(f64, f64) -> bool) -> u8 {
        let mut m = 0u8;
        for l in 0..LANES {
            m |= (f(self.0[l], b.0[l]) as u8) << l;
        }
        m
    }
}

impl Lanes for Portable {
    type Index = [u64; LANES];

    #[inline(always)]
    fn splat(x: f64) -> Self {
        Portable([x; LANES])
    }
    #[inline(always)]
    fn load(x: &[f64; LANES]) -> Self {
        Portable(*x)
    }
    #[inline(always)]
    fn store(self) -> [f64; LANES] {
        self.0
    }
    #[inline(always)]
    fn add(self, b: Self) -> Self {
        self.zip(b, |x, y| x + y)
    }
    #[inline(always)]
    fn sub(self, b: Self) -> Self {
        self.zip(b, |x, y| x - y)
    }
    #[inline(always)]
    fn mul(self, b: Self) -> Self {
        self.zip(b, |x, y| x * y)
    }
    #[inline(always)]
    fn div(self, b: Self) -> Self {
        self.zip(b, |x, y| x / y)
    }
    #[inline(always)]
    fn sqrt(self) -> Self {
        self.map(f64::sqrt)
    }
    #[inline(always)]
    fn neg(self) -> Self {
        self.map(|x| -x)
    }
    #[inline(always)]
    fn copysign(self, sign: Self) -> Self {
        self.zip(sign, f64::copysign)
    }
    #[inline(always)]
    fn abs(self) -> Self {
        self.map(f64::abs)
    }
    #[inline(always)]
    fn min(self, b: Self) -> Self {
        self.zip(b, f64::min)
    }
    #[inline(always)]
    fn max(self, b: Self) -> Self {
        self.zip(b, f64::max)
    }
    #[inline(always)]
    fn lt(self, b: Self) -> u8 {
        self.test(b, |x, y| x < y)
    }
    #[inline(always)]
    fn le(self, b: Self) -> u8 {
        self.test(b, |x, y| x <= y)
    }
    #[inline(always)]
    fn gt(self, b: Self) -> u8 {
        self.test(b, |x, y| x > y)
    }
    #[inline(always)]
    fn ge(self, b: Self) -> u8 {
        self.test(b, |x, y| x >= y)
    }
    #[inline(always)]
    fn eq(self, b: Self) -> u8 {
        self.test(b, |x, y| x == y)
    }
    #[inline(always)]
    fn blend(m: u8, a: Self, b: Self) -> Self {
        let mut out = a.0;
        for l in 0..LANES {
            if m >> l & 1 == 1 {
                out[l] = b.0[l];
            }
        }
        Portable(out)
    }
    #[inline(always)]
    fn to_i32(self, max: i32) -> [i32; LANES] {
        let mut out = [0; LANES];
        for l in 0..LANES {
            out[l] = (self.0[l] as i32).clamp(0, max);
        }
        out
    }

    #[inline(always)]
    fn index(k: u64) -> Self::Index {
        [k; LANES]
    }
    #[inline(always)]
    fn index_blend(m: u8, a: Self::Index, b: Self::Index) -> Self::Index {
        let mut out = a;
        for l in 0..LANES {
            if m >> l & 1 == 1 {
                out[l] = b[l];
            }
        }
        out
    }
    #[inline(always)]
    fn index_eq(a: Self::Index, b: Self::Index) -> u8 {
        let mut m = 0u8;
        for l in 0..LANES {
            m |= ((a[l] == b[l]) as u8) << l;
        }
        m
    }
    #[inline(always)]
    fn index_store(a: Self::Index) -> [u64; LANES] {
        a
    }
    #[inline(always)]
    fn gather(spheres: &[ViewSphere], own: Self::Index, offset: usize) -> Self {
        let mut out = [0.0; LANES];
        for l in 0..LANES {
            out[l] = read_f64(&spheres[own[l] as usize], offset);
        }
        Portable(out)
    }
    #[inline(always)]
    fn gather_ids(spheres: &[ViewSphere], own: Self::Index) -> Self::Index {
        let mut out = [0; LANES];
        for l in 0..LANES {
            out[l] = spheres[own[l] as usize].id as u64;
        }
        out
    }
}

/// The f64 field at byte `offset` of a sphere (`ViewSphere` is `repr(C)`; the offsets come from
/// `offset_of!` on its f64 and DVec3 fields).
#[inline(always)]
fn read_f64(s: &ViewSphere, offset: usize) -> f64 {
    debug_assert!(offset.is_multiple_of(8) && offset + 8 <= std::mem::size_of::<ViewSphere>());
    // SAFETY: the offset names an f64 inside the sphere.
    unsafe {
        (s as *const ViewSphere)
            .cast::<u8>()
            .add(offset)
            .cast::<f64>()
            .read()
    }
}

#[cfg(target_arch = "x86_64")]
pub(super) use x86::{Ymm2, Zmm};

#[cfg(target_arch = "x86_64")]
mod x86 {
    use std::arch::x86_64::*;
    use std::mem::{offset_of, size_of};

    use super::{Lanes, LANES};
    use crate::render::ViewSphere;

    const SPHERE: i64 = size_of::<ViewSphere>() as i64;
    const ID: i64 = offset_of!(ViewSphere, id) as i64;

    /// One AVX-512 register.
    #[derive(Clone, Copy)]
    pub struct Zmm(__m512d);

    // SAFETY (every `unsafe` block in this impl): the CPU has AVX-512F, see the module's
    // documentation; loads, stores and gathers stay inside the arrays and spheres given.
    impl Lanes for Zmm {
        type Index = __m512i;

        #[inline(always)]
        fn splat(x: f64) -> Self {
            unsafe { Zmm(_mm512_set1_pd(x)) }
        }
        #[inline(always)]
        fn load(x: &[f64; LANES]) -> Self {
            unsafe { Zmm(_mm512_loadu_pd(x.as_ptr())) }
        }
        #[inline(always)]
        fn store(self) -> [f64; LANES] {
            let mut out = [0.0; LANES];
            unsafe { _mm512_storeu_pd(out.as_mut_ptr(), self.0) };
            out
        }
        #[inline(always)]
        fn add(self, b: Self) -> Self {
            unsafe { Zmm(_mm512_add_pd(self.0, b.0)) }
        }
        #[inline(always)]
        fn sub(self, b: Self) -> Self {
            unsafe { Zmm(_mm512_sub_pd(self.0, b.0)) }
        }
        #[inline(always)]
        fn mul(self, b: Self) -> Self {
            unsafe { Zmm(_mm512_mul_pd(self.0, b.0)) }
        }
        #[inline(always)]
        fn div(self, b: Self) -> Self {
            unsafe { Zmm(_mm512_div_pd(self.0, b.0)) }
        }
        #[inline(always)]
        fn sqrt(self) -> Self {
            unsafe { Zmm(_mm512_sqrt_pd(self.0)) }
        }
        #[inline(always)]
        fn neg(self) -> Self {
            unsafe {
                let sign = _mm512_set1_epi64(i64::MIN);
                Zmm(_mm512_castsi512_pd(_mm512_xor_epi64(
                    _mm512_castpd_si512(self.0),
                    sign,
                )))
            }
        }
        #[inline(always)]
        fn copysign(self, s: Self) -> Self {
            unsafe {
                let sign = _mm512_set1_epi64(i64::MIN);
                let (a, b) = (_mm512_castpd_si512(self.0), _mm512_castpd_si512(s.0));
                Zmm(_mm512_castsi512_pd(_mm512_or_epi64(
                    _mm512_andnot_epi64(sign, a),
                    _mm512_and_epi64(sign, b),
                )))
            }
        }
        #[inline(always)]
        fn abs(self) -> Self {
            unsafe { Zmm(_mm512_abs_pd(self.0)) }
        }
        #[inline(always)]
        fn min(self, b: Self) -> Self {
            // vminpd gives its second operand when either is NaN.
            unsafe {
                let m = _mm512_min_pd(self.0, b.0);
                let b_nan = _mm512_cmp_pd_mask::<_CMP_UNORD_Q>(b.0, b.0);
                Zmm(_mm512_mask_blend_pd(b_nan, m, self.0))
            }
        }
        #[inline(always)]
        fn max(self, b: Self) -> Self {
            unsafe {
                let m = _mm512_max_pd(self.0, b.0);
                let b_nan = _mm512_cmp_pd_mask::<_CMP_UNORD_Q>(b.0, b.0);
                Zmm(_mm512_mask_blend_pd(b_nan, m, self.0))
            }
        }
        #[inline(always)]
        fn lt(self, b: Self) -> u8 {
            unsafe { _mm512_cmp_pd_mask::<_CMP_LT_OQ>(self.0, b.0) }
        }
        #[inline(always)]
        fn le(self, b: Self) -> u8 {
            unsafe { _mm512_cmp_pd_mask::<_CMP_LE_OQ>(self.0, b.0) }
        }
        #[inline(always)]
        fn gt(self, b: Self) -> u8 {
            unsafe { _mm512_cmp_pd_mask::<_CMP_GT_OQ>(self.0, b.0) }
        }
        #[inline(always)]
        fn ge(self, b: Self) -> u8 {
            unsafe { _mm512_cmp_pd_mask::<_CMP_GE_OQ>(self.0, b.0) }
        }
        #[inline(always)]
        fn eq(self, b: Self) -> u8 {
            unsafe { _mm512_cmp_pd_mask::<_CMP_EQ_OQ>(self.0, b.0) }
        }
        #[inline(always)]
        fn blend(m: u8, a: Self, b: Self) -> Self {
            unsafe { Zmm(_mm512_mask_blend_pd(m, a.0, b.0)) }
        }
        #[inline(always)]
        fn to_i32(self, max: i32) -> [i32; LANES] {
            let mut out = [0; LANES];
            unsafe {
                // NaN converts to i32::MIN, which the max lifts to 0, as `as` does.
                let i = _mm512_cvttpd_epi32(self.0);
                let i = _mm256_min_epi32(
                    _mm256_max_epi32(i, _mm256_setzero_si256()),
                    _mm256_set1_epi32(max),
                );
                _mm256_storeu_si256(out.as_mut_ptr().cast(), i);
            }
            out
        }

        #[inline(always)]
        fn index(k: u64) -> __m512i {
            unsafe { _mm512_set1_epi64(k as i64) }
        }
        #[inline(always)]
        fn index_blend(m: u8, a: __m512i, b: __m512i) -> __m512i {
            unsafe { _mm512_mask_blend_epi64(m, a, b) }
        }
        #[inline(always)]
        fn index_eq(a: __m512i, b: __m512i) -> u8 {
            unsafe { _mm512_cmpeq_epi64_mask(a, b) }
        }
        #[inline(always)]
        fn index_store(a: __m512i) -> [u64; LANES] {
            let mut out = [0; LANES];
            unsafe { _mm512_storeu_si512(out.as_mut_ptr().cast(), a) };
            out
        }
        #[inline(always)]
        fn gather(spheres: &[ViewSphere], own: __m512i, offset: usize) -> Self {
            unsafe {
                let bytes = _mm512_add_epi64(
                    _mm512_mul_epu32(own, _mm512_set1_epi64(SPHERE)),
                    _mm512_set1_epi64(offset as i64),
                );
                Zmm(_mm512_i64gather_pd::<1>(bytes, spheres.as_ptr().cast()))
            }
        }
        #[inline(always)]
        fn gather_ids(spheres: &[ViewSphere], own: __m512i) -> __m512i {
            unsafe {
                let bytes = _mm512_add_epi64(
                    _mm512_mul_epu32(own, _mm512_set1_epi64(SPHERE)),
                    _mm512_set1_epi64(ID),
                );
                _mm512_cvtepu32_epi64(_mm512_i64gather_epi32::<1>(bytes, spheres.as_ptr().cast()))
            }
        }
    }

    /// Two AVX2 registers: lanes 0–3 and 4–7.
    #[derive(Clone, Copy)]
    pub struct Ymm2([__m256d; 2]);

    /// The 4-lane vector mask of bits 0–3 of `m`.
    #[inline(always)]
    unsafe fn unpack(m: u8) -> __m256d {
        let bits = _mm256_setr_epi64x(1, 2, 4, 8);
        let set = _mm256_and_si256(_mm256_set1_epi64x(m as i64), bits);
        _mm256_castsi256_pd(_mm256_cmpeq_epi64(set, bits))
    }

    impl Ymm2 {
        #[inline(always)]
        fn each(self, f: impl Fn(__m256d) -> __m256d) -> Ymm2 {
            Ymm2([f(self.0[0]), f(self.0[1])])
        }

        #[inline(always)]
        fn both(self, b: Ymm2, f: impl Fn(__m256d, __m256d) -> __m256d) -> Ymm2 {
            Ymm2([f(self.0[0], b.0[0]), f(self.0[1], b.0[1])])
        }

        #[inline(always)]
        fn test(self, b: Ymm2, f: impl Fn(__m256d, __m256d) -> __m256d) -> u8 {
            unsafe {
                let lo = _mm256_movemask_pd(f(self.0[0], b.0[0]));
                let hi = _mm256_movemask_pd(f(self.0[1], b.0[1]));
                (lo | hi << 4) as u8
            }
        }
    }

    // SAFETY (every `unsafe` block in this impl): the CPU has AVX2, see the module's
    // documentation; loads, stores and gathers stay inside the arrays and spheres given.
    impl Lanes for Ymm2 {
        type Index = [__m256i; 2];

        #[inline(always)]
        fn splat(x: f64) -> Self {
            unsafe { Ymm2([_mm256_set1_pd(x); 2]) }
        }
        #[inline(always)]
        fn load(x: &[f64; LANES]) -> Self {
            unsafe {
                Ymm2([
                    _mm256_loadu_pd(x.as_ptr()),
                    _mm256_loadu_pd(x.as_ptr().add(4)),
                ])
            }
        }
        #[inline(always)]
        fn store(self) -> [f64; LANES] {
            let mut out = [0.0; LANES];
            unsafe {
                _mm256_storeu_pd(out.as_mut_ptr(), self.0[0]);
                _mm256_storeu_pd(out.as_mut_ptr().add(4), self.0[1]);
            }
            out
        }
        #[inline(always)]
        fn add(self, b: Self) -> Self {
            self.both(b, |x, y| unsafe { _mm256_add_pd(x, y) })
        }
        #[inline(always)]
        fn sub(self, b: Self) -> Self {
            self.both(b, |x, y| unsafe { _mm256_sub_pd(x, y) })
        }
        #[inline(always)]
        fn mul(self, b: Self) -> Self {
            self.both(b, |x, y| unsafe { _mm256_mul_pd(x, y) })
        }
        #[inline(always)]
        fn div(self, b: Self) -> Self {
            self.both(b, |x, y| unsafe { _mm256_div_pd(x, y) })
        }
        #[inline(always)]
        fn sqrt(self) -> Self {
            self.each(|x| unsafe { _mm256_sqrt_pd(x) })
        }
        #[inline(always)]
        fn neg(self) -> Self {
            self.each(|x| unsafe { _mm256_xor_pd(x, _mm256_set1_pd(-0.0)) })
        }
        #[inline(always)]
        fn copysign(self, s: Self) -> Self {
            self.both(s, |x, y| unsafe {
                let sign = _mm256_set1_pd(-0.0);
                _mm256_or_pd(_mm256_andnot_pd(sign, x), _mm256_and_pd(sign, y))
            })
        }
        #[inline(always)]
        fn abs(self) -> Self {
            self.each(|x| unsafe { _mm256_andnot_pd(_mm256_set1_pd(-0.0), x) })
        }
        #[inline(always)]
        fn min(self, b: Self) -> Self {
            // vminpd gives its second operand when either is NaN.
            self.both(b, |x, y| unsafe {
                let y_nan = _mm256_cmp_pd::<_CMP_UNORD_Q>(y, y);
                _mm256_blendv_pd(_mm256_min_pd(x, y), x, y_nan)
            })
        }
        #[inline(always)]
        fn max(self, b: Self) -> Self {
            self.both(b, |x, y| unsafe {
                let y_nan = _mm256_cmp_pd::<_CMP_UNORD_Q>(y, y);
                _mm256_blendv_pd(_mm256_max_pd(x, y), x, y_nan)
            })
        }
        #[inline(always)]
        fn lt(self, b: Self) -> u8 {
            self.test(b, |x, y| unsafe { _mm256_cmp_pd::<_CMP_LT_OQ>(x, y) })
        }
        #[inline(always)]
        fn le(self, b: Self) -> u8 {
            self.test(b, |x, y| unsafe { _mm256_cmp_pd::<_CMP_LE_OQ>(x, y) })
        }
        #[inline(always)]
        fn gt(self, b: Self) -> u8 {
            self.test(b, |x, y| unsafe { _mm256_cmp_pd::<_CMP_GT_OQ>(x, y) })
        }
        #[inline(always)]
        fn ge(self, b: Self) -> u8 {
            self.test(b, |x, y| unsafe { _mm256_cmp_pd::<_CMP_GE_OQ>(x, y) })
        }
        #[inline(always)]
        fn eq(self, b: Self) -> u8 {
            self.test(b, |x, y| unsafe { _mm256_cmp_pd::<_CMP_EQ_OQ>(x, y) })
        }
        #[inline(always)]
        fn blend(m: u8, a: Self, b: Self) -> Self {
            unsafe {
                Ymm2([
                    _mm256_blendv_pd(a.0[0], b.0[0], unpack(m)),
                    _mm256_blendv_pd(a.0[1], b.0[1], unpack(m >> 4)),
                ])
            }
        }
        #[inline(always)]
        fn to_i32(self, max: i32) -> [i32; LANES] {
            let mut out = [0; LANES];
            unsafe {
                for h in 0..2 {
                    // NaN converts to i32::MIN, which the max lifts to 0, as `as` does.
                    let i = _mm256_cvttpd_epi32(self.0[h]);
                    let i =
                        _mm_min_epi32(_mm_max_epi32(i, _mm_setzero_si128()), _mm_set1_epi32(max));
                    _mm_storeu_si128(out.as_mut_ptr().add(4 * h).cast(), i);
                }
            }
            out
        }

        #[inline(always)]
        fn index(k: u64) -> [__m256i; 2] {
            unsafe { [_mm256_set1_epi64x(k as i64); 2] }
        }
        #[inline(always)]
        fn index_blend(m: u8, a: [__m256i; 2], b: [__m256i; 2]) -> [__m256i; 2] {
            unsafe {
                let pick = |h: usize, m: u8| {
                    let (a, b) = (_mm256_castsi256_pd(a[h]), _mm256_castsi256_pd(b[h]));
                    _mm256_castpd_si256(_mm256_blendv_pd(a, b, unpack(m)))
                };
                [pick(0, m), pick(1, m >> 4)]
            }
        }
        #[inline(always)]
        fn index_eq(a: [__m256i; 2], b: [__m256i; 2]) -> u8 {
            unsafe {
                let half = |h: usize| {
                    _mm256_movemask_pd(_mm256_castsi256_pd(_mm256_cmpeq_epi64(a[h], b[h])))
                };
                (half(0) | half(1) << 4) as u8
            }
        }
        #[inline(always)]
        fn index_store(a: [__m256i; 2]) -> [u64; LANES] {
            let mut out = [0; LANES];
            unsafe {
                _mm256_storeu_si256(out.as_mut_ptr().cast(), a[0]);
                _mm256_storeu_si256(out.as_mut_ptr().add(4).cast(), a[1]);
            }
            out
        }
        #[inline(always)]
        fn gather(spheres: &[ViewSphere], own: [__m256i; 2], offset: usize) -> Self {
            unsafe {
                let half = |h: usize| {
                    let bytes = _mm256_add_epi64(
                        _mm256_mul_epu32(own[h], _mm256_set1_epi64x(SPHERE)),
                        _mm256_set1_epi64x(offset as i64),
                    );
                    _mm256_i64gather_pd::<1>(spheres.as_ptr().cast(), bytes)
                };
                Ymm2([half(0), half(1)])
            }
        }
        #[inline(always)]
        fn gather_ids(spheres: &[ViewSphere], own: [__m256i; 2]) -> [__m256i; 2] {
            unsafe {
                let half = |h: usize| {
                    let bytes = _mm256_add_epi64(
                        _mm256_mul_epu32(own[h], _mm256_set1_epi64x(SPHERE)),
                        _mm256_set1_epi64x(ID),
                    );
                    _mm256_cvtepu32_epi64(_mm256_i64gather_epi32::<1>(
                        spheres.as_ptr().cast(),
                        bytes,
                    ))
                };
                [half(0), half(1)]
            }
        }
    }
}
