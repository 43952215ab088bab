//! Least-squares sinusoid near a spectral line: frequency, amplitude and phase with intervals.
//!
//! The caller finds a line in a Welch spectrum, whose resolution (fs/segment) is far coarser
//! than the record's 1/T; the line's frequency is refined here on the whole record:
//!
//! 1. The series is detrended (a random walk's leakage through the record's rectangular window
//!    falls off less fast otherwise).
//! 2. Coarse search over f₀ ± max(16/T, fs/2048): heterodyne to the band centre, block sums that
//!    decimate to ≥ 8× the band, a zero-padded FFT (grid ≤ 1/(4T)), the block-average response
//!    divided out. O(n) plus an FFT of ≈ 8·(band)·T points: no O(n²) anywhere.
//! 3. Golden-section maximisation of the three-parameter least-squares power
//!    (constant + a·cos + b·sin) within ±1/(2T) of the coarse peak, each evaluation one O(n) pass
//!    with a rotation recurrence (resynchronised every 1024 samples).
//!
//! **Intervals** come from the noise level at the line, `noise_psd_one_sided` S₁ (unit²/Hz): the
//! noise near f₀ is locally white with per-sample variance σ² = S₁·fs/2, so each of a and b has
//! variance σ²·[(XᵀX)⁻¹] ≈ 2σ²/n = S₁/T (T the record length), and
//! SE(Â) = √(S₁/T) (checked by simulation in the tests); the frequency's Cramér–Rao bound is
//! Var(ω̂) = 24σ²/(Â²n(n²−1)) rad²/sample². Amplitude and phase are those of A·sin(2πft + φ)
//! point-sampled at t = (i + ½)/fs: the amplitude is the line's in the samples, what a least-
//! squares fit or a spectrum of the record shows (the crate's convention for lines, the
//! simulator's too). A sensor whose samples are interval means (delta angles or velocities)
//! saw a line of amplitude A/sinc(πf/fs) at its input; a filtered sensor's input amplitude is
//! A over its filter's gain at f. Neither correction is made: the line is reported as recorded.
//! (Divided by the sinc, a 2-mg vibration at 60 Hz on a 400-Hz MEMS accelerometer read
//! 2.12 mg, 6 % high; near Nyquist the factor reaches 1.57.)
//!
//! **Evidence.** x = (regression sum of squares of a, b)/σ² is χ²₂ on noise alone at a given
//! frequency; the maximum over the searched band of width W is corrected by Rice's formula for
//! the upcrossings of the periodogram (Davies): p ≈ e^{−x/2}·(1 + W·T·√(πx/6)).
//! `delta_bic = 2·ln n − χ²₂(p)`: amplitude and phase are two parameters on n samples that are
//! locally white at f₀ (the whitening is S₁), the frequency being paid for by the search
//! correction. A spectrum search over the whole band by the caller is then also covered: the
//! 2·ln n penalty alone makes the chance of a false line anywhere below ≈ 1/n per bin.

use std::f64::consts::{PI, TAU};

use realfft::num_complex::Complex;
use realfft::RealFftPlanner;

use super::stats::norm_isf;

/// Half-width of the frequency search in units of 1/T …
pub const SEARCH_BINS: f64 = 16.0;
/// … or in units of fs, whichever is wider (one bin of a 1024-point Welch segment).
pub const SEARCH_FRACTION: f64 = 1.0 / 2048.0;

/// A fitted sinusoid A·sin(2πf·t + φ) with two-sided intervals.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct SineFit {
    pub freq_hz: f64,
    pub freq_lo: f64,
    pub freq_hi: f64,
    /// Amplitude of the continuous rate (units of y), corrected for the sample-interval mean.
    pub amplitude: f64,
    pub amplitude_lo: f64,
    pub amplitude_hi: f64,
    /// φ at t = 0, sample i being at (i + ½)/fs.
    pub phase_rad: f64,
    /// Amplitude over its standard error.
    pub z: f64,
    /// Band-search-corrected p-value.
    pub p_value: f64,
    pub delta_bic: f64,
}

