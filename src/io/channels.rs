//! From a schema to the channels to analyse: which columns, in which unit and of which kind, with which
//! integer scale, and which column (if any) holds time.

use std::path::Path;

use arrow_schema::{DataType, Field, Schema, TimeUnit};
use serde::Serialize;

use super::InputError;
use crate::units::{Kind, Unit};

/// A column chosen for analysis, with everything needed to turn its raw values into SI.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ChannelSpec {
    pub name: String,
    /// Index of the column in the file's full schema.
    #[serde(skip)]
    pub column: usize,
    /// Arrow type of the stored values (e.g. `Int16`).
    pub stored_type: String,
    /// The unit the file (or a flag) says the values are in; `None` when nobody said.
    pub unit: Option<Unit>,
    pub kind: Kind,
    /// Multiplier from stored integers to `unit` (field metadata `scale`), 1 when absent.
    pub scale: f64,
}

impl ChannelSpec {
    /// The unit values are in after ingest: the SI unit of `unit`'s quantity, or none if unknown.
    pub fn si_unit(&self) -> Option<Unit> {
        self.unit.map(|u| u.quantity().si_unit())
    }

    /// `si = raw · factor + offset`, scale and unit conversion combined.
    pub fn to_si(&self) -> (f64, f64) {
        let (factor, offset) = self.unit.map(Unit::to_si).unwrap_or((1.0, 0.0));
        (self.scale * factor, offset)
    }
}

/// How a time column encodes time.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum TimeEncoding {
    /// Arrow timestamp; `seconds_per_tick` from its unit.
    Timestamp { seconds_per_tick: f64 },
    /// Floating-point seconds.
    Seconds,
    /// Integer ticks with a `unit` metadata of s, ms, us or ns.
    IntegerTicks { seconds_per_tick: f64 },
}

/// The time column of a recording.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TimeSpec {
    pub name: String,
    #[serde(skip)]
    pub column: usize,
    pub encoding: TimeEncoding,
}

/// What the user said about columns on the command line; each entry overrides file metadata.
#[derive(Debug, Clone, Default)]
pub struct ColumnOverrides {
    /// Analyse only these columns, in this order (all numeric non-time columns when empty).
    pub channels: Vec<String>,
    /// `(column or "*", unit)`.
    pub units: Vec<(String, Unit)>,
    /// `(column or "*", kind)`.
    pub kinds: Vec<(String, Kind)>,
    /// The time column's name, when not `time`/`timestamp`.
    pub time_column: Option<String>,
    /// Treat the recording as having no time column even if one is found.
    pub ignore_time: bool,
}

impl ColumnOverrides {
    fn unit_for(&self, column: &str) -> Option<Unit> {
        lookup(&self.units, column)
    }
    fn kind_for(&self, column: &str) -> Option<Kind> {
        lookup(&self.kinds, column)
    }
}

/// An exact column match wins over `*`.
fn lookup<T: Copy>(entries: &[(String, T)], column: &str) -> Option<T> {
    entries
        .iter()
        .find(|(c, _)| c == column)
        .or_else(|| entries.iter().find(|(c, _)| c == "*"))
        .map(|(_, v)| *v)
}

/// Types a channel column may have.
pub fn is_sample_type(t: &DataType) -> bool {
    matches!(
        t,
        DataType::Float32
            | DataType::Float64
            | DataType::Int8
            | DataType::Int16
            | DataType::Int32
            | DataType::Int64
            | DataType::UInt8
            | DataType::UInt16
            | DataType::UInt32
            | DataType::UInt64
    )
}

const TIME_NAMES: &[&str] = &["time", "timestamp", "t", "time_s"];

