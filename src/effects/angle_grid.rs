//! Whether a band edge is the output's coarse angle grid rather than a filter.
//!
//! A sensor that rounds its integrated angle to a step h (IEEE 952's quantisation) and moves less
//! than a step per sample keeps its rounding error near one value for several samples: the rate
//! error is no longer the differenced white error of IEEE 952's Q term and falls 12–15 % below it
//! over the top fifth of the band at 3.5 output σ per step (see
//! [`crate::model::ANGLE_ERROR_CORRELATED_FROM_STEPS`]), which the low-pass detector reads as a
//! roll-off. A real filter before that quantiser makes a roll-off too, and the two cannot be told
//! apart by the shape of the deficit alone. What tells them apart is its size: the quantiser alone
//! is simulated here (white noise of the fitted N, integrated, rounded to the recording's grid,
//! differenced) and its spectrum above the edge compared with the recording's. Without a filter
//! the two agree: the ratio of their medians was 0.95–1.04 (median 0.984) over 30 seeds of the
//! validation's angle quantiser (30-min records, 3.5 σ per step); a filter takes N's share away as
//! well: 0.65–0.72 (median 0.683) over 30 seeds of its fourth-order digital low-pass at 30 Hz under
//! the same grid, and the edge stays the filter's. The threshold, 0.85, sits between the two.

use crate::model::{
    angle_grid_steps_per_sigma, BandEdge, Bandwidth, NoiseFit, ANGLE_ERROR_CORRELATED_FROM_STEPS,
};
use crate::psd::{welch, Psd, Scaling, WelchConfig};
use crate::sim::quantize;
use crate::sim::rng::Rng;

/// Takes `band`'s edge for the angle quantiser's when the output lies on the grid of a rounded
/// integrated angle (`step`: the smallest step between samples, SI rate; one of the fits kept the
/// Q that grid makes, see [`angle_grid_steps_per_sigma`]) coarse enough for its error to be
/// correlated (at least [`ANGLE_ERROR_CORRELATED_FROM_STEPS`] output σ per step) and the
/// quantiser alone makes the recording's spectrum above the edge (within
/// [`GRID_EXPLAINS_FROM`]). Without it, every 30-min record of an unfiltered gyro whose angle was
/// rounded to 3.5 per-sample σ (the output on four or five levels) was reported with a low-pass
/// filter it does not have. Returns whether the cause changed.
pub fn attribute_edge(
    band: &mut Bandwidth,
    psd: &Psd,
    step: Option<f64>,
    allan: Option<&NoiseFit>,
    spectrum: Option<&NoiseFit>,
) -> bool {
    let Some(step) = step else { return false };
    let Some((steps_per_sigma, n)) = angle_grid_steps_per_sigma(step, psd.rate_hz, allan, spectrum)
    else {
        return false;
    };
    if steps_per_sigma < ANGLE_ERROR_CORRELATED_FROM_STEPS {
        return false;
    }
    let explained = data_over_grid_spectrum(psd, step, n, band.fit_max_freq_hz)
        .is_some_and(|r| r >= GRID_EXPLAINS_FROM);
    if explained {
        band.cause = BandEdge::AngleQuantiser {
            step,
            steps_per_sigma,
        };
    }
    explained
}

/// Ratio of the recording's spectrum above the edge to the simulated quantiser's from which the
/// grid alone accounts for the edge.
pub const GRID_EXPLAINS_FROM: f64 = 0.85;

/// Samples of the simulated quantiser (2¹⁹: 1023 segments of 1024, so its median density above
/// the edge is known to a fraction of a percent; 23–25 ms on average here, run only where the
/// grid is coarse and the fits' Q matches it).
const SIMULATED: usize = 1 << 19;

/// The median spectral density of `psd` over (`edge_hz`, 0.95·Nyquist) over that of an unfiltered
/// sensor of white noise `n` (SI rate/√Hz) whose integrated angle is rounded to `step` (SI rate:
/// the angle step times the rate), the same band. `None` where the band holds no bin of either.
pub fn data_over_grid_spectrum(psd: &Psd, step: f64, n: f64, edge_hz: f64) -> Option<f64> {
    let fs = psd.rate_hz;
    if !(step > 0.0 && n > 0.0 && fs > 0.0 && edge_hz < 0.95 * fs / 2.0) {
        return None;
    }
    // White rate noise of N, its angle rounded to the grid by the simulator's quantiser (Q is
    // the angle step over √12; the rate step is the angle step times fs).
    let sigma = n * fs.sqrt();
    let mut y = Rng::new(0x616e_676c_6567).gauss_vec(SIMULATED);
    y.iter_mut().for_each(|v| *v *= sigma);
    quantize(&mut y, fs, step / (fs * 12f64.sqrt()), 0.3);
    let sim = welch(&y, fs, &WelchConfig::new(1024)).ok()?;
    let median_over = |p: &Psd| {
        let mut v: Vec<f64> = p
            .freq_hz
            .iter()
            .zip(&p.value)
            .filter(|(f, _)| **f > edge_hz && **f < 0.95 * fs / 2.0)
            .map(|(_, v)| *v)
            .collect();
        if v.is_empty() {
            return None;
        }
        v.sort_by(f64::total_cmp);
        // Densities on both sides (a spectrum reading is a density times the bin's ENBW).
        let per_hz = match p.scaling {
            Scaling::Density => 1.0,
            Scaling::Spectrum => 1.0 / p.enbw_hz,
        };
        Some(v[v.len() / 2] * per_hz)
    };
    let (data, reference) = (median_over(psd)?, median_over(&sim)?);
    (reference > 0.0).then(|| data / reference)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The recording is the simulated quantiser itself (another seed, start and segment length):
    /// the ratio is 1 within a few percent; the same recording through a fourth-order low-pass at
    /// 20 Hz (two all-pole second-order sections with a Butterworth's poles) falls well below the
    /// threshold.
    #[test]
    fn the_grid_alone_matches_itself_and_a_filter_falls_below() {
        let (fs, n) = (100.0, 4.36e-5);
        let step = 3.5 * n * f64::sqrt(fs);
        let quantise = |rate: &[f64]| {
            let mut out = rate.to_vec();
            quantize(&mut out, fs, step / (fs * 12f64.sqrt()), 0.7);
            out
        };
        let mut rng = Rng::new(5);
        let white: Vec<f64> = (0..200_000).map(|_| rng.gauss() * n * fs.sqrt()).collect();
        let plain = welch(&quantise(&white), fs, &WelchConfig::new(4096)).unwrap();
        let r = data_over_grid_spectrum(&plain, step, n, 25.0).unwrap();
        assert!((r - 1.0).abs() < 0.05, "unfiltered: {r}");
        // Two passes of the poles of a second-order Butterworth at 20 Hz, gain 1 at DC.
        let mut filtered = white.clone();
        for _ in 0..2 {
            let (a1, a2) = (-0.3695, 0.1958);
            let g = 1.0 + a1 + a2;
            let (mut y1, mut y2) = (0.0, 0.0);
            for v in filtered.iter_mut() {
                let y0 = g * *v - a1 * y1 - a2 * y2;
                (y2, y1) = (y1, y0);
                *v = y0;
            }
        }
        let lowpassed = welch(&quantise(&filtered), fs, &WelchConfig::new(4096)).unwrap();
        let r = data_over_grid_spectrum(&lowpassed, step, n, 25.0).unwrap();
        assert!(r < GRID_EXPLAINS_FROM - 0.05, "filtered: {r}");
    }
}
