// Orientation bounds of lights and tree nodes: the WGSL mirror of
// src/lights/cone.rs (read its module docs). Needs lights/light_prim.wgsl.
// Constants from Rust: CONE_SLACK_COS_BITS, CONE_SLACK_SIN_BITS (the f32
// bits of cos and sin of cone::SLACK), CONE_EMPTY_COS_BITS.
//
//   cone_of_prim(l) -> LightCone           the cone of one light, widened
//   cone_union(a, b) -> LightCone          a cone containing both, widened
//
// These need not round as the CPU does (every cone is widened by
// cone::SLACK). The samplers' emission bound is in lights/sample.wgsl.

struct LightCone {
    axis: vec3<f32>,
    cos_o: f32,
    sin_o: f32,
    cos_e: f32,
    two_sided: u32,
    // 1 when a point light lies below (no near-distance clamp).
    points: u32,
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
    // Within rounding of 0 (cone.rs Angle::half explains): 0.
    if (a.y <= 0.0 && a.x >= 0.999999) {
        return vec2<f32>(1.0, 0.0);
    }
    if (a.y > 0.0 && a.x >= 0.0) {
        return cone_angle(1.0 + a.x, a.y);
    }
    return cone_angle(a.y, 1.0 - a.x);
}

// a ≤ b for a, b ∈ [0, π] (cone.rs angle_le: the sign of sin(b − a), or
// where that is 0 of cos a − cos b).
fn cone_le(a: vec2<f32>, b: vec2<f32>) -> bool {
    let d = b.y * a.x - b.x * a.y;
    if (d != 0.0) {
        return d > 0.0;
    }
    return a.x >= b.x;
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

fn cone_point() -> LightCone {
    return LightCone(vec3<f32>(0.0, 0.0, 1.0), -1.0, 0.0, 0.0, 0u, 1u);
}

fn cone_is_empty(c: LightCone) -> bool {
    return c.cos_o > 1.0;
}

fn cone_is_sphere(c: LightCone) -> bool {
    return c.cos_o <= -1.0;
}

fn cone_with(c: LightCone, axis: vec3<f32>, spread: vec2<f32>) -> LightCone {
    return LightCone(axis, spread.x, spread.y, c.cos_e, c.two_sided, c.points);
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
    if (l.kind == KIND_VPL) {
        let nv = l.p1;
        let len2 = dot(nv, nv);
        if (!(len2 > 0.0) || len2 > 3.0e38) {
            return cone_point();
        }
        return cone_widened(LightCone(nv / sqrt(len2), 1.0, 0.0, 0.0, 0u, 1u));
    }
    if (l.kind != KIND_TRIANGLE) {
        return cone_point();
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
    let base = LightCone(a.axis, a.cos_o, a.sin_o, min(a.cos_e, b.cos_e), a.two_sided | b.two_sided, a.points | b.points);
    let sphere = cone_with(base, a.axis, vec2<f32>(-1.0, 0.0));
    if (cone_is_sphere(a) || cone_is_sphere(b)) {
        return sphere;
    }
    let ta = vec2<f32>(a.cos_o, a.sin_o);
    let tb = vec2<f32>(b.cos_o, b.sin_o);
    let td = cone_angle_between(a.axis, b.axis);
    if (!cone_sum_reaches_pi(td, tb) && cone_le(cone_add(td, tb), ta)) {
        return cone_widened(cone_with(base, a.axis, ta));
    }
    if (!cone_sum_reaches_pi(td, ta) && cone_le(cone_add(td, ta), tb)) {
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
    return cone_widened(cone_with(base, w, select(sb, sa, cone_le(sb, sa))));
}
