//! The rows as Arrow record batches in Parquet files: one part file per input, the fleet table.
//!
//! Part files carry their provenance in the Parquet footer's key–value metadata (the input's
//! identity, the options' hash, the schema version, the status), so that a rerun decides whether
//! to skip an input by reading a footer, not the rows. Every file is written under a temporary
//! name and renamed ([`crate::report::write_atomically`]): a reader (or a rerun after a crash)
//! sees a whole file or none.
//!
//! Columns (SI values; one row per channel): `sensor`, `path`, `rel`, `key`, `status`
//! (`ok`/`error`), `error`, `error_column`, `error_row` (where the error names a place),
//! `channel_index`, `channel`, `kind` (`gyro`/`accel`), `rate_hz`,
//! `duration_s`, `samples`, `mean` (the channel's mean, SI), `analysed`, per term `q_`/`n_`/`b_`/`k_`/`r_` + `value`, `lo`, `hi`,
//! `upper` (the upper limit where there is no value), `confidence` (two-sided probability of the
//! intervals), `effects` (comma-joined kinds),
//! `effects_detail` (list), `effects_delta_bic` (list: each effect's ΔBIC), `quality` (comma-joined verdicts), `quality_detail` (list),
//! `warnings` (list). The fleet table adds per term `limit`, `verdict`, `basis`, `z`,
//! `fleet_median`, `outlier`, and `unusual_effects`, `flagged`, `reasons`.

use std::fs::File;
use std::path::Path;
use std::sync::Arc;

use arrow_array::builder::{
    BooleanBuilder, Float64Builder, ListBuilder, StringBuilder, UInt32Builder, UInt64Builder,
};
use arrow_array::{
    Array, ArrayRef, BooleanArray, Float64Array, ListArray, RecordBatch, StringArray, UInt32Array,
    UInt64Array,
};
use arrow_schema::{DataType, Field, Schema};
use parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder;
use parquet::arrow::ArrowWriter;
use parquet::basic::Compression;
use parquet::file::metadata::KeyValue;
use parquet::file::properties::WriterProperties;

use crate::model::{Sensor, Term};
use crate::report::write_atomically;

use super::assess::FleetRow;
use super::record::{ChannelRecord, Status, TermValues};
use super::{ScreenError, SCHEMA_VERSION};

/// Footer keys of a part file.
const META_IDENTITY: &str = "imunoise.screen.identity";
const META_OPTIONS: &str = "imunoise.screen.options";
const META_SCHEMA: &str = "imunoise.screen.schema";
const META_STATUS: &str = "imunoise.screen.status";
const META_KEY: &str = "imunoise.screen.key";

/// What a part file's footer says about it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct PartMeta {
    /// [`super::hash::file_identity`] of the input it was computed from.
    pub identity: String,
    /// [`super::hash::options_hash`] of the options it was computed with.
    pub options: String,
    pub schema: u32,
    pub status: Status,
    pub key: String,
}

/// Lower-case name of a sensor kind, as in the tables.
pub fn sensor_name(s: Sensor) -> &'static str {
    match s {
        Sensor::Gyro => "gyro",
        Sensor::Accel => "accel",
    }
}

fn parse_sensor(s: &str) -> Option<Sensor> {
    match s {
        "gyro" => Some(Sensor::Gyro),
        "accel" => Some(Sensor::Accel),
        _ => None,
    }
}

/// The column prefix of a term: `q`, `n`, `b`, `k`, `r`.
pub fn term_prefix(t: Term) -> String {
    t.symbol().to_ascii_lowercase()
}

fn list_type() -> DataType {
    DataType::List(Arc::new(Field::new("item", DataType::Utf8, true)))
}

/// Named columns, in order.
type Columns = Vec<(Field, ArrayRef)>;

