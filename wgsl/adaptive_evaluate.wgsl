// Per-pixel adaptive Halton: the evaluate kernels, over the integrand,
// the shared Halton points and adaptive.wgsl. See
// src/integrator/adaptive.rs.
//
// `evaluate`: invocation (entry j, slot) of the chunk evaluates the
//   entry's samples slot·spi + k (k < spi) below its count for this
//   round, at sample indices start + that, and writes (Σ finite f, their
//   number) and the same over the class-A ones to adaptive_partial.
// `evaluate_single`: one sample per invocation, no loop around the
//   integrand (GPUs; as Halton's).

fn adaptive_sample(index: u32, pixel: u32, px: vec2<f32>,
                   whole: ptr<function, vec4<f32>>, part: ptr<function, vec4<f32>>) {
    var point = halton_integrand_point(index, pixel, px, adaptive_params.dims, adaptive_params.seed);
    let f = integrand(&point);
    if (is_finite3(f)) {
        *whole += vec4<f32>(f, 1.0);
        if (adaptive_class_a(index)) {
            *part += vec4<f32>(f, 1.0);
        }
    }
}

@compute @workgroup_size(ADAPTIVE_WG)
fn evaluate(@builtin(global_invocation_id) gid: vec3<u32>,
            @builtin(num_workgroups) nwg: vec3<u32>) {
    let id = gid.x + gid.y * nwg.x * ADAPTIVE_WG;
    let n = adaptive_params.entries;
    if (id >= n * adaptive_params.slots) {
        return;
    }
    let e = adaptive_list[id % n];
    let slot = adaptive_params.first_slot + id / n;
    let pixel = e.x;
    let px = vec2<f32>(f32(pixel % adaptive_params.width), f32(pixel / adaptive_params.width));
    var whole = vec4<f32>(0.0);
    var part = vec4<f32>(0.0);
    let first = slot * adaptive_params.samples_per_invocation;
    for (var k = 0u; k < adaptive_params.samples_per_invocation; k++) {
        let s = first + k;
        if (s >= e.y) {
            break;
        }
        adaptive_sample(e.z + s, pixel, px, &whole, &part);
    }
    adaptive_partial[2u * id] = whole;
    adaptive_partial[2u * id + 1u] = part;
}

@compute @workgroup_size(ADAPTIVE_WG)
fn evaluate_single(@builtin(global_invocation_id) gid: vec3<u32>,
                   @builtin(num_workgroups) nwg: vec3<u32>) {
    let id = gid.x + gid.y * nwg.x * ADAPTIVE_WG;
    let n = adaptive_params.entries;
    if (id >= n * adaptive_params.slots) {
        return;
    }
    let e = adaptive_list[id % n];
    let s = adaptive_params.first_slot + id / n;
    var whole = vec4<f32>(0.0);
    var part = vec4<f32>(0.0);
    if (s < e.y) {
        let pixel = e.x;
        let px = vec2<f32>(f32(pixel % adaptive_params.width), f32(pixel / adaptive_params.width));
        adaptive_sample(e.z + s, pixel, px, &whole, &part);
    }
    adaptive_partial[2u * id] = whole;
    adaptive_partial[2u * id + 1u] = part;
}
