//! MCAP files (the ROS 2 bag format) presented as an Arrow schema and record batches, so that the
//! rest of imunoise reads them like any other recording.
//!
//! One IMU topic (`sensor_msgs/msg/Imu`) becomes the recording: `time` (Arrow timestamp, ns) from each
//! message's header stamp, `gyro_x/y/z` (rad/s) from `angular_velocity`, `accel_x/y/z` (m/s²) from
//! `linear_acceleration`. Every `sensor_msgs/msg/Temperature` topic joins as a temperature column
//! (°C) whose value at each IMU stamp is the latest reading stamped at or before it (before the
//! first reading: the first reading). Orientation and covariances are not read, except for the ROS
//! convention that element 0 of a covariance set to −1 means "no estimate": a gyro or accelerometer
//! so marked in the topic's first message is left out rather than read as zeros.
//!
//! Messages may be CDR (ROS 2) or ROS 1 serialised (MCAP files converted from ROS 1 bags by
//! `mcap convert`); both are decoded here by hand, bounds-checked, for these two message types only.
//! The file is streamed message by message with foxglove's `mcap` crate through its `io::MessageReader`
//! (memory: one decompressed chunk plus one batch, whatever the file's size; no memory map, so a file
//! shrinking under the reader is an error, not a SIGBUS). Temperature topics, a few readings a
//! second, are collected whole in a first pass over the file.
//!
//! The schema carries everything the batches need: schema metadata `topic` (the IMU topic) and, per
//! field, `topic` and `ros_field` (which field of which topic fills the column). [`open_batches`]
//! therefore needs nothing beyond the schema [`read_schema`] returned.

use std::collections::{BTreeMap, HashMap};
use std::fs::File;
use std::io::{BufReader, Read, Seek, SeekFrom};
use std::path::Path;
use std::sync::Arc;

use ::mcap::io::MessageReader;
use ::mcap::sans_io::{LinearReaderOptions, SummaryReadEvent, SummaryReader, SummaryReaderOptions};
use ::mcap::{Channel, McapError};
use arrow_array::{
    ArrayRef, Float64Array, RecordBatch, RecordBatchOptions, TimestampNanosecondArray,
};
use arrow_schema::{DataType, Field, Schema, SchemaRef, TimeUnit};

use super::format::Format;
use super::InputError;

/// Schema metadata key naming the IMU topic; field metadata key naming a column's topic.
const TOPIC_KEY: &str = "topic";
/// Field metadata key naming the message field a column is read from.
const ROS_FIELD_KEY: &str = "ros_field";

const IMU_COLUMNS: [(&str, &str, &str, &str); 6] = [
    ("gyro_x", "angular_velocity.x", "rad/s", "gyro"),
    ("gyro_y", "angular_velocity.y", "rad/s", "gyro"),
    ("gyro_z", "angular_velocity.z", "rad/s", "gyro"),
    ("accel_x", "linear_acceleration.x", "m/s^2", "accel"),
    ("accel_y", "linear_acceleration.y", "m/s^2", "accel"),
    ("accel_z", "linear_acceleration.z", "m/s^2", "accel"),
];
const STAMP_FIELD: &str = "header.stamp";
const TEMPERATURE_FIELD: &str = "temperature";

/// How a channel's messages are serialised.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Encoding {
    /// ROS 2: a 4-byte encapsulation header, then plain CDR (XCDR1), little or big endian.
    Cdr,
    /// ROS 1: little endian, packed, no header.
    Ros1,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum MessageType {
    Imu,
    Temperature,
}

/// The message type and encoding of a channel, if it is one imunoise reads: message encoding `cdr`
/// with a ROS 2 schema (`ros2msg` or `ros2idl`) named `sensor_msgs/msg/Imu|Temperature`, or `ros1`
/// with a `ros1msg` schema named `sensor_msgs/Imu|Temperature`.
fn classify(
    message_encoding: &str,
    schema: Option<(&str, &str)>,
) -> Option<(MessageType, Encoding)> {
    let (name, schema_encoding) = schema?;
    let encoding = match (message_encoding, schema_encoding) {
        ("cdr", "ros2msg" | "ros2idl") => Encoding::Cdr,
        ("ros1", "ros1msg") => Encoding::Ros1,
        _ => return None,
    };
    let kind = match (encoding, name) {
        (Encoding::Cdr, "sensor_msgs/msg/Imu") | (Encoding::Ros1, "sensor_msgs/Imu") => {
            MessageType::Imu
        }
        (Encoding::Cdr, "sensor_msgs/msg/Temperature")
        | (Encoding::Ros1, "sensor_msgs/Temperature") => MessageType::Temperature,
        _ => return None,
    };
    Some((kind, encoding))
}

