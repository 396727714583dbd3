//! Batch ray tracing kernel (`wgsl/trace.wgsl`), for tests and benchmarks.
//!
//! [`TraceKernel::run`] uploads rays, traces each with both queries of
//! `shared/bvh.wgsl` (closest hit and any hit) and reads back one
//! [`HitRecord`] per ray. [`TraceKernel::dispatch`] works on buffers that
//! are already on the device and runs one query ([`TraceMode`]), which is
//! what the benchmarks time. Large batches are split so that each ray and
//! hit buffer fits one storage binding, and each dispatch uses a 2D grid
//! ([`Gpu::dispatch_dims`]) when the ray count exceeds the per-dimension
//! workgroup limit.

use anyhow::Result;
use bytemuck::{Pod, Zeroable};

use super::GpuScene;
use crate::film::Film;
use crate::gpu::buffer::STORAGE;
use crate::gpu::shader::{bind_buffers, storage_entry, uniform_entry, Wgsl};
use crate::gpu::Gpu;

/// One pinhole ray through each pixel centre of `film`, row by row from the
/// top (docs/conventions.md "Primary ray"), at scene time 0, t_max infinite:
/// the shading points of the trace and visibility benchmarks.
pub fn pinhole_rays(camera: &crate::scene::Camera, film: Film) -> Vec<Ray> {
    let f = (camera.look_at - camera.position).normalize();
    let r = f.cross(camera.up).normalize();
    let u = r.cross(f);
    let tan = camera.tan_half_fov_y();
    let aspect = film.width as f32 / film.height as f32;
    let mut rays = Vec::with_capacity((film.width * film.height) as usize);
    for j in 0..film.height {
        for i in 0..film.width {
            let x = 2.0 * (i as f32 + 0.5) / film.width as f32 - 1.0;
            let y = 1.0 - 2.0 * (j as f32 + 0.5) / film.height as f32;
            let dir = (f + x * tan * aspect * r + y * tan * u).normalize();
            rays.push(Ray {
                origin: camera.position.into(),
                t_max: f32::INFINITY,
                dir: dir.into(),
                time: 0.0,
            });
        }
    }
    rays
}

/// `prim` of a miss.
pub const MISS: u32 = u32::MAX;

/// Invocations per workgroup of the trace kernels.
pub const TRACE_WORKGROUP_SIZE: u32 = 64;

/// A ray: origin, t_max, direction (need not be normalized; t is in units
/// of |dir|) and scene time.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct Ray {
    pub origin: [f32; 3],
    pub t_max: f32,
    pub dir: [f32; 3],
    /// Scene time (not the [0, 1) sample time).
    pub time: f32,
}

/// Result of tracing one ray.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct HitRecord {
    /// Closest hit distance; `t_max` on a miss.
    pub t: f32,
    /// Global triangle index; [`MISS`] on a miss.
    pub prim: u32,
    /// Barycentrics of v1 and v2.
    pub bary: [f32; 2],
    /// 1 when the any-hit query found something in (t_min, t_max).
    pub any_hit: u32,
    /// Traversal loop iterations of the closest-hit query.
    pub steps_closest: u32,
    /// Traversal loop iterations of the any-hit query.
    pub steps_any: u32,
    pub _pad: u32,
}

impl HitRecord {
    pub fn is_hit(&self) -> bool {
        self.prim != MISS
    }
}

/// Which queries a dispatch runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TraceMode {
    /// Closest hit and any hit (all fields of [`HitRecord`]).
    Both,
    /// Closest hit only (`any_hit` = whether it hit, `steps_any` = 0).
    Closest,
    /// Any hit only (`t` = t_max, `prim` = MISS, `steps_closest` = 0).
    Any,
    /// The voxel visibility query instead of the BVH (`any_hit` = occluded;
    /// the scene must have been uploaded with [`super::Visibility::Voxel`]).
    Voxel,
}

/// `TraceParams` in `wgsl/trace.wgsl` (public for
/// `tests/shader_interfaces.rs`, which compares the two layouts).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct TraceParams {
    pub ray_count: u32,
    /// Invocations per grid row: the linear index is x + y · row_stride.
    pub row_stride: u32,
    /// 1: binding 3 holds two normals per ray (voxel queries).
    pub normals: u32,
    pub _pad: u32,
}

