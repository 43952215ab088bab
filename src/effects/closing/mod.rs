//! The loop that closes the model: fit, look at what is left, trace it to an effect, add the
//! effect, refit everything, keep it only if the information criterion improves, repeat.
//!
//! Each round every candidate of the catalogue is tried on the current state and the one with the
//! lowest ΔBIC below [`ADMIT_BIC`] (−6) is taken:
//! - time-domain effects: spikes and a bias step ([`super::time`]), coupling to each aux channel
//!   (temperature) and a drift shape (settling, curvature), both regressed under the fitted noise
//!   model ([`super::slow`]), an excursion (the mean leaving and coming back, every box of blocks
//!   regressed under the same model: [`super::excursion`]), and a sinusoid at each line the raw spectrum shows over the model
//!   ([`super::lines`]); they are removed from the series, and the spectrum and the Allan variance
//!   are recomputed (on the CPU) and refitted. Their ΔBIC is the time-domain one the detectors
//!   report (an honest effective sample count, search-corrected); a coupling, a drift or an
//!   excursion is proposed only when its family-wise p-value is below [`DETECTION_P`] as well;
//! - stochastic effects ([`super::shapes`]): a first-order Gauss–Markov process (profiled over its
//!   correlation time) and a resonance (at an excess too wide to be a line); they enter both fits
//!   as one more column fitted with the base terms. Their ΔBIC is the sum over the two domains of
//!   the change of the best candidate's score, with one more parameter per shape parameter; where
//!   the spectrum fit's band can see the effect its share must itself be negative (its bands are
//!   close to independent), where it cannot (a Gauss–Markov knee below its lowest band) only the
//!   Allan domain votes. One stochastic effect at most: the fitting engine has one effect column.
//!
//! The loop stops when no candidate improves the criterion by that much, or after [`MAX_STEPS`]
//! additions. The candidate of the last round that was not admitted but scored within
//! [`SELECTION_WINDOW`] of the final model (a stochastic effect, or a slow effect with some
//! evidence: [`RIVAL_SLOW_P`]) is its [`Rival`]: the final coefficients are averaged over both
//! models by BIC weight (an effect that is there but short of strong evidence otherwise left the
//! IEEE terms that absorb its power with intervals as if it were known to be absent).
//! Every step records the error before and after (χ²/dof and RMS log residual in both domains).

use std::borrow::Cow;

use rayon::prelude::*;
use serde::Serialize;

use crate::avar::{compute, compute_owned, Confidence, Deviations, Statistic, TauGrid};
use crate::model::{
    average_with_rival, bic_weight, fit_avar_with, fit_psd_with, Bandwidth, Coefficients,
    EffectEstimate, EffectShape, FitOptions, FitWarning, NoiseFit, Term, SELECTION_WINDOW,
};
use crate::psd::{
    log_bin, log_bin_resolving, neighbour_redundancy, welch, BinnedPsd, Psd, WelchConfig,
};

use super::band::{fit_in_band, Series};
use super::excursion::{
    excursion_under_model, remove_excursion, BoxSearch, Excursion, LevelChange,
};
use super::lines::{find_excess, Excess};
use super::ramp::{
    ramp_free_coefficients, ramp_null_coefficients, test_ramp_beside, widen_ramp, without_ramp,
    RampAction, RampDecision, RampTest, TestedSeries, HINT_P,
};
use super::regression::{IncrementModel, MAX_INCREMENTS};
use super::residuals::{diagnose, Diagnostics};
use super::shapes::{GaussMarkov1, Resonance, ResonanceForm};
use super::shift::{step_from_search, step_under_model};
use super::slow::{
    coupling_under_model, drift_in, drift_under_model, remove_drift, Drift, DriftShapes,
    DETECTION_P,
};
use super::time::stats::norm_isf;
use super::time::{
    band_kurtosis, find_spikes_on_grid, find_step, fit_coupling, fit_sinusoid,
    intervals_from_parts, measure_narrowband, remove_coupling, remove_narrowband, remove_sinusoid,
    remove_spikes, remove_step, split_record, Coupling, NarrowBand, Persistence, SineFit, Spikes,
    SplitRecord, Step, StepMethod,
};

mod peak;
mod slow_candidates;
mod stochastic;

pub use peak::{fit_peak_resonance, PeakResonance};

use slow_candidates::slow_candidates;
use stochastic::{gauss_markov_candidate, resonance_candidate};

/// Most effects added to one channel.
pub const MAX_STEPS: usize = 8;
/// ΔBIC an effect must reach to be added: "strong" evidence on the Kass–Raftery scale (a
/// Bayes factor of e³ ≈ 20). Between 0 and −6 the screen of pure IEEE noise (200 records × 4
/// noise profiles) found only false additions — weak Gauss–Markov humps and a short noise
/// excursion taken for a step, whose removal then planted a real one.
pub const ADMIT_BIC: f64 = -6.0;
/// Family-wise false-alarm probability of the raw-spectrum line search.
const LINE_P: f64 = 1e-3;

/// How the estimates are recomputed after a time-domain correction.
#[derive(Debug, Clone)]
pub struct LoopConfig {
    pub welch: WelchConfig,
    pub bins_per_decade: u32,
    pub taus: TauGrid,
    pub confidence: Confidence,
    pub fit: FitOptions,
    /// Stretches of the series (start, end; seconds from its first sample) that the quality
    /// screen filled with a straight line (`--on-gap fill`), or (t, t) where it joined a gap's
    /// sides (`--on-gap ignore`): no level change is claimed at them.
    pub filled_s: Vec<(f64, f64)>,
}

impl LoopConfig {
    /// The settings `analyze` uses by default, with Welch segments of `nperseg` samples: 20 log
    /// bins per decade, octave τ, 1σ intervals, the default fit options.
    pub fn with_segment(nperseg: usize) -> Self {
        LoopConfig {
            welch: WelchConfig::new(nperseg),
            bins_per_decade: 20,
            taus: TauGrid::Octave,
            confidence: Confidence::OneSigma,
            fit: FitOptions::default(),
            filled_s: Vec::new(),
        }
    }
}

/// Seconds either side of a filled stretch within which a level change is taken for the fill's.
const FILLED_MARGIN_S: f64 = 0.5;

/// Share of an excursion's box that a filled stretch may cover before the box is taken for the
/// fill's.
const FILLED_BOX_SHARE: f64 = 0.25;

/// Why a step or an excursion is not proposed where it meets a stretch the quality screen filled
/// with a straight line: a line drawn between two single noisy samples sits off the local mean by
/// up to the white noise and carries none, so a step at its ends or an excursion over it was the
/// fill's (a 5-s gap filled in a 100-Hz gyro gave two "steps" of ±170 °/h and an "excursion").
/// A level change meets the stretch where its time, or any time of its interval, lies within
/// [`FILLED_MARGIN_S`] of it; an excursion also where the stretch covers [`FILLED_BOX_SHARE`] of
/// its box (a 10-s fill in a 200-Hz record gave excursions of 14–15 s around it, their ends at
/// the resolution of the scan's blocks, 1.5–3 s away).
fn on_filled_stretch(effect: &Effect, filled: &[(f64, f64)]) -> Option<String> {
    let span = |t: f64, interval: Option<(f64, f64)>| {
        interval.map_or((t, t), |(lo, hi)| (lo.min(t), hi.max(t)))
    };
    type Span = (f64, f64);
    let (times, boxed): (Vec<Span>, Option<Span>) = match effect {
        Effect::Step(s) => (vec![span(s.time_s, s.time_interval_s)], None),
        Effect::Excursion(e) => (
            vec![
                span(e.start_s, e.start_interval_s),
                span(e.end_s, e.end_interval_s),
            ],
            Some((e.start_s, e.end_s)),
        ),
        _ => return None,
    };
    let (a, b) = filled.iter().copied().find(|&(a, b)| {
        let near = times
            .iter()
            .any(|&(lo, hi)| hi >= a - FILLED_MARGIN_S && lo <= b + FILLED_MARGIN_S);
        let covers = boxed.is_some_and(|(start, end)| {
            let overlap = end.min(b) - start.max(a);
            end > start && overlap >= FILLED_BOX_SHARE * (end - start)
        });
        near || covers
    })?;
    Some(if a == b {
        format!(
            "not proposed: at the gap joined over at {a:.3} s (--on-gap ignore), where the \
             series jumps by what the sensor did in the missing time"
        )
    } else {
        format!(
            "not proposed: at the gap filled with a straight line from {a:.3} s to {b:.3} s \
             (--on-gap fill), which is no measurement"
        )
    })
}

/// A channel that may explain part of the signal (temperature, any aux channel).
#[derive(Debug, Clone, Copy)]
pub struct AuxSeries<'a> {
    pub name: &'a str,
    pub samples: &'a [f64],
}

