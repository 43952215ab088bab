//! `fleet.html`: one self-contained page (inline SVG, inline CSS, no script, no external asset)
//! that shows, per sensor kind and term, every channel's coefficient across the fleet against the
//! limit and the fleet median, outliers and failures marked; then the flagged channels with their
//! reasons. The figures are drawn by the report's own plotting ([`crate::report::plot`]), so they
//! look like the per-file plots.

use std::fmt::Write;

use crate::model::Term;
use crate::report::plot::{Color, Figure, Marker, Panel, Series, Style, PALETTE};

use super::assess::{display_unit, show, FleetRow, TermStats};
use super::layout::FleetStepSummary;
use super::record::Status;
use super::table::sensor_name;
use super::verdict::Verdict;

fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

const RED: Color = Color(213, 94, 0);

/// The strip plot of one term: x is the sensor's position in the fleet (axes of one sensor side
/// by side), y the coefficient in the display unit, with its interval.
fn figure(
    rows: &[&FleetRow],
    order: &[&str],
    st: &TermStats,
    summary: &FleetStepSummary,
    index: usize,
) -> String {
    let spec = &summary.fleet.spec;
    let unit = display_unit(spec, st.sensor, st.term);
    let position = |r: &FleetRow| {
        let s = order.iter().position(|k| *k == r.record.key).unwrap_or(0);
        let axes: Vec<&&FleetRow> = rows
            .iter()
            .filter(|o| o.record.key == r.record.key)
            .collect();
        let k = axes
            .iter()
            .position(|o| o.record.channel_index == r.record.channel_index)
            .unwrap_or(0);
        let spread = 0.5 / axes.len().max(1) as f64;
        (s + 1) as f64 + (k as f64 - (axes.len() as f64 - 1.0) / 2.0) * spread
    };
    type Pts = (Vec<f64>, Vec<f64>, Vec<f64>, Vec<f64>);
    let mut normal: Pts = Default::default();
    let mut marked: Pts = Default::default();
    let mut failed: Pts = Default::default();
    let mut upper: (Vec<f64>, Vec<f64>) = Default::default();
    for r in rows {
        let v = r.record.term(st.term);
        let a = &r.terms[st.term.index()];
        let x = position(r);
        match v.value {
            Some(value) => {
                let target = if a.verdict == Some(Verdict::Fail) {
                    &mut failed
                } else if a.outlier {
                    &mut marked
                } else {
                    &mut normal
                };
                target.0.push(x);
                target.1.push(unit.from_si(value));
                target.2.push(unit.from_si(v.lo.unwrap_or(value)));
                target.3.push(unit.from_si(v.hi.unwrap_or(value)));
            }
            None => {
                if let Some(u) = v.upper {
                    upper.0.push(x);
                    upper.1.push(unit.from_si(u));
                }
            }
        }
    }
    let name = st.term.name(st.sensor == crate::model::Sensor::Gyro);
    let mut panel = Panel::semilogy(
        "sensor (position in the table below)",
        &format!(
            "{} {} [{}]",
            sensor_name(st.sensor),
            st.term.symbol(),
            unit.pretty()
        ),
    );
    let pts = |label: &str, p: Pts, style: Style| Series::Points {
        label: Some(label.to_string()),
        x: p.0,
        y: p.1,
        lo: Some(p.2),
        hi: Some(p.3),
        style,
    };
    if !normal.0.is_empty() {
        panel
            .series
            .push(pts("channel", normal, Style::points(PALETTE[0])));
    }
    if !marked.0.is_empty() {
        panel.series.push(pts(
            "outlier",
            marked,
            Style::points(RED)
                .with_marker(Marker::Cross)
                .with_width(2.0),
        ));
    }
    if !failed.0.is_empty() {
        panel.series.push(pts(
            "fails the limit",
            failed,
            Style::points(RED)
                .with_marker(Marker::Square)
                .with_width(2.0),
        ));
    }
    if !upper.0.is_empty() {
        panel.series.push(Series::Points {
            label: Some("upper limit (not estimated)".into()),
            x: upper.0,
            y: upper.1,
            lo: None,
            hi: None,
            style: Style::points(Color::GRAY).with_marker(Marker::Cross),
        });
    }
    let limit = spec.limit(st.sensor, st.term);
    if let Some(l) = limit {
        panel
            .hlines
            .push((unit.from_si(l.si), Style::dashed(RED).with_width(1.5)));
    }
    if let Some(sc) = st.scale {
        panel
            .hlines
            .push((unit.from_si(sc.median.exp()), Style::dashed(Color::GRAY)));
    }
    panel.x_range = Some((0.0, order.len() as f64 + 1.0));
    panel.legend_at = crate::report::plot::Corner::Auto;
    let mut fig = Figure::new(&format!("{} — {name}", sensor_name(st.sensor)), 900, 380);
    fig.panels.push(panel);
    let svg = fig
        .to_svg()
        .replace("imn-clip-", &format!("imn-f{index}-clip-"));
    let mut caption = String::new();
    if let Some(l) = limit {
        let _ = write!(
            caption,
            "Dashed red: the limit, {}. ",
            show(spec, st.sensor, st.term, l.si)
        );
    }
    if let Some(sc) = st.scale {
        let _ = write!(
            caption,
            "Dashed grey: the fleet median, {} (robust σ of ln = {:.3}, {} channels). ",
            show(spec, st.sensor, st.term, sc.median.exp()),
            sc.scale,
            st.count
        );
    } else {
        let _ = write!(
            caption,
            "{} channels with a determined value: too few for the outlier test. ",
            st.count
        );
    }
    format!(
        "<figure>{svg}<figcaption>{}</figcaption></figure>\n",
        esc(&caption)
    )
}

