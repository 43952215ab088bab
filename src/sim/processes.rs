//! The rate processes other than flicker and quantisation, each added onto a channel in place.
//!
//! Every sample is the mean of the continuous-time rate over its sample interval, as an IMU that
//! outputs delta angles (or delta velocities) divided by τ₀ delivers, and each process is
//! discretised exactly for that: the Allan variance of the samples is then the continuous-time
//! IEEE form at every τ = mτ₀, m = 1 included, and their spectrum is the continuous one through
//! sinc²(πfτ₀), folded at Nyquist ([`Term::psd_sampled_unit`](crate::model::Term::psd_sampled_unit)).

use std::f64::consts::TAU;

use crate::model::GaussMarkov;

use super::rng::Rng;
use super::spec::{DriftSpec, LineWander, ResonanceSpec, SinusoidSpec};
use crate::effects::shapes::ResonanceForm;

/// White rate noise with two-sided PSD n² (AV n²/τ): interval means of white noise are white
/// with σ = n·√fs.
pub fn add_white(y: &mut [f64], rate_hz: f64, n: f64, rng: &mut Rng) {
    let sigma = n * rate_hz.sqrt();
    for v in y {
        *v += sigma * rng.gauss();
    }
}

/// White noise of density `n` (rate σ = n·√f_s) drawn from Student's t with `dof` (> 2) degrees of
/// freedom, scaled to unit variance: the same N as [`add_white`], with heavy tails (excess
/// kurtosis 6/(dof − 4) for dof > 4, unbounded below).
pub fn add_white_student(y: &mut [f64], rate_hz: f64, n: f64, dof: f64, rng: &mut Rng) {
    let sigma = n * rate_hz.sqrt() * ((dof - 2.0) / dof).sqrt();
    for v in y {
        // t = Z/√(V/ν) with V ~ χ²_ν = 2·Gamma(ν/2).
        let z = rng.gauss();
        let chi2 = 2.0 * gamma(dof / 2.0, rng);
        *v += sigma * z / (chi2 / dof).sqrt();
    }
}

/// A Gamma(`shape`, 1) draw, `shape` ≥ 1 (Marsaglia and Tsang, ACM TOMS 26(3), 2000).
fn gamma(shape: f64, rng: &mut Rng) -> f64 {
    let d = shape - 1.0 / 3.0;
    let c = 1.0 / (9.0 * d).sqrt();
    loop {
        let x = rng.gauss();
        let v = (1.0 + c * x).powi(3);
        if v <= 0.0 {
            continue;
        }
        let u = rng.uniform();
        if u > 0.0 && u.ln() < 0.5 * x * x + d - d * v + d * v.ln() {
            return d * v;
        }
    }
}

/// Rate random walk with AV k²τ/3 (continuous Brownian rate, from zero at t = 0). Over an
/// interval the rate moves by ΔW ~ N(0, k²τ₀), and its mean is W_start + ΔW/2 + ξ where ξ, the
/// mean of the Brownian bridge, is N(0, k²τ₀/12) and independent of ΔW. (Point samples of the
/// walk would have AV k²τ/3·(1 + 1/(2m²)) instead.)
pub fn add_random_walk(y: &mut [f64], rate_hz: f64, k: f64, rng: &mut Rng) {
    let step = k / rate_hz.sqrt();
    let bridge = step / 12f64.sqrt();
    let mut level = 0.0;
    for v in y {
        let dw = step * rng.gauss();
        *v += level + dw / 2.0 + bridge * rng.gauss();
        level += dw;
    }
}

/// A deterministic ramp r·t (AV r²τ²/2 exactly): interval i's mean is r·(i + ½)/fs.
pub fn add_ramp(y: &mut [f64], rate_hz: f64, r: f64) {
    for (i, v) in y.iter_mut().enumerate() {
        *v += r * (i as f64 + 0.5) / rate_hz;
    }
}

/// First-order Gauss–Markov (Ornstein–Uhlenbeck, variance σ², time constant Tc), started from
/// its stationary distribution. Exact for interval means: with φ = e^(−τ₀/Tc), the state at the
/// interval's end and its integral I over the interval are
/// x₁ = φx₀ + e₁, I = Tc(1 − φ)x₀ + e₂, with (e₁, e₂) jointly Gaussian:
/// Var e₁ = σ²(1 − φ²), Var e₂ = 2σ²Tc[τ₀ − 2Tc(1 − φ) + Tc(1 − φ²)/2], Cov = σ²Tc(1 − φ)².
pub fn add_gauss_markov(y: &mut [f64], rate_hz: f64, gm: &GaussMarkov, rng: &mut Rng) {
    let tau0 = 1.0 / rate_hz;
    let (s2, tc) = (gm.sigma * gm.sigma, gm.tc_s);
    let phi = (-tau0 / tc).exp();
    // 1 − φ and 1 − φ² without cancellation for τ₀ ≪ Tc.
    let one_minus_phi = -(-tau0 / tc).exp_m1();
    let one_minus_phi2 = -(-2.0 * tau0 / tc).exp_m1();
    let v1 = s2 * one_minus_phi2;
    let v2 = 2.0 * s2 * tc * (tau0 - 2.0 * tc * one_minus_phi + tc * one_minus_phi2 / 2.0);
    let c12 = s2 * tc * one_minus_phi * one_minus_phi;
    // e₁ = a·g₁, e₂ = b·g₁ + c·g₂ (Cholesky of the 2×2 covariance).
    let a = v1.sqrt();
    let b = if a > 0.0 { c12 / a } else { 0.0 };
    let c = (v2 - b * b).max(0.0).sqrt();
    let mut x = gm.sigma * rng.gauss();
    for v in y {
        let (g1, g2) = (rng.gauss(), rng.gauss());
        let integral = tc * one_minus_phi * x + b * g1 + c * g2;
        *v += integral / tau0;
        x = phi * x + a * g1;
    }
}

