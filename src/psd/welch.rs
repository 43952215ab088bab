//! One-shot Welch estimates of signals already in memory: a thin layer over the streaming
//! accumulator, so there is only one implementation to trust. The whole signal is pushed as one
//! chunk, which the accumulator reads in place (no copy).

use super::{Psd, PsdError, WelchAccumulator, WelchConfig, WelchPlan};

/// Welch PSD of one channel, with scipy.signal.welch's semantics (see [`WelchConfig`]).
///
/// ```
/// use imunoise::psd::{welch, WelchConfig};
/// let x: Vec<f64> = (0..4096).map(|i| ((i * 7919) % 101) as f64 - 50.0).collect();
/// let psd = welch(&x, 100.0, &WelchConfig::new(256))?;
/// assert_eq!(psd.value.len(), 129);
/// assert_eq!(psd.segments, 31);
/// # Ok::<(), imunoise::psd::PsdError>(())
/// ```
pub fn welch(x: &[f64], rate_hz: f64, cfg: &WelchConfig) -> Result<Psd, PsdError> {
    let plan = cfg.validate()?;
    let mut psd = welch_with_plan(&[x], rate_hz, &plan)?;
    Ok(psd.remove(0))
}

/// Welch PSDs of several equally long channels with one plan; segments of all channels are
/// transformed in parallel.
pub fn welch_with_plan(
    channels: &[&[f64]],
    rate_hz: f64,
    plan: &WelchPlan,
) -> Result<Vec<Psd>, PsdError> {
    let mut acc = WelchAccumulator::new(plan.clone(), rate_hz, channels.len());
    acc.push(channels);
    acc.finish()
}
