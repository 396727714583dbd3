// Lighting grid hierarchy construction (src/lights/lgh/gpu.rs runs the
// kernels; src/lights/lgh.rs `build` is the CPU oracle and documents the
// rules). Per frame: cell keys → stable radix sort of (key, id) → clear →
// cell ranges → level 1 gathered from the lights of its 8 cells → each
// coarser level gathered from the level below. Every vertex sums in a
// fixed order (no float atomics); the only atomic is the compaction
// counter, which decides where a grid light is stored, never its value.
// Needs lights/light_prim.wgsl and lights/lgh_light.wgsl; constants from
// Rust: WG.

struct LghBuildParams {
    lo: vec3<f32>,
    levels: u32,
    h1: f32,
    inv_h1: f32,
    // Lights N.
    n: u32,
    // lgh_level: the level ℓ ≥ 2 it builds.
    level: u32,
    // Where the cell ranges and the sorted ids start in `index`.
    cells_offset: u32,
    sorted_offset: u32,
    // Workgroups along x of the 2D dispatch.
    groups_x: u32,
    // lgh_clear: entries to clear (the vertex index and the cell ranges).
    clear_len: u32,
}

@group(0) @binding(0) var<uniform> params: LghBuildParams;
@group(0) @binding(1) var<storage, read> prims: array<LightPrim>;
@group(0) @binding(2) var<storage, read_write> keys: array<u32>;
@group(0) @binding(3) var<storage, read_write> ids: array<u32>;
// The vertex index of every level, the level-1 cell ranges, the sorted ids.
@group(0) @binding(4) var<storage, read_write> index: array<u32>;
@group(0) @binding(5) var<storage, read_write> grid_lights: array<GridLight>;
@group(0) @binding(6) var<storage, read_write> counter: array<atomic<u32>>;

fn invocation(wid: vec3<u32>, lid: u32) -> u32 {
    return (wid.x + wid.y * params.groups_x) * WG + lid;
}

fn cells_per_axis() -> u32 {
    return 1u << (params.levels - 1u);
}

// The level-1 cell key of each light, and the identity ids.
@compute @workgroup_size(WG)
fn lgh_keys(@builtin(workgroup_id) wid: vec3<u32>, @builtin(local_invocation_index) lid: u32) {
    let i = invocation(wid, lid);
    if (i >= params.n) {
        return;
    }
    let k = cells_per_axis();
    ids[i] = i;
    if (prims[i].kind == KIND_TRIANGLE) {
        // Not a grid light: past every cell.
        keys[i] = k * k * k;
        return;
    }
    let c = lgh_cell_of(params.lo, params.inv_h1, lgh_res(params.levels, 1u), prims[i].p0).cell;
    keys[i] = c.x + k * (c.y + k * c.z);
}

// Every vertex without a grid light, every cell empty.
@compute @workgroup_size(WG)
fn lgh_clear(@builtin(workgroup_id) wid: vec3<u32>, @builtin(local_invocation_index) lid: u32) {
    let i = invocation(wid, lid);
    if (i >= params.clear_len) {
        return;
    }
    index[i] = select(0u, LGH_EMPTY, i < params.cells_offset);
}

// [start, end) of each non-empty cell in the sorted order.
@compute @workgroup_size(WG)
fn lgh_cells(@builtin(workgroup_id) wid: vec3<u32>, @builtin(local_invocation_index) lid: u32) {
    let i = invocation(wid, lid);
    let n = params.n;
    if (i >= n) {
        return;
    }
    let k = keys[i];
    let c = cells_per_axis();
    if (k >= c * c * c) {
        return;
    }
    if (i == 0u || keys[i - 1u] != k) {
        index[params.cells_offset + 2u * k] = i;
    }
    if (i + 1u == n || keys[i + 1u] != k) {
        index[params.cells_offset + 2u * k + 1u] = i + 1u;
    }
}

