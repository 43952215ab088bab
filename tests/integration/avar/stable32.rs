//! Stable32 reference runs (files in `tests/data/avar`, see PROVENANCE.md).
//!
//! Stable32 prints 5 significant digits. Deviations are asserted to round to the printed value
//! (|ours − printed| ≤ half a unit in the 5th digit, i.e. ≤ 5e-5 relative to the leading digit).
//! Confidence bounds are asserted within 1% (they agree to 4e-4). Noise identification is compared
//! with the Alpha column: exactly where Stable32 used the lag-1 autocorrelation (≥ 30 τ-averages),
//! and as a count where it used its B1/R(n) fallback.

use imunoise::avar::edf::{edf, simple_edf};
use imunoise::avar::{
    compute, identify_noise, variance_bounds, Confidence, Statistic, TauGrid, ONE_SIGMA,
};

use super::support::Stable32Row;
use super::support::{agrees_to_printed, ocxo_rate, phase_dat_rate, read_stable32, rel};

/// Stable32's confidence factor for its 1σ bounds.
const STABLE32_CONFIDENCE: f64 = 0.683;

fn deviations_agree(y: &[f64], stat: Statistic, rows: &[Stable32Row]) {
    let ms: Vec<u64> = rows.iter().map(|r| r.af).collect();
    let d = compute(y, 1.0, &TauGrid::Explicit(ms), stat, Confidence::OneSigma).unwrap();
    for (dev, row) in d.deviation().iter().zip(rows) {
        assert!(
            agrees_to_printed(*dev, row.sigma, 5),
            "{stat} AF {}: {dev:.6e} vs Stable32 {:.4e}",
            row.af,
            row.sigma
        );
    }
}

#[test]
fn phase_dat_overlapping_allan_at_every_af() {
    let y = phase_dat_rate();
    let rows = read_stable32("phase_dat_oadev.txt");
    assert_eq!(rows.len(), 139);
    deviations_agree(&y, Statistic::Oadev, &rows);
    deviations_agree(
        &y,
        Statistic::Oadev,
        &read_stable32("phase_dat_oadev_octave.txt"),
    );
}

#[test]
fn phase_dat_allan_at_every_af() {
    let y = phase_dat_rate();
    let rows = read_stable32("phase_dat_adev.txt");
    assert_eq!(rows.len(), 125);
    deviations_agree(&y, Statistic::Adev, &rows);
}

#[test]
fn ocxo_overlapping_allan_all_tau() {
    // 5 printed digits allow up to 5e-5 relative of rounding; the asked 1e-4 therefore holds for
    // every AF, and the stricter "rounds to the printed value" is asserted as well.
    let y = ocxo_rate();
    let rows = read_stable32("stable32_oadev_alltau.txt");
    assert_eq!(rows.len(), 273);
    deviations_agree(&y, Statistic::Oadev, &rows);
    let ms: Vec<u64> = rows.iter().map(|r| r.af).collect();
    let d = compute(
        &y,
        1.0,
        &TauGrid::Explicit(ms),
        Statistic::Oadev,
        Confidence::OneSigma,
    )
    .unwrap();
    for (dev, row) in d.deviation().iter().zip(&rows) {
        assert!(rel(*dev, row.sigma) < 1e-4, "AF {}", row.af);
    }
}

/// Max relative deviation of bounds computed with `edf_of(row)` from Stable32's printed bounds.
fn bound_error(rows: &[Stable32Row], edf_of: impl Fn(&Stable32Row) -> f64) -> f64 {
    rows.iter()
        .map(|r| {
            let (lo, hi) = variance_bounds(r.sigma * r.sigma, edf_of(r), STABLE32_CONFIDENCE);
            rel(lo.sqrt(), r.min_sigma).max(rel(hi.sqrt(), r.max_sigma))
        })
        .fold(0.0, f64::max)
}

