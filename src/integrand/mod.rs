//! The integrand contract.
//!
//! An integrand is a function f: [0, W) × [0, H) × [0, 1)^(d−2) → RGB,
//! written in WGSL, whose integral over a pixel's footprint (divided by the
//! footprint's area) is the pixel value (docs/conventions.md "Pixel value": a
//! pixel's value is the mean radiance over its footprint). Dimensions 0 and 1
//! are the film point in raster units; dimensions 2.. are the integrand's own
//! (lens, time, light, bounce, …), documented by each integrand in a stable
//! order.
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

use crate::film::Film;
use crate::gpu::shader::Wgsl;

pub use ambient_occlusion::AmbientOcclusion;
pub use area_light::AreaLight;
pub use depth_of_field::DepthOfField;
pub use many_light::ManyLight;
pub use motion_blur::MotionBlur;
pub use path::PathTracing;
pub use spec::{IntegrandSpec, ManyLightSpec, DEFAULT_FRAME_DURATION};

pub use crate::kernel_base::{point_wgsl, scene_wgsl, MAX_DIMS};

/// A function over the film and the unit hypercube that integrators render
/// (module docs): its WGSL, its dimension count and film, and its own GPU
/// resources in bind group 1, if it has any.
///
/// An integrand with no buffers of its own is a few lines. This one is
/// 0.25 on the left half of a 4×2 film and 0.75 on the right, with one
/// dimension of its own it ignores; Halton renders it exactly:
///
/// ```
/// use mdas::film::Film;
/// use mdas::gpu::{shader::Wgsl, Gpu};
/// use mdas::integrand::{point_wgsl, Integrand};
/// use mdas::integrator::{Halton, Integrator};
///
/// struct Halves(Film);
///
/// impl Integrand for Halves {
///     fn name(&self) -> &'static str {
///         "halves"
///     }
///     fn dims(&self) -> u32 {
///         3
///     }
///     fn film(&self) -> Film {
///         self.0
///     }
///     fn wgsl(&self) -> Wgsl {
///         // `IntegrandPoint` comes from `point_wgsl`.
///         point_wgsl().part(("halves.wgsl", "
///             fn integrand(p: ptr<function, IntegrandPoint>) -> vec3<f32> {
///                 return vec3<f32>(select(0.25, 0.75, (*p).film.x >= 2.0));
///             }"))
///     }
/// }
///
/// # fn main() -> anyhow::Result<()> {
/// let gpu = Gpu::shared()?;
/// let halves = Halves(Film { width: 4, height: 2 });
/// let render = Halton::new(4, 0).render(gpu, &halves)?;
/// assert_eq!(render.image[0], [0.25; 3]);
/// assert_eq!(render.image[7], [0.75; 3]);
/// # Ok(())
/// }
/// ```
///
/// `examples/custom_integrand.rs` goes further: a moving edge with a closed
/// form, compared with MDAS and Halton at equal time.
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

    /// An upper bound on the shader loop iterations one evaluation runs, for
    /// integrators that evaluate several samples per invocation (lavapipe
    /// silently ends an invocation's loops after 65,535 iterations in all,
    /// docs/conventions.md "Known pitfalls"); 0, the default: a few rays'
    /// worth, small enough for any integrator.
    fn loop_iterations(&self) -> u32 {
        0
    }

    /// Layout of bind group 1, which holds the integrand's own resources
    /// (scene, lights); `None` (the default) when it has none.
    fn layout(&self) -> Option<&wgpu::BindGroupLayout> {
        None
    }

    /// Bind group 1 (with the layout of [`Integrand::layout`]).
    fn bind_group(&self) -> Option<&wgpu::BindGroup> {
        None
    }
}

/// The bind-group layouts of a kernel that calls `integrand`: the
/// integrator's group 0, then the integrand's group 1 if it has one.
pub fn kernel_layouts<'a>(
    group0: &'a wgpu::BindGroupLayout,
    integrand: &'a dyn Integrand,
) -> Vec<&'a wgpu::BindGroupLayout> {
    std::iter::once(group0).chain(integrand.layout()).collect()
}

/// Sets the integrand's bind group 1, if it has one, on `pass`.
pub fn bind_integrand(pass: &mut wgpu::ComputePass<'_>, integrand: &dyn Integrand) {
    if let Some(group) = integrand.bind_group() {
        pass.set_bind_group(1, group, &[]);
    }
}
