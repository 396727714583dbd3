// Ambient occlusion (4D): dims 0–1 film point, u[0], u[1] a cosine-
// weighted direction on the hemisphere of the visible side of the surface
// seen through the lens centre at shutter-open time. The value is 1 if
// the occlusion ray (from the offset origin) hits nothing within distance
// AO_RADIUS, else 0; its mean is the cosine-weighted unoccluded fraction
//   A(x) = (1/π) ∫_H V_r(x, ω) cosθ dω ∈ [0, 1].
// The hemisphere is the shading normal's; a direction behind the geometric
// surface counts as occluded (the surface itself is in the way).
// Camera rays that hit nothing return the background. Generated constant:
// AO_RADIUS_BITS (the f32 bits of the radius). See
// src/integrand/ambient_occlusion.rs.

fn integrand(p: ptr<function, IntegrandPoint>) -> vec3<f32> {
    let time = shutter_time(0.0);
    let ray = camera_ray((*p).film, vec2<f32>(0.5));
    let hit = scene_closest(ray.origin, ray.dir, RAY_T_MAX, time);
    if (hit.prim == BVH_MISS) {
        return scene.background;
    }
    let s = surface_at(hit, ray.dir, time);
    let wi = frame_from_normal(s.ns) * sample_cosine_hemisphere(vec2<f32>((*p).u[0], (*p).u[1]));
    if (dot(s.n, wi) <= 0.0) {
        return vec3<f32>(0.0);
    }
    let occluded = scene_occluded(offset_origin(s.x, s.n), wi, bitcast<f32>(AO_RADIUS_BITS), time,
                                  s.n, vec3<f32>(0.0));
    return vec3<f32>(select(1.0, 0.0, occluded));
}
