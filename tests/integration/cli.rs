//! The binary end to end: quick start on the sample, outputs, exit codes, batches with a bad file.

use serde_json::Value;

use super::support::*;

fn json_of(out: &std::process::Output) -> Value {
    serde_json::from_slice(&out.stdout).unwrap_or_else(|e| {
        panic!(
            "stdout is not JSON ({e}); stderr: {}",
            String::from_utf8_lossy(&out.stderr)
        )
    })
}

#[test]
fn info_on_the_sample_reports_rate_units_channels_and_duration() {
    let root = repo_root();
    let out = imunoise(&["info", "data/sample_imu.arrow", "--json"], &root);
    assert_eq!(
        out.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let doc = json_of(&out);
    assert_eq!(doc["schema_version"], 12);
    assert_eq!(doc["command"], "info");
    let file = &doc["files"][0];
    assert_eq!(file["status"], "ok");
    let rec = &file["recording"];
    assert_eq!(rec["rate_hz"], 100.0);
    assert_eq!(rec["rate_source"], "metadata");
    assert_eq!(rec["time_column"], "time");
    assert_eq!(rec["samples"], 90_000);
    assert_eq!(rec["duration_s"], 900.0);
    let channels = rec["channels"].as_array().unwrap();
    assert_eq!(channels.len(), 7);
    assert_eq!(channels[0]["name"], "gyro_x");
    assert_eq!(channels[0]["unit"], "deg/s");
    assert_eq!(channels[0]["si_unit"], "rad/s");
    assert_eq!(channels[3]["kind"], "accel");
    assert_eq!(channels[3]["scale"], 1e-5);
    assert_eq!(channels[6]["kind"], "temperature");
    // The accelerometer is stored in counts of 1e-5 m/s^2: the quantisation step is found.
    let step = file["quality"]["channels"][3]["smallest_step"]
        .as_f64()
        .unwrap();
    assert!((step - 1e-5).abs() < 1e-12, "{step}");
    // In a pipe: per-file status lines on stderr, but no progress bar (no carriage returns or escapes).
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.starts_with("ok    data/sample_imu.arrow: 7 channels"),
        "{stderr}"
    );
    assert!(
        !stderr.contains('\r') && !stderr.contains('\u{1b}'),
        "{stderr:?}"
    );
}

