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

/// Word offset in the arguments buffer of the leaf dispatches (error,
/// count, apply) and of the evaluate dispatch, three words each: generated
/// into plan.wgsl as `ARGS_LEAVES` and `ARGS_EVALUATE`.
const LEAVES_WORD: u32 = 0;
const EVALUATE_WORD: u32 = 3;
/// The same as byte offsets, for `dispatch_workgroups_indirect`.
pub const ARGS_LEAVES: u64 = 4 * LEAVES_WORD as u64;
pub const ARGS_EVALUATE: u64 = 4 * EVALUATE_WORD as u64;
/// Size of the arguments buffer.
pub const ARGS_BYTES: u64 = ARGS_EVALUATE + 12;

pub fn source(base: &Wgsl) -> Wgsl {
    base.clone()
        .constant("ARGS_LEAVES", LEAVES_WORD)
        .constant("ARGS_EVALUATE", EVALUATE_WORD)
        .part(wgsl_file!("mdas/plan.wgsl"))
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