/// An effect the loop added, with its parameters and intervals (SI).
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Effect {
    /// A line: a sinusoid fitted in the time domain and removed.
    Sinusoid(SineFit),
    /// A narrowband resonance (second-order Gauss–Markov) of centre `f0_hz`, quality factor `q`
    /// and standard deviation `sigma` (interval from the spectrum fit).
    Resonance {
        f0_hz: f64,
        /// Profile-likelihood interval of f₀.
        f0_lo: f64,
        f0_hi: f64,
        q: f64,
        /// Profile-likelihood interval of Q.
        q_lo: f64,
        q_hi: f64,
        /// Which output of the resonator the spectrum shows below its peak (a plateau or none).
        form: ResonanceForm,
        sigma: EffectEstimate,
    },
    /// A first-order Gauss–Markov process: correlation time with its profile-likelihood interval,
    /// and standard deviation (its interval joined over that of Tc).
    GaussMarkov {
        tc_s: f64,
        tc_lo_s: f64,
        tc_hi_s: f64,
        sigma: EffectEstimate,
    },
    /// Linear coupling to an aux channel, regressed out.
    Coupling { aux: String, fit: Coupling },
    /// A bias drift the IEEE terms lack (a settling, a curvature), removed.
    Drift(Drift),
    /// Spikes, replaced by the local level.
    Spikes(Spikes),
    /// A bias step, removed.
    Step(Step),
    /// The mean leaving and coming back (a step and its return), removed.
    Excursion(Excursion),
    /// A line with a width (a wandering line), measured and removed.
    Narrowband(NarrowBand),
}

impl Effect {
    /// A short name: `sinusoid`, `resonance`, …
    pub fn kind(&self) -> &'static str {
        match self {
            Effect::Sinusoid(_) => "sinusoid",
            Effect::Resonance { .. } => "resonance",
            Effect::GaussMarkov { .. } => "gauss_markov",
            Effect::Coupling { .. } => "coupling",
            Effect::Drift(_) => "drift",
            Effect::Spikes(_) => "spikes",
            Effect::Step(_) => "step",
            Effect::Excursion(_) => "excursion",
            Effect::Narrowband(_) => "narrowband",
        }
    }
}

/// The error of the model in both domains.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ErrorFigures {
    pub allan: Option<Diagnostics>,
    pub spectrum: Option<Diagnostics>,
}

/// One addition.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct LoopStep {
    pub effect: Effect,
    /// Which residual pointed at it, and where.
    pub evidence: String,
    pub delta_bic: f64,
    pub before: ErrorFigures,
    pub after: ErrorFigures,
}

/// A candidate weighed in the last round and not kept.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Rejected {
    pub kind: &'static str,
    /// `None` for an excess no candidate could be formed for (kind `excess`; the note says why).
    pub delta_bic: Option<f64>,
    pub note: String,
}

/// A model with one more effect that the loop did not admit (its ΔBIC is not below
/// [`ADMIT_BIC`]) yet that explains the data nearly as well as the final one, or better: the
/// final coefficients are averaged with it by the BIC weight `weight` = e^(−ΔBIC/2) relative to
/// the final model's 1, so that the IEEE terms that absorb the effect's power where it is left
/// out do not print intervals as if it were known to be absent.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Rival {
    pub effect: Effect,
    pub delta_bic: f64,
    pub weight: f64,
    /// The rival's share of the two models' total weight, weight/(1 + weight): the figure the
    /// warning and summary.md give ("weighing 29 % of the total").
    pub share: f64,
    pub evidence: String,
}

impl Rival {
    /// The rival of ΔBIC `delta_bic` against the final model, its weight and share derived from it.
    fn new(effect: Effect, delta_bic: f64, evidence: String) -> Rival {
        let weight = bic_weight(delta_bic);
        Rival {
            effect,
            delta_bic,
            weight,
            share: crate::model::rival_share(weight),
            evidence,
        }
    }
}

/// A [`Rival`] is named in a warning from this share of the weight on (ΔBIC below 4.4); below it
/// it still enters the average but is recorded in the loop's report only. On 50 clean 30-min
/// records the Gauss–Markov rival came within the averaging window in 29 and reached this share
/// in 5; with a Gauss–Markov process of Tc 60 s planted, in 39 of the 44 records that did not
/// admit it.
pub const RIVAL_WARNING_SHARE: f64 = 0.1;

/// A slow effect (coupling, drift, step, excursion) that was not admitted is a [`Rival`] only
/// below this family-wise p-value, the evidence at which its regression is already refined by
/// feasible GLS ([`slow_candidates`]): its model is the series without it, estimated and fitted
/// again, which the loop does not pay for on every channel. Without a rival, a 100 °/h warm-up
/// (Tc 300 s) that fell short of admission in 8 of 50 30-min records (p 5e-4–1e-2, ΔBIC −5.9 to
/// −0.1) left K at 2–3× the truth with intervals that excluded it and no warning.
pub const RIVAL_SLOW_P: f64 = 0.05;

/// The loop's account of one channel.
#[derive(Debug, Clone, Serialize)]
pub struct LoopReport {
    /// The sensor low-pass the loop found and stayed inside of (only when its configuration asked
    /// it to look: `analyze` detects it before the loop and hands the restricted band in).
    pub bandwidth: Option<Bandwidth>,
    pub initial: ErrorFigures,
    pub steps: Vec<LoopStep>,
    #[serde(rename = "final")]
    pub final_figures: ErrorFigures,
    /// Candidates of the last round (none of which improved the criterion).
    pub rejected: Vec<Rejected>,
    /// Split-record (four quarters) comparison of the Allan deviations of the final series.
    pub stationarity: Option<SplitRecord>,
    /// A stochastic effect of the last round that was not admitted but scored within
    /// [`SELECTION_WINDOW`] of the final model: the final coefficients average both models (see
    /// [`crate::model::average_with_rival`]).
    pub rival: Option<Rival>,
    /// The series' test of the rate ramp at the loop's end, where it changed the model: R
    /// dropped (the loop's corrections took the slope out) or added (the Allan fit had put K in
    /// its place).
    pub ramp: Option<RampDecision>,
    /// A K the final Allan fit determines that a coupling it did not admit would take away
    /// (see [`KOrCoupling`]); K's interval then reaches down to 0.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub k_or_coupling: Option<KOrCoupling>,
    /// The fits of the base model before any effect (those after are the channel's fits).
    #[serde(skip)]
    pub base_allan: Option<NoiseFit>,
    #[serde(skip)]
    pub base_spectrum: Option<NoiseFit>,
    /// Estimates of the corrected series, when a time-domain effect changed it.
    #[serde(skip)]
    pub corrected: Option<(Deviations, Psd)>,
}

impl LoopReport {
    /// What the report must say about the loop's own limits: that it stopped at [`MAX_STEPS`],
    /// that a [`Rival`] model's readings are averaged into the coefficients, that a coupling it
    /// kept may be a warm-up of the bias's own.
    pub fn warnings(&self) -> Vec<FitWarning> {
        let limit = (self.steps.len() >= MAX_STEPS)
            .then_some(FitWarning::LoopLimitReached { limit: MAX_STEPS });
        let rival = self
            .rival
            .as_ref()
            .filter(|r| r.share >= RIVAL_WARNING_SHARE);
        let rival = rival.map(|r| FitWarning::RivalModel {
            effect: r.effect.kind().to_owned(),
            delta_bic: r.delta_bic,
            weight: r.weight,
            evidence: r.evidence.clone(),
        });
        let k_or_coupling = self
            .k_or_coupling
            .as_ref()
            .map(|c| FitWarning::KOrCoupling {
                aux: c.aux.clone(),
                coefficient: c.coefficient,
                p_value: c.p_value,
                k: c.k,
            });
        let warm_up = self.steps.iter().filter_map(|s| match &s.effect {
            Effect::Coupling { aux, fit } => {
                fit.explains_drift
                    .map(|drift_delta_bic| FitWarning::CouplingOrWarmUp {
                        aux: aux.clone(),
                        coefficient: fit.coefficient,
                        drift_delta_bic,
                        coupling_delta_bic: s.delta_bic,
                    })
            }
            _ => None,
        });
        limit
            .into_iter()
            .chain(rival)
            .chain(warm_up)
            .chain(k_or_coupling)
            .collect()
    }

