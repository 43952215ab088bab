//! Regression of a channel on a slow regressor (an aux channel such as temperature, or a drift
//! shape) with the noise covariance the fitted IEEE model predicts: generalised least squares on
//! the increments of block means.
//!
//! **Why.** A temperature warm-up and the IEEE noise are both slow. Ordinary least squares treats
//! the samples as independent and calls two independent slow series correlated most of the time;
//! a model-free test on increments ([`super::time::fit_coupling`]) is honest but weak, because the
//! few long blocks where a warm-up lives carry nearly all of the information and it cannot weigh
//! them. The loop already has what is missing: the fitted noise model, whose density gives the
//! exact covariance of any linear statistic of the series. So:
//!
//! - the series and the regressor are averaged over M + 1 blocks of `block` samples (M = 512,
//!   fewer for short records) and differenced: d_j = ȳ_{j+1} − ȳ_j. The increments of every IEEE
//!   noise but the rate ramp are stationary, and a ramp (deterministic or not) becomes a constant,
//!   which the intercept of the regression absorbs;
//! - their autocovariance is γ(k) = f_b ∫₀^{1/2} P(u) 4 sin²(πu) cos(2πuk) du, with P the
//!   one-sided density of the block means folded into the block band (the noise density times the
//!   block mean's Dirichlet gain, summed over aliases) — computed by the midpoint rule on 8M
//!   points, aliases up to the 256th, the density tabulated on 512 log-spaced points per decade;
//! - the Toeplitz covariance is factored (Cholesky), both series are whitened, and
//!   d = a + β·x + e is solved by least squares on the whitened values. The scale of the
//!   covariance is estimated from the whitened residuals (the model's shape is trusted, its
//!   level need not be), so t = β/SE is Student-t with M − 2 degrees of freedom;
//! - a regressor with white measurement noise of its own (a temperature sensor's) attenuates β
//!   (errors in variables). The noise variance is the negative lag-1 autocovariance of the
//!   regressor's sample differences (white noise alone makes it negative; a smooth signal or a
//!   random walk does not), its share λ of the whitened, centred regressor is computed exactly,
//!   and β and its error are divided by λ (kept ≥ 1/2). The test of β = 0 uses the uncorrected t.

use super::time::stats::t_sf;
use crate::memo::Memo;

/// Block-mean increments used at most.
pub const MAX_INCREMENTS: usize = 512;
/// Fewest samples per block.
const MIN_BLOCK: usize = 4;
/// Fewest increments for a regression.
const MIN_INCREMENTS: usize = 32;
/// Aliases of the block band summed in the covariance.
const MAX_ALIASES: usize = 256;
/// Reliability a regressor must reach for the block length to be accepted (see
/// [`regress_series`]).
const GOOD_RELIABILITY: f64 = 0.9;
/// Floor of the attenuation correction.
const MIN_RELIABILITY: f64 = 0.25;
/// Reliability below which a regressor is mostly its own measurement noise at every block length
/// tried: no coefficient is measured on it (see [`crate::effects::slow::coupling_under_model`]).
pub const USEFUL_RELIABILITY: f64 = 0.5;

/// A regression of a series on a regressor, with the blocking it used.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Regression {
    pub gls: Gls,
    /// Samples per block.
    pub block: usize,
    /// Increments.
    pub m: usize,
}

/// Regresses `y` on `x` (same length, at `fs`) under the noise `density`: the most increments
/// (512, 256, … 32) at which the regressor's white measurement noise (`x_noise` per sample, see
/// [`white_noise_variance`]) leaves at least 90 % of its whitened variation as signal, else the
/// blocking with the most. Whitening under a random-walk-dominated model differences the
/// increments once more and so magnifies the regressor's fast noise: longer blocks average it
/// away. The choice depends on the regressor and the model only, never on `y`, so the test keeps
/// its level.
pub fn regress_series(
    density: &dyn Fn(f64) -> f64,
    fs: f64,
    y: &[f64],
    x: &[f64],
    x_noise: f64,
) -> Option<Regression> {
    let n = y.len().min(x.len());
    let mut best: Option<Regression> = None;
    let mut m = MAX_INCREMENTS;
    while m >= MIN_INCREMENTS {
        if let Some(model) = IncrementModel::with_increments(density, fs, n, m) {
            if let Some(gls) = model.regress(&model.increments(y), &model.increments(x), x_noise) {
                let r = Regression {
                    gls,
                    block: model.block,
                    m: model.m,
                };
                if gls.reliability >= GOOD_RELIABILITY || x_noise <= 0.0 {
                    return Some(r);
                }
                if best.is_none_or(|b| gls.reliability > b.gls.reliability) {
                    best = Some(r);
                }
            }
        }
        m /= 2;
    }
    best
}

/// The whitening of block-mean increments under a noise model.
#[derive(Debug, Clone)]
pub struct IncrementModel {
    /// Samples per block.
    pub block: usize,
    /// Number of increments.
    pub m: usize,
    /// The inverse W = L⁻¹ of the lower Cholesky factor of the increments' covariance, row-major
    /// m×m (see [`inverse_cholesky_toeplitz`]).
    winv: Vec<f64>,
    /// The whitened intercept column, L⁻¹1.
    ones: Vec<f64>,
}

/// The result of [`IncrementModel::best_box`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BoxScan {
    /// Increments of the rise and of the fall.
    pub rise: usize,
    pub fall: usize,
    pub gls: Gls,
    /// Boxes tried.
    pub tried: usize,
    /// The largest t² of a single step (a rise that stays).
    pub step_t2: f64,
    /// That step: its increment and its regression (with its Student p-value, uncorrected for
    /// the m positions tried).
    pub step: Option<(usize, Gls)>,
}

/// Block-mean increments whitened by an [`IncrementModel`].
#[derive(Debug, Clone)]
pub struct Whitened(Vec<f64>);

/// A regression of the increments on one regressor.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Gls {
    /// Coefficient, corrected for the regressor's own measurement noise.
    pub beta: f64,
    /// Its standard error.
    pub se: f64,
    /// Test statistic of β = 0 (uncorrected coefficient over its error).
    pub t: f64,
    /// Two-sided p-value of t (Student, `dof`).
    pub p: f64,
    pub dof: f64,
    /// Residual variance over the model's (1 when the model's level is right).
    pub scale: f64,
    /// Share of the regressor's whitened variation that is signal (1: no measurement noise).
    pub reliability: f64,
}

