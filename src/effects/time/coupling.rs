//! Linear coupling of a channel to an aux channel (temperature): y ≈ c·T + noise.
//!
//! **The trap.** The IEEE noise has slow parts (flicker, rate random walk) and a temperature
//! record is slow too (a warm-up, a wander). Ordinary least squares of y on T over the raw
//! samples treats the n samples as independent, and two independent slow processes then look
//! "significantly" correlated nearly every time (Granger & Newbold's spurious regression): on the
//! simulated gyros of the tests, OLS calls ≈ 85 % of independent pairs significant (|t| > 2).
//!
//! **The method.** Both series are averaged to blocks of s samples, and the *increments* of the
//! block means are regressed (with an intercept) on each other: Δȳ_j = a + c·ΔT̄_j + e_j.
//! Under any IEEE noise the increments are stationary, with variance 2σ²_A(sτ₀) and a
//! correlation that is short (lag 1 for white and random walk; flicker's decays), and the
//! intercept absorbs a ramp. Conditional on T the estimate ĉ = Σx_j e_j/Σx_j² has the exact
//! variance xᵀΓx/(Σx²)², Γ the autocovariance of e; it is estimated from the residuals, pooled
//! over j (lags 0–3, Newey–West style; Bartlett taper only if the truncated form is not
//! positive). Pooling rather than the x-weighted HAC keeps the error honest when a few
//! increments (the warm-up) carry all the leverage. The statistic t = ĉ/SE is Student-t with
//! (increments − 2) degrees of freedom.
//!
//! Octave scales from one sample to a length that still leaves [`MIN_INCREMENTS`] increments are
//! tried; the one with the smallest p-value is kept and that p-value is multiplied by the number
//! of scales (Bonferroni). Differencing throws away the low frequencies where a warm-up lives,
//! so long scales (a sizeable share of the warm-up) are needed for power; short ones suffer from
//! the white measurement noise of T (attenuation). The evidence (smallest p-value, Student-t
//! tails on m − 2 − lags degrees of freedom for the estimated Γ) decides whether there is a
//! coupling; `delta_bic = ln(m) − χ²_eq` with m the number of increments at that scale (the
//! effective sample count), floored at [`N_EFF_FLOOR`]. The estimate and its interval come from
//! the scale with the smallest standard error, which usually has fewer increments (so a larger
//! p-value) but the most precise coefficient: after [`remove_coupling`] the remainder is then
//! below one standard error at every scale, and a refit finds nothing.

use super::stats::{delta_bic, mean_var, t_sf, t_two_sided};

/// The fewest block-mean increments a scale may leave.
pub const MIN_INCREMENTS: usize = 16;
/// Floor of the effective sample count in the BIC penalty: with fewer increments than this, the
/// penalty would fall below a 3 % two-sided test.
pub const N_EFF_FLOOR: f64 = 100.0;
/// Autocovariance lags of the residual increments used in the standard error (fewer when there
/// are fewer than 8 increments per lag).
const LAGS: usize = 3;

/// A fitted linear coupling y = coefficient·aux + ….
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Coupling {
    /// Units of y per unit of aux (e.g. rad/s/°C).
    pub coefficient: f64,
    /// Two-sided interval at the requested probability.
    pub lo: f64,
    pub hi: f64,
    /// Coefficient over its standard error at the estimation scale.
    pub z: f64,
    /// Family-wise p-value (Bonferroni over the scales tried).
    pub p_value: f64,
    pub delta_bic: f64,
    /// Share of y's variance (about its mean) that coefficient·aux explains.
    pub explained_share: f64,
    /// The block length of the estimate, s.
    pub scale_s: f64,
    /// Increments at the scale of the best evidence: the effective sample count.
    pub n_eff: usize,
    /// How far the aux channel's 1-s means range over the record (max − min, its unit): the
    /// coupling moved the bias by |coefficient|·span. The share of the variance says little
    /// where white noise dominates the samples (0.0 % on a navigation-grade gyro at 200 Hz).
    pub aux_span: f64,
    /// ΔBIC of a drift of the bias that is significant on its own and that this coupling
    /// explains (the loop then takes the coupling and vetoes the drift): where the aux channel
    /// only warms up, with no wander the series follows, a warm-up of the bias and the aux
    /// channel's are not told apart, and [`crate::model::FitWarning::CouplingOrWarmUp`] says so.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub explains_drift: Option<f64>,
}

