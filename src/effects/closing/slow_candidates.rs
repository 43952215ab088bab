//! Slow effects as loop candidates: a drift shape, a bias step and an excursion estimated under
//! the fitted noise model (their estimators live in [`crate::effects::slow`],
//! [`crate::effects::shift`] and [`crate::effects::excursion`]), each refined once by feasible GLS,
//! and the coupling to each aux channel.

use super::*;
/// Raw p-value below which a slow effect's regression is repeated under the noise model refitted
/// without it.
pub(super) const REFINE_P: f64 = 0.05;

/// p-value of the model-free coupling test ([`fit_coupling`]) below which a coupling is refined
/// and iterated whatever the test under the fitted noise model says (see [`slow_candidates`]).
pub(super) const FREE_REFINE_P: f64 = 0.05;

/// p-value of the model-free coupling test below which the refinement weighs the coupling
/// against the refit's kept terms alone ([`NoiseK::Kept`]).
pub(super) const KEPT_P: f64 = 0.01;

/// The Allan fit of the current series after `correct`: the noise model with a slow effect taken
/// out. The corrected copy is a pooled buffer in which the Allan deviation builds its prefix sums
/// ([`compute_owned`]): one record-length buffer a refit, not two.
pub(super) fn allan_without(
    state: &State,
    fs: f64,
    cfg: &LoopConfig,
    correct: &dyn Fn(&mut Vec<f64>),
) -> Option<NoiseFit> {
    let mut work = pooled_copy(&state.y);
    correct(&mut work);
    let dev = compute_owned(work, fs, &cfg.taus, Statistic::Oadev, cfg.confidence).ok()?;
    let shape = state.stochastic.as_ref().map(Stochastic::shape);
    fit_avar_with(&dev, &cfg.fit, shape).ok()
}

/// How [`refined`] treats an effect: `remove` takes it out of a series; `iterate` (its p-value)
/// asks for further passes; `k` is the K it is weighed against.
pub(super) struct Refinement<'a, T> {
    pub remove: &'a dyn Fn(&mut Vec<f64>, &T),
    pub iterate: Option<&'a dyn Fn(&T) -> f64>,
    pub k: NoiseK,
}

/// A noise density, one-sided, units²/Hz.
pub(super) type Density<'a> = &'a dyn Fn(f64) -> f64;

/// Passes of feasible GLS at most (see [`refined`]).
const REFINE_PASSES: usize = 4;

