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
//! between: it is the bound for fully correlated contributions); see [`Problem::weights`]. The
//! working correlation is mixed from one correlation function per term, R = Σ_j S_j·R_j·S_j with
//! S_j = diag(√w_ij), w_ij the term's share of the point's standard deviation, which is a valid
//! correlation matrix whenever each R_j is.

use std::sync::Arc;

use super::correlation::{positive_definite_factor, Correlation};
use super::linalg::{inverse_spd, solve_lower, solve_lower_in_place};
use super::nnls::nnls;
use super::Term;

pub(crate) use super::terms::{BASE, EFFECT, TERMS};

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
    /// `cross[i]`: variance of point i from the product of a deterministic term (infinite EDF)
    /// and the random ones, per unit μ_det·μ_random (see `avar_fit.rs`); empty: none.
    pub cross: Vec<f64>,
}

/// A set of terms as a bit mask over [`Term::ALL`](super::Term::ALL).
pub(crate) type Mask = u8;

pub(crate) fn members(mask: Mask) -> Vec<usize> {
    (0..TERMS).filter(|&j| mask & (1 << j) != 0).collect()
}

/// The weights of one iteration: per-point EDF ν and standard deviation √(2/ν)·μ (diagonal of
/// D), and the Cholesky factor of the working correlation (`None`: independent points).
#[derive(Debug, Clone)]
pub(crate) struct Weights {
    pub nu: Vec<f64>,
    pub sd: Vec<f64>,
    pub chol: Option<Arc<Vec<Vec<f64>>>>,
}

/// One fitted subset.
#[derive(Debug, Clone)]
pub(crate) struct SubsetFit {
    /// Squared coefficients (0 outside the subset or where NNLS clamped them).
    pub c: [f64; TERMS],
    /// Model values at the points.
    pub mu: Vec<f64>,
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

    /// Weights for model `c` (values `mu`): per-point EDF, standard deviation √(2/ν)·μ and the
    /// working correlation. μ is floored at 10⁻³ of the measurement so that a subset that misses a
    /// region entirely gets large but finite weights there.
    ///
    /// Each term j contributes σ_ij = c_j·φ_ij·√(2/ν_ij) to point i's standard deviation and the
    /// contributions add (the fully correlated bound): σ_i = Σ_j σ_ij, so 1/√ν_i = Σ_j s_ij/√ν_ij
    /// with s_ij the term's share of μ_i. A deterministic term (ν = ∞: a ramp) adds to μ but
    /// nothing to σ. The per-term correlations are mixed with weights σ_ij/σ_i.
    pub fn weights(&self, c: &[f64; TERMS], mu: &[f64]) -> Weights {
        /// EDF cap: a point explained by deterministic terms alone is exact but for rounding.
        const NU_MAX: f64 = 1e12;
        let mut mix: Vec<Option<[f64; TERMS]>> = Vec::with_capacity(self.len());
        let nu: Vec<f64> = (0..self.len())
            .map(|i| {
                let part: [f64; TERMS] = std::array::from_fn(|j| c[j] * self.basis[i][j]);
                let total: f64 = part.iter().sum();
                if total.is_nan() || total <= 0.0 {
                    // No model here: the most pessimistic single-term EDF.
                    mix.push(None);
                    return self.edf[i].iter().cloned().fold(f64::INFINITY, f64::min);
                }
                let mut sigma: [f64; TERMS] =
                    std::array::from_fn(|j| part[j] * (2.0 / self.edf[i][j]).sqrt());
                let random: f64 = (0..TERMS)
                    .filter(|&j| self.edf[i][j].is_finite())
                    .map(|j| part[j])
                    .sum();
                let det = total - random;
                let cross = self.cross.get(i).copied().unwrap_or(0.0) * det * random;
                let sum: f64 = sigma.iter().sum();
                let sd = (sum * sum + cross).sqrt();
                if cross > 0.0 {
                    // The cross variance follows the record's ends at every τ: long-range
                    // correlated, as a random walk's is. Its share goes with that term's.
                    sigma[Term::RateRandomWalk.index()] += sd - sum;
                }
                mix.push((sd > 0.0).then(|| sigma.map(|v| v / sd)));
                // sd/μ = √2/√ν.
                (2.0 * total * total / (sd * sd)).min(NU_MAX)
            })
            .collect();
        let sd = (0..self.len())
            .map(|i| self.floored(mu[i], i) * (2.0 / nu[i]).sqrt())
            .collect();
        let chol = match &self.corr {
            None => None,
            Some(Correlation::Fixed(l)) => Some(Arc::clone(l)),
            // Where nothing random is modelled there is nothing to mix by: independence.
            Some(Correlation::PerTerm(_)) if mix.iter().any(Option::is_none) => None,
            Some(Correlation::PerTerm(per_term)) => {
                let s: Vec<[f64; TERMS]> = mix.iter().map(|s| s.unwrap_or_default()).collect();
                positive_definite_factor(Correlation::mix(per_term, &s)).map(Arc::new)
            }
        };
        Weights { nu, sd, chol }
    }

