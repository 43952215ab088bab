//! Welch power spectral density: the CPU reference path.
//!
//! Same definitions, options and defaults as `scipy.signal.welch` (periodic windows, segment layout
//! with `boundary=None, padded=False`, one-sided output, mean or bias-corrected median), checked
//! against scipy to 1e-10 on fixtures in `tests/data/psd`. Built for hours-long recordings:
//!
//! - [`WelchConfig`] holds plain options; [`WelchConfig::validate`] turns them into a
//!   [`WelchPlan`] (window, FFT plan, step) before any data is read.
//! - [`WelchAccumulator`] takes the recording in chunks of any size, for several channels at once,
//!   with memory bounded by nperseg per channel (mean averaging), and uses all cores.
//! - [`welch`] is the one-shot form for data in memory.
//! - [`log_bin`] averages bins into log-spaced bands for plotting and fitting, with each band's
//!   equivalent degrees of freedom; [`Psd::dof`] has the per-bin ones.
//! - [`reference`] is a slow direct-sum implementation that the fast paths are tested against.
//!
//! ```
//! use imunoise::psd::{log_bin, WelchAccumulator, WelchConfig, Window};
//! let plan = WelchConfig { window: Window::Hann, ..WelchConfig::new(1024) }.validate()?;
//! let mut acc = WelchAccumulator::new(plan, 200.0, 2);
//! for batch in 0..10 {
//!     let gx: Vec<f64> = (0..1000).map(|i| ((batch * 1000 + i) as f64 * 0.37).sin()).collect();
//!     let gy = vec![0.5; 1000];
//!     acc.push(&[&gx, &gy]);
//! }
//! let psds = acc.finish()?;
//! let binned = log_bin(&psds[0], 10);
//! assert!(binned.freq_hz.windows(2).all(|f| f[0] < f[1]));
//! # Ok::<(), imunoise::psd::PsdError>(())
//! ```

mod accumulator;
mod detrend;
mod dof;
mod error;
mod logbin;
mod median;
mod plan;
pub mod reference;
mod scaling;
mod segment;
mod spectrum;
mod welch;
mod window;

pub(crate) use accumulator::check_chunk;
pub use accumulator::WelchAccumulator;
pub use detrend::Detrend;
pub use error::PsdError;
pub use logbin::{log_bin, log_bin_resolving, neighbour_redundancy, BinnedPsd};
pub use median::{median_bias, median_efficiency, Average};
pub use plan::{WelchConfig, WelchPlan, MAX_NFFT};
pub use scaling::Scaling;
pub use spectrum::Psd;
pub use welch::{welch, welch_with_plan};
pub use window::Window;
