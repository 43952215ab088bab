//! The entry points: validate, build S once, run the estimator, then identify the noise and the
//! confidence interval at every τ.

use std::borrow::Cow;

use rayon::prelude::*;

use super::confidence::variance_bounds;
use super::edf::edf;
use super::noise_id::identify;
use super::prefix::PrefixSums;
use super::variances::variances;
use super::{AvarError, Confidence, Deviations, Statistic, TauGrid};

/// Computes `stat` of rate samples `y` (sampled at `rate_hz`) at the averaging factors of `grid`,
/// with confidence intervals at `conf` from the EDF of the automatically identified noise type.
///
/// ```
/// use imunoise::avar::{compute, Confidence, Statistic, TauGrid};
/// // The 9-sample frequency set of NIST SP 1065 (section 12.1), τ₀ = 1 s.
/// let y = [892.0, 809.0, 823.0, 798.0, 671.0, 644.0, 883.0, 903.0, 677.0];
/// let d = compute(&y, 1.0, &TauGrid::Octave, Statistic::Adev, Confidence::OneSigma)?;
/// assert_eq!(d.m, vec![1, 2]);
/// assert!((d.deviation()[0] - 91.22945).abs() < 1e-5);
/// # Ok::<(), imunoise::avar::AvarError>(())
/// ```
///
/// # Errors
/// [`AvarError::InvalidRate`] for a non-finite or non-positive rate,
/// [`AvarError::InvalidConfidence`] for a level outside (0, 1), [`AvarError::TooShort`] when the
/// data cannot support the statistic at m = 1 or at a factor of an explicit list,
/// [`AvarError::ZeroFactor`] for m = 0 in an explicit list, [`AvarError::NoValidTau`] when the grid
/// leaves no factor, [`AvarError::NonFinite`] with the index of the first NaN/infinite sample,
/// [`AvarError::Overflow`] when the samples are so large (beyond ~1e154) that their sum or squared
/// differences overflow f64.
pub fn compute(
    y: &[f64],
    rate_hz: f64,
    grid: &TauGrid,
    stat: Statistic,
    conf: Confidence,
) -> Result<Deviations, AvarError> {
    only(compute_each(Cow::Borrowed(y), rate_hz, grid, &[stat], conf))
}

/// The one result of a one-statistic [`compute_each`].
fn only(mut results: Vec<Result<Deviations, AvarError>>) -> Result<Deviations, AvarError> {
    results.pop().expect("one statistic asked, one result")
}

/// [`compute`] of each of `stats` on one channel, with its prefix sums built once — in `y`'s own
/// buffer when it is owned ([`PrefixSums::from_samples`]) — and each statistic's result in its
/// place: exactly what [`compute`] returns for that statistic alone, error included (a statistic
/// the record is too short for fails alone; the others are computed).
///
/// **Why.** `avar --stat oadev,mdev,ohdev,…` built S once per statistic: on 10⁷ samples each
/// build is a pass over 76 MB, and the copy the borrowed path makes.
pub fn compute_each(
    y: Cow<'_, [f64]>,
    rate_hz: f64,
    grid: &TauGrid,
    stats: &[Statistic],
    conf: Confidence,
) -> Vec<Result<Deviations, AvarError>> {
    let fail_all = |e: AvarError| stats.iter().map(|_| Err(e.clone())).collect();
    if !(rate_hz.is_finite() && rate_hz > 0.0) {
        return fail_all(AvarError::InvalidRate(rate_hz));
    }
    let p = match conf.probability() {
        Ok(p) => p,
        Err(e) => return fail_all(e),
    };
    let plans: Vec<Result<Vec<u64>, AvarError>> = stats
        .iter()
        .map(|&stat| checked_factors(grid, y.len(), stat))
        .collect();
    // S only where some statistic can use it (a record too short for all of them is not read).
    let ps = plans.iter().any(Result::is_ok).then(|| match y {
        Cow::Owned(samples) => PrefixSums::from_samples(samples),
        Cow::Borrowed(samples) => PrefixSums::new(samples),
    });
    stats
        .iter()
        .zip(plans)
        .map(|(&stat, plan)| {
            let ms = plan?;
            let ps = ps.as_ref().expect("built where a plan is ok");
            let ps = ps.as_ref().map_err(Clone::clone)?;
            let variance = variances(ps, &ms, stat);
            assemble(ps, rate_hz, ms, variance, stat, p)
        })
        .collect()
}

