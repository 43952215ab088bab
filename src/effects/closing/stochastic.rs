//! Stochastic effects as loop candidates: a resonance at an excess too wide to be a line and a
//! first-order Gauss–Markov process, profiled over their shape parameters with likelihood
//! intervals, entering both fits as one more column.

use super::*;
use crate::model::hull;
use crate::stats::golden;
/// The fit options for the many fits of a profile over an effect's shape parameters (a resonance's
/// f₀ and Q, a Gauss–Markov Tc): the base terms chosen among those the current fits kept in
/// either domain, not among all. An effect may replace a kept term but not call for a new one
/// (the selection over every subset is what made the loop slow: 31 subsets per fit, hundreds of
/// fits per channel). The optimum found this way is refitted with the full selection, which gives
/// the candidate's fits and ΔBIC; a profile point scores at best as well as with the full
/// selection, so the restriction can only make a profile interval wider, never narrower.
pub(super) fn profile_options(state: &State, cfg: &LoopConfig) -> FitOptions {
    let kept: Vec<Term> = [state.allan.as_ref(), state.spectrum.as_ref()]
        .into_iter()
        .flatten()
        .flat_map(|f| f.estimates.iter().map(|e| e.term))
        .collect();
    let mut opts = cfg.fit.clone();
    opts.selection_uncertainty = false;
    if !kept.is_empty() {
        // White noise stays allowed even where the current fits dropped it: an effect strong
        // enough to bend them had taken its place (a band-pass resonance as strong as the
        // sensor's white noise left Q and B, 40× the truth, in both fits; restricted to those,
        // every profile point misfitted by χ² ≈ 10⁴ and Q was read at 8 for 20).
        opts.terms
            .retain(|&t| kept.contains(&t) || t == Term::RandomWalk);
    }
    opts
}

/// ΔBIC of a stochastic effect: the change of the best score in each domain plus `extra` shape
/// parameters per domain. `None` when a fit failed or the effect came out zero.
pub(super) fn stochastic_delta(
    state: &State,
    allan: Option<&NoiseFit>,
    spectrum: Option<&NoiseFit>,
    extra: f64,
) -> Option<(f64, f64)> {
    let (a0, s0) = (state.allan.as_ref()?, state.spectrum.as_ref()?);
    let (a1, s1) = (allan?, spectrum?);
    if s1.effect.is_none_or(|e| e.value <= 0.0) {
        return None;
    }
    let n_s = s1.points.len() as f64;
    let n_a = a1.points.len() as f64;
    let ds = score(s1) + extra * n_s.ln() - score(s0);
    let da = score(a1) + extra * n_a.ln() - score(a0);
    Some((ds, da))
}

