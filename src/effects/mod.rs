//! Effects the IEEE noise model lacks, found in what the base fit leaves unexplained, and the loop
//! that adds them ([`closing::close_loop`]).
//!
//! - [`band`]: the base fits inside the sensor's band (shared by `analyze` and the loop).
//! - [`ramp`]: whether the time series determines a rate ramp the Allan fit kept.
//! - [`residuals`]: structure tests on a fit's normalised residuals.
//! - [`lines`]: narrow excesses of the raw spectrum over the model (lines, resonances).
//! - [`shapes`]: stochastic effects fitted as one more model column (Gauss–Markov, resonance).
//! - [`time`]: effects that live in the time series (coupling to an aux channel, spikes, bias
//!   steps, sinusoid regression, split-record stationarity).
pub mod angle_grid;
pub mod band;
pub mod closing;
pub mod excursion;
pub mod lines;
pub mod ramp;
pub mod regression;
pub mod residuals;
pub mod shapes;
pub mod shift;
pub mod skirt;
pub mod slow;
// The time-domain detectors guard their inputs with `!(x > 0.0)` on purpose: it rejects NaN along
// with non-positive values in one comparison.
#[allow(
    clippy::neg_cmp_op_on_partial_ord,
    clippy::nonminimal_bool,
    clippy::manual_contains
)]
pub mod time;

pub use closing::{
    close_loop, close_loop_from_base, AuxSeries, BaseFits, Effect, ErrorFigures, LoopConfig,
    LoopOutcome, LoopReport, LoopStep, Rejected, Rival, MAX_STEPS, RIVAL_SLOW_P,
    RIVAL_WARNING_SHARE,
};