    /// The problem restricted to the points `keep` (ascending), with their correlation.
    pub fn subset(&self, keep: &[usize]) -> Problem {
        let pick = |m: &Vec<Vec<f64>>| -> Vec<Vec<f64>> {
            keep.iter()
                .map(|&i| keep.iter().map(|&k| m[i][k]).collect())
                .collect()
        };
        let corr = match &self.corr {
            None => None,
            Some(Correlation::Fixed(l)) => {
                // R = L·Lᵀ, restricted, refactored.
                let r: Vec<Vec<f64>> = keep
                    .iter()
                    .map(|&i| {
                        keep.iter()
                            .map(|&k| (0..=i.min(k)).map(|j| l[i][j] * l[k][j]).sum())
                            .collect()
                    })
                    .collect();
                Correlation::fixed(r)
            }
            Some(Correlation::PerTerm(per_term)) => {
                Some(Correlation::PerTerm(per_term.iter().map(pick).collect()))
            }
        };
        Problem {
            value: keep.iter().map(|&i| self.value[i]).collect(),
            basis: keep.iter().map(|&i| self.basis[i]).collect(),
            edf: keep.iter().map(|&i| self.edf[i]).collect(),
            corr,
            cross: if self.cross.is_empty() {
                Vec::new()
            } else {
                keep.iter().map(|&i| self.cross[i]).collect()
            },
        }
    }

    /// The model value at point i, floored at 10⁻³ of the measurement.
    fn floored(&self, mu: f64, i: usize) -> f64 {
        mu.max(1e-3 * self.value[i].abs()).max(f64::MIN_POSITIVE)
    }

    /// Weights from the measurements themselves, points independent: only a starting point for
    /// the iteration.
    pub fn initial_weights(&self) -> Weights {
        let nu: Vec<f64> = self
            .edf
            .iter()
            .map(|e| e.iter().cloned().fold(f64::INFINITY, f64::min).min(1e12))
            .collect();
        let sd = (0..self.len())
            .map(|i| self.value[i].abs().max(f64::MIN_POSITIVE) * (2.0 / nu[i]).sqrt())
            .collect();
        Weights { nu, sd, chol: None }
    }

