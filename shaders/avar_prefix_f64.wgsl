// Overlapping Allan variance at any tau m*tau0 from f64 prefix sums of the mean-subtracted data,
// S_0 = 0, S_t = sum_{u<t} d_u:
//   term_j = (S_{j+2m} - 2 S_{j+m} + S_j)^2,   j in [0, N - 2m],
//   sigma^2 = sum(term) / (2 m^2 (N - 2m + 1)).
// Needs the SHADER_F64 feature; src/gpu/avar picks avar_prefix_fixed otherwise.
// CPU mirror: avar_prefix_f64 in src/gpu/mirror/avar.rs.
//
// One dispatch covers terms [j0, j0 + count) of one channel and one m; `s0`, `s1`, `s2` are windows
// of the prefix-sum buffer that start at (or just before) j0, j0 + m, j0 + 2m. Each workgroup writes
// the f64 sum of its terms to `partials`. Dispatch: (ceil(count / (WG*ITEMS)), 1, 1).

const WG: u32 = 256u;
const ITEMS: u32 = 16u;

// Keep in sync with `PrefixParams` in src/gpu/avar/params.rs.
struct PrefixParams {
    count: u32,
    off0: u32,
    off1: u32,
    off2: u32,
    partial_base: u32,
    // Used by avar_prefix_fixed only.
    scale: f32,
    _pad0: u32,
    _pad1: u32,
}

@group(0) @binding(0) var<uniform> p: PrefixParams;
@group(0) @binding(1) var<storage, read> s0: array<f64>;
@group(0) @binding(2) var<storage, read> s1: array<f64>;
@group(0) @binding(3) var<storage, read> s2: array<f64>;
@group(0) @binding(4) var<storage, read_write> partials: array<f64>;

var<workgroup> red: array<f64, 272>;

@compute @workgroup_size(WG)
fn avar_prefix_f64(
    @builtin(workgroup_id) wg: vec3<u32>,
    @builtin(local_invocation_index) tid: u32,
) {
    let first = wg.x * WG * ITEMS;
    var s = f64(0.0);
    for (var q = 0u; q < ITEMS; q++) {
        let j = first + q * WG + tid;
        if j < p.count {
            let d = s2[p.off2 + j] - 2.0 * s1[p.off1 + j] + s0[p.off0 + j];
            s += d * d;
        }
    }
    red[tid] = s;
    workgroupBarrier();
    if tid < 16u {
        var t = f64(0.0);
        for (var q = 0u; q < 16u; q++) {
            t += red[tid * 16u + q];
        }
        red[WG + tid] = t;
    }
    workgroupBarrier();
    if tid == 0u {
        var t = f64(0.0);
        for (var q = 0u; q < 16u; q++) {
            t += red[WG + q];
        }
        partials[p.partial_base + wg.x] = t;
    }
}
