//! Eight f64 lanes and 8-bit lane masks (lane l is bit l), in three forms: one AVX-512
//! register, two AVX2 registers, and plain arrays for every other target (the compiler
//! vectorises them for SSE2). The packet code (`kernels.rs`, `drivers.rs`, `shadows/`, `srgb.rs`)
//! is written once against [`Lanes`]. A leaf: it imports nothing of the renderer.
//!
//! Every operation is the IEEE operation Rust's scalar code does, correctly rounded at any width:
//! no fused multiply-add, no approximate reciprocal or square root. Comparisons are ordered
//! (false for NaN), as Rust's; the code negates a mask where the scalar code negates a
//! comparison.
//!
//! # Safety, by construction
//!
//! The x86 forms run instructions that not every x86-64 CPU has. Each holds a token (`Avx2`,
//! `Avx512`) that only feature detection makes (`Avx2::detect`), and a value of a form can be
//! made only from its token (`Lanes::splat`, `load`, `index`) or from another value of it, so
//! holding a `Zmm` proves that the CPU runs AVX-512F, and a `Ymm2` AVX2. That is the whole
//! contract of the trait's methods: safe to call wherever a value of the type exists. Each
//! `unsafe` block inside them says which value proves the feature there, and what else it needs
//! (a load's length, a gather's checked indices).
//!
//! Speed, not soundness, asks one more thing: the methods call intrinsics without
//! `#[target_feature]`, so they must be inlined into the row functions compiled for AVX-512F or
//! AVX2 (`RowJob::row_avx512` and the like). A closure between the two (`array::map`, a
//! callback) may be left out of line and compiled without the instruction set, which turns
//! every intrinsic in it into a call: no closure in the packet code calls one, and `.ci/run`
//! checks that the row functions call no intrinsic out of line.

// The portable lane loops index their arrays by lane, as the compiler vectorises them best.
#![allow(clippy::needless_range_loop)]

/// Rays per packet: a whole AVX-512 register, two AVX2 ones or four SSE2 ones of f64. Divides
/// the tile side, so a packet never straddles two tiles.
pub(super) const LANES: usize = 8;

/// An instruction set this CPU was found to run, with its proof: the argument of the renderer's
/// dispatch (`RowJob::row`). Adding one is an arm here and a file of `Lanes` (ARCHITECTURE.md).
#[derive(Debug, Clone, Copy)]
pub(super) enum Isa {
    /// Plain arrays: every CPU.
    Portable,
    #[cfg(target_arch = "x86_64")]
    Avx2(Avx2),
    #[cfg(target_arch = "x86_64")]
    Avx512(Avx512),
}

/// Eight lanes of f64 and a matching set of eight 64-bit sphere indices.
///
/// Every method is safe: a value of `Self` (or of `Self::Index`) exists only where the CPU runs
/// the instructions its methods use, because the only ways to make one from nothing take a
/// `Self::Token`, which only feature detection makes (see the module's documentation).
pub(super) trait Lanes: Copy {
    /// The proof that the CPU runs this form's instructions.
    type Token: Copy;
    type Index: Copy;

    fn token(self) -> Self::Token;
    fn splat(t: Self::Token, x: f64) -> Self;
    fn load(t: Self::Token, x: &[f64; LANES]) -> Self;
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

    fn index(t: Self::Token, k: u64) -> Self::Index;
    fn index_blend(m: u8, a: Self::Index, b: Self::Index) -> Self::Index;
    fn index_eq(a: Self::Index, b: Self::Index) -> u8;
    fn index_store(a: Self::Index) -> [u64; LANES];
    /// `field[own[l]]` in lane l.
    fn gather(field: &[f64], own: InBounds<Self::Index>) -> Self;
    /// `field[own[l]]` in lane l.
    fn gather_index(field: &[u64], own: InBounds<Self::Index>) -> Self::Index;
}

/// (a·b for x and y) + z: glam's dot product order.
#[inline(always)]
pub(super) fn dot<V: Lanes>(a: &[V; 3], b: &[V; 3]) -> V {
    a[0].mul(b[0]).add(a[1].mul(b[1])).add(a[2].mul(b[2]))
}

/// `v` in every lane, per coordinate.
#[inline(always)]
pub(super) fn splat3<V: Lanes>(tok: V::Token, v: glam::DVec3) -> [V; 3] {
    [V::splat(tok, v.x), V::splat(tok, v.y), V::splat(tok, v.z)]
}

