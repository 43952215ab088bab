//! The base fits inside the sensor's band: the one flow that `analyze` (before the loop) and the
//! loop (when it is handed no base fits) both run, so that the two cannot drift apart.
//!
//! 1. Look for the sensor's low-pass roll-off in the spectrum ([`detect_bandwidth`]), and drop
//!    it where the strongest narrow excess, modelled as a resonance, explains it as well
//!    ([`resonance_explains_roll_off`]: a band-pass resonance's skirt read as a filter).
//! 2. Fit the Allan variance and the spectrum with the options restricted to the band it keeps
//!    ([`Bandwidth::restrict`]).
//! 3. Ask whether the edge is the output's coarse angle grid rather than a filter
//!    ([`attribute_edge`]: that takes both fits' Q and N, so it comes after them); if the cause
//!    changed, the band changed with it and both fits are made again.
//!
//! 4. Where a fit kept a rate ramp R, ask the time series whether it determines one
//!    ([`super::ramp`]): if not, both fits are made again without R (and every later fit of the
//!    channel, the loop's included, goes without it: the returned options exclude it); if so, R's
//!    interval is widened to the series'. Not the other way: where the fits chose K, a ramp the
//!    series shows is not forced in. Tried: it found a planted ramp of 200 °/h/h (7σ of the
//!    random walk's wander over 30 min) in 45 of 60 records instead of 27, but before the loop
//!    the series' slope is also a warm-up's or a temperature coupling's, which the loop explains
//!    later (the sample's gyro_z got a ramp in K's place that way).
//!
//! It lives among the effects, not in `model`, because step 3 is one: the angle quantiser's
//! simulation is an effect's test, and `model` does not look up.

use crate::avar::Deviations;
use crate::model::{
    band_min_tau, detect_bandwidth, fit_avar, fit_psd, Bandwidth, FitError, FitOptions, NoiseFit,
    Term,
};
use crate::psd::{BinnedPsd, Psd};

use super::angle_grid::attribute_edge;
use super::ramp::{test_ramp, widen_ramp, without_ramp, RampAction, RampDecision, TestedSeries};
use super::skirt::resonance_explains_roll_off;

/// What the fits know of the series behind the estimates.
#[derive(Debug, Clone, Copy, Default)]
pub struct Series<'a> {
    /// The samples (SI), for the ramp's test (empty: no test).
    pub samples: &'a [f64],
    /// The smallest step between them, which tells a coarse angle quantiser's edge from a
    /// filter's (`None`: unknown).
    pub output_step: Option<f64>,
}

/// What [`fit_in_band`] made.
#[derive(Debug, Clone)]
pub struct BandFits {
    /// The roll-off found and the band kept (`None`: none found, or detection off).
    pub bandwidth: Option<Bandwidth>,
    /// The options both fits were made with: the caller's, restricted to the band, with
    /// detection off (the band is found), so that later fits inside the band use the same.
    pub options: FitOptions,
    /// The IEEE model fitted to the overlapping Allan variance.
    pub allan: Result<NoiseFit, FitError>,
    /// The IEEE model fitted to the log-binned spectrum.
    pub spectrum: Result<NoiseFit, FitError>,
    /// The series' test of the rate ramp a fit kept (`None`: no fit kept one, or too few
    /// samples); where it dropped R, the fits and options are without it.
    pub ramp: Option<RampDecision>,
}