/// Feasible GLS, for a first estimate with some evidence (its p-value below [`REFINE_P`], or
/// that times its family: the callers' test): `estimate` (a slow effect under a noise density)
/// again under the Allan fit of the series with the current estimate removed by `remove`. One
/// pass, or with `iterate` (its p-value) further passes while that keeps falling and stays below
/// [`REFINE_P`], at most [`REFINE_PASSES`]; `first` where the first pass fails.
///
/// **Why iterate a drift.** A large effect inflates the random walk of the fit it is tested
/// under, which hides it: after one pass a 100 °/h warm-up (Tc 300 s) in 30-min records was
/// missed in 11 of 50 (one read p = 2.8e-3 against the 1e-3 it needs, under a fit whose K had
/// taken the drift in, 3× the truth), and K stayed at 2–3× there. Each pass takes the effect out
/// of the noise model a little more: missed in 8 of 50 with them (`validation/`). Each pass costs
/// an Allan variance and a fit of the whole record, so only the drift iterates: iterating the
/// steps, excursions and couplings as well found nothing more in the validation and cost a fleet
/// screen 18 % of its throughput.
///
/// **Why each family of drift shapes apart** ([`slow_candidates`]). Under the inflated random
/// walk the parabola can beat the settling exponential by a hair (the shape is chosen by BIC),
/// and removing the parabola takes out little of a warm-up: the noise model refitted without it
/// keeps the inflated K, and the iteration goes nowhere. The warm-ups still missed were such
/// parabolas (one traced: p = 1.2e-3, K 2.6× before and after its removal). Refined in each family
/// apart, the exponential's own removal deflates K and its evidence grows: found in 49 of 50,
/// K 0.995× the truth with 87 % coverage (was 84 %, 1.42× and 53 %).
pub(super) fn refined<T>(
    state: &State,
    fs: f64,
    cfg: &LoopConfig,
    first: T,
    estimate: &dyn Fn(Density<'_>) -> Option<T>,
    how: Refinement<'_, T>,
) -> T {
    let Refinement { remove, iterate, k } = how;
    let mut current = first;
    let passes = if iterate.is_some() { REFINE_PASSES } else { 1 };
    for pass in 0..passes {
        let correct = |v: &mut Vec<f64>| remove(v, &current);
        let next = allan_without(state, fs, cfg, &correct)
            .and_then(|fit| estimate(&noise_density(&fit, state.stochastic.as_ref(), fs, k)));
        let Some(next) = next else { break };
        // The first pass replaces the estimate made under the fit that holds the effect; a later
        // one only while the evidence grows, and none once it has none left to grow from.
        if pass > 0 && iterate.is_some_and(|p_of| p_of(&next) >= p_of(&current)) {
            break;
        }
        current = next;
        if iterate.is_some_and(|p_of| p_of(&current) >= REFINE_P) {
            break;
        }
    }
    current
}

/// Coupling to each aux channel and a drift, regressed under the noise the Allan fit describes
/// (it sees the long τ where slow effects live; the spectrum fit's band starts at
/// 4·fs/nperseg). The base fit has absorbed part of a slow effect into its random walk and ramp,
/// which inflates the covariance and hides the effect; so a regression with some evidence
/// (p < [`REFINE_P`]) is repeated once under the Allan fit of the series with the first estimate
/// removed (feasible GLS). Added only below the family-wise [`DETECTION_P`]
/// ([`Candidate::barred`]); above it they are listed as considered.
pub(super) fn slow_candidates<'a>(
    state: &State,
    fs: f64,
    aux: &[AuxSeries<'a>],
    cfg: &LoopConfig,
    p: f64,
) -> Vec<Candidate<'a>> {
    let mut out = Vec::new();
    let y = &state.y;
    let Some(model) = state.allan.as_ref().or(state.spectrum.as_ref()) else {
        return out;
    };
    let stochastic = state.stochastic.as_ref();
    let density = noise_density(model, stochastic, fs, NoiseK::Fitted);
    let usable: Vec<&AuxSeries<'_>> = aux.iter().filter(|a| a.samples.len() == y.len()).collect();
    // The couplings strong enough to be added, for the drift's test below.
    let mut detected: Vec<(&str, &[f64], Coupling)> = Vec::new();
    for a in &usable {
        let family = usable.len();
        let estimate = |density: &dyn Fn(f64) -> f64| {
            coupling_under_model(y, a.samples, fs, density, family, p)
        };
        let Some(first) = estimate(&density) else {
            continue;
        };
        // The model-free test on the same data: it needs no noise model but weighs the
        // increments equally, so it is weaker on a smooth aux; it is not fooled by a noise model
        // whose random walk (or ramp) took the coupling's drift in.
        let free = fit_coupling(y, a.samples, fs, p);
        let free_p = free.as_ref().map_or(1.0, |f| f.p_value);
        // Refined where the model's test has some evidence, or where the model-free test has
        // strong evidence the model's lacks: then iterated while the evidence grows, as a drift
        // is. A 1.5e-3 (m/s²)/°C coupling over a 6-°C warm-up (≈ 30σ of 10-s means) read t = 1.8
        // under the base fit, whose random walk and ramp held the drift, while the model-free
        // test gave p = 2.7e-6: found in 6 of 10 such records, a false ramp kept in its place.
        let suspected = free_p < FREE_REFINE_P;
        // Refinement starts from the model-free estimate where that test is the one with the
        // evidence: the estimate under the base fit is shrunk by the random walk that took the
        // drift in, and removing only that much left the walk in place, so the iteration stopped
        // where it began (a -1.5e-4 (rad/s)/°C coupling over a 3-°C warm-up in 15 min read
        // -1.1e-4 at t = -1.8 beside model-free p = 5e-15, and K stayed at 44× the truth with an
        // interval that excluded it). The increments' estimate is not shrunk by a random walk.
        let start = match &free {
            Some(f) if suspected => f.clone(),
            _ => first.clone(),
        };
        let c = if first.p_value < REFINE_P * family as f64 || suspected {
            let p_of = |c: &Coupling| c.p_value;
            refined(
                state,
                fs,
                cfg,
                start,
                &estimate,
                Refinement {
                    remove: &|v, c| remove_coupling(v, a.samples, c),
                    iterate: suspected.then_some(&p_of as &dyn Fn(&Coupling) -> f64),
                    k: if free_p < KEPT_P {
                        NoiseK::Kept
                    } else {
                        NoiseK::Fitted
                    },
                },
            )
        } else {
            first
        };
        // The coefficient and its interval are in the evidence whether or not the coupling is
        // admitted: a sensitivity to temperature is a datasheet figure, and a bound on it is an
        // answer too. In SI (the channel's SI unit per the aux channel's: (rad/s)/K for a gyro on
        // a temperature), as everything the loop holds; the report layer names the units of the
        // couplings it admits.
        let free = free.map_or(String::new(), |f| {
            format!("; model-free increments test p = {:.1e}", f.p_value)
        });
        if c.p_value < DETECTION_P {
            detected.push((a.name, a.samples, c.clone()));
        }
        let (fit, samples) = (c.clone(), a.samples);
        out.push(Candidate {
            veto: None,
            delta_bic: c.delta_bic,
            evidence: format!(
                "time series: regression on {} under the fitted noise model: coefficient {:.3e} [{:.3e}, {:.3e}] in SI (t = {:.1} on {} increments of {:.1} s, p = {:.1e}){free}",
                a.name, c.coefficient, c.lo, c.hi, c.z, c.n_eff, c.scale_s, c.p_value
            ),
            effect: Effect::Coupling {
                aux: a.name.to_string(),
                fit: c,
            },
            apply: Apply::Series(Box::new(move |y: &mut Vec<f64>| {
                remove_coupling(y, samples, &fit)
            })),
        });
    }
    // The searches regress on whitened increments, whitened once per noise model: K as fitted
    // (the exponential drifts) and K guarded ([`NoiseK::Guarded`]: the parabola, the steps and
    // the excursions).
    let increments = IncrementModel::for_series(&density, fs, y, MAX_INCREMENTS);
    let guarded = noise_density(model, stochastic, fs, NoiseK::Guarded);
    // Whitened again only where the guard changes K (the fit kept K with an interval down to 0).
    let guard_changes_k = undetermined_k(model).is_some();
    let own_guarded = guard_changes_k
        .then(|| IncrementModel::for_series(&guarded, fs, y, MAX_INCREMENTS))
        .flatten();
    let guarded_increments = if guard_changes_k {
        &own_guarded
    } else {
        &increments
    };
    // A parabola is what a random walk's wander looks like over a record: weighed against K as
    // fitted where K read low, one was added to clean K-dominated accelerometers (ΔBIC −12 and
    // −20.8); the settling exponential of a warm-up keeps K as fitted (guarded, K took in more of
    // a 100-°/h warm-up, found then in 41 of 50 records instead of 49).
    let drift_k = |shapes: DriftShapes| match shapes {
        DriftShapes::Quadratic => NoiseK::Guarded,
        _ => NoiseK::Fitted,
    };
    // A drift with some evidence is refined in each family of shapes apart, and the one that
    // then scores best is the candidate: under a noise model whose random walk took a warm-up
    // in, the parabola can beat the settling exponential by a hair, and removing the parabola
    // leaves the warm-up, and the random walk, in place.
    let drift_of = |shapes: DriftShapes| {
        let whitened = match drift_k(shapes) {
            NoiseK::Guarded => guarded_increments,
            NoiseK::Fitted | NoiseK::Kept => &increments,
        };
        whitened
            .as_ref()
            .and_then(|(m, u)| drift_in(y, fs, m, u, p, shapes))
    };
    let drift = |first: Option<Drift>, shapes: DriftShapes| {
        let estimate = |density: &dyn Fn(f64) -> f64| drift_under_model(y, fs, density, p, shapes);
        slow_candidate(state, fs, cfg, first, &estimate, drift_k(shapes))
    };
    let all = drift_of(DriftShapes::All);
    let mut drift = if all.as_ref().is_some_and(|d| d.p_value < REFINE_P) {
        [DriftShapes::Exponential, DriftShapes::Quadratic]
            .into_iter()
            .filter_map(|shapes| drift(drift_of(shapes), shapes))
            .min_by(|a, b| a.delta_bic.total_cmp(&b.delta_bic))
    } else {
        drift(all, DriftShapes::All)
    };
    if let Some(d) = drift.as_mut() {
        d.veto = explained_by_coupling(d, &detected, y, fs, &density, p);
        // The coupling then stands for the drift, which is right where the temperature drives
        // it; but a drift that is significant on its own and that the coupling explains may be
        // the bias's own warm-up beside a temperature that warms up too (a 150-°/h warm-up of Tc
        // 300 s beside a temperature warming with Tc 600 s was reported as a coupling in 20 of 20
        // records, with nothing to say the coefficient rests on that reading): the coupling's
        // evidence says so, with both scores (the drift's under the base fit, the coupling's
        // refined).
        // Not where the coupling still holds once the drift is taken out (the series follows
        // the aux channel's wander, or its warm-up's own shape): then the data tell the two apart.
        if d.veto.is_some() && !coupling_beyond_drift(d, &detected, y, fs, &density, p) {
            let coupling = out
                .iter_mut()
                .filter(|c| matches!(c.effect, Effect::Coupling { .. }))
                .min_by(|a, b| a.delta_bic.total_cmp(&b.delta_bic));
            // The same is a warning of the channel's ([`FitWarning::CouplingOrWarmUp`]) once
            // the coupling is kept, so that stderr and the fleet table carry it, not only the
            // effect's evidence.
            if let Some(c) = coupling {
                if let Effect::Coupling { aux, fit } = &mut c.effect {
                    fit.explains_drift = Some(d.delta_bic);
                    c.evidence.push_str(&format!(
                        "; a drift of the bias is significant on its own too (ΔBIC {:.1} \
                         against the coupling's {:.1}) and the coupling explains it: where \
                         {aux} only warms up, with no wander the series follows, a warm-up of \
                         the bias and {aux}'s are not told apart, and the coefficient holds only \
                         if the drift is {aux}'s",
                        d.delta_bic, c.delta_bic
                    ));
                }
            }
        }
    }
    out.extend(drift);
    // One scan of every box gives the best excursion and the best single step, under K guarded.
    let boxes = guarded_increments
        .as_ref()
        .and_then(|(m, u)| BoxSearch::new(y, fs, &guarded, m, u));
    let first = boxes.as_ref().and_then(|b| step_from_search(b, p));
    let estimate = |density: &dyn Fn(f64) -> f64| step_under_model(y, fs, density, p);
    out.extend(slow_candidate(
        state,
        fs,
        cfg,
        first,
        &estimate,
        NoiseK::Guarded,
    ));
    let first = boxes.as_ref().and_then(|b| b.excursion(p));
    let estimate = |density: &dyn Fn(f64) -> f64| excursion_under_model(y, fs, density, p);
    out.extend(slow_candidate(
        state,
        fs,
        cfg,
        first,
        &estimate,
        NoiseK::Guarded,
    ));
    out
}

