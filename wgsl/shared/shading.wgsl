// Surface shading shared by the scene integrands (area_light,
// depth_of_field, motion_blur, path, ambient_occlusion): the surface seen
// by a ray, ray offsets, direct light from the analytic (point and
// directional) lights with one shadow ray each, and the one-sample
// area-light (emissive triangle) estimate. Lambertian materials: outgoing
// radiance ρ/π · irradiance; emission one-sided (toward the geometric
// normal), reflection two-sided unless the material is one-sided (then
// its back — behind the shading normal — reflects nothing, as Mitsuba's
// plain `diffuse`) (docs/conventions.md "Materials", "Lights").
// Reflection takes its cosine from the shading normal (an OBJ's vertex
// normals; the geometric normal elsewhere) and only light from the side the
// geometric normal faces (`cos_reflect`); emission sides, ray offsets and
// shadow-ray ends use the geometric normal.
// Needs GpuScene::wgsl() (scene.wgsl, bvh.wgsl) and shared/sampling.wgsl.

// Relative offset of secondary-ray origins along the normal, and the
// fraction of the light distance a shadow ray stops short by.
const RAY_EPSILON: f32 = 1e-4;
// t_max of rays that may go to infinity.
const RAY_T_MAX: f32 = 3.0e38;

// Rays traced so far by this invocation (camera, bounce, shadow and
// occlusion rays alike) and the traversal loop iterations they took:
// every integrand traces through the two functions below, so a counting
// kernel (benches/integrands.rs) can read them after calling `integrand`
// and check the budget lavapipe imposes (65,535 loop iterations per
// invocation). Other kernels never read them.
var<private> rays_traced: u32 = 0u;
var<private> traversal_steps: u32 = 0u;

fn scene_closest(origin: vec3<f32>, dir: vec3<f32>, t_max: f32, time: f32) -> Hit {
    let r = bvh_traverse(origin, dir, t_max, time, false);
    rays_traced += 1u;
    traversal_steps += r.steps;
    return r.hit;
}

// Whether the segment origin + t·dir, t ∈ (0, t_max), is blocked.
// `n_origin` and `n_end` are the unit normals of the surfaces the segment
// starts and ends on (zero where it does not end on a surface: a point
// light, a direction, an ambient-occlusion radius); the BVH ignores them,
// voxel visibility uses them to leave out the voxels of those surfaces
// (shared/voxel.wgsl, src/accel/voxel.rs "Self-occlusion rule").
fn scene_occluded(origin: vec3<f32>, dir: vec3<f32>, t_max: f32, time: f32,
                  n_origin: vec3<f32>, n_end: vec3<f32>) -> bool {
    if scene.visibility == VISIBILITY_VOXEL {
        // Per voxel object a box test and, where the segment meets it, a
        // slab clip and one row of at most MAX_VOXEL_WORDS words
        // (shared/voxel.wgsl): a bound on the loop iterations.
        rays_traced += 1u;
        traversal_steps += scene.voxel_objects * (7u + MAX_VOXEL_WORDS);
        return voxel_occluded(origin, dir, t_max, time, n_origin, n_end);
    }
    let r = bvh_traverse(origin, dir, t_max, time, true);
    rays_traced += 1u;
    traversal_steps += r.steps;
    return r.hit.prim != BVH_MISS;
}

// What a ray sees where it hits the scene.
struct Surface {
    x: vec3<f32>,        // hit point (world, at the ray's time)
    n: vec3<f32>,        // unit geometric normal, turned to face the ray's origin side
    ns: vec3<f32>,       // unit shading normal, turned with n (= n without vertex normals)
    rho: vec3<f32>,      // albedo at x (checker applied)
    emitted: vec3<f32>,  // L_e toward the ray: the emission if the front side is seen, else 0
}

