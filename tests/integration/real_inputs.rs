//! Inputs as real users bring them: time columns in milliseconds, jittery timestamps, stuck sensors,
//! files without units, and flags that name columns or values that do not fit the file. Each case
//! once went through silently with a wrong reading; each must now be read right or refused with a
//! message naming the flag, file, column or row.

use std::path::Path;
use std::sync::Arc;

use arrow_array::{Float64Array, Int64Array, RecordBatch};
use arrow_schema::{DataType, Field, Schema};
use imunoise::io::{self, ColumnOverrides, OpenOptions, TimeUnit, TimeUnitSource};
use imunoise::pipeline::{self, Inputs, Silent, Work};
use imunoise::quality::{ChannelVerdict, GapPolicy, QualityOptions};
use imunoise::units::Kind;

use super::support::*;

fn stderr(out: &std::process::Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// CSV text with an integer time column `t` in the given ticks and one gyro column.
fn csv_with_ticks(path: &Path, ticks: &[i64], values: &[f64]) {
    let mut s = String::from("t,gx [deg/s]\n");
    for (t, v) in ticks.iter().zip(values) {
        s.push_str(&format!("{t},{v:?}\n"));
    }
    std::fs::write(path, s).unwrap();
}

fn open_with(path: &Path, columns: ColumnOverrides, rate_hz: Option<f64>) -> io::Recording {
    io::open(
        path,
        &OpenOptions {
            columns,
            rate_hz,
            ..Default::default()
        },
    )
    .unwrap_or_else(|e| panic!("{e}"))
}

#[test]
fn integer_milliseconds_in_csv_are_inferred_and_said_so() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("ms.csv");
    let n = 2000;
    // 100 Hz from a Unix epoch in milliseconds.
    let ticks: Vec<i64> = (0..n).map(|i| 1_700_000_000_000 + 10 * i as i64).collect();
    csv_with_ticks(&p, &ticks, &noise(n, 1));
    let rec = open_with(&p, ColumnOverrides::default(), None);
    assert!((rec.rate_hz - 100.0).abs() < 1e-9, "{}", rec.rate_hz);
    let time = rec.time.as_ref().unwrap();
    assert_eq!(time.unit_source, TimeUnitSource::Inferred);
    assert_eq!(time.encoding.seconds_per_unit(), 1e-3);
    assert!(
        rec.notes
            .iter()
            .any(|n| n.contains("ms") && n.contains("--time-unit")),
        "{:?}",
        rec.notes
    );
    // The flag says it outright: no inference, no note.
    let rec = open_with(
        &p,
        ColumnOverrides {
            time_unit: Some(TimeUnit::Ms),
            ..Default::default()
        },
        None,
    );
    assert_eq!(rec.time.as_ref().unwrap().unit_source, TimeUnitSource::Flag);
    assert!(rec.notes.is_empty());
    assert!((rec.rate_hz - 100.0).abs() < 1e-9);
}

/// Float times in milliseconds (400 Hz: 0.0, 2.5, 5.0, …) read as seconds give 0.4 Hz: refused,
/// naming the flag and the rates each unit implies, where it once ran on with a note and printed
/// every density 1000× too high. A stated rate or the flag settles it; float seconds at a
/// plausible rate stay seconds without a word.
#[test]
fn float_milliseconds_are_refused_not_read_as_seconds() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("float_ms.csv");
    let n = 2000;
    let mut text = String::from("t,gx [deg/s]\n");
    for (i, v) in noise(n, 4).iter().enumerate() {
        text.push_str(&format!("{:.1},{v:?}\n", 2.5 * i as f64));
    }
    std::fs::write(&p, text).unwrap();
    let err = io::open(&p, &OpenOptions::default())
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("float_ms.csv")
            && err.contains("\"t\"")
            && err.contains("--time-unit")
            && err.contains("0.4 Hz")
            && err.contains("ms: 400 Hz"),
        "{err}"
    );
    let rec = open_with(&p, ColumnOverrides::default(), Some(400.0));
    assert_eq!(rec.time.as_ref().unwrap().encoding.seconds_per_unit(), 1e-3);
    assert!((rec.rate_hz - 400.0).abs() < 1e-6, "{}", rec.rate_hz);
    let rec = open_with(
        &p,
        ColumnOverrides {
            time_unit: Some(TimeUnit::Ms),
            ..Default::default()
        },
        None,
    );
    assert!((rec.rate_hz - 400.0).abs() < 1e-6, "{}", rec.rate_hz);
    // Seconds at 400 Hz: read as seconds, no note.
    let q = dir.path().join("float_s.csv");
    let mut text = String::from("t,gx [deg/s]\n");
    for (i, v) in noise(n, 5).iter().enumerate() {
        text.push_str(&format!("{:.4},{v:?}\n", 0.0025 * i as f64));
    }
    std::fs::write(&q, text).unwrap();
    let rec = open_with(&q, ColumnOverrides::default(), None);
    assert!((rec.rate_hz - 400.0).abs() < 1e-6, "{}", rec.rate_hz);
    assert_eq!(
        rec.time.as_ref().unwrap().unit_source,
        TimeUnitSource::FloatSeconds
    );
    assert!(
        rec.notes.iter().all(|n| !n.contains("time column")),
        "{:?}",
        rec.notes
    );
}

