//! Tiny deterministic pseudo-random number generator (SplitMix64).
//!
//! No global state: every [`SplitMix64`] owns its 64-bit state, so the same seed always yields
//! the same sequence, independent of anything else in the process.

/// SplitMix64 generator (Steele, Lea & Flood 2014; the seeding generator of xoshiro).
///
/// Every seed, including 0, is valid. Period 2^64.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SplitMix64 {
    state: u64,
}

impl SplitMix64 {
    /// Creates a generator from `seed`.
    pub fn new(seed: u64) -> Self {
        Self { state: seed }
    }

    /// Next uniformly distributed 64-bit value.
    pub fn next_u64(&mut self) -> u64 {
        self.state = self.state.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.state;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Approximately standard-normal sample (mean 0, standard deviation 1), bounded to
    /// about ±3.46.
    ///
    /// Irwin–Hall approximation: the sum of four uniform variates taken from the four 16-bit
    /// lanes of one [`next_u64`](Self::next_u64) draw, centred and scaled by √3. Cheap, exactly
    /// one draw per call, no transcendental functions.
    pub fn next_gaussian(&mut self) -> f64 {
        let x = self.next_u64();
        let mut sum = 0.0;
        for lane in 0..4 {
            let bits = (x >> (16 * lane)) & 0xFFFF;
            // (bits + 0.5) / 65536 is uniform on (0, 1) with mean exactly 0.5.
            sum += (bits as f64 + 0.5) * (1.0 / 65536.0);
        }
        // Var(sum of 4 U(0,1)) = 4/12 = 1/3.
        (sum - 2.0) * SQRT_3
    }
}

const SQRT_3: f64 = 1.732_050_807_568_877_2;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn splitmix_reference_values() {
        // Reference outputs of SplitMix64 seeded with 0 (as in the original C code).
        let mut r = SplitMix64::new(0);
        assert_eq!(r.next_u64(), 0xE220_A839_7B1D_CDAF);
        assert_eq!(r.next_u64(), 0x6E78_9E6A_A1B9_65F4);
        assert_eq!(r.next_u64(), 0x06C4_5D18_8009_454F);
    }

    #[test]
    fn gaussian_moments() {
        let mut r = SplitMix64::new(42);
        let n = 200_000;
        let (mut s, mut s2, mut max_abs) = (0.0_f64, 0.0_f64, 0.0_f64);
        for _ in 0..n {
            let g = r.next_gaussian();
            s += g;
            s2 += g * g;
            max_abs = max_abs.max(g.abs());
        }
        let mean = s / n as f64;
        let var = s2 / n as f64 - mean * mean;
        assert!(mean.abs() < 0.01, "mean {mean}");
        assert!((var.sqrt() - 1.0).abs() < 0.01, "std {}", var.sqrt());
        assert!(max_abs <= 2.0 * SQRT_3, "max {max_abs}");
        assert!(max_abs > 2.5, "tails missing: max {max_abs}");
    }
}
