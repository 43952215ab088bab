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
//! rate, which reaches zero at Nyquist), or the analog form sampled with its tail above Nyquist
//! folded back ([`FilterForm::Sampled`]: a part that decimates without a further filter, whose
//! spectrum rises back towards Nyquist), or a sinc^k decimator's folded response
//! ([`Decimator`], k ∈ {2, 3, 4, 5}: the CIC filter of sigma-delta MEMS parts, whose droop grows
//! as f² from DC and which no Butterworth shape follows) alone or times a digital low-pass of
//! order 1–4. Every family (form, order, decimator) is scored on a grid of corners f_c (8 per
//! decade, from 8 bands above the lowest fitted band to 2·fs; below Nyquist for the digital
//! form), each family's best corner is refined by a golden-section search within one grid step,
//! the best family's once more with every fit settled, and a decimator's factor is chosen among
//! 2–32 or large with the corner refined at each. A low-pass after a decimator is charged one
//! parameter more than a low-pass, a decimator alone one fewer, and a decimator is dropped for
//! the best response without one where the band below the latter's 2 % edge refutes it or holds
//! a narrow excess (see `detect_bandwidth`). A
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
//! 0.3–0.8 % and covered in 62–74 % after). The spectrum fit's terms carry the fitted response
//! (quantisation's excepted; [`FitOptions::lowpass`]): with a Butterworth edge the loss inside
//! the band is concentrated near the edge and N was unbiased without it, but a sinc³ decimator's
//! droop spreads over the whole band, and N read 0.4 % low (1-kHz records, ±0.15–0.25 %
//! intervals) until the fit carried it. An edge that falls inside a line, or within 10 % below
//! one, steps below the line ([`below_edge_line`]).

use rayon::prelude::*;
use serde::Serialize;

use crate::psd::{BinnedPsd, Psd};

use super::decimator::Decimator;
use super::fit::{members, Mask, Problem, SubsetFit};
use super::psd_fit::{filtered_basis, spectrum_problem, spectrum_terms, BandSamples};
use super::select::rank_subsets;
use super::terms::{BASE, EFFECT, TERMS};
use super::{FitOptions, Term};

/// Largest bias a band's filter may leave in the points the fits use (2 %).
pub const BAND_BIAS: f64 = 0.02;
/// ΔBIC a low-pass model must reach to be reported.
pub const DETECT_BIC: f64 = -25.0;
/// Least attenuation (dB) the response must reach at the top fitted band to be reported.
const MIN_ATTENUATION_DB: f64 = 1.0;
/// A band this many of its own standard errors above the median of its neighbours is a narrow
/// excess, left out of the detection.
const EXCESS_Z: f64 = 5.0;

/// Whether band i stands above the median of the three bands on either side by more than
/// [`EXCESS_Z`] standard errors: a line or a resonance, not the smooth shape of a filter.
pub(super) fn narrow_excess(p: &Problem, i: usize) -> bool {
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

/// ΔBIC (the decimator's response against the best without one, on the bands below the latter's
/// 2 % edge) beyond which the band refutes the decimator (strong evidence on the Kass–Raftery
/// scale).
const DECIMATOR_REFUTED_BIC: f64 = 10.0;
/// Orders tried.
const ORDERS: [u32; 7] = [1, 2, 3, 4, 5, 6, 8];
/// Stages of the sinc^k decimators tried (alone, and before a digital low-pass of an order in
/// [`CASCADE_ORDERS`]), in their large-factor limit; the factor is refined at the end.
const DECIMATOR_STAGES: [u32; 4] = [2, 3, 4, 5];
/// Orders of the digital low-pass tried after a decimator (a part's output low-pass after its
/// sinc stage is of low order; the higher ones are the plain low-pass's).
const CASCADE_ORDERS: [u32; 4] = [1, 2, 3, 4];
/// Decimation factors the best decimator is refined over (`None`: the large-factor limit).
const DECIMATOR_FACTORS: [Option<u32>; 9] = [
    Some(2),
    Some(3),
    Some(4),
    Some(5),
    Some(6),
    Some(8),
    Some(16),
    Some(32),
    None,
];
/// Corners per decade of the first, coarse scan (see [`detect_bandwidth`]).
const COARSE_PER_DECADE: f64 = 8.0;
/// Relative change of the coefficients at which the coarse scan and the families' corner searches
/// take a trial's fit as settled: they only rank trials whose scores differ by whole units, which a
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
    /// An analog (or fast digital) filter whose output is sampled at `rate_hz` with nothing
    /// more to stop its tail above Nyquist (a part that decimates without a further filter): the
    /// tail folds back, |H|² summed over the images f + k·fs, k = −2…2 ([`FOLDED_IMAGES`]), taken
    /// relative to that sum at 0 Hz (the white level N describes is the output's). Its
    /// spectrum rises back towards Nyquist from the analog form's; a 200-Hz MEMS record behind a
    /// second-order 60-Hz filter run at 1600 Hz and decimated by 8 was read in the analog form
    /// at 57 Hz, 10.2 dB at Nyquist for a measured 6.6, and the folded white noise left at the
    /// Allan fit's shortest τ was taken for angle quantisation (Q kept in 17 of 78 channels
    /// with none planted).
    Sampled { rate_hz: f64 },
}