struct ScaleFit {
    beta: f64,
    se: f64,
    p: f64,
    m: usize,
    nu: f64,
    s: usize,
}

/// Fits the coupling of `y` to `aux` (same length, same rate). `None` when the series are too
/// short (fewer than [`MIN_INCREMENTS`] + 1 samples), of different lengths, or `aux` does not vary.
pub fn fit_coupling(y: &[f64], aux: &[f64], rate_hz: f64, p: f64) -> Option<Coupling> {
    let n = y.len();
    if n != aux.len() || n < MIN_INCREMENTS + 1 || !(rate_hz > 0.0) {
        return None;
    }
    let (_, vy) = mean_var(y);
    let (_, vx) = mean_var(aux);
    // Block means of each scale from the previous scale's by pairs: no copy of either series at
    // one sample, and half a series' worth at most after it (prefix sums and four
    // series-long buffers per scale had held 7 series' worth, 160 MB per channel of a 4-h
    // 200-Hz record, while the channels are tested side by side).
    let mut fits = Vec::new();
    let mut level: Option<(Vec<f64>, Vec<f64>)> = None;
    let mut s = 1;
    while n / s > MIN_INCREMENTS {
        let (ym, xm) = match &level {
            Some((ym, xm)) => (ym.as_slice(), xm.as_slice()),
            None => (y, aux),
        };
        if let Some(f) = fit_scale(ym, xm, s) {
            fits.push(f);
        }
        level = Some((pair_means(ym), pair_means(xm)));
        s *= 2;
    }
    drop(level);
    let scales = fits.len();
    let det = fits.iter().min_by(|a, b| a.p.total_cmp(&b.p))?;
    let p_value = (det.p * scales as f64).min(1.0);
    let n_eff = det.m;
    // The estimate from the most precise scale (see the module notes).
    let est = fits
        .iter()
        .filter(|f| f.se > 0.0)
        .min_by(|a, b| a.se.total_cmp(&b.se))
        .unwrap_or(det);
    let z = if est.se > 0.0 { est.beta / est.se } else { 0.0 };
    let half = t_two_sided(p, est.nu) * est.se;
    let share = if vy > 0.0 {
        (est.beta * est.beta * vx / vy).min(1.0)
    } else {
        0.0
    };
    Some(Coupling {
        coefficient: est.beta,
        lo: est.beta - half,
        hi: est.beta + half,
        z,
        p_value,
        delta_bic: delta_bic(1.0, (n_eff as f64).max(N_EFF_FLOOR), p_value, z * z),
        explained_share: share,
        scale_s: est.s as f64 / rate_hz,
        n_eff,
        aux_span: span_of_means(aux, rate_hz),
        explains_drift: None,
    })
}

/// Max − min of `aux`'s means over 1 s (one sample where the rate is below 1 Hz): its range
/// with the sensor's own noise averaged down. 0 for an empty series.
pub fn span_of_means(aux: &[f64], rate_hz: f64) -> f64 {
    let block = (rate_hz.round() as usize).max(1);
    let (lo, hi) = aux
        .chunks(block)
        .map(|c| c.iter().sum::<f64>() / c.len() as f64)
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), m| {
            (lo.min(m), hi.max(m))
        });
    if hi >= lo {
        hi - lo
    } else {
        0.0
    }
}

/// The means of consecutive pairs of `v` (a last unpaired value is left out).
fn pair_means(v: &[f64]) -> Vec<f64> {
    v.chunks_exact(2).map(|p| 0.5 * (p[0] + p[1])).collect()
}

