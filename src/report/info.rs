//! `imunoise info` on a terminal: per recording, what it is (format, rows, duration, rate and where
//! the rate came from, time column, gaps) and a table of its channels (unit, kind, stored type,
//! statistics in SI, quantisation step, saturation, non-finite samples), then what the quality
//! screen says about each channel.

use std::fmt::Write;

use crate::io::RateSource;
use crate::pipeline::FileResult;

use super::format::{count, duration, rate_hz, sig, sig4};

/// Rows of cells as a plain-text table: columns padded to their widest cell, numbers right-aligned.
fn table(header: &[&str], rows: &[Vec<String>], numeric: &[bool]) -> String {
    let width = |s: &str| s.chars().count();
    let mut widths: Vec<usize> = header.iter().map(|h| width(h)).collect();
    for r in rows {
        for (w, c) in widths.iter_mut().zip(r) {
            *w = (*w).max(width(c));
        }
    }
    let mut out = String::new();
    let mut line = |cells: Vec<&str>| {
        let mut text = String::from("  ");
        for (i, c) in cells.iter().enumerate() {
            let pad = " ".repeat(widths[i] - width(c));
            if numeric.get(i).copied().unwrap_or(false) {
                text.push_str(&pad);
                text.push_str(c);
            } else {
                text.push_str(c);
                text.push_str(&pad);
            }
            text.push_str("  ");
        }
        let _ = writeln!(out, "{}", text.trim_end());
    };
    line(header.to_vec());
    for r in rows {
        line(r.iter().map(String::as_str).collect());
    }
    out
}

fn rate_source(r: &FileResult) -> String {
    let rec = &r.recording;
    let from_time = rec
        .rate_from_time_hz
        .filter(|_| rec.rate_source != RateSource::TimeColumn)
        .map_or(String::new(), |t| {
            format!("; the time column implies {}", rate_hz(t))
        });
    let source = match rec.rate_source {
        RateSource::Metadata => "schema metadata sample_rate_hz",
        RateSource::TimeColumn => "the time column's intervals",
        RateSource::Flag => "--rate",
    };
    format!("from {source}{from_time}")
}