pub struct TraceKernel {
    layout: wgpu::BindGroupLayout,
    both: wgpu::ComputePipeline,
    closest: wgpu::ComputePipeline,
    any: wgpu::ComputePipeline,
    voxel: wgpu::ComputePipeline,
}

impl TraceKernel {
    /// Group 0 of the trace kernels: parameters, rays (read-only), hits,
    /// and the rays' surface normals (voxel queries; two per ray).
    /// Group 1 is the scene's ([`GpuScene::layout_entries`]).
    pub fn layout_entries() -> Vec<wgpu::BindGroupLayoutEntry> {
        vec![
            uniform_entry(0),
            storage_entry(1, true),
            storage_entry(2, false),
            storage_entry(3, true),
        ]
    }

    /// The WGSL of the three trace entry points.
    pub fn source() -> Wgsl {
        Wgsl::new()
            .constant("TRACE_WORKGROUP_SIZE", TRACE_WORKGROUP_SIZE)
            .include(&GpuScene::wgsl())
            .part(crate::wgsl_file!("trace.wgsl"))
    }

    pub fn new(gpu: &Gpu, scene: &GpuScene) -> Result<TraceKernel> {
        let layout = gpu.bind_group_layout("mdas.trace", &Self::layout_entries());
        let source = Self::source();
        let layouts = [&layout, &scene.layout];
        Ok(TraceKernel {
            both: gpu.compute_pipeline("mdas.trace.both", &source, "trace_both", &layouts)?,
            closest: gpu.compute_pipeline(
                "mdas.trace.closest",
                &source,
                "trace_closest_only",
                &layouts,
            )?,
            any: gpu.compute_pipeline("mdas.trace.any", &source, "trace_any_only", &layouts)?,
            voxel: gpu.compute_pipeline(
                "mdas.trace.voxel",
                &source,
                "trace_voxel_only",
                &layouts,
            )?,
            layout,
        })
    }

    /// Most rays per dispatch: the ray and hit buffers must each fit one
    /// storage binding.
    pub fn max_rays_per_dispatch(gpu: &Gpu) -> usize {
        let per_ray = std::mem::size_of::<Ray>().max(std::mem::size_of::<HitRecord>()) as u64;
        (gpu.max_binding_bytes() / per_ray).min(u32::MAX as u64) as usize
    }

    /// Traces `rays` with both queries and returns one record per ray.
    pub fn run(&self, gpu: &Gpu, scene: &GpuScene, rays: &[Ray]) -> Result<Vec<HitRecord>> {
        self.run_mode(gpu, scene, rays, TraceMode::Both)
    }

    /// Traces `rays` with the queries of `mode`, one record per ray.
    pub fn run_mode(
        &self,
        gpu: &Gpu,
        scene: &GpuScene,
        rays: &[Ray],
        mode: TraceMode,
    ) -> Result<Vec<HitRecord>> {
        self.run_with_normals(gpu, scene, rays, None, mode)
    }

    /// [`TraceKernel::run_mode`] with, for voxel queries, the normals of
    /// the surfaces each ray starts and ends on: `normals[2i]`,
    /// `normals[2i + 1]` (xyz; zero where there is none).
    pub fn run_with_normals(
        &self,
        gpu: &Gpu,
        scene: &GpuScene,
        rays: &[Ray],
        normals: Option<&[[f32; 4]]>,
        mode: TraceMode,
    ) -> Result<Vec<HitRecord>> {
        if mode == TraceMode::Voxel && !scene.visibility.is_voxel() {
            anyhow::bail!("voxel queries need a scene uploaded with voxel visibility");
        }
        if let Some(n) = normals {
            anyhow::ensure!(n.len() == 2 * rays.len(), "two normals per ray");
        }
        let mut out = Vec::with_capacity(rays.len());
        let per = Self::max_rays_per_dispatch(gpu).max(1);
        for (k, batch) in rays.chunks(per).enumerate() {
            let hits = gpu.scoped("tracing rays", || {
                let ray_buffer = gpu.buffer_from("mdas.trace.rays", batch, STORAGE)?;
                let normal_buffer = normals
                    .map(|n| {
                        let n = &n[2 * k * per..2 * (k * per + batch.len())];
                        gpu.buffer_from("mdas.trace.normals", n, STORAGE)
                    })
                    .transpose()?;
                let hit_buffer = gpu.buffer_zeroed(
                    "mdas.trace.hits",
                    (batch.len() * std::mem::size_of::<HitRecord>()) as u64,
                    STORAGE,
                )?;
                self.dispatch_with_normals(
                    gpu,
                    scene,
                    &ray_buffer,
                    normal_buffer.as_ref(),
                    &hit_buffer,
                    batch.len() as u32,
                    mode,
                )?;
                gpu.read_buffer::<HitRecord>(&hit_buffer, batch.len())
            })?;
            out.extend(hits);
        }
        Ok(out)
    }

