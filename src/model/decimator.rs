//! A CIC (sinc^k) decimation filter's noise response as seen at its output rate.
//!
//! Most MEMS parts with a sigma-delta converter (ADXL35x, many IMUs) run their data through k
//! cascaded moving averages of D input samples and keep every D-th output: the impulse response
//! is h = box_D^{*k} / D^k and the response sinc^k, with zeros at every multiple of the output
//! rate fs. White noise at the input rate then reaches the output as a moving-average process of
//! order k − 1: its autocovariance at output lag m is σ²·R_h(mD) (R_h the autocorrelation of h),
//! zero from m = k on. Its spectrum at the output rate, relative to the white level N² that the
//! same input has at low frequency, is the folded response
//!
//! G(f) = Σ_n |H(f + n·fs)|² = D·Σ_{|m|<k} R_h(mD)·cos(2πmf/fs),
//!
//! a cosine polynomial of degree k − 1 in f/fs with G(0) = 1 (the zeros of H at the multiples of
//! fs leave nothing of the images at f = 0). For a large D, D·R_h(mD) tends to the centred
//! cardinal B-spline of order 2k at m, so G no longer depends on D: sinc³ gives
//! G = 0.55 + 0.4333·cos(2πf/fs) + 0.0167·cos(4πf/fs), −8.75 dB at Nyquist (−8.06 dB at D = 4).
//! No Butterworth shape follows this: a sinc³ decimator read as one was put 30–40 % too high
//! in frequency and left N about 1 % low with an interval of ±0.25 %.
//!
//! The response is the folded one for every column of the fits: low-frequency terms (B, K, R)
//! are unaffected either way, and for a line or a resonance inside the band (a signal, not
//! folded noise) the images the fold adds are below 1 % of |H(f)|² up to 0.35·fs at k = 3.

use serde::Serialize;

/// Most stages a decimator may have (sinc⁵ is the longest in common converters).
pub const MAX_STAGES: u32 = 5;

/// A sinc^k decimator: `stages` = k cascaded moving averages of `factor` = D input samples, then
/// every D-th kept (`factor` `None`: the large-D limit).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Decimator {
    pub stages: u32,
    pub factor: Option<u32>,
    /// c_m of G(f) = Σ_m c_m·cos(2πmf/fs), m < k (c_0 = D·R_h(0), c_m = 2·D·R_h(mD)).
    #[serde(skip)]
    cosine: [f64; MAX_STAGES as usize],
}

impl Decimator {
    /// `stages` from 1 to [`MAX_STAGES`], `factor` ≥ 2 (or `None`); `None` otherwise.
    pub fn new(stages: u32, factor: Option<u32>) -> Option<Decimator> {
        if !(1..=MAX_STAGES).contains(&stages) || factor.is_some_and(|d| d < 2) {
            return None;
        }
        let k = stages as usize;
        let mut cosine = [0.0; MAX_STAGES as usize];
        match factor {
            None => {
                for (m, c) in cosine.iter_mut().enumerate().take(k) {
                    let b = centred_bspline(2 * stages, m as f64);
                    *c = if m == 0 { b } else { 2.0 * b };
                }
            }
            Some(d) => {
                let h = impulse_response(stages, d);
                let d = d as usize;
                for (m, c) in cosine.iter_mut().enumerate().take(k) {
                    let lag = m * d;
                    let r: f64 = h.iter().zip(h.iter().skip(lag)).map(|(a, b)| a * b).sum();
                    *c = d as f64 * r * if m == 0 { 1.0 } else { 2.0 };
                }
            }
        }
        Some(Decimator {
            stages,
            factor,
            cosine,
        })
    }

    /// G(f) at the output rate `rate_hz` (|f| at most Nyquist).
    pub fn power_gain(&self, f_hz: f64, rate_hz: f64) -> f64 {
        let x = f_hz.abs().min(rate_hz / 2.0) / rate_hz;
        let g: f64 = self
            .cosine
            .iter()
            .enumerate()
            .take(self.stages as usize)
            .map(|(m, c)| c * (2.0 * std::f64::consts::PI * m as f64 * x).cos())
            .sum();
        g.max(0.0)
    }
}

