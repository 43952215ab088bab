//! The output's resolution: how much of the white noise N is the rounding of a digital output.
//!
//! A rate sensor's converter rounds each sample to a whole number of steps h. While the noise
//! spans a few steps, the rounding error is uniform on ±h/2, independent of the signal and white:
//! h²/12 of variance per sample, which the fits cannot tell from the sensor's own white noise and
//! take into N (N² = σ²/f_s for white samples of variance σ², so the rounding adds
//! r = h/√(12·f_s) in quadrature). The N reported stays the output's, which is what a navigation
//! filter fed by this output sees; a [`FitWarning::OutputResolution`] says how much of it is
//! rounding and what the sensor's N is without it, where that shift is larger than N's own
//! interval.
//!
//! **How far the subtraction holds** (Gaussian samples of σ rounded, 4·10⁶ per point): where the
//! mean wanders over several steps during the record (a bias that drifts, slow noise), σ² + h²/12
//! is the output variance within 0.3 % of σ up to h = 3σ. Where the mean stays at one place on
//! the grid, it holds within 0.1 % up to h = 1.5σ (1.38 of the output's σ) and then fails: at
//! h = 2σ the output's σ is 1.140σ, not 1.155σ; at 3σ 1.096σ (h = 2.74 output σ); at 4σ 0.854σ,
//! less noise than the sensor has. The step is measured against the output's white σ, the only
//! one known, so: up to [`SUBTRACTION_HOLDS_TO_STEPS`] the sensor's N is √(N² − r²); up to
//! [`UPPER_BOUND_HOLDS_TO_STEPS`] it lies between √(N² − r²) and N; beyond, the quantiser may hide
//! noise, N is no upper bound, and the other terms describe the quantised output as well.
//!
//! **An integrated angle rounded instead** (IEEE 952's quantisation, what [`Term::Quantization`]
//! models) leaves the output on a grid too, of step h = √12·Q·f_s, but its error is differenced:
//! blue rate noise, not white, and N does not contain it. Where the fits kept Q at that value
//! (within ×/÷ 1.5), the grid is taken as that angle's and nothing is said; where they neither
//! kept nor excluded it (its upper limit reaches half that value), the warning names both readings.

use super::combine::{upper_limit_at, Combined, FitWarning};
use super::result::NoiseFit;
use super::terms::Term;

/// Up to this many output σ per step the sensor's N is √(N² − r²).
pub const SUBTRACTION_HOLDS_TO_STEPS: f64 = 1.3;
/// Up to this many output σ per step the output's N is an upper bound of the sensor's.
pub const UPPER_BOUND_HOLDS_TO_STEPS: f64 = 2.7;

/// The warning for a channel whose samples lie on a grid of `step` (SI, the quality screen's
/// smallest step between samples) at `rate_hz`, given its combined result and the two fits (for
/// Q's upper limit). `None` where the rounding shifts N by less than N's own 1σ half-width, where
/// N was not kept, or where the fits' Q accounts for the grid.
pub fn rounding_warning(
    step: f64,
    rate_hz: f64,
    combined: &Combined,
    allan: Option<&NoiseFit>,
    spectrum: Option<&NoiseFit>,
) -> Option<FitWarning> {
    if !(step > 0.0 && step.is_finite() && rate_hz > 0.0) {
        return None;
    }
    let n = combined.get(Term::RandomWalk)?;
    let rounding_n = step / (12.0 * rate_hz).sqrt();
    let shift = n.value - (n.value.powi(2) - rounding_n.powi(2)).max(0.0).sqrt();
    // At 1σ whatever the intervals' confidence: whether to warn must not depend on it.
    let half_width = (n.one_sigma.1 - n.one_sigma.0) / 2.0;
    if shift.is_nan() || shift <= half_width {
        return None;
    }
    // The angle quantiser's Q for this grid, and whether the fits kept or allow it.
    let angle_q = step / (12f64.sqrt() * rate_hz);
    if let Some(q) = combined.get(Term::Quantization) {
        let ratio = q.value / angle_q;
        if ratio > 1.0 / 1.5 && ratio < 1.5 {
            return None;
        }
    }
    let angle_possible = combined.get(Term::Quantization).is_none()
        && upper_limit_at(allan, spectrum, Term::Quantization, true)
            .is_some_and(|u| u >= 0.5 * angle_q);
    let sigma_out = n.value * rate_hz.sqrt();
    let steps_per_sigma = step / sigma_out;
    let without = |x: f64| (x.powi(2) - rounding_n.powi(2)).max(0.0).sqrt();
    let (n_lo, n_hi) = if steps_per_sigma <= SUBTRACTION_HOLDS_TO_STEPS {
        (without(n.lo), Some(without(n.hi)))
    } else if steps_per_sigma <= UPPER_BOUND_HOLDS_TO_STEPS {
        (without(n.lo), Some(n.hi))
    } else {
        (without(n.lo), None)
    };
    Some(FitWarning::OutputResolution {
        step,
        steps_per_sigma,
        rounding_n,
        share: (rounding_n / n.value).powi(2),
        n_without: without(n.value),
        n_lo,
        n_hi,
        angle_q: angle_possible.then_some(angle_q),
    })
}

/// Output σ per step from which an angle quantiser's rounding error is no longer white: the
/// angle moves less than a step per sample, so the error stays near one value for several samples
/// and the differenced (rate) error falls below IEEE 952's white-angle-error form
/// (4Q²/τ₀)·sin²(πfτ₀) at high frequency. Measured on 2·10⁶ samples of white rate noise whose
/// integral is rounded to steps of r per-sample angle σ (Welch, 4096-sample segments, spectrum over
/// N² plus that form with Q = step/√12): r ≤ 1.5 within 0.3 % everywhere; r = 2 −0.8 % over
/// 40–50 Hz at 100 Hz; r = 2.5 −2 % over 30–40 Hz and −3 % over 40–50 Hz; r = 3.5 (the output on
/// five levels) −12 % and −15 %, with +5 % over 10–20 Hz. That deficit is what a low-pass
/// detector reads as a filter's roll-off (`scripts/angle_quantiser_spectrum.py` reruns the study).
pub const ANGLE_ERROR_CORRELATED_FROM_STEPS: f64 = 2.0;

