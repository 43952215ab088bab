//! Why a noise-model fit could not be made.

use crate::avar::Statistic;

#[non_exhaustive]
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum FitError {
    /// The model's Allan-variance terms are those of the (overlapping or not) Allan variance.
    #[error("the noise model fits Allan variances (oadev, adev), not {0}")]
    UnsupportedStatistic(Statistic),
    /// The spectrum fit needs a density (unit²/Hz), not a power spectrum.
    #[error("the spectrum must have density scaling to be fitted")]
    NotDensity,
    #[error("{points} usable points, at least {needed} needed")]
    TooFewPoints { points: usize, needed: usize },
    #[error("no term can be fitted: every candidate model came out zero")]
    NoSignal,
    #[error("options: {0}")]
    InvalidOptions(String),
}
