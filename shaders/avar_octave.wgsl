// Overlapping Allan variance at octave taus: one level of the pairwise-mean pyramid.
// With M_m[i] the mean of the m samples from i (M_1 = the mean-subtracted data),
//   term_i = (M_m[i+m] - M_m[i])^2,   M_2m[i] = (M_m[i] + M_m[i+m])/2,   i in [0, N - 2m],
// and sigma^2(m*tau0) = mean(term)/2. Every value stored is a mean of data values, never a running
// sum, so f32 storage keeps about 1e-7 relative accuracy at every level.
// CPU mirror: avar_octave in src/gpu/mirror/avar.rs.
//
// One dispatch covers terms [i0, i0 + count) of one channel and level; `lo`, `hi` and `next` are
// windows of the level buffers that start at (or just before, by the binding alignment) i0, i0 + m
// and i0. Each workgroup writes the f32 sum of its terms to `partials`; the host adds them in f64.
// Dispatch: (ceil(count / (WG*ITEMS)), 1, 1).

const WG: u32 = 256u;
const ITEMS: u32 = 16u;

// Keep in sync with `OctaveParams` in src/gpu/avar/params.rs.
struct OctaveParams {
    count: u32,
    // Element offsets of i0 (lo, next) and i0 + m (hi) inside their windows.
    lo_off: u32,
    hi_off: u32,
    next_off: u32,
    // Index in `partials` of this dispatch's first workgroup.
    partial_base: u32,
    // 1 when the next level is needed, 0 at the last level.
    write_next: u32,
    _pad0: u32,
    _pad1: u32,
}

@group(0) @binding(0) var<uniform> p: OctaveParams;
@group(0) @binding(1) var<storage, read> lo: array<f32>;
@group(0) @binding(2) var<storage, read> hi: array<f32>;
@group(0) @binding(3) var<storage, read_write> next: array<f32>;
@group(0) @binding(4) var<storage, read_write> partials: array<f32>;

var<workgroup> red: array<f32, 272>;

@compute @workgroup_size(WG)
fn avar_octave(
    @builtin(workgroup_id) wg: vec3<u32>,
    @builtin(local_invocation_index) tid: u32,
) {
    let first = wg.x * WG * ITEMS;
    var s = 0.0;
    for (var q = 0u; q < ITEMS; q++) {
        let i = first + q * WG + tid;
        if i < p.count {
            let a = lo[p.lo_off + i];
            let b = hi[p.hi_off + i];
            let d = b - a;
            s += d * d;
            if p.write_next == 1u {
                next[p.next_off + i] = 0.5 * (a + b);
            }
        }
    }
    // Workgroup sum in two levels of 16 (three barriers, at most 16 terms per partial sum).
    red[tid] = s;
    workgroupBarrier();
    if tid < 16u {
        var t = 0.0;
        for (var q = 0u; q < 16u; q++) {
            t += red[tid * 16u + q];
        }
        red[WG + tid] = t;
    }
    workgroupBarrier();
    if tid == 0u {
        var t = 0.0;
        for (var q = 0u; q < 16u; q++) {
            t += red[WG + q];
        }
        partials[p.partial_base + wg.x] = t;
    }
}
