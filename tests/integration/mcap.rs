//! MCAP files (ROS 2 bags) written by an independent writer (foxglove's Python `mcap` and
//! `mcap-ros2-support`/`mcap-ros1-support`, `tests/data/mcap/make_mcap.py`): channels, units, rate,
//! exact samples, the temperature join, the topic choice, ROS 1 data in MCAP, and the errors for
//! what is not read.

use std::path::{Path, PathBuf};

use imunoise::io::{self, InputError, OpenOptions};
use imunoise::units::{Kind, Unit};
use serde_json::Value;

use super::support::*;

fn fixture(name: &str) -> PathBuf {
    repo_root().join("tests/data/mcap").join(name)
}

// --- The fixture's closed-form values; keep in step with tests/data/mcap/make_mcap.py. ---

const T0_NS: i64 = 1_700_000_000 * 1_000_000_000;
const ACCEL_OFFSET: [f64; 3] = [0.125, -0.25, 9.8125];

fn splitmix64(x: u64) -> u64 {
    let mut z = x.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

fn counts(seed: u64, k: u64, c: u64) -> i64 {
    let z = splitmix64((seed << 32).wrapping_add(8 * k + c));
    [54, 44, 34, 24]
        .iter()
        .map(|s| ((z >> s) & 0x3FF) as i64)
        .sum::<i64>()
        - 2046
}

fn stamp_ns(k: u64, period_ns: i64) -> i64 {
    T0_NS + k as i64 * period_ns + ((splitmix64(k) >> 60) as i64 - 8) * 1000
}

/// gyro_x..z, accel_x..z of IMU message `k`.
fn imu_values(seed: u64, k: u64) -> [f64; 6] {
    let mut v = [0.0; 6];
    for c in 0..3 {
        v[c as usize] = counts(seed, k, c) as f64 * 2f64.powi(-16);
        v[3 + c as usize] =
            counts(seed, k, c + 3) as f64 * 2f64.powi(-12) + ACCEL_OFFSET[c as usize];
    }
    v
}

/// Temperature at IMU stamp `t_ns`: readings at T0 + 0.5 s + j s of 25 + j/8 °C, j < `n`, held;
/// before the first, the first.
fn temperature_at(t_ns: i64, n: i64) -> f64 {
    let j = (t_ns - T0_NS - 500_000_000).div_euclid(1_000_000_000);
    25.0 + j.clamp(0, n - 1) as f64 / 8.0
}

fn open(path: &Path, topic: Option<&str>, batch_rows: usize) -> Result<io::Recording, InputError> {
    io::open(
        path,
        &OpenOptions {
            topic: topic.map(str::to_string),
            batch_rows,
            ..Default::default()
        },
    )
}

/// All rows: (seconds since the first, channels).
fn read_all(rec: &io::Recording) -> (Vec<f64>, Vec<Vec<f64>>) {
    let mut time = Vec::new();
    let mut channels = vec![Vec::new(); rec.channels.len()];
    for block in rec.blocks().unwrap() {
        let block = block.unwrap_or_else(|e| panic!("{e}"));
        time.extend(block.time_s.unwrap());
        for (all, c) in channels.iter_mut().zip(block.channels) {
            all.extend(c);
        }
    }
    (time, channels)
}

#[test]
fn an_imu_topic_is_six_si_channels_with_header_times_and_the_temperature_joined() {
    let path = fixture("imu_200hz.mcap");
    // Batches of 1000 rows: the stream crosses batch and (32 KiB zstd) chunk boundaries.
    let rec = open(&path, None, 1000).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(rec.format, io::Format::Mcap);
    let names = rec.channel_names();
    assert_eq!(
        names,
        [
            "gyro_x",
            "gyro_y",
            "gyro_z",
            "accel_x",
            "accel_y",
            "accel_z",
            "imu_temperature"
        ]
    );
    for c in &rec.channels[..3] {
        assert_eq!(
            (c.unit, c.kind),
            (Some(Unit::RadPerS), Kind::Gyro),
            "{}",
            c.name
        );
    }
    for c in &rec.channels[3..6] {
        assert_eq!(
            (c.unit, c.kind),
            (Some(Unit::MPerS2), Kind::Accel),
            "{}",
            c.name
        );
    }
    assert_eq!(
        (rec.channels[6].unit, rec.channels[6].kind),
        (Some(Unit::DegC), Kind::Temperature)
    );
    // The rate comes from the header stamps (200 Hz with ±8 µs jitter), not from metadata.
    assert_eq!(rec.rate_source, io::RateSource::TimeColumn);
    assert!((rec.rate_hz / 200.0 - 1.0).abs() < 1e-5, "{}", rec.rate_hz);
    assert_eq!(rec.time.as_ref().unwrap().name, "time");
    let note = rec.notes.join(" | ");
    assert!(
        note.contains("/imu/data") && note.contains("imu_temperature from /imu/temperature"),
        "{note}"
    );

    let (time, channels) = read_all(&rec);
    assert_eq!(time.len(), 4000);
    let origin = stamp_ns(0, 5_000_000);
    for k in 0..4000u64 {
        let stamp = stamp_ns(k, 5_000_000);
        // Header stamps, not log times (those come 2.0 to 2.6 ms later).
        let expected_t = (stamp - origin) as f64 * 1e-9;
        assert!((time[k as usize] - expected_t).abs() < 1e-12, "row {k}");
        let values = imu_values(1, k);
        for c in 0..6 {
            // Exact: the values are binary fractions and the units are already SI.
            assert_eq!(channels[c][k as usize], values[c], "row {k} {}", names[c]);
        }
        assert_eq!(
            channels[6][k as usize],
            temperature_at(stamp, 20),
            "temperature at row {k}"
        );
    }
    // Held by header stamp: the first reading (stamped 0.5 s) from the start until the second
    // (1.5 s, between rows 299 and 301), not by log time (30 ms later, row 306).
    assert_eq!(channels[6][0], 25.0);
    assert_eq!(channels[6][299], 25.0);
    assert_eq!(channels[6][301..306], [25.125; 5]);
    assert_eq!(channels[6][3999], 25.0 + 19.0 / 8.0);
}

#[test]
fn a_projection_of_some_channels_reads_only_those() {
    let rec = io::open(
        &fixture("imu_200hz.mcap"),
        &OpenOptions {
            columns: io::ColumnOverrides {
                channels: vec!["accel_z".into(), "gyro_y".into()],
                ..Default::default()
            },
            ..Default::default()
        },
    )
    .unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(rec.channel_names(), ["accel_z", "gyro_y"]);
    let (time, channels) = read_all(&rec);
    assert_eq!(time.len(), 4000);
    assert_eq!(channels[0][17], imu_values(1, 17)[5]);
    assert_eq!(channels[1][3999], imu_values(1, 3999)[1]);
}

#[test]
fn several_imu_topics_need_topic_and_an_imu_without_gyro_has_no_gyro_channels() {
    let path = fixture("two_imus.mcap");
    let e = open(&path, None, 1000).unwrap_err();
    assert!(matches!(e, InputError::AmbiguousTopic { .. }), "{e}");
    let text = e.to_string();
    assert!(
        text.contains("two_imus.mcap")
            && text.contains("/imu0/data")
            && text.contains("/imu1/data")
            && text.contains("--topic"),
        "{text}"
    );

    let rec = open(&path, Some("/imu0/data"), 64).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(rec.channels.len(), 6);
    assert!((rec.rate_hz / 100.0 - 1.0).abs() < 1e-5, "{}", rec.rate_hz);
    let (time, channels) = read_all(&rec);
    assert_eq!(time.len(), 200);
    for k in [0u64, 63, 64, 199] {
        for (channel, value) in channels.iter().zip(imu_values(2, k)) {
            assert_eq!(channel[k as usize], value, "row {k}");
        }
    }

    // /imu1/data sets angular_velocity_covariance[0] = -1: the ROS "no estimate".
    let rec = open(&path, Some("/imu1/data"), 1000).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(rec.channel_names(), ["accel_x", "accel_y", "accel_z"]);
    assert!(rec.notes.join(" ").contains("no gyro"), "{:?}", rec.notes);
    let (_, channels) = read_all(&rec);
    assert_eq!(channels[2][150], imu_values(3, 150)[5]);

    for wrong in ["/chatter", "/nope"] {
        let e = open(&path, Some(wrong), 1000).unwrap_err();
        assert!(matches!(e, InputError::UnknownTopic { .. }), "{e}");
        let text = e.to_string();
        assert!(
            text.contains(wrong)
                && text.contains("/imu0/data (sensor_msgs/msg/Imu, cdr, 200 messages)")
                && text.contains("/chatter (std_msgs/msg/String, cdr, 10 messages)"),
            "{text}"
        );
    }
}

#[test]
fn a_file_without_imu_topics_lists_what_it_has() {
    let e = open(&fixture("no_imu.mcap"), None, 1000).unwrap_err();
    assert!(matches!(e, InputError::NoImuTopic { .. }), "{e}");
    assert!(
        e.to_string()
            .contains("/chatter (std_msgs/msg/String, cdr, 5 messages)"),
        "{e}"
    );
}

#[test]
fn ros1_messages_in_mcap_are_read_too() {
    // What `mcap convert IN.bag OUT.mcap` makes of a ROS 1 bag.
    let rec = open(&fixture("imu_ros1.mcap"), None, 128).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(rec.channels.len(), 7);
    assert!((rec.rate_hz / 100.0 - 1.0).abs() < 1e-5, "{}", rec.rate_hz);
    let (time, channels) = read_all(&rec);
    assert_eq!(time.len(), 300);
    for k in 0..300u64 {
        let expected_t = (stamp_ns(k, 10_000_000) - stamp_ns(0, 10_000_000)) as f64 * 1e-9;
        assert!((time[k as usize] - expected_t).abs() < 1e-12, "row {k}");
        for (channel, value) in channels.iter().zip(imu_values(4, k)) {
            assert_eq!(channel[k as usize], value, "row {k}");
        }
        assert_eq!(
            channels[6][k as usize],
            temperature_at(stamp_ns(k, 10_000_000), 3)
        );
    }
}

#[test]
fn topic_is_refused_for_other_formats() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("x.arrow");
    write_ipc_file(
        &path,
        &batch(&[f64_col("g", noise(100, 1), Some("rad/s"))], Some(50.0)),
        100,
    );
    let e = open(&path, Some("/imu"), 1000).unwrap_err();
    assert!(
        e.to_string().contains("--topic") && e.to_string().contains("MCAP"),
        "{e}"
    );
}