fn classify_channel(channel: &Channel) -> Option<(MessageType, Encoding)> {
    classify(
        &channel.message_encoding,
        channel
            .schema
            .as_ref()
            .map(|s| (s.name.as_str(), s.encoding.as_str())),
    )
}

/// One channel of the file, as the summary (or a scan) lists it.
#[derive(Debug, Clone)]
struct ChannelInfo {
    topic: String,
    type_name: String,
    kind: Option<(MessageType, Encoding)>,
    /// From the summary's statistics or the scan; `None` when the summary has no statistics.
    messages: Option<u64>,
}

impl ChannelInfo {
    fn from_channel(channel: &Channel, messages: Option<u64>) -> Self {
        ChannelInfo {
            topic: channel.topic.clone(),
            type_name: match &channel.schema {
                Some(s) => format!("{}, {}", s.name, channel.message_encoding),
                None => format!("no schema, {}", channel.message_encoding),
            },
            kind: classify_channel(channel),
            messages,
        }
    }

    fn is(&self, kind: MessageType) -> bool {
        self.kind.map(|k| k.0) == Some(kind) && self.messages != Some(0)
    }

    fn describe(&self) -> String {
        match self.messages {
            Some(n) => format!("{} ({}, {n} messages)", self.topic, self.type_name),
            None => format!("{} ({})", self.topic, self.type_name),
        }
    }
}

fn corrupt(path: &Path, message: impl ToString) -> InputError {
    InputError::Corrupt {
        path: path.to_path_buf(),
        format: Format::Mcap.as_str(),
        row: None,
        message: message.to_string(),
    }
}

/// An MCAP reader error, with what to do about a truncated file.
fn reader_error(e: &McapError, messages_read: u64) -> String {
    let hint = match e {
        McapError::UnexpectedEof | McapError::BadMagic | McapError::BadFooter => {
            "; a recording cut short (the recorder was killed) can be salvaged with \
             `mcap recover IN.mcap -o OUT.mcap` (foxglove's mcap CLI)"
        }
        _ => "",
    };
    format!("{e} (after {messages_read} messages of all topics){hint}")
}

fn options(file_len: u64) -> LinearReaderOptions {
    LinearReaderOptions::default()
        .with_validate_chunk_crcs(true)
        .with_record_length_limit(usize::try_from(file_len).unwrap_or(usize::MAX))
}

/// A message reader over the whole file, from its start. The passes over a file (summary, scan,
/// first message, temperatures, IMU messages) run one after the other, each seeking to the start.
fn messages<F: Read + Seek>(mut file: F, len: u64) -> std::io::Result<MessageReader<BufReader<F>>> {
    file.seek(SeekFrom::Start(0))?;
    Ok(MessageReader::new_with_options(
        BufReader::with_capacity(1 << 16, file),
        options(len),
    ))
}

fn file_len(file: &File) -> std::io::Result<u64> {
    file.metadata().map(|m| m.len())
}

/// The channels the summary section lists, with their message counts; `None` when the file has no
/// usable summary (a recording cut short, or written without one).
fn summary_channels(mut file: &File) -> Option<Vec<ChannelInfo>> {
    let len = file_len(file).ok()?;
    let mut reader = SummaryReader::new_with_options(
        SummaryReaderOptions::default()
            .with_file_size(len)
            .with_record_length_limit(usize::try_from(len).unwrap_or(usize::MAX)),
    );
    while let Some(event) = reader.next_event() {
        match event.ok()? {
            SummaryReadEvent::ReadRequest(n) => {
                let read = file.read(reader.insert(n)).ok()?;
                reader.notify_read(read);
            }
            SummaryReadEvent::SeekRequest(to) => {
                let pos = file.seek(to).ok()?;
                reader.notify_seeked(pos);
            }
        }
    }
    let summary = reader.finish()?;
    if summary.channels.is_empty() {
        return None;
    }
    let counts = summary.stats.as_ref().map(|s| &s.channel_message_counts);
    let mut channels: Vec<(u16, ChannelInfo)> = summary
        .channels
        .iter()
        .map(|(&id, c)| {
            let n = counts.map(|m| m.get(&id).copied().unwrap_or(0));
            (id, ChannelInfo::from_channel(c, n))
        })
        .collect();
    channels.sort_by_key(|(id, _)| *id);
    Some(channels.into_iter().map(|(_, c)| c).collect())
}

