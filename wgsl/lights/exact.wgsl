// Correctly rounded f32 division and square root in integer arithmetic,
// and the substitute tree's per-node quantities built from them with the
// CPU's operations in the CPU's order, so that the radix substitute tree
// built on the GPU (radix_build.wgsl) equals its CPU oracle
// (src/lights/substitute/radix.rs) bit for bit on any driver: WGSL lets
// x / y be off by 2.5 ulp and sqrt by more, and lets a driver contract
// a·b + c into one fma, so every product here goes through mul_rn
// (light_prim.wgsl) and every quotient and root through div_rn and
// sqrt_rn. src/lights/substitute/gpu_build.rs lists what stays outside
// (subnormals, NaN). Needs light_prim.wgsl, cone.wgsl and substitute.wgsl.
//
//   div_rn(a, b), sqrt_rn(x)              IEEE round-to-nearest-even
//   x_leaf_node(l, id)                    perfect::leaf_node
//   x_cone_of_prim(l), x_cone_union(a, b) LightCone::of_prim, ::union
//   x_substitute_merge(a, ca, b, cb)      substitute::merge

// a / b for normal a, b with a normal quotient: the quotient of the 24-bit
// significands by integer long division, 8 bits per step (the remainder
// stays below 2^24, so it shifts within 32 bits), then the rounding bit and
// the sticky remainder. Zeros, infinities, NaN, subnormal operands and
// subnormal quotients take the native division (0/b, a/0 and the special
// values are exact there).
fn div_rn(a: f32, b: f32) -> f32 {
    let ab = bitcast<u32>(a);
    let bb = bitcast<u32>(b);
    let ea = (ab >> 23u) & 0xffu;
    let eb = (bb >> 23u) & 0xffu;
    if (ea == 0u || eb == 0u || ea == 255u || eb == 255u) {
        return a / b;
    }
    let sign = (ab ^ bb) & 0x80000000u;
    var ma = (ab & 0x7fffffu) | 0x800000u;
    let mb = (bb & 0x7fffffu) | 0x800000u;
    var e = i32(ea) - i32(eb) + 127;
    if (ma < mb) {
        ma = ma << 1u;
        e -= 1;
    }
    // ma / mb ∈ [1, 2): the leading 1, then 24 bits.
    var r = ma - mb;
    var q = 1u;
    for (var k = 0u; k < 3u; k++) {
        r = r << 8u;
        let d = r / mb;
        r = r - d * mb;
        q = (q << 8u) | d;
    }
    var mant = q >> 1u;
    if ((q & 1u) == 1u && (r != 0u || (mant & 1u) == 1u)) {
        mant += 1u;
    }
    if (mant == 0x1000000u) {
        mant = mant >> 1u;
        e += 1;
    }
    if (e >= 255) {
        return bitcast<f32>(sign | 0x7f800000u);
    }
    if (e <= 0) {
        return a / b;
    }
    return bitcast<f32>(sign | (u32(e) << 23u) | (mant & 0x7fffffu));
}

// r² as (hi, lo) 32-bit halves, r < 2^27.
fn sq64(r: u32) -> vec2<u32> {
    let a = r >> 16u;
    let b = r & 0xffffu;
    let bb = b * b;
    let t = 2u * a * b;
    let lo = bb + (t << 16u);
    let carry = select(0u, 1u, lo < bb);
    return vec2<u32>(a * a + (t >> 16u) + carry, lo);
}

fn gt64(x: vec2<u32>, hi: u32, lo: u32) -> bool {
    return x.x > hi || (x.x == hi && x.y > lo);
}

// √x for normal x > 0: x = m2·2^p with p even, R = ⌊√(m2·2^26)⌋ (25 or 26
// bits) from the native root and corrected until R² ≤ N < (R + 1)², then
// rounded to 24 bits with the bits below and the remainder as sticky.
// Zero, negative, subnormal and non-finite x take the native root.
fn sqrt_rn(x: f32) -> f32 {
    let bits = bitcast<u32>(x);
    let ex = (bits >> 23u) & 0xffu;
    if (ex == 0u || ex == 255u || (bits & 0x80000000u) != 0u) {
        return sqrt(x);
    }
    var m2 = (bits & 0x7fffffu) | 0x800000u;
    var p = i32(ex) - 150;
    if ((p & 1) != 0) {
        m2 = m2 << 1u;
        p -= 1;
    }
    let n_hi = m2 >> 6u;
    let n_lo = m2 << 26u;
    var r = u32(sqrt(f32(m2)) * 8192.0);
    for (var k = 0u; k < 64u && gt64(sq64(r), n_hi, n_lo); k++) {
        r -= 1u;
    }
    for (var k = 0u; k < 64u && !gt64(sq64(r + 1u), n_hi, n_lo); k++) {
        r += 1u;
    }
    let r2 = sq64(r);
    let inexact = r2.x != n_hi || r2.y != n_lo;
    let shift = 32u - countLeadingZeros(r) - 24u;
    var mant = r >> shift;
    let round = (r >> (shift - 1u)) & 1u;
    let low = r & ((1u << (shift - 1u)) - 1u);
    if (round == 1u && (low != 0u || inexact || (mant & 1u) == 1u)) {
        mant += 1u;
    }
    var e = 137 + i32(shift) + p / 2;
    if (mant == 0x1000000u) {
        mant = mant >> 1u;
        e += 1;
    }
    return bitcast<f32>((u32(e) << 23u) | (mant & 0x7fffffu));
}

