// Overlapping Allan variance at any tau m*tau0 without f64 on the device: the same second differences
// as avar_prefix_f64, but of exact fixed-point prefix sums. The host quantises the mean-subtracted data
// to integers q_t = round(d_t / delta) with delta = A * 2^-k (A a power of two >= max|d|, k chosen
// so that no prefix sum can overflow 63 bits, at most 40), forms S_t = sum_{u<t} q_u exactly in i64 and
// uploads each S_t as two u32 words (low, high; two's complement). Here
//   D_j = S_{j+2m} - 2 S_{j+m} + S_j
// is formed exactly with carries, so no rounding happens before D_j itself is rounded once to f32:
// nothing can be lost to cancellation, and no compiler reassociation can change an integer result
// (the reason this scheme was chosen over compensated f32 arithmetic). `scale` = 2^-k turns D_j into
// units of A, which keeps the squares far from f32 overflow; the host multiplies by A^2.
// CPU mirror: avar_prefix_fixed in src/gpu/mirror/avar.rs.
//
// Dispatch and windows as avar_prefix_f64; partial sums are f32 (host adds them in f64).

const WG: u32 = 256u;
const ITEMS: u32 = 16u;

// Keep in sync with `PrefixParams` in src/gpu/avar/params.rs.
struct PrefixParams {
    count: u32,
    off0: u32,
    off1: u32,
    off2: u32,
    partial_base: u32,
    // 2^-k: D_j * scale is D_j in units of A.
    scale: f32,
    _pad0: u32,
    _pad1: u32,
}

@group(0) @binding(0) var<uniform> p: PrefixParams;
@group(0) @binding(1) var<storage, read> s0: array<vec2<u32>>;
@group(0) @binding(2) var<storage, read> s1: array<vec2<u32>>;
@group(0) @binding(3) var<storage, read> s2: array<vec2<u32>>;
@group(0) @binding(4) var<storage, read_write> partials: array<f32>;

var<workgroup> red: array<f32, 272>;

// a - b in 64-bit two's complement.
fn sub64(a: vec2<u32>, b: vec2<u32>) -> vec2<u32> {
    let borrow = select(0u, 1u, a.x < b.x);
    return vec2<u32>(a.x - b.x, a.y - b.y - borrow);
}

// The signed 64-bit value as f32, rounded from its magnitude (so that a small negative value is not
// the difference of two large numbers).
fn to_f32(a: vec2<u32>) -> f32 {
    let negative = (a.y & 0x80000000u) != 0u;
    var m = a;
    if negative {
        m = sub64(vec2<u32>(0u, 0u), a);
    }
    let v = f32(m.y) * 4294967296.0 + f32(m.x);
    return select(v, -v, negative);
}

@compute @workgroup_size(WG)
fn avar_prefix_fixed(
    @builtin(workgroup_id) wg: vec3<u32>,
    @builtin(local_invocation_index) tid: u32,
) {
    let first = wg.x * WG * ITEMS;
    var s = 0.0;
    for (var q = 0u; q < ITEMS; q++) {
        let j = first + q * WG + tid;
        if j < p.count {
            let a = s0[p.off0 + j];
            let b = s1[p.off1 + j];
            let c = s2[p.off2 + j];
            let d = to_f32(sub64(sub64(c, b), sub64(b, a))) * p.scale;
            s += d * d;
        }
    }
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
