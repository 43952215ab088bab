//! From GPU variances to [`Deviations`] identical in shape and convention to the CPU's: the same
//! validation and errors, the same tau grid, and the CPU module's noise identification, EDF and
//! confidence bounds (which depend on the data only through the prefix sums, built on the CPU
//! here exactly as `avar::compute` builds them).
//!
//! The steps of `avar::compute` are repeated here in the same order because that module computes
//! its variances internally; a hook there taking the variances from outside would remove this
//! copy.

use std::sync::Arc;

use rayon::prelude::*;

use super::{oadev_variances, ChannelData};
use crate::avar::edf::edf;
use crate::avar::noise_id::identify;
use crate::avar::{
    variance_bounds, AvarError, Confidence, Deviations, PrefixSums, Statistic, TauGrid,
};
use crate::gpu::{GpuContext, GpuError};

/// OADEV of every channel on the GPU: per channel the CPU's validation result or its
/// deviations, or `Err` when the device failed (the caller then runs the CPU path).
pub(crate) fn deviations(
    ctx: &Arc<GpuContext>,
    channels: &[Vec<f64>],
    rate_hz: f64,
    grid: &TauGrid,
    confidence: Confidence,
) -> Result<Vec<Result<Deviations, AvarError>>, GpuError> {
    let stat = Statistic::Oadev;
    let prepared: Vec<Prepared> = channels
        .iter()
        .map(|y| prepare(y, rate_hz, grid, stat, confidence))
        .collect();
    let mut data = Vec::new();
    let mut ms = Vec::new();
    for (y, p) in channels.iter().zip(&prepared) {
        if let Ok((ps, m, _)) = p {
            data.push(ChannelData {
                y,
                mean: ps.mean(),
                prefix: ps.s(),
            });
            ms.push(m.clone());
        }
    }
    let mut variances = oadev_variances(ctx, &data, &ms)?.into_iter();
    Ok(prepared
        .into_iter()
        .map(|p| {
            let (ps, ms, p) = p?;
            let variance = variances.next().expect("one result per valid channel");
            Ok(assemble(&ps, rate_hz, ms, variance, stat, p))
        })
        .collect())
}

/// A channel ready for the GPU (prefix sums, factors, confidence probability) or the error the
/// CPU path would give for it.
type Prepared = Result<(PrefixSums, Vec<u64>, f64), AvarError>;

/// `avar::compute_statistics`' checks, in its order: rate, confidence, grid factors, samples.
fn prepare(
    y: &[f64],
    rate_hz: f64,
    grid: &TauGrid,
    stat: Statistic,
    confidence: Confidence,
) -> Prepared {
    if !(rate_hz.is_finite() && rate_hz > 0.0) {
        return Err(AvarError::InvalidRate(rate_hz));
    }
    let p = confidence.probability()?;
    let ms = factors(grid, y.len(), stat)?;
    let ps = PrefixSums::new(y)?;
    Ok((ps, ms, p))
}

/// The grid's factors or the error explaining their absence (as `avar::compute`).
fn factors(grid: &TauGrid, n: usize, stat: Statistic) -> Result<Vec<u64>, AvarError> {
    let too_short = |m: u64| AvarError::TooShort {
        n,
        needed: stat.min_samples(m),
        statistic: stat,
        m,
    };
    if n < stat.min_samples(1) {
        return Err(too_short(1));
    }
    if let TauGrid::Explicit(list) = grid {
        if list.contains(&0) {
            return Err(AvarError::ZeroFactor);
        }
        let max = stat.max_factor(n);
        if let Some(&m) = list.iter().filter(|&&m| m > max).max() {
            return Err(too_short(m));
        }
    }
    let ms = grid.factors(n, stat);
    if ms.is_empty() {
        return Err(AvarError::NoValidTau {
            n,
            statistic: stat,
            grid: grid.to_string(),
        });
    }
    Ok(ms)
}

/// Noise identification, EDF and bounds at every τ (as `avar::compute`).
fn assemble(
    ps: &PrefixSums,
    rate_hz: f64,
    ms: Vec<u64>,
    variance: Vec<f64>,
    stat: Statistic,
    p: f64,
) -> Deviations {
    let n = ps.len();
    let per_tau: Vec<(i8, f64, (f64, f64))> = ms
        .par_iter()
        .zip(variance.par_iter())
        .map(|(&m, &var)| {
            let alpha = identify(ps, m, stat).alpha;
            let e = edf(stat, alpha, m, n);
            (alpha, e, variance_bounds(var, e, p))
        })
        .collect();
    Deviations {
        statistic: stat,
        rate_hz,
        tau_s: ms.iter().map(|&m| m as f64 / rate_hz).collect(),
        n_terms: ms.iter().map(|&m| stat.n_terms(n, m)).collect(),
        alpha: per_tau.iter().map(|t| t.0).collect(),
        edf: per_tau.iter().map(|t| t.1).collect(),
        variance_lo: per_tau.iter().map(|t| t.2 .0).collect(),
        variance_hi: per_tau.iter().map(|t| t.2 .1).collect(),
        variance,
        m: ms,
        confidence: p,
    }
}
