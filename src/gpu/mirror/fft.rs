//! CPU mirror of `shaders/fft_common.wgsl`, `shaders/fft_columns.wgsl` and `shaders/fft_rows.wgsl`:
//! the same functions with the same names, constants and loop structure, in f32, one workgroup
//! simulated thread by thread where the order of operations depends on the thread.

use crate::gpu::welch::WelchParams;

/// Threads per workgroup (`WG`).
pub const WG: u32 = 256;

/// A complex value (re, im), as `vec2<f32>`.
pub type C32 = [f32; 2];

/// The two workgroup arrays `fa` and `fb` (LOCAL_MAX values each).
#[derive(Debug, Clone)]
pub struct Workgroup {
    pub fa: Vec<C32>,
    pub fb: Vec<C32>,
}

impl Workgroup {
    pub fn new(local_max: u32) -> Workgroup {
        Workgroup {
            fa: vec![[0.0; 2]; local_max as usize],
            fb: vec![[0.0; 2]; local_max as usize],
        }
    }
}

pub fn add(a: C32, b: C32) -> C32 {
    [a[0] + b[0], a[1] + b[1]]
}

pub fn sub(a: C32, b: C32) -> C32 {
    [a[0] - b[0], a[1] - b[1]]
}

pub fn scale(s: f32, a: C32) -> C32 {
    [s * a[0], s * a[1]]
}

pub fn neg(a: C32) -> C32 {
    [-a[0], -a[1]]
}

/// `dot(x, x)`.
pub fn norm_sqr(a: C32) -> f32 {
    a[0] * a[0] + a[1] * a[1]
}

/// exp(−2πi·t/NFFT) for t in [0, NFFT), NFFT/2 = `twiddles.len()`.
pub fn tw(twiddles: &[C32], t: u32) -> C32 {
    let half = twiddles.len() as u32;
    if t < half {
        return twiddles[t as usize];
    }
    neg(twiddles[(t - half) as usize])
}

pub fn cmul(a: C32, b: C32) -> C32 {
    [a[0] * b[0] - a[1] * b[1], a[0] * b[1] + a[1] * b[0]]
}

/// x·(−i).
pub fn mul_neg_i(a: C32) -> C32 {
    [a[1], -a[0]]
}

/// One radix-2 or radix-4 Stockham stage over `len` values (see the WGSL for the formula).
pub fn stockham_stage(
    wg: &mut Workgroup,
    twiddles: &[C32],
    len: u32,
    radix: u32,
    ns: u32,
    nfft_over: u32,
    a_to_b: bool,
) {
    let quarter = len / radix;
    let (src, dst) = if a_to_b {
        (&wg.fa, &mut wg.fb)
    } else {
        (&wg.fb, &mut wg.fa)
    };
    for tid in 0..WG {
        let mut j = tid;
        while j < quarter {
            let k = j & (ns - 1);
            let out = ((j - k) * radix + k) as usize;
            let (q, ns_) = (quarter as usize, ns as usize);
            let ju = j as usize;
            if radix == 4 {
                let v0 = src[ju];
                let mut v1 = src[ju + q];
                let mut v2 = src[ju + 2 * q];
                let mut v3 = src[ju + 3 * q];
                if ns > 1 {
                    let e = k * nfft_over;
                    v1 = cmul(v1, tw(twiddles, e));
                    v2 = cmul(v2, tw(twiddles, 2 * e));
                    v3 = cmul(v3, tw(twiddles, 3 * e));
                }
                let a0 = add(v0, v2);
                let a1 = sub(v0, v2);
                let a2 = add(v1, v3);
                let a3 = mul_neg_i(sub(v1, v3));
                dst[out] = add(a0, a2);
                dst[out + ns_] = add(a1, a3);
                dst[out + 2 * ns_] = sub(a0, a2);
                dst[out + 3 * ns_] = sub(a1, a3);
            } else {
                let v0 = src[ju];
                let mut v1 = src[ju + q];
                if ns > 1 {
                    v1 = cmul(v1, tw(twiddles, k * nfft_over));
                }
                dst[out] = add(v0, v1);
                dst[out + ns_] = sub(v0, v1);
            }
            j += WG;
        }
    }
}

