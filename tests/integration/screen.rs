//! `imunoise screen` end to end on simulated fleets: exactly the planted faults flagged, sharded
//! runs equal to one run, reruns that skip finished files, bad files as error rows, the lock.
//!
//! Every fleet is 3-axis gyros at 100 Hz made with `imunoise::sim` on fixed seeds (100 + file
//! index, the first tried); the units' angle random walks differ by up to ±8 % (a deterministic
//! spread, as real units of one batch do), so the fleet has a spread for the robust z to measure.

use std::path::{Path, PathBuf};
use std::process::Output;

use arrow_array::RecordBatch;
use imunoise::io::StoredAs;
use imunoise::model::{CoefUnit, Coefficients, Sensor};
use imunoise::sim::{simulate, ChannelSpec, SimSpec, SinusoidSpec, StepSpec};
use parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder;

use super::support::imunoise;

const FS: f64 = 100.0;

/// N of the fleet's nominal unit: 0.15 °/√h.
fn n0() -> f64 {
    CoefUnit::DegPerSqrtH.to_si(0.15)
}

/// The three axes of unit `i`: N within ±8 % of [`n0`], B = 3 °/h, K = 5 °/h/√h.
fn axes(i: usize) -> Vec<ChannelSpec> {
    ["gyro_x", "gyro_y", "gyro_z"]
        .iter()
        .enumerate()
        .map(|(a, name)| {
            let spread = 1.0 + 0.08 * ((3 * i + a) as f64 * 1.7).sin();
            ChannelSpec::new(
                *name,
                Sensor::Gyro,
                Coefficients {
                    n: n0() * spread,
                    b: CoefUnit::DegPerH.to_si(3.0),
                    k: CoefUnit::DegPerHPerSqrtH.to_si(5.0),
                    ..Default::default()
                },
            )
        })
        .collect()
}

/// Writes unit `i` as `dir/imuNN.arrow` (`seconds` long, seed 100 + i), after `plant` edits its
/// channels.
fn write_unit(dir: &Path, i: usize, seconds: f64, plant: impl Fn(&mut ChannelSpec)) -> PathBuf {
    write_unit_seeded(dir, i, seconds, 100 + i as u64, plant)
}

