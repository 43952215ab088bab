//! Inner loops: sums of squared second and third differences of S over contiguous ranges of start
//! indices, the only place where the time of the overlapping estimators goes.
//!
//! - Second differences are computed for groups of up to four taus at once, sharing the loads of
//!   S_j. A *chain* m, 2m, 4m, 8m (octave grids are made of them) also shares S_{j+2m} of one τ as
//!   S_{j+m'} of the next, so each value is loaded once for two taus, which halves the memory
//!   traffic of long taus; unrelated taus share only S_j. Short taus are bound by the load ports
//!   (three loads per term alone, about two in a group).
//! - A τ accumulates in 4·R lanes (R 256-bit registers): lane l takes the terms with
//!   j − j₀ ≡ l (mod 4R); the lanes are added in order and the scalar tail last. A group uses
//!   R = 2 per τ; a lone τ uses R = 4, enough independent accumulators to hide the latency of the
//!   fused multiply-add (with 2 it would wait on it). The AVX2 version (x86-64, chosen at run time)
//!   and the portable one perform exactly these IEEE operations in this order, so results are
//!   bit-identical on every CPU.
//! - The second difference is formed from first differences d_c = S_{j+2^c·m} − S_j as
//!   v = d_{c+1} − 2·d_c (one fused multiply-add, rounded once, since 2·d_c is exact): values of S
//!   a few lags apart are close, so each d_c is exact or nearly so (Sterbenz) and the rounding is
//!   that of the small results, whereas S₂ − 2S₁ + S₀ would round at the magnitude of S. The square
//!   is accumulated with a fused multiply-add too: three floating-point operations per term, which
//!   is what bounds the short taus (their data sit in L1/L2).
//!
//! LLVM's auto-vectoriser handles the one-τ loop but not the groups (it falls back to shuffles and
//! 128-bit operations), hence the explicit intrinsics. The portable version uses `f64::mul_add`,
//! the same correctly rounded operation (a hardware instruction on aarch64; on an x86-64 without
//! AVX2 and FMA, a slow library call, but such CPUs predate 2013).

/// Most taus evaluated together by one kernel call.
pub(crate) const MAX_GROUP: usize = 4;
/// Most streams of a group (`Layout::Pairs` with `MAX_GROUP` taus).
const MAX_STREAMS: usize = 2 * MAX_GROUP + 1;

/// How the streams of a group of taus are laid out (see [`group_second`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Layout {
    /// A doubling chain m, 2m, 4m, …: `streams[c]` is S from j₀ + 2^(c−1)·m (c ≥ 1), τ number c
    /// uses streams c + 1 and c + 2. T + 2 streams.
    Chain,
    /// Unrelated taus: τ number c uses streams 2c + 1 (S from j₀ + m_c) and 2c + 2
    /// (S from j₀ + 2m_c). 2T + 1 streams.
    Pairs,
}

impl Layout {
    /// Number of streams for `taus` taus.
    pub(crate) fn streams(self, taus: usize) -> usize {
        match self {
            Layout::Chain => taus + 2,
            Layout::Pairs => 2 * taus + 1,
        }
    }
}

