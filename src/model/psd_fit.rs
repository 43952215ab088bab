//! The noise model fitted to a log-binned Welch spectrum.
//!
//! Points: the bands of a [`BinnedPsd`] between the lowest usable frequency and the top. Welch
//! output is one-sided (every bin but DC and Nyquist doubled), the model two-sided, so each band
//! value is halved: S = S₁/2. Basis: each term's two-sided PSD as sampled data have it
//! ([`Term::psd_sampled_unit`]: the IEEE form averaged over the sample interval and folded at
//! Nyquist, which matters for B and K near Nyquist; quantisation's (4Q²/τ₀)·sin²(πfτ₀) is already
//! that of a sampled angle and is what identifies Q there), averaged over the very bins the band
//! averaged (not evaluated at the band centre, which for 1/f² and 1/f³ in wide bands would be
//! biased). Variance of each point: 2μ²/ν with the band's EDF, which accounts for the window,
//! overlap and the correlation between the bins of a band; the correlation between neighbouring
//! bands (large where bands are single bins) is modelled too (`band_correlation.rs`).
//!
//! Lowest bins: excluded below 4·fs/nperseg by default. The per-segment detrend removes power
//! there (with Hann and constant detrend bin 1 reads 1/6 low for white noise; more for steep
//! spectra), and a deterministic drift (rate ramp, warm-up) appears only there. A rate ramp is
//! therefore invisible to this fit, whatever its size.
//!
//! Leakage: the window's spectral window averages a curved spectrum over about ±1 bin, so a
//! spectrum ∝ f^−p reads high by ≈ p(p+1)σ²/(2f²) (Hann: σ² = 1/3 bin², so 6 % for 1/f² and
//! 12.5 % for 1/f³ at bin 4). The basis carries that excess, to second order: uncorrected, it
//! biased K high by 1.8 % (mean of 100 records whose K shows only in the lowest bands; 0.4 % with
//! the correction). Windows with poor leakage (boxcar) have no finite σ² to speak of and should
//! not be used on red spectra.

use crate::memo::Memo;
use crate::psd::{BinnedPsd, Psd, Scaling, Window};

use super::band_correlation::band_correlation;
use super::correlation::Correlation;
use super::fit::{Problem, BASE, EFFECT, TERMS};
use super::result::Domain;
use super::select::select_and_fit;
use super::{EffectShape, FitError, FitOptions, NoiseFit, Term};

/// Second moment (Hz²) of the window's spectral window |W(ν)|²/Σw²: a Welch bin averages the
/// spectrum over ±σ around its frequency, so a curved spectrum reads high by ½S″σ² (Hann: σ² =
/// 1/3 bin², 6 % for 1/f² at bin 4). From Parseval, σ² = fs²·Σ(Δw)²/(4π²·Σw²), with the window
/// taken as zero outside the segment.
fn leakage_spread2(psd: &Psd) -> f64 {
    // Σ(Δw)²/Σw² per (window, length), remembered: every fit of the loop's profiles asks again,
    // and the window takes a cosine per sample to rebuild.
    static RATIOS: Memo<(Window, usize), f64> = Memo::new(8);
    let ratio = RATIOS.get_or((psd.window.clone(), psd.nperseg), || {
        let w = psd.window.coefficients(psd.nperseg).ok()?;
        let sum_w2: f64 = w.iter().map(|v| v * v).sum();
        let edges = w.first().map_or(0.0, |v| v * v) + w.last().map_or(0.0, |v| v * v);
        let diff2: f64 = w.windows(2).map(|p| (p[1] - p[0]).powi(2)).sum::<f64>() + edges;
        (sum_w2 > 0.0).then(|| diff2 / sum_w2)
    });
    ratio.map_or(0.0, |r| {
        psd.rate_hz * psd.rate_hz * r / (4.0 * std::f64::consts::PI.powi(2))
    })
}