struct Ls {
    a: f64,
    b: f64,
    /// Regression sum of squares of (a, b) beyond the mean.
    power: f64,
    /// Diagonal of (XᵀX)⁻¹ for a and b.
    inv_aa: f64,
    inv_bb: f64,
}

/// Σcos θᵢ, Σsin θᵢ, Σcos²θᵢ, Σsin²θᵢ, Σcos θᵢ·sin θᵢ over θᵢ = ω(i + ½), i < n, in closed form
/// (geometric sums of e^(iθ)): Σe^(iθᵢ) = e^(inω/2)·sin(nω/2)/sin(ω/2), and the squares through
/// 2θ. `None` where sin ω is too small for the quotients (ω near 0 or π).
fn trig_sums(n: usize, w: f64) -> Option<[f64; 5]> {
    let nf = n as f64;
    let (s1, s2) = ((0.5 * w).sin(), w.sin());
    if s1.abs() < 1e-9 || s2.abs() < 1e-9 {
        return None;
    }
    let d1 = (0.5 * nf * w).sin() / s1;
    let d2 = (nf * w).sin() / s2;
    let (sh, ch) = (0.5 * nf * w).sin_cos();
    let (sn, cn) = (nf * w).sin_cos();
    Some([
        ch * d1,
        sh * d1,
        0.5 * nf + 0.5 * cn * d2,
        0.5 * nf - 0.5 * cn * d2,
        0.5 * sn * d2,
    ])
}

/// Interleaved rotations the data sums run on: each lane steps by `LANES`·ω, so the lanes'
/// recurrences do not wait on each other (one chain of dependent multiplications made the sums
/// latency-bound: 44 % of a vibration record's analysis was here).
const LANES: usize = 8;
/// Samples between exact restarts of the rotations (their rounding grows with the steps).
const RESYNC: usize = 1024;

/// Σu·cos θᵢ and Σu·sin θᵢ over θᵢ = ω(i + ½).
fn data_sums(u: &[f64], w: f64) -> (f64, f64) {
    let (rs, rc) = (LANES as f64 * w).sin_cos();
    let (mut suc, mut sus) = ([0.0; LANES], [0.0; LANES]);
    for (block, values) in u.chunks(RESYNC).enumerate() {
        let start = block * RESYNC;
        let (mut s, mut c) = ([0.0; LANES], [0.0; LANES]);
        for j in 0..LANES {
            (s[j], c[j]) = (w * ((start + j) as f64 + 0.5)).sin_cos();
        }
        let mut quads = values.chunks_exact(LANES);
        for q in &mut quads {
            for j in 0..LANES {
                suc[j] += q[j] * c[j];
                sus[j] += q[j] * s[j];
                (s[j], c[j]) = (s[j] * rc + c[j] * rs, c[j] * rc - s[j] * rs);
            }
        }
        for (j, &v) in quads.remainder().iter().enumerate() {
            suc[j] += v * c[j];
            sus[j] += v * s[j];
        }
    }
    (suc.iter().sum(), sus.iter().sum())
}