/// The channels found by reading every message (for files without a summary).
fn scan_channels(path: &Path, file: &File) -> Result<Vec<ChannelInfo>, InputError> {
    let mut seen: BTreeMap<u16, (Arc<Channel<'static>>, u64)> = BTreeMap::new();
    let reader = file_len(file).and_then(|len| messages(file, len));
    for (n, message) in reader.map_err(|e| corrupt(path, e))?.enumerate() {
        let message = message.map_err(|e| corrupt(path, reader_error(&e, n as u64)))?;
        seen.entry(message.channel.id)
            .or_insert_with(|| (message.channel.clone(), 0))
            .1 += 1;
    }
    Ok(seen
        .values()
        .map(|(c, count)| ChannelInfo::from_channel(c, Some(*count)))
        .collect())
}

/// The channels, described, comma-separated.
fn list(channels: &[&ChannelInfo]) -> String {
    if channels.is_empty() {
        return "none".to_string();
    }
    channels
        .iter()
        .map(|c| c.describe())
        .collect::<Vec<_>>()
        .join(", ")
}

/// `/imu/temperature` → `imu_temperature`: a column name from a topic.
fn column_name(topic: &str) -> String {
    let name: String = topic
        .chars()
        .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
        .collect();
    let name = name.trim_matches('_');
    if name.is_empty() {
        "temperature".to_string()
    } else {
        name.to_string()
    }
}

fn meta(pairs: &[(&str, &str)]) -> HashMap<String, String> {
    pairs
        .iter()
        .map(|(k, v)| (k.to_string(), v.to_string()))
        .collect()
}

/// Reads the channels of an MCAP file, chooses the IMU topic (`topic`, or the only one) and returns
/// the schema the batches will have. Reads the summary section and the topic's first message; a
/// file without a summary is scanned whole.
pub(super) fn read_schema(
    path: &Path,
    file: &File,
    topic: Option<&str>,
) -> Result<SchemaRef, InputError> {
    let channels = match summary_channels(file) {
        Some(c) => c,
        None => scan_channels(path, file)?,
    };
    let everything: Vec<&ChannelInfo> = channels.iter().collect();
    let mut imus: Vec<&ChannelInfo> = Vec::new();
    for c in channels.iter().filter(|c| c.is(MessageType::Imu)) {
        if !imus.iter().any(|i| i.topic == c.topic) {
            imus.push(c);
        }
    }
    let chosen = match topic {
        Some(t) => {
            if !channels
                .iter()
                .any(|c| c.topic == t && c.kind.map(|k| k.0) == Some(MessageType::Imu))
            {
                return Err(InputError::UnknownTopic {
                    path: path.to_path_buf(),
                    topic: t.to_string(),
                    imu_topics: list(&imus),
                    topics: list(&everything),
                });
            }
            t.to_string()
        }
        None => match imus.as_slice() {
            [one] => one.topic.clone(),
            [] => {
                return Err(InputError::NoImuTopic {
                    path: path.to_path_buf(),
                    topics: list(&everything),
                })
            }
            _ => {
                return Err(InputError::AmbiguousTopic {
                    path: path.to_path_buf(),
                    imu_topics: list(&imus),
                })
            }
        },
    };

    let unusable = |reason: &str| InputError::UnusableTopic {
        path: path.to_path_buf(),
        topic: chosen.clone(),
        reason: reason.to_string(),
    };
    let Some(first) = first_imu_message(path, file, &chosen)? else {
        return Err(unusable("it has no messages"));
    };
    // The ROS convention for a sensor the IMU lacks: element 0 of its covariance is -1.
    let has_gyro = first.gyro_covariance_0 != -1.0;
    let has_accel = first.accel_covariance_0 != -1.0;
    if !has_gyro && !has_accel {
        return Err(unusable(
            "its first message marks both angular_velocity and linear_acceleration as absent \
             (covariance element 0 = -1)",
        ));
    }

    let mut fields = vec![Field::new(
        "time",
        DataType::Timestamp(TimeUnit::Nanosecond, None),
        false,
    )
    .with_metadata(meta(&[(TOPIC_KEY, &chosen), (ROS_FIELD_KEY, STAMP_FIELD)]))];
    for (name, ros_field, unit, kind) in IMU_COLUMNS {
        if (kind == "gyro" && has_gyro) || (kind == "accel" && has_accel) {
            fields.push(
                Field::new(name, DataType::Float64, false).with_metadata(meta(&[
                    ("unit", unit),
                    ("kind", kind),
                    (TOPIC_KEY, &chosen),
                    (ROS_FIELD_KEY, ros_field),
                ])),
            );
        }
    }
    let mut temperature_topics: Vec<&str> = channels
        .iter()
        .filter(|c| c.is(MessageType::Temperature))
        .map(|c| c.topic.as_str())
        .collect();
    temperature_topics.sort_unstable();
    temperature_topics.dedup();
    for t in temperature_topics {
        let base = column_name(t);
        let mut name = base.clone();
        let mut k = 2;
        while fields.iter().any(|f| f.name() == &name) {
            name = format!("{base}_{k}");
            k += 1;
        }
        fields.push(
            Field::new(name, DataType::Float64, false).with_metadata(meta(&[
                ("unit", "degC"),
                ("kind", "temperature"),
                (TOPIC_KEY, t),
                (ROS_FIELD_KEY, TEMPERATURE_FIELD),
            ])),
        );
    }
    Ok(Arc::new(
        Schema::new(fields).with_metadata(meta(&[(TOPIC_KEY, &chosen)])),
    ))
}

/// The first message of the IMU topic, decoded; `None` when the topic has none.
fn first_imu_message(path: &Path, file: &File, topic: &str) -> Result<Option<Imu>, InputError> {
    let reader = file_len(file).and_then(|len| messages(file, len));
    for (n, message) in reader.map_err(|e| corrupt(path, e))?.enumerate() {
        let message = message.map_err(|e| corrupt(path, reader_error(&e, n as u64)))?;
        if message.channel.topic != topic {
            continue;
        }
        if let Some((MessageType::Imu, encoding)) = classify_channel(&message.channel) {
            return decode_imu(&message.data, encoding)
                .map(Some)
                .map_err(|e| corrupt(path, locate(topic, 0, message.log_time, &e)));
        }
    }
    Ok(None)
}

/// One line for the recording's notes: which topics were read and how.
pub(super) fn describe(schema: &Schema) -> String {
    let topic = schema.metadata().get(TOPIC_KEY).map_or("?", String::as_str);
    let has = |kind: &str| {
        schema
            .fields()
            .iter()
            .any(|f| f.metadata().get("kind").map(String::as_str) == Some(kind))
    };
    let mut text = format!("MCAP topic {topic}, times from the message header stamps");
    for (kind, field) in [
        ("gyro", "angular_velocity"),
        ("accel", "linear_acceleration"),
    ] {
        if !has(kind) {
            text.push_str(&format!(
                "; no {kind} channels ({field}_covariance[0] = -1: the IMU gives no {field})"
            ));
        }
    }
    let joined: Vec<String> = schema
        .fields()
        .iter()
        .filter(|f| f.metadata().get(ROS_FIELD_KEY).map(String::as_str) == Some(TEMPERATURE_FIELD))
        .map(|f| {
            format!(
                "{} from {}",
                f.name(),
                f.metadata().get(TOPIC_KEY).map_or("?", String::as_str)
            )
        })
        .collect();
    if !joined.is_empty() {
        text.push_str(&format!(
            "; temperature {} (latest reading at or before each sample)",
            joined.join(", ")
        ));
    }
    text
}

/// What fills a column.
#[derive(Debug, Clone)]
enum Column {
    Stamp,
    /// Index into [`IMU_COLUMNS`] and [`Imu::values`].
    Imu(usize),
    /// Index into the collected temperature series.
    Temperature(usize),
}

type Inner = Box<dyn Iterator<Item = Result<RecordBatch, String>> + Send>;

/// Streams the IMU topic's messages as record batches of `batch_rows` rows holding the columns of
/// `projection` (indices into `schema`, as returned by [`read_schema`]), in that order.
pub(super) fn open_batches(
    file: File,
    schema: &SchemaRef,
    projection: &[usize],
    batch_rows: usize,
) -> Result<Inner, String> {
    let topic = schema
        .metadata()
        .get(TOPIC_KEY)
        .ok_or("the schema names no MCAP topic")?
        .clone();
    let mut temperature_topics: Vec<String> = Vec::new();
    let mut columns = Vec::with_capacity(projection.len());
    for &i in projection {
        let field = schema.fields().get(i).ok_or("projection out of range")?;
        let not_read = || format!("column {:?} is not read from a message", field.name());
        let column = match field.metadata().get(ROS_FIELD_KEY).map(String::as_str) {
            Some(STAMP_FIELD) => Column::Stamp,
            Some(TEMPERATURE_FIELD) => {
                let t = field.metadata().get(TOPIC_KEY).ok_or_else(not_read)?;
                temperature_topics.push(t.clone());
                Column::Temperature(temperature_topics.len() - 1)
            }
            Some(f) => Column::Imu(
                IMU_COLUMNS
                    .iter()
                    .position(|c| c.1 == f)
                    .ok_or_else(not_read)?,
            ),
            None => return Err(not_read()),
        };
        columns.push(column);
    }
    let temperatures = if temperature_topics.is_empty() {
        Vec::new()
    } else {
        read_temperatures(&file, &temperature_topics)?
    };
    let len = file_len(&file).map_err(|e| e.to_string())?;
    Ok(Box::new(ImuBatches {
        reader: messages(file, len).map_err(|e| e.to_string())?,
        topic,
        schema: Arc::new(schema.project(projection).map_err(|e| e.to_string())?),
        columns,
        temperatures,
        encodings: HashMap::new(),
        batch_rows: batch_rows.max(1),
        messages_read: 0,
        imu_messages: 0,
        pending: None,
        done: false,
    }))
}

/// Every reading of each topic: (header stamp ns, °C), sorted by stamp.
fn read_temperatures(file: &File, topics: &[String]) -> Result<Vec<Vec<(i64, f64)>>, String> {
    let mut series: Vec<Vec<(i64, f64)>> = vec![Vec::new(); topics.len()];
    let reader = file_len(file).and_then(|len| messages(file, len));
    for (n, message) in reader.map_err(|e| e.to_string())?.enumerate() {
        let message = message.map_err(|e| reader_error(&e, n as u64))?;
        let Some((MessageType::Temperature, encoding)) = classify_channel(&message.channel) else {
            continue;
        };
        for (k, topic) in topics.iter().enumerate() {
            if *topic == message.channel.topic {
                let reading = decode_temperature(&message.data, encoding)
                    .map_err(|e| locate(topic, series[k].len() as u64, message.log_time, &e))?;
                series[k].push(reading);
            }
        }
    }
    for (s, topic) in series.iter_mut().zip(topics) {
        if s.is_empty() {
            return Err(format!("temperature topic {topic:?} has no messages"));
        }
        s.sort_by_key(|r| r.0);
    }
    Ok(series)
}

/// The reading of a sorted series in force at `stamp`: the latest stamped at or before it, or the
/// first one before the series starts.
fn sample_and_hold(series: &[(i64, f64)], stamp: i64) -> f64 {
    let after = series.partition_point(|r| r.0 <= stamp);
    series[after.saturating_sub(1)].1
}

/// `topic "/imu/data", message 17 (log time 1700000000.085000000 s): …`
fn locate(topic: &str, index: u64, log_time: u64, what: &str) -> String {
    format!(
        "topic {topic:?}, message {index} (log time {}.{:09} s): {what}",
        log_time / 1_000_000_000,
        log_time % 1_000_000_000
    )
}

struct ImuBatches {
    reader: MessageReader<BufReader<File>>,
    topic: String,
    /// The projected schema.
    schema: SchemaRef,
    columns: Vec<Column>,
    temperatures: Vec<Vec<(i64, f64)>>,
    /// Per channel id: the encoding when the channel is the IMU topic's, else `None`.
    encodings: HashMap<u16, Option<Encoding>>,
    batch_rows: usize,
    messages_read: u64,
    imu_messages: u64,
    /// An error met after some rows of a batch: those rows come first, then this, so that the
    /// error's row is the first row not read.
    pending: Option<String>,
    done: bool,
}

impl ImuBatches {
    fn batch(&self, rows: &[Imu]) -> Result<RecordBatch, String> {
        let arrays: Vec<ArrayRef> = self
            .columns
            .iter()
            .map(|c| -> ArrayRef {
                match c {
                    Column::Stamp => Arc::new(TimestampNanosecondArray::from_iter_values(
                        rows.iter().map(|r| r.stamp_ns),
                    )),
                    Column::Imu(k) => Arc::new(Float64Array::from_iter_values(
                        rows.iter().map(|r| r.values[*k]),
                    )),
                    Column::Temperature(k) => {
                        let series = &self.temperatures[*k];
                        Arc::new(Float64Array::from_iter_values(
                            rows.iter().map(|r| sample_and_hold(series, r.stamp_ns)),
                        ))
                    }
                }
            })
            .collect();
        RecordBatch::try_new_with_options(
            self.schema.clone(),
            arrays,
            &RecordBatchOptions::new().with_row_count(Some(rows.len())),
        )
        .map_err(|e| e.to_string())
    }
}

impl Iterator for ImuBatches {
    type Item = Result<RecordBatch, String>;

    fn next(&mut self) -> Option<Self::Item> {
        if let Some(e) = self.pending.take() {
            return Some(Err(e));
        }
        if self.done {
            return None;
        }
        let mut rows: Vec<Imu> = Vec::with_capacity(self.batch_rows.min(1 << 16));
        while rows.len() < self.batch_rows {
            let message = match self.reader.next() {
                None => {
                    self.done = true;
                    break;
                }
                Some(Err(e)) => {
                    self.done = true;
                    self.pending = Some(reader_error(&e, self.messages_read));
                    break;
                }
                Some(Ok(m)) => m,
            };
            self.messages_read += 1;
            let topic = &self.topic;
            let encoding =
                *self.encodings.entry(message.channel.id).or_insert_with(
                    || match classify_channel(&message.channel) {
                        Some((MessageType::Imu, e)) if message.channel.topic == *topic => Some(e),
                        _ => None,
                    },
                );
            let Some(encoding) = encoding else { continue };
            match decode_imu(&message.data, encoding) {
                Ok(imu) => rows.push(imu),
                Err(e) => {
                    self.done = true;
                    self.pending =
                        Some(locate(&self.topic, self.imu_messages, message.log_time, &e));
                    break;
                }
            }
            self.imu_messages += 1;
        }
        if rows.is_empty() {
            return self.pending.take().map(Err);
        }
        Some(self.batch(&rows))
    }
}

/// The fields of a `sensor_msgs/msg/Imu` imunoise uses.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Imu {
    /// Header stamp, ns since the clock's epoch.
    stamp_ns: i64,
    /// `angular_velocity.x/y/z`, `linear_acceleration.x/y/z`: the order of [`IMU_COLUMNS`].
    values: [f64; 6],
    gyro_covariance_0: f64,
    accel_covariance_0: f64,
}