/// A gyro or accelerometer kind given to a column without a unit, or in counts, is refused naming
/// file, column and the flag: it was fitted as if in rad/s or m/s² (N 1730 m/s/√h from raw counts)
/// while the screen called it aux. Without a kind the same columns are aux, as before.
#[test]
fn a_forced_inertial_kind_needs_a_physical_unit() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("counts.csv");
    let mut text = String::from("t,accel_z [counts],gx\n");
    for (i, v) in noise(500, 6).iter().enumerate() {
        text.push_str(&format!("{:.2},{:.1},{v:?}\n", 0.01 * i as f64, 100.0 * v));
    }
    std::fs::write(&p, text).unwrap();
    let kinds = |pairs: &[(&str, Kind)]| ColumnOverrides {
        kinds: pairs.iter().map(|(c, k)| (c.to_string(), *k)).collect(),
        ..Default::default()
    };
    let open = |o: ColumnOverrides| {
        io::open(
            &p,
            &OpenOptions {
                columns: o,
                ..Default::default()
            },
        )
    };
    let err = open(kinds(&[("accel_z", Kind::Accel)]))
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("counts.csv")
            && err.contains("\"accel_z\"")
            && err.contains("counts")
            && err.contains("--unit accel_z="),
        "{err}"
    );
    let err = open(kinds(&[("gx", Kind::Gyro)])).unwrap_err().to_string();
    assert!(
        err.contains("\"gx\"") && err.contains("--unit gx="),
        "{err}"
    );
    let rec = open(ColumnOverrides::default()).unwrap();
    assert!(
        rec.channels.iter().all(|c| c.kind == Kind::Aux),
        "{:?}",
        rec.channels
    );
    // With a unit of its quantity the kind stands.
    let rec = open(ColumnOverrides {
        units: vec![("gx".into(), "deg/s".parse().unwrap())],
        kinds: vec![("gx".into(), Kind::Gyro)],
        ..Default::default()
    })
    .unwrap();
    assert!(rec
        .channels
        .iter()
        .any(|c| c.name == "gx" && c.kind == Kind::Gyro));
}

#[test]
fn an_ambiguous_time_unit_is_refused_naming_the_flag_and_a_stated_rate_settles_it() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("ambiguous.csv");
    // Whole numbers one apart: 1 Hz in seconds or 1 kHz in milliseconds.
    let ticks: Vec<i64> = (0..500).collect();
    csv_with_ticks(&p, &ticks, &noise(500, 2));
    let err = io::open(&p, &OpenOptions::default())
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("--time-unit") && err.contains("\"t\"") && err.contains("ambiguous"),
        "{err}"
    );
    let rec = open_with(&p, ColumnOverrides::default(), Some(1000.0));
    assert_eq!(rec.time.as_ref().unwrap().encoding.seconds_per_unit(), 1e-3);
    assert!((rec.rate_hz - 1000.0).abs() < 1e-9);
}

#[test]
fn an_arrow_integer_time_column_without_unit_is_inferred_from_its_intervals() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("us.arrow");
    let n = 3000;
    // 200 Hz in microseconds: only "us" gives a rate between 1 Hz and 10 kHz.
    let t: Vec<i64> = (0..n).map(|i| 5000 * i as i64).collect();
    let schema = Schema::new(vec![
        Field::new("time", DataType::Int64, false),
        Field::new("gx", DataType::Float64, false).with_metadata(std::collections::HashMap::from(
            [("unit".to_string(), "rad/s".to_string())],
        )),
    ]);
    let b = RecordBatch::try_new(
        Arc::new(schema),
        vec![
            Arc::new(Int64Array::from(t)),
            Arc::new(Float64Array::from(noise(n, 3))),
        ],
    )
    .unwrap();
    write_ipc_file(&p, &b, 1000);
    let rec = open_with(&p, ColumnOverrides::default(), None);
    assert!((rec.rate_hz - 200.0).abs() < 1e-9, "{}", rec.rate_hz);
    assert_eq!(rec.time.as_ref().unwrap().encoding.seconds_per_unit(), 1e-6);
}

fn screen(path: &Path, gaps: GapPolicy) -> pipeline::FileResult {
    let inputs = Inputs {
        open: OpenOptions::default(),
        quality: QualityOptions {
            gaps,
            ..Default::default()
        },
    };
    pipeline::run(
        path,
        &inputs,
        &Work::default(),
        &imunoise::estimate::CpuBackend,
        &Silent,
    )
    .unwrap_or_else(|e| panic!("{e}"))
}

