//! One answer per coefficient: the Allan and spectrum fits combined by a stated rule, the IEEE
//! read-offs beside them, and a named warning for every reason not to trust the numbers.
//!
//! **The rule.** Both fits rest on the same samples, so their errors are strongly and positively
//! correlated (for N, nearly fully). For two unbiased estimates with standard errors s₁ ≤ s₂ and
//! correlation ρ ≥ s₁/s₂, the minimum-variance linear combination puts all its weight on the more
//! precise one (the weight of the other is (s₁² − ρs₁s₂)/(s₁² + s₂² − 2ρs₁s₂) ≤ 0), and no
//! weighting of such estimates narrows the interval below s₁. So the combined value is the
//! estimate with the narrower relative interval, with its interval — except where only one of the
//! fits kept every neighbour of the term (the terms of adjacent slope, Q–N–B–K–R) that the other
//! kept: a fit without K lets B absorb K's power, so B then comes from the fit that has K
//! whatever the widths — and unless the two intervals do
//! not overlap: then the estimates disagree (one domain is missing an effect or sees a filter the
//! other does not), the value comes from the term's home domain (B, K, R from the Allan variance,
//! whose long τ reach below the spectrum's lowest band; Q from the spectrum; N from the more
//! precise) and the combined interval is the hull of both; a `domains_disagree` warning names the
//! term and the ratio where the difference is significant (|Δ ln| over the combined standard
//! error beyond 3.29, p < 0.001): two right 1σ intervals miss each other in ≈ 16 % of cases. A term kept in one domain only comes from that domain (the rate
//! ramp is invisible to the spectrum; quantisation to the Allan variance at long τ).
//!
//! A term a fit could not tell from a neighbour (a model with the neighbour in its place scored
//! within 6 BIC units: [`TermEstimate::ambiguous_with`]) yields to the other fit's estimate when
//! that one is clear, and a disagreement involving it widens the interval without a warning; kept
//! by one fit only, ambiguous there and bounded below its value by the other, it has no combined
//! value (neither fit determines it; below its value, not its interval's lower end, which for an
//! ambiguous term reaches down to where the neighbour's model puts it, often 0).
//!
//! **Read-offs.** What an engineer reads off the Allan deviation by hand (IEEE Std 952 Annex C):
//! N = σ(1 s), B = min σ / 0.664, K = σ(3 s), with the measured points' intervals. Each is an
//! upper bound on its fitted term (every other term only adds to σ²): a fitted term whose Allan
//! variance alone exceeds the measured one at its read-off τ by more than the point's 99 %
//! upper bound is a contradiction, and `contradicts_read_off` says so (for B only where the
//! minimum lies inside the τ grid: at its end the curve has not turned). A term one fit kept and
//! the other bounds below the first one's interval is a disagreement too: its interval then starts
//! at 0 — unless the fit that kept it is the term's home (B, K, R the Allan fit, Q the spectrum)
//! and the bound lies within both fits' scatter of it (no warning): a bound from the fit that
//! hardly sees the term's regime is then no reason to doubt the one that does.

use serde::Serialize;

use crate::avar::{Deviations, ONE_SIGMA};
use crate::stats::{chi2_quantile, normal_quantile};

use super::{hull, Domain, NoiseFit, Term, TermEstimate, UpperLimit, FLICKER_PLATEAU};

/// A coefficient's one answer.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct CombinedTerm {
    pub term: Term,
    pub value: f64,
    pub lo: f64,
    pub hi: f64,
    /// Which fit the value comes from.
    pub source: Domain,
    /// The interval is the hull of both fits' intervals (they disagree).
    pub hull: bool,
    /// The interval at 1σ whatever the run's confidence (see [`TermEstimate::one_sigma`]): what
    /// the fleet comparison tests for a value the record determines.
    #[serde(skip)]
    pub one_sigma: (f64, f64),
    /// The fit it comes from could not tell this term from a neighbour (see
    /// [`TermEstimate::ambiguous_with`]) and the other fit did not determine it either.
    pub ambiguous_with: Option<Term>,
}

/// A hand read-off of the Allan deviation curve.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ReadOff {
    pub term: Term,
    /// τ it is read at, s: 1 s for N and 3 s for K where the curve has the term's slope there,
    /// else where the term's slope line touches the curve ([`slope_line`]); the minimum for B.
    pub tau_s: f64,
    pub value: f64,
    pub lo: f64,
    pub hi: f64,
    /// Local slope of log σ against log τ there (−½ where N rules, 0 at B's plateau, +½ for K):
    /// a read-off is the term's value only where the slope is the term's.
    pub slope: f64,
}

/// A reason not to take a number at face value.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum FitWarning {
    /// The final model does not describe the data (χ² test, p below
    /// [`crate::model::LACK_OF_FIT_P`]); its intervals were widened by `inflation`.
    LackOfFit {
        domain: Domain,
        chi2_per_dof: f64,
        p_value: f64,
        inflation: f64,
        /// τ (s) or frequency (Hz) range where the misfit lives.
        from: f64,
        to: f64,
    },
    /// The two fits' intervals of a term do not overlap, or one fit kept a term the other bounds
    /// below the first one's interval (then the bound is given as that fit's value).
    DomainsDisagree {
        term: Term,
        allan: f64,
        spectrum: f64,
    },
    /// A fitted term alone exceeds the measured Allan variance at its read-off τ.
    ContradictsReadOff {
        term: Term,
        fitted: f64,
        read_off: f64,
        tau_s: f64,
    },
    /// A fitted term alone exceeds the measured Allan variance's 99 % upper bound (shared among
    /// the points the Allan fit used) at `tau_s`, where the curve allows it at most `allowed`:
    /// the fit's value is not the data's (a misfit it could not see, or a term taken from the
    /// other domain's edge). Where the spectrum fit alone kept it, the term has no combined value
    /// (an upper limit instead) and this names the reading refused.
    BeyondAllanCurve {
        term: Term,
        fitted: f64,
        allowed: f64,
        tau_s: f64,
    },
    /// The residual loop added as many effects as it may (`limit`) and stopped there: effects
    /// beyond those were not looked for, so the model may still lack some.
    LoopLimitReached { limit: usize },
    /// A model with one more effect (`effect`, described by `evidence`) that the loop did not
    /// admit explains the data nearly as well (`delta_bic` behind the final model, or ahead of it
    /// by less than the loop asks): the coefficients and their intervals are both models'
    /// averaged, the rival with `weight` against the final model's 1 (named from
    /// [`crate::effects::RIVAL_WARNING_SHARE`] of the total on).
    RivalModel {
        effect: String,
        delta_bic: f64,
        weight: f64,
        evidence: String,
    },
    /// The samples lie on a grid of `step`, whose rounding (white, r = `rounding_n` in N's unit)
    /// makes up `share` of N²: the sensor's N without it is `n_without` in [`n_lo`, `n_hi`] (bounds
    /// only where the step exceeds [`crate::model::SUBTRACTION_HOLDS_TO_STEPS`] output σ, no upper
    /// one beyond [`crate::model::UPPER_BOUND_HOLDS_TO_STEPS`]).
    /// `angle_q`: the fits do not exclude that the grid is an integrated angle's, whose Q this
    /// would be (and then N holds no rounding). See [`crate::model::rounding_warning`].
    OutputResolution {
        step: f64,
        steps_per_sigma: f64,
        rounding_n: f64,
        share: f64,
        n_without: f64,
        n_lo: f64,
        n_hi: Option<f64>,
        angle_q: Option<f64>,
    },
    /// The loop found a line or a narrow band in a record joined over `joins` places (gaps under
    /// `--on-gap ignore`, rows dropped under `--on-nonfinite drop`): a sinusoid's phase breaks at
    /// each join, so a steady line may read weaker, with a narrow band or a second line beside it
    /// (a 37-Hz line over six joins read 27 % low beside a band that does not exist).
    LinesAcrossJoins { joins: u64 },
    /// The record is not static: `channel`'s means over 1 s jump by up to `largest_jump` (SI),
    /// `jumps` times between `from_s` and `to_s` ([`crate::quality::motion`]). The IEEE model
    /// describes a sensor at rest, so the coefficients are not its noise; the residual loop was
    /// not run on any channel of the record.
    NotStatic {
        channel: String,
        sensor: super::Sensor,
        from_s: f64,
        to_s: f64,
        largest_jump: f64,
        jumps: usize,
    },
    /// The loop kept a coupling to `aux` that also explains a drift of the bias significant on
    /// its own (`drift_delta_bic`, the coupling's `coupling_delta_bic`): where the aux channel
    /// only warms up, with no wander the series follows, the bias's own warm-up and one the aux
    /// channel drives are not told apart, and the coefficient holds only if the drift is the aux
    /// channel's (a warm-up of the bias beside a warming temperature that does not drive it was
    /// read as a coupling in 20 of 20 records).
    CouplingOrWarmUp {
        aux: String,
        coefficient: f64,
        drift_delta_bic: f64,
        coupling_delta_bic: f64,
    },
    /// K that the final Allan fit determines would go with a coupling to `aux` taken out
    /// (`coefficient` SI, family-wise `p_value` under the final model, short of the evidence an
    /// effect needs): the rise K stands for may be that channel's warm-up, and K's interval
    /// reaches down to 0 (`k`: K as read, SI).
    KOrCoupling {
        aux: String,
        coefficient: f64,
        p_value: f64,
        k: f64,
    },
    /// The `spikes` samples the loop removed are the far end of a tail continuous with the noise
    /// (`shoulder` samples in the band one σ below the threshold where Gaussian noise puts
    /// `shoulder_gaussian`): heavy-tailed noise rather than glitches, or glitches whose amplitudes
    /// reach down into the noise; the data cannot tell. N is the noise's without them; with them
    /// (their removal's energy added back as white noise) it is `n_with`. See
    /// [`crate::effects::time::spikes::TailShape`]. `in_bursts` of them lie in `bursts` groups of
    /// at least [`BURST_MIN_SAMPLES`] spikes each within `burst_gap_s` of the next
    /// ([`spike_bursts`]): where that is most of them, they are the rings of transients (a
    /// knock, a footstep), which the sentence then names, not single glitches.
    HeavyTail {
        spikes: usize,
        shoulder: usize,
        shoulder_gaussian: f64,
        n: f64,
        n_with: f64,
        bursts: usize,
        in_bursts: usize,
        burst_gap_s: f64,
    },
}

