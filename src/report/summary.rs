//! `summary.md`: what an engineer reads first. Per recording, the quality screen, then tables in
//! the style of Paszek & Kaniewski (2014, Tables 3–5): each noise term per axis, estimated from the
//! spectrum and from the Allan variance, in both unit systems (°/√h and (°/s)/√Hz, °/h and °/s, …),
//! with intervals, the PSD/AV ratio and whether the intervals overlap; then the fit quality.

use std::fmt::Write;

use crate::analysis::ChannelAnalysis;
use crate::effects::ramp::{RampAction, RampDecision, TestedSeries};
use crate::effects::shapes::ResonanceForm;
use crate::effects::slow::DriftShape;
use crate::effects::{Effect, ErrorFigures};
use crate::io::Recording;
use crate::model::{BandEdge, FitWarning, NoiseFit, Sensor, Term, TermEstimate};
use crate::pipeline::FileResult;
use crate::units::Unit;

use super::format::{count, count_as, duration, rate_hz, sig, sig4, Shown};
use super::model::units_of;

/// One fit's estimate with its interval; a value the fit could not tell from a neighbouring
/// term's says so (its interval then reaches as low as the neighbour's reading puts it).
fn cell(e: Option<&TermEstimate>, unit: crate::model::CoefUnit) -> String {
    match e {
        Some(e) => format!(
            "{} [{}, {}]{}",
            sig4(unit.from_si(e.value)),
            sig4(unit.from_si(e.lo)),
            sig4(unit.from_si(e.hi)),
            e.ambiguous_with.map_or(String::new(), |u| format!(
                " (not told from {})",
                u.symbol()
            ))
        ),
        None => "not significant".into(),
    }
}

fn sensor_title(sensor: Sensor) -> &'static str {
    match sensor {
        Sensor::Gyro => "Gyroscopes",
        Sensor::Accel => "Accelerometers",
    }
}

/// One table: `term` for every channel of `sensor`, PSD and AV, in both display units.
fn term_table(out: &mut String, sensor: Sensor, term: Term, channels: &[&ChannelAnalysis]) {
    let [_, u1, u2] = units_of(sensor, term);
    let _ = writeln!(
        out,
        "\n**{} — {} ({})**\n",
        sensor_title(sensor),
        term.name(sensor == Sensor::Gyro),
        term.symbol()
    );
    let _ = writeln!(
        out,
        "| axis | PSD [{p1}] | AV [{p1}] | PSD [{p2}] | AV [{p2}] | PSD/AV | intervals overlap |",
        p1 = u1.pretty(),
        p2 = u2.pretty()
    );
    let _ = writeln!(out, "|---|---|---|---|---|---|---|");
    for a in channels {
        let (av, sp) = (
            a.allan_fit().and_then(|f| f.get(term)),
            a.spectrum_fit().and_then(|f| f.get(term)),
        );
        let row = a.comparison.iter().find(|r| r.term == term);
        let ratio = row
            .and_then(|r| r.ratio)
            .map_or("–".into(), |r| format!("{r:.3}"));
        let overlap = row
            .and_then(|r| r.overlap)
            .map_or("–", |o| if o { "yes" } else { "no" });
        let _ = writeln!(
            out,
            "| {} | {} | {} | {} | {} | {ratio} | {overlap} |",
            a.channel,
            cell(sp, u1),
            cell(av, u1),
            cell(sp, u2),
            cell(av, u2),
        );
    }
}

fn kept(fit: Option<&NoiseFit>) -> String {
    match fit {
        Some(f) if f.estimates.is_empty() => "none".into(),
        Some(f) => f
            .estimates
            .iter()
            .map(|e| e.term.symbol())
            .collect::<Vec<_>>()
            .join(" "),
        None => "fit failed".into(),
    }
}

fn chi2(fit: Option<&NoiseFit>) -> String {
    fit.map_or("–".into(), |f| {
        format!("{:.2} ({} dof)", f.chi2_per_dof(), f.dof)
    })
}

fn failure(r: &Result<NoiseFit, crate::model::FitError>) -> Option<String> {
    r.as_ref().err().map(|e| e.to_string())
}

