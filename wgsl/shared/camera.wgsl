// Primary rays, exactly as docs/conventions.md "Primary ray" specifies. Needs the
// `scene` uniform from shared/scene.wgsl and shared/sampling.wgsl.

struct Ray {
    origin: vec3<f32>,
    dir: vec3<f32>,
}

// Ray through film point `film` (raster units) from lens sample `lens_u`
// ∈ [0,1)² (ignored by a pinhole camera).
fn camera_ray(film: vec2<f32>, lens_u: vec2<f32>) -> Ray {
    let ndc = vec2<f32>(2.0 * film.x / scene.film_size.x - 1.0,
                        1.0 - 2.0 * film.y / scene.film_size.y);
    let t = scene.cam_tan_half_fov_y;
    let dir = normalize(scene.cam_forward
        + (ndc.x * t * scene.cam_aspect) * scene.cam_right
        + (ndc.y * t) * scene.cam_up);
    if (scene.cam_lens_radius <= 0.0) {
        return Ray(scene.cam_position, dir);
    }
    let disk = scene.cam_lens_radius * sample_concentric_disk(lens_u);
    let origin = scene.cam_position + disk.x * scene.cam_right + disk.y * scene.cam_up;
    let focus = scene.cam_position + dir * (scene.cam_focus_distance / dot(dir, scene.cam_forward));
    return Ray(origin, normalize(focus - origin));
}

// Scene time of a shutter sample t ∈ [0, 1).
fn shutter_time(t: f32) -> f32 {
    return mix(scene.shutter.x, scene.shutter.y, t);
}