/// A narrowband resonance (second-order Gauss–Markov process, see [`ResonanceSpec`]): its
/// displacement x point sampled at each sample's start or, for the band-pass form, its rate x′/ω₀
/// averaged over each sample's interval, exactly: the state (x, x′/ω₀)/σ of
/// x″ + (ω₀/q)x′ + ω₀²x = white noise has the identity as stationary covariance; one sample
/// interval maps it by Φ = e^(AΔ) (poles r·e^(±iω), r = e^(−πf₀/(q·fs)),
/// ω = 2πf₀√(1 − 1/(4q²))/fs) and adds Gaussian noise of covariance I − ΦΦᵀ, which keeps the
/// stationary distribution the process starts from.
pub fn add_resonance(y: &mut [f64], rate_hz: f64, r: &ResonanceSpec, rng: &mut Rng) {
    let dt = 1.0 / rate_hz;
    let w0 = TAU * r.f0_hz;
    let alpha = w0 / (2.0 * r.q);
    // e^(AΔ) = e^(−αΔ)·[C·I + S·(A + αI)], A = [[0, 1], [−ω₀², −2α]]: C and S from the damped
    // (oscillating), critical or overdamped roots.
    let disc = 1.0 / (4.0 * r.q * r.q) - 1.0;
    let (c, s) = if disc < -1e-12 {
        let wd = w0 * (-disc).sqrt();
        ((wd * dt).cos(), (wd * dt).sin() / wd)
    } else if disc > 1e-12 {
        let g = w0 * disc.sqrt();
        ((g * dt).cosh(), (g * dt).sinh() / g)
    } else {
        (1.0, dt)
    };
    let e = (-alpha * dt).exp();
    // Φ in the scaled state (x/σ, x′/(ω₀σ)).
    let p11 = e * (c + alpha * s);
    let p12 = e * s * w0;
    let p21 = -e * s * w0;
    let p22 = e * (c - alpha * s);
    // Innovation covariance I − ΦΦᵀ and its Cholesky factor [[a, 0], [b, d]].
    let q11 = 1.0 - (p11 * p11 + p12 * p12);
    let q12 = -(p11 * p21 + p12 * p22);
    let q22 = 1.0 - (p21 * p21 + p22 * p22);
    let a = q11.max(0.0).sqrt();
    let b = if a > 0.0 { q12 / a } else { 0.0 };
    let d = (q22 - b * b).max(0.0).sqrt();
    let (mut u1, mut u2) = (rng.gauss(), rng.gauss());
    let rate_output = r.form == ResonanceForm::BandPass;
    for v in y {
        let before = u1;
        let (g1, g2) = (rng.gauss(), rng.gauss());
        (u1, u2) = (
            p11 * u1 + p12 * u2 + a * g1,
            p21 * u1 + p22 * u2 + b * g1 + d * g2,
        );
        *v += r.sigma
            * if rate_output {
                // The rate x′/ω₀ (unit variance in these units) averaged over the sample
                // interval, as the other rate components are: the displacement's difference. Its
                // spectrum falls only as f⁻² above the peak, and point samples of it fold that tail
                // into the band (+30 % at 0.5–3 Hz for 8 Hz, q 20 at 100 Hz).
                (u1 - before) / (w0 * dt)
            } else {
                before
            };
    }
}

/// A deterministic drift over a record of `y.len()` samples (T = n/fs), each sample the exact
/// mean over its interval [tᵢ, tᵢ + τ₀]: A·Tc·(e^(−tᵢ/Tc) − e^(−(tᵢ+τ₀)/Tc))/τ₀ for the settling
/// A·e^(−t/Tc), and c·((tᵢ + τ₀/2 − T/2)² + τ₀²/12) for the curvature c·(t − T/2)².
pub fn add_drift(y: &mut [f64], rate_hz: f64, d: &DriftSpec) {
    let dt = 1.0 / rate_hz;
    let half = y.len() as f64 * dt / 2.0;
    for (i, v) in y.iter_mut().enumerate() {
        let t = i as f64 * dt;
        if let Some(ex) = &d.exponential {
            // −Tc·e^(−t/Tc)·(e^(−τ₀/Tc) − 1)/τ₀, without cancellation for τ₀ ≪ Tc.
            *v += ex.amplitude * (-t / ex.tc_s).exp() * (-(-dt / ex.tc_s).exp_m1()) * ex.tc_s / dt;
        }
        if d.quadratic != 0.0 {
            let m = t + dt / 2.0 - half;
            *v += d.quadratic * (m * m + dt * dt / 12.0);
        }
    }
}

