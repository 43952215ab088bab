//! The plots of one channel: the Allan deviation with its confidence band, the fitted terms and
//! the model, and the spectrum with its fit; each with a residual panel (normalised residuals z of
//! the fit, before and after the residual loop).

use crate::analysis::ChannelAnalysis;
use crate::avar::Deviations;
use crate::effects::shapes::{GaussMarkov1, Resonance};
use crate::effects::Effect;
use crate::estimate::ChannelPsd;
use crate::model::{EffectShape, NoiseFit};
use crate::psd::Psd;

use crate::units::Unit;

use super::format::{engineering_unit, sig4};
use super::model::units_of;
use super::plot::{Color, Corner, Figure, Panel, Series, Style, PALETTE};

const GRAY: Color = Color::GRAY;

/// An amplitude of the channel (SI `unit`) for a legend, in the engineering unit where there is one
/// (°/h, mg), else in `unit`: `0.2070 mg`.
fn amount(v: f64, unit: Option<Unit>) -> String {
    match unit {
        Some(u) => {
            let shown = engineering_unit(u).unwrap_or(u);
            format!("{} {}", sig4(v / shown.to_si().0), shown.pretty())
        }
        None => sig4(v),
    }
}

/// A fitted IEEE coefficient for a legend, in its datasheet unit: `N = 0.1502 °/√h`.
/// A term's legend entry: the value of the figure's own fit (`fit`: "Allan fit", "spectrum
/// fit"), which may differ from the combined value summary.md gives first (a B the spectrum fit
/// kept and the combination ruled out was drawn as "B = 51 µg" beside a summary's "≤ 4.8 µg").
fn coefficient(a: &ChannelAnalysis, term: crate::model::Term, value: f64, fit: &str) -> String {
    let [_, u, _] = units_of(a.sensor, term);
    format!(
        "{} = {} {} ({fit})",
        term.symbol(),
        sig4(u.from_si(value)),
        u.pretty()
    )
}

/// The stochastic effect of the final model, as a shape with its fitted amplitude.
fn stochastic(
    a: &ChannelAnalysis,
    fs: f64,
    unit: Option<Unit>,
) -> Option<(Box<dyn EffectShape>, f64, String)> {
    let steps = &a.residual_loop.as_ref()?.steps;
    steps.iter().find_map(|s| match &s.effect {
        Effect::GaussMarkov { tc_s, sigma, .. } => Some((
            Box::new(GaussMarkov1 { tc_s: *tc_s }) as Box<dyn EffectShape>,
            sigma.value,
            format!(
                "Gauss–Markov Tc = {} s, σ = {}",
                sig4(*tc_s),
                amount(sigma.value, unit)
            ),
        )),
        Effect::Resonance {
            f0_hz,
            q,
            form,
            sigma,
            ..
        } => Some((
            Box::new(Resonance::with_form(*f0_hz, *q, *form, fs)) as Box<dyn EffectShape>,
            sigma.value,
            format!(
                "resonance {f0_hz:.3} Hz, Q = {q:.1}, σ = {}",
                amount(sigma.value, unit)
            ),
        )),
        _ => None,
    })
}

fn log_grid(lo: f64, hi: f64, n: usize) -> Vec<f64> {
    (0..n)
        .map(|k| lo * (hi / lo).powf(k as f64 / (n - 1).max(1) as f64))
        .collect()
}

fn residual_panel(x_label: &str, fit: Option<&NoiseFit>, base: Option<&NoiseFit>) -> Panel {
    let mut p = Panel::semilogx(x_label, "z");
    p.height = 0.35;
    p.legend_at = Corner::Auto;
    for (v, dash) in [(0.0, false), (2.0, true), (-2.0, true)] {
        let s = if dash {
            Style::dashed(GRAY).with_width(1.0)
        } else {
            Style::line(GRAY).with_width(1.0)
        };
        p.hlines.push((v, s));
    }
    let changed = base.is_some() && base != fit;
    if let (true, Some(b)) = (changed, base) {
        p.series.push(Series::Points {
            label: Some("before the loop".into()),
            x: b.points.iter().map(|q| q.x).collect(),
            y: b.points.iter().map(|q| q.z).collect(),
            lo: None,
            hi: None,
            style: Style::points(GRAY),
        });
    }
    if let Some(f) = fit {
        p.series.push(Series::Points {
            label: Some(if changed { "after" } else { "residual" }.into()),
            x: f.points.iter().map(|q| q.x).collect(),
            y: f.points.iter().map(|q| q.z).collect(),
            lo: None,
            hi: None,
            style: Style::points(PALETTE[0]),
        });
    }
    p
}

