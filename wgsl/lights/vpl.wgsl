// Virtual point lights by instant radiosity (src/lights/vpl.rs explains the
// paths): one invocation traces light path `i` and writes its VPLs to slots
// i·bounces .. (i+1)·bounces of `vpls`. Needs the scene and shading code
// (integrand::scene_wgsl), lights/light_prim.wgsl and shared/rng.wgsl.
// Constants from Rust: VPL_WG, KIND_DIRECTIONAL_SOURCE, KIND_VPL,
// KIND_TRIANGLE.

struct VplParams {
    paths: u32,
    bounces: u32,
    seed: u32,
    // 0 when no source emits: every VPL is dark.
    source_count: u32,
    center: vec3<f32>,
    radius: f32,
    time: f32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

@group(0) @binding(0) var<uniform> vpl_params: VplParams;
@group(0) @binding(1) var<storage, read> vpl_sources: array<LightPrim>;
// Inclusive CDF of the sources' luminance flux; the last entry is 1.
@group(0) @binding(2) var<storage, read> vpl_cdf: array<f32>;
@group(0) @binding(3) var<storage, read_write> vpls: array<LightPrim>;

// The path's random number of dimension `dim`, in [0, 1).
fn vpl_rand(path: u32, dim: u32) -> f32 {
    return u32_to_unit_float(hash3(vpl_params.seed, path, dim));
}

// First source whose inclusive CDF exceeds u (binary search).
fn vpl_pick_source(u: f32) -> u32 {
    var lo = 0u;
    var hi = vpl_params.source_count - 1u;
    for (var i = 0u; i < 32u && lo < hi; i++) {
        let mid = (lo + hi) / 2u;
        if (vpl_cdf[mid] > u) {
            hi = mid;
        } else {
            lo = mid + 1u;
        }
    }
    return lo;
}

fn vpl_dark(x: vec3<f32>) -> LightPrim {
    return LightPrim(x, KIND_VPL, vec3<f32>(0.0, 0.0, 1.0), 0u, x, 0u, vec3<f32>(0.0), 0u);
}

// Uniform direction on the sphere (density 1/4π).
fn vpl_uniform_sphere(u: vec2<f32>) -> vec3<f32> {
    let z = 1.0 - 2.0 * u.x;
    let r = sqrt(max(0.0, 1.0 - z * z));
    let phi = 2.0 * PI * u.y;
    return vec3<f32>(r * cos(phi), r * sin(phi), z);
}

@compute @workgroup_size(VPL_WG)
fn generate_vpls(@builtin(workgroup_id) wid: vec3<u32>,
                 @builtin(num_workgroups) groups: vec3<u32>,
                 @builtin(local_invocation_index) lid: u32) {
    let path = (wid.x + wid.y * groups.x) * VPL_WG + lid;
    if (path >= vpl_params.paths) {
        return;
    }
    let first = path * vpl_params.bounces;
    let time = vpl_params.time;
    if (vpl_params.source_count == 0u) {
        for (var k = 0u; k < vpl_params.bounces; k++) {
            vpls[first + k] = vpl_dark(vpl_params.center);
        }
        return;
    }
    // Dimensions: 0 source, 1–2 start point, 3–4 direction, then 2 per bounce.
    let u0 = vpl_rand(path, 0u);
    let k_src = vpl_pick_source(u0);
    let below = select(0.0, vpl_cdf[max(k_src, 1u) - 1u], k_src > 0u);
    let pmf = vpl_cdf[k_src] - below;
    if (!(pmf > 0.0)) {
        // A flux too small to survive the f32 CDF: never picked in exact
        // arithmetic; dark rather than infinite.
        for (var k = 0u; k < vpl_params.bounces; k++) {
            vpls[first + k] = vpl_dark(vpl_params.center);
        }
        return;
    }
    let src = vpl_sources[k_src];
    let scale = 1.0 / (pmf * f32(vpl_params.paths));
    let ua = vec2<f32>(vpl_rand(path, 1u), vpl_rand(path, 2u));
    let ub = vec2<f32>(vpl_rand(path, 3u), vpl_rand(path, 4u));
    var origin: vec3<f32>;
    var dir: vec3<f32>;
    var flux: vec3<f32>;
    if (src.kind == KIND_TRIANGLE) {
        let b = sample_uniform_triangle(ua);
        let y = src.p0 * b.x + src.p1 * b.y + src.p2 * (1.0 - b.x - b.y);
        let c = cross(src.p1 - src.p0, src.p2 - src.p0);
        let n = normalize(c);
        origin = offset_origin(y, n);
        dir = frame_from_normal(n) * sample_cosine_hemisphere(ub);
        flux = src.emission * (PI * 0.5 * length(c) * scale);
    } else if (src.kind == KIND_DIRECTIONAL_SOURCE) {
        let d = src.p0;
        let f = frame_from_normal(d);
        let disk = sample_concentric_disk(ua) * vpl_params.radius;
        origin = vpl_params.center - d * (1.01 * vpl_params.radius) + f[0] * disk.x + f[1] * disk.y;
        dir = d;
        flux = src.emission * (PI * vpl_params.radius * vpl_params.radius * scale);
    } else {
        origin = src.p0;
        dir = vpl_uniform_sphere(ua);
        flux = src.emission * (4.0 * PI * scale);
    }
    var k = 0u;
    for (; k < vpl_params.bounces; k++) {
        let hit = scene_closest(origin, dir, RAY_T_MAX, time);
        if (hit.prim == BVH_MISS) {
            break;
        }
        let s = surface_at(hit, dir, time);
        // The VPL's lobe and the path's next direction follow the shading
        // normal; a direction behind the geometric surface ends the path.
        vpls[first + k] = LightPrim(s.x, KIND_VPL, s.ns, 0u, s.x, 0u, flux * s.rho * INV_PI, 0u);
        flux *= s.rho;
        let u = vec2<f32>(vpl_rand(path, 5u + 2u * k), vpl_rand(path, 6u + 2u * k));
        dir = frame_from_normal(s.ns) * sample_cosine_hemisphere(u);
        origin = offset_origin(s.x, s.n);
        if (dot(s.n, dir) <= 0.0) {
            k++;
            break;
        }
    }
    for (; k < vpl_params.bounces; k++) {
        vpls[first + k] = vpl_dark(origin);
    }
}
