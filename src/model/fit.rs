//! The fitting engine shared by the Allan-variance and the spectrum fits: weighted non-negative
//! least squares of a linear model in the squared coefficients, with weights from the model.
//!
//! Each point i (an AV at τ_i, a spectrum band at f_i) is an estimate v_i of μ_i = Σ_j c_j·φ_j(x_i)
//! that is approximately μ_i·χ²_ν/ν, so Var(v_i) = 2μ_i²/ν_i. Weighting by the measured v_i
//! instead would favour points that came out low and bias every coefficient down (as least
//! squares on log values does); weighting by the model and iterating (iteratively reweighted least
//! squares) converges to the Gamma-likelihood (Whittle) estimate, which has no such bias. With
//! independent points that is the maximum-likelihood estimate; with a working correlation R
//! between points (Allan variances at neighbouring τ share data) each step is a generalised least
//! squares step with covariance C = D·R·D, D = diag(√(2/ν_i)·μ_i), a quasi-likelihood estimate.
//!
//! ν_i depends on which term dominates point i (the Allan EDF depends on the noise type): the
//! problem holds the EDF each term would give alone, and a mixture takes
//! 1/√ν = Σ_j s_j/√ν_j with s_j the share of term j in μ_i (exact for one term, conservative in
//! between: it is the bound for fully correlated contributions). The working correlation is mixed
//! the same way from one correlation function per term, R = Σ_j S_j·R_j·S_j with
//! S_j = diag(√s_ij), which is a valid correlation matrix whenever each R_j is.

use super::linalg::{cholesky, inverse_spd, solve_lower};
use super::nnls::nnls;

/// Number of base terms.
pub(crate) const TERMS: usize = 5;

/// A fitting problem in one domain.
#[derive(Debug, Clone)]
pub(crate) struct Problem {
    /// Measured values.
    pub value: Vec<f64>,
    /// `basis[i][j]`: contribution of term j to point i per unit squared coefficient.
    pub basis: Vec<[f64; TERMS]>,
    /// `edf[i][j]`: equivalent degrees of freedom of point i if term j were alone.
    pub edf: Vec<[f64; TERMS]>,
    /// Working correlation between points; `None`: independent.
    pub corr: Option<Correlation>,
}

/// Per-term correlation functions ρ_j(Δ) = a_j + (1 − a_j)·exp(−(|Δ|/ℓ_j)^κ_j) of the distance Δ
/// between points on some axis (log₂ τ for Allan variances). Positive definite for 0 ≤ a < 1 and
/// 0 < κ ≤ 2 (a constant plus a member of the stable family), so every mixture is a valid
/// correlation matrix.
#[derive(Debug, Clone)]
pub(crate) struct Correlation {
    pub position: Vec<f64>,
    pub floor: [f64; TERMS],
    pub length: [f64; TERMS],
    pub power: [f64; TERMS],
}

impl Correlation {
    /// The correlation matrix for term shares `share[i][j]` (rows summing to 1).
    fn matrix(&self, share: &[[f64; TERMS]]) -> Vec<Vec<f64>> {
        let n = self.position.len();
        let mut r = vec![vec![0.0; n]; n];
        for i in 0..n {
            r[i][i] = 1.0;
            for k in 0..i {
                let d = (self.position[i] - self.position[k]).abs();
                let v: f64 = (0..TERMS)
                    .map(|j| {
                        let a = self.floor[j];
                        let rho = a + (1.0 - a) * (-(d / self.length[j]).powf(self.power[j])).exp();
                        (share[i][j] * share[k][j]).sqrt() * rho
                    })
                    .sum();
                r[i][k] = v;
                r[k][i] = v;
            }
        }
        r
    }
}

/// A set of terms as a bit mask over [`Term::ALL`](super::Term::ALL).
pub(crate) type Mask = u8;

pub(crate) fn members(mask: Mask) -> Vec<usize> {
    (0..TERMS).filter(|&j| mask & (1 << j) != 0).collect()
}

