//! The model stage in the outputs: fits as JSON (SI values plus the datasheet units), and one
//! long table of coefficients for fleet screening (one row per file × channel × fit × term).

use serde_json::{json, Value};

use crate::analysis::ChannelAnalysis;
use crate::model::{CoefUnit, NoiseFit, Sensor, Term};
use crate::pipeline::FileResult;

use super::{file_name, Column, Table};

/// The units a coefficient of `term` is shown in: SI first, then the two datasheet habits.
pub fn units_of(sensor: Sensor, term: Term) -> [CoefUnit; 3] {
    let (a, b) = CoefUnit::display_pair(sensor, term);
    [CoefUnit::si(sensor, term), a, b]
}

fn in_units(sensor: Sensor, term: Term, values: &[(&str, f64)]) -> Value {
    let mut units: Vec<CoefUnit> = Vec::new();
    for u in units_of(sensor, term) {
        if !units.contains(&u) {
            units.push(u);
        }
    }
    units
        .iter()
        .map(|u| {
            let mut o = serde_json::Map::new();
            o.insert("unit".into(), json!(u.label()));
            for (k, v) in values {
                o.insert((*k).into(), json!(u.from_si(*v)));
            }
            Value::Object(o)
        })
        .collect()
}

fn term_of(v: &Value) -> Option<Term> {
    Term::ALL
        .iter()
        .copied()
        .find(|t| serde_json::to_value(t).ok().as_ref() == v.get("term"))
}

/// Adds `symbol` and `units` (the value in SI and datasheet units) to every estimate and limit.
fn decorate_fit(sensor: Sensor, fit: &mut Value) {
    fit["chi2_per_dof"] = json!(
        fit["chi2"].as_f64().unwrap_or(f64::NAN) / fit["dof"].as_f64().unwrap_or(1.0).max(1.0)
    );
    for list in ["estimates", "upper_limits"] {
        let Some(items) = fit.get_mut(list).and_then(Value::as_array_mut) else {
            continue;
        };
        for e in items {
            decorate_estimate(sensor, e);
        }
    }
}

/// One channel's analysis as JSON.
pub fn analysis_json(a: &ChannelAnalysis) -> Value {
    let mut v = serde_json::to_value(a).unwrap_or(Value::Null);
    for domain in ["allan", "spectrum"] {
        if v[domain]["status"] == "ok" {
            decorate_fit(a.sensor, &mut v[domain]);
        }
    }
    if let Some(rows) = v["comparison"].as_array_mut() {
        for row in rows {
            if let Some(term) = term_of(row) {
                row["symbol"] = json!(term.symbol());
            }
            for domain in ["allan", "spectrum"] {
                if row[domain].is_object() {
                    decorate_estimate(a.sensor, &mut row[domain]);
                }
            }
        }
    }
    v
}

/// Adds `symbol` and `units` (every value in SI and the datasheet units) to an estimate or limit.
fn decorate_estimate(sensor: Sensor, e: &mut Value) {
    if let Some(term) = term_of(e) {
        let keys: Vec<(&str, f64)> = ["value", "lo", "hi", "upper"]
            .into_iter()
            .filter_map(|k| Some((k, e.get(k)?.as_f64()?)))
            .collect();
        e["symbol"] = json!(term.symbol());
        e["units"] = in_units(sensor, term, &keys);
    }
}

/// The fits of one channel, by domain name.
pub fn fits(a: &ChannelAnalysis) -> [(&'static str, Option<&NoiseFit>); 2] {
    [("allan", a.allan_fit()), ("spectrum", a.spectrum_fit())]
}

/// One row per file × channel × fit × allowed term: kept terms with their interval, absent ones
/// with their upper limit, in SI and in the datasheet unit.
pub fn coefficients_table(results: &[&FileResult]) -> Table {
    let mut cols: [Vec<String>; 7] = Default::default();
    let mut nums: [Vec<f64>; 7] = Default::default();
    for r in results {
        for a in r.analysis.iter().flatten() {
            // One row: its fit, term and status, then (value, lo, hi) in SI, in the datasheet
            // unit, and the fit's χ²/dof.
            let mut push = |fit: &str, term: Term, status: &str, v: [f64; 3], chi2: f64| {
                let [_, datasheet, _] = units_of(a.sensor, term);
                let text = [
                    file_name(&r.recording),
                    a.channel.clone(),
                    format!("{:?}", a.sensor).to_lowercase(),
                    fit.to_string(),
                    term.symbol().to_string(),
                    status.to_string(),
                    datasheet.label(),
                ];
                for (c, x) in cols.iter_mut().zip(text) {
                    c.push(x);
                }
                let row = [
                    v[0],
                    v[1],
                    v[2],
                    datasheet.from_si(v[0]),
                    datasheet.from_si(v[1]),
                    datasheet.from_si(v[2]),
                    chi2,
                ];
                for (c, x) in nums.iter_mut().zip(row) {
                    c.push(x);
                }
            };
            // The one answer per term first; the per-domain rows below are its evidence.
            for t in &a.combined.terms {
                let status = if t.hull { "kept_fits_disagree" } else { "kept" };
                push("combined", t.term, status, [t.value, t.lo, t.hi], f64::NAN);
            }
            for l in &a.combined.limits {
                push(
                    "combined",
                    l.term,
                    "upper_limit",
                    [f64::NAN, 0.0, l.upper],
                    f64::NAN,
                );
            }
            for (domain, fit) in fits(a) {
                let Some(fit) = fit else { continue };
                let kept = fit
                    .estimates
                    .iter()
                    .map(|e| (e.term, "kept", [e.value, e.lo, e.hi]));
                let absent = fit
                    .upper_limits
                    .iter()
                    .map(|u| (u.term, "upper_limit", [f64::NAN, 0.0, u.upper]));
                for (term, status, v) in kept.chain(absent) {
                    push(domain, term, status, v, fit.chi2_per_dof());
                }
            }
        }
    }
    let [file, channel, sensor, domain, term, status, unit] = cols;
    let [value, lo, hi, value_d, lo_d, hi_d, chi2] = nums;
    Table {
        columns: vec![
            ("file".into(), Column::Str(file)),
            ("channel".into(), Column::Str(channel)),
            ("sensor".into(), Column::Str(sensor)),
            ("fit".into(), Column::Str(domain)),
            ("term".into(), Column::Str(term)),
            ("status".into(), Column::Str(status)),
            ("value_si".into(), Column::F64(value)),
            ("lo_si".into(), Column::F64(lo)),
            ("hi_si".into(), Column::F64(hi)),
            ("unit".into(), Column::Str(unit)),
            ("value".into(), Column::F64(value_d)),
            ("lo".into(), Column::F64(lo_d)),
            ("hi".into(), Column::F64(hi_d)),
            ("chi2_per_dof".into(), Column::F64(chi2)),
        ],
        metadata: Default::default(),
    }
}