/// Builders for the columns every table shares.
struct Common {
    sensor: StringBuilder,
    path: StringBuilder,
    rel: StringBuilder,
    key: StringBuilder,
    status: StringBuilder,
    error: StringBuilder,
    error_column: StringBuilder,
    error_row: UInt64Builder,
    channel_index: UInt32Builder,
    channel: StringBuilder,
    kind: StringBuilder,
    rate_hz: Float64Builder,
    duration_s: Float64Builder,
    samples: UInt64Builder,
    mean: Float64Builder,
    analysed: BooleanBuilder,
    terms: Vec<[Float64Builder; 6]>,
    ambiguous: Vec<BooleanBuilder>,
    confidence: Float64Builder,
    effects: StringBuilder,
    effects_detail: ListBuilder<StringBuilder>,
    effects_delta_bic: ListBuilder<Float64Builder>,
    quality: StringBuilder,
    quality_detail: ListBuilder<StringBuilder>,
    warnings: ListBuilder<StringBuilder>,
}

fn push_list(b: &mut ListBuilder<StringBuilder>, items: &[String]) {
    for s in items {
        b.values().append_value(s);
    }
    b.append(true);
}

impl Common {
    fn new() -> Self {
        Common {
            sensor: StringBuilder::new(),
            path: StringBuilder::new(),
            rel: StringBuilder::new(),
            key: StringBuilder::new(),
            status: StringBuilder::new(),
            error: StringBuilder::new(),
            error_column: StringBuilder::new(),
            error_row: UInt64Builder::new(),
            channel_index: UInt32Builder::new(),
            channel: StringBuilder::new(),
            kind: StringBuilder::new(),
            rate_hz: Float64Builder::new(),
            duration_s: Float64Builder::new(),
            samples: UInt64Builder::new(),
            mean: Float64Builder::new(),
            analysed: BooleanBuilder::new(),
            terms: (0..5)
                .map(|_| std::array::from_fn(|_| Float64Builder::new()))
                .collect(),
            ambiguous: (0..5).map(|_| BooleanBuilder::new()).collect(),
            confidence: Float64Builder::new(),
            effects: StringBuilder::new(),
            effects_detail: ListBuilder::new(StringBuilder::new()),
            effects_delta_bic: ListBuilder::new(Float64Builder::new()),
            quality: StringBuilder::new(),
            quality_detail: ListBuilder::new(StringBuilder::new()),
            warnings: ListBuilder::new(StringBuilder::new()),
        }
    }

    fn push(&mut self, r: &ChannelRecord) {
        self.sensor.append_value(&r.sensor);
        self.path.append_value(&r.path);
        self.rel.append_value(&r.rel);
        self.key.append_value(&r.key);
        self.status.append_value(r.status.as_str());
        self.error.append_option(r.error.as_deref());
        self.error_column.append_option(r.error_column.as_deref());
        self.error_row.append_option(r.error_row);
        self.channel_index.append_option(r.channel_index);
        self.channel.append_option(r.channel.as_deref());
        self.kind.append_option(r.kind.map(sensor_name));
        self.rate_hz.append_option(r.rate_hz);
        self.duration_s.append_option(r.duration_s);
        self.samples.append_option(r.samples);
        self.mean.append_option(r.mean);
        self.analysed.append_value(r.analysed);
        for (b, t) in self.terms.iter_mut().zip(&r.terms) {
            b[0].append_option(t.value);
            b[1].append_option(t.lo);
            b[2].append_option(t.hi);
            b[3].append_option(t.upper);
            b[4].append_option(t.lo_one_sigma);
            b[5].append_option(t.hi_one_sigma);
        }
        for (b, t) in self.ambiguous.iter_mut().zip(&r.terms) {
            b.append_value(t.ambiguous);
        }
        self.confidence.append_option(r.confidence);
        self.effects.append_value(r.effects.join(","));
        push_list(&mut self.effects_detail, &r.effects_detail);
        for &d in &r.effects_delta_bic {
            self.effects_delta_bic.values().append_value(d);
        }
        self.effects_delta_bic.append(true);
        self.quality.append_value(r.quality.join(","));
        push_list(&mut self.quality_detail, &r.quality_detail);
        push_list(&mut self.warnings, &r.warnings);
    }