/// The weights of one iteration: per-point standard deviations (diagonal of D) and the Cholesky
/// factor of the working correlation (`None`: independent points).
#[derive(Debug, Clone)]
pub(crate) struct Weights {
    pub sd: Vec<f64>,
    pub chol: Option<Vec<Vec<f64>>>,
}

/// One fitted subset.
#[derive(Debug, Clone)]
pub(crate) struct SubsetFit {
    /// Squared coefficients (0 outside the subset or where NNLS clamped them).
    pub c: [f64; TERMS],
    /// Model values at the points.
    pub mu: Vec<f64>,
    /// Generalised χ² = rᵀC⁻¹r with the weights the fit ended with.
    pub chi2: f64,
    /// Weights at the fitted model.
    pub weights: Weights,
}

impl Problem {
    pub fn len(&self) -> usize {
        self.value.len()
    }

    pub fn model(&self, c: &[f64; TERMS]) -> Vec<f64> {
        self.basis
            .iter()
            .map(|b| b.iter().zip(c).map(|(b, c)| b * c).sum())
            .collect()
    }

    /// Term shares of each point's model value; `None` where the model is zero there.
    fn shares(&self, c: &[f64; TERMS]) -> Vec<Option<[f64; TERMS]>> {
        self.basis
            .iter()
            .map(|b| {
                let total: f64 = (0..TERMS).map(|j| c[j] * b[j]).sum();
                (total > 0.0).then(|| std::array::from_fn(|j| c[j] * b[j] / total))
            })
            .collect()
    }

    /// Weights for model `c` (values `mu`): per-point standard deviation √(2/ν)·μ and the working
    /// correlation. μ is floored at 10⁻³ of the measurement so that a subset that misses a region
    /// entirely gets large but finite weights there.
    pub fn weights(&self, c: &[f64; TERMS], mu: &[f64]) -> Weights {
        let shares = self.shares(c);
        let sd = (0..self.len())
            .map(|i| {
                let m = mu[i].max(1e-3 * self.value[i].abs()).max(f64::MIN_POSITIVE);
                let inv_sqrt_nu = match shares[i] {
                    Some(s) => (0..TERMS)
                        .map(|j| s[j] / self.edf[i][j].sqrt())
                        .sum::<f64>(),
                    // No model here: the most pessimistic single-term EDF.
                    None => self.edf[i]
                        .iter()
                        .map(|e| 1.0 / e.sqrt())
                        .fold(0.0, f64::max),
                };
                m * 2f64.sqrt() * inv_sqrt_nu
            })
            .collect();
        let chol = self.corr.as_ref().and_then(|corr| {
            if shares.iter().any(Option::is_none) {
                return None;
            }
            let s: Vec<[f64; TERMS]> = shares.iter().map(|s| s.unwrap_or_default()).collect();
            positive_definite_factor(corr.matrix(&s))
        });
        Weights { sd, chol }
    }

    /// Weights from the measurements themselves, points independent: only a starting point for
    /// the iteration.
    pub fn initial_weights(&self) -> Weights {
        let sd = (0..self.len())
            .map(|i| {
                let worst = self.edf[i].iter().cloned().fold(f64::INFINITY, f64::min);
                self.value[i].abs().max(f64::MIN_POSITIVE) * (2.0 / worst).sqrt()
            })
            .collect();
        Weights { sd, chol: None }
    }

    /// C^(−1/2)·x with C = D·R·D.
    pub fn whiten(&self, w: &Weights, x: &[f64]) -> Vec<f64> {
        let y: Vec<f64> = x.iter().zip(&w.sd).map(|(x, s)| x / s).collect();
        match &w.chol {
            Some(l) => solve_lower(l, &y),
            None => y,
        }
    }

    /// Whitened basis columns of the terms in `idx`.
    fn columns(&self, w: &Weights, idx: &[usize]) -> Vec<Vec<f64>> {
        idx.iter()
            .map(|&j| {
                let col: Vec<f64> = self.basis.iter().map(|b| b[j]).collect();
                self.whiten(w, &col)
            })
            .collect()
    }

