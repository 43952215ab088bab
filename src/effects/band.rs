//! The base fits inside the sensor's band: the one flow that `analyze` (before the loop) and the
//! loop (when it is handed no base fits) both run, so that the two cannot drift apart.
//!
//! 1. Look for the sensor's low-pass roll-off in the spectrum ([`detect_bandwidth`]).
//! 2. Fit the Allan variance and the spectrum with the options restricted to the band it keeps
//!    ([`Bandwidth::restrict`]).
//! 3. Ask whether the edge is the output's coarse angle grid rather than a filter
//!    ([`attribute_edge`]: that takes both fits' Q and N, so it comes after them); if the cause
//!    changed, the band changed with it and both fits are made again.
//!
//! It lives among the effects, not in `model`, because step 3 is one: the angle quantiser's
//! simulation is an effect's test, and `model` does not look up.

use crate::avar::Deviations;
use crate::model::{
    detect_bandwidth, fit_avar, fit_psd, Bandwidth, FitError, FitOptions, NoiseFit,
};
use crate::psd::{BinnedPsd, Psd};

use super::angle_grid::attribute_edge;

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
}

/// The base fits of one channel's estimates inside its band (see the module docs): `dev` its
/// overlapping Allan variance, `psd` and `binned` its spectrum, `grid` the smallest step between
/// its samples (which tells a coarse angle quantiser's edge from a filter's; `None` if unknown).
/// A missing estimate makes that fit an error that says which one it lacks; the other goes on.
pub fn fit_in_band(
    dev: Option<&Deviations>,
    psd: &Psd,
    binned: Option<&BinnedPsd>,
    opts: &FitOptions,
    grid: Option<f64>,
) -> BandFits {
    let mut bandwidth = match (binned, opts.detect_bandwidth) {
        (Some(binned), true) => {
            let taus = dev.map_or(&[][..], |d| &d.tau_s[..]);
            detect_bandwidth(psd, binned, taus, opts)
        }
        _ => None,
    };
    let mut unrestricted = opts.clone();
    unrestricted.detect_bandwidth = false;
    let inside = |band: Option<&Bandwidth>| {
        band.map_or_else(|| unrestricted.clone(), |b| b.restrict(&unrestricted))
    };
    let mut options = inside(bandwidth.as_ref());
    let (mut allan, mut spectrum) = fits(dev, psd, binned, &options);
    if let Some(b) = bandwidth.as_mut() {
        if attribute_edge(b, psd, grid, allan.as_ref().ok(), spectrum.as_ref().ok()) {
            options = inside(Some(b));
            (allan, spectrum) = fits(dev, psd, binned, &options);
        }
    }
    BandFits {
        bandwidth,
        options,
        allan,
        spectrum,
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
