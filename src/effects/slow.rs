//! Slow effects regressed under the fitted noise model ([`super::regression`]): a linear coupling
//! to an aux channel (temperature) and a bias drift the IEEE terms do not describe (an
//! exponential settling after switch-on, a curvature of the rate).
//!
//! Both are one regression of the series on a known regressor: the aux channel itself, or a
//! drift shape of the time. A straight ramp is not a drift candidate: the base model's rate ramp
//! R describes it (and the regression's intercept absorbs it). The shapes are exp(−t/τ) at
//! octave-spaced time constants from two blocks of the regression to 4T (T the record length;
//! beyond T it bends the rate like a parabola) and the parabola (t − T/2)². Their p-values are
//! multiplied by the number of shapes tried (Bonferroni; 11 for 512 blocks), and an exponential
//! pays two parameters in the ΔBIC, its amplitude and its time constant. A transient shorter
//! than two blocks looks like a step to this search (and to the step detector).
//!
//! An effect is proposed only when its family-wise p-value is below [`DETECTION_P`]: the BIC
//! penalty ln(M) of one parameter on M = 512 increments alone would admit ≈ 2 % of
//! independent channels, too many for a screen of a six-axis IMU with a temperature sensor.

use rayon::prelude::*;
use serde::Serialize;

use super::regression::{
    regress_series, white_noise_variance, Gls, IncrementModel, Regression, Whitened,
    MAX_INCREMENTS, USEFUL_RELIABILITY,
};
use super::time::stats::{delta_bic, mean_var, norm_isf, t_two_sided};
use super::time::Coupling;

/// Family-wise false-alarm probability of a slow effect (the same as the line search's).
pub const DETECTION_P: f64 = 1e-3;
/// Longest exponential time constant tried, in record lengths.
const EXP_TC_MAX: f64 = 4.0;

/// The shape of a drift.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
#[serde(tag = "shape", rename_all = "snake_case")]
pub enum DriftShape {
    /// amplitude·exp(−t/τ): a settling (amplitude = the part still to settle at the start).
    Exponential { tc_s: f64 },
    /// amplitude·(t − T/2)²: a curvature of the rate (amplitude in units/s²).
    Quadratic,
}

impl DriftShape {
    /// The regressor at time `t` of a record `duration` long.
    pub fn at(self, t: f64, duration: f64) -> f64 {
        match self {
            DriftShape::Exponential { tc_s } => (-t / tc_s).exp(),
            DriftShape::Quadratic => (t - duration / 2.0).powi(2),
        }
    }
}

/// A fitted drift.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Drift {
    #[serde(flatten)]
    pub shape: DriftShape,
    /// The exponential's time constant's profile interval, s.
    pub tc_interval_s: Option<(f64, f64)>,
    /// Coefficient of the shape (units of the series; per s² for the parabola), with its
    /// two-sided interval.
    pub amplitude: f64,
    pub lo: f64,
    pub hi: f64,
    pub z: f64,
    /// Family-wise p-value (over the shapes).
    pub p_value: f64,
    pub delta_bic: f64,
    /// Share of the series' variance the drift explains.
    pub explained_share: f64,
    /// Block length of the regression, s, and the number of increments.
    pub block_s: f64,
    pub increments: usize,
}

fn variance(v: &[f64]) -> f64 {
    mean_var(v).1
}