/// h = box_D^{*k}/D^k: k moving averages of D samples in cascade (sums to 1).
fn impulse_response(stages: u32, factor: u32) -> Vec<f64> {
    let d = factor as usize;
    let mut h = vec![1.0];
    for _ in 0..stages {
        let mut next = vec![0.0; h.len() + d - 1];
        for (i, v) in h.iter().enumerate() {
            for n in &mut next[i..i + d] {
                *n += v / d as f64;
            }
        }
        h = next;
    }
    h
}

/// The centred cardinal B-spline of order `order` (degree order − 1, support ±order/2) at x:
/// (1/(order−1)!)·Σ_j (−1)^j·C(order, j)·(x + order/2 − j)₊^(order−1).
fn centred_bspline(order: u32, x: f64) -> f64 {
    let n = order as i32;
    let mut sum = 0.0;
    let mut binom = 1.0;
    let mut fact = 1.0;
    for i in 1..n {
        fact *= f64::from(i);
    }
    for j in 0..=n {
        let t = x + f64::from(n) / 2.0 - f64::from(j);
        if t > 0.0 {
            let sign = if j % 2 == 0 { 1.0 } else { -1.0 };
            sum += sign * binom * t.powi(n - 1);
        }
        binom = binom * f64::from(n - j) / f64::from(j + 1);
    }
    sum / fact
}

#[cfg(test)]
mod tests {
    use super::*;

    /// |H(f)|² of h at the input rate, by its DFT sum (no closed form used).
    fn input_gain(h: &[f64], f_over_input_rate: f64) -> f64 {
        let w = 2.0 * std::f64::consts::PI * f_over_input_rate;
        let (re, im) = h.iter().enumerate().fold((0.0, 0.0), |(re, im), (i, v)| {
            (re + v * (w * i as f64).cos(), im - v * (w * i as f64).sin())
        });
        re * re + im * im
    }

    /// The folded response is the sum of |H|² over the images f + n·fs, n = 0..D−1 of the input
    /// band (an independent route: the transfer function, not the autocorrelation).
    #[test]
    fn folded_gain_is_the_sum_of_the_images() {
        for (k, d) in [(2, 4), (3, 4), (3, 8), (4, 3), (5, 16)] {
            let dec = Decimator::new(k, Some(d)).unwrap();
            let h = impulse_response(k, d);
            for x in [0.0, 0.05, 0.2, 0.31, 0.45, 0.5] {
                // Output frequency x·fs is x/D of the input rate; images at (x + n)/D.
                let folded: f64 = (0..d)
                    .map(|n| {
                        let xi = (x + n as f64) / d as f64;
                        input_gain(&h, xi.min(1.0 - xi))
                    })
                    .sum();
                let got = dec.power_gain(x * 100.0, 100.0);
                assert!(
                    (got - folded).abs() < 1e-12,
                    "k {k} D {d} x {x}: {got} vs {folded}"
                );
            }
        }
    }

    /// The large-D limit: sinc³'s known polynomial (33 + 26·cos 2πx + cos 4πx)/60, and sinc²'s
    /// (2 + cos 2πx)/3; a large finite D approaches it.
    #[test]
    fn the_limit_is_the_b_spline_polynomial() {
        let s3 = Decimator::new(3, None).unwrap();
        let s2 = Decimator::new(2, None).unwrap();
        let s3_512 = Decimator::new(3, Some(512)).unwrap();
        for x in [0.0, 0.1, 0.25, 0.4, 0.5] {
            let w = 2.0 * std::f64::consts::PI * x;
            let want3 = (33.0 + 26.0 * w.cos() + (2.0 * w).cos()) / 60.0;
            let want2 = (2.0 + w.cos()) / 3.0;
            assert!((s3.power_gain(x, 1.0) - want3).abs() < 1e-12);
            assert!((s2.power_gain(x, 1.0) - want2).abs() < 1e-12);
            assert!((s3_512.power_gain(x, 1.0) - want3).abs() < 1e-5);
        }
        // One stage: a plain average before decimation leaves white noise white.
        let s1 = Decimator::new(1, None).unwrap();
        assert!((s1.power_gain(0.37, 1.0) - 1.0).abs() < 1e-12);
        assert!(Decimator::new(6, None).is_none() && Decimator::new(2, Some(1)).is_none());
    }
}
