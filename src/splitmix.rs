//! A fixed-seed pseudo-random stream for generated scenes (the peers benchmark) and tests: the same
//! numbers on every run and machine, never seeded from entropy.

/// SplitMix64 (Steele, Lea and Flood, 2014): a fixed-seed generator for generated scenes and
/// test cameras, never seeded from entropy.
#[derive(Debug, Clone)]
pub struct SplitMix(pub u64);

impl SplitMix {
    /// The next number in [0, 1), with 53 random bits.
    pub fn unit(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
    }
}
