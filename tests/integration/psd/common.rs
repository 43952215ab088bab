//! Helpers shared by the PSD tests: a seeded Gaussian generator (no RNG crate needed) and the
//! comparison used everywhere.

use imunoise::psd::reference::relative_error;

/// SplitMix64 with Box–Muller normals: deterministic, platform-independent test signals.
pub struct Rng(u64);

impl Rng {
    pub fn new(seed: u64) -> Self {
        Rng(seed)
    }

    pub fn next_u64(&mut self) -> u64 {
        imunoise::sim::rng::splitmix64(&mut self.0)
    }

    /// Uniform on (0, 1].
    pub fn uniform(&mut self) -> f64 {
        ((self.next_u64() >> 11) + 1) as f64 / (1u64 << 53) as f64
    }

    /// Uniform integer in lo..=hi.
    pub fn range(&mut self, lo: usize, hi: usize) -> usize {
        lo + (self.next_u64() % (hi - lo + 1) as u64) as usize
    }

    pub fn normal(&mut self) -> f64 {
        let (u1, u2) = (self.uniform(), self.uniform());
        (-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos()
    }

    /// `n` samples of white Gaussian noise with standard deviation `sigma`.
    pub fn white(&mut self, n: usize, sigma: f64) -> Vec<f64> {
        (0..n).map(|_| sigma * self.normal()).collect()
    }
}

/// Asserts `value` equals `reference` to `rel` relative, bins below 1e-12 of the maximum compared
/// against that floor instead (see `reference::relative_error`).
#[track_caller]
pub fn assert_psd_close(value: &[f64], reference: &[f64], rel: f64, what: &str) {
    let err = relative_error(value, reference, 1e-12);
    assert!(err <= rel, "{what}: relative error {err:e} > {rel:e}");
}
