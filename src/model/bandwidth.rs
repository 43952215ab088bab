//! The band in which a recording follows the IEEE model: the sensor's own low-pass filter.
//!
//! Real inertial sensors filter their output (an analog anti-alias filter, a digital low-pass, a
//! decimation filter), so the spectrum falls away below Nyquist and the shortest-τ Allan variances
//! fall below N²/τ. Fitted as if it were IEEE noise, the roll-off pulls N down, B and K up (the
//! Allan fit bends its model towards the depressed first points) and leaves a misfit the residual
//! loop then "explains" with resonances that do not exist.
//!
//! **Detection.** The spectrum fit's model (the terms the criterion chose on the whole band, with
//! N added) is refitted with every column but quantisation's (the output is rounded after the
//! filter) multiplied by a Butterworth-type power gain |H(f)|² = 1/(1 + (f/f_c)^(2n)) (an analog
//! filter) or its bilinear digital form with tan(πf/fs) for f (a digital low-pass at the output
//! rate, which reaches zero at Nyquist), over a grid of corners f_c (from 8 bands above the lowest
//! fitted band to 2·fs; below Nyquist for the digital form) and orders n ∈ {1, 2, 3, 4, 5, 6, 8}:
//! 8 corners per decade for every order and form, then 24 per decade within one coarse step of the
//! best, then 96 per decade at the best order and form. A
//! roll-off is reported when the best filtered model beats the unfiltered one by ΔBIC < −25
//! (two more parameters; far beyond "very strong" on the Kass–Raftery scale) and attenuates the
//! top fitted band by at least 1 dB. Both guards were set on a broad resonance (Q = 20 at 8 Hz,
//! 100 Hz rate) that a first-order "filter" at 186 Hz (0.3 dB at Nyquist) improved by ΔBIC −15.5;
//! real filters score −10² (15 min) to −10⁶ (3 h). The family is a shape, not a claim about the
//! sensor's circuit: a digital or FIR filter's edge is matched by a high order. Bands more than 5
//! standard errors above the median of their six neighbours (a vibration line, a resonance) are
//! left out of the comparison: a low-pass explains a deficit only, and a strong line in the band
//! otherwise made a "roll-off" that trimmed the band below the line.
//!
//! **Band rule.** Both fits then use only what the filter leaves within [`BAND_BIAS`] (2 %) of
//! its unfiltered value: the spectrum up to the frequency where 1 − |H|² = 2 % (then checked on
//! the data: while the IEEE model fitted below the edge leaves a deficit in the top 0.2 decade
//! (a suffix of its top bands with Σz/√k < −3.5), the edge moves down by 1/20 decade, and the Allan cut up by the same factor), and the Allan
//! variances from the shortest τ at and beyond which white noise through the filter reads at most
//! 2 % low. The white-noise Allan bias at τ = mτ₀ is exact for sampled data:
//! 1 − r(m) = (4m/fs)·∫₀^{fs/2} (1 − |H(f)|²)·sin⁴(πfm/fs)/(m²·sin²(πf/fs)) df, since the same
//! integral of 1 gives fs/(4m). White noise is the worst case: B and K live at low frequencies
//! the filter passes. Nothing above the band's edge is searched for effects either.
//!
//! **The bias left inside the band.** The Allan points kept still read up to 2 % low for white
//! noise, all in the same direction, which left the Allan N 0.9–1.8 % low on filtered sensors
//! (its 1σ interval, ±1–3 %, covering the truth in 40–60 % of 30-min records): the Allan fit
//! therefore multiplies N's column by r(m) at each kept τ ([`LowPass::white_avar_kept`]; N within
//! 0.3–0.8 % and covered in 62–74 % after). The spectrum's band is not corrected the same way:
//! its edge is checked on the data, and its N was already unbiased (0.9999–1.003); the fitted
//! filter's gain there made it 0.2–0.6 % high.

use rayon::prelude::*;
use serde::Serialize;

use crate::psd::{BinnedPsd, Psd};

use super::fit::{members, Mask, Problem, SubsetFit};
use super::psd_fit::{filtered_basis, spectrum_problem, spectrum_terms, BandSamples};
use super::select::rank_subsets;
use super::terms::{BASE, EFFECT, TERMS};
use super::{FitOptions, Term};

