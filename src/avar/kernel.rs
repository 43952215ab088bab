//! Inner loops: sums of squared second and third differences of S over contiguous ranges of start
//! indices, the only place where the time of the overlapping estimators goes.
//!
//! - Second differences are computed for a *chain* of up to four taus m, 2m, 4m, 8m at once
//!   (octave grids are made of such chains): S_j, S_{j+m}, S_{j+2m}, S_{j+4m}, … are each loaded
//!   once and serve two taus, which halves the memory traffic of long taus; a lone τ is a chain of
//!   one.
//! - Each τ accumulates in 8 lanes (two 256-bit registers): lane l takes the terms with
//!   j − j₀ ≡ l (mod 8); the lanes are added in order 0..8 and the scalar tail last. The AVX2
//!   version (x86-64, chosen at run time) and the portable one perform exactly these IEEE
//!   operations in this order, so results are bit-identical on every CPU, and a τ gives the same
//!   bits whether it is computed alone or in a chain.
//! - The second difference is formed from first differences d_c = S_{j+2^c·m} − S_j as
//!   v = d_{c+1} − 2·d_c (one fused multiply-add, exactly rounded once since 2·d_c is exact): the
//!   values of S are close to each other, so each d_c is exact or nearly so (Sterbenz) and the
//!   rounding is that of the small results, whereas S₂ − 2S₁ + S₀ would round at the magnitude of
//!   S. The square is accumulated with a fused multiply-add too: three floating-point operations
//!   per term, which is what bounds the short taus (their data sit in L1/L2).
//!
//! LLVM's auto-vectoriser handles the one-τ loop but not the chain (it falls back to shuffles and
//! 128-bit operations), hence the explicit intrinsics. The portable version uses `f64::mul_add`,
//! the same correctly rounded operation (a hardware instruction on aarch64; on an x86-64 without
//! AVX2 and FMA, a slow library call, but such CPUs predate 2013).

/// Accumulator lanes per τ.
const LANES: usize = 8;
/// Longest chain of taus evaluated together.
pub(crate) const MAX_CHAIN: usize = 4;

/// Σ v² for a chain of taus over `len` start indices, where `streams[0]` is S from the first start
/// index j₀ and `streams[c]` is S from j₀ + 2^(c−1)·m, so τ number c (= 2^c·m) has
/// v = (streams[c+2] − streams[0]) − 2·(streams[c+1] − streams[0]). Returns one sum per τ in
/// `out[..streams.len() − 2]`.
///
/// # Panics
/// If `streams` has fewer than 3 or more than `MAX_CHAIN + 2` entries, or one is shorter than
/// `len`.
pub(crate) fn chain_second(len: usize, streams: &[&[f64]], out: &mut [f64]) {
    let taus = streams.len().wrapping_sub(2);
    assert!((1..=MAX_CHAIN).contains(&taus), "chain of {taus} taus");
    assert!(streams.iter().all(|s| s.len() >= len) && out.len() >= taus);
    match taus {
        1 => out[..1].copy_from_slice(&dispatch_second::<1>(len, streams)),
        2 => out[..2].copy_from_slice(&dispatch_second::<2>(len, streams)),
        3 => out[..3].copy_from_slice(&dispatch_second::<3>(len, streams)),
        _ => out[..4].copy_from_slice(&dispatch_second::<4>(len, streams)),
    }
}

/// Σ v² of third differences v = (f₂ − f₁) − (f₁ − f₀), f_k = S_{j+(k+1)m} − S_{j+km}, over
/// `len` start indices; `streams` = S from j₀, j₀ + m, j₀ + 2m, j₀ + 3m.
///
/// # Panics
/// If `streams` does not have 4 entries of at least `len` values.
pub(crate) fn third(len: usize, streams: &[&[f64]]) -> f64 {
    assert!(streams.len() == 4 && streams.iter().all(|s| s.len() >= len));
    #[cfg(target_arch = "x86_64")]
    if has_avx2_fma() {
        // SAFETY: AVX2 and FMA are available (checked above) and every stream holds at least
        // `len` values (asserted above), which is all the function reads.
        return unsafe { avx2::third(len, streams) };
    }
    third_portable(len, streams)
}

fn dispatch_second<const T: usize>(len: usize, streams: &[&[f64]]) -> [f64; T] {
    #[cfg(target_arch = "x86_64")]
    if has_avx2_fma() {
        // SAFETY: AVX2 and FMA are available (checked above); `chain_second` asserted that there
        // are T + 2 streams of at least `len` values, which is all the function reads.
        return unsafe { avx2::second::<T>(len, streams) };
    }
    second_portable::<T>(len, streams)
}

#[cfg(target_arch = "x86_64")]
fn has_avx2_fma() -> bool {
    std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma")
}

/// Lane sums added in lane order, then the tail.
fn finish(lanes: &[f64; LANES], tail: f64) -> f64 {
    lanes.iter().sum::<f64>() + tail
}