#[test]
fn analyze_writes_every_table_and_the_document_atomically() {
    let dir = tempfile::tempdir().unwrap();
    let out_dir = dir.path().join("run");
    let sample = repo_root().join("data/sample_imu.arrow");
    let out = imunoise(
        &[
            "analyze",
            sample.to_str().unwrap(),
            "-o",
            out_dir.to_str().unwrap(),
            "--nperseg",
            "2048",
        ],
        dir.path(),
    );
    assert_eq!(
        out.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let mut names: Vec<String> = std::fs::read_dir(&out_dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    assert_eq!(
        names,
        [
            "avar.arrow",
            "avar.csv",
            "coefficients.arrow",
            "coefficients.csv",
            "psd.arrow",
            "psd.csv",
            "psd_binned.arrow",
            "psd_binned.csv",
            "report.json",
            "sample_imu",
            "summary.md",
        ]
    );
    let doc: Value =
        serde_json::from_slice(&std::fs::read(out_dir.join("report.json")).unwrap()).unwrap();
    let psd = &doc["files"][0]["psd"][0];
    assert_eq!(psd["channel"], "gyro_x");
    assert_eq!(psd["unit"], "(rad/s)^2/Hz");
    assert_eq!(psd["nperseg"], 2048);
    // 90 000 samples, nperseg 2048, half overlap: (90000 - 1024) / 1024 = 86 segments.
    assert_eq!(psd["segments"], 86);
    // ARW of the sample is 0.0025 deg/s/sqrt(Hz) two-sided: one-sided PSD 2·N² in (rad/s)²/Hz at
    // high frequency where white noise dominates.
    let freq: Vec<f64> = serde_json::from_value(psd["freq_hz"].clone()).unwrap();
    let value: Vec<f64> = serde_json::from_value(psd["value"].clone()).unwrap();
    let band: Vec<f64> = freq
        .iter()
        .zip(&value)
        .filter(|(f, _)| **f > 10.0 && **f < 45.0)
        .map(|(_, v)| *v)
        .collect();
    let mean = band.iter().sum::<f64>() / band.len() as f64;
    let n_rad = 0.0025 * std::f64::consts::PI / 180.0;
    assert!((mean / (2.0 * n_rad * n_rad) - 1.0).abs() < 0.05, "{mean}");
    let avar = &doc["files"][0]["avar"][0]["statistics"][0];
    assert_eq!(avar["statistic"], "oadev");
    let dev: Vec<f64> = serde_json::from_value(avar["deviation"].clone()).unwrap();
    let lo: Vec<f64> = serde_json::from_value(avar["deviation_lo"].clone()).unwrap();
    let hi: Vec<f64> = serde_json::from_value(avar["deviation_hi"].clone()).unwrap();
    for i in 0..dev.len() {
        assert!(lo[i] < dev[i] && dev[i] < hi[i], "interval at {i}");
    }
    // OADEV at tau = 0.01 s of white noise N: N/sqrt(tau).
    assert!(
        (dev[0] / (n_rad / 0.01f64.sqrt()) - 1.0).abs() < 0.03,
        "{}",
        dev[0]
    );
    let csv = std::fs::read_to_string(out_dir.join("avar.csv")).unwrap();
    assert!(
        csv.starts_with("file,channel,unit,statistic,m,tau_s,deviation,deviation_lo,deviation_hi,")
    );
}

#[test]
fn one_bad_file_in_a_batch_does_not_stop_the_others() {
    let dir = tempfile::tempdir().unwrap();
    let good = dir.path().join("good.arrow");
    write_ipc_file(
        &good,
        &batch(&[f64_col("g", noise(4096, 1), Some("rad/s"))], Some(50.0)),
        1000,
    );
    let mut bad_values = noise(4096, 2);
    bad_values[3000] = f64::NAN;
    let bad = dir.path().join("bad.arrow");
    write_ipc_file(
        &bad,
        &batch(&[f64_col("g", bad_values, Some("rad/s"))], Some(50.0)),
        1000,
    );
    let out = imunoise(
        &[
            "avar",
            "bad.arrow",
            "missing.csv",
            "good.arrow",
            "-o",
            "out",
            "--format",
            "csv,json",
        ],
        dir.path(),
    );
    assert_eq!(out.status.code(), Some(1));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("bad.arrow: column \"g\", row 3000: non-finite"),
        "{stderr}"
    );
    assert!(stderr.contains("missing.csv: file not found"), "{stderr}");
    let doc: Value =
        serde_json::from_slice(&std::fs::read(dir.path().join("out/report.json")).unwrap())
            .unwrap();
    assert_eq!(doc["summary"]["failed"], 2);
    assert_eq!(doc["summary"]["ok"], 1);
    assert_eq!(doc["files"][0]["error"]["row"], 3000);
    assert_eq!(doc["files"][0]["error"]["column"], "g");
    assert_eq!(doc["files"][2]["status"], "ok");
    let csv = std::fs::read_to_string(dir.path().join("out/avar.csv")).unwrap();
    assert!(csv.lines().skip(1).all(|l| l.starts_with("good.arrow,")));
    assert!(
        !dir.path().join("out/avar.arrow").exists(),
        "--format limits the outputs"
    );
    let leftovers: Vec<_> = std::fs::read_dir(dir.path().join("out"))
        .unwrap()
        .filter(|e| {
            e.as_ref()
                .unwrap()
                .file_name()
                .to_string_lossy()
                .ends_with(".tmp")
        })
        .collect();
    assert!(leftovers.is_empty());
}

/// A second `analyze` into the same folder, with a recording that now fails: the first run's
/// folder of that recording moves to `earlier-runs/` instead of staying beside the new run's
/// folders looking current; the recording that still works keeps its folder.
#[test]
fn an_earlier_runs_folder_does_not_look_current() {
    let dir = tempfile::tempdir().unwrap();
    let write = |name: &str, seed: u64, nan: bool| {
        let mut v = noise(8192, seed);
        if nan {
            v[5000] = f64::NAN;
        }
        write_ipc_file(
            &dir.path().join(name),
            &batch(&[f64_col("g", v, Some("rad/s"))], Some(50.0)),
            1000,
        );
    };
    write("a.arrow", 1, false);
    write("b.arrow", 2, false);
    let args = ["analyze", "a.arrow", "b.arrow", "-o", "out", "--quiet"];
    let first = imunoise(&args, dir.path());
    assert_eq!(first.status.code(), Some(0), "{first:?}");
    let out = dir.path().join("out");
    assert!(out.join("b/imu.yaml").exists() && out.join("b/plots/g_avar.svg").exists());

    // A run killed while writing left temporaries (pid beyond the kernel's limit: not running);
    // the next run clears them where it writes.
    let litter = [
        out.join(".report.json.4194999.tmp"),
        out.join("a/.imu.yaml.4194999.tmp"),
        out.join("a/plots/.g_avar.svg.4194999.tmp"),
    ];
    for p in &litter {
        std::fs::write(p, "half").unwrap();
    }
    write("b.arrow", 2, true);
    let second = imunoise(&args, dir.path());
    for p in &litter {
        assert!(!p.exists(), "{} swept", p.display());
    }
    assert_eq!(second.status.code(), Some(1), "{second:?}");
    let stderr = String::from_utf8_lossy(&second.stderr);
    assert!(
        stderr.contains("earlier run") && stderr.contains("(b)"),
        "{stderr}"
    );
    assert!(
        !out.join("b").exists(),
        "b failed this run: no folder of b looks current"
    );
    assert!(out.join("earlier-runs/b/imu.yaml").exists());
    assert!(out.join("earlier-runs/b/plots/g_psd.png").exists());
    assert!(out.join("a/imu.yaml").exists() && out.join("a/plots/g_avar.svg").exists());

    // Every input failing: no table of the earlier run stays beside a summary of none analysed
    // (its numbers had looked current).
    assert!(out.join("coefficients.csv").exists() && out.join("psd.arrow").exists());
    write("a.arrow", 1, true);
    let third = imunoise(&args, dir.path());
    assert_eq!(third.status.code(), Some(1), "{third:?}");
    for table in ["coefficients", "psd", "psd_binned", "avar"] {
        for ext in ["csv", "arrow"] {
            let path = out.join(format!("{table}.{ext}"));
            assert!(
                !path.exists(),
                "{} left from the earlier run",
                path.display()
            );
        }
    }
    let summary = std::fs::read_to_string(out.join("summary.md")).unwrap();
    assert!(summary.contains("0 files analysed, 2 failed"), "{summary}");
}

/// `imunoise simulate --spec` of `spec`, then `analyze` of it: the first channel's analysis from
/// report.json and its combined N.
fn analyze_simulated(dir: &std::path::Path, spec: &Value) -> (Value, f64) {
    std::fs::write(dir.join("spec.json"), spec.to_string()).unwrap();
    let made = imunoise(&["simulate", "--spec", "spec.json", "-o", "g.arrow"], dir);
    assert_eq!(made.status.code(), Some(0), "{made:?}");
    let out = imunoise(&["analyze", "g.arrow", "-o", "out", "--quiet"], dir);
    assert_eq!(out.status.code(), Some(0), "{out:?}");
    let doc: Value =
        serde_json::from_slice(&std::fs::read(dir.join("out/report.json")).unwrap()).unwrap();
    let a = doc["files"][0]["analysis"][0].clone();
    let n = term_value(&a, "random_walk").expect("N kept");
    (a, n)
}

/// A 400-Hz gyro behind a digital low-pass (float samples, no quantisation): the top band of
/// its spectrum ends in the filter's zero at Nyquist, 10⁻¹¹ of the floor, which once drove every
/// spectrum model to zero, hid the filter and left the Allan fit alone to read B 80× the truth
/// (N 0.3 °/√h, B 3 °/h planted). Now the filter is found and N is right, in both orders.
#[test]
fn a_400_hz_gyro_behind_a_digital_filter_is_read_right() {
    let dir = tempfile::tempdir().unwrap();
    for order in [2, 4] {
        let spec = serde_json::json!({ "rate_hz": 400.0, "duration_s": 300.0, "seed": 3,
            "channels": [{ "name": "gyro_x", "sensor": "gyro", "noise": { "n": 8.73e-5, "b": 1.45e-5 },
                "lowpass": { "corner_hz": 100.0, "order": order } }] });
        let (a, n) = analyze_simulated(dir.path(), &spec);
        assert_eq!(a["spectrum"]["status"], "ok", "{}", a["spectrum"]);
        let lp = &a["bandwidth"]["lowpass"];
        assert_eq!(lp["order"], order, "{lp}");
        let corner = lp["corner_hz"].as_f64().unwrap();
        assert!((corner / 100.0 - 1.0).abs() < 0.05, "{lp}");
        assert!((n / 8.73e-5 - 1.0).abs() < 0.05, "N {n}");
    }
}

/// A gyro behind a coarse angle quantiser (Q = 2 arcsec at 200 Hz: about ten white σ per output
/// step): the band's edge is the quantiser's, and no output-resolution warning contradicts it by
/// saying the sensor's N cannot be read; N is read right (0.15 °/√h planted), and Q is the grid's.
#[test]
fn a_coarse_angle_quantiser_is_not_also_rate_rounding() {
    let dir = tempfile::tempdir().unwrap();
    let deg = std::f64::consts::PI / 180.0;
    let spec = serde_json::json!({ "rate_hz": 200.0, "duration_s": 1800.0, "seed": 1,
        "channels": [{ "name": "gyro_y", "sensor": "gyro", "noise": {
            "n": 0.15 * deg / 60.0, "b": 3.0 * deg / 3600.0, "q": 2.0 / 3600.0 * deg } }] });
    let (a, n) = analyze_simulated(dir.path(), &spec);
    assert_eq!(
        a["bandwidth"]["cause"]["kind"], "angle_quantiser",
        "{}",
        a["bandwidth"]
    );
    let warnings = a["combined"]["warnings"].as_array().unwrap();
    assert!(
        warnings.iter().all(|w| w["kind"] != "output_resolution"),
        "{warnings:?}"
    );
    assert!((n / (0.15 * deg / 60.0) - 1.0).abs() < 0.05, "N {n}");
    // Q is the grid's own: 2 arcsec, not the spectrum's 2.2× reading.
    let q = a["combined"]["terms"]
        .as_array()
        .unwrap()
        .iter()
        .find(|t| t["term"] == "quantization")
        .expect("Q kept");
    let value = q["value"].as_f64().unwrap() / (deg / 3600.0);
    assert!((value / 2.0 - 1.0).abs() < 0.01, "Q {value} arcsec: {q}");
    assert!(q["lo"].as_f64() <= q["value"].as_f64() && q["value"].as_f64() <= q["hi"].as_f64());
}

#[test]
fn usage_errors_exit_2_before_reading_anything() {
    let dir = tempfile::tempdir().unwrap();
    for args in [
        vec!["psd", "x.arrow", "--window", "triangle"],
        vec!["psd", "x.arrow", "--nperseg", "100", "--noverlap", "100"],
        vec!["avar", "x.arrow", "--taus", "-1"],
        vec!["avar", "x.arrow", "--stat", "tdev"],
        vec!["avar", "x.arrow", "--confidence", "1.5"],
        vec!["info", "x.arrow", "--unit", "x=parsec"],
        vec!["info", "x.arrow", "--on-gap", "pray"],
        vec!["frobnicate"],
    ] {
        let out = imunoise(&args, dir.path());
        assert_eq!(out.status.code(), Some(2), "{args:?}");
        assert!(!String::from_utf8_lossy(&out.stderr).is_empty());
    }
    assert!(!dir.path().join("imunoise-out").exists());
}

#[test]
fn help_explains_options_with_units() {
    let out = imunoise(&["psd", "--help"], &repo_root());
    assert_eq!(out.status.code(), Some(0));
    let help = String::from_utf8_lossy(&out.stdout);
    for needle in [
        "--nperseg",
        "samples",
        "Hz",
        "--on-gap",
        "--window",
        "hann",
        "--json",
    ] {
        assert!(help.contains(needle), "help lacks {needle}");
    }
    let out = imunoise(&["avar", "--help"], &repo_root());
    let help = String::from_utf8_lossy(&out.stdout);
    for needle in ["octave", "seconds", "oadev", "hdev", "1sigma"] {
        assert!(help.contains(needle), "help lacks {needle}");
    }
}

/// `--backend gpu` end to end: the outputs name the adapter and agree with `--backend cpu` (PSD 1e-4
/// on bins above 1e-6 of the maximum, deviations 1e-5); without an adapter it is a clear exit 2,
/// which CI (IMUNOISE_REQUIRE_GPU=1, lavapipe installed) does not accept.
#[test]
fn backend_gpu_agrees_with_cpu_or_fails_cleanly() {
    let root = repo_root();
    let args = |b: &'static str| {
        vec![
            "analyze",
            "data/sample_imu.arrow",
            "--json",
            "--channels",
            "gyro_x,accel_z",
            "--nperseg",
            "1024",
            "--backend",
            b,
        ]
    };
    let gpu = imunoise(&args("gpu"), &root);
    if gpu.status.code() == Some(2) {
        let stderr = String::from_utf8_lossy(&gpu.stderr);
        assert!(stderr.contains("--backend gpu"), "{stderr}");
        assert!(
            std::env::var("IMUNOISE_REQUIRE_GPU").as_deref() != Ok("1"),
            "IMUNOISE_REQUIRE_GPU=1 but --backend gpu failed: {stderr}"
        );
        eprintln!("skipping: no GPU adapter ({stderr})");
        return;
    }
    assert_eq!(
        gpu.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&gpu.stderr)
    );
    let cpu = imunoise(&args("cpu"), &root);
    let (g, c) = (json_of(&gpu), json_of(&cpu));
    assert!(
        g["backend"].as_str().unwrap().starts_with("gpu: "),
        "{}",
        g["backend"]
    );
    assert!(c["backend"].as_str().unwrap().starts_with("cpu"));
    assert_eq!(
        g["files"][0]["backend_notes"],
        serde_json::json!([]),
        "nothing fell back"
    );
    let floats = |v: &Value| -> Vec<f64> { serde_json::from_value(v.clone()).unwrap() };
    for ch in 0..2 {
        let (pg, pc) = (
            floats(&g["files"][0]["psd"][ch]["value"]),
            floats(&c["files"][0]["psd"][ch]["value"]),
        );
        let max = pc.iter().cloned().fold(0.0, f64::max);
        for (a, b) in pg.iter().zip(&pc).filter(|(_, b)| **b > 1e-6 * max) {
            assert!((a - b).abs() <= 1e-4 * b, "psd {a} vs {b}");
        }
        let dev = |d: &Value| floats(&d["files"][0]["avar"][ch]["statistics"][0]["deviation"]);
        for (a, b) in dev(&g).iter().zip(dev(&c)) {
            // 1e-5 on the variance is 5e-6 on the deviation.
            assert!((a - b).abs() <= 5e-6 * b, "deviation {a} vs {b}");
        }
    }
}