/// Largest bias a band's filter may leave in the points the fits use (2 %).
pub const BAND_BIAS: f64 = 0.02;
/// ΔBIC a low-pass model must reach to be reported.
const DETECT_BIC: f64 = -25.0;
/// Least attenuation (dB) the response must reach at the top fitted band to be reported.
const MIN_ATTENUATION_DB: f64 = 1.0;
/// A band this many of its own standard errors above the median of its neighbours is a narrow
/// excess, left out of the detection.
const EXCESS_Z: f64 = 5.0;

/// Whether band i stands above the median of the three bands on either side by more than
/// [`EXCESS_Z`] standard errors: a line or a resonance, not the smooth shape of a filter.
fn narrow_excess(p: &Problem, i: usize) -> bool {
    let lo = i.saturating_sub(3);
    let hi = (i + 3).min(p.len() - 1);
    let mut around: Vec<f64> = (lo..=hi).filter(|&k| k != i).map(|k| p.value[k]).collect();
    if around.is_empty() {
        return false;
    }
    around.sort_by(f64::total_cmp);
    let med = around[around.len() / 2];
    let nu = p.edf[i][0].max(1.0);
    med > 0.0 && p.value[i] / med - 1.0 > EXCESS_Z * (2.0 / nu).sqrt()
}
/// Orders tried.
const ORDERS: [u32; 7] = [1, 2, 3, 4, 5, 6, 8];
/// Corners per decade of the first, coarse scan (see [`detect_bandwidth`]).
const COARSE_PER_DECADE: f64 = 8.0;
/// Relative change of the coefficients at which the coarse and the 24-per-decade scans take a
/// trial's fit as settled: they only rank trials whose scores differ by whole units, which a
/// fit settled to a thousandth moves by far less; the refinement and the detection's ΔBIC use
/// fits settled to 1e-6 as every reported fit does.
const RANKING_TOLERANCE: f64 = 1e-3;
/// Factor beyond which [`LowPass::white_avar_kept`] extrapolates the bias as 1/m instead of
/// integrating (the integral's cost grows with m; the bias of a low-pass whose corner is well
/// inside the band falls as 1/m once m/fs is many filter time constants).
const WHITE_BIAS_EXACT_M: u64 = 4096;

/// The frequency axis of a [`LowPass`] response.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
#[serde(tag = "form", rename_all = "snake_case")]
pub enum FilterForm {
    /// An analog filter before the sampler: |H|² = 1/(1 + (f/f_c)^(2n)).
    Analog,
    /// A digital filter at the output rate (bilinear transform of the analog one):
    /// |H|² = 1/(1 + (tan(πf/fs)/tan(πf_c/fs))^(2n)), which reaches zero at Nyquist.
    Digital { rate_hz: f64 },
}

/// A Butterworth-type low-pass power response: −3 dB at the corner, a roll-off of −20·n dB per
/// decade beyond it (analog form), or its bilinear digital counterpart.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct LowPass {
    pub corner_hz: f64,
    pub order: u32,
    #[serde(flatten)]
    pub form: FilterForm,
}

impl LowPass {
    /// f on the filter's own frequency axis: |f| for the analog form, tan(π·|f|/fs) (f at most
    /// Nyquist) for the digital one.
    fn on_axis(form: FilterForm, f_hz: f64) -> f64 {
        match form {
            FilterForm::Analog => f_hz.abs(),
            FilterForm::Digital { rate_hz } => {
                (std::f64::consts::PI * f_hz.abs().min(rate_hz / 2.0) / rate_hz).tan()
            }
        }
    }

    /// f/f_c on the filter's own frequency axis (tan-warped for the digital form).
    fn ratio(&self, f_hz: f64) -> f64 {
        Self::on_axis(self.form, f_hz) / Self::on_axis(self.form, self.corner_hz)
    }

    /// |H(f)|².
    pub fn power_gain(&self, f_hz: f64) -> f64 {
        self.gain_at_ratio(self.ratio(f_hz))
    }

    /// |H|² at `r` = f/f_c on the filter's axis.
    fn gain_at_ratio(&self, r: f64) -> f64 {
        if r.is_finite() {
            1.0 / (1.0 + r.powi(2 * self.order as i32))
        } else {
            0.0
        }
    }

    /// The frequency where the gain has fallen by `bias` (1 − |H|² = bias).
    pub fn edge_hz(&self, bias: f64) -> f64 {
        let r = (bias / (1.0 - bias)).powf(1.0 / (2.0 * f64::from(self.order)));
        match self.form {
            FilterForm::Analog => self.corner_hz * r,
            FilterForm::Digital { rate_hz } => {
                let pi = std::f64::consts::PI;
                (r * (pi * self.corner_hz / rate_hz).tan()).atan() * rate_hz / pi
            }
        }
    }

