//! The noise terms of IEEE Std 952-1997 Annex C (gyros) and IEEE Std 1554-2005 (accelerometers):
//! what each contributes to the Allan variance σ²(τ) and to the two-sided PSD S(f) of a rate signal.
//!
//! Everything is per unit squared coefficient, in SI (rate in rad/s or m/s², τ in s, f in Hz), so
//! the model is linear in the squared coefficients c = Q², N², B², K², R² and a fit can keep them
//! non-negative. The AV and PSD of each term are linked by
//! σ²(τ) = 4∫₀^∞ S(f)·sin⁴(πfτ)/(πfτ)² df; `tests/integration/model.rs` checks the link numerically
//! for every term, and says where it holds only in a limit (flicker's plateau, rate ramp).

use std::f64::consts::{LN_2, PI};

use super::alias::sampled_power_law;

/// Number of model columns: the five base terms, then one slot for an effect the residual
/// analysis adds ([`crate::model::EffectShape`]); its basis is zero when there is none. Defined
/// here, with the terms, so that the fit and the correlation model both depend on this module and
/// not on each other.
pub(crate) const TERMS: usize = 6;
/// Number of base terms ([`Term::ALL`]); columns from here on are effects.
pub(crate) const BASE: usize = 5;
/// The effect's column.
pub(crate) const EFFECT: usize = 5;

/// One of the five base terms of the IEEE model, in order of increasing AV slope.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Term {
    /// Quantisation noise Q (rad, m/s): white noise of the integrated angle or velocity.
    Quantization,
    /// Angle / velocity random walk N (rad/√s, m/s/√s): white rate noise.
    RandomWalk,
    /// Bias instability B (rad/s, m/s²): flicker (1/f) rate noise.
    BiasInstability,
    /// Rate / acceleration random walk K (rad/s/√s, m/s²/√s): integrated white rate noise.
    RateRandomWalk,
    /// Rate ramp R (rad/s², m/s³): a steady drift of the rate.
    RateRamp,
}

/// (2 ln 2)/π: the flicker AV plateau per B², σ(τ) ≈ 0.664·B.
pub const FLICKER_PLATEAU: f64 = 2.0 * LN_2 / PI;

impl Term {
    /// All five, in order of AV slope (−2, −1, 0, +1, +2).
    pub const ALL: [Term; 5] = [
        Term::Quantization,
        Term::RandomWalk,
        Term::BiasInstability,
        Term::RateRandomWalk,
        Term::RateRamp,
    ];

    /// Position in [`Term::ALL`] (and in a [`Coefficients`] array).
    pub fn index(self) -> usize {
        self as usize
    }