/// The coupling of `y` to `aux` under the noise `density` (one-sided, without the ramp);
/// `family`: the number of aux channels tried (Bonferroni); `p`: interval probability. `None`
/// where `aux` does not vary beyond its own white noise at any block length tried (reliability
/// below [`USEFUL_RELIABILITY`]): a temperature held at 25 °C ± 0.02 °C of sensor noise gave a
/// "coefficient" of −0.061 (rad/s)/°C (12 700 (°/h)/°C), the noise's chance correlation
/// multiplied by the correction for it, and became a rival at 53 % of the weight.
pub fn coupling_under_model(
    y: &[f64],
    aux: &[f64],
    fs: f64,
    density: &dyn Fn(f64) -> f64,
    family: usize,
    p: f64,
) -> Option<Coupling> {
    if y.len() != aux.len() {
        return None;
    }
    let noise = white_noise_variance(aux);
    let Regression { gls, block, m } = regress_series(density, fs, y, aux, noise)?;
    if gls.reliability < USEFUL_RELIABILITY {
        return None;
    }
    let p_value = (gls.p * family.max(1) as f64).min(1.0);
    let half = t_two_sided(p, gls.dof) * gls.se;
    let vy = variance(y);
    Some(Coupling {
        coefficient: gls.beta,
        lo: gls.beta - half,
        hi: gls.beta + half,
        z: gls.t,
        p_value,
        delta_bic: delta_bic(1.0, m as f64, p_value, gls.t * gls.t),
        explained_share: if vy > 0.0 {
            (gls.beta * gls.beta * variance(aux) / vy).min(1.0)
        } else {
            0.0
        },
        scale_s: block as f64 / fs,
        n_eff: m,
        aux_span: super::time::coupling::span_of_means(aux, fs),
        explains_drift: None,
    })
}

/// Block means of `shape` over `count` blocks of `block` samples at `fs` (record `duration`):
/// the exponential in closed form (a geometric sum), the parabola summed.
fn shape_block_means(
    shape: DriftShape,
    fs: f64,
    block: usize,
    count: usize,
    duration: f64,
) -> Vec<f64> {
    match shape {
        DriftShape::Exponential { tc_s } => {
            // (1 − r^b)/(b(1 − r)) with r = e^{−1/(fs τ)}, through expm1: 1 − r cancels for
            // time constants long against the sample period.
            let x = 1.0 / (fs * tc_s);
            let b = block as f64;
            let within = if x == 0.0 {
                1.0
            } else {
                (-b * x).exp_m1() / (b * (-x).exp_m1())
            };
            (0..count)
                .map(|j| (-(j as f64) * b / (fs * tc_s)).exp() * within)
                .collect()
        }
        // The mean of (i/fs − D/2)² over the block's b consecutive samples, in closed form: the
        // square at the block's mean time plus the variance of its times, (b² − 1)/(12 fs²).
        // (Summed sample by sample it cost a pass over the record per fit.)
        DriftShape::Quadratic => {
            let b = block as f64;
            let spread = (b * b - 1.0) / (12.0 * fs * fs);
            (0..count)
                .map(|j| {
                    let mid = (j as f64 * b + (b - 1.0) / 2.0) / fs;
                    (mid - duration / 2.0).powi(2) + spread
                })
                .collect()
        }
    }
}

/// The drift shape that best explains `y` under the noise `density`, with the lowest p-value;
/// an exponential's time constant is then refined on a fine grid between the neighbours of the
/// best coarse one, with its profile interval (where t² stays within the χ²₁ quantile of `p` of
/// its maximum). The p-value and ΔBIC are the coarse search's, whose size the Bonferroni factor
/// counts; the fine search only refines the estimate.
pub fn drift_under_model(
    y: &[f64],
    fs: f64,
    density: &dyn Fn(f64) -> f64,
    p: f64,
    shapes: DriftShapes,
) -> Option<Drift> {
    // A noiseless regressor: one blocking (the finest) for all shapes.
    let (model, d) = IncrementModel::for_series(density, fs, y, MAX_INCREMENTS)?;
    drift_in(y, fs, &model, &d, p, shapes)
}

/// Which drift shapes a search fits. The family-wise p-value counts every shape of [`All`]
/// whichever are fitted, so that the p-values of searches restricted to one family compare with
/// each other and with the full search's.
///
/// [`All`]: DriftShapes::All
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DriftShapes {
    All,
    Exponential,
    Quadratic,
}

impl DriftShapes {
    fn admits(self, shape: DriftShape) -> bool {
        matches!(
            (self, shape),
            (DriftShapes::All, _)
                | (DriftShapes::Exponential, DriftShape::Exponential { .. })
                | (DriftShapes::Quadratic, DriftShape::Quadratic)
        )
    }
}

