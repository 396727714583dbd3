//! The radix substitute tree of `sst` and `sst_nosub` built on the GPU
//! every frame, as the paper does (Tatzgern et al. 2020 §3.3, "we
//! construct a radix tree … using the codes", after Karras 2012), bit for
//! bit equal to the CPU oracle [`super::radix::build`]: the same nodes in
//! the same BVH layout, parents, leaf of each light, cones and
//! substitutes, in the buffers `sst`'s upload binds
//! ([`GpuRadixTree::bind`]).
//!
//! # Phases
//!
//! [`GpuRadixTree::build`] takes the frame's `array<LightPrim>` (on the
//! GPU) and records one profiler phase per step ([`PHASES`]):
//!
//! | phase | kernels | work |
//! |---|---|---|
//! | `sst_tree.bounds` | `lights/bounds.wgsl` | centroid bounds (as the perfect tree's build) |
//! | `sst_tree.classes` | `radix_build.wgsl` `normal_classes`, then `gpu/radix_sort.wgsl` | the 10-bit normal class of every light ([`super::radix::normal_class`]), ids as values, stably sorted on 10 bits |
//! | `sst_tree.morton` | `lights/morton.wgsl` `morton_codes_sorted`, then the sort | the 30-bit Morton codes gathered in that order, stably sorted: the leaves are sorted by (Morton code, class, id), the oracle's (key, id) |
//! | `sst_tree.karras` | `classes_sorted`, `karras`, `number` | the sorted classes; Karras's per-node construction; the oracle's node numbering |
//! | `sst_tree.place` | `place`, `level_args`, `bucket` | ids, parents, each light's leaf, the leaves' nodes, cones and substitutes; the internal nodes grouped by depth |
//! | `sst_tree.merge` | `merge_level`, one indirect dispatch per depth, deepest first | bounds and intensities, cones and substitutes of the internal nodes |
//!
//! # What follows Karras 2012 and what departs
//!
//! * **Keys** (paper eq. 4, [`super::radix`]): 30 Morton bits and the
//!   10-bit class make 40 bits, more than a u32 sort key; the two stable
//!   LSD sorts (class, then Morton code) give the order of a sort of the
//!   40-bit keys with the ids as tie-break. The Morton codes are those of
//!   the perfect tree's build (exact, `src/lights/morton.rs`), the classes
//!   exact as the normal code is.
//! * **Construction**: Karras's Fig. 4, one invocation per internal node
//!   `i`: the direction `d = sign(δ(i, i+1) − δ(i, i−1))`, the other end of
//!   the range by exponential then binary search, the split by binary
//!   search, with Karras's tie-break for equal keys (δ over the indices,
//!   [`super::radix::delta`]), which gives the oracle's top-down tree
//!   (`karras_per_node_ranges_match_the_top_down_tree`).
//! * **Layout** (a departure): Karras numbers internal node `i` by one end
//!   of its range and keeps leaves apart; the oracle stores the BVH layout
//!   of [`crate::lights::bvh`], numbered as its depth-first build pops the
//!   nodes (children `1 + 2k`, `2 + 2k` of the k-th internal node in
//!   preorder). `number` finds `k` for every node at once: the internal
//!   nodes before X in preorder are its ancestors and the internal nodes of
//!   the subtrees left of its path, which together hold the leaves
//!   `[0, first)`, so `k = first + (left turns on the path to X)`, counted
//!   by walking the parent links up (O(depth) per node, depth ≤ 71).
//! * **Bottom-up pass** (a departure): Karras (and Apetrei 2014) let the
//!   second child to arrive at an atomic counter compute its parent. WGSL
//!   atomics are relaxed and give no cross-workgroup visibility of the
//!   sibling's data, so, as the perfect tree's build goes level by level,
//!   this one goes depth by depth: the walk up also gives each internal
//!   node's depth, a counting pass groups the nodes by depth, and one
//!   indirect dispatch per depth (deepest first, [`LEVELS`] of them, the
//!   empty ones dispatch nothing) builds every node of that depth from its
//!   children. Nothing depends on scheduling: the only atomics are integer
//!   counts and the bucket cursors, whose order changes where a node is
//!   listed but not what is written to it.
//!
//! # Exactness
//!
//! Bounds are min/max, intensities one f32 addition per node in the
//! oracle's child order, as in the perfect tree's build (`tree/gpu_build.rs`
//! explains why those are exact). Cones and substitutes divide and take
//! square roots: `wgsl/lights/exact.wgsl` does both in integer
//! arithmetic, correctly rounded (round to nearest even, as Rust's f32 `/`
//! and `sqrt`), and follows glam's and the oracle's operations in their
//! order with every product rounded on its own (`mul_rn`), so the results
//! are the CPU's bit for bit on any driver, not only on lavapipe. Left
//! outside, as for the perfect tree: subnormal operands and quotients
//! (the native operation, which a GPU may flush to zero), NaN and infinite
//! coordinates, and the sign of a zero that a min, max or `max(cos, 0)`
//! compares with the other zero.

