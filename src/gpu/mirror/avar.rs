//! CPU mirror of `shaders/avar_octave.wgsl`, `avar_prefix_f64.wgsl` and `avar_prefix_fixed.wgsl`,
//! line for line: per-thread sums over the same items, then the same two-level workgroup sum.

use crate::gpu::avar::{OctaveParams, PrefixParams};

const WG: u32 = 256;
const ITEMS: u32 = 16;

/// Two levels of 16, as the kernels reduce `red`.
fn reduce<T: Copy + Default + std::ops::Add<Output = T>>(red: &[T]) -> T {
    let mut level = [T::default(); 16];
    for (tid, l) in level.iter_mut().enumerate() {
        let mut t = T::default();
        for q in 0..16 {
            t = t + red[tid * 16 + q];
        }
        *l = t;
    }
    let mut t = T::default();
    for l in level {
        t = t + l;
    }
    t
}

/// `avar_octave` over `groups` workgroups: writes the next level (when asked) and one partial sum
/// per workgroup.
pub fn avar_octave(
    p: &OctaveParams,
    lo: &[f32],
    hi: &[f32],
    next: &mut [f32],
    partials: &mut [f32],
    groups: u32,
) {
    for wg in 0..groups {
        let first = wg * WG * ITEMS;
        let mut red = [0.0f32; WG as usize];
        for (tid, r) in red.iter_mut().enumerate() {
            let mut s = 0.0f32;
            for q in 0..ITEMS {
                let i = first + q * WG + tid as u32;
                if i < p.count {
                    let a = lo[(p.lo_off + i) as usize];
                    let b = hi[(p.hi_off + i) as usize];
                    let d = b - a;
                    s += d * d;
                    if p.write_next == 1 {
                        next[(p.next_off + i) as usize] = 0.5 * (a + b);
                    }
                }
            }
            *r = s;
        }
        partials[(p.partial_base + wg) as usize] = reduce(&red);
    }
}

/// `avar_prefix_f64` over `groups` workgroups.
pub fn avar_prefix_f64(
    p: &PrefixParams,
    s0: &[f64],
    s1: &[f64],
    s2: &[f64],
    partials: &mut [f64],
    groups: u32,
) {
    for wg in 0..groups {
        let first = wg * WG * ITEMS;
        let mut red = [0.0f64; WG as usize];
        for (tid, r) in red.iter_mut().enumerate() {
            let mut s = 0.0f64;
            for q in 0..ITEMS {
                let j = first + q * WG + tid as u32;
                if j < p.count {
                    let d = s2[(p.off2 + j) as usize] - 2.0 * s1[(p.off1 + j) as usize]
                        + s0[(p.off0 + j) as usize];
                    s += d * d;
                }
            }
            *r = s;
        }
        partials[(p.partial_base + wg) as usize] = reduce(&red);
    }
}

/// a − b in 64-bit two's complement.
pub fn sub64(a: [u32; 2], b: [u32; 2]) -> [u32; 2] {
    let borrow = u32::from(a[0] < b[0]);
    [
        a[0].wrapping_sub(b[0]),
        a[1].wrapping_sub(b[1]).wrapping_sub(borrow),
    ]
}

/// The signed value as f32, rounded from its magnitude.
pub fn to_f32(a: [u32; 2]) -> f32 {
    let negative = (a[1] & 0x8000_0000) != 0;
    let mut m = a;
    if negative {
        m = sub64([0, 0], a);
    }
    let v = m[1] as f32 * 4_294_967_296.0 + m[0] as f32;
    if negative {
        -v
    } else {
        v
    }
}

/// `avar_prefix_fixed` over `groups` workgroups.
pub fn avar_prefix_fixed(
    p: &PrefixParams,
    s0: &[[u32; 2]],
    s1: &[[u32; 2]],
    s2: &[[u32; 2]],
    partials: &mut [f32],
    groups: u32,
) {
    for wg in 0..groups {
        let first = wg * WG * ITEMS;
        let mut red = [0.0f32; WG as usize];
        for (tid, r) in red.iter_mut().enumerate() {
            let mut s = 0.0f32;
            for q in 0..ITEMS {
                let j = first + q * WG + tid as u32;
                if j < p.count {
                    let a = s0[(p.off0 + j) as usize];
                    let b = s1[(p.off1 + j) as usize];
                    let c = s2[(p.off2 + j) as usize];
                    let d = to_f32(sub64(sub64(c, b), sub64(b, a))) * p.scale;
                    s += d * d;
                }
            }
            *r = s;
        }
        partials[(p.partial_base + wg) as usize] = reduce(&red);
    }
}
