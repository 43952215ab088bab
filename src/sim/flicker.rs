//! Flicker (1/f) rate noise by spectral shaping: the bias-instability term.
//!
//! Independent complex Gaussian Fourier coefficients with E|X_k|² = L·fs·S(f_k), inverse real FFT
//! of length L, first n samples kept. S is B²/(2πf) as a sensor that outputs interval means sees
//! it (through sinc² and folded at Nyquist): 1/f over the whole band, exactly what makes the Allan
//! variance flat at (2 ln 2/π)·B² from τ₀ on (a plain 1/f up to Nyquist reads 19 % above the
//! plateau at τ₀, 9 % at 2τ₀). A Kasdin–Walter fractional-difference filter gives 1/(2 sin πfτ₀)
//! instead (57 % above 1/f at Nyquist), and one Gauss–Markov process pretending to be flicker is
//! 1/f nowhere.
//!
//! The synthetic series is periodic with period L, and has no power below f_min = fs/L. L ≥ 4n
//! (the next 2^a·3^b·5^c length, which FFTs fast) puts that cut at 1/(4T), and the record never
//! sees its own period. The missing band takes ≈ (πτf_min)²/(2 ln 2) of the flicker plateau of the
//! Allan variance: < 1 % up to τ = T/8, 3 % at T/4 and 11 % at T/2, the last octave point, whose
//! own scatter (EDF ≈ 2) is far larger. (Any finite simulation cuts a 1/f spectrum somewhere:
//! its total power diverges at f → 0.) DC gets no power.

use std::f64::consts::PI;

use realfft::num_complex::Complex;
use realfft::RealFftPlanner;

use crate::model::Term;

use super::rng::Rng;

/// `n` samples of zero-mean Gaussian noise with two-sided PSD `psd(f)` (unit²/Hz) for 0 < f ≤ fs/2.
pub fn shaped_noise(n: usize, rate_hz: f64, psd: impl Fn(f64) -> f64, rng: &mut Rng) -> Vec<f64> {
    if n == 0 {
        return Vec::new();
    }
    let l = smooth_length(4 * n.max(2));
    let c2r = RealFftPlanner::<f64>::new().plan_fft_inverse(l);
    let mut spectrum = c2r.make_input_vec();
    let half = spectrum.len() - 1; // index of f = fs/2 for even l, last bin below it for odd l
    let df = rate_hz / l as f64;
    for (k, x) in spectrum.iter_mut().enumerate().skip(1) {
        let power = (l as f64) * rate_hz * psd(k as f64 * df);
        if k == half && l.is_multiple_of(2) {
            // The Nyquist coefficient of a real series is real.
            *x = Complex::new(power.sqrt() * rng.gauss(), 0.0);
        } else {
            let a = (power / 2.0).sqrt();
            *x = Complex::new(a * rng.gauss(), a * rng.gauss());
        }
    }
    spectrum[0] = Complex::new(0.0, 0.0);
    let mut out = c2r.make_output_vec();
    // Lengths come from the plan, and the DC and Nyquist imaginary parts are zero.
    c2r.process(&mut spectrum, &mut out)
        .expect("buffers sized by the FFT plan");
    out.truncate(n);
    let scale = 1.0 / l as f64;
    for v in &mut out {
        *v *= scale;
    }
    out
}

/// Samples of the interval means of continuous flicker rate noise with two-sided PSD b²/(2πf):
/// the spectrum shaped is the sampled-average one ([`Term::psd_sampled_unit`]), so that the
/// Allan variance is the flicker plateau at every τ = mτ₀, m = 1 included.
pub fn flicker(n: usize, rate_hz: f64, b: f64, rng: &mut Rng) -> Vec<f64> {
    shaped_noise(n, rate_hz, flicker_shape(rate_hz, b), rng)
}