use super::radix::RadixTree;
use super::Substitute;
use crate::gpu::buffer::STORAGE;
use crate::gpu::profiler::PhaseTimes;
use crate::gpu::radix_sort::RadixSort;
use crate::gpu::shader::{storage_entry, uniform_entry, Wgsl};
use crate::gpu::{Gpu, Profiler};
use crate::lights::bvh::{LightBvh, INTERNAL_BIT, MAX_DEPTH};
use crate::lights::light_params::{LightParams, SamplerBuffers};
use crate::lights::tree::gpu_build::prim_wgsl;
use crate::lights::{LightCone, LightPrim, TreeNode};
use crate::wgsl_file;
use anyhow::{bail, Result};
use bytemuck::{Pod, Zeroable};

/// Invocations per workgroup.
const WG: u32 = 128;
/// Depth buckets of the bottom-up pass (node depths `0..LEVELS`; a radix
/// tree's internal nodes lie at most 70 edges below the root).
pub const LEVELS: u32 = MAX_DEPTH;
/// u32 scratch arrays per light (`radix_build.wgsl` `S_*`).
const SCRATCH_ARRAYS: u64 = 8;

/// Profiler phases, in the order they run.
pub const PHASES: [&str; 6] = [
    "sst_tree.bounds",
    "sst_tree.classes",
    "sst_tree.morton",
    "sst_tree.karras",
    "sst_tree.place",
    "sst_tree.merge",
];

/// `RadixParams` of `wgsl/lights/radix_bindings.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct RadixParams {
    pub n: u32,
    pub zero: u32,
    pub level: u32,
    pub cap: u32,
    pub max_groups_x: u32,
    pub _pad: [u32; 3],
}

/// The radix substitute tree for up to `capacity` lights, rebuilt on the
/// GPU by [`GpuRadixTree::build`].
pub struct GpuRadixTree {
    capacity: u32,
    light_count: u32,
    /// `2N − 1` [`TreeNode`]s in the BVH layout.
    pub nodes: wgpu::Buffer,
    /// `leaf_of_light` (`N` u32), then `parent` (`2N − 1`): the index
    /// table of [`crate::lights::bvh::gpu::upload`].
    pub index: wgpu::Buffer,
    /// One [`LightCone`] per node.
    pub cones: wgpu::Buffer,
    /// One [`Substitute`] per node.
    pub substitutes: wgpu::Buffer,
    /// The light ids in leaf order (`N` u32).
    pub sorted_ids: wgpu::Buffer,
    codes: wgpu::Buffer,
    centroid_bounds: wgpu::Buffer,
    scratch: wgpu::Buffer,
    levels: wgpu::Buffer,
    args: wgpu::Buffer,
    sorter: RadixSort,
    layout: wgpu::BindGroupLayout,
    args_layout: wgpu::BindGroupLayout,
    pipelines: Pipelines,
}