#[test]
fn octave_bounds_are_greenhall_edf() {
    // With Stable32's own Alpha, Greenhall–Riley EDF reproduces the printed 1σ bounds to < 4e-4
    // (the residual is Stable32's, visible also in allantools); the simple approximations of
    // SP 1065 table 5 miss by > 2e-3. So Stable32 uses Greenhall's EDF.
    let rows = read_stable32("phase_dat_oadev_octave.txt");
    assert_eq!(rows.len(), 8);
    let n = 1000; // rate samples
    let greenhall = bound_error(&rows, |r| edf(Statistic::Oadev, r.alpha, r.af, n));
    let simple = bound_error(&rows, |r| simple_edf(r.alpha, r.af, n as u64 + 1));
    eprintln!(
        "PHASE.DAT octave bounds: Greenhall max rel err {greenhall:.2e}, simple {simple:.2e}"
    );
    assert!(greenhall < 4e-4, "{greenhall:e}");
    assert!(simple > 2e-3, "{simple:e}");
}

#[test]
fn octave_bounds_with_own_noise_identification() {
    // compute() identifies α itself; where it agrees with Stable32's Alpha the bounds must agree
    // within 1%. Bounds at 0.683 are compared (Stable32's confidence factor).
    let y = phase_dat_rate();
    let rows = read_stable32("phase_dat_oadev_octave.txt");
    let ms: Vec<u64> = rows.iter().map(|r| r.af).collect();
    let d = compute(
        &y,
        1.0,
        &TauGrid::Explicit(ms),
        Statistic::Oadev,
        Confidence::Level(STABLE32_CONFIDENCE),
    )
    .unwrap();
    let mut agree = 0;
    for (i, row) in rows.iter().enumerate() {
        let (lo, hi) = (d.variance_lo[i].sqrt(), d.variance_hi[i].sqrt());
        eprintln!(
            "AF {:4} α {} (Stable32 {}): [{lo:.5e}, {hi:.5e}] vs [{:.4e}, {:.4e}]",
            row.af, d.alpha[i], row.alpha, row.min_sigma, row.max_sigma
        );
        if d.alpha[i] == row.alpha {
            agree += 1;
            assert!(rel(lo, row.min_sigma) < 0.01, "AF {}", row.af);
            assert!(rel(hi, row.max_sigma) < 0.01, "AF {}", row.af);
        }
    }
    assert!(agree >= 7, "α agrees at {agree} of 8 octave AFs");
    assert_eq!(d.confidence, STABLE32_CONFIDENCE);
    let _ = ONE_SIGMA;
}

/// (agreements where Stable32 used the autocorrelation, rows there, agreements elsewhere, rows).
fn alpha_agreement(
    y: &[f64],
    stat: Statistic,
    rows: &[Stable32Row],
) -> (usize, usize, usize, usize) {
    let mut counts = (0, 0, 0, 0);
    for row in rows {
        let ours = identify_noise(y, row.af, stat).unwrap().alpha;
        let acf = y.len() as u64 / row.af >= 30;
        let hit = usize::from(ours == row.alpha);
        if acf {
            counts.0 += hit;
            counts.1 += 1;
        } else {
            counts.2 += hit;
            counts.3 += 1;
        }
    }
    counts
}

#[test]
fn noise_identification_agrees_with_stable32() {
    let phase = phase_dat_rate();
    let ocxo = ocxo_rate();
    let cases = [
        (
            "PHASE.DAT oadev octave",
            &phase,
            Statistic::Oadev,
            "phase_dat_oadev_octave.txt",
            1,
        ),
        (
            "PHASE.DAT oadev",
            &phase,
            Statistic::Oadev,
            "phase_dat_oadev.txt",
            87,
        ),
        (
            "PHASE.DAT adev",
            &phase,
            Statistic::Adev,
            "phase_dat_adev.txt",
            80,
        ),
        (
            "OCXO oadev all-tau",
            &ocxo,
            Statistic::Oadev,
            "stable32_oadev_alltau.txt",
            91,
        ),
    ];
    for (name, y, stat, file, b1_floor) in cases {
        let rows = read_stable32(file);
        let (acf_hits, acf_rows, b1_hits, b1_rows) = alpha_agreement(y, stat, &rows);
        eprintln!(
            "{name}: α agrees at {acf_hits}/{acf_rows} autocorrelation AFs, \
             {b1_hits}/{b1_rows} B1/R(n) AFs"
        );
        assert_eq!(acf_hits, acf_rows, "{name}: lag-1 autocorrelation region");
        assert!(
            b1_hits >= b1_floor,
            "{name}: {b1_hits}/{b1_rows} in the B1 region"
        );
    }
}
