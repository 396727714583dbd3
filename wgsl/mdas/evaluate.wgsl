// Integrand evaluation of the samples params.sample_count ..
// params.sample_count + params.eval_count − 1 (only new samples are ever
// evaluated). A sample's point is the centre of its quantum; its Morton
// cell was left in values[4s] by the kernel that placed it. Non-finite
// results are stored as they are (later excluded on their bits) and
// counted; the largest finite |f| per channel is kept for the fixed-point
// scale of the reconstruction.

var<workgroup> wg_nonfinite: atomic<u32>;
var<workgroup> wg_maxabs: array<atomic<u32>, 3>;

// The largest f32 strictly below x > 0.
fn below(x: f32) -> f32 {
    return bitcast<f32>(bitcast<u32>(x) - 1u);
}

@compute @workgroup_size(WG)
fn evaluate(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(local_invocation_index) lid: u32) {
    if (lid == 0u) {
        atomicStore(&wg_nonfinite, 0u);
        for (var c = 0u; c < 3u; c++) {
            atomicStore(&wg_maxabs[c], 0u);
        }
    }
    workgroupBarrier();
    let i = thread_index(gid);
    if (i < params.eval_count) {
        let s = params.sample_count + i;
        let cell = morton_decode(values[4u * s], DIMS, BITS_PER_DIM, EXTRA_BITS);
        var point: IntegrandPoint;
        for (var axis = 0u; axis < DIMS; axis++) {
            let x = min(axis_coord(axis, cell[axis], f32(sample_q(s, axis)) + 0.5), ONE_MINUS_EPSILON);
            if (axis == 0u) {
                point.film.x = min(x * f32(params.width), below(f32(params.width)));
            } else if (axis == 1u) {
                point.film.y = min(x * f32(params.height), below(f32(params.height)));
            } else {
                point.u[axis - 2u] = x;
            }
        }
        let f = integrand(&point);
        let bits = bitcast<vec3<u32>>(f);
        values[4u * s] = bits.x;
        values[4u * s + 1u] = bits.y;
        values[4u * s + 2u] = bits.z;
        if (finite_bits(bits)) {
            let a = bitcast<vec3<u32>>(abs(f));
            for (var c = 0u; c < 3u; c++) {
                atomicMax(&wg_maxabs[c], a[c]);
            }
        } else {
            atomicAdd(&wg_nonfinite, 1u);
        }
    }
    workgroupBarrier();
    if (lid == 0u) {
        let n = atomicLoad(&wg_nonfinite);
        if (n > 0u) {
            atomicAdd(&counters[C_NONFINITE], n);
        }
        for (var c = 0u; c < 3u; c++) {
            atomicMax(&counters[C_MAXABS + c], atomicLoad(&wg_maxabs[c]));
        }
    }
}