/// Timestamps at 100 Hz, each off its instant by up to ±`jitter_ms`, with `drop` rows removed.
fn jittery(path: &Path, n: usize, jitter_ms: f64, drop: &[usize]) {
    let u = noise(n, 9);
    let keep: Vec<usize> = (0..n).filter(|i| !drop.contains(i)).collect();
    let t: Vec<i64> = keep
        .iter()
        .map(|&i| {
            // A bounded jitter: the normal deviate folded into ±1.
            let e = (u[i] * 0.7).tanh();
            ((i as f64 * 10.0 + e * jitter_ms) * 1e6).round() as i64
        })
        .collect();
    let g = noise(n, 10);
    let gx: Vec<f64> = keep.iter().map(|&i| g[i]).collect();
    let b = batch(
        &[
            time_col(keep.len(), 1.0, |k, _| t[k]),
            f64_col("gx", gx, Some("deg/s")),
        ],
        Some(100.0),
    );
    write_ipc_file(path, &b, 4096);
}

#[test]
fn jitter_is_not_a_gap_and_a_missing_sample_among_jitter_is() {
    let dir = tempfile::tempdir().unwrap();
    let clean = dir.path().join("jitter.arrow");
    // ±4 ms at 100 Hz: single intervals from 2 to 18 ms, yet no sample is missing.
    jittery(&clean, 30_000, 4.0, &[]);
    let r = screen(&clean, GapPolicy::Error);
    assert_eq!(r.quality.gap_count, 0);
    let j = r.quality.time_jitter.unwrap();
    assert!(
        j.max_s > 2e-3 && j.max_s < 4.5e-3 && j.rms_s > 5e-4,
        "{j:?}"
    );
    assert!(j.gaps_ambiguous, "±4 ms is 0.4 periods: gaps are ambiguous");

    let holes = dir.path().join("holes.arrow");
    // Three samples missing at row 10 000 and one at 20 000, under ±2 ms jitter.
    jittery(&holes, 30_000, 2.0, &[10_000, 10_001, 10_002, 20_000]);
    let r = screen(&holes, GapPolicy::Fill);
    assert_eq!(r.quality.gap_count, 2, "{:?}", r.quality.gaps);
    assert_eq!(r.quality.missing_samples, 4);
    assert_eq!(r.quality.filled_samples, 4);
    assert_eq!(r.quality.samples_out, 30_000);
    assert!(!r.quality.time_jitter.unwrap().gaps_ambiguous);
}

/// Timestamps that are exact to their floats' resolution (decimal seconds from the epoch, whose
/// spacing there is 2.4e-7 s) have no jitter to report, only rounding; the ±4-ms clock above has.
#[test]
fn rounding_of_float_timestamps_is_not_jitter() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("epoch.csv");
    let g = noise(30_000, 11);
    let mut text = String::from("time [s],gx [deg/s]\n");
    for (i, v) in g.iter().enumerate() {
        text.push_str(&format!("{:.2},{v}\n", 1.7e9 + i as f64 / 100.0));
    }
    std::fs::write(&path, text).unwrap();
    let j = screen(&path, GapPolicy::Error).quality.time_jitter.unwrap();
    assert!(j.max_s > 0.0, "the floats do round: {j:?}");
    assert_eq!(
        j.resolution_s,
        2f64.powi(-22),
        "spacing of floats near 1.7e9"
    );
    assert!(j.below_resolution(), "{j:?}");

    let clean = dir.path().join("jitter.arrow");
    jittery(&clean, 30_000, 4.0, &[]);
    let j = screen(&clean, GapPolicy::Error)
        .quality
        .time_jitter
        .unwrap();
    assert!(!j.below_resolution(), "{j:?}");
}

#[test]
fn stuck_and_unresolved_channels_are_named_and_not_fitted() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("stuck.arrow");
    let n = 40_000;
    let rate = 100.0;
    let lively = noise(n, 21).iter().map(|x| x * 0.01).collect::<Vec<_>>();
    let mut froze = noise(n, 22).iter().map(|x| x * 0.01).collect::<Vec<_>>();
    let held = froze[5000];
    froze[5000..5300].fill(held);
    let b = batch(
        &[
            time_col(n, rate, |_, t| t),
            f64_col("gx", lively, Some("deg/s")),
            f64_col("gy", vec![0.25; n], Some("deg/s")),
            f64_col(
                "gz",
                (0..n)
                    .map(|i| if i % 7 == 0 { 0.01 } else { 0.0 })
                    .collect(),
                Some("deg/s"),
            ),
            f64_col("ax", froze, Some("m/s^2")),
            f64_col("label", noise(n, 23), None),
        ],
        Some(rate),
    );
    write_ipc_file(&p, &b, 8192);
    let work = Work {
        welch: Some(pipeline::WelchWork {
            plan: imunoise::psd::WelchConfig::new(1024).validate().unwrap(),
            bins_per_decade: Some(20),
        }),
        avar: Some(pipeline::AvarWork {
            statistics: vec![imunoise::avar::Statistic::Oadev],
            taus: pipeline::TauSpec::Grid(imunoise::avar::TauGrid::Octave),
            confidence: imunoise::avar::Confidence::OneSigma,
        }),
        fit: Some(imunoise::model::FitOptions::default()),
        residual_loop: true,
    };
    let r = pipeline::run(
        &p,
        &Inputs::default(),
        &work,
        &imunoise::estimate::CpuBackend,
        &Silent,
    )
    .unwrap_or_else(|e| panic!("{e}"));
    let verdicts = |name: &str| {
        r.quality
            .channels
            .iter()
            .find(|c| c.name == name)
            .unwrap()
            .verdicts
            .clone()
    };
    assert!(verdicts("gx").is_empty(), "{:?}", verdicts("gx"));
    assert!(matches!(verdicts("gy")[..], [ChannelVerdict::Stuck { value }] if value > 0.0));
    assert!(
        matches!(
            verdicts("gz")[..],
            [ChannelVerdict::FewLevels { levels: 2, .. }]
        ),
        "{:?}",
        verdicts("gz")
    );
    assert!(
        matches!(
            verdicts("ax")[..],
            [ChannelVerdict::StuckRun {
                start_sample: 5000,
                samples: 300
            }]
        ),
        "{:?}",
        verdicts("ax")
    );
    assert_eq!(verdicts("label"), vec![ChannelVerdict::NoUnit]);
    // Only the analysable inertial channels are fitted: no model, and no invented line, for the
    // stuck or two-level ones.
    let fitted: Vec<String> = r
        .analysis
        .as_ref()
        .unwrap()
        .iter()
        .map(|a| a.channel.clone())
        .collect();
    assert_eq!(fitted, vec!["gx".to_string(), "ax".to_string()]);
}

