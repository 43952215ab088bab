// Four-step FFT, second half: transform every row k2 of the M2 x M1 matrix left by fft_columns over
// j1 (length M1, contiguous, in workgroup memory) and write the result in natural order,
// Z[k2 + M2*k1], to `spectrum`.
// Prepended by fft_common.wgsl and welch_common.wgsl. CPU mirror: fft_rows in src/gpu/mirror/fft.rs.
//
// Dispatch: (M2, segment slots, 1); one workgroup per row.

@group(0) @binding(5) var<storage, read> work: array<vec2<f32>>;
@group(0) @binding(6) var<storage, read_write> spectrum: array<vec2<f32>>;

@compute @workgroup_size(WG)
fn fft_rows(
    @builtin(workgroup_id) wg: vec3<u32>,
    @builtin(local_invocation_index) tid: u32,
) {
    let k2 = wg.x;
    let m1 = p.split;
    let m2 = p.half / m1;
    let row = wg.y * p.half;
    for (var j1 = tid; j1 < m1; j1 += WG) {
        fa[j1] = work[row + m1 * k2 + j1];
    }
    workgroupBarrier();
    let in_b = stockham_local(m1, p.nfft, tid);
    for (var k1 = tid; k1 < m1; k1 += WG) {
        spectrum[row + k2 + m2 * k1] = local_result(in_b, k1);
    }
}
