//! The voxelization array built on the GPU (`wgsl/voxel_build.wgsl`;
//! rules and CPU oracle: [`super::voxel`]).
//!
//! The host computes the layout (objects, frames, sizes — refused before
//! any work when the bits exceed one storage binding) and the work list
//! (triangle × tile); one kernel then runs one invocation per (work item,
//! direction) and sets bits with `atomicOr`, so the result does not depend
//! on the order of the invocations. Dispatches are split so that no grid
//! dimension exceeds the adapter's limit.

use anyhow::Result;
use bytemuck::{Pod, Zeroable};
use std::time::Instant;

use super::build::BuiltScene;
use super::voxel::{self, VoxelLayout};
use crate::gpu::buffer::STORAGE;
use crate::gpu::shader::{bind_buffers, storage_entry, uniform_entry, Wgsl};
use crate::gpu::Gpu;

/// Invocations per workgroup of the build kernel.
const WG: u32 = 64;

/// `VoxelBuildParams` of `wgsl/voxel_build.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct VoxelBuildParams {
    pub item_count: u32,
    pub row_stride: u32,
    pub direction_offset: u32,
    pub per_instance: u32,
}

/// A built voxelization array on the device.
pub struct GpuVoxels {
    pub layout: VoxelLayout,
    /// The bits (binding 8 of the scene group).
    pub bits: wgpu::Buffer,
    /// [`voxel::VoxelObject`]s (binding 9).
    pub objects: wgpu::Buffer,
    /// [`voxel::VoxelFrame`]s (binding 10).
    pub frames: wgpu::Buffer,
    /// Work items (triangle × tile) of the build.
    pub items: u32,
    /// Wall time of the build on the device (kernel compile excluded), ms.
    pub build_ms: f64,
}

/// The build kernel's WGSL.
pub fn source() -> Wgsl {
    Wgsl::new()
        .constant("TILE", voxel::TILE)
        .part(crate::wgsl_file!("voxel_build.wgsl"))
}

/// The build kernel's group 0.
pub fn layout_entries() -> Vec<wgpu::BindGroupLayoutEntry> {
    vec![
        uniform_entry(0),
        storage_entry(1, true),
        storage_entry(2, true),
        storage_entry(3, true),
        storage_entry(4, true),
        storage_entry(5, false),
    ]
}

impl GpuVoxels {
    /// Builds the array `layout` describes for `built` (its
    /// [`VoxelLayout::new`]), whose triangles are already on the device
    /// in `triangles` (the scene's binding 2). Fails, before allocating
    /// anything, when the bits do not fit one storage binding (the message
    /// names the size and what would fit).
    pub fn build(
        gpu: &Gpu,
        built: &BuiltScene,
        triangles: &wgpu::Buffer,
        layout: VoxelLayout,
    ) -> Result<GpuVoxels> {
        layout.check_fits(gpu.max_binding_bytes())?;
        let params = layout.params;
        let items = voxel::work_items(built, &layout);
        gpu.scoped("building the voxel visibility array", || {
            let bits = gpu.buffer_zeroed("mdas.voxel.bits", layout.bytes(), STORAGE)?;
            let objects = gpu.buffer_from("mdas.voxel.objects", &layout.objects, STORAGE)?;
            let frames = gpu.buffer_from("mdas.voxel.frames", &layout.frames, STORAGE)?;
            let item_buffer = gpu.buffer_from("mdas.voxel.items", &items, STORAGE)?;
            let group_layout = gpu.bind_group_layout("mdas.voxel.build", &layout_entries());
            let pipeline =
                gpu.compute_pipeline("mdas.voxel.build", &source(), "voxelize", &[&group_layout])?;
            let count = items.len() as u32;
            let (nx, ny) = gpu.dispatch_dims(count.div_ceil(WG));
            let max_z = gpu.limits.max_compute_workgroups_per_dimension.max(1);
            let directions = params.direction_count();
            let start = Instant::now();
            let mut encoder = gpu
                .device
                .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                    label: Some("mdas.voxel.build"),
                });
            let mut offset = 0;
            while offset < directions && count > 0 {
                let z = (directions - offset).min(max_z);
                let p = VoxelBuildParams {
                    item_count: count,
                    row_stride: nx * WG,
                    direction_offset: offset,
                    per_instance: u32::from(!built.instances.is_empty()),
                };
                let uniform = gpu.uniform("mdas.voxel.build.params", &p);
                let group = bind_buffers(
                    gpu,
                    "mdas.voxel.build",
                    &group_layout,
                    &[&uniform, &item_buffer, triangles, &objects, &frames, &bits],
                );
                let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                    label: Some("mdas.voxel.build"),
                    timestamp_writes: None,
                });
                pass.set_pipeline(&pipeline);
                pass.set_bind_group(0, &group, &[]);
                pass.dispatch_workgroups(nx, ny, z);
                drop(pass);
                offset += z;
            }
            gpu.queue.submit([encoder.finish()]);
            gpu.wait()?;
            Ok(GpuVoxels {
                layout,
                bits,
                objects,
                frames,
                items: count,
                build_ms: start.elapsed().as_secs_f64() * 1e3,
            })
        })
    }

    /// Reads the bits back (tests compare them with [`voxel::build_cpu`]).
    pub fn read_bits(&self, gpu: &Gpu) -> Result<Vec<u32>> {
        gpu.read_buffer::<u32>(&self.bits, self.layout.words as usize)
    }
}
