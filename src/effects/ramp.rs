//! Whether a rate ramp R is determined by the time series, not only by the Allan curve.
//!
//! **Why.** In the Allan domain a ramp is the rise σ² = R²τ²/2 of the longest τ, which a few
//! averages carry; one realisation of a rate random walk K wanders off in one direction and
//! makes that rise too. The Allan fit's Fisher interval of R counts only the χ² scatter of those
//! points, not the random walk's: measured on 1800-s records (N 0.15 °/√h, B 3 °/h,
//! K 20 °/h/√h, 100 Hz, `examples/ramp_check.rs`), the base Allan fit kept a ramp in 8 of 300
//! records without one, with intervals that excluded 0, and where a ramp of 400 °/h/h was planted
//! its 1σ interval covered it in 14 of 60 (ratios 0.84–1.23, the interval ±2.4 % at the median, ±1.3–6.7 %).
//!
//! **The test.** A ramp of R moves the block means of the series by R·(block length) per block,
//! so it is the mean of their increments, which every other IEEE noise keeps at zero. Under the
//! fitted noise model without the ramp (K in its place: the model the ramp competes with, with
//! left-out terms at their upper limits, as the slow effects' regressions use it) the increments'
//! covariance is known ([`super::regression`]), and the generalised-least-squares mean of the
//! whitened increments is R's best linear estimate with its standard error (the model's level
//! estimated from the whitened residuals, so Student-t). That error is what the random walk
//! leaves in a ramp over the record, ≈ K/√T.
//!
//! **The rule.** A ramp that the series does not show at the family-wise level of the slow
//! effects ([`super::slow::DETECTION_P`], two-sided) is not determined: the fits are made again
//! without R (K takes its place). A ramp it does show keeps the Allan fit's value, with an
//! interval no narrower than the series' (the hull of both).

use serde::Serialize;

use crate::model::{hull, Coefficients, FitOptions, NoiseFit, Term};

use super::regression::{IncrementModel, MAX_INCREMENTS};
use super::slow::DETECTION_P;

/// The time series' evidence on a rate ramp.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct RampTest {
    /// The ramp (rate units per second) and its standard error.
    pub ramp: f64,
    pub se: f64,
    /// ramp / se, Student-t with `dof` degrees of freedom, and its two-sided p-value.
    pub t: f64,
    pub dof: f64,
    pub p: f64,
}

impl RampTest {
    /// Whether the series determines a ramp ([`DETECTION_P`]).
    pub fn determined(&self) -> bool {
        self.p < DETECTION_P
    }
}

/// Which series a ramp's test was asked of.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum TestedSeries {
    /// The recorded samples, before the residual loop (the base fits).
    Recorded,
    /// The series the residual loop corrected (steps, excursions, drifts, spikes taken out), at
    /// its end.
    Corrected,
}

/// What the series' test did to the rate ramp.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum RampAction {
    /// A fit kept R and the series determines it: kept, its interval widened to the series'.
    Kept,
    /// A fit kept R and the series does not determine it: every fit made again without R.
    Dropped,
    /// No fit kept R (the Allan curve could not tell it from a random walk) and the corrected
    /// series determines it: R required in the Allan fit ([`FitOptions::required`]).
    Added,
    /// No fit kept R and the corrected series shows some ramp (p below [`HINT_P`]) but does not
    /// determine one beside the random walk at the upper end of K's interval: nothing changed,
    /// reported so that a rise the model reads as K is not silent (a 4-h FOG record with 0.1
    /// °/h² planted read "K 0.029 °/h/√h (not told from R)" and nothing more).
    NotAdded,
}

/// p-value of the series' ramp test below which a ramp not added is still reported
/// ([`RampAction::NotAdded`]).
pub const HINT_P: f64 = 0.01;

/// One decision on the rate ramp, for the report.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct RampDecision {
    pub series: TestedSeries,
    pub action: RampAction,
    /// The test that decided, under the model without R (K in its place).
    pub test: RampTest,
    /// Where R is kept or added: the series' estimate under the model with R, whose ± SE R's
    /// interval covers ([`widen_ramp`]).
    pub estimate: Option<RampTest>,
}

impl RampDecision {
    /// R in the final model: the series' estimate its interval must cover.
    pub fn widening(&self) -> Option<&RampTest> {
        self.estimate.as_ref()
    }
}

/// The ramp of `y` (at `fs`) under the noise of `model` without its ramp.
pub fn test_ramp(y: &[f64], fs: f64, model: &NoiseFit) -> Option<RampTest> {
    test_ramp_beside(y, fs, &ramp_free_density(model, fs), None)
}