#[test]
fn ros1_bags_and_sqlite_bags_are_refused_with_how_to_convert() {
    let dir = tempfile::tempdir().unwrap();
    let bag = dir.path().join("old.bag");
    std::fs::write(&bag, b"#ROSBAG V2.0\nE\x00\x00\x00 rest of a bag").unwrap();
    let db3 = dir.path().join("rosbag2_2024_01_01.db3");
    std::fs::write(&db3, b"SQLite format 3\x00 rest of a database").unwrap();
    // Recognised by content whatever the name, and by name when the content says nothing.
    let renamed = dir.path().join("recording.dat");
    std::fs::copy(&bag, &renamed).unwrap();
    let empty_bag = dir.path().join("empty.bag");
    std::fs::write(&empty_bag, b"").unwrap();
    for (path, needle) in [
        (&bag, "rosbags-convert --src IN.bag"),
        (&renamed, "mcap convert IN.bag OUT.mcap"),
        (&empty_bag, "ROS 1 bag"),
        (&db3, "ros2 bag convert"),
    ] {
        let e = open(path, None, 1000).unwrap_err();
        assert!(matches!(e, InputError::UnsupportedFormat { .. }), "{e}");
        let text = e.to_string();
        assert!(
            text.contains(path.file_name().unwrap().to_str().unwrap()) && text.contains(needle),
            "{text}"
        );
    }
    // A ROS 2 bag directory: pass the .mcap inside.
    let bag_dir = dir.path().join("rosbag2_run");
    std::fs::create_dir(&bag_dir).unwrap();
    std::fs::write(
        bag_dir.join("metadata.yaml"),
        "rosbag2_bagfile_information:\n",
    )
    .unwrap();
    std::fs::copy(fixture("no_imu.mcap"), bag_dir.join("rosbag2_run_0.mcap")).unwrap();
    let e = open(&bag_dir, None, 1000).unwrap_err();
    assert!(
        e.to_string().contains("rosbag2_run_0.mcap") && e.to_string().contains("ROS 2 bag"),
        "{e}"
    );
}

