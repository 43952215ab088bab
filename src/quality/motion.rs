//! Whether a recording is static at all: the IEEE model, the fits and the residual loop describe
//! a sensor at rest, and a record in which it was turned, tilted or carried gives numbers that are
//! not its noise (a robot rotated by 1 °/s for three minutes of an hour gave random walks 30–150×
//! the truth in `imu.yaml`, the loop reading the motion as steps, excursions and eight "lines",
//! and took minutes on one channel).
//!
//! **The rule.** Motion starts and stops within seconds; a bias moves by far less in a second
//! than the smallest motion worth the name (a warm-up of 0.5 °/s over 300 s changes by 0.002 °/s
//! in one). So the test is on the jump between consecutive means over [`BLOCK_S`]: a jump beyond
//! an absolute floor ([`GYRO_JUMP`], [`ACCEL_JUMP`]: 0.2 °/s, 0.02 g — a tilt of about 1°) that
//! is also beyond [`JUMP_SIGMAS`] times the jumps' own robust scale (so that a very noisy sensor's
//! scatter is not motion) is motion. The scale is the median absolute deviation of the jumps,
//! which the few jumps of a motion do not move. A bias step of a static sensor worth modelling is
//! orders of magnitude smaller (10σ of 10-s means of a 0.15-°/√h gyro is 0.008 °/s).

use serde::Serialize;

use crate::model::Sensor;

/// Length of the means whose jumps are tested, s.
pub const BLOCK_S: f64 = 1.0;
/// Smallest jump of a gyro's 1-s means read as motion, rad/s (0.2 °/s).
pub const GYRO_JUMP: f64 = 0.2 * std::f64::consts::PI / 180.0;
/// Smallest jump of an accelerometer's 1-s means read as motion, m/s² (0.02 g).
pub const ACCEL_JUMP: f64 = 0.02 * crate::units::STANDARD_GRAVITY;
/// A jump must also exceed this many robust σ of the jumps.
pub const JUMP_SIGMAS: f64 = 30.0;
/// Fewest means the test needs (a shorter record is not judged).
const MIN_BLOCKS: usize = 16;

/// Where a channel was seen to move.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Motion {
    /// Time of the first and the last jump read as motion, s from the start.
    pub from_s: f64,
    pub to_s: f64,
    /// The largest jump between consecutive means (SI, signed) and how many jumps passed.
    pub largest_jump: f64,
    pub jumps: usize,
}