/// The noise a ramp that no fit kept is weighed against: [`ramp_free_coefficients`] with K at
/// the upper end of its one-sigma interval. Where a fit kept R, the test's model is the refit
/// without it, whose K took up the ramp's rise: K errs high, and 0 of the 8 clean records of 300
/// whose Allan fit kept R were read as ramps. Asked of every channel whose fits left R out (the
/// residual loop's last check), K is the Allan fit's reading of the wander the test must not
/// take for a ramp, and where it read low the wander looked significant: at K's estimate a ramp
/// was added to 4 of 300 clean 30-min records, |t| 3.4–5.7 where K read 0.47–0.75× the truth.
pub fn ramp_null_coefficients(fit: &NoiseFit) -> Coefficients {
    let mut c = ramp_free_coefficients(fit);
    if let Some(k) = fit.get(Term::RateRandomWalk) {
        c.set(Term::RateRandomWalk, k.one_sigma.1);
    }
    c
}

/// The ramp of `y` (at `fs`) under the one-sided noise `density` (without a ramp; for a model
/// with more than the IEEE terms, such as the residual loop's Gauss–Markov process), with the
/// increments of `beside` (a series of the same length, such as a temperature) fitted beside it:
/// the ramp that is left once a regressor rising with it had its share
/// ([`IncrementModel::mean_increment_beside`]; `None` where the two cannot be told apart).
pub fn test_ramp_beside(
    y: &[f64],
    fs: f64,
    density: &dyn Fn(f64) -> f64,
    beside: Option<&[f64]>,
) -> Option<RampTest> {
    let (increments, u) = IncrementModel::for_series(density, fs, y, MAX_INCREMENTS)?;
    let gls = match beside {
        Some(x) if x.len() == y.len() => {
            increments.mean_increment_beside(&u, &increments.increments(x))?
        }
        Some(_) => return None,
        None => increments.mean_increment(&u)?,
    };
    let per_block = increments.block as f64 / fs;
    Some(RampTest {
        ramp: gls.beta / per_block,
        se: gls.se / per_block,
        t: gls.t,
        dof: gls.dof,
        p: gls.p,
    })
}

/// The one-sided noise density of `fit`'s model for regressions on the series: without the rate
/// ramp (a ramp's increments are a constant, which their intercept absorbs), and with the terms
/// the criterion left out at their upper limits. A term too weak to be admitted is not absent,
/// and slow noise missing from the covariance would make a slow regressor (or a ramp) look
/// significant: the regressions err on the side of too much noise.
pub fn ramp_free_density(fit: &NoiseFit, fs: f64) -> impl Fn(f64) -> f64 {
    let c = ramp_free_coefficients(fit);
    move |f| 2.0 * c.psd_sampled(f, fs)
}

/// `fit`'s coefficients as [`ramp_free_density`] takes them: the kept terms and the left-out ones
/// at their upper limits beside the kept ones ([`crate::model::UpperLimit::beside_kept`]), R at 0.
/// The reported limit, which may weigh a left-out term in a kept neighbour's place, counted the
/// power the two trade twice and hid a 200 °/h/h ramp the series showed plainly.
pub fn ramp_free_coefficients(fit: &NoiseFit) -> Coefficients {
    let mut c = fit.coefficients();
    for u in fit
        .upper_limits
        .iter()
        .filter(|u| u.beside_kept.is_finite())
    {
        c.set(u.term, u.beside_kept);
    }
    c.set(Term::RateRamp, 0.0);
    c
}

/// `opts` without the rate ramp.
pub fn without_ramp(opts: &FitOptions) -> FitOptions {
    let mut out = opts.clone();
    out.terms.retain(|&t| t != Term::RateRamp);
    out
}

/// Widens R's interval in `fit` to cover the series' interval at the fit's confidence.
///
/// Where the fit barely determines R beside K (its interval more than [`FIT_WIDER`] times the
/// series'), or its value lies outside the series' interval, the series' estimate |R̂| and its
/// interval are R's: the series measures the ramp directly. A clean 1-h record whose loop added a
/// ramp (series: −13.5 ± 1.2 °/h²) had the Allan fit's R printed as 5.849 [5.849, 2.2·10⁷]
/// °/h² beside it.
pub fn widen_ramp(fit: &mut NoiseFit, test: &RampTest) {
    let z = crate::stats::norm_isf((1.0 - fit.confidence) / 2.0);
    let r = test.ramp.abs();
    let (lo, hi) = ((r - z * test.se).max(0.0), r + z * test.se);
    let one_sigma = ((r - test.se).max(0.0), r + test.se);
    if let Some(e) = fit.estimates.iter_mut().find(|e| e.term == Term::RateRamp) {
        let undetermined = e.one_sigma.1 - e.one_sigma.0 > FIT_WIDER * (one_sigma.1 - one_sigma.0);
        if undetermined {
            (e.value, e.lo, e.hi, e.one_sigma) = (r, lo, hi, one_sigma);
            return;
        }
        if !(lo..=hi).contains(&e.value) {
            e.value = r;
        }
        (e.lo, e.hi) = hull((e.lo, e.hi), (lo, hi));
        e.one_sigma = hull(e.one_sigma, one_sigma);
    }
}