/// Forward FFT of the `len` values in `fa`; true when the result is in `fb`.
pub fn stockham_local(wg: &mut Workgroup, twiddles: &[C32], len: u32, nfft: u32) -> bool {
    let mut ns = 1u32;
    let mut a_to_b = true;
    let log2len = len.trailing_zeros();
    if (log2len & 1) == 1 {
        stockham_stage(wg, twiddles, len, 2, ns, nfft / 2, a_to_b);
        ns = 2;
        a_to_b = !a_to_b;
    }
    while ns < len {
        stockham_stage(wg, twiddles, len, 4, ns, nfft / (ns * 4), a_to_b);
        ns *= 4;
        a_to_b = !a_to_b;
    }
    !a_to_b
}

pub fn local_result(wg: &Workgroup, in_b: bool, i: u32) -> C32 {
    if in_b {
        return wg.fb[i as usize];
    }
    wg.fa[i as usize]
}

/// X_k of the real sequence from Z_{k mod M} and Z_{(M−k) mod M}.
pub fn twist(twiddles: &[C32], zk: C32, zmk: C32, k: u32) -> C32 {
    let c = [zmk[0], -zmk[1]];
    let e = scale(0.5, add(zk, c));
    let o = scale(0.5, mul_neg_i(sub(zk, c)));
    add(e, cmul(tw(twiddles, k), o))
}

/// Workgroup sum of one value per thread, in the kernel's order: 16 sums of 16, then the 16 sums
/// (every thread forms the total itself; they all get the same).
pub fn workgroup_sum(wg: &mut Workgroup, v: &[C32]) -> C32 {
    let wgs = WG as usize;
    wg.fb[..wgs].copy_from_slice(&v[..wgs]);
    for tid in 0..16 {
        let mut s = [0.0f32; 2];
        for q in 0..16 {
            s = add(s, wg.fb[tid * 16 + q]);
        }
        wg.fb[wgs + tid] = s;
    }
    let mut total = [0.0f32; 2];
    for q in 0..16 {
        total = add(total, wg.fb[wgs + q]);
    }
    total
}

/// `fft_columns` over every column of every slot of `work` (rows of `p.half` values). The kernel
/// transforms several columns per workgroup (`per_group`), each one exactly as here.
pub fn fft_columns(
    p: &WelchParams,
    twiddles: &[C32],
    work: &mut [C32],
    slots: usize,
    local_max: u32,
) {
    let (nfft, half) = (p.nfft, p.half);
    let m1 = p.split;
    let m2 = half / m1;
    let mut wg = Workgroup::new(local_max);
    for slot in 0..slots {
        let row = slot * half as usize;
        for j1 in 0..m1 {
            for j2 in 0..m2 {
                wg.fa[j2 as usize] = work[row + (j1 + m1 * j2) as usize];
            }
            let in_b = stockham_local(&mut wg, twiddles, m2, nfft);
            for k2 in 0..m2 {
                work[row + (j1 + m1 * k2) as usize] =
                    cmul(local_result(&wg, in_b, k2), tw(twiddles, 2 * j1 * k2));
            }
        }
    }
}

/// `fft_rows` over every row of every slot: `work` (after `fft_columns`) into `spectrum`. The kernel
/// transforms several rows per workgroup, each one exactly as here.
pub fn fft_rows(
    p: &WelchParams,
    twiddles: &[C32],
    work: &[C32],
    spectrum: &mut [C32],
    slots: usize,
    local_max: u32,
) {
    let (nfft, half) = (p.nfft, p.half);
    let m1 = p.split;
    let m2 = half / m1;
    let mut wg = Workgroup::new(local_max);
    for slot in 0..slots {
        let row = slot * half as usize;
        for k2 in 0..m2 {
            for j1 in 0..m1 {
                wg.fa[j1 as usize] = work[row + (m1 * k2 + j1) as usize];
            }
            let in_b = stockham_local(&mut wg, twiddles, m1, nfft);
            for k1 in 0..m1 {
                spectrum[row + (k2 + m2 * k1) as usize] = local_result(&wg, in_b, k1);
            }
        }
    }
}