    /// The fraction by which white noise through the filter reads low in the Allan variance at
    /// τ = m/fs (see the module docs).
    pub fn white_avar_bias(&self, rate_hz: f64, m: u64) -> f64 {
        let nyquist = rate_hz / 2.0;
        // Below `start` the filter loses less than 1e-9 of the power: nothing to integrate.
        let start = self.edge_hz(1e-9).min(nyquist);
        if start >= nyquist {
            return 0.0;
        }
        let mf = m as f64;
        // 32 points per period fs/m of sin⁴(πfm/fs), at least 4096.
        let points = ((32.0 * mf * (nyquist - start) / rate_hz) as usize).max(4096);
        let step = (nyquist - start) / points as f64;
        let sum: f64 = (0..points)
            .map(|i| {
                let f = start + (i as f64 + 0.5) * step;
                let u = std::f64::consts::PI * f / rate_hz;
                let t = (u * mf).sin().powi(4) / (mf * mf * u.sin().powi(2));
                (1.0 - self.power_gain(f)) * t
            })
            .sum();
        (4.0 * mf / rate_hz * sum * step).clamp(0.0, 1.0)
    }

    /// 1 − [`LowPass::white_avar_bias`]: the share of white noise's Allan variance at τ = m/fs
    /// that the filter leaves, which the Allan fit multiplies N's column by (the points it keeps
    /// read up to [`BAND_BIAS`] low, all the same way; see the module doc). Memoised: the fits of
    /// the residual loop ask for the same few factors hundreds of times. Beyond
    /// [`WHITE_BIAS_EXACT_M`] the bias is the one there times WHITE_BIAS_EXACT_M/m.
    pub fn white_avar_kept(&self, rate_hz: f64, m: u64) -> f64 {
        use std::collections::HashMap;
        use std::sync::{Mutex, OnceLock};
        type Key = (u64, u32, u64, u64, u64);
        static CACHE: OnceLock<Mutex<HashMap<Key, f64>>> = OnceLock::new();
        let exact_m = m.min(WHITE_BIAS_EXACT_M);
        let form = match self.form {
            FilterForm::Analog => 0,
            FilterForm::Digital { rate_hz } => rate_hz.to_bits(),
        };
        let key = (
            self.corner_hz.to_bits(),
            self.order,
            form,
            rate_hz.to_bits(),
            exact_m,
        );
        let cache = CACHE.get_or_init(|| Mutex::new(HashMap::new()));
        let cached = cache.lock().ok().and_then(|c| c.get(&key).copied());
        let bias = cached.unwrap_or_else(|| {
            let b = self.white_avar_bias(rate_hz, exact_m);
            if let Ok(mut c) = cache.lock() {
                if c.len() > 1 << 14 {
                    c.clear();
                }
                c.insert(key, b);
            }
            b
        });
        1.0 - bias * exact_m as f64 / m.max(1) as f64
    }
}

/// A detected roll-off and the band the fits keep.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Bandwidth {
    /// The fitted response.
    pub lowpass: LowPass,
    /// Asymptotic roll-off, dB per decade (−20·order).
    pub slope_db_per_decade: f64,
    /// Attenuation of the fitted response at Nyquist, dB (positive; at most 200: the digital form
    /// is zero there).
    pub nyquist_attenuation_db: f64,
    /// Highest band centre the spectrum fit keeps, Hz.
    pub fit_max_freq_hz: f64,
    /// Shortest τ the Allan fit keeps, s (`None`: every τ of the grid is biased beyond the rule).
    pub fit_min_tau_s: Option<f64>,
    /// BIC of the filtered model minus the unfiltered one (negative: the roll-off is real).
    pub delta_bic: f64,
    /// What the edge is taken for: the sensor's low-pass filter, or the coarse angle quantiser
    /// whose correlated rounding error makes the same deficit
    /// ([`crate::effects::angle_grid::attribute_edge`]).
    pub cause: BandEdge,
}

