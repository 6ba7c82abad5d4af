//! The `Lanes` trait and the `Token` trait, whose contract the module documentation of
//! `lanes/` states; the checked gather indices; the work written once for every form.

/// Seals [`Lanes`] and [`Token`]: only the forms in `lanes/` implement them, so no other code
/// can make a token or give a form a false `index_store`.
pub(in crate::render::lanes) mod sealed {
    pub trait Sealed {}
}

/// The proof that this CPU runs an instruction set: a value exists only where the detection
/// (`instruction_paths!`, simd.rs) found every feature of the set's list, the list its
/// functions are compiled with.
///
/// # Safety
///
/// `new_unchecked` is the only maker of a token (no other constructor, no public field).
// Only the x86 forms have tokens to prove.
#[cfg_attr(not(target_arch = "x86_64"), allow(dead_code))]
pub(in crate::render) unsafe trait Token: Copy + sealed::Sealed {
    /// The token, without a check.
    ///
    /// # Safety
    ///
    /// The CPU runs every feature of the token's list in `instruction_paths!`.
    unsafe fn new_unchecked() -> Self;
}

/// Rays per packet: a whole AVX-512 register, two AVX2 ones or four SSE2 ones of f64. Divides
/// the tile side, so a packet never straddles two tiles.
pub(in crate::render) const LANES: usize = 8;

/// Eight lanes of f64 and a matching set of eight 64-bit sphere indices.
///
/// Every method is safe: a value of `Self` (or of `Self::Index`) exists only where the CPU runs
/// the instructions its methods use, because the only ways to make one from nothing take a
/// `Self::Token`, which only feature detection makes (see the module's documentation).
pub(in crate::render) trait Lanes: Copy + sealed::Sealed {
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
    /// Eight rows of four f32 as four values, the kth holding each row's kth number in its
    /// lane (converted to f64, exactly).
    #[inline(always)]
    fn columns(t: Self::Token, rows: &[[f32; 4]; LANES]) -> [Self; 4] {
        let mut s = [[0.0; LANES]; 4];
        for (l, row) in rows.iter().enumerate() {
            for k in 0..4 {
                s[k][l] = f64::from(row[k]);
            }
        }
        [
            Self::load(t, &s[0]),
            Self::load(t, &s[1]),
            Self::load(t, &s[2]),
            Self::load(t, &s[3]),
        ]
    }
}

/// (a·b for x and y) + z: glam's dot product order.
#[inline(always)]
pub(in crate::render) fn dot<V: Lanes>(a: &[V; 3], b: &[V; 3]) -> V {
    a[0].mul(b[0]).add(a[1].mul(b[1])).add(a[2].mul(b[2]))
}

/// `v` in every lane, per coordinate.
#[inline(always)]
pub(in crate::render) fn splat3<V: Lanes>(tok: V::Token, v: glam::DVec3) -> [V; 3] {
    [V::splat(tok, v.x), V::splat(tok, v.y), V::splat(tok, v.z)]
}

/// Lane indices that are each below `len`, checked when made: a gather with them stays inside
/// any slice of at least `len` elements.
#[derive(Clone, Copy)]
pub(in crate::render) struct InBounds<I> {
    own: I,
    len: usize,
}

impl<I: Copy> InBounds<I> {
    /// `own`, indices of the form `V`, if every lane is below `len`.
    #[inline(always)]
    pub(in crate::render) fn new<V: Lanes<Index = I>>(own: I, len: usize) -> Option<InBounds<I>> {
        V::index_store(own)
            .iter()
            .all(|&k| k < len as u64)
            .then_some(InBounds { own, len })
    }

    /// The indices, for a gather from `field`, which must hold `len` elements (a panic
    /// otherwise: the check that makes the gather sound).
    #[inline(always)]
    pub(in crate::render) fn within<T>(self, field: &[T]) -> I {
        assert!(field.len() >= self.len, "a gather from a shorter slice");
        self.own
    }
}

/// Work written once for every form of lanes: the row drivers' rows. `Isa::run` runs it on the
/// form of an instruction set, inside a function compiled for that set.
pub(in crate::render) trait ForLanes {
    type Output;

    /// The work on the form `V`, whose token `tok` is. Mark it `#[inline(always)]`, so that it
    /// is compiled into the instruction set's function and not left outside it.
    fn run<V: Lanes>(self, tok: V::Token) -> Self::Output;
}