/// The images of the sampled form's fold: k·fs ± f for k = 1, 2 (beyond, an order-1 filter at a
/// quarter of the rate adds less than 1 % of its gain at Nyquist).
const FOLDED_IMAGES: i32 = 2;

/// A Butterworth-type low-pass power response: −3 dB at the corner, a roll-off of −20·n dB per
/// decade beyond it (analog form), or its bilinear digital counterpart; optionally after a sinc^k
/// decimator ([`Decimator`], digital form only), whose folded response multiplies it. `order` 0:
/// the decimator alone, and `corner_hz` is then the cascade's half-power frequency.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct LowPass {
    pub corner_hz: f64,
    pub order: u32,
    #[serde(flatten)]
    pub form: FilterForm,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub decimator: Option<Decimator>,
}

impl LowPass {
    /// f on the filter's own frequency axis: |f| for the analog form, tan(π·|f|/fs) (f at most
    /// Nyquist) for the digital one.
    fn on_axis(form: FilterForm, f_hz: f64) -> f64 {
        match form {
            FilterForm::Analog | FilterForm::Sampled { .. } => f_hz.abs(),
            FilterForm::Digital { rate_hz } => {
                (std::f64::consts::PI * f_hz.abs().min(rate_hz / 2.0) / rate_hz).tan()
            }
        }
    }

    /// f/f_c on the filter's own frequency axis (tan-warped for the digital form).
    fn ratio(&self, f_hz: f64) -> f64 {
        Self::on_axis(self.form, f_hz) / Self::on_axis(self.form, self.corner_hz)
    }

    /// |H(f)|² (with a decimator, its folded response times the low-pass's; the sampled form's
    /// summed over its images).
    pub fn power_gain(&self, f_hz: f64) -> f64 {
        if let FilterForm::Sampled { rate_hz } = self.form {
            return self.sampled_response(rate_hz)(f_hz);
        }
        self.gain_at_ratio(self.ratio(f_hz)) * self.decimator_gain(f_hz)
    }