// glam's Vec3 operations: dot = (xx + yy) + zz, cross, length = √dot,
// normalize = v · (1 / length).
fn x_dot(a: vec3<f32>, b: vec3<f32>) -> f32 {
    return (mul_rn(a.x, b.x) + mul_rn(a.y, b.y)) + mul_rn(a.z, b.z);
}

fn x_cross(a: vec3<f32>, b: vec3<f32>) -> vec3<f32> {
    return vec3<f32>(
        mul_rn(a.y, b.z) - mul_rn(b.y, a.z),
        mul_rn(a.z, b.x) - mul_rn(b.z, a.x),
        mul_rn(a.x, b.y) - mul_rn(b.x, a.y),
    );
}

fn x_length(a: vec3<f32>) -> f32 {
    return sqrt_rn(x_dot(a, a));
}

fn x_scale(a: vec3<f32>, s: f32) -> vec3<f32> {
    return vec3<f32>(mul_rn(a.x, s), mul_rn(a.y, s), mul_rn(a.z, s));
}

fn x_div(a: vec3<f32>, s: f32) -> vec3<f32> {
    return vec3<f32>(div_rn(a.x, s), div_rn(a.y, s), div_rn(a.z, s));
}

fn x_normalize(a: vec3<f32>) -> vec3<f32> {
    return x_scale(a, div_rn(1.0, x_length(a)));
}

fn x_finite(v: vec3<f32>) -> bool {
    let e = (vec3<u32>(bitcast<vec3<u32>>(v)) >> vec3<u32>(23u)) & vec3<u32>(0xffu);
    return all(e != vec3<u32>(255u));
}

// LightPrim::intensity with the triangle's area 0.5·|cross| rooted exactly.
fn x_leaf_node(l: LightPrim, id: u32) -> TreeNode {
    var node = leaf_node(l, id);
    if (l.kind == KIND_TRIANGLE) {
        let area = mul_rn(0.5, x_length(x_cross(l.p1 - l.p0, l.p2 - l.p0)));
        node.intensity = mul_rn(luminance(l.emission), area);
    }
    return node;
}

// ---- cones: cone.rs's Angle and LightCone, operation for operation ----

fn x_angle(c: f32, s: f32) -> vec2<f32> {
    let len = sqrt_rn(mul_rn(c, c) + mul_rn(s, s));
    return vec2<f32>(div_rn(c, len), div_rn(s, len));
}

fn x_angle_add(a: vec2<f32>, b: vec2<f32>) -> vec2<f32> {
    return x_angle(mul_rn(a.x, b.x) - mul_rn(a.y, b.y), mul_rn(a.y, b.x) + mul_rn(a.x, b.y));
}

fn x_angle_sub(a: vec2<f32>, b: vec2<f32>) -> vec2<f32> {
    return x_angle(mul_rn(a.x, b.x) + mul_rn(a.y, b.y), mul_rn(a.y, b.x) - mul_rn(a.x, b.y));
}

fn x_angle_half(a: vec2<f32>) -> vec2<f32> {
    if (a.y <= 0.0 && a.x >= 0.999999) {
        return vec2<f32>(1.0, 0.0);
    }
    if (a.y > 0.0 && a.x >= 0.0) {
        return x_angle(1.0 + a.x, a.y);
    }
    return x_angle(a.y, 1.0 - a.x);
}

fn x_angle_le(a: vec2<f32>, b: vec2<f32>) -> bool {
    let d = mul_rn(b.y, a.x) - mul_rn(b.x, a.y);
    if (d != 0.0) {
        return d > 0.0;
    }
    return a.x >= b.x;
}

fn x_angle_between(u: vec3<f32>, v: vec3<f32>) -> vec2<f32> {
    let s = x_length(x_cross(u, v));
    let c = x_dot(u, v);
    if (s == 0.0 && c == 0.0) {
        return vec2<f32>(1.0, 0.0);
    }
    return x_angle(c, s);
}

fn x_cone_widened(c: LightCone) -> LightCone {
    let slack = vec2<f32>(bitcast<f32>(CONE_SLACK_COS_BITS), bitcast<f32>(CONE_SLACK_SIN_BITS));
    let spread = vec2<f32>(c.cos_o, c.sin_o);
    if (cone_is_sphere(c) || cone_sum_reaches_pi(spread, slack)) {
        return cone_with(c, c.axis, vec2<f32>(-1.0, 0.0));
    }
    return cone_with(c, c.axis, x_angle_add(spread, slack));
}