/// Σ v² of second differences for a group of up to `MAX_GROUP` taus over `len` start indices;
/// `streams[0]` is S from the first start index j₀, the others as `layout` says, and
/// v = (S_far − S_j) − 2·(S_near − S_j). One sum per τ in `out[..taus]`.
///
/// # Panics
/// If `taus` is 0 or above `MAX_GROUP`, the number of streams does not match the layout, or a
/// stream is shorter than `len`.
pub(crate) fn group_second(
    len: usize,
    taus: usize,
    layout: Layout,
    streams: &[&[f64]],
    out: &mut [f64],
) {
    assert!((1..=MAX_GROUP).contains(&taus), "group of {taus} taus");
    assert_eq!(streams.len(), layout.streams(taus));
    assert!(streams.iter().all(|s| s.len() >= len) && out.len() >= taus);
    let pairs = layout == Layout::Pairs;
    match (taus, pairs) {
        (1, _) => out[..1].copy_from_slice(&dispatch_second::<1, 4, false>(len, streams)),
        (2, false) => out[..2].copy_from_slice(&dispatch_second::<2, 2, false>(len, streams)),
        (3, false) => out[..3].copy_from_slice(&dispatch_second::<3, 2, false>(len, streams)),
        (_, false) => out[..4].copy_from_slice(&dispatch_second::<4, 2, false>(len, streams)),
        (2, true) => out[..2].copy_from_slice(&dispatch_second::<2, 2, true>(len, streams)),
        (3, true) => out[..3].copy_from_slice(&dispatch_second::<3, 2, true>(len, streams)),
        (_, true) => out[..4].copy_from_slice(&dispatch_second::<4, 2, true>(len, streams)),
    }
}