    /// The [`FitWarning::HeavyTail`] of a loop that removed spikes ending a tail continuous with
    /// the noise ([`crate::effects::time::spikes::TailShape`]), given the final N (`n`, SI) of a
    /// record of `samples` at `rate_hz`: N with them adds their removal's energy back as white
    /// noise, √(N² + Σ removal²/(n·f_s)) (a white σ² per sample is N²·f_s).
    pub fn heavy_tail_warning(
        &self,
        n: Option<f64>,
        samples: usize,
        rate_hz: f64,
    ) -> Option<FitWarning> {
        let tails: Vec<&Spikes> = self
            .steps
            .iter()
            .filter_map(|s| match &s.effect {
                Effect::Spikes(spikes) if spikes.tail.continuous => Some(spikes),
                _ => None,
            })
            .collect();
        let first = tails.first()?;
        let n = n?;
        if !(samples > 0 && rate_hz > 0.0) {
            return None;
        }
        let energy: f64 = tails.iter().flat_map(|s| &s.removal).map(|e| e * e).sum();
        let times: Vec<f64> = tails
            .iter()
            .flat_map(|s| s.times_s.iter().copied())
            .collect();
        let (bursts, in_bursts, burst_gap_s) =
            crate::model::spike_bursts(&times, samples as f64 / rate_hz);
        Some(FitWarning::HeavyTail {
            spikes: tails.iter().map(|s| s.indices.len()).sum(),
            shoulder: first.tail.shoulder,
            shoulder_gaussian: first.tail.shoulder_gaussian,
            n,
            n_with: (n * n + energy / (samples as f64 * rate_hz)).sqrt(),
            bursts,
            in_bursts,
            burst_gap_s,
        })
    }
}

/// The stochastic effect in the model.
#[derive(Debug, Clone)]
enum Stochastic {
    GaussMarkov(GaussMarkov1),
    Resonance(Resonance),
}

impl Stochastic {
    fn shape(&self) -> &dyn EffectShape {
        match self {
            Stochastic::GaussMarkov(g) => g,
            Stochastic::Resonance(r) => r,
        }
    }
}

/// Estimates and fits of the current state.
/// The loop's state. The series is borrowed from the caller until a correction changes it (most
/// records need none, and a copy of a 10⁷-sample channel cost its time and its memory).
struct State<'a> {
    y: Cow<'a, [f64]>,
    dev: Deviations,
    psd: Psd,
    binned: BinnedPsd,
    allan: Option<NoiseFit>,
    spectrum: Option<NoiseFit>,
    stochastic: Option<Stochastic>,
    changed: bool,
    /// The recording's own quantisation step (the smallest non-zero difference between its
    /// samples before any effect was removed; about 0 for unquantised data). A removal leaves
    /// the series off that grid, and the spike detector, which reads the grid from the series
    /// it is given, would then take every one-step move of a coarsely quantised output for a
    /// spike (on an angle-quantised gyro whose output takes four values, 41 472 of 180 000
    /// samples once a line had been removed).
    grid: f64,
    /// The frequency ranges of the narrow bands removed so far (Hz): an excess found inside one
    /// afterwards is what its removal left of the same line.
    removed_bands: Vec<(f64, f64)>,
}

/// Spikes are outliers, a minority: a detection that flags more than this share of the samples
/// describes the distribution (or a series a removal has altered), not glitches, and is not
/// proposed. The heaviest contamination among the cases studied is 2.2 % of the samples beyond
/// 5.6 robust σ on a real gyro record.
pub const MAX_SPIKE_SHARE: f64 = 0.05;

fn estimates(y: &[f64], fs: f64, cfg: &LoopConfig) -> Option<(Deviations, Psd, BinnedPsd)> {
    // Independent: side by side (a channel left alone at the end of a file has a core to spare).
    let (dev, psd) = rayon::join(
        || compute(y, fs, &cfg.taus, Statistic::Oadev, cfg.confidence).ok(),
        || welch(y, fs, &cfg.welch).ok(),
    );
    let (dev, psd) = (dev?, psd?);
    let binned = log_bin(&psd, cfg.bins_per_decade.max(1));
    Some((dev, psd, binned))
}

fn fits(
    dev: &Deviations,
    psd: &Psd,
    binned: &BinnedPsd,
    cfg: &LoopConfig,
    effect: Option<&dyn EffectShape>,
) -> (Option<NoiseFit>, Option<NoiseFit>) {
    // Independent: side by side.
    rayon::join(
        || fit_avar_with(dev, &cfg.fit, effect).ok(),
        || fit_psd_with(psd, binned, &cfg.fit, effect).ok(),
    )
}

fn figures(allan: Option<&NoiseFit>, spectrum: Option<&NoiseFit>) -> ErrorFigures {
    ErrorFigures {
        allan: allan.map(diagnose),
        spectrum: spectrum.map(diagnose),
    }
}

/// The best eligible score of a fit's candidates.
fn score(fit: &NoiseFit) -> f64 {
    fit.candidates
        .iter()
        .filter(|c| c.proper)
        .map(|c| c.score)
        .fold(f64::INFINITY, f64::min)
}

/// One-sided density at f of the coefficients `c` plus the fit's stochastic effect.
fn density_of(
    c: &Coefficients,
    fit: &NoiseFit,
    stochastic: Option<&Stochastic>,
    f: f64,
    fs: f64,
) -> f64 {
    let effect = match (stochastic, fit.effect) {
        (Some(s), Some(e)) => e.value * e.value * s.shape().psd_unit(f, fs),
        _ => 0.0,
    };
    2.0 * (c.psd_sampled(f, fs) + effect)
}

/// The spectrum fit's model as a one-sided density at f.
fn model_one_sided(fit: &NoiseFit, stochastic: Option<&Stochastic>, f: f64, fs: f64) -> f64 {
    density_of(&fit.coefficients(), fit, stochastic, f, fs)
}

/// Which K a slow effect's regression weighs it against.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum NoiseK {
    /// The fit's estimate.
    Fitted,
    /// The upper end of K's one-sigma interval where that interval reaches 0 (the record does
    /// not determine K), else the estimate: for bias steps and excursions. A level change is a
    /// slow regressor against a random walk, and where K read low the walk's wander looked like
    /// one: at K's estimate, clean simulated 20-min accelerometers whose random walk rules from
    /// 20 s on had a step or excursion added to 8 of 600 channels (ΔBIC −6.4 to −13; the worst
    /// read K at 0.2× the truth, [0, 0.46×]), none under the guard. Also for the parabola among
    /// the drifts (a random walk's wander over a record looks like one). Not for the settling
    /// exponential and the couplings: guarded too, K took in more of a 100-°/h warm-up, found
    /// then in 41 of 50 records instead of 49, and a 5e-5 rad/s/°C coupling in 16 of 50 instead
    /// of 21.
    Guarded,
    /// The fit's kept terms only: a left-out term (K above all) at 0, not at its upper limit.
    /// For the refinement of a coupling that the model-free test finds below
    /// [`slow_candidates::KEPT_P`], under the fit of the series with the coupling removed: on a
    /// short record the upper limit of a K that fit does not keep rests on the few averages of
    /// the longest τ, and weighed at it a warm-up the temperature drives was still "explained"
    /// by the random walk (a 1.5e-4 (rad/s)/°C coupling
    /// over a 3-°C, Tc-300-s warm-up in a 10-min record read t = 1.5 under a K limit of
    /// 58 °/h/√h that the coupling-free series' increments reject, t = 4.8 without it; the base
    /// fit then printed K = 61 [48, 99] °/h/√h against a truth of 2). The spurious regression
    /// of a slow aux on a random walk the fit missed is what the model-free test, whose errors
    /// come from the increments' own scatter, rules out first: on a clean simulated fleet's
    /// accelerometers (random walk ruling from 20 s, a 3-°C warm-up, no coupling) a coupling was
    /// added on 6 of 300 channels where this weighing followed the model-free p below 0.05, on 3
    /// at 0.01 (and on none without it, when its gyros, all coupled, had 31 of 300 K intervals
    /// excluding the truth, 14 with it).
    Kept,
}

/// The noise density (one-sided) of a fit's model for the regressions of slow effects
/// ([`ramp_free_coefficients`]: the left-out terms at their upper limits, R at 0) with the fit's
/// stochastic effect, K as `k` says.
fn noise_density<'a>(
    fit: &'a NoiseFit,
    stochastic: Option<&'a Stochastic>,
    fs: f64,
    k: NoiseK,
) -> impl Fn(f64) -> f64 + 'a {
    let mut c = match k {
        NoiseK::Kept => {
            let mut c = fit.coefficients();
            c.set(Term::RateRamp, 0.0);
            c
        }
        _ => ramp_free_coefficients(fit),
    };
    if let (NoiseK::Guarded, Some(e)) = (k, undetermined_k(fit)) {
        c.set(Term::RateRandomWalk, e.one_sigma.1);
    }
    move |f| density_of(&c, fit, stochastic, f, fs)
}

/// A scan window's length for the evidence: in ms below a second (a 1-kHz record's 16-sample
/// windows were written "0.0 s").
fn window_text(seconds: f64) -> String {
    if seconds < 1.0 {
        format!("{:.1} ms", seconds * 1e3)
    } else {
        format!("{seconds:.1} s")
    }
}

