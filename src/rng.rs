//! The integer hashes of `wgsl/shared/rng.wgsl` on the CPU, bit for bit:
//! the CPU oracles of kernels that draw their random numbers from them
//! (MDAS's iterations, the many-light cut's subtree numbers) use these.
//! A module of its own below every other, so that any of them may use it.

/// `hash_u32` of `wgsl/shared/rng.wgsl`.
pub fn hash_u32(mut x: u32) -> u32 {
    x ^= x >> 16;
    x = x.wrapping_mul(0x7feb352d);
    x ^= x >> 15;
    x = x.wrapping_mul(0x846ca68b);
    x ^= x >> 16;
    x
}

/// `hash3` of `wgsl/shared/rng.wgsl`.
pub fn hash3(a: u32, b: u32, c: u32) -> u32 {
    hash_u32(a ^ hash_u32(b ^ hash_u32(c.wrapping_add(0x9e3779b9))))
}
