//! Allan variances at taus that are not powers of two: second differences of prefix sums,
//! S_{j+2m} − 2S_{j+m} + S_j, squared and summed on the device.
//!
//! With SHADER_F64 the device reads the CPU's own f64 prefix sums (`avar::PrefixSums`: mean removed,
//! exact anchors), so the terms are formed exactly as on the CPU. Without it, the prefix sums are
//! made exact instead of wide: the mean-removed samples are quantised to integers on a grid of
//! A·2^−k (A ≥ max|d| a power of two, k ≤ 40 chosen so that no second difference can overflow 63
//! bits) and summed in wrapping i64, which the kernel differences exactly with 32-bit words and
//! carries. The only roundings are the quantisation (at most A·2^−41 per sample, far below f32's
//! 2^−24 relative), one rounding of each difference to f32, and the f32 partial sums of at most
//! 16 + 16 + 16 terms. Compensated f32 tricks (double-single sums) were rejected because shader
//! compilers may legally reassociate them away; integer arithmetic cannot be reassociated wrongly.

use super::params::PrefixParams;

/// Prefix sums for `avar_prefix_fixed`.
pub(crate) struct FixedPrefix {
    /// S_t for t = 0..=N as (low, high) words of a two's-complement i64.
    pub words: Vec<[u32; 2]>,
    /// A: the power of two ≥ max|y − mean| that a difference of 2^k units equals.
    pub amplitude: f64,
    /// 2^−k.
    pub scale: f32,
}

/// Quantises `y − mean` and forms its exact prefix sums.
pub(crate) fn fixed_prefix(y: &[f64], mean: f64) -> FixedPrefix {
    let n = y.len();
    let max = y.iter().fold(0.0f64, |m, &v| m.max((v - mean).abs()));
    let amplitude = if max > 0.0 {
        2f64.powi(max.log2().ceil() as i32)
    } else {
        1.0
    };
    // |S_{j+2m} − 2S_{j+m} + S_j| ≤ 2m·2^k ≤ N·2^k must stay below 2^63.
    let bits_n = usize::BITS - n.max(1).leading_zeros();
    let k = (62i32 - bits_n as i32).clamp(0, 40);
    let to_units = 2f64.powi(k) / amplitude;
    let mut words = Vec::with_capacity(n + 1);
    let mut s = 0i64;
    words.push([0, 0]);
    for &v in y {
        s = s.wrapping_add(((v - mean) * to_units).round() as i64);
        let u = s as u64;
        words.push([u as u32, (u >> 32) as u32]);
    }
    FixedPrefix {
        words,
        amplitude,
        scale: 2f32.powi(-k),
    }
}

/// Parameters of one prefix dispatch over `count` terms with window offsets `off`.
pub(crate) fn params(count: usize, off: [u32; 3], scale: f32) -> PrefixParams {
    PrefixParams {
        count: count as u32,
        off0: off[0],
        off1: off[1],
        off2: off[2],
        partial_base: 0,
        scale,
        _pad0: 0,
        _pad1: 0,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gpu::mirror::avar::{sub64, to_f32};

    #[test]
    fn fixed_differences_equal_the_f64_ones() {
        let y: Vec<f64> = (0..5000)
            .map(|i| 1e4 + ((i * 7919) % 1013) as f64 * 1e-3 + (i as f64) * 1e-5)
            .collect();
        let mean = y.iter().sum::<f64>() / y.len() as f64;
        let f = fixed_prefix(&y, mean);
        let mut s = vec![0.0f64];
        for v in &y {
            s.push(s.last().unwrap() + (v - mean));
        }
        for m in [1usize, 3, 100, 2499] {
            for j in [0usize, 17, y.len() - 2 * m]
                .into_iter()
                .filter(|j| j + 2 * m <= y.len())
            {
                let d = s[j + 2 * m] - 2.0 * s[j + m] + s[j];
                let (a, b, c) = (f.words[j], f.words[j + m], f.words[j + 2 * m]);
                let q = to_f32(sub64(sub64(c, b), sub64(b, a))) * f.scale;
                let got = f64::from(q) * f.amplitude;
                assert!(
                    (got - d).abs() <= 1e-6 * d.abs() + 1e-9,
                    "m {m} j {j}: {got} vs {d}"
                );
            }
        }
    }
}
