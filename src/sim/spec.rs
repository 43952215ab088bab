//! The simulation specification: plain serde values (SI units), as read from a JSON file by
//! `imunoise simulate` or written in a test.

use serde::{Deserialize, Serialize};

use crate::effects::shapes::ResonanceForm;
use crate::model::{Coefficients, GaussMarkov, Sensor};

use super::SimError;

/// What to simulate: a static IMU recording of `channels` at `rate_hz` for `duration_s`,
/// reproducible from `seed`.
///
/// ```
/// let spec: imunoise::sim::SimSpec = serde_json::from_str(r#"{
///     "rate_hz": 100.0, "duration_s": 60.0, "seed": 7,
///     "channels": [{ "name": "gx", "sensor": "gyro", "noise": { "n": 1e-3, "b": 1e-5 } }]
/// }"#).unwrap();
/// assert_eq!(spec.samples(), 6000);
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SimSpec {
    pub rate_hz: f64,
    /// Recording length, s; the sample count is ⌊duration·rate⌋.
    pub duration_s: f64,
    #[serde(default)]
    pub seed: u64,
    pub channels: Vec<ChannelSpec>,
    /// A simulated temperature channel (emitted as an extra channel) that drives the channels'
    /// `temperature_coefficient` drift.
    #[serde(default)]
    pub temperature: Option<TemperatureSpec>,
}

/// One inertial channel: the sum of a constant bias, the IEEE noise terms, Gauss–Markov processes,
/// resonances, sinusoids, a temperature drift, a deterministic bias drift and bias steps, then (if
/// Q > 0) angle quantisation, then spikes.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ChannelSpec {
    pub name: String,
    pub sensor: Sensor,
    /// Constant bias (rad/s or m/s²).
    #[serde(default)]
    pub bias: f64,
    /// IEEE coefficients in SI: q (rad, m/s), n (rad/√s, m/s/√s), b (rad/s, m/s²), k (rad/s/√s,
    /// m/s²/√s), r (rad/s², m/s³).
    #[serde(default)]
    pub noise: Coefficients,
    #[serde(default)]
    pub gauss_markov: Vec<GaussMarkov>,
    #[serde(default)]
    pub sinusoids: Vec<SinusoidSpec>,
    /// Rate drift per °C of temperature rise above the start (rad/s/°C or m/s²/°C).
    #[serde(default)]
    pub temperature_coefficient: f64,
    /// Bias steps: the rate jumps by `size` at `time_s` and stays (non-stationarity the IEEE model
    /// lacks; what `effects::time::step` looks for).
    #[serde(default)]
    pub steps: Vec<StepSpec>,
    /// Single-sample output glitches (what `effects::time::spikes` looks for).
    #[serde(default)]
    pub spikes: Option<SpikeSpec>,
    /// Narrowband resonances (second-order Gauss–Markov processes; what `effects::shapes::Resonance`
    /// models).
    #[serde(default)]
    pub resonances: Vec<ResonanceSpec>,
    /// A deterministic bias drift (settling and curvature; neither is an IEEE term).
    #[serde(default)]
    pub drift: Option<DriftSpec>,
    /// The sensor's internal low-pass (anti-alias, digital low-pass) filter, applied to the sum of
    /// everything above before quantisation and spikes; `None`: none (each sample the exact mean
    /// rate over its interval).
    #[serde(default)]
    pub lowpass: Option<LowPassSpec>,
    /// A CIC (sinc^k) decimator before the low-pass: the sensed signal is made at `factor` times
    /// the output rate, averaged `stages` times over `factor` samples and decimated (what most
    /// sigma-delta MEMS parts do). `None`: none.
    #[serde(default)]
    pub decimator: Option<DecimatorSpec>,
    /// The output's resolution (rad/s or m/s²): each rate sample, spikes included, is rounded to
    /// a whole number of `lsb`, as a rate sensor's converter does. Unlike Q (an integrated angle
    /// rounded, whose error differences to blue rate noise), the rounding error of the rate itself
    /// is white: about `lsb`²/12 of variance per sample while the other noise spans a few steps.
    /// `None` (or 0): not rounded.
    #[serde(default)]
    pub lsb: Option<f64>,
    /// Heavy-tailed white noise: the white term (N) drawn from Student's t with this many degrees
    /// of freedom (> 2), scaled to the same variance N²·f_s, so that every sample, however far
    /// out, belongs to the noise (no outliers). `None`: Gaussian.
    #[serde(default)]
    pub white_tail_dof: Option<f64>,
    /// Band-limited bias instability: below this frequency (Hz) the flicker's density stays at
    /// its value there instead of rising as 1/f (a bias correlated over ≈ 1/(2π·corner) s, as a
    /// sum of Gauss–Markov processes makes it). `None`: 1/f down to the record's length.
    #[serde(default)]
    pub flicker_corner_hz: Option<f64>,
}

