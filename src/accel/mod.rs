//! Ray tracing acceleration: the scene on the GPU and ray queries.
//!
//! A [`Scene`](crate::scene::Scene) becomes a [`GpuScene`]: a two-level
//! compressed wide BVH (Ylitie, Karras & Laine 2017) built with obvhs
//! ([`build`]), a flat triangle array, instances with rigid keyframe motion
//! ([`crate::scene::motion`]), materials, the emissive-triangle selection table and the
//! analytic lights, bound at `@group(1)` as `wgsl/shared/scene.wgsl`
//! declares. Kernels include [`GpuScene::wgsl`] (scene.wgsl + bvh.wgsl) and
//! call `trace_closest(origin, dir, t_max, time) -> Hit` and
//! `trace_any(origin, dir, t_max, time) -> bool`. Shadow rays can instead
//! be answered approximately in constant time by the voxel array of
//! [`voxel`] ([`Visibility`]; `voxel_occluded` in `shared/voxel.wgsl`).
//!
//! | module         | what                                                      |
//! |----------------|-----------------------------------------------------------|
//! | [`build`]      | obvhs BLAS/TLAS builds and the flat node/triangle layout  |
//! | [`layout`]     | `#[repr(C)]` mirrors of the WGSL scene structs            |
//! | [`gpu_scene`]  | upload, bind group, camera frame, emitter table           |
//! | [`cpu`]        | the CPU oracle: same triangle test, brute force           |
//! | [`trace`]      | batch trace kernel (`wgsl/trace.wgsl`) for tests/benches  |
//! | [`voxel`]      | voxel visibility: parameters, layout, CPU oracle          |
//! | [`gpu_voxel`]  | the voxel array built on the device                       |
//!
//! Design in one paragraph: all static meshes are merged into one
//! world-space BLAS; each moving mesh has its own object-space BLAS; a TLAS
//! over the instances' (swept) bounds sits on top. Node indices and triangle
//! indices are global (rebased at build time), so the traversal adds no
//! offsets; the instance record only gives the BLAS root and the motion.
//! Traversal uses one fixed-size stack of [`BVH_STACK_SIZE`] entries and at
//! most [`BVH_MAX_STEPS`] loop iterations per query, which keeps every query
//! under lavapipe's 65,535-iteration cap with room for the caller.

pub mod build;
pub mod cpu;
pub mod gpu_scene;
pub mod gpu_voxel;
pub mod layout;
pub mod trace;
pub mod voxel;

pub use build::BuiltScene;
pub use gpu_scene::{emitter_table, GpuScene, SceneStats};
pub use layout::{GpuEmitter, GpuInstance, GpuKeyframe, GpuLight, GpuMaterial, SceneUniforms};
pub use trace::{HitRecord, Ray, TraceKernel, TraceMode, MISS};
pub use voxel::{Visibility, VoxelParams};

use crate::gpu::shader::Wgsl;

/// Entries of the private traversal stack (TLAS and BLAS share it). A
/// build whose depth needs more fails with an error.
pub const BVH_STACK_SIZE: u32 = 32;

/// Traversal loop iterations (node visits + triangle tests + instance
/// entries) after which one query gives up and returns what it found.
/// Typical rays need tens to a few hundred; kernels that trace several rays
/// per invocation must keep the sum of these budgets below lavapipe's
/// 65,535-iteration cap.
pub const BVH_MAX_STEPS: u32 = 4096;

impl GpuScene {
    /// The WGSL every kernel that uses the scene includes:
    /// `shared/scene.wgsl` and `shared/bvh.wgsl` with their constants.
    pub fn wgsl() -> Wgsl {
        Wgsl::new()
            .constant("BVH_STACK_SIZE", BVH_STACK_SIZE)
            .constant("BVH_MAX_STEPS", BVH_MAX_STEPS)
            .constant("BVH_T_MIN_REL_BITS", cpu::T_MIN_REL.to_bits())
            .constant("MAX_VOXEL_WORDS", voxel::MAX_RESOLUTION / voxel::WORD_BITS)
            .part(crate::wgsl_file!("shared/scene.wgsl"))
            .part(crate::wgsl_file!("shared/bvh.wgsl"))
            .part(crate::wgsl_file!("shared/voxel.wgsl"))
    }
}
