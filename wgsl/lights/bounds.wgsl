// Global light-centroid bounds (real-time stochastic lightcuts §4, "the
// bounding box of all lights is first computed using parallel reduction").
// min and max are exact and commutative, so reducing them with integer
// atomicMax on order-preserving bits (first in the workgroup, then one
// global atomic per axis and workgroup) gives the same bounds in any order.

var<workgroup> wg_bounds: array<atomic<u32>, 6>;

@compute @workgroup_size(WG)
fn centroid_bounds_reduce(@builtin(workgroup_id) wid: vec3<u32>,
                          @builtin(num_workgroups) groups: vec3<u32>,
                          @builtin(local_invocation_index) lid: u32) {
    opaque_zero = params.zero;
    if (lid < 6u) {
        atomicStore(&wg_bounds[lid], 0u);
    }
    workgroupBarrier();
    let i = linear_index(wid, groups, lid);
    if (i < params.n) {
        let c = prim_centroid(prims[i]);
        for (var a = 0u; a < 3u; a++) {
            let k = ordered_bits(c[a]);
            atomicMax(&wg_bounds[a], ~k);
            atomicMax(&wg_bounds[3u + a], k);
        }
    }
    workgroupBarrier();
    if (lid < 6u) {
        let v = atomicLoad(&wg_bounds[lid]);
        if (v != 0u) {
            atomicMax(&centroid_bounds[lid], v);
        }
    }
}
