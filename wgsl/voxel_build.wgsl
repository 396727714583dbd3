// Build of the voxelization array (src/accel/gpu_voxel.rs): one
// invocation per (work item, direction). A work item is a triangle and one
// tile of TILE×TILE columns of its footprint (src/accel/voxel.rs
// `work_items`); the invocation sets the voxels of that tile which the
// triangle meets, with atomicOr. The loop is src/accel/voxel.rs
// `voxelize_triangle`, operation for operation (explicit dot and cross
// products), so the CPU oracle's bits equal these.
//
// Needs shared/voxel.wgsl's structs only; TILE is a constant.

struct VoxelObject {
  centre: vec3<f32>, res: u32, words: u32, base: u32, frames: u32, _pad: u32,
  world_min: vec3<f32>, _pad1: u32, world_max: vec3<f32>, _pad2: u32,
}
struct VoxelFrame { a: vec4<f32>, b: vec4<f32>, u: vec4<f32> }
struct VoxelBuildParams {
  item_count: u32,
  row_stride: u32,       // invocations per grid row: item = x + y · row_stride
  direction_offset: u32, // first direction of this dispatch (z adds to it)
  per_instance: u32,     // 1: a triangle's object is its instance; 0: object 0
}

@group(0) @binding(0) var<uniform> params: VoxelBuildParams;
@group(0) @binding(1) var<storage, read> items: array<vec2<u32>>;
@group(0) @binding(2) var<storage, read> triangles: array<vec4<f32>>;
@group(0) @binding(3) var<storage, read> objects: array<VoxelObject>;
@group(0) @binding(4) var<storage, read> frames: array<VoxelFrame>;
@group(0) @binding(5) var<storage, read_write> bits: array<atomic<u32>>;

fn dot3(a: vec3<f32>, b: vec3<f32>) -> f32 {
  return a.x * b.x + a.y * b.y + a.z * b.z;
}

fn cross3(a: vec3<f32>, b: vec3<f32>) -> vec3<f32> {
  return vec3<f32>(a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x);
}

fn to_voxel(o: VoxelObject, f: VoxelFrame, p: vec3<f32>) -> vec3<f32> {
  let rel = p - o.centre;
  let half = f32(o.res / 2u);
  return vec3<f32>(dot3(rel, f.a.xyz) + half, dot3(rel, f.b.xyz) + half, dot3(rel, f.u.xyz) + half);
}

fn separated(axis: vec3<f32>, v0: vec3<f32>, v1: vec3<f32>, v2: vec3<f32>) -> bool {
  let p0 = dot3(axis, v0);
  let p1 = dot3(axis, v1);
  let p2 = dot3(axis, v2);
  let r = 0.5 * (abs(axis.x) + abs(axis.y) + abs(axis.z));
  return min(min(p0, p1), p2) > r || max(max(p0, p1), p2) < -r;
}

// The triangle (relative to the box centre) meets [−½, ½]³.
fn triangle_meets_box(v0: vec3<f32>, v1: vec3<f32>, v2: vec3<f32>) -> bool {
  let e0 = v1 - v0;
  let e1 = v2 - v1;
  let e2 = v0 - v2;
  let units = array<vec3<f32>, 3>(vec3<f32>(1.0, 0.0, 0.0), vec3<f32>(0.0, 1.0, 0.0), vec3<f32>(0.0, 0.0, 1.0));
  for (var a = 0u; a < 3u; a += 1u) {
    if separated(units[a], v0, v1, v2) {
      return false;
    }
  }
  if separated(cross3(e0, e1), v0, v1, v2) {
    return false;
  }
  for (var a = 0u; a < 3u; a += 1u) {
    if separated(cross3(units[a], e0), v0, v1, v2)
        || separated(cross3(units[a], e1), v0, v1, v2)
        || separated(cross3(units[a], e2), v0, v1, v2) {
      return false;
    }
  }
  return true;
}

fn component(v: vec3<f32>, k: u32) -> f32 {
  return select(select(v.z, v.y, k == 1u), v.x, k == 0u);
}

// [floor(min), floor(max)] of the triangle on `axis`, clamped to the grid.
fn footprint(q0: vec3<f32>, q1: vec3<f32>, q2: vec3<f32>, axis: u32, res: u32) -> vec2<i32> {
  let a = component(q0, axis);
  let b = component(q1, axis);
  let c = component(q2, axis);
  let lo = i32(clamp(floor(min(min(a, b), c)), -1.0, f32(res)));
  let hi = i32(clamp(floor(max(max(a, b), c)), -1.0, f32(res)));
  return vec2<i32>(max(lo, 0), min(hi, i32(res) - 1));
}

