// Ray queries against the scene's two-level CWBVH: `trace_closest` and
// `trace_any`. Needs shared/scene.wgsl and the generated constants
// BVH_STACK_SIZE, BVH_MAX_STEPS and BVH_T_MIN_REL_BITS (GpuScene::wgsl()).
//
// Traversal: Ylitie, Karras & Laine 2017, "Efficient Incoherent Ray
// Traversal on GPUs Through Compressed Wide BVHs" (Algorithm 1 and §3.2),
// in the form of obvhs' `traverse!` and van Bergen's GPU-Raytracer BVH8
// kernel: a node group (child base, hit bits in the top byte, imask in the
// low byte) and a primitive group (base, hit bits in the low 24 bits),
// children visited nearest-first through the octant-dependent slot order
// the builder laid out, remaining groups on a fixed-size private stack.
// The TLAS and BLASes share the stack: a TLAS leaf's primitive is an
// instance; entering it pushes what is left of the TLAS, remembers the
// stack size, transforms the ray into object space at `time` (inverse
// rigid transform, direction *not* renormalized so t is the same in both
// spaces) and continues at the BLAS root; when the stack drops back to
// the remembered size the world ray is restored.
//
// Robustness:
// - Ray direction components that are ±0 or smaller than BVH_DIR_EPS in
//   magnitude are replaced by ±BVH_DIR_EPS (−0.0 becomes +BVH_DIR_EPS)
//   before the inverse direction and the octant are computed, so the
//   octant test and the slab test always agree in sign and no 0·∞ NaN
//   arises (obvhs' octant test breaks on −0.0). The triangle test uses the
//   unmodified direction.
// - The node test is conservative (in the spirit of Ize 2013, "Robust BVH
//   Ray Traversal"): a slab distance q·e/d + (p − o)/d carries rounding
//   error relative to its *terms*, not to its value (the reciprocal, the
//   (p − o) product and the multiply-add each add ≤ 2.5 ulps), so every
//   entry is lowered and every exit raised by
//   BVH_BOX_REL_ERR·(|p − o| + 255·e)/|d| per axis (≈ 8 ulps of the
//   largest term), and entries are clamped at 0, not t_min. Without this,
//   rays crossing a box's edge exactly where two axis-aligned child boxes
//   meet were culled (found by the shared-edge test).
// - Triangles: watertight test (Woop, Benthin & Wald 2013); edges and
//   vertices are inclusive, so a ray through a shared edge hits both
//   neighbours and cannot slip through. Hits count when
//   t_min < t < t_max, t_min = T_MIN_REL·max(1, ‖o‖∞)/‖d‖∞ from the world
//   ray (src/accel/cpu.rs explains the choice and is the CPU twin).
//
// Loop bound (lavapipe stops any invocation after 65,535 loop iterations
// in total): one traversal iteration visits one node or tests one
// triangle/enters one instance, and a query gives up after BVH_MAX_STEPS
// iterations (returning what it found so far; the trace tests check no
// ray gets near it), plus at most key_count − 2 iterations of the keyframe
// search per moving instance entered. Callers budget BVH_MAX_STEPS per
// trace call.

const BVH_MISS: u32 = 0xffffffffu;
const BVH_DIR_EPS: f32 = 1e-12;
const BVH_BOX_REL_ERR: f32 = 1e-6;

struct Hit {
  t: f32,
  prim: u32,        // global triangle index into `triangles`/3; 0xffffffffu = miss
  bary: vec2<f32>,  // barycentrics of v1 and v2: p = (1−b.x−b.y)·v0 + b.x·v1 + b.y·v2
}

// A ray in one space (world or an instance's object space), prepared for
// the node and triangle tests.
struct BvhRay {
  origin: vec3<f32>,
  inv_dir: vec3<f32>,   // 1 / sanitized direction
  oct_inv4: u32,        // (7 − octant) replicated in 4 bytes
  k: vec3<u32>,         // watertight axes kx, ky, kz
  shear: vec3<f32>,     // (d[kx]/d[kz], d[ky]/d[kz], 1/d[kz])
}

