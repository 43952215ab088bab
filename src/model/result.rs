//! What a fit reports: the terms it kept with their intervals, limits on the others, goodness of
//! fit and every candidate model it weighed.

use serde::Serialize;

use super::{Coefficients, Term};

/// Which estimate a fit was made on.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Domain {
    /// Allan variance σ²(τ).
    Allan,
    /// Log-binned Welch spectrum.
    Spectrum,
}

/// Information criterion that decides which terms enter.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Criterion {
    /// Bayesian (Schwarz): −2 ln L + k·ln n. The default, because the question is which physical
    /// terms are present, not which model predicts best: BIC is consistent (it picks the true set
    /// of terms with probability → 1 as the data grow), and its penalty of ≈ 2.8–3.7 per term for
    /// 16–40 points admits an absent term (which can only enter positive) with probability
    /// ½·P(χ²₁ > ln n) ≈ 2.5–5 %, against ≈ 8 % for AIC's 2.
    #[default]
    Bic,
    /// Akaike, small-sample corrected: −2 ln L + 2k + 2k(k+1)/(n − k − 1). Better prediction, more
    /// false terms.
    Aicc,
}

impl Criterion {
    /// Score of a model with −2·log-likelihood `neg2ll`, `k` terms, on `n` points (lower is
    /// better); infinite when the model has too many terms for the points.
    pub fn score(self, neg2ll: f64, k: usize, n: usize) -> f64 {
        let (kf, nf) = (k as f64, n as f64);
        match self {
            Criterion::Bic if k <= n => neg2ll + kf * nf.ln(),
            Criterion::Aicc if k + 1 < n => {
                neg2ll + 2.0 * kf + 2.0 * kf * (kf + 1.0) / (nf - kf - 1.0)
            }
            _ => f64::INFINITY,
        }
    }
}

/// One coefficient the fit kept, SI units (see [`Coefficients`]).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct TermEstimate {
    pub term: Term,
    pub value: f64,
    /// Confidence interval of the coefficient at [`NoiseFit::confidence`].
    pub lo: f64,
    pub hi: f64,
    /// Satterthwaite degrees of freedom of the squared coefficient (2ĉ²/Var ĉ).
    pub edf: f64,
    /// The same interval at 1σ whatever the run's confidence: what the decisions test (whether
    /// the term is found, whether two fits agree, which fit gives the combined value), so that
    /// `--confidence` widens the printed intervals and moves no value. Before, it moved them:
    /// on 546 simulated channels 95 % instead of 1σ changed the combined N of 108 by more than
    /// 0.1 % (at most 5.6 %), an Allan fit's Q interval reaching 0 at 95 % and not at 1σ turning
    /// the choice of the fit N came from. Not in the report: `lo`, `hi` are the interval.
    #[serde(skip)]
    pub one_sigma: (f64, f64),
    /// A neighbouring term (adjacent slope) that the data could not tell from this one: the model
    /// with that term in this one's place scored within [`crate::model::AMBIGUITY_BIC`] of the
    /// chosen one. The value is then not determined by this fit (a spectrum whose lowest band lies
    /// above K's regime trades B for K).
    pub ambiguous_with: Option<Term>,
    /// Share of the weight that the term subsets averaged into this estimate put at 0 (those
    /// that lack the term; [`crate::model::SELECTION_WINDOW`]): the point at 0 of the mixture its
    /// interval is a quantile range of, which averaging with a rival model must carry over
    /// (`model::average`). Not in the report: the interval already says what it does.
    #[serde(skip)]
    pub zero_share: f64,
}

/// The smallest interval holding both `a` and `b` (each (lo, hi)).
pub fn hull(a: (f64, f64), b: (f64, f64)) -> (f64, f64) {
    (a.0.min(b.0), a.1.max(b.1))
}

impl TermEstimate {
    /// Whether `v` lies in the interval.
    pub fn covers(&self, v: f64) -> bool {
        self.lo <= v && v <= self.hi
    }
}

/// The fitted amplitude (√ of the power per unit shape) of an added effect.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct EffectEstimate {
    pub value: f64,
    pub lo: f64,
    pub hi: f64,
    pub edf: f64,
}

/// An absent term and the largest coefficient compatible with the data: the upper end of the
/// interval the term would have had if forced in (0 if even that fit gives it nothing).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct UpperLimit {
    pub term: Term,
    pub upper: f64,
    /// The bound with every kept term beside it (≤ `upper`, which also weighs the term in the
    /// place of a kept neighbour the fit could not tell from it): what a noise model that already
    /// holds the kept terms may add of this one, for the regressions that build such a model
    /// ([`crate::effects::ramp::ramp_free_coefficients`]), which would otherwise count the traded
    /// power twice. At 1σ whatever the run's confidence, as [`UpperLimit::one_sigma`]: a model
    /// built for a decision must not change with the intervals' level.
    #[serde(skip)]
    pub beside_kept: f64,
    /// `upper` at 1σ whatever the run's confidence, for the decisions that weigh a bound against
    /// an estimate (see [`TermEstimate::one_sigma`]).
    #[serde(skip)]
    pub one_sigma: f64,
}

