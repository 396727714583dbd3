// The stochastic substitute tree's binary radix tree built on the GPU
// (Tatzgern et al. 2020 §3.3; Karras 2012), bit for bit the CPU oracle
// src/lights/substitute/radix.rs in its BVH layout. The driver,
// src/lights/substitute/gpu_build.rs, documents the phases; after the
// bounds (bounds.wgsl) and the two stable sorts (classes, then
// morton.wgsl's morton_codes_sorted), the kernels here run in order:
//
//   classes_sorted  the 10-bit normal class of every sorted leaf
//   karras          one invocation per internal node (Karras Fig. 4)
//   number          the CPU's node numbering and each node's depth
//   place           ids, parents, leaves; depth histogram
//   level_args      one workgroup: per-depth offsets and indirect dispatches
//   bucket          internal nodes grouped by depth
//   merge_level     one depth, deepest first: bounds, cones, substitutes
//
// Needs light_prim.wgsl, cone.wgsl, substitute.wgsl, exact.wgsl and
// radix_bindings.wgsl. Constants from Rust: WG, LEVELS, INTERNAL_BIT.

const RIGHT_BIT: u32 = 0x80000000u;
// Scratch arrays, params.cap entries each.
const S_CLASS: u32 = 0u;
const S_FIRST: u32 = 1u;
const S_PARENT_INT: u32 = 2u;
const S_PARENT_LEAF: u32 = 3u;
const S_CBASE: u32 = 4u;
const S_DEPTH: u32 = 5u;
const S_FIDX: u32 = 6u;
const S_BUCKET: u32 = 7u;

fn at(slot: u32, i: u32) -> u32 {
    return slot * params.cap + i;
}

// radix.rs normal_class: the 9-bit code, or 1 << 9 without a normal.
fn normal_class(l: LightPrim) -> u32 {
    let n = prim_normal(l);
    if (all(n == vec3<f32>(0.0))) {
        return 1u << 9u;
    }
    return normal_code(n);
}

@compute @workgroup_size(WG)
fn normal_classes(@builtin(workgroup_id) wid: vec3<u32>,
                  @builtin(num_workgroups) groups: vec3<u32>,
                  @builtin(local_invocation_index) lid: u32) {
    let i = linear_index(wid, groups, lid);
    if (i >= params.n) {
        return;
    }
    codes[i] = normal_class(prims[i]);
    sorted_ids[i] = i;
}

@compute @workgroup_size(WG)
fn classes_sorted(@builtin(workgroup_id) wid: vec3<u32>,
                  @builtin(num_workgroups) groups: vec3<u32>,
                  @builtin(local_invocation_index) lid: u32) {
    let s = linear_index(wid, groups, lid);
    if (s >= params.n) {
        return;
    }
    scratch[at(S_CLASS, s)] = normal_class(prims[sorted_ids[s]]);
}

// radix.rs delta(i, j) for j = i + off·d: the common prefix of the 40-bit
// keys (Morton code above the class), 64 + that of the indices as u64 for
// equal keys; −1 outside [0, n).
fn delta_off(i: u32, off: u32, d: i32) -> i32 {
    var j: u32;
    if (d > 0) {
        if (off > params.n - 1u - i) {
            return -1;
        }
        j = i + off;
    } else {
        if (off > i) {
            return -1;
        }
        j = i - off;
    }
    let xm = codes[i] ^ codes[j];
    if (xm != 0u) {
        return 22 + i32(countLeadingZeros(xm));
    }
    let xc = scratch[at(S_CLASS, i)] ^ scratch[at(S_CLASS, j)];
    if (xc != 0u) {
        return 32 + i32(countLeadingZeros(xc));
    }
    return 96 + i32(countLeadingZeros(i ^ j));
}