impl FitWarning {
    /// A one-line description (SI values).
    pub fn describe(&self) -> String {
        match self {
            FitWarning::LackOfFit {
                domain,
                chi2_per_dof,
                p_value,
                inflation,
                from,
                to,
            } => {
                let (what, unit) = match domain {
                    Domain::Allan => ("Allan", "s (τ)"),
                    Domain::Spectrum => ("spectrum", "Hz"),
                };
                format!(
                    "lack of fit in the {what} domain: χ²/dof = {chi2_per_dof:.3} (p = {p_value:.1e}), \
                     worst at {from:.4}–{to:.4} {unit}; intervals widened ×{inflation:.2}"
                )
            }
            FitWarning::DomainsDisagree {
                term,
                allan,
                spectrum,
            } => format!(
                "{} disagrees between the fits: spectrum/Allan = {:.3}; the combined interval spans both",
                term.symbol(),
                spectrum / allan
            ),
            FitWarning::ContradictsReadOff {
                term,
                fitted,
                read_off,
                tau_s,
            } => format!(
                "fitted {} = {fitted:.4e} lies above what the Allan deviation allows at τ = {tau_s:.3} s \
                 (read-off {read_off:.4e})",
                term.symbol()
            ),
            FitWarning::BeyondAllanCurve {
                term,
                fitted,
                allowed,
                tau_s,
            } => format!(
                "fitted {} = {fitted:.4e} alone lies above the measured Allan deviation at \
                 τ = {tau_s:.4} s, which allows at most {allowed:.4e}",
                term.symbol()
            ),
            FitWarning::LoopLimitReached { limit } => format!(
                "the residual loop stopped at its limit of {limit} effects: further effects were \
                 not looked for, and the model may still lack some"
            ),
            FitWarning::RivalModel {
                effect,
                delta_bic,
                weight,
                evidence,
            } => format!(
                "a model with {} explains the data nearly as well (ΔBIC {delta_bic:+.1}{}; \
                 {evidence}): the coefficients and their intervals are those of both models \
                 averaged, this one weighing {:.0} % of the total",
                match effect.as_str() {
                    "gauss_markov" => "a Gauss–Markov process",
                    "coupling" => "a coupling to an aux channel",
                    "step" => "a bias step",
                    "excursion" => "an excursion",
                    "drift" => "a drift",
                    "resonance" => "a resonance",
                    other => other,
                },
                // A slow effect's own note says why it was not admitted where its ΔBIC was low
                // enough (its family-wise p-value).
                if *delta_bic >= -6.0 {
                    ", not below the −6 an effect needs"
                } else {
                    ""
                },
                100.0 * super::rival_share(*weight)
            ),
            FitWarning::CouplingOrWarmUp {
                aux,
                drift_delta_bic,
                coupling_delta_bic,
                ..
            } => format!(
                "the coupling to {aux} also stands for a drift of the bias that is significant on \
                 its own (ΔBIC {drift_delta_bic:.1}, the coupling's {coupling_delta_bic:.1}): \
                 where {aux} only warms up, with no wander the series follows, the bias's own \
                 warm-up and one {aux} drives are not told apart, and the coefficient holds only \
                 if the drift is {aux}'s"
            ),
            FitWarning::KOrCoupling {
                aux,
                coefficient,
                p_value,
                ..
            } => format!(
                "K may stand for {aux}'s warm-up: with a coupling of {coefficient:.3e} (SI) to \
                 {aux} taken out (p = {p_value:.1e}, short of the evidence an effect needs) the \
                 Allan fit keeps no random walk; the record does not tell the two apart, and K's \
                 interval reaches down to 0"
            ),
            FitWarning::LinesAcrossJoins { joins } => format!(
                "a line or narrow band was found in a record joined over {joins} place{} (gaps \
                 under --on-gap ignore, rows dropped as non-finite): a line's phase breaks at \
                 each join, so a steady line may read weaker, with a narrow band or a second line \
                 beside it; --on-gap fill keeps its phase",
                if *joins == 1 { "" } else { "s" }
            ),
            FitWarning::NotStatic { largest_jump, .. } => {
                not_static_line(self, &format!("{largest_jump:.4e} (SI)"))
            }
            FitWarning::HeavyTail { .. } => heavy_tail_line(self, |x| format!("{x:.4e}"), "(SI)"),
            FitWarning::OutputResolution { .. } => {
                resolution_line(
                    self,
                    |x| format!("{x:.4e}"),
                    "(SI)",
                    "(SI)",
                    |q| format!("{q:.3e} (SI)"),
                )
            }
        }
    }
}

/// The [`FitWarning::NotStatic`] sentence, with the largest jump written as `jump`.
pub fn not_static_line(w: &FitWarning, jump: &str) -> String {
    let FitWarning::NotStatic {
        channel,
        from_s,
        to_s,
        jumps,
        ..
    } = w
    else {
        return w.describe();
    };
    format!(
        "the record is not static: the 1-s means of {channel} jump by up to {jump} ({jumps} \
         jump{} between {from_s:.0} s and {to_s:.0} s), as a sensor turned, tilted or carried \
         does: the noise model describes a sensor at rest, so these coefficients are not its \
         noise, and the residual loop was not run; analyse a stretch at rest (cut the record)",
        if *jumps == 1 { "" } else { "s" }
    )
}

/// Spikes closer than this (s) belong to one burst, unless the spikes are so many that a
/// twentieth of their mean spacing is shorter (see [`spike_bursts`]).
pub const BURST_GAP_S: f64 = 0.5;
/// Spikes a group needs to be a burst.
pub const BURST_MIN_SAMPLES: usize = 3;

/// (bursts, spikes in them, the gap used): the groups of at least [`BURST_MIN_SAMPLES`] of
/// `times_s` (sorted or not) each within the gap of the next, the gap [`BURST_GAP_S`] or a
/// twentieth of the mean spacing over `duration_s` if shorter: spikes scattered at random then
/// link by chance with probability 1 − e^(−1/20) ≈ 5 % at most (1 % of a 1-kHz record's samples
/// would otherwise chain into "bursts" 0.1 s apart).
pub fn spike_bursts(times_s: &[f64], duration_s: f64) -> (usize, usize, f64) {
    let mut t: Vec<f64> = times_s.iter().copied().filter(|v| v.is_finite()).collect();
    t.sort_by(f64::total_cmp);
    let gap = BURST_GAP_S.min(duration_s / (20.0 * t.len().max(1) as f64));
    let (mut bursts, mut inside, mut run) = (0, 0, 0usize);
    for (i, &v) in t.iter().enumerate() {
        run += 1;
        let ends = t.get(i + 1).is_none_or(|&next| next - v > gap);
        if ends {
            if run >= BURST_MIN_SAMPLES {
                bursts += 1;
                inside += run;
            }
            run = 0;
        }
    }
    (bursts, inside, gap)
}

/// The [`FitWarning::HeavyTail`] sentence, with N's values written by `n` in `unit`.
pub fn heavy_tail_line(w: &FitWarning, n: impl Fn(f64) -> String, unit: &str) -> String {
    let FitWarning::HeavyTail {
        spikes,
        shoulder,
        shoulder_gaussian,
        n: n_without,
        n_with,
        bursts,
        in_bursts,
        burst_gap_s,
    } = w
    else {
        return String::new();
    };
    let cause = if 2 * in_bursts >= *spikes && *bursts > 0 {
        format!(
            "{in_bursts} of them come in {bursts} bursts (spikes within {burst_gap_s:.3} s of \
             each other): the rings of transients, such as a knock or a footstep, not single \
             glitches or heavy-tailed noise"
        )
    } else {
        "heavy-tailed noise, or glitches reaching down into it".to_string()
    };
    format!(
        "the {spikes} spikes removed are the far end of a tail continuous with the noise \
         ({shoulder} samples in the σ below the threshold, where Gaussian noise puts \
         {shoulder_gaussian:.1}): {cause}; N = {} {unit} is the noise's without them, {} {unit} \
         with them",
        n(*n_without),
        n(*n_with)
    )
}

/// The [`FitWarning::OutputResolution`] sentence, with N's values written by `n` in `unit`, the
/// step in `step_unit` and the angle reading's Q by `q` (value and unit).
pub fn resolution_line(
    w: &FitWarning,
    n: impl Fn(f64) -> String,
    unit: &str,
    step_unit: &str,
    q: impl Fn(f64) -> String,
) -> String {
    let FitWarning::OutputResolution {
        step,
        steps_per_sigma,
        rounding_n,
        share,
        n_without,
        n_lo,
        n_hi,
        angle_q,
    } = w
    else {
        return String::new();
    };
    let angle = angle_q.map_or(String::new(), |angle_q| {
        format!(
            "; if the grid is that of an integrated angle instead, its error is the quantisation \
             term Q = {}, which the fits do not exclude, and N holds no rounding",
            q(angle_q)
        )
    });
    let grid = format!("the samples lie on a grid of {step:.4e} {step_unit}");
    let added = format!(
        "rounding a rate to it adds white noise of {} {unit} to N, {:.1} % of N²",
        n(*rounding_n),
        100.0 * share
    );
    match n_hi {
        Some(hi) if *steps_per_sigma <= super::SUBTRACTION_HOLDS_TO_STEPS => format!(
            "{grid}: {added}; the sensor's N without it is {} [{}, {}] {unit}{angle}",
            n(*n_without),
            n(*n_lo),
            n(*hi)
        ),
        Some(hi) => format!(
            "{grid}: {added}; the step is {steps_per_sigma:.2} times the output's white σ, too \
             coarse for the rounding to be subtracted exactly: the sensor's N lies between {} \
             and {} {unit}{angle}",
            n(*n_lo),
            n(*hi)
        ),
        None => {
            let floor = if *n_lo > 0.0 {
                format!("the sensor's N is at least {} {unit} and", n(*n_lo))
            } else {
                "the sensor's N".to_string()
            };
            format!(
                "{grid}, {steps_per_sigma:.2} times the output's white σ: a quantiser this coarse \
                 hides noise (its rounding alone would add {} {unit}, {:.0} % of the output's N²), \
                 so {floor} cannot be read from this output, and the other terms too describe the \
                 quantised output, not the sensor{angle}",
                n(*rounding_n),
                100.0 * share
            )
        }
    }
}