/// Output a person reads: numbers to their precision (the rate of a CSV at 100 Hz printed as
/// `100.0000000000007 Hz`, `1 channels`), every coefficient, amplitude and legend with its unit
/// (the temperature coupling was "per unit", legends bare SI numbers).
#[test]
fn per_file_lines_print_numbers_to_their_precision() {
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("one.csv");
    let simulated = imunoise(
        &[
            "simulate",
            "-o",
            csv.to_str().unwrap(),
            "--rate",
            "100",
            "--duration",
            "10",
            "--axes",
            "1",
            "--noise",
            "N=0.15deg/sqrt(h)",
            "--quiet",
        ],
        dir.path(),
    );
    assert_eq!(simulated.status.code(), Some(0), "{simulated:?}");
    let out = imunoise(
        &["avar", "one.csv", "-o", "out", "--backend", "cpu"],
        dir.path(),
    );
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(0), "{stderr}");
    // The rate comes from the time column (1/mean interval, 100.0000000000007 in report.json).
    assert!(
        stderr.contains("ok    one.csv: 1 channel, 1000 samples at 100 Hz, 10 s\n"),
        "{stderr}"
    );
    assert!(
        stderr.contains("1 of 1 file ok; results in out"),
        "{stderr}"
    );
    let doc: Value =
        serde_json::from_slice(&std::fs::read(dir.path().join("out/report.json")).unwrap())
            .unwrap();
    let rate = doc["files"][0]["recording"]["rate_hz"].as_f64().unwrap();
    assert!((rate - 100.0).abs() < 1e-9, "{rate}");
}