@compute @workgroup_size(64)
fn voxelize(@builtin(global_invocation_id) id: vec3<u32>) {
  let item_index = id.x + id.y * params.row_stride;
  if item_index >= params.item_count {
    return;
  }
  let item = items[item_index];
  let prim = item.x;
  let tiles = item.y >> 16u;
  let tile = item.y & 0xffffu;
  let v = params.direction_offset + id.z;
  let r0 = triangles[3u * prim];
  let r1 = triangles[3u * prim + 1u];
  let r2 = triangles[3u * prim + 2u];
  let object = select(0u, bitcast<u32>(r1.w), params.per_instance != 0u);
  let o = objects[object];
  let f = frames[o.frames + v];
  let q0 = to_voxel(o, f, r0.xyz);
  let q1 = to_voxel(o, f, r1.xyz);
  let q2 = to_voxel(o, f, r2.xyz);

  let n = cross3(q1 - q0, q2 - q0);
  let an = abs(n);
  var k = 2u;
  if an.x >= an.y && an.x >= an.z {
    k = 0u;
  } else if an.y >= an.z {
    k = 1u;
  }
  let i = select(0u, 1u, k == 0u);
  let j = select(2u, 1u, k == 2u);
  let nk = component(n, k);
  // (abs(nk) <= 3e38 is false for NaN and ±inf.)
  if nk == 0.0 || !(abs(nk) <= 3.0e38) {
    return;
  }
  // A triangle inside one voxel meets it: the separating-axis test would
  // say so too (the same bit as the CPU oracle), so set it directly.
  let cell_lo = floor(min(min(q0, q1), q2));
  let cell_hi = floor(max(max(q0, q1), q2));
  if all(cell_lo == cell_hi) {
    if tile == 0u && all(cell_lo >= vec3<f32>(0.0)) && all(cell_lo < vec3<f32>(f32(o.res))) {
      let c = vec3<u32>(cell_lo);
      let word = o.base + ((v * o.res + c.y) * o.res + c.x) * o.words + c.z / 32u;
      atomicOr(&bits[word], 1u << (c.z % 32u));
    }
    return;
  }
  let bi = footprint(q0, q1, q2, i, o.res);
  let bj = footprint(q0, q1, q2, j, o.res);
  let bk = footprint(q0, q1, q2, k, o.res);
  let ti = i32((tile % tiles) * TILE);
  let tj = i32((tile / tiles) * TILE);
  let i0 = max(bi.x + ti, bi.x);
  let i1 = min(bi.x + ti + i32(TILE) - 1, bi.y);
  let j0 = max(bj.x + tj, bj.x);
  let j1 = min(bj.x + tj + i32(TILE) - 1, bj.y);
  let si = component(n, i) / nk;
  let sj = component(n, j) / nk;
  let qi = component(q0, i);
  let qj = component(q0, j);
  let qk = component(q0, k);
  let res = f32(o.res);
  for (var ci = i0; ci <= i1; ci += 1) {
    for (var cj = j0; cj <= j1; cj += 1) {
      let base = qk - si * (f32(ci) - qi) - sj * (f32(cj) - qj);
      let kmin = base - max(si, 0.0) - max(sj, 0.0);
      let kmax = base - min(si, 0.0) - min(sj, 0.0);
      let z0 = max(i32(clamp(floor(kmin - 1e-3), -1.0, res)), bk.x);
      let z1 = min(i32(clamp(floor(kmax + 1e-3), -1.0, res)), bk.y);
      for (var ck = z0; ck <= z1; ck += 1) {
        var cell = vec3<i32>(0);
        cell[i] = ci;
        cell[j] = cj;
        cell[k] = ck;
        let centre = vec3<f32>(cell) + vec3<f32>(0.5);
        if triangle_meets_box(q0 - centre, q1 - centre, q2 - centre) {
          let c = vec3<u32>(cell);
          let word = o.base + ((v * o.res + c.y) * o.res + c.x) * o.words + c.z / 32u;
          atomicOr(&bits[word], 1u << (c.z % 32u));
        }
      }
    }
  }
}
