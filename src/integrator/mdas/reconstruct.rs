//! Reconstruction by splatting (paper eq. 7, §4.3): `wgsl/mdas/reconstruct.wgsl`.
//! With [`super::Reconstruction::Pixel`] a leaf splats, into each pixel
//! p, (Σ_{s in p} f_s + κ·f̄)/(n_p + κ) in place of its mean f̄; the CPU
//! oracle of both rules is [`super::debug::Snapshot::reconstruct`].
//!
//! ## Precision and determinism
//!
//! Each term w·f̄ is formed in f32 (f̄ is a mean of ≤ 15 finite samples, or
//! the per-pixel blend, a convex combination of them; w
//! the product of two overlap lengths and ≤ 14 extents: relative error a
//! few 2⁻²⁴, the same on every run) and added to a 64-bit fixed-point sum
//! with an exact integer atomic add (32-bit add plus carry). Integer
//! addition is associative, so the sum is the same for every order of the
//! atomics: the image is a function of the leaves alone. The colour scale
//! is 2^(60 − ⌈log2 max|f|⌉): a pixel's |Σ w f̄| ≤ max|f|·Σw ≈ max|f| stays
//! below 2^61 of the 2^63 range (the exponent is computed on the GPU,
//! `fixed_scale` in `wgsl/mdas/stats.wgsl`, and read back with the state
//! for [`resolve`]), and each term loses at most one unit of
//! 2^−60·max|f| to truncation. With n terms per pixel the fixed-point error
//! is below n·2⁻⁶⁰·max|f|: for values spanning 1e-6…1e6 (max|f| = 1e6), a
//! pixel of mean 1e-6 is still exact to ~1e-18·n absolute, far below f32
//! resolution. Weights use the scale 2^60 (Σw ≤ 1 per pixel). The host turns
//! the 64-bit integers into f64 and divides colour by weight.
//!
//! Limits: fixed_exp is clamped to ≤ 128 (WGSL `ldexp` range), so integrands
//! whose largest |f| is below 2^−68 lose relative precision.

use super::{gpu_params::Grid, Kernels};
use crate::gpu::shader::Wgsl;
use crate::wgsl_file;

pub fn source(base: &Wgsl) -> Wgsl {
    base.clone().part(wgsl_file!("mdas/reconstruct.wgsl"))
}

pub fn record(pass: &mut wgpu::ComputePass<'_>, k: &Kernels, grid: Grid) {
    pass.set_pipeline(&k.pipes.reconstruct);
    pass.set_bind_group(0, &k.group0, &[]);
    pass.dispatch_workgroups(grid.x, grid.y, 1);
}

/// Pixel values from the 8 words per pixel (3 colours + weight, lo/hi).
pub fn resolve(words: &[u32], fixed_exp: i32) -> Vec<[f32; 3]> {
    let fixed = |lo: u32, hi: u32| (((hi as u64) << 32) | lo as u64) as i64 as f64;
    let colour_scale = (-fixed_exp as f64).exp2();
    let weight_scale = (-60f64).exp2();
    words
        .chunks_exact(8)
        .map(|w| {
            let weight = fixed(w[6], w[7]) * weight_scale;
            if weight > 0.0 {
                std::array::from_fn(|c| {
                    (fixed(w[2 * c], w[2 * c + 1]) * colour_scale / weight) as f32
                })
            } else {
                [f32::NAN; 3]
            }
        })
        .collect()
}