/// Whether the strongest detected coupling is still significant (family-wise p below
/// [`DETECTION_P`]) in `y` with the drift `candidate` removed: the converse of
/// [`explained_by_coupling`]. A coupling that holds only through the warm-up both series share is
/// not told from a warm-up of the bias's own; one that the series' following of the aux
/// channel's wander (or the warm-up's own shape, where it differs from the drift's) carries is.
fn coupling_beyond_drift(
    candidate: &Candidate,
    detected: &[(&str, &[f64], Coupling)],
    y: &[f64],
    fs: f64,
    density: Density<'_>,
    p: f64,
) -> bool {
    let Effect::Drift(drift) = &candidate.effect else {
        return false;
    };
    let Some((_, samples, _)) = strongest(detected) else {
        return false;
    };
    let mut without = y.to_vec();
    remove_drift(&mut without, fs, drift);
    coupling_under_model(&without, samples, fs, density, 1, p)
        .is_some_and(|c| c.p_value < DETECTION_P)
}

/// The coupling of `detected` with the lowest p-value.
fn strongest<'a, 'b>(
    detected: &'a [(&'b str, &'b [f64], Coupling)],
) -> Option<&'a (&'b str, &'b [f64], Coupling)> {
    detected
        .iter()
        .min_by(|a, b| a.2.p_value.total_cmp(&b.2.p_value))
}