// Karras 2012 Fig. 4 for internal node i: the direction of its range, its
// other end j by exponential then binary search on δ, its split γ by
// binary search; the children (leaf γ when the range starts at γ, else
// internal γ; leaf γ + 1 when it ends there, else internal γ + 1) record
// i as their parent, the right one with RIGHT_BIT.
@compute @workgroup_size(WG)
fn karras(@builtin(workgroup_id) wid: vec3<u32>,
          @builtin(num_workgroups) groups: vec3<u32>,
          @builtin(local_invocation_index) lid: u32) {
    let i = linear_index(wid, groups, lid);
    if (i + 1u >= params.n) {
        return;
    }
    let d = select(-1, 1, delta_off(i, 1u, 1) > delta_off(i, 1u, -1));
    let dmin = delta_off(i, 1u, -d);
    var lmax = 2u;
    while (delta_off(i, lmax, d) > dmin) {
        lmax *= 2u;
    }
    var len = 0u;
    for (var t = lmax / 2u; t >= 1u; t /= 2u) {
        if (delta_off(i, len + t, d) > dmin) {
            len += t;
        }
    }
    let dnode = delta_off(i, len, d);
    var s = 0u;
    for (var k = 1u; k < 32u; k++) {
        let t = (len + (1u << k) - 1u) >> k;
        if (delta_off(i, s + t, d) > dnode) {
            s += t;
        }
        if (t == 1u) {
            break;
        }
    }
    var first = i;
    var last = i + len;
    var gamma = i + s;
    if (d < 0) {
        first = i - len;
        last = i;
        gamma = i - s - 1u;
    }
    scratch[at(S_FIRST, i)] = first;
    if (first == gamma) {
        scratch[at(S_PARENT_LEAF, gamma)] = i;
    } else {
        scratch[at(S_PARENT_INT, gamma)] = i;
    }
    if (last == gamma + 1u) {
        scratch[at(S_PARENT_LEAF, gamma + 1u)] = i | RIGHT_BIT;
    } else {
        scratch[at(S_PARENT_INT, gamma + 1u)] = i | RIGHT_BIT;
    }
}

// The CPU numbers nodes as its depth-first build pops them: the k-th
// internal node popped (preorder) gets children 1 + 2k and 2 + 2k. The
// internal nodes before X in preorder are its ancestors and those of the
// subtrees left of its path, which hold the leaves [0, first): k = first +
// (left turns from the root to X). Walking up gives the left turns and the
// depth.
@compute @workgroup_size(WG)
fn number(@builtin(workgroup_id) wid: vec3<u32>,
          @builtin(num_workgroups) groups: vec3<u32>,
          @builtin(local_invocation_index) lid: u32) {
    let i = linear_index(wid, groups, lid);
    if (i + 1u >= params.n) {
        return;
    }
    var x = i;
    var left_turns = 0u;
    var depth = 0u;
    while (x != 0u) {
        let p = scratch[at(S_PARENT_INT, x)];
        left_turns += 1u - (p >> 31u);
        depth += 1u;
        x = p & ~RIGHT_BIT;
    }
    scratch[at(S_CBASE, i)] = 1u + 2u * (scratch[at(S_FIRST, i)] + left_turns);
    scratch[at(S_DEPTH, i)] = min(depth, LEVELS - 1u);
}

// The node index of a node whose parent entry is p.
fn index_below(p: u32) -> u32 {
    return scratch[at(S_CBASE, p & ~RIGHT_BIT)] + (p >> 31u);
}

fn index_of_internal(i: u32) -> u32 {
    if (i == 0u) {
        return 0u;
    }
    return index_below(scratch[at(S_PARENT_INT, i)]);
}

