// Batch ray tracing for tests and benchmarks (src/accel/trace.rs).
//
// One invocation per ray: closest hit and/or any hit against the scene at
// @group(1) via shared/bvh.wgsl, or the voxel visibility query of
// shared/voxel.wgsl. Rays and hits are flat arrays; the grid
// is 2D when one dimension would exceed the workgroup-count limit, and the
// linear ray index is id.x + id.y · params.row_stride.

struct Ray { origin: vec3<f32>, t_max: f32, dir: vec3<f32>, time: f32 }  // time: scene time
struct HitRecord {
  t: f32, prim: u32, bary: vec2<f32>,   // closest hit (Hit of bvh.wgsl)
  any_hit: u32,                         // 1 = trace_any was true
  steps_closest: u32, steps_any: u32,   // traversal loop iterations used
  _pad: u32,
}
struct TraceParams { ray_count: u32, row_stride: u32, normals: u32 /* 1: `normals` holds 2 per ray */, _pad: u32 }

@group(0) @binding(0) var<uniform> params: TraceParams;
@group(0) @binding(1) var<storage, read> rays: array<Ray>;
@group(0) @binding(2) var<storage, read_write> hits: array<HitRecord>;
// Per ray, the normals of the surfaces it starts and ends on (xyz; zero:
// none), read by the voxel query only.
@group(0) @binding(3) var<storage, read> normals: array<vec4<f32>>;

fn ray_index(id: vec3<u32>) -> u32 {
  return id.x + id.y * params.row_stride;
}

@compute @workgroup_size(TRACE_WORKGROUP_SIZE)
fn trace_both(@builtin(global_invocation_id) id: vec3<u32>) {
  let i = ray_index(id);
  if i >= params.ray_count {
    return;
  }
  let ray = rays[i];
  let closest = bvh_traverse(ray.origin, ray.dir, ray.t_max, ray.time, false);
  let any = bvh_traverse(ray.origin, ray.dir, ray.t_max, ray.time, true);
  hits[i] = HitRecord(closest.hit.t, closest.hit.prim, closest.hit.bary,
                      select(0u, 1u, any.hit.prim != BVH_MISS), closest.steps, any.steps, 0u);
}

@compute @workgroup_size(TRACE_WORKGROUP_SIZE)
fn trace_closest_only(@builtin(global_invocation_id) id: vec3<u32>) {
  let i = ray_index(id);
  if i >= params.ray_count {
    return;
  }
  let ray = rays[i];
  let closest = bvh_traverse(ray.origin, ray.dir, ray.t_max, ray.time, false);
  hits[i] = HitRecord(closest.hit.t, closest.hit.prim, closest.hit.bary,
                      select(0u, 1u, closest.hit.prim != BVH_MISS), closest.steps, 0u, 0u);
}

@compute @workgroup_size(TRACE_WORKGROUP_SIZE)
fn trace_any_only(@builtin(global_invocation_id) id: vec3<u32>) {
  let i = ray_index(id);
  if i >= params.ray_count {
    return;
  }
  let ray = rays[i];
  let any = bvh_traverse(ray.origin, ray.dir, ray.t_max, ray.time, true);
  hits[i] = HitRecord(ray.t_max, BVH_MISS, vec2<f32>(0.0), select(0u, 1u, any.hit.prim != BVH_MISS), 0u, any.steps, 0u);
}

// The voxel visibility query (shared/voxel.wgsl) in place of the BVH's any
// hit: any_hit = 1 when the segment [0, t_max] is occluded (with the
// surface normals of `normals` when params.normals is 1).
@compute @workgroup_size(TRACE_WORKGROUP_SIZE)
fn trace_voxel_only(@builtin(global_invocation_id) id: vec3<u32>) {
  let i = ray_index(id);
  if i >= params.ray_count {
    return;
  }
  let ray = rays[i];
  var n0 = vec3<f32>(0.0);
  var n1 = vec3<f32>(0.0);
  if params.normals != 0u {
    n0 = normals[2u * i].xyz;
    n1 = normals[2u * i + 1u].xyz;
  }
  let occluded = voxel_occluded(ray.origin, ray.dir, ray.t_max, ray.time, n0, n1);
  hits[i] = HitRecord(ray.t_max, BVH_MISS, vec2<f32>(0.0), select(0u, 1u, occluded), 0u, 0u, 0u);
}
