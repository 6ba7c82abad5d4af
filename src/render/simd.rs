//! The instruction paths a user can choose (`CAMPATH_SIMD`), and which of them this CPU runs:
//! each path's instruction set comes with its proof ([`Isa`]), made by feature detection.

use super::lanes::Isa;

/// How the renderer casts its rays. Every choice gives the same bytes; they differ in speed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Simd {
    /// The packet code on plain arrays of lanes (`Portable`), the form every target runs;
    /// on x86-64 the same code as `Baseline`.
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
        self.isa().is_some()
    }

    /// The path's instruction set, with the proof that this CPU runs it; None when it does not.
    pub(super) fn isa(self) -> Option<Isa> {
        match self {
            Simd::Scalar | Simd::Baseline => Some(Isa::Portable),
            #[cfg(target_arch = "x86_64")]
            Simd::Avx2 => super::lanes::Avx2::detect().map(Isa::Avx2),
            #[cfg(target_arch = "x86_64")]
            Simd::Avx512 => super::lanes::Avx512::detect().map(Isa::Avx512),
            #[cfg(not(target_arch = "x86_64"))]
            Simd::Avx2 | Simd::Avx512 => None,
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

    /// The path's name, as `CAMPATH_SIMD` takes it.
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