impl Gls {
    /// A coefficient and its error with the Student test of it being 0 (`dof` degrees of
    /// freedom).
    fn student(beta: f64, se: f64, dof: f64, scale: f64, reliability: f64) -> Gls {
        let t = if se > 0.0 { beta / se } else { 0.0 };
        Gls {
            beta,
            se,
            t,
            p: if se > 0.0 {
                2.0 * t_sf(t.abs(), dof)
            } else {
                1.0
            },
            dof,
            scale,
            reliability,
        }
    }
}

/// The normal equations' solution of a fit on the intercept and one regressor (whitened):
/// intercept `a`, slope `beta`, the cross products and the residual scale.
struct InterceptFit {
    a: f64,
    beta: f64,
    soo: f64,
    sww: f64,
    det: f64,
    dof: f64,
    scale: f64,
}

impl IncrementModel {
    /// The model for a series of `n` samples at `fs` whose noise has the one-sided density
    /// `density` (units²/Hz; without a rate ramp, which the intercept absorbs). `None` for a series
    /// too short for [`MIN_INCREMENTS`] increments or a covariance that is not positive definite.
    pub fn new(density: &dyn Fn(f64) -> f64, fs: f64, n: usize) -> Option<Self> {
        Self::with_increments(density, fs, n, MAX_INCREMENTS)
    }

    /// As [`IncrementModel::new`] with at most `m` increments.
    pub fn with_increments(
        density: &dyn Fn(f64) -> f64,
        fs: f64,
        n: usize,
        m: usize,
    ) -> Option<Self> {
        let m = m.min((n / MIN_BLOCK).saturating_sub(1));
        if m < MIN_INCREMENTS || fs.is_nan() || fs <= 0.0 {
            return None;
        }
        let block = n / (m + 1);
        let gamma = increment_autocovariance(density, fs, block, m);
        let winv = inverse_cholesky_toeplitz(&gamma)?;
        let mut model = Self {
            block,
            m,
            winv,
            ones: Vec::new(),
        };
        model.ones = model.whiten(&vec![1.0; m]);
        Some(model)
    }

    /// The block-mean increments of `v` (its first (m + 1)·block samples).
    pub fn increments(&self, v: &[f64]) -> Vec<f64> {
        let means: Vec<f64> = v
            .chunks_exact(self.block)
            .take(self.m + 1)
            .map(|c| crate::stats::lane_sum(c) / self.block as f64)
            .collect();
        means.windows(2).map(|w| w[1] - w[0]).collect()
    }

    /// L⁻¹v = W·v.
    fn whiten(&self, v: &[f64]) -> Vec<f64> {
        let m = self.m;
        (0..m)
            .map(|i| {
                let row = &self.winv[i * m..=i * m + i];
                row.iter().zip(v).map(|(a, b)| a * b).sum()
            })
            .collect()
    }

    /// Regresses the increments `d` of the series on the increments `x` of the regressor, with
    /// an intercept. `x_noise`: the variance per sample of the regressor's white measurement
    /// noise (0 for a noiseless regressor). `None` when `x` does not vary.
    pub fn regress(&self, d: &[f64], x: &[f64], x_noise: f64) -> Option<Gls> {
        if d.len() != self.m {
            return None;
        }
        self.regress_whitened(&Whitened(self.whiten(d)), x, x_noise)
    }

    /// The model for `y` under `density` with `y`'s increments whitened by it: what every
    /// regression of one series on many regressors starts from. `None` as [`IncrementModel::new`].
    pub fn for_series(
        density: &dyn Fn(f64) -> f64,
        fs: f64,
        y: &[f64],
        m: usize,
    ) -> Option<(Self, Whitened)> {
        let model = Self::with_increments(density, fs, y.len(), m)?;
        let u = model.whitened(&model.increments(y))?;
        Some((model, u))
    }

    /// The increments of a series whitened once, for regressions of one series on many
    /// regressors (the drift shapes).
    pub fn whitened(&self, d: &[f64]) -> Option<Whitened> {
        (d.len() == self.m).then(|| Whitened(self.whiten(d)))
    }

    /// The mean of the increments (a ramp's block-to-block rise) by generalised least squares on
    /// increments already whitened: the intercept alone. Its `t` tests a zero mean (Student,
    /// m − 1 degrees of freedom, the model's level estimated from the residuals).
    pub fn mean_increment(&self, u: &Whitened) -> Option<Gls> {
        let (u, o) = (&u.0, &self.ones);
        let soo: f64 = o.iter().map(|v| v * v).sum();
        if u.len() != self.m || soo.is_nan() || soo <= 0.0 {
            return None;
        }
        let a = o.iter().zip(u).map(|(p, q)| p * q).sum::<f64>() / soo;
        let rss: f64 = u.iter().zip(o).map(|(q, p)| (q - a * p).powi(2)).sum();
        let dof = (self.m - 1) as f64;
        let scale = rss / dof;
        Some(Gls::student(a, (scale / soo).sqrt(), dof, scale, 1.0))
    }

    /// The mean of the increments, as [`mean_increment`](Self::mean_increment), with the
    /// increments `x` of another series fitted beside it: what of a ramp is left once a regressor
    /// that rises with it (a temperature's warm-up) had its share. A regressor that does not
    /// change (all increments 0) takes nothing: the mean alone. `None` where `x` rises in step with
    /// the intercept (a straight line): the two cannot be told apart.
    pub fn mean_increment_beside(&self, u: &Whitened, x: &[f64]) -> Option<Gls> {
        if x.len() == self.m && x.iter().all(|&v| v == 0.0) {
            return self.mean_increment(u);
        }
        let f = self.with_intercept(u, x)?;
        Some(Gls::student(
            f.a,
            (f.scale * f.sww / f.det).sqrt(),
            f.dof,
            f.scale,
            1.0,
        ))
    }