/// Why a drift `candidate` may not be added: a coupling of `detected` (strong enough to be added
/// itself) explains it, the drift's family-wise p-value on the series without that coupling (the
/// one of lowest p) no longer below [`DETECTION_P`]. A warm-up seen on a temperature channel is
/// that channel's coupling, not a shape fitted to it: on a 1-h record with a 5 °C warm-up and a
/// coupling of 1e-4 (rad/s)/°C the drift, refined in its own family of shapes, scored a lower
/// ΔBIC than the coupling and was added in its place (the wander of the temperature left
/// unexplained). The drift is the observed cause's only where no coupling is strong.
fn explained_by_coupling(
    candidate: &Candidate,
    detected: &[(&str, &[f64], Coupling)],
    y: &[f64],
    fs: f64,
    density: Density<'_>,
    p: f64,
) -> Option<String> {
    let Effect::Drift(drift) = &candidate.effect else {
        return None;
    };
    if drift.p_value >= DETECTION_P {
        return None;
    }
    let (name, samples, coupling) = strongest(detected)?;
    let mut without = y.to_vec();
    remove_coupling(&mut without, samples, coupling);
    let left =
        drift_under_model(&without, fs, density, p, DriftShapes::All).map_or(1.0, |d| d.p_value);
    (left >= DETECTION_P).then(|| {
        format!(
            "not proposed: the coupling to {name} explains it (family-wise p = {left:.1e} without the coupling)"
        )
    })
}