/// [`flicker`] whose density stops rising below `corner_hz`: flat there at its value at the
/// corner. A bias that wanders over a finite correlation time (≈ 1/(2π·corner)), as a sum of a
/// few Gauss–Markov processes does: 1/f only above the corner, so that the Allan deviation leaves
/// its plateau for a fall (as τ^(−½)) beyond τ ≈ 1/(2·corner) instead of staying flat.
pub fn band_limited_flicker(
    n: usize,
    rate_hz: f64,
    b: f64,
    corner_hz: f64,
    rng: &mut Rng,
) -> Vec<f64> {
    let shape = flicker_shape(rate_hz, b);
    let floor = shape(corner_hz);
    shaped_noise(
        n,
        rate_hz,
        move |f| if f < corner_hz { floor } else { shape(f) },
        rng,
    )
}

/// b² times the sampled flicker form, f ↦ S(f).
///
/// The sampled form costs two Hurwitz sums per bin, too slow for the tens of millions of bins of
/// a long record; its ratio to b²/(2πf) is smooth in f/fs, so it is tabulated on 4097 points of
/// [0, ½] and interpolated linearly (error below 1e-8 relative).
fn flicker_shape(rate_hz: f64, b: f64) -> impl Fn(f64) -> f64 {
    const POINTS: usize = 4096;
    let step = 1.0 / (2 * POINTS) as f64;
    // ratio[i] at x = f/fs = i·step; at x → 0 the ratio tends to 1.
    let ratio: Vec<f64> = (0..=POINTS)
        .map(|i| {
            if i == 0 {
                return 1.0;
            }
            let f = i as f64 * step * rate_hz;
            Term::BiasInstability.psd_sampled_unit(f, rate_hz) * (2.0 * PI * f)
        })
        .collect();
    let b2 = b * b;
    move |f: f64| {
        let pos = (f / rate_hz / step).clamp(0.0, POINTS as f64);
        let i = (pos as usize).min(POINTS - 1);
        let t = pos - i as f64;
        b2 / (2.0 * PI * f) * (ratio[i] * (1.0 - t) + ratio[i + 1] * t)
    }
}

/// Smallest 2^a·3^b·5^c ≥ `n`.
fn smooth_length(n: usize) -> usize {
    let mut best = usize::MAX;
    let mut p5 = 1usize;
    while p5 < best {
        let mut p35 = p5;
        while p35 < best {
            let mut p = p35;
            while p < n {
                p *= 2;
            }
            best = best.min(p);
            p35 *= 3;
        }
        p5 *= 5;
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn smooth_lengths() {
        assert_eq!(smooth_length(1), 1);
        assert_eq!(smooth_length(7), 8);
        assert_eq!(smooth_length(11), 12);
        assert_eq!(smooth_length(4 * 10_085_040), 40_500_000);
        for n in 1..500 {
            let l = smooth_length(n);
            let mut m = l;
            for p in [2, 3, 5] {
                while m.is_multiple_of(p) {
                    m /= p;
                }
            }
            assert!(l >= n && m == 1, "{n} -> {l}");
        }
    }

    #[test]
    fn tabulated_flicker_shape_matches_the_sampled_form() {
        // Off the table's grid, from near DC to near Nyquist.
        let fs = 207.0;
        let shape = flicker_shape(fs, 1.0);
        for i in 0..115 {
            let f = (f64::from(i) + 0.37) * 0.9;
            let want = Term::BiasInstability.psd_sampled_unit(f, fs);
            let got = shape(f);
            assert!((got / want - 1.0).abs() < 1e-7, "f = {f}: {got} vs {want}");
        }
    }

    #[test]
    fn white_shape_has_the_requested_variance() {
        // S = 1 unit²/Hz over ±fs/2 is variance fs (less the missing DC bin, 1/L of it).
        // 100 000 samples: relative σ of the variance ≈ 0.45 %; bound 2 %.
        let fs = 50.0;
        let x = shaped_noise(100_000, fs, |_| 1.0, &mut Rng::new(3));
        let var = x.iter().map(|v| v * v).sum::<f64>() / x.len() as f64;
        assert!((var / fs - 1.0).abs() < 0.02, "{}", var / fs);
    }
}