/// The Allan-deviation figure of one channel.
/// `unit`: the SI unit of the channel's values (`None`: a channel without one, shown as "raw").
pub fn avar_figure(a: &ChannelAnalysis, original: &Deviations, unit: Option<Unit>) -> Figure {
    let fs = original.rate_hz;
    let label = unit.map_or("raw", Unit::pretty);
    let corrected = a
        .residual_loop
        .as_ref()
        .and_then(|l| l.corrected.as_ref())
        .map(|c| &c.0);
    let shown = corrected.unwrap_or(original);
    let mut main = Panel::loglog("τ (s)", &format!("Allan deviation ({label})"));
    main.legend_at = Corner::Auto;
    main.series.push(Series::Band {
        label: Some(format!("{:.0} % interval", 100.0 * shown.confidence)),
        x: shown.tau_s.clone(),
        lo: shown.variance_lo.iter().map(|v| v.sqrt()).collect(),
        hi: shown.variance_hi.iter().map(|v| v.sqrt()).collect(),
        style: Style::band(PALETTE[0]),
    });
    if corrected.is_some() {
        main.series.push(Series::Points {
            label: Some("measured, before corrections".into()),
            x: original.tau_s.clone(),
            y: original.deviation(),
            lo: None,
            hi: None,
            style: Style::points(GRAY),
        });
    }
    main.series.push(Series::Points {
        label: Some(
            if corrected.is_some() {
                "corrected (OADEV)"
            } else {
                "OADEV"
            }
            .into(),
        ),
        x: shown.tau_s.clone(),
        y: shown.deviation(),
        lo: None,
        hi: None,
        style: Style::points(PALETTE[0]),
    });
    let (Some(&t0), Some(&t1)) = (shown.tau_s.first(), shown.tau_s.last()) else {
        return figure(
            a,
            "Allan deviation",
            main,
            residual_panel("τ (s)", None, None),
        );
    };
    let taus = log_grid(t0, t1, 200);
    let fit = a.allan_fit();
    if let Some(fit) = fit {
        for (k, e) in fit.estimates.iter().enumerate() {
            main.series.push(Series::line(
                &coefficient(a, e.term, e.value, "Allan fit"),
                taus.clone(),
                taus.iter()
                    .map(|&t| e.value * e.term.avar_unit(t).sqrt())
                    .collect(),
                Style::dashed(PALETTE[(k + 1) % PALETTE.len()]),
            ));
        }
        let effect = stochastic(a, fs, unit);
        if let Some((shape, amp, label)) = &effect {
            main.series.push(Series::line(
                label,
                taus.clone(),
                taus.iter()
                    .map(|&t| amp * shape.avar_unit(t, fs).sqrt())
                    .collect(),
                Style::dashed(PALETTE[5]),
            ));
        }
        main.series.push(Series::line(
            "model",
            taus.clone(),
            taus.iter()
                .map(|&t| {
                    let base: f64 = fit
                        .estimates
                        .iter()
                        .map(|e| e.value * e.value * e.term.avar_unit(t))
                        .sum();
                    let eff = effect
                        .as_ref()
                        .map_or(0.0, |(s, amp, _)| amp * amp * s.avar_unit(t, fs));
                    (base + eff).sqrt()
                })
                .collect(),
            Style::line(Color(0, 0, 0)).with_width(2.0),
        ));
    }
    let base = a.residual_loop.as_ref().and_then(|l| l.base_allan.as_ref());
    figure(
        a,
        "Allan deviation",
        main,
        residual_panel("τ (s)", fit, base),
    )
}