/// A bounds-checked reader of CDR (alignment relative to the end of the encapsulation header) or of
/// ROS 1 serialisation (packed, little endian).
struct Reader<'a> {
    buf: &'a [u8],
    pos: usize,
    little_endian: bool,
    /// CDR aligns each primitive to its size; ROS 1 packs.
    aligned: bool,
}

impl<'a> Reader<'a> {
    fn new(data: &'a [u8], encoding: Encoding) -> Result<Self, String> {
        match encoding {
            Encoding::Ros1 => Ok(Reader {
                buf: data,
                pos: 0,
                little_endian: true,
                aligned: false,
            }),
            Encoding::Cdr => {
                let little_endian = match data {
                    [0x00, 0x01, _, _, ..] => true,
                    [0x00, 0x00, _, _, ..] => false,
                    [0x28, 0xB5, 0x2F, 0xFD, ..] => {
                        return Err("the message is zstd-compressed (rosbag2 per-message \
                                    compression); decompress the bag first, e.g. with \
                                    `ros2 bag convert`"
                            .to_string())
                    }
                    [a, b, _, _, ..] => {
                        return Err(format!(
                            "CDR encapsulation {a:#04x} {b:#04x} is not plain CDR \
                             (0x00 0x01 little endian or 0x00 0x00 big endian); XCDR2 and \
                             parameter lists are not read"
                        ))
                    }
                    _ => {
                        return Err(format!(
                            "message of {} bytes is shorter than the 4-byte CDR header",
                            data.len()
                        ))
                    }
                };
                Ok(Reader {
                    buf: &data[4..],
                    pos: 0,
                    little_endian,
                    aligned: true,
                })
            }
        }
    }

