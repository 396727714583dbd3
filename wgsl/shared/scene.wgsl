// Scene bindings at @group(1) and geometry helpers.
//
// Host side: src/accel (GpuScene uploads these buffers; the Rust mirrors
// of the structs are in src/accel/layout.rs). Every kernel that renders the
// scene includes this file and shared/bvh.wgsl via `GpuScene::wgsl()`.
//
// Geometry layout (src/accel/build.rs): `triangles` holds 3 vec4 per
// triangle in BVH leaf order — v0.xyz | bitcast material, v1.xyz | bitcast
// instance, v2.xyz | bitcast shading-normal record + 1 (0: none) — in world
// space for the static instance and object space for moving ones. After
// the `scene.triangle_count` triangles come the shading-normal records,
// 3 vec4 each: the corners' normals n0, n1, n2 in .xyz, in the same space. `nodes` holds the top-level CWBVH (root at
// `scene.tlas_root`) followed by every bottom-level CWBVH, with all child
// and primitive indices already global.
//
// Motion: an instance with keyframes places its object-space point p at
// R(τ)·p + T(τ) at scene time τ; T interpolates linearly, R by shortest-arc
// slerp, clamped to the end keyframes outside their range. Slerp uses
// Eberly's trig-free polynomial (JGGGT 2011; error ~1e-7), because WGSL's
// acos/sin are only as accurate as the driver makes them. src/accel/motion.rs is
// the CPU twin, operation for operation. A sample time t ∈ [0, 1) maps to
// τ = shutter.x + t·(shutter.y − shutter.x) (`scene_time`).

struct SceneUniforms {
  cam_position: vec3<f32>, cam_lens_radius: f32,
  cam_forward: vec3<f32>, cam_focus_distance: f32,   // forward f = normalize(look_at − position)
  cam_right: vec3<f32>, cam_tan_half_fov_y: f32,     // r = normalize(f × up)
  cam_up: vec3<f32>, cam_aspect: f32,                // u = r × f; aspect = W/H of the render film
  film_size: vec2<f32>, shutter: vec2<f32>,          // render film W,H; shutter open, close (scene time)
  background: vec3<f32>, emitter_count: u32,
  light_count: u32, instance_count: u32, tlas_root: u32, triangle_count: u32,
  visibility: u32 /* VISIBILITY_* */, voxel_directions: u32, voxel_skip: u32, voxel_objects: u32,  // shared/voxel.wgsl
}
struct Material { albedo: vec3<f32>, checker_scale: f32 /* 0 = no checker */, emission: vec3<f32>, one_sided: u32 /* 1: the back reflects nothing */, albedo2: vec3<f32>, checker_uv: u32 /* 1: to_uv0/1 map texture coordinates */, to_uv0: vec4<f32>, to_uv1: vec4<f32> }
struct Emitter { prim: u32, cdf: f32, pmf: f32, area: f32 }  // emissive triangles, selection pmf ∝ luminance(emission)·area; cdf inclusive, last = 1 exactly
struct Light { kind: u32 /* 0 point, 1 directional */, _pad0: u32, _pad1: u32, _pad2: u32, position: vec3<f32> /* or direction light travels, normalized */, _pad3: f32, intensity: vec3<f32> /* or irradiance */, _pad4: f32 }
struct Instance { node_root: u32, prim_offset: u32, key_offset: u32, key_count: u32 /* 0 = static, identity */ }
struct Keyframe { translation: vec3<f32>, time: f32, rotation: vec4<f32> /* quaternion xyzw */ }

// One compressed wide BVH node (Ylitie et al. 2017), obvhs' `CwBvhNode`
// byte for byte (80 bytes):
//   p_e.xyz   grid origin p (f32);  p_e.w: bytes e.x, e.y, e.z (exponents
//             of the power-of-two grid scale), imask (internal-child bits)
//   ids.x     child_base_idx (first internal child node)
//   ids.y     primitive_base_idx (first triangle / instance of the leaves)
//   ids.zw    child_meta[0..4], [4..8]
//   qx.xy / qx.zw  child_min_x[0..8] / child_max_x[0..8]; same for qy, qz
struct BvhNode { p_e: vec4<f32>, ids: vec4<u32>, qx: vec4<u32>, qy: vec4<u32>, qz: vec4<u32> }