/// What ends the band in which the recording follows the IEEE model.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum BandEdge {
    /// The sensor's low-pass filter (anti-alias, digital, decimation): `lowpass` is its response.
    LowPass,
    /// The output is a coarse angle quantiser's grid (`step`, SI rate units, `steps_per_sigma`
    /// output white σ per step, at least [`crate::model::ANGLE_ERROR_CORRELATED_FROM_STEPS`]):
    /// its rounding error is correlated from sample to sample and falls below IEEE 952's
    /// quantisation form at high frequency, which reads as a roll-off. No filter is claimed
    /// (one may be there as well); `lowpass` only describes the edge's shape, and the band is
    /// kept, since the IEEE model does not hold above it.
    AngleQuantiser { step: f64, steps_per_sigma: f64 },
}

impl Bandwidth {
    /// Whether a sensor low-pass filter is claimed (the edge is not another cause's).
    pub fn is_filter(&self) -> bool {
        self.cause == BandEdge::LowPass
    }

    /// `opts` restricted to this band (an explicit band limit the user set stays if narrower), with
    /// the filter's response where the edge is a filter's.
    pub fn restrict(&self, opts: &FitOptions) -> FitOptions {
        let mut out = opts.clone();
        out.max_freq_hz = Some(
            opts.max_freq_hz
                .map_or(self.fit_max_freq_hz, |f| f.min(self.fit_max_freq_hz)),
        );
        let tau = self.fit_min_tau_s.unwrap_or(f64::INFINITY);
        out.min_tau_s = Some(opts.min_tau_s.map_or(tau, |t| t.max(tau)));
        // A quantiser's edge is no filter: N's Allan column keeps its whole share, the line
        // search its unfiltered model.
        out.lowpass = self.is_filter().then_some(self.lowpass);
        out
    }
}

/// −2·log-likelihood of the IRLS fit of `mask` on `problem` (∞ if it fails).
fn neg2ll(problem: &Problem, mask: Mask) -> f64 {
    neg2ll_settled(problem, mask, Settle::Report)
}

/// How far a trial's fit is iterated: as every reported fit ([`Problem::irls`]), or only as
/// far as ranking trials needs ([`Problem::irls_accelerated`] to [`RANKING_TOLERANCE`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Settle {
    Report,
    Rank,
}

impl Settle {
    fn fit(self, problem: &Problem, mask: Mask) -> SubsetFit {
        match self {
            Settle::Report => problem.irls(mask),
            Settle::Rank => problem.irls_accelerated(mask, RANKING_TOLERANCE),
        }
    }
}

/// [`neg2ll`] with the fit settled as `settle` says.
fn neg2ll_settled(problem: &Problem, mask: Mask, settle: Settle) -> f64 {
    let fit = settle.fit(problem, mask);
    if members(mask).iter().all(|&j| fit.c[j] <= 0.0) {
        return f64::INFINITY;
    }
    let (_, _, ll) = problem.likelihood(&fit);
    if ll.is_nan() {
        f64::INFINITY
    } else {
        ll
    }
}

/// The subset of `allowed` with the best criterion score on `problem` (eligible subsets only).
fn best_mask(problem: &Problem, allowed: Mask, opts: &FitOptions) -> Option<Mask> {
    rank_subsets(problem, allowed, 0, opts)
        .into_iter()
        .find(|(c, _)| c.proper && c.score.is_finite())
        .map(|(_, m)| m)
}

