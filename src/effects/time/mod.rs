//! Time-domain effects the IEEE noise model lacks: linear coupling to an aux channel
//! ([`coupling`]), spikes ([`spikes`]), bias steps ([`step`]), a sinusoid refined by least squares
//! ([`sinusoid`]), a line with a width ([`narrowband`]) and a split-record stationarity test ([`stationarity`]).
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
pub mod extrapolate;
pub mod imputation;
pub mod narrowband;
pub mod sinusoid;
pub mod spikes;
pub mod stationarity;
pub(crate) mod stats;
pub mod step;
#[cfg(test)]
mod testutil;

pub use coupling::{fit_coupling, remove_coupling, Coupling};
pub use narrowband::{
    band_kurtosis, intervals_from_parts, measure_narrowband, remove_narrowband, NarrowBand,
};
pub use sinusoid::{fit_sinusoid, remove_sinusoid, SineFit};
pub use spikes::{find_spikes, find_spikes_on_grid, remove_spikes, Spikes};
pub use stationarity::{split_record, SplitRecord};
pub use step::{find_step, remove_step, Persistence, Step, StepMethod};

#[cfg(test)]
mod tests {
    use super::testutil::*;
    use super::*;

    #[test]
    fn runtime_on_a_million_samples() {
        // Timings only (printed with --nocapture); every call must stay O(n) or O(n log n).
        let n = 1_000_000;
        let mut ch = channel(profile(0));
        ch.temperature_coefficient = 1e-4;
        let mut cols = run(ch, n, 9, Some(temperature()));
        let t = cols.pop().unwrap();
        let y = cols.pop().unwrap();
        let time = |name: &str, f: &mut dyn FnMut()| {
            let start = std::time::Instant::now();
            f();
            let ms = start.elapsed().as_secs_f64() * 1e3;
            println!("runtime on 1e6 samples: {name} {ms:.0} ms");
            ms
        };
        let mut total = 0.0;
        total += time("fit_coupling", &mut || {
            fit_coupling(&y, &t, FS, 0.68).unwrap();
        });
        total += time("find_spikes", &mut || {
            find_spikes(&y, FS);
        });
        total += time("find_step", &mut || {
            find_step(&y, FS, 0.68).unwrap();
        });
        total += time("fit_sinusoid", &mut || {
            fit_sinusoid(&y, FS, 7.3, 1e-8, 0.68).unwrap();
        });
        total += time("split_record", &mut || {
            split_record(&y, FS, 4, 0.68).unwrap();
        });
        assert!(total < 60_000.0);
    }
}