/// The combined coefficients of one channel, the read-offs and the warnings.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Combined {
    pub terms: Vec<CombinedTerm>,
    /// The terms without a combined estimate: the largest value the fits and the measured Allan
    /// curve allow ([`upper_limit`], within [`allan_cap`]), at the fits' confidence.
    pub limits: Vec<UpperLimit>,
    pub read_offs: Vec<ReadOff>,
    pub warnings: Vec<FitWarning>,
}

impl Combined {
    /// The combined estimate of `term`, if either fit kept it.
    pub fn get(&self, term: Term) -> Option<&CombinedTerm> {
        self.terms.iter().find(|t| t.term == term)
    }

    /// The upper limit of `term` where it has no combined estimate.
    pub fn limit(&self, term: Term) -> Option<f64> {
        self.limits.iter().find(|l| l.term == term).map(|l| l.upper)
    }
}

/// |z| of a difference between the fits (in log value, over the root sum of squares of their
/// standard errors) beyond which a disagreement is named: p < 0.001 two-sided. Two right 1σ
/// intervals miss each other in ≈ 16 % of cases, so non-overlap alone (which still widens the
/// combined interval to the hull) would warn on half of all clean records.
const DISAGREE_Z: f64 = 3.29;

/// Two-sided confidence of the measured Allan curve's bounds: an upper end or limit is cut to
/// them, and a value beyond them is ruled out ([`FitWarning::BeyondAllanCurve`]), as for a
/// read-off's contradiction.
const BEYOND_CURVE_P: f64 = 0.99;

/// Whether an estimate `value` (standard error `s_e` of its logarithm) differs at p < 0.001 from
/// a term the other fit did not admit, of which that fit gives only `upper`, its upper limit at
/// two-sided confidence `p`. The limit is u² = ĉ + z·σ for the other fit's forced-in squared
/// coefficient ĉ and its standard error σ, which are not kept apart: the difference is named only
/// where it is significant for every split of u² between them — the limit taken as exact
/// (σ = 0: `value` beyond [`DISAGREE_Z`] of its own errors above u) and as all scatter (ĉ = 0,
/// σ = u²/z: value² against 0 with both errors). Comparing with the limit alone, as if exact,
/// warned "K disagrees" on 8 of 200 clean 24-h records, whose spectrum sees too little of K's
/// regime to admit it and bounds it at 0.75–0.79 of the Allan value at 1σ.
fn beyond_bound(value: f64, s_e: f64, upper: f64, p: f64) -> bool {
    let z = normal_quantile((1.0 + p) / 2.0);
    let exact = upper < value * (-DISAGREE_Z * s_e).exp();
    let c = value * value;
    let (own, other) = (2.0 * c * s_e, upper * upper / z.max(f64::MIN_POSITIVE));
    let scatter = c > DISAGREE_Z * own.hypot(other);
    exact && scatter
}

/// The confidence of the fits' intervals (1σ when neither says).
fn confidence(a: Option<&NoiseFit>, s: Option<&NoiseFit>) -> f64 {
    a.or(s).map_or(ONE_SIGMA, |f| f.confidence)
}

/// Standard error of ln(value) from an interval at two-sided probability `p`.
fn log_sd(e: &TermEstimate, p: f64) -> f64 {
    let z = normal_quantile((1.0 + p) / 2.0);
    if e.lo > 0.0 && e.hi > e.lo && z > 0.0 {
        (e.hi / e.lo).ln() / (2.0 * z)
    } else if e.value > 0.0 && e.hi > e.value {
        // An interval reaching 0: the upper half only.
        (e.hi / e.value).ln() / z
    } else {
        f64::INFINITY
    }
}

/// The 1σ interval's width over the value (at 1σ whatever the intervals' confidence: the widths
/// of two χ² intervals of different EDF compare differently at another level, and which fit gives
/// the value must not depend on it).
fn relative_width(e: &TermEstimate) -> f64 {
    if e.value > 0.0 {
        (e.one_sigma.1 - e.one_sigma.0) / e.value
    } else {
        f64::INFINITY
    }
}

