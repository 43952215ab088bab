//! Stochastic effects that enter the fits as one more column ([`EffectShape`]): their power is
//! fitted with the base terms, their shape parameters are profiled by the loop.

use std::f64::consts::PI;

use serde::{Deserialize, Serialize};

use crate::model::{EffectShape, GaussMarkov};

/// First-order Gauss–Markov process of correlation time `tc_s`, per unit variance: a hump in the
/// Allan deviation (slope +½ below Tc, −½ above), a Lorentzian knee in the spectrum.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct GaussMarkov1 {
    pub tc_s: f64,
}

impl GaussMarkov1 {
    fn unit(&self) -> GaussMarkov {
        GaussMarkov {
            sigma: 1.0,
            tc_s: self.tc_s,
        }
    }
}

impl EffectShape for GaussMarkov1 {
    fn avar_unit(&self, tau_s: f64, _rate_hz: f64) -> f64 {
        self.unit().avar(tau_s)
    }
    fn psd_unit(&self, f_hz: f64, rate_hz: f64) -> f64 {
        // Samples are interval means: the continuous spectrum through sinc².
        self.unit().psd(f_hz) * sinc2(f_hz / rate_hz)
    }
    fn alpha_at(&self, tau_s: f64) -> i8 {
        if tau_s < self.tc_s {
            -2
        } else {
            0
        }
    }
}

fn sinc2(x: f64) -> f64 {
    if x == 0.0 {
        1.0
    } else {
        let a = PI * x;
        (a.sin() / a).powi(2)
    }
}

/// Which output of a second-order system driven by white noise the sensor sees: its spectrum
/// below the peak.
///
/// Why two: the displacement-like output ([`ResonanceForm::LowPass`], what a mount transmits of a
/// broadband base excitation) keeps a plateau below f₀ at 1/q² of its peak, and for a strong
/// resonance of moderate Q that plateau is white noise of the same order as the sensor's own: a
/// flight controller's accelerometers on a frame resonance of Q 18 at 68 Hz (σ 0.03 m/s², 70
/// µg/√Hz sensor) had N read 0.65–0.82× the truth, the plateau taking the rest, with intervals
/// excluding it. The velocity-like output ([`ResonanceForm::BandPass`], a gyro's rate of a
/// torsional mode, or any mode excited by narrowband forcing) has no plateau: it falls as f²
/// below the peak. The data choose (same parameters; the loop compares the two at the best f₀
/// and Q of the first and searches again with the second where it fits better).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ResonanceForm {
    /// ∝ f₀⁴/((f₀² − f²)² + (f·f₀/q)²): unit gain at 0 Hz, q² at the peak.
    #[default]
    LowPass,
    /// ∝ (f·f₀/q)²/((f₀² − f²)² + (f·f₀/q)²): 0 at 0 Hz, 1 at the peak.
    BandPass,
}

impl ResonanceForm {
    pub fn name(self) -> &'static str {
        match self {
            ResonanceForm::LowPass => "low-pass",
            ResonanceForm::BandPass => "band-pass",
        }
    }
}

/// A narrowband resonance: white noise through a second-order system of centre `f0_hz` and
/// quality factor `q` (half-power width ≈ f0/q), per unit variance, seen in `form`. Its two-sided
/// spectrum is ∝ f0⁴/((f0² − f²)² + (f·f0/q)²) (low-pass) or (f·f0/q)²/((f0² − f²)² + (f·f0/q)²)
/// (band-pass); the normalisation and the Allan variance (through σ²(τ) = 4∫S(f)·sin⁴(πfτ)/(πfτ)²
/// df) are integrated numerically on a grid that resolves the peak.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Resonance {
    pub f0_hz: f64,
    pub q: f64,
    pub form: ResonanceForm,
    #[serde(skip)]
    grid: Vec<(f64, f64)>,
    #[serde(skip)]
    norm: f64,
}

impl Resonance {
    /// The low-pass shape for samples at `rate_hz` (the integrals run to Nyquist).
    pub fn new(f0_hz: f64, q: f64, rate_hz: f64) -> Resonance {
        Resonance::with_form(f0_hz, q, ResonanceForm::LowPass, rate_hz)
    }

    /// The shape in `form` for samples at `rate_hz`.
    pub fn with_form(f0_hz: f64, q: f64, form: ResonanceForm, rate_hz: f64) -> Resonance {
        let nyquist = rate_hz / 2.0;
        let width = f0_hz / q;
        // Log-spaced over the band, dense (0.02 widths) within ±20 widths of the centre.
        let mut f: Vec<f64> = (0..=2000)
            .map(|k| nyquist * 1e-6f64.powf(1.0 - f64::from(k) / 2000.0))
            .collect();
        f.extend((-1000..=1000).map(|k| f0_hz + 0.02 * width * f64::from(k)));
        f.retain(|&x| x > 0.0 && x <= nyquist);
        f.sort_by(f64::total_cmp);
        f.dedup();
        let raw = |x: f64| Resonance::response(f0_hz, q, form, x);
        // Trapezoid weights.
        let grid: Vec<(f64, f64)> = (0..f.len())
            .map(|i| {
                let lo = if i == 0 { 0.0 } else { (f[i] + f[i - 1]) / 2.0 };
                let hi = if i + 1 == f.len() {
                    nyquist
                } else {
                    (f[i] + f[i + 1]) / 2.0
                };
                (f[i], raw(f[i]) * (hi - lo))
            })
            .collect();
        let one_sided: f64 = grid.iter().map(|g| g.1).sum();
        Resonance {
            f0_hz,
            q,
            form,
            grid,
            norm: 1.0 / (2.0 * one_sided),
        }
    }

