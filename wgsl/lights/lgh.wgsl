// Lighting grid hierarchy shading (sampler lgh; src/lights/lgh.rs is the
// CPU oracle and documents every rule: Emitter::eval, LghGrid::blend,
// Lgh::candidates, pick). lgh_walk visits the candidates of a shading
// point in the oracle's order; the first walk sums U and F, the second
// inverts the running sum at the S stratified targets. The shadow rays are
// the integrand's (many_light.wgsl). Constants from Rust: LGH_MAX_SHADOWS.

struct LghEmitter {
    pos: vec3<f32>,
    e: vec3<f32>,
    iso: f32,
    n: vec3<f32>,
    clamp2: f32,
    // The grid lights' additive clamp (c·R)² (0 for a light).
    soft2: f32,
    // The centre's offset from its vertex m = P/W and Q/W: the variance is
    // Q/W − m², computed only for a picked grid light (0 for a light).
    m: vec3<f32>,
    qw: vec3<f32>,
}

// I(ω)·cosθ_x / (max(d², clamp²) + soft²) at x with unit shading normal
// n, and 0 for light from behind the unit geometric normal ng, as every
// other sampler's `cos_reflect` (Emitter::eval_shaded).
fn lgh_emitter_eval(em: LghEmitter, x: vec3<f32>, n: vec3<f32>, ng: vec3<f32>) -> vec3<f32> {
    let to = em.pos - x;
    let d2 = dot(to, to);
    if (!(d2 > 0.0)) {
        return vec3<f32>(0.0);
    }
    let wi = to / sqrt(d2);
    let cos_x = dot(n, wi);
    if (cos_x <= 0.0 || dot(ng, wi) <= 0.0) {
        return vec3<f32>(0.0);
    }
    let lobe = em.iso + max(-dot(em.n, wi), 0.0);
    if (!(lobe > 0.0)) {
        return vec3<f32>(0.0);
    }
    return em.e * (lobe * cos_x / (max(d2, em.clamp2) + em.soft2));
}

// An original point light or VPL (Emitter::light).
fn lgh_light_emitter(l: LightPrim, clamp2: f32) -> LghEmitter {
    let vpl = l.kind == KIND_VPL;
    return LghEmitter(
        l.p0,
        l.emission,
        select(1.0, 0.0, vpl),
        select(vec3<f32>(0.0), l.p1, vpl),
        select(0.0, clamp2, vpl),
        0.0,
        vec3<f32>(0.0),
        vec3<f32>(0.0),
    );
}

// A grid light, its vertex at v (GridLight::emitter, σ deferred).
fn lgh_grid_emitter(g: GridLight, v: vec3<f32>, clamp2: f32) -> LghEmitter {
    let inv = 1.0 / g.w;
    let m = g.p * inv;
    return LghEmitter(v + m, g.e, g.iso * inv, g.n * inv, clamp2, light_params.lgh_soft2, m, g.q * inv);
}

// The standard deviation of an emitter's centre per axis.
fn lgh_sigma(em: LghEmitter) -> vec3<f32> {
    return sqrt(max(em.qw - em.m * em.m, vec3<f32>(0.0)));
}

// B_ℓ(d) (LghGrid::blend); `first` is the finest level used.
fn lgh_blend(first: u32, level: u32, d: f32) -> f32 {
    let r = light_params.lgh_alpha * lgh_h(light_params.lgh_h1, level);
    var rise = 1.0;
    if (level != first && d < r) {
        rise = select(2.0 * d / r - 1.0, 0.0, d < 0.5 * r);
    }
    var fall = 1.0;
    if (level != light_params.lgh_levels && d > r) {
        fall = select(2.0 - d / r, 0.0, d >= 2.0 * r);
    }
    return rise * fall;
}

// Walk state: U and F (first walk); the running sum, the picks so far and
// their targets (second walk).
var<private> lgh_u: vec3<f32>;
var<private> lgh_total: f32;
var<private> lgh_cum: f32;
var<private> lgh_picked: u32;
var<private> lgh_targets: array<f32, LGH_MAX_SHADOWS>;
var<private> lgh_pick_pos: array<vec3<f32>, LGH_MAX_SHADOWS>;
var<private> lgh_pick_sigma: array<vec3<f32>, LGH_MAX_SHADOWS>;
var<private> lgh_pick_chroma: array<vec3<f32>, LGH_MAX_SHADOWS>;
// The last candidate (rounding can leave targets past the running sum).
var<private> lgh_last_pos: vec3<f32>;
var<private> lgh_last_sigma: vec3<f32>;
var<private> lgh_last_chroma: vec3<f32>;

fn lgh_visit(first: u32, level: u32, em: LghEmitter, x: vec3<f32>, n: vec3<f32>, ng: vec3<f32>, picking: bool) {
    let b = lgh_blend(first, level, length(em.pos - x));
    if (!(b > 0.0)) {
        return;
    }
    let f = b * lgh_emitter_eval(em, x, n, ng);
    let lum = luminance(f);
    if (!(lum > 0.0)) {
        return;
    }
    if (!picking) {
        lgh_u += f;
        lgh_total += lum;
        return;
    }
    lgh_cum += lum;
    let chroma = f / lum;
    let s = light_params.lgh_shadows;
    if (lgh_picked < s && lgh_targets[lgh_picked] < lgh_cum) {
        let sigma = lgh_sigma(em);
        while (lgh_picked < s && lgh_targets[lgh_picked] < lgh_cum) {
            lgh_pick_pos[lgh_picked] = em.pos;
            lgh_pick_sigma[lgh_picked] = sigma;
            lgh_pick_chroma[lgh_picked] = chroma;
            lgh_picked += 1u;
        }
    }
    if (lgh_picked >= s) {
        return;
    }
    lgh_last_pos = em.pos;
    lgh_last_sigma = lgh_sigma(em);
    lgh_last_chroma = chroma;
}

