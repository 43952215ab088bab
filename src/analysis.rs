//! The model stage of `analyze`: for every inertial channel of a recording, the IEEE noise model
//! fitted to its overlapping Allan variance and, separately, to its log-binned Welch spectrum, and
//! the term-by-term agreement of the two.
//!
//! Temperature and aux channels are not fitted: they are regressors for the residual analysis, not
//! sensors. A channel whose kind is not known (no `kind` metadata and a unit that implies none) is
//! not fitted either: the coefficients' units depend on the sensor.
//!
//! A fit that fails (too few τ points, a constant channel) does not fail the file: the channel's
//! entry carries the reason and the other channels go on.

use serde::Serialize;

use crate::avar::{Deviations, Statistic};
use crate::effects::band::{fit_in_band, BandFits, Series};
use crate::effects::ramp::{widen_ramp, RampAction, RampDecision};
use crate::effects::{close_loop_from_base, AuxSeries, LoopConfig, LoopReport};
use crate::estimate::{ChannelDeviations, ChannelPsd};
use crate::model::{
    combine, compare, hull, rounding_warning, BandEdge, Bandwidth, Combined, FitError, FitOptions,
    NoiseFit, Sensor, Term, TermComparison,
};

/// One channel's fits.
#[derive(Debug, Clone, Serialize)]
pub struct ChannelAnalysis {
    pub channel: String,
    pub sensor: Sensor,
    /// The sensor's low-pass roll-off and the band both fits keep (`None`: none detected, or
    /// detection off).
    pub bandwidth: Option<Bandwidth>,
    /// One answer per coefficient from the two fits, the IEEE read-offs and the warnings.
    pub combined: Combined,
    /// IEEE model fitted to the overlapping Allan variance.
    #[serde(serialize_with = "outcome")]
    pub allan: Result<NoiseFit, FitError>,
    /// IEEE model fitted to the log-binned Welch spectrum.
    #[serde(serialize_with = "outcome")]
    pub spectrum: Result<NoiseFit, FitError>,
    /// Spectrum- against Allan-derived value per term, when both fits succeeded.
    pub comparison: Vec<TermComparison>,
    /// The residual loop: effects added to the base model, step by step. The fits above are the
    /// final ones (base terms fitted together with the effects, on the corrected series).
    pub residual_loop: Option<LoopReport>,
    /// The time series' test of a rate ramp the base fits kept, and what it decided (`None`: no
    /// base fit kept one). The loop's own, at its end, is in `residual_loop`.
    pub ramp_test: Option<RampDecision>,
}

fn outcome<S: serde::Serializer>(r: &Result<NoiseFit, FitError>, s: S) -> Result<S::Ok, S::Error> {
    #[derive(Serialize)]
    #[serde(tag = "status", rename_all = "snake_case")]
    enum Outcome<'a> {
        Ok {
            #[serde(flatten)]
            fit: &'a NoiseFit,
        },
        Failed {
            reason: String,
        },
    }
    match r {
        Ok(fit) => Outcome::Ok { fit }.serialize(s),
        Err(e) => Outcome::Failed {
            reason: e.to_string(),
        }
        .serialize(s),
    }
}

impl ChannelAnalysis {
    /// The Allan fit, if it succeeded.
    pub fn allan_fit(&self) -> Option<&NoiseFit> {
        self.allan.as_ref().ok()
    }

    /// The spectrum fit, if it succeeded.
    pub fn spectrum_fit(&self) -> Option<&NoiseFit> {
        self.spectrum.as_ref().ok()
    }

    /// Every rate-ramp decision made on the channel, in order: the base fits' test, then the
    /// loop's last word.
    pub fn ramp_decisions(&self) -> impl Iterator<Item = &RampDecision> {
        let at_end = self.residual_loop.as_ref().and_then(|l| l.ramp.as_ref());
        self.ramp_test.iter().chain(at_end)
    }
}

