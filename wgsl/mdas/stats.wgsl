// Once per render, after the last evaluation: `stats` counts the
// non-finite samples (C_NONFINITE) and finds the largest finite |f| per
// channel (C_MAXABS, f32 bits: for non-negative floats the order of the
// bits is the order of the values) over all S_SAMPLES samples; then one
// invocation of `fixed_scale` turns the maximum into the reconstruction's
// fixed-point exponent (S_FIXED_EXP, read back by the host to decode the
// sums). Kept out of evaluate.wgsl so that the integrand runs without
// barriers or atomics around it.
// Invocation i of T = ⌈n / STATS_PER_INVOCATION⌉ reads samples i + j·T.

var<workgroup> wg_nonfinite: array<u32, WG>;
var<workgroup> wg_maxabs: array<vec3<u32>, WG>;

@compute @workgroup_size(WG)
fn stats(@builtin(global_invocation_id) gid: vec3<u32>,
         @builtin(local_invocation_index) lid: u32,
         @builtin(num_workgroups) groups: vec3<u32>) {
    let i = thread_index(gid, groups, WG);
    let n = state[S_SAMPLES];
    let threads = (n + STATS_PER_INVOCATION - 1u) / STATS_PER_INVOCATION;
    var nonfinite = 0u;
    var maxabs = vec3<u32>(0u);
    if (i < threads) {
        for (var s = i; s < n; s += threads) {
            let bits = sample_value_bits(s);
            if (finite_bits(bits)) {
                maxabs = max(maxabs, bits & vec3<u32>(0x7fffffffu));
            } else {
                nonfinite += 1u;
            }
        }
    }
    // Two-level reduction (three barriers, as workgroup_scan).
    wg_nonfinite[lid] = nonfinite;
    wg_maxabs[lid] = maxabs;
    workgroupBarrier();
    if (lid < WG / SEGMENT) {
        var n = 0u;
        var m = vec3<u32>(0u);
        for (var i = 0u; i < SEGMENT; i++) {
            n += wg_nonfinite[lid * SEGMENT + i];
            m = max(m, wg_maxabs[lid * SEGMENT + i]);
        }
        wg_nonfinite[lid * SEGMENT] = n;
        wg_maxabs[lid * SEGMENT] = m;
    }
    workgroupBarrier();
    if (lid == 0u) {
        var n = 0u;
        var m = vec3<u32>(0u);
        for (var i = 0u; i < WG / SEGMENT; i++) {
            n += wg_nonfinite[i * SEGMENT];
            m = max(m, wg_maxabs[i * SEGMENT]);
        }
        if (n > 0u) {
            atomicAdd(&counters[C_NONFINITE], n);
        }
        for (var c = 0u; c < 3u; c++) {
            atomicMax(&counters[C_MAXABS + c], m[c]);
        }
    }
}

// 60 − ⌈log2 max|f|⌉ over the channels, clamped to −100..=128 (so a
// pixel's |Σ w·f̄| < 2^61, reconstruct.wgsl); 60 when no finite sample is
// non-zero. ⌈log2 x⌉ of a normal f32 is its exponent, plus one unless the
// mantissa is zero; a subnormal maximum clamps to 128.
@compute @workgroup_size(1)
fn fixed_scale() {
    var bits = 0u;
    for (var c = 0u; c < 3u; c++) {
        bits = max(bits, atomicLoad(&counters[C_MAXABS + c]));
    }
    var e = 60;
    let biased = i32(bits >> 23u);
    if (bits != 0u && biased == 0) {
        e = 128;
    } else if (bits != 0u) {
        let ceil_log2 = biased - 127 + select(1, 0, (bits & 0x7fffffu) == 0u);
        e = clamp(60 - ceil_log2, -100, 128);
    }
    state[S_FIXED_EXP] = bitcast<u32>(e);
}