#[test]
fn analyze_labels_every_coefficient_amplitude_and_legend_with_its_unit() {
    let dir = tempfile::tempdir().unwrap();
    let sample = repo_root().join("data/sample_imu.arrow");
    let out = imunoise(
        &[
            "analyze",
            sample.to_str().unwrap(),
            "--channels",
            "gyro_z,accel_x,temperature",
            "-o",
            "out",
            "--backend",
            "cpu",
        ],
        dir.path(),
    );
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(0), "{stderr}");
    let md = std::fs::read_to_string(dir.path().join("out/summary.md")).unwrap();
    // A coupling weighed and not admitted states its coefficient in summary.md (accel_x: none
    // planted); none on gyro_z, whose coupling was admitted.
    let loop_line = |channel: &str| {
        md.lines()
            .find(|l| l.starts_with(&format!("- **{channel}**")))
            .unwrap_or_else(|| panic!("no loop line for {channel} in {md}"))
            .to_owned()
    };
    assert!(
        loop_line("accel_x")
            .contains("Not admitted: a coupling (time series: regression on temperature")
            && loop_line("accel_x").contains("in SI"),
        "{md}"
    );
    assert!(
        !loop_line("gyro_z").contains("Not admitted: a coupling"),
        "{md}"
    );
    for text in [&*stderr, &md] {
        assert!(!text.contains("per unit"), "{text}");
        // The coupling of the gyro to the temperature, in both unit systems.
        let coupling = text
            .lines()
            .find(|l| l.contains("coupling to temperature:"))
            .unwrap_or_else(|| panic!("no coupling in {text}"));
        assert!(
            coupling.contains(" (rad/s)/K (") && coupling.contains(" (°/h)/°C)"),
            "{coupling}"
        );
        // The line's amplitude on the accelerometer.
        let line = text
            .lines()
            .find(|l| l.contains("line at 12.5"))
            .unwrap_or_else(|| panic!("no line in {text}"));
        assert!(
            line.contains("] m/s² (") && line.contains("] mg)"),
            "{line}"
        );
    }
    assert!(stderr.contains("ok    "), "{stderr}");
    assert!(
        stderr.contains(": 3 channels, 90000 samples at 100 Hz, 900 s (15.0 min)"),
        "{stderr}"
    );
    assert!(md.contains("90000 samples per channel at 100 Hz, 900 s (15.0 min), 3 channels"));
    assert!(md.contains("1 file analysed"), "{md}");
    // Combined coefficients carry their unit in every column that has a number.
    let row = md
        .lines()
        .find(|l| l.starts_with("| gyro_z | N |"))
        .unwrap_or_else(|| panic!("{md}"));
    assert_eq!(row.matches("°/√h").count(), 3, "{row}");
    // Plot legends: each fitted term with its datasheet unit, the removed line with its amplitude.
    let legends = |name: &str| -> Vec<String> {
        let svg =
            std::fs::read_to_string(dir.path().join("out/sample_imu/plots").join(name)).unwrap();
        svg.split("<text")
            .skip(1)
            .filter_map(|t| t.split_once('>').map(|(_, r)| r))
            .filter_map(|r| r.split_once("</text>").map(|(t, _)| t.to_string()))
            .collect()
    };
    for name in ["gyro_z_avar.svg", "gyro_z_psd.svg", "accel_x_psd.svg"] {
        let texts = legends(name);
        let terms: Vec<&String> = texts
            .iter()
            .filter(|t| t.len() > 4 && t.as_bytes()[1..4] == *b" = " && "QNBKR".contains(&t[..1]))
            .collect();
        assert!(!terms.is_empty(), "{name}: {texts:?}");
        let domain = if name.contains("avar") {
            "(Allan fit)"
        } else {
            "(spectrum fit)"
        };
        for t in terms {
            // "N = 0.1504 °/√h (spectrum fit)": a symbol, a number, a unit, the fit drawn.
            let parts: Vec<&str> = t.splitn(4, ' ').collect();
            assert!(
                parts.len() == 4 && parts[2].parse::<f64>().is_ok() && !parts[3].is_empty(),
                "{name}: {t}"
            );
            assert!(t.ends_with(domain), "{name}: {t}");
        }
    }
    // The line was removed: the recorded spectrum is drawn beside the corrected one.
    let psd = legends("accel_x_psd.svg");
    assert!(psd.iter().any(|t| t == "Welch, recorded"), "{psd:?}");
    assert!(
        psd.iter().any(|t| t.starts_with("Welch, the loop")),
        "{psd:?}"
    );
    assert!(
        legends("accel_x_psd.svg")
            .iter()
            .any(|t| t.starts_with("line 12.500 Hz, ") && t.ends_with(" mg (removed)")),
        "{:?}",
        legends("accel_x_psd.svg")
    );
}

