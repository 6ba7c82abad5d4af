//! One AVX-512 register of eight f64 lanes (`Zmm`), and the token that proves AVX-512F.
//! Everything the instruction set needs is in this file and its line in `simd.rs`.

use std::arch::x86_64::*;

use super::contract::sealed::Sealed;
use super::contract::{InBounds, Lanes, Token, LANES};

/// Proof that this CPU runs AVX-512F and what `avx512f` implies to the compiler (AVX2, FMA,
/// F16C: a virtual machine may hide one): made only by [`Token::new_unchecked`], which the
/// detection calls.
#[derive(Debug, Clone, Copy)]
pub struct Avx512(());

impl Sealed for Avx512 {}

// SAFETY: `new_unchecked` makes the only Avx512 there is.
unsafe impl Token for Avx512 {
    unsafe fn new_unchecked() -> Avx512 {
        Avx512(())
    }
}

/// One AVX-512 register, with the proof that the CPU runs AVX-512F.
#[derive(Clone, Copy)]
pub struct Zmm(__m512d, Avx512);

/// Eight 64-bit indices in one AVX-512 register, with the same proof.
#[derive(Clone, Copy)]
pub struct ZmmIndex(__m512i, Avx512);

impl Zmm {
    /// `v` as a value of this form, kept with the proof.
    #[inline(always)]
    fn with(self, v: __m512d) -> Zmm {
        Zmm(v, self.1)
    }
}

/// Methods of [`Lanes`] that are one expression of intrinsics on `self` (named `a`, the other
/// operand `b`): a value of this form (`Self:`) or a mask (`u8:`).
macro_rules! lanewise {
    (Self: $($name:ident($a:ident $(, $b:ident)?) = $op:expr;)*) => {$(
        #[inline(always)]
        fn $name(self $(, $b: Self)?) -> Self {
            let $a = self;
            // SAFETY: `self` proves AVX-512F.
            self.with(unsafe { $op })
        }
    )*};
    (u8: $($name:ident($a:ident, $b:ident) = $op:expr;)*) => {$(
        #[inline(always)]
        fn $name(self, $b: Self) -> u8 {
            let $a = self;
            // SAFETY: `self` proves AVX-512F.
            unsafe { $op }
        }
    )*};
}

impl Sealed for Zmm {}

impl Lanes for Zmm {
    type Token = Avx512;
    type Index = ZmmIndex;