#[test]
fn flags_that_do_not_fit_the_file_are_refused_by_name() {
    let root = repo_root();
    let sample = "data/sample_imu.arrow";
    let out = imunoise(&["info", sample, "--unit", "gyro_q=deg/s", "--json"], &root);
    assert_eq!(out.status.code(), Some(1), "{}", stderr(&out));
    assert!(
        stderr(&out).contains("--unit names column \"gyro_q\""),
        "{}",
        stderr(&out)
    );
    let out = imunoise(
        &["psd", sample, "--bins-per-decade", "100000", "--json"],
        &root,
    );
    assert_eq!(out.status.code(), Some(2));
    assert!(
        stderr(&out).contains("--bins-per-decade 100000"),
        "{}",
        stderr(&out)
    );
    let out = imunoise(
        &["analyze", sample, "--fit-min-freq", "80", "--json"],
        &root,
    );
    assert_eq!(out.status.code(), Some(1), "{}", stderr(&out));
    assert!(
        stderr(&out).contains("--fit-min-freq") && stderr(&out).contains("Nyquist"),
        "{}",
        stderr(&out)
    );
    let out = imunoise(
        &["info", sample, "--no-time", "--on-gap", "fill", "--json"],
        &root,
    );
    assert_eq!(out.status.code(), Some(2));
    assert!(stderr(&out).contains("--on-gap fill"), "{}", stderr(&out));
}

/// Raw counts of six axes given their scale by two patterns, as a datasheet states them.
#[test]
fn unit_patterns_reach_every_axis_they_name() {
    let dir = tempfile::tempdir().unwrap();
    let mut text = String::from("time,gyro_x,gyro_y,gyro_z,accel_x,accel_y,accel_z\n");
    for i in 0..2000 {
        let c = |k: i64| (i * 7919 + k * 104729) % 41 - 20;
        text.push_str(&format!(
            "{},{},{},{},{},{},{}\n",
            i as f64 * 0.01,
            c(1),
            c(2),
            c(3),
            c(4),
            c(5),
            8196 + c(6)
        ));
    }
    std::fs::write(dir.path().join("counts.csv"), text).unwrap();
    let out = run_ok(
        &[
            "info",
            "counts.csv",
            "--unit",
            "gyro_*=0.00875 deg/s",
            "--unit",
            "accel_?=0.000122 g",
            "--json",
        ],
        dir.path(),
    );
    let doc: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let channels = doc["files"][0]["recording"]["channels"].as_array().unwrap();
    assert_eq!(channels.len(), 6);
    for ch in channels {
        let gyro = ch["name"].as_str().unwrap().starts_with("gyro");
        let (unit, kind, scale) = if gyro {
            ("deg/s", "gyro", 0.00875)
        } else {
            ("g", "accel", 0.000122)
        };
        assert_eq!(
            (ch["unit"].as_str(), ch["kind"].as_str()),
            (Some(unit), Some(kind)),
            "{ch}"
        );
        assert_eq!(ch["scale"].as_f64(), Some(scale), "{ch}");
    }
    let out = imunoise(&["info", "counts.csv", "--unit", "gyr_*=deg/s"], dir.path());
    assert_eq!(out.status.code(), Some(1), "{}", stderr(&out));
    assert!(
        stderr(&out).contains("--unit names column \"gyr_*\""),
        "{}",
        stderr(&out)
    );
}