/// A slow effect the time domain finds under the fitted noise model (a drift, a GLS step, an
/// excursion): what [`slow_candidate`] needs to refine it and offer it.
pub(super) trait SlowEffect: Clone + Send + 'static {
    /// Whether its feasible GLS iterates (see [`refined`]).
    const ITERATE: bool = false;
    fn p_value(&self) -> f64;
    fn delta_bic(&self) -> f64;
    fn evidence(&self) -> String;
    fn effect(self) -> Effect;
    fn remove(&self, y: &mut Vec<f64>, fs: f64);
}

impl SlowEffect for Drift {
    const ITERATE: bool = true;
    fn p_value(&self) -> f64 {
        self.p_value
    }
    fn delta_bic(&self) -> f64 {
        self.delta_bic
    }
    fn evidence(&self) -> String {
        format!(
            "time series: drift shape under the fitted noise model (t = {:.1} on {} increments of {:.1} s, p = {:.1e} over the shapes tried)",
            self.z, self.increments, self.block_s, self.p_value
        )
    }
    fn effect(self) -> Effect {
        Effect::Drift(self)
    }
    fn remove(&self, y: &mut Vec<f64>, fs: f64) {
        remove_drift(y, fs, self);
    }
}

impl SlowEffect for Step {
    fn p_value(&self) -> f64 {
        self.p_value
    }
    fn delta_bic(&self) -> f64 {
        self.delta_bic
    }
    fn evidence(&self) -> String {
        format!(
            "time series: the mean shifts at {:.1} s and stays, under the fitted noise model (t = {:.1} on increments of {:.1} s, p = {:.1e} over the positions)",
            self.time_s, self.z, self.window_s, self.p_value
        )
    }
    fn effect(self) -> Effect {
        Effect::Step(self)
    }
    fn remove(&self, y: &mut Vec<f64>, _fs: f64) {
        remove_step(y, self);
    }
}

impl SlowEffect for Excursion {
    fn p_value(&self) -> f64 {
        self.p_value
    }
    fn delta_bic(&self) -> f64 {
        self.delta_bic
    }
    fn evidence(&self) -> String {
        let settles = self.after.map_or(String::new(), |a| {
            format!(
                "; it settles {:.3e} from where it started (t = {:.1})",
                a.size, a.z
            )
        });
        format!(
            "time series: the mean leaves and returns, {:.1}–{:.1} s (t = {:.1} on {} increments of {:.1} s, p = {:.1e} over {} boxes){settles}",
            self.start_s, self.end_s, self.z, self.increments, self.block_s, self.p_value, self.boxes
        )
    }
    fn effect(self) -> Effect {
        Effect::Excursion(self)
    }
    fn remove(&self, y: &mut Vec<f64>, _fs: f64) {
        remove_excursion(y, self);
    }
}

/// `first`, refined by feasible GLS when its p-value is below [`REFINE_P`], as a candidate.
pub(super) fn slow_candidate<T: SlowEffect>(
    state: &State,
    fs: f64,
    cfg: &LoopConfig,
    first: Option<T>,
    estimate: &dyn Fn(Density<'_>) -> Option<T>,
    k: NoiseK,
) -> Option<Candidate<'static>> {
    let first = first?;
    let e = if first.p_value() < REFINE_P {
        refined(
            state,
            fs,
            cfg,
            first,
            estimate,
            Refinement {
                remove: &|v, e: &T| e.remove(v, fs),
                iterate: T::ITERATE.then_some(&|e: &T| e.p_value()),
                k,
            },
        )
    } else {
        first
    };
    let applied = e.clone();
    Some(Candidate {
        veto: None,
        delta_bic: e.delta_bic(),
        evidence: e.evidence(),
        effect: e.effect(),
        apply: Apply::Series(Box::new(move |y| applied.remove(y, fs))),
    })
}
