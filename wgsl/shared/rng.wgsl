// Stateless hash-based random numbers: every value is a pure function of
// its key, so results never depend on scheduling order.

// "lowbias32" integer hash (Chris Wellons' hash-prospector).
fn hash_u32(x_in: u32) -> u32 {
    var x = x_in;
    x ^= x >> 16u;
    x *= 0x7feb352du;
    x ^= x >> 15u;
    x *= 0x846ca68bu;
    x ^= x >> 16u;
    return x;
}

fn hash3(a: u32, b: u32, c: u32) -> u32 {
    return hash_u32(a ^ hash_u32(b ^ hash_u32(c + 0x9e3779b9u)));
}

// Top 24 bits as a float in [0, 1).
fn u32_to_unit_float(x: u32) -> f32 {
    return f32(x >> 8u) * (1.0 / 16777216.0);
}
