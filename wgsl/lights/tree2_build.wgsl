// The two-level tree's bottom levels gathered on the GPU every frame
// (src/lights/two_level/gpu.rs; the plan is two_level::GpuPlan): `leaves`
// writes every bottom level's leaves from the frame's lights, `joins` the
// nodes of one height from their children (one dispatch per height,
// lowest first). A destination with T2_ROOT_BIT is a group's root and goes
// to roots / root_cones (read back for the top level, built on the host);
// any other is a slot of nodes / cones. The same operations as the CPU's
// GpuPlan::tree_on_cpu: the node fields bit for bit (light_prim.wgsl), the
// cones within the stated tolerance (cone.wgsl).
// Constants from Rust: WG, T2_ROOT_BIT, T2_INTERNAL_BIT.

struct Tree2Params {
    // Entries of plan this dispatch handles, from `first`.
    count: u32,
    first: u32,
    // 0, for mul_rn (light_prim.wgsl).
    zero: u32,
    _pad: u32,
}

@group(0) @binding(0) var<uniform> params: Tree2Params;
@group(0) @binding(1) var<storage, read> prims: array<LightPrim>;
// (destination, light) for leaves, (destination, left child) for joins.
@group(0) @binding(2) var<storage, read> plan: array<vec2<u32>>;
@group(0) @binding(3) var<storage, read_write> nodes: array<TreeNode>;
@group(0) @binding(4) var<storage, read_write> cones: array<LightCone>;
@group(0) @binding(5) var<storage, read_write> roots: array<TreeNode>;
@group(0) @binding(6) var<storage, read_write> root_cones: array<LightCone>;

fn t2_store(dest: u32, node: TreeNode, cone: LightCone) {
    if ((dest & T2_ROOT_BIT) != 0u) {
        let g = dest & ~T2_ROOT_BIT;
        roots[g] = node;
        root_cones[g] = cone;
    } else {
        nodes[dest] = node;
        cones[dest] = cone;
    }
}

fn t2_entry(wid: vec3<u32>, groups: vec3<u32>, lid: u32) -> u32 {
    return (wid.x + wid.y * groups.x) * WG + lid;
}

@compute @workgroup_size(WG)
fn leaves(@builtin(workgroup_id) wid: vec3<u32>,
          @builtin(num_workgroups) groups: vec3<u32>,
          @builtin(local_invocation_index) lid: u32) {
    opaque_zero = params.zero;
    let i = t2_entry(wid, groups, lid);
    if (i >= params.count) {
        return;
    }
    let e = plan[params.first + i];
    let prim = prims[e.y];
    t2_store(e.x, leaf_node(prim, e.y), cone_of_prim(prim));
}

@compute @workgroup_size(WG)
fn joins(@builtin(workgroup_id) wid: vec3<u32>,
         @builtin(num_workgroups) groups: vec3<u32>,
         @builtin(local_invocation_index) lid: u32) {
    let i = t2_entry(wid, groups, lid);
    if (i >= params.count) {
        return;
    }
    let e = plan[params.first + i];
    let l = nodes[e.y];
    let r = nodes[e.y + 1u];
    // perfect::gather: componentwise min/max and one f32 addition.
    let node = TreeNode(min(l.bmin, r.bmin), l.intensity + r.intensity, max(l.bmax, r.bmax), T2_INTERNAL_BIT | e.y);
    t2_store(e.x, node, cone_union(cones[e.y], cones[e.y + 1u]));
}
