//! The evidence that tells a sensor's roll-off from the skirt of a strong narrowband excess.
//!
//! [`super::detect_bandwidth`] compares the IEEE model with and without a low-pass response on
//! the spectrum's bands, narrow excesses (lines, resonances) left out. A resonance's peak is such
//! an excess, but its skirt is not: a band-pass resonance (a rate of a mode, no plateau below
//! f₀) as strong as the sensor's white noise lifts the spectrum by 10–30 % for an octave above
//! its peak and falls back to the white floor as f⁻². A model that lacks the resonance reads that
//! fall as a roll-off over a floor (an order-8 "filter" at 12.6 Hz over a 100-Hz record's
//! quantisation column, for a Q-20 resonance at 8 Hz, in 50 of 50 records), and the fit band then
//! ends at 10 Hz, the resonance's skirt and half the spectrum cut away.
//!
//! [`RollOffCheck`] holds the spectrum problem on which the question is asked again with the
//! strongest excess modelled: the bands that are no narrow excess, plus the run of excess bands
//! around the strongest one, with an effect column the caller fills with a shape (a resonance, in
//! [`crate::effects::band`], which searches its f₀ and Q) and the base terms' columns with and
//! without the filter's response. The filter stands only if it still improves the model by
//! [`super::bandwidth::DETECT_BIC`] once the excess has its own shape.

use super::bandwidth::narrow_excess;
use super::fit::{Mask, Problem};
use super::psd_fit::{filtered_basis, spectrum_problem, spectrum_terms, BandSamples};
use super::terms::{BASE, EFFECT, TERMS};
use super::{EffectShape, FitOptions, LowPass};
use crate::psd::{BinnedPsd, Psd};

/// The spectrum problem of one roll-off and the strongest narrow excess beside it.
pub struct RollOffCheck {
    problem: Problem,
    samples: BandSamples,
    filtered: Vec<[f64; TERMS]>,
    mask: Mask,
    rate_hz: f64,
    /// Frequency of the excess's highest raw bin (Hz): where a shape's search starts.
    pub peak_hz: f64,
    /// The excess's band range (Hz).
    pub run_hz: (f64, f64),
}

impl RollOffCheck {
    /// The check of `lowpass` on `psd` (binned as `binned`, every band of `opts`' range but its
    /// own filter's restriction), or `None` where the spectrum holds no narrow excess.
    pub fn new(
        psd: &Psd,
        binned: &BinnedPsd,
        opts: &FitOptions,
        lowpass: &LowPass,
    ) -> Option<RollOffCheck> {
        let unfiltered = FitOptions {
            lowpass: None,
            max_freq_hz: None,
            ..opts.clone()
        };
        let (full, _, samples) = spectrum_problem(psd, binned, &unfiltered, None).ok()?;
        if full.len() < 8 {
            return None;
        }
        let excess: Vec<bool> = (0..full.len()).map(|i| narrow_excess(&full, i)).collect();
        // The strongest excess with bands on either side (the highest band over the median of
        // all): a band at either end of the spectrum stands above its neighbours on one side
        // only, which a rise does as well as a peak (an angle quantiser's f² towards Nyquist,
        // where a resonance then "explained" a filter's edge over the quantisation floor).
        let n = full.len();
        let mut sorted = full.value.clone();
        sorted.sort_by(f64::total_cmp);
        let median = sorted[sorted.len() / 2];
        let run_of = |i: usize| {
            let (mut first, mut last) = (i, i);
            while first > 0 && excess[first - 1] {
                first -= 1;
            }
            while last + 1 < n && excess[last + 1] {
                last += 1;
            }
            (first, last)
        };
        let top = (0..n)
            .filter(|&i| excess[i])
            .filter(|&i| {
                let (first, last) = run_of(i);
                first >= 3 && last + 3 < n
            })
            .max_by(|&a, &b| (full.value[a] / median).total_cmp(&(full.value[b] / median)))?;
        let (first, last) = run_of(top);
        let keep: Vec<usize> = (0..full.len())
            .filter(|&i| !excess[i] || (first..=last).contains(&i))
            .collect();
        let half_bin = psd.bin_width_hz() / 2.0;
        let run_hz = (
            samples[first].first()?.0 - half_bin,
            samples[last].last()?.0 + half_bin,
        );
        let peak_hz = psd
            .freq_hz
            .iter()
            .zip(&psd.value)
            .filter(|(f, _)| (run_hz.0..=run_hz.1).contains(*f))
            .max_by(|a, b| a.1.total_cmp(b.1))
            .map(|(&f, _)| f)?;
        let samples: BandSamples = keep.iter().map(|&i| samples[i].clone()).collect();
        let filtered = filtered_basis(&samples, |b, k| lowpass.power_gain(samples[b][k].0));
        Some(RollOffCheck {
            problem: full.subset(&keep),
            filtered,
            samples,
            mask: spectrum_terms(opts),
            rate_hz: psd.rate_hz,
            peak_hz,
            run_hz,
        })
    }

    /// −2 ln L of the base terms plus `shape` (its power free), with the filter's response on
    /// the base terms or without; infinite where the fit fails.
    pub fn neg2ll(&self, shape: &dyn EffectShape, filtered: bool) -> f64 {
        let mut p = self.problem.clone();
        for (i, band) in self.samples.iter().enumerate() {
            let mean = band
                .iter()
                .map(|s| shape.psd_unit(s.0, self.rate_hz))
                .sum::<f64>()
                / band.len().max(1) as f64;
            if filtered {
                p.basis[i][..BASE].copy_from_slice(&self.filtered[i][..BASE]);
            }
            p.basis[i][EFFECT] = mean;
        }
        let fit = p.irls(self.mask | (1 << EFFECT));
        let (_, _, ll) = p.likelihood(&fit);
        if ll.is_nan() {
            f64::INFINITY
        } else {
            ll
        }
    }

    /// What the filter's two parameters (corner, order) are charged: 2 ln n.
    pub fn filter_penalty(&self) -> f64 {
        2.0 * (self.problem.len() as f64).ln()
    }
}
