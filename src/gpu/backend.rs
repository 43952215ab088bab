//! [`GpuBackend`]: the [`Backend`] that runs Welch and OADEV on the GPU and everything else — and
//! anything the GPU fails at — on the CPU reference backend.
//!
//! Every fallback is recorded (task and reason) in a log the caller reads after the run
//! ([`GpuBackend::fallbacks`], [`GpuBackend::last_fallback_reason`]): options the GPU path does not
//! implement are notes, device failures are warnings. No result ever mixes a failed GPU
//! computation with a CPU one; see [`GpuWelch`] for how a stream survives a device lost half-way.

use std::sync::Arc;

use super::fallback::{Fallback, FallbackLog, Task};
use super::{avar, FallbackReason, GpuContext, GpuError, GpuWelch};
use crate::avar::{AvarError, Confidence, Deviations, Statistic, TauGrid};
use crate::estimate::{Backend, BackendKind, CpuBackend, WelchSink};
use crate::psd::{WelchAccumulator, WelchPlan};

/// See the module docs.
pub struct GpuBackend {
    ctx: Arc<GpuContext>,
    cpu: CpuBackend,
    log: Arc<FallbackLog>,
}

impl GpuBackend {
    /// The preferred adapter with its own limits (see [`GpuContext::new`]).
    ///
    /// # Errors
    /// [`GpuError::NoAdapter`] when the machine has no usable adapter: the caller decides between
    /// the CPU backend (`--backend auto`) and an error (`--backend gpu`).
    pub fn new() -> Result<GpuBackend, GpuError> {
        Ok(GpuBackend::with_context(Arc::new(GpuContext::new()?)))
    }

    /// A backend on an existing context (several backends, or a test, can share one device).
    pub fn with_context(ctx: Arc<GpuContext>) -> GpuBackend {
        GpuBackend {
            ctx,
            cpu: CpuBackend,
            log: Arc::new(FallbackLog::default()),
        }
    }

    pub fn context(&self) -> &Arc<GpuContext> {
        &self.ctx
    }

    /// Every fallback to the CPU so far, in order.
    pub fn fallbacks(&self) -> Vec<Fallback> {
        self.log.entries()
    }

    /// The most recent fallback's reason, if any job fell back.
    pub fn last_fallback_reason(&self) -> Option<FallbackReason> {
        self.log.last().map(|f| f.reason)
    }
}

impl Backend for GpuBackend {
    fn kind(&self) -> BackendKind {
        BackendKind::Gpu
    }

    /// "gpu: <adapter name> (<backend>, <device type>, <driver>)".
    fn describe(&self) -> String {
        format!("gpu: {}", self.ctx.describe())
    }

    /// The fallbacks recorded since the last call, as "task: reason" lines.
    fn take_notes(&self) -> Vec<String> {
        self.log
            .take_new()
            .iter()
            .map(ToString::to_string)
            .collect()
    }

    fn welch(&self, plan: &WelchPlan, rate_hz: f64, channels: usize) -> Box<dyn WelchSink> {
        match GpuWelch::new(Arc::clone(&self.ctx), plan.clone(), rate_hz, channels) {
            Ok(sink) => Box::new(sink.with_log(Arc::clone(&self.log))),
            Err(reason) => {
                self.log.record(Task::Welch, reason);
                Box::new(WelchAccumulator::new(plan.clone(), rate_hz, channels))
            }
        }
    }

    fn deviations(
        &self,
        channels: &[Vec<f64>],
        rate_hz: f64,
        grid: &TauGrid,
        statistic: Statistic,
        confidence: Confidence,
    ) -> Vec<Result<Deviations, AvarError>> {
        if statistic != Statistic::Oadev {
            self.log.record(
                Task::Deviations,
                FallbackReason::Unsupported(format!("{statistic} (only oadev is on the GPU)")),
            );
            return self
                .cpu
                .deviations(channels, rate_hz, grid, statistic, confidence);
        }
        match avar::deviations(&self.ctx, channels, rate_hz, grid, confidence) {
            Ok(out) => out,
            Err(e) => {
                self.log.record(Task::Deviations, FallbackReason::Failed(e));
                self.cpu
                    .deviations(channels, rate_hz, grid, statistic, confidence)
            }
        }
    }
}
