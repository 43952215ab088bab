//! The simulated sensor temperature and the drift it drives.
//!
//! A warm-up T(t) = T₀ + ΔT·(1 − e^(−t/τ_w)) (a first-order thermal response after power-on)
//! plus an optional slow Gauss–Markov wander is the true temperature; the channel drift is
//! coefficient·(T(t) − T₀). The recorded temperature channel adds white measurement noise, so that
//! a later regression of a rate on it sees what it would see on a real recording: a noisy
//! regressor.

use super::processes::add_gauss_markov;
use super::rng::Rng;
use super::spec::TemperatureSpec;

/// The true temperature (°C) at each of `n` samples.
pub fn true_temperature(spec: &TemperatureSpec, n: usize, rate_hz: f64, rng: &mut Rng) -> Vec<f64> {
    let mut t: Vec<f64> = (0..n)
        .map(|i| {
            let time = i as f64 / rate_hz;
            spec.start_degc + spec.rise_degc * (1.0 - (-time / spec.warmup_s).exp())
        })
        .collect();
    if let Some(w) = &spec.wander {
        add_gauss_markov(&mut t, rate_hz, w, rng);
    }
    t
}

/// The recorded channel: the true temperature plus white noise.
pub fn recorded_temperature(truth: &[f64], noise_degc: f64, rng: &mut Rng) -> Vec<f64> {
    truth.iter().map(|t| t + noise_degc * rng.gauss()).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn warm_up_reaches_the_plateau() {
        let spec = TemperatureSpec {
            name: "t".into(),
            start_degc: 20.0,
            rise_degc: 10.0,
            warmup_s: 100.0,
            wander: None,
            noise_degc: 0.0,
        };
        let t = true_temperature(&spec, 10_001, 10.0, &mut Rng::new(1));
        assert_eq!(t[0], 20.0);
        // t = 100 s = τ_w: 1 − 1/e of the rise.
        assert!((t[1000] - (20.0 + 10.0 * (1.0 - (-1.0f64).exp()))).abs() < 1e-12);
        assert!((t[10_000] - 30.0).abs() < 10.0 * (-10.0f64).exp() + 1e-12);
    }
}