/// A Butterworth low-pass of `order` with its −3 dB corner at `corner_hz` (below Nyquist),
/// realised digitally at the output rate (see `sim/lowpass.rs`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LowPassSpec {
    pub corner_hz: f64,
    pub order: u32,
}

/// `stages` cascaded moving averages of `factor` input samples, every `factor`-th kept.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DecimatorSpec {
    pub stages: u32,
    pub factor: u32,
}

impl ChannelSpec {
    /// A channel of `sensor` with the IEEE `noise` (SI) and nothing else: no bias, no effects.
    pub fn new(name: impl Into<String>, sensor: Sensor, noise: Coefficients) -> Self {
        Self {
            name: name.into(),
            sensor,
            bias: 0.0,
            noise,
            gauss_markov: vec![],
            sinusoids: vec![],
            temperature_coefficient: 0.0,
            steps: vec![],
            spikes: None,
            resonances: vec![],
            drift: None,
            lowpass: None,
            decimator: None,
            lsb: None,
            white_tail_dof: None,
            flicker_corner_hz: None,
        }
    }
}

/// A narrowband resonance: white noise through a damped oscillator of natural frequency `f0_hz`
/// and quality factor `q`, of standard deviation `sigma` (rad/s or m/s²).
///
/// The definitions are those of `effects::shapes::Resonance`, the shape the residual loop fits:
/// the process is x″ + (ω₀/q)·x′ + ω₀²·x = white noise, ω₀ = 2πf₀, whose spectrum is
/// ∝ f₀⁴/((f₀² − f²)² + (f·f₀/q)²) (half-power width ≈ f₀/q; the peak, at f₀√(1 − 1/(2q²)), is
/// at f₀ but for O(1/q²)), and `sigma` is the standard deviation of the samples. The simulator
/// samples this continuous process at the sample instants (point samples, not interval means as
/// for the other components: the shape's spectrum has no sinc² either), exactly: a state-space
/// AR(2) step with the poles r·e^(±iω), r = e^(−πf₀/(q·fs)), ω = 2πf₀√(1 − 1/(4q²))/fs, started
/// from the stationary distribution. The samples' spectrum is the continuous one folded at
/// Nyquist; the shape cuts it at Nyquist instead and renormalises, which differs by the share of
/// the power above Nyquist f_N, ≈ 2f₀³/(3πq·f_N³) (4e-5 for f₀ = 8 Hz, q = 20 at 100 Hz).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ResonanceSpec {
    pub f0_hz: f64,
    /// Quality factor, > 0 (≤ ½ is an overdamped, non-resonant second-order process).
    pub q: f64,
    /// Standard deviation of the process (rad/s or m/s²).
    pub sigma: f64,
    /// Which output of the resonator: `low_pass` (the default: the displacement-like state,
    /// a plateau at 1/q² of the peak below f₀) or `band_pass` (its rate, σ·x′/(ω₀σₓ): no
    /// plateau, ∝ f² below the peak), as [`crate::effects::shapes::ResonanceForm`].
    #[serde(default)]
    pub form: ResonanceForm,
}

/// A deterministic bias drift over the record of length T (s): an exponential settling
/// `amplitude`·e^(−t/`tc_s`) and a curvature `quadratic`·(t − T/2)², each sample being the mean over
/// its interval (exactly, as for the other components).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DriftSpec {
    #[serde(default)]
    pub exponential: Option<ExponentialDrift>,
    /// Curvature of the bias, rad/s per s² (or m/s² per s²).
    #[serde(default)]
    pub quadratic: f64,
}

/// A bias settling `amplitude`·e^(−t/`tc_s`) from power-on (t = 0 at the first sample's start).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ExponentialDrift {
    /// Bias offset at t = 0 (rad/s or m/s²), decaying to zero.
    pub amplitude: f64,
    /// Time constant, s.
    pub tc_s: f64,
}

/// A bias step: from `time_s` on the rate is higher by `size` (rad/s or m/s²). A step inside a
/// sample interval enters that sample pro rata (samples are interval means).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StepSpec {
    pub time_s: f64,
    pub size: f64,
}

