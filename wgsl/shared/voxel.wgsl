// Voxel visibility: constant-time shadow queries against the 2D array of
// per-direction bit voxelizations (Wang, Meng & Popescu). The rules — the
// direction array, the frames, the row through the midpoint, the
// self-occlusion rule — are documented in src/accel/voxel.rs, the CPU
// twin of every function here, operation for operation.
//
// Bindings 8–10 of the scene group; with BVH visibility they hold one
// zeroed element each and scene.visibility is 0.

struct VoxelObject {
  centre: vec3<f32>, res: u32, words: u32, base: u32, frames: u32, _pad: u32,
  world_min: vec3<f32>, _pad1: u32, world_max: vec3<f32>, _pad2: u32,  // world bounds at every time
}
struct VoxelFrame { a: vec4<f32>, b: vec4<f32>, u: vec4<f32> }  // axes scaled to voxels (xyz)

@group(1) @binding(8) var<storage, read> voxel_bits: array<u32>;
@group(1) @binding(9) var<storage, read> voxel_objects: array<VoxelObject>;
@group(1) @binding(10) var<storage, read> voxel_frames: array<VoxelFrame>;

const VOXEL_PI: f32 = 3.14159265358979323846;

// Object-space vector d in the voxel coordinates of grid f (explicit
// arithmetic: the CPU twin must round the same way).
fn voxel_vector(f: VoxelFrame, d: vec3<f32>) -> vec3<f32> {
  let x = d.x * f.a.x + d.y * f.a.y + d.z * f.a.z;
  let y = d.x * f.b.x + d.y * f.b.y + d.z * f.b.z;
  let z = d.x * f.u.x + d.y * f.u.y + d.z * f.u.z;
  return vec3<f32>(x, y, z);
}