/// Finds the time column: the one named by `--time-column`, else an Arrow timestamp column, else a
/// column called `time`/`timestamp`/`t`/`time_s`.
pub fn find_time(
    path: &Path,
    schema: &Schema,
    overrides: &ColumnOverrides,
) -> Result<Option<TimeSpec>, InputError> {
    if overrides.ignore_time {
        return Ok(None);
    }
    let index = match &overrides.time_column {
        Some(name) => Some(
            schema
                .index_of(name)
                .map_err(|_| InputError::UnknownColumn {
                    path: path.to_path_buf(),
                    column: name.clone(),
                    available: column_list(schema),
                })?,
        ),
        None => schema
            .fields()
            .iter()
            .position(|f| matches!(f.data_type(), DataType::Timestamp(..)))
            .or_else(|| {
                schema
                    .fields()
                    .iter()
                    .position(|f| TIME_NAMES.contains(&f.name().to_ascii_lowercase().as_str()))
            }),
    };
    let Some(column) = index else {
        return Ok(None);
    };
    let field = schema.field(column);
    let encoding = time_encoding(path, field)?;
    Ok(Some(TimeSpec {
        name: field.name().clone(),
        column,
        encoding,
    }))
}

fn time_encoding(path: &Path, field: &Field) -> Result<TimeEncoding, InputError> {
    let bad = |message: String| InputError::BadMetadata {
        path: path.to_path_buf(),
        column: field.name().clone(),
        message,
    };
    match field.data_type() {
        DataType::Timestamp(unit, _) => Ok(TimeEncoding::Timestamp {
            seconds_per_tick: seconds_per(unit),
        }),
        DataType::Float32 | DataType::Float64 => Ok(TimeEncoding::Seconds),
        t if t.is_integer() => {
            let unit = field.metadata().get("unit").map(|s| s.trim().to_string());
            let seconds_per_tick = match unit.as_deref() {
                Some("s") => 1.0,
                Some("ms") => 1e-3,
                Some("us") | Some("µs") => 1e-6,
                Some("ns") => 1e-9,
                other => {
                    return Err(bad(format!(
                        "integer time column needs field metadata unit = s, ms, us or ns (found {other:?})"
                    )))
                }
            };
            Ok(TimeEncoding::IntegerTicks { seconds_per_tick })
        }
        t => Err(bad(format!(
            "time column has type {t}; expected an Arrow timestamp or seconds as floating point"
        ))),
    }
}

fn seconds_per(unit: &TimeUnit) -> f64 {
    match unit {
        TimeUnit::Second => 1.0,
        TimeUnit::Millisecond => 1e-3,
        TimeUnit::Microsecond => 1e-6,
        TimeUnit::Nanosecond => 1e-9,
    }
}

fn column_list(schema: &Schema) -> String {
    schema
        .fields()
        .iter()
        .map(|f| f.name().as_str())
        .collect::<Vec<_>>()
        .join(", ")
}

/// The channels to analyse, in order.
pub fn select_channels(
    path: &Path,
    schema: &Schema,
    time: Option<&TimeSpec>,
    overrides: &ColumnOverrides,
) -> Result<Vec<ChannelSpec>, InputError> {
    let time_column = time.map(|t| t.column);
    let numeric: Vec<usize> = (0..schema.fields().len())
        .filter(|&i| Some(i) != time_column && is_sample_type(schema.field(i).data_type()))
        .collect();
    let numeric_names = || {
        numeric
            .iter()
            .map(|&i| schema.field(i).name().as_str())
            .collect::<Vec<_>>()
            .join(", ")
    };
    let columns: Vec<usize> = if overrides.channels.is_empty() {
        if numeric.is_empty() {
            return Err(InputError::NoNumericColumn {
                path: path.to_path_buf(),
                columns: column_list(schema),
            });
        }
        numeric.clone()
    } else {
        overrides
            .channels
            .iter()
            .map(|name| {
                let i = schema
                    .index_of(name)
                    .map_err(|_| InputError::UnknownColumn {
                        path: path.to_path_buf(),
                        column: name.clone(),
                        available: numeric_names(),
                    })?;
                if numeric.contains(&i) {
                    Ok(i)
                } else {
                    Err(InputError::UnsupportedType {
                        path: path.to_path_buf(),
                        column: name.clone(),
                        data_type: schema.field(i).data_type().to_string(),
                    })
                }
            })
            .collect::<Result<_, _>>()?
    };
    columns
        .into_iter()
        .map(|i| channel_spec(path, schema.field(i), i, overrides))
        .collect()
}