/// Regression of the increments of the block means `ym`, `xm` (blocks of `s` samples). The
/// increments, centred regressor and residuals are computed where they are used, not stored.
fn fit_scale(ym: &[f64], xm: &[f64], s: usize) -> Option<ScaleFit> {
    let m = ym.len().min(xm.len()).saturating_sub(1);
    if m < 3 {
        return None;
    }
    let dy = |j: usize| ym[j + 1] - ym[j];
    let dx = |j: usize| xm[j + 1] - xm[j];
    let mean_of = |d: &dyn Fn(usize) -> f64| (0..m).map(d).sum::<f64>() / m as f64;
    let (ay, ax) = (mean_of(&dy), mean_of(&dx));
    let x = |j: usize| dx(j) - ax;
    let sxx: f64 = (0..m).map(|j| x(j) * x(j)).sum();
    if !(sxx > 0.0 && sxx.is_finite()) {
        return None;
    }
    let beta = (0..m).map(|j| x(j) * (dy(j) - ay)).sum::<f64>() / sxx;
    let e = |j: usize| dy(j) - ay - beta * x(j);
    let lag_sum =
        |v: &dyn Fn(usize) -> f64, h: usize| (0..m - h).map(|j| v(j) * v(j + h)).sum::<f64>();
    let lags = LAGS.min(m / 8);
    let gamma: Vec<f64> = (0..=lags)
        .map(|h| lag_sum(&e, h) / (m as f64 - 2.0))
        .collect();
    let rx: Vec<f64> = (0..gamma.len()).map(|h| lag_sum(&x, h)).collect();
    let quad = |taper: bool| {
        gamma[0] * rx[0]
            + 2.0
                * (1..gamma.len())
                    .map(|h| {
                        let w = if taper {
                            1.0 - h as f64 / (lags as f64 + 1.0)
                        } else {
                            1.0
                        };
                        w * gamma[h] * rx[h]
                    })
                    .sum::<f64>()
    };
    let mut q = quad(false);
    if q <= 0.0 {
        q = quad(true).max(gamma[0] * rx[0] * 1e-3);
    }
    let se = (q.max(0.0)).sqrt() / sxx;
    let nu = (m - 2 - lags) as f64;
    let p = if se > 0.0 {
        2.0 * t_sf((beta / se).abs(), nu)
    } else if beta == 0.0 {
        1.0
    } else {
        0.0
    };
    Some(ScaleFit {
        beta,
        se,
        p,
        m,
        nu,
        s,
    })
}

/// Subtracts coefficient·(aux − mean aux) from `y` (the mean of y is kept), aux smoothed by a
/// centred running mean just long enough to suppress its white measurement noise (see
/// [`smoothing_length`]): subtracting the raw aux would inject that noise, perfectly correlated
/// with aux, into y, and a refit would find a spurious negative coupling at the shortest scales;
/// smoothing over the whole fit scale would leave the fast part of the real drift in y.
pub fn remove_coupling(y: &mut [f64], aux: &[f64], c: &Coupling) {
    let n = y.len().min(aux.len());
    let (mx, _) = mean_var(&aux[..n]);
    let mut prefix = Vec::with_capacity(n + 1);
    let mut acc = 0.0;
    prefix.push(0.0);
    for t in &aux[..n] {
        acc += t - mx;
        prefix.push(acc);
    }
    let half = smoothing_length(&aux[..n]) / 2;
    for (i, v) in y[..n].iter_mut().enumerate() {
        let (a, b) = (i.saturating_sub(half), (i + half + 1).min(n));
        *v -= c.coefficient * (prefix[b] - prefix[a]) / (b - a) as f64;
    }
}