#[test]
fn a_truncated_or_damaged_file_is_an_error_naming_it_never_a_panic() {
    let dir = tempfile::tempdir().unwrap();
    let bytes = std::fs::read(fixture("imu_200hz.mcap")).unwrap();
    // Cut anywhere: the summary is gone, the scan meets the end of the file mid-record.
    for keep in [8, 100, bytes.len() / 3, bytes.len() / 2, bytes.len() - 30] {
        let path = dir.path().join(format!("cut_{keep}.mcap"));
        std::fs::write(&path, &bytes[..keep]).unwrap();
        let e = open(&path, None, 1000).unwrap_err();
        let text = e.to_string();
        assert!(
            text.contains(&format!("cut_{keep}.mcap")) && text.contains("MCAP"),
            "{text}"
        );
        assert!(matches!(e, InputError::Corrupt { .. }), "{text}");
    }
    // A flipped byte inside a chunk, the summary intact: found while streaming (chunk CRC or
    // decompression), reported with the row, not read as numbers.
    let mut damaged = bytes.clone();
    for i in 0..10 {
        damaged[bytes.len() / 2 + 1000 * i] ^= 0x5A;
    }
    let path = dir.path().join("damaged.mcap");
    std::fs::write(&path, &damaged).unwrap();
    let failure = match open(&path, None, 1000) {
        Err(e) => e,
        Ok(rec) => rec
            .blocks()
            .unwrap()
            .find_map(Result::err)
            .expect("a damaged chunk must not read cleanly"),
    };
    assert!(failure.to_string().contains("damaged.mcap"), "{failure}");
    // The rows before the damaged chunk were read; the error names the first row that was not.
    assert!(
        failure.row().is_some_and(|r| r > 1000 && r < 4000),
        "{failure}"
    );
}

