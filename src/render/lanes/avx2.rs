//! Two AVX2 registers of four f64 lanes each (`Ymm2`), and the token that proves AVX2.
//! Everything the instruction set needs is in this file and its line in `simd.rs`.

use std::arch::x86_64::*;

use super::contract::sealed::Sealed;
use super::contract::{InBounds, Lanes, Token, LANES};

/// Proof that this CPU runs AVX2 and what this file's intrinsics need with it (AVX, SSE4.1):
/// made only by [`Token::new_unchecked`], which the detection calls.
#[derive(Debug, Clone, Copy)]
pub struct Avx2(());

impl Sealed for Avx2 {}

// SAFETY: `new_unchecked` makes the only Avx2 there is.
unsafe impl Token for Avx2 {
    unsafe fn new_unchecked() -> Avx2 {
        Avx2(())
    }
}

/// Two AVX2 registers (lanes 0–3 and 4–7), with the proof that the CPU runs AVX2.
#[derive(Clone, Copy)]
pub struct Ymm2([__m256d; 2], Avx2);

/// Eight 64-bit indices in two AVX2 registers, with the same proof.
#[derive(Clone, Copy)]
pub struct Ymm2Index([__m256i; 2], Avx2);

impl Avx2 {
    /// The 4-lane vector mask of bits 0–3 of `m`.
    #[inline(always)]
    fn unpack(self, m: u8) -> __m256d {
        // SAFETY: `self` proves AVX2.
        unsafe {
            let bits = _mm256_setr_epi64x(1, 2, 4, 8);
            let set = _mm256_and_si256(_mm256_set1_epi64x(m as i64), bits);
            _mm256_castsi256_pd(_mm256_cmpeq_epi64(set, bits))
        }
    }
}

impl Ymm2 {
    #[inline(always)]
    fn each(self, f: impl Fn(__m256d) -> __m256d) -> Ymm2 {
        Ymm2([f(self.0[0]), f(self.0[1])], self.1)
    }

    #[inline(always)]
    fn both(self, b: Ymm2, f: impl Fn(__m256d, __m256d) -> __m256d) -> Ymm2 {
        Ymm2([f(self.0[0], b.0[0]), f(self.0[1], b.0[1])], self.1)
    }

    #[inline(always)]
    fn test(self, b: Ymm2, f: impl Fn(__m256d, __m256d) -> __m256d) -> u8 {
        // SAFETY: `self` proves AVX2.
        unsafe {
            let lo = _mm256_movemask_pd(f(self.0[0], b.0[0]));
            let hi = _mm256_movemask_pd(f(self.0[1], b.0[1]));
            (lo | hi << 4) as u8
        }
    }
}

/// Methods of [`Lanes`] that are one helper above on `self` (and `b`), its closure's intrinsics
/// in an unsafe block: `name(b) -> R = helper(|x, y| intrinsics)`.
macro_rules! lanewise {
    ($($name:ident($($b:ident)?) -> $ret:ty = $via:ident(|$($v:ident),+| $op:expr);)*) => {$(
        #[inline(always)]
        fn $name(self $(, $b: Self)?) -> $ret {
            // SAFETY: `self` (a `Ymm2`) proves AVX2, and the closure is called only by
            // `each`, `both` or `test` on it.
            self.$via($($b,)? |$($v),+| unsafe { $op })
        }
    )*};
}

impl Sealed for Ymm2 {}

impl Lanes for Ymm2 {
    type Token = Avx2;
    type Index = Ymm2Index;

