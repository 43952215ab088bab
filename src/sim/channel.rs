//! One simulated inertial channel: every component summed, then quantised.

use crate::model::{Coefficients, GaussMarkov, Sinusoid};

use super::flicker::{band_limited_flicker, flicker};
use super::lowpass::apply_lowpass;
use super::processes::{
    add_drift, add_gauss_markov, add_ramp, add_random_walk, add_resonance, add_sinusoid, add_white,
    add_white_student,
};
use super::quantize::quantize;
use super::rng::Rng;
use super::spec::{ChannelSpec, DriftSpec, ResonanceSpec, StepSpec};

/// What a simulated channel truly contains, in the model's SI types: what a fit should find.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct ChannelTruth {
    pub bias: f64,
    pub coefficients: Coefficients,
    pub gauss_markov: Vec<GaussMarkov>,
    pub sinusoids: Vec<Sinusoid>,
    /// Rate per °C of the true temperature's rise above its start.
    pub temperature_coefficient: f64,
    /// Planted bias steps (not in [`ChannelTruth::avar`]).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub steps: Vec<StepSpec>,
    /// Sample indices of the planted spikes, ascending (not in [`ChannelTruth::avar`]).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub spike_indices: Vec<usize>,
    /// Planted resonances (not in [`ChannelTruth::avar`]).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub resonances: Vec<ResonanceSpec>,
    /// Planted deterministic bias drift (not in [`ChannelTruth::avar`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub drift: Option<DriftSpec>,
    /// The sample rate, Hz: the sinusoids are point-sampled at it.
    pub rate_hz: f64,
}

impl ChannelTruth {
    pub(crate) fn of(spec: &ChannelSpec, rate_hz: f64) -> ChannelTruth {
        ChannelTruth {
            bias: spec.bias,
            coefficients: spec.noise,
            gauss_markov: spec.gauss_markov.clone(),
            sinusoids: spec
                .sinusoids
                .iter()
                .map(|s| Sinusoid {
                    amplitude: s.amplitude,
                    freq_hz: s.freq_hz,
                })
                .collect(),
            temperature_coefficient: spec.temperature_coefficient,
            steps: spec.steps.clone(),
            spike_indices: Vec::new(),
            resonances: spec.resonances.clone(),
            drift: spec.drift,
            rate_hz,
        }
    }

    /// The model Allan variance of everything random or deterministic in the channel except the
    /// temperature drift (whose AV depends on the realised temperature), the steps, spikes,
    /// resonances and the deterministic drift.
    pub fn avar(&self, tau: f64) -> f64 {
        self.coefficients.avar(tau)
            + self.gauss_markov.iter().map(|g| g.avar(tau)).sum::<f64>()
            + self
                .sinusoids
                .iter()
                .map(|s| s.avar_point_sampled(tau, self.rate_hz))
                .sum::<f64>()
    }
}

/// Independent random streams per component, so that adding a sinusoid or a second channel
/// leaves every other component's samples unchanged.
#[derive(Clone, Copy)]
enum Component {
    White = 1,
    RandomWalk,
    Flicker,
    Quantisation,
    Spikes = 50,
    GaussMarkov = 100,
    Resonance = 200,
    LineWander = 300,
}

fn rng_for(channel_seed: u64, component: Component, index: usize) -> Rng {
    Rng::stream(channel_seed, component as u64 + index as u64)
}

/// Samples of `spec` (SI units), `n` at `rate_hz`; `drift_temperature` is T(t) − T₀ when the
/// channel has a temperature coefficient. With a decimator, everything the sensor senses is
/// made at `factor` times the rate and decimated; the low-pass, quantisation, spikes and the
/// output's rounding follow at the output rate.
pub fn simulate_channel(
    spec: &ChannelSpec,
    n: usize,
    rate_hz: f64,
    channel_seed: u64,
    drift_temperature: Option<&[f64]>,
) -> Vec<f64> {
    let c = &spec.noise;
    let mut y = match &spec.decimator {
        None => sensed(spec, n, rate_hz, channel_seed, drift_temperature),
        Some(d) => {
            let f = d.factor as usize;
            // The temperature is slow: held over each output interval.
            let held: Option<Vec<f64>> = drift_temperature
                .map(|t| t.iter().flat_map(|&v| std::iter::repeat_n(v, f)).collect());
            let fine = sensed(
                spec,
                n * f,
                rate_hz * f as f64,
                channel_seed,
                held.as_deref(),
            );
            decimate_cic(&fine, d.stages, f)
        }
    };
    if let Some(lp) = &spec.lowpass {
        apply_lowpass(&mut y, rate_hz, lp);
    }
    if c.q > 0.0 {
        let start = rng_for(channel_seed, Component::Quantisation, 0).uniform();
        quantize(&mut y, rate_hz, c.q, start);
    }
    for (i, sign) in spikes(spec, n, channel_seed) {
        y[i] += sign * spec.spikes.map_or(0.0, |s| s.size);
    }
    if let Some(lsb) = spec.lsb.filter(|l| *l > 0.0) {
        for v in &mut y {
            *v = (*v / lsb).round() * lsb;
        }
    }
    y
}

