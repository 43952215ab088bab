//! Which terms earn their place: every subset of the allowed terms is fitted and scored by an
//! information criterion, and the winner is refitted and given confidence intervals.
//!
//! Subsets are compared on an equal footing: all are fitted with the same weights (and working
//! correlation), those of the full model's fit, so that the χ² of a subset and of a subset with
//! one more term differ by a χ²₁-distributed amount when that term is absent, and the criterion's
//! penalty sets the false-inclusion rate. (Each subset weighted by its own model would reward
//! subsets that inflate their own variances.) 31 subsets of five terms take a few milliseconds.

use super::fit::{members, Mask, Problem, TERMS};
use super::interval::{coefficient_interval, normal_quantile};
use super::result::Domain;
use super::{Candidate, FitError, FitOptions, FitPoint, NoiseFit, Term, TermEstimate, UpperLimit};

/// Fits `problem` (points at `x`), choosing among the subsets of `allowed`.
pub(crate) fn select_and_fit(
    problem: &Problem,
    x: &[f64],
    allowed: Mask,
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
    let full = problem.irls(allowed);
    let common = &full.weights;
    let mut candidates: Vec<(Mask, Candidate)> = (1..=allowed)
        .filter(|&m| m & allowed == m && m != 0)
        .map(|mask| {
            let (c, chi2) = problem.solve(mask, common);
            let idx = members(mask);
            let proper = idx.iter().all(|&j| c[j] > 0.0);
            let score = opts.criterion.score(chi2, idx.len(), n);
            let terms = idx.iter().map(|&j| Term::ALL[j]).collect();
            (
                mask,
                Candidate {
                    terms,
                    chi2,
                    score,
                    proper,
                },
            )
        })
        .collect();
    candidates.sort_by(|a, b| a.1.score.total_cmp(&b.1.score));
    let best = candidates
        .iter()
        .find(|(_, c)| c.proper && c.score.is_finite())
        .map(|(m, _)| *m)
        .ok_or(FitError::NoSignal)?;

    // Final fit of the chosen subset with its own weights; should the reweighting clamp a term
    // (it can, rarely, near the criterion's threshold), refit without it.
    let mut mask = best;
    let mut fit = problem.irls(mask);
    for _ in 0..TERMS {
        let zeroed = members(mask)
            .into_iter()
            .filter(|&j| fit.c[j] <= 0.0)
            .fold(0, |acc, j| acc | (1 << j));
        if zeroed == 0 || zeroed == mask {
            break;
        }
        mask &= !zeroed;
        fit = problem.irls(mask);
    }
    let idx = members(mask);
    if idx.iter().all(|&j| fit.c[j] <= 0.0) {
        return Err(FitError::NoSignal);
    }
    let cov = problem.covariance(&fit.weights, &idx);
    let estimates = idx
        .iter()
        .enumerate()
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

    let z = normal_quantile((1.0 + p) / 2.0);
    let upper_limits = members(allowed & !mask)
        .into_iter()
        .map(|j| {
            let with = mask | (1 << j);
            let (c, _) = problem.solve(with, &fit.weights);
            let all = members(with);
            let pos = all.iter().position(|&t| t == j).unwrap_or(0);
            let sd = problem
                .covariance(&fit.weights, &all)
                .map_or(f64::INFINITY, |cov| cov[pos][pos].max(0.0).sqrt());
            UpperLimit {
                term: Term::ALL[j],
                upper: (c[j].max(0.0) + z * sd).sqrt(),
            }
        })
        .collect();

    let points = (0..n)
        .map(|i| FitPoint {
            x: x[i],
            value: problem.value[i],
            model: fit.mu[i],
            sd: fit.weights.sd[i],
        })
        .collect();
    Ok(NoiseFit {
        domain,
        estimates,
        upper_limits,
        chi2: fit.chi2,
        dof: n.saturating_sub(idx.len()),
        criterion: opts.criterion,
        confidence: p,
        candidates: candidates.into_iter().map(|(_, c)| c).collect(),
        points,
    })
}
