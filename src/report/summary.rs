//! `summary.md`: what an engineer reads first. Per recording, the quality screen, then tables in
//! the style of Paszek & Kaniewski (2014, Tables 3–5): each noise term per axis, estimated from the
//! spectrum and from the Allan variance, in both unit systems (°/√h and (°/s)/√Hz, °/h and °/s, …),
//! with intervals, the PSD/AV ratio and whether the intervals overlap; then the fit quality.

use std::fmt::Write;

use crate::analysis::ChannelAnalysis;
use crate::effects::slow::DriftShape;
use crate::effects::{Effect, ErrorFigures};
use crate::model::{NoiseFit, Sensor, Term, TermEstimate};
use crate::pipeline::FileResult;

use super::model::units_of;

/// Four significant digits, plain or scientific as fits the magnitude.
pub fn sig4(v: f64) -> String {
    if !v.is_finite() {
        return "–".into();
    }
    if v == 0.0 {
        return "0".into();
    }
    let e = v.abs().log10().floor();
    if (-3.0..5.0).contains(&e) {
        let decimals = (3.0 - e).max(0.0) as usize;
        format!("{v:.decimals$}")
    } else {
        format!("{v:.3e}")
    }
}

fn cell(e: Option<&TermEstimate>, unit: crate::model::CoefUnit) -> String {
    match e {
        Some(e) => format!(
            "{} [{}, {}]",
            sig4(unit.from_si(e.value)),
            sig4(unit.from_si(e.lo)),
            sig4(unit.from_si(e.hi))
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
        "{} samples per channel at {} Hz ({:.1} min), {} channels; backend: {}.",
        q.samples_out,
        r.recording.rate_hz,
        q.duration_s / 60.0,
        r.recording.channels.len(),
        r.backend
    );
    let mut notes = Vec::new();
    if q.gap_count > 0 {
        notes.push(format!(
            "{} gaps, {} samples missing (policy {})",
            q.gap_count, q.missing_samples, q.gap_policy
        ));
    }
    for c in &q.channels {
        if c.nonfinite_samples > 0 {
            notes.push(format!(
                "{}: {} non-finite samples (policy {})",
                c.name, c.nonfinite_samples, q.nonfinite_policy
            ));
        }
        if c.summary.possibly_saturated {
            notes.push(format!("{}: possibly saturated", c.name));
        }
    }
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
        "\nIntervals are {} two-sided; a term is listed as not significant when the information \
         criterion did not admit it (its upper limit is in report.json).",
        confidence_text(analysis)
    );
    combined_section(out, analysis);
    let _ = writeln!(
        out,
        "\n### Evidence: the two fits\n\nEach term as the spectrum (PSD) and the Allan variance (AV) \
         fits give it; the combined values above come from these."
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
    loop_section(out, analysis);
    for a in analysis {
        for (what, r) in [("AV", &a.allan), ("PSD", &a.spectrum)] {
            if let Some(reason) = failure(r) {
                let _ = writeln!(out, "\n- {} {what} fit failed: {reason}", a.channel);
            }
        }
    }
}

/// The combined coefficients first (one answer per term, both display units), the IEEE read-offs
/// beside them, the sensor bandwidth and every warning.
fn combined_section(out: &mut String, analysis: &[ChannelAnalysis]) {
    let _ = writeln!(
        out,
        "\n### Coefficients (combined)\n\nOne value per term: the more precise of the two fits, or \
         the one whose model has the term's neighbours (Q–N–B–K–R) when only one does; the interval \
         spans both fits where they disagree. Read-offs: N = σ(1 s), B = min σ/0.664, K = σ(3 s) \
         from the Allan deviation (the slope there says whether the term rules it).\n"
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
                "| {} | {} | {} {} | [{}, {}]{} | {source}{ambiguous} | {} | {} |",
                a.channel,
                t.term.symbol(),
                sig4(u1.from_si(t.value)),
                u1.pretty(),
                sig4(u1.from_si(t.lo)),
                sig4(u1.from_si(t.hi)),
                if t.hull { " (both fits)" } else { "" },
                read.map_or("–".into(), |r| format!(
                    "{} at τ = {} s",
                    sig4(u1.from_si(r.value)),
                    sig4(r.tau_s)
                )),
                read.filter(|r| r.slope.is_finite())
                    .map_or("–".into(), |r| format!("{:+.2}", r.slope)),
            );
        }
    }
    let mut notes = Vec::new();
    for a in analysis {
        if let Some(b) = &a.bandwidth {
            notes.push(format!(
                "{}: sensor low-pass detected ({} form, corner {} Hz, order {}, {} dB/decade, ΔBIC {:.0}); \
                 fits use the spectrum up to {} Hz and the Allan variance from τ = {} s",
                a.channel,
                match b.lowpass.form {
                    crate::model::FilterForm::Analog => "analog",
                    crate::model::FilterForm::Digital { .. } => "digital",
                },
                sig4(b.lowpass.corner_hz),
                b.lowpass.order,
                b.slope_db_per_decade,
                b.delta_bic,
                sig4(b.fit_max_freq_hz),
                b.fit_min_tau_s.map_or("–".into(), sig4),
            ));
        }
        for w in &a.combined.warnings {
            notes.push(format!("**warning** {}: {}", a.channel, w.describe()));
        }
    }
    if !notes.is_empty() {
        let _ = writeln!(out);
        for n in notes {
            let _ = writeln!(out, "- {n}");
        }
    }
}