    /// The letter IEEE 952 uses.
    pub fn symbol(self) -> &'static str {
        match self {
            Term::Quantization => "Q",
            Term::RandomWalk => "N",
            Term::BiasInstability => "B",
            Term::RateRandomWalk => "K",
            Term::RateRamp => "R",
        }
    }

    /// Long name; `gyro` picks angle/rate wording over velocity/acceleration wording.
    pub fn name(self, gyro: bool) -> &'static str {
        match (self, gyro) {
            (Term::Quantization, _) => "quantisation noise",
            (Term::RandomWalk, true) => "angle random walk",
            (Term::RandomWalk, false) => "velocity random walk",
            (Term::BiasInstability, _) => "bias instability",
            (Term::RateRandomWalk, true) => "rate random walk",
            (Term::RateRandomWalk, false) => "acceleration random walk",
            (Term::RateRamp, true) => "rate ramp",
            (Term::RateRamp, false) => "acceleration ramp",
        }
    }

    /// Log-log slope of σ²(τ).
    pub fn avar_slope(self) -> i8 {
        self as i8 - 2
    }

    /// Power-law exponent α of the rate PSD, S(f) ∝ f^α (Q: +2, N: 0, B: −1, K: −2, R: −3): what
    /// the Allan-variance EDF depends on.
    pub fn alpha(self) -> i8 {
        match self {
            Term::Quantization => 2,
            Term::RandomWalk => 0,
            Term::BiasInstability => -1,
            Term::RateRandomWalk => -2,
            Term::RateRamp => -3,
        }
    }

    /// σ²(τ) per unit squared coefficient.
    ///
    /// Quantisation 3/τ² (exact for white angle error of variance Q², sampled), random walk 1/τ,
    /// flicker the plateau (2 ln 2)/π (exact for a 1/f spectrum over all f > 0; a spectrum cut at
    /// the Nyquist frequency reads about 10 % more at τ = τ₀ and < 1 % from τ = 4τ₀), rate random
    /// walk τ/3 (continuous time; a discrete random walk of the rate adds 1/(2m²) relative), ramp
    /// τ²/2 (exact for a deterministic ramp).
    pub fn avar_unit(self, tau: f64) -> f64 {
        match self {
            Term::Quantization => 3.0 / (tau * tau),
            Term::RandomWalk => 1.0 / tau,
            Term::BiasInstability => FLICKER_PLATEAU,
            Term::RateRandomWalk => tau / 3.0,
            Term::RateRamp => tau * tau / 2.0,
        }
    }

    /// Two-sided PSD S(f) per unit squared coefficient at f > 0 (unit²/Hz); `tau0` = 1/rate is
    /// only used by quantisation, whose exact form (4/τ₀)·sin²(πfτ₀) is what a differentiated
    /// sampled angle has (≈ (2πf)²τ₀ well below Nyquist).
    ///
    /// Rate ramp: IEEE 952 lists R²/(2πf)³, but that spectrum is not the transform of the τ²/2
    /// Allan variance (the link integral diverges logarithmically at f → 0) and a deterministic
    /// ramp leaves only the lowest Welch bins, which a fit excludes. It is kept so that a ramp-like
    /// random process (flicker walk) can be fitted, with that caveat.
    pub fn psd_unit(self, f: f64, tau0: f64) -> f64 {
        let w = 2.0 * PI * f;
        match self {
            Term::Quantization => {
                let s = (PI * f * tau0).sin();
                4.0 * s * s / tau0
            }
            Term::RandomWalk => 1.0,
            Term::BiasInstability => 1.0 / w,
            Term::RateRandomWalk => 1.0 / (w * w),
            Term::RateRamp => 1.0 / (w * w * w),
        }
    }
}

impl Term {
    /// Two-sided PSD per unit squared coefficient of the *sampled* signal at 0 < f < fs/2, for a
    /// sensor whose samples are mean rates over each sample interval (delta angle / τ₀): the
    /// continuous spectrum through sinc²(πfτ₀) and folded at fs (see `alias.rs`). Equal to
    /// [`Term::psd_unit`] for N and Q (Q's form already is that of a sampled angle), and within
    /// 1 % of it below fs/10 for B, K, R; near Nyquist B reads ≈ 0.8× and K ≈ 0.7× the
    /// continuous form. This is what a Welch spectrum of such data estimates, and the sampled
    /// process has exactly the continuous Allan variance at every τ = mτ₀.
    pub fn psd_sampled_unit(self, f: f64, rate_hz: f64) -> f64 {
        match self {
            Term::Quantization | Term::RandomWalk => self.psd_unit(f, 1.0 / rate_hz),
            Term::BiasInstability => sampled_power_law(f, rate_hz, 1),
            Term::RateRandomWalk => sampled_power_law(f, rate_hz, 2),
            Term::RateRamp => sampled_power_law(f, rate_hz, 3),
        }
    }
}

impl std::fmt::Display for Term {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.symbol())
    }
}

/// The five IEEE coefficients of one channel, in SI: Q (rad or m/s), N (rad/√s or m/s/√s), B (rad/s
/// or m/s²), K (rad/s/√s or m/s²/√s), R (rad/s² or m/s³). Zero means the term is absent.
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Coefficients {
    pub q: f64,
    pub n: f64,
    pub b: f64,
    pub k: f64,
    pub r: f64,
}

impl Coefficients {
    /// Coefficient of `term`.
    pub fn get(&self, term: Term) -> f64 {
        self.as_array()[term.index()]
    }

    /// Sets the coefficient of `term`.
    pub fn set(&mut self, term: Term, value: f64) {
        match term {
            Term::Quantization => self.q = value,
            Term::RandomWalk => self.n = value,
            Term::BiasInstability => self.b = value,
            Term::RateRandomWalk => self.k = value,
            Term::RateRamp => self.r = value,
        }
    }

    /// In [`Term::ALL`] order.
    pub fn as_array(&self) -> [f64; 5] {
        [self.q, self.n, self.b, self.k, self.r]
    }

    /// From coefficients in [`Term::ALL`] order.
    pub fn from_array(c: [f64; 5]) -> Coefficients {
        Coefficients {
            q: c[0],
            n: c[1],
            b: c[2],
            k: c[3],
            r: c[4],
        }
    }

