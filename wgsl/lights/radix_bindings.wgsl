// Bindings of the radix substitute tree's build kernels
// (src/lights/substitute/gpu_build.rs): one group-0 layout for all of
// them, with the names bounds.wgsl and morton.wgsl read (params.n,
// params.zero, prims, centroid_bounds, codes, sorted_ids); group 1 only
// for level_args, which writes the indirect dispatches.

struct RadixParams {
    // Number of lights N.
    n: u32,
    // 0, for mul_rn (light_prim.wgsl).
    zero: u32,
    // merge_level: the depth it builds.
    level: u32,
    // Entries of each scratch array (the tree's capacity).
    cap: u32,
    // The adapter's workgroups per dimension (level_args).
    max_groups_x: u32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

@group(0) @binding(0) var<uniform> params: RadixParams;
@group(0) @binding(1) var<storage, read> prims: array<LightPrim>;
// Centroid bounds as order-preserving bits (tree_bindings.wgsl).
@group(0) @binding(2) var<storage, read_write> centroid_bounds: array<atomic<u32>, 6>;
// Sort keys, then the sorted Morton codes.
@group(0) @binding(3) var<storage, read_write> codes: array<u32>;
@group(0) @binding(4) var<storage, read_write> sorted_ids: array<u32>;
// The tree (2N − 1 nodes in the BVH layout), its index table
// (leaf_of_light, then parent), cones and substitutes.
@group(0) @binding(5) var<storage, read_write> nodes: array<TreeNode>;
@group(0) @binding(6) var<storage, read_write> node_index: array<u32>;
@group(0) @binding(7) var<storage, read_write> cones: array<LightCone>;
@group(0) @binding(8) var<storage, read_write> substitutes: array<Substitute>;
// Per-node scratch arrays (radix_build.wgsl S_*).
@group(0) @binding(9) var<storage, read_write> scratch: array<u32>;
// Per-depth counts, offsets and cursors (radix_build.wgsl level_args).
@group(0) @binding(10) var<storage, read_write> levels: array<atomic<u32>>;
// Indirect dispatch arguments of merge_level, one triple per depth.
@group(1) @binding(0) var<storage, read_write> args: array<u32>;

// Linear invocation index of a 2D dispatch of WG-wide workgroups.
fn linear_index(wid: vec3<u32>, groups: vec3<u32>, lid: u32) -> u32 {
    return (wid.x + wid.y * groups.x) * WG + lid;
}