/// A·sin(2πf₀t + φ), point-sampled at each interval's centre: the samples hold amplitude A (the
/// crate's convention for lines, see [`crate::effects::time::sinusoid`]).
pub fn add_sinusoid(y: &mut [f64], rate_hz: f64, s: &SinusoidSpec, rng: &mut Rng) {
    if let Some(wander) = &s.wander {
        add_wandering_line(y, rate_hz, s, wander, rng);
        return;
    }
    let w = TAU * s.freq_hz / rate_hz;
    for (i, v) in y.iter_mut().enumerate() {
        *v += s.amplitude * (w * (i as f64 + 0.5) + s.phase_rad).sin();
    }
}

/// A line whose frequency and amplitude wander (see [`SinusoidSpec::wander`]): the phase is the
/// running sum of the instantaneous frequency, each sample the point value at its interval's
/// middle.
fn add_wandering_line(
    y: &mut [f64],
    rate_hz: f64,
    s: &SinusoidSpec,
    wander: &LineWander,
    rng: &mut Rng,
) {
    let tau0 = 1.0 / rate_hz;
    let phi = (-tau0 / wander.wander_tc_s).exp();
    let kick = (1.0 - phi * phi).max(0.0).sqrt();
    let (mut df, mut da) = (
        wander.freq_wander_hz * rng.gauss(),
        wander.amplitude_wander * rng.gauss(),
    );
    let mut phase = s.phase_rad + TAU * (s.freq_hz + df) * tau0 / 2.0;
    for v in y.iter_mut() {
        *v += s.amplitude * (1.0 + da) * phase.sin();
        df = phi * df + kick * wander.freq_wander_hz * rng.gauss();
        da = phi * da + kick * wander.amplitude_wander * rng.gauss();
        phase += TAU * (s.freq_hz + df) * tau0;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::avar::reference::oadev;

    #[test]
    fn allan_variances_of_the_discretisations() {
        // 200 000 samples; the tolerances are about 3σ of the AV estimate at the m used (EDF
        // from ≈ 2N/3m for white, far fewer for the random walk: checked at small m).
        let fs = 100.0;
        let n = 200_000;
        let mut y = vec![0.0; n];
        add_white(&mut y, fs, 0.02, &mut Rng::new(1));
        let m = 10;
        let av = oadev(&y, m);
        let want = 0.02f64.powi(2) / (m as f64 / fs);
        assert!((av / want - 1.0).abs() < 0.03, "{}", av / want);

        // Random walk at m = 1 and 2, where point samples would read 50 % and 12.5 % high.
        let mut y = vec![0.0; n];
        add_random_walk(&mut y, fs, 1e-3, &mut Rng::new(2));
        for m in [1, 2] {
            let tau = m as f64 / fs;
            let av = oadev(&y, m);
            let want = 1e-6 * tau / 3.0;
            assert!((av / want - 1.0).abs() < 0.05, "m={m}: {}", av / want);
        }

        let mut y = vec![0.0; 1000];
        add_ramp(&mut y, fs, 0.5);
        let tau = 0.3;
        let av = oadev(&y, 30);
        assert!((av / (0.25 * tau * tau / 2.0) - 1.0).abs() < 1e-9);
    }

    #[test]
    fn gauss_markov_has_its_allan_variance_from_the_first_sample() {
        // Tc = 5 samples, so interval averaging matters at m = 1. 400 000 samples: the AV at
        // m = 1, 4, 16 has EDF > 10⁴, σ < 1.5 %; bound 5 %.
        let fs = 100.0;
        let gm = GaussMarkov {
            sigma: 0.3,
            tc_s: 0.05,
        };
        let mut y = vec![0.0; 400_000];
        add_gauss_markov(&mut y, fs, &gm, &mut Rng::new(4));
        for m in [1usize, 4, 16] {
            let ratio = oadev(&y, m) / gm.avar(m as f64 / fs);
            assert!((ratio - 1.0).abs() < 0.05, "m={m}: {ratio}");
        }
    }

    #[test]
    fn sinusoid_has_its_allan_variance() {
        // Deterministic: exact but for the partial periods at the ends (< 1e-3 here).
        let fs = 100.0;
        let s = SinusoidSpec {
            amplitude: 2.0,
            freq_hz: 7.3,
            phase_rad: 0.4,
            wander: None,
        };
        let mut y = vec![0.0; 100_000];
        add_sinusoid(&mut y, fs, &s, &mut Rng::new(1));
        let model = crate::model::Sinusoid {
            amplitude: 2.0,
            freq_hz: 7.3,
        };
        for m in [1usize, 3, 10] {
            let ratio = oadev(&y, m) / model.avar_point_sampled(m as f64 / fs, fs);
            assert!((ratio - 1.0).abs() < 1e-3, "m={m}: {ratio}");
        }
    }
}