/// A temperature in 0.125 °C steps that warms up and stays at its last level holds its maximum
/// for many samples: a slow sensor, not a clipped one (saturation is judged on gyros and
/// accelerometers only; `info` had listed it as "possibly" saturated).
#[test]
fn a_warmed_up_temperature_is_not_saturated() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("t.csv");
    let mut text = String::from("time [s],g [rad/s],temperature [degC]\n");
    for i in 0..4000u32 {
        let t = f64::from(i) / 100.0;
        let temp = ((25.0 + 2.0 * (1.0 - (-t / 8.0).exp())) / 0.125).round() * 0.125;
        let g = (f64::from(i * 7919 % 1000) - 500.0) * 1e-5;
        text.push_str(&format!("{t},{g},{temp}\n"));
    }
    std::fs::write(&path, text).unwrap();
    let out = imunoise(&["info", path.to_str().unwrap()], dir.path());
    assert_eq!(out.status.code(), Some(0));
    let table = String::from_utf8_lossy(&out.stdout);
    let row = table
        .lines()
        .find(|l| l.trim_start().starts_with("temperature "))
        .unwrap_or_else(|| panic!("{table}"));
    assert!(row.trim_end().ends_with(" no"), "{row}");
    assert!(!table.contains("possibly"), "{table}");
}

