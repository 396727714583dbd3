// E_max of the initial grid (§4.2): the errors of its cells
// (leaf_error.wgsl) and their maximum, run once before the first
// iteration. Afterwards no pass sweeps every leaf for them: the count pass
// gathers the maximum of the errors it leaves unchanged, and the evaluate
// pass recomputes the errors of the leaves an iteration changed
// (evaluate.wgsl, adapt.wgsl; `emax_word` in common.wgsl). Only leaves
// marked DIRTY are computed; collapsed leaves take no part in E_max; one
// atomicMax per workgroup into counters[emax_word(1)].

// Each invocation looks at its leaf: a DIRTY one is appended to the
// workgroup's list, any other (not collapsed) enters the workgroup's
// maximum as it is; then the first invocations compute the listed leaves'
// errors, packed (few leaves change per iteration, and a SIMD group or
// warp pays for leaf_error if any of its lanes runs it). The maximum is
// order-independent, so the list's order (atomics) changes nothing.
var<workgroup> wg_list: array<u32, WG>;
var<workgroup> wg_listed: atomic<u32>;
var<workgroup> wg_max: atomic<u32>;

@compute @workgroup_size(WG)
fn error(@builtin(global_invocation_id) gid: vec3<u32>,
         @builtin(local_invocation_index) lid: u32,
         @builtin(num_workgroups) groups: vec3<u32>) {
    let k = thread_index(gid, groups, WG);
    if (lid == 0u) {
        atomicStore(&wg_listed, 0u);
        atomicStore(&wg_max, 0u);
    }
    workgroupBarrier();
    if (k < leaf_count()) {
        let base = leaf_base(k);
        if (!header_collapsed(leaves_get(base + 1u))) {
            let bits = leaves_get(base + 2u);
            if (bits == DIRTY) {
                wg_list[atomicAdd(&wg_listed, 1u)] = k;
            } else {
                atomicMax(&wg_max, bits);
            }
        }
    }
    workgroupBarrier();
    if (lid < atomicLoad(&wg_listed)) {
        let leaf = wg_list[lid];
        let bits = bitcast<u32>(leaf_error(leaf));
        leaves_set(leaf_base(leaf) + 2u, bits);
        atomicMax(&wg_max, bits);
    }
    workgroupBarrier();
    if (lid == 0u) {
        atomicMax(&counters[emax_word(iteration())], atomicLoad(&wg_max));
    }
}