/// The text `imunoise info` prints for one recording.
pub fn info_text(r: &FileResult) -> String {
    let rec = &r.recording;
    let q = &r.quality;
    let mut out = String::new();
    let _ = writeln!(out, "{}", rec.path.display());
    let mut facts: Vec<(&str, String)> = vec![
        ("format", rec.format.as_str().to_string()),
        (
            "rows",
            if q.samples_out == q.rows_read {
                count(q.rows_read, "row")
            } else {
                format!(
                    "{} ({} per channel after the quality policies)",
                    count(q.rows_read, "row"),
                    count(q.samples_out, "sample")
                )
            },
        ),
        ("duration", duration(q.duration_s)),
        (
            "rate",
            format!("{} ({})", rate_hz(rec.rate_hz), rate_source(r)),
        ),
    ];
    facts.push((
        "time",
        match &rec.time {
            Some(t) => {
                let jitter = q.time_jitter.map_or(String::new(), |j| {
                    if j.below_resolution() {
                        format!(
                            "; no jitter (every timestamp on its grid to the column's resolution, \
                             {} s)",
                            sig(j.resolution_s, 2)
                        )
                    } else {
                        format!(
                            "; jitter rms {} s, max {} s",
                            sig(j.rms_s, 3),
                            sig(j.max_s, 3)
                        )
                    }
                });
                format!("column {:?}{jitter}", t.name)
            }
            None => "no time column (no gap check)".into(),
        },
    ));
    if rec.time.is_some() {
        let ambiguous = if q.time_jitter.is_some_and(|j| j.gaps_ambiguous) {
            format!(
                " (ambiguous: the jitter reaches {} of a period)",
                crate::quality::JITTER_AMBIGUOUS_PERIODS
            )
        } else {
            String::new()
        };
        facts.push((
            "gaps",
            if q.gap_count == 0 {
                format!("none{ambiguous}")
            } else {
                format!(
                    "{}, {} missing (policy {}){ambiguous}",
                    count(q.gap_count, "gap"),
                    count(q.missing_samples, "sample"),
                    q.gap_policy
                )
            },
        ));
    }
    if q.dropped_rows > 0 {
        facts.push((
            "dropped",
            format!(
                "{} with non-finite samples (policy {})",
                count(q.dropped_rows, "row"),
                q.nonfinite_policy
            ),
        ));
    }
    if q.duplicate_rows > 0 {
        facts.push((
            "repeats",
            format!(
                "{} repeating the previous timestamp (policy {}: the first of each kept)",
                count(q.duplicate_rows, "row"),
                q.duplicate_policy
            ),
        ));
    }
    for n in &rec.notes {
        facts.push(("note", n.clone()));
    }
    for n in &r.backend_notes {
        facts.push(("note", n.clone()));
    }
    let key_width = facts.iter().map(|(k, _)| k.len()).max().unwrap_or(0);
    for (k, v) in &facts {
        let _ = writeln!(out, "  {k:<key_width$}  {v}");
    }
    let _ = writeln!(out);
    let header = [
        "channel",
        "unit",
        "SI unit",
        "kind",
        "stored",
        "min",
        "max",
        "mean",
        "std",
        "step",
        "non-finite",
        "saturated",
    ];
    let numeric = [
        false, false, false, false, false, true, true, true, true, true, true, false,
    ];
    let mut rows = Vec::new();
    let mut verdicts = Vec::new();
    for c in &rec.channels {
        let quality = q.channels.iter().find(|x| x.name == c.name);
        let stat = |f: fn(&crate::quality::ChannelSummary) -> f64| {
            quality
                .filter(|x| x.summary.finite_samples > 0)
                .map_or("–".into(), |x| sig4(f(&x.summary)))
        };
        let stored = if c.scale == 1.0 {
            c.stored_type.clone()
        } else {
            format!("{} × {}", c.stored_type, sig(c.scale, 6))
        };
        rows.push(vec![
            c.name.clone(),
            c.unit.map_or("–".into(), |u| u.pretty().to_string()),
            c.si_unit().map_or("–".into(), |u| u.pretty().to_string()),
            c.kind.to_string(),
            stored,
            stat(|s| s.min),
            stat(|s| s.max),
            stat(|s| s.mean),
            stat(|s| s.std),
            quality
                .and_then(|x| x.summary.smallest_step)
                .map_or("–".into(), sig4),
            quality.map_or("–".into(), |x| x.nonfinite_samples.to_string()),
            match quality {
                Some(x) if x.summary.possibly_saturated => "possibly".into(),
                Some(_) => "no".into(),
                None => "–".into(),
            },
        ]);
        for v in quality.iter().flat_map(|x| &x.verdicts) {
            verdicts.push(format!("{}: {}", c.name, v.describe()));
        }
    }
    out.push_str(&table(&header, &rows, &numeric));
    if !verdicts.is_empty() {
        let _ = writeln!(out);
        for v in verdicts {
            let _ = writeln!(out, "  {v}");
        }
    }
    let _ = writeln!(
        out,
        "\n  min, max, mean, std and step are in the SI unit; step is the smallest change between\n  \
         consecutive samples (the quantisation step of an integer-coded sensor)."
    );
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn table_pads_columns_and_right_aligns_numbers() {
        let t = table(
            &["name", "value"],
            &[
                vec!["a".into(), "1.5".into()],
                vec!["longer".into(), "12.25".into()],
            ],
            &[false, true],
        );
        let lines: Vec<&str> = t.lines().collect();
        assert_eq!(lines[0], "  name    value");
        assert_eq!(lines[1], "  a         1.5");
        assert_eq!(lines[2], "  longer  12.25");
    }
}