#[test]
fn a_file_without_units_is_not_analysed_as_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("nounits.csv");
    write_csv(
        &p,
        &[("a", None), ("b", None)],
        &[noise(5000, 4), noise(5000, 5)],
    );
    let out = imunoise(
        &[
            "analyze",
            p.to_str().unwrap(),
            "--rate",
            "100",
            "--nperseg",
            "512",
            "-o",
            dir.path().join("out").to_str().unwrap(),
        ],
        dir.path(),
    );
    assert_eq!(out.status.code(), Some(1), "{}", stderr(&out));
    let e = stderr(&out);
    assert!(
        e.contains("no gyro or accelerometer channel")
            && e.contains("a (no unit)")
            && e.contains("--unit"),
        "{e}"
    );
    assert!(!dir.path().join("out").join("imu.yaml").exists());
}

#[test]
fn simulate_wants_units_and_writes_the_format_its_extension_names() {
    let dir = tempfile::tempdir().unwrap();
    let run = |args: &[&str]| imunoise(args, dir.path());
    let out = run(&[
        "simulate",
        "--rate",
        "100",
        "--duration",
        "60",
        "--noise",
        "N=0.15",
        "-o",
        "x.arrow",
    ]);
    assert_eq!(out.status.code(), Some(2));
    assert!(stderr(&out).contains("give a unit"), "{}", stderr(&out));
    let out = run(&[
        "simulate",
        "--rate",
        "100",
        "--duration",
        "60",
        "--noise",
        "N=0.15deg/sqrt(h)",
        "-o",
        "x.txt",
    ]);
    assert_eq!(out.status.code(), Some(2));
    assert!(stderr(&out).contains(".csv"), "{}", stderr(&out));
    let out = run(&[
        "simulate",
        "--rate",
        "100",
        "--duration",
        "60",
        "--noise",
        "N=0.15deg/sqrt(h)",
        "-o",
        "missing/x.arrow",
    ]);
    assert_eq!(out.status.code(), Some(2));
    let e = stderr(&out);
    assert!(
        e.contains("missing") && e.contains("does not exist") && !e.contains(".x.arrow."),
        "{e}"
    );
    for name in ["x.csv", "x.parquet", "x.arrows", "x.arrow"] {
        let out = run(&[
            "simulate",
            "--rate",
            "100",
            "--duration",
            "60",
            "--seed",
            "3",
            "--noise",
            "N=0.15deg/sqrt(h)",
            "-o",
            name,
        ]);
        assert_eq!(out.status.code(), Some(0), "{name}: {}", stderr(&out));
        let rec = io::open(&dir.path().join(name), &OpenOptions::default())
            .unwrap_or_else(|e| panic!("{name}: {e}"));
        assert!(
            (rec.rate_hz - 100.0).abs() < 1e-6,
            "{name}: {}",
            rec.rate_hz
        );
        assert_eq!(rec.channels.len(), 3, "{name}");
        assert_eq!(rec.channels[0].kind, imunoise::units::Kind::Gyro, "{name}");
    }
    let bytes = std::fs::read(dir.path().join("x.csv")).unwrap();
    assert!(
        bytes.starts_with(b"time [s],gyro_x [rad/s]"),
        "{:?}",
        &bytes[..40]
    );
}

#[test]
fn version_names_the_commit() {
    let out = imunoise(&["--version"], &repo_root());
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.contains("(commit "), "{text}");
}

#[test]
fn a_model_restricted_to_terms_that_cannot_fit_is_warned_about() {
    let dir = tempfile::tempdir().unwrap();
    let out = imunoise(
        &[
            "analyze",
            "data/sample_imu.arrow",
            "--terms",
            "K",
            "--no-loop",
            "--backend",
            "cpu",
            "-o",
            dir.path().to_str().unwrap(),
        ],
        &repo_root(),
    );
    assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
    let e = stderr(&out);
    for channel in ["gyro_x", "accel_x"] {
        assert!(
            e.lines()
                .any(|l| l.contains(channel) && l.contains("lack of fit") && l.contains("widened")),
            "{e}"
        );
    }
}

/// A gyro axis whose unit is missing is left out of the noise analysis (it is not a gyro without
/// one), and every batch output says so: `analyze`'s stderr and summary.md, `screen`'s stderr
/// and fleet summary. Before, the axis simply was not there.
#[test]
fn an_axis_without_a_unit_is_named_wherever_it_is_left_out() {
    let dir = tempfile::tempdir().unwrap();
    let fleet = dir.path().join("fleet");
    std::fs::create_dir(&fleet).unwrap();
    let p = fleet.join("imu.csv");
    let scaled = |seed| noise(20_000, seed).iter().map(|v| 1e-3 * v).collect();
    write_csv(
        &p,
        &[("gyro_x", Some("rad/s")), ("gyro_y", None)],
        &[scaled(6), scaled(7)],
    );
    let common = [
        "--rate",
        "100",
        "--nperseg",
        "512",
        "--no-loop",
        "--backend",
        "cpu",
    ];
    let mut args = vec!["analyze", p.to_str().unwrap(), "-o", "out"];
    args.extend(common);
    // Runs `args`, which must succeed and say on stderr, on a line starting with `prefix`, that
    // gyro_y has no unit.
    let run_and_check = |args: &[&str], prefix: &str| {
        let out = imunoise(args, dir.path());
        let e = stderr(&out);
        assert_eq!(out.status.code(), Some(0), "{e}");
        assert!(
            e.lines()
                .any(|l| l.starts_with(prefix) && l.contains("gyro_y: no unit")),
            "{e}"
        );
    };
    run_and_check(&args, "quality ");
    let summary = std::fs::read_to_string(dir.path().join("out/summary.md")).unwrap();
    assert!(summary.contains("gyro_y: no unit"), "{summary}");

    let mut args = vec!["screen", "fleet", "-o", "screened"];
    args.extend(common);
    run_and_check(&args, "note ");
    let fleet_summary = std::fs::read_to_string(dir.path().join("screened/summary.md")).unwrap();
    assert!(
        fleet_summary.contains("## Channels not analysed") && fleet_summary.contains("gyro_y"),
        "{fleet_summary}"
    );
}