/// Looks for the sensor's low-pass roll-off in `psd` (binned as `binned`) and, if there is one,
/// the band both fits keep; `taus_s`: the Allan τ grid the band's shortest τ is chosen from.
/// `None`: no roll-off the data show (or the spectrum cannot be fitted at all).
pub fn detect_bandwidth(
    psd: &Psd,
    binned: &BinnedPsd,
    taus_s: &[f64],
    opts: &FitOptions,
) -> Option<Bandwidth> {
    let fs = psd.rate_hz;
    let (full, x_full, samples) = spectrum_problem(psd, binned, opts, None).ok()?;
    if full.len() < 8 {
        return None;
    }
    let allowed = spectrum_terms(opts);
    let white = 1u8 << Term::RandomWalk.index();
    let mask = best_mask(&full, allowed, opts)? | (white & allowed);
    if mask & white == 0 {
        return None;
    }
    // Narrow excesses (lines, resonances) are left out: a low-pass explains only a deficit, and
    // an excess it cannot fit would otherwise bend the comparison.
    let keep: Vec<usize> = (0..full.len())
        .filter(|&i| !narrow_excess(&full, i))
        .collect();
    let plain = full.subset(&keep);
    let x: Vec<f64> = keep.iter().map(|&i| x_full[i]).collect();
    let n = plain.len();
    if n < 8 {
        return None;
    }
    let base = neg2ll(&plain, mask);
    // The basis samples and the bands' correlation are computed once; each response only
    // reweights the samples.
    let samples: BandSamples = keep.iter().map(|&i| samples[i].clone()).collect();
    // With a white floor after the filter too (a converter's noise, output glitches), charged one
    // parameter: without it, 300 glitches of a gyro (a floor 0.11× the white level) made the
    // roll-off of a second-order filter at 40 Hz read as a first-order one at 25 Hz, and the fit
    // band end at 3.6 Hz.
    let floor_penalty = (plain.len() as f64).ln();
    let forms = [FilterForm::Analog, FilterForm::Digital { rate_hz: fs }];
    // The floor's column is the unfiltered white basis, the same for every response: set once (in
    // the effect column, with white noise's EDF) on the problem the trials copy.
    let white = Term::RandomWalk.index();
    let mut floored = plain.clone();
    for (b, edf) in floored.basis.iter_mut().zip(floored.edf.iter_mut()) {
        b[EFFECT] = b[white];
        edf[EFFECT] = edf[white];
    }
    // Every sample's place on both forms' axes, computed once for the hundreds of trials (the
    // digital form's tangent at each sample of each trial was a sixth of the detection's time).
    let axes: Vec<Vec<[f64; 2]>> = samples
        .iter()
        .map(|band| {
            band.iter()
                .map(|&(f, _)| forms.map(|form| LowPass::on_axis(form, f)))
                .collect()
        })
        .collect();
    // `base` (the unfiltered or floored problem) with the response's filtered base terms.
    let filtered = |base: &Problem, lp: &LowPass| -> Problem {
        let form = forms
            .iter()
            .position(|&f| f == lp.form)
            .expect("every trial has one of the forms");
        let corner = LowPass::on_axis(lp.form, lp.corner_hz);
        let gain = |band: usize, k: usize| lp.gain_at_ratio(axes[band][k][form] / corner);
        let mut p = base.clone();
        for (b, f) in p.basis.iter_mut().zip(filtered_basis(&samples, gain)) {
            b[..BASE].copy_from_slice(&f[..BASE]);
        }
        p
    };
    let with_floor = |lp: &LowPass| filtered(&floored, lp);
    // One fit per trial with the floor allowed: the non-negative fit leaves it at 0 where it
    // does not help, and only a floor in use is charged.
    let try_filter = |lp: LowPass, floor: bool, settle: Settle| -> f64 {
        if !floor {
            return neg2ll_settled(&filtered(&plain, &lp), mask, settle);
        }
        let p = with_floor(&lp);
        let fit = settle.fit(&p, mask | (1 << EFFECT));
        if members(mask).iter().all(|&j| fit.c[j] <= 0.0) {
            return f64::INFINITY;
        }
        let (_, _, ll) = p.likelihood(&fit);
        let charged = if fit.c[EFFECT] > 0.0 {
            floor_penalty
        } else {
            0.0
        };
        if ll.is_nan() {
            f64::INFINITY
        } else {
            ll + charged
        }
    };
    // Corners from 8 bands above the lowest fitted one to 2·fs.
    let f_lo = x[8.min(n - 1)];
    let f_hi = 2.0 * fs;
    let grid = |per_decade: f64, lo: f64, hi: f64| -> Vec<f64> {
        let steps = ((hi / lo).log10() * per_decade).ceil().max(1.0) as usize;
        (0..=steps)
            .map(|k| lo * 10f64.powf(k as f64 / per_decade))
            .collect()
    };
    // Every trial is independent: they are scored in parallel (the channel's other cores are idle
    // when a file has fewer channels than cores, or at the end of a file) and the first best in
    // the sequential order is taken, as a sequential scan would.
    let first_best = |trials: Vec<LowPass>,
                      start: (f64, LowPass),
                      floor: bool,
                      settle: Settle|
     -> (f64, LowPass) {
        let scores: Vec<f64> = trials
            .par_iter()
            .map(|&lp| try_filter(lp, floor, settle))
            .collect();
        trials.into_iter().zip(scores).fold(
            start,
            |best, (lp, ll)| if ll < best.0 { (ll, lp) } else { best },
        )
    };
    // Every order and form on a coarse corner grid (8 per decade), then every order and form on
    // a 24-per-decade grid within one coarse step of the coarse best, then the best's corner at
    // 96 per decade. The likelihood moves smoothly with the corner (a low-pass's response changes
    // by a few per cent between corners a third of a decade apart), so the coarse pass finds the
    // basin at a third of the trials of a 24-per-decade scan of the whole band, which was a
    // tenth of the model stage on 10⁷-sample records.
    let trials_between = |per_decade: f64, lo: f64, hi: f64| -> Vec<LowPass> {
        let mut trials = Vec::new();
        for form in forms {
            // A digital corner lies below Nyquist.
            let top = match form {
                FilterForm::Analog => hi,
                FilterForm::Digital { .. } => hi.min(0.499 * fs),
            };
            if top < lo {
                continue;
            }
            for &order in &ORDERS {
                for &corner_hz in &grid(per_decade, lo, top) {
                    if matches!(form, FilterForm::Digital { .. }) && corner_hz >= 0.5 * fs {
                        continue;
                    }
                    trials.push(LowPass {
                        corner_hz,
                        order,
                        form,
                    });
                }
            }
        }
        trials
    };
    let unfiltered = LowPass {
        corner_hz: f_hi,
        order: 1,
        form: FilterForm::Analog,
    };
    let search = |floor: bool| -> (f64, LowPass) {
        let best = first_best(
            trials_between(COARSE_PER_DECADE, f_lo, f_hi),
            (f64::INFINITY, unfiltered),
            floor,
            Settle::Rank,
        );
        let best = if best.0.is_finite() {
            let step = 10f64.powf(1.0 / COARSE_PER_DECADE);
            let lo = (best.1.corner_hz / step).max(f_lo);
            let hi = (best.1.corner_hz * step).min(f_hi);
            first_best(trials_between(24.0, lo, hi), best, floor, Settle::Rank)
        } else {
            best
        };
        // The refinement's scores are the fits' own (settled to 1e-6), the start's too: the
        // detection's ΔBIC is taken from them.
        let best = if best.0.is_finite() {
            (try_filter(best.1, floor, Settle::Report), best.1)
        } else {
            best
        };
        // Refine the corner at the best order.
        let coarse = best.1;
        let step = 10f64.powf(1.0 / 24.0);
        let refine: Vec<LowPass> = grid(96.0, coarse.corner_hz / step, coarse.corner_hz * step)
            .into_iter()
            .map(|corner_hz| LowPass {
                corner_hz,
                ..coarse
            })
            .filter(|lp| {
                !(matches!(lp.form, FilterForm::Digital { .. }) && lp.corner_hz >= 0.5 * fs)
            })
            .collect();
        first_best(refine, best, floor, Settle::Report)
    };
    // The attenuation (dB) the model shows at the top band: with a floor, the filtered terms plus
    // the floor against the same terms unfiltered plus the floor (a floor near the white level
    // lets a response that attenuates little of the total mimic a bump: a resonance's shoulder
    // was read as a filter in 49 of 50 records before this was checked); without, the
    // response's own.
    let attenuation_db = |lp: &LowPass, floor: bool| -> f64 {
        if !floor {
            return -10.0 * lp.power_gain(x[n - 1]).log10();
        }
        let p = with_floor(lp);
        let fit = p.irls(mask | (1 << EFFECT));
        let last = p.len() - 1;
        let model = |basis: &[f64; TERMS]| -> f64 {
            members(mask | (1 << EFFECT))
                .iter()
                .map(|&j| fit.c[j].max(0.0) * basis[j])
                .sum()
        };
        let mut unfiltered = plain.basis[last];
        unfiltered[EFFECT] = p.basis[last][EFFECT];
        10.0 * (model(&unfiltered) / model(&p.basis[last])).log10()
    };
    let penalty = 2.0 * (n as f64).ln();
    let accepted = |(ll, lp): (f64, LowPass), floor: bool| -> Option<(f64, LowPass)> {
        let delta_bic = ll - base + penalty;
        let db = attenuation_db(&lp, floor);
        (delta_bic < DETECT_BIC && db >= MIN_ATTENUATION_DB).then_some((delta_bic, lp))
    };
    // The floor first; where its best response attenuates too little of the total, the search
    // without it (whose response then has to fall by itself: a band where the spectrum falls
    // below the model is not the model's, filter or not; an angle quantiser with little motion
    // falls 17 % below the IEEE form near Nyquist, and fitting there bent N by 5 %).
    let with = search(true);
    let (delta_bic, lowpass) = match accepted(with, true) {
        Some(found) => found,
        None if with.0 - base + penalty < DETECT_BIC => accepted(search(false), false)?,
        None => return None,
    };
    let shaped_edge = lowpass.edge_hz(BAND_BIAS);
    let fit_max_freq_hz = checked_edge(&full, &x_full, opts, mask, shaped_edge);
    // Where the data moved the edge down, the filter acts lower than its fitted shape says: the
    // Allan cut moves up by the same factor.
    let tau_scale = shaped_edge / fit_max_freq_hz;
    // The shortest τ after the last one the filter biases beyond the rule.
    let mut sorted: Vec<f64> = taus_s.iter().copied().filter(|t| *t > 0.0).collect();
    sorted.sort_by(f64::total_cmp);
    let biased = |tau: f64| {
        let m = (tau * fs).round().max(1.0) as u64;
        lowpass.white_avar_bias(fs, m) > BAND_BIAS
    };
    // Bias falls with τ; scan from the short end and stop after a run of clean octaves.
    let mut last_biased = None;
    let mut clean_run = 0.0;
    let mut prev: Option<f64> = None;
    for (i, &tau) in sorted.iter().enumerate() {
        if biased(tau) {
            last_biased = Some(i);
            clean_run = 0.0;
        } else if let Some(p) = prev {
            clean_run += (tau / p).log2();
            if clean_run >= 3.0 {
                break;
            }
        }
        prev = Some(tau);
    }
    let fit_min_tau_s = match last_biased {
        None => sorted.first().copied(),
        Some(i) => sorted.get(i + 1).copied(),
    }
    .and_then(|t| {
        sorted
            .iter()
            .copied()
            .find(|&s| s >= t * tau_scale * (1.0 - 1e-9))
    });
    Some(Bandwidth {
        lowpass,
        slope_db_per_decade: -20.0 * f64::from(lowpass.order),
        nyquist_attenuation_db: (-10.0 * lowpass.power_gain(fs / 2.0).log10()).min(200.0),
        fit_max_freq_hz,
        fit_min_tau_s,
        delta_bic,
        cause: BandEdge::LowPass,
    })
}

