//! mdas — multidimensional adaptive sampling and quasi-Monte Carlo
//! integrators on the GPU (wgpu + WGSL compute).
//!
//! The flow is one-directional (layers in `docs/architecture.md`): a scene
//! file is loaded by [`scene_file`] into a [`scene::Scene`], the
//! integrand's spec and the MDAS parameters; the scene is uploaded as an
//! [`accel::GpuScene`] (CWBVH + buffers); an [`integrand::Integrand`]
//! is a WGSL function f(film point, u ∈ [0,1)^d) → RGB with its bindings;
//! an [`integrator::Integrator`] drives kernels around any integrand and
//! returns a [`integrator::Render`]; [`metrics`] compare renders.

pub mod accel;
pub mod analytic;
pub mod atomic;
pub mod colormap;
pub mod compare;
pub mod film;
pub mod gpu;
pub mod image_io;
pub mod integrand;
pub mod integrator;
pub mod kernel_base;
pub mod lights;
pub mod metrics;
pub mod provenance;
pub mod rng;
pub mod scene;
pub mod scene_file;
pub mod scene_gen;
pub mod session;
pub mod viewer;

#[cfg(test)]
mod layout_tests;

/// The wgpu this crate is built on (version 30), so that a library user
/// writing an [`integrand::Integrand`] needs no separate, matching
/// dependency.
pub use wgpu;