fn ray_t_min(origin: vec3<f32>, dir: vec3<f32>) -> f32 {
  let o = abs(origin);
  let d = abs(dir);
  return bitcast<f32>(BVH_T_MIN_REL_BITS) * max(max(o.x, o.y), max(o.z, 1.0)) / max(max(d.x, d.y), d.z);
}

fn bvh_ray(origin: vec3<f32>, dir: vec3<f32>) -> BvhRay {
  let tiny = abs(dir) < vec3<f32>(BVH_DIR_EPS);
  let signed_eps = select(vec3<f32>(BVH_DIR_EPS), vec3<f32>(-BVH_DIR_EPS), dir < vec3<f32>(0.0));
  let d = select(dir, signed_eps, tiny);
  let oct_inv4 = select(0x04040404u, 0u, d.x < 0.0)
    | select(0x02020202u, 0u, d.y < 0.0)
    | select(0x01010101u, 0u, d.z < 0.0);

  let a = abs(dir);
  var kz = 2u;
  if a.x > a.y && a.x > a.z {
    kz = 0u;
  } else if a.y > a.z {
    kz = 1u;
  }
  var kx = (kz + 1u) % 3u;
  var ky = (kx + 1u) % 3u;
  if dir[kz] < 0.0 {
    let swap = kx;
    kx = ky;
    ky = swap;
  }
  let shear = vec3<f32>(dir[kx] / dir[kz], dir[ky] / dir[kz], 1.0 / dir[kz]);
  return BvhRay(origin, 1.0 / d, oct_inv4, vec3<u32>(kx, ky, kz), shear);
}

struct TriangleHit { hit: bool, t: f32, bary: vec2<f32> }

// Watertight ray–triangle test; same operations as ShearedRay::intersect
// in src/accel/cpu.rs.
fn intersect_triangle(ray: BvhRay, v0: vec3<f32>, v1: vec3<f32>, v2: vec3<f32>, t_min: f32, t_max: f32) -> TriangleHit {
  var out = TriangleHit(false, 0.0, vec2<f32>(0.0));
  let kx = ray.k.x;
  let ky = ray.k.y;
  let kz = ray.k.z;
  let s = ray.shear;
  let a = v0 - ray.origin;
  let b = v1 - ray.origin;
  let c = v2 - ray.origin;
  let ax = a[kx] - s.x * a[kz];
  let ay = a[ky] - s.y * a[kz];
  let bx = b[kx] - s.x * b[kz];
  let by = b[ky] - s.y * b[kz];
  let cx = c[kx] - s.x * c[kz];
  let cy = c[ky] - s.y * c[kz];
  let u = cx * by - cy * bx;
  let v = ax * cy - ay * cx;
  let w = bx * ay - by * ax;
  if (u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0) {
    return out;
  }
  let det = u + v + w;
  if det == 0.0 {
    return out;
  }
  let az = s.z * a[kz];
  let bz = s.z * b[kz];
  let cz = s.z * c[kz];
  let rcp_det = 1.0 / det;
  let t = (u * az + v * bz + w * cz) * rcp_det;
  if !(t > t_min && t < t_max) {
    return out;
  }
  out = TriangleHit(true, t, vec2<f32>(v * rcp_det, w * rcp_det));
  return out;
}

// Hit bits of one child (byte `shift`/8 of the packed words).
// adj_near / adj_far: (p − o)/d lowered / raised by the error bound.
fn bvh_child_hit(shift: u32, near: vec3<u32>, far: vec3<u32>, adj_inv: vec3<f32>, adj_near: vec3<f32>,
                 adj_far: vec3<f32>, child_bits4: u32, bit_index4: u32, t_max: f32) -> u32 {
  let qn = vec3<f32>((near >> vec3<u32>(shift)) & vec3<u32>(0xffu));
  let qf = vec3<f32>((far >> vec3<u32>(shift)) & vec3<u32>(0xffu));
  let tn = qn * adj_inv + adj_near;
  let tf = qf * adj_inv + adj_far;
  let t_enter = max(max(tn.x, tn.y), max(tn.z, 0.0));
  let t_exit = min(min(tf.x, tf.y), min(tf.z, t_max));
  if t_enter <= t_exit {
    return ((child_bits4 >> shift) & 0xffu) << ((bit_index4 >> shift) & 0xffu);
  }
  return 0u;
}

