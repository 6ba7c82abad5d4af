//! The instruction paths a user can choose (`CAMPATH_SIMD`), and which of them this CPU runs:
//! each path's instruction set comes with its proof ([`Isa`]), made by feature detection.

#[cfg(target_arch = "x86_64")]
use super::lanes::Token;
use super::lanes::{ForLanes, Portable};

/// The instruction paths beside the portable one, one line each, slowest first: the `Simd`
/// variant (with its documentation), its `CAMPATH_SIMD` name, the targets it exists on, its
/// token and `Lanes` form in `lanes/`, the features its functions are compiled with (every one
/// the form's intrinsics need, and what those imply to the compiler), and the name of those
/// functions (for profiles). From this list come `Simd`, `Isa`, the detection (of exactly those
/// features, so the token proves what the functions use) and the dispatch (`Isa::run`): adding
/// an instruction set is a file of `lanes/` and a line here (ARCHITECTURE.md).
macro_rules! instruction_paths {
    ($(
        $(#[doc = $doc:literal])*
        $variant:ident = $name:literal, cfg($cfg:meta), $token:ident, $form:ident,
        [$($feature:tt),+], $rows:ident;
    )*) => {
        /// How the renderer casts its rays. Every choice gives the same bytes; they differ in
        /// speed.
        #[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
        pub enum Simd {
            /// Packets on plain arrays of lanes (`Portable`), which the compiler vectorises for
            /// the target's baseline (SSE2 on x86-64): every CPU runs it.
            Baseline,
            $($(#[doc = $doc])* $variant,)*
        }

        /// An instruction set this CPU was found to run, with its proof (a token only detection
        /// makes): the argument of the renderer's dispatch.
        #[derive(Debug, Clone, Copy)]
        pub(super) enum Isa {
            /// Plain arrays: every CPU.
            Portable,
            $(#[cfg($cfg)] $variant(super::lanes::$token),)*
        }

        impl Simd {
            /// Every path, slowest first.
            pub const ALL: [Simd; 1 + <[&str]>::len(&[$($name),*])] =
                [Simd::Baseline, $(Simd::$variant),*];

            /// The path's instruction set, with the proof that this CPU runs it; None when it
            /// does not.
            pub(super) fn isa(self) -> Option<Isa> {
                match self {
                    Simd::Baseline => Some(Isa::Portable),
                    $(Simd::$variant => {
                        #[cfg($cfg)]
                        let isa = ($(std::arch::is_x86_feature_detected!($feature))&&+).then(|| {
                            // SAFETY: the CPU runs every feature of the path's list, just
                            // detected.
                            Isa::$variant(unsafe { super::lanes::$token::new_unchecked() })
                        });
                        #[cfg(not($cfg))]
                        let isa = None;
                        isa
                    })*
                }
            }

            /// The path's name, as `CAMPATH_SIMD` takes it.
            pub fn name(self) -> &'static str {
                match self {
                    Simd::Baseline if cfg!(target_arch = "x86_64") => "sse2",
                    Simd::Baseline => "baseline",
                    $(Simd::$variant => $name,)*
                }
            }
        }

        impl Isa {
            /// `work` on this instruction set's form of lanes, compiled for the set: the
            /// renderer's one dispatch.
            #[inline(always)]
            pub(super) fn run<W: ForLanes>(self, work: W) -> W::Output {
                match self {
                    Isa::Portable => work.run::<Portable>(()),
                    $(#[cfg($cfg)]
                    Isa::$variant(t) => {
                        $(#[target_feature(enable = $feature)])+
                        fn $rows<W: ForLanes>(t: super::lanes::$token, work: W) -> W::Output {
                            work.run::<super::lanes::$form>(t)
                        }
                        // SAFETY: `t` proves that the CPU runs the features `$rows` is
                        // compiled with: only the detection above makes a token, from the
                        // same list.
                        unsafe { $rows(t, work) }
                    })*
                }
            }
        }
    };
}

instruction_paths! {
    /// Packets compiled for AVX2.
    Avx2 = "avx2", cfg(target_arch = "x86_64"), Avx2, Ymm2, ["avx2", "avx", "sse4.1"], rows_avx2;
    /// Packets compiled for AVX-512F.
    Avx512 = "avx512", cfg(target_arch = "x86_64"), Avx512, Zmm,
        ["avx512f", "avx2", "fma", "f16c"], rows_avx512;
}

impl Simd {
    /// Whether this CPU can run the path.
    pub fn supported(self) -> bool {
        self.isa().is_some()
    }

    /// The fastest path this CPU runs.
    pub fn fastest() -> Simd {
        *Simd::ALL
            .iter()
            .rev()
            .find(|s| s.supported())
            .unwrap_or(&Simd::Baseline)
    }

    /// The path named by the environment variable `CAMPATH_SIMD` (`sse2`, `avx2`, `avx512`;
    /// `scalar`, an older name of the baseline path) when this CPU runs it, otherwise the
    /// fastest. The choice never changes the
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
}

impl std::str::FromStr for Simd {
    type Err = String;

    /// A path's name, or `scalar`, the baseline path's older name.
    fn from_str(s: &str) -> Result<Simd, String> {
        Simd::ALL
            .into_iter()
            .find(|p| p.name() == s || (s == "scalar" && *p == Simd::Baseline))
            .ok_or_else(|| {
                let names: Vec<&str> = Simd::ALL.iter().map(|p| p.name()).collect();
                format!(
                    "unknown instruction path {s:?}: one of {}",
                    names.join(", ")
                )
            })
    }
}
