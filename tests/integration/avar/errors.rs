//! Bad input: every refusal is a typed error that names the numbers involved, and no input panics.

use imunoise::avar::{compute, identify_noise, AvarError, Confidence, Statistic, TauGrid};
use proptest::prelude::*;

fn run(y: &[f64], grid: &TauGrid, stat: Statistic) -> Result<(), AvarError> {
    compute(y, 100.0, grid, stat, Confidence::OneSigma).map(|_| ())
}

#[test]
fn too_short_names_what_was_needed_and_given() {
    let y = vec![1.0, 2.0];
    let err = run(&y, &TauGrid::Octave, Statistic::Oadev).unwrap_err();
    assert_eq!(
        err,
        AvarError::TooShort {
            n: 2,
            needed: 3,
            statistic: Statistic::Oadev,
            m: 1
        }
    );
    let text = err.to_string();
    assert!(
        text.contains("oadev") && text.contains('3') && text.contains('2'),
        "{text}"
    );
    // Each statistic's own minimum at m = 1.
    let needed = [
        (Statistic::Adev, 3),
        (Statistic::Mdev, 3),
        (Statistic::Hdev, 4),
        (Statistic::Ohdev, 4),
    ];
    for (stat, n) in needed {
        let y = vec![0.5; n - 1];
        assert!(
            matches!(run(&y, &TauGrid::All, stat), Err(AvarError::TooShort { needed, .. }) if needed == n),
            "{stat}"
        );
        assert!(run(&vec![0.5; n], &TauGrid::All, stat).is_ok(), "{stat}");
    }
}

#[test]
fn explicit_tau_beyond_the_data_is_too_short() {
    let y: Vec<f64> = (0..1000).map(|i| (i as f64).sin()).collect();
    let err = run(
        &y,
        &TauGrid::Explicit(vec![1, 10, 600, 400]),
        Statistic::Oadev,
    )
    .unwrap_err();
    assert_eq!(
        err,
        AvarError::TooShort {
            n: 1000,
            needed: 1201,
            statistic: Statistic::Oadev,
            m: 600
        }
    );
    assert!(err.to_string().contains("m = 600"), "{err}");
    assert_eq!(
        run(&y, &TauGrid::Explicit(vec![0, 4]), Statistic::Oadev).unwrap_err(),
        AvarError::ZeroFactor
    );
    assert!(matches!(
        run(&y, &TauGrid::PerDecade(0), Statistic::Oadev),
        Err(AvarError::NoValidTau { n: 1000, .. })
    ));
    assert!(matches!(
        run(&y, &TauGrid::Explicit(vec![]), Statistic::Oadev),
        Err(AvarError::NoValidTau { .. })
    ));
}

#[test]
fn non_finite_sample_is_reported_with_its_index() {
    let mut y: Vec<f64> = (0..50_000).map(|i| (i as f64 * 0.1).cos()).collect();
    y[31_337] = f64::NAN;
    y[40_000] = f64::NEG_INFINITY;
    let err = run(&y, &TauGrid::Octave, Statistic::Mdev).unwrap_err();
    assert_eq!(err, AvarError::NonFinite { index: 31_337 });
    assert!(err.to_string().contains("31337"), "{err}");
    y[31_337] = 0.0;
    assert_eq!(
        run(&y, &TauGrid::Octave, Statistic::Oadev).unwrap_err(),
        AvarError::NonFinite { index: 40_000 }
    );
    assert_eq!(
        identify_noise(&y, 4, Statistic::Oadev).unwrap_err(),
        AvarError::NonFinite { index: 40_000 }
    );
}

#[test]
fn invalid_rate_and_confidence() {
    let y = vec![1.0, 2.0, 0.5, 0.25, 3.0];
    for rate in [0.0, -1.0, f64::NAN, f64::INFINITY] {
        let err = compute(
            &y,
            rate,
            &TauGrid::Octave,
            Statistic::Oadev,
            Confidence::OneSigma,
        );
        assert!(matches!(err, Err(AvarError::InvalidRate(_))), "{rate}");
    }
    for p in [0.0, 1.0, 1.2, -0.5, f64::NAN] {
        let err = compute(
            &y,
            1.0,
            &TauGrid::Octave,
            Statistic::Oadev,
            Confidence::Level(p),
        );
        assert!(matches!(err, Err(AvarError::InvalidConfidence(_))), "{p}");
    }
}

#[test]
fn constant_and_huge_data_do_not_break() {
    let d = compute(
        &[4.0; 500],
        1.0,
        &TauGrid::Octave,
        Statistic::Oadev,
        Confidence::OneSigma,
    )
    .unwrap();
    assert!(d.variance.iter().all(|&v| v == 0.0));
    assert!(d.variance_hi.iter().all(|&v| v == 0.0));
    assert_eq!(
        run(&[f64::MAX; 10], &TauGrid::Octave, Statistic::Oadev).unwrap_err(),
        AvarError::Overflow
    );
}

fn any_statistic() -> impl Strategy<Value = Statistic> {
    prop::sample::select(Statistic::ALL.to_vec())
}

fn any_grid() -> impl Strategy<Value = TauGrid> {
    prop_oneof![
        Just(TauGrid::Octave),
        Just(TauGrid::Decade125),
        Just(TauGrid::All),
        (0u32..6).prop_map(TauGrid::PerDecade),
        prop::collection::vec(0u64..40, 0..5).prop_map(TauGrid::Explicit),
    ]
}

proptest! {
    // No failure-persistence file: a failing case is printed, shrunk, in the test output.
    #![proptest_config(ProptestConfig { cases: 300, failure_persistence: None, ..ProptestConfig::default() })]

    /// Any length, any values (including NaN, ±∞, huge and tiny), any grid and statistic: an Ok
    /// with consistent, ordered, non-negative results, or an error; never a panic. (The interval
    /// contains the estimate only for p ≥ 0.5: at small EDF and low p both chi-square quantiles
    /// can fall on the same side of ν.)
    #[test]
    fn never_panics(
        y in prop::collection::vec(
            prop_oneof![
                8 => -1e3f64..1e3,
                1 => prop::num::f64::ANY,
                1 => Just(1e300f64),
            ],
            0..120,
        ),
        grid in any_grid(),
        stat in any_statistic(),
        p in 0.0f64..1.2,
    ) {
        if let Ok(d) = compute(&y, 10.0, &grid, stat, Confidence::Level(p)) {
            let k = d.len();
            prop_assert!(k > 0);
            for v in [&d.variance, &d.edf, &d.variance_lo, &d.variance_hi, &d.tau_s] {
                prop_assert_eq!(v.len(), k);
            }
            prop_assert!(d.m.windows(2).all(|w| w[0] < w[1]));
            for i in 0..k {
                prop_assert!(d.n_terms[i] >= 2);
                prop_assert!(d.variance[i] >= 0.0);
                prop_assert!(d.variance_lo[i] <= d.variance_hi[i]);
                if p >= 0.5 {
                    prop_assert!(d.variance_lo[i] <= d.variance[i] * (1.0 + 1e-12));
                    prop_assert!(d.variance[i] <= d.variance_hi[i] * (1.0 + 1e-12));
                }
                prop_assert!(d.alpha[i] >= stat.alpha_min() && d.alpha[i] <= 2);
            }
        }
    }
}
