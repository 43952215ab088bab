//! The host side of the GPU FFT: which algorithm a length gets, and the twiddle table.
//!
//! A real FFT of length nfft is done as a complex FFT of M = nfft/2 (pairs of samples packed as
//! re/im) followed by a twist that separates the even and odd halves (`twist` in
//! `shaders/fft_common.wgsl`). The complex FFT is a Stockham autosort FFT, radix 4 with one radix-2
//! stage when log2 M is odd, run entirely in workgroup memory when M fits (`LOCAL_MAX` values, 2048
//! on a 32 KiB device); beyond that, the four-step algorithm splits M = M1·M2 with both factors
//! local: column FFTs of length M2 with a twiddle, then row FFTs of length M1 into natural order.
//! Four-step was preferred over global-memory Stockham passes because each of its two passes does
//! all its butterflies in workgroup memory, so the data crosses device memory twice instead of
//! log4 M times.
//!
//! Twiddles are computed on the CPU in f64 and rounded once to f32: sin/cos on GPUs are
//! approximations whose error grows with the argument, which would cap the accuracy of long
//! transforms. One table of exp(−2πi·t/nfft), t < nfft/2, serves every stage, the four-step twiddles
//! and the twist, because every length involved divides nfft.

/// Which kernels transform a segment.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FftAlgorithm {
    /// The whole complex FFT in one workgroup (`welch_local`).
    Local,
    /// Four-step with column length `m2` and row length `m1` (`fft_columns`, `fft_rows`).
    FourStep { m1: usize, m2: usize },
}

/// Largest nfft the GPU path transforms on a device whose workgroup FFT holds `local` values:
/// nfft/2 = local².
pub fn max_nfft(local: usize) -> usize {
    2 * local * local
}

/// The algorithm for a power-of-two `nfft` ≥ 2, or `None` when nfft/2 exceeds local².
pub fn algorithm(nfft: usize, local: usize) -> Option<FftAlgorithm> {
    debug_assert!(nfft.is_power_of_two() && nfft >= 2);
    let half = nfft / 2;
    if half <= local {
        return Some(FftAlgorithm::Local);
    }
    // Balanced split (M1 ≥ M2): both passes get blocks as large as possible.
    let log = half.trailing_zeros();
    let m1 = 1usize << log.div_ceil(2);
    let m2 = half / m1;
    (m1 <= local).then_some(FftAlgorithm::FourStep { m1, m2 })
}

/// Transforms of length `len` one workgroup of the four-step passes does at once: as many as fill
/// its arrays of `local` values, at most `available` (`per_group` in `shaders/fft_common.wgsl`,
/// which must agree). Several columns per workgroup make the column pass's reads and writes, at a
/// stride of M1 values within a column, come in runs of consecutive addresses; several rows per
/// workgroup do the same for the row pass's writes into natural order.
pub fn per_group(available: usize, len: usize, local: usize) -> usize {
    available.min((local / len.max(1)).max(1))
}

/// exp(−2πi·t/nfft) for t in [0, nfft/2), as (re, im) in f32, rounded once from f64.
///
/// The angle is formed from the exact integer ratio t/nfft, and the octant symmetry keeps every
/// argument of sin/cos within [0, π/4], where they are accurate to the last bit.
pub fn twiddles(nfft: usize) -> Vec<[f32; 2]> {
    (0..nfft / 2)
        .map(|t| {
            let (c, s) = unit_root(t, nfft);
            [c as f32, -s as f32]
        })
        .collect()
}

/// (cos, sin) of 2π·t/n, reduced to an angle in [0, π/4].
fn unit_root(t: usize, n: usize) -> (f64, f64) {
    use std::f64::consts::PI;
    // Work in eighths of a turn: 8t = q·n + r, angle = (q + r/n)·π/4.
    let t = t % n;
    let q = (8 * t) / n;
    let r = (8 * t) % n;
    let frac = r as f64 / n as f64 * (PI / 4.0);
    // Odd octants are mirrored so that the argument is always the distance to the nearest
    // multiple of π/4 from below within the octant.
    let (a, mirrored) = if q % 2 == 1 {
        (PI / 4.0 - frac, true)
    } else {
        (frac, false)
    };
    let (s0, c0) = a.sin_cos();
    // In octant q (mirrored for odd q) the point is a rotation of (c0, s0) by a multiple of π/2,
    // or its reflection about the diagonal.
    let (c, s) = if mirrored { (s0, c0) } else { (c0, s0) };
    match q {
        0 | 1 => (c, s),
        2 | 3 => (-s, c),
        4 | 5 => (-c, -s),
        _ => (s, -c),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn twiddles_are_unit_roots_to_the_last_bit() {
        for n in [2usize, 4, 8, 64, 1 << 12, 1 << 20] {
            let tw = twiddles(n);
            assert_eq!(tw.len(), n / 2);
            for (t, w) in tw.iter().enumerate().step_by((n / 512).max(1)) {
                let a = -2.0 * std::f64::consts::PI * t as f64 / n as f64;
                let (c, s) = (a.cos() as f32, a.sin() as f32);
                assert!(
                    (w[0] - c).abs() <= 1e-7 && (w[1] - s).abs() <= 1e-7,
                    "n {n} t {t}"
                );
            }
        }
        let tw = twiddles(8);
        let h = std::f32::consts::FRAC_1_SQRT_2;
        let expected = [[1.0, 0.0], [h, -h], [0.0, -1.0], [-h, -h]];
        for (w, e) in tw.iter().zip(expected) {
            assert!(
                (w[0] - e[0]).abs() < 1e-7 && (w[1] - e[1]).abs() < 1e-7,
                "{w:?} {e:?}"
            );
        }
    }

    #[test]
    fn algorithms_by_size() {
        assert_eq!(algorithm(4096, 2048), Some(FftAlgorithm::Local));
        assert_eq!(
            algorithm(8192, 2048),
            Some(FftAlgorithm::FourStep { m1: 64, m2: 64 })
        );
        assert_eq!(
            algorithm(1 << 21, 1024),
            Some(FftAlgorithm::FourStep { m1: 1024, m2: 1024 })
        );
        assert_eq!(
            algorithm(1 << 20, 2048),
            Some(FftAlgorithm::FourStep { m1: 1024, m2: 512 })
        );
        assert_eq!(algorithm(1 << 22, 1024), None);
        assert_eq!(max_nfft(2048), 1 << 23);
    }
}