/// The motion `y` (sampled at `rate_hz`, SI units of `sensor`) shows, if any.
pub fn motion(y: &[f64], rate_hz: f64, sensor: Sensor) -> Option<Motion> {
    if rate_hz.is_nan() || rate_hz <= 0.0 {
        return None;
    }
    let block = ((BLOCK_S * rate_hz).round() as usize).max(1);
    let means: Vec<f64> = y
        .chunks_exact(block)
        .map(|c| c.iter().sum::<f64>() / block as f64)
        .collect();
    if means.len() < MIN_BLOCKS {
        return None;
    }
    let jumps: Vec<f64> = means.windows(2).map(|w| w[1] - w[0]).collect();
    let mut abs: Vec<f64> = jumps.iter().map(|d| d.abs()).collect();
    let mid = abs.len() / 2;
    abs.select_nth_unstable_by(mid, f64::total_cmp);
    // The jumps have mean ≈ 0: the median of |d| is the MAD, 0.6745 σ for Gaussian jumps.
    let sigma = abs[mid] / 0.6745;
    let floor = match sensor {
        Sensor::Gyro => GYRO_JUMP,
        Sensor::Accel => ACCEL_JUMP,
    };
    let threshold = floor.max(JUMP_SIGMAS * sigma);
    let moved: Vec<(usize, f64)> = jumps
        .iter()
        .copied()
        .enumerate()
        .filter(|(_, d)| d.abs() > threshold)
        .collect();
    let (first, last) = (moved.first()?, moved.last()?);
    let largest = moved
        .iter()
        .map(|m| m.1)
        .max_by(|a, b| a.abs().total_cmp(&b.abs()))?;
    let at = |i: usize| (i + 1) as f64 * block as f64 / rate_hz;
    Some(Motion {
        from_s: at(first.0),
        to_s: at(last.0),
        largest_jump: largest,
        jumps: moved.len(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::rng::Rng;

    const FS: f64 = 200.0;

    /// A 0.15-°/√h-class MEMS gyro (N 1.7e-4 rad/s/√Hz) at rest for 20 min.
    fn at_rest(seed: u64) -> Vec<f64> {
        let mut rng = Rng::new(seed);
        let sd = 1.7e-4 * (FS / 2.0).sqrt();
        (0..(1200.0 * FS) as usize)
            .map(|_| 1e-3 + sd * rng.gauss())
            .collect()
    }

    /// A turn of 1 °/s for 90 s and back: motion, from its start to its end.
    #[test]
    fn a_turn_is_motion() {
        let mut y = at_rest(1);
        let rate = 1f64.to_radians();
        for (i, v) in y.iter_mut().enumerate() {
            let t = i as f64 / FS;
            if (600.0..690.0).contains(&t) {
                *v += rate;
            } else if (690.0..780.0).contains(&t) {
                *v -= rate;
            }
        }
        let m = motion(&y, FS, Sensor::Gyro).expect("motion");
        assert!(
            (m.from_s - 600.0).abs() <= 1.0 && (m.to_s - 780.0).abs() <= 1.0,
            "{m:?}"
        );
        assert!(
            (m.largest_jump.abs() / (2.0 * rate) - 1.0).abs() < 0.05,
            "{m:?}"
        );
    }

    /// At rest: nothing, on 20 seeds; nor with a warm-up of 0.5 °/s (Tc 300 s), nor with a bias
    /// step of 0.05 °/s, nor on an accelerometer's 1-mg step.
    #[test]
    fn a_sensor_at_rest_does_not_move() {
        for seed in 0..20 {
            let mut y = at_rest(100 + seed);
            assert_eq!(motion(&y, FS, Sensor::Gyro), None, "seed {seed}");
            for (i, v) in y.iter_mut().enumerate() {
                let t = i as f64 / FS;
                *v += 0.5f64.to_radians() * (-t / 300.0).exp();
                if t > 700.0 {
                    *v += 0.05f64.to_radians();
                }
            }
            assert_eq!(motion(&y, FS, Sensor::Gyro), None, "seed {seed}");
        }
        let mut rng = Rng::new(7);
        let g = crate::units::STANDARD_GRAVITY;
        let a: Vec<f64> = (0..(600.0 * FS) as usize)
            .map(|i| g + 2e-3 * 10.0 * rng.gauss() + if i > 60_000 { 1e-3 * g } else { 0.0 })
            .collect();
        assert_eq!(motion(&a, FS, Sensor::Accel), None);
    }

    /// A tilt of 5° of an accelerometer axis that holds gravity's horizontal share: motion.
    #[test]
    fn a_tilt_is_motion() {
        let mut rng = Rng::new(9);
        let g = crate::units::STANDARD_GRAVITY;
        let a: Vec<f64> = (0..(600.0 * FS) as usize)
            .map(|i| {
                let tilt = if i > 60_000 { 5f64.to_radians() } else { 0.0 };
                g * tilt.sin() + 2e-3 * 10.0 * rng.gauss()
            })
            .collect();
        let m = motion(&a, FS, Sensor::Accel).expect("motion");
        assert!((m.from_s - 300.0).abs() <= 1.0, "{m:?}");
    }

    /// Too short to judge.
    #[test]
    fn a_short_record_is_not_judged() {
        assert_eq!(motion(&[0.0; 100], FS, Sensor::Gyro), None);
        assert_eq!(motion(&[], 0.0, Sensor::Gyro), None);
    }
}