    fn take<const N: usize>(&mut self, what: &str) -> Result<[u8; N], String> {
        if self.aligned {
            self.pos = self.pos.next_multiple_of(N);
        }
        let bytes = self
            .pos
            .checked_add(N)
            .and_then(|end| self.buf.get(self.pos..end))
            .ok_or_else(|| {
                format!(
                    "message ends at byte {} of its body, {what} needs bytes {}..{}",
                    self.buf.len(),
                    self.pos,
                    self.pos.saturating_add(N)
                )
            })?;
        self.pos += N;
        Ok(bytes.try_into().expect("slice of length N"))
    }

    fn u32(&mut self, what: &str) -> Result<u32, String> {
        let b = self.take::<4>(what)?;
        Ok(if self.little_endian {
            u32::from_le_bytes(b)
        } else {
            u32::from_be_bytes(b)
        })
    }

    fn f64(&mut self, what: &str) -> Result<f64, String> {
        let b = self.take::<8>(what)?;
        Ok(if self.little_endian {
            f64::from_le_bytes(b)
        } else {
            f64::from_be_bytes(b)
        })
    }

    fn skip_string(&mut self, what: &str) -> Result<(), String> {
        let len = self.u32(what)? as usize;
        let end = self.pos.checked_add(len).filter(|&e| e <= self.buf.len());
        self.pos = end.ok_or_else(|| {
            format!(
                "{what} claims {len} bytes from byte {} but the message body has {}",
                self.pos,
                self.buf.len()
            )
        })?;
        Ok(())
    }