    /// Goodness of `fit` on the Wilson–Hilferty scale: each point's
    /// z_i = ((v_i/μ_i)^(1/3) − (1 − 2/(9ν_i)))/√(2/(9ν_i)), which is close to standard normal
    /// for a μ·χ²_ν/ν variable even at ν = 1–2, where (v − μ)/sd is badly skewed. Returns the
    /// per-point z, the whitened χ² = zᵀR⁻¹z and −2·log-likelihood (up to a constant that is the
    /// same for every model of these data): χ² + ln det R + Σ [ln(2/(9ν_i)) + (2/3)·ln μ_i], the
    /// last terms from the Jacobian of the transform.
    ///
    /// Comparing models by this likelihood rather than by a least-squares χ² with fixed weights
    /// matters where points have few degrees of freedom (the longest τ): a point measured at 5×
    /// a model's value is a 10σ outlier for that model but only 1σ from a model that predicts it,
    /// if both use the latter's weights.
    pub fn likelihood(&self, fit: &SubsetFit) -> (Vec<f64>, f64, f64) {
        let w = &fit.weights;
        let mut log_terms = 0.0;
        let z: Vec<f64> = (0..self.len())
            .map(|i| {
                let nu = w.nu[i];
                let mu = self.floored(fit.mu[i], i);
                let s2 = 2.0 / (9.0 * nu);
                log_terms += s2.ln() + (2.0 / 3.0) * mu.ln();
                ((self.value[i] / mu).cbrt() - (1.0 - s2)) / s2.sqrt()
            })
            .collect();
        let (chi2, log_det) = match &w.chol {
            Some(l) => {
                let white = solve_lower(l, &z);
                let log_det = 2.0 * (0..l.len()).map(|i| l[i][i].ln()).sum::<f64>();
                (white.iter().map(|v| v * v).sum(), log_det)
            }
            None => (z.iter().map(|v| v * v).sum(), 0.0),
        };
        (z, chi2, chi2 + log_det + log_terms)
    }

    /// C^(−1/2)·x with C = D·R·D for every x of `xs`, in one pass over the factor.
    fn whiten_all(&self, w: &Weights, mut xs: Vec<Vec<f64>>) -> Vec<Vec<f64>> {
        for x in &mut xs {
            for (v, s) in x.iter_mut().zip(&w.sd) {
                *v /= s;
            }
        }
        if let Some(l) = &w.chol {
            solve_lower_in_place(l, &mut xs);
        }
        xs
    }

    /// The basis columns of the terms in `idx`, unwhitened.
    fn raw_columns(&self, idx: &[usize]) -> Vec<Vec<f64>> {
        idx.iter()
            .map(|&j| self.basis.iter().map(|b| b[j]).collect())
            .collect()
    }

    /// Whitened basis columns of the terms in `idx`.
    fn columns(&self, w: &Weights, idx: &[usize]) -> Vec<Vec<f64>> {
        self.whiten_all(w, self.raw_columns(idx))
    }

    /// Weighted NNLS of the subset `mask` with fixed weights `w`: the squared coefficients.
    pub fn solve(&self, mask: Mask, w: &Weights) -> [f64; TERMS] {
        let idx = members(mask);
        // The columns and the data whitened together.
        let mut cols = self.raw_columns(&idx);
        cols.push(self.value.clone());
        let mut cols = self.whiten_all(w, cols);
        let b = cols.pop().expect("the data was pushed");
        let x = nnls(&cols, &b);
        let mut c = [0.0; TERMS];
        for (&j, &v) in idx.iter().zip(&x) {
            c[j] = v;
        }
        c
    }

    /// Iteratively reweighted NNLS of subset `mask`: weights from the model of the previous step
    /// until the coefficients settle (relative change < 1e-6, a thousandth of the narrowest
    /// interval the fits report), at most 100 steps.
    pub fn irls(&self, mask: Mask) -> SubsetFit {
        self.reweighted(mask, 1e-6, false)
    }

    /// [`Problem::irls`] until the coefficients' relative change is below `tolerance` (a search
    /// that only ranks many trials settles for less than the fit it reports), extrapolating where
    /// the steps shrink geometrically: once two successive changes keep one ratio r (0 < r < 0.9,
    /// a least-squares ratio with each coefficient's change taken relative to the coefficient),
    /// the iteration jumps by the rest of the geometric series, r/(1 − r) times the last change
    /// (negative coefficients clipped to 0), and goes on from there (Aitken's Δ² for a vector).
    /// Only the point it starts from changes, not the fixed point it stops at, but the stop (two
    /// steps within the tolerance) comes at another iterate: for searches that only rank trials. A trial filter whose white noise gives way to the floor halved the white
    /// coefficient at every step for 20–40 steps.
    pub fn irls_accelerated(&self, mask: Mask, tolerance: f64) -> SubsetFit {
        self.reweighted(mask, tolerance, true)
    }

