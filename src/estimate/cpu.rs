//! The CPU reference backend: realfft Welch and prefix-sum Allan variances, both parallel with rayon.

use std::borrow::Cow;

use super::{Backend, BackendKind, Samples, WelchSink};
use crate::avar::{self, AvarError, Confidence, Deviations, Statistic, TauGrid};
use crate::psd::{Psd, PsdError, WelchAccumulator, WelchPlan};

/// See the module docs.
#[derive(Debug, Clone, Copy, Default)]
pub struct CpuBackend;

impl WelchSink for WelchAccumulator {
    fn push(&mut self, chunk: &[&[f64]]) {
        WelchAccumulator::push(self, chunk)
    }
    fn finish(self: Box<Self>) -> Result<Vec<Psd>, PsdError> {
        WelchAccumulator::finish(*self)
    }
    fn peak_buffered_samples(&self) -> usize {
        WelchAccumulator::peak_buffered_samples(self)
    }
}

impl Backend for CpuBackend {
    fn kind(&self) -> BackendKind {
        BackendKind::Cpu
    }

    fn describe(&self) -> String {
        format!("cpu ({} threads)", rayon::current_num_threads())
    }

    fn welch(&self, plan: &WelchPlan, rate_hz: f64, channels: usize) -> Box<dyn WelchSink> {
        Box::new(WelchAccumulator::new(plan.clone(), rate_hz, channels))
    }

    fn deviations(
        &self,
        channels: &[Vec<f64>],
        rate_hz: f64,
        grid: &TauGrid,
        statistic: Statistic,
        confidence: Confidence,
    ) -> Vec<Result<Deviations, AvarError>> {
        // Each channel's computation is itself parallel; channels run one after another so that the
        // working set (one prefix-sum array) stays small.
        channels
            .iter()
            .map(|y| avar::compute(y, rate_hz, grid, statistic, confidence))
            .collect()
    }

    fn statistics(
        &self,
        samples: Samples<'_>,
        rate_hz: f64,
        grid: &TauGrid,
        statistics: &[Statistic],
        confidence: Confidence,
    ) -> Vec<Vec<Result<Deviations, AvarError>>> {
        // Channel by channel as above, every statistic from one prefix-sum array.
        let each = |y: Cow<'_, [f64]>| avar::compute_each(y, rate_hz, grid, statistics, confidence);
        let per_channel: Vec<Vec<Result<Deviations, AvarError>>> = match samples {
            Samples::Borrowed(channels) => {
                channels.iter().map(|y| each(Cow::Borrowed(y))).collect()
            }
            Samples::Owned(channels) => channels.into_iter().map(|y| each(Cow::Owned(y))).collect(),
        };
        let mut by_statistic: Vec<Vec<_>> = statistics.iter().map(|_| Vec::new()).collect();
        for results in per_channel {
            for (slot, result) in by_statistic.iter_mut().zip(results) {
                slot.push(result);
            }
        }
        by_statistic
    }
}