    /// `std_msgs/Header`: the stamp in ns. ROS 2: `int32 sec, uint32 nanosec, string frame_id`;
    /// ROS 1: `uint32 seq, uint32 secs, uint32 nsecs, string frame_id`.
    fn header(&mut self) -> Result<i64, String> {
        let seconds = if self.aligned {
            self.u32("header.stamp.sec")? as i32 as i64
        } else {
            self.u32("header.seq")?;
            self.u32("header.stamp.secs")? as i64
        };
        let nanoseconds = self.u32("header.stamp.nanosec")? as i64;
        self.skip_string("header.frame_id")?;
        Ok(seconds * 1_000_000_000 + nanoseconds)
    }

    fn f64s<const N: usize>(&mut self, what: &str) -> Result<[f64; N], String> {
        let mut out = [0.0; N];
        for v in &mut out {
            *v = self.f64(what)?;
        }
        Ok(out)
    }
}

/// Decodes the header stamp, angular velocity and linear acceleration (and element 0 of their
/// covariances) of a `sensor_msgs/msg/Imu`.
fn decode_imu(data: &[u8], encoding: Encoding) -> Result<Imu, String> {
    let mut r = Reader::new(data, encoding)?;
    let stamp_ns = r.header()?;
    r.f64s::<4>("orientation")?;
    r.f64s::<9>("orientation_covariance")?;
    let gyro = r.f64s::<3>("angular_velocity")?;
    let gyro_covariance = r.f64s::<9>("angular_velocity_covariance")?;
    let accel = r.f64s::<3>("linear_acceleration")?;
    let accel_covariance = r.f64s::<9>("linear_acceleration_covariance")?;
    Ok(Imu {
        stamp_ns,
        values: [gyro[0], gyro[1], gyro[2], accel[0], accel[1], accel[2]],
        gyro_covariance_0: gyro_covariance[0],
        accel_covariance_0: accel_covariance[0],
    })
}