/// [`compute`] of samples the caller no longer needs: S is built in their buffer
/// ([`PrefixSums::from_samples`]), which goes to the scratch pool afterwards; the same results
/// to the bit, with one record-length buffer instead of two.
///
/// # Errors
/// As [`compute`].
pub fn compute_owned(
    y: Vec<f64>,
    rate_hz: f64,
    grid: &TauGrid,
    stat: Statistic,
    conf: Confidence,
) -> Result<Deviations, AvarError> {
    only(compute_each(Cow::Owned(y), rate_hz, grid, &[stat], conf))
}

/// Completes variances computed elsewhere (another backend, e.g. a GPU) into [`Deviations`]
/// exactly as [`compute`] does: noise identification, EDF and confidence bounds at every τ. `ms`
/// must come from [`checked_factors`] for the same data and `ps` from [`PrefixSums::new`] on it.
///
/// # Errors
/// [`AvarError::InvalidConfidence`] for a level outside (0, 1); [`AvarError::Overflow`] if a
/// variance is not finite.
///
/// # Panics
/// If `ms` and `variance` differ in length.
pub fn deviations_from_variances(
    ps: &PrefixSums,
    rate_hz: f64,
    ms: Vec<u64>,
    variance: Vec<f64>,
    stat: Statistic,
    conf: Confidence,
) -> Result<Deviations, AvarError> {
    assert_eq!(
        ms.len(),
        variance.len(),
        "one variance per averaging factor"
    );
    assemble(ps, rate_hz, ms, variance, stat, conf.probability()?)
}

/// The averaging factors [`compute`] uses for `grid` on `n` samples of `stat`, or the error it
/// returns when there are none, when an explicit factor is zero, or when an explicit factor (or
/// m = 1) needs more samples than there are.
pub fn checked_factors(grid: &TauGrid, n: usize, stat: Statistic) -> Result<Vec<u64>, AvarError> {
    let too_short = |m: u64| AvarError::TooShort {
        n,
        needed: stat.min_samples(m),
        statistic: stat,
        m,
    };
    if n < stat.min_samples(1) {
        return Err(too_short(1));
    }
    if let TauGrid::Explicit(list) = grid {
        if list.contains(&0) {
            return Err(AvarError::ZeroFactor);
        }
        let max = stat.max_factor(n);
        if let Some(&m) = list.iter().filter(|&&m| m > max).max() {
            return Err(too_short(m));
        }
    }
    let ms = grid.factors(n, stat);
    if ms.is_empty() {
        return Err(AvarError::NoValidTau {
            n,
            statistic: stat,
            grid: grid.to_string(),
        });
    }
    Ok(ms)
}

