//! `imunoise simulate`: a specification (JSON file, flags, or both) validated into a
//! [`SimSpec`], simulated by the library and written through [`imunoise::sim::Simulation::write`].

use std::path::PathBuf;

use imunoise::io::{Format, StoredAs};
use imunoise::model::{CoefUnit, Sensor, Term};
use imunoise::sim::{simulate, SimSpec};
use serde_json::{json, Value};

use super::args::SimulateArgs;
use super::config::UsageError;
use super::run::{EXIT_FATAL, EXIT_OK};

/// A validated simulation job.
#[derive(Debug, Clone)]
pub struct SimulateJob {
    pub spec: SimSpec,
    pub out: PathBuf,
    pub stored: StoredAs,
    pub quiet: bool,
}

fn usage(e: impl std::fmt::Display) -> UsageError {
    UsageError(e.to_string())
}

/// `TERM=VALUEUNIT` → (term, SI value). The unit is required: a bare number would be read in some
/// unit the user did not mean (N=0.15 is 0.15 °/√h on a datasheet, 0.15 rad/√s in SI: 3400× apart).
fn noise_flag(text: &str, sensor: Sensor) -> Result<(Term, f64), UsageError> {
    let (term, rest) = text
        .split_once('=')
        .ok_or_else(|| usage(format!("--noise {text:?}: expected TERM=VALUE[UNIT]")))?;
    let term: Term = term
        .parse()
        .map_err(|e| usage(format!("--noise {text:?}: {e}")))?;
    let rest = rest.trim();
    let split = rest
        .find(|c: char| !(c.is_ascii_digit() || matches!(c, '.' | 'e' | 'E' | '+' | '-')))
        .unwrap_or(rest.len());
    // "2e-3deg/h" splits after the number; "1e" alone would be swallowed, so back off a trailing e.
    let (mut number, mut unit) = rest.split_at(split);
    if number.ends_with(['e', 'E']) {
        (number, unit) = rest.split_at(split - 1);
    }
    let value: f64 = number
        .parse()
        .map_err(|_| usage(format!("--noise {text:?}: {number:?} is not a number")))?;
    if !(value.is_finite() && value >= 0.0) {
        return Err(usage(format!("--noise {text:?}: must be >= 0")));
    }
    if unit.trim().is_empty() {
        return Err(usage(format!(
            "--noise {text:?}: give a unit, e.g. {}={value}{} (SI) — a bare number is ambiguous",
            term.symbol(),
            CoefUnit::si(sensor, term)
        )));
    }
    let unit: CoefUnit = unit
        .parse()
        .map_err(|e| usage(format!("--noise {text:?}: {e}")))?;
    unit.check(sensor, term)
        .map_err(|e| usage(format!("--noise {text:?}: {e}")))?;
    Ok((term, unit.to_si(value)))
}

/// Flags over the specification file (or over an empty one).
pub fn job(a: &SimulateArgs) -> Result<SimulateJob, UsageError> {
    let mut spec: Value = match &a.spec {
        Some(path) => {
            let text = std::fs::read_to_string(path)
                .map_err(|e| usage(format!("--spec {}: {e}", path.display())))?;
            serde_json::from_str(&text)
                .map_err(|e| usage(format!("--spec {}: {e}", path.display())))?
        }
        None => json!({}),
    };
    if let Some(r) = a.rate {
        spec["rate_hz"] = json!(r);
    }
    if let Some(d) = a.duration {
        spec["duration_s"] = json!(d);
    }
    if let Some(s) = a.seed {
        spec["seed"] = json!(s);
    }
    if a.spec.is_none() || !a.noise.is_empty() {
        if a.spec.is_some() {
            return Err(usage(
                "--noise builds the channels; with --spec the file gives them (use one or the other)",
            ));
        }
        let sensor = match a.sensor.trim() {
            "gyro" => Sensor::Gyro,
            "accel" => Sensor::Accel,
            other => return Err(usage(format!("--sensor {other:?}: expected gyro or accel"))),
        };
        if a.axes == 0 || a.axes > 26 {
            return Err(usage("--axes must be between 1 and 26"));
        }
        let mut noise = serde_json::Map::new();
        for flag in &a.noise {
            let (term, si) = noise_flag(flag, sensor)?;
            noise.insert(term.symbol().to_ascii_lowercase(), json!(si));
        }
        let prefix = match sensor {
            Sensor::Gyro => "gyro",
            Sensor::Accel => "accel",
        };
        let names = ["x", "y", "z"];
        spec["channels"] = (0..a.axes)
            .map(|i| {
                let axis = names
                    .get(i)
                    .map_or_else(|| ((b'a' + i as u8) as char).to_string(), |s| s.to_string());
                json!({ "name": format!("{prefix}_{axis}"), "sensor": sensor, "noise": noise })
            })
            .collect();
    }
    for (key, flag) in [("rate_hz", "--rate"), ("duration_s", "--duration")] {
        if spec.get(key).is_none() {
            return Err(usage(format!("{flag} is required (or {key} in --spec)")));
        }
    }
    match Format::from_extension(&a.out) {
        Some(Format::ArrowFile | Format::ArrowStream | Format::Parquet | Format::Csv) => {}
        _ => {
            return Err(usage(format!(
                "-o {}: the extension names no format simulate writes; use .arrow (Arrow IPC \
                 file), .arrows (Arrow IPC stream), .parquet or .csv",
                a.out.display()
            )))
        }
    }
    if let Some(dir) = a.out.parent().filter(|p| !p.as_os_str().is_empty()) {
        if !dir.is_dir() {
            return Err(usage(format!(
                "-o {}: the folder {} does not exist",
                a.out.display(),
                dir.display()
            )));
        }
    }
    let spec: SimSpec =
        serde_json::from_value(spec).map_err(|e| usage(format!("specification: {e}")))?;
    spec.validate()
        .map_err(|e| usage(format!("specification: {e}")))?;
    Ok(SimulateJob {
        spec,
        out: a.out.clone(),
        stored: if a.f32 { StoredAs::F32 } else { StoredAs::F64 },
        quiet: a.quiet,
    })
}

pub fn run(job: &SimulateJob) -> i32 {
    let sim = match simulate(&job.spec) {
        Ok(s) => s,
        Err(e) => {
            eprintln!("imunoise: simulate: {e}");
            return EXIT_FATAL;
        }
    };
    if let Err(e) = sim.write(&job.out, job.stored) {
        eprintln!("imunoise: {e}");
        return EXIT_FATAL;
    }
    if !job.quiet {
        eprintln!(
            "wrote {}: {} channels × {} samples at {} Hz (seed {})",
            job.out.display(),
            sim.channels.len(),
            job.spec.samples(),
            job.spec.rate_hz,
            job.spec.seed
        );
    }
    EXIT_OK
}