/// The profile interval of a parameter, and the conditional effect intervals of the points inside it
/// joined. `points` are (parameter, score, effect) at trial values; the interval's ends are where
/// the score crosses `best + threshold`, interpolated between the last point inside and the first
/// outside on each side, linearly in √(score − best) (which a locally quadratic profile makes
/// linear in the parameter) and in the parameter itself (`log`: in its logarithm). A side without a
/// point outside ends at its last point inside, or, where trial points beyond that one could not
/// be fitted (no finite score), at the farthest of them: the profile is unknown there, and an end
/// at the last point inside would claim the parameter known to the optimum. The ends of the points
/// inside alone were too narrow: the trial grid is a twelfth of a half-power width apart, about
/// the interval's own width, and the resonance's f₀ interval covered the truth in 16 % of 50
/// seeds, Q's in 20 %.
pub(super) fn profile_range(
    points: &[(f64, f64, Option<EffectEstimate>)],
    best: f64,
    threshold: f64,
    log: bool,
) -> (f64, f64, Option<(f64, f64)>) {
    let to = |x: f64| if log { x.ln() } else { x };
    let from = |x: f64| if log { x.exp() } else { x };
    let mut sorted: Vec<(f64, f64)> = points
        .iter()
        .filter(|p| p.0.is_finite() && p.1.is_finite() && (!log || p.0 > 0.0))
        .map(|p| (to(p.0), (p.1 - best).max(0.0).sqrt()))
        .collect();
    sorted.sort_by(|a, b| a.0.total_cmp(&b.0));
    let edge = threshold.max(0.0).sqrt();
    let inside: Vec<usize> = (0..sorted.len()).filter(|&i| sorted[i].1 <= edge).collect();
    // The farthest trial values on either side, fitted or not.
    let tried = points
        .iter()
        .filter(|p| p.0.is_finite() && (!log || p.0 > 0.0))
        .map(|p| to(p.0));
    let (tried_lo, tried_hi) = tried.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), x| {
        (a.min(x), b.max(x))
    });
    let (Some(&first), Some(&last)) = (inside.first(), inside.last()) else {
        // No point of this profile within the threshold of `best` (found off it): where the
        // parameter lies is not known from these points, and the interval spans all tried.
        return (from(tried_lo), from(tried_hi), None);
    };
    let crossing = |i: usize, j: usize| {
        let ((xi, ri), (xj, rj)) = (sorted[i], sorted[j]);
        if rj > ri {
            xi + (xj - xi) * (edge - ri) / (rj - ri)
        } else {
            xi
        }
    };
    let lo = if first > 0 {
        crossing(first, first - 1)
    } else {
        sorted[first].0.min(tried_lo)
    };
    let hi = if last + 1 < sorted.len() {
        crossing(last, last + 1)
    } else {
        sorted[last].0.max(tried_hi)
    };
    let sigma = points
        .iter()
        .filter(|p| p.1 <= best + threshold)
        .filter_map(|p| p.2)
        .fold(None, |acc: Option<(f64, f64)>, e| {
            Some(acc.map_or((e.lo, e.hi), |(l, h)| (l.min(e.lo), h.max(e.hi))))
        });
    (from(lo), from(hi), sigma)
}

