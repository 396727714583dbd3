//! Host mirrors of the scene bindings declared in `wgsl/shared/scene.wgsl`.
//!
//! Every struct is `#[repr(C)]`, `Pod`, with its padding spelled out so the
//! byte layout equals WGSL's (uniform layout for [`SceneUniforms`], storage
//! layout with 16-byte alignment for the arrays). The sizes are asserted at
//! compile time below and again in the tests; the WGSL side is the contract
//! the other kernels are written against, so a change here is a change
//! there.

use bytemuck::{Pod, Zeroable};

/// `SceneUniforms` (binding 0): camera frame, film, shutter and counts.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct SceneUniforms {
    pub cam_position: [f32; 3],
    pub cam_lens_radius: f32,
    /// f = normalize(look_at − position).
    pub cam_forward: [f32; 3],
    pub cam_focus_distance: f32,
    /// r = normalize(f × up).
    pub cam_right: [f32; 3],
    pub cam_tan_half_fov_y: f32,
    /// u = r × f.
    pub cam_up: [f32; 3],
    /// W / H of the render film.
    pub cam_aspect: f32,
    /// Render film width, height in pixels.
    pub film_size: [f32; 2],
    /// Scene time at shutter open, close.
    pub shutter: [f32; 2],
    pub background: [f32; 3],
    pub emitter_count: u32,
    pub light_count: u32,
    pub instance_count: u32,
    /// Index in `nodes` of the top-level CWBVH root (0; unused when
    /// `instance_count` is 0).
    pub tlas_root: u32,
    pub triangle_count: u32,
    /// Shadow rays: 0 = BVH, 1 = voxel array (`VISIBILITY_*`).
    pub visibility: u32,
    /// n of the n × n direction array (voxel visibility).
    pub voxel_directions: u32,
    /// Extra voxels skipped at each endpoint (the self-occlusion rule).
    pub voxel_skip: u32,
    /// Voxelized objects (one per instance, or 1; 0 with BVH visibility).
    pub voxel_objects: u32,
}

/// `SceneUniforms::visibility` of the BVH.
pub const VISIBILITY_BVH: u32 = 0;
/// `SceneUniforms::visibility` of the voxel array.
pub const VISIBILITY_VOXEL: u32 = 1;

/// `Material` (binding 5): Lambertian albedo, optional checker, emission,
/// sidedness.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuMaterial {
    pub albedo: [f32; 3],
    /// Checker cell size in world units; 0 = no checker.
    pub checker_scale: f32,
    pub emission: [f32; 3],
    /// 1: the back side (behind the shading normal) reflects nothing
    /// (Mitsuba's plain `diffuse`); 0: both sides reflect.
    pub one_sided: u32,
    /// Second checker colour (equals `albedo` without a checker).
    pub albedo2: [f32; 3],
    /// 1: the checker is in texture space (`to_uv0`, `to_uv1`,
    /// [`crate::scene::UvChecker`]) instead of the world-space one.
    pub checker_uv: u32,
    /// Rows of the UV checker's map (u', v') = M·(u, v, 1); `w` unused.
    pub to_uv0: [f32; 4],
    pub to_uv1: [f32; 4],
}

/// `Emitter` (binding 6): one emissive triangle of the light-selection
/// table, pmf ∝ luminance(emission) · area.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuEmitter {
    /// Global triangle index (into `triangles` / 3).
    pub prim: u32,
    /// Inclusive cdf; the last entry is exactly 1.
    pub cdf: f32,
    pub pmf: f32,
    /// World-space area (rigid motion preserves it).
    pub area: f32,
}

/// `Light::kind` of a point light.
pub const LIGHT_POINT: u32 = 0;
/// `Light::kind` of a directional light.
pub const LIGHT_DIRECTIONAL: u32 = 1;

/// `Light` (binding 7): a point or directional light.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuLight {
    /// [`LIGHT_POINT`] or [`LIGHT_DIRECTIONAL`].
    pub kind: u32,
    pub _pad0: u32,
    pub _pad1: u32,
    pub _pad2: u32,
    /// Point: position. Directional: normalized direction light travels.
    pub position: [f32; 3],
    pub _pad3: f32,
    /// Point: intensity I. Directional: irradiance E.
    pub intensity: [f32; 3],
    pub _pad4: f32,
}

/// `Instance` (binding 3): one bottom-level CWBVH placed in the world.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Pod, Zeroable)]
pub struct GpuInstance {
    /// Index in `nodes` of the BLAS root.
    pub node_root: u32,
    /// First global triangle of the BLAS (its triangles are contiguous).
    pub prim_offset: u32,
    /// First keyframe in `keyframes`.
    pub key_offset: u32,
    /// Keyframe count; 0 = static (identity transform, world-space
    /// triangles).
    pub key_count: u32,
}

/// `Keyframe` (binding 4): world = R·p + T at scene time `time`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuKeyframe {
    pub translation: [f32; 3],
    pub time: f32,
    /// Unit quaternion, xyzw.
    pub rotation: [f32; 4],
}

const _: () = {
    assert!(std::mem::size_of::<SceneUniforms>() == 128);
    assert!(std::mem::size_of::<GpuMaterial>() == 80);
    assert!(std::mem::size_of::<GpuEmitter>() == 16);
    assert!(std::mem::size_of::<GpuLight>() == 48);
    assert!(std::mem::size_of::<GpuInstance>() == 16);
    assert!(std::mem::size_of::<GpuKeyframe>() == 32);
    assert!(std::mem::size_of::<obvhs::cwbvh::node::CwBvhNode>() == 80);
};
