// Voxel visibility: constant-time shadow queries against the 2D array of
// per-direction bit voxelizations (Wang, Meng & Popescu). The rules — the
// direction array, the frames, the row through the midpoint, the
// self-occlusion rule — are documented in src/accel/voxel.rs, the CPU
// twin of every function here, operation for operation.
//
// Bindings 8–10 of the scene group; with BVH visibility they hold one
// zeroed element each and scene.visibility is 0.

struct VoxelObject { centre: vec3<f32>, inv_h: f32, radius: f32, res: u32, words: u32, base: u32 }
struct VoxelFrame { a: vec4<f32>, b: vec4<f32>, u: vec4<f32> }

@group(1) @binding(8) var<storage, read> voxel_bits: array<u32>;
@group(1) @binding(9) var<storage, read> voxel_objects: array<VoxelObject>;
@group(1) @binding(10) var<storage, read> voxel_frames: array<VoxelFrame>;

const VOXEL_PI: f32 = 3.14159265358979323846;

// Object-space point p in the voxel coordinates of frame f (explicit
// arithmetic: the CPU twin must round the same way).
fn voxel_coords(o: VoxelObject, f: VoxelFrame, p: vec3<f32>) -> vec3<f32> {
  let rel = p - o.centre;
  let half = f32(o.res / 2u);
  let x = (rel.x * f.a.x + rel.y * f.a.y + rel.z * f.a.z) * o.inv_h + half;
  let y = (rel.x * f.b.x + rel.y * f.b.y + rel.z * f.b.z) * o.inv_h + half;
  let z = (rel.x * f.u.x + rel.y * f.u.y + rel.z * f.u.z) * o.inv_h + half;
  return vec3<f32>(x, y, z);
}

// The voxelization whose rows best match direction d (length > 0).
fn voxel_direction(n: u32, d_in: vec3<f32>) -> u32 {
  var d = normalize(d_in);
  if d.y < 0.0 {
    d = -d;
  }
  let k = f32(n) / VOXEL_PI;
  let theta = acos(clamp(d.z, -1.0, 1.0));
  let phi = atan2(max(d.y, 0.0), d.x);
  var i = min(u32(floor(theta * k + 0.5)), n);
  var j = min(u32(floor(phi * k + 0.5)), n);
  if j == n {
    j = 0u;
    i = n - i;
  }
  if i == n {
    i = 0u;
  }
  return i * n + j;
}

// Whether object o's bits occlude the object-space segment p + t·d,
// t ∈ [0, t_max].
fn voxel_object_hit(o: VoxelObject, p: vec3<f32>, d: vec3<f32>, t_max: f32) -> bool {
  let oc = p - o.centre;
  let dd = dot(d, d);
  let b = dot(oc, d);
  let cc = dot(oc, oc) - o.radius * o.radius;
  let disc = b * b - dd * cc;
  // (disc <= 3e38 also refuses NaN and +inf.)
  if dd <= 0.0 || disc < 0.0 || !(disc <= 3.0e38) {
    return false;
  }
  let s = sqrt(disc);
  let t0 = max((-b - s) / dd, 0.0);
  let t1 = min((-b + s) / dd, t_max);
  if t0 >= t1 {
    return false;
  }
  let v = voxel_direction(scene.voxel_directions, d);
  let f = voxel_frames[v];
  let x0 = p + d * t0;
  let x1 = p + d * t1;
  let m = voxel_coords(o, f, (x0 + x1) * 0.5);
  let res = f32(o.res);
  let x = floor(m.x);
  let y = floor(m.y);
  if x < 0.0 || y < 0.0 || x >= res || y >= res {
    return false;
  }
  let z0 = voxel_coords(o, f, x0).z;
  let z1 = voxel_coords(o, f, x1).z;
  var lo_end = t0 == 0.0;
  var hi_end = t1 == t_max;
  var zlo = z0;
  var zhi = z1;
  if z0 > z1 {
    zlo = z1;
    zhi = z0;
    lo_end = t1 == t_max;
    hi_end = t0 == 0.0;
  }
  let skip = 1 + i32(scene.voxel_skip);
  let lo = max(i32(clamp(floor(zlo), -1.0, res)) + select(0, skip, lo_end), 0);
  let hi = min(i32(clamp(floor(zhi), -1.0, res)) - select(0, skip, hi_end), i32(o.res) - 1);
  if lo > hi {
    return false;
  }
  let row = o.base + ((v * o.res + u32(y)) * o.res + u32(x)) * o.words;
  let ulo = u32(lo);
  let uhi = u32(hi);
  for (var w = ulo / 32u; w <= uhi / 32u; w += 1u) {
    let wlo = max(ulo, 32u * w) - 32u * w;
    let whi = min(uhi, 32u * w + 31u) - 32u * w;
    // Both shifts stay in 0..31: WGSL would use only their low 5 bits.
    let mask = (0xffffffffu >> (31u - (whi - wlo))) << wlo;
    if (voxel_bits[row + w] & mask) != 0u {
      return true;
    }
  }
  return false;
}

// Whether the world-space segment origin + t·dir, t ∈ [0, t_max], at
// scene time `time` is occluded: any voxel object hit, moving instances
// queried in their own frame (the paper's Algorithm 4).
fn voxel_occluded(origin: vec3<f32>, dir: vec3<f32>, t_max: f32, time: f32) -> bool {
  for (var i = 0u; i < scene.voxel_objects; i += 1u) {
    var p = origin;
    var d = dir;
    if i < scene.instance_count && instances[i].key_count > 0u {
      let x = instance_transform_at(i, time);
      p = rigid_inverse_point(x, origin);
      d = rigid_inverse_vector(x, dir);
    }
    if voxel_object_hit(voxel_objects[i], p, d, t_max) {
      return true;
    }
  }
  return false;
}