/// A resonance at an excess too wide to be a line. Q is optimised (golden section on log Q
/// within ×/÷ 8 of the excess's f/width), then f₀ (within ± one half-power width), then Q again;
/// f₀ and Q get likelihood intervals (the spectrum score within the χ²₁ quantile of the
/// confidence, times the fit's dispersion, of its best: the score is −2 ln L plus a constant
/// penalty; σ and the base terms refitted at each trial point, the other of f₀ and Q held at its
/// optimum, which a Lorentzian's nearly uncorrelated centre and width allow), ends interpolated
/// between trial points ([`profile_range`]), and σ the union of its conditional intervals over both.
///
/// The profiles run on single bins, which their likelihood takes as independent; a Hann window
/// makes neighbouring bins' powers correlate by 4/9, so the threshold is scaled by the spectrum's
/// [`neighbour_redundancy`] (1.98 here). Without it, over 50 seeds of a 30-min record (8 Hz, Q 20,
/// peak ≈ 30× the floor) the 1σ intervals covered f₀ in 52 %, Q in 72 %, σ in 76 %: f₀ scattered
/// 0.0077 Hz where its intervals said 0.0063. With it, over 150 seeds (`VALIDATION_CASES=resonance`):
/// f₀ 75 %, Q 77 %, σ 71 %; the scatter over the median half-width is 0.90 for f₀ and 0.76 for
/// ln Q (1 is calibrated), so f₀ is now about right and Q's interval a quarter too wide: the
/// correction is the same for both, and why Q's profile was already nearly calibrated without it
/// is not understood. Median ratios to the truth 1.0000, 0.999, 1.001. Holding the other parameter
/// at its optimum is not what narrowed f₀'s interval: profiled with Q re-optimised at each f₀,
/// coverage was the same. On the loop's log bands (a twentieth of a decade, wider than the peak)
/// Q covered in 38 % and read 5 % low.
pub(super) fn resonance_candidate(
    state: &State,
    e: &Excess,
    fs: f64,
    cfg: &LoopConfig,
    p: f64,
) -> Option<Candidate<'static>> {
    let nyquist = fs / 2.0;
    let q0 = (e.freq_hz / e.width_hz.max(state.psd.bin_width_hz())).clamp(0.5, 1e4);
    let profile_opts = profile_options(state, cfg);
    // The searches and profiles run on the spectrum with the bins around the excess unaveraged
    // (within 4 half-power widths and the profile's reach): the loop's bands are wider than a
    // resonance of Q ≳ 10 there (a twentieth of a decade at 8 Hz is 0.98 Hz; the half-power
    // width of Q 20 is 0.4 Hz), and over two or three bands f₀ and Q trade against each other,
    // which the profile of one at the other's optimum does not see: Q's 1σ interval covered the
    // truth in 38 % of 50 seeds. The candidate's own fit, whose score the loop compares with the
    // current model's, stays on the loop's bands.
    let reach = 4.0 * e.width_hz.max(e.freq_hz / q0);
    let resolved = log_bin_resolving(
        &state.psd,
        cfg.bins_per_decade.max(1),
        e.freq_hz - reach,
        e.freq_hz + reach,
    );
    let fit_with = |f0: f64, q: f64, form: ResonanceForm, binned: &BinnedPsd, opts: &FitOptions| {
        if !(f0 > 0.0 && f0 < nyquist) {
            return (f64::INFINITY, None);
        }
        let shape = Resonance::with_form(f0, q, form, fs);
        let spectrum = fit_psd_with(&state.psd, binned, opts, Some(&shape)).ok();
        (spectrum.as_ref().map_or(f64::INFINITY, score), spectrum)
    };
    let fit_at =
        |f0: f64, q: f64, form: ResonanceForm| fit_with(f0, q, form, &resolved, &profile_opts);
    let (lq_lo, lq_hi) = ((q0 / 8.0).max(0.5).ln(), (q0 * 8.0).min(1e4).ln());
    type Points = Vec<(f64, f64, Option<EffectEstimate>)>;
    // Q at the excess's centre, f₀ at that Q, Q again at that f₀: (f₀, Q, score, Q's points at
    // the final f₀).
    let search = |form: ResonanceForm| -> (f64, f64, f64, Points) {
        let by_q = |f0: f64, pts: &mut Points| {
            golden(
                &mut |lq: f64| {
                    let (sc, fit) = fit_at(f0, lq.exp(), form);
                    pts.push((lq.exp(), sc, fit.and_then(|f| f.effect)));
                    sc
                },
                lq_lo,
                lq_hi,
                18,
            )
        };
        let (lq, _) = by_q(e.freq_hz, &mut Vec::new());
        let half_width = e.freq_hz / lq.exp();
        let (f0, _) = golden(
            &mut |f: f64| fit_at(f, lq.exp(), form).0,
            e.freq_hz - half_width,
            e.freq_hz + half_width,
            16,
        );
        let mut q_points = Vec::new();
        let (lq, best) = by_q(f0, &mut q_points);
        (f0, lq.exp(), best, q_points)
    };
    // The low-pass form first; the band-pass one searched too where it fits better at that
    // optimum (a plateau the data do not hold), and kept where its own optimum is better.
    let mut form = ResonanceForm::LowPass;
    let (mut f0, mut q, mut best, mut q_points) = search(form);
    if fit_at(f0, q, ResonanceForm::BandPass).0 < best {
        let other = search(ResonanceForm::BandPass);
        if other.2 < best {
            form = ResonanceForm::BandPass;
            (f0, q, best, q_points) = other;
        }
    }
    let fit_at = |f0: f64, q: f64| fit_at(f0, q, form);
    // Profile grids around the optimum, for the intervals: f₀ at the final Q only (the golden
    // search's points were at the first Q, a slice offset by the change of Q, which made the
    // optimum an isolated point of the profile), a 24th of a half-power width apart within half a
    // width and coarser beyond; Q a twelfth of a decade apart (its golden-search points at the
    // final f₀ stay).
    let f_steps: Vec<f64> = (-12..=12)
        .map(|k| f64::from(k) / 24.0)
        .chain([-2.0, -1.5, -1.0, -0.75, 0.75, 1.0, 1.5, 2.0])
        .collect();
    let grids = |f0: f64, q: f64| -> (Points, Points) {
        let by_q = (-12..=12)
            .into_par_iter()
            .map(|k| {
                let qk = q * 10f64.powf(f64::from(k) / 12.0);
                let (sq, fq) = fit_at(f0, qk);
                (qk, sq, fq.and_then(|f| f.effect))
            })
            .collect();
        let by_f = f_steps
            .par_iter()
            .map(|&step| {
                let fk = f0 + step * (f0 / q);
                let (sf, ff) = fit_at(fk, q);
                (fk, sf, ff.and_then(|f| f.effect))
            })
            .collect();
        (by_q, by_f)
    };
    // Where a grid finds a better point than the search's optimum (a profile with several wells:
    // a 131-Hz mode among a drone's rotor lines, whose f₀ grid found a better f₀ than the Q
    // search's), the optimum moves there and both grids are made again around it (at most
    // three times): profiles through a point that is not the optimum held no point within the
    // threshold of the best score, and Q's interval came out as the single point [12.4, 12.4].
    let (by_q, mut f_points) = grids(f0, q);
    q_points.extend(by_q);
    for _ in 0..3 {
        let moved = q_points
            .iter()
            .map(|p| (f0, p.0, p.1))
            .chain(f_points.iter().map(|p| (p.0, q, p.1)))
            .filter(|p| p.2 < best - 1e-9 * best.abs().max(1.0))
            .min_by(|a, b| a.2.total_cmp(&b.2));
        let Some((f1, q1, s1)) = moved else {
            break;
        };
        (f0, q, best) = (f1, q1, s1);
        (q_points, f_points) = grids(f0, q);
    }
    // The profile intervals compare restricted fits with the best restricted score; the
    // candidate's own fit at the optimum has every base term allowed.
    let best = q_points
        .iter()
        .chain(&f_points)
        .map(|p| p.1)
        .fold(best, f64::min);
    let (_, spectrum) = fit_with(f0, q, form, &state.binned, &cfg.fit);
    let shape = Resonance::with_form(f0, q, form, fs);
    let allan = fit_avar_with(&state.dev, &cfg.fit, Some(&shape)).ok();
    let (ds, da) = stochastic_delta(state, allan.as_ref(), spectrum.as_ref(), 2.0)?;
    let mut sigma = spectrum.as_ref()?.effect?;
    // The profiles' scale: the misfit of the spectrum they were computed on, and the correlation
    // of the unaveraged neighbouring bins they were computed on, which their likelihood takes as
    // independent ([`neighbour_redundancy`]).
    let dispersion = fit_at(f0, q)
        .1
        .map_or(1.0, |f| f.lack_of_fit.inflation.powi(2));
    let threshold =
        norm_isf((1.0 - p) / 2.0).powi(2) * dispersion * neighbour_redundancy(&state.psd);
    let (q_lo, q_hi, sq) = profile_range(&q_points, best, threshold, true);
    let (f0_lo, f0_hi, sf) = profile_range(&f_points, best, threshold, false);
    for (lo, hi) in [sq, sf].into_iter().flatten() {
        (sigma.lo, sigma.hi) = (sigma.lo.min(lo), sigma.hi.max(hi));
    }
    Some(Candidate {
        veto: None,
        delta_bic: if ds < 0.0 { ds + da } else { ds.max(0.0) + da.max(0.0) },
        evidence: format!(
            "{}; wider than a line (half-power width {:.3} Hz); ΔBIC spectrum {ds:.1}, Allan {da:.1}",
            describe_excess(e),
            e.width_hz
        ),
        effect: Effect::Resonance {
            f0_hz: f0,
            f0_lo: f0_lo.min(f0),
            f0_hi: f0_hi.max(f0),
            q,
            q_lo: q_lo.min(q),
            q_hi: q_hi.max(q),
            form,
            sigma,
        },
        apply: Apply::Model(Box::new((Stochastic::Resonance(shape), allan, spectrum))),
    })
}

