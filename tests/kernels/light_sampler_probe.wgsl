// tests/lights_gpu_sampler.rs: light_sample / light_pmf per query (or, for
// a query with a subtree, light_sample_subtree / light_pmf_subtree) and
// select_cut per representative, through wgsl/lights/sample.wgsl.
struct Query { p: vec3<f32>, u: f32, n: vec3<f32>, cut_base: u32, probe: u32, subtree: u32, _p1: u32, _p2: u32 }
struct Answer { light: u32, pmf_m: f32, pmf_e: i32, sampled_m: f32, sampled_e: i32, probe_m: f32, probe_e: i32, _pad: u32 }
struct Rep { p: vec3<f32>, _p0: u32, n: vec3<f32>, _p1: u32 }

@group(0) @binding(0) var<storage, read> queries: array<Query>;
@group(0) @binding(1) var<storage, read_write> answers: array<Answer>;
@group(0) @binding(2) var<storage, read> reps: array<Rep>;
@group(0) @binding(3) var<storage, read_write> cut_out: array<u32>;

@compute @workgroup_size(64)
fn sample_main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = gid.x;
    if (i >= arrayLength(&queries)) {
        return;
    }
    let q = queries[i];
    let mixture = q.subtree == 0xffffffffu;
    var pick: LightPick;
    if (mixture) {
        pick = light_sample(q.p, q.n, q.cut_base, q.u);
    } else {
        pick = light_sample_subtree(q.p, q.n, q.cut_base, q.subtree, q.u);
    }
    var sampled = LightPmf(0.0, 0);
    if (pick.light != NO_LIGHT && (pick.light & LIGHT_SUBSTITUTE_BIT) != 0u) {
        // A substitute (sst) is no light: light_pmf has nothing to say.
        sampled = LightPmf(pick.pmf_m, pick.pmf_e);
    } else if (pick.light != NO_LIGHT && mixture) {
        sampled = light_pmf(q.p, q.n, q.cut_base, pick.light);
    } else if (pick.light != NO_LIGHT) {
        sampled = light_pmf_subtree(q.p, q.n, q.cut_base, pick.light);
    }
    var probe = light_pmf(q.p, q.n, q.cut_base, q.probe);
    if (!mixture) {
        probe = light_pmf_subtree(q.p, q.n, q.cut_base, q.probe);
    }
    answers[i] = Answer(pick.light, pick.pmf_m, pick.pmf_e, sampled.m, sampled.e, probe.m, probe.e, 0u);
}

@compute @workgroup_size(64)
fn cut_main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let b = gid.x;
    if (b >= arrayLength(&reps)) {
        return;
    }
    var cut: array<u32, MAX_CUT>;
    let len = select_cut(reps[b].p, reps[b].n, &cut);
    for (var j = 0u; j < MAX_CUT; j++) {
        cut_out[b * (MAX_CUT + 1u) + j] = select(NO_LIGHT, cut[j], j < len);
    }
    cut_out[b * (MAX_CUT + 1u) + MAX_CUT] = len;
}