fn file_section(out: &mut String, r: &FileResult) {
    let q = &r.quality;
    let _ = writeln!(out, "\n## {}\n", r.recording.path.display());
    let _ = writeln!(
        out,
        "{} per channel at {}, {}, {}; backend: {}.",
        count(q.samples_out, "sample"),
        rate_hz(r.recording.rate_hz),
        duration(q.duration_s),
        count(r.recording.channels.len() as u64, "channel"),
        r.backend
    );
    let mut notes = Vec::new();
    if q.gap_count > 0 {
        notes.push(format!(
            "{}, {} missing (policy {})",
            count(q.gap_count, "gap"),
            count(q.missing_samples, "sample"),
            q.gap_policy
        ));
    }
    if q.dropped_rows > 0 {
        notes.push(format!(
            "{} with non-finite samples dropped (policy drop): the samples either side are \
             joined as if contiguous, as `--on-gap ignore` joins a gap's",
            count(q.dropped_rows, "row")
        ));
    }
    if q.duplicate_rows > 0 {
        notes.push(format!(
            "{} repeating the previous timestamp dropped (policy drop; the first of each kept)",
            count(q.duplicate_rows, "row")
        ));
    }
    for c in &q.channels {
        for v in &c.verdicts {
            notes.push(format!("{}: {}", c.name, v.describe()));
        }
        if c.nonfinite_samples > 0 {
            notes.push(format!(
                "{}: {} (policy {})",
                c.name,
                count(c.nonfinite_samples, "non-finite sample"),
                q.nonfinite_policy
            ));
        }
    }
    notes.extend(r.recording.notes.iter().cloned());
    notes.extend(r.backend_notes.iter().cloned());
    for n in notes {
        let _ = writeln!(out, "- {n}");
    }
    let Some(analysis) = &r.analysis else { return };
    if analysis.is_empty() {
        let _ = writeln!(
            out,
            "\nNo gyro or accelerometer channel (set `kind` metadata or `--kind COLUMN=gyro`)."
        );
        return;
    }
    let _ = writeln!(
        out,
        "\nIntervals are {} two-sided; a term is listed as not significant, with the largest \
         value the fits allow, when the information criterion admitted it in neither fit.",
        confidence_text(analysis)
    );
    combined_section(out, analysis);
    let _ = writeln!(
        out,
        "\n### Evidence: the two fits\n\nEach term as the spectrum (PSD) and the Allan variance (AV) \
         fits give it; the combined values above come from these. A value marked \"not told from\" \
         is one the fit could not tell from the neighbouring term named: a model with that term in \
         its place fits as well, and the interval reaches down as far as that model puts it \
         (to 0 where it weighs more than the interval's lower tail)."
    );
    for sensor in [Sensor::Gyro, Sensor::Accel] {
        let channels: Vec<&ChannelAnalysis> =
            analysis.iter().filter(|a| a.sensor == sensor).collect();
        if channels.is_empty() {
            continue;
        }
        let _ = writeln!(out, "\n#### {}", sensor_title(sensor));
        for term in Term::ALL {
            let present = channels.iter().any(|a| {
                a.allan_fit().and_then(|f| f.get(term)).is_some()
                    || a.spectrum_fit().and_then(|f| f.get(term)).is_some()
            });
            // N and B are always tabled (the paper's Tables 4 and 5); other terms when found.
            if present || matches!(term, Term::RandomWalk | Term::BiasInstability) {
                term_table(out, sensor, term, &channels);
            }
        }
    }
    let _ = writeln!(out, "\n### Fit quality\n");
    let _ = writeln!(
        out,
        "| channel | terms (AV) | χ²/dof (AV) | terms (PSD) | χ²/dof (PSD) |"
    );
    let _ = writeln!(out, "|---|---|---|---|---|");
    for a in analysis {
        let _ = writeln!(
            out,
            "| {} | {} | {} | {} | {} |",
            a.channel,
            kept(a.allan_fit()),
            chi2(a.allan_fit()),
            kept(a.spectrum_fit()),
            chi2(a.spectrum_fit())
        );
    }
    loop_section(out, &r.recording, analysis);
    for a in analysis {
        for (what, r) in [("AV", &a.allan), ("PSD", &a.spectrum)] {
            if let Some(reason) = failure(r) {
                let _ = writeln!(out, "\n- {} {what} fit failed: {reason}", a.channel);
            }
        }
    }
}

/// The read-off and the slope there, as the last two cells of a coefficient row.
fn read_off_cells(read: Option<&crate::model::ReadOff>, u: crate::model::CoefUnit) -> String {
    // With its 1σ interval: B's read-off is the minimum over every τ, which can sit at the
    // longest τ, where a handful of averages leave it uncertain several-fold.
    let value = read.map_or("–".into(), |r| {
        format!(
            "{} [{}, {}] {} at τ = {} s",
            sig4(u.from_si(r.value)),
            sig4(u.from_si(r.lo)),
            sig4(u.from_si(r.hi)),
            u.pretty(),
            sig4(r.tau_s)
        )
    });
    // B's read-off without a slope: the lowest σ is the τ grid's first or last point, where the
    // curve has not turned (no plateau), so min σ/0.664 is not B there and the fit is not checked
    // against it (see `model::combine`).
    let slope = read.map_or("–".into(), |r| {
        if r.slope.is_finite() {
            format!("{:+.2}", r.slope)
        } else if r.term == crate::model::Term::BiasInstability {
            "none: lowest σ at the τ grid's end, no plateau".into()
        } else {
            "–".into()
        }
    });
    format!("{value} | {slope}")
}

