//! Which terms earn their place: every subset of the allowed terms is fitted and scored by an
//! information criterion, and the winner gets confidence intervals.
//!
//! Each subset is fitted on its own (iterated weights from its own model) and scored by its
//! log-likelihood on the Wilson–Hilferty scale ([`Problem::likelihood`]) plus the criterion's
//! penalty. A subset whose non-negative fit sets one of its terms to zero duplicates a smaller
//! subset and is not eligible. 31 subsets of five terms take a few milliseconds.
//!
//! The subsets are scored on a *screening* form of the problem, which may differ from the one the
//! winner is then fitted on: in the Allan domain the rate ramp is deterministic and adds little
//! scatter, so a model with a ramp could claim the last two or three points as nearly exact and
//! gain likelihood from that claim alone (measured: the likelihood-ratio statistic for an absent
//! ramp averaged 2.0 instead of 1). Screened with the scatter of a random walk, a ramp has to earn
//! its place like any other term; once in, it is fitted and given its interval with its own
//! scatter.

use super::fit::{members, Mask, Problem, BASE, EFFECT, TERMS};
use super::interval::{coefficient_interval, normal_quantile};
use super::result::Domain;
use super::{
    Candidate, EffectEstimate, FitError, FitOptions, FitPoint, NoiseFit, Term, TermEstimate,
    UpperLimit,
};

/// Fits `problem` (points at `x`), choosing among the subsets of `allowed` by their scores on
/// `screen` (the same points, possibly other variances). Columns in `forced` (an effect) are in
/// every candidate; the base terms are chosen around them.
pub(crate) fn select_and_fit(
    problem: &Problem,
    screen: &Problem,
    x: &[f64],
    allowed: Mask,
    forced: Mask,
    opts: &FitOptions,
    domain: Domain,
) -> Result<NoiseFit, FitError> {
    let n = problem.len();
    if n < 2 {
        return Err(FitError::TooFewPoints {
            points: n,
            needed: 2,
        });
    }
    let p = opts
        .confidence
        .probability()
        .map_err(|e| FitError::InvalidOptions(e.to_string()))?;
    let first = if forced == 0 { 1 } else { 0 };
    let mut fits: Vec<(Candidate, Mask)> = (first..=allowed)
        .filter(|&m| m & allowed == m)
        .map(|m| m | forced)
        .map(|mask| {
            let fit = screen.irls(mask);
            let idx = members(mask);
            let proper = idx.iter().all(|&j| fit.c[j] > 0.0);
            let (_, chi2, neg2ll) = screen.likelihood(&fit);
            let candidate = Candidate {
                terms: idx
                    .iter()
                    .filter(|&&j| j < BASE)
                    .map(|&j| Term::ALL[j])
                    .collect(),
                chi2,
                score: opts.criterion.score(neg2ll, idx.len(), n),
                proper,
            };
            (candidate, mask)
        })
        .collect();
    fits.sort_by(|a, b| a.0.score.total_cmp(&b.0.score));
    let best = fits
        .iter()
        .position(|(c, _)| c.proper && c.score.is_finite())
        .ok_or(FitError::NoSignal)?;
    let mut mask = fits[best].1;
    // Refit on the problem itself; should that clamp a term (a screening/final difference near
    // the criterion's threshold), the term goes.
    let mut fit = problem.irls(mask);
    for _ in 0..TERMS {
        let zeroed = members(mask)
            .into_iter()
            .filter(|&j| fit.c[j] <= 0.0)
            .fold(0, |acc, j| acc | (1 << j));
        if zeroed == 0 || zeroed == mask {
            break;
        }
        if zeroed & forced != 0 {
            // The effect itself came out zero: the caller's criterion will reject it.
            break;
        }
        mask &= !zeroed;
        fit = problem.irls(mask);
    }
    let idx = members(mask);
    if idx.iter().all(|&j| fit.c[j] <= 0.0) {
        return Err(FitError::NoSignal);
    }
    let (z, chi2, _) = problem.likelihood(&fit);

    let cov = problem.covariance(&fit.weights, &idx);
    let effect = idx.iter().position(|&j| j == EFFECT).map(|a| {
        let var = cov.as_ref().map_or(f64::INFINITY, |cov| cov[a][a]);
        let (lo, hi, edf) = coefficient_interval(fit.c[EFFECT], var, p);
        EffectEstimate {
            value: fit.c[EFFECT].max(0.0).sqrt(),
            lo,
            hi,
            edf,
        }
    });
    let estimates = idx
        .iter()
        .enumerate()
        .filter(|(_, &j)| j < BASE)
        .map(|(a, &j)| {
            let var = cov.as_ref().map_or(f64::INFINITY, |cov| cov[a][a]);
            let (lo, hi, edf) = coefficient_interval(fit.c[j], var, p);
            TermEstimate {
                term: Term::ALL[j],
                value: fit.c[j].sqrt(),
                lo,
                hi,
                edf,
            }
        })
        .collect();

    // Absent terms: forced in, with the chosen model's weights; the upper end of the interval
    // they would have (normal approximation, as their estimate is near zero).
    let zq = normal_quantile((1.0 + p) / 2.0);
    let upper_limits = members(allowed & !mask)
        .into_iter()
        .map(|j| {
            let with = mask | (1 << j);
            let c = problem.solve(with, &fit.weights);
            let all = members(with);
            let pos = all.iter().position(|&t| t == j).unwrap_or(0);
            let sd = problem
                .covariance(&fit.weights, &all)
                .map_or(f64::INFINITY, |cov| cov[pos][pos].max(0.0).sqrt());
            UpperLimit {
                term: Term::ALL[j],
                upper: (c[j].max(0.0) + zq * sd).sqrt(),
            }
        })
        .collect();

    let points = (0..n)
        .map(|i| FitPoint {
            x: x[i],
            value: problem.value[i],
            model: fit.mu[i],
            edf: fit.weights.nu[i],
            z: z[i],
        })
        .collect();
    Ok(NoiseFit {
        domain,
        estimates,
        upper_limits,
        chi2,
        dof: n.saturating_sub(idx.len()),
        effect,
        criterion: opts.criterion,
        confidence: p,
        candidates: fits.into_iter().map(|(c, _)| c).collect(),
        points,
    })
}