/// Fits the IEEE terms to `binned`, the log-binned form of `psd` (which supplies the sample rate,
/// segment length and bin width).
///
/// ```
/// use imunoise::psd::{log_bin, welch, WelchConfig};
/// use imunoise::model::{fit_psd, FitOptions, Term};
/// # let y: Vec<f64> = imunoise::sim::rng::Rng::new(2).gauss_vec(200_000);
/// // y: rate samples at 100 Hz, white with σ = 1: N = 0.1 (two-sided PSD N² = σ²/fs).
/// let psd = welch(&y, 100.0, &WelchConfig::new(4096))?;
/// let fit = fit_psd(&psd, &log_bin(&psd, 10), &FitOptions::default())?;
/// let n = fit.get(Term::RandomWalk).unwrap();
/// assert!((n.value - 0.1).abs() < 0.002);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
///
/// # Errors
/// [`FitError::NotDensity`] for a power spectrum, [`FitError::InvalidOptions`] for a band limit
/// that is not a positive number, [`FitError::TooFewPoints`] when fewer than two bands remain,
/// [`FitError::NoSignal`] if every candidate is zero.
pub fn fit_psd(psd: &Psd, binned: &BinnedPsd, opts: &FitOptions) -> Result<NoiseFit, FitError> {
    fit_psd_with(psd, binned, opts, None)
}

/// [`fit_psd`] with an effect's column fitted together with the base terms (see
/// [`fit_avar_with`](super::fit_avar_with)).
pub fn fit_psd_with(
    psd: &Psd,
    binned: &BinnedPsd,
    opts: &FitOptions,
    effect: Option<&dyn EffectShape>,
) -> Result<NoiseFit, FitError> {
    let (problem, x, _) = spectrum_problem(psd, binned, opts, effect)?;
    let forced = if effect.is_some() { 1 << EFFECT } else { 0 }
        | (opts.required_mask() & spectrum_terms(opts));
    select_and_fit(
        &problem,
        &problem,
        &x,
        spectrum_terms(opts),
        forced,
        opts,
        Domain::Spectrum,
    )
}

/// The terms a spectrum fit may choose among: those `opts` allows but the rate ramp. A ramp is a
/// drift; it lives in the bins below the fit band (see the module doc), so an R the spectrum fit
/// keeps is only an f⁻³ stand-in for the red power of B and K in its lowest bands. Allowed, it
/// was kept in 23 of 200 clean 30-min records (N, B, K; no ramp) and printed as a rate ramp of
/// ≈ 1e-5 rad/s² with intervals as narrow as ±30 %.
pub(crate) fn spectrum_terms(opts: &FitOptions) -> u8 {
    opts.mask() & !(1 << Term::RateRamp.index())
}

/// Per band of a spectrum problem: the frequencies its basis is averaged over and each base
/// term's sampled PSD there (leakage included), kept so that a filter response can reweight the
/// basis without recomputing it ([`filtered_basis`]).
pub(crate) type BandSamples = Vec<Vec<BasisSample>>;

/// A frequency and each base term's sampled PSD there.
pub(crate) type BasisSample = (f64, [f64; BASE]);

/// The spectrum fit's problem, the band centres of its points and the basis samples: the bands of
/// `binned` inside the fit band of `opts`, each term's sampled PSD averaged over the band's bins.
/// Bands this far below the median band are dead: no IEEE term and no roll-off the fits model
/// reaches there (see [`without_dead_bands`]).
pub const DEAD_BAND: f64 = 1e-6;

/// `keep` without the bands whose value lies more than 60 dB below the median of the bands kept:
/// a digital filter's zero at Nyquist (the bilinear transform puts one there) leaves the top band
/// 10⁻¹¹ of the floor on a 400-Hz gyro behind a 100-Hz second-order filter, where the band ends
/// in the zero's four bins. Such a band holds only leakage and rounding, and its weight — the
/// fits start from weights set by the data, so a point that far below every model dominates the
/// first solution — drove every candidate model to zero: no spectrum fit, no filter found, and
/// the Allan fit alone, its shortest τ inside the filter's transition, read B 80× the truth.
fn without_dead_bands(keep: Vec<usize>, value: &[f64]) -> Vec<usize> {
    let mut sorted: Vec<f64> = keep.iter().map(|&b| value[b]).collect();
    if sorted.is_empty() {
        return keep;
    }
    sorted.sort_by(f64::total_cmp);
    let median = sorted[sorted.len() / 2];
    keep.into_iter()
        .filter(|&b| value[b] >= DEAD_BAND * median)
        .collect()
}