// Hit bits of four children sharing the meta word `meta4`.
fn bvh_node_quad(meta4: u32, near: vec3<u32>, far: vec3<u32>, adj_inv: vec3<f32>, adj_near: vec3<f32>,
                 adj_far: vec3<f32>, oct_inv4: u32, t_max: f32) -> u32 {
  // Internal children have meta 001xxxxx with xxxxx = 24 + slot: both bit
  // 3 and bit 4 set, which a leaf's offset (< 24) never has.
  let is_inner4 = (meta4 & (meta4 << 1u)) & 0x10101010u;
  let inner_mask4 = (is_inner4 >> 4u) * 0xffu;
  // Internal: 24 + (slot ^ (7 − octant)), the traversal priority bit;
  // leaf: the triangle offset from primitive_base_idx.
  let bit_index4 = (meta4 ^ (oct_inv4 & inner_mask4)) & 0x1f1f1f1fu;
  // Internal: 1; leaf: the unary triangle count; empty: 0.
  let child_bits4 = (meta4 >> 5u) & 0x07070707u;
  return bvh_child_hit(0u, near, far, adj_inv, adj_near, adj_far, child_bits4, bit_index4, t_max)
    | bvh_child_hit(8u, near, far, adj_inv, adj_near, adj_far, child_bits4, bit_index4, t_max)
    | bvh_child_hit(16u, near, far, adj_inv, adj_near, adj_far, child_bits4, bit_index4, t_max)
    | bvh_child_hit(24u, near, far, adj_inv, adj_near, adj_far, child_bits4, bit_index4, t_max);
}

// Hit mask of a node's 8 children: top byte internal children (bit 24 +
// priority), low 24 bits triangles. Loop-free (see the loop bound above).
fn bvh_node_hits(node: BvhNode, ray: BvhRay, t_max: f32) -> u32 {
  let e_imask = bitcast<u32>(node.p_e.w);
  let e = vec3<f32>(
    bitcast<f32>((e_imask & 0xffu) << 23u),
    bitcast<f32>(((e_imask >> 8u) & 0xffu) << 23u),
    bitcast<f32>(((e_imask >> 16u) & 0xffu) << 23u),
  );
  let adj_inv = e * ray.inv_dir;
  let adj_o = (node.p_e.xyz - ray.origin) * ray.inv_dir;
  let err = BVH_BOX_REL_ERR * (abs(adj_o) + 255.0 * abs(adj_inv));
  let adj_near = adj_o - err;
  let adj_far = adj_o + err;
  let neg = ray.inv_dir < vec3<f32>(0.0);
  let lo0 = vec3<u32>(node.qx.x, node.qy.x, node.qz.x);
  let lo1 = vec3<u32>(node.qx.y, node.qy.y, node.qz.y);
  let hi0 = vec3<u32>(node.qx.z, node.qy.z, node.qz.z);
  let hi1 = vec3<u32>(node.qx.w, node.qy.w, node.qz.w);
  return bvh_node_quad(node.ids.z, select(lo0, hi0, neg), select(hi0, lo0, neg), adj_inv, adj_near, adj_far, ray.oct_inv4, t_max)
    | bvh_node_quad(node.ids.w, select(lo1, hi1, neg), select(hi1, lo1, neg), adj_inv, adj_near, adj_far, ray.oct_inv4, t_max);
}

struct BvhTrace { hit: Hit, steps: u32 }