/// `count` single-sample spikes of absolute amplitude `size` (rad/s or m/s²) and random sign at
/// distinct random samples, added to the output after quantisation (a glitch of the output, not
/// of the rate). Positions and signs come from the channel's own stream (`seed_offset` picks
/// another draw), so the other components' samples are unchanged.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SpikeSpec {
    pub count: usize,
    pub size: f64,
    #[serde(default)]
    pub seed_offset: u64,
}

/// A sinusoidal rate A·sin(2πf₀t + φ).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SinusoidSpec {
    /// Amplitude A (rad/s or m/s²).
    pub amplitude: f64,
    pub freq_hz: f64,
    #[serde(default)]
    pub phase_rad: f64,
    /// Wander of a real machine's line (a pump, a fan whose speed drifts): the instantaneous
    /// frequency is `freq_hz` + δf(t) and the amplitude A·(1 + δa(t)), δf and δa independent
    /// first-order Gauss–Markov processes of standard deviations `freq_wander_hz` and
    /// `amplitude_wander` (relative) and correlation time `wander_tc_s`. `None`: a coherent
    /// sinusoid.
    #[serde(default)]
    pub wander: Option<LineWander>,
}

/// See [`SinusoidSpec::wander`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LineWander {
    pub freq_wander_hz: f64,
    #[serde(default)]
    pub amplitude_wander: f64,
    pub wander_tc_s: f64,
}

/// The sensor temperature: a first-order warm-up from `start_degc` by `rise_degc` with time
/// constant `warmup_s`, plus a slow Gauss–Markov wander; the recorded channel adds white
/// measurement noise.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TemperatureSpec {
    #[serde(default = "TemperatureSpec::default_name")]
    pub name: String,
    pub start_degc: f64,
    pub rise_degc: f64,
    pub warmup_s: f64,
    /// Wander of the true temperature (σ in °C, correlation time in s).
    #[serde(default)]
    pub wander: Option<GaussMarkov>,
    /// Standard deviation of the white measurement noise of the recorded channel, °C.
    #[serde(default)]
    pub noise_degc: f64,
}

impl TemperatureSpec {
    fn default_name() -> String {
        "temperature".into()
    }
}

impl SimSpec {
    /// Number of samples per channel.
    pub fn samples(&self) -> usize {
        (self.duration_s * self.rate_hz).floor() as usize
    }