    #[inline(always)]
    fn token(self) -> Avx2 {
        self.1
    }
    #[inline(always)]
    fn splat(t: Avx2, x: f64) -> Self {
        // SAFETY: `t` proves AVX2.
        Ymm2([unsafe { _mm256_set1_pd(x) }; 2], t)
    }
    #[inline(always)]
    fn load(t: Avx2, x: &[f64; LANES]) -> Self {
        // SAFETY: `t` proves AVX2; `x` holds the eight f64 read.
        let v = unsafe {
            [
                _mm256_loadu_pd(x.as_ptr()),
                _mm256_loadu_pd(x.as_ptr().add(4)),
            ]
        };
        Ymm2(v, t)
    }
    #[inline(always)]
    fn store(self) -> [f64; LANES] {
        let mut out = [0.0; LANES];
        // SAFETY: `self` proves AVX2; `out` holds the eight f64 written.
        unsafe {
            _mm256_storeu_pd(out.as_mut_ptr(), self.0[0]);
            _mm256_storeu_pd(out.as_mut_ptr().add(4), self.0[1]);
        }
        out
    }
    lanewise! {
        add(b) -> Self = both(|x, y| _mm256_add_pd(x, y));
        sub(b) -> Self = both(|x, y| _mm256_sub_pd(x, y));
        mul(b) -> Self = both(|x, y| _mm256_mul_pd(x, y));
        div(b) -> Self = both(|x, y| _mm256_div_pd(x, y));
        sqrt() -> Self = each(|x| _mm256_sqrt_pd(x));
        neg() -> Self = each(|x| _mm256_xor_pd(x, _mm256_set1_pd(-0.0)));
        copysign(b) -> Self = both(|x, y| {
            let sign = _mm256_set1_pd(-0.0);
            _mm256_or_pd(_mm256_andnot_pd(sign, x), _mm256_and_pd(sign, y))
        });
        abs() -> Self = each(|x| _mm256_andnot_pd(_mm256_set1_pd(-0.0), x));
        // vminpd and vmaxpd give their second operand when either is NaN.
        min(b) -> Self = both(|x, y| {
            let y_nan = _mm256_cmp_pd::<_CMP_UNORD_Q>(y, y);
            _mm256_blendv_pd(_mm256_min_pd(x, y), x, y_nan)
        });
        max(b) -> Self = both(|x, y| {
            let y_nan = _mm256_cmp_pd::<_CMP_UNORD_Q>(y, y);
            _mm256_blendv_pd(_mm256_max_pd(x, y), x, y_nan)
        });
        lt(b) -> u8 = test(|x, y| _mm256_cmp_pd::<_CMP_LT_OQ>(x, y));
        le(b) -> u8 = test(|x, y| _mm256_cmp_pd::<_CMP_LE_OQ>(x, y));
        gt(b) -> u8 = test(|x, y| _mm256_cmp_pd::<_CMP_GT_OQ>(x, y));
        ge(b) -> u8 = test(|x, y| _mm256_cmp_pd::<_CMP_GE_OQ>(x, y));
        eq(b) -> u8 = test(|x, y| _mm256_cmp_pd::<_CMP_EQ_OQ>(x, y));
    }
    #[inline(always)]
    fn blend(m: u8, a: Self, b: Self) -> Self {
        let t = a.1;
        // SAFETY: `a` proves AVX2.
        let v = unsafe {
            [
                _mm256_blendv_pd(a.0[0], b.0[0], t.unpack(m)),
                _mm256_blendv_pd(a.0[1], b.0[1], t.unpack(m >> 4)),
            ]
        };
        Ymm2(v, t)
    }
    #[inline(always)]
    fn to_i32(self, max: i32) -> [i32; LANES] {
        let mut out = [0; LANES];
        // SAFETY: `self` proves AVX2; `out` holds the eight i32 written, four at a time.
        unsafe {
            for h in 0..2 {
                // NaN converts to i32::MIN, which the max lifts to 0, as `as` does.
                let i = _mm256_cvttpd_epi32(self.0[h]);
                let i = _mm_min_epi32(_mm_max_epi32(i, _mm_setzero_si128()), _mm_set1_epi32(max));
                _mm_storeu_si128(out.as_mut_ptr().add(4 * h).cast(), i);
            }
        }
        out
    }