/// `imunoise info FILE` printed nothing on stdout and wrote an `imunoise-out` folder.
#[test]
fn info_prints_a_table_and_writes_files_only_when_asked() {
    let dir = tempfile::tempdir().unwrap();
    let sample = repo_root().join("data/sample_imu.arrow");
    let sample = sample.to_str().unwrap();
    let out = imunoise(&["info", sample], dir.path());
    assert_eq!(
        out.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let table = String::from_utf8_lossy(&out.stdout);
    for needle in [
        "format    Arrow IPC file",
        "rows      90000 rows",
        "duration  900 s (15.0 min)",
        "rate      100 Hz (from schema metadata sample_rate_hz",
        "gaps      none",
        "channel",
        "stored",
        "non-finite",
        "saturated",
    ] {
        assert!(table.contains(needle), "{needle:?} not in\n{table}");
    }
    let row = |name: &str| -> Vec<String> {
        table
            .lines()
            .find(|l| l.trim_start().starts_with(&format!("{name} ")))
            .unwrap_or_else(|| panic!("no {name} in\n{table}"))
            .split("  ")
            .map(str::trim)
            .filter(|c| !c.is_empty())
            .map(String::from)
            .collect()
    };
    let gyro = row("gyro_x");
    assert_eq!(
        gyro[..5],
        ["gyro_x", "°/s", "rad/s", "gyro", "Float32"],
        "{gyro:?}"
    );
    let accel = row("accel_x");
    assert_eq!(accel[4], "Int32 × 1e-5", "{accel:?}");
    // min, max, mean, std, step, non-finite, saturated.
    assert_eq!(accel.len(), 12, "{accel:?}");
    assert_eq!(accel[9], "1.000e-5", "{accel:?}");
    assert_eq!(accel[10..], ["0", "no"], "{accel:?}");
    assert!(
        !dir.path().join("imunoise-out").exists(),
        "info without -o wrote files"
    );
    assert!(
        !String::from_utf8_lossy(&out.stderr).contains("results in"),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );

    // With -o the document is written too, and the table still printed.
    let out = imunoise(&["info", sample, "-o", "given"], dir.path());
    assert_eq!(out.status.code(), Some(0));
    assert!(dir.path().join("given/report.json").exists());
    assert!(String::from_utf8_lossy(&out.stdout).contains("Arrow IPC file"));

    // The other commands keep their default folder.
    let out = imunoise(
        &[
            "psd",
            sample,
            "--channels",
            "gyro_x",
            "--nperseg",
            "256",
            "--backend",
            "cpu",
        ],
        dir.path(),
    );
    assert_eq!(out.status.code(), Some(0));
    assert!(dir.path().join("imunoise-out/psd.csv").exists());
}

/// Mesa and the Vulkan loader printed "XDG_RUNTIME_DIR is invalid" twice on every default run,
/// straight to fd 2, even with --quiet; they now show only with -v.
#[test]
fn the_gpu_probe_is_quiet_unless_verbose() {
    let run = |extra: &[&str]| {
        let mut args = vec![
            "analyze",
            "data/sample_imu.arrow",
            "--channels",
            "gyro_x",
            "--no-loop",
            "--json",
            "--backend",
            "auto",
        ];
        args.extend_from_slice(extra);
        std::process::Command::new(env!("CARGO_BIN_EXE_imunoise"))
            .args(&args)
            .current_dir(repo_root())
            .env_remove("XDG_RUNTIME_DIR")
            .stdin(std::process::Stdio::null())
            .output()
            .unwrap()
    };
    for extra in [&[][..], &["--quiet"][..]] {
        let out = run(extra);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(0), "{extra:?}: {stderr}");
        assert!(!stderr.contains("XDG_RUNTIME_DIR"), "{extra:?}: {stderr}");
        if extra.is_empty() {
            // Our own messages still come through once the probe is over.
            assert!(stderr.contains("imunoise: backend "), "{stderr}");
        }
    }
    let verbose = run(&["-v"]);
    let stderr = String::from_utf8_lossy(&verbose.stderr);
    assert_eq!(verbose.status.code(), Some(0), "{stderr}");
    if !stderr.contains("XDG_RUNTIME_DIR") {
        eprintln!(
            "note: the graphics stack prints nothing here even with -v; the test shows little"
        );
    }
}