// Invocation t < n − 1: internal node t (its index, its parent, the depth
// histogram); t ≥ n − 1: leaf t − (n − 1) (its node, cone and substitute,
// its light's leaf, its parent). node_index holds leaf_of_light[0, n),
// then parent[n, 3n − 1).
@compute @workgroup_size(WG)
fn place(@builtin(workgroup_id) wid: vec3<u32>,
         @builtin(num_workgroups) groups: vec3<u32>,
         @builtin(local_invocation_index) lid: u32) {
    opaque_zero = params.zero;
    let t = linear_index(wid, groups, lid);
    let n = params.n;
    if (t >= 2u * n - 1u) {
        return;
    }
    if (t + 1u < n) {
        let f = index_of_internal(t);
        scratch[at(S_FIDX, t)] = f;
        var parent = NO_LIGHT;
        if (t != 0u) {
            parent = index_of_internal(scratch[at(S_PARENT_INT, t)] & ~RIGHT_BIT);
        }
        node_index[n + f] = parent;
        atomicAdd(&levels[scratch[at(S_DEPTH, t)]], 1u);
        return;
    }
    let k = t + 1u - n;
    var f = 0u;
    var parent = NO_LIGHT;
    if (n > 1u) {
        let p = scratch[at(S_PARENT_LEAF, k)];
        f = index_below(p);
        parent = index_of_internal(p & ~RIGHT_BIT);
    }
    let id = sorted_ids[k];
    let l = prims[id];
    nodes[f] = x_leaf_node(l, id);
    cones[f] = x_cone_of_prim(l);
    substitutes[f] = substitute_of_prim(l);
    node_index[id] = f;
    node_index[n + f] = parent;
}

// levels: [0, LEVELS) internal nodes per depth, [LEVELS, 2·LEVELS) their
// offsets in the bucket array, [2·LEVELS, 3·LEVELS) the bucket cursors.
@compute @workgroup_size(1)
fn level_args() {
    var run = 0u;
    for (var d = 0u; d < LEVELS; d++) {
        let count = atomicLoad(&levels[d]);
        atomicStore(&levels[LEVELS + d], run);
        atomicStore(&levels[2u * LEVELS + d], run);
        run += count;
        // Gpu::dispatch_dims of ⌈count / WG⌉ workgroups (none when 0).
        let wgs = (count + WG - 1u) / WG;
        var gx = wgs;
        var gy = 1u;
        if (wgs > params.max_groups_x) {
            gy = (wgs + params.max_groups_x - 1u) / params.max_groups_x;
            gx = (wgs + gy - 1u) / gy;
        }
        args[3u * d] = gx;
        args[3u * d + 1u] = gy;
        args[3u * d + 2u] = 1u;
    }
}

@compute @workgroup_size(WG)
fn bucket(@builtin(workgroup_id) wid: vec3<u32>,
          @builtin(num_workgroups) groups: vec3<u32>,
          @builtin(local_invocation_index) lid: u32) {
    let i = linear_index(wid, groups, lid);
    if (i + 1u >= params.n) {
        return;
    }
    let slot = atomicAdd(&levels[2u * LEVELS + scratch[at(S_DEPTH, i)]], 1u);
    scratch[at(S_BUCKET, slot)] = i;
}

// The internal nodes of depth params.level from their children (all
// deeper, so built by earlier dispatches or by `place`), with the CPU's
// gather, cone union and substitute merge.
@compute @workgroup_size(WG)
fn merge_level(@builtin(workgroup_id) wid: vec3<u32>,
               @builtin(num_workgroups) groups: vec3<u32>,
               @builtin(local_invocation_index) lid: u32) {
    opaque_zero = params.zero;
    let t = linear_index(wid, groups, lid);
    let d = params.level;
    if (t >= atomicLoad(&levels[d])) {
        return;
    }
    let i = scratch[at(S_BUCKET, atomicLoad(&levels[LEVELS + d]) + t)];
    let f = scratch[at(S_FIDX, i)];
    let c = scratch[at(S_CBASE, i)];
    let a = nodes[c];
    let b = nodes[c + 1u];
    nodes[f] = TreeNode(min(a.bmin, b.bmin), a.intensity + b.intensity, max(a.bmax, b.bmax), INTERNAL_BIT | c);
    cones[f] = x_cone_union(cones[c], cones[c + 1u]);
    substitutes[f] = x_substitute_merge(substitutes[c], a.intensity, substitutes[c + 1u], b.intensity);
}