/// Index of the (near, far) streams of τ number c.
#[inline(always)]
const fn pair_of<const PAIRS: bool>(c: usize) -> (usize, usize) {
    if PAIRS {
        (2 * c + 1, 2 * c + 2)
    } else {
        (c + 1, c + 2)
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

/// Lanes per register.
const W: usize = 4;
/// Registers per τ of the third-difference kernel.
const R3: usize = 4;

fn dispatch_second<const T: usize, const R: usize, const PAIRS: bool>(
    len: usize,
    streams: &[&[f64]],
) -> [f64; T] {
    #[cfg(target_arch = "x86_64")]
    if has_avx2_fma() {
        // SAFETY: AVX2 and FMA are available (checked above); `group_second` asserted the streams
        // of the layout are there with at least `len` values, which is all the function reads.
        return unsafe { avx2::second::<T, R, PAIRS>(len, streams) };
    }
    second_portable::<T, R, PAIRS>(len, streams)
}

#[cfg(target_arch = "x86_64")]
fn has_avx2_fma() -> bool {
    std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma")
}

/// Lane sums (register r, lane w at index r·4 + w) added in order, then the tail.
fn finish<const R: usize>(lanes: &[[f64; W]; R], tail: f64) -> f64 {
    lanes.iter().flatten().sum::<f64>() + tail
}

fn second_portable<const T: usize, const R: usize, const PAIRS: bool>(
    len: usize,
    streams: &[&[f64]],
) -> [f64; T] {
    let mut acc = [[[0.0f64; W]; R]; T];
    let step = W * R;
    let full = len - len % step;
    for i in (0..full).step_by(step) {
        for r in 0..R {
            let at = i + r * W;
            let base = &streams[0][at..at + W];
            let mut d = [0.0f64; W];
            if !PAIRS {
                let near = &streams[1][at..at + W];
                d = std::array::from_fn(|l| near[l] - base[l]);
            }
            for (c, lanes) in acc.iter_mut().enumerate() {
                let (n, f) = pair_of::<PAIRS>(c);
                if PAIRS {
                    let near = &streams[n][at..at + W];
                    d = std::array::from_fn(|l| near[l] - base[l]);
                }
                let far = &streams[f][at..at + W];
                for l in 0..W {
                    let e = far[l] - base[l];
                    let v = (-2.0f64).mul_add(d[l], e);
                    lanes[r][l] = v.mul_add(v, lanes[r][l]);
                    d[l] = e;
                }
            }
        }
    }
    let mut out = [0.0f64; T];
    for (c, slot) in out.iter_mut().enumerate() {
        let (n, f) = pair_of::<PAIRS>(c);
        *slot = finish(
            &acc[c],
            tail_second(full, len, streams[0], streams[n], streams[f]),
        );
    }
    out
}

fn tail_second(from: usize, len: usize, base: &[f64], near: &[f64], far: &[f64]) -> f64 {
    let mut tail = 0.0f64;
    for k in from..len {
        let (b, n, f) = (base[k], near[k], far[k]);
        let v = (-2.0f64).mul_add(n - b, f - b);
        tail = v.mul_add(v, tail);
    }
    tail
}

fn third_portable(len: usize, streams: &[&[f64]]) -> f64 {
    let mut acc = [[0.0f64; W]; R3];
    let step = W * R3;
    let full = len - len % step;
    for i in (0..full).step_by(step) {
        for (r, lanes) in acc.iter_mut().enumerate() {
            for (l, lane) in lanes.iter_mut().enumerate() {
                let v = third_term(streams, i + r * W + l);
                *lane = v.mul_add(v, *lane);
            }
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
    //! The same arithmetic as the portable loops, one 256-bit register per four lanes;
    //! `_mm256_fmadd_pd` is `f64::mul_add` lane by lane.

    use core::arch::x86_64::{
        __m256d, _mm256_fmadd_pd, _mm256_loadu_pd, _mm256_set1_pd, _mm256_setzero_pd,
        _mm256_storeu_pd, _mm256_sub_pd,
    };

    use super::{finish, pair_of, tail_second, tail_third, MAX_STREAMS, R3, W};

    /// # Safety
    /// The CPU must support AVX2 and FMA; `streams` must hold the streams of the layout, each of
    /// at least `len` values.
    #[target_feature(enable = "avx2,fma")]
    pub(super) unsafe fn second<const T: usize, const R: usize, const PAIRS: bool>(
        len: usize,
        streams: &[&[f64]],
    ) -> [f64; T] {
        let mut ptr = [std::ptr::null::<f64>(); MAX_STREAMS];
        for (p, s) in ptr.iter_mut().zip(streams) {
            *p = s.as_ptr();
        }
        let mut acc = [[_mm256_setzero_pd(); R]; T];
        let minus_two = _mm256_set1_pd(-2.0);
        let step = W * R;
        let full = len - len % step;
        let mut i = 0;
        while i < full {
            // SAFETY (all loads): i + 4R ≤ full ≤ len and every stream holds ≥ len values.
            let mut base = [_mm256_setzero_pd(); R];
            let mut d = [_mm256_setzero_pd(); R];
            for r in 0..R {
                base[r] = _mm256_loadu_pd(ptr[0].add(i + r * W));
                if !PAIRS {
                    d[r] = _mm256_sub_pd(_mm256_loadu_pd(ptr[1].add(i + r * W)), base[r]);
                }
            }
            for (c, lanes) in acc.iter_mut().enumerate() {
                let (n, f) = pair_of::<PAIRS>(c);
                for r in 0..R {
                    if PAIRS {
                        d[r] = _mm256_sub_pd(_mm256_loadu_pd(ptr[n].add(i + r * W)), base[r]);
                    }
                    let e = _mm256_sub_pd(_mm256_loadu_pd(ptr[f].add(i + r * W)), base[r]);
                    let v = _mm256_fmadd_pd(minus_two, d[r], e);
                    lanes[r] = _mm256_fmadd_pd(v, v, lanes[r]);
                    d[r] = e;
                }
            }
            i += step;
        }
        let mut out = [0.0f64; T];
        for (c, slot) in out.iter_mut().enumerate() {
            let (n, f) = pair_of::<PAIRS>(c);
            let tail = tail_second(full, len, streams[0], streams[n], streams[f]);
            *slot = finish(&lanes(&acc[c]), tail);
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
        let mut acc = [_mm256_setzero_pd(); R3];
        let step = W * R3;
        let full = len - len % step;
        let mut i = 0;
        while i < full {
            for (r, lane) in acc.iter_mut().enumerate() {
                let at = i + r * W;
                // SAFETY: at + 4 ≤ full ≤ len, every stream holds ≥ len values.
                let s0 = _mm256_loadu_pd(p[0].add(at));
                let s1 = _mm256_loadu_pd(p[1].add(at));
                let s2 = _mm256_loadu_pd(p[2].add(at));
                let s3 = _mm256_loadu_pd(p[3].add(at));
                let (f0, f1, f2) = (
                    _mm256_sub_pd(s1, s0),
                    _mm256_sub_pd(s2, s1),
                    _mm256_sub_pd(s3, s2),
                );
                let v = _mm256_sub_pd(_mm256_sub_pd(f2, f1), _mm256_sub_pd(f1, f0));
                *lane = _mm256_fmadd_pd(v, v, *lane);
            }
            i += step;
        }
        finish(&lanes(&acc), tail_third(full, len, streams))
    }

    #[target_feature(enable = "avx2,fma")]
    unsafe fn lanes<const R: usize>(acc: &[__m256d; R]) -> [[f64; W]; R] {
        let mut out = [[0.0f64; W]; R];
        for (o, a) in out.iter_mut().zip(acc) {
            // SAFETY: each `o` has room for 4 values.
            _mm256_storeu_pd(o.as_mut_ptr(), *a);
        }
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
    fn groups_match_plain_loops() {
        let s = data(3000);
        let m = 7;
        let chain: Vec<&[f64]> = [0, m, 2 * m, 4 * m, 8 * m, 16 * m]
            .iter()
            .map(|&o| &s[o..])
            .collect();
        let ms = [3usize, 10, 11, 40];
        let mut offsets = vec![0];
        for &t in &ms {
            offsets.extend([t, 2 * t]);
        }
        let pairs: Vec<&[f64]> = offsets.iter().map(|&o| &s[o..]).collect();
        let direct = |t: usize, len: usize| -> f64 {
            (0..len)
                .map(|k| (s[k + 2 * t] - 2.0 * s[k + t] + s[k]).powi(2))
                .sum()
        };
        for len in [0, 1, 7, 8, 9, 17, 100, 333] {
            for taus in 1..=MAX_GROUP {
                let mut out = [0.0; MAX_GROUP];
                group_second(len, taus, Layout::Chain, &chain[..taus + 2], &mut out);
                for (c, got) in out[..taus].iter().enumerate() {
                    let want = direct(m << c, len);
                    assert!((got - want).abs() <= 1e-12 * want.max(1.0), "{len} {c}");
                }
                group_second(len, taus, Layout::Pairs, &pairs[..2 * taus + 1], &mut out);
                for (c, got) in out[..taus].iter().enumerate() {
                    let want = direct(ms[c], len);
                    assert!(
                        (got - want).abs() <= 1e-12 * want.max(1.0),
                        "{len} pairs {c}"
                    );
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
    fn dispatch_is_bit_identical_to_portable() {
        let s = data(20_000);
        let m = 5;
        let chain: Vec<&[f64]> = [0, m, 2 * m, 4 * m, 8 * m, 16 * m]
            .iter()
            .map(|&o| &s[o..])
            .collect();
        let pairs: Vec<&[f64]> = [0, 3, 6, 9, 18, 100, 200, 101, 202]
            .iter()
            .map(|&o| &s[o..])
            .collect();
        for len in [3, 64, 999, 4000] {
            let mut out = [0.0; MAX_GROUP];
            group_second(len, 4, Layout::Chain, &chain, &mut out);
            assert_eq!(
                out.map(f64::to_bits),
                second_portable::<4, 2, false>(len, &chain).map(f64::to_bits)
            );
            group_second(len, 4, Layout::Pairs, &pairs, &mut out);
            assert_eq!(
                out.map(f64::to_bits),
                second_portable::<4, 2, true>(len, &pairs).map(f64::to_bits)
            );
            group_second(len, 1, Layout::Chain, &chain[..3], &mut out);
            assert_eq!(
                out[0].to_bits(),
                second_portable::<1, 4, false>(len, &chain[..3])[0].to_bits()
            );
            let st3 = [&s[..], &s[m..], &s[2 * m..], &s[3 * m..]];
            assert_eq!(
                third(len, &st3).to_bits(),
                third_portable(len, &st3).to_bits()
            );
        }
    }
}
