//! From GPU variances to [`Deviations`] identical in shape and convention to the CPU's: the Allan
//! module's own validation ([`checked_factors`]) and its noise identification, EDF and confidence
//! bounds ([`deviations_from_variances`]), which depend on the data only through the prefix sums,
//! built on the CPU as `avar::compute` builds them.

use std::sync::Arc;

use super::{oadev_variances, ChannelData};
use crate::avar::{
    checked_factors, deviations_from_variances, AvarError, Confidence, Deviations, PrefixSums,
    Statistic, TauGrid,
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
        if let Ok((ps, m)) = p {
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
            let (ps, ms) = p?;
            let variance = variances.next().expect("one result per valid channel");
            deviations_from_variances(&ps, rate_hz, ms, variance, stat, confidence)
        })
        .collect())
}

/// A channel ready for the GPU (prefix sums, factors) or the error the CPU path would give for it.
type Prepared = Result<(PrefixSums, Vec<u64>), AvarError>;

/// `avar::compute_each`'s checks for one statistic, in its order: rate, confidence, grid
/// factors, samples.
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
    confidence.probability()?;
    let ms = checked_factors(grid, y.len(), stat)?;
    let ps = PrefixSums::new(y)?;
    Ok((ps, ms))
}
