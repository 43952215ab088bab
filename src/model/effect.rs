//! An effect added to the base model by the residual analysis: a stochastic process whose Allan
//! variance and spectrum have a known shape and an unknown power, so that it enters the fits as one
//! more non-negative column, fitted together with the base terms.
//!
//! Shapes with nonlinear parameters (a Gauss–Markov correlation time, a resonance's centre and
//! width) are fixed per call; the caller profiles over them.

/// The shape of an effect, per unit power (variance of the rate it adds, unit²).
pub trait EffectShape: Sync {
    /// Allan variance at τ (s) of samples at `rate_hz`, per unit power.
    fn avar_unit(&self, tau_s: f64, rate_hz: f64) -> f64;
    /// Two-sided PSD at f (Hz), per unit power (integrates to 1 over ±rate/2).
    fn psd_unit(&self, f_hz: f64, rate_hz: f64) -> f64;
    /// The power-law noise type it looks like at τ (α of S_y ∝ f^α: 0 white, −1 flicker, −2
    /// random walk), for the Allan EDF of the points it dominates.
    fn alpha_at(&self, tau_s: f64) -> i8;
}