    /// Checks every value before any sample is made.
    pub fn validate(&self) -> Result<(), SimError> {
        if !(self.rate_hz.is_finite() && self.rate_hz > 0.0) {
            return Err(SimError::InvalidRate(self.rate_hz));
        }
        if !(self.duration_s.is_finite() && self.duration_s * self.rate_hz >= 2.0) {
            return Err(SimError::InvalidDuration {
                duration_s: self.duration_s,
                rate_hz: self.rate_hz,
            });
        }
        if self.channels.is_empty() {
            return Err(SimError::NoChannels);
        }
        let mut names: Vec<&str> = self.channels.iter().map(|c| c.name.as_str()).collect();
        if let Some(t) = &self.temperature {
            names.push(&t.name);
        }
        names.sort_unstable();
        if let Some(w) = names.windows(2).find(|w| w[0] == w[1]) {
            return Err(SimError::DuplicateName(w[0].to_string()));
        }
        let nyquist_hz = self.rate_hz / 2.0;
        for ch in &self.channels {
            let bad = |field: &'static str, value: f64| SimError::InvalidParameter {
                channel: ch.name.clone(),
                field,
                value,
            };
            let non_negative = |field, v: f64| {
                if v.is_finite() && v >= 0.0 {
                    Ok(())
                } else {
                    Err(bad(field, v))
                }
            };
            let finite = |field, v: f64| {
                if v.is_finite() {
                    Ok(())
                } else {
                    Err(bad(field, v))
                }
            };
            let c = &ch.noise;
            non_negative("noise.q", c.q)?;
            non_negative("noise.n", c.n)?;
            non_negative("noise.b", c.b)?;
            non_negative("noise.k", c.k)?;
            // A ramp may fall as well as rise.
            finite("noise.r", c.r)?;
            finite("bias", ch.bias)?;
            finite("temperature_coefficient", ch.temperature_coefficient)?;
            for gm in &ch.gauss_markov {
                non_negative("gauss_markov.sigma", gm.sigma)?;
                if !(gm.tc_s.is_finite() && gm.tc_s > 0.0) {
                    return Err(bad("gauss_markov.tc_s", gm.tc_s));
                }
            }
            for s in &ch.sinusoids {
                if let Some(w) = &s.wander {
                    non_negative("sinusoids.wander.freq_wander_hz", w.freq_wander_hz)?;
                    non_negative("sinusoids.wander.amplitude_wander", w.amplitude_wander)?;
                    if !(w.wander_tc_s.is_finite() && w.wander_tc_s > 0.0) {
                        return Err(bad("sinusoids.wander.wander_tc_s", w.wander_tc_s));
                    }
                }
                finite("sinusoids.amplitude", s.amplitude)?;
                finite("sinusoids.phase_rad", s.phase_rad)?;
                non_negative("sinusoids.freq_hz", s.freq_hz)?;
                if s.freq_hz >= nyquist_hz {
                    return Err(SimError::AboveNyquist {
                        channel: ch.name.clone(),
                        freq_hz: s.freq_hz,
                        nyquist_hz,
                    });
                }
            }
            if let Some(lsb) = ch.lsb {
                non_negative("lsb", lsb)?;
            }
            if let Some(corner) = ch.flicker_corner_hz {
                if !(corner.is_finite() && corner > 0.0 && corner < nyquist_hz) {
                    return Err(bad("flicker_corner_hz", corner));
                }
            }
            if let Some(dof) = ch.white_tail_dof {
                if !(dof.is_finite() && dof > 2.0) {
                    return Err(bad("white_tail_dof", dof));
                }
            }
            for st in &ch.steps {
                non_negative("steps.time_s", st.time_s)?;
                finite("steps.size", st.size)?;
            }
            if let Some(sp) = &ch.spikes {
                finite("spikes.size", sp.size)?;
                if sp.count > self.samples() {
                    return Err(bad("spikes.count", sp.count as f64));
                }
            }
            for r in &ch.resonances {
                non_negative("resonances.sigma", r.sigma)?;
                if !(r.q.is_finite() && r.q > 0.0) {
                    return Err(bad("resonances.q", r.q));
                }
                if !(r.f0_hz.is_finite() && r.f0_hz > 0.0) {
                    return Err(bad("resonances.f0_hz", r.f0_hz));
                }
                if r.f0_hz >= nyquist_hz {
                    return Err(SimError::AboveNyquist {
                        channel: ch.name.clone(),
                        freq_hz: r.f0_hz,
                        nyquist_hz,
                    });
                }
            }
            if let Some(d) = &ch.drift {
                finite("drift.quadratic", d.quadratic)?;
                if let Some(e) = &d.exponential {
                    finite("drift.exponential.amplitude", e.amplitude)?;
                    if !(e.tc_s.is_finite() && e.tc_s > 0.0) {
                        return Err(bad("drift.exponential.tc_s", e.tc_s));
                    }
                }
            }
            if let Some(lp) = &ch.lowpass {
                if !(lp.corner_hz.is_finite() && lp.corner_hz > 0.0 && lp.corner_hz < nyquist_hz) {
                    return Err(bad("lowpass.corner_hz", lp.corner_hz));
                }
                if !(1..=16).contains(&lp.order) {
                    return Err(bad("lowpass.order", f64::from(lp.order)));
                }
            }
            if let Some(d) = &ch.decimator {
                if !(1..=5).contains(&d.stages) {
                    return Err(bad("decimator.stages", f64::from(d.stages)));
                }
                if !(2..=64).contains(&d.factor) {
                    return Err(bad("decimator.factor", f64::from(d.factor)));
                }
            }
            if ch.temperature_coefficient != 0.0 && self.temperature.is_none() {
                return Err(SimError::NoTemperature {
                    channel: ch.name.clone(),
                });
            }
        }
        if let Some(t) = &self.temperature {
            let bad = |field: &'static str, value: f64| SimError::InvalidParameter {
                channel: t.name.clone(),
                field,
                value,
            };
            for (field, v) in [("start_degc", t.start_degc), ("rise_degc", t.rise_degc)] {
                if !v.is_finite() {
                    return Err(bad(field, v));
                }
            }
            if !(t.warmup_s.is_finite() && t.warmup_s > 0.0) {
                return Err(bad("warmup_s", t.warmup_s));
            }
            if !(t.noise_degc.is_finite() && t.noise_degc >= 0.0) {
                return Err(bad("noise_degc", t.noise_degc));
            }
            if let Some(gm) = &t.wander {
                if !(gm.sigma.is_finite() && gm.sigma >= 0.0) {
                    return Err(bad("wander.sigma", gm.sigma));
                }
                if !(gm.tc_s.is_finite() && gm.tc_s > 0.0) {
                    return Err(bad("wander.tc_s", gm.tc_s));
                }
            }
        }
        Ok(())
    }
}