// The albedo at x (a hit of triangle `prim` at barycentrics `bary`): the
// world-space checker, or Mitsuba's checkerboard in texture space (the
// material's albedo where frac(u') > 1/2 equals frac(v') > 1/2).
fn albedo_at(m: Material, x: vec3<f32>, prim: u32, bary: vec2<f32>) -> vec3<f32> {
    if (m.checker_uv != 0u) {
        let uv = vec3<f32>(triangle_uv(prim, bary), 1.0);
        let t = vec2<f32>(dot(m.to_uv0.xyz, uv), dot(m.to_uv1.xyz, uv));
        let f = t - floor(t);
        return select(m.albedo2, m.albedo, (f.x > 0.5) == (f.y > 0.5));
    }
    if (m.checker_scale > 0.0) {
        let c = floor(x / m.checker_scale);
        let parity = i32(c.x + c.y + c.z) & 1;
        if (parity != 0) {
            return m.albedo2;
        }
    }
    return m.albedo;
}

// The surface of a hit of the ray with direction `dir` at scene time `time`.
fn surface_at(hit: Hit, dir: vec3<f32>, time: f32) -> Surface {
    let tri = triangle_world(hit.prim, time);
    let x = tri[0] * (1.0 - hit.bary.x - hit.bary.y) + tri[1] * hit.bary.x + tri[2] * hit.bary.y;
    let ng = normalize(cross(tri[1] - tri[0], tri[2] - tri[0]));
    let m = materials[triangle_material(hit.prim)];
    let front = dot(ng, dir) < 0.0;
    let side = select(-1.0, 1.0, front);
    let ns = triangle_shading_normal(hit.prim, hit.bary, time, ng);
    // A one-sided material (Mitsuba's plain `diffuse`) is black from
    // behind, where — as in Mitsuba's shading frame — the shading normal
    // decides which side the ray sees (the geometric normal without
    // vertex normals).
    let rho = select(vec3<f32>(0.0), albedo_at(m, x, hit.prim, hit.bary), dot(ns, dir) < 0.0 || m.one_sided == 0u);
    return Surface(x, side * ng, side * ns, rho, select(vec3<f32>(0.0), m.emission, front));
}

// The cosine a Lambertian reflection at s weights light arriving from
// direction wi (unit, pointing away from s) by: max(ns·wi, 0), and 0 for
// light from behind the geometric surface (it cannot pass through).
fn cos_reflect(s: Surface, wi: vec3<f32>) -> f32 {
    if (dot(s.n, wi) <= 0.0) {
        return 0.0;
    }
    return max(dot(s.ns, wi), 0.0);
}

// Origin of a secondary ray leaving x on the side n faces: offset against
// self-intersection by RAY_EPSILON relative to the coordinates' magnitude.
fn offset_origin(x: vec3<f32>, n: vec3<f32>) -> vec3<f32> {
    let scale = max(1.0, max(abs(x.x), max(abs(x.y), abs(x.z))));
    return x + n * (RAY_EPSILON * scale);
}

// Radiance reflected at s from the point and directional lights, one
// shadow ray per light that faces s:
//   ρ/π · Σ_lights E_l · cosθ_l · V,  E_l = I/d² (point) or E (directional).
fn direct_delta_lights(s: Surface, time: f32) -> vec3<f32> {
    var irradiance = vec3<f32>(0.0);
    if (scene.light_count == 0u || all(s.rho == vec3<f32>(0.0))) {
        return irradiance;
    }
    let origin = offset_origin(s.x, s.n);
    for (var i = 0u; i < scene.light_count; i++) {
        let light = lights[i];
        var wi: vec3<f32>;
        var t_max = RAY_T_MAX;
        var e = light.intensity;  // irradiance at normal incidence
        if (light.kind == LIGHT_POINT) {
            // Aim from the offset origin at the light (as for area lights).
            let to_light = light.position - origin;
            let d2 = dot(to_light, to_light);
            if (d2 <= 0.0) {
                continue;
            }
            let d = sqrt(d2);
            wi = to_light / d;
            t_max = d * (1.0 - RAY_EPSILON);
            e = light.intensity / d2;
        } else {
            wi = -light.position;  // `position` holds the direction of travel
        }
        let cos_x = cos_reflect(s, wi);
        if (cos_x <= 0.0 || all(e == vec3<f32>(0.0))) {
            continue;
        }
        if (scene_occluded(origin, wi, t_max, time, s.n, vec3<f32>(0.0))) {
            continue;
        }
        irradiance += e * cos_x;
    }
    return s.rho * INV_PI * irradiance;
}

