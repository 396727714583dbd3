//! The iteration loop on the GPU: `wgsl/mdas/plan.wgsl`.
//!
//! After each iteration's count → scan → apply, one invocation of `plan`
//! advances the state kept in the counters buffer (samples, leaves,
//! iteration, the range to evaluate, the stop flag; `counter` in
//! [`super`]) and writes the indirect arguments of the next evaluate
//! dispatch and of the next iteration's leaf dispatches, zero once the
//! render is done. The host therefore records many iterations in one
//! submission and reads the counters once per submission, never inside
//! the loop; iterations recorded past the end dispatch nothing. `prime`
//! writes the first arguments from the state the host set up.

use super::Kernels;
use crate::gpu::shader::Wgsl;
use crate::wgsl_file;

/// Byte offset in the arguments buffer of the leaf dispatches (error,
/// count, apply): `ARGS_LEAVES` in the WGSL.
pub const ARGS_LEAVES: u64 = 0;
/// Byte offset of the evaluate dispatch: `ARGS_EVALUATE` (word 3).
pub const ARGS_EVALUATE: u64 = 12;

pub fn source(base: &Wgsl) -> Wgsl {
    base.clone().part(wgsl_file!("mdas/plan.wgsl"))
}

/// `plan`, after apply in the adaptive pass.
pub fn record(pass: &mut wgpu::ComputePass<'_>, k: &Kernels) {
    pass.set_pipeline(&k.pipes.plan);
    pass.set_bind_group(0, &k.group0, &[]);
    pass.set_bind_group(1, &k.args_group, &[]);
    pass.dispatch_workgroups(1, 1, 1);
}

/// `prime`, once before the initial samples are evaluated.
pub fn record_prime(pass: &mut wgpu::ComputePass<'_>, k: &Kernels) {
    pass.set_pipeline(&k.pipes.prime);
    pass.set_bind_group(0, &k.group0, &[]);
    pass.set_bind_group(1, &k.args_group, &[]);
    pass.dispatch_workgroups(1, 1, 1);
}