/// Three-parameter least squares at ω rad/sample (t_i = i + ½).
fn ls(u: &[f64], w: f64) -> Option<Ls> {
    let [sc, ss, scc, sss, scs] = match trig_sums(u.len(), w) {
        Some(sums) => sums,
        None => {
            let (mut acc, (rs, rc)) = ([0.0; 5], w.sin_cos());
            let (mut s, mut c) = (0.0, 1.0);
            for i in 0..u.len() {
                if i % RESYNC == 0 {
                    (s, c) = (w * (i as f64 + 0.5)).sin_cos();
                }
                for (a, x) in acc.iter_mut().zip([c, s, c * c, s * s, c * s]) {
                    *a += x;
                }
                (s, c) = (s * rc + c * rs, c * rc - s * rs);
            }
            acc
        }
    };
    let su: f64 = u.iter().sum();
    let (suc, sus) = data_sums(u, w);
    let n = u.len() as f64;
    // Symmetric 3×3 [n sc ss; sc scc scs; ss scs sss], inverse by cofactors.
    let m = [[n, sc, ss], [sc, scc, scs], [ss, scs, sss]];
    let cof =
        |r0: usize, r1: usize, c0: usize, c1: usize| m[r0][c0] * m[r1][c1] - m[r0][c1] * m[r1][c0];
    let det = n * cof(1, 2, 1, 2) - sc * cof(1, 2, 0, 2) + ss * cof(1, 2, 0, 1);
    if !(det.abs() > 1e-12 * n * n * n) {
        return None;
    }
    let inv = [
        [cof(1, 2, 1, 2), -cof(0, 2, 1, 2), cof(0, 1, 1, 2)],
        [-cof(1, 2, 0, 2), cof(0, 2, 0, 2), -cof(0, 1, 0, 2)],
        [cof(1, 2, 0, 1), -cof(0, 2, 0, 1), cof(0, 1, 0, 1)],
    ];
    let rhs = [su, suc, sus];
    let beta: Vec<f64> = (0..3)
        .map(|r| (0..3).map(|k| inv[r][k] * rhs[k]).sum::<f64>() / det)
        .collect();
    let power = beta.iter().zip(rhs).map(|(b, r)| b * r).sum::<f64>() - su * su / n;
    Some(Ls {
        a: beta[1],
        b: beta[2],
        power: power.max(0.0),
        inv_aa: inv[1][1] / det,
        inv_bb: inv[2][2] / det,
    })
}