// First emitter whose inclusive CDF exceeds u (binary search).
fn select_emitter(u: f32) -> u32 {
    var lo = 0u;
    var hi = scene.emitter_count - 1u;
    for (var i = 0u; i < 32u && lo < hi; i++) {
        let mid = (lo + hi) / 2u;
        if (emitters[mid].cdf > u) {
            hi = mid;
        } else {
            lo = mid + 1u;
        }
    }
    return lo;
}

// A point on the emissive triangles, with its area density.
struct EmitterSample {
    y: vec3<f32>,        // the point (world, at `time`)
    n: vec3<f32>,        // unit geometric normal there (emission faces it)
    le: vec3<f32>,       // emitted radiance
    pdf_area: f32,       // pmf(triangle) / area(triangle)
    prim: u32,
}

// Chooses an emitter with probability ∝ luminance(L_e)·area by u.x,
// reuses u.x remapped within the chosen CDF interval, and with u.y picks
// a uniform point on it. Needs scene.emitter_count > 0.
fn sample_emitter(u: vec2<f32>, time: f32) -> EmitterSample {
    let k = select_emitter(u.x);
    let e = emitters[k];
    let cdf_below = e.cdf - e.pmf;
    let u0 = clamp((u.x - cdf_below) / e.pmf, 0.0, ONE_MINUS_EPSILON);
    let light = triangle_world(e.prim, time);
    let b = sample_uniform_triangle(vec2<f32>(u0, u.y));
    let y = light[0] * b.x + light[1] * b.y + light[2] * (1.0 - b.x - b.y);
    let n_light = normalize(cross(light[1] - light[0], light[2] - light[0]));
    let le = materials[triangle_material(e.prim)].emission;
    return EmitterSample(y, n_light, le, e.pmf / e.area, e.prim);
}

// One-sample estimate of the radiance reflected at s from the emissive
// triangles (light point chosen by `u`, one shadow ray):
//   ρ/π · L_e(y) · cosθ_x · cosθ_y / |x − y|² · V(x, y) / p(y).
fn direct_area_light(s: Surface, u: vec2<f32>, time: f32) -> vec3<f32> {
    if (scene.emitter_count == 0u || all(s.rho == vec3<f32>(0.0))) {
        return vec3<f32>(0.0);
    }
    let l = sample_emitter(u, time);
    // The shadow ray starts off the surface (against self-intersection)
    // and aims at y from there, so it reaches the light's plane at the
    // target distance and stops just short of it.
    let origin = offset_origin(s.x, s.n);
    let to_light = l.y - origin;
    let dist2 = dot(to_light, to_light);
    if (dist2 <= 0.0) {
        return vec3<f32>(0.0);
    }
    let dist = sqrt(dist2);
    let wi = to_light / dist;
    let cos_x = cos_reflect(s, wi);
    let cos_y = -dot(l.n, wi);
    if (cos_x <= 0.0 || cos_y <= 0.0) {
        return vec3<f32>(0.0);
    }
    if (scene_occluded(origin, wi, dist * (1.0 - RAY_EPSILON), time, s.n, l.n)) {
        return vec3<f32>(0.0);
    }
    return s.rho * INV_PI * l.le * (cos_x * cos_y / (dist2 * l.pdf_area));
}

// What a camera ray sees under the analytic lights: emission seen
// directly plus direct light from the point and directional lights
// (background where it hits nothing). The depth-of-field and motion-blur
// integrands are this along their own rays.
fn shade_direct(origin: vec3<f32>, dir: vec3<f32>, time: f32) -> vec3<f32> {
    let hit = scene_closest(origin, dir, RAY_T_MAX, time);
    if (hit.prim == BVH_MISS) {
        return scene.background;
    }
    let s = surface_at(hit, dir, time);
    return s.emitted + direct_delta_lights(s, time);
}
