//! The specification a fleet is screened against: a TOML file of upper limits per sensor kind
//! and IEEE term, each with its unit, and the fleet test's options.
//!
//! ```toml
//! [gyro]
//! N = "0.3 deg/sqrt(h)"   # angle random walk
//! B = "5 deg/h"
//! K = "20 deg/h/sqrt(h)"
//! [accel]
//! N = "60 ug/sqrt(Hz)"
//! B = "20 ug"
//! [fleet]
//! outlier_z = 3.5          # |robust z| of ln(coefficient) that makes an outlier
//! min_siblings = 5         # fewer channels of a kind with the term: no outlier test
//! rare_effect_share = 0.25 # an effect fewer than this share of siblings show is unusual
//! ```
//! Every value needs its unit, read by [`CoefUnit`] (the units `imunoise simulate --noise`
//! takes) and checked against the sensor and term, so that an angle random walk written in °/h
//! is an error, not a limit 60× off. Unknown sections, keys, terms or units are errors naming the
//! key: a misspelt limit must not silently pass every sensor.

use std::path::Path;

use crate::model::{CoefUnit, Sensor, Term};

/// One upper limit.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Limit {
    pub sensor: Sensor,
    pub term: Term,
    /// The limit in SI (see [`crate::model::Coefficients`]).
    pub si: f64,
    /// As written: the value in `unit`.
    pub value: f64,
    pub unit: CoefUnit,
}

/// Options of the fleet comparison (`[fleet]`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FleetOptions {
    /// |z| beyond which a coefficient is an outlier (robust z of its logarithm).
    pub outlier_z: f64,
    /// Least number of channels of a sensor kind with the term (or, for effects, analysed) for
    /// the fleet comparison to be made at all.
    pub min_siblings: usize,
    /// An effect shown by fewer than this share of the analysed channels of a kind is unusual.
    pub rare_effect_share: f64,
}

impl Default for FleetOptions {
    fn default() -> Self {
        FleetOptions {
            outlier_z: 3.5,
            min_siblings: 5,
            rare_effect_share: 0.25,
        }
    }
}

/// A parsed specification: limits (in `[gyro]` then `[accel]` order, terms in Q–N–B–K–R order)
/// and fleet options.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Spec {
    pub limits: Vec<Limit>,
    pub fleet: FleetOptions,
}

/// A specification that cannot be used; the message names the file and key.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{0}")]
pub struct SpecError(pub String);

impl Spec {
    /// The limit on `term` of a `sensor`, if the specification sets one.
    pub fn limit(&self, sensor: Sensor, term: Term) -> Option<&Limit> {
        self.limits
            .iter()
            .find(|l| l.sensor == sensor && l.term == term)
    }

    /// Reads and parses the file at `path`.
    pub fn read(path: &Path) -> Result<Spec, SpecError> {
        let text = std::fs::read_to_string(path)
            .map_err(|e| SpecError(format!("{}: {e}", path.display())))?;
        Spec::parse(&text).map_err(|SpecError(m)| SpecError(format!("{}: {m}", path.display())))
    }

    /// Parses specification text.
    pub fn parse(text: &str) -> Result<Spec, SpecError> {
        let table: toml::Table = text
            .parse()
            .map_err(|e: toml::de::Error| SpecError(e.to_string().trim_end().to_string()))?;
        let mut spec = Spec::default();
        for (section, value) in &table {
            let sensor = match section.as_str() {
                "gyro" => Some(Sensor::Gyro),
                "accel" => Some(Sensor::Accel),
                "fleet" => None,
                other => {
                    return Err(SpecError(format!(
                        "unknown section [{other}]: expected [gyro], [accel] or [fleet]"
                    )))
                }
            };
            let entries = value.as_table().ok_or_else(|| {
                SpecError(format!(
                    "{section} must be a section ([{section}]), not a value"
                ))
            })?;
            match sensor {
                Some(sensor) => {
                    for (key, v) in entries {
                        spec.limits.push(limit(section, sensor, key, v)?);
                    }
                }
                None => spec.fleet = fleet_options(entries)?,
            }
        }
        let order = |l: &Limit| (l.sensor == Sensor::Accel, l.term);
        spec.limits.sort_by_key(order);
        Ok(spec)
    }
}

fn limit(section: &str, sensor: Sensor, key: &str, v: &toml::Value) -> Result<Limit, SpecError> {
    let at = format!("[{section}] {key}");
    let term: Term = key.parse().map_err(|_| {
        SpecError(format!(
            "{at}: unknown term {key:?}: expected Q, N, B, K or R"
        ))
    })?;
    let text = v.as_str().ok_or_else(|| {
        SpecError(format!(
            "{at}: expected a string with value and unit, e.g. {key} = \"1.5 {}\"",
            CoefUnit::display_pair(sensor, term).0.label()
        ))
    })?;
    let (value, unit) = split_value_unit(text).ok_or_else(|| {
        SpecError(format!(
            "{at} = {text:?}: expected a number and a unit, e.g. \"1.5 {}\"",
            CoefUnit::display_pair(sensor, term).0.label()
        ))
    })?;
    let unit: CoefUnit = unit
        .parse()
        .map_err(|e| SpecError(format!("{at} = {text:?}: {e}")))?;
    unit.check(sensor, term)
        .map_err(|e| SpecError(format!("{at} = {text:?}: {e}")))?;
    if !(value.is_finite() && value >= 0.0) {
        return Err(SpecError(format!("{at} = {text:?}: a limit must be >= 0")));
    }
    Ok(Limit {
        sensor,
        term,
        si: unit.to_si(value),
        value,
        unit,
    })
}

