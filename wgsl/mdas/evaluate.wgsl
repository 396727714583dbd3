// Integrand evaluation of the samples placed since the last evaluation:
// S_EVAL_FIRST .. S_EVAL_FIRST + S_EVAL_COUNT − 1 in state (written by
// the host for the initial samples and by plan.wgsl after every
// iteration; only new samples are ever evaluated). A sample's point is the
// centre of its quantum; its Morton cell was left in values[3s] by the
// kernel that placed it.
//
// Invocation i of T = ⌈count / per⌉ evaluates samples
// first + i, first + i + T, …: neighbouring invocations take neighbouring
// samples (one leaf's, or neighbouring leaves': coherent rays). On a GPU
// EVAL_PER_INVOCATION is 1 and every sample is in flight at once (the
// integrand's ray tracing is latency-bound: 4 samples per invocation
// halved the H200's throughput, BENCHMARKS.md); on a CPU adapter it is
// Halton's 8, since an invocation there costs about what eight samples
// cost (docs/conventions.md). Each invocation takes per =
// state[S_EVAL_PER] ≤ EVAL_PER_INVOCATION of them: fewer where the
// dispatch would otherwise have fewer than params.eval_min_groups
// workgroups (plan.wgsl), so that a small adaptive iteration still
// keeps every thread of a CPU adapter busy. No barrier and no atomic: the results
// are stored as they are, and stats.wgsl counts non-finite ones and finds
// max |f| once, before the reconstruction.

fn evaluate_sample(s: u32) {
    let cell = morton_decode(values_get(3u * s), DIMS, BITS_PER_DIM, EXTRA_BITS);
    var point: IntegrandPoint;
    point.film = vec2<f32>(sample_raster(0u, cell[0], sample_q(s, 0u)),
                           sample_raster(1u, cell[1], sample_q(s, 1u)));
    for (var axis = 2u; axis < DIMS; axis++) {
        point.u[axis - 2u] = sample_coord(axis, cell[axis], sample_q(s, axis));
    }
    let bits = bitcast<vec3<u32>>(integrand(&point));
    values_set(3u * s, bits.x);
    values_set(3u * s + 1u, bits.y);
    values_set(3u * s + 2u, bits.z);
}

@compute @workgroup_size(WG)
fn evaluate(@builtin(global_invocation_id) gid: vec3<u32>,
            @builtin(num_workgroups) groups: vec3<u32>) {
    let i = thread_index(gid, groups, WG);
    let count = state[S_EVAL_COUNT];
    let per = state[S_EVAL_PER];
    let invocations = (count + per - 1u) / per;
    if (i >= invocations) {
        return;
    }
    // j < per ≤ EVAL_PER_INVOCATION: the constant bound keeps the loop
    // within the integrand's loop budget (Config::eval_per_invocation).
    for (var j = 0u; j < EVAL_PER_INVOCATION; j++) {
        let n = i + j * invocations;
        if (j >= per || n >= count) {
            break;
        }
        evaluate_sample(state[S_EVAL_FIRST] + n);
    }
}