/// Output σ per step of a grid that is an angle quantiser's, and the N it is measured with:
/// `step` (SI rate, the quality screen's smallest step) at `rate_hz` is the grid of a rounded
/// integrated angle whose Q (step/(√12·fs)) one of the fits kept within ×/÷ 1.5, measured against
/// the white σ of the output (N·√fs, N from the same fit). `None` where no fit kept both Q at that
/// value and N.
pub fn angle_grid_steps_per_sigma(
    step: f64,
    rate_hz: f64,
    allan: Option<&NoiseFit>,
    spectrum: Option<&NoiseFit>,
) -> Option<(f64, f64)> {
    if !(step > 0.0 && step.is_finite() && rate_hz > 0.0) {
        return None;
    }
    let angle_q = step / (12f64.sqrt() * rate_hz);
    [allan, spectrum].into_iter().flatten().find_map(|fit| {
        let q = fit.get(Term::Quantization)?.value;
        let n = fit.get(Term::RandomWalk)?.value;
        let ratio = q / angle_q;
        (ratio > 1.0 / 1.5 && ratio < 1.5 && n > 0.0).then(|| (step / (n * rate_hz.sqrt()), n))
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::combine::CombinedTerm;
    use crate::model::Domain;

    fn combined(n: f64, rel: f64, q: Option<f64>) -> Combined {
        let term = |term, value: f64| CombinedTerm {
            term,
            value,
            lo: value * (1.0 - rel),
            hi: value * (1.0 + rel),
            source: Domain::Allan,
            hull: false,
            one_sigma: (value * (1.0 - rel), value * (1.0 + rel)),
            ambiguous_with: None,
        };
        let mut terms = vec![term(Term::RandomWalk, n)];
        terms.extend(q.map(|q| term(Term::Quantization, q)));
        Combined {
            terms,
            limits: Vec::new(),
            read_offs: Vec::new(),
            warnings: Vec::new(),
        }
    }

    /// White samples of σ = 1 at 100 Hz (N = 0.1), rounded to h = σ: the output's N is
    /// √(1 + 1/12)·0.1, and the sensor's N without the rounding is 0.1 again.
    #[test]
    fn a_step_of_one_sigma_is_subtracted() {
        let fs = 100.0;
        let n_out = 0.1 * (1.0 + 1.0 / 12.0f64).sqrt();
        let w = rounding_warning(1.0, fs, &combined(n_out, 0.002, None), None, None).unwrap();
        let FitWarning::OutputResolution {
            n_without,
            share,
            steps_per_sigma,
            n_lo,
            n_hi,
            angle_q,
            ..
        } = w
        else {
            panic!("{w:?}")
        };
        assert!((n_without - 0.1).abs() < 1e-12, "{n_without}");
        assert!((share - (1.0 / 12.0) / (1.0 + 1.0 / 12.0)).abs() < 1e-12);
        assert!((steps_per_sigma - 1.0 / (1.0 + 1.0 / 12.0f64).sqrt()).abs() < 1e-12);
        let n_hi = n_hi.unwrap();
        assert!(n_lo < 0.1 && 0.1 < n_hi && n_hi < n_out);
        assert_eq!(angle_q, None, "no fit to allow a Q");
    }

    /// A fine grid (f64 data, or a converter far finer than the noise) shifts N by less than its
    /// interval: nothing to say.
    #[test]
    fn a_fine_grid_says_nothing() {
        assert!(rounding_warning(0.05, 100.0, &combined(0.1, 0.002, None), None, None).is_none());
        assert!(rounding_warning(0.0, 100.0, &combined(0.1, 0.002, None), None, None).is_none());
    }

    /// A coarse grid (h = 2 output σ): only bounds; a coarser one (h = 4): a lower bound only.
    #[test]
    fn a_coarse_grid_gives_bounds() {
        let w = rounding_warning(2.0, 100.0, &combined(0.1, 0.002, None), None, None).unwrap();
        let FitWarning::OutputResolution { n_lo, n_hi, .. } = w else {
            panic!("{w:?}")
        };
        assert!(n_lo < 0.1 * 0.998 && (n_hi.unwrap() - 0.1 * 1.002).abs() < 1e-12);
        let w = rounding_warning(4.0, 100.0, &combined(0.1, 0.002, None), None, None).unwrap();
        let FitWarning::OutputResolution { n_hi, .. } = w else {
            panic!("{w:?}")
        };
        assert_eq!(n_hi, None);
    }

    /// The grid of an angle quantiser whose Q the fits kept: N does not hold its error.
    #[test]
    fn the_grid_of_a_kept_q_is_that_of_an_angle() {
        let fs = 100.0;
        let h = 1.0;
        let q = h / (12f64.sqrt() * fs);
        assert!(
            rounding_warning(h, fs, &combined(0.1, 0.002, Some(q * 1.2)), None, None).is_none()
        );
        assert!(
            rounding_warning(h, fs, &combined(0.1, 0.002, Some(q / 1.4)), None, None).is_none()
        );
        // A Q of another size does not explain the grid (beyond ×/÷ 1.5 either way).
        for other in [q * 1.6, q / 1.6, q * 5.0] {
            assert!(
                rounding_warning(h, fs, &combined(0.1, 0.002, Some(other)), None, None).is_some()
            );
        }
    }
}
