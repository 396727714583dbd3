// Bindings shared by the light tree build kernels (src/lights/tree/gpu_build.rs).
// One layout for all of them; each kernel uses the ones it needs.

struct BuildParams {
    // Number of lights N.
    n: u32,
    // P: N rounded up to a power of two.
    leaf_count: u32,
    // 0, for mul_rn (light_prim.wgsl).
    zero: u32,
    // internal: the source level ℓs and how many levels k it builds above it;
    // cone_level: the level ℓ it builds.
    src_level: u32,
    levels_up: u32,
    // 1: also build the nodes' cones (binding 7).
    cones: u32,
    _pad1: u32,
    _pad2: u32,
}

@group(0) @binding(0) var<uniform> params: BuildParams;
@group(0) @binding(1) var<storage, read> prims: array<LightPrim>;
// Centroid bounds as order-preserving bits: [0, 3) = ~bits of the minimum,
// [3, 6) = bits of the maximum; both reduced with atomicMax from zero.
@group(0) @binding(2) var<storage, read_write> centroid_bounds: array<atomic<u32>, 6>;
@group(0) @binding(3) var<storage, read_write> codes: array<u32>;
@group(0) @binding(4) var<storage, read_write> sorted_ids: array<u32>;
@group(0) @binding(5) var<storage, read_write> nodes: array<TreeNode>;
@group(0) @binding(6) var<storage, read_write> leaf_of_light: array<u32>;
// The nodes' orientation bounds (2P − 1, indexed like nodes) when
// params.cones == 1; a dummy otherwise.
@group(0) @binding(7) var<storage, read_write> cones: array<LightCone>;
// The nodes' substitute distributions (2P − 1, indexed like nodes) for a
// substitute tree; a dummy otherwise.
@group(0) @binding(8) var<storage, read_write> substitutes: array<Substitute>;

// Linear invocation index of a 2D dispatch of WG-wide workgroups.
fn linear_index(wid: vec3<u32>, groups: vec3<u32>, lid: u32) -> u32 {
    return (wid.x + wid.y * groups.x) * WG + lid;
}
