//! Parity with scipy.signal.welch on the fixtures written by scripts/make_welch_fixtures.py
//! (tests/data/psd/PROVENANCE.md): relative error ≤ 1e-10 on every bin above 1e-12 of the
//! spectrum's maximum, for every case; the frequency grid and segment count must match too.

use std::collections::{BTreeSet, HashMap};

use imunoise::psd::{reference, welch, Average, WelchConfig, Window};
use serde::Deserialize;

const FIXTURE: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/tests/data/psd/welch_scipy.json"
);
const REL_TOL: f64 = 1e-10;
const FLOOR: f64 = 1e-12;

#[derive(Deserialize)]
struct Fixture {
    versions: HashMap<String, String>,
    signals: HashMap<String, Vec<f64>>,
    windows: HashMap<String, Vec<f64>>,
    cases: Vec<Case>,
}

#[derive(Deserialize)]
#[serde(untagged)]
enum WindowSpec {
    Named(String),
    Custom { custom: String },
}

#[derive(Deserialize)]
struct Case {
    id: usize,
    signal: String,
    n: usize,
    fs: f64,
    window: WindowSpec,
    nperseg: usize,
    noverlap: Option<usize>,
    nfft: Option<usize>,
    detrend: String,
    scaling: String,
    average: String,
    segments: usize,
    f_last: f64,
    psd: Vec<f64>,
}

fn load() -> Fixture {
    let text = std::fs::read_to_string(FIXTURE).expect("fixture present");
    serde_json::from_str(&text).expect("fixture parses")
}

impl Case {
    /// The configuration, built by parsing the same names the CLI accepts.
    fn config(&self, fx: &Fixture) -> WelchConfig {
        let window = match &self.window {
            WindowSpec::Named(name) => name.parse().unwrap(),
            WindowSpec::Custom { custom } => Window::Custom(fx.windows[custom].clone()),
        };
        WelchConfig {
            window,
            nperseg: self.nperseg,
            noverlap: self.noverlap,
            nfft: self.nfft,
            detrend: self.detrend.parse().unwrap(),
            scaling: self.scaling.parse().unwrap(),
            average: self.average.parse().unwrap(),
        }
    }

    fn input<'a>(&self, fx: &'a Fixture) -> &'a [f64] {
        &fx.signals[&self.signal][..self.n]
    }

    fn label(&self) -> String {
        let window = match &self.window {
            WindowSpec::Named(n) => n.clone(),
            WindowSpec::Custom { custom } => custom.clone(),
        };
        format!(
            "case {} ({window}, nperseg {}, noverlap {:?}, nfft {:?}, {}, {}, {}, {} segments, n {})",
            self.id,
            self.nperseg,
            self.noverlap,
            self.nfft,
            self.detrend,
            self.scaling,
            self.average,
            self.segments,
            self.n
        )
    }
}

/// Largest relative error over bins above FLOOR·max (the requirement's definition).
fn max_rel_error(ours: &[f64], scipy: &[f64]) -> f64 {
    let max = scipy.iter().fold(0.0_f64, |m, v| m.max(*v));
    ours.iter()
        .zip(scipy)
        .filter(|(_, s)| **s > FLOOR * max)
        .map(|(o, s)| ((o - s) / s).abs())
        .fold(
            0.0,
            |m, e| if e.is_nan() { f64::INFINITY } else { m.max(e) },
        )
}

#[test]
fn welch_matches_scipy_on_every_fixture_case() {
    let fx = load();
    let mut failures = Vec::new();
    for case in &fx.cases {
        let psd = welch(case.input(&fx), case.fs, &case.config(&fx))
            .unwrap_or_else(|e| panic!("{}: {e}", case.label()));
        let err = max_rel_error(&psd.value, &case.psd);
        let df_err = (psd.freq_hz.last().unwrap() - case.f_last).abs() / case.f_last.max(1e-300);
        if psd.value.len() != case.psd.len()
            || psd.segments != case.segments
            || err > REL_TOL
            || df_err > 1e-13
        {
            failures.push(format!(
                "{}: bins {} vs {}, segments {}, rel error {err:e}, f_last error {df_err:e}",
                case.label(),
                psd.value.len(),
                case.psd.len(),
                psd.segments
            ));
        }
    }
    assert!(
        failures.is_empty(),
        "{} of {} cases differ from scipy {}:\n{}",
        failures.len(),
        fx.cases.len(),
        fx.versions["scipy"],
        failures.join("\n")
    );
}

#[test]
fn direct_sum_reference_matches_scipy_too() {
    // The reference is what other backends are checked against, so it is itself pinned to scipy.
    let fx = load();
    for case in &fx.cases {
        let value = reference::welch(case.input(&fx), case.fs, &case.config(&fx)).unwrap();
        let err = max_rel_error(&value, &case.psd);
        assert!(err <= 1e-9, "{}: rel error {err:e}", case.label());
    }
}

#[test]
fn fixture_covers_the_required_grid() {
    // Guards against a regenerated fixture that silently drops part of the grid.
    let fx = load();
    let set =
        |f: &dyn Fn(&Case) -> String| -> BTreeSet<String> { fx.cases.iter().map(f).collect() };
    let windows = set(&|c| match &c.window {
        WindowSpec::Named(n) => n.clone(),
        WindowSpec::Custom { .. } => "custom".into(),
    });
    assert_eq!(
        windows,
        [
            "blackman",
            "blackmanharris",
            "boxcar",
            "custom",
            "flattop",
            "hamming",
            "hann"
        ]
        .map(String::from)
        .into()
    );
    assert!(set(&|c| c.nperseg.to_string())
        .is_superset(&["64", "100", "127", "256"].map(String::from).into()));
    assert_eq!(set(&|c| c.detrend.clone()).len(), 3);
    assert_eq!(set(&|c| c.scaling.clone()).len(), 2);
    let nfft_kinds = set(&|c| match c.nfft {
        None => "default".into(),
        Some(n) if n.is_multiple_of(2) => "even".into(),
        Some(_) => "odd".into(),
    });
    assert_eq!(nfft_kinds.len(), 3);
    let overlaps = set(&|c| match c.noverlap {
        None => "default".into(),
        Some(0) => "zero".into(),
        Some(_) => "other".into(),
    });
    assert_eq!(overlaps.len(), 3);
    let medians: Vec<&Case> = fx
        .cases
        .iter()
        .filter(|c| c.average.parse::<Average>().unwrap() == Average::Median)
        .collect();
    assert!(medians
        .iter()
        .any(|c| c.segments > 2 && c.segments.is_multiple_of(2)));
    assert!(medians
        .iter()
        .any(|c| c.segments > 2 && c.segments % 2 == 1));
    assert!(fx.cases.iter().any(|c| c.n % 2 == 1));
    assert!(fx.versions.contains_key("numpy") && fx.versions.contains_key("scipy"));
}
