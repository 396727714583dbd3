// Orientation bounds of lights and tree nodes: the WGSL mirror of
// src/lights/cone.rs (read its module docs). Needs lights/light_prim.wgsl.
// Constants from Rust: CONE_SLACK_COS_BITS, CONE_SLACK_SIN_BITS (the f32
// bits of cos and sin of cone::SLACK), CONE_EMPTY_COS_BITS.
//
//   cone_of_prim(l) -> LightCone           the cone of one light, widened
//   cone_union(a, b) -> LightCone          a cone containing both, widened
//   light_emission_bound(cone, c, r, x)    the bound cos θ' toward x
//
// The build functions need not round as the CPU does (every cone is widened
// by cone::SLACK); light_emission_bound repeats the CPU's f32 operations in
// order, so that samplers over the same cones take the same decisions.

struct LightCone {
    axis: vec3<f32>,
    cos_o: f32,
    sin_o: f32,
    cos_e: f32,
    two_sided: u32,
    _pad: u32,
}

// An angle as the unit pair (cos, sin).
fn cone_angle(c: f32, s: f32) -> vec2<f32> {
    return vec2<f32>(c, s) / sqrt(c * c + s * s);
}

fn cone_add(a: vec2<f32>, b: vec2<f32>) -> vec2<f32> {
    return cone_angle(a.x * b.x - a.y * b.y, a.y * b.x + a.x * b.y);
}

fn cone_sub(a: vec2<f32>, b: vec2<f32>) -> vec2<f32> {
    return cone_angle(a.x * b.x + a.y * b.y, a.y * b.x - a.x * b.y);
}

// Half of an angle in (0, 2π).
fn cone_half(a: vec2<f32>) -> vec2<f32> {
    if (a.y > 0.0 && a.x >= 0.0) {
        return cone_angle(1.0 + a.x, a.y);
    }
    return cone_angle(a.y, 1.0 - a.x);
}

// a + b ≥ π for a, b ∈ [0, π].
fn cone_sum_reaches_pi(a: vec2<f32>, b: vec2<f32>) -> bool {
    return a.x <= -b.x;
}

fn cone_angle_between(u: vec3<f32>, v: vec3<f32>) -> vec2<f32> {
    let s = length(cross(u, v));
    let c = dot(u, v);
    if (s == 0.0 && c == 0.0) {
        return vec2<f32>(1.0, 0.0);
    }
    return cone_angle(c, s);
}

fn cone_empty() -> LightCone {
    return LightCone(vec3<f32>(0.0, 0.0, 1.0), bitcast<f32>(CONE_EMPTY_COS_BITS), 0.0, 1.0, 0u, 0u);
}

fn cone_sphere() -> LightCone {
    return LightCone(vec3<f32>(0.0, 0.0, 1.0), -1.0, 0.0, 0.0, 0u, 0u);
}

fn cone_is_empty(c: LightCone) -> bool {
    return c.cos_o > 1.0;
}

fn cone_is_sphere(c: LightCone) -> bool {
    return c.cos_o <= -1.0;
}

fn cone_with(c: LightCone, axis: vec3<f32>, spread: vec2<f32>) -> LightCone {
    return LightCone(axis, spread.x, spread.y, c.cos_e, c.two_sided, 0u);
}

fn cone_widened(c: LightCone) -> LightCone {
    let slack = vec2<f32>(bitcast<f32>(CONE_SLACK_COS_BITS), bitcast<f32>(CONE_SLACK_SIN_BITS));
    let spread = vec2<f32>(c.cos_o, c.sin_o);
    if (cone_is_sphere(c) || cone_sum_reaches_pi(spread, slack)) {
        return cone_with(c, c.axis, vec2<f32>(-1.0, 0.0));
    }
    return cone_with(c, c.axis, cone_add(spread, slack));
}

fn cone_of_prim(l: LightPrim) -> LightCone {
    if (l.kind != KIND_TRIANGLE) {
        return cone_sphere();
    }
    let n = cross(l.p1 - l.p0, l.p2 - l.p0);
    let a = abs(n);
    let m = max(max(a.x, a.y), a.z);
    // !(m > 0) also catches NaN.
    if (!(m > 0.0) || m > 3.0e38) {
        return cone_sphere();
    }
    let s = n / m;
    return cone_widened(LightCone(s / length(s), 1.0, 0.0, 0.0, 0u, 0u));
}

fn cone_union(a: LightCone, b: LightCone) -> LightCone {
    if (cone_is_empty(a)) {
        return b;
    }
    if (cone_is_empty(b)) {
        return a;
    }
    let base = LightCone(a.axis, a.cos_o, a.sin_o, min(a.cos_e, b.cos_e), a.two_sided | b.two_sided, 0u);
    let sphere = cone_with(base, a.axis, vec2<f32>(-1.0, 0.0));
    if (cone_is_sphere(a) || cone_is_sphere(b)) {
        return sphere;
    }
    let ta = vec2<f32>(a.cos_o, a.sin_o);
    let tb = vec2<f32>(b.cos_o, b.sin_o);
    let td = cone_angle_between(a.axis, b.axis);
    if (!cone_sum_reaches_pi(td, tb) && cone_add(td, tb).x >= ta.x) {
        return cone_widened(cone_with(base, a.axis, ta));
    }
    if (!cone_sum_reaches_pi(td, ta) && cone_add(td, ta).x >= tb.x) {
        return cone_widened(cone_with(base, b.axis, tb));
    }
    let normal = cross(a.axis, b.axis);
    if (dot(normal, normal) == 0.0) {
        return sphere;
    }
    let tr = cone_half(cone_sub(cone_add(td, tb), ta));
    let u = normalize(cross(normal, a.axis));
    let w = normalize(a.axis * tr.x + u * tr.y);
    let da = cone_angle_between(w, a.axis);
    let db = cone_angle_between(w, b.axis);
    if (cone_sum_reaches_pi(ta, da) || cone_sum_reaches_pi(tb, db)) {
        return sphere;
    }
    let sa = cone_add(ta, da);
    let sb = cone_add(tb, db);
    return cone_widened(cone_with(base, w, select(sb, sa, sa.x <= sb.x)));
}

// LightCone::emission_bound, operation by operation.
fn light_emission_bound(cone: LightCone, c: vec3<f32>, r: f32, x: vec3<f32>) -> f32 {
    if (cone.cos_o <= -1.0) {
        return 1.0;
    }
    let v = x - c;
    let dist = sqrt(v.x * v.x + v.y * v.y + v.z * v.z);
    if (dist <= r) {
        return 1.0;
    }
    let w = cone.axis;
    var cos_w = (w.x * v.x + w.y * v.y + w.z * v.z) / dist;
    if (cone.two_sided != 0u) {
        cos_w = abs(cos_w);
    }
    let sin_w = sqrt(max(1.0 - cos_w * cos_w, 0.0));
    var cos_x = 1.0;
    var sin_x = 0.0;
    if (!(cos_w > cone.cos_o)) {
        cos_x = cos_w * cone.cos_o + sin_w * cone.sin_o;
        sin_x = sin_w * cone.cos_o - cos_w * cone.sin_o;
    }
    let sin_b = r / dist;
    let cos_b = sqrt(max(1.0 - sin_b * sin_b, 0.0));
    var cos_p = 1.0;
    if (!(cos_x > cos_b)) {
        cos_p = cos_x * cos_b + sin_x * sin_b;
    }
    if (cos_p <= cone.cos_e) {
        return 0.0;
    }
    return cos_p;
}
