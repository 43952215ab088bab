//! The residual loop on real third-party recordings (`tests/data/avar/`, provenance there):
//! the 10 MHz OCXO measured against an H-maser (19 982 fractional-frequency samples at 1 s) and
//! Stable32's PHASE.DAT (1 000 frequency samples). Neither is an inertial sensor, but the IEEE
//! model is the clock model in other words (white PM ↔ Q, white FM ↔ N, flicker FM ↔ B,
//! random-walk FM ↔ K, drift ↔ R), with the fractional frequency y in place of the rate.
//!
//! Run: `cargo run --release --example reference_loop`. Prints the base fits, each effect the
//! loop adds with its evidence and the error before and after, and the final fits.

use std::path::Path;

use imunoise::effects::{close_loop, LoopConfig, LoopOutcome};
use imunoise::model::NoiseFit;

fn read_column(path: &Path) -> Vec<f64> {
    std::fs::read_to_string(path)
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()))
        .lines()
        .map(str::trim)
        .filter(|l| !l.is_empty() && !l.starts_with('#'))
        .map(|l| {
            l.split_whitespace()
                .next()
                .and_then(|v| v.parse().ok())
                .unwrap_or_else(|| panic!("{}: not a number: {l}", path.display()))
        })
        .collect()
}

fn describe(fit: Option<&NoiseFit>) -> String {
    let Some(fit) = fit else {
        return "no fit".into();
    };
    let terms: Vec<String> = fit
        .estimates
        .iter()
        .map(|e| format!("{} {:.3e} [{:.3e}, {:.3e}]", e.term, e.value, e.lo, e.hi))
        .collect();
    format!("{}; χ²/dof {:.2}", terms.join(", "), fit.chi2_per_dof())
}

fn report(name: &str, o: &LoopOutcome) {
    let r = &o.report;
    println!("## {name}");
    println!("base Allan fit:    {}", describe(r.base_allan.as_ref()));
    println!("base spectrum fit: {}", describe(r.base_spectrum.as_ref()));
    if r.steps.is_empty() {
        println!("loop: nothing beyond the IEEE model");
    }
    // Fractional frequency: a plain number.
    let units = imunoise::report::EffectUnits {
        value: Some(imunoise::units::Unit::One),
        ..Default::default()
    };
    for (i, s) in r.steps.iter().enumerate() {
        let fig = |d: &Option<imunoise::effects::residuals::Diagnostics>| {
            d.as_ref().map_or("–".to_string(), |d| {
                format!("χ²/dof {:.2}, RMS log {:.3}", d.chi2_per_dof, d.rms_log)
            })
        };
        println!(
            "step {}: {} (ΔBIC {:.1})\n  evidence: {}\n  Allan    {} → {}\n  spectrum {} → {}",
            i + 1,
            imunoise::report::effect_line(&s.effect, &units),
            s.delta_bic,
            s.evidence,
            fig(&s.before.allan),
            fig(&s.after.allan),
            fig(&s.before.spectrum),
            fig(&s.after.spectrum)
        );
    }
    for rej in &r.rejected {
        println!(
            "  considered, not added: {} (ΔBIC {:.1}): {}",
            rej.kind,
            rej.delta_bic.unwrap_or(f64::NAN),
            rej.note
        );
    }
    if let Some(split) = &r.stationarity {
        println!("split record: {split:?}");
    }
    println!("final Allan fit:    {}", describe(o.allan.as_ref()));
    println!("final spectrum fit: {}\n", describe(o.spectrum.as_ref()));
}

fn config(nperseg: usize) -> LoopConfig {
    LoopConfig::with_segment(nperseg)
}

fn main() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/avar");
    let hz = read_column(&dir.join("ocxo_frequency.txt"));
    let y: Vec<f64> = hz.iter().map(|f| (f - 1e7) / 1e7).collect();
    let o = close_loop(&y, 1.0, &[], &config(2048), None).expect("OCXO loop");
    report(
        &format!("OCXO, {} s of fractional frequency at 1 s", y.len()),
        &o,
    );

    let phase = read_column(&dir.join("PHASE.DAT"));
    let y: Vec<f64> = phase.windows(2).map(|w| w[1] - w[0]).collect();
    let o = close_loop(&y, 1.0, &[], &config(128), None).expect("PHASE.DAT loop");
    report(
        &format!("PHASE.DAT, {} frequency samples at τ0 = 1", y.len()),
        &o,
    );
}