    fn reweighted(&self, mask: Mask, tolerance: f64, accelerate: bool) -> SubsetFit {
        let mut w = self.initial_weights();
        let mut c = [0.0; TERMS];
        let mut last_change: Option<[f64; TERMS]> = None;
        for _ in 0..100 {
            let mut next = self.solve(mask, &w);
            let settled = next
                .iter()
                .zip(&c)
                .all(|(a, b)| (a - b).abs() <= tolerance * a.abs().max(b.abs()));
            if accelerate && !settled {
                let change: [f64; TERMS] = std::array::from_fn(|j| next[j] - c[j]);
                if let Some(before) = last_change.replace(change) {
                    let (mut num, mut den) = (0.0, 0.0);
                    for j in 0..TERMS {
                        let scale = next[j].abs().max(c[j].abs());
                        if scale > 0.0 {
                            num += change[j] * before[j] / (scale * scale);
                            den += before[j] * before[j] / (scale * scale);
                        }
                    }
                    let r = num / den;
                    if den > 0.0 && r > 0.0 && r < 0.9 {
                        let jump = r / (1.0 - r);
                        for j in 0..TERMS {
                            next[j] = (next[j] + jump * change[j]).max(0.0);
                        }
                        last_change = None;
                    }
                }
            }
            c = next;
            let mu = self.model(&c);
            w = self.weights(&c, &mu);
            if settled {
                break;
            }
        }
        SubsetFit {
            c,
            mu: self.model(&c),
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

#[cfg(test)]
mod tests {
    use super::*;

    /// The extrapolated iteration stops at the fixed point the plain one reaches: on a trial
    /// like the filter search's worst (a low-pass that cuts the white noise far below where the
    /// data fall, beside an unfiltered floor that takes its place), the coefficients agree within
    /// the ranking tolerance's reach and the likelihoods within a thousandth of a unit.
    #[test]
    fn extrapolation_keeps_the_fixed_point() {
        let freqs: Vec<f64> = (0..40).map(|k| 0.1 * 10f64.powf(k as f64 / 13.0)).collect();
        let effect = super::super::terms::EFFECT;
        let basis: Vec<[f64; TERMS]> = freqs
            .iter()
            .map(|&f| {
                let mut b = [0.0; TERMS];
                b[1] = 1.0 / (1.0 + (f / 5.0).powi(8));
                b[effect] = 1.0;
                b
            })
            .collect();
        let value = freqs
            .iter()
            .enumerate()
            .map(|(i, &f)| 1e-6 / (1.0 + (f / 40.0).powi(4)) * (1.0 + 0.2 * (i as f64).sin()))
            .collect();
        let p = Problem {
            value,
            basis,
            edf: vec![[20.0; TERMS]; freqs.len()],
            corr: None,
            cross: Vec::new(),
        };
        let mask = (1 << 1) | (1 << effect);
        let plain = p.irls(mask);
        let fast = p.irls_accelerated(mask, 1e-3);
        let largest = plain.c.iter().cloned().fold(0.0, f64::max);
        for j in 0..TERMS {
            assert!(
                (plain.c[j] - fast.c[j]).abs() <= 1e-2 * largest,
                "{:?} vs {:?}",
                plain.c,
                fast.c
            );
        }
        let (_, _, ll_plain) = p.likelihood(&plain);
        let (_, _, ll_fast) = p.likelihood(&fast);
        assert!((ll_plain - ll_fast).abs() < 1e-3, "{ll_plain} vs {ll_fast}");
    }

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
            cross: Vec::new(),
        };
        let fit = p.irls(0b11111);
        for (got, want) in fit.c.iter().zip(&truth) {
            assert!((got - want).abs() <= 1e-9 * want.max(1e-20), "{:?}", fit.c);
        }
    }
}
