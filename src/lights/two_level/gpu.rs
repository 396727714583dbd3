//! The two-level tree (`tree2`) built on the GPU every frame of a
//! sequence: the bottom levels gathered by kernels, the top level on the
//! host (real-time stochastic lightcuts §3.1; the paper builds its bottom
//! levels on the CPU, §5).
//!
//! A sequence whose light groups keep their arrangement (every emissive
//! mesh under its rigid motion, static point lights and light sets:
//! [`super::two_level::BottomLevels`]) has bottom levels of a fixed shape, and
//! [`super::two_level`]'s layout puts every node below a group's root at
//! a slot that depends only on the group sizes ([`GpuPlan`]). So per frame:
//!
//! | phase | where | work |
//! |---|---|---|
//! | `tree2.bottom` | `wgsl/lights/tree2_build.wgsl` | `leaves`: every bottom level's leaves from the frame's lights (bounds, intensity, cone); `joins`: one dispatch per height, each node from its two children (min/max, intensity sum, cone union); the groups' roots go to a small buffer |
//! | `tree2.top` | host | the roots read back (one node and one cone per group); the SAOH top level over them ([`GpuPlan::top`]); its slots, its parents and the links below each root written to the tree's buffers |
//!
//! No sort, no Morton codes: the leaf orders were sorted once, in object
//! space, when the sequence began. The nodes' bounds and intensities equal
//! the CPU's [`super::two_level::BottomLevels::tree`] bit for bit (the rules of
//! [`crate::lights::tree::gpu_build`]: `leaf_node` and a gather are exact); the cones
//! take square roots and are compared within a tolerance
//! (`tests/light_tree_gpu.rs`), and the top level is built from the
//! GPU's roots, so its cones inherit that tolerance. Groups sorted every
//! frame (orbiting light sets) and VPLs have no fixed shape: those
//! sequences build `tree2` on the CPU (they have no plan).
//!
//! Buffers: `nodes` and `cones` (`2N − 1` each, the BVH layout of
//! [`super::bvh`]) and `index` (`leaf_of_light`, then the parent of every
//! node), bound by the sampler as the CPU-built tree's would be.

use super::{GpuPlan, ROOT_BIT};
use crate::gpu::buffer::{Readback, STORAGE};
use crate::gpu::shader::{storage_entry, uniform_entry};
use crate::gpu::{Gpu, Profiler};
use crate::lights::bvh::INTERNAL_BIT;
use crate::lights::light_params::{LightParams, SamplerBuffers};
use crate::lights::tree::gpu_build::prim_wgsl;
use crate::lights::{LightCone, LightPrim, TreeNode};
use crate::wgsl_file;
use anyhow::{bail, Result};
use bytemuck::{Pod, Zeroable};

/// Invocations per workgroup of the gather kernels.
const WG: u32 = 128;

/// Profiler phases of a build, in order.
pub const PHASES: [&str; 2] = ["tree2.bottom", "tree2.top"];

/// `Tree2Params` of `tree2_build.wgsl` (public for
/// `tests/shader_interfaces.rs`, which compares the layouts).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct Tree2Params {
    pub count: u32,
    pub first: u32,
    pub zero: u32,
    pub _pad: u32,
}

/// A sequence's two-level tree, gathered on the GPU per frame.
pub struct GpuTwoLevel {
    plan: GpuPlan,
    light_count: u32,
    /// The tree's nodes (`2N − 1`).
    pub nodes: wgpu::Buffer,
    /// The nodes' cones, indexed like `nodes`.
    pub cones: wgpu::Buffer,
    /// `leaf_of_light` (N entries), then the parent of every node.
    pub index: wgpu::Buffer,
    roots: wgpu::Buffer,
    root_cones: wgpu::Buffer,
    plan_entries: wgpu::Buffer,
    /// One parameter entry per dispatch: the leaves, then each height.
    params: wgpu::Buffer,
    params_stride: u64,
    /// Entries per dispatch, in `params` order.
    counts: Vec<u32>,
    layout: wgpu::BindGroupLayout,
    leaves_pipeline: wgpu::ComputePipeline,
    joins_pipeline: wgpu::ComputePipeline,
}

impl GpuTwoLevel {
    /// The WGSL of the gather kernels.
    pub fn source() -> crate::gpu::shader::Wgsl {
        prim_wgsl()
            .constant("WG", WG)
            .constant("T2_ROOT_BIT", ROOT_BIT)
            .constant("T2_INTERNAL_BIT", INTERNAL_BIT)
            .part(wgsl_file!("lights/tree2_build.wgsl"))
    }

