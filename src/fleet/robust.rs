//! Robust location and scale: what "unlike its siblings" means.
//!
//! A coefficient is compared with its siblings (the same term of the same sensor kind across the
//! fleet) on a log scale, because noise coefficients are positive and spread multiplicatively
//! (a unit twice as noisy is as far from the median as one half as noisy). The centre is the
//! median and the scale 1.4826·MAD (the median absolute deviation, scaled to equal the standard
//! deviation for normal data), so that the outliers being looked for do not inflate the yardstick
//! that should find them; a mean and standard deviation would let one wild sensor hide itself.
//!
//! **MAD = 0** (more than half the siblings share one value, e.g. a fleet of identical
//! simulations): the scale falls back to 1.2533·(mean absolute deviation from the median), the
//! normal-consistent form of that spread; if that is 0 too, every value equal to the median has
//! z = 0 and any other has z = ±∞.

/// MAD → σ for normal data: 1/Φ⁻¹(3/4).
pub const MAD_TO_SIGMA: f64 = 1.4826;
/// Mean absolute deviation → σ for normal data: √(π/2).
pub const MEAN_AD_TO_SIGMA: f64 = 1.2533;

/// The median of `values` (the mean of the middle two for an even count); `None` when empty.
/// NaNs must have been removed.
pub fn median(values: &[f64]) -> Option<f64> {
    if values.is_empty() {
        return None;
    }
    let mut v = values.to_vec();
    v.sort_by(f64::total_cmp);
    let n = v.len();
    Some(if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    })
}

/// Centre and scale of a set of values.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RobustScale {
    pub median: f64,
    /// σ-equivalent spread: 1.4826·MAD, or the mean-absolute-deviation fallback (may be 0).
    pub scale: f64,
    pub count: usize,
}

impl RobustScale {
    /// The centre and scale of `values`; `None` for fewer than `min_count` values.
    pub fn of(values: &[f64], min_count: usize) -> Option<RobustScale> {
        if values.len() < min_count.max(1) {
            return None;
        }
        let m = median(values)?;
        let dev: Vec<f64> = values.iter().map(|v| (v - m).abs()).collect();
        let mad = median(&dev)?;
        let scale = if mad > 0.0 {
            MAD_TO_SIGMA * mad
        } else {
            MEAN_AD_TO_SIGMA * dev.iter().sum::<f64>() / dev.len() as f64
        };
        Some(RobustScale {
            median: m,
            scale,
            count: values.len(),
        })
    }

    /// The robust z of `x`: (x − median)/scale (see the module docs for a zero scale).
    pub fn z(&self, x: f64) -> f64 {
        self.z_with(x, 0.0)
    }

    /// The robust z of `x` whose own standard error is `u`: (x − median)/√(scale² + u²).
    pub fn z_with(&self, x: f64, u: f64) -> f64 {
        let d = x - self.median;
        let s = self.scale.hypot(u);
        if s > 0.0 {
            d / s
        } else if d == 0.0 {
            0.0
        } else {
            d.signum() * f64::INFINITY
        }
    }
}

/// The robust z of every value against all of them (itself included, as the median and MAD
/// barely move for one value among many); `None` for fewer than `min_count` values.
pub fn robust_z(values: &[f64], min_count: usize) -> Option<Vec<f64>> {
    let s = RobustScale::of(values, min_count)?;
    Some(values.iter().map(|&v| s.z(v)).collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn median_and_mad_by_hand() {
        assert_eq!(median(&[3.0, 1.0, 2.0]), Some(2.0));
        assert_eq!(median(&[4.0, 1.0, 3.0, 2.0]), Some(2.5));
        assert_eq!(median(&[]), None);
        // 1..=9 and one wild value: median 5.5, |dev| = 4.5 3.5 … 0.5 0.5 … 3.5 94.5, MAD = 2.5.
        let mut v: Vec<f64> = (1..=9).map(f64::from).collect();
        v.push(100.0);
        let s = RobustScale::of(&v, 5).unwrap();
        assert_eq!(s.median, 5.5);
        assert!((s.scale - 1.4826 * 2.5).abs() < 1e-12);
        let z = robust_z(&v, 5).unwrap();
        assert!((z[9] - 94.5 / (1.4826 * 2.5)).abs() < 1e-9);
        assert!(z[..9].iter().all(|z| z.abs() < 1.3), "{z:?}");
        // Too few siblings: no test.
        assert!(robust_z(&v[..4], 5).is_none());
    }

    #[test]
    fn zero_mad_falls_back_then_to_infinity() {
        // Six equal values and two others: MAD = 0, mean |dev| = (1 + 3)/8.
        let v = [1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 2.0, 4.0];
        let s = RobustScale::of(&v, 5).unwrap();
        assert_eq!(s.median, 1.0);
        assert!((s.scale - 1.2533 * 0.5).abs() < 1e-12);
        assert!((s.z(4.0) - 3.0 / (1.2533 * 0.5)).abs() < 1e-9);
        let same = [2.0; 6];
        let s = RobustScale::of(&same, 5).unwrap();
        assert_eq!(s.scale, 0.0);
        assert_eq!(s.z(2.0), 0.0);
        assert_eq!(s.z(3.0), f64::INFINITY);
        assert_eq!(s.z(1.0), f64::NEG_INFINITY);
        // The value's own error enters in quadrature.
        assert!((s.z_with(3.0, 0.5) - 2.0).abs() < 1e-12);
    }

    #[test]
    fn one_sensor_three_times_noisier_stands_out_on_the_log_scale() {
        // Nineteen sensors within ±10 % and one at 3×.
        let mut v: Vec<f64> = (0..19)
            .map(|i| (1.0 + 0.01 * (i as f64 - 9.0)).ln())
            .collect();
        v.push(3f64.ln());
        let z = robust_z(&v, 5).unwrap();
        assert!(z[19] > 3.5, "{}", z[19]);
        assert!(z[..19].iter().all(|z| z.abs() < 3.5));
    }
}