    /// [`IncrementModel::regress`] of increments already whitened by [`IncrementModel::whitened`].
    pub fn regress_whitened(&self, u: &Whitened, x: &[f64], x_noise: f64) -> Option<Gls> {
        let f = self.with_intercept(u, x)?;
        let se = (f.scale * f.soo / f.det).sqrt();
        let reliability = if x_noise > 0.0 {
            let centred = f.det / f.soo;
            (1.0 - x_noise / self.block as f64 * self.noise_trace(&self.ones, f.soo) / centred)
                .max(MIN_RELIABILITY)
        } else {
            1.0
        };
        // t tests the uncorrected coefficient; the reported one and its error are corrected for
        // the regressor's noise.
        let gls = Gls::student(f.beta, se, f.dof, f.scale, reliability);
        Some(Gls {
            beta: f.beta / reliability,
            se: se / reliability,
            ..gls
        })
    }

    /// The GLS fit of whitened increments `u` on the intercept and several regressors `xs` (their
    /// increments) at once: one [`Gls`] per regressor, each coefficient's t testing it with the
    /// others in the model (Student, m − 1 − k degrees of freedom; noiseless regressors).
    /// `None` for mismatched lengths or regressors the others explain (singular equations).
    pub fn regress_whitened_jointly(&self, u: &Whitened, xs: &[&[f64]]) -> Option<Vec<Gls>> {
        let m = self.m;
        if u.0.len() != m || xs.iter().any(|x| x.len() != m) {
            return None;
        }
        let mut cols = vec![self.ones.clone()];
        cols.extend(xs.iter().map(|x| self.whiten(x)));
        let dot = |a: &[f64], b: &[f64]| a.iter().zip(b).map(|(p, q)| p * q).sum::<f64>();
        let gram: Vec<Vec<f64>> = cols
            .iter()
            .map(|a| cols.iter().map(|b| dot(a, b)).collect())
            .collect();
        let inverse = crate::model::linalg::inverse_spd(&gram)?;
        let rhs: Vec<f64> = cols.iter().map(|c| dot(c, &u.0)).collect();
        let coef: Vec<f64> = inverse.iter().map(|row| dot(row, &rhs)).collect();
        let rss: f64 = (0..m)
            .map(|i| {
                let fit: f64 = cols.iter().zip(&coef).map(|(c, b)| c[i] * b).sum();
                (u.0[i] - fit).powi(2)
            })
            .sum();
        let dof = (m - cols.len()) as f64;
        let scale = rss / dof;
        if !(scale.is_finite() && dof > 0.0) {
            return None;
        }
        Some(
            (1..cols.len())
                .map(|j| {
                    let se = (scale * inverse[j][j]).max(0.0).sqrt();
                    Gls::student(coef[j], se, dof, scale, 1.0)
                })
                .collect(),
        )
    }

    /// The GLS fit of whitened increments `u` on the intercept and the increments `x`: the
    /// normal equations both [`regress_whitened`](Self::regress_whitened) (the slope) and
    /// [`mean_increment_beside`](Self::mean_increment_beside) (the intercept) read from. `None`
    /// for mismatched lengths or a regressor the intercept explains (singular equations).
    fn with_intercept(&self, u: &Whitened, x: &[f64]) -> Option<InterceptFit> {
        let m = self.m;
        if u.0.len() != m || x.len() != m {
            return None;
        }
        let (u, w, o) = (&u.0, self.whiten(x), &self.ones);
        let dot = |a: &[f64], b: &[f64]| a.iter().zip(b).map(|(p, q)| p * q).sum::<f64>();
        let (soo, sow, sww) = (dot(o, o), dot(o, &w), dot(&w, &w));
        let (sou, swu) = (dot(o, u), dot(&w, u));
        let det = soo * sww - sow * sow;
        if !det.is_finite() || det <= 1e-12 * soo * sww {
            return None;
        }
        let beta = (soo * swu - sow * sou) / det;
        let a = (sww * sou - sow * swu) / det;
        let rss: f64 = (0..m)
            .map(|i| (u[i] - a * o[i] - beta * w[i]).powi(2))
            .sum();
        let dof = (m - 2) as f64;
        Some(InterceptFit {
            a,
            beta,
            soo,
            sww,
            det,
            dof,
            scale: rss / dof,
        })
    }

    /// C⁻¹ = WᵀW, the inverse of the increments' Toeplitz covariance, as the upper triangle of a
    /// row-major m×m matrix (entries k ≥ j of row j; the rest 0), in O(m²) from W's last row
    /// alone: that row is the order-(m − 1) prediction-error filter α over √P (α₀ = 1), and by
    /// the Gohberg–Semencul formula C⁻¹ = (A·Aᵀ − B·Bᵀ)/P with A and B the lower-triangular
    /// Toeplitz matrices of first columns (1, α₁, …, α_{m−1}) and (0, α_{m−1}, …, α₁), whence
    /// Trench's recursion along the diagonals: (C⁻¹)_{0,k} = α₀α_k/P and (C⁻¹)_{j+1,k+1} =
    /// (C⁻¹)_{j,k} + (α_{j+1}α_{k+1} − β_{j+1}β_{k+1})/P. The product WᵀW itself took
    /// m³/6 multiply-adds (2·10⁷ at m = 512), most of the box scan's time. The test
    /// `trench_inverse_matches_the_gram_matrix` holds it to the product.
    fn inverse_covariance(&self) -> Vec<f64> {
        let m = self.m;
        let last = &self.winv[(m - 1) * m..m * m];
        // α_k/√P and β_k/√P.
        let alpha: Vec<f64> = (0..m).map(|k| last[m - 1 - k]).collect();
        let beta: Vec<f64> = (0..m)
            .map(|k| if k == 0 { 0.0 } else { last[k - 1] })
            .collect();
        let mut gram = vec![0.0; m * m];
        for k in 0..m {
            gram[k] = alpha[0] * alpha[k];
        }
        for j in 1..m {
            let (above, row) = gram.split_at_mut(j * m);
            let previous = &above[(j - 1) * m..];
            for k in j..m {
                row[k] = previous[k - 1] + alpha[j] * alpha[k] - beta[j] * beta[k];
            }
        }
        gram
    }

