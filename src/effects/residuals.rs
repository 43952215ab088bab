//! What a fit leaves unexplained, in numbers: the normalised residuals of one domain (AV or
//! log-binned PSD) and three tests for structure in them.
//!
//! - χ²/dof of the whitened residuals (the fit's own figure): too large means the model misses
//!   something or the points scatter more than their EDF says.
//! - Runs of same-sign residuals (Wald–Wolfowitz): a smooth misfit (a hump, a knee) makes long
//!   runs even when χ² is modest.
//! - Localised excess: the largest Σz² over a window of 1–5 neighbouring points against χ² with as
//!   many degrees of freedom, Bonferroni-corrected for the windows scanned: a line or a resonance
//!   lives in a few bands.
//!
//! The residual of a point is the fit's Wilson–Hilferty z (see [`crate::model::FitPoint`]), close
//! to standard normal under the model even at few degrees of freedom.

use crate::stats::{chi2_sf, norm_sf};
use serde::Serialize;

use crate::model::NoiseFit;

/// Significance of each structure test.
pub const STRUCTURE_P: f64 = 0.01;

/// A window of points with excess residual.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct LocalExcess {
    /// τ (s) or frequency (Hz) range of the window.
    pub x_lo: f64,
    pub x_hi: f64,
    pub points: usize,
    pub sum_z2: f64,
    /// Bonferroni-corrected p-value.
    pub p_value: f64,
}

/// The residual figures of one fit.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Diagnostics {
    pub chi2_per_dof: f64,
    /// p-value of χ² against χ²_dof.
    pub chi2_p: f64,
    /// Root mean square of ln(measured/model): the error in the log domain, as a plot shows it.
    pub rms_log: f64,
    pub runs: usize,
    /// Normal z of the run count (negative: fewer runs than chance, i.e. smooth structure).
    pub runs_z: f64,
    pub runs_p: f64,
    pub local: Option<LocalExcess>,
    /// Any of the three tests below [`STRUCTURE_P`].
    pub structured: bool,
}

/// Diagnostics of `fit`.
pub fn diagnose(fit: &NoiseFit) -> Diagnostics {
    let z: Vec<f64> = fit.points.iter().map(|p| p.z).collect();
    let n = z.len();
    let rms_log = (fit
        .points
        .iter()
        .map(|p| (p.value / p.model).ln().powi(2))
        .filter(|v| v.is_finite())
        .sum::<f64>()
        / n.max(1) as f64)
        .sqrt();
    let chi2_p = chi2_sf(fit.chi2, fit.dof.max(1) as f64);

    // Wald–Wolfowitz runs test on the signs.
    let pos = z.iter().filter(|v| **v > 0.0).count() as f64;
    let neg = n as f64 - pos;
    let runs = 1 + z
        .windows(2)
        .filter(|w| (w[0] > 0.0) != (w[1] > 0.0))
        .count();
    let (runs_z, runs_p) = if pos > 0.0 && neg > 0.0 && n >= 6 {
        let total = pos + neg;
        let mean = 2.0 * pos * neg / total + 1.0;
        let var = 2.0 * pos * neg * (2.0 * pos * neg - total) / (total * total * (total - 1.0));
        let rz = (runs as f64 - mean) / var.max(1e-12).sqrt();
        // One-sided: too few runs is structure; too many is not.
        (rz, 1.0 - norm_sf(rz))
    } else {
        (0.0, 1.0)
    };

    // Localised excess over windows of 1..=5 points.
    let mut local: Option<LocalExcess> = None;
    let windows: usize = (1..=5.min(n)).map(|w| n + 1 - w).sum();
    for w in 1..=5.min(n) {
        for start in 0..=n - w {
            let s: f64 = z[start..start + w].iter().map(|v| v * v).sum();
            let p = (chi2_sf(s, w as f64) * windows as f64).min(1.0);
            if local.is_none_or(|l| p < l.p_value) {
                local = Some(LocalExcess {
                    x_lo: fit.points[start].x,
                    x_hi: fit.points[start + w - 1].x,
                    points: w,
                    sum_z2: s,
                    p_value: p,
                });
            }
        }
    }
    let structured = chi2_p < STRUCTURE_P
        || runs_p < STRUCTURE_P
        || local.is_some_and(|l| l.p_value < STRUCTURE_P);
    Diagnostics {
        chi2_per_dof: fit.chi2_per_dof(),
        chi2_p,
        rms_log,
        runs,
        runs_z,
        runs_p,
        local,
        structured,
    }
}
