//! The IEEE noise model of inertial sensors and its fit to Allan variances and spectra.
mod linalg;
mod nnls;
mod terms;
mod units;

pub use terms::{Coefficients, GaussMarkov, Sinusoid, Term, FLICKER_PLATEAU};
pub use units::{CoefUnit, Sensor, UnitError};