/// The combined coefficients first (one answer per term, both display units), the IEEE read-offs
/// beside them, the sensor bandwidth and every warning.
fn combined_section(out: &mut String, analysis: &[ChannelAnalysis]) {
    // The read-offs' intervals are at the run's confidence, as every other interval here.
    let _ = writeln!(
        out,
        "\n### Coefficients (combined)\n\nOne value per term: the more precise of the two fits, or \
         the one whose model has the term's neighbours (Q–N–B–K–R) when only one does; the interval \
         spans both fits where they disagree. Read-offs from the Allan deviation: N = σ(τ)·√τ and \
         K = σ(τ)·√(3/τ) on their slope lines (at τ = 1 s and 3 s, interpolated between the \
         octave points, where the curve's slope is the term's there; else at the τ shown, the \
         best-measured pair of points with the term's slope), B = min σ/0.664; with the {} \
         interval of σ there (the slope says whether the term rules it).\n",
        confidence_text(analysis)
    );
    let _ = writeln!(
        out,
        "| channel | term | value | interval | from | read-off | slope at read-off |"
    );
    let _ = writeln!(out, "|---|---|---|---|---|---|---|");
    for a in analysis {
        for t in &a.combined.terms {
            let [_, u1, _] = units_of(a.sensor, t.term);
            let read = a.combined.read_offs.iter().find(|r| r.term == t.term);
            let source = match t.source {
                crate::model::Domain::Allan => "AV",
                crate::model::Domain::Spectrum => "PSD",
            };
            let ambiguous = t.ambiguous_with.map_or(String::new(), |u| {
                format!(" (not told from {})", u.symbol())
            });
            let _ = writeln!(
                out,
                "| {} | {} | {} {unit} | [{}, {}] {unit}{} | {source}{ambiguous} | {} |",
                a.channel,
                t.term.symbol(),
                sig4(u1.from_si(t.value)),
                sig4(u1.from_si(t.lo)),
                sig4(u1.from_si(t.hi)),
                if t.hull { " (both fits)" } else { "" },
                read_off_cells(read, u1),
                unit = u1.pretty(),
            );
        }
        // The terms neither fit admitted: not significant, with the largest value the fits allow.
        for term in Term::ALL {
            if a.combined.get(term).is_some() {
                continue;
            }
            let Some(upper) = a.combined.limit(term) else {
                continue;
            };
            let [_, u1, _] = units_of(a.sensor, term);
            let read = a.combined.read_offs.iter().find(|r| r.term == term);
            let _ = writeln!(
                out,
                "| {} | {} | not significant | ≤ {} {unit} | – | {} |",
                a.channel,
                term.symbol(),
                sig4(u1.from_si(upper)),
                read_off_cells(read, u1),
                unit = u1.pretty(),
            );
        }
    }
    let mut notes = Vec::new();
    for a in analysis {
        if let Some(b) = &a.bandwidth {
            let band = format!(
                "fits use the spectrum up to {} Hz and the Allan variance from τ = {} s",
                sig4(b.fit_max_freq_hz),
                b.fit_min_tau_s.map_or("–".into(), sig4),
            );
            notes.push(match b.cause {
                BandEdge::LowPass => format!(
                    "{}: {} detected ({}, {:.0} dB/decade envelope, ΔBIC {:.0}); {band}",
                    a.channel,
                    super::lowpass_text(&b.lowpass),
                    match b.lowpass.form {
                        crate::model::FilterForm::Analog => "analog form",
                        crate::model::FilterForm::Digital { .. } => "digital form",
                        crate::model::FilterForm::Sampled { .. } =>
                            "analog form sampled with its tail folded back",
                    },
                    b.slope_db_per_decade,
                    b.delta_bic,
                ),
                BandEdge::AngleQuantiser { steps_per_sigma, .. } => format!(
                    "{}: the spectrum falls below the IEEE model towards Nyquist (an edge fitted at {} Hz, \
                     ΔBIC {:.0}), where the output's coarse angle grid ({:.1} white σ per step, the fits' Q) \
                     makes the rounding error correlated: no filter is claimed, and Q's interval spans both \
                     fits (IEEE 952's Q form describes a correlated error only roughly); {band}",
                    a.channel,
                    sig4(b.lowpass.corner_hz),
                    b.delta_bic,
                    steps_per_sigma,
                ),
            });
        }
        for w in &a.combined.warnings {
            notes.push(format!(
                "**warning** {}: {}",
                a.channel,
                warning_line(w, a.sensor)
            ));
        }
    }
    if !notes.is_empty() {
        let _ = writeln!(out);
        for n in notes {
            let _ = writeln!(out, "- {n}");
        }
    }
}

/// The run's confidence level in words: "1σ (68.3 %)" or "95.0 %".
pub(super) fn confidence_text(analysis: &[ChannelAnalysis]) -> String {
    let p = analysis
        .iter()
        .find_map(|a| a.allan_fit().or(a.spectrum_fit()))
        .map(|f| f.confidence);
    match p {
        Some(p) if (p - 0.682_689).abs() < 1e-4 => "1σ (68.3 %)".into(),
        Some(p) => format!("{:.1} %", 100.0 * p),
        None => "–".into(),
    }
}

/// The whole summary.
pub fn summary_markdown(ok: &[&FileResult], failed: &[(String, String)], elapsed_s: f64) -> String {
    let mut out = String::new();
    let _ = writeln!(out, "# imunoise noise analysis\n");
    let _ = writeln!(
        out,
        "imunoise {}; {} analysed, {} failed, in {}. Coefficients are fitted by \
         weighted non-negative least squares to the overlapping Allan variance (AV) and, \
         separately, to the log-binned Welch spectrum (PSD); values in SI are in report.json and \
         coefficients.csv.",
        env!("CARGO_PKG_VERSION"),
        count_as(ok.len() as u64, "file", "files"),
        failed.len(),
        duration(elapsed_s)
    );
    for r in ok {
        file_section(&mut out, r);
    }
    if !failed.is_empty() {
        let _ = writeln!(out, "\n## Files that failed\n");
        for (path, message) in failed {
            let _ = writeln!(out, "- {path}: {message}");
        }
    }
    out
}

/// The units the effects of one channel are in: the channel's SI unit, and the unit of every other
/// channel of its recording (the aux channel a coupling names).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct EffectUnits {
    pub value: Option<Unit>,
    pub others: Vec<(String, Option<Unit>)>,
}

impl EffectUnits {
    /// The units of `channel` of `recording` (values in SI after ingest).
    pub fn of(recording: &Recording, channel: &str) -> EffectUnits {
        let unit = |name: &str| {
            recording
                .channels
                .iter()
                .find(|c| c.name == name)
                .and_then(|c| c.si_unit())
        };
        EffectUnits {
            value: unit(channel),
            others: recording
                .channels
                .iter()
                .map(|c| (c.name.clone(), c.si_unit()))
                .collect(),
        }
    }

    fn of_other(&self, name: &str) -> Option<Unit> {
        self.others
            .iter()
            .find(|(n, _)| n == name)
            .and_then(|(_, u)| *u)
    }
}

