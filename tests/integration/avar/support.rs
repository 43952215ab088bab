//! Helpers for the Allan-variance tests: reading the reference files, a seeded RNG, tolerances.

use std::path::PathBuf;

/// Path of a file in `tests/data/avar`.
pub fn data_path(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data/avar")
        .join(name)
}

/// Numbers of a whitespace-separated text file, skipping `#` comment lines, one Vec per line.
pub fn read_table(name: &str) -> Vec<Vec<f64>> {
    let text = std::fs::read_to_string(data_path(name)).expect("reference file");
    text.lines()
        .map(str::trim)
        .filter(|l| !l.is_empty() && !l.starts_with('#'))
        .map(|l| {
            l.split_whitespace()
                .map(|v| v.parse::<f64>().expect("number"))
                .collect()
        })
        .collect()
}

/// One row of a Stable32 result table.
#[derive(Debug, Clone, Copy)]
pub struct Stable32Row {
    pub af: u64,
    pub alpha: i8,
    pub min_sigma: f64,
    pub sigma: f64,
    pub max_sigma: f64,
}

/// A Stable32 result table: AF, Tau, #, Alpha, Min Sigma, Sigma, Max Sigma.
pub fn read_stable32(name: &str) -> Vec<Stable32Row> {
    read_table(name)
        .into_iter()
        .map(|r| Stable32Row {
            af: r[0] as u64,
            alpha: r[3] as i8,
            min_sigma: r[4],
            sigma: r[5],
            max_sigma: r[6],
        })
        .collect()
}

/// PHASE.DAT as rate data: first differences of the phase (τ₀ = 1 s).
pub fn phase_dat_rate() -> Vec<f64> {
    let x: Vec<f64> = read_table("PHASE.DAT").into_iter().map(|r| r[0]).collect();
    assert_eq!(x.len(), 1001);
    x.windows(2).map(|w| w[1] - w[0]).collect()
}

/// The OCXO recording as fractional frequency, y = (f − 10⁷)/10⁷.
pub fn ocxo_rate() -> Vec<f64> {
    let f: Vec<f64> = read_table("ocxo_frequency.txt")
        .into_iter()
        .map(|r| r[0])
        .collect();
    assert_eq!(f.len(), 19982);
    f.iter().map(|f| (f - 1e7) / 1e7).collect()
}

/// |got − printed| in units of the last of `digits` printed significant digits.
pub fn units_in_last_digit(got: f64, printed: f64, digits: i32) -> f64 {
    let exponent = printed.abs().log10().floor() as i32;
    (got - printed).abs() / 10f64.powi(exponent - (digits - 1))
}

/// Whether `got` rounds to the value printed as `printed` with `digits` significant digits:
/// |got − printed| ≤ half a unit in the last printed digit (plus 1e-12 relative for the reference's
/// own rounding at exact ties).
pub fn agrees_to_printed(got: f64, printed: f64, digits: i32) -> bool {
    let exponent = printed.abs().log10().floor() as i32;
    let half_unit = 0.5 * 10f64.powi(exponent - (digits - 1));
    (got - printed).abs() <= half_unit * (1.0 + 1e-9) + 1e-12 * printed.abs()
}

/// Seeded uniform generator (the project's SplitMix64).
pub struct SplitMix(pub u64);

impl SplitMix {
    pub fn next_u64(&mut self) -> u64 {
        imunoise::sim::rng::splitmix64(&mut self.0)
    }

    /// Uniform in (0, 1].
    pub fn uniform(&mut self) -> f64 {
        ((self.next_u64() >> 11) + 1) as f64 / (1u64 << 53) as f64
    }

    /// Standard normal (Box–Muller, one value per call).
    pub fn gauss(&mut self) -> f64 {
        let (u, v) = (self.uniform(), self.uniform());
        (-2.0 * u.ln()).sqrt() * (std::f64::consts::TAU * v).cos()
    }

    pub fn gauss_vec(&mut self, n: usize) -> Vec<f64> {
        (0..n).map(|_| self.gauss()).collect()
    }
}

/// Relative difference |a − b| / |b|.
pub fn rel(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs()
}
