// Light primitives and tree nodes (src/lights/mod.rs), with the per-light
// quantities computed exactly as the CPU computes them (LightPrim::centroid,
// ::intensity, ::bounds_min/max; points and VPLs sit at p0), so that the GPU tree equals the CPU oracle
// bit for bit. src/lights/tree/gpu_build.rs explains each rule; in short:
//   * no product may be fused with a following addition (drivers may contract
//     a·b + c into an fma, which rounds once instead of twice): products that
//     feed additions go through mul_rn, whose XOR with a zero the compiler
//     cannot see (opaque_zero, loaded from a uniform) forces the rounding;
//   * division by 3 is done in integer arithmetic (div3_rn), correctly
//     rounded, since WGSL's x / y may be off by 2.5 ulp;
//   * min/max of vectors follow glam (`if a < b { a } else { b }`).
// Constants from Rust: LUM_R_BITS, LUM_G_BITS, LUM_B_BITS (f32 bits of the
// Rec. 709 weights as the CPU rounds them), KIND_TRIANGLE, NO_LIGHT,
// EMPTY_MIN_BITS, EMPTY_MAX_BITS.

struct LightPrim {
    p0: vec3<f32>,
    kind: u32,
    p1: vec3<f32>,
    _pad0: u32,
    p2: vec3<f32>,
    _pad1: u32,
    emission: vec3<f32>,
    _pad2: u32,
}

struct TreeNode {
    bmin: vec3<f32>,
    intensity: f32,
    bmax: vec3<f32>,
    id: u32,
}

// Zero, read from a uniform at the start of every entry point.
var<private> opaque_zero: u32;

// a·b rounded to f32 on its own (never contracted into an fma).
fn mul_rn(a: f32, b: f32) -> f32 {
    return bitcast<f32>(bitcast<u32>(a * b) ^ opaque_zero);
}

// x / 3, correctly rounded (round to nearest, ties to even), for normal x
// whose quotient is normal; zero, subnormal, tiny (|x| < 2^-124) and
// non-finite x fall back to the native division.
fn div3_rn(x: f32) -> f32 {
    let bits = bitcast<u32>(x);
    let field = (bits >> 23u) & 0xffu;
    if (field <= 2u || field == 255u) {
        return x / 3.0;
    }
    // x = m·2^(field − 150) with m ∈ [2^23, 2^24); m·2^8 / 3 = q + r/3.
    let m = (bits & 0x7fffffu) | 0x800000u;
    let big = m << 8u;
    let q = big / 3u;
    let r = big - 3u * q;
    // q ∈ [2^29.4, 2^30.4): keep 24 bits.
    let s = select(6u, 7u, q >= 0x40000000u);
    var mant = q >> s;
    let rest = q & ((1u << s) - 1u);
    let half = 1u << (s - 1u);
    if (rest > half || (rest == half && (r != 0u || (mant & 1u) == 1u))) {
        mant += 1u;
    }
    var field_out = field - 8u + s;
    if (mant == 0x1000000u) {
        mant = mant >> 1u;
        field_out += 1u;
    }
    return bitcast<f32>((bits & 0x80000000u) | (field_out << 23u) | (mant & 0x7fffffu));
}

fn vmin(a: vec3<f32>, b: vec3<f32>) -> vec3<f32> {
    return select(b, a, a < b);
}

fn vmax(a: vec3<f32>, b: vec3<f32>) -> vec3<f32> {
    return select(b, a, a > b);
}

fn prim_centroid(l: LightPrim) -> vec3<f32> {
    if (l.kind != KIND_TRIANGLE) {
        return l.p0;
    }
    let s = (l.p0 + l.p1) + l.p2;
    return vec3<f32>(div3_rn(s.x), div3_rn(s.y), div3_rn(s.z));
}

fn luminance(c: vec3<f32>) -> f32 {
    return (mul_rn(bitcast<f32>(LUM_R_BITS), c.x) + mul_rn(bitcast<f32>(LUM_G_BITS), c.y))
        + mul_rn(bitcast<f32>(LUM_B_BITS), c.z);
}

fn prim_area(l: LightPrim) -> f32 {
    let u = l.p1 - l.p0;
    let v = l.p2 - l.p0;
    let n = vec3<f32>(
        mul_rn(u.y, v.z) - mul_rn(v.y, u.z),
        mul_rn(u.z, v.x) - mul_rn(v.z, u.x),
        mul_rn(u.x, v.y) - mul_rn(v.x, u.y),
    );
    let len2 = (mul_rn(n.x, n.x) + mul_rn(n.y, n.y)) + mul_rn(n.z, n.z);
    return 0.5 * sqrt(len2);
}

fn prim_intensity(l: LightPrim) -> f32 {
    let e = luminance(l.emission);
    if (l.kind == KIND_TRIANGLE) {
        return e * prim_area(l);
    }
    return e;
}

fn leaf_node(l: LightPrim, id: u32) -> TreeNode {
    if (l.kind != KIND_TRIANGLE) {
        return TreeNode(l.p0, prim_intensity(l), l.p0, id);
    }
    return TreeNode(
        vmin(vmin(l.p0, l.p1), l.p2),
        prim_intensity(l),
        vmax(vmax(l.p0, l.p1), l.p2),
        id,
    );
}

fn empty_node() -> TreeNode {
    return TreeNode(
        vec3<f32>(bitcast<f32>(EMPTY_MIN_BITS)),
        0.0,
        vec3<f32>(bitcast<f32>(EMPTY_MAX_BITS)),
        NO_LIGHT,
    );
}

// f32 → u32 preserving order (−0 < +0); NaN is not expected.
fn ordered_bits(f: f32) -> u32 {
    let b = bitcast<u32>(f);
    return select(b | 0x80000000u, ~b, (b & 0x80000000u) != 0u);
}

fn from_ordered_bits(k: u32) -> f32 {
    return bitcast<f32>(select(~k, k & 0x7fffffffu, (k & 0x80000000u) != 0u));
}
