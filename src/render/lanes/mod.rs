//! Eight f64 lanes and 8-bit lane masks (lane l is bit l), in three forms: one AVX-512
//! register, two AVX2 registers, and plain arrays for every other target (the compiler
//! vectorises them for SSE2). The packet code (`kernels.rs`, `drivers.rs`, `shadows/`, `srgb.rs`)
//! is written once against [`Lanes`]. A leaf: it imports nothing of the renderer. It also
//! holds [`prefetch`], the renderer's one cache hint.
//!
//! Every operation is the IEEE operation Rust's scalar code does, correctly rounded at any width:
//! no fused multiply-add, no approximate reciprocal or square root. Comparisons are ordered
//! (false for NaN), as Rust's; the code negates a mask where the scalar code negates a
//! comparison.
//!
//! # Safety, by construction
//!
//! The x86 forms run instructions that not every x86-64 CPU has. Each holds a token (`Avx2`,
//! `Avx512`: [`Token`], an unsafe trait) that only feature detection makes (`instruction_paths!`
//! in simd.rs, from the list the functions are compiled with),
//! and a value of a form can be made only from its token (`Lanes::splat`, `load`, `index`) or
//! from another value of it, so holding a `Zmm` proves that the CPU runs AVX-512F, and a `Ymm2`
//! AVX2. That is the whole contract of the trait's methods: safe to call wherever a value of the
//! type exists. Each `unsafe` block inside them says which value proves the feature there, and
//! what else it needs (a load's length, a gather's indices, checked by [`InBounds`] against the
//! form's own `index_store`). Both traits are sealed: only the files here implement them.
//!
//! Speed, not soundness, asks one more thing: the methods call intrinsics without
//! `#[target_feature]`, so they must be inlined into the functions compiled for the instruction
//! set, which `Isa::run` (simd.rs) makes for each [`ForLanes`] work. A closure between the two
//! (`array::map`, a callback) may be left out of line and compiled without the instruction set,
//! which turns every intrinsic in it into a call: no closure in the packet code calls one, and
//! `.ci/run` checks that nothing calls an intrinsic out of line.
//!
//! Each form is a file (`portable.rs`, `avx2.rs`, `avx512.rs`), declared below.

mod contract;
#[cfg(target_arch = "x86_64")]
pub(super) use contract::Token;
pub(super) use contract::{dot, splat3, ForLanes, InBounds, Lanes, LANES};

mod portable;
pub(super) use portable::Portable;

#[cfg(target_arch = "x86_64")]
mod avx2;
#[cfg(target_arch = "x86_64")]
pub(super) use avx2::{Avx2, Ymm2};

#[cfg(target_arch = "x86_64")]
mod avx512;
#[cfg(target_arch = "x86_64")]
pub(super) use avx512::{Avx512, Zmm};

/// Asks the CPU to bring `x` into the caches: a hint, which changes no value.
#[inline(always)]
pub(in crate::render) fn prefetch<T>(x: &T) {
    #[cfg(target_arch = "x86_64")]
    // SAFETY: a prefetch only hints at an address (here a valid reference) and never faults;
    // it needs SSE, which every x86-64 CPU has.
    unsafe {
        use std::arch::x86_64::{_mm_prefetch, _MM_HINT_T0};
        _mm_prefetch::<_MM_HINT_T0>((x as *const T).cast::<i8>());
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = x;
}
