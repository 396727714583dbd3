// Cut-sharing pre-pass (real-time stochastic lightcuts §3.3): one
// invocation per k×k pixel block. A representative pixel of the block is
// chosen by a hash of (block, frame); its pinhole primary ray through the
// pixel centre at the frame time gives the shading point and normal whose
// greedy cut (`select_cut`) every sample in the block then uses. A ray that
// misses leaves the cut [root]. Constants from Rust: CUT_WG, CUT_BLOCKS.

@group(0) @binding(0) var<storage, read_write> cuts_out: array<u32>;

@compute @workgroup_size(CUT_WG)
fn select_cuts(@builtin(global_invocation_id) gid: vec3<u32>,
               @builtin(num_workgroups) groups: vec3<u32>) {
    let block = gid.x + gid.y * groups.x * CUT_WG;
    if (block >= CUT_BLOCKS) {
        return;
    }
    let k = light_params.block_size;
    let size = vec2<u32>(scene.film_size);
    let origin_px = vec2<u32>(block % light_params.blocks_per_row, block / light_params.blocks_per_row) * k;
    let extent = min(vec2<u32>(k), size - origin_px);
    let h = hash3(block, light_params.frame, 0x6c69u);
    let px = origin_px + vec2<u32>(h % extent.x, (h / extent.x) % extent.y);

    var cut: array<u32, MAX_CUT>;
    var len = 1u;
    cut[0] = 0u;
    let time = ml_time();
    let ray = camera_ray(vec2<f32>(px) + vec2<f32>(0.5), vec2<f32>(0.5));
    let hit = scene_closest(ray.origin, ray.dir, RAY_T_MAX, time);
    if (hit.prim != BVH_MISS) {
        let s = surface_at(hit, ray.dir, time);
        len = select_cut(s.x, s.ns, &cut);
    }
    let base = block * light_params.cut_size;
    for (var i = 0u; i < light_params.cut_size; i++) {
        cuts_out[base + i] = select(NO_LIGHT, cut[i], i < len);
    }
}