    /// Weighted NNLS of the subset `mask` with fixed weights `w`; returns the squared coefficients
    /// and the generalised χ² under those weights.
    pub fn solve(&self, mask: Mask, w: &Weights) -> ([f64; TERMS], f64) {
        let idx = members(mask);
        let cols = self.columns(w, &idx);
        let b = self.whiten(w, &self.value);
        let x = nnls(&cols, &b);
        let mut c = [0.0; TERMS];
        for (&j, &v) in idx.iter().zip(&x) {
            c[j] = v;
        }
        let r: Vec<f64> = self
            .value
            .iter()
            .zip(self.model(&c))
            .map(|(v, m)| v - m)
            .collect();
        let chi2 = self.whiten(w, &r).iter().map(|v| v * v).sum();
        (c, chi2)
    }

    /// Iteratively reweighted NNLS of subset `mask`: weights from the model of the previous step
    /// until the coefficients settle (relative change < 1e-9), at most 100 steps.
    pub fn irls(&self, mask: Mask) -> SubsetFit {
        let mut w = self.initial_weights();
        let mut c = [0.0; TERMS];
        for _ in 0..100 {
            let (next, _) = self.solve(mask, &w);
            let settled = next
                .iter()
                .zip(&c)
                .all(|(a, b)| (a - b).abs() <= 1e-9 * a.abs().max(b.abs()));
            c = next;
            let mu = self.model(&c);
            w = self.weights(&c, &mu);
            if settled {
                break;
            }
        }
        let mu = self.model(&c);
        let r: Vec<f64> = self.value.iter().zip(&mu).map(|(v, m)| v - m).collect();
        let chi2 = self.whiten(&w, &r).iter().map(|v| v * v).sum();
        SubsetFit {
            c,
            mu,
            chi2,
            weights: w,
        }
    }

    /// Covariance of the squared coefficients of `idx` (the inverse Fisher information
    /// (AᵀC⁻¹A)⁻¹ at weights `w`), or `None` if the columns are dependent.
    pub fn covariance(&self, w: &Weights, idx: &[usize]) -> Option<Vec<Vec<f64>>> {
        let cols = self.columns(w, idx);
        let fisher: Vec<Vec<f64>> = cols
            .iter()
            .map(|a| {
                cols.iter()
                    .map(|b| a.iter().zip(b).map(|(a, b)| a * b).sum())
                    .collect()
            })
            .collect();
        inverse_spd(&fisher)
    }
}

/// Cholesky factor of a correlation matrix. Rounding can make a mixture of nearly singular
/// correlation matrices (points very close on the axis) indefinite; the off-diagonal part is then
/// shrunk towards the identity until it factors.
fn positive_definite_factor(mut r: Vec<Vec<f64>>) -> Option<Vec<Vec<f64>>> {
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

    /// Points that are exactly a model: IRLS returns it, with χ² = 0.
    #[test]
    fn exact_data_is_reproduced() {
        let taus: Vec<f64> = (0..12).map(|k| 2f64.powi(k) * 0.01).collect();
        let truth = [0.0, 4e-6, 1e-8, 1e-10, 0.0];
        let basis: Vec<[f64; TERMS]> = taus
            .iter()
            .map(|&t| {
                let mut b = [0.0; TERMS];
                for (j, term) in super::super::Term::ALL.iter().enumerate() {
                    b[j] = term.avar_unit(t);
                }
                b
            })
            .collect();
        let p = Problem {
            value: basis
                .iter()
                .map(|b| b.iter().zip(&truth).map(|(b, c)| b * c).sum())
                .collect(),
            basis,
            edf: vec![[100.0; TERMS]; 12],
            corr: None,
        };
        let fit = p.irls(0b11111);
        for j in 0..TERMS {
            assert!(
                (fit.c[j] - truth[j]).abs() <= 1e-9 * truth[j].max(1e-20),
                "{j}: {:?}",
                fit.c
            );
        }
        assert!(fit.chi2 < 1e-12);
    }
}