    #[inline(always)]
    fn token(self) -> Avx512 {
        self.1
    }
    #[inline(always)]
    fn splat(t: Avx512, x: f64) -> Self {
        // SAFETY: `t` proves AVX-512F.
        Zmm(unsafe { _mm512_set1_pd(x) }, t)
    }
    #[inline(always)]
    fn load(t: Avx512, x: &[f64; LANES]) -> Self {
        // SAFETY: `t` proves AVX-512F; `x` holds the eight f64 read.
        Zmm(unsafe { _mm512_loadu_pd(x.as_ptr()) }, t)
    }
    #[inline(always)]
    fn store(self) -> [f64; LANES] {
        let mut out = [0.0; LANES];
        // SAFETY: `self` proves AVX-512F; `out` holds the eight f64 written.
        unsafe { _mm512_storeu_pd(out.as_mut_ptr(), self.0) };
        out
    }
    lanewise! {
        Self: add(a, b) = _mm512_add_pd(a.0, b.0);
        sub(a, b) = _mm512_sub_pd(a.0, b.0);
        mul(a, b) = _mm512_mul_pd(a.0, b.0);
        div(a, b) = _mm512_div_pd(a.0, b.0);
        sqrt(a) = _mm512_sqrt_pd(a.0);
        neg(a) = {
            let sign = _mm512_set1_epi64(i64::MIN);
            _mm512_castsi512_pd(_mm512_xor_epi64(_mm512_castpd_si512(a.0), sign))
        };
        copysign(a, s) = {
            let sign = _mm512_set1_epi64(i64::MIN);
            let (a, b) = (_mm512_castpd_si512(a.0), _mm512_castpd_si512(s.0));
            _mm512_castsi512_pd(_mm512_or_epi64(
                _mm512_andnot_epi64(sign, a),
                _mm512_and_epi64(sign, b),
            ))
        };
        abs(a) = _mm512_abs_pd(a.0);
        // vminpd and vmaxpd give their second operand when either is NaN.
        min(a, b) = {
            let m = _mm512_min_pd(a.0, b.0);
            let b_nan = _mm512_cmp_pd_mask::<_CMP_UNORD_Q>(b.0, b.0);
            _mm512_mask_blend_pd(b_nan, m, a.0)
        };
        max(a, b) = {
            let m = _mm512_max_pd(a.0, b.0);
            let b_nan = _mm512_cmp_pd_mask::<_CMP_UNORD_Q>(b.0, b.0);
            _mm512_mask_blend_pd(b_nan, m, a.0)
        };
    }
    lanewise! {
        u8: lt(a, b) = _mm512_cmp_pd_mask::<_CMP_LT_OQ>(a.0, b.0);
        le(a, b) = _mm512_cmp_pd_mask::<_CMP_LE_OQ>(a.0, b.0);
        gt(a, b) = _mm512_cmp_pd_mask::<_CMP_GT_OQ>(a.0, b.0);
        ge(a, b) = _mm512_cmp_pd_mask::<_CMP_GE_OQ>(a.0, b.0);
        eq(a, b) = _mm512_cmp_pd_mask::<_CMP_EQ_OQ>(a.0, b.0);
    }
    #[inline(always)]
    fn blend(m: u8, a: Self, b: Self) -> Self {
        // SAFETY: `a` proves AVX-512F.
        a.with(unsafe { _mm512_mask_blend_pd(m, a.0, b.0) })
    }
    #[inline(always)]
    fn to_i32(self, max: i32) -> [i32; LANES] {
        let mut out = [0; LANES];
        // SAFETY: `self` proves AVX-512F (and with it AVX2); `out` holds the eight i32
        // written.
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
    fn index(t: Avx512, k: u64) -> ZmmIndex {
        // SAFETY: `t` proves AVX-512F.
        ZmmIndex(unsafe { _mm512_set1_epi64(k as i64) }, t)
    }
    #[inline(always)]
    fn index_blend(m: u8, a: ZmmIndex, b: ZmmIndex) -> ZmmIndex {
        // SAFETY: `a` proves AVX-512F.
        ZmmIndex(unsafe { _mm512_mask_blend_epi64(m, a.0, b.0) }, a.1)
    }
    #[inline(always)]
    fn index_eq(a: ZmmIndex, b: ZmmIndex) -> u8 {
        // SAFETY: `a` proves AVX-512F.
        unsafe { _mm512_cmpeq_epi64_mask(a.0, b.0) }
    }
    #[inline(always)]
    fn index_store(a: ZmmIndex) -> [u64; LANES] {
        let mut out = [0; LANES];
        // SAFETY: `a` proves AVX-512F; `out` holds the eight u64 written.
        unsafe { _mm512_storeu_si512(out.as_mut_ptr().cast(), a.0) };
        out
    }
    #[inline(always)]
    fn gather(field: &[f64], own: InBounds<ZmmIndex>) -> Self {
        let own = own.within(field);
        // SAFETY: `own` proves AVX-512F, and every lane of it indexes `field` (checked by
        // `InBounds`, the length by `within`); the scale 8 makes an index an f64's.
        Zmm(
            unsafe { _mm512_i64gather_pd::<8>(own.0, field.as_ptr()) },
            own.1,
        )
    }
    #[inline(always)]
    fn columns(t: Avx512, rows: &[[f32; 4]; LANES]) -> [Zmm; 4] {
        let p = rows.as_ptr().cast::<f32>();
        // SAFETY: `t` proves AVX-512F; `rows` holds the 32 f32 read, 16 from `p` and 16 on.
        // Row l's kth number is f32 4l + k of the 32 (from 16 on, in `b`): each column's eight
        // picked into the low half, then widened.
        unsafe {
            let (a, b) = (_mm512_loadu_ps(p), _mm512_loadu_ps(p.add(16)));
            let x = _mm512_setr_epi32(0, 4, 8, 12, 16, 20, 24, 28, 0, 0, 0, 0, 0, 0, 0, 0);
            let one = _mm512_set1_epi32(1);
            let y = _mm512_add_epi32(x, one);
            let z = _mm512_add_epi32(y, one);
            let r = _mm512_add_epi32(z, one);
            let x = _mm512_castps512_ps256(_mm512_permutex2var_ps(a, x, b));
            let y = _mm512_castps512_ps256(_mm512_permutex2var_ps(a, y, b));
            let z = _mm512_castps512_ps256(_mm512_permutex2var_ps(a, z, b));
            let r = _mm512_castps512_ps256(_mm512_permutex2var_ps(a, r, b));
            [
                Zmm(_mm512_cvtps_pd(x), t),
                Zmm(_mm512_cvtps_pd(y), t),
                Zmm(_mm512_cvtps_pd(z), t),
                Zmm(_mm512_cvtps_pd(r), t),
            ]
        }
    }
    #[inline(always)]
    fn gather_index(field: &[u64], own: InBounds<ZmmIndex>) -> ZmmIndex {
        let own = own.within(field);
        // SAFETY: as `gather`: AVX-512F by `own`, indices checked, the scale a u64's.
        let v = unsafe { _mm512_i64gather_epi64::<8>(own.0, field.as_ptr().cast()) };
        ZmmIndex(v, own.1)
    }
}