/// How much wider than the series' interval the fit's interval of R may be before the fit is
/// taken not to determine R (see [`widen_ramp`]).
pub const FIT_WIDER: f64 = 10.0;

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::avar::{compute, Confidence, Deviations, Statistic, TauGrid};
    use crate::model::{fit_avar, CoefUnit, Coefficients};
    use crate::sim::{simulate, SimSpec};

    const FS: f64 = 100.0;

    /// A 30-min gyro record at 100 Hz (N 0.15 °/√h, B 3 °/h, K 20 °/h/√h) with a ramp of
    /// `r_deg_h_h` °/h per hour.
    pub(crate) fn series(seed: u64, r_deg_h_h: f64) -> Vec<f64> {
        let truth = Coefficients {
            n: CoefUnit::DegPerSqrtH.to_si(0.15),
            b: CoefUnit::DegPerH.to_si(3.0),
            k: CoefUnit::DegPerHPerSqrtH.to_si(20.0),
            r: r_deg_h_h.to_radians() / 3600.0 / 3600.0,
            ..Default::default()
        };
        let spec = serde_json::json!({ "rate_hz": FS, "duration_s": 1800.0, "seed": seed,
            "channels": [{ "name": "g", "sensor": "gyro", "noise": truth }] });
        let spec: SimSpec = serde_json::from_value(spec).unwrap();
        simulate(&spec).unwrap().into_columns().0.remove(0)
    }

    /// The overlapping Allan variance of `y` at octave τ, 1σ.
    pub(crate) fn octave_oadev(y: &[f64]) -> Deviations {
        compute(
            y,
            FS,
            &TauGrid::Octave,
            Statistic::Oadev,
            Confidence::OneSigma,
        )
        .unwrap()
    }

    fn no_ramp_fit(y: &[f64]) -> NoiseFit {
        fit_avar(&octave_oadev(y), &without_ramp(&FitOptions::default())).unwrap()
    }

    /// The series' ramp replaces a fit's R that it rules out or that the fit barely determines,
    /// and widens one the fit determines.
    #[test]
    fn the_series_ramp_stands_where_the_fit_does_not_determine_r() {
        let y = series(5, 400.0);
        let mut opts = FitOptions::default();
        opts.required.push(Term::RateRamp);
        let fit = fit_avar(&octave_oadev(&y), &opts).unwrap();
        let r_of = |f: &NoiseFit| {
            let e = f.get(Term::RateRamp).unwrap();
            (e.value, e.lo, e.hi)
        };
        let (v, lo, hi) = r_of(&fit);
        let test = |ramp: f64, se: f64| RampTest {
            ramp,
            se,
            t: ramp / se,
            dof: 500.0,
            p: 1e-9,
        };
        // Barely determined by the fit: the series' interval alone.
        let precise = test(-2.0 * v, (hi - lo) / 100.0);
        let mut f = fit.clone();
        widen_ramp(&mut f, &precise);
        let (v2, lo2, hi2) = r_of(&f);
        assert_eq!(v2, 2.0 * v);
        assert!(
            (hi2 - lo2 - 2.0 * precise.se).abs() < 1e-9 * hi2,
            "{lo2} {hi2}"
        );
        // Determined alike: the hull, the fit's value kept where the series allows it.
        let alike = test(v * 1.01, (hi - lo) / 2.0);
        let mut f = fit.clone();
        widen_ramp(&mut f, &alike);
        let (v3, lo3, hi3) = r_of(&f);
        assert_eq!(v3, v);
        assert!(
            lo3 <= lo && hi3 >= hi && lo3 <= v * 1.01 - alike.se,
            "{lo3} {hi3}"
        );
        // Ruled out by a series as wide as the fit: the series' value, the hull.
        let elsewhere = test(3.0 * v, (hi - lo) / 4.0);
        let mut f = fit.clone();
        widen_ramp(&mut f, &elsewhere);
        let (v4, lo4, hi4) = r_of(&f);
        assert_eq!(v4, 3.0 * v);
        assert!(lo4 <= lo && hi4 >= 3.0 * v + elsewhere.se, "{lo4} {hi4}");
    }

    /// Under N, B and K alone the test's t is Student: over 40 records |t| stays below 3.3
    /// (p 1e-3) in all and below 1 in about two thirds; a planted ramp of 400 °/h/h (R·T eight
    /// times the random walk's K·√T) is found in each of 10 records, its estimate within 3 SE.
    #[test]
    fn ramp_test_keeps_its_level_and_finds_a_ramp() {
        let mut small = 0;
        for seed in 0..40 {
            let y = series(31_000 + seed, 0.0);
            let t = test_ramp(&y, FS, &no_ramp_fit(&y)).unwrap();
            assert!(!t.determined(), "seed {seed}: {t:?}");
            small += usize::from(t.t.abs() < 1.0);
        }
        assert!((20..=35).contains(&small), "|t| < 1 in {small} of 40");
        let r = 400f64.to_radians() / 3600.0 / 3600.0;
        for seed in 0..10 {
            let y = series(32_000 + seed, 400.0);
            let t = test_ramp(&y, FS, &no_ramp_fit(&y)).unwrap();
            assert!(t.determined(), "seed {seed}: {t:?}");
            assert!(
                ((t.ramp - r) / t.se).abs() < 3.0,
                "seed {seed}: {t:?} vs {r}"
            );
        }
    }
}