    /// (head columns, term columns, tail columns) as fields and arrays.
    fn finish(mut self) -> (Columns, Vec<Columns>, Columns) {
        let s = |name: &str, a: ArrayRef| (Field::new(name, a.data_type().clone(), true), a);
        let head = vec![
            s("sensor", Arc::new(self.sensor.finish())),
            s("path", Arc::new(self.path.finish())),
            s("rel", Arc::new(self.rel.finish())),
            s("key", Arc::new(self.key.finish())),
            s("status", Arc::new(self.status.finish())),
            s("error", Arc::new(self.error.finish())),
            s("error_column", Arc::new(self.error_column.finish())),
            s("error_row", Arc::new(self.error_row.finish())),
            s("channel_index", Arc::new(self.channel_index.finish())),
            s("channel", Arc::new(self.channel.finish())),
            s("kind", Arc::new(self.kind.finish())),
            s("rate_hz", Arc::new(self.rate_hz.finish())),
            s("duration_s", Arc::new(self.duration_s.finish())),
            s("samples", Arc::new(self.samples.finish())),
            s("mean", Arc::new(self.mean.finish())),
            s("analysed", Arc::new(self.analysed.finish())),
        ];
        let terms = Term::ALL
            .iter()
            .zip(self.terms.iter_mut())
            .map(|(t, b)| {
                let p = term_prefix(*t);
                ["value", "lo", "hi", "upper", "lo_1sigma", "hi_1sigma"]
                    .iter()
                    .zip(b.iter_mut())
                    .map(|(what, b)| s(&format!("{p}_{what}"), Arc::new(b.finish())))
                    .chain([s(
                        &format!("{p}_ambiguous"),
                        Arc::new(self.ambiguous[t.index()].finish()),
                    )])
                    .collect()
            })
            .collect();
        let list = |name: &str, a: ArrayRef| (Field::new(name, list_type(), true), a);
        let tail = vec![
            s("confidence", Arc::new(self.confidence.finish())),
            s("effects", Arc::new(self.effects.finish())),
            list("effects_detail", Arc::new(self.effects_detail.finish())),
            s(
                "effects_delta_bic",
                Arc::new(self.effects_delta_bic.finish()),
            ),
            s("quality", Arc::new(self.quality.finish())),
            list("quality_detail", Arc::new(self.quality_detail.finish())),
            list("warnings", Arc::new(self.warnings.finish())),
        ];
        (head, terms, tail)
    }
}

fn batch(columns: Columns) -> Result<RecordBatch, arrow_schema::ArrowError> {
    let (fields, arrays): (Vec<Field>, Vec<ArrayRef>) = columns.into_iter().unzip();
    RecordBatch::try_new(Arc::new(Schema::new(fields)), arrays)
}

/// The part-file batch of `records`.
pub fn records_batch(records: &[ChannelRecord]) -> Result<RecordBatch, arrow_schema::ArrowError> {
    let mut c = Common::new();
    for r in records {
        c.push(r);
    }
    let (head, terms, tail) = c.finish();
    batch(
        head.into_iter()
            .chain(terms.into_iter().flatten())
            .chain(tail)
            .collect(),
    )
}

/// Writes `batch` to `path` atomically as Parquet (Snappy), with `metadata` in the footer.
pub fn write_parquet(
    path: &Path,
    batch: &RecordBatch,
    metadata: Vec<(String, String)>,
) -> Result<(), ScreenError> {
    let props = WriterProperties::builder()
        .set_compression(Compression::SNAPPY)
        .set_key_value_metadata(Some(
            metadata
                .into_iter()
                .map(|(k, v)| KeyValue::new(k, v))
                .collect(),
        ))
        .build();
    write_atomically(path, |w| {
        let mut writer = ArrowWriter::try_new(w, batch.schema(), Some(props))?;
        writer.write(batch)?;
        writer.close().map(|_| ())
    })?;
    Ok(())
}

/// Writes the part file of one input.
pub fn write_part(
    path: &Path,
    records: &[ChannelRecord],
    meta: &PartMeta,
) -> Result<(), ScreenError> {
    let b = records_batch(records).map_err(|e| ScreenError::output(path, e))?;
    write_parquet(
        path,
        &b,
        vec![
            (META_IDENTITY.into(), meta.identity.clone()),
            (META_OPTIONS.into(), meta.options.clone()),
            (META_SCHEMA.into(), meta.schema.to_string()),
            (META_STATUS.into(), meta.status.as_str().into()),
            (META_KEY.into(), meta.key.clone()),
        ],
    )
}

