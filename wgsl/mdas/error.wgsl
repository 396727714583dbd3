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
// as u32 is the maximum of the floats: one atomicMax per workgroup.

var<workgroup> wg_max: array<u32, WG>;

fn leaf_error(k: u32) -> f32 {
    let base = leaf_base(k);
    let h = leaves_get(base + 1u);
    let head = header_head(h);
    let count = header_count(h);
    let m = leaf_mean(head, count);
    var contrast = 0.0;
    if (m.finite > 0u) {
        var dev = vec3<f32>(0.0);
        let inv_n = 1.0 / f32(m.finite);
        var s = head;
        for (var i = 0u; i < count; i++) {
            let bits = sample_value_bits(s);
            if (finite_bits(bits)) {
                dev += abs(bitcast<vec3<f32>>(bits) - m.mean) * inv_n;
            }
            s = sample_next(s);
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

@compute @workgroup_size(WG)
fn error(@builtin(global_invocation_id) gid: vec3<u32>,
         @builtin(local_invocation_index) lid: u32,
         @builtin(num_workgroups) groups: vec3<u32>) {
    let k = thread_index(gid, groups, WG);
    var bits = 0u;
    if (k < leaf_count()) {
        let base = leaf_base(k);
        if (!header_collapsed(leaves_get(base + 1u))) {
            bits = leaves_get(base + 2u);
            if (bits == DIRTY) {
                bits = bitcast<u32>(leaf_error(k));
                leaves_set(base + 2u, bits);
            }
        }
    }
    // Two-level maximum (three barriers, as workgroup_scan).
    wg_max[lid] = bits;
    workgroupBarrier();
    if (lid < WG / SEGMENT) {
        var m = 0u;
        for (var i = 0u; i < SEGMENT; i++) {
            m = max(m, wg_max[lid * SEGMENT + i]);
        }
        wg_max[lid * SEGMENT] = m;
    }
    workgroupBarrier();
    if (lid == 0u) {
        var m = 0u;
        for (var i = 0u; i < WG / SEGMENT; i++) {
            m = max(m, wg_max[i * SEGMENT]);
        }
        atomicMax(&counters[C_EMAX], m);
    }
}