#[test]
fn a_message_that_does_not_decode_is_an_error_naming_topic_index_and_log_time() {
    // Message 50 of /imu/data is cut to 100 bytes; messages 0..49 are fine.
    let path = fixture("bad_message.mcap");
    let failure = match open(&path, None, 16) {
        Err(e) => e,
        Ok(rec) => rec
            .blocks()
            .unwrap()
            .find_map(Result::err)
            .expect("a cut message must not read cleanly"),
    };
    let text = failure.to_string();
    let log_time = stamp_ns(50, 10_000_000) + 2_000_000 + 100_000;
    assert!(
        text.contains("bad_message.mcap")
            && text.contains("topic \"/imu/data\", message 50")
            && text.contains(&format!(
                "log time {}.{:09} s",
                log_time / 1_000_000_000,
                log_time % 1_000_000_000
            )),
        "{text}"
    );
    assert_eq!(failure.row(), Some(50), "{text}");
}

#[test]
fn analyze_runs_end_to_end_on_an_mcap_file() {
    let dir = tempfile::tempdir().unwrap();
    let out_dir = dir.path().join("run");
    let path = fixture("imu_200hz.mcap");
    let out = imunoise(
        &[
            "analyze",
            path.to_str().unwrap(),
            "-o",
            out_dir.to_str().unwrap(),
            "--nperseg",
            "512",
            "--backend",
            "cpu",
        ],
        dir.path(),
    );
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(0), "{stderr}");
    let doc: Value =
        serde_json::from_slice(&std::fs::read(out_dir.join("report.json")).unwrap()).unwrap();
    let file = &doc["files"][0];
    assert_eq!(file["status"], "ok", "{file}");
    let rec = &file["recording"];
    assert_eq!(rec["format"], "mcap");
    assert_eq!(rec["samples"], 4000);
    let channels = rec["channels"].as_array().unwrap();
    let inertial = channels
        .iter()
        .filter(|c| c["kind"] == "gyro" || c["kind"] == "accel")
        .count();
    assert_eq!(inertial, 6, "{channels:?}");
    assert!(channels.iter().any(|c| c["kind"] == "temperature"));
    // The Allan deviation of each IMU channel is there.
    assert_eq!(file["avar"].as_array().unwrap().len(), 7);

    // Several IMU topics and no --topic: that file fails (exit 1), naming the flag.
    let out = imunoise(
        &["info", fixture("two_imus.mcap").to_str().unwrap()],
        dir.path(),
    );
    assert_eq!(out.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&out.stderr).contains("--topic"));
    let out = imunoise(
        &[
            "info",
            fixture("two_imus.mcap").to_str().unwrap(),
            "--topic",
            "/imu1/data",
            "--json",
        ],
        dir.path(),
    );
    assert_eq!(
        out.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}
