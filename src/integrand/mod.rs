//! The integrand contract.
//!
//! An integrand is a function f: [0, W) × [0, H) × [0, 1)^(d−2) → RGB,
//! written in WGSL, whose integral over a pixel's footprint (divided by the
//! footprint's area) is the pixel value (DESIGN.md: a pixel's value is the
//! mean radiance over its footprint). Dimensions 0 and 1 are the film point
//! in raster units; dimensions 2.. are the integrand's own (lens, time,
//! light, bounce, …), documented by each integrand in a stable order.
//!
//! On the WGSL side an integrand defines
//!
//! ```wgsl
//! fn integrand(p: ptr<function, IntegrandPoint>) -> vec3<f32>
//! ```
//!
//! where `IntegrandPoint` (declared in `wgsl/shared/integrand_point.wgsl`)
//! holds `film: vec2<f32>` and `u: array<f32, MAX_U_DIMS>`, `u[k]` being
//! dimension k + 2. Its resources live in bind group 1; group 0 belongs to
//! the integrator. An integrand knows nothing of how its points were chosen,
//! and every integrator can drive every integrand.
//!
//! | module                  | scene-file `type`    | d            | dimensions 2.. |
//! |-------------------------|----------------------|--------------|----------------|
//! | [`area_light`]          | `area_light`         | 4            | emitter point (2) |
//! | [`depth_of_field`]      | `depth_of_field`     | 4            | lens (2) |
//! | [`motion_blur`]         | `motion_blur`        | 3            | shutter time (1) |
//! | [`path`]                | `path`               | 2+2m / 4+4m  | per vertex: [area NEE (2)], bounce (2) |
//! | [`ambient_occlusion`]   | `ambient_occlusion`  | 4            | hemisphere direction (2) |
//! | [`many_light`]          | `many_light`         | 3 / 5        | light selection (1), [point on an emissive triangle (2)] |
//!
//! The scene integrands share `wgsl/shared/shading.wgsl` (surface records,
//! ray offsets, delta-light and area-light direct lighting).

pub mod ambient_occlusion;
pub mod area_light;
pub mod depth_of_field;
pub mod many_light;
pub mod motion_blur;
pub mod path;
pub mod spec;

use crate::accel::GpuScene;
use crate::film::Film;
use crate::gpu::shader::Wgsl;
use crate::wgsl_file;

pub use ambient_occlusion::AmbientOcclusion;
pub use area_light::AreaLight;
pub use depth_of_field::DepthOfField;
pub use many_light::ManyLight;
pub use motion_blur::MotionBlur;
pub use path::PathTracing;
pub use spec::{IntegrandSpec, ManyLightSpec};

/// Most dimensions (film included) any integrand may use.
pub const MAX_DIMS: u32 = 16;

/// The WGSL declaration of `IntegrandPoint` and `MAX_U_DIMS`.
pub fn point_wgsl() -> Wgsl {
    Wgsl::new()
        .constant("MAX_DIMS", MAX_DIMS)
        .constant("MAX_U_DIMS", MAX_DIMS - 2)
        .part(wgsl_file!("shared/integrand_point.wgsl"))
}

/// What every scene integrand's WGSL starts from: the point, the scene
/// bindings and traversal, the warps, the camera and the shared shading.
pub fn scene_wgsl() -> Wgsl {
    point_wgsl()
        .include(&GpuScene::wgsl())
        .part(wgsl_file!("shared/sampling.wgsl"))
        .part(wgsl_file!("shared/camera.wgsl"))
        .part(wgsl_file!("shared/shading.wgsl"))
}

pub trait Integrand {
    /// Short name for reports, e.g. `"area_light"`.
    fn name(&self) -> &'static str;

    /// Total dimension count d, film included (2 < d ≤ [`MAX_DIMS`]).
    fn dims(&self) -> u32;

    /// The film the integrand is defined over (its first two dimensions).
    fn film(&self) -> Film;

    /// WGSL defining `fn integrand(p: ptr<function, IntegrandPoint>) -> vec3<f32>`
    /// and everything it needs (shared parts are de-duplicated by name).
    fn wgsl(&self) -> Wgsl;

    /// Layout of bind group 1.
    fn layout(&self) -> &wgpu::BindGroupLayout;

    /// Bind group 1.
    fn bind_group(&self) -> &wgpu::BindGroup;
}
