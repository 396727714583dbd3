// Per-leaf contrast error (paper eq. 4) and its maximum E_max (§4.2).
//
// E = V·(ε + c), V the leaf's volume in the normalized domain [0,1)^d and c
// the mean over RGB of each channel's contrast mean|f − f̄| / |f̄| over the
// leaf's finite samples. A channel whose contrast is undefined or large is
// clamped: c_ch = 0 when every sample equals f̄ (all-zero included), else
// min(mean|f − f̄| / |f̄|, 2) evaluated as "2 when mean|f − f̄| ≥ 2|f̄|", so
// f̄ = 0 never divides (for f ≥ 0 the ratio is below 2 anyway). A leaf with
// no finite sample gets c = 0. Only leaves marked DIRTY are recomputed; the
// others keep their error from earlier iterations. Collapsed leaves take no
// part in E_max. E is finite and non-negative, so the maximum of its bits
// as u32 is the maximum of the floats: one atomicMax per workgroup into
// counters[C_EMAX].

fn leaf_error(k: u32) -> f32 {
    let base = leaf_base(k);
    let values = leaf_values(k, leaves_get(base + 1u));
    let m = values_mean(values);
    var contrast = 0.0;
    if (m.finite > 0u) {
        var dev = vec3<f32>(0.0);
        let inv_n = 1.0 / f32(m.finite);
        for (var i = 0u; i < LEAF_SAMPLES; i++) {
            if (leaf_value_finite(values, i)) {
                dev += abs(bitcast<vec3<f32>>(values.bits[i]) - m.mean) * inv_n;
            }
        }
        for (var c = 0u; c < 3u; c++) {
            let a = abs(m.mean[c]);
            if (dev[c] > 0.0) {
                if (dev[c] >= 2.0 * a) {
                    contrast += 2.0;
                } else {
                    contrast += dev[c] / a;
                }
            }
        }
        contrast *= 1.0 / 3.0;
    }
    var volume = 1.0;
    for (var axis = 0u; axis < DIMS; axis++) {
        let word = boxes_get(box_base(k) + axis);
        volume *= ldexp(f32(box_hi(word) - box_lo(word)), -i32(QUANTUM_BITS + axis_bits(axis)));
    }
    let e = volume * (params.epsilon + contrast);
    // Saturated arithmetic on huge finite values: fall back to the cap.
    if (!finite_bits(vec3<u32>(bitcast<u32>(e)))) {
        return volume * (params.epsilon + 2.0);
    }
    return e;
}

// Each invocation looks at its leaf: a DIRTY one is appended to the
// workgroup's list, any other (not collapsed) enters the workgroup's
// maximum as it is; then the first invocations compute the listed leaves'
// errors, packed (few leaves change per iteration, and a SIMD group or
// warp pays for leaf_error if any of its lanes runs it). The maximum is
// order-independent, so the list's order (atomics) changes nothing.
var<workgroup> wg_list: array<u32, WG>;
var<workgroup> wg_listed: atomic<u32>;
var<workgroup> wg_max: atomic<u32>;

@compute @workgroup_size(WG)
fn error(@builtin(global_invocation_id) gid: vec3<u32>,
         @builtin(local_invocation_index) lid: u32,
         @builtin(num_workgroups) groups: vec3<u32>) {
    let k = thread_index(gid, groups, WG);
    if (lid == 0u) {
        atomicStore(&wg_listed, 0u);
        atomicStore(&wg_max, 0u);
    }
    workgroupBarrier();
    if (k < leaf_count()) {
        let base = leaf_base(k);
        if (!header_collapsed(leaves_get(base + 1u))) {
            let bits = leaves_get(base + 2u);
            if (bits == DIRTY) {
                wg_list[atomicAdd(&wg_listed, 1u)] = k;
            } else {
                atomicMax(&wg_max, bits);
            }
        }
    }
    workgroupBarrier();
    if (lid < atomicLoad(&wg_listed)) {
        let leaf = wg_list[lid];
        let bits = bitcast<u32>(leaf_error(leaf));
        leaves_set(leaf_base(leaf) + 2u, bits);
        atomicMax(&wg_max, bits);
    }
    workgroupBarrier();
    if (lid == 0u) {
        atomicMax(&counters[C_EMAX], atomicLoad(&wg_max));
    }
}