/// One channel's inputs to the model stage.
#[derive(Debug, Clone, Copy)]
pub struct ChannelInput<'a> {
    pub sensor: Sensor,
    pub psd: &'a ChannelPsd,
    pub deviations: &'a ChannelDeviations,
    /// The clean samples (SI), for the residual loop.
    pub samples: &'a [f64],
    pub rate_hz: f64,
    /// The smallest step between the channel's samples (SI; the quality screen's): the grid of a
    /// digital output, whose rounding [`crate::model::rounding_warning`] weighs against N.
    pub output_step: Option<f64>,
}

/// Fits one channel and, with `loop_cfg`, closes the loop on it (`aux`: channels that may
/// explain part of it, such as temperature). The loop fits with `opts` (`loop_cfg.fit` is not
/// used) and starts from the base fits made here.
pub fn analyze_channel(
    input: ChannelInput<'_>,
    aux: &[AuxSeries<'_>],
    opts: &FitOptions,
    loop_cfg: Option<&LoopConfig>,
) -> ChannelAnalysis {
    let (step, rate_hz, samples) = (input.output_step, input.rate_hz, input.samples.len());
    let mut a = fit_and_close(input, aux, opts, loop_cfg);
    // Where the band's edge was taken for a coarse angle quantiser, Q is the grid's, and the
    // output's grid is that quantiser's, explained by Q: no rate rounding to warn of (a 2-arcsec
    // quantiser, three output levels, was both, its warning saying the sensor's N could not be
    // read while N was read right).
    let angle_grid = a.bandwidth.as_ref().and_then(|b| match b.cause {
        BandEdge::AngleQuantiser { step, .. } => Some(step),
        BandEdge::LowPass => None,
    });
    if let Some(h) = angle_grid {
        span_both_fits(&mut a, Term::Quantization);
        grid_quantisation(&mut a, h, rate_hz);
    }
    let rounding = step
        .filter(|_| angle_grid.is_none())
        .and_then(|h| rounding_warning(h, rate_hz, &a.combined, a.allan_fit(), a.spectrum_fit()));
    a.combined.warnings.extend(rounding);
    let n = a.combined.get(Term::RandomWalk).map(|t| t.value);
    let tail = a
        .residual_loop
        .as_ref()
        .and_then(|r| r.heavy_tail_warning(n, samples, rate_hz));
    a.combined.warnings.extend(tail);
    a
}

/// Q's combined value where the band's edge is a coarse angle quantiser's of output step `step`
/// (SI rate units): the grid's own. An angle quantiser of step h (rad) has Q = h/√12 (IEEE 952),
/// h the output's rate step over the sample rate; the interval is widened to hold it, the fits'
/// readings stay as evidence. On a 2-arcsec quantiser (ten white σ a step) the spectrum's Q read
/// 4.43 arcsec, its own interval excluding the truth, and became the combined value; the grid
/// gives 2.00.
fn grid_quantisation(a: &mut ChannelAnalysis, step: f64, rate_hz: f64) {
    let q = step / (12f64.sqrt() * rate_hz);
    if let Some(t) = a
        .combined
        .terms
        .iter_mut()
        .find(|t| t.term == Term::Quantization)
    {
        if q.is_finite() && q > 0.0 {
            t.value = q;
            (t.lo, t.hi) = hull((t.lo, t.hi), (q, q));
            t.one_sigma = hull(t.one_sigma, (q, q));
        }
    }
}

/// `term`'s combined interval widened to the hull of both fits' intervals: for Q where the band's
/// edge is a coarse angle quantiser's (`effects::angle_grid`). Its rounding error is correlated
/// from sample to sample, IEEE 952's Q form describes it only roughly, and each fit's Q is off in
/// its own way: on 30-min records at 3.5 σ per step the spectrum's read 1.06–1.08× the truth with a
/// ±2 % interval that excluded it (the correlated error's +5 % excess at 10–20 Hz), the Allan
/// fit's 0.82–1.11× with a wide one (its shortest τ cut at the edge). The hull covers both.
fn span_both_fits(a: &mut ChannelAnalysis, term: Term) {
    let fits: Vec<_> = [a.allan_fit(), a.spectrum_fit()]
        .into_iter()
        .flatten()
        .filter_map(|f| f.get(term).map(|e| ((e.lo, e.hi), e.one_sigma)))
        .collect();
    if fits.len() < 2 {
        return;
    }
    if let Some(t) = a.combined.terms.iter_mut().find(|t| t.term == term) {
        for (reported, one_sigma) in fits {
            (t.lo, t.hi) = hull((t.lo, t.hi), reported);
            t.one_sigma = hull(t.one_sigma, one_sigma);
        }
        t.hull = true;
    }
}

/// The base fits and the residual loop of [`analyze_channel`].
fn fit_and_close(
    input: ChannelInput<'_>,
    aux: &[AuxSeries<'_>],
    opts: &FitOptions,
    loop_cfg: Option<&LoopConfig>,
) -> ChannelAnalysis {
    let (mut a, options, ramp) = fit_channel(&input, opts);
    let (Some(cfg), Some(binned), Some(dev)) =
        (loop_cfg, &input.psd.binned, oadev(input.deviations))
    else {
        bound_dropped_ramp(&mut a);
        return a;
    };
    // The loop fits and searches with the base fits' options, inside the band they kept (its
    // own `fit` options are replaced by them, so that the base fits handed to it are its own).
    let mut cfg = cfg.clone();
    cfg.fit = options;
    let initial = (dev.clone(), input.psd.psd.clone(), binned.clone());
    // The base fits were made above with these options on these estimates: handed over, not
    // repeated.
    let base = (a.allan.clone().ok(), a.spectrum.clone().ok());
    if let Some(outcome) =
        close_loop_from_base(input.samples, input.rate_hz, aux, &cfg, initial, base)
    {
        let report = &outcome.report;
        if !report.steps.is_empty()
            || report.rival.is_some()
            || report.ramp.is_some()
            || report.k_or_coupling.is_some()
        {
            for (fit, out) in [
                (&mut a.allan, outcome.allan),
                (&mut a.spectrum, outcome.spectrum),
            ] {
                if let Some(mut f) = out {
                    // The loop's refits keep a determined ramp's Fisher interval only.
                    if let Some(test) = ramp.as_ref().and_then(RampDecision::widening) {
                        widen_ramp(&mut f, test);
                    }
                    *fit = Ok(f);
                }
            }
            a.comparison = comparison(&a.allan, &a.spectrum);
            let final_dev = outcome.report.corrected.as_ref().map_or(dev, |(d, _)| d);
            a.combined = combine(a.allan_fit(), a.spectrum_fit(), Some(final_dev));
        }
        a.combined.warnings.extend(outcome.report.warnings());
        a.residual_loop = Some(outcome.report);
    }
    bound_dropped_ramp(&mut a);
    a
}

/// Where the last decision on the rate ramp dropped it (the series did not determine it beside
/// the random walk), the Allan fit, made again without R, has no word on R at all: the series'
/// bound, |R̂| + z·SE at the run's confidence, is R's upper limit. Without one, a screen called
/// an R over its limit `no_estimate` (2 of 3 2-h records with a ramp of 40 °/h² against a limit
/// of 30: unflagged), and no table had an R row.
fn bound_dropped_ramp(a: &mut ChannelAnalysis) {
    let Some(test) = a
        .ramp_decisions()
        .last()
        .filter(|d| d.action == RampAction::Dropped)
        .map(|d| d.test)
    else {
        return;
    };
    let Ok(fit) = a.allan.as_mut() else {
        return;
    };
    let r = Term::RateRamp;
    if fit.get(r).is_some() || fit.upper_limits.iter().any(|u| u.term == r) {
        return;
    }
    let z = crate::stats::norm_isf((1.0 - fit.confidence) / 2.0);
    let upper = test.ramp.abs() + z * test.se;
    if upper.is_finite() {
        let limit = crate::model::UpperLimit {
            term: r,
            upper,
            beside_kept: test.ramp.abs() + test.se,
            one_sigma: test.ramp.abs() + test.se,
        };
        fit.upper_limits.push(limit);
        // The combined result was made from the fits before this bound existed: it takes the
        // bound too (8-h FOG records whose ramp was dropped had R in no table and no limit).
        let combined = &mut a.combined;
        if !combined.terms.iter().any(|t| t.term == r)
            && !combined.limits.iter().any(|u| u.term == r)
        {
            combined.limits.push(limit);
        }
    }
}

/// The base fits of one channel from its estimates, and the options they were made with: the OADEV
/// of `input.deviations` and the binned spectrum of `input.psd`, inside the sensor's bandwidth
/// when `opts.detect_bandwidth` and the spectrum shows a roll-off, a rate ramp only where the
/// samples determine it ([`fit_in_band`]). `input.output_step`, the smallest step between the
/// samples, tells a coarse angle quantiser's edge from a filter's (the fits are then made again
/// without the filter's response).
fn fit_channel(
    input: &ChannelInput<'_>,
    opts: &FitOptions,
) -> (ChannelAnalysis, FitOptions, Option<RampDecision>) {
    let (psd, dev) = (input.psd, oadev(input.deviations));
    let series = Series {
        samples: input.samples,
        output_step: input.output_step,
    };
    let BandFits {
        bandwidth,
        options,
        allan,
        spectrum,
        ramp,
    } = fit_in_band(dev, &psd.psd, psd.binned.as_ref(), opts, series);
    let analysis = ChannelAnalysis {
        channel: psd.channel.clone(),
        sensor: input.sensor,
        bandwidth,
        combined: combine(allan.as_ref().ok(), spectrum.as_ref().ok(), dev),
        comparison: comparison(&allan, &spectrum),
        allan,
        spectrum,
        residual_loop: None,
        ramp_test: ramp,
    };
    (analysis, options, ramp)
}

/// The overlapping Allan variance among a channel's statistics.
pub fn oadev(deviations: &ChannelDeviations) -> Option<&Deviations> {
    deviations
        .statistics
        .iter()
        .find(|d| d.statistic == Statistic::Oadev)
}

/// The term-by-term comparison, when both fits succeeded.
fn comparison(
    allan: &Result<NoiseFit, FitError>,
    spectrum: &Result<NoiseFit, FitError>,
) -> Vec<TermComparison> {
    match (allan, spectrum) {
        (Ok(a), Ok(s)) => compare(a, s),
        _ => Vec::new(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::effects::ramp::tests::{octave_oadev, series};
    use crate::psd::{log_bin, welch, WelchConfig};

    /// Clean 30-min records whose Allan fit alone keeps a ramp that the series does not show
    /// (the seeds of `effects::band`'s test): the ramp is dropped, and R still has an upper limit,
    /// the series' |R̂| + z·SE, with and without the loop.
    #[test]
    fn a_dropped_ramp_keeps_an_upper_limit() {
        let fs = 100.0;
        for seed in [163, 166, 175] {
            let y = series(11_000_000 + seed, 0.0);
            let psd = welch(&y, fs, &WelchConfig::new(4096)).unwrap();
            let binned = log_bin(&psd, 20);
            let psd = ChannelPsd {
                channel: "g".into(),
                psd,
                binned: Some(binned),
            };
            let deviations = ChannelDeviations {
                channel: "g".into(),
                statistics: vec![octave_oadev(&y)],
            };
            let input = ChannelInput {
                sensor: Sensor::Gyro,
                psd: &psd,
                deviations: &deviations,
                samples: &y,
                rate_hz: fs,
                output_step: None,
            };
            let cfg = LoopConfig::with_segment(4096);
            for with_loop in [None, Some(&cfg)] {
                let a = analyze_channel(input, &[], &FitOptions::default(), with_loop);
                let d = a.ramp_decisions().last().copied().expect("decided");
                assert_eq!(d.action, RampAction::Dropped, "seed {seed}");
                let fit = a.allan_fit().unwrap();
                assert!(fit.get(Term::RateRamp).is_none());
                let upper = crate::model::upper_limit(Some(fit), a.spectrum_fit(), Term::RateRamp)
                    .expect("an upper limit of R");
                let z = crate::stats::norm_isf((1.0 - fit.confidence) / 2.0);
                let want = d.test.ramp.abs() + z * d.test.se;
                assert!(
                    (upper / want - 1.0).abs() < 1e-12,
                    "seed {seed}: {upper} vs {want}"
                );
            }
        }
    }
}
