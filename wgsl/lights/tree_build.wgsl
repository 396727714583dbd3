// The perfect light tree's nodes (real-time stochastic lightcuts §3.1, §4):
// `leaves` copies the Morton-sorted lights into the leaf level, pads it with
// bogus leaves and records each light's leaf slot (and their cones when
// asked); `cone_level` merges the cones of one level; `internal` builds k
// levels above a source level ℓs in one dispatch. src/lights/tree/gpu_build.rs
// explains why the result equals the level-by-level CPU oracle bit for bit.

@compute @workgroup_size(WG)
fn leaves(@builtin(workgroup_id) wid: vec3<u32>,
          @builtin(num_workgroups) groups: vec3<u32>,
          @builtin(local_invocation_index) lid: u32) {
    opaque_zero = params.zero;
    let slot = linear_index(wid, groups, lid);
    let p = params.leaf_count;
    if (slot >= p) {
        return;
    }
    if (slot < params.n) {
        let id = sorted_ids[slot];
        nodes[p - 1u + slot] = leaf_node(prims[id], id);
        leaf_of_light[id] = slot;
        if (params.cones != 0u) {
            cones[p - 1u + slot] = cone_of_prim(prims[id]);
        }
    } else {
        nodes[p - 1u + slot] = empty_node();
        if (params.cones != 0u) {
            cones[p - 1u + slot] = cone_empty();
        }
    }
}

// The cones of level ℓ = params.src_level from the level below (one
// dispatch per level, after `leaves`): the same pairwise order as the CPU's.
@compute @workgroup_size(WG)
fn cone_level(@builtin(workgroup_id) wid: vec3<u32>,
              @builtin(num_workgroups) groups: vec3<u32>,
              @builtin(local_invocation_index) lid: u32) {
    let j = linear_index(wid, groups, lid);
    let level = params.src_level;
    if (j >= (1u << level)) {
        return;
    }
    let i = (1u << level) - 1u + j;
    cones[i] = cone_union(cones[2u * i + 1u], cones[2u * i + 2u]);
}

// The substitutes of level ℓ = params.src_level (one dispatch per level,
// leaves first, after `internal`): a leaf's from its light, an internal
// node's from its children, weighted by their intensities.
@compute @workgroup_size(WG)
fn substitute_level(@builtin(workgroup_id) wid: vec3<u32>,
                    @builtin(num_workgroups) groups: vec3<u32>,
                    @builtin(local_invocation_index) lid: u32) {
    opaque_zero = params.zero;
    let j = linear_index(wid, groups, lid);
    let level = params.src_level;
    if (j >= (1u << level)) {
        return;
    }
    let i = (1u << level) - 1u + j;
    if (i + 1u >= params.leaf_count) {
        let id = nodes[i].id;
        if (id == NO_LIGHT) {
            substitutes[i] = substitute_zero();
        } else {
            substitutes[i] = substitute_of_prim(prims[id]);
        }
        return;
    }
    let l = 2u * i + 1u;
    substitutes[i] = substitute_merge(substitutes[l], nodes[l].intensity, substitutes[l + 1u], nodes[l + 1u].intensity);
}

// A workgroup loads B = 2^k consecutive nodes of level ℓs and gathers them
// pairwise in shared memory, writing level ℓs − t (t = 1..k) as it goes:
// destination node j of level ℓs − t is the balanced pairwise gather, in
// child order, of source nodes [j·2^t, (j+1)·2^t).
var<workgroup> wg_lo: array<vec4<f32>, WG>;
var<workgroup> wg_hi: array<vec4<f32>, WG>;

fn gather_lo(a: vec4<f32>, b: vec4<f32>) -> vec4<f32> {
    return vec4<f32>(min(a.xyz, b.xyz), a.w + b.w);
}

@compute @workgroup_size(WG)
fn internal(@builtin(workgroup_id) wid: vec3<u32>,
            @builtin(num_workgroups) groups: vec3<u32>,
            @builtin(local_invocation_index) lid: u32) {
    let src = params.src_level;
    let k = params.levels_up;
    let block = 1u << k;
    let w = wid.x + wid.y * groups.x;
    let in_range = w < (1u << (src - k));
    if (in_range && lid < block) {
        let node = nodes[(1u << src) - 1u + w * block + lid];
        wg_lo[lid] = vec4<f32>(node.bmin, node.intensity);
        wg_hi[lid] = vec4<f32>(node.bmax, 0.0);
    }
    workgroupBarrier();
    for (var t = 1u; t <= k; t++) {
        let width = block >> t;
        var lo: vec4<f32>;
        var hi: vec4<f32>;
        if (lid < width) {
            lo = gather_lo(wg_lo[2u * lid], wg_lo[2u * lid + 1u]);
            hi = vec4<f32>(max(wg_hi[2u * lid].xyz, wg_hi[2u * lid + 1u].xyz), 0.0);
        }
        workgroupBarrier();
        if (lid < width) {
            wg_lo[lid] = lo;
            wg_hi[lid] = hi;
            if (in_range) {
                let level = src - t;
                nodes[(1u << level) - 1u + w * width + lid] =
                    TreeNode(lo.xyz, lo.w, hi.xyz, NO_LIGHT);
            }
        }
        workgroupBarrier();
    }
}
