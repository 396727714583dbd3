// Area-light direct lighting (4D): dims 0–1 film point, u[0] selects an
// emissive triangle (by power) and, remapped, with u[1] picks a uniform
// point on it. Lambertian surfaces, one shadow ray; the estimate is
//   L_e(x) + ρ(x)/π · L_e(y) · cosθ_x · cosθ_y / |x − y|² · V(x, y) / p(y),
// p(y) = pmf(triangle) / area(triangle) (shared/shading.wgsl,
// `direct_area_light`). Camera rays are pinhole rays through the lens
// centre at shutter-open time: this integrand has no lens or time
// dimension.

fn integrand(p: ptr<function, IntegrandPoint>) -> vec3<f32> {
    let time = shutter_time(0.0);
    let ray = camera_ray((*p).film, vec2<f32>(0.5));
    let hit = scene_closest(ray.origin, ray.dir, RAY_T_MAX, time);
    if (hit.prim == BVH_MISS) {
        return scene.background;
    }
    let s = surface_at(hit, ray.dir, time);
    return s.emitted + direct_area_light(s, vec2<f32>((*p).u[0], (*p).u[1]), time);
}
