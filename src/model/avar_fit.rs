//! The noise model fitted to an Allan-variance curve.
//!
//! Points: every τ of the [`Deviations`] with a positive variance. Basis: σ²(τ) of each term per
//! unit squared coefficient ([`Term::avar_unit`]). Variance of each point: 2μ²/ν with μ the model
//! and ν Greenhall's EDF for the noise type of each term (recomputed from the model at every
//! iteration, not the noise type identified on the data, which at the largest τ rests on a few
//! averages and is unreliable). The rate ramp is taken as deterministic (IEEE 952 describes it
//! so): it raises σ²(τ) but adds no scatter of its own, only through its product with the noise
//! ([`cross_factor`]).
//!
//! Correlation: overlapping Allan variances at neighbouring τ are computed from the same samples,
//! and their errors are strongly correlated, the more so the redder the noise. Measured on 2000
//! simulated records of 2¹⁴ samples per noise type (octave τ, averaged over 2 ≤ m ≤ N/64), the
//! correlation between the estimates one to four octaves apart is
//!
//! | noise | 1 octave | 2 | 3 | 4 | model a + (1 − a)·exp(−(Δ/ℓ)^κ): a, ℓ, κ |
//! |---|---|---|---|---|---|
//! | quantisation (white PM) | 0.40 | 0.52 | 0.53 | 0.51 | 0.5, 0.5, 1.5 |
//! | white (N) | 0.54 | 0.20 | 0.08 | 0.04 | 0, 1.46, 1.25 |
//! | flicker (B) | 0.68 | 0.30 | 0.12 | 0.04 | 0, 1.87, 1.52 |
//! | random walk (K) | 0.89 | 0.67 | 0.49 | 0.35 | 0, 3.89, 1.55 |
//!
//! (Quantisation's floor: every τ's estimate is then mostly 3/τ² times the same sample variance of
//! the angle error.) Ignoring the correlation would count each octave as independent evidence and
//! make the intervals too narrow; modelling it (a working correlation in log₂ τ, mixed per point by
//! the terms' shares) brings the intervals' coverage close to its nominal rate
//! (`tests/integration/model.rs`).

use crate::avar::{edf::edf, Deviations, Statistic};

use super::correlation::Correlation;
use super::fit::{Problem, EFFECT, TERMS};
use super::result::Domain;
use super::select::select_and_fit;
use super::{EffectShape, FitError, FitOptions, NoiseFit, Term};

/// Floor a, correlation length ℓ (octaves) and exponent κ of the error correlation of
/// overlapping Allan variances per term, in [`Term::ALL`] order (table in the module docs).
const CORRELATION: [(f64, f64, f64); TERMS] = [
    (0.5, 0.5, 1.5),
    (0.0, 1.46, 1.25),
    (0.0, 1.87, 1.52),
    (0.0, 3.89, 1.55),
    (0.0, 3.89, 1.55),
    // An effect: correlated as white noise (a Gauss–Markov process is white beyond Tc, where its
    // points carry weight).
    (0.0, 1.46, 1.25),
];

/// The smallest ratio between neighbouring τ the fit uses (a quarter octave).
pub const FIT_TAU_RATIO: f64 = 1.189_207_115_002_721;

/// The points of an Allan curve the fit uses: from the first, each next one at least
/// [`FIT_TAU_RATIO`] beyond the last taken (at most about 13 per decade). Neighbouring τ of a
/// denser grid share almost every sample, so they add little the correlation model does not
/// already discount, while the fit's working correlations grow with the square of the points
/// and their factorisation with the cube: `--taus all` on a 10-min 100-Hz record (30 000 τ)
/// had run out of memory. Every grid up to 13 per decade (octave, 1-2-5, 10 per decade) is used
/// whole; the tables and plots keep the grid asked for.
pub fn fit_points(tau_s: &[f64]) -> Vec<usize> {
    let mut keep: Vec<usize> = Vec::new();
    for (i, &t) in tau_s.iter().enumerate() {
        match keep.last() {
            Some(&k) if t < tau_s[k] * FIT_TAU_RATIO * (1.0 - 1e-9) => {}
            _ => keep.push(i),
        }
    }
    keep
}

