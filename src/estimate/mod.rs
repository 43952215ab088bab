//! Estimator backends: one interface, implemented on the CPU now and on the GPU later.
//!
//! Like a planner in an FFT library, [`Backend`] is chosen once per run (knowing the hardware) and hands
//! out per-recording work: a streaming Welch sink fed block by block, and Allan-family variances of
//! whole channels. The CPU backend is the reference every other backend is tested against.

mod cpu;

use std::fmt;

use serde::Serialize;

use crate::avar::{AvarError, Confidence, Deviations, Statistic, TauGrid};
use crate::psd::{BinnedPsd, Psd, PsdError, WelchPlan};

pub use cpu::CpuBackend;

/// A channel's PSD, raw and log-binned: what the estimate stage hands to the model stage.
#[derive(Debug, Clone)]
pub struct ChannelPsd {
    pub channel: String,
    pub psd: Psd,
    pub binned: Option<BinnedPsd>,
}

/// A channel's Allan-family statistics, one entry per statistic asked for.
#[derive(Debug, Clone)]
pub struct ChannelDeviations {
    pub channel: String,
    pub statistics: Vec<Deviations>,
}

/// Which implementation computed a result; written into every output.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum BackendKind {
    Cpu,
    Gpu,
}

impl fmt::Display for BackendKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            BackendKind::Cpu => "cpu",
            BackendKind::Gpu => "gpu",
        })
    }
}

/// A Welch estimate in progress over all channels of one recording.
pub trait WelchSink: Send {
    /// Adds consecutive samples: one slice per channel, all of equal length.
    fn push(&mut self, chunk: &[&[f64]]);
    /// The PSD of every channel, in channel order.
    fn finish(self: Box<Self>) -> Result<Vec<Psd>, PsdError>;
    /// The most samples per channel held between pushes so far: the evidence that memory stays
    /// bounded by the segment length, however long the recording.
    fn peak_buffered_samples(&self) -> usize;
}

/// The samples of a recording's channels as the Allan statistics get them: borrowed when the
/// caller reads them afterwards (the fit), owned when it does not.
#[derive(Debug)]
pub enum Samples<'a> {
    Borrowed(&'a [Vec<f64>]),
    Owned(Vec<Vec<f64>>),
}

impl Samples<'_> {
    /// The channels, however held.
    pub fn channels(&self) -> &[Vec<f64>] {
        match self {
            Samples::Borrowed(c) => c,
            Samples::Owned(c) => c,
        }
    }
}

/// An estimator backend.
pub trait Backend: Send + Sync {
    fn kind(&self) -> BackendKind;
    /// A human-readable description (device, threads), for logs and output metadata.
    fn describe(&self) -> String;
    /// Starts a streaming Welch estimate for `channels` channels sampled at `rate_hz`.
    fn welch(&self, plan: &WelchPlan, rate_hz: f64, channels: usize) -> Box<dyn WelchSink>;
    /// Notes on work done since the last call that did not run where asked (a GPU job that ran on
    /// the CPU, and why), so that outputs can say which numbers came from where.
    fn take_notes(&self) -> Vec<String> {
        Vec::new()
    }
    /// One Allan-family statistic of each channel.
    fn deviations(
        &self,
        channels: &[Vec<f64>],
        rate_hz: f64,
        grid: &TauGrid,
        statistic: Statistic,
        confidence: Confidence,
    ) -> Vec<Result<Deviations, AvarError>>;
    /// Each of `statistics` of each channel, as `[statistic][channel]`, every entry what
    /// [`Backend::deviations`] gives for it. Samples the caller hands over ([`Samples::Owned`]) may
    /// become a backend's working arrays (the CPU's prefix sums, built in place: no second
    /// record-length buffer to fault in). The default asks [`Backend::deviations`] once per
    /// statistic.
    fn statistics(
        &self,
        samples: Samples<'_>,
        rate_hz: f64,
        grid: &TauGrid,
        statistics: &[Statistic],
        confidence: Confidence,
    ) -> Vec<Vec<Result<Deviations, AvarError>>> {
        let channels = samples.channels();
        statistics
            .iter()
            .map(|&statistic| self.deviations(channels, rate_hz, grid, statistic, confidence))
            .collect()
    }
}