/// The α found at each τ (`alphas`, per averaging factor of `ms`, `n` samples) may not be phase
/// noise (α > 0) where the α at the next shorter τ is rate noise (α ≤ 0): it is then taken as
/// white rate noise (α = 0). Where fewer than [`super::noise_id::ACF_MIN_POINTS`] τ-averages
/// leave it to the B1 ratio, it may not be whiter than the α at the next shorter τ at all. Each
/// τ is judged against the one before as settled.
///
/// Why: both identifications read whiter noise than there is where the τ-averages are few. B1
/// is a ratio of two variances of a few degrees of freedom each: on 40-min white-noise records at
/// 100 Hz it said α = +1 at τ = 655 s in 13 of 18 channels, and on flicker and random-walk
/// records it said white (α = 0) at the last octave between α = −1 and −2 (EDF 2.16 where
/// α = −2 gives 1.24). The lag-1 autocorrelation of n averages scatters by 1/√n, so that white
/// noise passes its δ ≤ −¼ boundary (r₁ ≤ −0.2) with about 8 % probability at 58 averages. A
/// whiter α has the larger EDF (68 against 3.6 at 655 s for phase against white rate noise):
/// intervals that narrow covered the true σ in 7 of 25 such points. A rate sensor's noise does
/// not turn into phase noise at long τ after rate noise at shorter ones, and where the averages
/// are few the α of the shorter τ, identified on more of them, is the better guess; where the
/// noise does turn whiter (beyond a Gauss–Markov process's correlation time, an oscillation
/// averaged out), the redder α's EDF is the smaller one, so the interval errs wide. Phase noise
/// after phase noise (a clock's white PM) stands, so Stable32's identification of clock data is
/// untouched where its autocorrelation method rules.
fn no_whiter_than_the_evidence(ms: &[u64], n: usize, alphas: &mut [i8]) {
    let mut order: Vec<usize> = (0..ms.len()).collect();
    order.sort_by_key(|&i| ms[i]);
    for pair in order.windows(2) {
        let (shorter, here) = (pair[0], pair[1]);
        let few = n / (ms[here].max(1) as usize) < super::noise_id::ACF_MIN_POINTS;
        if few {
            alphas[here] = alphas[here].min(alphas[shorter]);
        } else if alphas[shorter] <= 0 {
            alphas[here] = alphas[here].min(0);
        }
    }
}