/// A first-order Gauss–Markov process, profiled over Tc (8 per decade from 10 samples to a tenth
/// of the record), its ΔBIC charged 2·ln K for the choice among the K grid points; barred where
/// the profile's best is the grid's shortest Tc (not resolved). Tc is chosen by the two domains'
/// joint ΔBIC, not by the spectrum alone: a correlation time longer than a Welch segment puts its knee below the spectrum's lowest band,
/// where only the Allan variance shows it (such processes were missed when the spectrum's own
/// best Tc, a noise-level improvement at short Tc, decided).
pub(super) fn gauss_markov_candidate(
    state: &State,
    fs: f64,
    cfg: &LoopConfig,
    p: f64,
) -> Option<Candidate<'static>> {
    let duration = state.y.len() as f64 / fs;
    let (lo, hi) = (10.0 / fs, duration / 10.0);
    if hi <= lo {
        return None;
    }
    let (a0, s0) = (state.allan.as_ref()?, state.spectrum.as_ref()?);
    let lowest_band = s0.points.first().map_or(f64::INFINITY, |p| p.x);
    let steps = ((hi / lo).log10() * 8.0).ceil() as usize;
    // The choice of one Tc among the grid's: −2·ln(1/K) on the BIC scale (a uniform prior over
    // the K grid points). Without it the joint search admitted 6 Gauss–Markov processes in 400
    // records of pure IEEE noise (ΔBIC −6.4 to −9.7).
    let search = 2.0 * ((steps + 1) as f64).ln();
    struct Point {
        tc: f64,
        delta: f64,
        ds: f64,
        da: f64,
        visible: bool,
        allan: NoiseFit,
        spectrum: Option<NoiseFit>,
    }
    let profile_opts = profile_options(state, cfg);
    // `always_spectrum`: fit the spectrum even where the knee is invisible there (the chosen
    // point's spectrum fit becomes the model's); on the profile an invisible knee's spectrum fit
    // decides nothing and is skipped (most of the Tc grid lies below the lowest band: the
    // profile's spectrum fits were a third of the candidate's time).
    let point = |tc: f64, opts: &FitOptions, always_spectrum: bool| -> Option<Point> {
        let shape = GaussMarkov1 { tc_s: tc };
        // A knee below the spectrum fit's lowest band is invisible there: only the Allan fit
        // votes.
        let knee = 1.0 / (2.0 * std::f64::consts::PI * tc);
        let visible = knee >= lowest_band;
        let spectrum = (visible || always_spectrum)
            .then(|| fit_psd_with(&state.psd, &state.binned, opts, Some(&shape)).ok())
            .flatten();
        let allan = fit_avar_with(&state.dev, opts, Some(&shape)).ok()?;
        let da = score(&allan) + (allan.points.len() as f64).ln() - score(a0);
        let ds = spectrum.as_ref().map_or(f64::INFINITY, |f| {
            score(f) + (f.points.len() as f64).ln() - score(s0)
        });
        let delta = match (visible, ds < 0.0) {
            (false, _) => da,
            (true, true) => ds + da,
            (true, false) => ds.max(0.0) + da.max(0.0),
        } + search;
        let effect_of = |f: &NoiseFit| f.effect.is_some_and(|e| e.value > 0.0);
        let present = if visible {
            spectrum.as_ref().is_some_and(effect_of)
        } else {
            effect_of(&allan)
        };
        (present && delta.is_finite()).then_some(Point {
            tc,
            delta,
            ds,
            da,
            visible,
            allan,
            spectrum,
        })
    };
    let profile: Vec<Point> = (0..=steps)
        .into_par_iter()
        .filter_map(|k| {
            point(
                lo * (hi / lo).powf(k as f64 / steps.max(1) as f64),
                &profile_opts,
                false,
            )
        })
        .collect();
    let restricted_best = profile.iter().min_by(|a, b| a.delta.total_cmp(&b.delta))?;
    // The optimum again with every base term allowed: the candidate's fits and ΔBIC.
    let best = &point(restricted_best.tc, &cfg.fit, true)?;
    let tc = best.tc;
    let shape = GaussMarkov1 { tc_s: tc };
    // σ from the domain that sees the process; it is tied to Tc (a longer correlation time puts
    // the same low-frequency power in a larger σ): its interval is the union of the conditional
    // ones over the Tc whose joint score lies within the χ²₁ quantile of the confidence of the
    // best (the profile interval of Tc).
    let sigma_of = |pt: &Point| {
        if pt.visible {
            pt.spectrum.as_ref()?.effect
        } else {
            pt.allan.effect
        }
    };
    let mut sigma = sigma_of(best)?;
    let q = norm_isf((1.0 - p) / 2.0).powi(2);
    // Tc's profile-likelihood interval: the joint score within the χ²₁ quantile of the best,
    // its ends interpolated between the grid's points (log Tc) and always holding the chosen Tc
    // (it had none: a Tc read 1.4× the truth was printed as if exact).
    let trials: Vec<(f64, f64, Option<EffectEstimate>)> =
        profile.iter().map(|c| (c.tc, c.delta, None)).collect();
    let (tc_lo_s, tc_hi_s, _) = profile_range(&trials, restricted_best.delta, q, true);
    let (tc_lo_s, tc_hi_s) = (tc_lo_s.min(tc), tc_hi_s.max(tc));
    for e in profile
        .iter()
        .filter(|c| c.delta <= restricted_best.delta + q)
        .filter_map(sigma_of)
    {
        (sigma.lo, sigma.hi) = (sigma.lo.min(e.lo), sigma.hi.max(e.hi));
    }
    // The base terms trade with the process too (a longer Tc takes more of K's low-frequency
    // power): each one's interval, in each fit, joins its conditional intervals over the same
    // profile interval of Tc, as σ's does.
    // The 1σ intervals the decisions use (`TermEstimate::one_sigma`) join over the Tc within 1
    // (the χ²₁ quantile at 1σ) whatever the confidence.
    let (mut allan, mut spectrum) = (best.allan.clone(), best.spectrum.clone());
    for c in profile
        .iter()
        .filter(|c| c.delta <= restricted_best.delta + q.max(1.0))
    {
        let at = |threshold: f64| c.delta <= restricted_best.delta + threshold;
        let (reported, one_sigma) = (at(q), at(1.0));
        join_intervals(&mut allan, Some(&c.allan), reported, one_sigma);
        if let Some(f) = spectrum.as_mut() {
            join_intervals(f, c.spectrum.as_ref(), reported, one_sigma);
        }
    }
    let where_ = state
        .spectrum
        .as_ref()
        .map(diagnose)
        .and_then(|d| d.local)
        .map_or(String::new(), |l| {
            // Three significant digits; one band (or two that print alike) is a frequency.
            let hz = |x: f64| {
                let decimals = (2 - x.abs().log10().floor() as i32).clamp(0, 12) as usize;
                format!("{x:.decimals$}")
            };
            let (lo, hi) = (hz(l.x_lo), hz(l.x_hi));
            if lo == hi {
                format!("; largest spectrum residual at {lo} Hz")
            } else {
                format!("; largest spectrum residual {lo}–{hi} Hz")
            }
        });
    let (ds, da) = (best.ds, best.da);
    // A profile whose best Tc is the grid's shortest has not resolved a process: its knee lies
    // where the sensor's filter, the quantisation and a resonance's skirt shape the spectrum,
    // and there the process served as a flat band that lets the quantisation's f² rise more
    // steeply (a flight controller's accelerometers, the band kept below 50 Hz under a 68-Hz
    // resonance: Tc = 10 samples on 5 of 6 channels, none of them a process).
    let veto = (restricted_best.tc <= lo * (1.0 + 1e-9)).then(|| {
        format!(
            "not a process: its best correlation time is the search's shortest ({lo:.3} s, 10 \
             samples), where the sensor's filter and quantisation shape the spectrum"
        )
    });
    Some(Candidate {
        veto,
        delta_bic: best.delta,
        evidence: format!(
            "Lorentzian knee near {:.4} Hz (Tc = {tc:.3} s{}){where_}; ΔBIC spectrum {ds:.1}, Allan {da:.1}",
            1.0 / (2.0 * std::f64::consts::PI * tc),
            if best.visible { "" } else { ", below the spectrum's lowest band: the Allan fit decides" }
        ),
        effect: Effect::GaussMarkov {
            tc_s: tc,
            tc_lo_s,
            tc_hi_s,
            sigma,
        },
        apply: Apply::Model(Box::new((Stochastic::GaussMarkov(shape), Some(allan), spectrum))),
    })
}

