//! Parity with allantools 2024.06 on seeded random data (fixture made by
//! `scripts/make_avar_fixtures.py`): every deviation of oadev, adev, mdev, hdev and ohdev
//! (`data_type="freq"`) on the octave, decade and all grids, to 1e-10 relative.

use imunoise::avar::{compute, Confidence, Statistic, TauGrid};

use super::support::{data_path, rel};

#[derive(serde::Deserialize)]
struct Fixture {
    rate_hz: f64,
    y: Vec<f64>,
    results: Vec<ResultSet>,
}

#[derive(serde::Deserialize)]
struct ResultSet {
    statistic: String,
    grid: String,
    m: Vec<u64>,
    deviation: Vec<f64>,
    n: Vec<u64>,
}

fn fixture() -> Fixture {
    let text = std::fs::read_to_string(data_path("allantools_parity.json")).unwrap();
    serde_json::from_str(&text).unwrap()
}

#[test]
fn matches_allantools_to_1e_10() {
    let fx = fixture();
    assert_eq!(fx.y.len(), 3000);
    assert_eq!(fx.results.len(), 15);
    let mut checked = 0;
    for set in &fx.results {
        let stat: Statistic = set.statistic.parse().unwrap();
        let d = compute(
            &fx.y,
            fx.rate_hz,
            &TauGrid::Explicit(set.m.clone()),
            stat,
            Confidence::OneSigma,
        )
        .unwrap();
        assert_eq!(d.m, set.m, "{stat} {}", set.grid);
        assert_eq!(d.n_terms, set.n, "{stat} {}: term counts", set.grid);
        for ((m, got), want) in d.m.iter().zip(d.deviation()).zip(&set.deviation) {
            assert!(
                rel(got, *want) < 1e-10,
                "{stat} {} m={m}: {got:e} vs allantools {want:e} (rel {:e})",
                set.grid,
                rel(got, *want)
            );
            checked += 1;
        }
        for (tau, m) in d.tau_s.iter().zip(&d.m) {
            assert_eq!(*tau, *m as f64 / fx.rate_hz);
        }
    }
    assert!(checked > 5000, "{checked}");
}

#[test]
fn octave_and_all_grids_are_allantools_grids() {
    // Same conventions: factors up to the last one with at least two terms.
    let fx = fixture();
    for set in &fx.results {
        let stat: Statistic = set.statistic.parse().unwrap();
        let grid = match set.grid.as_str() {
            "octave" => TauGrid::Octave,
            "all" => TauGrid::All,
            _ => continue, // allantools' "decade" is 1-2-4; TauGrid::Decade125 is 1-2-5 by design
        };
        assert_eq!(grid.factors(fx.y.len(), stat), set.m, "{stat} {}", set.grid);
    }
}
