// Four-step FFT, first half: for a row of M = NFFT/2 values viewed as an M2 x M1 matrix,
// z[j1 + M1*j2], transform every column j1 over j2 (length M2, in workgroup memory), multiply by
// exp(-2*pi*i*j1*k2/M) and write back in place at [j1 + M1*k2]. fft_rows finishes the transform.
// Prepended by fft_common.wgsl and welch_common.wgsl. CPU mirror: fft_columns in
// src/gpu/mirror/fft.rs.
//
// Dispatch: (M1 / C, segment slots, 1), C = per_group(M1, M2) columns per workgroup, so that
// consecutive threads read and write consecutive j1 (runs of C values) rather than one column at
// a stride of M1 values (a separate memory transaction per value). Each column's arithmetic is
// the same as with one column per workgroup.

@group(0) @binding(5) var<storage, read_write> work: array<vec2<f32>>;

@compute @workgroup_size(WG)
fn fft_columns(
    @builtin(workgroup_id) wg: vec3<u32>,
    @builtin(local_invocation_index) tid: u32,
) {
    let m1 = p.split;
    let m2 = p.half / m1;
    let cols = per_group(m1, m2);
    let c_shift = firstTrailingBit(cols);
    let first = wg.x * cols;
    let row = wg.y * p.half;
    // Value i of the group: column c = i mod C, element j2 = i / C; column c in fa[c*M2, (c+1)*M2).
    for (var i = tid; i < cols * m2; i += WG) {
        let c = i & (cols - 1u);
        let j2 = i >> c_shift;
        fa[c * m2 + j2] = work[row + first + c + m1 * j2];
    }
    workgroupBarrier();
    let in_b = stockham_batch(m2, cols, p.nfft, tid);
    for (var i = tid; i < cols * m2; i += WG) {
        let c = i & (cols - 1u);
        let k2 = i >> c_shift;
        let j1 = first + c;
        // exp(-2*pi*i*j1*k2/M) = tw(2*j1*k2), and j1*k2 < M1*M2 = M.
        work[row + j1 + m1 * k2] = cmul(local_result(in_b, c * m2 + k2), tw(2u * j1 * k2));
    }
}
