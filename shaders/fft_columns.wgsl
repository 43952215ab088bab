// Four-step FFT, first half: for a row of M = NFFT/2 values viewed as an M2 x M1 matrix,
// z[j1 + M1*j2], transform every column j1 over j2 (length M2, in workgroup memory), multiply by
// exp(-2*pi*i*j1*k2/M) and write back in place at [j1 + M1*k2]. fft_rows finishes the transform.
// Prepended by fft_common.wgsl and welch_common.wgsl. CPU mirror: fft_columns in
// src/gpu/mirror/fft.rs.
//
// Dispatch: (M1, segment slots, 1); one workgroup per column.

@group(0) @binding(5) var<storage, read_write> work: array<vec2<f32>>;

@compute @workgroup_size(WG)
fn fft_columns(
    @builtin(workgroup_id) wg: vec3<u32>,
    @builtin(local_invocation_index) tid: u32,
) {
    let j1 = wg.x;
    let m1 = p.split;
    let m2 = p.half / m1;
    let row = wg.y * p.half;
    for (var j2 = tid; j2 < m2; j2 += WG) {
        fa[j2] = work[row + j1 + m1 * j2];
    }
    workgroupBarrier();
    let in_b = stockham_local(m2, p.nfft, tid);
    for (var k2 = tid; k2 < m2; k2 += WG) {
        // exp(-2*pi*i*j1*k2/M) = tw(2*j1*k2), and j1*k2 < M1*M2 = M.
        work[row + j1 + m1 * k2] = cmul(local_result(in_b, k2), tw(2u * j1 * k2));
    }
}