/// `12.500002 Hz [12.499987, 12.500016]`: a frequency and its interval with as many decimals as
/// tell the ends apart (four at least, nine at most). With four always, a line's interval of
/// ±15 µHz printed as `12.5000 Hz [12.5000, 12.5000]`, as if it had none.
fn hz_interval(v: f64, lo: f64, hi: f64) -> String {
    let spread = (hi - lo) / 2.0;
    let decimals = if spread > 0.0 && spread.is_finite() {
        (1 - spread.log10().floor() as i32).clamp(4, 9) as usize
    } else {
        4
    };
    format!("{v:.decimals$} Hz [{lo:.decimals$}, {hi:.decimals$}]")
}

/// A line-like effect's centre and the spread within which a multiple of another's counts as
/// its harmonic, Hz: a sinusoid's centre interval, a narrow band's or a resonance's width.
fn tonal(e: &Effect) -> Option<(f64, f64)> {
    match e {
        Effect::Sinusoid(s) => Some((s.freq_hz, (s.freq_hi - s.freq_lo).abs())),
        Effect::Narrowband(nb) => Some((nb.freq_hz, nb.width_hz)),
        Effect::Resonance { f0_hz, q, .. } => Some((*f0_hz, f0_hz / q.max(1.0))),
        _ => None,
    }
}

/// Harmonics reach no higher than this multiple of their fundamental.
const MAX_HARMONIC: f64 = 8.0;

/// For each of `effects`, the note that it lies at a whole multiple n ≥ 2 of a lower tonal
/// effect of the same channel (a line, a narrow band or a resonance): within half the narrower
/// of its spread and n times the lower one's, and at least 0.5 % of the frequency (a broad
/// resonance near a high multiple of a line is not called its harmonic on its breadth alone). A fan's
/// second and third harmonics were listed as two more lines and one as a "resonance at 150 Hz",
/// with nothing tying them to the 50-Hz fundamental; a structural resonance does not sit at a
/// whole multiple of a line by chance often, and the note says "harmonic?" not more.
pub fn harmonic_notes(effects: &[&Effect]) -> Vec<Option<String>> {
    let tones: Vec<Option<(f64, f64)>> = effects.iter().map(|e| tonal(e)).collect();
    tones
        .iter()
        .enumerate()
        .map(|(i, t)| {
            let (f, w) = (*t)?;
            tones
                .iter()
                .enumerate()
                .filter(|(j, _)| *j != i)
                .filter_map(|(_, o)| *o)
                .filter(|&(f0, _)| f0 > 0.0 && f > 1.5 * f0 && f <= MAX_HARMONIC * f0)
                .find_map(|(f0, w0)| {
                    let n = (f / f0).round();
                    let tolerance = (0.5 * w.min(n * w0)).max(0.005 * f);
                    ((f - n * f0).abs() <= tolerance).then(|| {
                        format!(
                            " ({}× the one at {} Hz: a harmonic?)",
                            n as u32,
                            super::format::sig4(f0)
                        )
                    })
                })
        })
        .collect()
}

/// [`effect_line`] of each of a channel's effects, with [`harmonic_notes`].
pub fn effect_lines(effects: &[&Effect], units: &EffectUnits) -> Vec<String> {
    effects
        .iter()
        .zip(harmonic_notes(effects))
        .map(|(e, note)| effect_line(e, units) + note.as_deref().unwrap_or(""))
        .collect()
}