struct Pipelines {
    bounds: wgpu::ComputePipeline,
    classes: wgpu::ComputePipeline,
    morton: wgpu::ComputePipeline,
    classes_sorted: wgpu::ComputePipeline,
    karras: wgpu::ComputePipeline,
    number: wgpu::ComputePipeline,
    place: wgpu::ComputePipeline,
    level_args: wgpu::ComputePipeline,
    bucket: wgpu::ComputePipeline,
    merge: wgpu::ComputePipeline,
}

impl GpuRadixTree {
    /// The WGSL of the build kernels: the light structs, the exact
    /// arithmetic, the bindings, then `kernel`.
    pub fn source(kernel: (&'static str, &'static str)) -> Wgsl {
        prim_wgsl()
            .constant("WG", WG)
            .constant("LEVELS", LEVELS)
            .constant("INTERNAL_BIT", INTERNAL_BIT)
            .part(wgsl_file!("lights/exact.wgsl"))
            .part(wgsl_file!("lights/radix_bindings.wgsl"))
            .part(kernel)
    }

    /// Group 0 of every kernel: parameters, the lights, ten read-write
    /// buffers.
    pub fn layout_entries() -> Vec<wgpu::BindGroupLayoutEntry> {
        let mut entries = vec![uniform_entry(0), storage_entry(1, true)];
        entries.extend((2..=10).map(|b| storage_entry(b, false)));
        entries
    }

    /// Group 1 of `level_args`: the indirect dispatch arguments.
    pub fn args_layout_entries() -> Vec<wgpu::BindGroupLayoutEntry> {
        vec![storage_entry(0, false)]
    }