/// K where `fit` kept it with an interval (at 1σ) down to 0: the record does not determine it, and
/// [`NoiseK::Guarded`] raises it.
fn undetermined_k(fit: &NoiseFit) -> Option<&crate::model::TermEstimate> {
    fit.get(Term::RateRandomWalk)
        .filter(|e| e.one_sigma.0 <= 0.0)
}

/// A candidate for this round: its ΔBIC, what it would add, and the evidence.
struct Candidate<'a> {
    /// Why it may not be added, found beside the candidate itself (a drift that a coupling
    /// explains).
    veto: Option<String>,
    delta_bic: f64,
    effect: Effect,
    evidence: String,
    apply: Apply<'a>,
}

impl Candidate<'_> {
    /// Why the candidate may not be added whatever its ΔBIC: a slow effect whose family-wise
    /// p-value is not below [`DETECTION_P`], or an excursion that a single step explains nearly
    /// as well.
    fn barred(&self) -> Option<String> {
        if self.veto.is_some() {
            return self.veto.clone();
        }
        if let Effect::Excursion(e) = &self.effect {
            if !e.beats_step() {
                return Some(format!(
                    "not proposed: a single step explains it nearly as well (t² {:.1} over the best step's, below the {:.1} a second position costs)",
                    e.over_step_t2, e.step_price_t2
                ));
            }
        }
        let p = self.slow_p()?;
        (p.is_nan() || p >= DETECTION_P)
            .then(|| format!("not proposed: family-wise p = {p:.1e}, not below {DETECTION_P:.0e}"))
    }

    /// The family-wise p-value of a slow effect regressed under the noise model (a coupling, a
    /// drift, an excursion that beats a single step, a GLS step); `None` for the others.
    fn slow_p(&self) -> Option<f64> {
        match &self.effect {
            Effect::Coupling { fit, .. } => Some(fit.p_value),
            Effect::Drift(d) => Some(d.p_value),
            Effect::Excursion(e) if e.beats_step() => Some(e.p_value),
            Effect::Step(s) if s.method == StepMethod::Gls => Some(s.p_value),
            _ => None,
        }
    }

    /// Whether this candidate, not admitted, may be the final model's [`Rival`]: a stochastic
    /// effect within [`SELECTION_WINDOW`], or a slow effect within it that the regression found
    /// some evidence for (p below [`RIVAL_SLOW_P`]) but not enough.
    fn may_rival(&self) -> bool {
        self.delta_bic < SELECTION_WINDOW
            && match self.apply {
                Apply::Model(_) => true,
                Apply::Series(_) => self.slow_p().is_some_and(|p| p < RIVAL_SLOW_P),
            }
    }

    fn admissible(&self) -> bool {
        self.delta_bic < ADMIT_BIC && self.barred().is_none()
    }
}

/// A rate random walk the final Allan fit determines (its interval above 0) that a coupling to
/// an aux channel, not admitted, would take away: with the coupling at its estimate under the
/// final model taken out of the series, the Allan fit keeps no K, or one whose interval reaches
/// 0. The rise K stands for is then the aux channel's warm-up as well as it is a random walk, and
/// the record does not tell which: K's interval in both fits is extended down to 0 and the
/// warning [`FitWarning::KOrCoupling`] says why. On clean simulated 10-min records of coupled
/// gyros (a 3-°C warm-up of Tc 300 s), a coupling short of the evidence an effect needs (both
/// tests: p 0.01–0.6) left K "determined" at 18–56× the truth on 14 of 300 channels, every one
/// of those intervals excluding the truth.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct KOrCoupling {
    pub aux: String,
    /// The coupling's coefficient under the final model (SI per the aux channel's unit).
    pub coefficient: f64,
    /// Its family-wise p-value under the final model.
    pub p_value: f64,
    /// K as the final Allan fit read it (SI).
    pub k: f64,
}

