// Welch, last step of the multi-pass path: the real-FFT twist of the complex spectrum Z (NFFT/2 values
// per segment slot, natural order) and |X_k|^2 for k in [0, NFFT/2] into the slot's row of `power`.
// Prepended by fft_common.wgsl and welch_common.wgsl. CPU mirror: welch_power in
// src/gpu/mirror/welch.rs.
//
// Dispatch: (ceil(bins/WG), segment slots, 1).

@group(0) @binding(6) var<storage, read> spectrum: array<vec2<f32>>;
@group(0) @binding(7) var<storage, read_write> power: array<f32>;

@compute @workgroup_size(WG)
fn welch_power(
    @builtin(workgroup_id) wg: vec3<u32>,
    @builtin(local_invocation_index) tid: u32,
) {
    let k = wg.x * WG + tid;
    if k >= p.bins {
        return;
    }
    let half = p.half;
    let row = wg.y * half;
    let x = twist(spectrum[row + k % half], spectrum[row + (half - k) % half], k);
    power[wg.y * p.bins + k] = dot(x, x);
}
