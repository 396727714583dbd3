// Many-light direct lighting (src/integrand/many_light.rs): dims 0–1 film
// point, u[0] light selection through the sampler (lights/sample.wgsl),
// u[1..3] a uniform point on a selected emissive triangle (only when
// ML_TRIANGLES = 1), u[1..4] the Gaussian position of a selected substitute
// (sst only, ML_SUBSTITUTES = 1). One shadow ray; the estimate is
//   L_e(x) + ρ(x)/π · C(y) · cosθ_x · V(x, y) / pmf(light),
// or, for the kinds with cuts under the paper's estimator, the sum of that
// term over one light per subtree of the pixel's share of the cut (pmf
// within its subtree; subtree j > 0 with its own hashed numbers,
// ml_subtree_u),
// C = I/d² (point), L_e·cosθ_y·area/d² (one-sided triangle) or
// I·cosθ_v/max(d², clamp²) (VPL, a cosine lobe about its normal; a
// substitute is a VPL at a drawn position with its node's summed intensity
// and merged normal, and pmf the probability of stopping at its node).
// With the lgh sampler (ML_LGH = 1) an evaluation sums over the grid
// lights instead (ml_lgh, lights/lgh.wgsl): u[0] is the stratification
// offset of the S shadow-sample picks, u[1..4] the jitter of the first
// shadow sample in its box, the others' jitter a Kronecker (R3) shift of
// it; with emissive triangles (not grid lights) u[4] picks one uniformly
// and u[5..7] a point on it.
// Constants from Rust: ML_TRIANGLES, ML_SUBSTITUTES, ML_LGH. The frame time and number are
// uniforms (light_params.time, light_params.frame): a new frame compiles
// no new shader.

fn ml_time() -> f32 {
    return light_params.time;
}

// The film pixel holding film point `film`, clamped to the film.
fn ml_pixel(film: vec2<f32>) -> vec2<u32> {
    let size = vec2<u32>(scene.film_size);
    let px = vec2<u32>(max(floor(film), vec2<f32>(0.0)));
    return min(px, size - vec2<u32>(1u));
}

// The random numbers of subtree j of the paper's estimator (src/lights/
// tree/cut.rs subtree_random): subtree 0 takes the evaluation's own u;
// subtree j > 0 takes u rotated (mod 1) by four numbers hashed
// (shared/rng.wgsl) from the pixel and j. Each subtree draws with its own
// random offset (the authors draw a new number per cut node), and across
// a pixel's samples each subtree's numbers keep the stratification of
// the pixel's sequence: hashing u itself instead gave white noise and
// 6–12 % more variance on cornell_lights (BENCHMARKS.md). Each term's
// numbers are uniform, so each term stays unbiased.
fn ml_subtree_u(u: vec4<f32>, px: vec2<u32>, j: u32) -> vec4<f32> {
    if (j == 0u) {
        return u;
    }
    let key = hash3(px.x, px.y, j);
    let r = vec4<f32>(
        u32_to_unit_float(hash_u32(key)),
        u32_to_unit_float(hash_u32(key + 0x9e3779b9u)),
        u32_to_unit_float(hash_u32(key + 0x3c6ef372u)),
        u32_to_unit_float(hash_u32(key + 0xdaa66d2bu)),
    );
    return fract(u + r);
}

