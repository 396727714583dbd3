// Depth of field (4D): dims 0–1 film point, u[0], u[1] the lens sample
// (concentric disk map in camera_ray, shared/camera.wgsl). Rays are traced
// at shutter-open time and shaded by shade_direct (shared/shading.wgsl):
// emission seen directly plus the point and directional lights with one
// shadow ray each. See src/integrand/depth_of_field.rs.

fn integrand(p: ptr<function, IntegrandPoint>) -> vec3<f32> {
    let time = shutter_time(0.0);
    let ray = camera_ray((*p).film, vec2<f32>((*p).u[0], (*p).u[1]));
    return shade_direct(ray.origin, ray.dir, time);
}
