//! The middle pass of the reduce-then-scan allocation: `wgsl/mdas/scan.wgsl`.
//!
//! A single workgroup scans the per-workgroup totals of `adapt.wgsl`
//! `count` in place and publishes the grand totals. There is no
//! decoupled look-back (docs/conventions.md: lavapipe gives wrong answers with
//! spin-waits), and allocation does not use one atomic per workgroup
//! either: the order in which workgroups won such an atomic would decide
//! where a right child is stored, its index keys the random numbers, and
//! the image would depend on scheduling. Three dispatches (reduce, scan,
//! scan + apply) cost about as much and are deterministic.

use super::Kernels;
use crate::gpu::shader::Wgsl;
use crate::wgsl_file;

pub fn source(base: &Wgsl) -> Wgsl {
    base.clone().part(wgsl_file!("mdas/scan.wgsl"))
}

pub fn record(pass: &mut wgpu::ComputePass<'_>, k: &Kernels) {
    pass.set_pipeline(&k.pipes.scan);
    pass.set_bind_group(0, &k.group0, &[]);
    pass.dispatch_workgroups(1, 1, 1);
}
