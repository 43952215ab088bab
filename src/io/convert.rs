//! Arrow arrays to `f64` samples in SI units, and time columns to seconds.

use arrow_array::cast::AsArray;
use arrow_array::types::*;
use arrow_array::{Array, ArrayRef, ArrowPrimitiveType};
use arrow_schema::DataType;

use super::channels::{TimeEncoding, TimeSpec};

/// Appends `array`'s values to `out` as `v · factor + offset`; a null becomes NaN so that the quality
/// stage reports it like any other missing sample.
///
/// Returns false when the array's type is not a sample type (the caller checked the schema, so this
/// only happens for a file whose batches contradict its own schema).
pub fn append_samples(array: &ArrayRef, factor: f64, offset: f64, out: &mut Vec<f64>) -> bool {
    fn push<T: ArrowPrimitiveType>(
        array: &ArrayRef,
        out: &mut Vec<f64>,
        f: impl Fn(T::Native) -> f64,
    ) {
        let a = array.as_primitive::<T>();
        if a.null_count() == 0 {
            out.extend(a.values().iter().map(|&v| f(v)));
        } else {
            out.extend(a.iter().map(|v| v.map(&f).unwrap_or(f64::NAN)));
        }
    }
    let lin = |v: f64| v * factor + offset;
    match array.data_type() {
        DataType::Float64 => push::<Float64Type>(array, out, lin),
        DataType::Float32 => push::<Float32Type>(array, out, |v| lin(v as f64)),
        DataType::Int8 => push::<Int8Type>(array, out, |v| lin(v as f64)),
        DataType::Int16 => push::<Int16Type>(array, out, |v| lin(v as f64)),
        DataType::Int32 => push::<Int32Type>(array, out, |v| lin(v as f64)),
        DataType::Int64 => push::<Int64Type>(array, out, |v| lin(v as f64)),
        DataType::UInt8 => push::<UInt8Type>(array, out, |v| lin(v as f64)),
        DataType::UInt16 => push::<UInt16Type>(array, out, |v| lin(v as f64)),
        DataType::UInt32 => push::<UInt32Type>(array, out, |v| lin(v as f64)),
        DataType::UInt64 => push::<UInt64Type>(array, out, |v| lin(v as f64)),
        // Half floats, decimals and dictionaries of numbers: cast to f64 first (a copy of the
        // block; these are rare enough not to need a path of their own).
        t if super::channels::is_sample_type(t) => {
            match arrow_cast::cast(array, &DataType::Float64) {
                Ok(cast) => push::<Float64Type>(&cast, out, lin),
                Err(_) => return false,
            }
        }
        _ => return false,
    }
    true
}

/// Converts time values to seconds since `origin`, the file's first timestamp in its own ticks.
///
/// Integer ticks are subtracted as integers before the conversion to f64, so nanosecond epoch
/// timestamps (~1.7e18) keep their resolution. A null timestamp becomes NaN and is reported as
/// non-monotonic time by the quality stage.
pub struct TimeDecoder {
    encoding: TimeEncoding,
    origin_ticks: Option<i64>,
    /// The first value of a float column, in its stored units.
    origin_seconds: Option<f64>,
    /// The resolution of the values seen so far, in seconds (see [`TimeDecoder::resolution_s`]).
    resolution_s: f64,
}

impl TimeDecoder {
    pub fn new(spec: &TimeSpec) -> Self {
        TimeDecoder {
            encoding: spec.encoding,
            origin_ticks: None,
            origin_seconds: None,
            resolution_s: 0.0,
        }
    }

    /// How finely the stored values resolve time, in seconds: a tick for integers, the spacing
    /// of the column's floats (f32 or f64) at the largest magnitude seen for floats.
    pub fn resolution_s(&self) -> f64 {
        self.resolution_s
    }

    /// Appends seconds since the first timestamp; false for an unexpected array type.
    pub fn append(&mut self, array: &ArrayRef, out: &mut Vec<f64>) -> bool {
        match self.encoding {
            TimeEncoding::Float { seconds_per_unit } => {
                // The first value is subtracted in stored units, before scaling: epoch milliseconds
                // (~1.7e12) scaled first would keep only ~0.2 µs of resolution.
                let start = out.len();
                let ok = append_samples(array, 1.0, 0.0, out);
                let largest = out[start..]
                    .iter()
                    .filter(|v| v.is_finite())
                    .fold(0.0f64, |m, v| m.max(v.abs()));
                let spacing = if array.data_type() == &DataType::Float32 {
                    let a = largest as f32;
                    (f32::from_bits(a.to_bits() + 1) - a) as f64
                } else {
                    crate::stats::float_spacing(largest)
                };
                self.resolution_s = self.resolution_s.max(spacing * seconds_per_unit.abs());
                if let Some(&first) = out[start..].iter().find(|v| v.is_finite()) {
                    let origin = *self.origin_seconds.get_or_insert(first);
                    for v in &mut out[start..] {
                        *v = (*v - origin) * seconds_per_unit;
                    }
                }
                ok
            }
            TimeEncoding::Timestamp { seconds_per_tick }
            | TimeEncoding::IntegerTicks { seconds_per_tick } => {
                self.resolution_s = seconds_per_tick.abs();
                let Some(ticks) = integer_ticks(array) else {
                    return false;
                };
                for t in ticks {
                    match t {
                        Some(t) => {
                            let origin = *self.origin_ticks.get_or_insert(t);
                            out.push(t.wrapping_sub(origin) as f64 * seconds_per_tick);
                        }
                        None => out.push(f64::NAN),
                    }
                }
                true
            }
        }
    }
}

fn integer_ticks(array: &ArrayRef) -> Option<Vec<Option<i64>>> {
    fn collect<T: ArrowPrimitiveType>(
        a: &ArrayRef,
        f: impl Fn(T::Native) -> i64,
    ) -> Vec<Option<i64>> {
        a.as_primitive::<T>().iter().map(|v| v.map(&f)).collect()
    }
    Some(match array.data_type() {
        DataType::Timestamp(unit, _) => {
            use arrow_schema::TimeUnit::*;
            match unit {
                Second => collect::<TimestampSecondType>(array, |v| v),
                Millisecond => collect::<TimestampMillisecondType>(array, |v| v),
                Microsecond => collect::<TimestampMicrosecondType>(array, |v| v),
                Nanosecond => collect::<TimestampNanosecondType>(array, |v| v),
            }
        }
        DataType::Int8 => collect::<Int8Type>(array, |v| v as i64),
        DataType::Int16 => collect::<Int16Type>(array, |v| v as i64),
        DataType::Int32 => collect::<Int32Type>(array, |v| v as i64),
        DataType::Int64 => collect::<Int64Type>(array, |v| v),
        DataType::UInt8 => collect::<UInt8Type>(array, |v| v as i64),
        DataType::UInt16 => collect::<UInt16Type>(array, |v| v as i64),
        DataType::UInt32 => collect::<UInt32Type>(array, |v| v as i64),
        DataType::UInt64 => collect::<UInt64Type>(array, |v| v as i64),
        _ => return None,
    })
}