/// The footer of a part file; `None` when it is missing, unreadable or not one of ours.
pub fn read_part_meta(path: &Path) -> Option<PartMeta> {
    let file = File::open(path).ok()?;
    let builder = ParquetRecordBatchReaderBuilder::try_new(file).ok()?;
    let kv = builder.metadata().file_metadata().key_value_metadata()?;
    let get = |k: &str| kv.iter().find(|e| e.key == k).and_then(|e| e.value.clone());
    Some(PartMeta {
        identity: get(META_IDENTITY)?,
        options: get(META_OPTIONS)?,
        schema: get(META_SCHEMA)?.parse().ok()?,
        status: match get(META_STATUS)?.as_str() {
            "ok" => Status::Ok,
            "error" => Status::Error,
            _ => return None,
        },
        key: get(META_KEY)?,
    })
}

fn column<'a, T: 'static>(b: &'a RecordBatch, name: &str) -> Result<&'a T, String> {
    b.column_by_name(name)
        .ok_or_else(|| format!("no column {name}"))?
        .as_any()
        .downcast_ref::<T>()
        .ok_or_else(|| {
            format!(
                "column {name} has type {:?}",
                b.column_by_name(name).map(|c| c.data_type().clone())
            )
        })
}

fn opt<T>(valid: bool, v: T) -> Option<T> {
    valid.then_some(v)
}

fn list_numbers(a: &ListArray, i: usize) -> Vec<f64> {
    if a.is_null(i) {
        return Vec::new();
    }
    let v = a.value(i);
    match v.as_any().downcast_ref::<Float64Array>() {
        Some(x) => (0..x.len())
            .map(|j| if x.is_valid(j) { x.value(j) } else { f64::NAN })
            .collect(),
        None => Vec::new(),
    }
}

fn list_items(a: &ListArray, i: usize) -> Vec<String> {
    if a.is_null(i) {
        return Vec::new();
    }
    let v = a.value(i);
    match v.as_any().downcast_ref::<StringArray>() {
        Some(s) => (0..s.len())
            .filter(|&j| s.is_valid(j))
            .map(|j| s.value(j).to_string())
            .collect(),
        None => Vec::new(),
    }
}

fn split_joined(s: &str) -> Vec<String> {
    if s.is_empty() {
        Vec::new()
    } else {
        s.split(',').map(str::to_string).collect()
    }
}

/// The rows of a part file.
pub fn read_part(path: &Path) -> Result<Vec<ChannelRecord>, ScreenError> {
    let fail = |e: &dyn std::fmt::Display| ScreenError::output(path, e);
    let file = File::open(path).map_err(|e| fail(&e))?;
    let reader = ParquetRecordBatchReaderBuilder::try_new(file)
        .and_then(|b| b.build())
        .map_err(|e| fail(&e))?;
    let mut out = Vec::new();
    for b in reader {
        let b = b.map_err(|e| fail(&e))?;
        records_from_batch(&b, &mut out).map_err(|e| fail(&e))?;
    }
    Ok(out)
}

fn records_from_batch(b: &RecordBatch, out: &mut Vec<ChannelRecord>) -> Result<(), String> {
    let text = |n: &str| column::<StringArray>(b, n);
    let (sensor, path, rel, key, status, error) = (
        text("sensor")?,
        text("path")?,
        text("rel")?,
        text("key")?,
        text("status")?,
        text("error")?,
    );
    let error_column = text("error_column")?;
    let error_row = column::<UInt64Array>(b, "error_row")?;
    let channel_index = column::<UInt32Array>(b, "channel_index")?;
    let (channel, kind) = (text("channel")?, text("kind")?);
    let rate = column::<Float64Array>(b, "rate_hz")?;
    let duration = column::<Float64Array>(b, "duration_s")?;
    let samples = column::<UInt64Array>(b, "samples")?;
    let mean = column::<Float64Array>(b, "mean")?;
    let analysed = column::<BooleanArray>(b, "analysed")?;
    let mut terms: Vec<[&Float64Array; 4]> = Vec::new();
    let mut one_sigma: Vec<[&Float64Array; 2]> = Vec::new();
    let mut ambiguous: Vec<&BooleanArray> = Vec::new();
    for t in Term::ALL {
        let p = term_prefix(t);
        terms.push([
            column::<Float64Array>(b, &format!("{p}_value"))?,
            column::<Float64Array>(b, &format!("{p}_lo"))?,
            column::<Float64Array>(b, &format!("{p}_hi"))?,
            column::<Float64Array>(b, &format!("{p}_upper"))?,
        ]);
        one_sigma.push([
            column::<Float64Array>(b, &format!("{p}_lo_1sigma"))?,
            column::<Float64Array>(b, &format!("{p}_hi_1sigma"))?,
        ]);
        ambiguous.push(column::<BooleanArray>(b, &format!("{p}_ambiguous"))?);
    }
    let confidence = column::<Float64Array>(b, "confidence")?;
    let (effects, quality) = (text("effects")?, text("quality")?);
    let effects_detail = column::<ListArray>(b, "effects_detail")?;
    let effects_delta_bic = column::<ListArray>(b, "effects_delta_bic")?;
    let quality_detail = column::<ListArray>(b, "quality_detail")?;
    let warnings = column::<ListArray>(b, "warnings")?;
    let f = |a: &Float64Array, i: usize| opt(a.is_valid(i), a.value(i));
    let s = |a: &StringArray, i: usize| opt(a.is_valid(i), a.value(i).to_string());
    for i in 0..b.num_rows() {
        let mut tv = [TermValues::default(); 5];
        for (((slot, cols), amb), one) in tv.iter_mut().zip(&terms).zip(&ambiguous).zip(&one_sigma)
        {
            *slot = TermValues {
                value: f(cols[0], i),
                lo: f(cols[1], i),
                hi: f(cols[2], i),
                upper: f(cols[3], i),
                lo_one_sigma: f(one[0], i),
                hi_one_sigma: f(one[1], i),
                ambiguous: amb.is_valid(i) && amb.value(i),
            };
        }
        out.push(ChannelRecord {
            sensor: sensor.value(i).to_string(),
            path: path.value(i).to_string(),
            rel: rel.value(i).to_string(),
            key: key.value(i).to_string(),
            status: if status.value(i) == "ok" {
                Status::Ok
            } else {
                Status::Error
            },
            error: s(error, i),
            error_column: s(error_column, i),
            error_row: opt(error_row.is_valid(i), error_row.value(i)),
            channel_index: opt(channel_index.is_valid(i), channel_index.value(i)),
            channel: s(channel, i),
            kind: s(kind, i).and_then(|k| parse_sensor(&k)),
            rate_hz: f(rate, i),
            duration_s: f(duration, i),
            samples: opt(samples.is_valid(i), samples.value(i)),
            mean: f(mean, i),
            analysed: analysed.is_valid(i) && analysed.value(i),
            terms: tv,
            confidence: f(confidence, i),
            effects: split_joined(effects.value(i)),
            effects_detail: list_items(effects_detail, i),
            effects_delta_bic: list_numbers(effects_delta_bic, i),
            quality: split_joined(quality.value(i)),
            quality_detail: list_items(quality_detail, i),
            warnings: list_items(warnings, i),
        });
    }
    Ok(())
}

/// The fleet table: the part columns plus, per term, the limit, the verdict and its basis, the
/// robust z, the fleet median and the outlier flag; then the unusual effects, whether the channel
/// is flagged and why.
pub fn fleet_batch(rows: &[FleetRow]) -> Result<RecordBatch, arrow_schema::ArrowError> {
    let mut c = Common::new();
    let mut limit: Vec<Float64Builder> = (0..5).map(|_| Float64Builder::new()).collect();
    let mut verdict: Vec<StringBuilder> = (0..5).map(|_| StringBuilder::new()).collect();
    let mut basis: Vec<StringBuilder> = (0..5).map(|_| StringBuilder::new()).collect();
    let mut z: Vec<Float64Builder> = (0..5).map(|_| Float64Builder::new()).collect();
    let mut median: Vec<Float64Builder> = (0..5).map(|_| Float64Builder::new()).collect();
    let mut outlier: Vec<BooleanBuilder> = (0..5).map(|_| BooleanBuilder::new()).collect();
    let mut unusual = StringBuilder::new();
    let mut flagged = BooleanBuilder::new();
    let mut reasons = ListBuilder::new(StringBuilder::new());
    for r in rows {
        c.push(&r.record);
        for (i, a) in r.terms.iter().enumerate() {
            limit[i].append_option(a.limit);
            verdict[i].append_option(a.verdict.map(|v| v.as_str()));
            basis[i].append_option(a.basis.map(|b| b.as_str()));
            z[i].append_option(a.z);
            median[i].append_option(a.median);
            outlier[i].append_value(a.outlier);
        }
        unusual.append_value(
            r.unusual_effects
                .iter()
                .map(|u| u.kind.as_str())
                .collect::<Vec<_>>()
                .join(","),
        );
        flagged.append_value(r.flagged);
        push_list(&mut reasons, &r.reasons);
    }
    let (head, terms, tail) = c.finish();
    let mut columns = head;
    let f = |name: String, a: ArrayRef| (Field::new(name, a.data_type().clone(), true), a);
    for (i, (t, cols)) in Term::ALL.iter().zip(terms).enumerate() {
        let p = term_prefix(*t);
        columns.extend(cols);
        columns.push(f(format!("{p}_limit"), Arc::new(limit[i].finish())));
        columns.push(f(format!("{p}_verdict"), Arc::new(verdict[i].finish())));
        columns.push(f(format!("{p}_basis"), Arc::new(basis[i].finish())));
        columns.push(f(format!("{p}_z"), Arc::new(z[i].finish())));
        columns.push(f(format!("{p}_fleet_median"), Arc::new(median[i].finish())));
        columns.push(f(format!("{p}_outlier"), Arc::new(outlier[i].finish())));
    }
    columns.extend(tail);
    columns.push(f("unusual_effects".into(), Arc::new(unusual.finish())));
    columns.push(f("flagged".into(), Arc::new(flagged.finish())));
    columns.push((
        Field::new("reasons", list_type(), true),
        Arc::new(reasons.finish()),
    ));
    batch(columns)
}

/// Writes the fleet table to `path` atomically.
pub fn write_fleet(path: &Path, rows: &[FleetRow]) -> Result<(), ScreenError> {
    let b = fleet_batch(rows).map_err(|e| ScreenError::output(path, e))?;
    write_parquet(
        path,
        &b,
        vec![(META_SCHEMA.into(), SCHEMA_VERSION.to_string())],
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    fn record() -> ChannelRecord {
        let input = super::super::Input {
            path: "fleet/a.arrow".into(),
            rel: "a.arrow".into(),
            sensor: "a".into(),
            key: "a-0000000000000001".into(),
            hash: 1,
        };
        let mut r = ChannelRecord::error(&input, "boom".into());
        r.status = Status::Ok;
        r.error = None;
        r.channel = Some("gyro_x".into());
        r.channel_index = Some(1);
        r.kind = Some(Sensor::Gyro);
        r.rate_hz = Some(100.0);
        r.samples = Some(18000);
        r.analysed = true;
        r.terms[1] = TermValues {
            value: Some(4e-5),
            lo: Some(3.9e-5),
            hi: Some(4.1e-5),
            upper: None,
            lo_one_sigma: Some(3.9e-5),
            hi_one_sigma: Some(4.1e-5),
            ambiguous: false,
        };
        r.terms[4].upper = Some(1e-9);
        r.confidence = Some(0.6827);
        r.effects = vec!["sinusoid".into(), "step".into()];
        r.effects_detail = vec!["line at 7 Hz; big".into(), "step, at 3 s".into()];
        r.warnings = vec!["w1".into()];
        r
    }

    #[test]
    fn a_part_file_round_trips_with_its_footer() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("part-a.parquet");
        let input = super::super::Input {
            path: "fleet/b.csv".into(),
            rel: "b.csv".into(),
            sensor: "b".into(),
            key: "b-2".into(),
            hash: 2,
        };
        let rows = vec![
            record(),
            ChannelRecord::error(&input, "no such file".into()),
        ];
        let meta = PartMeta {
            identity: "size=1".into(),
            options: "abc".into(),
            schema: SCHEMA_VERSION,
            status: Status::Ok,
            key: "a-0000000000000001".into(),
        };
        write_part(&p, &rows, &meta).unwrap();
        assert_eq!(read_part_meta(&p), Some(meta));
        assert_eq!(read_part(&p).unwrap(), rows);
        // Not one of ours (or half a file): no footer to trust.
        std::fs::write(&p, b"PAR1 garbage").unwrap();
        assert_eq!(read_part_meta(&p), None);
    }
}