/// The base fits of one channel's estimates inside its band (see the module docs): `dev` its
/// overlapping Allan variance, `psd` and `binned` its spectrum, `series` what is known of its
/// samples. A missing estimate makes that fit an error that says which one it lacks; the other
/// goes on.
pub fn fit_in_band(
    dev: Option<&Deviations>,
    psd: &Psd,
    binned: Option<&BinnedPsd>,
    opts: &FitOptions,
    series: Series<'_>,
) -> BandFits {
    // The Allan fit's start that a band the user keeps the spectrum fit to asks for
    // ([`band_min_tau`]); where no τ of the grid qualifies, the Allan fit has no point.
    let user_floor = opts
        .max_freq_hz
        .zip(dev)
        .map(|(f, d)| band_min_tau(f, d.rate_hz, &d.tau_s).unwrap_or(f64::INFINITY));
    let mut bandwidth = match (binned, opts.detect_bandwidth) {
        (Some(binned), true) => {
            let taus = dev.map_or(&[][..], |d| &d.tau_s[..]);
            // The roll-off is looked for over the whole spectrum, whatever band the user keeps
            // the spectrum fit to (`--fit-max-freq`): searched inside a 20-Hz limit, the
            // 250-Hz filter of a 1-kHz sensor was not found, the Allan fit then started at
            // τ = 1 ms inside its droop (χ²/dof 5·10⁴), and N came out "not significant" with
            // an upper limit of 0.46× the truth, which imu.yaml took. The band the fits keep is
            // the narrower of the two ([`Bandwidth::restrict`]).
            let mut whole = opts.clone();
            whole.max_freq_hz = None;
            detect_bandwidth(psd, binned, taus, &whole)
                .filter(|b| !resonance_explains_roll_off(psd, binned, &whole, b))
                .map(|mut b| {
                    if let Some(user) = opts.max_freq_hz {
                        b.fit_max_freq_hz = b.fit_max_freq_hz.min(user);
                    }
                    if let Some(floor) = user_floor.filter(|f| f.is_finite()) {
                        b.fit_min_tau_s = Some(b.fit_min_tau_s.map_or(floor, |t| t.max(floor)));
                    }
                    b
                })
        }
        _ => None,
    };
    let mut unrestricted = opts.clone();
    unrestricted.detect_bandwidth = false;
    if let Some(floor) = user_floor {
        unrestricted.min_tau_s = Some(opts.min_tau_s.map_or(floor, |t| t.max(floor)));
    }
    let inside = |band: Option<&Bandwidth>| {
        band.map_or_else(|| unrestricted.clone(), |b| b.restrict(&unrestricted))
    };
    let mut options = inside(bandwidth.as_ref());
    let (mut allan, mut spectrum) = fits(dev, psd, binned, &options);
    if let Some(b) = bandwidth.as_mut() {
        let grid = series.output_step;
        if attribute_edge(b, psd, grid, allan.as_ref().ok(), spectrum.as_ref().ok()) {
            options = inside(Some(b));
            (allan, spectrum) = fits(dev, psd, binned, &options);
        }
    }
    let keeps_ramp =
        |f: &Result<NoiseFit, FitError>| f.as_ref().is_ok_and(|f| f.get(Term::RateRamp).is_some());
    let mut ramp = None;
    if keeps_ramp(&allan) || keeps_ramp(&spectrum) {
        let flat = without_ramp(&options);
        let (allan_flat, spectrum_flat) = fits(dev, psd, binned, &flat);
        let model = allan_flat.as_ref().or(spectrum_flat.as_ref()).ok();
        let decided = model.and_then(|m| test_ramp(series.samples, psd.rate_hz, m));
        ramp = decided.map(|test| RampDecision {
            series: TestedSeries::Recorded,
            action: if test.determined() {
                RampAction::Kept
            } else {
                RampAction::Dropped
            },
            test,
            estimate: None,
        });
        match &mut ramp {
            Some(d) if d.action == RampAction::Kept => {
                // Determined under the model without R, whose K took up the ramp's rise (which
                // keeps the test's level); its size is measured under the model with R, whose
                // left-out K is the random walk's own (the first's error was 2.5× the scatter).
                let with_ramp = allan.as_ref().or(spectrum.as_ref()).ok();
                let sized = with_ramp
                    .and_then(|m| test_ramp(series.samples, psd.rate_hz, m))
                    .unwrap_or(d.test);
                for f in [&mut allan, &mut spectrum].into_iter().flatten() {
                    widen_ramp(f, &sized);
                }
                d.estimate = Some(sized);
            }
            Some(_) => {
                (options, allan, spectrum) = (flat, allan_flat, spectrum_flat);
            }
            None => {}
        }
    }
    BandFits {
        bandwidth,
        options,
        allan,
        spectrum,
        ramp,
    }
}

