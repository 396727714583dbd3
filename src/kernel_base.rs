//! The WGSL every scene kernel starts from, below both the integrands and
//! the light samplers (the VPL tracer compiles it too): the integrand point
//! and its dimension limit, then the scene's bindings, traversal, warps,
//! camera and shared shading. [`crate::integrand`] re-exports it.

use crate::accel::GpuScene;
use crate::gpu::shader::Wgsl;
use crate::wgsl_file;

/// Loop iterations allowed for one ray's traversal in the loop bounds of an
/// evaluation (lavapipe ends an invocation's loops after 65,535 iterations in
/// all, docs/conventions.md "Known pitfalls"): a typical ray takes a few
/// hundred steps.
pub const RAY_ITERATIONS: u64 = 1_000;

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