// Radiance reflected at s from the sampler's lights. The kinds with cuts
// under the paper's estimator (light_per_subtree): one light from each
// subtree of the pixel's share of the cut, one shadow ray each, summed;
// otherwise light_samples lights picked (one with u; one shadow ray each),
// averaged.
fn ml_direct(s: Surface, px: vec2<u32>, u: vec4<f32>, time: f32) -> vec3<f32> {
    if (all(s.rho == vec3<f32>(0.0))) {
        return vec3<f32>(0.0);
    }
    let base = light_cut_base(px);
    var sum = vec3<f32>(0.0);
    if (light_per_subtree()) {
        var len = light_cut_len(base);
        if (light_params.count == 0u) {
            len = 0u;
        }
        for (var j = 0u; j < len; j++) {
            let uj = ml_subtree_u(u, px, j);
            sum += ml_pick(s, light_descend_subtree(s.x, s.ns, base, j, uj.x), uj.yzw, time);
        }
    } else {
        // light_samples picks at this point, averaged; pick j draws with
        // subtree j's numbers (pick 0 with u itself).
        let n = max(light_params.light_samples, 1u);
        for (var j = 0u; j < n; j++) {
            let uj = ml_subtree_u(u, px, j);
            sum += ml_pick(s, light_sample(s.x, s.ns, base, uj.x), uj.yzw, time);
        }
        sum /= f32(n);
    }
    return s.rho * INV_PI * sum * light_interleave_scale();
}

// C(y)·cosθ_x·V(x, y) / pmf of a picked light (u3: the point on a triangle
// or the substitute's position).
fn ml_pick(s: Surface, pick: LightPick, u3: vec3<f32>, time: f32) -> vec3<f32> {
    if (pick.light == NO_LIGHT || !(pick.pmf_m > 0.0)) {
        return vec3<f32>(0.0);
    }
    var l: LightPrim;
    if ((pick.light & LIGHT_SUBSTITUTE_BIT) != 0u) {
        // A substitute VPL drawn from its node's distribution, inside the box.
        let node = pick.light & ~LIGHT_SUBSTITUTE_BIT;
        let sub = light_substitutes[node];
        let b = light_nodes[node];
        let y = substitute_position(sub, u3, b.bmin, b.bmax);
        l = LightPrim(y, KIND_VPL, sub.normal, 0u, y, 0u, sub.emission, 0u);
    } else {
        l = light_prims[pick.light];
    }
    let c = ml_light(s, l, u3.xy, time);
    // c / pmf with pmf = m·2^e: divide by the mantissa, then scale.
    return ldexp(c / pick.pmf_m, vec3<i32>(-pick.pmf_e));
}

// C(y)·cosθ_x·V(x, y) of light l at s (a triangle sampled uniformly with
// u2): the estimate before ρ/π and the pmf.
fn ml_light(s: Surface, l: LightPrim, u2: vec2<f32>, time: f32) -> vec3<f32> {
    let origin = offset_origin(s.x, s.n);
    var y = l.p0;
    var area = 0.0;
    var ng = vec3<f32>(0.0);
    if (l.kind == KIND_TRIANGLE) {
        let b = sample_uniform_triangle(u2);
        y = l.p0 * b.x + l.p1 * b.y + l.p2 * (1.0 - b.x - b.y);
        let c = cross(l.p1 - l.p0, l.p2 - l.p0);
        area = 0.5 * length(c);
        ng = normalize(c);
    }
    let to_light = y - origin;
    let dist2 = dot(to_light, to_light);
    if (!(dist2 > 0.0)) {
        return vec3<f32>(0.0);
    }
    let dist = sqrt(dist2);
    let wi = to_light / dist;
    let cos_x = cos_reflect(s, wi);
    if (cos_x <= 0.0) {
        return vec3<f32>(0.0);
    }
    var c = l.emission * (cos_x / dist2);
    if (l.kind == KIND_VPL) {
        // A cosine lobe about the VPL's normal, 1/d² clamped.
        let cos_v = -dot(l.p1, wi);
        if (cos_v <= 0.0) {
            return vec3<f32>(0.0);
        }
        c = l.emission * (cos_x * cos_v / max(dist2, light_params.vpl_clamp2));
    }
    if (l.kind == KIND_TRIANGLE) {
        let cos_y = -dot(ng, wi);
        if (cos_y <= 0.0 || !(area > 0.0)) {
            return vec3<f32>(0.0);
        }
        c *= cos_y * area;
    }
    // The light's surface: a triangle's, a VPL's (p1), none for a point.
    var n_light = ng;
    if (l.kind == KIND_VPL) {
        n_light = l.p1;
    }
    if (scene_occluded(origin, wi, dist * (1.0 - RAY_EPSILON), time, s.n, n_light)) {
        return vec3<f32>(0.0);
    }
    return c;
}