    /// The best box regressor of the whitened increments `u`: of every x = e_a − e_b (a rise at
    /// increment a and a fall at increment b, b − a ≥ `min_len`: the block means a + 1 … b shifted
    /// by one amount), the one whose GLS t (with the intercept) is largest in magnitude; and the
    /// best single step x = e_a (a shift that stays), to compare with. With g = Wᵀ(W1), h = Wᵀu
    /// and G = WᵀW every box's normal equations are sums of three entries of these, so all m²/2
    /// boxes cost O(m³/6) once (G) plus O(1) each.
    pub fn best_box(&self, u: &Whitened, min_len: usize) -> Option<BoxScan> {
        let m = self.m;
        let u = &u.0;
        if u.len() != m || m < min_len + 3 {
            return None;
        }
        let w = &self.winv;
        let o = &self.ones;
        // The Gram matrix of W's columns, WᵀW = C⁻¹ (upper triangle), its column sums against o
        // (Wᵀo = WᵀW·1: its row sums) and W's against u.
        let gram = self.inverse_covariance();
        let g: Vec<f64> = (0..m)
            .map(|j| {
                let upper: f64 = gram[j * m + j..(j + 1) * m].iter().sum();
                let lower: f64 = (0..j).map(|k| gram[k * m + j]).sum();
                upper + lower
            })
            .collect();
        let mut h = vec![0.0; m];
        for r in 0..m {
            for (hj, wj) in h.iter_mut().zip(&w[r * m..=r * m + r]) {
                *hj += wj * u[r];
            }
        }
        let dot = |a: &[f64], b: &[f64]| a.iter().zip(b).map(|(p, q)| p * q).sum::<f64>();
        let (soo, sou, suu) = (dot(o, o), dot(o, u), dot(u, u));
        let dof = (m - 2) as f64;
        // x = e_a − e_b, or e_a alone when b is None.
        let fit = |a: usize, b: Option<usize>| -> Option<Gls> {
            let (sow, swu, sww) = match b {
                Some(b) => (
                    g[a] - g[b],
                    h[a] - h[b],
                    gram[a * m + a] + gram[b * m + b] - 2.0 * gram[a * m + b],
                ),
                None => (g[a], h[a], gram[a * m + a]),
            };
            let det = soo * sww - sow * sow;
            if !det.is_finite() || det <= 1e-12 * soo * sww {
                return None;
            }
            let beta = (soo * swu - sow * sou) / det;
            let icpt = (sww * sou - sow * swu) / det;
            let rss = (suu - icpt * sou - beta * swu).max(0.0);
            let scale = rss / dof;
            let se = (scale * soo / det).sqrt();
            let t = if se > 0.0 { beta / se } else { 0.0 };
            Some(Gls {
                beta,
                se,
                t,
                // Computed for the best box only: a Student tail per box was most of the scan.
                p: 1.0,
                dof,
                scale,
                reliability: 1.0,
            })
        };
        let mut best: Option<(usize, usize, Gls)> = None;
        let mut step: Option<(usize, Gls)> = None;
        let mut tried = 0;
        for a in 0..m {
            if let Some(f) = fit(a, None) {
                if step.is_none_or(|(_, x)| f.t.abs() > x.t.abs()) {
                    step = Some((a, f));
                }
            }
            for b in a + min_len..m {
                tried += 1;
                if let Some(f) = fit(a, Some(b)) {
                    if best.is_none_or(|(_, _, x)| f.t.abs() > x.t.abs()) {
                        best = Some((a, b, f));
                    }
                }
            }
        }
        let with_p = |mut gls: Gls| {
            if gls.se > 0.0 {
                gls.p = 2.0 * t_sf(gls.t.abs(), dof);
            }
            gls
        };
        let step = step.map(|(a, g)| (a, with_p(g)));
        best.map(|(rise, fall, gls)| BoxScan {
            rise,
            fall,
            gls: with_p(gls),
            tried,
            step_t2: step.map_or(0.0, |(_, g)| g.t * g.t),
            step,
        })
    }

    /// tr(M W D Dᵀ Wᵀ): the whitened, centred sum of squares that unit-variance white noise
    /// of the block means puts into increments (W = L⁻¹, D the differencing, M the projection off
    /// the whitened intercept `o`).
    fn noise_trace(&self, o: &[f64], soo: f64) -> f64 {
        // W D has column j = W(e_{j−1} − e_j) over the m + 1 block means (block mean j enters
        // increment j − 1 with +1 and increment j with −1): a difference of two columns of W,
        // which is at hand, so the whole trace costs O(m²).
        let m = self.m;
        let w = |r: usize, c: usize| if c <= r { self.winv[r * m + c] } else { 0.0 };
        let mut total = 0.0;
        let mut proj = 0.0;
        for j in 0..=m {
            let (mut norm, mut dot) = (0.0, 0.0);
            for (r, o_r) in o.iter().enumerate().skip(j.saturating_sub(1)) {
                let up = if j > 0 { w(r, j - 1) } else { 0.0 };
                let down = if j < m { w(r, j) } else { 0.0 };
                let v = up - down;
                norm += v * v;
                dot += v * o_r;
            }
            total += norm;
            proj += dot * dot;
        }
        total - proj / soo
    }
}

/// The variance per sample of the white measurement noise in `x`: minus the lag-1
/// autocovariance of its differences (white noise σ² gives −σ²; a smooth signal or a random walk
/// gives ≈ 0 or more), floored at 0.
pub fn white_noise_variance(x: &[f64]) -> f64 {
    if x.len() < 3 {
        return 0.0;
    }
    let d: Vec<f64> = x.windows(2).map(|w| w[1] - w[0]).collect();
    let mean = d.iter().sum::<f64>() / d.len() as f64;
    let c1 = d
        .windows(2)
        .map(|w| (w[0] - mean) * (w[1] - mean))
        .sum::<f64>()
        / (d.len() - 1) as f64;
    (-c1).max(0.0)
}

/// A function tabulated on a log-spaced grid, linearly interpolated in log f (clamped outside).
struct LogTable {
    step: f64,
    /// The grid's frequencies, f_j = exp(ln_lo + j·step).
    freqs: Vec<f64>,
    values: Vec<f64>,
}