@group(1) @binding(0) var<uniform> scene: SceneUniforms;
@group(1) @binding(1) var<storage, read> nodes: array<BvhNode>;        // CWBVH nodes (80 B each), TLAS and all BLASes
@group(1) @binding(2) var<storage, read> triangles: array<vec4<f32>>; // 3 per triangle
@group(1) @binding(3) var<storage, read> instances: array<Instance>;
@group(1) @binding(4) var<storage, read> keyframes: array<Keyframe>;
@group(1) @binding(5) var<storage, read> materials: array<Material>;
@group(1) @binding(6) var<storage, read> emitters: array<Emitter>;
@group(1) @binding(7) var<storage, read> lights: array<Light>;

const VISIBILITY_BVH: u32 = 0u;
const VISIBILITY_VOXEL: u32 = 1u;

const LIGHT_POINT: u32 = 0u;
const LIGHT_DIRECTIONAL: u32 = 1u;

// world = R·p + T, R a unit quaternion (xyzw).
struct RigidTransform { rotation: vec4<f32>, translation: vec3<f32> }

// Scene time of a sample time t ∈ [0, 1).
fn scene_time(t: f32) -> f32 {
  return scene.shutter.x + t * (scene.shutter.y - scene.shutter.x);
}

// Rotates v by the unit quaternion q: t = 2 q⃗ × v, v' = v + w·t + q⃗ × t.
fn quat_rotate(q: vec4<f32>, v: vec3<f32>) -> vec3<f32> {
  let t = 2.0 * cross(q.xyz, v);
  return v + q.w * t + cross(q.xyz, t);
}

fn quat_conjugate(q: vec4<f32>) -> vec4<f32> {
  return vec4<f32>(-q.xyz, q.w);
}

// Eberly's series term (u_i t² − v_i)(cos θ − 1), u_i = 1/(i(2i+1)),
// v_i = i/(2i+1); the 8th term is scaled by 1 + μ = 1.90110745351730037.
fn slerp_term(u: f32, v: f32, t2: f32, xm1: f32) -> f32 {
  return (u * t2 - v) * xm1;
}

// sin(tθ)/sin θ for xm1 = cos θ − 1 (Horner form, loop-free; the same
// order of operations as slerp_weight in src/accel/motion.rs).
fn slerp_weight(t: f32, xm1: f32) -> f32 {
  let t2 = t * t;
  var c = 1.0 + slerp_term(1.90110745351730037 / (8.0 * 17.0), 1.90110745351730037 * 8.0 / 17.0, t2, xm1) * 1.0;
  c = 1.0 + slerp_term(1.0 / (7.0 * 15.0), 7.0 / 15.0, t2, xm1) * c;
  c = 1.0 + slerp_term(1.0 / (6.0 * 13.0), 6.0 / 13.0, t2, xm1) * c;
  c = 1.0 + slerp_term(1.0 / (5.0 * 11.0), 5.0 / 11.0, t2, xm1) * c;
  c = 1.0 + slerp_term(1.0 / (4.0 * 9.0), 4.0 / 9.0, t2, xm1) * c;
  c = 1.0 + slerp_term(1.0 / (3.0 * 7.0), 3.0 / 7.0, t2, xm1) * c;
  c = 1.0 + slerp_term(1.0 / (2.0 * 5.0), 2.0 / 5.0, t2, xm1) * c;
  c = 1.0 + slerp_term(1.0 / (1.0 * 3.0), 1.0 / 3.0, t2, xm1) * c;
  return t * c;
}

// Shortest-arc spherical linear interpolation of unit quaternions.
fn quat_slerp(a: vec4<f32>, b_in: vec4<f32>, s: f32) -> vec4<f32> {
  var b = b_in;
  var d = dot(a, b);
  if d < 0.0 {
    b = -b;
    d = -d;
  }
  let xm1 = d - 1.0;
  return normalize(a * slerp_weight(1.0 - s, xm1) + b * slerp_weight(s, xm1));
}

fn rigid_point(x: RigidTransform, p: vec3<f32>) -> vec3<f32> {
  return quat_rotate(x.rotation, p) + x.translation;
}

fn rigid_vector(x: RigidTransform, v: vec3<f32>) -> vec3<f32> {
  return quat_rotate(x.rotation, v);
}

fn rigid_inverse_point(x: RigidTransform, p: vec3<f32>) -> vec3<f32> {
  return quat_rotate(quat_conjugate(x.rotation), p - x.translation);
}

fn rigid_inverse_vector(x: RigidTransform, v: vec3<f32>) -> vec3<f32> {
  return quat_rotate(quat_conjugate(x.rotation), v);
}