    /// |H(f)|² of the second-order system's output in `form`, unnormalised.
    fn response(f0_hz: f64, q: f64, form: ResonanceForm, x: f64) -> f64 {
        let d = f0_hz * f0_hz - x * x;
        let damping = (x * f0_hz / q).powi(2);
        let numerator = match form {
            ResonanceForm::LowPass => f0_hz.powi(4),
            ResonanceForm::BandPass => damping,
        };
        numerator / (d * d + damping)
    }
}

impl EffectShape for Resonance {
    fn avar_unit(&self, tau_s: f64, _rate_hz: f64) -> f64 {
        4.0 * self.norm
            * self
                .grid
                .iter()
                .map(|&(f, w)| {
                    let x = PI * f * tau_s;
                    w * x.sin().powi(4) / (x * x)
                })
                .sum::<f64>()
    }
    fn psd_unit(&self, f_hz: f64, rate_hz: f64) -> f64 {
        let h2 = self.norm * Resonance::response(self.f0_hz, self.q, self.form, f_hz);
        match self.form {
            // A displacement's spectrum falls as f⁻⁴ above the peak: point samples of it fold
            // nothing, as the sampled process assumes.
            ResonanceForm::LowPass => h2,
            // A rate's falls only as f⁻²: its samples are taken as interval means (a sensor's
            // own averaging or anti-alias filter), through sinc².
            ResonanceForm::BandPass => h2 * sinc2(f_hz / rate_hz),
        }
    }
    fn alpha_at(&self, _tau_s: f64) -> i8 {
        0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The resonance's spectrum integrates to its unit variance, and its Allan variance at the
    /// shortest τ is close to the variance of the τ-means (≈ 1 for τ ≪ 1/f0).
    #[test]
    fn resonance_is_normalised_and_its_allan_variance_follows() {
        let r = Resonance::new(5.0, 10.0, 200.0);
        let mut total = 0.0;
        let df = 1e-3;
        let mut f = df / 2.0;
        while f < 100.0 {
            total += 2.0 * r.psd_unit(f, 200.0) * df;
            f += df;
        }
        assert!((total - 1.0).abs() < 2e-3, "{total}");
        // τ ≪ 1/f0: differences of τ-means are ≈ x' τ; σ²(τ) → 0. τ = half period: large.
        assert!(r.avar_unit(1e-4, 200.0) < 1e-3);
        let peak = r.avar_unit(0.074, 200.0);
        assert!(peak > 0.5 && peak < 1.5, "{peak}");
        // Far beyond the resonance it behaves as white noise of density S(0) = norm: 2S(0)·... ∝ 1/τ.
        let (a, b) = (r.avar_unit(100.0, 200.0), r.avar_unit(1000.0, 200.0));
        assert!((a / b - 10.0).abs() < 0.5, "{a} {b}");
    }

    /// The band-pass form integrates to its unit variance, peaks at f₀ and has no plateau: below
    /// the peak it falls as f², where the low-pass form stays at 1/q² of its peak.
    #[test]
    fn the_band_pass_resonance_has_no_plateau() {
        let (f0, q, fs) = (5.0, 10.0, 200.0);
        let r = Resonance::with_form(f0, q, ResonanceForm::BandPass, fs);
        let mut total = 0.0;
        let df = 1e-3;
        let mut f = df / 2.0;
        while f < 100.0 {
            // The continuous process's spectrum: without the sampling's sinc².
            total += 2.0 * r.psd_unit(f, fs) / sinc2(f / fs) * df;
            f += df;
        }
        assert!((total - 1.0).abs() < 2e-3, "{total}");
        let peak = r.psd_unit(f0, fs);
        assert!(peak > r.psd_unit(0.98 * f0, fs) && peak > r.psd_unit(1.02 * f0, fs));
        let (a, b) = (r.psd_unit(0.05, fs), r.psd_unit(0.1, fs));
        assert!((b / a - 4.0).abs() < 0.01, "{a} {b}");
        let low = Resonance::new(f0, q, fs);
        let plateau = low.psd_unit(0.05, fs) / low.psd_unit(f0, fs);
        assert!((plateau * q * q - 1.0).abs() < 1e-3, "{plateau}");
        // (f·f₀/q)²/f₀⁴ = 1.6e-7 at 0.02 Hz, where the low-pass form stays at 1/q² = 0.01.
        assert!(r.psd_unit(0.02, fs) / peak < 2e-7);
    }

    /// The Gauss–Markov shape integrates to its unit variance.
    #[test]
    fn gauss_markov_is_normalised() {
        let g = GaussMarkov1 { tc_s: 2.0 };
        let mut total = 0.0;
        let df = 1e-4;
        let mut f = df / 2.0;
        while f < 50.0 {
            total += 2.0 * g.psd_unit(f, 1e9) * df;
            f += df;
        }
        assert!((total - 1.0).abs() < 5e-3, "{total}");
    }
}