fn assemble(
    ps: &PrefixSums,
    rate_hz: f64,
    ms: Vec<u64>,
    variance: Vec<f64>,
    stat: Statistic,
    p: f64,
) -> Result<Deviations, AvarError> {
    let n = ps.len();
    // Samples near 1e154 and beyond square to infinity: no variance to report.
    if variance.iter().any(|v| !v.is_finite()) {
        return Err(AvarError::Overflow);
    }
    let mut alphas: Vec<i8> = ms
        .par_iter()
        .map(|&m| identify(ps, m, stat).alpha)
        .collect();
    no_whiter_than_the_evidence(&ms, n, &mut alphas);
    let per_tau: Vec<(i8, f64, (f64, f64))> = ms
        .par_iter()
        .zip(variance.par_iter())
        .zip(alphas.par_iter())
        .map(|((&m, &var), &alpha)| {
            let e = edf(stat, alpha, m, n);
            (alpha, e, variance_bounds(var, e, p))
        })
        .collect();
    Ok(Deviations {
        statistic: stat,
        rate_hz,
        tau_s: ms.iter().map(|&m| m as f64 / rate_hz).collect(),
        n_terms: ms.iter().map(|&m| stat.n_terms(n, m)).collect(),
        alpha: per_tau.iter().map(|t| t.0).collect(),
        edf: per_tau.iter().map(|t| t.1).collect(),
        variance_lo: per_tau.iter().map(|t| t.2 .0).collect(),
        variance_hi: per_tau.iter().map(|t| t.2 .1).collect(),
        variance,
        m: ms,
        confidence: p,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The rule alone: with many averages phase noise after rate noise becomes white rate noise
    /// and redder α stand; with few (B1) nothing is whiter than the shorter τ; phase noise after
    /// phase noise (a clock's white PM at every τ) stands where the averages are many.
    #[test]
    fn the_noise_is_no_whiter_than_the_evidence() {
        let n = 1_000;
        // Averages: 500, 250, 62, 31 (autocorrelation), 15, 7, 3 (B1).
        let ms = [2u64, 4, 16, 32, 64, 128, 256];
        let mut a = [0i8, -1, 1, -1, 1, 2, -2];
        no_whiter_than_the_evidence(&ms, n, &mut a);
        assert_eq!(a, [0, -1, 0, -1, -1, -1, -2]);
        let mut clock = [2i8, 2, 2, 1, 2, 0, 2];
        no_whiter_than_the_evidence(&ms, n, &mut clock);
        assert_eq!(clock, [2, 2, 2, 1, 1, 0, 0]);
        // Flicker then random walk, B1 reading white at the last octave.
        let mut red = [0i8, 0, -1, -1, -2, -2, 0];
        no_whiter_than_the_evidence(&ms, n, &mut red);
        assert_eq!(red, [0, 0, -1, -1, -2, -2, -2]);
        // The grid's order does not matter.
        let mut reversed = ms;
        reversed.reverse();
        let mut b = [-2i8, 2, 1, -1, 1, -1, 0];
        no_whiter_than_the_evidence(&reversed, n, &mut b);
        assert_eq!(b, [-2, -1, -1, -1, 0, -1, 0]);
    }

    /// White rate noise, 40 min at 100 Hz, 12 records: no point of the octave grid is taken for
    /// phase noise, so none gets its tenfold EDF.
    #[test]
    fn white_rate_noise_is_never_phase_noise_at_the_longest_tau() {
        for seed in 0..12 {
            let y = crate::sim::rng::Rng::new(4_000 + seed).gauss_vec(240_000);
            let d = compute(
                &y,
                100.0,
                &TauGrid::Octave,
                Statistic::Oadev,
                Confidence::OneSigma,
            )
            .unwrap();
            assert!(
                d.alpha.iter().all(|&a| a <= 0),
                "seed {seed}: {:?}",
                d.alpha
            );
        }
    }

    #[test]
    fn owned_samples_give_the_same_deviations() {
        let y: Vec<f64> = crate::sim::rng::Rng::new(11)
            .gauss_vec(70_001)
            .iter()
            .scan(0.0, |w, v| {
                *w += 1e-3 * v;
                Some(v + *w)
            })
            .collect();
        for stat in [Statistic::Oadev, Statistic::Mdev, Statistic::Ohdev] {
            let a = compute(&y, 100.0, &TauGrid::Octave, stat, Confidence::OneSigma).unwrap();
            let b = compute_owned(
                y.clone(),
                100.0,
                &TauGrid::Octave,
                stat,
                Confidence::OneSigma,
            )
            .unwrap();
            assert_eq!(a, b, "{stat:?}");
        }
        assert_eq!(
            compute_owned(
                vec![1.0, f64::NAN, 2.0],
                1.0,
                &TauGrid::Octave,
                Statistic::Adev,
                Confidence::OneSigma
            )
            .unwrap_err(),
            AvarError::NonFinite { index: 1 }
        );
    }

    #[test]
    fn each_statistic_is_what_it_is_alone() {
        use std::borrow::Cow;
        let y: Vec<f64> = crate::sim::rng::Rng::new(12).gauss_vec(20_000);
        let all = [
            Statistic::Oadev,
            Statistic::Adev,
            Statistic::Mdev,
            Statistic::Hdev,
            Statistic::Ohdev,
        ];
        // m = 8000 is too long for the Hadamard and modified statistics of 20 000 samples only.
        for grid in [TauGrid::Octave, TauGrid::Explicit(vec![1, 10, 8000])] {
            let alone: Vec<_> = all
                .iter()
                .map(|&s| compute(&y, 10.0, &grid, s, Confidence::OneSigma))
                .collect();
            let borrowed = compute_each(Cow::Borrowed(&y), 10.0, &grid, &all, Confidence::OneSigma);
            let owned = compute_each(
                Cow::Owned(y.clone()),
                10.0,
                &grid,
                &all,
                Confidence::OneSigma,
            );
            assert_eq!(borrowed, alone, "{grid:?}");
            assert_eq!(owned, alone, "{grid:?}");
        }
        let mut bad = y.clone();
        bad[7] = f64::INFINITY;
        let grid = TauGrid::Explicit(vec![1, 8000]);
        let alone: Vec<_> = all
            .iter()
            .map(|&s| compute(&bad, 10.0, &grid, s, Confidence::OneSigma))
            .collect();
        assert!(alone
            .iter()
            .any(|r| matches!(r, Err(AvarError::TooShort { .. }))));
        assert!(alone
            .iter()
            .any(|r| r == &Err(AvarError::NonFinite { index: 7 })));
        assert_eq!(
            compute_each(Cow::Owned(bad), 10.0, &grid, &all, Confidence::OneSigma),
            alone
        );
        assert_eq!(
            compute_each(Cow::Borrowed(&y), -1.0, &grid, &all, Confidence::OneSigma),
            vec![Err(AvarError::InvalidRate(-1.0)); 5]
        );
    }
}