/// The page.
pub fn page(summary: &FleetStepSummary, title: &str) -> String {
    let fleet = &summary.fleet;
    let ok: Vec<&FleetRow> = fleet
        .rows
        .iter()
        .filter(|r| r.record.status == Status::Ok)
        .collect();
    let mut h = String::new();
    let _ = write!(
        h,
        "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">\
         <title>Fleet screen</title><style>\
         body{{font-family:DejaVu Sans,sans-serif;margin:2em;max-width:960px;color:#222}}\
         table{{border-collapse:collapse;margin:1em 0}}td,th{{border:1px solid #ccc;padding:3px 8px;\
         text-align:left;vertical-align:top}}.bad{{color:#d55e00}}figure{{margin:1em 0}}\
         figcaption{{font-size:90%;color:#555}}</style></head><body>\n\
         <h1>Fleet screen</h1><p>{}</p>\n",
        esc(title)
    );
    let flagged = ok.iter().filter(|r| r.flagged).count();
    let errors = fleet.rows.len() - ok.len();
    let _ = writeln!(
        h,
        "<p>{} files, {} channels; <span class=\"bad\">{flagged} flagged</span>; {errors} files \
         with errors; {} pending.</p>",
        summary.files,
        ok.len(),
        summary.pending.len()
    );
    // Every file's position on the x axes: its row in the table of sensors at the end.
    let mut order: Vec<&str> = ok.iter().map(|r| r.record.key.as_str()).collect();
    order.dedup();
    for (i, st) in fleet.stats.iter().enumerate() {
        let rows: Vec<&FleetRow> = ok
            .iter()
            .copied()
            .filter(|r| r.record.kind == Some(st.sensor))
            .collect();
        let _ = writeln!(
            h,
            "<h2>{} {} — {}</h2>",
            sensor_name(st.sensor),
            st.term.symbol(),
            esc(st.term.name(st.sensor == crate::model::Sensor::Gyro))
        );
        h.push_str(&figure(&rows, &order, st, summary, i));
    }
    let _ = writeln!(
        h,
        "<h2>Flagged channels</h2><table><tr><th>sensor</th><th>channel</th><th>why</th></tr>"
    );
    for r in ok.iter().filter(|r| r.flagged) {
        let _ = writeln!(
            h,
            "<tr><td>{}</td><td>{}</td><td>{}</td></tr>",
            esc(&r.record.sensor),
            esc(r.record.channel.as_deref().unwrap_or("")),
            r.reasons
                .iter()
                .map(|s| esc(s))
                .collect::<Vec<_>>()
                .join("<br>")
        );
    }
    let _ = writeln!(h, "</table>");
    if errors > 0 {
        let _ = writeln!(
            h,
            "<h2>Errors</h2><table><tr><th>path</th><th>error</th></tr>"
        );
        for r in fleet
            .rows
            .iter()
            .filter(|r| r.record.status == Status::Error)
        {
            let _ = writeln!(
                h,
                "<tr><td>{}</td><td>{}</td></tr>",
                esc(&r.record.path),
                esc(r.record.error.as_deref().unwrap_or(""))
            );
        }
        let _ = writeln!(h, "</table>");
    }
    // The x positions of the plots.
    let sensors: Vec<(&str, &str, bool)> = order
        .iter()
        .filter_map(|k| {
            let of = || ok.iter().filter(|r| r.record.key == *k);
            let first = of().next()?;
            Some((
                first.record.sensor.as_str(),
                first.record.path.as_str(),
                of().any(|r| r.flagged),
            ))
        })
        .collect();
    let _ = writeln!(
        h,
        "<h2>Sensors</h2><table><tr><th>#</th><th>sensor</th><th>path</th></tr>"
    );
    for (i, (s, p, bad)) in sensors.iter().enumerate() {
        let class = if *bad { " class=\"bad\"" } else { "" };
        let _ = writeln!(
            h,
            "<tr{class}><td>{}</td><td>{}</td><td>{}</td></tr>",
            i + 1,
            esc(s),
            esc(p)
        );
    }
    let _ = writeln!(h, "</table>");
    let _ = writeln!(
        h,
        "<p>Terms: {}.</p></body></html>",
        Term::ALL
            .iter()
            .map(|t| format!("{} {}", t.symbol(), t.name(true)))
            .collect::<Vec<_>>()
            .join(", ")
    );
    h
}