/// Decodes a `sensor_msgs/msg/Temperature`: (header stamp ns, temperature °C).
fn decode_temperature(data: &[u8], encoding: Encoding) -> Result<(i64, f64), String> {
    let mut r = Reader::new(data, encoding)?;
    let stamp_ns = r.header()?;
    let t = r.f64("temperature")?;
    r.f64("variance")?;
    Ok((stamp_ns, t))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Serialises an Imu message by hand: CDR (with header, aligned) or ROS 1 (packed).
    fn imu_bytes(encoding: Encoding, little_endian: bool, frame_id: &str) -> Vec<u8> {
        let mut body: Vec<u8> = Vec::new();
        let aligned = encoding == Encoding::Cdr;
        let pad = |b: &mut Vec<u8>, n: usize| {
            if aligned {
                while !b.len().is_multiple_of(n) {
                    b.push(0);
                }
            }
        };
        let u32b = |v: u32| {
            if little_endian {
                v.to_le_bytes()
            } else {
                v.to_be_bytes()
            }
        };
        let f64b = |v: f64| {
            if little_endian {
                v.to_le_bytes()
            } else {
                v.to_be_bytes()
            }
        };
        if !aligned {
            body.extend(u32b(7)); // seq
        }
        body.extend(u32b(1_700_000_000));
        body.extend(u32b(123_456_789));
        let mut s = frame_id.as_bytes().to_vec();
        if aligned {
            s.push(0);
        }
        body.extend(u32b(s.len() as u32));
        body.extend(&s);
        let mut value = 0.0;
        for count in [4, 9, 3, 9, 3, 9] {
            for _ in 0..count {
                pad(&mut body, 8);
                value += 0.5;
                body.extend(f64b(value));
            }
        }
        if aligned {
            let mut out = vec![0x00, if little_endian { 0x01 } else { 0x00 }, 0, 0];
            out.extend(body);
            out
        } else {
            body
        }
    }

    #[test]
    fn cdr_and_ros1_imu_messages_decode() {
        for (encoding, le) in [
            (Encoding::Cdr, true),
            (Encoding::Cdr, false),
            (Encoding::Ros1, true),
        ] {
            for frame in ["", "imu", "imu_link", "a_longer_frame_name"] {
                let bytes = imu_bytes(encoding, le, frame);
                let imu = decode_imu(&bytes, encoding).unwrap();
                assert_eq!(imu.stamp_ns, 1_700_000_000_123_456_789);
                // Values count up by 0.5 from the orientation's first element (0.5).
                assert_eq!(
                    imu.values,
                    [7.0, 7.5, 8.0, 13.0, 13.5, 14.0],
                    "{encoding:?} {le} {frame:?}"
                );
                assert_eq!(imu.gyro_covariance_0, 8.5);
                assert_eq!(imu.accel_covariance_0, 14.5);
                // Every cut is an error, never a panic or a number.
                for cut in 0..bytes.len() {
                    assert!(decode_imu(&bytes[..cut], encoding).is_err(), "{cut}");
                }
            }
        }
    }

    #[test]
    fn negative_stamps_and_bad_headers() {
        let mut bytes = imu_bytes(Encoding::Cdr, true, "x");
        bytes[4..8].copy_from_slice(&(-2i32).to_le_bytes());
        let imu = decode_imu(&bytes, Encoding::Cdr).unwrap();
        assert_eq!(imu.stamp_ns, -2_000_000_000 + 123_456_789);
        bytes[1] = 0x07; // XCDR2
        let e = decode_imu(&bytes, Encoding::Cdr).unwrap_err();
        assert!(e.contains("not plain CDR"), "{e}");
        let e = decode_imu(&[0x28, 0xB5, 0x2F, 0xFD, 0, 0], Encoding::Cdr).unwrap_err();
        assert!(e.contains("zstd"), "{e}");
        // A string length past the end.
        let mut bytes = imu_bytes(Encoding::Cdr, true, "x");
        bytes[12..16].copy_from_slice(&u32::MAX.to_le_bytes());
        let e = decode_imu(&bytes, Encoding::Cdr).unwrap_err();
        assert!(e.contains("header.frame_id"), "{e}");
    }

    #[test]
    fn temperature_holds_the_latest_reading() {
        let series = [(10, 1.0), (20, 2.0), (30, 3.0)];
        let at: Vec<f64> = [0, 10, 15, 20, 29, 30, 99]
            .iter()
            .map(|&t| sample_and_hold(&series, t))
            .collect();
        assert_eq!(at, [1.0, 1.0, 1.0, 2.0, 2.0, 3.0, 3.0]);
    }

    #[test]
    fn channels_are_classified_by_encoding_and_schema() {
        use Encoding::*;
        use MessageType::*;
        let c = |m, n, e| classify(m, Some((n, e)));
        assert_eq!(c("cdr", "sensor_msgs/msg/Imu", "ros2msg"), Some((Imu, Cdr)));
        assert_eq!(c("cdr", "sensor_msgs/msg/Imu", "ros2idl"), Some((Imu, Cdr)));
        assert_eq!(
            c("cdr", "sensor_msgs/msg/Temperature", "ros2msg"),
            Some((Temperature, Cdr))
        );
        assert_eq!(c("ros1", "sensor_msgs/Imu", "ros1msg"), Some((Imu, Ros1)));
        assert_eq!(c("cdr", "sensor_msgs/Imu", "ros2msg"), None);
        assert_eq!(c("json", "sensor_msgs/msg/Imu", "jsonschema"), None);
        assert_eq!(c("cdr", "sensor_msgs/msg/Imu", "ros1msg"), None);
        assert_eq!(classify("cdr", None), None);
        assert_eq!(column_name("/imu/temperature"), "imu_temperature");
        assert_eq!(column_name("/"), "temperature");
    }
}