/// Fits the IEEE terms to an Allan-variance curve (OADEV or ADEV).
///
/// ```
/// use imunoise::avar::{compute, Confidence, Statistic, TauGrid};
/// use imunoise::model::{fit_avar, FitOptions, Term};
/// # let y: Vec<f64> = imunoise::sim::rng::Rng::new(1).gauss_vec(100_000);
/// // y: rate samples at 100 Hz (white noise of σ = 1 here: N = 1/√100 = 0.1).
/// let d = compute(&y, 100.0, &TauGrid::Octave, Statistic::Oadev, Confidence::OneSigma)?;
/// let fit = fit_avar(&d, &FitOptions::default())?;
/// let n = fit.get(Term::RandomWalk).unwrap();
/// assert!((n.value - 0.1).abs() < 0.005 && n.covers(0.1));
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
///
/// # Errors
/// [`FitError::UnsupportedStatistic`] for other statistics than OADEV and ADEV,
/// [`FitError::TooFewPoints`] with fewer than two positive variances, [`FitError::NoSignal`] if
/// every candidate is zero.
pub fn fit_avar(d: &Deviations, opts: &FitOptions) -> Result<NoiseFit, FitError> {
    fit_avar_with(d, opts, None)
}

/// [`fit_avar`] with an effect's column fitted together with the base terms (in every candidate
/// model; the base terms are chosen around it). The result's [`NoiseFit::effect`] is its
/// amplitude.
pub fn fit_avar_with(
    d: &Deviations,
    opts: &FitOptions,
    effect: Option<&dyn EffectShape>,
) -> Result<NoiseFit, FitError> {
    if !matches!(d.statistic, Statistic::Oadev | Statistic::Adev) {
        return Err(FitError::UnsupportedStatistic(d.statistic));
    }
    let min_tau = opts.min_tau_s.unwrap_or(0.0);
    let keep: Vec<usize> = (0..d.len())
        .filter(|&i| {
            d.variance[i] > 0.0
                && d.variance[i].is_finite()
                && d.tau_s[i] > 0.0
                && d.tau_s[i] >= min_tau * (1.0 - 1e-9)
        })
        .collect();
    let n_samples = samples(d);
    let tau: Vec<f64> = keep.iter().map(|&i| d.tau_s[i]).collect();
    let problem = Problem {
        value: keep.iter().map(|&i| d.variance[i]).collect(),
        // With the sensor's filter known, white noise's column carries the share of its Allan
        // variance the filter leaves at each τ (see `LowPass::white_avar_kept`); the other terms
        // live at frequencies the filter passes.
        basis: keep
            .iter()
            .map(|&i| {
                let t = d.tau_s[i];
                std::array::from_fn(|j| match (j, effect) {
                    (EFFECT, Some(e)) => e.avar_unit(t, d.rate_hz),
                    (EFFECT, None) => 0.0,
                    _ if Term::ALL[j] == Term::RandomWalk => {
                        let kept = opts
                            .lowpass
                            .map_or(1.0, |lp| lp.white_avar_kept(d.rate_hz, d.m[i]));
                        Term::RandomWalk.avar_unit(t) * kept
                    }
                    _ => Term::ALL[j].avar_unit(t),
                })
            })
            .collect(),
        edf: keep
            .iter()
            .map(|&i| {
                std::array::from_fn(|j| {
                    let alpha = match (j, effect) {
                        (EFFECT, Some(e)) => e.alpha_at(d.tau_s[i]),
                        (EFFECT, None) => Term::RandomWalk.alpha(),
                        _ if Term::ALL[j] == Term::RateRamp => {
                            // Deterministic: adds to σ²(τ) but no scatter of its own.
                            return f64::INFINITY;
                        }
                        _ => Term::ALL[j].alpha(),
                    };
                    let e = edf(d.statistic, alpha, d.m[i], n_samples);
                    if e.is_finite() && e > 0.0 {
                        e
                    } else {
                        1.0
                    }
                })
            })
            .collect(),
        cross: keep.iter().map(|&i| cross_factor(d, i)).collect(),
        corr: opts.correlated_points.then(|| {
            let position: Vec<f64> = keep.iter().map(|&i| (d.m[i] as f64).log2()).collect();
            Correlation::per_term(&position, CORRELATION)
        }),
    };
    // Screening: the ramp judged with the scatter of a random walk (see `select.rs`).
    let mut screen = problem.clone();
    let (ramp, walk) = (Term::RateRamp.index(), Term::RateRandomWalk.index());
    for e in &mut screen.edf {
        e[ramp] = e[walk];
    }
    screen.cross.clear();
    let forced = if effect.is_some() { 1 << EFFECT } else { 0 } | opts.required_mask();
    select_and_fit(
        &problem,
        &screen,
        &tau,
        opts.mask(),
        forced,
        opts,
        Domain::Allan,
    )
}