    /// Compiles the kernels and uploads the fixed part of the tree of
    /// `plan` ([`BottomLevels::gpu_plan`]: its gather entries,
    /// `leaf_of_light`, the parents below the roots). Fails with a clear
    /// message when the adapter cannot hold or dispatch the tree.
    pub fn new(gpu: &Gpu, plan: GpuPlan) -> Result<GpuTwoLevel> {
        let n = plan.leaf_of_light.len() as u32;
        let total = plan.node_count as u64;
        let g = plan.groups.len() as u64;
        let node_bytes = total * size_of::<TreeNode>() as u64;
        let cone_bytes = total * size_of::<LightCone>() as u64;
        gpu.check_binding_size("tree2.nodes", node_bytes)?;
        gpu.check_binding_size("tree2.cones", cone_bytes)?;
        let mut entries: Vec<[u32; 2]> = plan.leaves.clone();
        let mut counts = vec![plan.leaves.len() as u32];
        for level in &plan.joins {
            entries.extend_from_slice(level);
            counts.push(level.len() as u32);
        }
        let widest = counts.iter().copied().max().unwrap_or(0);
        let (_, gy) = gpu.dispatch_dims(widest.div_ceil(WG));
        if gy > gpu.limits.max_compute_workgroups_per_dimension {
            bail!("a two-level tree of {n} lights needs more workgroups than this adapter can dispatch");
        }
        let table: Vec<u32> = plan
            .leaf_of_light
            .iter()
            .chain(&plan.parent)
            .copied()
            .collect();
        let stride = (size_of::<Tree2Params>() as u64)
            .next_multiple_of(gpu.limits.min_uniform_buffer_offset_alignment as u64);
        let mut bytes = vec![0u8; stride as usize * counts.len()];
        let mut first = 0;
        for (i, &count) in counts.iter().enumerate() {
            let p = Tree2Params {
                count,
                first,
                zero: 0,
                _pad: 0,
            };
            first += count;
            let at = i * stride as usize;
            bytes[at..at + size_of::<Tree2Params>()].copy_from_slice(bytemuck::bytes_of(&p));
        }
        let layout = gpu.bind_group_layout("tree2.layout", &Self::layout_entries());
        let source = Self::source();
        let leaves_pipeline =
            gpu.compute_pipeline("tree2.leaves", &source, "leaves", &[&layout])?;
        let joins_pipeline = gpu.compute_pipeline("tree2.joins", &source, "joins", &[&layout])?;
        Ok(GpuTwoLevel {
            light_count: n,
            nodes: gpu.buffer_zeroed("tree2.nodes", node_bytes, STORAGE)?,
            cones: gpu.buffer_zeroed("tree2.cones", cone_bytes, STORAGE)?,
            index: gpu.buffer_from("tree2.index", &table, STORAGE)?,
            roots: gpu.buffer_zeroed("tree2.roots", g * size_of::<TreeNode>() as u64, STORAGE)?,
            root_cones: gpu.buffer_zeroed(
                "tree2.root_cones",
                g * size_of::<LightCone>() as u64,
                STORAGE,
            )?,
            plan_entries: gpu.buffer_from("tree2.plan", &entries, STORAGE)?,
            params: gpu.buffer_from::<u8>("tree2.params", &bytes, gpu.uniform_usage())?,
            params_stride: stride,
            counts,
            layout,
            leaves_pipeline,
            joins_pipeline,
            plan,
        })
    }

    /// The layout of the gather kernels: parameters, the lights, the plan
    /// (read-only), then nodes, cones, roots and root cones.
    pub fn layout_entries() -> Vec<wgpu::BindGroupLayoutEntry> {
        vec![
            uniform_entry(0),
            storage_entry(1, true),
            storage_entry(2, true),
            storage_entry(3, false),
            storage_entry(4, false),
            storage_entry(5, false),
            storage_entry(6, false),
        ]
    }

    /// The number of lights the tree is over.
    pub fn light_count(&self) -> u32 {
        self.light_count
    }

    /// The number of nodes, `2N − 1`.
    pub fn node_count(&self) -> u32 {
        self.plan.node_count
    }