    /// Model Allan variance σ²(τ).
    pub fn avar(&self, tau: f64) -> f64 {
        Term::ALL
            .iter()
            .map(|&t| self.get(t).powi(2) * t.avar_unit(tau))
            .sum()
    }

    /// Model two-sided PSD S(f) at f > 0; `tau0` = 1/rate (for quantisation).
    pub fn psd(&self, f: f64, tau0: f64) -> f64 {
        Term::ALL
            .iter()
            .map(|&t| self.get(t).powi(2) * t.psd_unit(f, tau0))
            .sum()
    }

    /// Model two-sided PSD of the *sampled* signal at 0 < f < fs/2 ([`Term::psd_sampled_unit`]):
    /// what a Welch spectrum of samples at `rate_hz` estimates.
    pub fn psd_sampled(&self, f: f64, rate_hz: f64) -> f64 {
        Term::ALL
            .iter()
            .map(|&t| self.get(t).powi(2) * t.psd_sampled_unit(f, rate_hz))
            .sum()
    }
}

/// First-order Gauss–Markov process: stationary variance σ² (SI rate units²) and correlation time
/// Tc (s); the exponentially correlated noise of many MEMS biases.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GaussMarkov {
    /// Standard deviation σ of the process (rad/s or m/s²).
    pub sigma: f64,
    /// Correlation time Tc, s.
    pub tc_s: f64,
}

impl GaussMarkov {
    /// σ²(τ) = (2σ²Tc/τ)·[1 − (Tc/2τ)(3 − 4e^(−τ/Tc) + e^(−2τ/Tc))]. For τ ≪ Tc it rises as
    /// (2/3)σ²τ/Tc, a rate random walk with K² = 2σ²/Tc; for τ ≫ Tc it falls as 2σ²Tc/τ, white
    /// noise with N² = 2σ²Tc.
    pub fn avar(&self, tau: f64) -> f64 {
        let (s2, tc) = (self.sigma * self.sigma, self.tc_s);
        let x = tau / tc;
        if x < 0.5 {
            return 2.0 * s2 / x * small_x_bracket(x);
        }
        let bracket = 1.0 - (3.0 - 4.0 * (-x).exp() + (-2.0 * x).exp()) / (2.0 * x);
        2.0 * s2 / x * bracket
    }

    /// Two-sided PSD 2σ²Tc/(1 + (2πfTc)²) (a Lorentzian; ∫ over all f gives σ²).
    pub fn psd(&self, f: f64) -> f64 {
        let w = 2.0 * PI * f * self.tc_s;
        2.0 * self.sigma * self.sigma * self.tc_s / (1.0 + w * w)
    }
}

/// 1 − (3 − 4e^(−x) + e^(−2x))/(2x) by its Taylor series Σ_{k≥3} (−1)^(k+1)(2^k − 4)/(2·k!)·x^(k−1)
/// = x²/3 − x³/4 + 7x⁴/60 − …: the closed form loses digits to cancellation for small x (half of
/// them at x = 1e-4). Thirty terms are exact to rounding for x < 0.5.
fn small_x_bracket(x: f64) -> f64 {
    let mut sum = 0.0;
    // p = x^(k−1)/k!, starting at k = 3.
    let mut p = x * x / 6.0;
    let mut two_k = 8.0;
    for k in 3..30 {
        let sign = if k % 2 == 1 { 1.0 } else { -1.0 };
        sum += sign * (two_k - 4.0) / 2.0 * p;
        p *= x / f64::from(k + 1);
        two_k *= 2.0;
    }
    sum
}

/// A sinusoidal rate Ω₀·sin(2πf₀t + φ): vibration, a fan, a mains pickup.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Sinusoid {
    /// Amplitude Ω₀ (rad/s or m/s²).
    pub amplitude: f64,
    /// Frequency f₀, Hz.
    pub freq_hz: f64,
}

impl Sinusoid {
    /// σ²(τ) = Ω₀²·sin⁴(πf₀τ)/(πf₀τ)²: zero at τ = k/f₀, peaks near τ ≈ 0.37/f₀.
    pub fn avar(&self, tau: f64) -> f64 {
        let x = PI * self.freq_hz * tau;
        if x == 0.0 {
            return 0.0;
        }
        let s = x.sin();
        self.amplitude * self.amplitude * s.powi(4) / (x * x)
    }