fn x_cone_of_prim(l: LightPrim) -> LightCone {
    if (l.kind == KIND_VPL) {
        let n = l.p1;
        if (!x_finite(n) || x_dot(n, n) == 0.0) {
            return cone_point();
        }
        return x_cone_widened(LightCone(x_normalize(n), 1.0, 0.0, 0.0, 0u, 1u));
    }
    if (l.kind != KIND_TRIANGLE) {
        return cone_point();
    }
    let n = x_cross(l.p1 - l.p0, l.p2 - l.p0);
    let a = abs(n);
    let m = max(a.x, max(a.y, a.z));
    if (m == 0.0 || !x_finite(vec3<f32>(m))) {
        return cone_sphere();
    }
    let s = x_div(n, m);
    return x_cone_widened(LightCone(x_div(s, x_length(s)), 1.0, 0.0, 0.0, 0u, 0u));
}

fn x_cone_union(a: LightCone, b: LightCone) -> LightCone {
    if (cone_is_empty(a)) {
        return b;
    }
    if (cone_is_empty(b)) {
        return a;
    }
    let base = LightCone(a.axis, a.cos_o, a.sin_o, min(a.cos_e, b.cos_e), a.two_sided | b.two_sided, a.points | b.points);
    let sphere = cone_with(base, a.axis, vec2<f32>(-1.0, 0.0));
    if (cone_is_sphere(a) || cone_is_sphere(b)) {
        return sphere;
    }
    let ta = vec2<f32>(a.cos_o, a.sin_o);
    let tb = vec2<f32>(b.cos_o, b.sin_o);
    let td = x_angle_between(a.axis, b.axis);
    if (!cone_sum_reaches_pi(td, tb) && x_angle_le(x_angle_add(td, tb), ta)) {
        return x_cone_widened(cone_with(base, a.axis, ta));
    }
    if (!cone_sum_reaches_pi(td, ta) && x_angle_le(x_angle_add(td, ta), tb)) {
        return x_cone_widened(cone_with(base, b.axis, tb));
    }
    let normal = x_cross(a.axis, b.axis);
    if (x_dot(normal, normal) == 0.0) {
        return sphere;
    }
    let tr = x_angle_half(x_angle_sub(x_angle_add(td, tb), ta));
    let u = x_normalize(x_cross(normal, a.axis));
    let w = x_normalize(x_scale(a.axis, tr.x) + x_scale(u, tr.y));
    let da = x_angle_between(w, a.axis);
    let db = x_angle_between(w, b.axis);
    if (cone_sum_reaches_pi(ta, da) || cone_sum_reaches_pi(tb, db)) {
        return sphere;
    }
    let sa = x_angle_add(ta, da);
    let sb = x_angle_add(tb, db);
    return x_cone_widened(cone_with(base, w, select(sb, sa, x_angle_le(sb, sa))));
}

// ---- substitutes: substitute::merge ----

fn x_second(s: Substitute, d: vec3<f32>) -> array<f32, 6> {
    return array<f32, 6>(
        s.cov_diag.x + mul_rn(d.x, d.x),
        s.cov_diag.y + mul_rn(d.y, d.y),
        s.cov_diag.z + mul_rn(d.z, d.z),
        s.cov_xy + mul_rn(d.x, d.y),
        s.cov_xz + mul_rn(d.x, d.z),
        s.cov_yz + mul_rn(d.y, d.z),
    );
}

fn x_substitute_merge(a: Substitute, ca: f32, b: Substitute, cb: f32) -> Substitute {
    // !(c > 0) is the CPU's `c.is_nan() || c <= 0`.
    if (!(cb > 0.0)) {
        if (ca > 0.0) {
            return a;
        }
        return substitute_zero();
    }
    if (!(ca > 0.0)) {
        return b;
    }
    let w = ca + cb;
    let ta = div_rn(ca, w);
    let tb = div_rn(cb, w);
    let mean = a.mean + x_scale(b.mean - a.mean, tb);
    let m = x_scale(a.normal, ca) + x_scale(b.normal, cb);
    let len = x_length(m);
    var out = substitute_zero();
    out.mean = mean;
    if (len > 0.0) {
        let cos = x_dot(a.normal, b.normal);
        out.normal = x_div(m, len);
        out.nu = mul_rn(mul_rn(a.nu, b.nu), max(cos, 0.0));
    }
    let sa = x_second(a, a.mean - mean);
    let sb = x_second(b, b.mean - mean);
    out.cov_diag = vec3<f32>(
        mul_rn(ta, sa[0]) + mul_rn(tb, sb[0]),
        mul_rn(ta, sa[1]) + mul_rn(tb, sb[1]),
        mul_rn(ta, sa[2]) + mul_rn(tb, sb[2]),
    );
    out.cov_xy = mul_rn(ta, sa[3]) + mul_rn(tb, sb[3]);
    out.cov_xz = mul_rn(ta, sa[4]) + mul_rn(tb, sb[4]);
    out.cov_yz = mul_rn(ta, sa[5]) + mul_rn(tb, sb[5]);
    out.emission = a.emission + b.emission;
    return out;
}
