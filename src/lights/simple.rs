//! The simple pickers: `uniform` ([`UniformSampler`], the "random
//! sampling" baseline of real-time stochastic lightcuts §4) and `power`
//! ([`alias::PowerSampler`], an alias table over the lights' intensity as
//! pbrt-v4's `PowerLightSampler`), and their GPU upload ([`gpu`]). The
//! WGSL is the `light_params.kind` branches of `wgsl/lights/sample.wgsl`
//! that read `light_alias`.

pub mod alias;
pub mod gpu;

use super::importance::Shading;
use super::sampler::{LightSample, LightSampler};

/// Every light with probability `1/N`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct UniformSampler {
    pub count: u32,
}

impl LightSampler for UniformSampler {
    fn sample(&self, _s: &Shading, u: f32) -> Option<LightSample> {
        if self.count == 0 {
            return None;
        }
        let light = ((u * self.count as f32).floor() as u32).min(self.count - 1);
        Some(LightSample {
            light,
            pmf: 1.0 / self.count as f64,
        })
    }

    fn pmf(&self, _s: &Shading, light: u32) -> f64 {
        if light < self.count {
            1.0 / self.count as f64
        } else {
            0.0
        }
    }
}