fn write_unit_seeded(
    dir: &Path,
    i: usize,
    seconds: f64,
    seed: u64,
    plant: impl Fn(&mut ChannelSpec),
) -> PathBuf {
    let mut channels = axes(i);
    channels.iter_mut().for_each(plant);
    let spec = SimSpec {
        rate_hz: FS,
        duration_s: seconds,
        seed,
        channels,
        temperature: None,
    };
    let sim = simulate(&spec).unwrap();
    let path = dir.join(format!("imu{i:02}.arrow"));
    sim.write(&path, StoredAs::F64).unwrap();
    path
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

fn lines_starting(o: &Output, prefix: &str) -> usize {
    stderr(o).lines().filter(|l| l.starts_with(prefix)).count()
}

fn read_batches(path: &Path) -> Vec<RecordBatch> {
    let f = std::fs::File::open(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    ParquetRecordBatchReaderBuilder::try_new(f)
        .unwrap()
        .build()
        .unwrap()
        .map(Result::unwrap)
        .collect()
}

/// The values of a column of the fleet table as strings (`null` for nulls).
fn column_text(batches: &[RecordBatch], name: &str) -> Vec<String> {
    let mut out = Vec::new();
    for b in batches {
        let c = b
            .column_by_name(name)
            .unwrap_or_else(|| panic!("no {name}"));
        for i in 0..b.num_rows() {
            out.push(if c.is_null(i) {
                "null".into()
            } else {
                arrow_array::cast::as_string_array(c).value(i).to_string()
            });
        }
    }
    out
}

fn column_bool(batches: &[RecordBatch], name: &str) -> Vec<bool> {
    batches
        .iter()
        .flat_map(|b| {
            let c = arrow_array::cast::as_boolean_array(b.column_by_name(name).unwrap());
            (0..b.num_rows()).map(|i| c.value(i)).collect::<Vec<_>>()
        })
        .collect()
}

fn parts(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    for shard in std::fs::read_dir(dir.join("results")).unwrap() {
        for p in std::fs::read_dir(shard.unwrap().path()).unwrap() {
            out.push(p.unwrap().path());
        }
    }
    out.sort();
    out
}

/// Twenty units of 3 minutes; unit 3 has three times the angle random walk on every axis, unit 7
/// a vibration line (1e-3 rad/s at 7.3 Hz, 2.3× the white noise's per-sample σ), unit 12 a bias
/// step at 80 s of 30× the white σ of 10-s means (4.1e-4 rad/s). With N ≤ 0.25 °/√h in the spec:
/// unit 3 fails N and is an N outlier, units 7 and 12 show an effect no other unit shows; no other
/// channel may be flagged.
///
/// Measured (2 cores, release): 1.4–2.2 s per file (3.3 s for the two with an effect). Unit 3's N
/// reads 0.448–0.454 °/√h, robust z +12.5 to +12.7 against the fleet median 0.150 °/√h; the line
/// (amplitude within 1 %) and the step (80.0 s, −6 % to +16 % in size) were found on every axis of
/// their units and on no other channel; four B verdicts were undecided (one interval straddling
/// 10 °/h, three upper limits only, on unit 3), which does not flag. A rerun skips all twenty.
#[test]
fn a_fleet_with_three_planted_faults_flags_exactly_those_and_a_rerun_skips_every_file() {
    let tmp = tempfile::tempdir().unwrap();
    let fleet = tmp.path().join("fleet");
    std::fs::create_dir(&fleet).unwrap();
    for i in 0..20 {
        write_unit(&fleet, i, 180.0, |c| match i {
            3 => c.noise.n = 3.0 * n0(),
            7 => c.sinusoids.push(SinusoidSpec {
                amplitude: 1e-3,
                freq_hz: 7.3,
                phase_rad: 0.0,
                wander: None,
            }),
            12 => c.steps.push(StepSpec {
                time_s: 80.0,
                size: 30.0 * n0() / 10f64.sqrt(),
            }),
            _ => {}
        });
    }
    std::fs::write(
        tmp.path().join("spec.toml"),
        "[gyro]\nN = \"0.25 deg/sqrt(h)\"  # ARW\nB = \"10 deg/h\"\n[fleet]\noutlier_z = 3.5\n",
    )
    .unwrap();
    let args = [
        "screen",
        "fleet",
        "-o",
        "out",
        "--spec",
        "spec.toml",
        "--backend",
        "cpu",
    ];
    let first = imunoise(&args, tmp.path());
    // Unit 3 fails its N limit on three axes: exit 3 (`--fail-on fail`, the default).
    assert_eq!(first.status.code(), Some(3), "{}", stderr(&first));
    assert!(
        stderr(&first).contains("exit 3: 3 channels fail a limit"),
        "{}",
        stderr(&first)
    );
    assert_eq!(lines_starting(&first, "done  "), 20, "{}", stderr(&first));
    // Where the 20 files' time went, by stage: every stage named, the fits (with the loop) the
    // largest, the shares adding up to 100 % within rounding.
    let time = stderr(&first)
        .lines()
        .find_map(|l| l.strip_prefix("time of the 20 files computed, summed over files: "))
        .map(str::to_owned)
        .unwrap_or_else(|| panic!("{}", stderr(&first)));
    let stages: Vec<(String, f64, f64)> = time
        .split(", ")
        .map(|stage| {
            // "fit and loop 12.3 s (81 %)"
            let (head, share) = stage.split_once(" s (").unwrap();
            let (what, seconds) = head.rsplit_once(' ').unwrap();
            let share = share.trim_end_matches(" %)");
            (
                what.to_owned(),
                seconds.parse().unwrap(),
                share.parse().unwrap(),
            )
        })
        .collect();
    let names: Vec<&str> = stages.iter().map(|s| s.0.as_str()).collect();
    assert_eq!(
        names,
        ["read and screen", "estimate", "fit and loop", "write"],
        "{time}"
    );
    assert!(stages.iter().all(|s| s.1 >= 0.0), "{time}");
    let shares: f64 = stages.iter().map(|s| s.2).sum();
    assert!((shares - 100.0).abs() <= 2.0, "{time}");
    assert!(
        stages[2].1 > stages[1].1 && stages[2].1 > stages[0].1,
        "{time}"
    );
    let out = tmp.path().join("out");
    assert_eq!(parts(&out).len(), 20);

    let table = read_batches(&out.join("fleet.parquet"));
    let sensors = column_text(&table, "sensor");
    let flagged = column_bool(&table, "flagged");
    assert_eq!(sensors.len(), 60);
    let mut flagged_sensors: Vec<&str> = sensors
        .iter()
        .zip(&flagged)
        .filter(|(_, f)| **f)
        .map(|(s, _)| s.as_str())
        .collect();
    flagged_sensors.dedup();
    assert_eq!(flagged_sensors, ["imu03", "imu07", "imu12"]);
    // Every axis of a planted unit, for its own reason.
    let n_verdict = column_text(&table, "n_verdict");
    let n_outlier = column_bool(&table, "n_outlier");
    let unusual = column_text(&table, "unusual_effects");
    for (row, sensor) in sensors.iter().enumerate() {
        let why = (
            n_verdict[row].as_str(),
            n_outlier[row],
            unusual[row].as_str(),
        );
        match sensor.as_str() {
            "imu03" => assert_eq!(why, ("fail", true, ""), "{row}"),
            "imu07" => assert_eq!(why, ("pass", false, "sinusoid"), "{row}"),
            "imu12" => assert_eq!(why, ("pass", false, "step"), "{row}"),
            _ => assert_eq!(why, ("pass", false, ""), "{sensor} {row}"),
        }
    }
    let summary = std::fs::read_to_string(out.join("summary.md")).unwrap();
    assert!(
        summary.contains("| flagged channels | 9 (sensors: imu03, imu07, imu12) |"),
        "{summary}"
    );
    let html = std::fs::read_to_string(out.join("fleet.html")).unwrap();
    assert!(html.contains("<svg") && html.contains("imu03"));
    // Self-contained: nothing fetched (the only URL is the SVG namespace).
    for needle in ["src=", "<link", "<script", "@import"] {
        assert!(!html.contains(needle), "{needle}");
    }
    assert!(!html
        .replace("http://www.w3.org/2000/svg", "")
        .contains("http"));

    // The rerun: nothing recomputed, the same table. With `--plots failures` the flagged units
    // get their plots, the outlier and the unusual effects too (known only in the fleet step,
    // which analyses those files again), and no other unit.
    let mut plotted = args.to_vec();
    plotted.extend(["--plots", "failures", "--fail-on", "never"]);
    let again = imunoise(&plotted, tmp.path());
    assert_eq!(again.status.code(), Some(0), "{}", stderr(&again));
    let mut plot_dirs: Vec<String> = std::fs::read_dir(out.join("plots"))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    plot_dirs.sort();
    assert_eq!(plot_dirs.len(), 3, "{plot_dirs:?}");
    for (dir, unit) in plot_dirs.iter().zip(["imu03", "imu07", "imu12"]) {
        assert!(dir.starts_with(unit), "{plot_dirs:?}");
        assert!(
            std::fs::read_dir(out.join("plots").join(dir))
                .unwrap()
                .count()
                > 0,
            "{dir}"
        );
    }
    assert_eq!(lines_starting(&again, "skipped "), 20, "{}", stderr(&again));
    assert_eq!(lines_starting(&again, "done  "), 0, "{}", stderr(&again));
    assert!(
        stderr(&again).contains("0 computed, 20 skipped"),
        "{}",
        stderr(&again)
    );
    assert!(
        !stderr(&again).contains("time of the"),
        "{}",
        stderr(&again)
    );
    assert_eq!(read_batches(&out.join("fleet.parquet")), table);
    // A corrupt input beside the failing limits: exit 1 (inputs failed outranks 3), and the line
    // says which code it is, not "exit 3".
    std::fs::write(tmp.path().join("fleet").join("imu99.arrow"), b"not arrow").unwrap();
    let bad = imunoise(&args, tmp.path());
    assert_eq!(bad.status.code(), Some(1), "{}", stderr(&bad));
    assert!(
        stderr(&bad)
            .contains("exit 1 (inputs failed, which outranks exit 3): 3 channels fail a limit"),
        "{}",
        stderr(&bad)
    );
}

/// Nine units of one minute, fitted without the loop (fast): three shards run one after the other
/// into one folder give the fleet table of a single run; a rerun skips every file; a file whose
/// content changed (same name, another seed) is the only one recomputed; a file removed from the
/// fleet leaves the table.
#[test]
fn shards_give_the_single_runs_table_and_reruns_recompute_only_what_changed() {
    let tmp = tempfile::tempdir().unwrap();
    let fleet = tmp.path().join("fleet");
    std::fs::create_dir(&fleet).unwrap();
    for i in 0..9 {
        write_unit(&fleet, i, 60.0, |_| {});
    }
    let run = |out: &str, extra: &[&str]| {
        let mut args = vec![
            "screen",
            "fleet",
            "-o",
            out,
            "--backend",
            "cpu",
            "--no-loop",
        ];
        args.extend_from_slice(extra);
        imunoise(&args, tmp.path())
    };
    let single = run("one", &[]);
    assert_eq!(single.status.code(), Some(0), "{}", stderr(&single));
    let mut per_shard = Vec::new();
    for k in 0..3 {
        let shard = format!("{k}/3");
        let o = run("many", &["--shard", &shard]);
        assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
        per_shard.push(lines_starting(&o, "done  "));
        let summary = std::fs::read_to_string(tmp.path().join("many/summary.md")).unwrap();
        // Every input not computed yet is pending, those of the shards not run yet included.
        let done: usize = per_shard.iter().sum();
        let pending = format!("| pending (not computed yet) | {}", 9 - done);
        assert!(summary.contains(&pending), "{pending}: {summary}");
        if k < 2 {
            assert!(summary.contains("shards not run yet"), "{summary}");
        }
    }
    // Every file in exactly one shard; the shards together are the fleet.
    assert_eq!(per_shard.iter().sum::<usize>(), 9, "{per_shard:?}");
    let many_parts = parts(&tmp.path().join("many"));
    assert_eq!(many_parts.len(), 9);
    let one_table = read_batches(&tmp.path().join("one/fleet.parquet"));
    assert_eq!(
        read_batches(&tmp.path().join("many/fleet.parquet")),
        one_table
    );
    assert_eq!(column_text(&one_table, "sensor").len(), 27);

    // Rerun: nothing recomputed.
    let again = run("one", &[]);
    assert_eq!(lines_starting(&again, "skipped "), 9, "{}", stderr(&again));
    assert_eq!(lines_starting(&again, "done  "), 0, "{}", stderr(&again));
    // One file rewritten with other samples: only it is recomputed.
    write_unit_seeded(&fleet, 4, 60.0, 999, |_| {});
    let changed = run("one", &[]);
    assert_eq!(
        lines_starting(&changed, "skipped "),
        8,
        "{}",
        stderr(&changed)
    );
    assert_eq!(
        lines_starting(&changed, "done  "),
        1,
        "{}",
        stderr(&changed)
    );
    assert!(stderr(&changed).contains("done  fleet/imu04.arrow"));
    // Other analysis options: everything recomputed.
    let options = run("one", &["--nperseg", "2048"]);
    assert_eq!(
        lines_starting(&options, "done  "),
        9,
        "{}",
        stderr(&options)
    );
    // A file removed from the fleet leaves the folder and the table.
    std::fs::remove_file(fleet.join("imu08.arrow")).unwrap();
    let fewer = run("one", &["--nperseg", "2048"]);
    assert_eq!(lines_starting(&fewer, "done  "), 0, "{}", stderr(&fewer));
    assert_eq!(parts(&tmp.path().join("one")).len(), 8);
    let table = read_batches(&tmp.path().join("one/fleet.parquet"));
    assert!(!column_text(&table, "sensor").contains(&"imu08".to_string()));
}

/// A corrupt, an empty and a mislabelled file among five good ones, and a listed file that no
/// longer exists (given through a second --files-from): each is a row with its error, the good ones are written, the exit code is 1; the rerun skips
/// the error results too and still exits 1.
#[test]
fn bad_files_are_error_rows_and_do_not_stop_the_batch() {
    let tmp = tempfile::tempdir().unwrap();
    let fleet = tmp.path().join("fleet");
    std::fs::create_dir(&fleet).unwrap();
    for i in 0..5 {
        write_unit(&fleet, i, 60.0, |_| {});
    }
    std::fs::write(fleet.join("corrupt.arrow"), b"ARROW1\0\0 not really").unwrap();
    std::fs::write(fleet.join("empty.csv"), b"").unwrap();
    std::fs::write(fleet.join("mislabelled.parquet"), b"time,gyro_x\n0,1\n").unwrap();
    // A missing sample in data row 300 of gyro_x: the row names the column and the row.
    let mut nan = String::from("time,gyro_x [rad/s]\n");
    for i in 0..600 {
        let v = if i == 300 {
            String::new()
        } else {
            format!("{:e}", 1e-3 * ((i * 7919) % 13) as f64)
        };
        nan.push_str(&format!("{},{v}\n", i as f64 / FS));
    }
    std::fs::write(fleet.join("nan.csv"), nan).unwrap();
    std::fs::write(tmp.path().join("list.txt"), "# the fleet\nfleet\n").unwrap();
    std::fs::write(tmp.path().join("more.txt"), "fleet/gone.arrow\n").unwrap();
    // Two lists (--files-from repeats).
    let args = [
        "screen",
        "--files-from",
        "list.txt",
        "--files-from",
        "more.txt",
        "-o",
        "out",
        "--backend",
        "cpu",
        "--no-loop",
    ];
    let o = imunoise(&args, tmp.path());
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    let err = stderr(&o);
    for bad in [
        "corrupt.arrow",
        "empty.csv",
        "mislabelled.parquet",
        "gone.arrow",
        "nan.csv",
    ] {
        assert!(
            err.lines()
                .any(|l| l.starts_with("error ") && l.contains(bad)),
            "{bad}: {err}"
        );
    }
    assert_eq!(lines_starting(&o, "done  "), 5, "{err}");
    let out = tmp.path().join("out");
    assert_eq!(parts(&out).len(), 10);
    let table = read_batches(&out.join("fleet.parquet"));
    let status = column_text(&table, "status");
    let sensors = column_text(&table, "sensor");
    let errors: Vec<&str> = sensors
        .iter()
        .zip(&status)
        .filter(|(_, s)| *s == "error")
        .map(|(s, _)| s.as_str())
        .collect();
    assert_eq!(errors, ["corrupt", "empty", "gone", "mislabelled", "nan"]);
    // The place in the file, as columns.
    let rows: Vec<Option<u64>> = table
        .iter()
        .flat_map(|b| {
            let c = b.column_by_name("error_row").expect("error_row");
            let c = c
                .as_any()
                .downcast_ref::<arrow_array::UInt64Array>()
                .expect("u64");
            (0..c.len())
                .map(|i| (!arrow_array::Array::is_null(c, i)).then(|| c.value(i)))
                .collect::<Vec<_>>()
        })
        .collect();
    let place: Vec<(String, Option<u64>)> = column_text(&table, "error_column")
        .into_iter()
        .zip(rows)
        .zip(&sensors)
        .filter(|(_, s)| *s == "nan")
        .map(|(p, _)| p)
        .collect();
    assert_eq!(place, [("gyro_x".to_string(), Some(300))]);
    assert_eq!(status.iter().filter(|s| *s == "ok").count(), 15);
    assert!(column_text(&table, "error")
        .iter()
        .zip(&status)
        .all(|(e, s)| (s == "error") == (e != "null")));
    let summary = std::fs::read_to_string(out.join("summary.md")).unwrap();
    assert!(summary.contains("## Errors") && summary.contains("mislabelled.parquet"));

    let again = imunoise(&args, tmp.path());
    assert_eq!(again.status.code(), Some(1), "{}", stderr(&again));
    assert_eq!(lines_starting(&again, "done  "), 0, "{}", stderr(&again));
    assert_eq!(lines_starting(&again, "skipped "), 5, "{}", stderr(&again));
}

/// A live run's lock refuses a second run into the same shard folder (exit 2, nothing written);
/// another shard has its own lock; a lock left by a dead process is taken over with a note.
#[test]
fn the_lock_refuses_a_concurrent_run_and_a_stale_one_is_taken_over() {
    let tmp = tempfile::tempdir().unwrap();
    let fleet = tmp.path().join("fleet");
    std::fs::create_dir(&fleet).unwrap();
    for i in 0..2 {
        write_unit(&fleet, i, 60.0, |_| {});
    }
    let out = tmp.path().join("out");
    std::fs::create_dir(&out).unwrap();
    let host = imunoise::fleet::lock::host_name();
    // This test process is alive: its lock holds.
    let lock = out.join(".lock-shard-0");
    std::fs::write(&lock, format!("pid={}\nhost={host}\n", std::process::id())).unwrap();
    let args = [
        "screen",
        "fleet",
        "-o",
        "out",
        "--backend",
        "cpu",
        "--no-loop",
    ];
    let refused = imunoise(&args, tmp.path());
    assert_eq!(refused.status.code(), Some(2), "{}", stderr(&refused));
    assert!(
        stderr(&refused).contains("in use by another run"),
        "{}",
        stderr(&refused)
    );
    assert!(!out.join("results").exists());
    // Shard 1 of 2 has its own lock.
    let other = imunoise(
        &[
            "screen",
            "fleet",
            "-o",
            "out",
            "--backend",
            "cpu",
            "--no-loop",
            "--shard",
            "1/2",
        ],
        tmp.path(),
    );
    assert_eq!(other.status.code(), Some(0), "{}", stderr(&other));
    if !Path::new("/proc/self").exists() {
        return; // staleness is judged through /proc only
    }
    let mut child = std::process::Command::new("true").spawn().unwrap();
    let dead = child.id();
    child.wait().unwrap();
    std::fs::write(&lock, format!("pid={dead}\nhost={host}\n")).unwrap();
    let taken = imunoise(&args, tmp.path());
    assert_eq!(taken.status.code(), Some(0), "{}", stderr(&taken));
    assert!(
        stderr(&taken).contains("took over the stale lock"),
        "{}",
        stderr(&taken)
    );
    assert!(!lock.exists(), "the lock is removed at the end");
}
