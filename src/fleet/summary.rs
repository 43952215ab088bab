//! `summary.md`: what a person reads first after a screen — counts, then every failure, outlier,
//! unusual effect, quality problem, undecided verdict and error, each with its evidence, then the
//! fleet statistics and the specification used. Values are shown in the limit's unit where the
//! specification sets one, else in the datasheet unit (°/√h, °/h, µg, …).

use std::fmt::Write;

use crate::model::Term;

use super::assess::{display_unit, show, FleetRow};
use super::layout::FleetStepSummary;
use super::record::Status;
use super::table::sensor_name;
use super::verdict::{Basis, Verdict};

fn cell(s: &str) -> String {
    s.replace('|', "\\|").replace('\n', " ")
}

fn who(r: &FleetRow) -> (String, String) {
    (
        cell(&r.record.sensor),
        cell(r.record.channel.as_deref().unwrap_or("–")),
    )
}

/// The Markdown summary of a fleet step.
pub fn markdown(s: &FleetStepSummary, title: &str) -> String {
    let fleet = &s.fleet;
    let spec = &fleet.spec;
    let rows = &fleet.rows;
    let ok: Vec<&FleetRow> = rows
        .iter()
        .filter(|r| r.record.status == Status::Ok)
        .collect();
    let errors: Vec<&FleetRow> = rows
        .iter()
        .filter(|r| r.record.status == Status::Error)
        .collect();
    let count = |pred: &dyn Fn(&FleetRow) -> bool| ok.iter().filter(|r| pred(r)).count();
    let verdicts = |v: Verdict| {
        ok.iter()
            .flat_map(|r| r.terms.iter())
            .filter(|a| a.verdict == Some(v))
            .count()
    };
    let mut flagged_sensors: Vec<&str> = ok
        .iter()
        .filter(|r| r.flagged)
        .map(|r| r.record.sensor.as_str())
        .collect();
    flagged_sensors.sort_unstable();
    flagged_sensors.dedup();
    let mut md = String::new();
    let _ = writeln!(md, "# Fleet screen\n\n{title}\n");
    let _ = writeln!(md, "| | |\n|---|---|");
    let _ = writeln!(md, "| files counted | {} |", s.files);
    let kinds: Vec<String> = ["gyro", "accel"]
        .iter()
        .map(|k| {
            let n = ok
                .iter()
                .filter(|r| r.record.kind.map(sensor_name) == Some(k))
                .count();
            format!("{k} {n}")
        })
        .collect();
    let _ = writeln!(md, "| channels | {} ({}) |", ok.len(), kinds.join(", "));
    let _ = writeln!(
        md,
        "| flagged channels | {} (sensors: {}) |",
        count(&|r| r.flagged),
        if flagged_sensors.is_empty() {
            "none".to_string()
        } else {
            cell(&flagged_sensors.join(", "))
        }
    );
    // Verdicts are per term: a channel failing two limits counts twice here, once in the
    // channels failing (the figure the exit line gives).
    let _ = writeln!(
        md,
        "| limit failures (terms) | {} on {} channels |",
        verdicts(Verdict::Fail),
        count(&|r| r.fails_spec())
    );
    let _ = writeln!(
        md,
        "| undecided (terms) | {} |",
        verdicts(Verdict::Undecided)
    );
    let _ = writeln!(
        md,
        "| outliers | {} |",
        ok.iter()
            .flat_map(|r| r.terms.iter())
            .filter(|a| a.outlier)
            .count()
    );
    let _ = writeln!(
        md,
        "| unusual effects | {} |",
        ok.iter().map(|r| r.unusual_effects.len()).sum::<usize>()
    );
    let _ = writeln!(md, "| files with errors | {} |", errors.len());
    let _ = writeln!(
        md,
        "| pending (not computed yet) | {}{} |",
        s.pending.len(),
        s.shards_not_run()
            .map_or(String::new(), |k| format!("; shards not run yet: {k}"))
    );
    if !s.stale.is_empty() {
        let _ = writeln!(
            md,
            "| computed with other options (not counted) | {} |",
            s.stale.len()
        );
    }
    if !s.unreadable.is_empty() {
        let _ = writeln!(
            md,
            "| results that do not read (not counted; delete them to recompute) | {} |",
            s.unreadable.len()
        );
    }
    if s.orphans > 0 {
        let _ = writeln!(
            md,
            "| part files in shard folders ≥ {} (not counted) | {} |",
            s.shards, s.orphans
        );
    }

    let fails: Vec<(&FleetRow, Term)> = ok
        .iter()
        .flat_map(|r| {
            Term::ALL
                .iter()
                .filter(|t| r.terms[t.index()].verdict == Some(Verdict::Fail))
                .map(move |t| (*r, *t))
        })
        .collect();
    if !fails.is_empty() {
        let _ = writeln!(
            md,
            "\n## Limit failures\n\nThe whole interval lies above the limit.\n\n\
             | sensor | channel | term | value [interval] | limit |\n|---|---|---|---|---|"
        );
        for (r, t) in fails {
            let (sensor, channel) = who(r);
            let kind = r.record.kind.unwrap_or(crate::model::Sensor::Gyro);
            let v = r.record.term(t);
            let _ = writeln!(
                md,
                "| {sensor} | {channel} | {} | {} [{}, {}] | {} |",
                t.symbol(),
                show(spec, kind, t, v.value.unwrap_or(f64::NAN)),
                show(spec, kind, t, v.lo.unwrap_or(f64::NAN)),
                show(spec, kind, t, v.hi.unwrap_or(f64::NAN)),
                show(spec, kind, t, r.terms[t.index()].limit.unwrap_or(f64::NAN)),
            );
        }
    }

    let outliers: Vec<(&FleetRow, Term)> = ok
        .iter()
        .flat_map(|r| {
            Term::ALL
                .iter()
                .filter(|t| r.terms[t.index()].outlier)
                .map(move |t| (*r, *t))
        })
        .collect();
    if !outliers.is_empty() {
        let _ = writeln!(
            md,
            "\n## Outliers\n\n|robust z| of ln(value) above {} against the channels of the same \
             kind: (ln value − median)/√(s² + u²), s = 1.4826·MAD of the fleet, u the estimate's \
             own standard error.\n\n\
             | sensor | channel | term | value | fleet median | ratio | z |\n|---|---|---|---|---|---|---|",
            spec.fleet.outlier_z
        );
        for (r, t) in outliers {
            let (sensor, channel) = who(r);
            let kind = r.record.kind.unwrap_or(crate::model::Sensor::Gyro);
            let a = &r.terms[t.index()];
            let v = r.record.term(t).value.unwrap_or(f64::NAN);
            let m = a.median.unwrap_or(f64::NAN);
            let _ = writeln!(
                md,
                "| {sensor} | {channel} | {} | {} | {} | {:.2} | {:+.1} |",
                t.symbol(),
                show(spec, kind, t, v),
                show(spec, kind, t, m),
                v / m,
                a.z.unwrap_or(f64::NAN)
            );
        }
    }

    let unusual: Vec<&FleetRow> = ok
        .iter()
        .copied()
        .filter(|r| !r.unusual_effects.is_empty())
        .collect();
    if !unusual.is_empty() {
        let _ = writeln!(
            md,
            "\n## Unusual effects\n\nEffects the residual loop found on fewer than {:.0} % of \
             the channels of the same kind.\n\n\
             | sensor | channel | effect | channels showing it | what was found |\n|---|---|---|---|---|",
            100.0 * spec.fleet.rare_effect_share
        );
        for r in unusual {
            let (sensor, channel) = who(r);
            for u in &r.unusual_effects {
                let detail = r
                    .record
                    .effects
                    .iter()
                    .zip(&r.record.effects_detail)
                    .filter(|(k, _)| **k == u.kind)
                    .map(|(_, d)| d.as_str())
                    .collect::<Vec<_>>()
                    .join("; ");
                let _ = writeln!(
                    md,
                    "| {sensor} | {channel} | {} | {} of {} | {} |",
                    u.kind,
                    u.count,
                    u.siblings,
                    cell(&detail)
                );
            }
        }
    }

    let quality: Vec<&FleetRow> = ok
        .iter()
        .copied()
        .filter(|r| r.record.quality.iter().any(|q| q != "no_unit"))
        .collect();
    if !quality.is_empty() {
        let _ = writeln!(
            md,
            "\n## Quality\n\n| sensor | channel | verdict | detail |\n|---|---|---|---|"
        );
        for r in quality {
            let (sensor, channel) = who(r);
            for (q, d) in r.record.quality.iter().zip(&r.record.quality_detail) {
                if q != "no_unit" {
                    let _ = writeln!(md, "| {sensor} | {channel} | {q} | {} |", cell(d));
                }
            }
        }
    }

    // Channels left out for want of a unit are not rows; every row of their file says so.
    let mut unitless: Vec<(String, String)> = ok
        .iter()
        .flat_map(|r| {
            r.record
                .warnings
                .iter()
                .filter(|w| w.ends_with(crate::quality::NO_UNIT_TEXT))
                .map(|w| (cell(&r.record.sensor), cell(w)))
        })
        .collect();
    unitless.sort();
    unitless.dedup();
    if !unitless.is_empty() {
        let _ = writeln!(
            md,
            "\n## Channels not analysed\n\nNo unit in the file, so not analysed as gyro or \
             accelerometer channels (their sensors' other channels are).\n\n\
             | sensor | channel and reason |\n|---|---|"
        );
        for (sensor, line) in unitless {
            let _ = writeln!(md, "| {sensor} | {line} |");
        }
    }

    let undecided: Vec<(&FleetRow, Term)> = ok
        .iter()
        .flat_map(|r| {
            Term::ALL
                .iter()
                .filter(|t| r.terms[t.index()].verdict == Some(Verdict::Undecided))
                .map(move |t| (*r, *t))
        })
        .collect();
    if !undecided.is_empty() {
        let _ = writeln!(
            md,
            "\n## Undecided\n\nThe interval straddles the limit, or only an upper limit above it \
             is known: the record cannot tell (a longer one can).\n\n\
             | sensor | channel | term | estimate | limit |\n|---|---|---|---|---|"
        );
        for (r, t) in undecided {
            let (sensor, channel) = who(r);
            let kind = r.record.kind.unwrap_or(crate::model::Sensor::Gyro);
            let v = r.record.term(t);
            let a = &r.terms[t.index()];
            let estimate = match a.basis {
                Some(Basis::UpperLimit) => format!(
                    "not estimated; ≤ {}",
                    show(spec, kind, t, v.upper.unwrap_or(f64::NAN))
                ),
                _ => format!(
                    "{} [{}, {}]",
                    show(spec, kind, t, v.value.unwrap_or(f64::NAN)),
                    show(spec, kind, t, v.lo.unwrap_or(f64::NAN)),
                    show(spec, kind, t, v.hi.unwrap_or(f64::NAN))
                ),
            };
            let _ = writeln!(
                md,
                "| {sensor} | {channel} | {} | {estimate} | {} |",
                t.symbol(),
                show(spec, kind, t, a.limit.unwrap_or(f64::NAN)),
            );
        }
    }

    if !errors.is_empty() {
        let _ = writeln!(
            md,
            "\n## Errors\n\n| sensor | path | error |\n|---|---|---|"
        );
        for r in &errors {
            // The readers' errors name the file; the path column already does.
            let error = r.record.error.as_deref().unwrap_or("");
            let error = error
                .strip_prefix(r.record.path.as_str())
                .and_then(|e| e.strip_prefix(": "))
                .unwrap_or(error);
            let _ = writeln!(
                md,
                "| {} | {} | {} |",
                cell(&r.record.sensor),
                cell(&r.record.path),
                cell(error)
            );
        }
    }

    if !s.unreadable.is_empty() {
        let _ = writeln!(md, "\n## Results that do not read\n");
        for (e, err) in &s.unreadable {
            let _ = writeln!(md, "- {}: {}", e.path, err);
        }
    }

    if !s.pending.is_empty() {
        let _ = writeln!(md, "\n## Pending\n");
        for e in s.pending.iter().take(50) {
            let _ = writeln!(md, "- {}", e.path);
        }
        if s.pending.len() > 50 {
            let _ = writeln!(md, "- … and {} more", s.pending.len() - 50);
        }
    }

    if !fleet.stats.is_empty() {
        let _ = writeln!(
            md,
            "\n## Fleet statistics\n\n\
             | kind | term | channels with a determined value | median | robust σ of ln |\n|---|---|---|---|---|"
        );
        for st in &fleet.stats {
            let (median, spread) = match st.scale {
                Some(sc) => (
                    show(spec, st.sensor, st.term, sc.median.exp()),
                    format!("{:.3}", sc.scale),
                ),
                None => (
                    "–".into(),
                    format!("– (fewer than {})", spec.fleet.min_siblings),
                ),
            };
            let _ = writeln!(
                md,
                "| {} | {} | {} | {median} | {spread} |",
                sensor_name(st.sensor),
                st.term.symbol(),
                st.count
            );
        }
    }

    let _ = writeln!(md, "\n## Specification\n");
    if spec.limits.is_empty() {
        let _ = writeln!(md, "No limits (no --spec): fleet comparison only.");
    }
    for l in &spec.limits {
        let _ = writeln!(
            md,
            "- {} {} ≤ {} {}",
            sensor_name(l.sensor),
            l.term.symbol(),
            crate::report::sig4(l.value),
            display_unit(spec, l.sensor, l.term).pretty()
        );
    }
    let _ = writeln!(
        md,
        "- fleet: outlier_z = {}, min_siblings = {}, rare_effect_share = {}",
        spec.fleet.outlier_z, spec.fleet.min_siblings, spec.fleet.rare_effect_share
    );
    md
}