/// `analyze --taus all`: the tables keep every averaging factor, the fit a quarter-octave
/// thinning of them (the fit's working correlations over 30 000 τ had run out of memory), and
/// the white noise comes out as with the octave grid.
#[test]
fn analyze_with_every_averaging_factor_fits_a_thinned_curve() {
    let dir = tempfile::tempdir().unwrap();
    let n = 6000;
    write_ipc_file(
        &dir.path().join("g.arrow"),
        &batch(&[f64_col("gyro", noise(n, 9), Some("rad/s"))], Some(50.0)),
        1000,
    );
    let mut n_values = Vec::new();
    for taus in ["all", "octave"] {
        let out = format!("out_{taus}");
        run_ok(
            &["analyze", "g.arrow", "-o", &out, "--taus", taus, "--quiet"],
            dir.path(),
        );
        let report: Value = serde_json::from_str(
            &std::fs::read_to_string(dir.path().join(&out).join("report.json")).unwrap(),
        )
        .unwrap();
        let stats = &report["files"][0]["avar"][0]["statistics"][0];
        let rows = stats["m"].as_array().unwrap().len();
        if taus == "all" {
            assert_eq!(rows, (n - 1) / 2, "the table keeps every factor");
        }
        n_values.push(combined_value(&report, "gyro", "random_walk").unwrap());
    }
    // White noise σ = 1 at 50 Hz: N = 1/√50.
    for v in &n_values {
        assert!((v * 50f64.sqrt() - 1.0).abs() < 0.05, "{n_values:?}");
    }
}

/// `info` describes a file with non-finite samples (it had refused it under the default
/// `--on-nonfinite error`, which is what a user runs `info` to find out about): exit 0, the count
/// on the file's line; `--on-nonfinite error` still stops at the row.
#[test]
fn info_counts_non_finite_samples_by_default() {
    let dir = tempfile::tempdir().unwrap();
    let mut values = noise(5000, 3);
    values[100] = f64::NAN;
    values[200] = f64::INFINITY;
    write_ipc_file(
        &dir.path().join("nan.arrow"),
        &batch(&[f64_col("g", values, Some("rad/s"))], Some(50.0)),
        1000,
    );
    let out = run_ok(&["info", "nan.arrow"], dir.path());
    let stdout = String::from_utf8_lossy(&out.stdout);
    let row = stdout
        .lines()
        .find(|l| l.trim_start().starts_with("g "))
        .unwrap_or_else(|| panic!("{stdout}"));
    assert!(stdout.contains("non-finite"), "{stdout}");
    assert!(row.split_whitespace().any(|w| w == "2"), "{row}");
    let stopped = imunoise(
        &["info", "nan.arrow", "--on-nonfinite", "error"],
        dir.path(),
    );
    assert_eq!(stopped.status.code(), Some(1));
    let stderr = String::from_utf8_lossy(&stopped.stderr);
    assert!(stderr.contains("row 100"), "{stderr}");
}