impl LogTable {
    fn new(g: &dyn Fn(f64) -> f64, lo: f64, hi: f64, per_decade: f64) -> LogTable {
        let (ln_lo, ln_hi) = (lo.max(f64::MIN_POSITIVE).ln(), hi.max(lo).ln());
        let step = std::f64::consts::LN_10 / per_decade;
        let n = ((ln_hi - ln_lo) / step).ceil().max(1.0) as usize + 1;
        let freqs: Vec<f64> = (0..n).map(|i| (ln_lo + i as f64 * step).exp()).collect();
        let values = freqs.iter().map(|&f| g(f)).collect();
        LogTable {
            step,
            freqs,
            values,
        }
    }

    /// A reader of the table at ascending frequencies.
    fn ascending(&self) -> Ascending<'_> {
        let mut reader = Ascending {
            table: self,
            inv_step: 1.0 / self.step,
            j: 0,
            next: 0.0,
            inv_f: 0.0,
            value: 0.0,
            slope: 0.0,
        };
        reader.enter(0);
        reader
    }
}

/// Reads a [`LogTable`] at frequencies that never decrease, finding each one's interval by
/// walking on from the last one's instead of by a logarithm ([`Ascending::seek`]), then reading
/// every point of a run inside that interval without a test ([`Ascending::interpolate`]): the
/// alias sums read the table at ~2·10⁶ points a call, and a logarithm at each was two thirds of
/// their time; a test of the interval at each, half of what was left. The interpolation
/// weight, ln(f/f_j)/step, comes from the series x − x²/2 + x³/3 of ln(1 + x), x = f/f_j − 1 <
/// e^step − 1 (1.1e-3 at 2048 points a decade): its error, below x⁴/4 = 4e-13, is 4e-10 of an
/// interval.
struct Ascending<'a> {
    table: &'a LogTable,
    inv_step: f64,
    /// The current interval [f_j, next): its start's reciprocal, value and rise to the next.
    j: usize,
    next: f64,
    inv_f: f64,
    value: f64,
    slope: f64,
}

impl Ascending<'_> {
    /// Makes interval j current (the last point: the constant beyond the table).
    fn enter(&mut self, j: usize) {
        let (freqs, values) = (&self.table.freqs, &self.table.values);
        self.j = j;
        self.value = values[j];
        if j + 1 < values.len() {
            self.next = freqs[j + 1];
            self.inv_f = 1.0 / freqs[j];
            self.slope = values[j + 1] - values[j];
        } else {
            self.next = f64::INFINITY;
            self.inv_f = 0.0;
            self.slope = 0.0;
        }
    }

    /// Makes the interval holding `f` current.
    fn seek(&mut self, f: f64) {
        while f >= self.next {
            self.enter(self.j + 1);
        }
    }

    /// The table at `f` on the current interval (a point a rounding beyond its end reads the
    /// end's value, as the next interval would).
    fn interpolate(&self, f: f64) -> f64 {
        // Below the first point x < 0 and the weight clamps to 0: the first value.
        let x = f * self.inv_f - 1.0;
        let w = (x * (1.0 - x * (0.5 - x * (1.0 / 3.0))) * self.inv_step).clamp(0.0, 1.0);
        self.value + self.slope * w
    }
}

/// Autocovariance (lags 0..m) of the increments of `block`-sample means of a series at `fs` with
/// one-sided density `density`.
///
/// The density is folded onto the block-mean band: bin u (in cycles per block) collects the
/// aliases a = n + u and n + 1 − u (n = 0, 1, …, a ≤ block/2), each weighted by the block mean's
/// gain (sin(π·a)/(block·sin(π·a/block)))². Its numerator sin²(π·a) = sin²(π·u) is the same at
/// every alias of a bin, so it is taken out of the alias sum, and what is left per alias,
/// density(f)/(block·sin(πf/fs))², is smooth on (0, fs/2] and tabulated once on a log-frequency
/// grid (2048 points per decade, linear in log f: below 5e-6 relative for power laws as steep as
/// f⁻⁵; a resonance of Q = 50 spans 16 points of its half-power width, 4e-4 on the covariance)
/// instead of being evaluated, with two sines, at each of the ~2·256·4096 alias points (a tenth
/// of the loop's time on 10⁷-sample records). The test `folding_matches_the_direct_alias_sum`
/// checks it against that direct sum.
pub fn increment_autocovariance(
    density: &dyn Fn(f64) -> f64,
    fs: f64,
    block: usize,
    m: usize,
) -> Vec<f64> {
    use std::f64::consts::PI;
    let fb = fs / block as f64;
    let bins = 8 * m.max(1);
    let du = 0.5 / bins as f64;
    let per_alias = |f: f64| {
        let den = block as f64 * (PI * f / fs).sin();
        density(f) / (den * den)
    };
    let f_lo = 0.5 * du * fb;
    let table = LogTable::new(&per_alias, f_lo, fs / 2.0, 2048.0);
    // The result depends on the density only through the table: the key below holds everything
    // else it depends on (fb is fs/block, du is fixed by m).
    let key = CovarianceKey {
        fs_bits: fs.to_bits(),
        block,
        m,
        table: table.values.iter().map(|v| v.to_bits()).collect(),
    };
    COVARIANCES
        .get_or(key, || Some(fold_and_sum(&table, fb, block, bins, du, m)))
        .unwrap_or_default()
}

/// [`increment_autocovariance`] from its tabulated density: the aliases folded onto the block
/// band, then the cosine sums.
///
/// Every alias of every bin lies on one grid, a_k = (k + ½)·du (with 1 = 2·bins·du, bin i's
/// aliases n + u_i and n + 1 − u_i are the k ≡ i and k ≡ 2·bins − 1 − i modulo 2·bins), so the
/// table is read once along that grid in ascending order and each reading added to its residue.
fn fold_and_sum(
    table: &LogTable,
    fb: f64,
    block: usize,
    bins: usize,
    du: f64,
    m: usize,
) -> Vec<f64> {
    use std::f64::consts::PI;
    let half_band = block as f64 / 2.0;
    let period = 2 * bins;
    // The grid's points with a_k ≤ block/2 and n = k div period ≤ MAX_ALIASES.
    let cap = (MAX_ALIASES + 1) * period;
    let within = |k: usize| (k as f64 + 0.5) * du <= half_band;
    let mut count = ((half_band / du - 0.5).floor().max(0.0) as usize).min(cap);
    while count > 0 && !within(count - 1) {
        count -= 1;
    }
    while count < cap && within(count) {
        count += 1;
    }
    let mut by_residue = vec![0.0; period];
    let mut reader = table.ascending();
    let at = |k: usize| (k as f64 + 0.5) * du * fb;
    for first in (0..count).step_by(period) {
        let len = period.min(count - first);
        // Runs of points inside one interval of the table, each read without a test (beyond
        // a few aliases an interval holds hundreds of points).
        let mut r = 0;
        while r < len {
            reader.seek(at(first + r));
            let next = (reader.next / (du * fb) - 0.5).ceil() as usize;
            let end = next.saturating_sub(first).clamp(r + 1, len);
            for (k, sum) in (first + r..).zip(&mut by_residue[r..end]) {
                *sum += reader.interpolate(at(k));
            }
            r = end;
        }
    }
    let folded: Vec<f64> = (0..bins)
        .map(|i| {
            let u = (i as f64 + 0.5) * du;
            let p = by_residue[i] + by_residue[period - 1 - i];
            let s2 = (PI * u).sin().powi(2);
            fb * p * s2 * 4.0 * s2 * du
        })
        .collect();
    cosine_sums(&folded, m)
}

