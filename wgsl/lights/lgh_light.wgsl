// Grid lights of the lighting grid hierarchy and the grid geometry they
// live on (src/lights/lgh.rs is the CPU oracle and documents every rule;
// these functions are its GridLight / LghGrid methods, the same f32
// operations in the same order). Shared by the build (lgh_build.wgsl) and
// the shading (lgh.wgsl). Needs LightPrim, luminance and KIND_VPL
// (light_prim.wgsl).

struct GridLight {
    // Σ w·I (RGB) and W = Σ ω, ω = w·‖I‖.
    e: vec3<f32>,
    w: f32,
    // Σ ω·(p − v) and Σ ω over point lights.
    p: vec3<f32>,
    iso: f32,
    // Σ ω·(p − v)² per axis, and the linear index of its vertex.
    q: vec3<f32>,
    vertex: u32,
    // Σ ω·n over VPLs, and its level.
    n: vec3<f32>,
    level: u32,
}

// A vertex without a grid light in the vertex index.
const LGH_EMPTY: u32 = 0xffffffffu;

// Vertices per axis of level ℓ ≥ 1 of an L-level grid: 2^(L−ℓ) + 1.
fn lgh_res(levels: u32, level: u32) -> u32 {
    return (1u << (levels - level)) + 1u;
}

// First vertex-index entry of level ℓ ≥ 1.
fn lgh_index_offset(levels: u32, level: u32) -> u32 {
    var o = 0u;
    for (var m = 1u; m < level; m++) {
        let r = lgh_res(levels, m);
        o += r * r * r;
    }
    return o;
}

fn lgh_vertex_index(levels: u32, level: u32, v: vec3<u32>) -> u32 {
    let r = lgh_res(levels, level);
    return v.x + r * (v.y + r * v.z);
}

// h_ℓ from h_1 (h_0 = h_1/2): exact power-of-two scaling.
fn lgh_h(h1: f32, level: u32) -> f32 {
    return h1 * ldexp(1.0, i32(level) - 1);
}

fn lgh_inv_h(inv_h1: f32, level: u32) -> f32 {
    return inv_h1 * ldexp(1.0, 1 - i32(level));
}

fn lgh_vertex_pos(lo: vec3<f32>, h: f32, v: vec3<u32>) -> vec3<f32> {
    return lo + vec3<f32>(f32(v.x) * h, f32(v.y) * h, f32(v.z) * h);
}

struct LghCell {
    cell: vec3<u32>,
    t: vec3<f32>,
}

// The cell of a level with `res` vertices per axis holding p, and p's
// fraction in it.
fn lgh_cell_of(lo: vec3<f32>, inv_h: f32, res: u32, p: vec3<f32>) -> LghCell {
    let q = (p - lo) * inv_h;
    let last = f32(res - 2u);
    let c = clamp(floor(q), vec3<f32>(0.0), vec3<f32>(last));
    let t = clamp(q - c, vec3<f32>(0.0), vec3<f32>(1.0));
    return LghCell(vec3<u32>(c), t);
}

// Weight of vertex c + δ (δ = bits x, y, z) of a point with fraction t.
fn lgh_trilinear(t: vec3<f32>, delta: u32) -> f32 {
    let a = select(vec3<f32>(1.0) - t, t, vec3<bool>((delta & 1u) != 0u, (delta & 2u) != 0u, (delta & 4u) != 0u));
    return (a.x * a.y) * a.z;
}

// Adds a light (its vertex at v) with trilinear weight w.
fn grid_light_add_light(acc: ptr<function, GridLight>, w: f32, l: LightPrim, v: vec3<f32>) {
    let omega = w * luminance(l.emission);
    let d = l.p0 - v;
    (*acc).e = (*acc).e + w * l.emission;
    (*acc).w = (*acc).w + omega;
    (*acc).p = (*acc).p + omega * d;
    (*acc).q = (*acc).q + omega * (d * d);
    if (l.kind == KIND_VPL) {
        (*acc).n = (*acc).n + omega * l.p1;
    } else {
        (*acc).iso = (*acc).iso + omega;
    }
}

// Adds grid light g with weight w, its moments moved by delta = v_g − v.
fn grid_light_add_grid(acc: ptr<function, GridLight>, w: f32, g: GridLight, delta: vec3<f32>) {
    let p = g.p + g.w * delta;
    let q = (g.q + 2.0 * delta * g.p) + g.w * (delta * delta);
    (*acc).e = (*acc).e + w * g.e;
    (*acc).w = (*acc).w + w * g.w;
    (*acc).p = (*acc).p + w * p;
    (*acc).q = (*acc).q + w * q;
    (*acc).n = (*acc).n + w * g.n;
    (*acc).iso = (*acc).iso + w * g.iso;
}

// Illumination centre of g, its vertex at v.
fn grid_light_centre(g: GridLight, v: vec3<f32>) -> vec3<f32> {
    return v + g.p / g.w;
}