/// Digital outputs on a coarse grid, as real converters give them. A rate rounded to a step of
/// its white σ: N carries the rounding, and an `output_resolution` warning gives the sensor's N
/// without it (the truth, within its interval's reach); a step of 4σ: the warning says the N
/// cannot be read off. An integrated angle rounded (IEEE Q, an output of four levels): its grid
/// is the Q the fits find, so no rounding warning, no saturation verdict for its populous
/// extreme levels, and no effect — once a removal moved the series off its grid, the spike
/// detector took 23 % of the samples for spikes and the loop ended with N a thousandth of the truth.
#[test]
fn coarse_digital_outputs_are_read_as_what_they_are() {
    let dir = tempfile::tempdir().unwrap();
    let (n, b, k) = (4.363e-5, 1.454e-5, 1.616e-6);
    let noise = serde_json::json!({ "n": n, "b": b, "k": k });
    let sigma = n * 10.0; // white σ per sample at 100 Hz
    let spec = serde_json::json!({ "rate_hz": 100.0, "duration_s": 1800.0, "seed": 43,
        "channels": [
            { "name": "fine", "sensor": "gyro", "noise": noise },
            { "name": "rounded", "sensor": "gyro", "noise": noise, "lsb": sigma },
            { "name": "coarse", "sensor": "gyro", "noise": noise, "lsb": 4.0 * sigma },
            { "name": "angle", "sensor": "gyro",
              "noise": { "q": 4.363e-6, "n": n, "b": b, "k": k } } ] });
    let (e, doc) = simulate_and_analyze(dir.path(), &spec);
    let file = &doc["files"][0];
    let analysis = |name: &str| channel_analysis(&doc, name);
    let resolution = |name: &str| combined_warning(&doc, name, "output_resolution");
    let term = |name: &str, symbol: &str| combined_value(&doc, name, symbol);
    assert!(resolution("fine").is_none());

    let w = resolution("rounded").expect("a warning on the rounded axis");
    let without = w["n_without"].as_f64().unwrap();
    // The output's N is √(1 + 1/12) times the sensor's; without the rounding, the truth.
    let output_n = term("rounded", "random_walk").unwrap();
    assert!(output_n / n > 1.03, "output N {output_n}");
    assert!(
        (without / n - 1.0).abs() < 0.01,
        "N without rounding {without}"
    );
    assert!(e.contains("rounded: the samples lie on a grid"), "{e}");

    let w = resolution("coarse").expect("a warning on the coarse axis");
    assert!(w["n_hi"].is_null(), "{w}");
    assert!(w["steps_per_sigma"].as_f64().unwrap() > 2.7, "{w}");

    assert!(resolution("angle").is_none());
    let angle = analysis("angle");
    let steps = angle["residual_loop"]["steps"].as_array().unwrap();
    assert!(
        steps.is_empty(),
        "effects on the angle-quantised axis: {steps:?}"
    );
    let q = term("angle", "quantization").expect("Q found");
    assert!((q / 4.363e-6 - 1.0).abs() < 0.1, "Q {q}");
    let angle_n = term("angle", "random_walk").unwrap();
    assert!((angle_n / n - 1.0).abs() < 0.05, "N {angle_n}");
    let verdicts = &file["quality"]["channels"]
        .as_array()
        .unwrap()
        .iter()
        .find(|c| c["name"] == "angle")
        .unwrap()["verdicts"];
    assert_eq!(verdicts.as_array().map(Vec::len), Some(0), "{verdicts}");

    // A screen flags the axis whose noise the grid hides, and only that one.
    run_ok(
        &["screen", "sim.arrow", "-o", "screened", "--backend", "cpu"],
        dir.path(),
    );
    let fleet = std::fs::read_to_string(dir.path().join("screened/summary.md")).unwrap();
    let flagged: Vec<&str> = fleet
        .lines()
        .filter(|l| l.contains("| coarse_output |"))
        .collect();
    assert_eq!(flagged.len(), 1, "{fleet}");
    assert!(flagged[0].contains("| coarse |"), "{fleet}");
}

