//! Initial sampling on the Morton grid (paper §4.1): `wgsl/mdas/initial.wgsl`.
//!
//! One invocation per cell: the Morton code is the cell (and leaf) index
//! and is decoded in the kernel, so nothing is sorted. The cell's l samples
//! are Latin-hypercube stratified inside it, the offset inside their
//! strata shared by the cell and following a randomly shifted Kronecker
//! sequence over the cell index (`initial.wgsl`).

use super::{gpu_params::Grid, Kernels};
use crate::gpu::shader::Wgsl;
use crate::wgsl_file;

pub fn source(base: &Wgsl) -> Wgsl {
    base.clone()
        .part(("mdas/lattice.wgsl (generated)", lattice_wgsl()))
        .part(wgsl_file!("mdas/initial.wgsl"))
}

/// The first sixteen primes: axis a's lattice step is the fractional part
/// of √p_a ([`LATTICE_STEPS`]).
const PRIMES: [u32; 16] = [2, 3, 5, 7, 11, 13, 17, 19, 23, 29, 31, 37, 41, 43, 47, 53];

/// Per axis, frac(√p_a) in 0.32 fixed point: the steps of the Kronecker
/// sequence {c·α_a + s_a} over the cell index c that places each cell's
/// strata (`initial.wgsl`). The √ of distinct primes are linearly
/// independent over the rationals, so the axes' sequences are too.
pub fn lattice_steps() -> [u32; 16] {
    PRIMES.map(|p| {
        let f = f64::from(p).sqrt().fract();
        (f * 4294967296.0) as u32
    })
}

/// `LATTICE_STEPS`, the WGSL array of [`lattice_steps`].
fn lattice_wgsl() -> String {
    let steps: Vec<String> = lattice_steps().iter().map(|s| format!("{s}u")).collect();
    format!(
        "const LATTICE_STEPS = array<u32, 16>({});\n",
        steps.join(", ")
    )
}

pub fn record(pass: &mut wgpu::ComputePass<'_>, k: &Kernels, grid: Grid) {
    pass.set_pipeline(&k.pipes.initial);
    pass.set_bind_group(0, &k.group0, &[]);
    pass.dispatch_workgroups(grid.x, grid.y, 1);
}
