//! The session layer: what the CLI does, as library functions (so tests
//! and other programs can call them), between the scene file and the
//! experiments.
//!
//! - [`prepare`]: a scene prepared for one film size (the film at
//!   `--scale`, the MDAS grid scaled with it, the integrand on the GPU,
//!   integrand overrides, frame sequences);
//! - [`reference`]: high-spp Halton references and their cache;
//! - [`parts`]: references rendered in parts and merged exactly;
//! - [`outputs`]: output paths and the images written to them.

pub mod outputs;
pub mod parts;
pub mod prepare;
pub mod reference;

pub use outputs::*;
pub use prepare::*;
pub use reference::*;

#[cfg(test)]
mod tests;