/// Heavy-tailed white noise is not mistaken for glitches without a word: on a Student-t axis (4
/// degrees of freedom) the samples beyond the spike threshold are counted and removed, and a
/// `heavy_tail` warning gives N with them, the planted N within 4 % (the N without them reads
/// several % low); ±8σ glitches on 1 % of another axis are removed with no such warning, N right.
#[test]
fn heavy_tailed_noise_is_told_from_glitches() {
    let dir = tempfile::tempdir().unwrap();
    let (n, b, k) = (4.363e-5, 1.454e-5, 1.616e-6);
    let noise = serde_json::json!({ "n": n, "b": b, "k": k });
    let spec = serde_json::json!({ "rate_hz": 100.0, "duration_s": 1800.0, "seed": 47,
        "channels": [
            { "name": "tails", "sensor": "gyro", "noise": noise, "white_tail_dof": 4.0 },
            { "name": "glitches", "sensor": "gyro", "noise": noise,
              "spikes": { "count": 1800, "size": 8.0 * n * 10.0 } } ] });
    let (e, doc) = simulate_and_analyze(dir.path(), &spec);
    let warning = |name: &str| combined_warning(&doc, name, "heavy_tail");
    let n_of = |name: &str| combined_value(&doc, name, "random_walk").unwrap();
    let w = warning("tails").expect("a heavy-tail warning on the Student-t axis");
    let with = w["n_with"].as_f64().unwrap();
    assert!((with / n - 1.0).abs() < 0.04, "N with the tail {with}");
    assert!(
        n_of("tails") / n < 0.98,
        "N without the tail {}",
        n_of("tails")
    );
    assert!(
        w["shoulder"].as_f64().unwrap() > 10.0 * w["shoulder_gaussian"].as_f64().unwrap(),
        "{w}"
    );
    assert!(
        e.contains("tails: the") && e.contains("far end of a tail"),
        "{e}"
    );
    assert!(warning("glitches").is_none());
    assert!(
        (n_of("glitches") / n - 1.0).abs() < 0.02,
        "{}",
        n_of("glitches")
    );
}

/// A MEMS unit with everything at once: a digital second-order low-pass at 40 Hz on every axis,
/// a rounded output, a warm-up, and on single axes glitches, a wandering 23 Hz line and a
/// temperature coupling (x), an excursion (y), a Gauss–Markov process (z), a resonance in the
/// filter's transition band (accel, measured as a band beyond the fit band). Each effect is found on its axis and nowhere else, and the
/// filter is read right on every axis: once, the glitches' white floor after the filter turned it
/// into a first-order 25 Hz one with a 3.6 Hz fit band, and the line was dropped as the filter's
/// edge.
#[test]
fn a_sensor_with_everything_at_once_is_taken_apart() {
    let dir = tempfile::tempdir().unwrap();
    let gyro = serde_json::json!({ "n": 8.7e-5, "b": 2.9e-5, "k": 3e-6 });
    let lp = serde_json::json!({ "corner_hz": 40.0, "order": 2 });
    let spec = serde_json::json!({ "rate_hz": 200.0, "duration_s": 3600.0, "seed": 7,
        "temperature": { "start_degc": 20.0, "rise_degc": 5.0, "warmup_s": 900.0,
                         "wander": { "sigma": 0.3, "tc_s": 300.0 }, "noise_degc": 0.02 },
        "channels": [
            { "name": "gyro_x", "sensor": "gyro", "bias": 0.002, "noise": gyro, "lowpass": lp,
              "lsb": 1.33e-4, "temperature_coefficient": 1e-4,
              "sinusoids": [ { "amplitude": 6e-4, "freq_hz": 23.0, "wander":
                  { "freq_wander_hz": 0.1, "amplitude_wander": 0.2, "wander_tc_s": 5.0 } } ],
              "spikes": { "count": 300, "size": 0.02 } },
            { "name": "gyro_y", "sensor": "gyro", "bias": -0.001, "noise": gyro, "lowpass": lp,
              "lsb": 1.33e-4,
              "steps": [ { "time_s": 1200.0, "size": 3e-4 }, { "time_s": 1500.0, "size": -3e-4 } ] },
            { "name": "gyro_z", "sensor": "gyro", "noise": gyro, "lowpass": lp, "lsb": 1.33e-4,
              "gauss_markov": [ { "sigma": 2e-4, "tc_s": 30.0 } ] },
            { "name": "accel_x", "sensor": "accel", "bias": 9.81,
              "noise": { "n": 6e-4, "b": 2e-4, "k": 1e-5 }, "lowpass": lp, "lsb": 5.98e-4,
              "resonances": [ { "f0_hz": 31.0, "q": 15.0, "sigma": 1.5e-3 } ] } ] });
    let (_, doc) = simulate_and_analyze(dir.path(), &spec);
    let analyses = doc["files"][0]["analysis"].as_array().unwrap();
    assert_eq!(analyses.len(), 4);
    for a in analyses {
        let name = a["channel"].as_str().unwrap();
        let lp = &a["bandwidth"]["lowpass"];
        let corner = lp["corner_hz"].as_f64().unwrap_or(0.0);
        assert!(
            (corner / 40.0 - 1.0).abs() < 0.1 && lp["order"] == 2,
            "{name}: {}",
            a["bandwidth"]
        );
        let mut kinds: Vec<&str> = a["residual_loop"]["steps"]
            .as_array()
            .unwrap()
            .iter()
            .map(|s| s["effect"]["kind"].as_str().unwrap())
            .collect();
        kinds.sort_unstable();
        let expected: &[&str] = match name {
            "gyro_x" => &["coupling", "narrowband", "spikes"],
            "gyro_y" => &["excursion"],
            "gyro_z" => &["gauss_markov"],
            // The resonance lies beyond the fit band, in the filter's transition band: a peak
            // there, measured as a band (it was once dismissed as the filter's edge).
            _ => &["narrowband"],
        };
        assert_eq!(kinds, expected, "{name}");
        if name == "gyro_x" {
            let line = a["residual_loop"]["steps"]
                .as_array()
                .unwrap()
                .iter()
                .find(|s| s["effect"]["kind"] == "narrowband")
                .unwrap();
            let f = line["effect"]["freq_hz"].as_f64().unwrap();
            assert!((f - 23.0).abs() < 0.2, "line at {f} Hz");
        }
        if name == "accel_x" {
            let peak = &a["residual_loop"]["steps"][0]["effect"];
            let f = peak["freq_hz"].as_f64().unwrap();
            assert!((f - 31.0).abs() < 0.5, "peak at {f} Hz");
            // The resonance's variance through the filter at its frequency.
            let filter = imunoise::sim::LowPassSpec {
                corner_hz: 40.0,
                order: 2,
            };
            let expected = 1.5e-3f64.powi(2) * imunoise::sim::lowpass_power_gain(&filter, 200.0, f);
            let power = peak["power"].as_f64().unwrap();
            assert!(
                (power / expected - 1.0).abs() < 0.25,
                "power {power} against {expected}"
            );
        }
    }
}