/// The spectrum figure of one channel (one-sided density).
///
/// `unit`: the SI unit of the channel's values (`None`: a channel without one, shown as "raw").
pub fn psd_figure(a: &ChannelAnalysis, original: &ChannelPsd, unit: Option<Unit>) -> Figure {
    let label = unit.map_or("raw", Unit::pretty);
    let corrected = a
        .residual_loop
        .as_ref()
        .and_then(|l| l.corrected.as_ref())
        .map(|c| &c.1);
    let psd = corrected.unwrap_or(&original.psd);
    let fs = psd.rate_hz;
    let mut main = Panel::loglog("f (Hz)", &format!("PSD, one-sided (({label})²/Hz)"));
    main.legend_at = Corner::Auto;
    let trace = |p: &Psd| -> (Vec<f64>, Vec<f64>) {
        p.freq_hz
            .iter()
            .zip(&p.value)
            .skip(1)
            .map(|(f, v)| (*f, *v))
            .unzip()
    };
    // The recorded spectrum is always drawn: where the loop corrected the series, the corrected
    // one alone had the lines it removed (the largest thing in a vibration record) missing from
    // a trace labelled as the measurement.
    if corrected.is_some() {
        let (x, y) = trace(&original.psd);
        main.series.push(Series::line(
            "Welch, recorded",
            x,
            y,
            Style::line(Color(215, 215, 215)).with_width(1.0),
        ));
    }
    let (x, y) = trace(psd);
    main.series.push(Series::line(
        if corrected.is_some() {
            "Welch, the loop's lines and slow effects taken out"
        } else {
            "Welch"
        },
        x,
        y,
        Style::line(Color(150, 150, 150)).with_width(1.0),
    ));
    let fit = a.spectrum_fit();
    if let Some(fit) = fit {
        main.series.push(Series::Points {
            label: Some("log-binned (fitted)".into()),
            x: fit.points.iter().map(|p| p.x).collect(),
            y: fit.points.iter().map(|p| 2.0 * p.value).collect(),
            lo: None,
            hi: None,
            style: Style::points(PALETTE[0]),
        });
        let f_lo = psd.freq_hz.get(1).copied().unwrap_or(1e-3);
        let freqs = log_grid(f_lo, fs / 2.0, 300);
        for (k, e) in fit.estimates.iter().enumerate() {
            main.series.push(Series::line(
                &coefficient(a, e.term, e.value, "spectrum fit"),
                freqs.clone(),
                freqs
                    .iter()
                    .map(|&f| 2.0 * e.value * e.value * e.term.psd_sampled_unit(f, fs))
                    .collect(),
                Style::dashed(PALETTE[(k + 1) % PALETTE.len()]),
            ));
        }
        let effect = stochastic(a, fs, unit);
        main.series.push(Series::line(
            "model",
            freqs.clone(),
            freqs
                .iter()
                .map(|&f| {
                    let base: f64 = fit
                        .estimates
                        .iter()
                        .map(|e| e.value * e.value * e.term.psd_sampled_unit(f, fs))
                        .sum();
                    let eff = effect
                        .as_ref()
                        .map_or(0.0, |(s, amp, _)| amp * amp * s.psd_unit(f, fs));
                    2.0 * (base + eff)
                })
                .collect(),
            Style::line(Color(0, 0, 0)).with_width(2.0),
        ));
    }
    for s in a.residual_loop.iter().flat_map(|l| &l.steps) {
        let (f, label) = match &s.effect {
            Effect::Sinusoid(sine) => (
                sine.freq_hz,
                format!(
                    "line {:.3} Hz, {} (removed)",
                    sine.freq_hz,
                    amount(sine.amplitude, unit)
                ),
            ),
            Effect::Resonance { f0_hz, .. } => (*f0_hz, format!("resonance {f0_hz:.3} Hz")),
            _ => continue,
        };
        main.series.push(Series::VLine {
            label: Some(label),
            x: f,
            style: Style::dashed(PALETTE[1]),
        });
    }
    let base = a
        .residual_loop
        .as_ref()
        .and_then(|l| l.base_spectrum.as_ref());
    figure(a, "Spectrum", main, residual_panel("f (Hz)", fit, base))
}

fn figure(a: &ChannelAnalysis, what: &str, main: Panel, residual: Panel) -> Figure {
    let mut f = Figure::new(&format!("{} — {what}", a.channel), 900, 700);
    f.panels = vec![main, residual];
    f
}