fn second_portable<const T: usize>(len: usize, streams: &[&[f64]]) -> [f64; T] {
    let mut acc = [[0.0f64; LANES]; T];
    let full = len - len % LANES;
    for i in (0..full).step_by(LANES) {
        let base = &streams[0][i..i + LANES];
        let near = &streams[1][i..i + LANES];
        let mut d: [f64; LANES] = std::array::from_fn(|l| near[l] - base[l]);
        for (c, lanes) in acc.iter_mut().enumerate() {
            let far = &streams[c + 2][i..i + LANES];
            for l in 0..LANES {
                let next = far[l] - base[l];
                let v = (-2.0f64).mul_add(d[l], next);
                lanes[l] = v.mul_add(v, lanes[l]);
                d[l] = next;
            }
        }
    }
    let mut out = [0.0f64; T];
    for (c, slot) in out.iter_mut().enumerate() {
        *slot = finish(&acc[c], tail_second(full, len, streams, c));
    }
    out
}

fn tail_second(from: usize, len: usize, streams: &[&[f64]], c: usize) -> f64 {
    let mut tail = 0.0f64;
    for k in from..len {
        let (b, n, f) = (streams[0][k], streams[c + 1][k], streams[c + 2][k]);
        let v = (-2.0f64).mul_add(n - b, f - b);
        tail = v.mul_add(v, tail);
    }
    tail
}

fn third_portable(len: usize, streams: &[&[f64]]) -> f64 {
    let mut acc = [0.0f64; LANES];
    let full = len - len % LANES;
    for i in (0..full).step_by(LANES) {
        for (l, lane) in acc.iter_mut().enumerate() {
            let v = third_term(streams, i + l);
            *lane = v.mul_add(v, *lane);
        }
    }
    finish(&acc, tail_third(full, len, streams))
}

#[inline(always)]
fn third_term(streams: &[&[f64]], k: usize) -> f64 {
    let (s0, s1, s2, s3) = (streams[0][k], streams[1][k], streams[2][k], streams[3][k]);
    let (f0, f1, f2) = (s1 - s0, s2 - s1, s3 - s2);
    (f2 - f1) - (f1 - f0)
}

fn tail_third(from: usize, len: usize, streams: &[&[f64]]) -> f64 {
    let mut tail = 0.0f64;
    for k in from..len {
        let v = third_term(streams, k);
        tail = v.mul_add(v, tail);
    }
    tail
}

#[cfg(target_arch = "x86_64")]
mod avx2 {
    //! The same arithmetic as the portable loops, four lanes per 256-bit register, two registers
    //! per τ (lanes 0–3 and 4–7); `_mm256_fmadd_pd` is `f64::mul_add` lane by lane.

    use core::arch::x86_64::{
        __m256d, _mm256_fmadd_pd, _mm256_loadu_pd, _mm256_set1_pd, _mm256_setzero_pd,
        _mm256_storeu_pd, _mm256_sub_pd,
    };

    use super::{finish, tail_second, tail_third, LANES, MAX_CHAIN};

    /// # Safety
    /// The CPU must support AVX2 and FMA; `streams` must hold T + 2 slices of at least `len`
    /// values.
    #[target_feature(enable = "avx2,fma")]
    pub(super) unsafe fn second<const T: usize>(len: usize, streams: &[&[f64]]) -> [f64; T] {
        let mut ptr = [std::ptr::null::<f64>(); MAX_CHAIN + 2];
        for (p, s) in ptr.iter_mut().zip(streams) {
            *p = s.as_ptr();
        }
        let mut lo = [_mm256_setzero_pd(); T];
        let mut hi = [_mm256_setzero_pd(); T];
        let minus_two = _mm256_set1_pd(-2.0);
        let full = len - len % LANES;
        let mut i = 0;
        while i < full {
            // SAFETY (all loads): i + 8 ≤ full ≤ len and every stream holds ≥ len values.
            let b0 = _mm256_loadu_pd(ptr[0].add(i));
            let b1 = _mm256_loadu_pd(ptr[0].add(i + 4));
            let mut d0 = _mm256_sub_pd(_mm256_loadu_pd(ptr[1].add(i)), b0);
            let mut d1 = _mm256_sub_pd(_mm256_loadu_pd(ptr[1].add(i + 4)), b1);
            for c in 0..T {
                let e0 = _mm256_sub_pd(_mm256_loadu_pd(ptr[c + 2].add(i)), b0);
                let e1 = _mm256_sub_pd(_mm256_loadu_pd(ptr[c + 2].add(i + 4)), b1);
                let v0 = _mm256_fmadd_pd(minus_two, d0, e0);
                let v1 = _mm256_fmadd_pd(minus_two, d1, e1);
                lo[c] = _mm256_fmadd_pd(v0, v0, lo[c]);
                hi[c] = _mm256_fmadd_pd(v1, v1, hi[c]);
                d0 = e0;
                d1 = e1;
            }
            i += LANES;
        }
        let mut out = [0.0f64; T];
        for (c, slot) in out.iter_mut().enumerate() {
            *slot = finish(&lanes(lo[c], hi[c]), tail_second(full, len, streams, c));
        }
        out
    }

