// Area-light direct lighting (4D): dims 0–1 film point, u[0] selects an
// emissive triangle (by power) and, remapped, with u[1] picks a uniform
// point on it. Lambertian surfaces, one shadow ray; the estimate is
//   L_e(x) + ρ(x)/π · L_e(y) · cosθ_x · cosθ_y / |x − y|² · V(x, y) / p(y),
// p(y) = pmf(triangle) / area(triangle). Camera rays are pinhole rays
// through the lens centre at shutter-open time: this integrand has no lens
// or time dimension.

// Relative offset of secondary-ray origins along the normal, and the
// fraction of the light distance a shadow ray stops short by.
const RAY_EPSILON: f32 = 1e-4;

fn albedo_at(m: Material, x: vec3<f32>) -> vec3<f32> {
    if (m.checker_scale > 0.0) {
        let c = floor(x / m.checker_scale);
        let parity = i32(c.x + c.y + c.z) & 1;
        if (parity != 0) {
            return m.albedo2;
        }
    }
    return m.albedo;
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

fn integrand(p: ptr<function, IntegrandPoint>) -> vec3<f32> {
    let time = shutter_time(0.0);
    let ray = camera_ray((*p).film, vec2<f32>(0.5));
    let hit = trace_closest(ray.origin, ray.dir, 3.0e38, time);
    if (hit.prim == 0xffffffffu) {
        return scene.background;
    }
    let tri = triangle_world(hit.prim, time);
    let x = tri[0] * (1.0 - hit.bary.x - hit.bary.y) + tri[1] * hit.bary.x + tri[2] * hit.bary.y;
    let ng = normalize(cross(tri[1] - tri[0], tri[2] - tri[0]));
    let m = materials[triangle_material(hit.prim)];

    // Emission is one-sided: seen only from the side the normal faces.
    var radiance = select(vec3<f32>(0.0), m.emission, dot(ng, ray.dir) < 0.0);
    let rho = albedo_at(m, x);
    if (scene.emitter_count == 0u || all(rho == vec3<f32>(0.0))) {
        return radiance;
    }
    // Reflection is two-sided: shade with the normal facing the viewer.
    let n = select(ng, -ng, dot(ng, ray.dir) > 0.0);

    // Choose an emitter by power and reuse u[0] within its CDF interval.
    let k = select_emitter((*p).u[0]);
    let e = emitters[k];
    let cdf_below = e.cdf - e.pmf;
    let u0 = clamp(((*p).u[0] - cdf_below) / e.pmf, 0.0, ONE_MINUS_EPSILON);
    let light = triangle_world(e.prim, time);
    let b = sample_uniform_triangle(vec2<f32>(u0, (*p).u[1]));
    let y = light[0] * b.x + light[1] * b.y + light[2] * (1.0 - b.x - b.y);
    let n_light = normalize(cross(light[1] - light[0], light[2] - light[0]));

    // The shadow ray starts off the surface (against self-intersection)
    // and aims at y from there, so it reaches the light's plane at the
    // target distance and stops just short of it.
    let scale = max(1.0, max(abs(x.x), max(abs(x.y), abs(x.z))));
    let origin = x + n * (RAY_EPSILON * scale);
    let to_light = y - origin;
    let dist2 = dot(to_light, to_light);
    if (dist2 <= 0.0) {
        return radiance;
    }
    let dist = sqrt(dist2);
    let wi = to_light / dist;
    let cos_x = dot(n, wi);
    let cos_y = -dot(n_light, wi);
    if (cos_x <= 0.0 || cos_y <= 0.0) {
        return radiance;
    }
    if (trace_any(origin, wi, dist * (1.0 - RAY_EPSILON), time)) {
        return radiance;
    }
    let le = materials[triangle_material(e.prim)].emission;
    let pdf_area = e.pmf / e.area;
    return radiance + rho * INV_PI * le * (cos_x * cos_y / (dist2 * pdf_area));
}
