//! The integrator contract and what a render returns.
//!
//! An integrator chooses points of an integrand's domain, evaluates the
//! integrand there with GPU kernels and reconstructs pixel values — the
//! mean of the integrand over each pixel's footprint (docs/conventions.md). It knows
//! nothing of scenes. Implementations: [`Halton`] (quasi-Monte Carlo
//! baseline, randomly shifted), [`Mdas`] (multidimensional adaptive
//! sampling, `mdas/`) and [`AdaptiveHalton`] (per-pixel adaptive Halton
//! with Blender Cycles' rule, `adaptive.rs`).

pub mod adaptive;
pub mod halton;
pub mod mdas;

use crate::film::Film;
use crate::gpu::profiler::{Clock, PhaseTimes};
use crate::gpu::Gpu;
use crate::integrand::Integrand;
use anyhow::Result;

pub use adaptive::{AdaptiveHalton, AdaptiveParams};
pub use halton::Halton;
pub use mdas::Mdas;

/// The result of one render.
#[derive(Clone, Debug)]
pub struct Render {
    pub film: Film,
    /// Linear RGB pixel values, row-major, top row first. A pixel none of
    /// whose samples was finite is NaN.
    pub image: Vec<[f32; 3]>,
    /// Integrand evaluations performed (finite or not).
    pub samples: u64,
    /// Evaluations that returned NaN or ±Inf; they are excluded from the
    /// estimate and reported here.
    pub nonfinite: u64,
    /// GPU time per phase, milliseconds.
    pub times: PhaseTimes,
    /// Whether `times` come from GPU timestamps or the wall clock.
    pub clock: Clock,
    /// Peak GPU memory the integrator allocated for this render (bytes),
    /// excluding the scene.
    pub gpu_bytes: u64,
}

impl Render {
    pub fn nonfinite_pixels(&self) -> usize {
        self.image
            .iter()
            .filter(|p| p.iter().any(|c| !c.is_finite()))
            .count()
    }
}

/// Renders any [`Integrand`]: chooses its points, evaluates it in GPU
/// kernels and reconstructs the pixel means. Every integrator drives every
/// integrand, so code that compares them takes `&mut dyn Integrator`;
/// [`crate::session::prepare()`] sets one up on a scene file and the
/// [`Integrand`] trait shows a custom integrand.
///
/// Both shipped integrators on f(x, y, u) = 2u, whose integral over every
/// pixel is 1, at 8 samples per pixel on a 16×16 film:
///
/// ```
/// use mdas::film::Film;
/// use mdas::gpu::{shader::Wgsl, Gpu};
/// use mdas::integrand::{point_wgsl, Integrand};
/// use mdas::integrator::{mdas::MdasParams, Halton, Integrator, Mdas};
///
/// struct Ramp(Film);
///
/// impl Integrand for Ramp {
///     fn name(&self) -> &'static str { "ramp" }
///     fn dims(&self) -> u32 { 3 }
///     fn film(&self) -> Film { self.0 }
///     fn wgsl(&self) -> Wgsl {
///         point_wgsl().part(("ramp.wgsl", "
///             fn integrand(p: ptr<function, IntegrandPoint>) -> vec3<f32> {
///                 return vec3<f32>(2.0 * (*p).u[0]);
///             }"))
///     }
/// }
///
/// # fn main() -> anyhow::Result<()> {
/// let gpu = Gpu::shared()?;
/// let ramp = Ramp(Film { width: 16, height: 16 });
/// let mdas = MdasParams { spp: 8.0, ..MdasParams::for_film(ramp.film()) };
/// let mut integrators: Vec<Box<dyn Integrator>> =
///     vec![Box::new(Halton::new(8, 0)), Box::new(Mdas::new(mdas)?)];
/// for integrator in &mut integrators {
///     let render = integrator.render(gpu, &ramp)?;
///     assert_eq!(render.samples, 8 * 256);
///     // One sample of 2u has standard deviation 2/√12 ≈ 0.58, so the
///     // mean of 2048 independent ones 0.013 (stratified, less): 0.05 is
///     // beyond 3.8σ for either integrator.
///     let mean = render.image.iter().map(|p| p[0] as f64).sum::<f64>() / 256.0;
///     assert!((mean - 1.0).abs() < 0.05, "{}: {mean}", integrator.name());
/// }
/// # Ok(())
/// # }
/// ```
pub trait Integrator {
    /// Short name for reports, e.g. `"halton"`.
    fn name(&self) -> &'static str;

    /// Renders the integrand's film.
    fn render(&mut self, gpu: &Gpu, integrand: &dyn Integrand) -> Result<Render>;
}