/// One line per effect found: what, its parameters with their units, the evidence.
pub fn effect_line(e: &Effect, units: &EffectUnits) -> String {
    let v = Shown::value(units.value);
    match e {
        Effect::Sinusoid(s) => format!(
            "line at {}, amplitude (as sampled) {}",
            hz_interval(s.freq_hz, s.freq_lo, s.freq_hi),
            v.interval(s.amplitude, s.amplitude_lo, s.amplitude_hi)
        ),
        Effect::Narrowband(nb) => {
            let band = format!(
                "narrow band (a wandering line or a peak) at {}, width {} Hz [{}, {}], rms {} (power {}; a coherent sinusoid explains {:.0} %)",
                hz_interval(nb.freq_hz, nb.freq_lo_hz, nb.freq_hi_hz),
                sig4(nb.width_hz),
                sig4(nb.width_lo_hz),
                sig4(nb.width_hi_hz),
                v.interval(nb.power.sqrt(), nb.power_lo.sqrt(), nb.power_hi.sqrt()),
                Shown::squared(units.value).one(nb.power),
                100.0 * nb.coherent_share
            );
            match &nb.resonance {
                None => band,
                Some(r) => format!(
                    "{band}; as a resonance over the extrapolated floor: f₀ {:.3} Hz [{:.3}, {:.3}], Q {:.1} [{:.1}, {:.1}], σ before the sensor's low-pass {}",
                    r.f0_hz,
                    r.f0_lo_hz,
                    r.f0_hi_hz,
                    r.q,
                    r.q_lo,
                    r.q_hi,
                    v.interval(r.sigma, r.sigma_lo, r.sigma_hi)
                ),
            }
        }
        Effect::Resonance {
            f0_hz,
            f0_lo,
            f0_hi,
            q,
            q_lo,
            q_hi,
            form,
            sigma,
        } => format!(
            "resonance at {f0_hz:.3} Hz [{f0_lo:.3}, {f0_hi:.3}], Q {q:.1} [{q_lo:.1}, {q_hi:.1}], σ {} ({})",
            v.interval(sigma.value, sigma.lo, sigma.hi),
            match form {
                ResonanceForm::LowPass => "low-pass: a plateau below f₀",
                ResonanceForm::BandPass => "band-pass: no plateau below f₀",
            }
        ),
        Effect::GaussMarkov {
            tc_s,
            tc_lo_s,
            tc_hi_s,
            sigma,
        } => format!(
            "Gauss–Markov process, Tc {} s [{}, {}], σ {}",
            sig4(*tc_s),
            sig4(*tc_lo_s),
            sig4(*tc_hi_s),
            v.interval(sigma.value, sigma.lo, sigma.hi)
        ),
        Effect::Coupling { aux, fit } => format!(
            "coupling to {aux}: {}; {} across the {} that {aux} spans (1-s means), {:.1} % of \
             the variance",
            Shown::ratio(units.value, units.of_other(aux), aux).interval(
                fit.coefficient,
                fit.lo,
                fit.hi
            ),
            Shown::value(units.value).one(fit.coefficient.abs() * fit.aux_span),
            Shown::value(units.of_other(aux)).one(fit.aux_span),
            100.0 * fit.explained_share
        ),
        Effect::Drift(d) => {
            let (what, shown) = match (d.shape, d.tc_interval_s) {
                (DriftShape::Exponential { tc_s }, Some((lo, hi))) => (
                    format!(
                        "settling drift exp(−t/τ), τ {} s [{}, {}], amplitude",
                        sig4(tc_s),
                        sig4(lo),
                        sig4(hi)
                    ),
                    v.clone(),
                ),
                (DriftShape::Exponential { tc_s }, None) => (
                    format!("settling drift exp(−t/τ), τ {} s, amplitude", sig4(tc_s)),
                    v.clone(),
                ),
                (DriftShape::Quadratic, _) => (
                    "quadratic drift c·(t − T/2)², c".to_string(),
                    Shown::per_s2(units.value),
                ),
            };
            format!(
                "{what} {}, {:.1} % of the variance",
                shown.interval(d.amplitude, d.lo, d.hi),
                100.0 * d.explained_share
            )
        }
        Effect::Spikes(s) => format!(
            "{} (first at {:.2} s), {:.2} % of the variance",
            count(s.indices.len() as u64, "spike"),
            s.times_s.first().copied().unwrap_or(f64::NAN),
            100.0 * s.variance_share
        ),
        Effect::Step(s) => format!(
            "bias step at {} of {}",
            match s.time_interval_s {
                Some((a, b)) => format!("{:.1} s [{a:.1}, {b:.1}]", s.time_s),
                None => format!("{:.1} s", s.time_s),
            },
            v.interval(s.size, s.lo, s.hi)
        ),
        Effect::Excursion(e) => {
            let when = |t: f64, i: Option<(f64, f64)>| match i {
                Some((a, b)) => format!("{t:.1} s [{a:.1}, {b:.1}]"),
                None => format!("{t:.1} s"),
            };
            let settles = e.after.map_or(String::new(), |a| {
                format!(
                    ", the mean settling {} from the level before it (not coming all the way back)",
                    v.interval(a.size, a.lo, a.hi)
                )
            });
            format!(
                "excursion from {} to {} of {}{settles}{}",
                when(e.start_s, e.start_interval_s),
                when(e.end_s, e.end_interval_s),
                v.interval(e.size, e.lo, e.hi),
                if e.interval_cut {
                    " (an edge interval cut at its search's end)"
                } else {
                    ""
                }
            )
        }
    }
}

/// A fit warning for a person: as [`FitWarning::describe`], with coefficients in the datasheet
/// unit of their term.
pub fn warning_line(w: &FitWarning, sensor: Sensor) -> String {
    match w {
        FitWarning::ContradictsReadOff {
            term,
            fitted,
            read_off,
            tau_s,
        } => {
            let [_, u, _] = units_of(sensor, *term);
            format!(
                "fitted {} = {} {unit} lies above what the Allan deviation allows at τ = {} s \
                 (read-off {} {unit})",
                term.symbol(),
                sig4(u.from_si(*fitted)),
                sig4(*tau_s),
                sig4(u.from_si(*read_off)),
                unit = u.pretty()
            )
        }
        FitWarning::BeyondAllanCurve {
            term,
            fitted,
            allowed,
            tau_s,
        } => {
            let [_, u, _] = units_of(sensor, *term);
            format!(
                "fitted {} = {} {unit} alone lies above the measured Allan deviation at τ = {} s, \
                 which allows at most {} {unit}",
                term.symbol(),
                sig4(u.from_si(*fitted)),
                sig4(*tau_s),
                sig4(u.from_si(*allowed)),
                unit = u.pretty()
            )
        }
        FitWarning::LackOfFit {
            domain,
            chi2_per_dof,
            p_value,
            inflation,
            from,
            to,
        } => {
            let (what, range) = match domain {
                crate::model::Domain::Allan => {
                    ("Allan", format!("τ = {}–{} s", sig(*from, 4), sig(*to, 4)))
                }
                crate::model::Domain::Spectrum => {
                    ("spectrum", format!("{}–{} Hz", sig(*from, 4), sig(*to, 4)))
                }
            };
            format!(
                "lack of fit in the {what} domain: χ²/dof = {chi2_per_dof:.3} (p = {p_value:.1e}), \
                 worst at {range}; intervals widened ×{inflation:.2}"
            )
        }
        FitWarning::CouplingOrWarmUp { .. }
        | FitWarning::LinesAcrossJoins { .. }
        | FitWarning::KOrCoupling { .. } => w.describe(),
        FitWarning::NotStatic {
            sensor: moving,
            largest_jump,
            ..
        } => {
            // In the moving channel's unit: rad/s and °/s, m/s² and g.
            let jump = match moving {
                Sensor::Gyro => format!(
                    "{} rad/s ({} °/s)",
                    sig4(*largest_jump),
                    sig4(largest_jump.to_degrees())
                ),
                Sensor::Accel => format!(
                    "{} m/s² ({} g)",
                    sig4(*largest_jump),
                    sig4(largest_jump / crate::units::STANDARD_GRAVITY)
                ),
            };
            crate::model::not_static_line(w, &jump)
        }
        FitWarning::HeavyTail { .. } => {
            let [_, u, _] = units_of(sensor, Term::RandomWalk);
            crate::model::heavy_tail_line(w, |x| sig4(u.from_si(x)), &u.pretty())
        }
        FitWarning::OutputResolution { .. } => {
            let [_, u, _] = units_of(sensor, Term::RandomWalk);
            let [_, uq, _] = units_of(sensor, Term::Quantization);
            // The step is a rate: in B's SI unit (rad/s, m/s²).
            let [rate, _, _] = units_of(sensor, Term::BiasInstability);
            crate::model::resolution_line(
                w,
                |x| sig4(u.from_si(x)),
                &u.pretty(),
                &rate.pretty(),
                |q| format!("{} {}", sig4(uq.from_si(q)), uq.pretty()),
            )
        }
        other => other.describe(),
    }
}

