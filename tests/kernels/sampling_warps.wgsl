// One warp per invocation, for the chi-square tests of
// tests/integrands_sampling.rs. WARP (generated constant) selects it:
//   0  lens: camera_ray's lens point, as (right, up) coordinates in units
//      of the lens radius (the concentric disk map through the camera)
//   1  shutter: shutter_time(u.x)
//   2  cosine hemisphere around params.normal: world direction
//   3  sample_emitter(u, 0): the point, its triangle (bitcast), and
//      (pdf_area, 0, 0, 0) in the second output
// Inputs are independent uniform pairs generated on the CPU.

struct WarpParams {
    normal: vec3<f32>,
    count: u32,
}

@group(0) @binding(0) var<uniform> params: WarpParams;
@group(0) @binding(1) var<storage, read> inputs: array<vec2<f32>>;
@group(0) @binding(2) var<storage, read_write> outputs: array<vec4<f32>>;

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = gid.x;
    if (i >= params.count) {
        return;
    }
    let u = inputs[i];
    var a = vec4<f32>(0.0);
    var b = vec4<f32>(0.0);
    if (WARP == 0u) {
        let ray = camera_ray(0.5 * scene.film_size, u);
        let d = ray.origin - scene.cam_position;
        a = vec4<f32>(dot(d, scene.cam_right), dot(d, scene.cam_up), 0.0, 0.0) / scene.cam_lens_radius;
    } else if (WARP == 1u) {
        a = vec4<f32>(shutter_time(u.x), 0.0, 0.0, 0.0);
    } else if (WARP == 2u) {
        a = vec4<f32>(frame_from_normal(params.normal) * sample_cosine_hemisphere(u), 0.0);
    } else {
        let s = sample_emitter(u, 0.0);
        a = vec4<f32>(s.y, bitcast<f32>(s.prim));
        b = vec4<f32>(s.pdf_area, 0.0, 0.0, 0.0);
    }
    outputs[2u * i] = a;
    outputs[2u * i + 1u] = b;
}
