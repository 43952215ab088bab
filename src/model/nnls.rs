//! Non-negative least squares, Lawson & Hanson (*Solving Least Squares Problems*, 1974, ch. 23).
//!
//! The squared noise coefficients cannot be negative, and an unconstrained fit makes them so
//! whenever a term is absent or weak (a negative Q² where white noise dominates): the active-set
//! method keeps them at zero instead and is exact for the handful of unknowns here. The columns are
//! scaled to unit norm first, since AV basis columns differ by twenty orders of magnitude.

use super::linalg::lstsq;

/// Solution of min ‖A·x − b‖ subject to x ≥ 0, with A given by its columns.
///
/// Returns x; entries outside the final passive set are exactly 0. Dependent columns in the
/// passive set are dropped from it (their coefficient stays 0).
pub fn nnls(cols: &[Vec<f64>], b: &[f64]) -> Vec<f64> {
    let p = cols.len();
    let norms: Vec<f64> = cols
        .iter()
        .map(|c| c.iter().map(|v| v * v).sum::<f64>().sqrt())
        .collect();
    let scaled: Vec<Vec<f64>> = cols
        .iter()
        .zip(&norms)
        .map(|(c, &s)| {
            if s > 0.0 {
                c.iter().map(|v| v / s).collect()
            } else {
                c.clone()
            }
        })
        .collect();
    let bnorm = b.iter().map(|v| v * v).sum::<f64>().sqrt();
    let tol = 1e-12 * bnorm.max(f64::MIN_POSITIVE);
    let mut x = vec![0.0; p];
    let mut passive = vec![false; p];
    let usable: Vec<bool> = norms.iter().map(|&s| s > 0.0 && s.is_finite()).collect();
    let gradient = |x: &[f64]| -> Vec<f64> {
        let r: Vec<f64> = (0..b.len())
            .map(|i| b[i] - (0..p).map(|j| scaled[j][i] * x[j]).sum::<f64>())
            .collect();
        scaled
            .iter()
            .map(|c| c.iter().zip(&r).map(|(a, r)| a * r).sum())
            .collect()
    };
    for _outer in 0..3 * p + 3 {
        let w = gradient(&x);
        let candidate = (0..p)
            .filter(|&j| !passive[j] && usable[j] && w[j] > tol)
            .max_by(|&a, &b| w[a].total_cmp(&w[b]));
        let Some(t) = candidate else { break };
        passive[t] = true;
        for _inner in 0..3 * p + 3 {
            let idx: Vec<usize> = (0..p).filter(|&j| passive[j]).collect();
            let sub: Vec<Vec<f64>> = idx.iter().map(|&j| scaled[j].clone()).collect();
            let Some(z) = lstsq(&sub, b) else {
                // The entering column depends on the passive ones: it cannot improve the fit.
                passive[t] = false;
                x[t] = 0.0;
                break;
            };
            if z.iter().all(|&v| v > 0.0) {
                for (&j, &v) in idx.iter().zip(&z) {
                    x[j] = v;
                }
                break;
            }
            // Step from x towards z until the first passive coefficient reaches zero; that one
            // (and any other that got there) leaves the passive set.
            let (mut alpha, mut first) = (f64::INFINITY, idx[0]);
            for (&j, &v) in idx.iter().zip(&z) {
                if v <= 0.0 {
                    let a = x[j] / (x[j] - v);
                    if a < alpha {
                        (alpha, first) = (a, j);
                    }
                }
            }
            for (&j, &v) in idx.iter().zip(&z) {
                x[j] += alpha * (v - x[j]);
            }
            x[first] = 0.0;
            for &j in &idx {
                if x[j] <= 0.0 {
                    x[j] = 0.0;
                    passive[j] = false;
                }
            }
        }
    }
    x.iter()
        .zip(&norms)
        .map(|(&v, &s)| if s > 0.0 && v > 0.0 { v / s } else { 0.0 })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn residual(cols: &[Vec<f64>], b: &[f64], x: &[f64]) -> f64 {
        (0..b.len())
            .map(|i| {
                let r = b[i] - (0..x.len()).map(|j| cols[j][i] * x[j]).sum::<f64>();
                r * r
            })
            .sum()
    }

    #[test]
    fn unconstrained_optimum_is_kept_when_positive() {
        let t: Vec<f64> = (1..=8).map(f64::from).collect();
        let cols = vec![vec![1.0; 8], t.clone()];
        let b: Vec<f64> = t.iter().map(|x| 1.0 + 2.0 * x).collect();
        let x = nnls(&cols, &b);
        assert!(
            (x[0] - 1.0).abs() < 1e-12 && (x[1] - 2.0).abs() < 1e-12,
            "{x:?}"
        );
    }

    #[test]
    fn negative_coefficient_is_clamped_and_the_rest_refitted() {
        // b = 3 − 0.5 t: the slope wants to be negative; NNLS keeps it 0 and fits the mean.
        let t: Vec<f64> = (1..=8).map(f64::from).collect();
        let cols = vec![vec![1.0; 8], t.clone()];
        let b: Vec<f64> = t.iter().map(|x| 3.0 - 0.5 * x).collect();
        let x = nnls(&cols, &b);
        let mean = b.iter().sum::<f64>() / 8.0;
        assert_eq!(x[1], 0.0);
        assert!((x[0] - mean).abs() < 1e-12, "{x:?}");
    }

    #[test]
    fn kkt_conditions_hold_on_random_problems() {
        // Optimality of x ≥ 0: gradient Aᵀ(b − Ax) is ≤ 0 where x = 0 and ≈ 0 where x > 0; and no
        // small feasible perturbation lowers the residual.
        let mut state = 12345u64;
        let mut rnd = || crate::sim::rng::splitmix64(&mut state) as f64 / u64::MAX as f64 - 0.5;
        for _ in 0..200 {
            let cols: Vec<Vec<f64>> = (0..4).map(|_| (0..12).map(|_| rnd()).collect()).collect();
            let b: Vec<f64> = (0..12).map(|_| rnd()).collect();
            let x = nnls(&cols, &b);
            let r: Vec<f64> = (0..12)
                .map(|i| b[i] - (0..4).map(|j| cols[j][i] * x[j]).sum::<f64>())
                .collect();
            for j in 0..4 {
                let g: f64 = cols[j].iter().zip(&r).map(|(a, r)| a * r).sum();
                assert!(x[j] >= 0.0);
                if x[j] > 0.0 {
                    assert!(g.abs() < 1e-10, "gradient {g} at active {j}");
                } else {
                    assert!(g < 1e-10, "gradient {g} at zero {j}");
                }
            }
            let f0 = residual(&cols, &b, &x);
            for j in 0..4 {
                let mut y = x.clone();
                y[j] += 1e-4;
                assert!(residual(&cols, &b, &y) >= f0 - 1e-15);
            }
        }
    }
}