/// Fits a sinusoid near `f0_guess_hz`. `None` for fewer than 16 samples, a guess outside
/// (0, fs/2), a non-positive noise level, or a singular fit.
pub fn fit_sinusoid(
    y: &[f64],
    rate_hz: f64,
    f0_guess_hz: f64,
    noise_psd_one_sided: f64,
    p: f64,
) -> Option<SineFit> {
    let n = y.len();
    let fs = rate_hz;
    if n < 16
        || !(fs > 0.0)
        || !(f0_guess_hz > 0.0 && f0_guess_hz < fs / 2.0)
        || !(noise_psd_one_sided > 0.0 && noise_psd_one_sided.is_finite())
    {
        return None;
    }
    let t_rec = n as f64 / fs;
    // Detrend.
    let mid = (n as f64 - 1.0) / 2.0;
    let mean = y.iter().sum::<f64>() / n as f64;
    let sxx: f64 = (0..n).map(|i| (i as f64 - mid).powi(2)).sum();
    let slope = y
        .iter()
        .enumerate()
        .map(|(i, v)| (i as f64 - mid) * (v - mean))
        .sum::<f64>()
        / sxx;
    let u: Vec<f64> = y
        .iter()
        .enumerate()
        .map(|(i, v)| v - mean - slope * (i as f64 - mid))
        .collect();
    // Band.
    let half = (SEARCH_BINS / t_rec).max(fs * SEARCH_FRACTION);
    let lo_f = (f0_guess_hz - half).max(1.0 / t_rec);
    let hi_f = (f0_guess_hz + half).min(fs / 2.0 - 1.0 / t_rec);
    if lo_f >= hi_f {
        return None;
    }
    let coarse = coarse_peak(&u, fs, lo_f, hi_f);
    // Golden section on ±1/(2T) around the coarse peak.
    let to_w = |f: f64| TAU * f / fs;
    let power = |f: f64| ls(&u, to_w(f)).map_or(0.0, |l| l.power);
    let (mut a, mut b) = (
        (coarse - 0.5 / t_rec).max(lo_f),
        (coarse + 0.5 / t_rec).min(hi_f),
    );
    let g = (5f64.sqrt() - 1.0) / 2.0;
    let (mut c, mut d) = (b - g * (b - a), a + g * (b - a));
    let (mut pc, mut pd) = (power(c), power(d));
    for _ in 0..50 {
        if pc > pd {
            b = d;
            (d, pd) = (c, pc);
            c = b - g * (b - a);
            pc = power(c);
        } else {
            a = c;
            (c, pc) = (d, pd);
            d = a + g * (b - a);
            pd = power(d);
        }
    }
    let f = if pc > pd { c } else { d };
    let fit = ls(&u, to_w(f))?;
    let sigma2 = noise_psd_one_sided * fs / 2.0;
    let amp_s = fit.a.hypot(fit.b);
    let (va, vb) = (sigma2 * fit.inv_aa, sigma2 * fit.inv_bb);
    let se_a = if amp_s > 0.0 {
        ((fit.a * fit.a * va + fit.b * fit.b * vb) / (amp_s * amp_s)).sqrt()
    } else {
        ((va + vb) / 2.0).sqrt()
    };
    let nf = n as f64;
    let se_f = if amp_s > 0.0 {
        (24.0 * sigma2 / (amp_s * amp_s * nf * (nf * nf - 1.0))).sqrt() * fs / TAU
    } else {
        f64::INFINITY
    };
    let zq = norm_isf((1.0 - p.clamp(1e-9, 1.0 - 1e-12)) / 2.0);
    let x = fit.power / sigma2;
    let search = 1.0 + (hi_f - lo_f) * t_rec * (PI * x / 6.0).sqrt();
    let ln_p = (-x / 2.0 + search.ln()).min(0.0);
    Some(SineFit {
        freq_hz: f,
        freq_lo: f - zq * se_f,
        freq_hi: f + zq * se_f,
        amplitude: amp_s,
        amplitude_lo: (amp_s - zq * se_a).max(0.0),
        amplitude_hi: amp_s + zq * se_a,
        phase_rad: fit.a.atan2(fit.b),
        z: amp_s / se_a,
        p_value: ln_p.exp(),
        delta_bic: 2.0 * nf.ln() + 2.0 * ln_p,
    })
}

/// Frequency of the largest periodogram value of `u` in [lo, hi] Hz: heterodyne, block sums,
/// zero-padded FFT.
fn coarse_peak(u: &[f64], fs: f64, lo: f64, hi: f64) -> f64 {
    let (fc, hw) = ((lo + hi) / 2.0, (hi - lo) / 2.0);
    let block = ((fs / (8.0 * hw)).floor() as usize).clamp(1, u.len());
    let nb = u.len() / block;
    let wc = TAU * fc / fs;
    let (rs, rc) = wc.sin_cos();
    let mut z = vec![Complex::new(0.0, 0.0); nb];
    let (mut s, mut c) = (0.0, 1.0);
    for (i, &v) in u[..nb * block].iter().enumerate() {
        if i % 1024 == 0 {
            (s, c) = (wc * i as f64).sin_cos();
        }
        z[i / block] += Complex::new(v * c, -v * s);
        (s, c) = (s * rc + c * rs, c * rc - s * rs);
    }
    let len = (4 * nb).next_power_of_two();
    let mut planner = RealFftPlanner::<f64>::new();
    let fft = planner.plan_fft_forward(len);
    // Complex DFT from the real FFTs of the real and imaginary parts.
    let spectrum = |part: &dyn Fn(&Complex<f64>) -> f64| {
        let mut inp = fft.make_input_vec();
        for (d, v) in inp.iter_mut().zip(&z) {
            *d = part(v);
        }
        let mut out = fft.make_output_vec();
        fft.process(&mut inp, &mut out).ok();
        out
    };
    let (re, im) = (spectrum(&|v| v.re), spectrum(&|v| v.im));
    let full = |x: &[Complex<f64>], k: usize| {
        if k <= len / 2 {
            x[k]
        } else {
            x[len - k].conj()
        }
    };
    let fs_dec = fs / block as f64;
    let mut best = (f64::NEG_INFINITY, fc);
    for k in 0..len {
        let kk = if k <= len / 2 {
            k as f64
        } else {
            k as f64 - len as f64
        };
        let delta = kk * fs_dec / len as f64;
        if delta.abs() > hw {
            continue;
        }
        let v = full(&re, k) + Complex::new(0.0, 1.0) * full(&im, k);
        let arg = PI * delta / fs_dec;
        let resp = if arg == 0.0 { 1.0 } else { arg.sin() / arg };
        let pw = v.norm_sqr() / (resp * resp);
        if pw > best.0 {
            best = (pw, fc + delta);
        }
    }
    best.1
}

