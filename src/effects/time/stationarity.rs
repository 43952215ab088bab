//! Split-record stationarity test: do the parts of a record have the same Allan deviation?
//!
//! The IEEE noise is not stationary in the strict sense (a random walk's variance grows), but its
//! Allan variance is the same in every stretch of the record: that is what the base model
//! assumes, and what a changed operating state (a noise level that doubles, a resonance that
//! appears) breaks. Each of `parts` equal parts gets its overlapping Allan variance at octave τ up
//! to a tenth of the part (so every estimate rests on ≥ ≈ 10 terms), with Greenhall–Riley EDF
//! ν_j from [`crate::avar::compute`]. At each τ, Bartlett's test of equal variances for
//! estimates σ̂²_j ~ σ²·χ²_{ν_j}/ν_j:
//! M = Σν_j·ln(σ̄²/σ̂²_j), σ̄² = Σν_jσ̂²_j/Σν_j, divided by
//! C = 1 + (Σ1/ν_j − 1/Σν_j)/(3(k − 1)), is χ²_{k−1}. The smallest p-value over the τ is
//! multiplied by their number (Bonferroni: the τ are positively correlated, so this is
//! conservative) and the record is declared non-stationary when the result is below
//! [`FAMILY_FALSE_ALARM`].

use rayon::prelude::*;

use crate::avar::{compute, Confidence, Statistic, TauGrid};

use super::stats::{chi2_sf, norm_isf};

/// Family-wise false-alarm probability over the τ tested, on stationary data.
pub const FAMILY_FALSE_ALARM: f64 = 0.01;
/// Largest τ: part length over this.
const MIN_TERMS: usize = 10;

/// Per-part Allan deviations and the homogeneity test.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct SplitRecord {
    pub parts: usize,
    pub tau_s: Vec<f64>,
    /// `deviation[j][i]`: part j at `tau_s[i]`, with its interval at the requested probability.
    pub deviation: Vec<Vec<f64>>,
    pub deviation_lo: Vec<Vec<f64>>,
    pub deviation_hi: Vec<Vec<f64>>,
    /// Per τ: p-value of "all parts agree".
    pub p_values: Vec<f64>,
    /// Smallest p-value times the number of τ (capped at 1).
    pub p_value: f64,
    /// Normal-equivalent z of the smallest per-τ p-value, and where it is.
    pub max_z: f64,
    pub worst_tau_s: f64,
    pub stationary: bool,
}

/// Splits `y` into `parts` equal parts (the remainder dropped) and compares their Allan
/// deviations. `None` for fewer than 2 parts, parts shorter than 64 samples, or `p` outside (0, 1).
pub fn split_record(y: &[f64], rate_hz: f64, parts: usize, p: f64) -> Option<SplitRecord> {
    if parts < 2 || !(rate_hz > 0.0) {
        return None;
    }
    let len = y.len() / parts;
    if len < 64 {
        return None;
    }
    let ms: Vec<u64> = (0..)
        .map(|k| 1u64 << k)
        .take_while(|&m| m as usize * MIN_TERMS <= len)
        .collect();
    // The parts are independent: computed in parallel (this runs once the loop has ended, when
    // the channel's other core may be idle).
    let devs = (0..parts)
        .into_par_iter()
        .map(|j| {
            compute(
                &y[j * len..(j + 1) * len],
                rate_hz,
                &TauGrid::Explicit(ms.clone()),
                Statistic::Oadev,
                Confidence::Level(p),
            )
            .ok()
        })
        .collect::<Option<Vec<_>>>()?;
    let nt = devs.iter().map(|d| d.len()).min()?;
    if nt == 0 {
        return None;
    }
    let k = parts as f64;
    let p_values: Vec<f64> = (0..nt)
        .map(|i| {
            let v: Vec<f64> = devs.iter().map(|d| d.variance[i]).collect();
            let nu: Vec<f64> = devs.iter().map(|d| d.edf[i]).collect();
            if v.iter().all(|x| *x == 0.0) {
                return 1.0;
            }
            if v.iter().any(|x| *x == 0.0) || nu.iter().any(|x| !(x.is_finite() && *x > 0.0)) {
                return if v.iter().any(|x| *x == 0.0) {
                    0.0
                } else {
                    1.0
                };
            }
            let sum_nu: f64 = nu.iter().sum();
            let pooled = v.iter().zip(&nu).map(|(a, b)| a * b).sum::<f64>() / sum_nu;
            let m: f64 = v.iter().zip(&nu).map(|(a, b)| b * (pooled / a).ln()).sum();
            let c =
                1.0 + (nu.iter().map(|x| 1.0 / x).sum::<f64>() - 1.0 / sum_nu) / (3.0 * (k - 1.0));
            chi2_sf(m / c, k - 1.0)
        })
        .collect();
    let (worst, p_min) = p_values
        .iter()
        .copied()
        .enumerate()
        .min_by(|a, b| a.1.total_cmp(&b.1))?;
    let p_value = (p_min * nt as f64).min(1.0);
    Some(SplitRecord {
        parts,
        tau_s: devs[0].tau_s[..nt].to_vec(),
        deviation: devs.iter().map(|d| d.deviation()[..nt].to_vec()).collect(),
        deviation_lo: devs
            .iter()
            .map(|d| d.deviation_lo()[..nt].to_vec())
            .collect(),
        deviation_hi: devs
            .iter()
            .map(|d| d.deviation_hi()[..nt].to_vec())
            .collect(),
        max_z: norm_isf(p_min.clamp(1e-300, 0.5)),
        worst_tau_s: devs[0].tau_s[worst],
        p_values,
        p_value,
        stationary: p_value >= FAMILY_FALSE_ALARM,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::effects::time::testutil::*;

    #[test]
    fn ieee_noise_is_stationary() {
        let runs = 150;
        let mut alarms = 0;
        for seed in 0..runs {
            let y = noise(200_000, seed);
            let parts = 2 + (seed as usize / 3) % 3;
            let s = split_record(&y, FS, parts, 0.68).unwrap();
            alarms += usize::from(!s.stationary);
        }
        let rate = alarms as f64 / runs as f64;
        println!("split record: false alarms {rate:.3}");
        assert!(rate <= 0.03, "{rate}");
    }

    #[test]
    fn doubled_white_noise_is_flagged() {
        for seed in 0..6 {
            let c = profile(seed);
            let mut a = run(channel(c), 100_000, seed, None).remove(0);
            let loud = crate::model::Coefficients { n: 2.0 * c.n, ..c };
            let b = run(channel(loud), 100_000, seed + 100, None).remove(0);
            let off = a[a.len() - 1] - b[0];
            a.extend(b.iter().map(|v| v + off));
            let s = split_record(&a, FS, 2, 0.68).unwrap();
            println!(
                "split record seed {seed}: p {:.2e} z {:.1} worst τ {} s",
                s.p_value, s.max_z, s.worst_tau_s
            );
            assert!(!s.stationary);
            let ratio = s.deviation[1][0] / s.deviation[0][0];
            assert!(ratio > 1.3, "{ratio}");
        }
    }

    #[test]
    fn degenerate_inputs() {
        assert!(split_record(&[], FS, 2, 0.68).is_none());
        assert!(split_record(&[1.0; 100], FS, 2, 0.68).is_none());
        assert!(split_record(&[1.0; 1000], FS, 1, 0.68).is_none());
        if let Some(s) = split_record(&[1.0; 1000], FS, 2, 0.68) {
            assert!(s.stationary);
        }
    }
}
