// Rays per Halton sample, for benches/integrands.rs: evaluates the same
// Halton points as wgsl/halton.wgsl's `evaluate` (samples 0..spp of every
// pixel) and writes, per pixel, the rays the integrand traced
// (`rays_traced`, from wgsl/shared/shading.wgsl), the traversal loop
// iterations of its worst sample (`traversal_steps`) and the number of
// non-finite values. Needs the integrand's WGSL,
// shared/rng.wgsl, shared/sampling.wgsl and shared/halton.wgsl.

struct CountParams {
    width: u32,
    height: u32,
    dims: u32,
    seed: u32,
    spp: u32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

@group(0) @binding(0) var<uniform> params: CountParams;
@group(0) @binding(1) var<storage, read_write> counts: array<vec4<u32>>;

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let pixel = gid.x;
    if (pixel >= params.width * params.height) {
        return;
    }
    let px = vec2<f32>(f32(pixel % params.width), f32(pixel / params.width));
    rays_traced = 0u;
    var worst_steps = 0u;
    var nonfinite = 0u;
    for (var index = 0u; index < params.spp; index++) {
        traversal_steps = 0u;
        var point: IntegrandPoint;
        point.film = px + vec2<f32>(halton_sample(0u, index, pixel, params.seed),
                                    halton_sample(1u, index, pixel, params.seed));
        for (var d = 2u; d < params.dims; d++) {
            point.u[d - 2u] = halton_sample(d, index, pixel, params.seed);
        }
        let f = integrand(&point);
        worst_steps = max(worst_steps, traversal_steps);
        if (!is_finite3(f)) {
            nonfinite += 1u;
        }
    }
    counts[pixel] = vec4<u32>(rays_traced, worst_steps, nonfinite, 0u);
}