/// The shortest octave block length at which the block-mean increments of `aux` carry 20× the
/// variance its white measurement noise alone would give them (2σ²_n/s, σ²_n from the lag-1
/// differences), i.e. where the real signal dominates; 1 for a series without measurement noise
/// worth the name.
pub fn smoothing_length(aux: &[f64]) -> usize {
    let n = aux.len();
    if n < 16 {
        return 1;
    }
    let noise = aux.windows(2).map(|w| (w[1] - w[0]).powi(2)).sum::<f64>() / (2.0 * (n - 1) as f64);
    let mut s = 1;
    while n / (2 * s) >= 8 {
        let nb = n / s;
        let means: Vec<f64> = aux[..nb * s]
            .chunks_exact(s)
            .map(|c| c.iter().sum::<f64>() / s as f64)
            .collect();
        let v = means.windows(2).map(|w| (w[1] - w[0]).powi(2)).sum::<f64>() / (nb - 1) as f64;
        if v >= 40.0 * noise / s as f64 {
            break;
        }
        s *= 2;
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::effects::time::testutil::*;

    /// Naive OLS of y on T over the raw samples: the t statistic with iid errors.
    fn naive_t(y: &[f64], t: &[f64]) -> f64 {
        let (my, _) = mean_var(y);
        let (mt, vt) = mean_var(t);
        let n = y.len() as f64;
        let b = y
            .iter()
            .zip(t)
            .map(|(a, c)| (a - my) * (c - mt))
            .sum::<f64>()
            / (vt * n);
        let rss: f64 = y
            .iter()
            .zip(t)
            .map(|(a, c)| (a - my - b * (c - mt)).powi(2))
            .sum();
        b / (rss / (n - 2.0) / (vt * n)).sqrt()
    }

    /// A channel of profile `seed % 3` with coefficient `per_b`·B per °C (B the flicker
    /// coefficient: the warm-up of 5 °C moves the rate by 5·`per_b`·B), and the temperature.
    fn coupled(seed: u64, per_b: f64, n: usize) -> (Vec<f64>, Vec<f64>, f64) {
        let c = profile(seed);
        let coef = per_b * c.b;
        let mut ch = channel(c);
        ch.temperature_coefficient = coef;
        let mut cols = run(ch, n, seed, Some(temperature()));
        let t = cols.pop().unwrap();
        (cols.pop().unwrap(), t, coef)
    }

    #[test]
    fn independent_slow_temperature_is_not_a_coupling() {
        let runs = 150;
        let (mut false_bic, mut naive) = (0, 0);
        for seed in 0..runs {
            let (y, t, _) = coupled(seed, 0.0, 200_000);
            let c = fit_coupling(&y, &t, FS, 0.6827).unwrap();
            false_bic += usize::from(c.delta_bic < 0.0);
            naive += usize::from(naive_t(&y, &t).abs() > 2.0);
        }
        let (rate, naive_rate) = (false_bic as f64 / runs as f64, naive as f64 / runs as f64);
        println!("coupling: false discoveries {rate:.3}, naive OLS |t|>2: {naive_rate:.3}");
        assert!(rate <= 0.03, "{rate}");
        assert!(naive_rate > 0.5, "{naive_rate}");
    }

    #[test]
    fn strong_coupling_is_recovered_and_removed() {
        // A warm-up drift of 200 B (40 °/h/°C on a 1 °/h gyro: a MEMS-typical sensitivity).
        for seed in 0..6 {
            let (mut y, t, coef) = coupled(seed, 40.0, 200_000);
            let c = fit_coupling(&y, &t, FS, 0.95).unwrap();
            println!(
                "coupling seed {seed}: {:.4e} [{:.4e}, {:.4e}] z {:.1} scale {} s ΔBIC {:.1} share {:.2}",
                c.coefficient, c.lo, c.hi, c.z, c.scale_s, c.delta_bic, c.explained_share
            );
            assert!(c.delta_bic < 0.0);
            assert!(c.lo <= coef && coef <= c.hi);
            assert!((c.coefficient / coef - 1.0).abs() < 0.10);
            remove_coupling(&mut y, &t, &c);
            assert!(fit_coupling(&y, &t, FS, 0.95).unwrap().delta_bic > 0.0);
        }
    }

    #[test]
    fn interval_coverage() {
        // Moderate coupling (a drift of 50 B, z ≈ 10); 200 seeds: binomial σ of the coverage
        // ≈ 3.3 %.
        let p = 0.6827;
        let runs = 200;
        let mut covered = 0;
        let mut rel = Vec::new();
        let mut zs = Vec::new();
        for seed in 0..runs {
            let (y, t, coef) = coupled(1000 + seed, 10.0, 200_000);
            let c = fit_coupling(&y, &t, FS, p).unwrap();
            covered += usize::from(c.lo <= coef && coef <= c.hi);
            rel.push(c.coefficient / coef - 1.0);
            zs.push(c.z);
        }
        let cov = covered as f64 / runs as f64;
        let (bias, var) = mean_var(&rel);
        let (mz, _) = mean_var(&zs);
        println!(
            "coupling coverage at p={p}: {cov:.3}; relative bias {bias:.4}, rms {:.4}, mean z {mz:.1}",
            var.sqrt()
        );
        assert!((cov - p).abs() < 0.09, "{cov}");
    }

    #[test]
    fn degenerate_inputs() {
        let t: Vec<f64> = (0..1000).map(|i| (i as f64 / 100.0).sin()).collect();
        assert!(fit_coupling(&[1.0; 1000], &[2.0; 1000], FS, 0.68).is_none());
        assert!(fit_coupling(&[1.0; 10], &t[..10], FS, 0.68).is_none());
        assert!(fit_coupling(&[1.0; 1000], &t[..999], FS, 0.68).is_none());
        let c = fit_coupling(&[1.0; 1000], &t, FS, 0.68).unwrap();
        assert_eq!(c.coefficient, 0.0);
        assert!(c.delta_bic > 0.0);
        let q: Vec<f64> = (0..1000).map(|i| ((i * 7919) % 13 / 12) as f64).collect();
        assert!(fit_coupling(&q, &t, FS, 0.68).unwrap().delta_bic > 0.0);
    }
}
