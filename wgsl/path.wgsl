// Path tracing with next-event estimation, fixed length (no Russian
// roulette). Generated constants: PATH_MAX_BOUNCES = m (indirect bounces)
// and PATH_AREA_NEE (1 if the scene has emissive triangles, else 0).
//
// Vertex k = 0..m is the k-th surface hit (x_0 seen by the camera ray
// through the lens centre at shutter-open time). Its dimensions start at
// u[k · PATH_VERTEX_DIMS]: with area NEE, two for the emitter sample then
// two for the bounce; without, two for the bounce. The last vertex has no
// bounce, so d = 2 + 2m (no area lights) or 4 + 4m (area lights).
//
// Estimate: L = L_e(x_0) + Σ_{k=0..m} β_k · [ρ/π Σ_delta E cosθ V +
// area-light NEE sample] + Σ_{k=1..m} β_k · L_background (bounce rays that
// escape). β_0 = 1, β_{k+1} = β_k · ρ(x_k): cosine-weighted bounces make
// f·cosθ/pdf = ρ. Emission reached by a bounce ray is not added: the NEE
// at the vertex before it accounts for it. See src/integrand/path.rs.
// Bounces are cosine-weighted about the shading normal; one that leaves
// behind the geometric surface ends the path (`cos_reflect` is 0 there).


const PATH_VERTEX_DIMS: u32 = 2u + 2u * PATH_AREA_NEE;

fn integrand(p: ptr<function, IntegrandPoint>) -> vec3<f32> {
    let time = shutter_time(0.0);
    let ray = camera_ray((*p).film, vec2<f32>(0.5));
    var hit = scene_closest(ray.origin, ray.dir, RAY_T_MAX, time);
    if (hit.prim == BVH_MISS) {
        return scene.background;
    }
    var s = surface_at(hit, ray.dir, time);
    var radiance = s.emitted;
    var beta = vec3<f32>(1.0);
    for (var k = 0u; k <= PATH_MAX_BOUNCES; k++) {
        let base = k * PATH_VERTEX_DIMS;
        // Next-event estimation at x_k.
        var direct = direct_delta_lights(s, time);
        if (PATH_AREA_NEE == 1u) {
            direct += direct_area_light(s, vec2<f32>((*p).u[base], (*p).u[base + 1u]), time);
        }
        radiance += beta * direct;
        if (k == PATH_MAX_BOUNCES || all(s.rho == vec3<f32>(0.0))) {
            break;
        }
        // Cosine-weighted bounce on the side of x_k the ray arrived from.
        let b = base + 2u * PATH_AREA_NEE;
        let wi = frame_from_normal(s.ns) * sample_cosine_hemisphere(vec2<f32>((*p).u[b], (*p).u[b + 1u]));
        if (dot(s.n, wi) <= 0.0) {
            break;
        }
        beta *= s.rho;
        hit = scene_closest(offset_origin(s.x, s.n), wi, RAY_T_MAX, time);
        if (hit.prim == BVH_MISS) {
            radiance += beta * scene.background;
            break;
        }
        s = surface_at(hit, wi, time);
    }
    return radiance;
}