    /// The sampled form's |H(f)|²: the analog response summed over its images ([`folded`]),
    /// relative to that sum at 0 Hz, which is computed once here (the detection evaluates one
    /// trial's response at thousands of frequencies). Relative to 0 Hz: N is the white level the
    /// output holds at low frequency, aliased noise included (what the Allan deviation at 1 s
    /// reads and a navigation filter sees), as for the other forms, whose gain there is 1.
    fn sampled_response(&self, rate_hz: f64) -> impl Fn(f64) -> f64 + '_ {
        let at = move |image: f64| self.gain_at_ratio(image / self.corner_hz);
        let at_zero = folded(0.0, rate_hz, at);
        move |f_hz| folded(f_hz, rate_hz, at) / at_zero
    }

    /// The decimator's folded response at f (1 without one).
    fn decimator_gain(&self, f_hz: f64) -> f64 {
        match (self.decimator, self.form) {
            (Some(d), FilterForm::Digital { rate_hz }) => d.power_gain(f_hz, rate_hz),
            _ => 1.0,
        }
    }

    /// A sinc^k decimator alone at the output rate `rate_hz`: `corner_hz` is its half-power
    /// frequency.
    pub fn decimator_alone(decimator: Decimator, rate_hz: f64) -> LowPass {
        let mut lp = LowPass {
            corner_hz: rate_hz / 2.0,
            order: 0,
            form: FilterForm::Digital { rate_hz },
            decimator: Some(decimator),
        };
        lp.corner_hz = lp.edge_hz(0.5);
        lp
    }

    /// |H|² at `r` = f/f_c on the filter's axis (the low-pass stage alone).
    fn gain_at_ratio(&self, r: f64) -> f64 {
        if self.order == 0 {
            1.0
        } else if r.is_finite() {
            1.0 / (1.0 + r.powi(2 * self.order as i32))
        } else {
            0.0
        }
    }

    /// The frequency where the gain has fallen by `bias` (1 − |H|² = bias); with a decimator, by
    /// bisection up to Nyquist (Nyquist where the loss stays below `bias`).
    pub fn edge_hz(&self, bias: f64) -> f64 {
        if let (Some(_), FilterForm::Digital { rate_hz }) = (self.decimator, self.form) {
            let loss = |f: f64| 1.0 - self.power_gain(f);
            let (mut lo, mut hi) = (0.0, rate_hz / 2.0);
            if loss(hi) <= bias {
                return hi;
            }
            for _ in 0..100 {
                let mid = 0.5 * (lo + hi);
                if loss(mid) > bias {
                    hi = mid;
                } else {
                    lo = mid;
                }
            }
            return 0.5 * (lo + hi);
        }
        // The sampled form's images add power near Nyquist only: its edge is taken as the
        // analog one's, which errs low.
        let r = (bias / (1.0 - bias)).powf(1.0 / (2.0 * f64::from(self.order)));
        match self.form {
            FilterForm::Analog | FilterForm::Sampled { .. } => self.corner_hz * r,
            FilterForm::Digital { rate_hz } => {
                let pi = std::f64::consts::PI;
                (r * (pi * self.corner_hz / rate_hz).tan()).atan() * rate_hz / pi
            }
        }
    }

    /// The asymptotic roll-off of the response's envelope, dB per decade: −20 per low-pass order
    /// and per decimator stage.
    pub fn slope_db_per_decade(&self) -> f64 {
        -20.0 * f64::from(self.order + self.decimator.map_or(0, |d| d.stages))
    }

    /// The fraction by which white noise through the filter reads low in the Allan variance at
    /// τ = m/fs (see the module docs).
    pub fn white_avar_bias(&self, rate_hz: f64, m: u64) -> f64 {
        // Below `start` the filter loses less than 1e-9 of the power: nothing to integrate.
        let start = self.edge_hz(1e-9);
        white_avar_share(rate_hz, m, start, |f| 1.0 - self.power_gain(f))
    }

    /// 1 − [`LowPass::white_avar_bias`]: the share of white noise's Allan variance at τ = m/fs
    /// that the filter leaves, which the Allan fit multiplies N's column by (the points it keeps
    /// read up to [`BAND_BIAS`] low, all the same way; see the module doc). Memoised: the fits of
    /// the residual loop ask for the same few factors hundreds of times. Beyond
    /// [`WHITE_BIAS_EXACT_M`] the bias is the one there times WHITE_BIAS_EXACT_M/m.
    pub fn white_avar_kept(&self, rate_hz: f64, m: u64) -> f64 {
        use std::collections::HashMap;
        use std::sync::{Mutex, OnceLock};
        type Key = (u64, u32, u64, u64, u64, u32, u32);
        static CACHE: OnceLock<Mutex<HashMap<Key, f64>>> = OnceLock::new();
        let exact_m = m.min(WHITE_BIAS_EXACT_M);
        let form = match self.form {
            FilterForm::Analog => 0,
            FilterForm::Digital { rate_hz } => rate_hz.to_bits(),
            FilterForm::Sampled { rate_hz } => !rate_hz.to_bits(),
        };
        let key = (
            self.corner_hz.to_bits(),
            self.order,
            form,
            rate_hz.to_bits(),
            exact_m,
            self.decimator.map_or(0, |d| d.stages),
            self.decimator.map_or(0, |d| d.factor.unwrap_or(u32::MAX)),
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

/// Σ `gain`(|f + k·fs|) over k = −[`FOLDED_IMAGES`]…[`FOLDED_IMAGES`]: a response sampled at fs
/// with its tail folded back.
fn folded(f_hz: f64, rate_hz: f64, gain: impl Fn(f64) -> f64) -> f64 {
    (-FOLDED_IMAGES..=FOLDED_IMAGES)
        .map(|k| gain((f_hz + f64::from(k) * rate_hz).abs()))
        .sum()
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

/// The share of white noise's Allan variance at τ = m/fs that frequencies from `start` Hz to
/// Nyquist carry, each weighted by `weight(f)` (a filter's lost power 1 − |H|², or 1 above a
/// band's edge): (4m/fs)·∫ weight(f)·sin⁴(πfm/fs)/(m²·sin²(πf/fs)) df, the Allan transfer
/// function of the sampled series against its white density.
fn white_avar_share(rate_hz: f64, m: u64, start: f64, weight: impl Fn(f64) -> f64) -> f64 {
    let nyquist = rate_hz / 2.0;
    if start >= nyquist {
        return 0.0;
    }
    let start = start.max(0.0);
    let mf = m as f64;
    // 32 points per period fs/m of sin⁴(πfm/fs), at least 4096.
    let points = ((32.0 * mf * (nyquist - start) / rate_hz) as usize).max(4096);
    let step = (nyquist - start) / points as f64;
    let sum: f64 = (0..points)
        .map(|i| {
            let f = start + (i as f64 + 0.5) * step;
            let u = std::f64::consts::PI * f / rate_hz;
            let t = (u * mf).sin().powi(4) / (mf * mf * u.sin().powi(2));
            weight(f) * t
        })
        .sum();
    (4.0 * mf / rate_hz * sum * step).clamp(0.0, 1.0)
}

/// The shortest τ of `taus_s` from which the Allan fit answers for the band below `max_freq_hz`
/// only: where white noise above that frequency carries at most [`BAND_BIAS`] of the Allan
/// variance (about τ ≥ 7.6/f; the bias a detected filter's edge may leave). A user who keeps the
/// spectrum fit below a frequency (`--fit-max-freq`, to leave out a rotor's lines, say) keeps
/// the Allan fit from the τ that do not see above it: at τ = 1 ms a 1-kHz record's Allan
/// variance holds every line up to Nyquist, and a line at 192 Hz beyond a 100-Hz band was read
/// there as a Gauss–Markov process (ΔBIC −2·10⁵).
///
/// The rule is white noise's, not the measured spectrum's: strong lines above the band (0.3 m/s²
/// at 83 and 166 Hz over 90 µg/√Hz on a flight controller's accelerometer) would move the
/// measured rule's start to tens of seconds, where the Allan fit no longer sees N, and the
/// time-domain detectors, which take their null from the fitted model, then found excursions
/// and steps in white noise (4 on one channel). What the lines leave in the Allan variance
/// beyond the start is what the loop's narrow bands take out of the series. `None` when no τ of
/// the grid qualifies.
pub fn band_min_tau(max_freq_hz: f64, rate_hz: f64, taus_s: &[f64]) -> Option<f64> {
    let mut sorted: Vec<f64> = taus_s.iter().copied().filter(|t| *t > 0.0).collect();
    sorted.sort_by(f64::total_cmp);
    sorted.into_iter().find(|&tau| {
        let m = (tau * rate_hz).round().max(1.0) as u64;
        white_avar_share(rate_hz, m, max_freq_hz, |_| 1.0) <= BAND_BIAS
    })
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
    // The problem of the unfiltered model: each trial's response reweights its samples.
    let unfiltered_opts = FitOptions {
        lowpass: None,
        ..opts.clone()
    };
    let (full, x_full, samples) = spectrum_problem(psd, binned, &unfiltered_opts, None).ok()?;
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
    // Which bands are narrow excesses: left out of the detection, and asked again by the
    // decimator's gate, the edge's check and the edge's step below a line.
    let excess: Vec<bool> = (0..full.len()).map(|i| narrow_excess(&full, i)).collect();
    let keep: Vec<usize> = (0..full.len()).filter(|&i| !excess[i]).collect();
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
    let forms = [
        FilterForm::Analog,
        FilterForm::Digital { rate_hz: fs },
        FilterForm::Sampled { rate_hz: fs },
    ];
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
    let axes: Vec<Vec<[f64; 3]>> = samples
        .iter()
        .map(|band| {
            band.iter()
                .map(|&(f, _)| forms.map(|form| LowPass::on_axis(form, f)))
                .collect()
        })
        .collect();
    // The decimators searched (large-factor limit) and their folded response at every sample.
    let decimators: Vec<Decimator> = DECIMATOR_STAGES
        .iter()
        .filter_map(|&k| Decimator::new(k, None))
        .collect();
    let decimated: Vec<Vec<Vec<f64>>> = samples
        .iter()
        .map(|band| {
            band.iter()
                .map(|&(f, _)| decimators.iter().map(|d| d.power_gain(f, fs)).collect())
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
        let searched = lp
            .decimator
            .map(|d| decimators.iter().position(|&e| e == d));
        // The sampled form's response, its normalisation made once per trial.
        let sampled = match lp.form {
            FilterForm::Sampled { rate_hz } => Some(lp.sampled_response(rate_hz)),
            _ => None,
        };
        let gain = |band: usize, k: usize| {
            if let Some(response) = &sampled {
                return response(samples[band][k].0);
            }
            let g = lp.gain_at_ratio(axes[band][k][form] / corner);
            match searched {
                None => g,
                Some(Some(i)) => g * decimated[band][k][i],
                Some(None) => g * lp.decimator_gain(samples[band][k].0),
            }
        };
        let mut p = base.clone();
        for (b, f) in p.basis.iter_mut().zip(filtered_basis(&samples, gain)) {
            b[..BASE].copy_from_slice(&f[..BASE]);
        }
        p
    };
    let with_floor = |lp: &LowPass| filtered(&floored, lp);
    // One fit per trial with the floor allowed: the non-negative fit leaves it at 0 where it
    // does not help, and only a floor in use is charged.
    let try_response = |lp: LowPass, floor: bool, settle: Settle| -> f64 {
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
    // Parameters against a low-pass (a corner): a low-pass after a decimator is charged one more
    // (the decimator's stages on top of the corner), a decimator alone one fewer (no continuous
    // parameter). A sinc² decimator's response is exactly a first-order low-pass at fs/4 over a
    // white floor a third of the level, and sinc³'s nearly one over a floor of 13 %: charged
    // alike, the low-pass and the floor were read, and the floor is no part of the fits' response
    // (N 0.6–0.9 % low).
    let parameter = (plain.len() as f64).ln();
    let try_filter = |lp: LowPass, floor: bool, settle: Settle| -> f64 {
        // The sampled form with its corner near Nyquist rises there (its images add more than
        // it loses): a bump, not a roll-off, which then failed the attenuation test and left no
        // filter at all where the analog form had read an angle quantiser's edge (46 of 50
        // records of the validation's quantiser case lost it).
        if matches!(lp.form, FilterForm::Sampled { .. })
            && -10.0 * lp.power_gain(x[n - 1]).log10() < MIN_ATTENUATION_DB
        {
            return f64::INFINITY;
        }
        let charge = match (lp.decimator.is_some(), lp.order > 0) {
            (true, true) => parameter,
            (true, false) => -parameter,
            _ => 0.0,
        };
        charge + try_response(lp, floor, settle)
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
    // Every family's trials on the coarse grid of corners from `f_lo` to `f_hi` (a digital corner
    // below Nyquist), with the decimators' families where `decimated`. Trials are scored in
    // parallel (the channel's other cores are idle when a file has fewer channels than cores, or
    // at the end of a file) and ties go to the first in this order, as a sequential scan's would.
    let coarse_trials = |decimated: bool| -> Vec<LowPass> {
        let (per_decade, lo, hi) = (COARSE_PER_DECADE, f_lo, f_hi);
        let mut trials = Vec::new();
        for form in forms {
            // A digital corner lies below Nyquist.
            let top = match form {
                FilterForm::Analog | FilterForm::Sampled { .. } => hi,
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
                        decimator: None,
                    });
                }
            }
            if decimated && matches!(form, FilterForm::Digital { .. }) {
                for &decimator in &decimators {
                    for &order in &CASCADE_ORDERS {
                        for &corner_hz in &grid(per_decade, lo, top) {
                            if corner_hz < 0.5 * fs {
                                trials.push(LowPass {
                                    corner_hz,
                                    order,
                                    form,
                                    decimator: Some(decimator),
                                });
                            }
                        }
                    }
                }
            }
        }
        trials
    };
    let unfiltered = LowPass {
        corner_hz: f_hi,
        order: 1,
        form: FilterForm::Analog,
        decimator: None,
    };
    // The corner of `lp`'s family (every parameter of the response but its corner) that scores
    // best within [lo, hi], by golden-section search on log f_c down to `tol_decades`. The
    // likelihood is smooth and single-welled over one coarse step, and on long records narrow:
    // a sinc³-then-2nd-order chain 9 % off its corner scored 6·10⁴ worse on a 1-h, 1-kHz record,
    // so that a grid of corners ranked the families by where the grid happened to fall.
    let golden = |lp: LowPass,
                  lo: f64,
                  hi: f64,
                  floor: bool,
                  settle: Settle,
                  tol_decades: f64|
     -> (f64, LowPass) {
        let at = |log_c: f64| {
            let t = LowPass {
                corner_hz: log_c.exp(),
                ..lp
            };
            (try_filter(t, floor, settle), t)
        };
        let r = (5f64.sqrt() - 1.0) / 2.0;
        let (mut a, mut b) = (lo.ln(), hi.ln());
        let (mut c, mut d) = (b - r * (b - a), a + r * (b - a));
        let (mut fc, mut fd) = (at(c), at(d));
        while b - a > tol_decades * std::f64::consts::LN_10 {
            if fc.0 <= fd.0 {
                b = d;
                d = c;
                fd = fc;
                c = b - r * (b - a);
                fc = at(c);
            } else {
                a = c;
                c = d;
                fc = fd;
                d = a + r * (b - a);
                fd = at(d);
            }
        }
        if fc.0 <= fd.0 {
            fc
        } else {
            fd
        }
    };
    // Highest corner a family's search may try.
    let top_of = |lp: &LowPass| match lp.form {
        FilterForm::Analog | FilterForm::Sampled { .. } => f_hi,
        FilterForm::Digital { .. } => f_hi.min(0.499 * fs),
    };
    // `best`'s corner refined within a factor `step` either way, kept only where it scores better.
    let refine_corner = |best: (f64, LowPass), step: f64, floor: bool, settle: Settle, tol: f64| {
        if best.1.order == 0 || !best.0.is_finite() {
            return best;
        }
        let lp = best.1;
        let lo = (lp.corner_hz / step).max(f_lo);
        let hi = (lp.corner_hz * step).min(top_of(&lp));
        if hi <= lo {
            return best;
        }
        let g = golden(lp, lo, hi, floor, settle, tol);
        if g.0 < best.0 {
            g
        } else {
            best
        }
    };
    // The best decimator's factor among [`DECIMATOR_FACTORS`] at the same stages (and the same
    // low-pass, its corner refined again for each factor, or alone): the factor changes the
    // response near Nyquist by up to 0.7 dB (sinc³, 4 against the limit), and trades against the
    // low-pass's corner.
    let refine_factor = |best: (f64, LowPass), floor: bool, step: f64| -> (f64, LowPass) {
        let Some(d) = best.1.decimator else {
            return best;
        };
        let trials: Vec<LowPass> = DECIMATOR_FACTORS
            .iter()
            .filter_map(|&f| Decimator::new(d.stages, f))
            .filter(|e| *e != d)
            .map(|e| {
                if best.1.order == 0 {
                    LowPass::decimator_alone(e, fs)
                } else {
                    LowPass {
                        decimator: Some(e),
                        ..best.1
                    }
                }
            })
            .collect();
        let scored: Vec<(f64, LowPass)> = trials
            .par_iter()
            .map(|&lp| {
                let start = (try_filter(lp, floor, Settle::Report), lp);
                refine_corner(start, step, floor, Settle::Report, 0.002)
            })
            .collect();
        scored
            .into_iter()
            .fold(best, |best, t| if t.0 < best.0 { t } else { best })
    };
    // Every family (form, order, decimator) on a coarse corner grid (8 per decade); each
    // family's best corner refined by a golden-section search within one coarse step (to 1/200
    // decade, fits settled for ranking); the best family's corner once more with every fit
    // settled (to 1/500 decade within 1/24 decade), then a decimator's factor with the corner
    // refined at each.
    let search = |floor: bool, decimated: bool| -> (f64, LowPass) {
        let mut coarse = coarse_trials(decimated);
        if decimated {
            coarse.extend(decimators.iter().map(|&d| LowPass::decimator_alone(d, fs)));
        }
        let scores: Vec<f64> = coarse
            .par_iter()
            .map(|&lp| try_filter(lp, floor, Settle::Rank))
            .collect();
        let same_family = |a: &LowPass, b: &LowPass| {
            a.form == b.form && a.order == b.order && a.decimator == b.decimator
        };
        let mut families: Vec<(f64, LowPass)> = Vec::new();
        for (lp, score) in coarse.into_iter().zip(scores) {
            match families.iter_mut().find(|f| same_family(&f.1, &lp)) {
                Some(f) => {
                    if score < f.0 {
                        *f = (score, lp);
                    }
                }
                None => families.push((score, lp)),
            }
        }
        let coarse_step = 10f64.powf(1.0 / COARSE_PER_DECADE);
        let refined: Vec<(f64, LowPass)> = families
            .par_iter()
            .map(|&f| refine_corner(f, coarse_step, floor, Settle::Rank, 0.005))
            .collect();
        let best = refined
            .into_iter()
            .fold((f64::INFINITY, unfiltered), |best, f| {
                if f.0 < best.0 {
                    f
                } else {
                    best
                }
            });
        if !best.0.is_finite() {
            return best;
        }
        // The refinement's scores are the fits' own (settled to 1e-6), the start's too: the
        // detection's ΔBIC is taken from them.
        let fine_step = 10f64.powf(1.0 / 24.0);
        let best = (try_filter(best.1, floor, Settle::Report), best.1);
        let best = refine_corner(best, fine_step, floor, Settle::Report, 0.002);
        refine_factor(best, floor, fine_step)
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
    // A decimator is not claimed where the band the fits keep refutes it: the best response
    // without one is found as well, and where it beats the decimator's by more than
    // [`DECIMATOR_REFUTED_BIC`] on the bands below its own 2 % edge (every coefficient refitted
    // there, parameters counted as in the search), it is taken instead. Above the corner a broad
    // excess (a Q-25 resonance at 380 Hz on a 250-Hz second-order filter's skirt, 1-kHz rate)
    // was matched better by a sinc⁴ decimator's droop and a 390-Hz corner than by the true
    // low-pass, and the fit band was cut to 39 Hz; the in-band data refuted that droop. The
    // test is one-sided: on a 100-Hz record the true sinc³ chain beat the best low-pass by 6000
    // over the whole spectrum, and tied with it (ΔBIC +3.6) below 8.5 Hz, where the refitted N,
    // B and K absorb the droop (and N comes out biased by it).
    let in_band_choice = |with: (f64, LowPass), floor: bool| -> (f64, LowPass) {
        if with.1.decimator.is_none() || !with.0.is_finite() {
            return with;
        }
        let without = search(floor, false);
        if !without.0.is_finite() {
            return with;
        }
        let edge = without.1.edge_hz(BAND_BIAS);
        let idx: Vec<usize> = (0..n).filter(|&k| x[k] <= edge).collect();
        if idx.len() < 8 {
            return with;
        }
        let in_band = |lp: &LowPass| -> f64 {
            let p = if floor {
                with_floor(lp).subset(&idx)
            } else {
                filtered(&plain, lp).subset(&idx)
            };
            let terms = if floor { mask | (1 << EFFECT) } else { mask };
            let fit = p.irls(terms);
            let (_, _, ll) = p.likelihood(&fit);
            if ll.is_nan() {
                f64::INFINITY
            } else {
                ll
            }
        };
        // The decimator's parameters against the low-pass's, as in the search.
        let charge = if with.1.order > 0 { 1.0 } else { -1.0 };
        let delta = in_band(&with.1) - in_band(&without.1) + charge * (idx.len() as f64).ln();
        // A line or a peak inside that band: a decimator's droop cannot be told from a
        // resonance's skirt and plateau (a Q-20 resonance at 7 Hz, 15× the floor at its peak,
        // behind a 4th-order 26-Hz low-pass at 100 Hz, was read as a sinc² decimator whose droop
        // put the fit band's edge at 5.4 Hz, below the peak).
        let peak_in_band = (0..full.len()).any(|i| x_full[i] <= edge && excess[i]);
        if delta > DECIMATOR_REFUTED_BIC || peak_in_band {
            without
        } else {
            with
        }
    };
    let with = in_band_choice(search(true, true), true);
    let (delta_bic, lowpass) = match accepted(with, true) {
        Some(found) => found,
        None if with.0 - base + penalty < DETECT_BIC => {
            accepted(in_band_choice(search(false, true), false), false)?
        }
        None => return None,
    };
    let shaped_edge = lowpass.edge_hz(BAND_BIAS);
    let checked = checked_edge(&full, &x_full, &excess, opts, mask, shaped_edge);
    // Where the data moved the edge down, the filter acts lower than its fitted shape says: the
    // Allan cut moves up by the same factor (not for a line the edge steps below).
    let tau_scale = shaped_edge / checked;
    let fit_max_freq_hz = below_edge_line(&excess, &x_full, checked);
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
        slope_db_per_decade: lowpass.slope_db_per_decade(),
        nyquist_attenuation_db: (-10.0 * lowpass.power_gain(fs / 2.0).log10()).min(200.0),
        fit_max_freq_hz,
        fit_min_tau_s,
        delta_bic,
        cause: BandEdge::LowPass,
    })
}

/// Margin (a factor in frequency) within which a run of narrow-excess bands counts as touching the
/// band's edge, and by which the edge then steps below the run.
const LINE_EDGE_MARGIN: f64 = 1.1;

/// `edge`, or, where a run of narrow-excess bands ([`narrow_excess`]: a line, a wandering line's
/// spread, a resonance) straddles it or begins within [`LINE_EDGE_MARGIN`] of it, a frequency that
/// margin below the run's lowest band (not below half the edge). A fit band that ends inside a
/// line keeps the line's lower skirt without its peak: on a 1-kHz accelerometer whose 49-Hz fan
/// line wanders ±1.5 Hz, an edge at 48 Hz left the skirt in the band's top, which the spectrum
/// fit took for quantisation noise rising as f², a Gauss–Markov process made up the rest, and N
/// came out 14–17 % low.
fn below_edge_line(excess: &[bool], x: &[f64], edge: f64) -> f64 {
    let mut i = 0;
    while i < x.len() {
        if !excess[i] {
            i += 1;
            continue;
        }
        let start = i;
        while i + 1 < x.len() && excess[i + 1] {
            i += 1;
        }
        let (lo, hi) = (x[start], x[i]);
        if lo <= edge * LINE_EDGE_MARGIN && hi >= edge / LINE_EDGE_MARGIN {
            return (lo / LINE_EDGE_MARGIN).max(edge / 2.0).min(edge);
        }
        i += 1;
    }
    edge
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
fn checked_edge(
    full: &Problem,
    x: &[f64],
    excess: &[bool],
    opts: &FitOptions,
    mask: Mask,
    edge: f64,
) -> f64 {
    let mut edge = edge;
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
                decimator: None,
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
            decimator: None,
        };
        assert!(high.white_avar_bias(100.0, 1) < 1e-9);
        let low = LowPass {
            corner_hz: 1e-6,
            order: 4,
            form: FilterForm::Analog,
            decimator: None,
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
            decimator: None,
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
                decimator: None,
            },
            LowPass {
                corner_hz: 10.0,
                order: 1,
                form: FilterForm::Analog,
                decimator: None,
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

    /// A decimator's response is its folded sinc^k times the low-pass's; its edge (by bisection)
    /// is where that product has lost the bias; alone, its corner is its half-power frequency.
    #[test]
    fn a_decimator_cascade_multiplies_the_responses() {
        let dec = Decimator::new(3, Some(4)).unwrap();
        let fs = 1000.0;
        let lp = LowPass {
            corner_hz: 250.0,
            order: 2,
            form: FilterForm::Digital { rate_hz: fs },
            decimator: Some(dec),
        };
        // The low-pass's part from the simulator's biquad sections (an independent
        // implementation); the decimator's from its own test against the images' sum.
        let spec = crate::sim::LowPassSpec {
            corner_hz: 250.0,
            order: 2,
        };
        for f in [0.0, 30.0, 120.0, 250.0, 400.0] {
            let want = dec.power_gain(f, fs) * crate::sim::lowpass_power_gain(&spec, fs, f);
            assert!((lp.power_gain(f) - want).abs() < 1e-9, "{f}");
        }
        let edge = lp.edge_hz(BAND_BIAS);
        assert!(
            (1.0 - lp.power_gain(edge) - BAND_BIAS).abs() < 1e-9,
            "{edge}"
        );
        // sinc³'s droop is 0.9375·π²·(f/fs)² near DC at ↓4: 2 % near 46 Hz, below the low-pass's
        // own 2 % edge (≈ 100 Hz).
        assert!((40.0..50.0).contains(&edge), "{edge}");
        let alone = LowPass::decimator_alone(dec, fs);
        assert_eq!(alone.order, 0);
        assert!((alone.power_gain(alone.corner_hz) - 0.5).abs() < 1e-9);
        assert_eq!(alone.slope_db_per_decade(), -60.0);
        assert_eq!(lp.slope_db_per_decade(), -100.0);
    }

    #[test]
    fn edge_is_where_the_gain_has_fallen_by_the_bias() {
        for form in [FilterForm::Analog, FilterForm::Digital { rate_hz: 100.0 }] {
            let lp = LowPass {
                corner_hz: 20.0,
                order: 3,
                form,
                decimator: None,
            };
            let f = lp.edge_hz(BAND_BIAS);
            assert!((1.0 - lp.power_gain(f) - BAND_BIAS).abs() < 1e-12);
            assert!((lp.power_gain(20.0) - 0.5).abs() < 1e-12);
        }
    }
}
