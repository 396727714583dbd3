// Halton quasi-Monte Carlo sampling of an integrand, one sample mean per
// pixel. See src/integrator/halton.rs.
//
// `evaluate`: invocation (pixel, slot) evaluates the samples with indices
//   first_index + slot·samples_per_invocation + k, k < samples_per_invocation,
//   below spp, and writes (Σ finite f, number of finite f) to
//   partial[slot · pixels + pixel].
// `evaluate_single`: the same with samples_per_invocation = 1 and no loop
//   around the integrand (GPUs: with the loop, an H200 ran Halton's
//   samples 1.2-3.4x slower; see src/integrator/halton.rs).
// `accumulate`: invocation `pixel` adds the slots' partial sums, in slot
//   order, into accum[pixel] with Kahan compensation (deterministic).

struct HaltonParams {
    width: u32,
    height: u32,
    dims: u32,
    seed: u32,
    // One past the last sample index of the render (its spp when it starts
    // at sample 0; a part of a reference starts later).
    spp: u32,
    first_index: u32,
    samples_per_invocation: u32,
    slots: u32,
    // Invocations per row of the 2D dispatch grid.
    row_invocations: u32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

@group(0) @binding(0) var<uniform> params: HaltonParams;
@group(0) @binding(1) var<storage, read_write> partial: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read_write> accum: array<vec4<f32>>;
@group(0) @binding(3) var<storage, read_write> compensation: array<vec4<f32>>;

const WORKGROUP_SIZE: u32 = 64u;

// Sample `index` of `pixel` (whose lower corner is `px`):
// shared/halton_point.wgsl.
fn halton_point(index: u32, pixel: u32, px: vec2<f32>) -> IntegrandPoint {
    return halton_integrand_point(index, pixel, px, params.dims, params.seed);
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn evaluate(@builtin(global_invocation_id) gid: vec3<u32>) {
    let pixels = params.width * params.height;
    let id = gid.x + gid.y * params.row_invocations;
    if (id >= pixels * params.slots) {
        return;
    }
    let pixel = id % pixels;
    let slot = id / pixels;
    let px = vec2<f32>(f32(pixel % params.width), f32(pixel / params.width));

    var sum = vec3<f32>(0.0);
    var finite = 0.0;
    let start = params.first_index + slot * params.samples_per_invocation;
    for (var k = 0u; k < params.samples_per_invocation; k++) {
        let index = start + k;
        if (index >= params.spp) {
            break;
        }
        var point = halton_point(index, pixel, px);
        let f = integrand(&point);
        if (is_finite3(f)) {
            sum += f;
            finite += 1.0;
        }
    }
    partial[slot * pixels + pixel] = vec4<f32>(sum, finite);
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn evaluate_single(@builtin(global_invocation_id) gid: vec3<u32>) {
    let pixels = params.width * params.height;
    let id = gid.x + gid.y * params.row_invocations;
    if (id >= pixels * params.slots) {
        return;
    }
    let pixel = id % pixels;
    let slot = id / pixels;
    let index = params.first_index + slot;
    var out = vec4<f32>(0.0);
    if (index < params.spp) {
        let px = vec2<f32>(f32(pixel % params.width), f32(pixel / params.width));
        var point = halton_point(index, pixel, px);
        let f = integrand(&point);
        if (is_finite3(f)) {
            out = vec4<f32>(f, 1.0);
        }
    }
    partial[slot * pixels + pixel] = out;
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn accumulate(@builtin(global_invocation_id) gid: vec3<u32>) {
    let pixels = params.width * params.height;
    let pixel = gid.x + gid.y * params.row_invocations;
    if (pixel >= pixels) {
        return;
    }
    var s = accum[pixel];
    var c = compensation[pixel];
    for (var slot = 0u; slot < params.slots; slot++) {
        let y = partial[slot * pixels + pixel] - c;
        let t = s + y;
        c = (t - s) - y;
        s = t;
    }
    accum[pixel] = s;
    compensation[pixel] = c;
}
