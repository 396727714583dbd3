// tests/bvh_traversal.rs `scene_bindings_read_back_in_wgsl`: dumps what
// the scene bindings of wgsl/shared/scene.wgsl read, for comparison with
// the CPU scene.
struct Query { prim: u32, time: f32 }
@group(0) @binding(0) var<storage, read> queries: array<Query>;
@group(0) @binding(1) var<storage, read_write> out: array<f32>;
const HEADER: u32 = 64u;
@compute @workgroup_size(1)
fn dump(@builtin(workgroup_id) id: vec3<u32>) {
  if id.x == 0u {
    let s = scene;
    let u = array<f32, 28>(s.cam_position.x, s.cam_position.y, s.cam_position.z, s.cam_lens_radius,
      s.cam_forward.x, s.cam_forward.y, s.cam_forward.z, s.cam_focus_distance,
      s.cam_right.x, s.cam_right.y, s.cam_right.z, s.cam_tan_half_fov_y,
      s.cam_up.x, s.cam_up.y, s.cam_up.z, s.cam_aspect,
      s.film_size.x, s.film_size.y, s.shutter.x, s.shutter.y,
      s.background.x, s.background.y, s.background.z, bitcast<f32>(s.emitter_count),
      bitcast<f32>(s.light_count), bitcast<f32>(s.instance_count), bitcast<f32>(s.tlas_root), bitcast<f32>(s.triangle_count));
    for (var i = 0u; i < 28u; i++) { out[i] = u[i]; }
    let m = materials[arrayLength(&materials) - 1u];
    let mm = array<f32, 10>(m.albedo.x, m.albedo.y, m.albedo.z, m.checker_scale, m.emission.x, m.emission.y, m.emission.z, m.albedo2.x, m.albedo2.y, m.albedo2.z);
    for (var i = 0u; i < 10u; i++) { out[28u + i] = mm[i]; }
    out[56] = bitcast<f32>(m.one_sided);
    let e = emitters[1];
    out[38] = bitcast<f32>(e.prim); out[39] = e.cdf; out[40] = e.pmf; out[41] = e.area;
    for (var l = 0u; l < 2u; l++) {
      let li = lights[l];
      out[42u + 7u * l] = bitcast<f32>(li.kind);
      out[43u + 7u * l] = li.position.x; out[44u + 7u * l] = li.position.y; out[45u + 7u * l] = li.position.z;
      out[46u + 7u * l] = li.intensity.x; out[47u + 7u * l] = li.intensity.y; out[48u + 7u * l] = li.intensity.z;
    }
  }
  let q = queries[id.x];
  let v = triangle_world(q.prim, q.time);
  let base = HEADER + 10u * id.x;
  for (var k = 0u; k < 3u; k++) {
    out[base + 3u * k] = v[k].x; out[base + 3u * k + 1u] = v[k].y; out[base + 3u * k + 2u] = v[k].z;
  }
  out[base + 9u] = bitcast<f32>(triangle_material(q.prim));
}