/// A gap filled with a straight line (`--on-gap fill`) is no measurement: the line between two
/// single noisy samples sits off the local mean and carries no noise, and the loop took its ends
/// for bias steps (±170 °/h on a 100-Hz gyro) and its span for an excursion, which then also
/// weighed as a rival. Now no level change is claimed there: each is listed as rejected with the
/// reason, and none is a rival.
#[test]
fn a_filled_gap_is_no_step_and_no_excursion() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("gap.csv");
    let (fs, n, gap) = (100.0, 60_000, 30_000..30_500);
    let white = noise(n, 21);
    let walk = noise(n, 22);
    let mut level = 0.0;
    let mut text = String::from("t,gx [deg/s],gy [deg/s]\n");
    for i in 0..n {
        level += 2e-4 * walk[i];
        if !gap.contains(&i) {
            let v = 0.05 * white[i] + level;
            let w = 0.05 * walk[(i + 7) % n] - level;
            text.push_str(&format!("{:.2},{v:?},{w:?}\n", i as f64 / fs));
        }
    }
    std::fs::write(&p, text).unwrap();
    let out = imunoise(
        &[
            "analyze",
            p.to_str().unwrap(),
            "--on-gap",
            "fill",
            "--json",
            "--backend",
            "cpu",
        ],
        dir.path(),
    );
    assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
    let report: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    for a in report["files"][0]["analysis"].as_array().unwrap() {
        let r = &a["residual_loop"];
        for s in r["steps"].as_array().unwrap() {
            let kind = s["effect"]["kind"].as_str().unwrap_or("");
            assert!(
                kind != "step" && kind != "excursion",
                "{}: {s}",
                a["channel"]
            );
        }
        let rival = r["rival"]["effect"]["kind"].as_str().unwrap_or("");
        assert!(
            rival != "step" && rival != "excursion",
            "{}: {}",
            a["channel"],
            r["rival"]
        );
    }
    let text = report.to_string();
    assert!(
        text.contains("at the gap filled with a straight line"),
        "no level change was even tried at the fill"
    );
}

/// An empty file, or one whose timestamps all repeat, has a time column that gives no rate: the
/// error says so, naming it, where it used to ask for "a time column" the file has.
#[test]
fn a_time_column_without_a_rate_is_named_not_asked_for() {
    let dir = tempfile::tempdir().unwrap();
    for (name, text) in [
        ("empty.csv", "t,gx [deg/s]\n".to_string()),
        ("same.csv", "t,gx [deg/s]\n0,1\n0,2\n0,3\n".to_string()),
    ] {
        let p = dir.path().join(name);
        std::fs::write(&p, text).unwrap();
        let err = io::open(&p, &OpenOptions::default())
            .unwrap_err()
            .to_string();
        assert!(
            err.contains(name)
                && err.contains("\"t\"")
                && err.contains("gives no sample rate")
                && err.contains("--rate")
                && !err.contains("add schema metadata"),
            "{err}"
        );
    }
}
