// Radical inverses in the first MAX_DIMS primes, in exact integer
// arithmetic. See src/integrator/halton.rs for the error bound.
// Needs shared/sampling.wgsl (ONE_MINUS_EPSILON) and shared/rng.wgsl.

fn halton_prime(dim: u32) -> u32 {
    var primes = array<u32, 16>(2u, 3u, 5u, 7u, 11u, 13u, 17u, 19u,
                                23u, 29u, 31u, 37u, 41u, 43u, 47u, 53u);
    return primes[dim];
}

// u32 → f32 with one rounding (the high half is converted exactly).
fn u32_to_f32_rounded(x: u32) -> f32 {
    return f32(x >> 16u) * 65536.0 + f32(x & 0xffffu);
}

// Φ_b(a) = Σ_k d_k b^−(k+1) for a = Σ_k d_k b^k. The digits are reversed
// into integers in two chunks, each as long as the chunk's denominator
// b^n fits in 32 bits; two chunks exhaust any 32-bit index for b ≤ 65535.
// The result is rev1/b^n1 + rev2/(b^n1·b^n2), rounded a few times in f32.
fn radical_inverse(b: u32, a_in: u32) -> f32 {
    let limit = 0xffffffffu / b;
    var a = a_in;
    var rev1 = 0u;
    var den1 = 1u;
    for (var i = 0u; i < 32u; i++) {
        if (a == 0u || den1 > limit) { break; }
        rev1 = rev1 * b + a % b;
        a = a / b;
        den1 = den1 * b;
    }
    var rev2 = 0u;
    var den2 = 1u;
    for (var i = 0u; i < 32u; i++) {
        if (a == 0u || den2 > limit) { break; }
        rev2 = rev2 * b + a % b;
        a = a / b;
        den2 = den2 * b;
    }
    let tail = u32_to_f32_rounded(rev2) / u32_to_f32_rounded(den2);
    let value = (u32_to_f32_rounded(rev1) + tail) / u32_to_f32_rounded(den1);
    return min(value, ONE_MINUS_EPSILON);
}

// Dimension `dim` of sample `index` of `pixel`: the radical inverse in the
// dim-th prime, toroidally shifted (Cranley–Patterson rotation) by a hash
// of (pixel, dim, seed).
fn halton_sample(dim: u32, index: u32, pixel: u32, seed: u32) -> f32 {
    let shift = u32_to_unit_float(hash3(pixel, dim, seed));
    var x = radical_inverse(halton_prime(dim), index) + shift;
    if (x >= 1.0) {
        x -= 1.0;
    }
    return min(x, ONE_MINUS_EPSILON);
}
