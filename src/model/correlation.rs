//! Working correlations between the points of a fit: Allan variances at neighbouring τ share
//! samples, spectrum bands share leakage; a fit that treated them as independent would count the
//! same evidence several times and give intervals that are too narrow.

use std::sync::Arc;

use super::linalg::cholesky;
use super::terms::TERMS;

/// The working correlation between points.
#[derive(Debug, Clone)]
pub(crate) enum Correlation {
    /// The same for every model (spectrum bands: set by the window and the segment layout), held
    /// as its Cholesky factor, shared with every iteration's weights (not copied into each).
    Fixed(Arc<Vec<Vec<f64>>>),
    /// One correlation matrix per term (Allan variances: the correlation depends on the noise
    /// type), mixed per point by the terms' shares.
    PerTerm(Vec<Vec<Vec<f64>>>),
}

impl Correlation {
    /// Per-term correlation functions ρ_j(Δ) = a_j + (1 − a_j)·exp(−(|Δ|/ℓ_j)^κ_j) of the distance
    /// Δ between points at `position` on some axis (log₂ τ for Allan variances), with parameters
    /// (a_j, ℓ_j, κ_j). Positive definite for 0 ≤ a < 1 and 0 < κ ≤ 2 (a constant plus a member
    /// of the stable family), so every mixture is a valid correlation matrix. Built once; each
    /// iteration only mixes them.
    pub fn per_term(position: &[f64], params: [(f64, f64, f64); TERMS]) -> Correlation {
        let per_term = params
            .iter()
            .map(|&(a, l, k)| {
                position
                    .iter()
                    .map(|&p| {
                        position
                            .iter()
                            .map(|&q| a + (1.0 - a) * (-((p - q).abs() / l).powf(k)).exp())
                            .collect()
                    })
                    .collect()
            })
            .collect();
        Correlation::PerTerm(per_term)
    }

    /// A fixed correlation matrix; `None` if it is not positive definite.
    pub fn fixed(r: Vec<Vec<f64>>) -> Option<Correlation> {
        positive_definite_factor(r).map(|l| Correlation::Fixed(Arc::new(l)))
    }

    /// The per-term correlations mixed with weights `share[i][j]` (rows summing to 1).
    pub(crate) fn mix(per_term: &[Vec<Vec<f64>>], share: &[[f64; TERMS]]) -> Vec<Vec<f64>> {
        let n = share.len();
        // √(s_ij·s_kj) as √s_ij·√s_kj: the roots once per point, not once per pair and term (the
        // mixing runs at every reweighting of every fit).
        let root: Vec<[f64; TERMS]> = share.iter().map(|s| s.map(f64::sqrt)).collect();
        let mut r = vec![vec![0.0; n]; n];
        for i in 0..n {
            r[i][i] = 1.0;
            for k in 0..i {
                let v: f64 = (0..TERMS)
                    .map(|j| root[i][j] * root[k][j] * per_term[j][i][k])
                    .sum();
                r[i][k] = v;
                r[k][i] = v;
            }
        }
        r
    }
}

/// Cholesky factor of a correlation matrix. Rounding can make a mixture of nearly singular
/// correlation matrices (points very close on the axis) indefinite; the off-diagonal part is then
/// shrunk towards the identity until it factors.
pub(crate) fn positive_definite_factor(mut r: Vec<Vec<f64>>) -> Option<Vec<Vec<f64>>> {
    for _ in 0..50 {
        if let Some(l) = cholesky(&r) {
            return Some(l);
        }
        let n = r.len();
        for (i, row) in r.iter_mut().enumerate() {
            for (k, v) in row.iter_mut().enumerate().take(n) {
                if i != k {
                    *v *= 0.9;
                }
            }
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mixtures_of_per_term_correlations_are_correlation_matrices() {
        // Octave positions, the Allan-variance parameters, shares that change along the axis.
        let pos: Vec<f64> = (0..12).map(f64::from).collect();
        let params = [
            (0.5, 0.5, 1.5),
            (0.0, 1.46, 1.25),
            (0.0, 1.87, 1.52),
            (0.0, 3.89, 1.55),
            (0.0, 3.89, 1.55),
            (0.0, 1.46, 1.25),
        ];
        let Correlation::PerTerm(per_term) = Correlation::per_term(&pos, params) else {
            unreachable!()
        };
        let share: Vec<[f64; TERMS]> = (0..12)
            .map(|i| {
                let t = f64::from(i) / 11.0;
                [
                    0.1 * (1.0 - t),
                    0.8 * (1.0 - t),
                    0.1,
                    0.9 * t,
                    0.1 * t,
                    0.05,
                ]
            })
            .map(|s: [f64; TERMS]| {
                let sum: f64 = s.iter().sum();
                s.map(|v| v / sum)
            })
            .collect();
        let r = Correlation::mix(&per_term, &share);
        for (i, row) in r.iter().enumerate() {
            assert_eq!(row[i], 1.0);
            for (k, v) in row.iter().enumerate() {
                assert!(v.abs() <= 1.0 + 1e-12 && (v - r[k][i]).abs() < 1e-15);
            }
        }
        assert!(cholesky(&r).is_some(), "positive definite");
        // Neighbours one octave apart, white-dominated: ≈ the white-noise value 0.54.
        assert!((r[0][1] - 0.5).abs() < 0.1, "{}", r[0][1]);
    }
}