/// Both fits with `opts`, side by side (they are independent).
fn fits(
    dev: Option<&Deviations>,
    psd: &Psd,
    binned: Option<&BinnedPsd>,
    opts: &FitOptions,
) -> (Result<NoiseFit, FitError>, Result<NoiseFit, FitError>) {
    rayon::join(
        || match dev {
            Some(d) => fit_avar(d, opts),
            None => Err(FitError::InvalidOptions(
                "the Allan fit needs the overlapping Allan variance (oadev)".into(),
            )),
        },
        || match binned {
            Some(b) => fit_psd(psd, b, opts),
            None => Err(FitError::InvalidOptions(
                "the spectrum fit needs the log-binned spectrum (bins per decade > 0)".into(),
            )),
        },
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::effects::ramp::tests::{octave_oadev, series};
    use crate::psd::{log_bin, welch, WelchConfig};

    const FS: f64 = 100.0;

    /// The Allan fit alone and the base fits' flow of `y`.
    fn both(y: &[f64]) -> (NoiseFit, BandFits) {
        let d = octave_oadev(y);
        let psd = welch(y, FS, &WelchConfig::new(4096)).unwrap();
        let binned = log_bin(&psd, 20);
        let opts = FitOptions::default();
        let series = Series {
            samples: y,
            output_step: None,
        };
        let alone = fit_avar(&d, &opts).unwrap();
        (
            alone,
            fit_in_band(Some(&d), &psd, Some(&binned), &opts, series),
        )
    }

    /// White noise (N = 0.1 /√Hz at 100 Hz) under a strong line at 40 Hz (amplitude 3σ), with
    /// the spectrum fit kept below 10 Hz by the user: the Allan fit starts where the band above
    /// 10 Hz carries at most 2 % of white noise's Allan variance (τ ≥ 0.76 s, the octave grid's
    /// 1.28 s), and its N is the white noise's. From τ = 10 ms, as before, the line was read as
    /// quantisation and N came out 14 % low (0.086 [0.065, 0.159]).
    #[test]
    fn a_users_band_holds_the_allan_fit_to_the_taus_below_it() {
        use crate::sim::rng::Rng;
        let mut rng = Rng::new(41);
        let y: Vec<f64> = (0..400_000)
            .map(|i| rng.gauss() + 3.0 * (std::f64::consts::TAU * 40.0 * i as f64 / FS).sin())
            .collect();
        let d = octave_oadev(&y);
        let psd = welch(&y, FS, &WelchConfig::new(4096)).unwrap();
        let binned = log_bin(&psd, 20);
        let opts = FitOptions {
            max_freq_hz: Some(10.0),
            ..FitOptions::default()
        };
        let floor = crate::model::band_min_tau(10.0, FS, &d.tau_s).unwrap();
        assert!((floor - 1.28).abs() < 1e-9, "{floor}");
        let series = Series {
            samples: &y,
            output_step: None,
        };
        let base = fit_in_band(Some(&d), &psd, Some(&binned), &opts, series);
        let allan = base.allan.unwrap();
        assert!(allan.points.iter().all(|p| p.x >= floor * (1.0 - 1e-9)));
        let n = allan.get(Term::RandomWalk).unwrap().value;
        assert!((n / 0.1 - 1.0).abs() < 0.05, "N {n}");
        let unheld = fit_avar(&d, &opts).unwrap();
        let n_unheld = unheld.get(Term::RandomWalk).map_or(0.0, |e| e.value);
        println!(
            "N from 1.28 s {n}, from 10 ms {n_unheld}: {:?}",
            unheld.estimates
        );
        assert!((n_unheld / 0.1 - 1.0).abs() > 0.1, "{n_unheld}");
    }

    /// The clean records among seeds 11 000 000–11 000 299 (`examples/ramp_check.rs`) whose Allan
    /// fit alone keeps a ramp, with an interval that excludes 0: the series does not determine one
    /// in any, and the base fits go without R (K in its place).
    #[test]
    fn a_ramp_the_series_does_not_show_is_dropped() {
        for seed in [163, 166, 175, 183, 187, 233, 100, 258] {
            let y = series(11_000_000 + seed, 0.0);
            let (alone, base) = both(&y);
            let r = alone
                .get(Term::RateRamp)
                .expect("the Allan fit alone keeps R");
            assert!(r.lo > 0.0, "seed {seed}: {r:?}");
            let d = base.ramp.expect("tested");
            assert!(!d.test.determined(), "seed {seed}: {d:?}");
            assert_eq!(d.action, RampAction::Dropped);
            let allan = base.allan.unwrap();
            assert!(allan.get(Term::RateRamp).is_none(), "seed {seed}");
            assert!(!base.options.terms.contains(&Term::RateRamp));
        }
    }

    /// A planted ramp of 400 °/h/h (R·T ≈ 14 times the random walk's wander K·√T): kept in each of
    /// 8 records, with an interval that holds the Allan fit's own and the series' estimate ± its
    /// error; the Allan fit's own interval alone covered it in 14 of 60 records (54 of 60 now,
    /// `validation/ramp.md`), here in fewer than the widened one.
    #[test]
    fn a_determined_ramp_keeps_the_series_interval() {
        let truth = 400f64.to_radians() / 3600.0 / 3600.0;
        let (mut alone_covers, mut widened_covers) = (0, 0);
        for seed in 0..8 {
            let y = series(12_000_000 + seed, 400.0);
            let (alone, base) = both(&y);
            let d = base.ramp.expect("tested");
            assert!(d.test.determined(), "seed {seed}: {d:?}");
            assert_eq!(d.action, RampAction::Kept);
            let test = d.estimate.expect("sized under the model with R");
            let a = alone.get(Term::RateRamp).expect("kept alone");
            let w = base
                .allan
                .as_ref()
                .unwrap()
                .get(Term::RateRamp)
                .expect("kept");
            assert!(w.lo <= a.lo && w.hi >= a.hi, "seed {seed}: {w:?} vs {a:?}");
            assert!(w.lo <= (test.ramp - test.se).max(0.0) && w.hi >= test.ramp + test.se);
            alone_covers += usize::from(a.covers(truth));
            widened_covers += usize::from(w.covers(truth));
        }
        assert!(
            widened_covers >= 6,
            "widened intervals cover in {widened_covers} of 8"
        );
        assert!(
            alone_covers < widened_covers,
            "{alone_covers} vs {widened_covers}"
        );
    }
}