/// Subtracts the fitted sinusoid (point-sampled, as fitted) from `y`.
pub fn remove_sinusoid(y: &mut [f64], rate_hz: f64, s: &SineFit) {
    let w = TAU * s.freq_hz / rate_hz;
    for (i, v) in y.iter_mut().enumerate() {
        *v -= s.amplitude * (w * (i as f64 + 0.5) + s.phase_rad).sin();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The closed-form trigonometric sums and the interleaved data sums against sums taken
    /// sample by sample with each angle's own sin and cos: lengths not a multiple of the lanes or
    /// the restart block, ω from near 0 to near π.
    #[test]
    fn the_sums_match_direct_ones() {
        let u = crate::sim::rng::Rng::new(3).gauss_vec(5_003);
        for w in [1e-4, 0.01, 0.7, 2.0, 3.1, std::f64::consts::PI - 1e-4] {
            for n in [1, 7, 1024, 1027, 5_003] {
                let u = &u[..n];
                let mut direct = [0.0; 7];
                for (i, &v) in u.iter().enumerate() {
                    let (s, c) = (w * (i as f64 + 0.5)).sin_cos();
                    for (d, x) in direct
                        .iter_mut()
                        .zip([c, s, c * c, s * s, c * s, v * c, v * s])
                    {
                        *d += x;
                    }
                }
                let scale = n as f64;
                if let Some(t) = trig_sums(n, w) {
                    for k in 0..5 {
                        assert!(
                            (t[k] - direct[k]).abs() < 1e-9 * scale,
                            "ω {w} n {n} sum {k}: {} vs {}",
                            t[k],
                            direct[k]
                        );
                    }
                }
                let (suc, sus) = data_sums(u, w);
                assert!(
                    (suc - direct[5]).abs() < 1e-9 * scale,
                    "ω {w} n {n}: {suc} vs {}",
                    direct[5]
                );
                assert!(
                    (sus - direct[6]).abs() < 1e-9 * scale,
                    "ω {w} n {n}: {sus} vs {}",
                    direct[6]
                );
            }
        }
    }
    use crate::effects::time::stats::mean_var;
    use crate::effects::time::testutil::*;
    use crate::model::Coefficients;
    use crate::sim::SinusoidSpec;

    const F0: f64 = 7.3;

    /// One-sided model PSD of the noise at f.
    fn s1(c: &Coefficients, f: f64) -> f64 {
        2.0 * c.psd(f, 1.0 / FS)
    }

    /// Profile `seed % 3` with a line of `amp_se` standard errors √(S₁/T) (0: none).
    fn with_line(seed: u64, amp_se: f64, n: usize) -> (Vec<f64>, Coefficients, f64) {
        let c = profile(seed);
        let amp = amp_se * (s1(&c, F0) * FS / n as f64).sqrt();
        let mut ch = channel(c);
        if amp > 0.0 {
            ch.sinusoids = vec![SinusoidSpec {
                amplitude: amp,
                freq_hz: F0,
                phase_rad: 0.7,
                wander: None,
            }];
        }
        (run(ch, n, seed, None).remove(0), c, amp)
    }

    #[test]
    fn no_line_in_ieee_noise() {
        let runs = 150;
        let mut hits = 0;
        let mut xs = Vec::new();
        for seed in 0..runs {
            let (y, c, _) = with_line(seed, 0.0, 200_000);
            let s = fit_sinusoid(&y, FS, F0 + 0.01, s1(&c, F0), 0.68).unwrap();
            hits += usize::from(s.delta_bic < 0.0);
            xs.push(s.z);
        }
        let rate = hits as f64 / runs as f64;
        let (mz, _) = mean_var(&xs);
        println!("sinusoid: false discoveries {rate:.3} (mean amplitude z of the best noise peak {mz:.2})");
        assert!(rate <= 0.03, "{rate}");
    }

    #[test]
    fn line_is_recovered_and_removed() {
        for seed in 0..6 {
            // 60 standard errors: ±5 % is ±3 SE.
            let (mut y, c, amp) = with_line(seed, 60.0, 200_000);
            let s = fit_sinusoid(&y, FS, F0 + 0.02, s1(&c, F0), 0.95).unwrap();
            println!(
                "sinusoid seed {seed}: f {:.6} [{:.6}, {:.6}] A {:.4e} [{:.4e}, {:.4e}] φ {:.3} ΔBIC {:.0}",
                s.freq_hz, s.freq_lo, s.freq_hi, s.amplitude, s.amplitude_lo, s.amplitude_hi,
                s.phase_rad, s.delta_bic
            );
            assert!(s.freq_lo <= F0 && F0 <= s.freq_hi);
            assert!((s.amplitude / amp - 1.0).abs() < 0.05);
            assert!((s.phase_rad - 0.7).abs() < 0.1);
            assert!(s.delta_bic < 0.0);
            remove_sinusoid(&mut y, FS, &s);
            let again = fit_sinusoid(&y, FS, F0, s1(&c, F0), 0.95).unwrap();
            assert!(again.delta_bic > 0.0, "{}", again.delta_bic);
        }
    }

    #[test]
    fn interval_coverage() {
        // Amplitude z = 10; 200 seeds: binomial σ of a coverage ≈ 3.3 %.
        let p = 0.6827;
        let runs = 200;
        let (mut ca, mut cf) = (0, 0);
        let mut rel = Vec::new();
        for seed in 0..runs {
            let (y, c, amp) = with_line(500 + seed, 10.0, 100_000);
            let s = fit_sinusoid(&y, FS, F0 - 0.03, s1(&c, F0), p).unwrap();
            ca += usize::from(s.amplitude_lo <= amp && amp <= s.amplitude_hi);
            cf += usize::from(s.freq_lo <= F0 && F0 <= s.freq_hi);
            rel.push(s.amplitude / amp - 1.0);
        }
        let (ca, cf) = (ca as f64 / runs as f64, cf as f64 / runs as f64);
        let (bias, var) = mean_var(&rel);
        println!(
            "sinusoid coverage at p={p}: amplitude {ca:.3}, frequency {cf:.3}; amplitude bias {bias:.4}, rms {:.4}",
            var.sqrt()
        );
        assert!((ca - p).abs() < 0.09, "{ca}");
        assert!((cf - p).abs() < 0.09, "{cf}");
    }

    #[test]
    fn degenerate_inputs() {
        assert!(fit_sinusoid(&[], FS, 1.0, 1.0, 0.68).is_none());
        assert!(fit_sinusoid(&[1.0; 100], FS, 60.0, 1.0, 0.68).is_none());
        assert!(fit_sinusoid(&[1.0; 100], FS, 1.0, 0.0, 0.68).is_none());
        let s = fit_sinusoid(&[1.0; 1000], FS, 3.0, 1e-6, 0.68).unwrap();
        assert_eq!(s.amplitude, 0.0);
        assert!(s.delta_bic > 0.0);
    }
}