    /// Compiles the kernels and allocates a tree for up to `capacity` ≤
    /// 2^30 lights (per light about 300 bytes: nodes, cones and
    /// substitutes for `2N − 1` nodes, the index table, the sort and eight
    /// scratch arrays). Fails with a clear message when the adapter
    /// cannot hold or dispatch it.
    pub fn new(gpu: &Gpu, capacity: u32) -> Result<GpuRadixTree> {
        if capacity > super::MAX_LIGHTS {
            bail!("a substitute tree holds at most 2^30 lights; {capacity} requested");
        }
        let need = Self::layout_entries().len() as u32 - 1;
        if gpu.limits.max_storage_buffers_per_shader_stage < need {
            bail!(
                "the radix substitute tree's GPU build binds {need} storage buffers; this adapter allows {}",
                gpu.limits.max_storage_buffers_per_shader_stage
            );
        }
        let c = capacity.max(1) as u64;
        let node_count = 2 * c - 1;
        let sizes = [
            ("sst_tree.nodes", node_count * size_of::<TreeNode>() as u64),
            ("sst_tree.index", (c + node_count) * 4),
            ("sst_tree.cones", node_count * size_of::<LightCone>() as u64),
            (
                "sst_tree.substitutes",
                node_count * size_of::<Substitute>() as u64,
            ),
            ("sst_tree.scratch", SCRATCH_ARRAYS * c * 4),
        ];
        for (label, bytes) in sizes {
            gpu.check_binding_size(label, bytes)?;
        }
        let (_, gy) = gpu.dispatch_dims((2 * c).div_ceil(WG as u64) as u32);
        if gy > gpu.limits.max_compute_workgroups_per_dimension {
            bail!("a substitute tree of {capacity} lights needs more workgroups than this adapter can dispatch");
        }
        let layout = gpu.bind_group_layout("sst_tree.layout", &Self::layout_entries());
        let args_layout =
            gpu.bind_group_layout("sst_tree.args_layout", &Self::args_layout_entries());
        let build = wgsl_file!("lights/radix_build.wgsl");
        let pipeline = |label: &str, part, entry: &str| {
            gpu.compute_pipeline(label, &Self::source(part), entry, &[&layout])
        };
        let pipelines = Pipelines {
            bounds: pipeline(
                "sst_tree.bounds",
                wgsl_file!("lights/bounds.wgsl"),
                "centroid_bounds_reduce",
            )?,
            classes: pipeline("sst_tree.classes", build, "normal_classes")?,
            morton: pipeline(
                "sst_tree.morton",
                wgsl_file!("lights/morton.wgsl"),
                "morton_codes_sorted",
            )?,
            classes_sorted: pipeline("sst_tree.classes_sorted", build, "classes_sorted")?,
            karras: pipeline("sst_tree.karras", build, "karras")?,
            number: pipeline("sst_tree.number", build, "number")?,
            place: pipeline("sst_tree.place", build, "place")?,
            level_args: gpu.compute_pipeline(
                "sst_tree.level_args",
                &Self::source(build),
                "level_args",
                &[&layout, &args_layout],
            )?,
            bucket: pipeline("sst_tree.bucket", build, "bucket")?,
            merge: pipeline("sst_tree.merge", build, "merge_level")?,
        };
        let buffer = |label: &str, bytes: u64| gpu.buffer_zeroed(label, bytes, STORAGE);
        Ok(GpuRadixTree {
            capacity,
            light_count: 0,
            nodes: buffer(sizes[0].0, sizes[0].1)?,
            index: buffer(sizes[1].0, sizes[1].1)?,
            cones: buffer(sizes[2].0, sizes[2].1)?,
            substitutes: buffer(sizes[3].0, sizes[3].1)?,
            scratch: buffer(sizes[4].0, sizes[4].1)?,
            sorted_ids: buffer("sst_tree.sorted_ids", 4 * c)?,
            codes: buffer("sst_tree.codes", 4 * c)?,
            centroid_bounds: buffer("sst_tree.centroid_bounds", 32)?,
            levels: buffer("sst_tree.levels", 4 * 3 * LEVELS as u64)?,
            args: gpu.buffer_zeroed(
                "sst_tree.args",
                4 * 3 * LEVELS as u64,
                STORAGE | wgpu::BufferUsages::INDIRECT,
            )?,
            sorter: RadixSort::new(gpu, capacity)?,
            layout,
            args_layout,
            pipelines,
        })
    }

    /// Largest light count [`GpuRadixTree::build`] accepts.
    pub fn capacity(&self) -> u32 {
        self.capacity
    }

    /// `N`, the light count of the last build.
    pub fn light_count(&self) -> u32 {
        self.light_count
    }

    /// `2N − 1` (0 without lights).
    pub fn node_count(&self) -> u32 {
        (2 * self.light_count).saturating_sub(1)
    }

    /// Binds the tree's buffers as `sst`'s upload binds the oracle's
    /// ([`crate::lights::bvh::gpu::upload`] and the substitutes; cones only
    /// when `cones`) for `params.count` lights, the count of the builds
    /// that follow (the buffers hold a tree once one has run).
    pub fn bind(
        &self,
        cones: bool,
        params: &mut LightParams,
        out: &mut SamplerBuffers,
    ) -> Result<()> {
        if params.count > self.capacity {
            bail!(
                "radix substitute tree for up to {} lights bound for {} lights",
                self.capacity,
                params.count
            );
        }
        params.node_count = (2 * params.count).saturating_sub(1);
        out.nodes = Some(self.nodes.clone());
        out.index = Some(self.index.clone());
        if cones {
            out.cones = Some(self.cones.clone());
        }
        out.substitutes = Some(self.substitutes.clone());
        Ok(())
    }

