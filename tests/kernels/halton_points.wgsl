// Test kernel: evaluates the shared Halton functions for a list of
// (dim, index, pixel, seed) queries.

struct Query {
    dim: u32,
    index: u32,
    pixel: u32,
    seed: u32,
}

@group(0) @binding(0) var<storage, read> queries: array<Query>;
@group(0) @binding(1) var<storage, read_write> raw: array<f32>;
@group(0) @binding(2) var<storage, read_write> shifted: array<f32>;

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = gid.x;
    if (i >= arrayLength(&queries)) {
        return;
    }
    let q = queries[i];
    raw[i] = radical_inverse(halton_prime(q.dim), q.index);
    shifted[i] = halton_sample(q.dim, q.index, q.pixel, q.seed);
}