fn errors(f: &ErrorFigures) -> String {
    let d = |x: &Option<crate::effects::residuals::Diagnostics>| {
        x.as_ref().map_or("–".to_string(), |d| {
            format!("χ²/dof {:.2}, RMS log {:.3}", d.chi2_per_dof, d.rms_log)
        })
    };
    format!("AV {}; PSD {}", d(&f.allan), d(&f.spectrum))
}

/// [`ramp_sentence`] of every ramp decision of `a`, and where the base fits' test kept a ramp that
/// the final model lacks (the loop's effects took its rise in: a temperature coupling, a drift),
/// that said, so that "kept" does not read as the final answer beside "R not significant".
pub fn ramp_sentences(a: &ChannelAnalysis) -> String {
    let mut out: String = a
        .ramp_decisions()
        .map(|d| ramp_sentence(d, a.sensor))
        .collect();
    let kept = a
        .ramp_decisions()
        .last()
        .is_some_and(|d| d.action == RampAction::Kept);
    if kept && a.combined.get(Term::RateRamp).is_none() {
        out.push_str(" The final model has no ramp: the effects the loop added took its rise in.");
    }
    out
}

/// What the series' test of a rate ramp decided ([`crate::effects::ramp`]), as a sentence (with
/// a leading space: it follows the channel's loop line in summary.md).
pub fn ramp_sentence(d: &RampDecision, sensor: Sensor) -> String {
    let [_, u, _] = units_of(sensor, Term::RateRamp);
    let series = match d.series {
        TestedSeries::Recorded => "the recorded series",
        TestedSeries::Corrected => "the corrected series",
    };
    let action = match d.action {
        RampAction::Kept => "kept, its interval widened to the series'",
        RampAction::Dropped => "dropped, the fits made again without it",
        RampAction::Added => "added, required in the Allan fit (K alone had taken its place)",
        RampAction::NotAdded => match (d.test.determined(), d.estimate) {
            (false, _) => {
                "not added, the series showing a rise it does not tell from the random walk at \
                 the upper end of K's interval"
            }
            (true, None) => {
                "not added, the series showing a rise it does not tell from an aux channel's \
                 (a temperature's) fitted beside it"
            }
            (true, Some(_)) => {
                "not added, the series showing a rise that the model with R does not determine"
            }
        },
    };
    let t = &d.test;
    let sized = d.estimate.map_or(String::new(), |e| {
        format!(
            "; under the model with R, {} ± {}",
            sig4(u.from_si(e.ramp)),
            sig4(u.from_si(e.se))
        )
    });
    let name = Term::RateRamp.name(sensor == Sensor::Gyro);
    let mut title = name.chars();
    let title: String = title
        .next()
        .map(|c| c.to_uppercase().chain(title).collect())
        .unwrap_or_default();
    format!(
        " {title} {action}: in {series} R = {} ± {} {} under the model without it (t = {:.1}, p = {:.1e}){sized}.",
        sig4(u.from_si(t.ramp)),
        sig4(u.from_si(t.se)),
        u.pretty(),
        t.t,
        t.p
    )
}

