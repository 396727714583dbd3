//! The integrator contract and what a render returns.
//!
//! An integrator chooses points of an integrand's domain, evaluates the
//! integrand there with GPU kernels and reconstructs pixel values — the
//! mean of the integrand over each pixel's footprint (DESIGN.md). It knows
//! nothing of scenes. Implementations: [`Halton`] (quasi-Monte Carlo
//! baseline, randomly shifted) and [`Mdas`] (multidimensional adaptive
//! sampling, `mdas/`).

pub mod halton;
pub mod mdas;

use crate::film::Film;
use crate::gpu::profiler::{Clock, PhaseTimes};
use crate::gpu::Gpu;
use crate::integrand::Integrand;
use anyhow::Result;

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
/// integrand; [`crate::app::prepare`] shows both shipped ones on a scene
/// and the [`Integrand`] trait a custom integrand.
pub trait Integrator {
    /// Short name for reports, e.g. `"halton"`.
    fn name(&self) -> &'static str;

    /// Renders the integrand's film.
    fn render(&mut self, gpu: &Gpu, integrand: &dyn Integrand) -> Result<Render>;
}