/// Each of `fit`'s term intervals widened to take in `other`'s interval of the same term (a term
/// `other` lacks leaves it as it is): the reported ones where `reported`, the 1σ ones where
/// `one_sigma`.
fn join_intervals(fit: &mut NoiseFit, other: Option<&NoiseFit>, reported: bool, one_sigma: bool) {
    let Some(other) = other else {
        return;
    };
    for e in &mut fit.estimates {
        if let Some(o) = other.get(e.term) {
            if reported {
                (e.lo, e.hi) = hull((e.lo, e.hi), (o.lo, o.hi));
            }
            if one_sigma {
                e.one_sigma = hull(e.one_sigma, o.one_sigma);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A quadratic profile (score − best = ((x − x₀)/s)²) sampled at its optimum and on grids as
    /// coarse as the interval: the interpolated ends are x₀ ± s·√threshold exactly, where the
    /// points inside alone would give a narrower range; in log space for a scale parameter.
    #[test]
    fn profile_interval_ends_are_interpolated_between_trial_points() {
        let (x0, s, best) = (8.0, 0.01, -1000.0);
        let score = |x: f64| best + ((x - x0) / s).powi(2);
        for step in [0.004, 0.007, 0.013] {
            // The optimum is among the points (the loop's searches end there), the grid is not
            // centred on it.
            let points: Vec<_> = (-6..=6)
                .map(|k| x0 + 0.3 * step + f64::from(k) * step)
                .chain([x0])
                .map(|x| (x, score(x), None))
                .collect();
            let best_seen = points.iter().map(|p| p.1).fold(f64::INFINITY, f64::min);
            for threshold in [1.0, 4.0] {
                let (lo, hi, _) = profile_range(&points, best, threshold, false);
                let half = s * threshold.sqrt();
                assert!((lo - (x0 - half)).abs() < 1e-9, "step {step}: lo {lo}");
                assert!((hi - (x0 + half)).abs() < 1e-9, "step {step}: hi {hi}");
                // Relative to the best point seen (above the true minimum), no narrower.
                let (l2, h2, _) = profile_range(&points, best_seen, threshold, false);
                assert!(l2 <= lo + 1e-12 && h2 >= hi - 1e-12);
            }
        }
        // Q-like: quadratic in ln q.
        let q_score = |q: f64| best + ((q / 20.0).ln() / 0.08).powi(2);
        let points: Vec<_> = (-12..=12)
            .map(|k| 20.0 * 10f64.powf(f64::from(k) / 12.0 + 0.01))
            .chain([20.0])
            .map(|q| (q, q_score(q), None))
            .collect();
        let (lo, hi, _) = profile_range(&points, best, 1.0, true);
        assert!((lo / (20.0 * (-0.08f64).exp()) - 1.0).abs() < 1e-9, "{lo}");
        assert!((hi / (20.0 * 0.08f64.exp()) - 1.0).abs() < 1e-9, "{hi}");
        // No point within the threshold of the best (a best found off this profile): the
        // interval spans every trial, not the single point it was before.
        let off: Vec<_> = [(10.0, best + 5.0), (12.4, best + 3.0), (15.0, best + 9.0)]
            .iter()
            .map(|&(q, sc)| (q, sc, None))
            .collect();
        let (lo, hi, _) = profile_range(&off, best, 1.0, true);
        assert!(
            (lo - 10.0).abs() < 1e-9 && (hi - 15.0).abs() < 1e-9,
            "{lo} {hi}"
        );
        // The side without a point outside ends at its last.
        let one_sided: Vec<_> = [7.99, 8.0, 8.005]
            .iter()
            .map(|&x| (x, score(x), None))
            .collect();
        let (lo, hi, _) = profile_range(&one_sided, best, 1.0, false);
        assert!((lo - 7.99).abs() < 1e-12 && hi == 8.005, "{lo} {hi}");
        // Every trial but the optimum failed: the interval spans the trials, not a point.
        let failed: Vec<_> = [(30.0, f64::INFINITY), (40.0, best), (55.0, f64::NAN)]
            .iter()
            .map(|&(q, sc)| (q, sc, None))
            .collect();
        let (lo, hi, _) = profile_range(&failed, best, 1.0, true);
        assert!(
            (lo - 30.0).abs() < 1e-9 && (hi - 55.0).abs() < 1e-9,
            "{lo} {hi}"
        );
    }
}