// Visits every candidate of x (unit normal n) in the oracle's order.
fn lgh_walk(x: vec3<f32>, n: vec3<f32>, ng: vec3<f32>, picking: bool) {
    let levels = light_params.lgh_levels;
    let lo = light_params.lgh_lo;
    let alpha = light_params.lgh_alpha;
    let clamp2 = light_params.vpl_clamp2;
    let first = select(1u, 0u, light_params.lgh_level0 != 0u);
    if (levels == 0u) {
        // No hierarchy (no lights).
        return;
    }
    if (light_params.lgh_level0 != 0u) {
        let c = 1u << (levels - 1u);
        let q = (x - lo) * light_params.lgh_inv_h1;
        let last = vec3<f32>(f32(c - 1u));
        let a = vec3<u32>(clamp(floor(q - alpha), vec3<f32>(0.0), last));
        let b = vec3<u32>(clamp(floor(q + alpha), vec3<f32>(0.0), last));
        // A light lies in its cell's box: a cell farther than 2r_0 = α·h_1
        // (B_0 = 0 beyond; 1.001 covers the rounding of the distances) is
        // skipped unread, as when x lies far outside the lights' bounds.
        let h1 = light_params.lgh_h1;
        let reach0 = 1.001 * alpha * h1;
        for (var z = a.z; z <= b.z; z++) {
            for (var y = a.y; y <= b.y; y++) {
                for (var xi = a.x; xi <= b.x; xi++) {
                    let box_lo = lo + vec3<f32>(f32(xi), f32(y), f32(z)) * h1;
                    let gap = max(max(box_lo - x, x - (box_lo + vec3<f32>(h1))), vec3<f32>(0.0));
                    if (length(gap) >= reach0) {
                        continue;
                    }
                    let at = light_params.lgh_cells_offset + 2u * (xi + c * (y + c * z));
                    let end = light_index[at + 1u];
                    for (var s = light_index[at]; s < end; s++) {
                        if (picking && lgh_picked >= light_params.lgh_shadows) {
                            return;
                        }
                        let id = light_index[light_params.lgh_sorted_offset + s];
                        lgh_visit(first, 0u, lgh_light_emitter(light_prims[id], clamp2), x, n, ng, picking);
                    }
                }
            }
        }
    }
    for (var level = 1u; level <= levels; level++) {
        let r = lgh_res(levels, level);
        var a = vec3<u32>(0u);
        var b = vec3<u32>(r - 1u);
        if (level != levels) {
            let q = (x - lo) * lgh_inv_h(light_params.lgh_inv_h1, level);
            let reach = 2.0 * alpha + 1.0;
            let last = vec3<f32>(f32(r - 1u));
            a = vec3<u32>(clamp(floor(q - reach), vec3<f32>(0.0), last));
            b = vec3<u32>(clamp(floor(q + reach), vec3<f32>(0.0), last));
        }
        let offset = lgh_index_offset(levels, level);
        let h = lgh_h(light_params.lgh_h1, level);
        // A grid light lies within its vertex's 8 cells, |centre − v| ≤ √3·h:
        // vertices farther than 2r + √3·h (B = 0 beyond 2r) or nearer than
        // r/2 − √3·h (B = 0 within r/2) are skipped unread (1.7321 > √3
        // covers the rounding of the distances).
        let rb = alpha * h;
        let outer = select(2.0 * rb + 1.7321 * h, 3.0e38, level == levels);
        let inner = select(0.5 * rb - 1.7321 * h, -1.0, level == first);
        for (var z = a.z; z <= b.z; z++) {
            for (var y = a.y; y <= b.y; y++) {
                for (var xi = a.x; xi <= b.x; xi++) {
                    let v = lgh_vertex_pos(lo, h, vec3<u32>(xi, y, z));
                    let dv = length(v - x);
                    if (dv >= outer || dv < inner) {
                        continue;
                    }
                    if (picking && lgh_picked >= light_params.lgh_shadows) {
                        // Every shadow sample picked: the rest of the walk
                        // cannot change them.
                        return;
                    }
                    let slot = light_index[offset + xi + r * (y + r * z)];
                    if (slot != LGH_EMPTY) {
                        lgh_visit(first, level, lgh_grid_emitter(lgh_lights[slot], v, clamp2), x, n, ng, picking);
                    }
                }
            }
        }
    }
}

// Sums U and F at x: lgh_u, lgh_total.
fn lgh_sum(x: vec3<f32>, n: vec3<f32>, ng: vec3<f32>) {
    lgh_u = vec3<f32>(0.0);
    lgh_total = 0.0;
    lgh_walk(x, n, ng, false);
}

// Picks the S shadow samples for stratification offset xi after lgh_sum
// (pick): lgh_pick_* [0, S).
fn lgh_pick(x: vec3<f32>, n: vec3<f32>, ng: vec3<f32>, xi: f32) {
    let s = light_params.lgh_shadows;
    for (var k = 0u; k < s; k++) {
        lgh_targets[k] = lgh_total * ((f32(k) + xi) / f32(s));
    }
    lgh_cum = 0.0;
    lgh_picked = 0u;
    lgh_walk(x, n, ng, true);
    for (var k = lgh_picked; k < s; k++) {
        lgh_pick_pos[k] = lgh_last_pos;
        lgh_pick_sigma[k] = lgh_last_sigma;
        lgh_pick_chroma[k] = lgh_last_chroma;
    }
}