    /// Rebuilds the tree over the first `count` lights of `prims` (an
    /// `array<LightPrim>` with `STORAGE` usage), one profiler phase per
    /// step ([`PHASES`]), each submitted. Nothing is read back. `count ==
    /// 0` dispatches nothing (no tree).
    pub fn build(
        &mut self,
        gpu: &Gpu,
        prims: &wgpu::Buffer,
        count: u32,
        profiler: &mut Profiler,
    ) -> Result<()> {
        if count > self.capacity {
            bail!(
                "{count} lights exceed the substitute tree's capacity of {}",
                self.capacity
            );
        }
        if prims.size() < count as u64 * size_of::<LightPrim>() as u64 {
            bail!("the light buffer is too small for {count} lights");
        }
        self.light_count = count;
        if count == 0 {
            return Ok(());
        }
        let stride = (size_of::<RadixParams>() as u64).next_multiple_of(
            gpu.limits
                .min_uniform_buffer_offset_alignment
                .max(gpu.limits.min_storage_buffer_offset_alignment) as u64,
        );
        // Entry d: merge_level of depth d (entry 0 serves every other kernel).
        let mut bytes = vec![0u8; (stride * LEVELS as u64) as usize];
        for level in 0..LEVELS {
            let p = RadixParams {
                n: count,
                zero: 0,
                level,
                cap: self.capacity.max(1),
                max_groups_x: gpu.limits.max_compute_workgroups_per_dimension.max(1),
                _pad: [0; 3],
            };
            let at = (stride * level as u64) as usize;
            bytes[at..at + size_of::<RadixParams>()].copy_from_slice(bytemuck::bytes_of(&p));
        }
        let params = gpu.buffer_from::<u8>("sst_tree.params", &bytes, gpu.uniform_usage())?;
        let buffers = [
            prims,
            &self.centroid_bounds,
            &self.codes,
            &self.sorted_ids,
            &self.nodes,
            &self.index,
            &self.cones,
            &self.substitutes,
            &self.scratch,
            &self.levels,
        ];
        let group = |level: u32| {
            let mut entries = vec![wgpu::BindGroupEntry {
                binding: 0,
                resource: wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                    buffer: &params,
                    offset: stride * level as u64,
                    size: wgpu::BufferSize::new(size_of::<RadixParams>() as u64),
                }),
            }];
            entries.extend(buffers.iter().zip(1..).map(|(b, i)| wgpu::BindGroupEntry {
                binding: i,
                resource: b.as_entire_binding(),
            }));
            gpu.device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("sst_tree.group"),
                layout: &self.layout,
                entries: &entries,
            })
        };
        let main = group(0);
        let args_group = gpu.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("sst_tree.args_group"),
            layout: &self.args_layout,
            entries: &[wgpu::BindGroupEntry {
                binding: 0,
                resource: self.args.as_entire_binding(),
            }],
        });
        let levels: Vec<wgpu::BindGroup> = (0..LEVELS).map(group).collect();
        let dims = |items: u32| gpu.dispatch_dims(items.div_ceil(WG));
        let (lights, internal, all) = (dims(count), dims(count - 1), dims(2 * count - 1));
        let p = &self.pipelines;
        // One compute pass of dispatches (pipeline, groups; None for the
        // one-invocation level_args).
        let pass = |profiler: &mut Profiler,
                    phase: &str,
                    clear: &[&wgpu::Buffer],
                    steps: &[(&wgpu::ComputePipeline, Option<(u32, u32)>)]| {
            profiler.phase(phase, |encoder, timestamps| {
                for b in clear {
                    encoder.clear_buffer(b, 0, None);
                }
                let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                    label: Some(phase),
                    timestamp_writes: timestamps,
                });
                pass.set_bind_group(0, &main, &[]);
                for &(pipeline, groups) in steps {
                    pass.set_pipeline(pipeline);
                    match groups {
                        Some((gx, gy)) => pass.dispatch_workgroups(gx, gy, 1),
                        None => {
                            pass.set_bind_group(1, &args_group, &[]);
                            pass.dispatch_workgroups(1, 1, 1);
                        }
                    }
                }
            })
        };
        let sort = |profiler: &mut Profiler, phase: &str, bits: u32| -> Result<()> {
            let mut sorted = Ok(());
            profiler.phase(phase, |encoder, timestamps| {
                sorted = self.sorter.sort(
                    gpu,
                    encoder,
                    timestamps,
                    &self.codes,
                    &self.sorted_ids,
                    count,
                    bits,
                );
            })?;
            sorted
        };
        // Internal-node kernels only when there are internal nodes.
        let inner = |pipeline| {
            if count > 1 {
                Some((pipeline, Some(internal)))
            } else {
                None
            }
        };
        gpu.scoped("building the radix substitute tree", || {
            pass(
                profiler,
                PHASES[0],
                &[&self.centroid_bounds, &self.levels],
                &[(&p.bounds, Some(lights))],
            )?;
            pass(profiler, PHASES[1], &[], &[(&p.classes, Some(lights))])?;
            sort(profiler, PHASES[1], super::NORMAL_BITS + 1)?;
            pass(profiler, PHASES[2], &[], &[(&p.morton, Some(lights))])?;
            sort(profiler, PHASES[2], 30)?;
            let karras: Vec<_> = [(&p.classes_sorted, Some(lights))]
                .into_iter()
                .chain(inner(&p.karras))
                .chain(inner(&p.number))
                .collect();
            pass(profiler, PHASES[3], &[], &karras)?;
            let place: Vec<_> = [(&p.place, Some(all)), (&p.level_args, None)]
                .into_iter()
                .chain(inner(&p.bucket))
                .collect();
            pass(profiler, PHASES[4], &[], &place)?;
            if count > 1 {
                profiler.phase(PHASES[5], |encoder, timestamps| {
                    let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                        label: Some(PHASES[5]),
                        timestamp_writes: timestamps,
                    });
                    pass.set_pipeline(&p.merge);
                    for level in (0..LEVELS).rev() {
                        pass.set_bind_group(0, &levels[level as usize], &[]);
                        pass.dispatch_workgroups_indirect(&self.args, 12 * level as u64);
                    }
                })?;
            }
            Ok(())
        })
    }

    /// [`GpuRadixTree::build`] with its own profiler; waits for the GPU and
    /// returns the phase times (ms).
    pub fn build_timed(
        &mut self,
        gpu: &Gpu,
        prims: &wgpu::Buffer,
        count: u32,
    ) -> Result<PhaseTimes> {
        let mut profiler = Profiler::new(gpu);
        self.build(gpu, prims, count, &mut profiler)?;
        profiler.finish()
    }

    /// The tree of the last build read back (tests and tools; `None`
    /// without lights), in the oracle's form.
    pub fn read_back(&self, gpu: &Gpu) -> Result<Option<RadixTree>> {
        let n = self.light_count as usize;
        if n == 0 {
            return Ok(None);
        }
        let m = 2 * n - 1;
        let nodes: Vec<TreeNode> = gpu.read_buffer(&self.nodes, m)?;
        let index: Vec<u32> = gpu.read_buffer(&self.index, n + m)?;
        let cones: Vec<LightCone> = gpu.read_buffer(&self.cones, m)?;
        let substitutes: Vec<Substitute> = gpu.read_buffer(&self.substitutes, m)?;
        let sorted: Vec<u32> = gpu.read_buffer(&self.sorted_ids, n)?;
        let (leaf_of_light, parent) = (index[..n].to_vec(), index[n..].to_vec());
        // Depth in nodes; every parent precedes its children.
        let mut depth = vec![1u32; m];
        for i in 1..m {
            let p = parent[i] as usize;
            if p >= i {
                bail!("GPU radix tree: node {i} has parent {p}");
            }
            depth[i] = depth[p] + 1;
        }
        Ok(Some(RadixTree {
            bvh: LightBvh {
                nodes,
                parent,
                leaf_of_light,
                depth: depth.into_iter().max().unwrap_or(1),
                cones,
            },
            substitutes,
            sorted,
        }))
    }
}