/// Combines the two fits' estimates (either may be missing) and checks them against the read-offs
/// of `dev` (the overlapping Allan variance the Allan fit was made on).
pub fn combine(
    allan: Option<&NoiseFit>,
    spectrum: Option<&NoiseFit>,
    dev: Option<&Deviations>,
) -> Combined {
    let mut warnings = Vec::new();
    for fit in [allan, spectrum].into_iter().flatten() {
        let l = fit.lack_of_fit;
        if l.significant {
            warnings.push(FitWarning::LackOfFit {
                domain: fit.domain,
                chi2_per_dof: l.chi2_per_dof,
                p_value: l.p_value,
                inflation: l.inflation,
                from: l.worst_from,
                to: l.worst_to,
            });
        }
    }
    let (allan_fit, spectrum_fit) = (allan, spectrum);
    // The measured Allan curve's bounds at the τ the Allan fit used (below them a sensor's
    // low-pass has taken variance out); without an Allan fit the curve is not known to follow
    // the model anywhere, and nothing is bounded by it. At 99 % whatever the intervals'
    // confidence: at the run's 1σ, the bounds of the shortest τ fitted (EDF in the thousands)
    // held N of a 1-kHz gyro behind a 102-Hz filter 1 % below the truth, and cut the hull of the
    // two fits' N below the spectrum's value.
    let fitted_from = allan_fit.and_then(|f| f.points.iter().map(|x| x.x).reduce(f64::min));
    let bounds = dev
        .zip(fitted_from)
        .map_or_else(Vec::new, |(dev, min_tau)| {
            allan_bounds(dev, BEYOND_CURVE_P, min_tau)
        });
    let cap = |term: Term| allan_cap(&bounds, term).map(|(c, _)| c);
    let impossible = |term: Term, value: f64| allan_cap(&bounds, term).filter(|&(c, _)| value > c);
    let mut terms = Vec::new();
    for term in Term::ALL {
        let a = allan.and_then(|f| f.get(term));
        let s = spectrum.and_then(|f| f.get(term));
        // The other fit's bound on an absent term: (at the intervals' confidence, at 1σ for the
        // decisions).
        let upper = |fit: Option<&NoiseFit>| {
            fit.and_then(|f| f.upper_limits.iter().find(|u| u.term == term))
                .map(|u| (u.upper, u.one_sigma))
        };
        let combined = match (a, s) {
            (None, None) => continue,
            (Some(e), None) | (None, Some(e)) => {
                let (domain, other) = if a.is_some() {
                    (Domain::Allan, spectrum)
                } else {
                    (Domain::Spectrum, allan)
                };
                let mut c = pick(e, domain);
                // Against the value, not the interval's lower end: an ambiguous term's interval
                // reaches down to where the neighbour's model puts it, 0 where that model weighs
                // more than the lower tail (`select::averaged_interval`), and no bound is below 0.
                let bound = upper(other).filter(|&(_, u)| u < e.value);
                if e.ambiguous_with.is_some()
                    && (bound.is_some() || impossible(term, e.value).is_some())
                    && term != Term::RateRamp
                {
                    // Neither fit determines it: this one could not tell it from a neighbour,
                    // and the other fit or the measured Allan curve bounds it below this
                    // estimate. No answer beats a wrong one.
                    continue;
                }
                // Kept clearly by the spectrum fit only, at a value the measured Allan curve
                // rules out (the term alone above its 99 % upper bound): the other fit, which
                // sees the curve, did not keep it, and the curve forbids this reading, so neither
                // determines the term. It is an upper limit, with the warning that names the
                // reading refused (an 8-h
                // FOG record's spectrum kept K = 4.65 °/h/√h on a gyro with none, the curve
                // allowing 0.024 at τ = 2621 s, and the combined K and imu.yaml took it).
                let refused = impossible(term, e.value).filter(|_| domain == Domain::Spectrum);
                if let Some((allowed, tau_s)) = refused {
                    warnings.push(FitWarning::BeyondAllanCurve {
                        term,
                        fitted: e.value,
                        allowed,
                        tau_s,
                    });
                    continue;
                }
                // The other fit did not admit the term and bounds it below this estimate: the
                // term may not be there at all.
                // The spectrum fit is blind to a ramp (its lowest bands are above the drift):
                // its bound on R says nothing.
                let blind = term == Term::RateRamp && domain == Domain::Allan;
                // Nor is a bound evidence where the other fit kept a neighbour in this term's
                // place that it could not tell from this term (a spectrum whose lowest bands
                // see B's excess and give it to K): the bound holds only beside that substitute.
                // 30-min clean records: 8 of 200 warned "B disagrees" this way.
                let substituted = other
                    .is_some_and(|f| f.estimates.iter().any(|n| n.ambiguous_with == Some(term)));
                let below = |&(_, u): &(f64, f64)| u < e.one_sigma.0 && !blind && !substituted;
                if let Some((u, u_one_sigma)) = upper(other).filter(below) {
                    let (allan, spectrum) = match domain {
                        Domain::Allan => (e.value, u),
                        Domain::Spectrum => (u, e.value),
                    };
                    // Named only where the difference is significant (p < 0.001) with both
                    // fits' scatter counted (see `beyond_bound`).
                    let s_e = log_sd(e, confidence(allan_fit, spectrum_fit));
                    let significant = beyond_bound(e.value, s_e, u_one_sigma, ONE_SIGMA);
                    // A bound from outside the term's home that its scatter explains is no
                    // reason to doubt the home fit's estimate (a 40-min spectrum bounded B at
                    // 1.9 °/h, its lowest band holding B's excess at a fifth of the floor, beside
                    // an Allan fit of [2.6, 3.2] °/h on a 3-°/h gyro: the hull to 0 made B
                    // unfailable in a screen).
                    let home_keeps_it = home(term) == Some(domain) && e.ambiguous_with.is_none();
                    if significant || !home_keeps_it {
                        (c.lo, c.one_sigma.0) = (0.0, 0.0);
                        c.hull = true;
                    }
                    if e.ambiguous_with.is_none() && significant {
                        warnings.push(FitWarning::DomainsDisagree {
                            term,
                            allan,
                            spectrum,
                        });
                    }
                }
                c
            }
            (Some(a), Some(s)) => {
                let (a_whole, s_whole) = (
                    complete(allan, spectrum, term),
                    complete(spectrum, allan, term),
                );
                let (a_clear, s_clear) = (a.ambiguous_with.is_none(), s.ambiguous_with.is_none());
                let prefer_allan = match (a_clear, s_clear, a_whole, s_whole) {
                    (true, false, ..) => true,
                    (false, true, ..) => false,
                    // Neither fit could tell the term from a neighbour: the one whose range
                    // holds its slope regime widest. Relative widths of two intervals down to 0
                    // favour the larger value (a spectrum's K of 550 [0, 912] °/h/√h, its
                    // lowest bands holding a warm-up, beat the Allan fit's 3.4 [0, 6.7] on a
                    // 10-°/h/√h gyro and went into imu.yaml).
                    (false, false, ..) if home(term).is_some() => home(term) == Some(Domain::Allan),
                    (.., true, false) => true,
                    (.., false, true) => false,
                    _ => relative_width(a) <= relative_width(s),
                };
                // An estimate the measured Allan curve rules out yields to one it allows.
                let prefer_allan = match (impossible(term, a.value), impossible(term, s.value)) {
                    (Some(_), None) => false,
                    (None, Some(_)) => true,
                    _ => prefer_allan,
                };
                let (best, domain) = if prefer_allan {
                    (a, Domain::Allan)
                } else {
                    (s, Domain::Spectrum)
                };
                let mut c = pick(best, domain);
                // Tested at 1σ whatever the intervals' confidence: the value must not move
                // with it (`TermEstimate::one_sigma`).
                if a.one_sigma.1 < s.one_sigma.0 || s.one_sigma.1 < a.one_sigma.0 {
                    // Disagreement: the value from the term's home domain, where its slope regime
                    // is widest (B, K, R at long τ; Q at high frequency).
                    c = match home(term) {
                        Some(Domain::Allan) => pick(a, Domain::Allan),
                        Some(Domain::Spectrum) => pick(s, Domain::Spectrum),
                        None => c,
                    };
                    (c.lo, c.hi) = hull((a.lo, a.hi), (s.lo, s.hi));
                    c.one_sigma = hull(a.one_sigma, s.one_sigma);
                    c.hull = true;
                    let p = confidence(allan_fit, spectrum_fit);
                    let d = (a.value / s.value).ln().abs()
                        / (log_sd(a, p).powi(2) + log_sd(s, p).powi(2)).sqrt();
                    if d > DISAGREE_Z && a_clear && s_clear {
                        warnings.push(FitWarning::DomainsDisagree {
                            term,
                            allan: a.value,
                            spectrum: s.value,
                        });
                    }
                }
                c
            }
        };
        terms.push(combined);
    }
    for t in &mut terms {
        if let Some(cap) = cap(t.term) {
            t.hi = t.hi.min(cap).max(t.value);
            t.one_sigma.1 = t.one_sigma.1.min(cap).max(t.value);
        }
        if let Some((allowed, tau_s)) = impossible(t.term, t.value) {
            warnings.push(FitWarning::BeyondAllanCurve {
                term: t.term,
                fitted: t.value,
                allowed,
                tau_s,
            });
        }
    }
    let limits = Term::ALL
        .into_iter()
        .filter(|&term| !terms.iter().any(|t| t.term == term))
        .filter_map(|term| {
            let capped = |u: f64| cap(term).map_or(u, |c| u.min(c));
            let upper = capped(upper_limit(allan_fit, spectrum_fit, term)?);
            let one_sigma =
                upper_limit_at(allan_fit, spectrum_fit, term, true).map_or(upper, capped);
            Some(UpperLimit {
                term,
                upper,
                beside_kept: one_sigma,
                one_sigma,
            })
        })
        .collect();
    let read_offs = dev
        .map(|d| read_offs(d, fitted_from.unwrap_or(0.0)))
        .unwrap_or_default();
    if let Some(dev) = dev {
        for t in &terms {
            if let Some((tau, bound)) = allan_bound(dev, t.term) {
                let alone = t.term.avar_unit(tau) * t.value * t.value;
                if alone > bound {
                    let read_off = read_offs
                        .iter()
                        .find(|r| r.term == t.term)
                        .map_or(f64::NAN, |r| r.value);
                    warnings.push(FitWarning::ContradictsReadOff {
                        term: t.term,
                        fitted: t.value,
                        read_off,
                        tau_s: tau,
                    });
                }
            }
        }
    }
    Combined {
        terms,
        limits,
        read_offs,
        warnings,
    }
}

/// Whether `fit` kept every neighbour of `term` (the terms of adjacent slope: Q–N–B–K–R) that
/// `other` found: a fit that lacks a neighbour the other one found lets its estimate of `term`
/// absorb that neighbour's power (a spectrum without K reads B high). A neighbour `other` kept
/// with an interval down to 0 is not found: that fit cannot say it is there. (An Allan fit of a
/// 400-Hz accelerometer kept a Q of [0, 0.33] mm/s that the spectrum bounded; by the neighbour
/// rule N then came from the Allan fit, 2.6 % low with an interval missing the truth, beside a
/// spectrum N five times as precise and on it.)
fn complete(fit: Option<&NoiseFit>, other: Option<&NoiseFit>, term: Term) -> bool {
    let (Some(fit), Some(other)) = (fit, other) else {
        return false;
    };
    let i = term.index();
    [i.checked_sub(1), Some(i + 1)]
        .into_iter()
        .flatten()
        .filter_map(|j| Term::ALL.get(j))
        .all(|&u| other.get(u).is_none_or(|e| e.one_sigma.0 <= 0.0) || fit.get(u).is_some())
}

/// The fit whose range covers the term's slope regime widest: B, K and R the Allan variance's
/// long τ, Q the spectrum's high frequencies; N both.
fn home(term: Term) -> Option<Domain> {
    match term {
        Term::BiasInstability | Term::RateRandomWalk | Term::RateRamp => Some(Domain::Allan),
        Term::Quantization => Some(Domain::Spectrum),
        Term::RandomWalk => None,
    }
}

fn pick(e: &TermEstimate, source: Domain) -> CombinedTerm {
    CombinedTerm {
        term: e.term,
        value: e.value,
        lo: e.lo,
        hi: e.hi,
        source,
        hull: false,
        one_sigma: e.one_sigma,
        ambiguous_with: e.ambiguous_with,
    }
}

/// Index of the measured point nearest to τ in log τ, and whether τ lies inside the grid.
fn nearest(dev: &Deviations, tau: f64) -> Option<usize> {
    let (first, last) = (*dev.tau_s.first()?, *dev.tau_s.last()?);
    if !(tau >= first * 0.999 && tau <= last * 1.001) {
        return None;
    }
    (0..dev.len())
        .filter(|&i| dev.variance[i] > 0.0)
        .min_by(|&a, &b| {
            let da = (dev.tau_s[a] / tau).ln().abs();
            let db = (dev.tau_s[b] / tau).ln().abs();
            da.total_cmp(&db)
        })
}

/// σ² interpolated in log–log at τ, with its interval and local slope of log σ.
fn at(dev: &Deviations, tau: f64) -> Option<(f64, f64, f64, f64)> {
    let i = nearest(dev, tau)?;
    let j = if dev.tau_s[i] <= tau {
        i + 1
    } else {
        i.checked_sub(1)?
    };
    let j = if j < dev.len() && dev.variance[j] > 0.0 {
        j
    } else {
        return Some((
            dev.variance[i],
            dev.variance_lo[i],
            dev.variance_hi[i],
            f64::NAN,
        ));
    };
    let (a, b) = (i.min(j), i.max(j));
    let t = ((tau / dev.tau_s[a]).ln() / (dev.tau_s[b] / dev.tau_s[a]).ln()).clamp(0.0, 1.0);
    let lerp = |v: &[f64]| (v[a].ln() * (1.0 - t) + v[b].ln() * t).exp();
    let slope = 0.5 * (dev.variance[b] / dev.variance[a]).ln() / (dev.tau_s[b] / dev.tau_s[a]).ln();
    Some((
        lerp(&dev.variance),
        lerp(&dev.variance_lo),
        lerp(&dev.variance_hi),
        slope,
    ))
}

/// σ² of `dev` interpolated in log–log at τ ([`at`]); `None` outside its τ grid.
pub(crate) fn variance_at(dev: &Deviations, tau: f64) -> Option<f64> {
    at(dev, tau).map(|(v, ..)| v)
}