fn channel_spec(
    path: &Path,
    field: &Field,
    column: usize,
    overrides: &ColumnOverrides,
) -> Result<ChannelSpec, InputError> {
    let name = field.name().clone();
    let bad = |message: String| InputError::BadMetadata {
        path: path.to_path_buf(),
        column: name.clone(),
        message,
    };
    let meta = field.metadata();
    let unit = match overrides.unit_for(&name) {
        Some(u) => Some(u),
        None => match meta.get("unit") {
            Some(text) => Some(text.parse::<Unit>().map_err(|e| bad(e.to_string()))?),
            None => None,
        },
    };
    let kind = match overrides.kind_for(&name) {
        Some(k) => k,
        None => match meta.get("kind") {
            Some(text) => text.parse::<Kind>().map_err(|e| bad(e.to_string()))?,
            None => Kind::implied_by(unit),
        },
    };
    let scale = match meta.get("scale") {
        Some(text) => {
            let s: f64 = text
                .trim()
                .parse()
                .map_err(|_| bad(format!("scale {text:?} is not a number")))?;
            if !s.is_finite() || s == 0.0 {
                return Err(bad(format!("scale {text:?} must be finite and non-zero")));
            }
            s
        }
        None => 1.0,
    };
    Ok(ChannelSpec {
        name,
        column,
        stored_type: field.data_type().to_string(),
        unit,
        kind,
        scale,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::HashMap;

    fn field(name: &str, t: DataType, meta: &[(&str, &str)]) -> Field {
        let m: HashMap<String, String> = meta
            .iter()
            .map(|(k, v)| (k.to_string(), v.to_string()))
            .collect();
        Field::new(name, t, false).with_metadata(m)
    }

    #[test]
    fn channels_take_unit_kind_and_scale_from_metadata_and_flags_override() {
        let schema = Schema::new(vec![
            field("time", DataType::Float64, &[]),
            field(
                "gx",
                DataType::Int16,
                &[("unit", "deg/s"), ("scale", "0.01")],
            ),
            field("ax", DataType::Float32, &[("unit", "g")]),
            field("label", DataType::Utf8, &[]),
        ]);
        let p = Path::new("x.arrow");
        let mut ov = ColumnOverrides::default();
        let time = find_time(p, &schema, &ov).unwrap().unwrap();
        assert_eq!(time.column, 0);
        let ch = select_channels(p, &schema, Some(&time), &ov).unwrap();
        assert_eq!(ch.len(), 2);
        assert_eq!(ch[0].kind, Kind::Gyro);
        assert!((ch[0].to_si().0 - 0.01 * std::f64::consts::PI / 180.0).abs() < 1e-18);
        assert_eq!(ch[1].kind, Kind::Accel);
        ov.units.push(("ax".into(), Unit::MilliG));
        ov.kinds.push(("*".into(), Kind::Aux));
        let ch = select_channels(p, &schema, Some(&time), &ov).unwrap();
        assert_eq!(ch[1].unit, Some(Unit::MilliG));
        assert_eq!(ch[0].kind, Kind::Aux);
    }

    #[test]
    fn bad_metadata_and_unknown_columns_name_the_column() {
        let schema = Schema::new(vec![field("gx", DataType::Float64, &[("unit", "furlong")])]);
        let p = Path::new("x.arrow");
        let err = select_channels(p, &schema, None, &ColumnOverrides::default()).unwrap_err();
        assert!(err.to_string().contains("\"gx\"") && err.to_string().contains("furlong"));
        let ov = ColumnOverrides {
            channels: vec!["gy".into()],
            ..Default::default()
        };
        let err = select_channels(p, &schema, None, &ov).unwrap_err();
        assert!(matches!(err, InputError::UnknownColumn { .. }), "{err}");
    }
}
