//! Simulated recordings for the detectors' tests: realistic gyro noise (white, flicker, rate
//! random walk, optionally quantised) with effects planted through the simulator.

use crate::model::{CoefUnit, Coefficients, GaussMarkov, Sensor};
use crate::sim::{simulate, ChannelSpec, SimSpec, TemperatureSpec};

pub const FS: f64 = 100.0;

/// Noise profiles cycled over seeds: a tactical gyro (N = 0.1 °/√h, B = 1 °/h, K = 5 °/h/√h),
/// a MEMS gyro (0.3 °/√h, 5 °/h, 30 °/h/√h) and the tactical one heavily quantised (step of the
/// rate output 3σ of the white noise: most first differences are 0).
pub fn profile(seed: u64) -> Coefficients {
    let fine = Coefficients {
        n: CoefUnit::DegPerSqrtH.to_si(0.1),
        b: CoefUnit::DegPerH.to_si(1.0),
        k: CoefUnit::DegPerHPerSqrtH.to_si(5.0),
        ..Default::default()
    };
    match seed % 3 {
        0 => fine,
        1 => Coefficients {
            n: CoefUnit::DegPerSqrtH.to_si(0.3),
            b: CoefUnit::DegPerH.to_si(5.0),
            k: CoefUnit::DegPerHPerSqrtH.to_si(30.0),
            ..Default::default()
        },
        _ => Coefficients {
            // Rate step √12·q·fs = 3·N·√fs.
            q: 3.0 * fine.n * FS.sqrt() / (12f64.sqrt() * FS),
            ..fine
        },
    }
}

/// σ of the white noise of the samples.
pub fn white_sigma(c: &Coefficients) -> f64 {
    c.n * FS.sqrt()
}

pub fn channel(noise: Coefficients) -> ChannelSpec {
    ChannelSpec {
        bias: 1e-3,
        ..ChannelSpec::new("g", Sensor::Gyro, noise)
    }
}

/// A warm-up of 5 °C (τ = 400 s) with a slow wander (0.3 °C, 300 s) and 0.01 °C sensor noise.
pub fn temperature() -> TemperatureSpec {
    TemperatureSpec {
        name: "temp".into(),
        start_degc: 20.0,
        rise_degc: 5.0,
        warmup_s: 400.0,
        wander: Some(GaussMarkov {
            sigma: 0.3,
            tc_s: 300.0,
        }),
        noise_degc: 0.01,
    }
}

/// All simulated columns (the temperature last, if any).
pub fn run(ch: ChannelSpec, n: usize, seed: u64, temp: Option<TemperatureSpec>) -> Vec<Vec<f64>> {
    let spec = SimSpec {
        rate_hz: FS,
        duration_s: n as f64 / FS,
        seed,
        channels: vec![ch],
        temperature: temp,
    };
    simulate(&spec)
        .unwrap()
        .channels
        .into_iter()
        .map(|c| c.samples)
        .collect()
}

/// Pure IEEE noise of profile `seed % 3`.
pub fn noise(n: usize, seed: u64) -> Vec<f64> {
    run(channel(profile(seed)), n, seed, None).remove(0)
}