/// Lane indices that are each below `len`, checked when made: a gather with them stays inside
/// any slice of at least `len` elements.
#[derive(Clone, Copy)]
pub(super) struct InBounds<I> {
    own: I,
    len: usize,
}

impl<I: Copy> InBounds<I> {
    /// `own` (whose lanes are `lanes`), if every lane is below `len`.
    #[inline(always)]
    pub(super) fn new(own: I, lanes: &[u64; LANES], len: usize) -> Option<InBounds<I>> {
        lanes
            .iter()
            .all(|&k| k < len as u64)
            .then_some(InBounds { own, len })
    }

    /// The indices, for a gather from `field`, which must hold `len` elements (a panic
    /// otherwise: the check that makes the gather sound).
    #[inline(always)]
    fn within<T>(self, field: &[T]) -> I {
        assert!(field.len() >= self.len, "a gather from a shorter slice");
        self.own
    }
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
    /// Plain arrays run everywhere: nothing to prove.
    type Token = ();
    type Index = [u64; LANES];

    #[inline(always)]
    fn token(self) {}
    #[inline(always)]
    fn splat((): (), x: f64) -> Self {
        Portable([x; LANES])
    }
    #[inline(always)]
    fn load((): (), x: &[f64; LANES]) -> Self {
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
    fn index((): (), k: u64) -> Self::Index {
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
    fn gather(field: &[f64], own: InBounds<Self::Index>) -> Self {
        let own = own.within(field);
        let mut out = [0.0; LANES];
        for l in 0..LANES {
            out[l] = field[own[l] as usize];
        }
        Portable(out)
    }
    #[inline(always)]
    fn gather_index(field: &[u64], own: InBounds<Self::Index>) -> Self::Index {
        let own = own.within(field);
        let mut out = [0; LANES];
        for l in 0..LANES {
            out[l] = field[own[l] as usize];
        }
        out
    }
}

#[cfg(target_arch = "x86_64")]
pub(super) use x86::{Avx2, Avx512, Ymm2, Zmm};

#[cfg(target_arch = "x86_64")]
mod x86 {
    use std::arch::x86_64::*;

    // From the crate root: the file-level import check (tests/it/architecture.rs) reads a
    // `super::` as the file's parent, not this inline module's.
    use crate::render::lanes::{InBounds, Lanes, LANES};

    /// Proof that this CPU runs AVX2: made only by [`Avx2::detect`].
    #[derive(Debug, Clone, Copy)]
    pub struct Avx2(());

    impl Avx2 {
        pub fn detect() -> Option<Avx2> {
            std::arch::is_x86_feature_detected!("avx2").then_some(Avx2(()))
        }
    }

    /// Proof that this CPU runs AVX-512F: made only by [`Avx512::detect`].
    #[derive(Debug, Clone, Copy)]
    pub struct Avx512(());

    impl Avx512 {
        pub fn detect() -> Option<Avx512> {
            std::arch::is_x86_feature_detected!("avx512f").then_some(Avx512(()))
        }
    }

    /// One AVX-512 register, with the proof that the CPU runs AVX-512F.
    #[derive(Clone, Copy)]
    pub struct Zmm(__m512d, Avx512);

    /// Eight 64-bit indices in one AVX-512 register, with the same proof.
    #[derive(Clone, Copy)]
    pub struct ZmmIndex(__m512i, Avx512);

    impl Zmm {
        /// `f` of the register, kept with the proof.
        #[inline(always)]
        fn with(self, v: __m512d) -> Zmm {
            Zmm(v, self.1)
        }
    }

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
        #[inline(always)]
        fn add(self, b: Self) -> Self {
            // SAFETY: `self` proves AVX-512F.
            self.with(unsafe { _mm512_add_pd(self.0, b.0) })
        }
        #[inline(always)]
        fn sub(self, b: Self) -> Self {
            // SAFETY: `self` proves AVX-512F.
            self.with(unsafe { _mm512_sub_pd(self.0, b.0) })
        }
        #[inline(always)]
        fn mul(self, b: Self) -> Self {
            // SAFETY: `self` proves AVX-512F.
            self.with(unsafe { _mm512_mul_pd(self.0, b.0) })
        }
        #[inline(always)]
        fn div(self, b: Self) -> Self {
            // SAFETY: `self` proves AVX-512F.
            self.with(unsafe { _mm512_div_pd(self.0, b.0) })
        }
        #[inline(always)]
        fn sqrt(self) -> Self {
            // SAFETY: `self` proves AVX-512F.
            self.with(unsafe { _mm512_sqrt_pd(self.0) })
        }
        #[inline(always)]
        fn neg(self) -> Self {
            // SAFETY: `self` proves AVX-512F.
            self.with(unsafe {
                let sign = _mm512_set1_epi64(i64::MIN);
                _mm512_castsi512_pd(_mm512_xor_epi64(_mm512_castpd_si512(self.0), sign))
            })
        }
        #[inline(always)]
        fn copysign(self, s: Self) -> Self {
            // SAFETY: `self` proves AVX-512F.
            self.with(unsafe {
                let sign = _mm512_set1_epi64(i64::MIN);
                let (a, b) = (_mm512_castpd_si512(self.0), _mm512_castpd_si512(s.0));
                _mm512_castsi512_pd(_mm512_or_epi64(
                    _mm512_andnot_epi64(sign, a),
                    _mm512_and_epi64(sign, b),
                ))
            })
        }
        #[inline(always)]
        fn abs(self) -> Self {
            // SAFETY: `self` proves AVX-512F.
            self.with(unsafe { _mm512_abs_pd(self.0) })
        }
        #[inline(always)]
        fn min(self, b: Self) -> Self {
            // vminpd gives its second operand when either is NaN.
            // SAFETY: `self` proves AVX-512F.
            self.with(unsafe {
                let m = _mm512_min_pd(self.0, b.0);
                let b_nan = _mm512_cmp_pd_mask::<_CMP_UNORD_Q>(b.0, b.0);
                _mm512_mask_blend_pd(b_nan, m, self.0)
            })
        }
        #[inline(always)]
        fn max(self, b: Self) -> Self {
            // SAFETY: `self` proves AVX-512F.
            self.with(unsafe {
                let m = _mm512_max_pd(self.0, b.0);
                let b_nan = _mm512_cmp_pd_mask::<_CMP_UNORD_Q>(b.0, b.0);
                _mm512_mask_blend_pd(b_nan, m, self.0)
            })
        }
        #[inline(always)]
        fn lt(self, b: Self) -> u8 {
            // SAFETY: `self` proves AVX-512F.
            unsafe { _mm512_cmp_pd_mask::<_CMP_LT_OQ>(self.0, b.0) }
        }
        #[inline(always)]
        fn le(self, b: Self) -> u8 {
            // SAFETY: `self` proves AVX-512F.
            unsafe { _mm512_cmp_pd_mask::<_CMP_LE_OQ>(self.0, b.0) }
        }
        #[inline(always)]
        fn gt(self, b: Self) -> u8 {
            // SAFETY: `self` proves AVX-512F.
            unsafe { _mm512_cmp_pd_mask::<_CMP_GT_OQ>(self.0, b.0) }
        }
        #[inline(always)]
        fn ge(self, b: Self) -> u8 {
            // SAFETY: `self` proves AVX-512F.
            unsafe { _mm512_cmp_pd_mask::<_CMP_GE_OQ>(self.0, b.0) }
        }
        #[inline(always)]
        fn eq(self, b: Self) -> u8 {
            // SAFETY: `self` proves AVX-512F.
            unsafe { _mm512_cmp_pd_mask::<_CMP_EQ_OQ>(self.0, b.0) }
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
        fn gather_index(field: &[u64], own: InBounds<ZmmIndex>) -> ZmmIndex {
            let own = own.within(field);
            // SAFETY: as `gather`: AVX-512F by `own`, indices checked, the scale a u64's.
            let v = unsafe { _mm512_i64gather_epi64::<8>(own.0, field.as_ptr().cast()) };
            ZmmIndex(v, own.1)
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

    // In the closures below, `self` (a `Ymm2`) proves AVX2: each is called only by `each`,
    // `both` or `test` on it.
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
        #[inline(always)]
        fn add(self, b: Self) -> Self {
            // SAFETY: `self` proves AVX2.
            self.both(b, |x, y| unsafe { _mm256_add_pd(x, y) })
        }
        #[inline(always)]
        fn sub(self, b: Self) -> Self {
            // SAFETY: `self` proves AVX2.
            self.both(b, |x, y| unsafe { _mm256_sub_pd(x, y) })
        }
        #[inline(always)]
        fn mul(self, b: Self) -> Self {
            // SAFETY: `self` proves AVX2.
            self.both(b, |x, y| unsafe { _mm256_mul_pd(x, y) })
        }
        #[inline(always)]
        fn div(self, b: Self) -> Self {
            // SAFETY: `self` proves AVX2.
            self.both(b, |x, y| unsafe { _mm256_div_pd(x, y) })
        }
        #[inline(always)]
        fn sqrt(self) -> Self {
            // SAFETY: `self` proves AVX2.
            self.each(|x| unsafe { _mm256_sqrt_pd(x) })
        }
        #[inline(always)]
        fn neg(self) -> Self {
            // SAFETY: `self` proves AVX2.
            self.each(|x| unsafe { _mm256_xor_pd(x, _mm256_set1_pd(-0.0)) })
        }
        #[inline(always)]
        fn copysign(self, s: Self) -> Self {
            // SAFETY: `self` proves AVX2.
            self.both(s, |x, y| unsafe {
                let sign = _mm256_set1_pd(-0.0);
                _mm256_or_pd(_mm256_andnot_pd(sign, x), _mm256_and_pd(sign, y))
            })
        }
        #[inline(always)]
        fn abs(self) -> Self {
            // SAFETY: `self` proves AVX2.
            self.each(|x| unsafe { _mm256_andnot_pd(_mm256_set1_pd(-0.0), x) })
        }
        #[inline(always)]
        fn min(self, b: Self) -> Self {
            // vminpd gives its second operand when either is NaN.
            // SAFETY: `self` proves AVX2.
            self.both(b, |x, y| unsafe {
                let y_nan = _mm256_cmp_pd::<_CMP_UNORD_Q>(y, y);
                _mm256_blendv_pd(_mm256_min_pd(x, y), x, y_nan)
            })
        }
        #[inline(always)]
        fn max(self, b: Self) -> Self {
            // SAFETY: `self` proves AVX2.
            self.both(b, |x, y| unsafe {
                let y_nan = _mm256_cmp_pd::<_CMP_UNORD_Q>(y, y);
                _mm256_blendv_pd(_mm256_max_pd(x, y), x, y_nan)
            })
        }
        #[inline(always)]
        fn lt(self, b: Self) -> u8 {
            // SAFETY: `self` proves AVX2.
            self.test(b, |x, y| unsafe { _mm256_cmp_pd::<_CMP_LT_OQ>(x, y) })
        }
        #[inline(always)]
        fn le(self, b: Self) -> u8 {
            // SAFETY: `self` proves AVX2.
            self.test(b, |x, y| unsafe { _mm256_cmp_pd::<_CMP_LE_OQ>(x, y) })
        }
        #[inline(always)]
        fn gt(self, b: Self) -> u8 {
            // SAFETY: `self` proves AVX2.
            self.test(b, |x, y| unsafe { _mm256_cmp_pd::<_CMP_GT_OQ>(x, y) })
        }
        #[inline(always)]
        fn ge(self, b: Self) -> u8 {
            // SAFETY: `self` proves AVX2.
            self.test(b, |x, y| unsafe { _mm256_cmp_pd::<_CMP_GE_OQ>(x, y) })
        }
        #[inline(always)]
        fn eq(self, b: Self) -> u8 {
            // SAFETY: `self` proves AVX2.
            self.test(b, |x, y| unsafe { _mm256_cmp_pd::<_CMP_EQ_OQ>(x, y) })
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
                    let i =
                        _mm_min_epi32(_mm_max_epi32(i, _mm_setzero_si128()), _mm_set1_epi32(max));
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
                unsafe {
                    _mm256_movemask_pd(_mm256_castsi256_pd(_mm256_cmpeq_epi64(a.0[h], b.0[h])))
                }
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
        fn gather_index(field: &[u64], own: InBounds<Ymm2Index>) -> Ymm2Index {
            let own = own.within(field);
            let half = |h: usize| {
                // SAFETY: as `gather`: AVX2 by `own`, indices checked, the scale a u64's.
                unsafe { _mm256_i64gather_epi64::<8>(field.as_ptr().cast(), own.0[h]) }
            };
            Ymm2Index([half(0), half(1)], own.1)
        }
    }
}