/// Deficit (the most negative suffix sum of the top bands' z over √count) below which the edge
/// is lowered.
const EDGE_DEFICIT_Z: f64 = -3.5;

/// The edge checked on the data: the unfiltered model (the terms the criterion picks on that band)
/// fitted below `edge` must leave no deficit in its top 0.2 decade (the fitted response is a family shape and may be wrong near the corner);
/// while it does, the edge is lowered by 1/20 decade (at most a decade in all). Narrow excesses
/// ([`narrow_excess`]) are left out of that fit and that deficit, as out of the detection: a
/// resonance's peak (Q 20 at 13.8 Hz, 15× the floor, 200 Hz rate) lifted the model, left the
/// bands beside it "in deficit", and walked the edge down from 21.6 Hz to 12.6 Hz, below the
/// peak; its skirt, left in the band, then passed for a Gauss–Markov process and a cascade of
/// slow effects followed.
fn checked_edge(full: &Problem, x: &[f64], opts: &FitOptions, mask: Mask, edge: f64) -> f64 {
    let mut edge = edge;
    let excess: Vec<bool> = (0..x.len()).map(|i| narrow_excess(full, i)).collect();
    for _ in 0..20 {
        let below: Vec<usize> = (0..x.len())
            .filter(|&i| x[i] <= edge && !excess[i])
            .collect();
        let p = full.subset(&below);
        let f: Vec<f64> = below.iter().map(|&i| x[i]).collect();
        if p.len() < 8 {
            break;
        }
        // The terms the fit itself would choose on this band (quantisation's rise can hide a
        // deficit from a model fixed on the whole band).
        let mask = best_mask(&p, spectrum_terms(opts), opts).unwrap_or(mask);
        let fit = p.irls(mask);
        let (z, _, _) = p.likelihood(&fit);
        let floor = edge / 10f64.powf(0.2);
        let top: Vec<f64> = z
            .iter()
            .zip(&f)
            .filter(|(_, &f)| f >= floor)
            .map(|(z, _)| *z)
            .collect();
        if top.is_empty() {
            break;
        }
        // The most negative of the suffix sums (top band, top two, …) over √count: a deficit
        // that grows towards the edge shows first in the last bands.
        let mut stat = f64::INFINITY;
        let mut sum = 0.0;
        for (k, z) in top.iter().rev().enumerate() {
            sum += z;
            stat = stat.min(sum / ((k + 1) as f64).sqrt());
        }
        if stat > EDGE_DEFICIT_Z {
            break;
        }
        edge /= 10f64.powf(0.05);
    }
    edge
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn digital_form_is_the_simulators_bilinear_butterworth() {
        // The simulator's filter is an independent implementation (biquad sections).
        for order in [1, 2, 4] {
            let spec = crate::sim::LowPassSpec {
                corner_hz: 20.0,
                order,
            };
            let lp = LowPass {
                corner_hz: 20.0,
                order,
                form: FilterForm::Digital { rate_hz: 100.0 },
            };
            for f in [1.0, 10.0, 20.0, 35.0, 49.0] {
                let want = crate::sim::lowpass_power_gain(&spec, 100.0, f);
                assert!(
                    (lp.power_gain(f) - want).abs() < 1e-9,
                    "order {order} f {f}"
                );
            }
        }
    }

    #[test]
    fn white_bias_of_a_brick_wall_at_nyquist_is_zero_and_of_nothing_is_one() {
        // A filter far above Nyquist loses nothing; one far below loses everything.
        let high = LowPass {
            corner_hz: 1e6,
            order: 4,
            form: FilterForm::Analog,
        };
        assert!(high.white_avar_bias(100.0, 1) < 1e-9);
        let low = LowPass {
            corner_hz: 1e-6,
            order: 4,
            form: FilterForm::Analog,
        };
        assert!((low.white_avar_bias(100.0, 4) - 1.0).abs() < 1e-3);
    }

    #[test]
    fn white_bias_matches_filtered_noise() {
        // Measured: Allan variance of white noise through a sharp low-pass at half Nyquist,
        // against the integral. m = 1: the first difference sees the filter fully.
        let lp = LowPass {
            corner_hz: 25.0,
            order: 8,
            form: FilterForm::Analog,
        };
        // For m = 1 the transfer is sin²(πf/fs); a brick wall at fs/4 loses
        // 4·∫_{1/4}^{1/2} sin²(πx) dx = 1/2 + 1/π of it. An 8th-order edge is close to that.
        let brick = 0.5 + 1.0 / std::f64::consts::PI;
        let got = lp.white_avar_bias(100.0, 1);
        assert!((got - brick).abs() < 0.03, "{got} vs {brick}");
        // Long τ: the loss falls roughly as 1/m.
        let b8 = lp.white_avar_bias(100.0, 8);
        let b64 = lp.white_avar_bias(100.0, 64);
        assert!(b64 < b8 && b64 > 0.0 && b64 < 0.2 * b8, "{b8} {b64}");
    }

    /// The memoised share equals 1 − the integral up to the exact range, and beyond it the 1/m
    /// extrapolation agrees with the integral (digital order 2 at 20 Hz and analog order 1 at
    /// 10 Hz, 100 Hz rate, as in the validation).
    #[test]
    fn kept_white_share_is_the_integral_and_extrapolates_as_one_over_m() {
        let filters = [
            LowPass {
                corner_hz: 20.0,
                order: 2,
                form: FilterForm::Digital { rate_hz: 100.0 },
            },
            LowPass {
                corner_hz: 10.0,
                order: 1,
                form: FilterForm::Analog,
            },
        ];
        for lp in filters {
            for m in [1, 8, 64, 4096] {
                let direct = 1.0 - lp.white_avar_bias(100.0, m);
                assert_eq!(lp.white_avar_kept(100.0, m), direct);
                // Asked again: the memo gives the same.
                assert_eq!(lp.white_avar_kept(100.0, m), direct);
            }
            for m in [8192, 32768] {
                let (got, want) = (
                    1.0 - lp.white_avar_kept(100.0, m),
                    lp.white_avar_bias(100.0, m),
                );
                assert!(
                    (got / want - 1.0).abs() < 0.02,
                    "m {m}: {got:e} vs {want:e}"
                );
            }
        }
    }

    #[test]
    fn edge_is_where_the_gain_has_fallen_by_the_bias() {
        for form in [FilterForm::Analog, FilterForm::Digital { rate_hz: 100.0 }] {
            let lp = LowPass {
                corner_hz: 20.0,
                order: 3,
                form,
            };
            let f = lp.edge_hz(BAND_BIAS);
            assert!((1.0 - lp.power_gain(f) - BAND_BIAS).abs() < 1e-12);
            assert!((lp.power_gain(20.0) - 0.5).abs() < 1e-12);
        }
    }
}
