//! Allan-family variances of rate data: the CPU reference path.
//!
//! Rate (frequency-type) samples y_k at τ₀ = 1/fs; τ = m·τ₀. Every estimator is a sum of squared
//! finite differences of S, the cumulative sum of the mean-removed samples (S₀ = 0): for the
//! overlapping Allan variance
//!
//! σ²(τ) = 1/(2m²(N − 2m + 1)) Σ_{j=0}^{N−2m} (S_{j+2m} − 2S_{j+m} + S_j)².
//!
//! - [`compute`] runs one [`Statistic`] (OADEV, ADEV, MDEV, HDEV, OHDEV) on a [`TauGrid`] and
//!   returns [`Deviations`]: variances, the identified noise exponent, EDF and a chi-square
//!   confidence interval at every τ. [`compute_each`] does several on the same data from one
//!   prefix-sum array, each result what [`compute`] gives for it alone.
//! - The numbers agree with NIST SP 1065's published NBS14 values, with Stable32 (PHASE.DAT and an
//!   OCXO recording, deviations and confidence bounds) and with allantools (1e-10 on random data);
//!   see `tests/integration/avar`.
//! - Built for long recordings: S is built once in f64 with exact (double-double) anchors, and the
//!   overlapping estimators sweep S in cache-sized blocks with all taus per block, four taus per
//!   kernel pass, on all cores (`sweep.rs`, `kernel.rs`). Ten million samples at octave taus take
//!   a few tens of milliseconds, 25–30 times less than allantools. The S buffer of a long
//!   recording is kept for the next call ([`release_cached_memory`] frees it).
//! - [`noise_id`] follows Stable32 (lag-1 autocorrelation, B1 and R(n)); [`edf`] is Greenhall and
//!   Riley's combined EDF algorithm.
//! - [`reference`](mod@reference) holds brute-force textbook estimators that the fast paths (and
//!   the GPU backend) are tested against; [`deviations_from_variances`] turns variances computed by
//!   another backend into [`Deviations`] the same way [`compute`] does.
//!
//! ```
//! use imunoise::avar::{compute, Confidence, Statistic, TauGrid};
//! let y: Vec<f64> = (0..10_000).map(|i| ((i * 7919 % 1009) as f64 - 504.0) * 1e-3).collect();
//! let d = compute(&y, 100.0, &TauGrid::Octave, Statistic::Oadev, Confidence::OneSigma)?;
//! for ((tau, sigma), (lo, hi)) in d
//!     .tau_s
//!     .iter()
//!     .zip(d.deviation())
//!     .zip(d.deviation_lo().into_iter().zip(d.deviation_hi()))
//! {
//!     assert!(lo <= sigma && sigma <= hi, "τ = {tau} s");
//! }
//! # Ok::<(), imunoise::avar::AvarError>(())
//! ```

mod compute;
mod confidence;
mod deviations;
pub mod edf;
mod error;
mod kernel;
mod mdev;
pub mod noise_id;
mod prefix;
pub mod reference;
mod statistic;
mod strided;
mod sweep;
mod tau;
mod variances;

pub use crate::memory::release_cached_memory;
pub use compute::{
    checked_factors, compute, compute_each, compute_owned, deviations_from_variances,
};
pub use confidence::{chi2_quantile, variance_bounds, Confidence, ONE_SIGMA};
pub use deviations::Deviations;
pub use error::AvarError;
pub use noise_id::{identify_noise, NoiseEstimate, NoiseIdMethod};
pub use prefix::PrefixSums;
pub use statistic::Statistic;
pub use tau::TauGrid;