/// See [`KOrCoupling`]. Not where the loop admitted a coupling (what is left of the warm-up
/// then is the coupling's error, not its absence), nor for an estimate within one standard
/// error of 0.
fn k_standing_for_a_coupling(
    state: &mut State,
    fs: f64,
    aux: &[AuxSeries<'_>],
    cfg: &LoopConfig,
    p: f64,
    steps: &[LoopStep],
) -> Option<KOrCoupling> {
    if steps
        .iter()
        .any(|s| matches!(s.effect, Effect::Coupling { .. }))
    {
        return None;
    }
    let allan = state.allan.as_ref()?;
    let k = allan.get(Term::RateRandomWalk)?;
    if k.one_sigma.0 <= 0.0 || k.one_sigma.0.is_nan() {
        return None;
    }
    let k_value = k.value;
    let (aux_name, c) = coupling_taking_k(state, allan, fs, aux, cfg, p)?;
    for f in [state.allan.as_mut(), state.spectrum.as_mut()]
        .into_iter()
        .flatten()
    {
        if let Some(e) = f
            .estimates
            .iter_mut()
            .find(|e| e.term == Term::RateRandomWalk)
        {
            (e.lo, e.one_sigma.0) = (0.0, 0.0);
        }
    }
    Some(KOrCoupling {
        aux: aux_name.to_string(),
        coefficient: c.coefficient,
        p_value: c.p_value,
        k: k_value,
    })
}

/// The first aux channel (its name and coupling) whose coupling, estimated under `allan` (the
/// final Allan fit) at least one standard error from 0 and taken out of the series, leaves an
/// Allan fit without a determined K.
fn coupling_taking_k<'a>(
    state: &State,
    allan: &NoiseFit,
    fs: f64,
    aux: &[AuxSeries<'a>],
    cfg: &LoopConfig,
    p: f64,
) -> Option<(&'a str, Coupling)> {
    let density = noise_density(allan, state.stochastic.as_ref(), fs, NoiseK::Fitted);
    let usable: Vec<&AuxSeries<'_>> = aux
        .iter()
        .filter(|a| a.samples.len() == state.y.len())
        .collect();
    let family = usable.len();
    usable.iter().find_map(|a| {
        let c = coupling_under_model(&state.y, a.samples, fs, &density, family, p)?;
        if c.z.abs() < 1.0 {
            return None;
        }
        let refit = slow_candidates::allan_without(state, fs, cfg, &|v: &mut Vec<f64>| {
            remove_coupling(v, a.samples, &c)
        })?;
        let k_gone = refit
            .get(Term::RateRandomWalk)
            .is_none_or(|e| e.one_sigma.0 <= 0.0);
        k_gone.then_some((a.name, c))
    })
}

/// A correction of the series.
/// A correction of the series; it may borrow the aux channels' samples (a coupling's), not copy
/// them: a copy per coupling candidate per round held 370 MB more than the model of `analyze`'s
/// memory on a 4-h 200-Hz 6-axis record with a temperature channel.
type Correction<'a> = Box<dyn Fn(&mut Vec<f64>) + Send + 'a>;

enum Apply<'a> {
    /// Correct the series with this closure.
    Series(Correction<'a>),
    /// Put this stochastic effect in the model (with its already computed fits).
    Model(Box<(Stochastic, Option<NoiseFit>, Option<NoiseFit>)>),
}

/// Runs the loop on one channel's samples `y` at `fs`. `initial`: the estimates of `y` already
/// made with `cfg` (the OADEV and the spectrum, e.g. by a GPU backend); `None` computes them.
pub fn close_loop(
    y: &[f64],
    fs: f64,
    aux: &[AuxSeries<'_>],
    cfg: &LoopConfig,
    initial: Option<(Deviations, Psd, BinnedPsd)>,
) -> Option<LoopOutcome> {
    run_loop(y, fs, aux, cfg, initial, None)
}

/// The base fits a caller already made: the Allan and spectrum fits of the estimates it hands
/// to [`close_loop_from_base`], with that loop configuration's fit options.
pub type BaseFits = (Option<NoiseFit>, Option<NoiseFit>);

/// [`close_loop`] from the caller's estimates and base fits, which must have been made with
/// `cfg.fit` on exactly those estimates (`cfg.fit.detect_bandwidth` off: the band already
/// restricted), so that the loop does not fit the same model a second time.
pub fn close_loop_from_base(
    y: &[f64],
    fs: f64,
    aux: &[AuxSeries<'_>],
    cfg: &LoopConfig,
    initial: (Deviations, Psd, BinnedPsd),
    base: BaseFits,
) -> Option<LoopOutcome> {
    run_loop(y, fs, aux, cfg, Some(initial), Some(base))
}

fn run_loop(
    y: &[f64],
    fs: f64,
    aux: &[AuxSeries<'_>],
    cfg: &LoopConfig,
    initial: Option<(Deviations, Psd, BinnedPsd)>,
    base: Option<BaseFits>,
) -> Option<LoopOutcome> {
    let (dev, psd, binned) = match initial {
        Some(e) => e,
        None => estimates(y, fs, cfg)?,
    };
    // Fit and search only inside the sensor's bandwidth (see `model::bandwidth`): the caller's
    // base fits where it made them (on these estimates, inside the band, with these options),
    // else the same flow as `analyze`'s ([`fit_in_band`]).
    let mut cfg = cfg.clone();
    let grid = crate::quality::smallest_step(y);
    let (bandwidth, ramp, allan, spectrum) = match base {
        Some((allan, spectrum)) => (None, None, allan, spectrum),
        None => {
            let series = Series {
                samples: y,
                output_step: grid,
            };
            let b = fit_in_band(Some(&dev), &psd, Some(&binned), &cfg.fit, series);
            cfg.fit = b.options;
            (b.bandwidth, b.ramp, b.allan.ok(), b.spectrum.ok())
        }
    };
    let cfg = &cfg;
    let mut state = State {
        y: Cow::Borrowed(y),
        dev,
        psd,
        binned,
        allan,
        spectrum,
        stochastic: None,
        changed: false,
        grid: grid.unwrap_or(0.0),
        removed_bands: Vec::new(),
    };
    let initial = figures(state.allan.as_ref(), state.spectrum.as_ref());
    let (base_allan, base_spectrum) = (state.allan.clone(), state.spectrum.clone());
    let p = cfg.confidence.probability().unwrap_or(0.682_689_492);
    let mut steps: Vec<LoopStep> = Vec::new();
    let mut rejected = Vec::new();
    let mut rival = None;
    let mut end_ramp = None;
    while steps.len() < MAX_STEPS {
        let mut unexplained = Vec::new();
        let mut candidates = propose(&state, fs, aux, cfg, p, &mut unexplained);
        rejected = unexplained;
        // A fill's level change is listed as rejected and goes no further, not even as a rival
        // (as one it took 100 % of the weight of the coefficients it averaged): no model of the
        // sensor.
        candidates.retain(|c| match on_filled_stretch(&c.effect, &cfg.filled_s) {
            Some(why) => {
                rejected.push(Rejected {
                    kind: c.effect.kind(),
                    delta_bic: c.delta_bic.is_finite().then_some(c.delta_bic),
                    note: format!("{}; {why}", c.evidence),
                });
                false
            }
            None => true,
        });
        rejected.extend(candidates.iter().filter(|c| !c.admissible()).map(|c| {
            Rejected {
                kind: c.effect.kind(),
                delta_bic: c.delta_bic.is_finite().then_some(c.delta_bic),
                note: c
                    .barred()
                    .map_or(c.evidence.clone(), |b| format!("{}; {b}", c.evidence)),
            }
        }));
        let (admissible, others): (Vec<Candidate<'_>>, Vec<Candidate<'_>>) =
            candidates.into_iter().partition(Candidate::admissible);
        let Some(best) = admissible
            .into_iter()
            .min_by(|a, b| a.delta_bic.total_cmp(&b.delta_bic))
        else {
            rival = others
                .into_iter()
                .filter(Candidate::may_rival)
                .min_by(|a, b| a.delta_bic.total_cmp(&b.delta_bic));
            break;
        };
        let before = figures(state.allan.as_ref(), state.spectrum.as_ref());
        match best.apply {
            Apply::Series(correct) => {
                correct(owned(&mut state.y));
                let Some((dev, psd, binned)) = estimates(&state.y, fs, cfg) else {
                    break;
                };
                let shape = state.stochastic.as_ref().map(Stochastic::shape);
                let (allan, spectrum) = fits(&dev, &psd, &binned, cfg, shape);
                (state.dev, state.psd, state.binned) = (dev, psd, binned);
                (state.allan, state.spectrum) = (allan, spectrum);
                state.changed = true;
            }
            Apply::Model(model) => {
                let (stochastic, allan, spectrum) = *model;
                state.stochastic = Some(stochastic);
                (state.allan, state.spectrum) = (allan, spectrum);
            }
        }
        let after = figures(state.allan.as_ref(), state.spectrum.as_ref());
        // A wandering line's tails, found once its core is gone, are the same line.
        if let Effect::Narrowband(nb) = &best.effect {
            state.removed_bands.push((nb.f_lo_hz, nb.f_hi_hz));
            if let Some(step) = steps.iter_mut().find(|s| {
                matches!(&s.effect, Effect::Narrowband(p) if p.f_lo_hz <= nb.f_hi_hz && nb.f_lo_hz <= p.f_hi_hz)
            }) {
                if let Effect::Narrowband(prev) = &mut step.effect {
                    merge_narrowband(prev, nb);
                }
                step.delta_bic += best.delta_bic;
                step.after = after;
                continue;
            }
        }
        steps.push(LoopStep {
            effect: best.effect,
            evidence: best.evidence,
            delta_bic: best.delta_bic,
            before,
            after,
        });
    }
    // A ramp the base fits kept because the series showed one may have been a step's, a
    // warm-up's or a coupling's slope that the loop took out: asked again of the corrected series
    // (as in `band`), and without R from here on (the rival's refit included) if it is gone.
    // And a ramp the fits left out (the Allan curve could not tell it from a random walk K) is
    // required where the corrected series determines it: only now, once the loop had its chance
    // to explain a slope as a warm-up, a coupling or a step (asked of the recorded series before
    // the loop, the sample's gyro_z got a ramp that way).
    let decided = ramp_gone(&state, fs, cfg)
        .map(|end| RampCheck::Changed(Box::new(end)))
        .or_else(|| ramp_found(&state, fs, aux, cfg));
    let end_cfg;
    let cfg = match decided {
        Some(RampCheck::Changed(end)) => {
            let (decision, next, allan, spectrum) = *end;
            (state.allan, state.spectrum) = (allan, spectrum);
            end_cfg = next;
            end_ramp = Some(decision);
            &end_cfg
        }
        Some(RampCheck::Unchanged(decision)) => {
            end_ramp = Some(decision);
            cfg
        }
        None => cfg,
    };
    let final_figures = figures(state.allan.as_ref(), state.spectrum.as_ref());
    // Where the final fits' intervals must also count the rival model (the figures above stay
    // the final model's: it is the one drawn).
    let rival = rival.and_then(|c| {
        let evidence = match c.barred() {
            Some(b) => format!("{}; {b}", c.evidence),
            None => c.evidence,
        };
        let (allan, spectrum) = match c.apply {
            Apply::Model(model) => {
                let (_, allan, spectrum) = *model;
                (allan, spectrum)
            }
            // A slow effect's model is the series without it, estimated and fitted afresh.
            Apply::Series(correct) => {
                let mut y = pooled_copy(&state.y);
                correct(&mut y);
                let estimated = estimates(&y, fs, cfg);
                crate::memory::recycle(y);
                let (dev, psd, binned) = estimated?;
                let shape = state.stochastic.as_ref().map(Stochastic::shape);
                fits(&dev, &psd, &binned, cfg, shape)
            }
        };
        let rival = Rival::new(c.effect, c.delta_bic, evidence);
        let average = |fit: &mut Option<NoiseFit>, other: Option<NoiseFit>| {
            if let (Some(f), Some(o)) = (fit.as_mut(), other) {
                *f = average_with_rival(f, &o, rival.weight);
            }
        };
        average(&mut state.allan, allan);
        average(&mut state.spectrum, spectrum);
        Some(rival)
    });
    // The refits keep a determined ramp's Fisher interval only (see `ramp`; a caller that
    // handed its base fits in widens them itself).
    let widening = [&ramp, &end_ramp]
        .into_iter()
        .filter_map(|d| d.as_ref().and_then(RampDecision::widening));
    for test in widening {
        for f in [&mut state.allan, &mut state.spectrum]
            .into_iter()
            .flatten()
        {
            widen_ramp(f, test);
        }
    }
    let k_or_coupling = k_standing_for_a_coupling(&mut state, fs, aux, cfg, p, &steps);
    let report = LoopReport {
        bandwidth,
        initial,
        steps,
        final_figures,
        rejected,
        stationarity: split_record(&state.y, fs, 4, 0.99),
        rival,
        ramp: end_ramp,
        k_or_coupling,
        base_allan,
        base_spectrum,
        corrected: state
            .changed
            .then(|| (state.dev.clone(), state.psd.clone())),
    };
    if let Cow::Owned(y) = state.y {
        crate::memory::recycle(y);
    }
    Some(LoopOutcome {
        report,
        allan: state.allan,
        spectrum: state.spectrum,
    })
}

/// A copy of `y` in a pooled buffer (see [`crate::memory::scratch`]): the loop's corrected
/// series are record-length, and a fresh one is faulted in page by page (on 24 h × 400 Hz × 7
/// channels, the loop's page faults were a tenth of its CPU time, in the kernel).
fn pooled_copy(y: &[f64]) -> Vec<f64> {
    let mut copy = crate::memory::scratch(y.len());
    copy.copy_from_slice(y);
    copy
}

/// The series as a mutable, owned one: copied into a pooled buffer on the first change.
fn owned<'a, 'b>(y: &'b mut Cow<'a, [f64]>) -> &'b mut Vec<f64> {
    if let Cow::Borrowed(b) = y {
        *y = Cow::Owned(pooled_copy(b));
    }
    y.to_mut()
}

/// The loop's last word on the rate ramp: the decision, the configuration from here on, both fits.
type RampEnd = (RampDecision, LoopConfig, Option<NoiseFit>, Option<NoiseFit>);

/// A ramp check that changed the model, or one reported without changing it
/// ([`RampAction::NotAdded`]).
enum RampCheck {
    Changed(Box<RampEnd>),
    Unchanged(RampDecision),
}

/// The series' test of a ramp under the final model without R (`model`, with the loop's
/// stochastic effect in its noise: a Gauss–Markov process the loop admitted is slow noise the
/// ramp must stand out from).
/// `c`: the model's coefficients without R ([`ramp_free_coefficients`] where a fit kept R,
/// [`ramp_null_coefficients`] where none did).
fn test_final(state: &State, fs: f64, model: &NoiseFit, c: Coefficients) -> Option<RampTest> {
    test_beside(state, fs, model, &c, None)
}

/// [`test_final`] with `beside` (an aux channel) fitted beside the ramp.
fn test_beside(
    state: &State,
    fs: f64,
    model: &NoiseFit,
    c: &Coefficients,
    beside: Option<&[f64]>,
) -> Option<RampTest> {
    let stochastic = state.stochastic.as_ref();
    let density = |f| density_of(c, model, stochastic, f, fs);
    test_ramp_beside(&state.y, fs, &density, beside)
}

/// Whether a fit keeps a rate ramp.
fn keeps_ramp(f: &Option<NoiseFit>) -> bool {
    f.as_ref().is_some_and(|f| f.get(Term::RateRamp).is_some())
}

/// Where the loop corrected the series and a final fit still keeps a rate ramp that the corrected
/// series does not determine ([`super::ramp`]): the configuration without R and both fits made
/// again with it.
fn ramp_gone(state: &State, fs: f64, cfg: &LoopConfig) -> Option<RampEnd> {
    if !state.changed || !(keeps_ramp(&state.allan) || keeps_ramp(&state.spectrum)) {
        return None;
    }
    let mut flat = cfg.clone();
    flat.fit = without_ramp(&cfg.fit);
    let shape = state.stochastic.as_ref().map(Stochastic::shape);
    let (allan, spectrum) = fits(&state.dev, &state.psd, &state.binned, &flat, shape);
    let test = allan
        .as_ref()
        .or(spectrum.as_ref())
        .and_then(|m| test_final(state, fs, m, ramp_free_coefficients(m)))?;
    let decision = RampDecision {
        series: TestedSeries::Corrected,
        action: RampAction::Dropped,
        test,
        estimate: None,
    };
    (!test.determined()).then_some((decision, flat, allan, spectrum))
}

/// Where no final fit keeps a rate ramp, the fits may still have one (R allowed) and the final
/// series determines it: the Allan fit made again with R required (K in its place could not be
/// told from it on the Allan curve's few longest-τ averages, while the block means of the whole
/// record show it at the slow effects' level). The series must show it under both models: the
/// final one without R, its K at the upper end of its interval ([`ramp_null_coefficients`]),
/// and the refit with R, its left-out K at its upper limit. Measured on 30-min records
/// (`validation/ramp.md`): a ramp of 200 °/h/h (≈ 7 K·√T) kept in 39 of 60 records (27 by the
/// base fits alone); clean records given a ramp 0 of 300 (30 min) and 1 of 200 (2 h).
///
/// And it must stand out beside every aux channel (`aux`: a temperature), each fitted with it:
/// a coupling too weak for the loop to admit still rises with a warm-up, and its slope alone
/// was read as a ramp in 1 of the 24 records of the validation's 5e-5 rad/s/°C row whose
/// coupling the loop did not find. Where a ramp and a temperature's rise cannot be told apart,
/// neither is claimed.
fn ramp_found(
    state: &State,
    fs: f64,
    aux: &[AuxSeries<'_>],
    cfg: &LoopConfig,
) -> Option<RampCheck> {
    let allowed = cfg.fit.terms.contains(&Term::RateRamp);
    if !allowed || keeps_ramp(&state.allan) || keeps_ramp(&state.spectrum) {
        return None;
    }
    let model = state.allan.as_ref()?;
    let null = ramp_null_coefficients(model);
    let test = test_final(state, fs, model, null)?;
    // Why it is not added shows in the decision: the test not determined (K's wander), the test
    // determined without an estimate (an aux channel's rise), or the estimate under the model
    // with R not determined. Where the fit with R fails, nothing is said (no reason is known).
    let not_added = |estimate: Option<RampTest>| {
        (test.p < HINT_P).then_some(RampCheck::Unchanged(RampDecision {
            series: TestedSeries::Corrected,
            action: RampAction::NotAdded,
            test,
            estimate,
        }))
    };
    if !test.determined() {
        return not_added(None);
    }
    for a in aux {
        let beside = test_beside(state, fs, model, &null, Some(a.samples));
        if !beside.is_some_and(|t| t.determined()) {
            return not_added(None);
        }
    }
    let mut required = cfg.clone();
    required.fit.required.push(Term::RateRamp);
    let shape = state.stochastic.as_ref().map(Stochastic::shape);
    let (allan, spectrum) = fits(&state.dev, &state.psd, &state.binned, &required, shape);
    let with_ramp = allan.as_ref().filter(|f| f.get(Term::RateRamp).is_some())?;
    // Sized under the model with R, as where the base fits kept it (see `band`); whose left-out
    // K enters at its upper limit: the ramp must stand out from that noise too. Weighed against
    // the model without R alone, 3 of 200 clean 2-h records got a ramp where the Allan fit read K
    // at 0.30–0.56× the truth (t 4.5–6.1); under the model with R their t was 1.5–3.5.
    let estimate = test_final(state, fs, with_ramp, ramp_free_coefficients(with_ramp))?;
    if !estimate.determined() {
        return not_added(Some(estimate));
    }
    let decision = RampDecision {
        series: TestedSeries::Corrected,
        action: RampAction::Added,
        test,
        estimate: Some(estimate),
    };
    Some(RampCheck::Changed(Box::new((
        decision, required, allan, spectrum,
    ))))
}

/// The loop's report and the final fits (base terms and the stochastic effect, on the corrected
/// series).
#[derive(Debug, Clone)]
pub struct LoopOutcome {
    pub report: LoopReport,
    pub allan: Option<NoiseFit>,
    pub spectrum: Option<NoiseFit>,
}

fn describe_excess(e: &Excess) -> String {
    format!(
        "raw spectrum {:.4} Hz: {} bins over the model (peak {:.1}×, p = {:.1e})",
        e.freq_hz, e.bins, e.peak_ratio, e.p_value
    )
}

/// Every candidate of the catalogue on the current state; spectral excesses no candidate could be
/// formed for go to `unexplained` with the reason.
fn propose<'a>(
    state: &State,
    fs: f64,
    aux: &[AuxSeries<'a>],
    cfg: &LoopConfig,
    p: f64,
    unexplained: &mut Vec<Rejected>,
) -> Vec<Candidate<'a>> {
    let mut out = Vec::new();
    let y = &state.y;

    // The time-domain detectors are independent: run side by side, so that a channel that is
    // analysed alone (the last of three on two cores) still uses every core.
    // The Gauss–Markov candidate (a search over correlation times with a refit each) depends on
    // the state alone and runs beside them too.
    let (((spikes, step), slow), gauss_markov) = rayon::join(
        || {
            rayon::join(
                || {
                    rayon::join(
                        || find_spikes_on_grid(y, fs, state.grid),
                        || find_step(y, fs, p),
                    )
                },
                || slow_candidates(state, fs, aux, cfg, p),
            )
        },
        || {
            state
                .stochastic
                .is_none()
                .then(|| gauss_markov_candidate(state, fs, cfg, p))
                .flatten()
        },
    );
    let too_many = spikes.indices.len() as f64 > MAX_SPIKE_SHARE * y.len() as f64;
    if too_many {
        unexplained.push(Rejected {
            kind: "spikes",
            delta_bic: Some(spikes.delta_bic),
            note: format!(
                "{} samples ({:.1} %) beyond {:.1}σ of the running median: more than {:.0} % of \
                 the samples cannot be outliers; the distribution itself is not Gaussian there",
                spikes.indices.len(),
                100.0 * spikes.indices.len() as f64 / y.len() as f64,
                spikes.threshold_sigma,
                100.0 * MAX_SPIKE_SHARE
            ),
        });
    } else if !spikes.indices.is_empty() {
        let s = spikes.clone();
        out.push(Candidate {
            veto: None,
            delta_bic: spikes.delta_bic,
            evidence: format!(
                "time series: {} samples beyond {:.1}σ of the running median, {:.1} % of the variance",
                spikes.indices.len(),
                spikes.threshold_sigma,
                100.0 * spikes.variance_share
            ),
            effect: Effect::Spikes(spikes),
            apply: Apply::Series(Box::new(move |y| remove_spikes(y, &s))),
        });
    }
    if let Some(mut step) = step {
        // Its time's interval under the fitted noise, for a step that may be kept, searched over
        // four of its scan windows either side.
        if step.delta_bic < 0.0 {
            if let Some(model) = state.allan.as_ref().or(state.spectrum.as_ref()) {
                let density = noise_density(model, state.stochastic.as_ref(), fs, NoiseK::Guarded);
                let search = (4.0 * step.window_s * fs) as usize;
                let change = LevelChange {
                    y,
                    fs,
                    density: &density,
                    sign: step.size.signum(),
                    level: p,
                };
                if let Some(i) = change.interval(step.index, search) {
                    step.time_interval_s = Some(i.seconds(fs));
                    step.time_interval_cut = i.cut;
                }
            }
        }
        // A jump the long windows either side do not show was a transient (a knock, a
        // footstep), not a step ([`Persistence`]).
        let lasting = Persistence::of(y, fs, &step, p, |tau| {
            crate::model::variance_at(&state.dev, tau)
        });
        let veto = lasting.filter(|l| l.refutes(step.size)).map(|l| {
            format!(
                "not a step: over {:.1} s either side, 2 s or more away, the mean moves by {:.3e} \
                 ± {:.1e}, not by the jump: a transient",
                l.long_s, l.shift, l.sd
            )
        });
        let s = step.clone();
        out.push(Candidate {
            veto,
            delta_bic: step.delta_bic,
            evidence: format!(
                "time series: mean jumps at {:.1} s (dynamic Allan z = {:.1} over {} windows)",
                step.time_s,
                step.z,
                window_text(step.window_s)
            ),
            effect: Effect::Step(step),
            apply: Apply::Series(Box::new(move |y| remove_step(y, &s))),
        });
    }
    out.extend(slow);

    let Some(spectrum) = &state.spectrum else {
        out.extend(gauss_markov);
        return out;
    };
    let stochastic = state.stochastic.as_ref();
    let min_f = 4.0 * fs / state.psd.nperseg.max(1) as f64;
    // Inside the fit band the model is the fit's; beyond it, up to the sensor filter's corner, the
    // model times the filter's response, where only narrow lines are looked for. Nothing beyond
    // the corner is searched: that is the filter's edge, which no effect may be claimed from.
    let fit_edge = cfg.fit.max_freq_hz.unwrap_or(f64::INFINITY);
    let lowpass = cfg.fit.lowpass;
    let max_f = lowpass.map_or(fit_edge, |lp| lp.corner_hz.max(fit_edge));
    let model = |f: f64| {
        model_one_sided(spectrum, stochastic, f, fs) * lowpass.map_or(1.0, |lp| lp.power_gain(f))
    };
    let excess = find_excess(&state.psd, model, min_f, max_f, LINE_P);
    let searched = state
        .psd
        .freq_hz
        .iter()
        .filter(|&&f| f >= min_f && f <= max_f)
        .count();
    let z = norm_isf((1.0 - p) / 2.0);
    for e in excess.iter().take(4) {
        let width = e.f_hi_hz - e.f_lo_hz;
        let narrow = width <= NARROW_FRACTION * e.freq_hz;
        let in_band = e.f_hi_hz <= fit_edge;
        let around = (!in_band).then(|| shoulder_ratio(&state.psd, &model, e.f_lo_hz, e.f_hi_hz));
        // Beyond the fit band a broader excess is a peak, not the filter's transition, where it
        // is no wider than a quarter of its frequency and the spectrum on either side follows
        // the model through the fitted filter: a Butterworth response falls monotonically, and a
        // misjudged one leaves the whole region off the model, shoulders included.
        let peak = !in_band
            && !narrow
            && width <= PEAK_FRACTION * e.freq_hz
            && e.peak_ratio >= PEAK_MIN_RATIO
            && around.is_some_and(|a| a <= OUT_OF_BAND_SLACK);
        if !in_band && !narrow && !peak {
            unexplained.push(excess_note(
                e,
                "broad or low excess beyond the fit band (the sensor filter's transition or \
                 ripple): not an effect",
            ));
            continue;
        }
        // Beyond the fit band a line is measured against the spectrum's own level around it
        // where that lies above the extrapolated model (within OUT_OF_BAND_SLACK of it).
        let mut level = 1.0;
        if let Some(around) = around {
            level = around.max(1.0);
            if around > OUT_OF_BAND_SLACK {
                unexplained.push(excess_note(
                    e,
                    &format!(
                        "beyond the fit band the spectrum on either side lies {around:.2}× the \
                         extrapolated model too: the model, not a line, is off there"
                    ),
                ));
                continue;
            }
        }
        let local = |f: f64| level * model(f);
        let noise = local(e.freq_hz);
        let sine = fit_sinusoid(y, fs, e.freq_hz, noise, p);
        // A line puts its power A²/2 in the group; a resonance or a wandering line spreads power
        // the sinusoid explains only a part of.
        let line_share = sine.as_ref().map_or(0.0, |s| {
            s.amplitude * s.amplitude / 2.0 / e.excess_power.max(f64::MIN_POSITIVE)
        });
        if let Some(sine) = sine.filter(|_| line_share >= 0.5) {
            let s = sine.clone();
            out.push(Candidate {
                veto: None,
                delta_bic: sine.delta_bic,
                evidence: describe_excess(e),
                effect: Effect::Sinusoid(sine),
                apply: Apply::Series(Box::new(move |y| remove_sinusoid(y, fs, &s))),
            });
            continue;
        }
        // Inside the band an excess too wide for a line is a resonance or a line whose frequency
        // wanders; the band's amplitude tells them apart (a line's is nearly constant, a
        // resonance's Gaussian): a ±0.3-Hz wandering line at 9 Hz (15× the floor) had been
        // fitted as a resonance of Q 45, its σ the line's rms, in 7 of 10 records of an
        // independent simulator, the rest of it split off as narrow bands.
        // The resonance the excess would be (inside the band, where no stochastic effect is held
        // yet); its amplitude is judged over ±2 of its half-power widths, which hold most of a
        // resonance's power and the range a wandering line moves over (the excess group alone
        // may be two bins a wandering line only passes through, bursts that look Gaussian).
        let resonance = (in_band && stochastic.is_none())
            .then(|| resonance_candidate(state, e, fs, cfg, p))
            .flatten();
        let kurtosis = resonance.as_ref().and_then(|c| match &c.effect {
            Effect::Resonance { f0_hz, q, .. } => {
                let reach = 2.0 * f0_hz / q.max(0.5);
                band_kurtosis(y, fs, (f0_hz - reach).max(0.0), f0_hz + reach)
            }
            _ => None,
        });
        // What a narrow band's removal left of its line (a wandering line's removal, bin by bin
        // against a one-Welch-bin smoothing, leaves some of its power) is that line too: it had
        // come back as a resonance of Q 13 inside the band just removed.
        let leftover = state
            .removed_bands
            .iter()
            .find(|&&(lo, hi)| lo <= e.f_hi_hz && e.f_lo_hz <= hi)
            .copied();
        let line_like = kurtosis.is_some_and(|k| k < LINE_KURTOSIS) || leftover.is_some();
        if narrow || peak || line_like {
            if let Some(mut nb) =
                measure_narrowband(&state.psd, &local, e.f_lo_hz, e.f_hi_hz, searched, z)
            {
                intervals_from_parts(&mut nb, y, fs, &cfg.welch, &local, p);
                nb.coherent_share = line_share.min(1.0);
                let clean = remove_narrowband(y, fs, &nb, &local, state.psd.nperseg);
                // Inside the fit band a resonance is a column of the fit (`resonance_candidate`,
                // below); beyond it the model is an extrapolation, so the peak is measured as a
                // band and read as a resonance over that floor held fixed ([`peak`]).
                let beyond = if peak {
                    let gain = |f: f64| lowpass.map_or(1.0, |lp| lp.power_gain(f));
                    nb.resonance =
                        fit_peak_resonance(&state.psd, &local, &gain, e.f_lo_hz, e.f_hi_hz, z);
                    let reading = nb.resonance.as_ref().map_or(String::new(), |r| {
                        format!(
                            "; read as a resonance over the extrapolated floor: f₀ {:.3} Hz, Q \
                             {:.1}, σ {:.3e} (deviance {:.2} a bin)",
                            r.f0_hz, r.q, r.sigma, r.deviance_per_bin
                        )
                    });
                    format!(
                        "; a peak beyond the fit band (which ends at {fit_edge:.3} Hz): measured \
                         as a band (centre, width, power){reading}"
                    )
                } else {
                    String::new()
                };
                out.push(Candidate {
                    veto: None,
                    delta_bic: nb.delta_bic,
                    evidence: format!(
                        "{}; one coherent sinusoid explains {:.0} % of it{beyond}",
                        describe_excess(e),
                        100.0 * line_share.min(1.0)
                    ),
                    effect: Effect::Narrowband(nb),
                    apply: Apply::Series(Box::new(move |y| *y = clean.clone())),
                });
            }
        }
        if in_band && stochastic.is_none() {
            if let Some(mut c) = resonance {
                if let Some((lo, hi)) = leftover {
                    c.veto = Some(format!(
                        "not a resonance: inside the narrow band {lo:.3}–{hi:.3} Hz already \
                         removed, what its removal left of the same line"
                    ));
                } else if let Some(k) = kurtosis.filter(|_| line_like) {
                    c.veto = Some(format!(
                        "not a resonance: the band's amplitude is nearly constant (kurtosis \
                         {k:.2}; Gaussian noise through a resonance has 3, a line 1.5): a line \
                         whose frequency wanders, measured as a narrow band"
                    ));
                }
                out.push(c);
            }
        } else if in_band && !narrow {
            unexplained.push(excess_note(
                e,
                "resonance not tried: the model already holds a stochastic effect",
            ));
        }
    }
    out.extend(gauss_markov);
    out
}

/// Beyond the fit band a line must stand out of its surroundings: the model there is the fit's
/// extrapolated through the filter's fitted response, and where the filter was misjudged (or
/// the recording leaves the IEEE model near Nyquist, as an angle quantiser with little motion
/// does: its error is no longer white) the whole region lies above it and every noise bump of
/// it passes for a line. An excess whose shoulders ([`shoulder_ratio`]) lie more than this
/// factor above the model is not proposed, and one within it is measured against the shoulders'
/// level (where above the model). A line beside a well-fitted filter keeps shoulders within a few
/// per cent of the model.
const OUT_OF_BAND_SLACK: f64 = 1.3;

/// The median of P_k/model(f_k) over the bins on either side of [f_lo, f_hi] (three times its
/// width or 16 bins each side, whichever is more; below Nyquist): how far the spectrum's own
/// level around an excess lies from the model. The median keeps a wandering line's tails from
/// counting; for ν-dof bins its bias (≈ 1 − 2/(3ν)) is negligible here.
fn shoulder_ratio(psd: &Psd, model: &dyn Fn(f64) -> f64, f_lo: f64, f_hi: f64) -> f64 {
    let reach = (3.0 * (f_hi - f_lo)).max(16.0 * psd.bin_width_hz());
    let nyquist = psd.rate_hz / 2.0;
    let mut ratios: Vec<f64> = psd
        .freq_hz
        .iter()
        .zip(&psd.value)
        .filter(|(&f, _)| {
            f > 0.0
                && f < nyquist
                && ((f >= f_lo - reach && f < f_lo) || (f > f_hi && f <= f_hi + reach))
        })
        .map(|(&f, &p)| p / model(f))
        .filter(|r| r.is_finite())
        .collect();
    if ratios.is_empty() {
        return 1.0;
    }
    let mid = ratios.len() / 2;
    *ratios.select_nth_unstable_by(mid, f64::total_cmp).1
}

/// An excess group no wider than this fraction of its frequency is narrow (a line, possibly
/// wandering: Q ≳ 20); wider ones are resonances.
const NARROW_FRACTION: f64 = 0.05;

/// Band kurtosis ([`band_kurtosis`]) below which an in-band excess too wide for a line is taken
/// for a wandering line, not a resonance: a line over the floor at power ratio 3 reads 2.16,
/// Gaussian noise 3 with a scatter of √(24/(W·T)) (0.31 for a Q-50 resonance at 7 Hz over 30 min,
/// 2.4 of them above this).
const LINE_KURTOSIS: f64 = 2.25;

/// Beyond the fit band, an excess group wider than [`NARROW_FRACTION`] but no wider than this
/// fraction of its frequency, with shoulders on the model ([`OUT_OF_BAND_SLACK`]), is a peak (a
/// resonance of Q ≳ 5: its group reaches about three half-power widths) rather than the filter's
/// transition, which spans a good part of the corner frequency. Before this rule a resonance at
/// 18 Hz (Q 30, peak 7–9× the floor) beside a 25-Hz filter was dismissed as the filter's edge in
/// 5 of 5 records (`validation/`).
const PEAK_FRACTION: f64 = 0.25;

/// …and whose strongest bin stands at least this many times the model. A decimation filter's
/// passband ripple (a few tenths of a dB) or a slightly misjudged response moves the level by
/// tens of per cent over a band of a similar width, which long records measure as significant;
/// a resonance worth naming stands out of the floor (the 18-Hz one above: 7–9×). Weaker peaks
/// are narrow enough for the line search (its sweep in `validation/detection.md` finds them from
/// a peak excess ≈ 0.9× the floor, where their group of excess bins is narrow).
const PEAK_MIN_RATIO: f64 = 2.0;

/// `into` extended by `more`, a later pass over the same line (its tails): powers and their
/// interval ends add, the band is the union, the centre the power-weighted mean.
fn merge_narrowband(into: &mut NarrowBand, more: &NarrowBand) {
    let total = into.power + more.power;
    if total > 0.0 {
        // The centre's interval: the weighted mean's, each pass's half-widths weighted alike and
        // added in quadrature (the passes cover different bins).
        let (a, b) = (into.power / total, more.power / total);
        let half = |n: &NarrowBand| (n.freq_hi_hz - n.freq_lo_hz) / 2.0;
        let half = (a * a * half(into).powi(2) + b * b * half(more).powi(2)).sqrt();
        into.freq_hz = a * into.freq_hz + b * more.freq_hz;
        into.freq_lo_hz = into.freq_hz - half;
        into.freq_hi_hz = into.freq_hz + half;
    }
    if more.width_hz > into.width_hz {
        into.width_hz = more.width_hz;
        into.width_lo_hz = more.width_lo_hz;
        into.width_hi_hz = more.width_hi_hz;
    }
    into.f_lo_hz = into.f_lo_hz.min(more.f_lo_hz);
    into.f_hi_hz = into.f_hi_hz.max(more.f_hi_hz);
    into.power = total;
    into.power_lo += more.power_lo;
    into.power_hi += more.power_hi;
    into.equivalent_amplitude = (2.0 * total).sqrt();
    into.delta_bic += more.delta_bic;
}

/// An excess that no candidate could be formed for, as the report lists it (kind `excess`, no
/// ΔBIC).
fn excess_note(e: &Excess, why: &str) -> Rejected {
    Rejected {
        kind: "excess",
        delta_bic: None,
        note: format!("{}; {why}", describe_excess(e)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_short_scan_window_is_written_in_milliseconds() {
        assert_eq!(window_text(0.016), "16.0 ms");
        assert_eq!(window_text(2.56), "2.6 s");
    }

    fn excursion(start_s: f64, end_s: f64) -> Effect {
        Effect::Excursion(crate::effects::excursion::Excursion {
            start_index: 0,
            end_index: 0,
            start_s,
            end_s,
            start_interval_s: Some((start_s - 0.2, start_s + 0.2)),
            end_interval_s: Some((end_s - 0.2, end_s + 0.2)),
            interval_cut: false,
            size: 1.0,
            lo: 0.5,
            hi: 1.5,
            after: None,
            z: 8.0,
            p_value: 1e-9,
            delta_bic: -40.0,
            boxes: 1000,
            over_step_t2: 30.0,
            step_price_t2: 13.0,
            block_s: 2.3,
            increments: 512,
        })
    }

    /// A 10-s fill from 3000.15 s: the box of 2997.0–3011.7 s around it (ends 3 s and 1.5 s
    /// away, as claimed on a 2-h 200-Hz record) is the fill's; a 300-s excursion that holds it,
    /// or one that ends 2 s before it, is not.
    #[test]
    fn an_excursion_around_a_filled_stretch_is_the_fills() {
        let filled = [(3000.15, 3010.15)];
        assert!(on_filled_stretch(&excursion(2997.0, 3011.7), &filled).is_some());
        assert!(on_filled_stretch(&excursion(2900.0, 3200.0), &filled).is_none());
        assert!(on_filled_stretch(&excursion(2800.0, 2998.0), &filled).is_none());
        // An end whose interval reaches within the margin.
        assert!(on_filled_stretch(&excursion(2800.0, 2999.5), &filled).is_some());
        // A gap joined over (`--on-gap ignore`): an end at the join is the join's.
        let joined = [(979.0, 979.0)];
        let why = on_filled_stretch(&excursion(388.1, 979.1), &joined).unwrap();
        assert!(why.contains("joined over"), "{why}");
        assert!(on_filled_stretch(&excursion(388.1, 960.0), &joined).is_none());
    }
}