/// [`drift_under_model`] with the increment model and the whitened increments of `y` given
/// (the loop whitens once for the drift and the excursion searches).
pub fn drift_in(
    y: &[f64],
    fs: f64,
    model: &IncrementModel,
    d: &Whitened,
    p: f64,
    shapes: DriftShapes,
) -> Option<Drift> {
    let duration = y.len() as f64 / fs;
    let fit = |shape: DriftShape| {
        let means = shape_block_means(shape, fs, model.block, model.m + 1, duration);
        let x: Vec<f64> = means.windows(2).map(|w| w[1] - w[0]).collect();
        let gls = model.regress_whitened(d, &x, 0.0)?;
        Some((shape, means, gls))
    };
    let exponential = |tc_s: f64| DriftShape::Exponential { tc_s };
    let mut grid = vec![2.0 * model.block as f64 / fs];
    while grid[grid.len() - 1] * 2.0 <= EXP_TC_MAX * duration {
        grid.push(grid[grid.len() - 1] * 2.0);
    }
    // The shapes are independent regressions on one whitened series: fitted in parallel.
    let coarse: Vec<_> = grid
        .iter()
        .map(|&k| exponential(k))
        .chain([DriftShape::Quadratic])
        .filter(|&s| shapes.admits(s))
        .collect::<Vec<_>>()
        .into_par_iter()
        .filter_map(fit)
        .collect();
    let family = (grid.len() + 1) as f64;
    // The evidence: the smallest p-value of the search (corrected below by `family`).
    let detection = coarse
        .iter()
        .map(|c| c.2)
        .min_by(|a, b| a.p.total_cmp(&b.p))?;
    // The shape: by BIC, an exponential paying one parameter more than the parabola (a slow
    // exponential, τ beyond the record, bends like a parabola and would otherwise win by a
    // hair with a meaningless amplitude).
    let penalty = (model.m as f64).ln();
    let bic = |g: &Gls, shape: DriftShape| {
        let k = match shape {
            DriftShape::Exponential { .. } => 2.0,
            DriftShape::Quadratic => 1.0,
        };
        k * penalty - g.t * g.t
    };
    let (mut shape, mut means, mut gls) = coarse
        .iter()
        .min_by(|a, b| bic(&a.2, a.0).total_cmp(&bic(&b.2, b.0)))?
        .clone();
    let mut tc_interval = None;
    let mut amplitude_interval = None;
    if let DriftShape::Exponential { tc_s } = shape {
        let (lo, hi) = (tc_s / 3.0, tc_s * 3.0);
        let fine: Vec<_> = (0..=48)
            .into_par_iter()
            .map(|i| lo * (hi / lo).powf(i as f64 / 48.0))
            .filter_map(|k| fit(exponential(k)))
            .collect();
        if let Some(top) = fine
            .iter()
            .max_by(|a, b| a.2.t.abs().total_cmp(&b.2.t.abs()))
        {
            let q = norm_isf((1.0 - p) / 2.0).powi(2);
            let t2 = top.2.t * top.2.t;
            let inside: Vec<_> = fine.iter().filter(|f| f.2.t * f.2.t >= t2 - q).collect();
            let tcs: Vec<f64> = inside
                .iter()
                .filter_map(|f| match f.0 {
                    DriftShape::Exponential { tc_s } => Some(tc_s),
                    DriftShape::Quadratic => None,
                })
                .collect();
            // The amplitude is tied to τ (a longer settling needs a larger amplitude for the
            // same slope): its interval is the union of the conditional ones over τ's interval.
            let half = |g: &Gls| t_two_sided(p, g.dof) * g.se;
            amplitude_interval = Some((
                inside
                    .iter()
                    .map(|f| f.2.beta - half(&f.2))
                    .fold(f64::INFINITY, f64::min),
                inside
                    .iter()
                    .map(|f| f.2.beta + half(&f.2))
                    .fold(f64::NEG_INFINITY, f64::max),
            ));
            tc_interval = Some((
                tcs.iter().copied().fold(f64::INFINITY, f64::min),
                tcs.iter().copied().fold(0.0, f64::max),
            ));
            (shape, means, gls) = top.clone();
        }
    }
    let p_value = (detection.p * family).min(1.0);
    let k = match shape {
        DriftShape::Exponential { .. } => 2.0,
        DriftShape::Quadratic => 1.0,
    };
    let half = t_two_sided(p, gls.dof) * gls.se;
    let (lo, hi) = amplitude_interval.unwrap_or((gls.beta - half, gls.beta + half));
    let vy = variance(y);
    Some(Drift {
        shape,
        tc_interval_s: tc_interval,
        amplitude: gls.beta,
        lo,
        hi,
        z: gls.t,
        p_value,
        delta_bic: delta_bic(k, model.m as f64, p_value, detection.t * detection.t),
        explained_share: if vy > 0.0 {
            (gls.beta * gls.beta * variance(&means) / vy).min(1.0)
        } else {
            0.0
        },
        block_s: model.block as f64 / fs,
        increments: model.m,
    })
}