/// What [`increment_autocovariance`]'s result depends on, bit for bit: the rate, the block, the
/// lag count and the tabulated density.
#[derive(PartialEq, Eq)]
struct CovarianceKey {
    fs_bits: u64,
    block: usize,
    m: usize,
    table: Vec<u64>,
}

/// The autocovariances computed last, process-wide.
///
/// **Why.** The loop asks for the covariance of the same model more than once on a channel (the
/// slow effects' candidates, the drift's test under the same model, the ramp's test at the end
/// when nothing was added in between, the ramp's test beside each aux channel): 6 of the 14
/// computations of a 6-channel 1-h record at 200 Hz repeated an earlier one, each about 60 ms.
/// The key is exact (every input compared bit for bit), so a hit returns what the computation
/// would. A channel repeats within a few of its own calls; 32 entries (~125 kB each) leave room
/// for the calls of 16 channels in flight at once in between.
static COVARIANCES: Memo<CovarianceKey, Vec<f64>> = Memo::new(32);

/// `Σ_i p_i·cos(π·k·(2i + 1)/(2N))` for k in 0..m (N = `p.len()` ≥ m): the first m terms of
/// p's DCT-II, from one real FFT of length 2N of p followed by its mirror image (V_k =
/// 2·e^{iπk/(2N)}·X_k), O(N log N) instead of the O(m·N) of summing the cosines lag by lag (a
/// third of the covariance's time at m = 512). Agrees with the direct sums to 1e-13 of Σ|p_i|
/// (see the test).
fn cosine_sums(p: &[f64], m: usize) -> Vec<f64> {
    use std::cell::RefCell;
    use std::f64::consts::PI;
    thread_local! {
        static PLANNER: RefCell<realfft::RealFftPlanner<f64>> =
            RefCell::new(realfft::RealFftPlanner::new());
    }
    let n = p.len();
    assert!(m <= n, "{m} lags from {n} terms");
    let fft = PLANNER.with(|planner| planner.borrow_mut().plan_fft_forward(2 * n));
    let mut mirrored = Vec::with_capacity(2 * n);
    mirrored.extend_from_slice(p);
    mirrored.extend(p.iter().rev());
    let mut spectrum = fft.make_output_vec();
    fft.process(&mut mirrored, &mut spectrum)
        .expect("the buffers are the plan's sizes");
    spectrum[..m]
        .iter()
        .enumerate()
        .map(|(k, v)| {
            let (sin, cos) = (PI * k as f64 / (2 * n) as f64).sin_cos();
            0.5 * (v.re * cos + v.im * sin)
        })
        .collect()
}

