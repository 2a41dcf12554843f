//! The sweep's random numbers: SplitMix64 (Steele, Lea & Flood 2014), one
//! stream per sample and parameter, so that a sample's values depend only on
//! the master seed, its index and the parameter's place in the file (never on
//! which worker or shard ran it, nor in what order).

/// One step of SplitMix64's output function on `z`.
pub fn mix(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// The seed of sample `index` of a sweep with master seed `seed`.
pub fn sample_seed(seed: u64, index: u64) -> u64 {
    mix(seed ^ mix(index))
}

/// SplitMix64 generator.
#[derive(Clone, Debug)]
pub struct Rng {
    state: u64,
}

impl Rng {
    /// The stream of parameter `param` (its place in the file) of a sample.
    pub fn for_param(sample_seed: u64, param: usize) -> Rng {
        Rng {
            state: mix(sample_seed ^ mix(0x5EED_0000 + param as u64)),
        }
    }
    pub fn next_u64(&mut self) -> u64 {
        self.state = self.state.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.state;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    /// Uniform in [0, 1) (53 random bits).
    pub fn uniform(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }
    /// Standard normal (Box-Muller, one of the pair).
    pub fn normal(&mut self) -> f64 {
        // 1 - u lies in (0, 1]: its logarithm is finite.
        let u1 = 1.0 - self.uniform();
        let u2 = self.uniform();
        (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn splitmix_reference_values() {
        // SplitMix64 seeded with 0: the first outputs of the reference
        // implementation (Vigna's splitmix64.c).
        let mut r = Rng { state: 0 };
        assert_eq!(r.next_u64(), 0xE220_A839_7B1D_CDAF);
        assert_eq!(r.next_u64(), 0x6E78_9E6A_A1B9_65F4);
        assert_eq!(mix(0), 0xE220_A839_7B1D_CDAF);
    }

    #[test]
    fn uniform_and_normal_moments() {
        let mut r = Rng::for_param(sample_seed(7, 3), 0);
        let n = 20_000;
        let u: Vec<f64> = (0..n).map(|_| r.uniform()).collect();
        let z: Vec<f64> = (0..n).map(|_| r.normal()).collect();
        let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
        let var = |v: &[f64]| {
            let m = mean(v);
            v.iter().map(|x| (x - m) * (x - m)).sum::<f64>() / v.len() as f64
        };
        assert!(u.iter().all(|&x| (0.0..1.0).contains(&x)));
        // standard errors: uniform mean 0.002, normal mean 0.007, variance 0.01
        assert!((mean(&u) - 0.5).abs() < 0.01, "{}", mean(&u));
        assert!((var(&u) - 1.0 / 12.0).abs() < 0.005, "{}", var(&u));
        assert!(mean(&z).abs() < 0.03, "{}", mean(&z));
        assert!((var(&z) - 1.0).abs() < 0.04, "{}", var(&z));
    }
}
