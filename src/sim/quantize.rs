//! Quantisation as IEEE 952 models it: the sensor integrates the rate into an angle (or velocity),
//! outputs that angle in whole steps q, and the rate is recovered by differencing the steps.
//!
//! Rate out_i = q·(number of steps crossed in sample i)/τ₀ = y_i + (e_{i−1} − e_i)/τ₀, with e the
//! angle's rounding error. When the angle moves by more than about q/2 per sample between samples
//! (here: when the other noise terms make it do so), e is white and uniform on ±q/2, of variance
//! q²/12, and the Allan variance gains 3Q²/τ² with Q = q/√12. With too little motion the error
//! is correlated and that model fails, as it does on a real sensor.
//!
//! Only the rounding remainder is carried from sample to sample, never the total angle, so no
//! precision is lost on long recordings however large the bias.

/// Quantises rate samples `y` (rad/s or m/s²) at `rate_hz` with quantisation coefficient `q`
/// (rad or m/s; step √12·q). `start` in [0, 1) places the first angle within a step.
pub fn quantize(y: &mut [f64], rate_hz: f64, q: f64, start: f64) {
    if q <= 0.0 {
        return;
    }
    let step = q * 12f64.sqrt();
    let tau0 = 1.0 / rate_hz;
    let out_step = step * rate_hz;
    // Remainder of the angle after rounding, in units of the step, in [−½, ½).
    let mut e = start - 0.5;
    for v in y {
        let a = e + *v * tau0 / step;
        let steps = a.round();
        e = a - steps;
        *v = steps * out_step;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::avar::reference::oadev;
    use crate::sim::rng::Rng;

    #[test]
    fn output_is_whole_steps_and_angle_is_kept() {
        let fs = 10.0;
        let q = 0.01;
        let step = q * 12f64.sqrt();
        let mut rng = Rng::new(9);
        let y0: Vec<f64> = (0..1000).map(|_| 0.3 + 0.2 * rng.gauss()).collect();
        let mut y = y0.clone();
        quantize(&mut y, fs, q, 0.5);
        for v in &y {
            let k = v / (step * fs);
            assert!((k - k.round()).abs() < 1e-9);
        }
        // Integrated angles differ by less than one step at every sample.
        let (mut a, mut b) = (0.0, 0.0);
        for (u, v) in y0.iter().zip(&y) {
            a += u / fs;
            b += v / fs;
            assert!((a - b).abs() <= step / 2.0 + 1e-12);
        }
    }

    #[test]
    fn dithered_quantisation_adds_three_q_squared_over_tau_squared() {
        // White rate moving the angle by 2 steps per sample (σ): quantisation error is white.
        // 100 000 samples, m = 1 and 4: the AV of quantisation (α = 2) has EDF ≈ N, so the
        // sampling error is ≈ 1 %; bound 4 %.
        let fs = 100.0;
        let q = 1e-3;
        let step = q * 12f64.sqrt();
        let sigma = 2.0 * step * fs;
        let mut rng = Rng::new(5);
        let y0: Vec<f64> = (0..100_000).map(|_| sigma * rng.gauss()).collect();
        let mut y = y0.clone();
        quantize(&mut y, fs, q, 0.25);
        for m in [1usize, 4] {
            let tau = m as f64 / fs;
            let added = oadev(&y, m) - oadev(&y0, m);
            let want = 3.0 * q * q / (tau * tau);
            assert!((added / want - 1.0).abs() < 0.04, "m={m}: {}", added / want);
        }
    }
}