/// A subset of terms the criterion weighed.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Candidate {
    pub terms: Vec<Term>,
    /// χ² of its normalised residuals (see [`FitPoint::z`]).
    pub chi2: f64,
    /// −2·log-likelihood plus the criterion's penalty; lower is better.
    pub score: f64,
    /// False when the non-negative fit set one of the subset's coefficients to zero: the subset
    /// then duplicates a smaller one and is not eligible.
    pub proper: bool,
}

/// How well the final model fits, and what that did to the intervals.
///
/// The intervals of every coefficient (and the upper limits of absent terms) are computed from
/// the inverse Fisher information scaled by the dispersion max(1, χ²/dof) (quasi-likelihood): a
/// model the data reject by χ²/dof = 100 gets intervals 10× wider than the Fisher ones, not the
/// ±0.1 % an exact model would earn. The inflation is applied whatever the p-value (under a right
/// model it is ≈ 1); `significant` marks a misfit the report warns about.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct LackOfFit {
    pub chi2_per_dof: f64,
    /// P(χ²_dof ≥ χ²) under the model.
    pub p_value: f64,
    /// Factor the intervals were widened by, √max(1, χ²/dof).
    pub inflation: f64,
    /// p-value below [`crate::model::LACK_OF_FIT_P`]: the model does not describe the data.
    pub significant: bool,
    /// τ (s) or frequency (Hz) range of the contiguous run of points that carries the largest
    /// excess Σ(z² − 1): where the misfit lives.
    pub worst_from: f64,
    pub worst_to: f64,
    /// Share of Σz² in that run.
    pub worst_share: f64,
}

/// One point the fit used.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct FitPoint {
    /// τ (s) or frequency (Hz).
    pub x: f64,
    /// Measured AV (unit²) or two-sided PSD (unit²/Hz).
    pub value: f64,
    /// Model value.
    pub model: f64,
    /// Degrees of freedom of the measurement under the model (value·ν/model ~ χ²_ν).
    pub edf: f64,
    /// Normalised residual on the Wilson–Hilferty scale,
    /// ((value/model)^(1/3) − 1 + 2/(9ν))/√(2/(9ν)): standard normal when the model is right, even
    /// for the few-EDF points at long τ where (value − model)/σ is far from it.
    pub z: f64,
}

/// A fit of the IEEE model in one domain.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct NoiseFit {
    pub domain: Domain,
    /// Terms kept, in [`Term::ALL`] order.
    pub estimates: Vec<TermEstimate>,
    /// Terms that were allowed but not kept.
    pub upper_limits: Vec<UpperLimit>,
    /// χ² of the normalised residuals of the final fit, zᵀR⁻¹z with R the working correlation
    /// between points (identity for spectra).
    pub chi2: f64,
    /// Points − fitted columns (kept terms and the effect).
    pub dof: usize,
    /// The χ² test of this model and the widening of its intervals.
    pub lack_of_fit: LackOfFit,
    /// The power of the effect the fit was asked to include ([`crate::model::EffectShape`]), as
    /// an amplitude (√power) with its interval; `None` for the base model.
    pub effect: Option<EffectEstimate>,
    pub criterion: Criterion,
    pub confidence: f64,
    /// Every subset weighed, best score first.
    pub candidates: Vec<Candidate>,
    pub points: Vec<FitPoint>,
}

impl NoiseFit {
    /// The estimate of `term`, if kept.
    pub fn get(&self, term: Term) -> Option<&TermEstimate> {
        self.estimates.iter().find(|e| e.term == term)
    }

    /// χ²/dof: ≈ 1 when the model explains the data to within their scatter.
    pub fn chi2_per_dof(&self) -> f64 {
        self.chi2 / self.dof.max(1) as f64
    }

    /// The kept coefficients (absent ones 0).
    pub fn coefficients(&self) -> Coefficients {
        let mut c = Coefficients::default();
        for e in &self.estimates {
            c.set(e.term, e.value);
        }
        c
    }
}

impl std::str::FromStr for Criterion {
    type Err = String;

    fn from_str(s: &str) -> Result<Criterion, String> {
        match s.trim().to_ascii_lowercase().as_str() {
            "bic" => Ok(Criterion::Bic),
            "aicc" => Ok(Criterion::Aicc),
            _ => Err(format!("unknown criterion {s:?}: expected bic or aicc")),
        }
    }
}

/// A fit with the given estimates and upper limits and a model that fits (χ²/dof 1), for the unit
/// tests of what is built on fits (combination, averaging).
#[cfg(test)]
pub(crate) fn fit_for_tests(
    domain: Domain,
    estimates: Vec<TermEstimate>,
    upper: Vec<(Term, f64)>,
) -> NoiseFit {
    NoiseFit {
        domain,
        estimates,
        upper_limits: upper
            .into_iter()
            .map(|(term, upper)| UpperLimit {
                term,
                upper,
                beside_kept: upper,
                one_sigma: upper,
            })
            .collect(),
        chi2: 10.0,
        dof: 10,
        lack_of_fit: LackOfFit {
            chi2_per_dof: 1.0,
            p_value: 0.5,
            inflation: 1.0,
            significant: false,
            worst_from: 1.0,
            worst_to: 1.0,
            worst_share: 0.1,
        },
        effect: None,
        criterion: Criterion::Bic,
        confidence: crate::avar::ONE_SIGMA,
        candidates: Vec::new(),
        points: Vec::new(),
    }
}
