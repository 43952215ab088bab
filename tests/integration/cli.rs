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
    assert_eq!(doc["schema_version"], 4);
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