    /// # Safety
    /// The CPU must support AVX2 and FMA; `streams` must hold 4 slices of at least `len` values.
    #[target_feature(enable = "avx2,fma")]
    pub(super) unsafe fn third(len: usize, streams: &[&[f64]]) -> f64 {
        let p = [
            streams[0].as_ptr(),
            streams[1].as_ptr(),
            streams[2].as_ptr(),
            streams[3].as_ptr(),
        ];
        let mut lo = _mm256_setzero_pd();
        let mut hi = _mm256_setzero_pd();
        let full = len - len % LANES;
        let mut i = 0;
        while i < full {
            for (half, acc) in [(0usize, &mut lo), (4, &mut hi)] {
                // SAFETY: i + half + 4 ≤ full ≤ len, every stream holds ≥ len values.
                let s0 = _mm256_loadu_pd(p[0].add(i + half));
                let s1 = _mm256_loadu_pd(p[1].add(i + half));
                let s2 = _mm256_loadu_pd(p[2].add(i + half));
                let s3 = _mm256_loadu_pd(p[3].add(i + half));
                let (f0, f1, f2) = (
                    _mm256_sub_pd(s1, s0),
                    _mm256_sub_pd(s2, s1),
                    _mm256_sub_pd(s3, s2),
                );
                let v = _mm256_sub_pd(_mm256_sub_pd(f2, f1), _mm256_sub_pd(f1, f0));
                *acc = _mm256_fmadd_pd(v, v, *acc);
            }
            i += LANES;
        }
        finish(&lanes(lo, hi), tail_third(full, len, streams))
    }

    #[target_feature(enable = "avx2,fma")]
    unsafe fn lanes(lo: __m256d, hi: __m256d) -> [f64; LANES] {
        let mut out = [0.0f64; LANES];
        // SAFETY: `out` has room for 8 values.
        _mm256_storeu_pd(out.as_mut_ptr(), lo);
        _mm256_storeu_pd(out.as_mut_ptr().add(4), hi);
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn data(n: usize) -> Vec<f64> {
        (0..n)
            .map(|i| ((i * 37 % 101) as f64).sqrt() + i as f64)
            .collect()
    }

    #[test]
    fn chains_match_plain_loops() {
        let s = data(3000);
        let m = 7;
        for len in [0, 1, 7, 8, 9, 100, 333] {
            let streams: Vec<&[f64]> = [0, m, 2 * m, 4 * m, 8 * m, 16 * m]
                .iter()
                .map(|&o| &s[o..])
                .collect();
            for taus in 1..=MAX_CHAIN {
                let mut out = [0.0; MAX_CHAIN];
                chain_second(len, &streams[..taus + 2], &mut out);
                for (c, got) in out[..taus].iter().enumerate() {
                    let t = m << c;
                    let want: f64 = (0..len)
                        .map(|k| (s[k + 2 * t] - 2.0 * s[k + t] + s[k]).powi(2))
                        .sum();
                    assert!((got - want).abs() <= 1e-12 * want.max(1.0), "{len} {c}");
                }
            }
            let want3: f64 = (0..len)
                .map(|k| (s[k + 3 * m] - 3.0 * s[k + 2 * m] + 3.0 * s[k + m] - s[k]).powi(2))
                .sum();
            let t3 = third(len, &[&s[..], &s[m..], &s[2 * m..], &s[3 * m..]]);
            assert!((t3 - want3).abs() <= 1e-12 * want3.max(1.0), "{len}");
        }
    }

    #[test]
    fn dispatch_and_chaining_are_bit_identical() {
        let s = data(20_000);
        let m = 5;
        let streams: Vec<&[f64]> = [0, m, 2 * m, 4 * m, 8 * m, 16 * m]
            .iter()
            .map(|&o| &s[o..])
            .collect();
        for len in [3, 64, 999, 4000] {
            let mut chained = [0.0; MAX_CHAIN];
            chain_second(len, &streams, &mut chained);
            let portable = second_portable::<4>(len, &streams);
            for c in 0..MAX_CHAIN {
                assert_eq!(chained[c].to_bits(), portable[c].to_bits());
                // The same τ alone: streams S_j, S_{j+t}, S_{j+2t}.
                let alone = [streams[0], streams[c + 1], streams[c + 2]];
                let mut one = [0.0; 1];
                chain_second(len, &alone, &mut one);
                assert_eq!(one[0].to_bits(), chained[c].to_bits());
            }
            let st3 = [&s[..], &s[m..], &s[2 * m..], &s[3 * m..]];
            assert_eq!(
                third(len, &st3).to_bits(),
                third_portable(len, &st3).to_bits()
            );
        }
    }
}