fn confidence_text(analysis: &[ChannelAnalysis]) -> String {
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
        "imunoise {}; {} file(s) analysed, {} failed, in {:.2} s. Coefficients are fitted by \
         weighted non-negative least squares to the overlapping Allan variance (AV) and, \
         separately, to the log-binned Welch spectrum (PSD); values in SI are in report.json and \
         coefficients.csv.",
        env!("CARGO_PKG_VERSION"),
        ok.len(),
        failed.len(),
        elapsed_s
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

/// One line per effect found: what, its parameters, the evidence, the error before and after.
pub fn effect_line(e: &Effect) -> String {
    match e {
        Effect::Sinusoid(s) => format!(
            "line at {:.4} Hz [{:.4}, {:.4}], amplitude {} [{}, {}]",
            s.freq_hz,
            s.freq_lo,
            s.freq_hi,
            sig4(s.amplitude),
            sig4(s.amplitude_lo),
            sig4(s.amplitude_hi)
        ),
        Effect::Narrowband(nb) => format!(
            "wandering line at {:.4} Hz, width {} Hz, rms {} [{}, {}] (power {}; a coherent sinusoid explains {:.0} %)",
            nb.freq_hz,
            sig4(nb.width_hz),
            sig4(nb.power.sqrt()),
            sig4(nb.power_lo.sqrt()),
            sig4(nb.power_hi.sqrt()),
            sig4(nb.power),
            100.0 * nb.coherent_share
        ),
        Effect::Resonance {
            f0_hz,
            f0_lo,
            f0_hi,
            q,
            q_lo,
            q_hi,
            sigma,
        } => format!(
            "resonance at {f0_hz:.3} Hz [{f0_lo:.3}, {f0_hi:.3}], Q {q:.1} [{q_lo:.1}, {q_hi:.1}], σ {} [{}, {}]",
            sig4(sigma.value),
            sig4(sigma.lo),
            sig4(sigma.hi)
        ),
        Effect::GaussMarkov { tc_s, sigma } => format!(
            "Gauss–Markov process, Tc {} s, σ {} [{}, {}]",
            sig4(*tc_s),
            sig4(sigma.value),
            sig4(sigma.lo),
            sig4(sigma.hi)
        ),
        Effect::Coupling { aux, fit } => format!(
            "coupling to {aux}: {} [{}, {}] per unit, {:.1} % of the variance",
            sig4(fit.coefficient),
            sig4(fit.lo),
            sig4(fit.hi),
            100.0 * fit.explained_share
        ),
        Effect::Drift(d) => {
            let what = match (d.shape, d.tc_interval_s) {
                (DriftShape::Exponential { tc_s }, Some((lo, hi))) => format!(
                    "settling drift exp(−t/τ), τ {} s [{}, {}], amplitude",
                    sig4(tc_s),
                    sig4(lo),
                    sig4(hi)
                ),
                (DriftShape::Exponential { tc_s }, None) => {
                    format!("settling drift exp(−t/τ), τ {} s, amplitude", sig4(tc_s))
                }
                (DriftShape::Quadratic, _) => "quadratic drift (t − T/2)², per s²".to_string(),
            };
            format!(
                "{what} {} [{}, {}], {:.1} % of the variance",
                sig4(d.amplitude),
                sig4(d.lo),
                sig4(d.hi),
                100.0 * d.explained_share
            )
        }
        Effect::Spikes(s) => format!(
            "{} spikes (first at {:.2} s), {:.2} % of the variance",
            s.indices.len(),
            s.times_s.first().copied().unwrap_or(f64::NAN),
            100.0 * s.variance_share
        ),
        Effect::Step(s) => format!(
            "bias step at {:.1} s of {} [{}, {}]",
            s.time_s,
            sig4(s.size),
            sig4(s.lo),
            sig4(s.hi)
        ),
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

fn loop_section(out: &mut String, analysis: &[ChannelAnalysis]) {
    let _ = writeln!(out, "\n### Residual loop: effects the IEEE model lacks\n");
    for a in analysis {
        let Some(l) = &a.residual_loop else { continue };
        if l.steps.is_empty() {
            let _ = writeln!(
                out,
                "- **{}**: nothing added ({}).",
                a.channel,
                errors(&l.final_figures)
            );
            continue;
        }
        let _ = writeln!(out, "- **{}**:", a.channel);
        for (i, s) in l.steps.iter().enumerate() {
            let _ = writeln!(
                out,
                "  {}. {} — ΔBIC {:.1}. Evidence: {}. Before: {}. After: {}.",
                i + 1,
                effect_line(&s.effect),
                s.delta_bic,
                s.evidence,
                errors(&s.before),
                errors(&s.after)
            );
        }
    }
}