/// Variance of the ramp × noise cross term of point i per unit μ_R·μ_noise.
///
/// With a ramp, each difference of τ-averages is Rτ + δ_j, so σ̂² gains Rτ·mean(δ_j), of variance
/// 2μ_R·Var(mean δ). For the non-overlapping estimator the mean telescopes to
/// (ȳ_last − ȳ_first)/M: variance 4μ_Rμ_N/M² for white noise. For the overlapping one, mean(δ)
/// is a weighted sum of the samples, whose weights are the difference of two trapezoids m apart;
/// summing their squares for white noise gives, with r = M/m, Var(mean δ)/μ_N = (4/3)/r² for
/// r ≥ 2 (the first and last m averages), (4/3 − (2 − r)³/3)/r² for 1 ≤ r ≤ 2 and 2 − r for
/// r ≤ 1 (checked against the explicit sum of squared weights in the tests). Carried on below
/// r = 2 as (4/3)/r², the first form put 190 times the cross variance on the last octave's point
/// of a 6-h record (r = 0.06): its EDF fell to 0.02, where the cube-root residual means nothing,
/// and a clean record read a lack of fit there. Negligible at short τ, the term dominates the scatter of the
/// longest τ, where M is a few m. The white-noise form is used for any noise (red noise makes the
/// two ends of the record differ more: an underestimate there).
fn cross_factor(d: &Deviations, i: usize) -> f64 {
    let (m, big_m) = (d.m[i] as f64, d.n_terms[i] as f64);
    if big_m <= 0.0 {
        return 0.0;
    }
    match d.statistic {
        Statistic::Oadev => 2.0 * overlapping_mean_difference_variance(big_m / m),
        _ => 4.0 / (big_m * big_m),
    }
}

/// Var(mean δ)/μ_N of the overlapping estimator for white noise, r = M/m (see [`cross_factor`]).
fn overlapping_mean_difference_variance(r: f64) -> f64 {
    if r >= 2.0 {
        4.0 / 3.0 / (r * r)
    } else if r >= 1.0 {
        (4.0 / 3.0 - (2.0 - r).powi(3) / 3.0) / (r * r)
    } else {
        2.0 - r
    }
}

/// Number of rate samples behind `d`, from the term count of its first τ (exact for OADEV; for
/// ADEV exact when the first factor is 1, otherwise within one block).
fn samples(d: &Deviations) -> usize {
    let (m, terms) = match (d.m.first(), d.n_terms.first()) {
        (Some(&m), Some(&t)) => (m, t),
        _ => return 0,
    };
    let n = match d.statistic {
        Statistic::Oadev => terms + 2 * m - 1,
        _ => (terms + 1) * m,
    };
    usize::try_from(n).unwrap_or(usize::MAX)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every averaging factor (`--taus all`) is thinned to quarter octaves; an octave or 10-per-
    /// decade grid is used whole.
    #[test]
    fn the_fit_thins_only_grids_denser_than_a_quarter_octave() {
        let all: Vec<f64> = (1..=30_000).map(|m| m as f64 / 100.0).collect();
        let keep = fit_points(&all);
        assert_eq!(keep[0], 0);
        for w in keep.windows(2) {
            assert!(all[w[1]] >= all[w[0]] * FIT_TAU_RATIO * (1.0 - 1e-9));
            // The next point after the last kept one is taken, not a later one.
            assert!(all[w[1] - 1] < all[w[0]] * FIT_TAU_RATIO);
        }
        assert!(keep.len() < 90, "{}", keep.len());
        let octave: Vec<f64> = (0..15).map(|k| 2f64.powi(k) / 100.0).collect();
        assert_eq!(fit_points(&octave), (0..15).collect::<Vec<_>>());
        let decade: Vec<f64> = (0..40).map(|k| 10f64.powf(k as f64 / 10.0)).collect();
        assert_eq!(fit_points(&decade).len(), 40);
    }

    /// Var(mean δ)/μ_N from the weights themselves: mean(δ) = Σ_k y_k·(a_k − b_k)/(M·m), with
    /// a_k and b_k the number of later and earlier τ-averages that sample k is in; white noise of
    /// unit variance has μ_N = 1/m.
    fn explicit(m: usize, big_m: usize) -> f64 {
        let n = big_m + 2 * m - 1;
        let mut w = vec![0.0f64; n];
        for j in 0..big_m {
            w[j..j + m].iter_mut().for_each(|v| *v -= 1.0);
            w[j + m..j + 2 * m].iter_mut().for_each(|v| *v += 1.0);
        }
        let scale = (big_m * m) as f64;
        w.iter().map(|v| (v / scale).powi(2)).sum::<f64>() * m as f64
    }

    #[test]
    fn the_mean_difference_variance_matches_its_weights_at_every_length() {
        let m = 240;
        for big_m in [
            1, 24, 120, 239, 240, 241, 300, 360, 479, 480, 481, 960, 2400,
        ] {
            let exact = explicit(m, big_m);
            let formula = overlapping_mean_difference_variance(big_m as f64 / m as f64);
            assert!(
                (formula / exact - 1.0).abs() < 0.01,
                "M = {big_m}: formula {formula}, weights {exact}"
            );
        }
    }
}