// Transform of instance `inst` at scene time `time` (identity if static).
// The segment search loops at most key_count − 2 times.
fn instance_transform_at(inst: u32, time: f32) -> RigidTransform {
  let info = instances[inst];
  if info.key_count == 0u {
    return RigidTransform(vec4<f32>(0.0, 0.0, 0.0, 1.0), vec3<f32>(0.0));
  }
  let first = keyframes[info.key_offset];
  if info.key_count == 1u || time <= first.time {
    return RigidTransform(first.rotation, first.translation);
  }
  let last = keyframes[info.key_offset + info.key_count - 1u];
  if time >= last.time {
    return RigidTransform(last.rotation, last.translation);
  }
  // first.time < time < last.time: find i with key[i].time <= time < key[i+1].time.
  var i = 0u;
  loop {
    if i + 2u >= info.key_count || keyframes[info.key_offset + i + 1u].time > time {
      break;
    }
    i += 1u;
  }
  let a = keyframes[info.key_offset + i];
  let b = keyframes[info.key_offset + i + 1u];
  let s = (time - a.time) / (b.time - a.time);
  return RigidTransform(quat_slerp(a.rotation, b.rotation, s), mix(a.translation, b.translation, s));
}

// Instance of global triangle `prim`.
fn triangle_instance(prim: u32) -> u32 {
  return bitcast<u32>(triangles[3u * prim + 1u].w);
}

// Material index of global triangle `prim`.
fn triangle_material(prim: u32) -> u32 {
  return bitcast<u32>(triangles[3u * prim].w);
}

// Stored vertices of `prim`: world space if static, object space if moving.
fn triangle_stored(prim: u32) -> array<vec3<f32>, 3> {
  return array<vec3<f32>, 3>(
    triangles[3u * prim].xyz,
    triangles[3u * prim + 1u].xyz,
    triangles[3u * prim + 2u].xyz,
  );
}

// World-space vertices of global triangle `prim` at scene time `time`.
fn triangle_world(prim: u32, time: f32) -> array<vec3<f32>, 3> {
  let v = triangle_stored(prim);
  let inst = triangle_instance(prim);
  if instances[inst].key_count == 0u {
    return v;
  }
  let x = instance_transform_at(inst, time);
  return array<vec3<f32>, 3>(rigid_point(x, v[0]), rigid_point(x, v[1]), rigid_point(x, v[2]));
}

// Unit shading normal of global triangle `prim` at barycentrics `bary`
// (weights of v1 and v2), world space at scene time `time`: its corner
// normals interpolated and normalized. `ng` (the unit geometric normal)
// where the triangle has none or the interpolation vanishes.
// Rows of a triangle's record of normals and texture coordinates
// (src/accel/build.rs): n_k.xyz | u_k for the three corners, then
// (v0, v1, v2, 0).
const RECORD_ROWS: u32 = 4u;

// Texture coordinates at barycentrics `bary` (of v1, v2) of `prim`; (0, 0)
// where its mesh has none.
fn triangle_uv(prim: u32, bary: vec2<f32>) -> vec2<f32> {
  let record = bitcast<u32>(triangles[3u * prim + 2u].w);
  if record == 0u {
    return vec2<f32>(0.0);
  }
  let base = 3u * scene.triangle_count + RECORD_ROWS * (record - 1u);
  let w = vec3<f32>(1.0 - bary.x - bary.y, bary.x, bary.y);
  let u = vec3<f32>(triangles[base].w, triangles[base + 1u].w, triangles[base + 2u].w);
  return vec2<f32>(dot(w, u), dot(w, triangles[base + 3u].xyz));
}

fn triangle_shading_normal(prim: u32, bary: vec2<f32>, time: f32, ng: vec3<f32>) -> vec3<f32> {
  let record = bitcast<u32>(triangles[3u * prim + 2u].w);
  if record == 0u {
    return ng;
  }
  let base = 3u * scene.triangle_count + RECORD_ROWS * (record - 1u);
  var n = triangles[base].xyz * (1.0 - bary.x - bary.y) + triangles[base + 1u].xyz * bary.x
    + triangles[base + 2u].xyz * bary.y;
  let inst = triangle_instance(prim);
  if instances[inst].key_count != 0u {
    n = rigid_vector(instance_transform_at(inst, time), n);
  }
  let len2 = dot(n, n);
  if !(len2 > 1e-12) {
    return ng;
  }
  return n * inverseSqrt(len2);
}
