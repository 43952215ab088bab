// Welch: sum |X_k|^2 over the segments of each channel in a batch and add the sums to the running
// per-channel sums in `acc` (kept on the GPU between batches; the host reads them, and restarts
// them, at the end of each push and every 16 batches within one).
// CPU mirror: welch_accumulate in src/gpu/mirror/welch.rs.
//
// Dispatch: (ceil(bins/WG), channels, 1); one thread per (bin, channel), reading one column of
// `power` (consecutive threads read consecutive bins).

const WG: u32 = 256u;
// Segment terms per block: a block's sum holds at most BLOCK terms before it joins the total, so a
// batch of S segments costs at most BLOCK + S/BLOCK roundings instead of S.
const BLOCK: u32 = 32u;

// Keep in sync with `AccumulateParams` in src/gpu/welch/params.rs.
struct AccumulateParams {
    bins: u32,
    // Segments per channel in this batch.
    segments: u32,
    // 1: overwrite `acc` (first batch after a read-back), 0: add to it.
    reset: u32,
    _pad: u32,
}

@group(0) @binding(0) var<uniform> q: AccumulateParams;
@group(0) @binding(1) var<storage, read> power: array<f32>;
@group(0) @binding(2) var<storage, read_write> acc: array<f32>;

@compute @workgroup_size(WG)
fn welch_accumulate(
    @builtin(workgroup_id) wg: vec3<u32>,
    @builtin(local_invocation_index) tid: u32,
) {
    let k = wg.x * WG + tid;
    if k >= q.bins {
        return;
    }
    let ch = wg.y;
    var outer = 0.0;
    var inner = 0.0;
    for (var s = 0u; s < q.segments; s++) {
        inner += power[(ch * q.segments + s) * q.bins + k];
        if (s % BLOCK) == BLOCK - 1u {
            outer += inner;
            inner = 0.0;
        }
    }
    let i = ch * q.bins + k;
    var prior = 0.0;
    if q.reset == 0u {
        prior = acc[i];
    }
    acc[i] = prior + (outer + inner);
}