/// A message published twice (a ROS bag export's repeated stamp): by default an error that names
/// the row and the option; with `--on-duplicate drop` the first of each kept (the repeat holds a
/// wild value here, which must not reach the statistics) and counted; `info` counts it unasked.
#[test]
fn a_repeated_timestamp_is_named_or_dropped_on_request() {
    let dir = tempfile::tempdir().unwrap();
    let n = 6000;
    let g = noise(n, 21);
    let mut text = String::from("timestamp,gx [rad/s]\n");
    for (i, v) in g.iter().enumerate() {
        let t = 1_700_000_000_000_000_000i64 + i as i64 * 10_000_000;
        text.push_str(&format!("{t},{:?}\n", 1e-3 * v));
        if i == 500 {
            text.push_str(&format!("{t},1000.0\n"));
        }
    }
    std::fs::write(dir.path().join("r.csv"), text).unwrap();
    let out = imunoise(
        &["analyze", "r.csv", "-o", "a", "--backend", "cpu"],
        dir.path(),
    );
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_ne!(out.status.code(), Some(0), "{stderr}");
    assert!(
        stderr.contains("row 501") && stderr.contains("--on-duplicate drop"),
        "{stderr}"
    );
    let out = run_ok(
        &[
            "analyze",
            "r.csv",
            "-o",
            "b",
            "--backend",
            "cpu",
            "--on-duplicate",
            "drop",
        ],
        dir.path(),
    );
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("1 row repeating the previous timestamp dropped"),
        "{stderr}"
    );
    let doc: Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("b/report.json")).unwrap())
            .unwrap();
    let q = &doc["files"][0]["quality"];
    assert_eq!(q["duplicate_rows"], 1);
    assert_eq!(q["samples_out"], n as u64);
    assert!(q["channels"][0]["max"].as_f64().unwrap() < 1.0, "{q}");
    let out = run_ok(&["info", "r.csv"], dir.path());
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        stdout.contains("1 row repeating the previous timestamp"),
        "{stdout}"
    );
}

/// A CSV cut off while being written (no line end after its last value) says so; a whole one
/// does not.
#[test]
fn a_csv_without_its_last_line_end_is_noted() {
    let dir = tempfile::tempdir().unwrap();
    let g = noise(3000, 22);
    let mut text = String::from("gx [rad/s]\n");
    for v in &g {
        text.push_str(&format!("{:?}\n", 1e-3 * v));
    }
    std::fs::write(dir.path().join("whole.csv"), &text).unwrap();
    text.push('9');
    std::fs::write(dir.path().join("cut.csv"), &text).unwrap();
    for (file, cut) in [("whole.csv", false), ("cut.csv", true)] {
        let out = run_ok(&["info", file, "--rate", "100"], dir.path());
        let stdout = String::from_utf8_lossy(&out.stdout);
        assert_eq!(
            stdout.contains("does not end with a line end"),
            cut,
            "{file}: {stdout}"
        );
    }
}

/// EuRoC/ASL `imu0.csv`: its header is a comment line with `rad s^-1` and `m s^-2` units. It is
/// read as the header, with every record below it data: the same recording as the file with the
/// `#` removed (rows, rate, units, kinds), and a bad value's row and line counted from the comment.
#[test]
fn a_euroc_header_is_recognised() {
    let dir = tempfile::tempdir().unwrap();
    let (w, a) = (noise(3000, 41), noise(3000, 42));
    let mut text = String::from("#timestamp [ns],w_RS_S_x [rad s^-1],a_RS_S_x [m s^-2]\n");
    for i in 0..3000 {
        let t = 1_403_636_579_758_555_392i64 + i as i64 * 5_000_000;
        text.push_str(&format!("{t},{:?},{:?}\n", 2e-3 * w[i], 9.81 + 0.02 * a[i]));
    }
    std::fs::write(dir.path().join("imu0.csv"), &text).unwrap();
    std::fs::write(dir.path().join("fixed.csv"), &text[1..]).unwrap();
    let recording = |file: &str| {
        let out = run_ok(&["info", file, "--json"], dir.path());
        let doc: Value = serde_json::from_slice(&out.stdout).unwrap();
        doc["files"][0]["recording"].clone()
    };
    let (euroc, fixed) = (recording("imu0.csv"), recording("fixed.csv"));
    let channels = &euroc["channels"];
    assert_eq!(channels[0]["unit"], "rad/s", "{channels}");
    assert_eq!(channels[0]["kind"], "gyro", "{channels}");
    assert_eq!(channels[1]["unit"], "m/s^2", "{channels}");
    assert_eq!(channels[1]["kind"], "accel", "{channels}");
    for key in ["channels", "samples", "rate_hz", "duration_s"] {
        assert_eq!(euroc[key], fixed[key], "{key}: {euroc}");
    }
    assert_eq!(euroc["samples"], 3000, "the first record is data: {euroc}");

    // A bad value in data row 10: line 12 of the file (the comment is line 1).
    let mut lines: Vec<&str> = text.lines().collect();
    let bad = lines[11].replacen(",", ",oops", 1);
    lines[11] = &bad;
    std::fs::write(dir.path().join("bad.csv"), lines.join("\n") + "\n").unwrap();
    let out = imunoise(&["info", "bad.csv"], dir.path());
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_ne!(out.status.code(), Some(0));
    assert!(
        stderr.contains("w_RS_S_x") && stderr.contains("row 10") && stderr.contains("line 12"),
        "{stderr}"
    );

    // Numbers under a comment that does not name each column: still no header.
    std::fs::write(
        dir.path().join("headless.csv"),
        "# logged by rig 4\n1,2\n3,4\n",
    )
    .unwrap();
    let out = imunoise(&["info", "headless.csv"], dir.path());
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_ne!(out.status.code(), Some(0));
    assert!(
        stderr.contains("holds numbers, not column names"),
        "{stderr}"
    );
}
