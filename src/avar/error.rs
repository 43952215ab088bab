//! Errors of the Allan-family estimators. Each variant carries the numbers involved: a user who asked
//! for τ = 2000 s on a 30-minute recording needs to see how many samples that τ needs and how many
//! there are, not just "too short".

use super::Statistic;

/// Why a deviation could not be computed. No input makes [`compute`](super::compute) panic; every
/// refusal comes back as one of these.
#[non_exhaustive]
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum AvarError {
    /// The recording is too short for the statistic at averaging factor `m`: the estimator needs at
    /// least two terms, which takes `needed` samples (see [`Statistic::min_samples`]).
    #[error("{statistic} at m = {m} needs at least {needed} samples, the input has {n}")]
    TooShort {
        n: usize,
        needed: usize,
        statistic: Statistic,
        m: u64,
    },
    /// The tau grid leaves no averaging factor for this length and statistic (for example
    /// `PerDecade(0)` or an empty explicit list).
    #[error("no valid averaging factor for {statistic} on {n} samples with tau grid {grid}")]
    NoValidTau {
        n: usize,
        statistic: Statistic,
        grid: String,
    },
    /// An explicit averaging factor of zero: τ = 0 has no meaning.
    #[error("averaging factor m = 0 in an explicit tau list (m counts samples, τ = m / rate)")]
    ZeroFactor,
    /// The sample rate must be finite and positive.
    #[error("sample rate must be finite and positive, got {0} Hz")]
    InvalidRate(f64),
    /// The confidence level must lie strictly between 0 and 1.
    #[error("confidence level must lie strictly between 0 and 1, got {0}")]
    InvalidConfidence(f64),
    /// A NaN or infinite sample; `index` is its position in the input (the first one found).
    #[error("sample {index} is not finite (NaN or infinite)")]
    NonFinite { index: usize },
    /// Every sample is finite but their sum or their squared differences overflow f64 (samples
    /// beyond ~1e154): rescale the data.
    #[error("the samples are too large: their sum or squared differences overflow f64; rescale the data")]
    Overflow,
    /// A name that does not parse into a statistic or a tau grid.
    #[error("unknown {what} {name:?} (expected {expected})")]
    UnknownName {
        what: &'static str,
        name: String,
        expected: &'static str,
    },
}