fn loop_section(out: &mut String, recording: &Recording, analysis: &[ChannelAnalysis]) {
    let _ = writeln!(out, "\n### Residual loop: effects the IEEE model lacks\n");
    if analysis.iter().all(|a| a.residual_loop.is_none()) {
        let _ = writeln!(
            out,
            "Not run (`--no-loop`, or no base fit to start from): the coefficients are the base fits'.\n"
        );
    }
    for a in analysis {
        let ramp = ramp_sentences(a);
        let Some(l) = &a.residual_loop else {
            // The base fits' ramp decision stands without a loop too.
            if !ramp.is_empty() {
                let _ = writeln!(out, "- **{}**:{ramp}", a.channel);
            }
            continue;
        };
        let units = EffectUnits::of(recording, &a.channel);
        // A rival the coefficients were averaged with (see `effects::Rival`), at any weight.
        let rival = l.rival.as_ref().map_or(String::new(), |r| {
            format!(
                " Not admitted, averaged into the coefficients as a rival at {:.0} % of the weight: {} (ΔBIC {:+.1}).",
                100.0 * r.share,
                effect_line(&r.effect, &units),
                r.delta_bic
            )
        });
        // A coupling the loop weighed and did not admit still bounds the sensitivity the data
        // allow: its coefficient and interval (SI) are in the candidate's note.
        // Not where a coupling was admitted or is the rival: the last round's candidate is then
        // what is left of it in the corrected series.
        let rival_coupling = l
            .rival
            .as_ref()
            .is_some_and(|r| matches!(r.effect, Effect::Coupling { .. }))
            || l.steps
                .iter()
                .any(|s| matches!(s.effect, Effect::Coupling { .. }));
        let rival = l
            .rejected
            .iter()
            .filter(|r| r.kind == "coupling" && !rival_coupling)
            .fold(rival, |mut acc, r| {
                let _ = write!(
                    acc,
                    " Not admitted: a coupling ({}{}).",
                    r.note,
                    r.delta_bic
                        .map_or(String::new(), |d| format!("; ΔBIC {d:+.1}"))
                );
                acc
            });
        if l.steps.is_empty() {
            let _ = writeln!(
                out,
                "- **{}**: nothing added ({}).{rival}{ramp}",
                a.channel,
                errors(&l.final_figures)
            );
            continue;
        }
        let _ = writeln!(out, "- **{}**:{rival}{ramp}", a.channel);
        let effects: Vec<&Effect> = l.steps.iter().map(|s| &s.effect).collect();
        let lines = effect_lines(&effects, &units);
        for (i, (s, line)) in l.steps.iter().zip(&lines).enumerate() {
            let _ = writeln!(
                out,
                "  {}. {} — ΔBIC {:.1}. Evidence: {}. Before: {}. After: {}.",
                i + 1,
                line,
                s.delta_bic,
                s.evidence,
                errors(&s.before),
                errors(&s.after)
            );
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::effects::time::{Coupling, Spikes};
    use crate::model::Domain;

    fn units(value: Unit) -> EffectUnits {
        EffectUnits {
            value: Some(value),
            others: vec![("temperature".into(), Some(Unit::DegC))],
        }
    }

    /// A frequency interval gets the decimals that tell its ends apart, four at least.
    #[test]
    fn frequency_intervals_show_their_width() {
        assert_eq!(
            hz_interval(12.500002, 12.499987, 12.500016),
            "12.500002 Hz [12.499987, 12.500016]"
        );
        assert_eq!(hz_interval(8.91, 8.9, 8.92), "8.9100 Hz [8.9000, 8.9200]");
        assert_eq!(hz_interval(5.0, 5.0, 5.0), "5.0000 Hz [5.0000, 5.0000]");
        assert_eq!(
            hz_interval(5.0, 5.0 - 1e-12, 5.0 + 1e-12),
            "5.000000000 Hz [5.000000000, 5.000000000]"
        );
    }

    fn resonance(f0_hz: f64, q: f64) -> Effect {
        Effect::Resonance {
            f0_hz,
            f0_lo: f0_hz * 0.999,
            f0_hi: f0_hz * 1.001,
            q,
            q_lo: q * 0.9,
            q_hi: q * 1.1,
            form: ResonanceForm::LowPass,
            sigma: crate::model::EffectEstimate {
                value: 1e-3,
                lo: 9e-4,
                hi: 1.1e-3,
                edf: 50.0,
            },
        }
    }

    /// A 49.3-Hz fan line with its harmonics, one of them read as a resonance, beside a
    /// structural resonance at 520 Hz: the harmonics say so, the structure does not.
    #[test]
    fn harmonics_name_their_fundamental() {
        let effects = [
            resonance(98.9, 30.0),
            resonance(49.3, 20.0),
            resonance(150.4, 26.0),
            resonance(520.0, 20.0),
            resonance(71.0, 20.0),
        ];
        let refs: Vec<&Effect> = effects.iter().collect();
        let notes = harmonic_notes(&refs);
        assert_eq!(
            notes[0].as_deref(),
            Some(" (2× the one at 49.30 Hz: a harmonic?)")
        );
        assert_eq!(notes[1], None);
        assert_eq!(
            notes[2].as_deref(),
            Some(" (3× the one at 49.30 Hz: a harmonic?)")
        );
        assert_eq!(
            notes[3], None,
            "520 Hz is not the 10th or 7th multiple within its width"
        );
        assert_eq!(notes[4], None);
        let lines = effect_lines(&refs, &units(Unit::RadPerS));
        assert!(lines[2].ends_with("a harmonic?)") && lines[2].starts_with("resonance at"));
    }

    #[test]
    fn a_coupling_carries_its_unit_in_both_systems() {
        let fit = Coupling {
            coefficient: 9.80665e-4,
            lo: 8.0e-4,
            hi: 1.1e-3,
            z: 5.0,
            p_value: 1e-6,
            delta_bic: -20.0,
            explained_share: 0.2,
            scale_s: 1.0,
            n_eff: 100,
            aux_span: 2.0,
            explains_drift: None,
        };
        let e = Effect::Coupling {
            aux: "temperature".into(),
            fit,
        };
        let accel = effect_line(&e, &units(Unit::MPerS2));
        assert!(
            accel.starts_with("coupling to temperature: 9.807e-4 [8.000e-4, 0.001100] (m/s²)/K (")
                && accel.contains("0.1000 [")
                && accel.contains("] mg/°C); 0.001961 m/s² (0.2000 mg) across the 2.000 ")
                && accel.ends_with(" that temperature spans (1-s means), 20.0 % of the variance"),
            "{accel}"
        );
        assert!(!accel.contains("per unit"), "{accel}");
        let gyro = effect_line(&e, &units(Unit::RadPerS));
        assert!(
            gyro.contains("(rad/s)/K (") && gyro.contains("(°/h)/°C)"),
            "{gyro}"
        );
        // An aux channel without a unit: per unit of that channel, named.
        let plain = effect_line(
            &e,
            &EffectUnits {
                value: Some(Unit::RadPerS),
                others: vec![("temperature".into(), None)],
            },
        );
        assert!(plain.contains("rad/s per unit of temperature"), "{plain}");
    }

    #[test]
    fn counts_in_effect_lines_agree_with_their_noun() {
        let spikes = |n: usize| {
            Effect::Spikes(Spikes {
                indices: (0..n).collect(),
                times_s: (0..n).map(|i| i as f64).collect(),
                excess: vec![1.0; n],
                threshold_sigma: 5.0,
                sigma: 1.0,
                variance_share: 0.01,
                delta_bic: -10.0,
                tail: Default::default(),
                removal: vec![1.0; n],
            })
        };
        let u = units(Unit::RadPerS);
        assert!(effect_line(&spikes(1), &u).starts_with("1 spike (first"));
        assert!(effect_line(&spikes(3), &u).starts_with("3 spikes (first"));
    }

    /// A ramp decision reads in °/h per hour (SI rad/s² in report.json), with the deciding test
    /// and, where R is in the model, the estimate its interval covers.
    #[test]
    fn a_ramp_decision_reads_in_degrees_per_hour_squared() {
        use crate::effects::ramp::RampTest;
        let per_h2 = std::f64::consts::PI / 180.0 / 3600.0 / 3600.0;
        let test = |r: f64, se: f64| RampTest {
            ramp: r * per_h2,
            se: se * per_h2,
            t: r / se,
            dof: 511.0,
            p: 8.1e-6,
        };
        let d = RampDecision {
            series: TestedSeries::Corrected,
            action: RampAction::Added,
            test: test(200.0, 45.0),
            estimate: Some(test(210.0, 40.0)),
        };
        let line = ramp_sentence(&d, Sensor::Gyro);
        assert!(line.starts_with(" Rate ramp added"), "{line}");
        assert!(
            line.contains("in the corrected series R = 200.0 ± 45.00 °/h² under the model without it (t = 4.4, p = 8.1e-6); under the model with R, 210.0 ± 40.00."),
            "{line}"
        );
        let dropped = RampDecision {
            action: RampAction::Dropped,
            series: TestedSeries::Recorded,
            estimate: None,
            ..d
        };
        let line = ramp_sentence(&dropped, Sensor::Gyro);
        assert!(line.contains("dropped") && line.contains("in the recorded series"));
        assert!(ramp_sentence(&dropped, Sensor::Accel).starts_with(" Acceleration ramp dropped"));
        // Not added: the reason follows from what was determined.
        let aux = RampDecision {
            action: RampAction::NotAdded,
            estimate: None,
            ..d
        };
        assert!(
            ramp_sentence(&aux, Sensor::Gyro).contains("not added")
                && ramp_sentence(&aux, Sensor::Gyro).contains("aux channel")
        );
        let weak = RampDecision {
            test: RampTest { p: 4e-3, ..d.test },
            ..aux
        };
        assert!(ramp_sentence(&weak, Sensor::Gyro).contains("upper end of K's interval"));
        assert!(!line.contains("under the model with R"), "{line}");
    }

    #[test]
    fn warnings_name_the_unit_of_their_numbers() {
        let w = FitWarning::ContradictsReadOff {
            term: Term::RandomWalk,
            // 0.15 °/√h and 0.12 °/√h.
            fitted: 0.15 * std::f64::consts::PI / 180.0 / 60.0,
            read_off: 0.12 * std::f64::consts::PI / 180.0 / 60.0,
            tau_s: 1.0,
        };
        assert_eq!(
            warning_line(&w, Sensor::Gyro),
            "fitted N = 0.1500 °/√h lies above what the Allan deviation allows at τ = 1.000 s \
             (read-off 0.1200 °/√h)"
        );
        let w = FitWarning::LackOfFit {
            domain: Domain::Allan,
            chi2_per_dof: 3.2,
            p_value: 1e-5,
            inflation: 1.79,
            from: 0.01,
            to: 163.84,
        };
        assert!(
            warning_line(&w, Sensor::Gyro).contains("worst at τ = 0.01–163.8 s;"),
            "{}",
            warning_line(&w, Sensor::Gyro)
        );
        // N in °/√h, the step in rad/s, the angle reading's Q in arcsec (1 arcsec = 4.848e-6 rad).
        let deg_sqrt_h = std::f64::consts::PI / 180.0 / 60.0;
        let w = FitWarning::OutputResolution {
            step: 4.363e-4,
            steps_per_sigma: 0.96,
            rounding_n: 0.0433 * deg_sqrt_h,
            share: 0.077,
            n_without: 0.1498 * deg_sqrt_h,
            n_lo: 0.1495 * deg_sqrt_h,
            n_hi: Some(0.1502 * deg_sqrt_h),
            angle_q: Some(2.0 * 4.848_137e-6),
        };
        let line = warning_line(&w, Sensor::Gyro);
        assert!(
            line.contains("grid of 4.3630e-4 rad/s")
                && line.contains("0.04330 °/√h to N, 7.7 % of N²")
                && line.contains("0.1498 [0.1495, 0.1502] °/√h")
                && line.contains("Q = 2.000 arcsec"),
            "{line}"
        );
    }
}