/// `"0.3 deg/sqrt(h)"` or `"0.3deg/sqrt(h)"` → (0.3, `"deg/sqrt(h)"`); `None` without a number
/// or without a unit.
fn split_value_unit(text: &str) -> Option<(f64, &str)> {
    let t = text.trim();
    let end = t
        .find(|c: char| !(c.is_ascii_digit() || matches!(c, '.' | 'e' | 'E' | '+' | '-')))
        .unwrap_or(t.len());
    // "2e-3deg/h" splits after the number; a trailing e belongs to the unit.
    let mut split = end;
    while split > 0 && t[..split].parse::<f64>().is_err() {
        split -= 1;
    }
    let value: f64 = t[..split].parse().ok()?;
    let unit = t[split..].trim();
    (!unit.is_empty()).then_some((value, unit))
}

fn fleet_options(entries: &toml::Table) -> Result<FleetOptions, SpecError> {
    let mut o = FleetOptions::default();
    for (key, v) in entries {
        let at = format!("[fleet] {key}");
        let number = v
            .as_float()
            .or_else(|| v.as_integer().map(|i| i as f64))
            .ok_or_else(|| SpecError(format!("{at}: expected a number")))?;
        match key.as_str() {
            "outlier_z" if number > 0.0 && number.is_finite() => o.outlier_z = number,
            "min_siblings" if number >= 2.0 && number.fract() == 0.0 => {
                o.min_siblings = number as usize
            }
            "rare_effect_share" if number > 0.0 && number <= 1.0 => o.rare_effect_share = number,
            "outlier_z" => return Err(SpecError(format!("{at} = {number}: must be > 0"))),
            "min_siblings" => {
                return Err(SpecError(format!(
                    "{at} = {number}: must be a whole number >= 2"
                )))
            }
            "rare_effect_share" => {
                return Err(SpecError(format!("{at} = {number}: must be in (0, 1]")))
            }
            other => {
                return Err(SpecError(format!(
                    "unknown key {other:?} in [fleet]: expected outlier_z, min_siblings or \
                     rare_effect_share"
                )))
            }
        }
    }
    Ok(o)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: f64, b: f64) -> bool {
        (a / b - 1.0).abs() < 1e-12
    }

    #[test]
    fn parses_limits_in_their_units_and_fleet_options() {
        let spec = Spec::parse(
            r#"
            [accel]
            B = "20 ug"
            N = "60ug/sqrt(Hz)"
            [gyro]
            N = "0.3 deg/sqrt(h)"  # ARW
            K = "2e-3deg/h/sqrt(h)"
            [fleet]
            outlier_z = 4
            "#,
        )
        .unwrap();
        let order: Vec<(Sensor, &str)> = spec
            .limits
            .iter()
            .map(|l| (l.sensor, l.term.symbol()))
            .collect();
        assert_eq!(
            order,
            [
                (Sensor::Gyro, "N"),
                (Sensor::Gyro, "K"),
                (Sensor::Accel, "N"),
                (Sensor::Accel, "B")
            ]
        );
        let n = spec.limit(Sensor::Gyro, Term::RandomWalk).unwrap();
        assert!(close(n.si, 0.3 * std::f64::consts::PI / 180.0 / 60.0));
        let k = spec.limit(Sensor::Gyro, Term::RateRandomWalk).unwrap();
        assert!(close(k.value, 2e-3));
        let b = spec.limit(Sensor::Accel, Term::BiasInstability).unwrap();
        assert!(close(b.si, 20.0 * 9.80665e-6));
        assert_eq!(spec.fleet.outlier_z, 4.0);
        assert_eq!(spec.fleet.min_siblings, 5);
        assert_eq!(Spec::parse("").unwrap(), Spec::default());
    }

    #[test]
    fn errors_name_the_key() {
        for (text, needle) in [
            ("[gyro]\nN = \"0.3 deg/h\"", "[gyro] N"),
            ("[gyro]\nX = \"0.3 deg/h\"", "unknown term \"X\""),
            ("[gyro]\nN = 0.3", "[gyro] N: expected a string"),
            ("[gyro]\nN = \"0.3\"", "[gyro] N = \"0.3\""),
            ("[gyro]\nB = \"5 furlongs\"", "unknown coefficient unit"),
            ("[gyro]\nB = \"5 ug\"", "[gyro] B"),
            ("[magneto]\nB = \"5 ug\"", "unknown section [magneto]"),
            ("[fleet]\noutlier = 3", "unknown key \"outlier\""),
            ("[fleet]\noutlier_z = -1", "[fleet] outlier_z"),
            ("[gyro\n", "TOML"),
        ] {
            let err = Spec::parse(text).unwrap_err().to_string();
            assert!(
                err.contains(needle) || (needle == "TOML" && !err.is_empty()),
                "{text:?}: {err}"
            );
        }
    }

    #[test]
    fn numbers_split_from_units() {
        assert_eq!(
            split_value_unit("0.3 deg/sqrt(h)"),
            Some((0.3, "deg/sqrt(h)"))
        );
        assert_eq!(split_value_unit("2e-3deg/h"), Some((2e-3, "deg/h")));
        assert_eq!(split_value_unit("5 ug"), Some((5.0, "ug")));
        assert_eq!(split_value_unit("deg/h"), None);
    }
}
