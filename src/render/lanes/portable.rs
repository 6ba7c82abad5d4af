//! Eight f64 lanes as a plain array (`Portable`): the form every target runs, which the
//! compiler vectorises for the baseline (SSE2 on x86-64). Nothing to prove: its token is `()`.

// The lane loops index their arrays by lane, as the compiler vectorises them best.
#![allow(clippy::needless_range_loop)]

use super::contract::sealed::Sealed;
use super::contract::{InBounds, Lanes, LANES};

/// Plain arrays, for the baseline path and targets without an x86 form.
#[derive(Clone, Copy)]
pub struct Portable([f64; LANES]);

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

/// Methods of [`Lanes`] that are one helper above on `self` (and `b`): `name(b) -> R = helper(f)`.
macro_rules! lanewise {
    ($($name:ident($($b:ident)?) -> $ret:ty = $via:ident($f:expr);)*) => {$(
        #[inline(always)]
        fn $name(self $(, $b: Self)?) -> $ret {
            self.$via($($b,)? $f)
        }
    )*};
}

impl Sealed for Portable {}

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
    lanewise! {
        add(b) -> Self = zip(|x, y| x + y);
        sub(b) -> Self = zip(|x, y| x - y);
        mul(b) -> Self = zip(|x, y| x * y);
        div(b) -> Self = zip(|x, y| x / y);
        sqrt() -> Self = map(f64::sqrt);
        neg() -> Self = map(|x| -x);
        copysign(b) -> Self = zip(f64::copysign);
        abs() -> Self = map(f64::abs);
        min(b) -> Self = zip(f64::min);
        max(b) -> Self = zip(f64::max);
        lt(b) -> u8 = test(|x, y| x < y);
        le(b) -> u8 = test(|x, y| x <= y);
        gt(b) -> u8 = test(|x, y| x > y);
        ge(b) -> u8 = test(|x, y| x >= y);
        eq(b) -> u8 = test(|x, y| x == y);
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