    /// Records and submits one dispatch over `count` rays already in
    /// `rays` (an array of [`Ray`]), writing [`HitRecord`]s to `hits`.
    /// Does not wait; follow with [`Gpu::wait`] to time it.
    pub fn dispatch(
        &self,
        gpu: &Gpu,
        scene: &GpuScene,
        rays: &wgpu::Buffer,
        hits: &wgpu::Buffer,
        count: u32,
        mode: TraceMode,
    ) -> Result<()> {
        self.dispatch_with_normals(gpu, scene, rays, None, hits, count, mode)
    }

    /// [`TraceKernel::dispatch`] with the rays' surface normals (two per
    /// ray, see [`TraceKernel::run_with_normals`]).
    #[allow(clippy::too_many_arguments)]
    pub fn dispatch_with_normals(
        &self,
        gpu: &Gpu,
        scene: &GpuScene,
        rays: &wgpu::Buffer,
        normals: Option<&wgpu::Buffer>,
        hits: &wgpu::Buffer,
        count: u32,
        mode: TraceMode,
    ) -> Result<()> {
        let mut encoder = gpu
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("mdas.trace"),
            });
        self.encode_with_normals(
            gpu,
            &mut encoder,
            scene,
            rays,
            normals,
            hits,
            count,
            mode,
            None,
        );
        gpu.queue.submit([encoder.finish()]);
        Ok(())
    }

    /// Records one dispatch into `encoder` (for callers that time passes
    /// with a [`crate::gpu::Profiler`]).
    #[allow(clippy::too_many_arguments)]
    pub fn encode(
        &self,
        gpu: &Gpu,
        encoder: &mut wgpu::CommandEncoder,
        scene: &GpuScene,
        rays: &wgpu::Buffer,
        hits: &wgpu::Buffer,
        count: u32,
        mode: TraceMode,
        timestamps: Option<wgpu::ComputePassTimestampWrites<'_>>,
    ) {
        self.encode_with_normals(
            gpu, encoder, scene, rays, None, hits, count, mode, timestamps,
        );
    }

    #[allow(clippy::too_many_arguments)]
    fn encode_with_normals(
        &self,
        gpu: &Gpu,
        encoder: &mut wgpu::CommandEncoder,
        scene: &GpuScene,
        rays: &wgpu::Buffer,
        normals: Option<&wgpu::Buffer>,
        hits: &wgpu::Buffer,
        count: u32,
        mode: TraceMode,
        timestamps: Option<wgpu::ComputePassTimestampWrites<'_>>,
    ) {
        let groups = count.div_ceil(TRACE_WORKGROUP_SIZE);
        let (nx, ny) = gpu.dispatch_dims(groups);
        let params = TraceParams {
            ray_count: count,
            row_stride: nx * TRACE_WORKGROUP_SIZE,
            normals: u32::from(normals.is_some()),
            _pad: 0,
        };
        let params = gpu.uniform("mdas.trace.params", &params);
        let placeholder;
        let normals = match normals {
            Some(n) => n,
            None => {
                placeholder = gpu.device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some("mdas.trace.normals (none)"),
                    size: 16,
                    usage: wgpu::BufferUsages::STORAGE,
                    mapped_at_creation: false,
                });
                &placeholder
            }
        };
        let bind_group = bind_buffers(
            gpu,
            "mdas.trace",
            &self.layout,
            &[&params, rays, hits, normals],
        );
        let pipeline = match mode {
            TraceMode::Both => &self.both,
            TraceMode::Closest => &self.closest,
            TraceMode::Any => &self.any,
            TraceMode::Voxel => &self.voxel,
        };
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("mdas.trace"),
            timestamp_writes: timestamps,
        });
        pass.set_pipeline(pipeline);
        pass.set_bind_group(0, &bind_group, &[]);
        pass.set_bind_group(1, &scene.bind_group, &[]);
        if count > 0 {
            pass.dispatch_workgroups(nx, ny, 1);
        }
    }
}