    /// Binds the tree, as the kernels leave it, into the samplers'
    /// bindings for `params.count` lights (nodes, cones, index: the BVH
    /// layout).
    pub fn bind(&self, params: &mut LightParams, out: &mut SamplerBuffers) -> Result<()> {
        let n = params.count;
        if self.light_count != n {
            bail!(
                "two-level tree over {} lights for {n} lights",
                self.light_count
            );
        }
        params.node_count = self.node_count();
        out.nodes = Some(self.nodes.clone());
        out.cones = Some(self.cones.clone());
        out.index = Some(self.index.clone());
        Ok(())
    }

    /// The plan the kernels run.
    pub fn plan(&self) -> &GpuPlan {
        &self.plan
    }

    /// Rebuilds the tree over the frame's lights `prims` (an
    /// `array<LightPrim>` of [`GpuTwoLevel::light_count`] lights in the
    /// groups' id order, with `STORAGE` usage): the gather (GPU phase
    /// `tree2.bottom`), then the roots read back and the top level built
    /// and written (`tree2.top`, wall clock, read-back wait included). The
    /// tree is ready for any work submitted afterwards.
    pub fn build(&self, gpu: &Gpu, prims: &wgpu::Buffer, profiler: &mut Profiler) -> Result<()> {
        let need = self.light_count as u64 * size_of::<LightPrim>() as u64;
        if prims.size() < need {
            bail!(
                "the light buffer holds {} bytes, {} lights need {need}",
                prims.size(),
                self.light_count
            );
        }
        let group = |i: usize| {
            fn entry(b: u32, buffer: &wgpu::Buffer) -> wgpu::BindGroupEntry<'_> {
                wgpu::BindGroupEntry {
                    binding: b,
                    resource: buffer.as_entire_binding(),
                }
            }
            gpu.device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("tree2.group"),
                layout: &self.layout,
                entries: &[
                    wgpu::BindGroupEntry {
                        binding: 0,
                        resource: wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                            buffer: &self.params,
                            offset: self.params_stride * i as u64,
                            size: wgpu::BufferSize::new(size_of::<Tree2Params>() as u64),
                        }),
                    },
                    entry(1, prims),
                    entry(2, &self.plan_entries),
                    entry(3, &self.nodes),
                    entry(4, &self.cones),
                    entry(5, &self.roots),
                    entry(6, &self.root_cones),
                ],
            })
        };
        gpu.scoped("building the two-level light tree", || {
            let groups: Vec<wgpu::BindGroup> = (0..self.counts.len()).map(group).collect();
            profiler.phase(PHASES[0], |encoder, timestamps| {
                let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                    label: Some(PHASES[0]),
                    timestamp_writes: timestamps,
                });
                for (i, (&count, g)) in self.counts.iter().zip(&groups).enumerate() {
                    if count == 0 {
                        continue;
                    }
                    let pipeline = if i == 0 {
                        &self.leaves_pipeline
                    } else {
                        &self.joins_pipeline
                    };
                    let (gx, gy) = gpu.dispatch_dims(count.div_ceil(WG));
                    pass.set_pipeline(pipeline);
                    pass.set_bind_group(0, g, &[]);
                    pass.dispatch_workgroups(gx, gy, 1);
                }
            })?;
            let start = std::time::Instant::now();
            let g = self.plan.groups.len();
            let roots = Readback::<TreeNode>::new(gpu, &self.roots, g)?;
            let root_cones = Readback::<LightCone>::new(gpu, &self.root_cones, g)?;
            let mut encoder = gpu.device.create_command_encoder(&Default::default());
            roots.record(&mut encoder);
            root_cones.record(&mut encoder);
            gpu.queue.submit([encoder.finish()]);
            let (roots, root_cones) = (roots.finish(gpu)?, root_cones.finish(gpu)?);
            let top = self.plan.top(&roots, &root_cones);
            let write = |buffer: &wgpu::Buffer, at: u64, data: &[u8]| {
                gpu.queue.write_buffer(buffer, at, data);
            };
            write(&self.nodes, 0, bytemuck::cast_slice(&top.nodes));
            write(&self.cones, 0, bytemuck::cast_slice(&top.cones));
            for (at, value) in self.plan.links(&top) {
                write(&self.index, 4 * at as u64, bytemuck::bytes_of(&value));
            }
            profiler.wall_phase(PHASES[1], start.elapsed().as_secs_f64() * 1e3);
            Ok(())
        })
    }
}