// R3 sequence steps (Roberts 2018: powers of 1/φ₃, the plastic number's
// 3D analogue) that shift shadow sample k's jitter by k·step mod 1.
const LGH_JITTER_STEP: vec3<f32> = vec3<f32>(0.8191725, 0.6710436, 0.5497005);

// Radiance reflected at s from the grid hierarchy (src/lights/lgh.rs):
//   ρ/π · (F/S) · Σ_k (f_k/‖f_k‖) · V(x, y_k),
// y_k the picked centre jittered uniformly in ±√3·σ; ρ/π · U when S = 0.
fn ml_lgh(s: Surface, u: vec4<f32>, u_tri: vec3<f32>, time: f32) -> vec3<f32> {
    if (all(s.rho == vec3<f32>(0.0))) {
        return vec3<f32>(0.0);
    }
    // Emissive triangles are not grid lights: one of them, picked
    // uniformly, is sampled as the other kinds sample a light.
    var tri = vec3<f32>(0.0);
    let t = light_params.lgh_triangles;
    if (t > 0u) {
        let j = min(u32(floor(u_tri.x * f32(t))), t - 1u);
        let id = light_index[light_params.lgh_sorted_offset + light_params.count - t + j];
        tri = s.rho * INV_PI * f32(t) * ml_light(s, light_prims[id], u_tri.yz, time);
    }
    let origin = offset_origin(s.x, s.n);
    lgh_sum(origin, s.ns, s.n);
    if (!(lgh_total > 0.0)) {
        return tri;
    }
    let count = light_params.lgh_shadows;
    if (count == 0u) {
        return tri + s.rho * INV_PI * lgh_u;
    }
    lgh_pick(origin, s.ns, s.n, u.x);
    var sum = vec3<f32>(0.0);
    for (var k = 0u; k < count; k++) {
        let j = fract(u.yzw + f32(k) * LGH_JITTER_STEP);
        let y = lgh_pick_pos[k] + (2.0 * j - 1.0) * (sqrt(3.0) * lgh_pick_sigma[k]);
        let to_light = y - origin;
        let dist2 = dot(to_light, to_light);
        if (!(dist2 > 0.0)) {
            continue;
        }
        let dist = sqrt(dist2);
        if (!scene_occluded(origin, to_light / dist, dist * (1.0 - RAY_EPSILON), time, s.n, vec3<f32>(0.0))) {
            sum += lgh_pick_chroma[k];
        }
    }
    return tri + s.rho * INV_PI * (lgh_total / f32(count)) * sum;
}

fn integrand(p: ptr<function, IntegrandPoint>) -> vec3<f32> {
    let time = ml_time();
    let ray = camera_ray((*p).film, vec2<f32>(0.5));
    let hit = scene_closest(ray.origin, ray.dir, RAY_T_MAX, time);
    if (hit.prim == BVH_MISS) {
        return scene.background;
    }
    let s = surface_at(hit, ray.dir, time);
    var u = vec4<f32>((*p).u[0], 0.5, 0.5, 0.5);
    if (ML_LGH == 1u) {
        let v = vec4<f32>((*p).u[0], (*p).u[1], (*p).u[2], (*p).u[3]);
        var w = vec3<f32>(0.5);
        if (ML_TRIANGLES == 1u) {
            w = vec3<f32>((*p).u[4], (*p).u[5], (*p).u[6]);
        }
        return s.emitted + ml_lgh(s, v, w, time);
    }
    if (ML_SUBSTITUTES == 1u) {
        u = vec4<f32>((*p).u[0], (*p).u[1], (*p).u[2], (*p).u[3]);
    } else if (ML_TRIANGLES == 1u) {
        u = vec4<f32>((*p).u[0], (*p).u[1], (*p).u[2], 0.5);
    }
    return s.emitted + ml_direct(s, ml_pixel((*p).film), u, time);
}
