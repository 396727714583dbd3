// tests/bvh_traversal.rs `shading_normals_read_back_in_wgsl`: the shading
// normal `triangle_shading_normal` (wgsl/shared/scene.wgsl) returns per
// query, with the geometric normal of `triangle_world` as its fallback.
struct Query { prim: u32, time: f32, bary: vec2<f32> }
@group(0) @binding(0) var<storage, read> queries: array<Query>;
@group(0) @binding(1) var<storage, read_write> out: array<f32>;
@compute @workgroup_size(1)
fn shading_normal(@builtin(workgroup_id) id: vec3<u32>) {
  let q = queries[id.x];
  let v = triangle_world(q.prim, q.time);
  let ng = normalize(cross(v[1] - v[0], v[2] - v[0]));
  let n = triangle_shading_normal(q.prim, q.bary, q.time, ng);
  out[3u * id.x] = n.x;
  out[3u * id.x + 1u] = n.y;
  out[3u * id.x + 2u] = n.z;
}
