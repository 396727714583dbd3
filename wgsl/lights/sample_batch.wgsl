// One light sample per query (src/lights/gpu_sampler.rs BatchSampler):
// light_sample at a shading point with a given u, its cut-sharing block's
// cut (the kinds with cuts), its pmf as (mantissa, exponent). Needs the
// sampler WGSL (GpuSamplerData::wgsl) and its bindings at @group(1).

struct SampleQuery {
    p: vec3<f32>,
    u: f32,
    n: vec3<f32>,
    block: u32,
}

struct SampleAnswer {
    light: u32,
    pmf_m: f32,
    pmf_e: i32,
    _pad: u32,
}

@group(0) @binding(0) var<storage, read> batch_queries: array<SampleQuery>;
@group(0) @binding(1) var<storage, read_write> batch_answers: array<SampleAnswer>;

@compute @workgroup_size(64)
fn sample_batch(@builtin(global_invocation_id) gid: vec3<u32>,
                @builtin(num_workgroups) groups: vec3<u32>) {
    let i = gid.x + gid.y * groups.x * 64u;
    if (i >= arrayLength(&batch_queries)) {
        return;
    }
    let q = batch_queries[i];
    let pick = light_sample(q.p, q.n, q.block * light_params.cut_size, q.u);
    batch_answers[i] = SampleAnswer(pick.light, pick.pmf_m, pick.pmf_e, 0u);
}