/// W = L⁻¹ (lower, row-major) for the symmetric Toeplitz matrix C = L·Lᵀ with first row `gamma`,
/// by the Levinson–Durbin recursion in O(m²) instead of a Cholesky factorisation in O(m³): with
/// a_i the order-i one-step prediction filter and P_i its error variance, the innovations
/// e_i = v_i − Σ_k a_{i,k}·v_{i−k} are independent with variances P_i, so row i of W is
/// (−a_{i,i}, …, −a_{i,1}, 1)/√P_i. A tiny ridge is added when rounding makes the matrix
/// indefinite (an error variance ≤ 0); `None` if that does not help.
fn inverse_cholesky_toeplitz(gamma: &[f64]) -> Option<Vec<f64>> {
    let m = gamma.len();
    if m == 0 || gamma.iter().any(|g| !g.is_finite()) || gamma[0] <= 0.0 {
        return None;
    }
    'ridges: for ridge in [0.0, 1e-10, 1e-7] {
        let mut g = gamma.to_vec();
        g[0] *= 1.0 + ridge;
        let mut w = vec![0.0; m * m];
        let mut a: Vec<f64> = Vec::with_capacity(m);
        let mut next = Vec::with_capacity(m);
        let mut p = g[0];
        w[0] = 1.0 / p.sqrt();
        for i in 1..m {
            // a holds a_{i−1,1..i−1}.
            let acc: f64 = a.iter().enumerate().map(|(k, ak)| ak * g[i - 1 - k]).sum();
            let kappa = (g[i] - acc) / p;
            next.clear();
            next.extend((0..a.len()).map(|k| a[k] - kappa * a[a.len() - 1 - k]));
            next.push(kappa);
            std::mem::swap(&mut a, &mut next);
            p *= 1.0 - kappa * kappa;
            if p.is_nan() || p <= 0.0 {
                continue 'ridges;
            }
            let scale = 1.0 / p.sqrt();
            let row = &mut w[i * m..=i * m + i];
            row[i] = scale;
            for (k, ak) in a.iter().enumerate() {
                row[i - 1 - k] = -ak * scale;
            }
        }
        return Some(w);
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::rng::Rng;

    /// Trench's recursion gives WᵀW, the Gram matrix of W's columns, at the sizes the scans use,
    /// for the best- and the worst-conditioned covariances (white noise; a random walk plus white
    /// noise; flicker noise behind a low-pass): within 1e-12 of the largest entry (measured:
    /// 2.5e-15 at most).
    #[test]
    fn trench_inverse_matches_the_gram_matrix() {
        let densities: [&dyn Fn(f64) -> f64; 3] = [
            &|_f: f64| 2e-6,
            &|f: f64| 1e-6 + 1e-9 / (f * f),
            &|f: f64| (1e-6 + 1e-7 / f) / (1.0 + (f / 20.0).powi(4)),
        ];
        for density in densities {
            for (block, m) in [(50, 64), (50, 512), (3, 128)] {
                let gamma = increment_autocovariance(density, 100.0, block, m);
                let winv = inverse_cholesky_toeplitz(&gamma).expect("positive definite");
                let model = IncrementModel {
                    block,
                    m,
                    ones: vec![0.0; m],
                    winv,
                };
                let fast = model.inverse_covariance();
                let w = &model.winv;
                let largest = fast.iter().fold(0.0f64, |a, v| a.max(v.abs()));
                for j in (0..m).step_by(7) {
                    for k in (j..m).step_by(5) {
                        let direct: f64 = (k..m).map(|r| w[r * m + j] * w[r * m + k]).sum();
                        assert!(
                            (fast[j * m + k] - direct).abs() <= 1e-12 * largest,
                            "m {m} block {block} ({j}, {k}): {} vs {direct}",
                            fast[j * m + k]
                        );
                    }
                }
            }
        }
    }

    /// W·C·Wᵀ = I for the Toeplitz covariance of increments under a random walk plus white noise
    /// (the case where C is worst conditioned), at the largest size used.
    #[test]
    fn levinson_inverts_the_cholesky_factor() {
        let m = 512;
        let gamma = increment_autocovariance(&|f: f64| 1e-6 + 1e-9 / (f * f), 100.0, 50, m);
        let w = inverse_cholesky_toeplitz(&gamma).expect("positive definite");
        for i in (0..m).step_by(37) {
            for j in (0..m).step_by(41) {
                // (W C Wᵀ)_ij = Σ_a Σ_b W_ia C_ab W_jb
                let mut s = 0.0;
                for a in 0..=i {
                    for b in 0..=j {
                        s += w[i * m + a] * gamma[a.abs_diff(b)] * w[j * m + b];
                    }
                }
                let want = if i == j { 1.0 } else { 0.0 };
                assert!((s - want).abs() < 1e-9, "({i},{j}): {s}");
            }
        }
    }

    /// The folded density agrees with the alias sum evaluated directly (the density and the
    /// block mean's gain at every alias, no table), for white noise, a random walk, flicker and a
    /// narrow resonance, at a short and a long block.
    /// The memo returns a repeat's covariance exactly, and never another density's: two densities
    /// that differ only above a tenth of the rate (where a low-pass acts) give different
    /// covariances, and asking for the first again after the second gives the first's, bit for
    /// bit (block and lag count used by no other test, so that the first call computes).
    #[test]
    fn the_memo_answers_only_the_same_question() {
        let white_rw = |f: f64| 1e-6 + 1e-9 / (f * f);
        let filtered = |f: f64| white_rw(f) / (1.0 + (f / 10.0).powi(4));
        let (fs, block, m) = (100.0, 51, 63);
        let first = increment_autocovariance(&white_rw, fs, block, m);
        let other = increment_autocovariance(&filtered, fs, block, m);
        assert_ne!(first, other);
        let again = increment_autocovariance(&white_rw, fs, block, m);
        let bits = |g: &[f64]| g.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&first), bits(&again));
        // Another lag count or block is another question.
        assert_eq!(increment_autocovariance(&white_rw, fs, block, 31).len(), 31);
        assert_ne!(increment_autocovariance(&white_rw, fs, block + 1, m), first);
    }

    #[test]
    fn folding_matches_the_direct_alias_sum() {
        use std::f64::consts::PI;
        fn direct(density: &dyn Fn(f64) -> f64, fs: f64, block: usize, m: usize) -> Vec<f64> {
            let fb = fs / block as f64;
            let bins = 8 * m;
            let du = 0.5 / bins as f64;
            let gain = |f: f64| {
                let x = PI * f / fs;
                let g = (block as f64 * x).sin() / (block as f64 * x.sin());
                g * g
            };
            let folded: Vec<f64> = (0..bins)
                .map(|i| {
                    let u = (i as f64 + 0.5) * du;
                    let mut p = 0.0;
                    for n in 0..=MAX_ALIASES {
                        for a in [n as f64 + u, n as f64 + 1.0 - u] {
                            if a <= block as f64 / 2.0 {
                                p += density(a * fb) * gain(a * fb);
                            }
                        }
                    }
                    fb * p * 4.0 * (PI * u).sin().powi(2) * du
                })
                .collect();
            cosine_sums(&folded, m)
        }
        let fs = 100.0;
        let resonance = |f: f64| {
            let (f0, q) = (7.0, 50.0);
            1e-6 / ((f * f - f0 * f0).powi(2) + (f * f0 / q).powi(2))
        };
        // (density, tolerance relative to the lag-0 variance): measured 4–7e-7 on the power
        // laws, 3–4e-4 on the resonance (16 table points across its half-power width).
        let cases: [(&dyn Fn(f64) -> f64, f64); 4] = [
            (&|_f: f64| 2e-6, 2e-6),
            (&|f: f64| 1e-9 / (f * f) + 1e-6, 2e-6),
            (&|f: f64| 1e-7 / f + 1e-6, 2e-6),
            (&resonance, 1e-3),
        ];
        for (density, tolerance) in cases {
            for block in [6, 350] {
                let fast = increment_autocovariance(density, fs, block, 64);
                let want = direct(density, fs, block, 64);
                for (k, (a, b)) in fast.iter().zip(&want).enumerate() {
                    assert!(
                        (a - b).abs() <= tolerance * want[0].abs(),
                        "block {block} lag {k}: {a} vs {b}"
                    );
                }
            }
        }
    }

    /// The transform agrees with cosines evaluated one by one, at the largest size used (8·512
    /// terms, lags to 512), for a spectrum spanning many decades as a random walk's does.
    #[test]
    fn cosine_sums_match_the_direct_sum() {
        let m = 512;
        let bins = 8 * m;
        let du = 0.5 / bins as f64;
        let mut rng = Rng::new(7);
        let p: Vec<f64> = (0..bins)
            .map(|i| rng.uniform() / (1.0 + i as f64).powi(2))
            .collect();
        let fast = cosine_sums(&p, m);
        let scale: f64 = p.iter().map(|v| v.abs()).sum();
        for (k, got) in fast.iter().enumerate() {
            let want: f64 = p
                .iter()
                .enumerate()
                .map(|(i, v)| {
                    v * (2.0 * std::f64::consts::PI * (i as f64 + 0.5) * du * k as f64).cos()
                })
                .sum();
            assert!(
                (got - want).abs() <= 1e-13 * scale,
                "lag {k}: {got} vs {want}"
            );
        }
    }

    /// White noise of variance σ²: block means have variance σ²/s, increments 2σ²/s at lag 0,
    /// −σ²/s at lag 1, 0 beyond.
    #[test]
    fn white_noise_increment_covariance_is_exact() {
        let (fs, s, sigma2) = (100.0, 50, 4.0);
        let density = |_f: f64| 2.0 * sigma2 / fs;
        let g = increment_autocovariance(&density, fs, s, 8);
        let v = sigma2 / s as f64;
        assert!((g[0] / (2.0 * v) - 1.0).abs() < 2e-3, "{g:?}");
        assert!((g[1] / -v - 1.0).abs() < 2e-3, "{g:?}");
        for k in 2..8 {
            assert!(g[k].abs() < 2e-3 * v, "{g:?}");
        }
    }

    /// A random walk of step variance q: increments of block means have variance
    /// q(2s² + 1)/(3s) and lag-1 covariance q(s² − 1)/(6s) (direct sums over the blocks).
    #[test]
    fn random_walk_increment_covariance_matches_the_direct_sum() {
        let (fs, s, q) = (10.0, 16usize, 1.0);
        // A discrete random walk of step variance q has one-sided density
        // 2q/fs / (4 sin²(πf/fs)).
        let density = |f: f64| {
            let x = (std::f64::consts::PI * f / fs).sin();
            2.0 * q / fs / (4.0 * x * x)
        };
        let g = increment_autocovariance(&density, fs, s, 4);
        let sf = s as f64;
        let var = q * (2.0 * sf * sf + 1.0) / (3.0 * sf);
        let lag1 = q * (sf * sf - 1.0) / (6.0 * sf);
        assert!((g[0] / var - 1.0).abs() < 5e-3, "{} vs {var}", g[0]);
        assert!((g[1] / lag1 - 1.0).abs() < 1e-2, "{} vs {lag1}", g[1]);
        assert!(g[2].abs() < 1e-2 * var, "{g:?}");
    }

    #[test]
    fn recovers_a_coefficient_under_random_walk_with_a_covering_interval() {
        // y = c·x + random walk + white; x a smooth warm-up plus white measurement noise.
        let (fs, n, c) = (10.0, 40_000, 0.5);
        let (q, w, xn) = (1e-4, 0.01, 0.05);
        let density = |f: f64| {
            let s = (std::f64::consts::PI * f / fs).sin();
            2.0 * q / fs / (4.0 * s * s) + 2.0 * w * w / fs
        };
        let (mut covered, mut zs, runs) = (0, Vec::new(), 200);
        let mut blocks = Vec::new();
        for seed in 0..runs {
            let mut rng = Rng::new(seed);
            let mut rw = 0.0;
            let xs: Vec<f64> = (0..n)
                .map(|i| 3.0 * (1.0 - (-(i as f64) / fs / 600.0).exp()))
                .collect();
            let y: Vec<f64> = xs
                .iter()
                .map(|x| {
                    rw += q.sqrt() * rng.gauss();
                    c * x + rw + w * rng.gauss()
                })
                .collect();
            let x_meas: Vec<f64> = xs.iter().map(|x| x + xn * rng.gauss()).collect();
            let noise = white_noise_variance(&x_meas);
            assert!((noise / (xn * xn) - 1.0).abs() < 0.1, "{noise}");
            let r = regress_series(&density, fs, &y, &x_meas, noise).unwrap();
            let g = r.gls;
            blocks.push(r.m);
            covered += usize::from((g.beta - c).abs() <= g.se);
            zs.push((g.beta - c) / g.se);
        }
        let cov = covered as f64 / runs as f64;
        let mean = zs.iter().sum::<f64>() / runs as f64;
        println!(
            "GLS coupling: 1σ coverage {cov:.3}, mean standardised error {mean:.3}, increments {:?}",
            &blocks[..5]
        );
        // Binomial σ of the coverage at 200 runs: 3.3 %.
        assert!((cov - 0.6827).abs() < 0.09, "{cov}");
        assert!(mean.abs() < 0.25, "{mean}");
    }

    #[test]
    fn independent_regressor_gives_uniform_p_values() {
        // Flat-spectrum noise against a smooth regressor: P(p < 0.05) ≈ 0.05.
        let (fs, n) = (10.0, 20_000);
        let density = |_f: f64| 2.0 / fs;
        let model = IncrementModel::new(&density, fs, n).unwrap();
        let x: Vec<f64> = (0..n).map(|i| (-(i as f64) / 3000.0).exp()).collect();
        let dx = model.increments(&x);
        let runs = 400;
        let mut small = 0;
        for seed in 0..runs {
            let mut rng = Rng::new(1000 + seed);
            let y: Vec<f64> = (0..n).map(|_| rng.gauss()).collect();
            let g = model.regress(&model.increments(&y), &dx, 0.0).unwrap();
            small += usize::from(g.p < 0.05);
        }
        let rate = small as f64 / runs as f64;
        println!("GLS null: P(p < 0.05) = {rate:.3}");
        // Binomial σ at 400 runs: 1.1 %.
        assert!((rate - 0.05).abs() < 0.035, "{rate}");
    }

    #[test]
    fn degenerate_inputs() {
        let density = |_f: f64| 1.0;
        assert!(IncrementModel::new(&density, 10.0, 50).is_none());
        let model = IncrementModel::new(&density, 10.0, 10_000).unwrap();
        let d = vec![0.0; model.m];
        assert!(model.regress(&d, &vec![1.0; model.m], 0.0).is_none());
        assert!(model.regress(&d[1..], &d[1..], 0.0).is_none());
        assert_eq!(white_noise_variance(&[1.0, 2.0]), 0.0);
    }
}
