// tests/light_tree_gpu.rs `gpu_prim_quantities`: prim_centroid and
// prim_intensity of wgsl/lights/light_prim.wgsl for each light, as bits.
@group(0) @binding(0) var<uniform> zero: vec4<u32>;
@group(0) @binding(1) var<storage, read> prims: array<LightPrim>;
@group(0) @binding(2) var<storage, read_write> out: array<vec4<u32>>;

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    opaque_zero = zero.x;
    let i = gid.x;
    if (i < arrayLength(&prims)) {
        let l = prims[i];
        out[i] = vec4<u32>(bitcast<vec3<u32>>(prim_centroid(l)), bitcast<u32>(prim_intensity(l)));
    }
}
