//! The sensor's internal low-pass filter (anti-alias or digital low-pass): what makes a real
//! recording's spectrum fall away below Nyquist and its shortest-τ Allan points fall below N²/τ.
//!
//! A digital Butterworth filter of the given order and −3 dB corner, designed by the bilinear
//! transform with the corner pre-warped, run as a cascade of second-order sections (plus one
//! first-order section for odd orders) at the output rate. Its response near Nyquist is the
//! bilinear one (|H| → 0 at fs/2), not the analog Butterworth form the bandwidth detector fits
//! ([`crate::model::LowPass`]): the detector is tested on a shape it does not assume.
//!
//! The filter state starts at the steady state of the first sample, so the record has no start
//! transient (a real sensor has been running before the recording starts).

use super::spec::LowPassSpec;

/// One section, direct form II transposed: y = b0·x + z1; z1 = b1·x − a1·y + z2; z2 = b2·x − a2·y.
#[derive(Debug, Clone, Copy)]
struct Section {
    b: [f64; 3],
    a: [f64; 2],
}

impl Section {
    fn run(&self, y: &mut [f64]) {
        let Some(&first) = y.first() else {
            return;
        };
        // DC gain is 1: at rest on `first`, input and output are both `first`.
        let mut z2 = (self.b[2] - self.a[1]) * first;
        let mut z1 = (self.b[1] - self.a[0]) * first + z2;
        for v in y.iter_mut() {
            let x = *v;
            let out = self.b[0] * x + z1;
            z1 = self.b[1] * x - self.a[0] * out + z2;
            z2 = self.b[2] * x - self.a[1] * out;
            *v = out;
        }
    }
}

/// The sections of `spec` at `rate_hz` (the corner must lie below Nyquist: checked by
/// [`crate::sim::SimSpec::validate`]).
fn sections(spec: &LowPassSpec, rate_hz: f64) -> Vec<Section> {
    let n = spec.order.max(1);
    let k = (std::f64::consts::PI * spec.corner_hz / rate_hz).tan();
    let mut out: Vec<Section> = (0..n / 2)
        .map(|i| {
            // Pole pair i of the analog prototype: Q = 1/(2·sin θ), θ = π(2i + 1)/(2n).
            let theta = std::f64::consts::PI * f64::from(2 * i + 1) / f64::from(2 * n);
            let q = 1.0 / (2.0 * theta.sin());
            let norm = 1.0 / (1.0 + k / q + k * k);
            let b0 = k * k * norm;
            Section {
                b: [b0, 2.0 * b0, b0],
                a: [2.0 * (k * k - 1.0) * norm, (1.0 - k / q + k * k) * norm],
            }
        })
        .collect();
    if n % 2 == 1 {
        let norm = 1.0 / (1.0 + k);
        out.push(Section {
            b: [k * norm, k * norm, 0.0],
            a: [(k - 1.0) * norm, 0.0],
        });
    }
    out
}

/// Filters `y` (samples at `rate_hz`) in place.
pub(crate) fn apply_lowpass(y: &mut [f64], rate_hz: f64, spec: &LowPassSpec) {
    for s in sections(spec, rate_hz) {
        s.run(y);
    }
}

/// |H(f)|² of the filter, evaluated from its sections (for tests and the validation study).
pub fn lowpass_power_gain(spec: &LowPassSpec, rate_hz: f64, f_hz: f64) -> f64 {
    let w = 2.0 * std::f64::consts::PI * f_hz / rate_hz;
    let (c1, s1, c2, s2) = (w.cos(), w.sin(), (2.0 * w).cos(), (2.0 * w).sin());
    sections(spec, rate_hz)
        .iter()
        .map(|s| {
            // H(e^{jw}) = (b0 + b1 z⁻¹ + b2 z⁻²)/(1 + a1 z⁻¹ + a2 z⁻²).
            let num = (
                s.b[0] + s.b[1] * c1 + s.b[2] * c2,
                -(s.b[1] * s1 + s.b[2] * s2),
            );
            let den = (
                1.0 + s.a[0] * c1 + s.a[1] * c2,
                -(s.a[0] * s1 + s.a[1] * s2),
            );
            (num.0 * num.0 + num.1 * num.1) / (den.0 * den.0 + den.1 * den.1)
        })
        .product()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn corner_is_half_power_and_dc_is_unity() {
        for order in [1, 2, 3, 4, 6] {
            let spec = LowPassSpec {
                corner_hz: 20.0,
                order,
            };
            let dc = lowpass_power_gain(&spec, 100.0, 0.0);
            let corner = lowpass_power_gain(&spec, 100.0, 20.0);
            assert!((dc - 1.0).abs() < 1e-12, "order {order}: dc {dc}");
            assert!(
                (corner - 0.5).abs() < 1e-9,
                "order {order}: corner {corner}"
            );
            // Monotone fall above the corner.
            assert!(lowpass_power_gain(&spec, 100.0, 30.0) < corner);
        }
    }

    #[test]
    fn filtered_white_noise_has_the_filters_power() {
        // Var of filtered unit white noise = mean of |H|² over (−fs/2, fs/2).
        let spec = LowPassSpec {
            corner_hz: 10.0,
            order: 4,
        };
        let mut rng = crate::sim::rng::Rng::new(7);
        let mut y = rng.gauss_vec(400_000);
        apply_lowpass(&mut y, 100.0, &spec);
        let var = y.iter().map(|v| v * v).sum::<f64>() / y.len() as f64;
        let m = 20_000;
        let expected = (0..m)
            .map(|i| lowpass_power_gain(&spec, 100.0, 50.0 * (i as f64 + 0.5) / m as f64))
            .sum::<f64>()
            / m as f64;
        assert!((var / expected - 1.0).abs() < 0.01, "{var} vs {expected}");
    }

    #[test]
    fn constant_passes_unchanged() {
        let spec = LowPassSpec {
            corner_hz: 5.0,
            order: 3,
        };
        let mut y = vec![2.5; 100];
        apply_lowpass(&mut y, 100.0, &spec);
        assert!(y.iter().all(|v| (v - 2.5).abs() < 1e-12));
    }
}
