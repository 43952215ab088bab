// Four-step FFT, second half: transform every row k2 of the M2 x M1 matrix left by fft_columns over
// j1 (length M1, contiguous, in workgroup memory) and write the result in natural order,
// Z[k2 + M2*k1], to `spectrum`.
// Prepended by fft_common.wgsl and welch_common.wgsl. CPU mirror: fft_rows in src/gpu/mirror/fft.rs.
//
// Dispatch: (M2 / R, segment slots, 1), R = per_group(M2, M1) rows per workgroup, so that the
// strided writes of the natural order come in runs of R consecutive values. Each row's arithmetic
// is the same as with one row per workgroup.

@group(0) @binding(5) var<storage, read> work: array<vec2<f32>>;
@group(0) @binding(6) var<storage, read_write> spectrum: array<vec2<f32>>;

@compute @workgroup_size(WG)
fn fft_rows(
    @builtin(workgroup_id) wg: vec3<u32>,
    @builtin(local_invocation_index) tid: u32,
) {
    let m1 = p.split;
    let m2 = p.half / m1;
    let rows = per_group(m2, m1);
    let r_shift = firstTrailingBit(rows);
    let first = wg.x * rows;
    let row = wg.y * p.half;
    // The group's rows are contiguous in `work`: row c of the group in fa[c*M1, (c+1)*M1).
    for (var i = tid; i < rows * m1; i += WG) {
        fa[i] = work[row + m1 * first + i];
    }
    workgroupBarrier();
    let in_b = stockham_batch(m1, rows, p.nfft, tid);
    // Value i: row c = i mod R, k1 = i / R, written to Z[k2 + M2*k1] with k2 = first + c.
    for (var i = tid; i < rows * m1; i += WG) {
        let c = i & (rows - 1u);
        let k1 = i >> r_shift;
        spectrum[row + first + c + m2 * k1] = local_result(in_b, c * m1 + k1);
    }
}
