// Middle pass of the reduce-then-scan allocation (docs/conventions.md: no
// decoupled look-back): one workgroup turns the per-workgroup totals
// (selected leaves, splits) written by adapt.wgsl `count` into exclusive
// prefixes, in place, and stores the grand totals in state. Each
// invocation sums a contiguous chunk of ⌈G / WG⌉ totals, so its loops run
// at most 2·⌈G / WG⌉ times (G ≤ 2^19: ≤ 4096). Once the render is done
// (S_DONE, plan.wgsl) it leaves everything as it is.

var<workgroup> wg_done: u32;

@compute @workgroup_size(WG)
fn scan(@builtin(local_invocation_index) lid: u32) {
    if (lid == 0u) {
        wg_done = state[S_DONE];
    }
    // A workgroup-uniform value: workgroup_scan below needs uniform
    // control flow.
    if (workgroupUniformLoad(&wg_done) != 0u) {
        return;
    }
    let g = leaf_groups();
    let chunk = (g + WG - 1u) / WG;
    let start = lid * chunk;
    let end = min(start + chunk, g);
    var sum = vec2<u32>(0u);
    for (var i = start; i < end; i++) {
        sum += vec2<u32>(partials[2u * i], partials[2u * i + 1u]);
    }
    var run = workgroup_scan(lid, sum);
    let total = wg_total;
    for (var i = start; i < end; i++) {
        let v = vec2<u32>(partials[2u * i], partials[2u * i + 1u]);
        partials[2u * i] = run.x;
        partials[2u * i + 1u] = run.y;
        run += v;
    }
    if (lid == 0u) {
        state[S_SELECTED] = total.x;
        state[S_SPLITS] = total.y;
    }
}
