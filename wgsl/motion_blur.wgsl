// Motion blur (3D): dims 0–1 film point, u[0] the shutter sample t; the
// ray (through the lens centre) and its shadow rays are traced at scene
// time shutter_time(t), where every moving mesh sits at its keyframe-
// interpolated pose. Shaded by shade_direct (shared/shading.wgsl). See
// src/integrand/motion_blur.rs.

fn integrand(p: ptr<function, IntegrandPoint>) -> vec3<f32> {
    let time = shutter_time((*p).u[0]);
    let ray = camera_ray((*p).film, vec2<f32>(0.5));
    return shade_direct(ray.origin, ray.dir, time);
}
