// Light-sampler bindings at @group(1), 16–23 (src/lights/gpu_sampler.rs owns
// the layout and the buffers). TreeNode and LightPrim come from
// lights/light_prim.wgsl, LightCone from lights/cone.wgsl, Substitute from lights/substitute.wgsl; constants from Rust: MAX_CUT, LIGHT_MAX_DEPTH,
// LIGHT_INTERNAL_BIT, NO_LIGHT, LIGHT_KIND_* (SamplerKind::index).
//
// 16 light_nodes   perfect tree (2P − 1 nodes, level by level) or the
//                  unbalanced BVH (id = light for a leaf, LIGHT_INTERNAL_BIT |
//                  left child for an internal node, right = left + 1)
// 17 light_prims   the N light primitives
// 18 light_index   per kind: perfect tree: leaf slot of each light (N);
//                  BVH: leaf node of each light (N), then the parent of each
//                  node (node_count, NO_LIGHT for the root); power: the f32
//                  bits of each light's pmf (N); uniform: unused
// 19 light_alias   power: the alias table (N entries); others: unused
// 20 light_cuts    tree / unbalanced: cut_size node indices per k×k pixel
//                  block, row-major over blocks, NO_LIGHT-padded; written by
//                  the cut pre-pass (select_cut) or uploaded
// 21 light_params  the uniform below
// 22 light_cones   cone kinds (tree_cone, unbalanced, unbalanced_nocut): the
//                  orientation bound of every node, indexed like light_nodes;
//                  others: unused
// 23 light_substitutes  sst, sst_nosub: the substitute distribution of every
//                  node, indexed like light_nodes; others: unused
// 24 lgh_lights    lgh: the grid lights (lights/lgh.wgsl); others: unused.
//                  For lgh, light_index holds the vertex index of every
//                  level, then (start, end) of every level-1 cell, then the
//                  light ids sorted by cell (src/lights/lgh.rs).

// AliasEntry { q, alias } of src/lights/simple/alias.rs (`alias` is a WGSL keyword).
struct AliasEntry {
    q: f32,
    alias_id: u32,
}

struct LightParams {
    // N, the number of lights (0: every sampler returns NO_LIGHT).
    count: u32,
    // SamplerKind::index: LIGHT_KIND_*.
    kind: u32,
    // Perfect tree: L + 1 levels and P leaves (0 otherwise).
    levels: u32,
    leaf_count: u32,
    // Nodes in light_nodes.
    node_count: u32,
    // Cut entries per block (1 for the no-cut kinds).
    cut_size: u32,
    // Cut sharing: k×k pixel blocks, blocks_per_row = ceil(width / k).
    block_size: u32,
    blocks_per_row: u32,
    // Power: N, or 0 when Σ I = 0 (no light can be sampled).
    alias_count: u32,
    // Interleaved sampling (§3.4): sub-block side m (1 = off), frame number.
    interleave: u32,
    frame: u32,
    // Frame time (scene time units).
    time: f32,
    // Square of the VPL distance clamp (0 = none): 1/max(d², vpl_clamp2).
    vpl_clamp2: f32,
    // sst: ν_min and σ_max² of the suitability test (substitute.rs, eq. 3).
    sst_nu_min: f32,
    sst_sigma_max2: f32,
    // Kinds with cuts: 0 = one light per cut subtree (the paper's
    // estimator, light_sample_subtree), 1 = one pick from the cut's mixture
    // (light_sample; the ablation).
    cut_mixture: u32,
    // lgh (src/lights/lgh.rs): the grid's lo, L, h_1, 1/h_1, α, level 0 on
    // (1) or off, shadow samples S, and where the level-1 cell ranges and
    // the sorted light ids start in light_index (after the vertex index).
    lgh_lo: vec3<f32>,
    lgh_levels: u32,
    lgh_h1: f32,
    lgh_inv_h1: f32,
    lgh_alpha: f32,
    lgh_level0: u32,
    lgh_shadows: u32,
    lgh_cells_offset: u32,
    lgh_sorted_offset: u32,
    // lgh: emissive triangles T, the last T sorted ids (not grid lights).
    lgh_triangles: u32,
    // lgh: the grid lights' additive distance clamp (c·R)².
    lgh_soft2: f32,
    // Kinds picking one light per evaluation: picks per evaluation
    // (light_samples; 0 reads as 1).
    light_samples: u32,
    _pad2: u32,
    _pad3: u32,
}

@group(1) @binding(16) var<storage, read> light_nodes: array<TreeNode>;
@group(1) @binding(17) var<storage, read> light_prims: array<LightPrim>;
@group(1) @binding(18) var<storage, read> light_index: array<u32>;
@group(1) @binding(19) var<storage, read> light_alias: array<AliasEntry>;
@group(1) @binding(20) var<storage, read> light_cuts: array<u32>;
@group(1) @binding(21) var<uniform> light_params: LightParams;
@group(1) @binding(22) var<storage, read> light_cones: array<LightCone>;
@group(1) @binding(23) var<storage, read> light_substitutes: array<Substitute>;
@group(1) @binding(24) var<storage, read> lgh_lights: array<GridLight>;

// The part [start, end) of the block's cut this pixel samples: the whole cut
// unless interleaved sampling is on (light_cut_base sets it).
var<private> light_subset: vec2<u32> = vec2<u32>(0u, 0xffffffffu);

// First light_cuts entry of the block holding pixel `px`. With interleaved
// sampling (paper §3.4, eq. 3) it also restricts the pixel to its share of
// the cut: pixel i of its m×m sub-block (row-major) takes index
// p = (i + frame) mod m² and the cut nodes [⌊p·n/m²⌋, ⌊(p+1)·n/m²⌋), n the
// cut's length (light_cut_len applies it).
fn light_cut_base(px: vec2<u32>) -> u32 {
    let block = px / light_params.block_size;
    let m = max(light_params.interleave, 1u);
    if (m > 1u) {
        let q = px % vec2<u32>(m);
        let p = (q.y * m + q.x + light_params.frame) % (m * m);
        light_subset = vec2<u32>(p, p + 1u);
    } else {
        light_subset = vec2<u32>(0u, 0xffffffffu);
    }
    return (block.y * light_params.blocks_per_row + block.x) * light_params.cut_size;
}

// The estimate's scale under interleaved sampling: a pixel samples 1/m² of
// the cut, so its estimate is scaled by m² (the average over a sub-block is
// then the whole cut's; per pixel it is biased, as in the paper, which
// filters the result).
fn light_interleave_scale() -> f32 {
    let m = max(light_params.interleave, 1u);
    return f32(m * m);
}