/// Subtracts the drift from `y` (sampled at `fs`).
pub fn remove_drift(y: &mut [f64], fs: f64, d: &Drift) {
    let duration = y.len() as f64 / fs;
    for (i, v) in y.iter_mut().enumerate() {
        *v -= d.amplitude * d.shape.at(i as f64 / fs, duration);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::rng::Rng;

    const FS: f64 = 10.0;

    /// White noise of σ = 1 plus a random walk of step 0.001: its one-sided density.
    fn density(f: f64) -> f64 {
        let s = (std::f64::consts::PI * f / FS).sin();
        2.0 * 1e-6 / FS / (4.0 * s * s) + 2.0 / FS
    }

    fn noise(seed: u64, n: usize) -> Vec<f64> {
        let mut rng = Rng::new(seed);
        let mut rw = 0.0;
        (0..n)
            .map(|_| {
                rw += 0.001 * rng.gauss();
                rw + rng.gauss()
            })
            .collect()
    }

    /// The shapes' block means in closed form are the means of the shapes sample by sample.
    #[test]
    fn block_means_in_closed_form_match_the_samples() {
        let (fs, block, count) = (200.0, 1000, 37);
        let duration = (block * count) as f64 / fs;
        for shape in [
            DriftShape::Quadratic,
            DriftShape::Exponential { tc_s: 30.0 },
            DriftShape::Exponential { tc_s: 1e9 },
        ] {
            let got = shape_block_means(shape, fs, block, count, duration);
            for (j, g) in got.iter().enumerate() {
                let want = (j * block..(j + 1) * block)
                    .map(|i| shape.at(i as f64 / fs, duration))
                    .sum::<f64>()
                    / block as f64;
                assert!(
                    (g - want).abs() <= 1e-12 * want.abs(),
                    "{shape:?} block {j}: {g} vs {want}"
                );
            }
        }
    }

    #[test]
    fn a_settling_is_found_with_its_time_constant() {
        // 2·exp(−t/300 s) over an hour against white noise and a random walk, 8 seeds.
        // Measured: τ̂ 279–333 s, Â 1.67–2.14; both intervals (1σ) cover the truth 7 of 8 times.
        let n = 36_000;
        let (mut tc_covered, mut a_covered, mut amps) = (0, 0, Vec::new());
        for seed in 1..9 {
            let mut y = noise(seed, n);
            for (i, v) in y.iter_mut().enumerate() {
                *v += 2.0 * (-(i as f64) / FS / 300.0).exp();
            }
            let d = drift_under_model(&y, FS, &density, 0.6827, DriftShapes::All).unwrap();
            assert!(d.p_value < DETECTION_P && d.delta_bic < 0.0, "{d:?}");
            let DriftShape::Exponential { tc_s } = d.shape else {
                panic!("{d:?}")
            };
            let (lo, hi) = d.tc_interval_s.unwrap();
            assert!(lo <= tc_s && tc_s <= hi, "{d:?}");
            assert!((tc_s / 300.0 - 1.0).abs() < 0.2, "{d:?}");
            tc_covered += usize::from(lo <= 300.0 && 300.0 <= hi);
            a_covered += usize::from(d.lo <= 2.0 && 2.0 <= d.hi);
            amps.push(d.amplitude);
            remove_drift(&mut y, FS, &d);
            let again = drift_under_model(&y, FS, &density, 0.6827, DriftShapes::All).unwrap();
            assert!(again.p_value > DETECTION_P, "{again:?}");
        }
        amps.sort_by(f64::total_cmp);
        let median = (amps[3] + amps[4]) / 2.0;
        assert!(
            tc_covered >= 6 && a_covered >= 6,
            "{tc_covered} {a_covered}"
        );
        assert!((median / 2.0 - 1.0).abs() < 0.05, "{amps:?}");
    }

    #[test]
    fn a_search_restricted_to_one_family_fits_only_its_shapes_and_pays_for_all() {
        // The settling of the test above, seed 1: the full search picks the exponential; the
        // parabola alone is fitted when asked for, and its family-wise p-value, counting every
        // shape of the full search, is at least the full search's.
        let mut y = noise(1, 36_000);
        for (i, v) in y.iter_mut().enumerate() {
            *v += 2.0 * (-(i as f64) / FS / 300.0).exp();
        }
        let all = drift_under_model(&y, FS, &density, 0.6827, DriftShapes::All).unwrap();
        let exp = drift_under_model(&y, FS, &density, 0.6827, DriftShapes::Exponential).unwrap();
        let quad = drift_under_model(&y, FS, &density, 0.6827, DriftShapes::Quadratic).unwrap();
        assert!(
            matches!(all.shape, DriftShape::Exponential { .. }),
            "{all:?}"
        );
        assert_eq!(exp, all);
        assert_eq!(quad.shape, DriftShape::Quadratic);
        assert!(quad.p_value >= all.p_value, "{quad:?} vs {all:?}");
    }

    #[test]
    fn noise_alone_is_rarely_a_drift() {
        let runs = 100;
        let mut found = 0;
        for seed in 0..runs {
            let y = noise(100 + seed, 12_000);
            let d = drift_under_model(&y, FS, &density, 0.6827, DriftShapes::All).unwrap();
            found += usize::from(d.p_value < DETECTION_P);
        }
        println!("drift false detections: {found} of {runs}");
        assert!(found <= 2, "{found}");
    }

    #[test]
    fn a_coupling_is_found_and_an_independent_aux_is_not() {
        let n = 36_000;
        let temp: Vec<f64> = {
            let mut rng = Rng::new(7);
            (0..n)
                .map(|i| 4.0 * (1.0 - (-(i as f64) / FS / 600.0).exp()) + 0.01 * rng.gauss())
                .collect()
        };
        let base = noise(3, n);
        let c = coupling_under_model(&base, &temp, FS, &density, 1, 0.6827).unwrap();
        assert!(c.p_value > DETECTION_P, "{c:?}");
        let y: Vec<f64> = base.iter().zip(&temp).map(|(a, t)| a + 0.3 * t).collect();
        let c = coupling_under_model(&y, &temp, FS, &density, 1, 0.6827).unwrap();
        println!("{c:?}");
        assert!(c.p_value < DETECTION_P && c.delta_bic < 0.0);
        assert!(
            (c.coefficient - 0.3).abs() < 3.0 * (c.hi - c.lo) / 2.0,
            "{c:?}"
        );
    }

    /// A temperature held constant, only its sensor's white noise moving: no coefficient is
    /// measured on it, whatever the series does.
    #[test]
    fn an_aux_that_is_only_its_own_noise_gives_no_coupling() {
        let n = 36_000;
        for seed in 0..10 {
            let mut rng = Rng::new(100 + seed);
            let temp: Vec<f64> = (0..n).map(|_| 25.0 + 0.02 * rng.gauss()).collect();
            let y = noise(200 + seed, n);
            assert!(
                coupling_under_model(&y, &temp, FS, &density, 1, 0.6827).is_none(),
                "seed {seed}"
            );
        }
    }
}