/// `stages` cascaded moving averages of `factor` samples, then every `factor`-th output (the
/// last of each block of input samples): a CIC (sinc^k) decimator with unit DC gain. The history
/// before the first sample is that sample (a running sensor, no start transient).
fn decimate_cic(x: &[f64], stages: u32, factor: usize) -> Vec<f64> {
    let mut y = x.to_vec();
    for _ in 0..stages {
        let first = y.first().copied().unwrap_or(0.0);
        let mut sum = first * factor as f64;
        let mut out = Vec::with_capacity(y.len());
        for i in 0..y.len() {
            let leaving = if i >= factor { y[i - factor] } else { first };
            sum += y[i] - leaving;
            out.push(sum / factor as f64);
        }
        y = out;
    }
    y.into_iter().skip(factor - 1).step_by(factor).collect()
}

/// Everything the sensor senses, before its filters and its output stage: `n` samples at
/// `rate_hz`, each the mean rate over its interval.
fn sensed(
    spec: &ChannelSpec,
    n: usize,
    rate_hz: f64,
    channel_seed: u64,
    drift_temperature: Option<&[f64]>,
) -> Vec<f64> {
    let c = &spec.noise;
    let mut y = if c.b > 0.0 {
        let mut rng = rng_for(channel_seed, Component::Flicker, 0);
        match spec.flicker_corner_hz {
            Some(corner) => band_limited_flicker(n, rate_hz, c.b, corner, &mut rng),
            None => flicker(n, rate_hz, c.b, &mut rng),
        }
    } else {
        vec![0.0; n]
    };
    for v in &mut y {
        *v += spec.bias;
    }
    if c.n > 0.0 {
        let mut rng = rng_for(channel_seed, Component::White, 0);
        match spec.white_tail_dof {
            Some(dof) => add_white_student(&mut y, rate_hz, c.n, dof, &mut rng),
            None => add_white(&mut y, rate_hz, c.n, &mut rng),
        }
    }
    if c.k > 0.0 {
        let mut rng = rng_for(channel_seed, Component::RandomWalk, 0);
        add_random_walk(&mut y, rate_hz, c.k, &mut rng);
    }
    if c.r != 0.0 {
        add_ramp(&mut y, rate_hz, c.r);
    }
    for (i, gm) in spec.gauss_markov.iter().enumerate() {
        let mut rng = rng_for(channel_seed, Component::GaussMarkov, i);
        add_gauss_markov(&mut y, rate_hz, gm, &mut rng);
    }
    for (i, r) in spec.resonances.iter().enumerate() {
        let mut rng = rng_for(channel_seed, Component::Resonance, i);
        add_resonance(&mut y, rate_hz, r, &mut rng);
    }
    for (i, s) in spec.sinusoids.iter().enumerate() {
        add_sinusoid(
            &mut y,
            rate_hz,
            s,
            &mut rng_for(channel_seed, Component::LineWander, i),
        );
    }
    if let Some(d) = &spec.drift {
        add_drift(&mut y, rate_hz, d);
    }
    if let Some(dt) = drift_temperature {
        if spec.temperature_coefficient != 0.0 {
            for (v, t) in y.iter_mut().zip(dt) {
                *v += spec.temperature_coefficient * t;
            }
        }
    }
    for st in &spec.steps {
        add_step(&mut y, rate_hz, st);
    }
    y
}

/// A rate step: sample i (interval [i, i+1)/fs) gets the share of its interval after `time_s`.
fn add_step(y: &mut [f64], rate_hz: f64, st: &StepSpec) {
    let at = st.time_s * rate_hz;
    for (i, v) in y.iter_mut().enumerate().skip(at.floor() as usize) {
        *v += st.size * (i as f64 + 1.0 - at).clamp(0.0, 1.0);
    }
}

/// Positions (distinct, ascending) and signs of the planted spikes; empty without a spike spec,
/// and then no random number is drawn.
pub(crate) fn spikes(spec: &ChannelSpec, n: usize, channel_seed: u64) -> Vec<(usize, f64)> {
    let Some(sp) = spec.spikes.filter(|s| s.count > 0 && n > 0) else {
        return Vec::new();
    };
    let mut rng = Rng::stream(
        channel_seed,
        (Component::Spikes as u64).wrapping_add(sp.seed_offset.wrapping_mul(0x9E37_79B9)),
    );
    let count = sp.count.min(n);
    let mut taken = std::collections::BTreeMap::new();
    while taken.len() < count {
        let i = ((rng.uniform() * n as f64) as usize).min(n - 1);
        let sign = if rng.uniform() < 0.5 { -1.0 } else { 1.0 };
        taken.entry(i).or_insert(sign);
    }
    taken.into_iter().collect()
}