pub(crate) fn spectrum_problem(
    psd: &Psd,
    binned: &BinnedPsd,
    opts: &FitOptions,
    effect: Option<&dyn EffectShape>,
) -> Result<(Problem, Vec<f64>, BandSamples), FitError> {
    if psd.scaling != Scaling::Density {
        return Err(FitError::NotDensity);
    }
    let f_min = match opts.min_freq_hz {
        Some(f) if f.is_nan() || f < 0.0 => {
            return Err(FitError::InvalidOptions(format!("min_freq_hz = {f}")))
        }
        Some(f) => f,
        None => 4.0 * psd.rate_hz / psd.nperseg.max(1) as f64,
    };
    let f_max = match opts.max_freq_hz {
        Some(f) if f.is_nan() || f <= 0.0 => {
            return Err(FitError::InvalidOptions(format!("max_freq_hz = {f}")))
        }
        Some(f) => f,
        None => f64::INFINITY,
    };
    let df = psd.bin_width_hz();
    let keep: Vec<usize> = (0..binned.freq_hz.len())
        .filter(|&b| {
            let f = binned.freq_hz[b];
            f >= f_min
                && f <= f_max
                && binned.value[b] > 0.0
                && binned.value[b].is_finite()
                && binned.dof[b] > 0.0
        })
        .collect();
    let keep = without_dead_bands(keep, &binned.value);
    let spread2 = leakage_spread2(psd);
    let samples: BandSamples = keep
        .iter()
        .map(|&b| {
            let bins = binned.bins[b].max(1);
            let first = binned.f_lo_hz[b] + df / 2.0;
            // Bins of the band the basis is averaged over: all of them up to 64, else 64 evenly
            // spaced (a midpoint rule over sub-blocks of a band at most 1/10 decade wide: exact
            // to ~1e-6 for these smooth shapes, and a long record's top bands hold 10⁵ bins).
            let count = bins.min(64);
            (0..count)
                .map(|k| {
                    let i = ((f64::from(k) + 0.5) * f64::from(bins) / f64::from(count)).floor();
                    let f = first + i * df;
                    let gain = opts.lowpass.map_or(1.0, |lp| lp.power_gain(f));
                    let values = std::array::from_fn(|j| {
                        let term = Term::ALL[j];
                        // Second-order leakage of S ∝ f^−p: ½S″·σ² = S·p(p+1)σ²/(2f²).
                        let p = -f64::from(term.alpha());
                        let leak = 1.0 + p * (p + 1.0) * spread2 / (2.0 * f * f);
                        // The sensor's filter acts on the rate before the output is rounded.
                        let filtered = if term == Term::Quantization {
                            1.0
                        } else {
                            gain
                        };
                        term.psd_sampled_unit(f, psd.rate_hz) * leak * filtered
                    });
                    (f, values)
                })
                .collect()
        })
        .collect();
    let basis = samples
        .iter()
        .map(|band| {
            let mean = |v: &dyn Fn(&BasisSample) -> f64| {
                band.iter().map(v).sum::<f64>() / band.len().max(1) as f64
            };
            std::array::from_fn(|j| {
                if j == EFFECT {
                    effect.map_or(0.0, |e| mean(&|s| e.psd_unit(s.0, psd.rate_hz)))
                } else {
                    mean(&|s| s.1[j])
                }
            })
        })
        .collect();
    let problem = Problem {
        value: keep.iter().map(|&b| binned.value[b] / 2.0).collect(),
        basis,
        edf: keep.iter().map(|&b| [binned.dof[b]; TERMS]).collect(),
        corr: band_correlation(psd, binned, &keep).and_then(Correlation::fixed),
        cross: Vec::new(),
    };
    let x: Vec<f64> = keep.iter().map(|&b| binned.freq_hz[b]).collect();
    Ok((problem, x, samples))
}

/// The base terms' basis of `samples` with every column but quantisation's multiplied by the
/// filter's power gain |H(f)|² (`gain(band, k)`: at sample k of the band): the sensor's filter
/// acts on the rate before the output is rounded to its quantisation step. The effect column is
/// 0.
pub(crate) fn filtered_basis(
    samples: &BandSamples,
    gain: impl Fn(usize, usize) -> f64,
) -> Vec<[f64; TERMS]> {
    let q = Term::Quantization.index();
    samples
        .iter()
        .enumerate()
        .map(|(b, band)| {
            let mut out = [0.0; TERMS];
            for (k, (_, v)) in band.iter().enumerate() {
                let g = gain(b, k);
                for j in 0..BASE {
                    out[j] += if j == q { v[j] } else { g * v[j] };
                }
            }
            out.map(|x| x / band.len().max(1) as f64)
        })
        .collect()
}
