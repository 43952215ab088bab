//! Time-domain effects the IEEE noise model lacks: linear coupling to an aux channel
//! ([`coupling`]), spikes ([`spikes`]), bias steps ([`step`]), a sinusoid refined by least squares
//! ([`sinusoid`]) and a split-record stationarity test ([`stationarity`]).
//!
//! Every detector is built for the question the residual loop asks of a *static* recording:
//! "does this effect earn its place?", and the main danger is saying yes when it is absent. The
//! IEEE noise itself (flicker, rate random walk, quantisation) is slow, correlated and sometimes
//! discrete; a test that assumes white, Gaussian, continuous samples finds spurious couplings,
//! steps and spikes in nearly every long record. Each detector therefore
//!
//! - works on a statistic whose null distribution holds under *any* of the IEEE noises
//!   (increments of block means, the dynamic Allan difference, a residual from a running median,
//!   the noise PSD at the line),
//! - corrects for the search it does (scales, positions, frequencies, samples: Bonferroni, or
//!   Pickands' formula for the maximum of a scan),
//! - reports `delta_bic = k·ln(n_eff) − χ²_eq`: the BIC change when the effect's k amplitude
//!   parameters are added, with `n_eff` the number of effectively independent observations the
//!   estimate rests on and `χ²_eq` the likelihood-ratio statistic after that search correction
//!   (the χ² with the same, corrected, p-value). The caller keeps an effect only if
//!   `delta_bic < 0`.
//!
//! The detectors never panic on degenerate input (constant, quantised or very short series):
//! they return `None` or an empty result. Measured false-discovery rates, interval coverage and
//! recovery are in each module's tests (`cargo test --lib effects::time -- --nocapture`).

pub mod coupling;
pub mod sinusoid;
pub mod spikes;
pub mod stationarity;
mod stats;
pub mod step;
#[cfg(test)]
mod testutil;

pub use coupling::{fit_coupling, remove_coupling, Coupling};
pub use sinusoid::{fit_sinusoid, remove_sinusoid, SineFit};
pub use spikes::{find_spikes, remove_spikes, Spikes};
pub use stationarity::{split_record, SplitRecord};
pub use step::{find_step, remove_step, Step};
