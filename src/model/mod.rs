//! The IEEE noise model of inertial sensors (IEEE Std 952 Annex C, IEEE Std 1554) and its fit to
//! Allan variances and to spectra.
//!
//! - [`Term`] and [`Coefficients`]: the five base terms (Q, N, B, K, R) with their Allan variance
//!   and two-sided PSD per unit squared coefficient; [`GaussMarkov`] and [`Sinusoid`] for the
//!   effects a residual analysis adds. All SI.
//! - [`CoefUnit`]: every unit a datasheet writes coefficients in (°/√h, µg/√Hz, °/h, …), converted
//!   in one place.
//! - [`fit_avar`] and [`fit_psd`]: non-negative weighted least squares of the squared coefficients
//!   (linear in both domains), weights from each point's EDF under the model, iterated; terms enter
//!   only when the information criterion ([`Criterion`], BIC by default) says they earn their place
//!   among all subsets of the allowed terms; every kept coefficient gets a confidence interval
//!   (inverse Fisher information with Satterthwaite degrees of freedom), every absent one an upper
//!   limit, and the fit a χ²/dof.
//! - [`compare`]: spectrum-derived against AV-derived values, per term.
//!
//! Both fits assume what most IMUs deliver: each sample is the mean rate over its interval (delta
//! angle or delta velocity over τ₀). Then the IEEE Allan variances hold exactly at every τ = mτ₀
//! and the spectrum of the samples is the IEEE one through sinc² and folded at Nyquist
//! ([`Term::psd_sampled_unit`]); [`crate::sim`] makes exactly such samples.
//!
//! Known limits: the information criterion admits an absent term in ≈ 3–7 % of fits per term
//! (BIC's price for ~16–40 points); Allan-domain intervals of N run ≈ 10 % narrow (the EDF at
//! m = 1); a deterministic drift other than a ramp (warm-up) is read as ramp or random walk.
//!
//! ```
//! use imunoise::avar::{compute, Confidence, Statistic, TauGrid};
//! use imunoise::model::{compare, fit_avar, fit_psd, Coefficients, CoefUnit, FitOptions, Sensor, Term};
//! use imunoise::psd::{log_bin, welch, WelchConfig};
//! use imunoise::sim::{simulate, ChannelSpec, SimSpec};
//!
//! let n = CoefUnit::DegPerSqrtH.to_si(0.5); // angle random walk 0.5 °/√h
//! let spec = SimSpec {
//!     rate_hz: 100.0,
//!     duration_s: 2000.0,
//!     seed: 3,
//!     channels: vec![ChannelSpec::new(
//!         "gz",
//!         Sensor::Gyro,
//!         Coefficients { n, ..Default::default() },
//!     )],
//!     temperature: None,
//! };
//! let y = &simulate(&spec)?.channels[0].samples;
//! let opts = FitOptions::default();
//! let av = fit_avar(&compute(y, 100.0, &TauGrid::Octave, Statistic::Oadev, Confidence::OneSigma)?, &opts)?;
//! let psd = welch(y, 100.0, &WelchConfig::new(8192))?;
//! let sp = fit_psd(&psd, &log_bin(&psd, 10), &opts)?;
//! let arw = av.get(Term::RandomWalk).unwrap();
//! assert!(arw.covers(n));
//! println!("N = {:.3} °/√h", CoefUnit::DegPerSqrtH.from_si(arw.value));
//! for row in compare(&av, &sp) {
//!     assert_eq!(row.overlap, Some(true));
//! }
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

mod alias;
mod avar_fit;
mod average;
mod band_correlation;
mod bandwidth;
mod combine;
mod compare;
mod correlation;
mod decimator;
mod effect;
mod error;
mod fit;
mod interval;
pub(crate) mod linalg;
mod nnls;
mod options;
mod psd_fit;
mod resolution;
mod result;
mod roll_off_check;
mod select;
mod terms;
mod units;

pub use avar_fit::{fit_avar, fit_avar_with, fit_points, FIT_TAU_RATIO};
pub use average::{average_with_rival, rival_share};
pub use bandwidth::{
    band_min_tau, detect_bandwidth, BandEdge, Bandwidth, FilterForm, LowPass, BAND_BIAS, DETECT_BIC,
};
pub(crate) use combine::variance_at;
pub use combine::{
    combine, heavy_tail_line, not_static_line, read_offs, resolution_line, spike_bursts,
    upper_limit, Combined, CombinedTerm, FitWarning, ReadOff,
};
pub use compare::{compare, TermComparison};
pub use decimator::Decimator;
pub use effect::EffectShape;
pub use error::FitError;
pub use options::FitOptions;
pub use psd_fit::{fit_psd, fit_psd_with};
pub use resolution::{
    angle_grid_steps_per_sigma, rounding_warning, ANGLE_ERROR_CORRELATED_FROM_STEPS,
    SUBTRACTION_HOLDS_TO_STEPS, UPPER_BOUND_HOLDS_TO_STEPS,
};
pub use result::{
    hull, Candidate, Criterion, Domain, EffectEstimate, FitPoint, LackOfFit, NoiseFit,
    TermEstimate, UpperLimit,
};
pub use roll_off_check::RollOffCheck;
pub use select::{bic_weight, AMBIGUITY_BIC, LACK_OF_FIT_P, SELECTION_WINDOW};
pub use terms::{Coefficients, GaussMarkov, Sinusoid, Term, FLICKER_PLATEAU};
pub use units::{CoefUnit, Sensor, UnitError};
