//! The rate processes other than flicker and quantisation, each added onto a channel in place.
//! Discretised so that their Allan variance and PSD are those of [`crate::model`].

use std::f64::consts::TAU;

use crate::model::GaussMarkov;

use super::rng::Rng;
use super::spec::SinusoidSpec;

/// White rate noise with two-sided PSD n² (AV n²/τ): per-sample σ = n·√fs.
pub fn add_white(y: &mut [f64], rate_hz: f64, n: f64, rng: &mut Rng) {
    let sigma = n * rate_hz.sqrt();
    for v in y {
        *v += sigma * rng.gauss();
    }
}

/// Rate random walk with AV k²τ/3: the rate takes a step of σ = k·√τ₀ every sample, starting from
/// zero (the first sample already has one step). Its discrete AV is k²τ/3·(1 + 1/(2m²)).
pub fn add_random_walk(y: &mut [f64], rate_hz: f64, k: f64, rng: &mut Rng) {
    let sigma = k / rate_hz.sqrt();
    let mut level = 0.0;
    for v in y {
        level += sigma * rng.gauss();
        *v += level;
    }
}

/// A deterministic ramp r·t, t = i/fs (AV r²τ²/2 exactly).
pub fn add_ramp(y: &mut [f64], rate_hz: f64, r: f64) {
    for (i, v) in y.iter_mut().enumerate() {
        *v += r * i as f64 / rate_hz;
    }
}

/// First-order Gauss–Markov: the exact AR(1) discretisation x_i = φx_{i−1} + σ√(1 − φ²)·w_i with
/// φ = e^(−τ₀/Tc), started from its stationary distribution so that there is no transient.
pub fn add_gauss_markov(y: &mut [f64], rate_hz: f64, gm: &GaussMarkov, rng: &mut Rng) {
    let phi = (-1.0 / (rate_hz * gm.tc_s)).exp();
    let drive = gm.sigma * (1.0 - phi * phi).sqrt();
    let mut x = gm.sigma * rng.gauss();
    for v in y {
        *v += x;
        x = phi * x + drive * rng.gauss();
    }
}

/// A·sin(2πf₀t + φ).
pub fn add_sinusoid(y: &mut [f64], rate_hz: f64, s: &SinusoidSpec) {
    let w = TAU * s.freq_hz / rate_hz;
    for (i, v) in y.iter_mut().enumerate() {
        *v += s.amplitude * (w * i as f64 + s.phase_rad).sin();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::avar::reference::oadev;

    #[test]
    fn allan_variances_of_the_discretisations() {
        // 200 000 samples; the tolerances are about 3σ of the AV estimate at the m used (EDF
        // from ≈ 2N/3m for white, far fewer for the random walk: checked at small m).
        let fs = 100.0;
        let n = 200_000;
        let mut y = vec![0.0; n];
        add_white(&mut y, fs, 0.02, &mut Rng::new(1));
        let m = 10;
        let av = oadev(&y, m);
        let want = 0.02f64.powi(2) / (m as f64 / fs);
        assert!((av / want - 1.0).abs() < 0.03, "{}", av / want);

        let mut y = vec![0.0; n];
        add_random_walk(&mut y, fs, 1e-3, &mut Rng::new(2));
        let m = 4;
        let tau = m as f64 / fs;
        let want = 1e-6 * tau / 3.0 * (1.0 + 1.0 / (2.0 * (m * m) as f64));
        let av = oadev(&y, m);
        assert!((av / want - 1.0).abs() < 0.05, "{}", av / want);

        let mut y = vec![0.0; 1000];
        add_ramp(&mut y, fs, 0.5);
        let tau = 0.3;
        let av = oadev(&y, 30);
        assert!((av / (0.25 * tau * tau / 2.0) - 1.0).abs() < 1e-9);
    }

    #[test]
    fn gauss_markov_is_stationary_with_the_given_variance() {
        // Tc = 0.5 s at 100 Hz over 2000 s: about 2000 correlation times, so the sample variance
        // has σ ≈ √(2·2·Tc/T)= 3 %; bound 10 %.
        let gm = GaussMarkov {
            sigma: 0.3,
            tc_s: 0.5,
        };
        let mut y = vec![0.0; 200_000];
        add_gauss_markov(&mut y, 100.0, &gm, &mut Rng::new(4));
        let var = y.iter().map(|v| v * v).sum::<f64>() / y.len() as f64;
        assert!((var / 0.09 - 1.0).abs() < 0.1, "{}", var / 0.09);
        let lag = 50; // one Tc
        let c: f64 =
            y.windows(lag + 1).map(|w| w[0] * w[lag]).sum::<f64>() / (y.len() - lag) as f64;
        assert!((c / var - (-1.0f64).exp()).abs() < 0.06, "{}", c / var);
    }
}