/// How far (in log σ per log τ) the curve's local slope may be from a term's for the term's slope
/// line to be read there.
const SLOPE_TOLERANCE: f64 = 0.15;

/// A read-off of N or K by its slope line (σ = N/√τ, σ = K·√(τ/3)) through the measured curve
/// where the curve has the term's `slope`, read at `tau` (1 s for N, 3 s for K), as the field
/// reads them by hand (IEEE Std 952 Annex C, and allan_variance_ros's fitted lines): at `tau`
/// itself where the local slope there is the term's, else through the midpoint of the pair of
/// neighbouring points whose slope is the term's within [`SLOPE_TOLERANCE`] and is measured best
/// (the most averages: [`slope_noise`]; nearest the term's slope among equals; both points from
/// `min_tau_s` on), else N at 1 s with the slope shown and no K: the value at τ = 3 s alone, where
/// N still rules there, had read K at 15× the fitted value (slope −0.45) on a 1-kHz MEMS gyro, and
/// at 34× the truth on a 20-min one. The pair nearest the term's slope whatever its noise read N at
/// 100× the truth on a gyro whose bias instability rules from 0.05 s: a pair at 463 s with 4
/// degrees of freedom happened to fall at −0.45, nearer −½ than the short-τ pairs' −0.44.
fn slope_line(
    dev: &Deviations,
    term: Term,
    tau: f64,
    slope: f64,
    min_tau_s: f64,
) -> Option<ReadOff> {
    let read = |v: f64, at: f64| v * term.avar_unit(tau) / term.avar_unit(at);
    let (v, lo, hi, local) = at(dev, tau)?;
    let here = ReadOff {
        term,
        tau_s: tau,
        value: v.sqrt(),
        lo: lo.sqrt(),
        hi: hi.sqrt(),
        slope: local,
    };
    if (local - slope).abs() <= SLOPE_TOLERANCE && tau >= min_tau_s {
        return Some(here);
    }
    let usable = |i: usize| {
        dev.variance[i] > 0.0
            && dev.variance[i].is_finite()
            && dev.tau_s[i] >= min_tau_s * (1.0 - 1e-9)
    };
    let best = (0..dev.len().saturating_sub(1))
        .filter(|&i| usable(i) && usable(i + 1))
        .map(|i| {
            let s = 0.5 * (dev.variance[i + 1] / dev.variance[i]).ln()
                / (dev.tau_s[i + 1] / dev.tau_s[i]).ln();
            (i, s)
        })
        .filter(|(_, s)| (s - slope).abs() <= SLOPE_TOLERANCE)
        .min_by(|a, b| {
            let key = |(i, s): (usize, f64)| (slope_noise(dev, i), (s - slope).abs());
            key(*a)
                .partial_cmp(&key(*b))
                .unwrap_or(std::cmp::Ordering::Equal)
        });
    let Some((i, s)) = best else {
        return (term == Term::RandomWalk).then_some(here);
    };
    let mid = (dev.tau_s[i] * dev.tau_s[i + 1]).sqrt();
    let geo = |x: &[f64]| (x[i] * x[i + 1]).sqrt();
    Some(ReadOff {
        term,
        tau_s: mid,
        value: read(geo(&dev.variance), mid).sqrt(),
        lo: read(geo(&dev.variance_lo), mid).sqrt(),
        hi: read(geo(&dev.variance_hi), mid).sqrt(),
        slope: s,
    })
}

/// The standard error of the log-log slope between points `i` and `i + 1`, from their degrees of
/// freedom (var ln σ² ≈ 2/EDF each, taken as independent).
fn slope_noise(dev: &Deviations, i: usize) -> f64 {
    let var = |k: usize| match dev.edf.get(k) {
        Some(&e) if e > 0.0 => 2.0 / e,
        _ => f64::INFINITY,
    };
    0.5 * (var(i) + var(i + 1)).sqrt() / (dev.tau_s[i + 1] / dev.tau_s[i]).ln().abs()
}

/// The index of the smallest Allan variance.
fn minimum(dev: &Deviations) -> Option<usize> {
    (0..dev.len())
        .filter(|&i| dev.variance[i] > 0.0 && dev.variance[i].is_finite())
        .min_by(|&a, &b| dev.variance[a].total_cmp(&dev.variance[b]))
}

/// The IEEE read-offs of N, B and K from `dev`.
///
/// The slope lines are looked for from `min_tau_s` on (the shortest τ the Allan fit used): below
/// it a sensor's low-pass bends the curve, and its roll-off passed for K's +½ (K read at 10³–10⁴×
/// the truth at τ = 0.007 s behind a 40-Hz filter at 200 Hz).
pub fn read_offs(dev: &Deviations, min_tau_s: f64) -> Vec<ReadOff> {
    let mut out = Vec::new();
    for (term, tau, slope) in [
        (Term::RandomWalk, 1.0, -0.5),
        (Term::RateRandomWalk, 3.0, 0.5),
    ] {
        if let Some(r) = slope_line(dev, term, tau, slope, min_tau_s) {
            out.push(r);
        }
    }
    if let Some(i) = minimum(dev) {
        let k = FLICKER_PLATEAU.sqrt();
        let slope = if i > 0 && i + 1 < dev.len() {
            0.5 * (dev.variance[i + 1] / dev.variance[i - 1]).ln()
                / (dev.tau_s[i + 1] / dev.tau_s[i - 1]).ln()
        } else {
            f64::NAN
        };
        out.push(ReadOff {
            term: Term::BiasInstability,
            tau_s: dev.tau_s[i],
            value: dev.variance[i].sqrt() / k,
            lo: dev.variance_lo[i].sqrt() / k,
            hi: dev.variance_hi[i].sqrt() / k,
            slope,
        });
    }
    out.sort_by_key(|r| r.term.index());
    out
}

/// The number of rate samples behind point `i` of `dev` (from its term count).
fn samples_behind(dev: &Deviations, i: usize) -> usize {
    use crate::avar::Statistic;
    let (terms, m) = (dev.n_terms[i], dev.m[i]);
    let d = u64::from(dev.statistic.difference_order());
    (match dev.statistic {
        Statistic::Oadev | Statistic::Ohdev => (terms + d * m).saturating_sub(1),
        Statistic::Adev => (terms + 1) * m,
        Statistic::Hdev => (terms + 2) * m,
        Statistic::Mdev => (terms + 3 * m).saturating_sub(2),
    }) as usize
}

/// The EDF of point `i` of `dev` for a bound on it: the identified noise's, but never more than
/// a rate noise (white, flicker or random-walk FM) would give there (see [`allan_bound`]).
fn bound_edf(dev: &Deviations, i: usize) -> Option<f64> {
    let identified = dev
        .edf
        .get(i)
        .copied()
        .filter(|v| v.is_finite() && *v > 0.0)?;
    let (m, n) = (dev.m[i], samples_behind(dev, i));
    Some(
        [0i8, -1, -2]
            .into_iter()
            .map(|alpha| crate::avar::edf::edf(dev.statistic, alpha, m, n))
            .filter(|v| v.is_finite() && *v > 0.0)
            .fold(identified, f64::min),
    )
}

/// The measured Allan variance's upper bounds, (τ, bound), at the two-sided confidence `p`: at
/// every τ of `dev` from `min_tau_s` on (those the Allan fit used: below, a sensor's low-pass
/// has taken variance out, and N's bound there would fall below the truth), the point's upper
/// bound with (1 − p)/2 shared among the points (Bonferroni), so that the smallest of the
/// bounds a term takes from them ([`allan_cap`]) holds the truth at least as often as an
/// interval's upper end should.
fn allan_bounds(dev: &Deviations, p: f64, min_tau_s: f64) -> Vec<(f64, f64)> {
    let points: Vec<usize> = (0..dev.len())
        .filter(|&i| dev.tau_s[i] >= min_tau_s * (1.0 - 1e-9))
        .filter(|&i| dev.variance[i] > 0.0 && dev.variance[i].is_finite())
        .collect();
    let q = (1.0 - p) / 2.0 / points.len().max(1) as f64;
    points
        .into_iter()
        .filter_map(|i| {
            let nu = bound_edf(dev, i)?;
            let bound = dev.variance[i] * nu / chi2_quantile(q, nu);
            bound.is_finite().then_some((dev.tau_s[i], bound))
        })
        .collect()
}

/// The largest value of `term` the measured Allan variance allows: its Allan variance alone
/// within every one of `bounds` ([`allan_bounds`]; every other term only adds to σ²), the
/// smallest of these. An interval's upper end beyond it says more than the data: a K of
/// 4.8 °/h/√h had a 95 % interval reaching 133.7, whose Allan deviation alone at τ = 2621 s
/// (66 °/h) is 4.5 times the measured point's 95 % upper bound (14.6 °/h). Not for the rate ramp,
/// whose interval the series' test sets.
fn allan_cap(bounds: &[(f64, f64)], term: Term) -> Option<(f64, f64)> {
    if term == Term::RateRamp {
        return None;
    }
    bounds
        .iter()
        .filter_map(|&(tau, bound)| {
            let unit = term.avar_unit(tau);
            (unit > 0.0).then(|| ((bound / unit).sqrt(), tau))
        })
        .reduce(|a, b| if b.0 < a.0 { b } else { a })
}

/// The τ at which a term's Allan variance alone is checked against the measurement and the
/// measurement's 99 % upper bound there (from the point's EDF).
fn allan_bound(dev: &Deviations, term: Term) -> Option<(f64, f64)> {
    let i = match term {
        Term::RandomWalk => nearest(dev, 1.0)?,
        // Only a minimum inside the curve is a plateau; at either end of the τ grid the curve is
        // still falling (or rising) and its lowest point, picked among noisy ones, is biased low.
        Term::BiasInstability => minimum(dev).filter(|&i| i > 0 && i + 1 < dev.len())?,
        Term::RateRandomWalk => nearest(dev, 3.0)?,
        _ => return None,
    };
    // The EDF of the identified noise type, but never more than a rate noise (white, flicker or
    // random-walk FM) would give there: at the longest τ a handful of averages can be identified
    // as phase noise (α = 1), whose EDF (154 at 4 averages of a 24-h record) made the bound so
    // tight that a right B (3.07 °/h, truth 3) was called a contradiction of its read-off.
    let nu = bound_edf(dev, i)?;
    Some((
        dev.tau_s[i],
        dev.variance[i] * nu / chi2_quantile(0.005, nu),
    ))
}