// Two-level CWBVH traversal. `any_hit`: stop at the first hit. On a miss
// hit.t = t_max and hit.prim = BVH_MISS. `steps` = loop iterations used.
fn bvh_traverse(origin: vec3<f32>, dir: vec3<f32>, t_max: f32, time: f32, any_hit: bool) -> BvhTrace {
  var result = BvhTrace(Hit(t_max, BVH_MISS, vec2<f32>(0.0)), 0u);
  if scene.instance_count == 0u {
    return result;
  }
  let t_min = ray_t_min(origin, dir);
  let world = bvh_ray(origin, dir);
  var ray = world;
  var stack: array<vec2<u32>, BVH_STACK_SIZE>;
  var sp = 0u;
  // The root is "internal child in slot 7" of a virtual parent: any
  // octant's priority bit 31 maps back to relative index 0.
  var node_group = vec2<u32>(scene.tlas_root, 0x80000000u);
  var prim_group = vec2<u32>(0u);
  var blas_sp = BVH_MISS; // stack size when the current BLAS was entered; BVH_MISS = in the TLAS
  loop {
    if result.steps >= BVH_MAX_STEPS {
      break;
    }
    result.steps += 1u;

    if prim_group.y != 0u {
      let local = firstLeadingBit(prim_group.y);
      prim_group.y &= ~(1u << local);
      let index = prim_group.x + local;
      if blas_sp == BVH_MISS {
        // TLAS leaf: descend into instance `index`.
        if prim_group.y != 0u {
          stack[sp] = prim_group;
          sp += 1u;
        }
        if (node_group.y & 0xff000000u) != 0u {
          stack[sp] = node_group;
          sp += 1u;
        }
        blas_sp = sp;
        let info = instances[index];
        if info.key_count != 0u {
          let x = instance_transform_at(index, time);
          ray = bvh_ray(rigid_inverse_point(x, origin), rigid_inverse_vector(x, dir));
        }
        node_group = vec2<u32>(info.node_root, 0x80000000u);
        prim_group = vec2<u32>(0u);
      } else {
        let v0 = triangles[3u * index].xyz;
        let v1 = triangles[3u * index + 1u].xyz;
        let v2 = triangles[3u * index + 2u].xyz;
        let h = intersect_triangle(ray, v0, v1, v2, t_min, result.hit.t);
        if h.hit {
          result.hit = Hit(h.t, index, h.bary);
          if any_hit {
            break;
          }
        }
      }
      continue;
    }

    if (node_group.y & 0xff000000u) != 0u {
      // Visit the nearest remaining child node of the group.
      let hits_imask = node_group.y;
      let child_bit = firstLeadingBit(hits_imask);
      node_group.y &= ~(1u << child_bit);
      if (node_group.y & 0xff000000u) != 0u {
        stack[sp] = node_group;
        sp += 1u;
      }
      let slot = (child_bit - 24u) ^ (ray.oct_inv4 & 0xffu);
      let relative = countOneBits(hits_imask & ~(0xffffffffu << slot));
      let node = nodes[node_group.x + relative];
      let hitmask = bvh_node_hits(node, ray, result.hit.t);
      node_group = vec2<u32>(node.ids.x, (hitmask & 0xff000000u) | (bitcast<u32>(node.p_e.w) >> 24u));
      prim_group = vec2<u32>(node.ids.y, hitmask & 0x00ffffffu);
      continue;
    }

    // Both groups exhausted: pop, leaving the BLAS when its entries are gone.
    if sp == 0u {
      break;
    }
    if sp == blas_sp {
      blas_sp = BVH_MISS;
      ray = world;
    }
    sp -= 1u;
    let group = stack[sp];
    if (group.y & 0xff000000u) != 0u {
      node_group = group;
    } else {
      prim_group = group;
      node_group = vec2<u32>(0u);
    }
  }
  return result;
}

// Closest hit with t_min < t < t_max at scene time `time`; prim = 0xffffffffu on a miss.
fn trace_closest(origin: vec3<f32>, dir: vec3<f32>, t_max: f32, time: f32) -> Hit {
  return bvh_traverse(origin, dir, t_max, time, false).hit;
}

// Whether anything is hit with t_min < t < t_max at scene time `time`.
fn trace_any(origin: vec3<f32>, dir: vec3<f32>, t_max: f32, time: f32) -> bool {
  return bvh_traverse(origin, dir, t_max, time, true).hit.prim != BVH_MISS;
}