// Stores a vertex's sums as a grid light when they hold light.
fn store(level: u32, v: u32, acc_in: GridLight) {
    if (!(acc_in.w > 0.0)) {
        return;
    }
    var acc = acc_in;
    acc.vertex = v;
    acc.level = level;
    let slot = atomicAdd(&counter[0], 1u);
    if (slot < arrayLength(&grid_lights)) {
        grid_lights[slot] = acc;
        index[lgh_index_offset(params.levels, level) + v] = slot;
    }
}

fn decode(v: u32, r: u32) -> vec3<u32> {
    return vec3<u32>(v % r, (v / r) % r, v / (r * r));
}

// Level 1: one invocation per vertex gathers from its 8 cells (δ = 0…7,
// lights in sorted order).
@compute @workgroup_size(WG)
fn lgh_level1(@builtin(workgroup_id) wid: vec3<u32>, @builtin(local_invocation_index) lid: u32) {
    let r = lgh_res(params.levels, 1u);
    let lin = invocation(wid, lid);
    if (lin >= r * r * r) {
        return;
    }
    let v = decode(lin, r);
    let vpos = lgh_vertex_pos(params.lo, params.h1, v);
    let c = cells_per_axis();
    var acc = GridLight();
    for (var delta = 0u; delta < 8u; delta++) {
        let d = vec3<u32>(delta & 1u, (delta >> 1u) & 1u, (delta >> 2u) & 1u);
        if (any(v < d) || any(v - d >= vec3<u32>(c))) {
            continue;
        }
        let cell = v - d;
        let at = params.cells_offset + 2u * (cell.x + c * (cell.y + c * cell.z));
        let end = index[at + 1u];
        for (var s = index[at]; s < end; s++) {
            let l = prims[index[params.sorted_offset + s]];
            if (!(luminance(l.emission) > 0.0)) {
                continue;
            }
            let t = lgh_cell_of(params.lo, params.inv_h1, r, l.p0).t;
            grid_light_add_light(&acc, lgh_trilinear(t, delta), l, vpos);
        }
    }
    store(1u, lin, acc);
}

// Level ℓ ≥ 2: one invocation per vertex gathers the grid lights of level
// ℓ − 1 within 3 fine vertices whose centre falls in one of its 8 cells.
@compute @workgroup_size(WG)
fn lgh_level(@builtin(workgroup_id) wid: vec3<u32>, @builtin(local_invocation_index) lid: u32) {
    let level = params.level;
    let r = lgh_res(params.levels, level);
    let lin = invocation(wid, lid);
    if (lin >= r * r * r) {
        return;
    }
    let v = decode(lin, r);
    let h = lgh_h(params.h1, level);
    let inv_h = lgh_inv_h(params.inv_h1, level);
    let fine_h = lgh_h(params.h1, level - 1u);
    let vpos = lgh_vertex_pos(params.lo, h, v);
    let fine = lgh_res(params.levels, level - 1u);
    let fine_offset = lgh_index_offset(params.levels, level - 1u);
    let a = max(2u * v, vec3<u32>(3u)) - vec3<u32>(3u);
    let b = min(2u * v + vec3<u32>(3u), vec3<u32>(fine - 1u));
    var acc = GridLight();
    for (var z = a.z; z <= b.z; z++) {
        for (var y = a.y; y <= b.y; y++) {
            for (var x = a.x; x <= b.x; x++) {
                let slot = index[fine_offset + x + fine * (y + fine * z)];
                if (slot == LGH_EMPTY) {
                    continue;
                }
                let g = grid_lights[slot];
                let upos = lgh_vertex_pos(params.lo, fine_h, vec3<u32>(x, y, z));
                let cell = lgh_cell_of(params.lo, inv_h, r, grid_light_centre(g, upos));
                let d = v - cell.cell;
                if (any(d > vec3<u32>(1u))) {
                    continue;
                }
                let delta = d.x | (d.y << 1u) | (d.z << 2u);
                grid_light_add_grid(&acc, lgh_trilinear(cell.t, delta), g, upos - vpos);
            }
        }
    }
    store(level, lin, acc);
}