    /// The Allan variance of the line point-sampled at `rate_hz` (the amplitude the samples hold,
    /// the crate's convention for lines): the mean of m point samples of a sine has the
    /// amplitude Ω₀·sin(x)/(m·sin(x/m)), x = πf₀τ, where the continuous mean has Ω₀·sin(x)/x, so
    /// this is [`Sinusoid::avar`] over sinc²(πf₀/rate).
    pub fn avar_point_sampled(&self, tau: f64, rate_hz: f64) -> f64 {
        let half = PI * self.freq_hz / rate_hz;
        let sinc = if half == 0.0 { 1.0 } else { half.sin() / half };
        self.avar(tau) / (sinc * sinc)
    }

    /// Power of each of the two spectral lines of the two-sided PSD (at ±f₀): Ω₀²/4. A one-sided
    /// spectrum shows Ω₀²/2 at f₀.
    pub fn line_power(&self) -> f64 {
        self.amplitude * self.amplitude / 4.0
    }
}

impl std::str::FromStr for Term {
    type Err = String;

    /// A term by its symbol (`Q`, `N`, `B`, `K`, `R`, any case).
    fn from_str(s: &str) -> Result<Term, String> {
        Term::ALL
            .iter()
            .copied()
            .find(|t| t.symbol().eq_ignore_ascii_case(s.trim()))
            .ok_or_else(|| format!("unknown term {s:?}: expected one of Q, N, B, K, R"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn slopes_match_the_table() {
        for t in Term::ALL {
            let (a, b) = (t.avar_unit(1.0), t.avar_unit(10.0));
            let slope = (b / a).log10();
            assert!((slope - f64::from(t.avar_slope())).abs() < 1e-12, "{t}");
        }
        assert!((FLICKER_PLATEAU.sqrt() - 0.664).abs() < 5e-4);
    }

    #[test]
    fn quantisation_psd_tends_to_the_low_frequency_form() {
        // (4/τ₀)sin²(πfτ₀) = (2πf)²τ₀·(1 − x²/3 + 2x⁴/45 − …), x = πfτ₀ = 0.031 here: the
        // next term is 4.3e-8.
        let tau0 = 0.01;
        let f = 1.0;
        let approx = (2.0 * PI * f).powi(2) * tau0;
        let rel = Term::Quantization.psd_unit(f, tau0) / approx - 1.0;
        assert!((rel + (PI * f * tau0).powi(2) / 3.0).abs() < 1e-7, "{rel}");
    }

    #[test]
    fn gauss_markov_limits() {
        let gm = GaussMarkov {
            sigma: 2.0,
            tc_s: 10.0,
        };
        // τ ≫ Tc: white noise with N² = 2σ²Tc.
        let tau = 1e5;
        assert!((gm.avar(tau) / (2.0 * 4.0 * 10.0 / tau) - 1.0).abs() < 2e-4);
        // τ ≪ Tc: σ²·(2/3)(τ/Tc); the series branch and the closed form agree at the switch.
        assert!((gm.avar(1e-3) / (4.0 * (2.0 / 3.0) * 1e-4) - 1.0).abs() < 1e-4);
        // The series and the closed form agree where one hands over to the other.
        let x: f64 = 0.5;
        let closed = 1.0 - (3.0 - 4.0 * (-x).exp() + (-2.0 * x).exp()) / (2.0 * x);
        assert!((small_x_bracket(x) / closed - 1.0).abs() < 1e-13);
        assert!((small_x_bracket(1e-3) / (1e-6 / 3.0 - 1e-9 / 4.0) - 1.0).abs() < 1e-6);
        assert!((gm.psd(0.0) - 2.0 * 4.0 * 10.0).abs() < 1e-12);
    }

    #[test]
    fn coefficients_round_trip() {
        let mut c = Coefficients::default();
        for (i, t) in Term::ALL.iter().enumerate() {
            c.set(*t, i as f64 + 1.0);
        }
        assert_eq!(c.as_array(), [1.0, 2.0, 3.0, 4.0, 5.0]);
        assert_eq!(Coefficients::from_array(c.as_array()), c);
        let expected =
            3.0 / 4.0 + 4.0 / 2.0 + 9.0 * FLICKER_PLATEAU + 16.0 * 2.0 / 3.0 + 25.0 * 2.0;
        assert!((c.avar(2.0) - expected).abs() < 1e-12);
    }
}