/// The largest value of `term` the fits allow when the combined estimate has none: the upper end
/// of a kept estimate's interval (a fit that kept it ambiguously) or the fit's upper limit, from
/// the term's home domain where that fit gives one — B, K and R from the Allan variance, whose
/// long τ see their slopes where the spectrum's lowest band does not begin to — else from the
/// other fit; for Q and N, whose home is either, the larger of the two fits, so that a pass on it
/// holds for both. A bound of the spectrum's on B or K is then only its trade with a neighbour
/// in its lowest bands: the verdict on a limit must not hang on which fit happened to keep the
/// term. The
/// spectrum's bound on a rate ramp is never used: its lowest band is above the drift (see
/// [`crate::model::combine`]).
pub fn upper_limit(
    allan: Option<&NoiseFit>,
    spectrum: Option<&NoiseFit>,
    term: Term,
) -> Option<f64> {
    upper_limit_at(allan, spectrum, term, false)
}

/// [`upper_limit`] at the intervals' confidence, or at 1σ where `one_sigma`.
pub(crate) fn upper_limit_at(
    allan: Option<&NoiseFit>,
    spectrum: Option<&NoiseFit>,
    term: Term,
    one_sigma: bool,
) -> Option<f64> {
    let bound = |f: &NoiseFit| {
        f.get(term)
            .map(|e| if one_sigma { e.one_sigma.1 } else { e.hi })
            .or_else(|| {
                f.upper_limits.iter().find(|u| u.term == term).map(|u| {
                    if one_sigma {
                        u.one_sigma
                    } else {
                        u.upper
                    }
                })
            })
            .filter(|u| u.is_finite())
    };
    match term {
        Term::BiasInstability | Term::RateRandomWalk => {
            allan.and_then(bound).or_else(|| spectrum.and_then(bound))
        }
        Term::RateRamp => allan.and_then(bound),
        Term::Quantization | Term::RandomWalk => [allan, spectrum]
            .into_iter()
            .flatten()
            .filter_map(bound)
            .reduce(f64::max),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn est(term: Term, value: f64, rel: f64) -> TermEstimate {
        TermEstimate {
            term,
            value,
            lo: value * (1.0 - rel),
            hi: value * (1.0 + rel),
            edf: 100.0,
            one_sigma: (value * (1.0 - rel), value * (1.0 + rel)),
            ambiguous_with: None,
            zero_share: 0.0,
        }
    }

    /// The 24-h record that called a right B a contradiction: its Allan minimum at 4 averages
    /// was identified as flicker PM (α = 1, EDF 154). The bound now takes at most a rate noise's
    /// EDF there, and the term counts give back the sample count.
    #[test]
    fn a_minimum_at_few_averages_is_bounded_with_a_rate_noises_edf() {
        use crate::avar::{edf::edf, Statistic};
        let n = 34_560_000usize;
        let ms = [4_194_304u64, 8_388_608, 16_777_216];
        let variance = vec![7.38e-11, 3.66e-11, 4.51e-11];
        let dev = Deviations {
            statistic: Statistic::Oadev,
            rate_hz: 400.0,
            m: ms.to_vec(),
            tau_s: ms.iter().map(|&m| m as f64 / 400.0).collect(),
            variance: variance.clone(),
            n_terms: ms.iter().map(|&m| Statistic::Oadev.n_terms(n, m)).collect(),
            alpha: vec![0, 1, 1],
            edf: vec![10.2, 154.2, 17.9],
            variance_lo: variance.clone(),
            variance_hi: variance.clone(),
            confidence: 0.6827,
        };
        for i in 0..3 {
            assert_eq!(samples_behind(&dev, i), n);
        }
        let (tau, bound) = allan_bound(&dev, Term::BiasInstability).unwrap();
        assert_eq!(tau, ms[1] as f64 / 400.0);
        let nu = edf(Statistic::Oadev, -2, ms[1], n);
        assert!(nu < 10.0, "{nu}");
        let want = 3.66e-11 * nu / chi2_quantile(0.005, nu);
        assert!((bound / want - 1.0).abs() < 1e-9, "{bound} vs {want}");
        // B = 3.07 °/h: (0.664·B)² = 9.8e-11, below the bound now, above the old one.
        let b = 3.07 * std::f64::consts::PI / 180.0 / 3600.0;
        let b_var = FLICKER_PLATEAU * b * b;
        let old = 3.66e-11 * 154.2 / chi2_quantile(0.005, 154.2);
        assert!(b_var > old && b_var < bound, "{b_var} {old} {bound}");
    }

    /// N = 0.1 and K = 1e-3 (crossing at τ ≈ 173 s): σ(3 s) is N's (slope −½), so K is read
    /// from its +½ line through the long τ where K rules, not as σ(3 s), 57× K; N stays at 1 s.
    #[test]
    fn n_and_k_are_read_from_their_slope_lines() {
        use crate::avar::Statistic;
        let ms: Vec<u64> = (0..21).map(|k| 1u64 << k).collect();
        let tau: Vec<f64> = ms.iter().map(|&m| m as f64 / 100.0).collect();
        let (n, k) = (0.1f64, 1e-3f64);
        let variance: Vec<f64> = tau.iter().map(|t| n * n / t + k * k * t / 3.0).collect();
        let dev = Deviations {
            statistic: Statistic::Oadev,
            rate_hz: 100.0,
            m: ms.clone(),
            tau_s: tau,
            variance: variance.clone(),
            n_terms: ms.iter().map(|_| 100).collect(),
            alpha: vec![0; ms.len()],
            edf: vec![10.0; ms.len()],
            variance_lo: variance.iter().map(|v| 0.8 * v).collect(),
            variance_hi: variance.iter().map(|v| 1.25 * v).collect(),
            confidence: 0.6827,
        };
        let r = read_offs(&dev, 0.01);
        let get = |t: Term| *r.iter().find(|x| x.term == t).unwrap();
        let rn = get(Term::RandomWalk);
        assert_eq!(rn.tau_s, 1.0);
        assert!((rn.value / n - 1.0).abs() < 1e-3, "{rn:?}");
        let rk = get(Term::RateRandomWalk);
        assert!(
            rk.tau_s > 1000.0 && (rk.slope - 0.5).abs() <= SLOPE_TOLERANCE,
            "{rk:?}"
        );
        assert!((rk.value / k - 1.0).abs() < 0.1, "{rk:?}");
        assert!(rk.lo < rk.value && rk.value < rk.hi);
    }

    /// A gyro whose bias instability rules from 0.1 s: the shortest pair falls at −0.485, and a
    /// chance wiggle at long τ (few averages) at −0.495. N is read where it is measured best, not at
    /// the wiggle (which had read it at 100× the truth).
    #[test]
    fn n_is_read_where_its_slope_is_measured_best() {
        use crate::avar::Statistic;
        let ms: Vec<u64> = (0..18).map(|k| 1u64 << k).collect();
        let tau: Vec<f64> = ms.iter().map(|&m| m as f64 / 200.0).collect();
        let (n, b) = (0.01f64, 0.025f64);
        let mut variance: Vec<f64> = tau.iter().map(|t| n * n / t + b * b).collect();
        let j = 16;
        variance[j + 1] = variance[j] * 2f64.powf(-0.99);
        let edf: Vec<f64> = ms.iter().map(|&m| 4e5 / m as f64).collect();
        let dev = Deviations {
            statistic: Statistic::Oadev,
            rate_hz: 200.0,
            m: ms.clone(),
            tau_s: tau,
            variance: variance.clone(),
            n_terms: ms.iter().map(|_| 100).collect(),
            alpha: vec![0; ms.len()],
            edf,
            variance_lo: variance.iter().map(|v| 0.9 * v).collect(),
            variance_hi: variance.iter().map(|v| 1.1 * v).collect(),
            confidence: 0.6827,
        };
        let first = 0.5 * (variance[1] / variance[0]).ln() / 2f64.ln();
        assert!((first + 0.5).abs() <= SLOPE_TOLERANCE, "{first}");
        let r = read_offs(&dev, 0.005);
        let rn = *r.iter().find(|x| x.term == Term::RandomWalk).unwrap();
        assert!(rn.tau_s < 0.01, "{rn:?}");
        assert!((rn.value / n - 1.0).abs() < 0.15, "{rn:?}");
    }

    fn fit(domain: Domain, estimates: Vec<TermEstimate>, upper: Vec<(Term, f64)>) -> NoiseFit {
        crate::model::result::fit_for_tests(domain, estimates, upper)
    }

    /// The octave OADEV (1σ) of 100 000 white samples of σ = 1 at 100 Hz (N = 0.1).
    fn white_oadev(seed: u64) -> Deviations {
        use crate::avar::{compute, Confidence, Statistic, TauGrid};
        let y = crate::sim::rng::Rng::new(seed).gauss_vec(100_000);
        compute(
            &y,
            100.0,
            &TauGrid::Octave,
            Statistic::Oadev,
            Confidence::OneSigma,
        )
        .unwrap()
    }

    /// `f` as an Allan fit that used the curve from τ = 0.01 s on (one point there).
    fn fitted_from_the_start(mut f: NoiseFit) -> NoiseFit {
        f.points = vec![crate::model::FitPoint {
            x: 0.01,
            value: 1.0,
            model: 1.0,
            edf: 1.0,
            z: 0.0,
        }];
        f
    }

    /// B kept by the Allan fit (its home), bounded a little below its interval by the spectrum:
    /// the Allan interval stands. Kept by the spectrum and bounded so by the Allan fit, it may
    /// not be there at all: the interval starts at 0. Bounded far below (beyond both fits'
    /// scatter), the Allan fit's too, with a warning.
    #[test]
    fn a_bound_from_outside_the_home_within_its_scatter_leaves_the_home_interval() {
        let b = Term::BiasInstability;
        let kept = est(b, 2.85, 0.07);
        let a = fit(Domain::Allan, vec![kept], vec![]);
        let s = fit(Domain::Spectrum, vec![], vec![(b, 2.55)]);
        let c = combine(Some(&a), Some(&s), None);
        let got = c.get(b).unwrap();
        assert!(!got.hull && got.lo == kept.lo, "{got:?}");
        assert!(c.warnings.is_empty());
        let a = fit(Domain::Allan, vec![], vec![(b, 2.55)]);
        let s = fit(Domain::Spectrum, vec![kept], vec![]);
        let got = *combine(Some(&a), Some(&s), None).get(b).unwrap();
        assert!(got.hull && got.lo == 0.0, "{got:?}");
        let a = fit(Domain::Allan, vec![kept], vec![]);
        let s = fit(Domain::Spectrum, vec![], vec![(b, 0.3)]);
        let c = combine(Some(&a), Some(&s), None);
        assert!(c.get(b).unwrap().hull && c.get(b).unwrap().lo == 0.0);
        assert!(matches!(c.warnings[0], FitWarning::DomainsDisagree { .. }));
    }

    /// The measured Allan variance caps an upper end: white noise (N = 0.1 at 100 Hz) read
    /// with a K whose interval reaches 1e3 gets K's upper end cut to what the curve allows, which
    /// still holds K = 0's neighbourhood and N's truth is never cut.
    #[test]
    fn the_allan_curve_caps_an_upper_end() {
        let mut below = 0;
        for seed in 0..40 {
            let dev = white_oadev(9_100 + seed);
            let bounds = allan_bounds(&dev, 0.95, 0.01);
            let n_cap = allan_cap(&bounds, Term::RandomWalk).unwrap().0;
            below += usize::from(n_cap < 0.1);
            assert!(n_cap < 0.2, "seed {seed}: {n_cap}");
            let k_cap = allan_cap(&bounds, Term::RateRandomWalk).unwrap().0;
            assert!(k_cap.is_finite() && k_cap < 1.0, "seed {seed}: {k_cap}");
            assert!(allan_cap(&bounds, Term::RateRamp).is_none());
            // A combined K with a wild upper end is cut to the cap, keeping its value.
            let mut k = est(Term::RateRandomWalk, 1e-3, 0.5);
            k.hi = 1e3;
            let a = fitted_from_the_start(fit(
                Domain::Allan,
                vec![est(Term::RandomWalk, 0.1, 0.01), k],
                vec![],
            ));
            let c = combine(Some(&a), None, Some(&dev));
            let got = c.get(Term::RateRandomWalk).unwrap();
            let (k_cap_99, _) = allan_cap(
                &allan_bounds(&dev, BEYOND_CURVE_P, 0.01),
                Term::RateRandomWalk,
            )
            .unwrap();
            assert!(k_cap_99 > k_cap && k_cap_99 < 1.0, "{k_cap_99} {k_cap}");
            assert!(
                got.hi <= k_cap_99.max(got.value) && got.hi >= got.value,
                "{got:?}"
            );
        }
        // The bound holds the truth (one-sided, at least 97.5 % each): at most 2 of 40 below.
        assert!(below <= 2, "{below} of 40 caps below N");
    }

    /// What the measured Allan curve rules out (white noise, N = 0.1 at 100 Hz): K kept by both
    /// fits, neither telling it from B, comes from its home (the Allan fit) however the
    /// intervals' relative widths compare; an N the curve rules out yields to the one it allows
    /// even where it is the more precise; a term kept ambiguously by one fit beyond the curve
    /// has no answer; and an upper limit is cut to the curve's.
    #[test]
    fn the_allan_curve_rules_estimates_out() {
        let dev = white_oadev(9_300);
        let ambiguous = |mut e: TermEstimate| {
            (e.lo, e.one_sigma.0) = (0.0, 0.0);
            e.ambiguous_with = Some(Term::BiasInstability);
            e
        };
        let k = Term::RateRandomWalk;
        let a = fitted_from_the_start(fit(
            Domain::Allan,
            vec![
                est(Term::RandomWalk, 0.1, 0.01),
                ambiguous(est(k, 1e-4, 1.0)),
            ],
            vec![(Term::BiasInstability, 1e3)],
        ));
        let s = fit(
            Domain::Spectrum,
            vec![
                est(Term::RandomWalk, 3.0, 0.001),
                ambiguous(est(k, 0.5, 0.6)),
            ],
            vec![],
        );
        // Without the curve, N is the more precise spectrum's (the hull of both)...
        let blind = combine(Some(&a), Some(&s), None);
        assert_eq!(
            blind.get(Term::RandomWalk).unwrap().source,
            Domain::Spectrum
        );
        // ... with it, the Allan fit's, as K (the spectrum's relative interval is the narrower).
        let c = combine(Some(&a), Some(&s), Some(&dev));
        let n = c.get(Term::RandomWalk).unwrap();
        assert_eq!((n.source, n.value), (Domain::Allan, 0.1), "{n:?}");
        let got = c.get(k).unwrap();
        assert_eq!((got.source, got.value), (Domain::Allan, 1e-4), "{got:?}");
        assert!(
            !c.warnings
                .iter()
                .any(|w| matches!(w, FitWarning::BeyondAllanCurve { .. })),
            "{:?}",
            c.warnings
        );
        let (b_cap, _) = allan_cap(
            &allan_bounds(&dev, BEYOND_CURVE_P, 0.01),
            Term::BiasInstability,
        )
        .unwrap();
        assert_eq!(c.limit(Term::BiasInstability), Some(b_cap));
        assert!(b_cap < 1.0, "{b_cap}");
        // The Allan fit alone with K ambiguous beyond the curve: no answer, a limit instead.
        let a = fitted_from_the_start(fit(
            Domain::Allan,
            vec![
                est(Term::RandomWalk, 0.1, 0.01),
                ambiguous(est(k, 0.5, 0.6)),
            ],
            vec![],
        ));
        let c = combine(Some(&a), None, Some(&dev));
        assert!(c.get(k).is_none(), "{:?}", c.get(k));
        let limit = c.limit(k).unwrap();
        assert!(limit < 0.5, "{limit}");
        // Kept clearly by the spectrum alone beyond it, the Allan fit leaving K out: no answer
        // either (the fit that sees the curve did not keep it), a limit from the Allan fit, and
        // the warning that names the reading refused.
        let a = fitted_from_the_start(fit(
            Domain::Allan,
            vec![est(Term::RandomWalk, 0.1, 0.01)],
            vec![(k, 1e-3)],
        ));
        let s = fit(
            Domain::Spectrum,
            vec![est(Term::RandomWalk, 0.1, 0.01), est(k, 0.5, 0.2)],
            vec![],
        );
        let c = combine(Some(&a), Some(&s), Some(&dev));
        assert!(c.get(k).is_none(), "{:?}", c.get(k));
        assert_eq!(c.limit(k), Some(1e-3));
        assert!(c.warnings.iter().any(
            |w| matches!(w, FitWarning::BeyondAllanCurve { term, fitted, .. } if *term == k && *fitted == 0.5)
        ));
        // Kept clearly beyond it by the Allan fit alone: kept, with a warning.
        let a = fitted_from_the_start(fit(
            Domain::Allan,
            vec![est(Term::RandomWalk, 0.1, 0.01), est(k, 0.5, 0.6)],
            vec![],
        ));
        let c = combine(Some(&a), None, Some(&dev));
        assert_eq!(c.get(k).unwrap().value, 0.5);
        assert!(c
            .warnings
            .iter()
            .any(|w| matches!(w, FitWarning::BeyondAllanCurve { term, .. } if *term == k)));
    }

    /// A neighbour whose interval reaches 0 does not pull the term to its fit: N comes from the
    /// more precise spectrum beside an Allan fit that kept a Q of [0, …]; with that Q's interval
    /// off 0 it would come from the Allan fit.
    #[test]
    fn a_neighbour_down_to_zero_is_not_found() {
        let mut q = est(Term::Quantization, 0.15, 0.5);
        (q.lo, q.one_sigma.0) = (0.0, 0.0);
        let a = fit(
            Domain::Allan,
            vec![q, est(Term::RandomWalk, 0.229, 0.025)],
            vec![],
        );
        let s = fit(
            Domain::Spectrum,
            vec![est(Term::RandomWalk, 0.235, 0.005)],
            vec![(Term::Quantization, 0.13)],
        );
        let c = combine(Some(&a), Some(&s), None);
        let n = c.get(Term::RandomWalk).unwrap();
        assert_eq!(n.source, Domain::Spectrum, "{n:?}");
        let a = fit(
            Domain::Allan,
            vec![
                est(Term::Quantization, 0.15, 0.5),
                est(Term::RandomWalk, 0.229, 0.025),
            ],
            vec![],
        );
        let c = combine(Some(&a), Some(&s), None);
        assert_eq!(c.get(Term::RandomWalk).unwrap().source, Domain::Allan);
    }

    /// The choices are made on the 1σ intervals whatever the intervals' confidence: a Q whose
    /// 95 % interval reaches 0 and whose 1σ interval does not is found (N from the Allan fit that
    /// kept it), and two N readings whose 1σ intervals miss each other disagree (the value from
    /// the more precise fit, the hull as interval) though their 95 % intervals overlap. Before,
    /// the 95 % intervals decided both, and the combined N changed with the level.
    #[test]
    fn the_choices_do_not_depend_on_the_intervals_level() {
        let at_95 = |mut e: TermEstimate, lo: f64, hi: f64| {
            (e.lo, e.hi) = (lo, hi);
            e
        };
        let q = at_95(est(Term::Quantization, 0.15, 0.5), 0.0, 0.3);
        let n_allan = at_95(est(Term::RandomWalk, 0.229, 0.025), 0.22, 0.24);
        let mut a = fit(Domain::Allan, vec![q, n_allan], vec![]);
        let n_spectrum = at_95(est(Term::RandomWalk, 0.235, 0.005), 0.2326, 0.2374);
        let mut s = fit(
            Domain::Spectrum,
            vec![n_spectrum],
            vec![(Term::Quantization, 0.13)],
        );
        for f in [&mut a, &mut s] {
            f.confidence = 0.95;
        }
        let c = combine(Some(&a), Some(&s), None);
        let n = c.get(Term::RandomWalk).unwrap();
        assert_eq!((n.source, n.value), (Domain::Allan, 0.229), "{n:?}");
        assert!(!n.hull, "{n:?}");
        // 1σ: [0.223, 0.235] and [0.2397, 0.2503]; 95 %: [0.21, 0.25] and [0.238, 0.252].
        let n_spectrum = at_95(est(Term::RandomWalk, 0.245, 0.02), 0.238, 0.252);
        s.estimates = vec![n_spectrum];
        let c = combine(Some(&a), Some(&s), None);
        let n = c.get(Term::RandomWalk).unwrap();
        assert!(n.hull && (n.lo, n.hi) == (0.22, 0.252), "{n:?}");
        assert_eq!(n.one_sigma, (0.229 * 0.975, 0.245 * 1.02), "{n:?}");
    }

    /// K's bound comes from the Allan fit whichever fit kept it: a spectrum that kept K
    /// ambiguously (its lowest bands trading it for B) with a wide interval does not loosen it;
    /// without an Allan fit the spectrum's bound stands. Q and N take the larger of the two; the
    /// spectrum never bounds R.
    #[test]
    fn an_upper_limit_comes_from_the_terms_home_fit() {
        let k = Term::RateRandomWalk;
        let allan = fit(Domain::Allan, vec![], vec![(k, 2.0)]);
        let mut wide = est(k, 5.0, 0.9);
        wide.ambiguous_with = Some(Term::BiasInstability);
        let spectrum = fit(Domain::Spectrum, vec![wide], vec![(Term::RateRamp, 1.0)]);
        assert_eq!(upper_limit(Some(&allan), Some(&spectrum), k), Some(2.0));
        assert_eq!(upper_limit(None, Some(&spectrum), k), Some(9.5));
        assert_eq!(
            upper_limit(Some(&allan), Some(&spectrum), Term::RateRamp),
            None
        );
        let q = Term::Quantization;
        let a = fit(Domain::Allan, vec![], vec![(q, 3.0)]);
        let s = fit(Domain::Spectrum, vec![], vec![(q, 1.0)]);
        assert_eq!(upper_limit(Some(&a), Some(&s), q), Some(3.0));
    }

    /// A 1σ upper limit at 0.75 of an estimate known to ±8 % (in log) lies beyond that estimate's
    /// 99.9 % lower end, but the limit is itself that loose: no disagreement. At 0.3 of an
    /// estimate known to ±5 %, both ways of reading the limit say so; at 0.9, neither.
    #[test]
    fn a_bound_disagrees_only_beyond_both_fits_scatter() {
        let one = crate::avar::ONE_SIGMA;
        assert!(
            0.75 < (-DISAGREE_Z * 0.08f64).exp(),
            "beyond the estimate's own errors"
        );
        assert!(!beyond_bound(1.0, 0.08, 0.75, one));
        assert!(beyond_bound(1.0, 0.05, 0.3, one));
        assert!(!beyond_bound(1.0, 0.05, 0.9, one));
        // At 2σ limits the same u² holds half the scatter: 0.55 of the estimate now disagrees.
        assert!(!beyond_bound(1.0, 0.05, 0.55, one));
        assert!(beyond_bound(1.0, 0.05, 0.55, 0.954_499_736));
    }

    #[test]
    fn the_more_precise_estimate_wins_and_a_small_miss_widens_without_a_warning() {
        let a = fit(
            Domain::Allan,
            vec![est(Term::RandomWalk, 1.00, 0.02)],
            vec![],
        );
        let s = fit(
            Domain::Spectrum,
            vec![est(Term::RandomWalk, 1.03, 0.005)],
            vec![],
        );
        let c = combine(Some(&a), Some(&s), None);
        let n = c.get(Term::RandomWalk).unwrap();
        assert_eq!(n.source, Domain::Spectrum);
        assert_eq!(n.value, 1.03);
        // 1σ intervals miss (1.02 < 1.02485) but the difference is 1.4σ: hull, no warning.
        assert!(n.hull && n.lo == 0.98 && c.warnings.is_empty(), "{c:?}");
    }

    /// Spikes in groups of three or more, each within 0.5 s of the next, are bursts (in a record
    /// long enough that random spikes would rarely link so); where they hold most of the spikes
    /// the sentence names transients, otherwise heavy-tailed noise.
    #[test]
    fn spikes_in_bursts_are_named_transients() {
        // Two rings (4 and 3 samples), a pair too small to count, and two lone spikes.
        let times = [
            10.0, 10.1, 10.3, 10.7, 50.0, 50.2, 50.4, 80.0, 80.3, 120.0, 200.0,
        ];
        assert_eq!(spike_bursts(&times, 7200.0), (2, 7, 0.5));
        // The same times in a record of 20 s: a twentieth of their spacing, 0.09 s, links none.
        assert_eq!(spike_bursts(&times, 20.0).0, 0);
        let warning = |bursts, in_bursts| FitWarning::HeavyTail {
            spikes: times.len(),
            shoulder: 40,
            shoulder_gaussian: 3.2,
            n: 1e-3,
            n_with: 1.1e-3,
            bursts,
            in_bursts,
            burst_gap_s: 0.5,
        };
        let line = heavy_tail_line(&warning(2, 7), |x| format!("{x:.1e}"), "u");
        assert!(line.contains("7 of them come in 2 bursts"), "{line}");
        assert!(line.contains("knock or a footstep"), "{line}");
        let lone = heavy_tail_line(&warning(1, 3), |x| format!("{x:.1e}"), "u");
        assert!(lone.contains("heavy-tailed noise, or glitches"), "{lone}");
        assert_eq!(spike_bursts(&[1.0, 2.0, 3.0], 7200.0), (0, 0, 0.5));
    }

    #[test]
    fn a_significant_miss_is_named_and_b_comes_from_the_allan_fit() {
        let a = fit(
            Domain::Allan,
            vec![est(Term::BiasInstability, 1.0, 0.05)],
            vec![],
        );
        let s = fit(
            Domain::Spectrum,
            vec![est(Term::BiasInstability, 1.5, 0.02)],
            vec![],
        );
        let c = combine(Some(&a), Some(&s), None);
        let b = c.get(Term::BiasInstability).unwrap();
        assert_eq!((b.source, b.value), (Domain::Allan, 1.0));
        assert!(b.hull && (b.hi - 1.53).abs() < 1e-12);
        assert!(matches!(
            c.warnings.as_slice(),
            [FitWarning::DomainsDisagree {
                term: Term::BiasInstability,
                ..
            }]
        ));
    }

    #[test]
    fn a_fit_missing_a_neighbour_yields_and_an_ambiguous_term_has_no_answer() {
        // The spectrum kept B without K, the Allan fit both: B from the Allan fit although the
        // spectrum's interval is narrower.
        let a = fit(
            Domain::Allan,
            vec![
                est(Term::BiasInstability, 1.0, 0.1),
                est(Term::RateRandomWalk, 2.0, 0.2),
            ],
            vec![],
        );
        let mut k = est(Term::RateRandomWalk, 50.0, 0.1);
        k.ambiguous_with = Some(Term::BiasInstability);
        let s = fit(
            Domain::Spectrum,
            vec![est(Term::BiasInstability, 1.05, 0.02)],
            vec![],
        );
        let c = combine(Some(&a), Some(&s), None);
        assert_eq!(c.get(Term::BiasInstability).unwrap().source, Domain::Allan);
        // A K only the spectrum kept, ambiguous with B, bounded far lower by the Allan fit.
        let a = fit(
            Domain::Allan,
            vec![est(Term::BiasInstability, 1.0, 0.1)],
            vec![(Term::RateRandomWalk, 3.0)],
        );
        let s = fit(Domain::Spectrum, vec![k], vec![]);
        let c = combine(Some(&a), Some(&s), None);
        assert!(c.get(Term::RateRandomWalk).is_none(), "{c:?}");
        assert!(c.warnings.is_empty());
        // The same with its interval down to 0 (the model with B in its place weighs more than
        // the lower tail): still no answer, the bound lies below the value.
        (k.lo, k.one_sigma.0) = (0.0, 0.0);
        let s = fit(Domain::Spectrum, vec![k], vec![]);
        let c = combine(Some(&a), Some(&s), None);
        assert!(c.get(Term::RateRandomWalk).is_none(), "{c:?}");
        // A bound above the value does not contradict it: kept, with its interval and flag.
        let a = fit(
            Domain::Allan,
            vec![est(Term::BiasInstability, 1.0, 0.1)],
            vec![(Term::RateRandomWalk, 80.0)],
        );
        let c = combine(Some(&a), Some(&s), None);
        let kept = c.get(Term::RateRandomWalk).expect("kept");
        assert_eq!((kept.value, kept.lo), (50.0, 0.0));
        assert_eq!(kept.ambiguous_with, Some(Term::BiasInstability));
    }
}
