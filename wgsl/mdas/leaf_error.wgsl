// Per-leaf contrast error (paper eq. 4), shared by error.wgsl (the
// initial grid's cells) and evaluate.wgsl (the leaves an iteration
// changed, once their new sample is evaluated).
//
// E = V·(ε + c), V the leaf's volume in the normalized domain [0,1)^d and c
// the mean over RGB of each channel's contrast mean|f − f̄| / |f̄| over the
// leaf's finite samples. A channel whose contrast is undefined or large is
// clamped: c_ch = 0 when every sample equals f̄ (all-zero included), else
// min(mean|f − f̄| / |f̄|, 2) evaluated as "2 when mean|f − f̄| ≥ 2|f̄|", so
// f̄ = 0 never divides (for f ≥ 0 the ratio is below 2 anyway). A leaf with
// no finite sample gets c = 0. E is finite and non-negative, so the
// maximum of its bits as u32 is the maximum of the floats.

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
