//! Effects the IEEE noise model lacks, found in what the base fit leaves unexplained.
//!
//! - [`time`]: effects that live in the time series (coupling to an aux channel, spikes, bias
//!   steps, sinusoid regression, split-record stationarity).
pub mod time;