    #[inline(always)]
    fn index(t: Avx2, k: u64) -> Ymm2Index {
        // SAFETY: `t` proves AVX2.
        Ymm2Index([unsafe { _mm256_set1_epi64x(k as i64) }; 2], t)
    }
    #[inline(always)]
    fn index_blend(m: u8, a: Ymm2Index, b: Ymm2Index) -> Ymm2Index {
        let t = a.1;
        let pick = |h: usize, m: u8| {
            // SAFETY: `a` proves AVX2.
            unsafe {
                let (a, b) = (_mm256_castsi256_pd(a.0[h]), _mm256_castsi256_pd(b.0[h]));
                _mm256_castpd_si256(_mm256_blendv_pd(a, b, t.unpack(m)))
            }
        };
        Ymm2Index([pick(0, m), pick(1, m >> 4)], t)
    }
    #[inline(always)]
    fn index_eq(a: Ymm2Index, b: Ymm2Index) -> u8 {
        let half = |h: usize| {
            // SAFETY: `a` proves AVX2.
            unsafe { _mm256_movemask_pd(_mm256_castsi256_pd(_mm256_cmpeq_epi64(a.0[h], b.0[h]))) }
        };
        (half(0) | half(1) << 4) as u8
    }
    #[inline(always)]
    fn index_store(a: Ymm2Index) -> [u64; LANES] {
        let mut out = [0; LANES];
        // SAFETY: `a` proves AVX2; `out` holds the eight u64 written, four at a time.
        unsafe {
            _mm256_storeu_si256(out.as_mut_ptr().cast(), a.0[0]);
            _mm256_storeu_si256(out.as_mut_ptr().add(4).cast(), a.0[1]);
        }
        out
    }
    #[inline(always)]
    fn gather(field: &[f64], own: InBounds<Ymm2Index>) -> Self {
        let own = own.within(field);
        let half = |h: usize| {
            // SAFETY: `own` proves AVX2, and every lane of it indexes `field` (checked by
            // `InBounds`, the length by `within`); the scale 8 makes an index an f64's.
            unsafe { _mm256_i64gather_pd::<8>(field.as_ptr(), own.0[h]) }
        };
        Ymm2([half(0), half(1)], own.1)
    }
    #[inline(always)]
    fn columns(t: Avx2, rows: &[[f32; 4]; LANES]) -> [Ymm2; 4] {
        let p = rows.as_ptr().cast::<f32>();
        // SAFETY: `t` proves AVX2; `rows` holds the 32 f32 read, four from each of `p`, `p` + 4,
        // … `p` + 28. Rows 0–3 and 4–7 are each a 4 × 4 transpose: pairs of rows interleaved,
        // then their halves joined, then widened.
        unsafe {
            let r = [
                _mm_loadu_ps(p),
                _mm_loadu_ps(p.add(4)),
                _mm_loadu_ps(p.add(8)),
                _mm_loadu_ps(p.add(12)),
                _mm_loadu_ps(p.add(16)),
                _mm_loadu_ps(p.add(20)),
                _mm_loadu_ps(p.add(24)),
                _mm_loadu_ps(p.add(28)),
            ];
            let (lo_a, lo_b) = (_mm_unpacklo_ps(r[0], r[1]), _mm_unpacklo_ps(r[2], r[3]));
            let (hi_a, hi_b) = (_mm_unpackhi_ps(r[0], r[1]), _mm_unpackhi_ps(r[2], r[3]));
            let (lo_c, lo_d) = (_mm_unpacklo_ps(r[4], r[5]), _mm_unpacklo_ps(r[6], r[7]));
            let (hi_c, hi_d) = (_mm_unpackhi_ps(r[4], r[5]), _mm_unpackhi_ps(r[6], r[7]));
            let x = [_mm_movelh_ps(lo_a, lo_b), _mm_movelh_ps(lo_c, lo_d)];
            let y = [_mm_movehl_ps(lo_b, lo_a), _mm_movehl_ps(lo_d, lo_c)];
            let z = [_mm_movelh_ps(hi_a, hi_b), _mm_movelh_ps(hi_c, hi_d)];
            let w = [_mm_movehl_ps(hi_b, hi_a), _mm_movehl_ps(hi_d, hi_c)];
            [
                Ymm2([_mm256_cvtps_pd(x[0]), _mm256_cvtps_pd(x[1])], t),
                Ymm2([_mm256_cvtps_pd(y[0]), _mm256_cvtps_pd(y[1])], t),
                Ymm2([_mm256_cvtps_pd(z[0]), _mm256_cvtps_pd(z[1])], t),
                Ymm2([_mm256_cvtps_pd(w[0]), _mm256_cvtps_pd(w[1])], t),
            ]
        }
    }
    #[inline(always)]
    fn gather_index(field: &[u64], own: InBounds<Ymm2Index>) -> Ymm2Index {
        let own = own.within(field);
        let half = |h: usize| {
            // SAFETY: as `gather`: AVX2 by `own`, indices checked, the scale a u64's.
            unsafe { _mm256_i64gather_epi64::<8>(field.as_ptr().cast(), own.0[h]) }
        };
        Ymm2Index([half(0), half(1)], own.1)
    }
}
