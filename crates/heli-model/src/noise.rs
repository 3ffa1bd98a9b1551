//! Seeded noise: every random number of a simulation comes from a stream of its own,
//! derived from the scenario's seed, so that the same seed flies the same flight bit for bit.

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};

/// A seeded noise source: each device gets its own stream derived from the scenario seed,
/// so adding a device never changes another device's noise.
#[derive(Clone, Debug)]
pub struct Noise {
    rng: ChaCha8Rng,
}

impl Noise {
    /// The noise stream of device number `stream` for `seed`.
    pub fn new(seed: u64, stream: u64) -> Self {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        rng.set_stream(stream);
        Self { rng }
    }

    /// A normal sample with standard deviation `sigma`.
    pub fn gaussian(&mut self, sigma: f64) -> f64 {
        let z: f64 = StandardNormal.sample(&mut self.rng);
        sigma * z
    }

    /// A uniform sample in [0, 1).
    pub fn uniform(&mut self) -> f64 {
        rand::Rng::random::<f64>(&mut self.rng)
    }
}