// Object-space point p in the voxel coordinates of grid f.
fn voxel_coords(o: VoxelObject, f: VoxelFrame, p: vec3<f32>) -> vec3<f32> {
  return voxel_vector(f, p - o.centre) + vec3<f32>(f32(o.res / 2u));
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
// t ∈ [0, t_max], which starts on a surface of normal n0 and ends on one
// of normal n1 (zero: no surface).
fn voxel_object_hit(o: VoxelObject, p: vec3<f32>, d: vec3<f32>, t_max: f32,
                    n0: vec3<f32>, n1: vec3<f32>) -> bool {
  let v = voxel_direction(scene.voxel_directions, d);
  let f = voxel_frames[o.frames + v];
  let qp = voxel_coords(o, f, p);
  let qd = voxel_vector(f, d);
  let res = f32(o.res);
  // Clip to the grid [0, R]³, slab by slab.
  var t0 = 0.0;
  var t1 = t_max;
  for (var k = 0u; k < 3u; k += 1u) {
    if qd[k] == 0.0 {
      if qp[k] < 0.0 || qp[k] > res {
        return false;
      }
    } else {
      let ta = (0.0 - qp[k]) / qd[k];
      let tb = (res - qp[k]) / qd[k];
      t0 = max(t0, min(ta, tb));
      t1 = min(t1, max(ta, tb));
    }
  }
  // (Also false for NaN.)
  if !(t0 < t1) {
    return false;
  }
  let x0 = qp + qd * t0;
  let xm = qp + qd * (0.5 * (t0 + t1));
  let x1 = qp + qd * t1;
  let x = floor(xm.x);
  let y = floor(xm.y);
  if x < 0.0 || y < 0.0 || x >= res || y >= res {
    return false;
  }
  let z0 = i32(clamp(floor(x0.z), -1.0, res));
  let z1 = i32(clamp(floor(x1.z), -1.0, res));
  var s0 = 0;
  var s1 = 0;
  if t0 == 0.0 {
    s0 = voxel_endpoint_skip(o, f, vec2<f32>(x, y), x0, xm, n0);
  }
  if t1 == t_max {
    s1 = voxel_endpoint_skip(o, f, vec2<f32>(x, y), x1, xm, n1);
  }
  var lo = z1 + s1;
  var hi = z0 - s0;
  if x0.z <= x1.z {
    lo = z0 + s0;
    hi = z1 - s1;
  }
  lo = max(lo, 0);
  hi = min(hi, i32(o.res) - 1);
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

// Voxels excluded at a true endpoint `near` on the row (x, y) running
// towards `far`, whose surface has the object-space normal n (zero: none):
// its own, the next ones the surface's tangent plane still touches, and
// scene.voxel_skip more (src/accel/voxel.rs endpoint_skip).
fn voxel_endpoint_skip(o: VoxelObject, f: VoxelFrame, row: vec2<f32>, near: vec3<f32>,
                       far: vec3<f32>, n: vec3<f32>) -> i32 {
  let extra = 1 + i32(scene.voxel_skip);
  if all(n == vec3<f32>(0.0)) {
    return extra;
  }
  // The normal in voxel space: x·n / |x|² for each scaled axis x.
  let a = f.a.xyz;
  let b = f.b.xyz;
  let u = f.u.xyz;
  let nv = vec3<f32>((a.x * n.x + a.y * n.y + a.z * n.z) / (a.x * a.x + a.y * a.y + a.z * a.z),
                     (b.x * n.x + b.y * n.y + b.z * n.z) / (b.x * b.x + b.y * b.y + b.z * b.z),
                     (u.x * n.x + u.y * n.y + u.z * n.z) / (u.x * u.x + u.y * u.y + u.z * u.z));
  // The plane through `near` touches the row's k-th voxel (centre c_k)
  // while |nv·(c_k − near)| ≤ r; nv·(c_k − near) = f0 + k·slope.
  let r = 0.5 * (abs(nv.x) + abs(nv.y) + abs(nv.z));
  let c0 = vec3<f32>(row.x + 0.5, row.y + 0.5, floor(near.z) + 0.5);
  let f0 = nv.x * (c0.x - near.x) + nv.y * (c0.y - near.y) + nv.z * (c0.z - near.z);
  let slope = select(-nv.z, nv.z, far.z >= near.z);
  let res = f32(o.res);
  var touching = 0.0;
  if slope != 0.0 {
    let q = (r - sign(slope) * f0) / abs(slope);
    // (NaN, from a NaN normal, counts as 0.)
    if q >= 0.0 {
      touching = min(floor(q), res);
    }
  } else if abs(f0) <= r {
    touching = res;
  }
  return i32(touching) + extra;
}

// Whether the world segment p + t·d, t ∈ [0, t_max], meets the box
// [lo, hi] (slabs; a zero component of d needs p inside that slab).
fn voxel_segment_meets_box(p: vec3<f32>, d: vec3<f32>, t_max: f32, lo: vec3<f32>, hi: vec3<f32>) -> bool {
  var t0 = 0.0;
  var t1 = t_max;
  for (var k = 0u; k < 3u; k += 1u) {
    if d[k] == 0.0 {
      if p[k] < lo[k] || p[k] > hi[k] {
        return false;
      }
    } else {
      let ta = (lo[k] - p[k]) / d[k];
      let tb = (hi[k] - p[k]) / d[k];
      t0 = max(t0, min(ta, tb));
      t1 = min(t1, max(ta, tb));
    }
  }
  return t0 <= t1;
}

// Whether the world-space segment origin + t·dir, t ∈ [0, t_max], at
// scene time `time` is occluded: any voxel object hit, moving instances
// queried in their own frame (the paper's Algorithm 4). n0, n1: the
// normals of the surfaces it starts and ends on (zero: none).
fn voxel_occluded(origin: vec3<f32>, dir: vec3<f32>, t_max: f32, time: f32,
                  n0: vec3<f32>, n1: vec3<f32>) -> bool {
  for (var i = 0u; i < scene.voxel_objects; i += 1u) {
    let o = voxel_objects[i];
    if !voxel_segment_meets_box(origin, dir, t_max, o.world_min, o.world_max) {
      continue;
    }
    var p = origin;
    var d = dir;
    var m0 = n0;
    var m1 = n1;
    if i < scene.instance_count && instances[i].key_count > 0u {
      let x = instance_transform_at(i, time);
      p = rigid_inverse_point(x, origin);
      d = rigid_inverse_vector(x, dir);
      m0 = rigid_inverse_vector(x, n0);
      m1 = rigid_inverse_vector(x, n1);
    }
    if voxel_object_hit(o, p, d, t_max, m0, m1) {
      return true;
    }
  }
  return false;
}
