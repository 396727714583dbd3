//! The perfect light tree built on the GPU every frame (real-time
//! stochastic lightcuts §3.1 and §4), bit for bit equal to the CPU oracle
//! [`super::perfect::build`].
//!
//! # Algorithm
//!
//! [`GpuLightTree::build`] takes the frame's `array<LightPrim>` (already on
//! the GPU: lights may be animated) and runs five phases (six with cones, nine for a substitute tree), each one compute
//! pass timed by the [`Profiler`]:
//!
//! | phase | kernel | work |
//! |---|---|---|
//! | `light_tree.bounds` | `wgsl/lights/bounds.wgsl` | global centroid bounds: per-workgroup min/max, then one `atomicMax` per axis on order-preserving bits |
//! | `light_tree.morton` | `wgsl/lights/morton.wgsl` | 30-bit Morton code of every centroid (the exact rule of [`crate::lights::morton`]), light ids as values |
//! | `light_tree.sort` | `wgsl/gpu/radix_sort.wgsl` | stable radix sort of (code, id) over 30 bits ([`RadixSort`]) |
//! | `light_tree.leaves` | `wgsl/lights/tree_build.wgsl` `leaves` | leaf slot `s < N` = leaf of light `sorted[s]`, slots `N..P` bogus ([`TreeNode::EMPTY`]), `leaf_of_light[sorted[s]] = s` |
//! | `light_tree.internal` | `wgsl/lights/tree_build.wgsl` `internal` | levels bottom-up, up to 7 per dispatch from one source level |
//! | `light_tree.cones` | `wgsl/lights/tree_build.wgsl` `cone_level` | with cones only: each level's cones from the level below, one dispatch per level (the leaves' cones are written by `leaves`) |
//!
//! A substitute tree ([`GpuLightTree::with_substitutes`], `sst`) sorts by
//! (Morton code, normal code, id) in two stable passes: `light_tree.normals`
//! (`morton.wgsl` `normal_codes`: the 9-bit normal code of every light,
//! ids as values) and `light_tree.normal_sort` (its 9-bit radix sort) run
//! after the bounds, then `light_tree.morton` gathers the Morton codes in that order
//! (`morton_codes_sorted`) and the 30-bit sort keeps normal order among
//! equal codes. After the cones, `light_tree.substitutes`
//! (`tree_build.wgsl` `substitute_level`) writes the [`Substitute`] of every
//! node, leaves first, one dispatch per level. The normal codes are exact
//! on both sides, so the leaf order and the nodes still equal the oracle's
//! ([`crate::lights::substitute::build`]) bit for bit; the substitutes divide and
//! take square roots and are compared within a tolerance
//! (`tests/lights_gpu_sampler.rs`).
//!
//! The internal levels are built in groups as in the paper (§4): a dispatch
//! reads source level `ℓs` once; each workgroup loads `B = 2^k` (≤ 128)
//! consecutive source nodes into shared memory and gathers them pairwise
//! `k` times, writing levels `ℓs − 1, …, ℓs − k`. Destination node `j` of
//! level `ℓs − t` is thus the gather of source nodes `[j·2^t, (j+1)·2^t)`,
//! which is what "each destination node merges `2^(ℓs−ℓ)` source nodes"
//! means. `P = 2^20` lights take three dispatches (levels 20 → 13 → 6 → 0).
//!
//! Zero lights: no tree; `build` dispatches nothing, [`GpuLightTree::levels`]
//! and [`GpuLightTree::leaf_count`] are 0 and the buffers' contents are
//! unspecified. Samplers must treat a zero light count as "no light".
//!
//! # Exactness: why the nodes equal the CPU oracle bit for bit
//!
//! * **Per-light quantities** (`wgsl/lights/light_prim.wgsl`). The CPU
//!   computes centroids as `((p0 + p1) + p2) / 3`, intensities as
//!   `((wr·r + wg·g) + wb·b)·area` with `area = 0.5·sqrt(dot(cross, cross))`
//!   and bounds with glam's `if a < b { a } else { b }`. Vulkan requires
//!   f32 addition, subtraction and multiplication to be correctly rounded,
//!   but lets a driver contract `a·b + c` into one fma (rounded once); every
//!   product that feeds an addition therefore goes through `mul_rn`, an XOR
//!   of its bits with a zero read from a uniform, which no compiler can see
//!   through. WGSL's division may be off by 2.5 ulp, so `div3_rn` divides by
//!   3 in integer arithmetic with round-to-nearest-even. The weights
//!   `wr, wg, wb` are passed as f32 bits from [`crate::lights::luminance`] itself.
//!   Bounds use `select`, which is exact.
//! * **Morton codes** follow [`crate::lights::morton`] step for step: one
//!   subtraction, the exponent read from bits, powers of two built from bits
//!   (split in two above 2^127), floor, clamp. The centroid bounds are a
//!   min/max, exact in any order.
//! * **Order**: the sort is stable and its values are the ids `0..N` in
//!   order, so equal codes keep id order: the leaves hold the lights sorted
//!   by (code, id), as the oracle sorts them.
//! * **Internal nodes**: a gather is a componentwise min/max (exact) and
//!   one f32 addition `I(left) + I(right)`. Building level `ℓs − t` through
//!   shared-memory levels performs exactly the same additions on the same
//!   operands as the oracle's level-by-level loop (a balanced pairwise sum
//!   in child order), so every level is bit-identical whichever source level
//!   it was built from.
//!
//! Caveats, all outside normal scenes: subnormal coordinates, extents or
//! intensities may be flushed to zero by a GPU (WGSL allows it), NaN and
//! infinite coordinates are not supported, the square root is the driver's
//! `sqrt` (correctly rounded on lavapipe and on most drivers at full
//! precision; WGSL does not promise it), and when a min or max compares +0
//! with −0 either sign may be kept on either side (the values compare
//! equal).
//!
//! # Determinism
//!
//! No phase depends on scheduling: the only atomics are integer maxima
//! (commutative), the sort is reduce-then-scan without spin-waits, and every
//! other write goes to a position computed from the input alone.
//!
//! The cones ([`crate::lights::cone`]) are the one exception to bit-for-bit
//! equality: their union takes square roots and divisions, which WGSL does
//! not round exactly, so they are compared with the oracle's within a
//! stated tolerance; every cone is widened so that it bounds its lights
//! either way.

use crate::gpu::buffer::STORAGE;
use crate::gpu::profiler::PhaseTimes;
use crate::gpu::radix_sort::RadixSort;
use crate::gpu::shader::{storage_entry, uniform_entry, Wgsl};
use crate::gpu::{Gpu, Profiler};
use crate::lights::substitute::{self, Substitute};
use crate::lights::{
    cone, luminance, LightCone, LightPrim, TreeNode, KIND_TRIANGLE, KIND_VPL, NO_LIGHT,
};
use crate::wgsl_file;
use anyhow::{bail, Result};
use bytemuck::{Pod, Zeroable};
use glam::Vec3;

/// Invocations per workgroup of the tree kernels (also the largest block of
/// source nodes one `internal` workgroup gathers: up to 7 levels per dispatch).
const WG: u32 = 128;
/// Bits of a Morton code.
const CODE_BITS: u32 = 30;

/// Profiler phase names, in the order they run (`normals`, `normal_sort`
/// and `substitutes` only for a substitute tree, `cones` only with cones).
pub const PHASES: [&str; 9] = [
    "light_tree.bounds",
    "light_tree.morton",
    "light_tree.sort",
    "light_tree.leaves",
    "light_tree.internal",
    "light_tree.cones",
    "light_tree.normals",
    "light_tree.normal_sort",
    "light_tree.substitutes",
];

const _: () = assert!(std::mem::size_of::<LightPrim>() == 64);
const _: () = assert!(std::mem::size_of::<TreeNode>() == 32);
const _: () = assert!(std::mem::size_of::<Substitute>() == 64);

/// Uniform of the tree kernels (`BuildParams` in `tree_bindings.wgsl`;
/// public for `tests/shader_interfaces.rs`, which compares the layouts).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct BuildParams {
    pub n: u32,
    pub leaf_count: u32,
    pub zero: u32,
    pub src_level: u32,
    pub levels_up: u32,
    pub cones: u32,
    pub _pad: [u32; 2],
}

/// Per-phase build times in milliseconds (GPU timestamps where the adapter
/// has them, else wall clock around a device sync; see [`Profiler`]).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct BuildTimes {
    pub bounds: f64,
    pub morton: f64,
    pub sort: f64,
    pub leaves: f64,
    pub internal: f64,
    /// The internal nodes' cones (0 for a tree without cones; the leaves'
    /// cones are part of `leaves`).
    pub cones: f64,
    /// Substitute trees: the normal codes, their sort (the first of the
    /// two stable passes) and the substitute distributions (0 otherwise).
    pub normals: f64,
    pub normal_sort: f64,
    pub substitutes: f64,
}

impl BuildTimes {
    /// The tree phases of `times` (other phases are ignored; absent ones
    /// are 0).
    pub fn from_phases(times: &PhaseTimes) -> BuildTimes {
        let get = |i: usize| times.get(PHASES[i]).unwrap_or(0.0);
        BuildTimes {
            bounds: get(0),
            morton: get(1),
            sort: get(2),
            leaves: get(3),
            internal: get(4),
            cones: get(5),
            normals: get(6),
            normal_sort: get(7),
            substitutes: get(8),
        }
    }

    pub fn total(&self) -> f64 {
        self.bounds
            + self.morton
            + self.sort
            + self.leaves
            + self.internal
            + self.cones
            + self.normals
            + self.normal_sort
            + self.substitutes
    }
}

/// The shared WGSL of light primitives, tree nodes and cones with their
/// generated constants (`wgsl/lights/light_prim.wgsl`,
/// `wgsl/lights/cone.wgsl`), for kernels that read lights or nodes exactly
/// as the CPU does.
pub fn prim_wgsl() -> Wgsl {
    Wgsl::new()
        .constant("CONE_SLACK_COS_BITS", cone::SLACK.cos().to_bits())
        .constant("CONE_SLACK_SIN_BITS", cone::SLACK.sin().to_bits())
        .constant("CONE_EMPTY_COS_BITS", cone::EMPTY_COS.to_bits())
        .constant("LUM_R_BITS", luminance(Vec3::X).to_bits())
        .constant("LUM_G_BITS", luminance(Vec3::Y).to_bits())
        .constant("LUM_B_BITS", luminance(Vec3::Z).to_bits())
        .constant("KIND_TRIANGLE", KIND_TRIANGLE)
        .constant("KIND_VPL", KIND_VPL)
        .constant("NO_LIGHT", NO_LIGHT)
        .constant("EMPTY_MIN_BITS", TreeNode::EMPTY_MIN.to_bits())
        .constant("EMPTY_MAX_BITS", TreeNode::EMPTY_MAX.to_bits())
        .part(wgsl_file!("lights/light_prim.wgsl"))
        .part(wgsl_file!("lights/cone.wgsl"))
        .part(wgsl_file!("lights/substitute.wgsl"))
}

/// A perfect light tree for up to `capacity` lights, rebuilt on the GPU by
/// [`GpuLightTree::build`]. Layout: `src/lights/mod.rs`.
pub struct GpuLightTree {
    capacity: u32,
    /// `2P − 1` [`TreeNode`]s for the capacity's `P`; the current tree uses
    /// the first `2·leaf_count() − 1`.
    pub nodes: wgpu::Buffer,
    /// Leaf slot of each light id (`u32`, first `light_count()` entries).
    pub leaf_of_light: wgpu::Buffer,
    /// After a build: the light ids in leaf order (`u32`, first
    /// `light_count()` entries).
    pub sorted_ids: wgpu::Buffer,
    /// After a build: the Morton codes in leaf order (`u32`).
    pub sorted_codes: wgpu::Buffer,
    /// With cones: the [`LightCone`] of each node, indexed like `nodes`
    /// (widened, not bit-equal to [`super::perfect::build`]'s: see
    /// [`crate::lights::cone`]); without: `None`.
    pub cones: Option<wgpu::Buffer>,
    /// Binds in place of `cones` when the tree has none.
    no_cones: wgpu::Buffer,
    /// A substitute tree ([`GpuLightTree::with_substitutes`]): the
    /// [`Substitute`] of each node, indexed like `nodes` (within a stated
    /// tolerance of [`crate::lights::substitute::build`]'s); otherwise `None`.
    pub substitutes: Option<wgpu::Buffer>,
    no_substitutes: wgpu::Buffer,
    centroid_bounds: wgpu::Buffer,
    sorter: RadixSort,
    layout: wgpu::BindGroupLayout,
    bounds_pipeline: wgpu::ComputePipeline,
    morton_pipeline: wgpu::ComputePipeline,
    leaves_pipeline: wgpu::ComputePipeline,
    internal_pipeline: wgpu::ComputePipeline,
    cone_pipeline: wgpu::ComputePipeline,
    normal_pipeline: wgpu::ComputePipeline,
    morton_sorted_pipeline: wgpu::ComputePipeline,
    substitute_pipeline: wgpu::ComputePipeline,
    light_count: u32,
}

impl GpuLightTree {
    /// The WGSL of the build kernels in `kernel` (`lights/bounds.wgsl`,
    /// `lights/morton.wgsl` or `lights/tree_build.wgsl`): the light structs
    /// and the shared bindings first.
    pub fn source(kernel: (&'static str, &'static str)) -> Wgsl {
        prim_wgsl()
            .constant("WG", WG)
            .part(wgsl_file!("lights/tree_bindings.wgsl"))
            .part(kernel)
    }

    /// The one layout of the build kernels (`lights/tree_bindings.wgsl`):
    /// parameters, the lights (read-only), then seven read-write buffers.
    pub fn layout_entries() -> Vec<wgpu::BindGroupLayoutEntry> {
        let mut entries = vec![uniform_entry(0), storage_entry(1, true)];
        entries.extend((2..=8).map(|b| storage_entry(b, false)));
        entries
    }

    /// A substitute tree ([`crate::lights::substitute`]) for up to `capacity` ≤
    /// 2^30 lights: leaves sorted by (Morton code, normal code, id), with
    /// cones and a 64-byte [`Substitute`] per node.
    pub fn with_substitutes(gpu: &Gpu, capacity: u32) -> Result<GpuLightTree> {
        if capacity > substitute::MAX_LIGHTS {
            bail!("a substitute tree holds at most 2^30 lights; {capacity} requested");
        }
        Self::create(gpu, capacity, true, true)
    }

    /// Compiles the kernels and allocates a tree for up to `capacity`
    /// lights (`2P − 1` nodes of 32 bytes, `P = capacity` rounded up to a
    /// power of two, as many 32-byte cones when `with_cones`, plus 20 bytes
    /// per light of scratch). Fails with a clear message when the adapter
    /// cannot hold or dispatch it.
    pub fn new(gpu: &Gpu, capacity: u32, with_cones: bool) -> Result<GpuLightTree> {
        Self::create(gpu, capacity, with_cones, false)
    }

    fn create(
        gpu: &Gpu,
        capacity: u32,
        with_cones: bool,
        with_substitutes: bool,
    ) -> Result<GpuLightTree> {
        if capacity > 1 << 31 {
            bail!("a light tree holds at most 2^31 lights; {capacity} requested");
        }
        let p = capacity.max(1).next_power_of_two() as u64;
        let node_bytes = (2 * p - 1) * std::mem::size_of::<TreeNode>() as u64;
        gpu.check_binding_size("light_tree.nodes", node_bytes)?;
        let cone_bytes = (2 * p - 1) * std::mem::size_of::<LightCone>() as u64;
        if with_cones {
            gpu.check_binding_size("light_tree.cones", cone_bytes)?;
        }
        let substitute_bytes = (2 * p - 1) * std::mem::size_of::<Substitute>() as u64;
        if with_substitutes {
            gpu.check_binding_size("light_tree.substitutes", substitute_bytes)?;
        }
        let (_, gy) = gpu.dispatch_dims(p.div_ceil(WG as u64) as u32);
        if gy > gpu.limits.max_compute_workgroups_per_dimension {
            bail!("a light tree of {capacity} lights needs more workgroups than this adapter can dispatch");
        }
        let sorter = RadixSort::new(gpu, capacity)?;

        let layout = gpu.bind_group_layout("light_tree.layout", &Self::layout_entries());
        let pipeline = |label: &str, part, entry: &str| {
            gpu.compute_pipeline(label, &Self::source(part), entry, &[&layout])
        };
        let bounds_pipeline = pipeline(
            "light_tree.bounds",
            wgsl_file!("lights/bounds.wgsl"),
            "centroid_bounds_reduce",
        )?;
        let morton_pipeline = pipeline(
            "light_tree.morton",
            wgsl_file!("lights/morton.wgsl"),
            "morton_codes",
        )?;
        let leaves_pipeline = pipeline(
            "light_tree.leaves",
            wgsl_file!("lights/tree_build.wgsl"),
            "leaves",
        )?;
        let internal_pipeline = pipeline(
            "light_tree.internal",
            wgsl_file!("lights/tree_build.wgsl"),
            "internal",
        )?;
        let cone_pipeline = pipeline(
            "light_tree.cones",
            wgsl_file!("lights/tree_build.wgsl"),
            "cone_level",
        )?;
        let normal_pipeline = pipeline(
            "light_tree.normals",
            wgsl_file!("lights/morton.wgsl"),
            "normal_codes",
        )?;
        let morton_sorted_pipeline = pipeline(
            "light_tree.morton_sorted",
            wgsl_file!("lights/morton.wgsl"),
            "morton_codes_sorted",
        )?;
        let substitute_pipeline = pipeline(
            "light_tree.substitutes",
            wgsl_file!("lights/tree_build.wgsl"),
            "substitute_level",
        )?;

        let light_bytes = 4 * capacity as u64;
        Ok(GpuLightTree {
            capacity,
            nodes: gpu.buffer_zeroed("light_tree.nodes", node_bytes, STORAGE)?,
            leaf_of_light: gpu.buffer_zeroed("light_tree.leaf_of_light", light_bytes, STORAGE)?,
            sorted_ids: gpu.buffer_zeroed("light_tree.sorted_ids", light_bytes, STORAGE)?,
            sorted_codes: gpu.buffer_zeroed("light_tree.codes", light_bytes, STORAGE)?,
            cones: if with_cones {
                Some(gpu.buffer_zeroed("light_tree.cones", cone_bytes, STORAGE)?)
            } else {
                None
            },
            no_cones: gpu.buffer_zeroed("light_tree.no_cones", 32, STORAGE)?,
            substitutes: if with_substitutes {
                Some(gpu.buffer_zeroed("light_tree.substitutes", substitute_bytes, STORAGE)?)
            } else {
                None
            },
            no_substitutes: gpu.buffer_zeroed("light_tree.no_substitutes", 64, STORAGE)?,
            centroid_bounds: gpu.buffer_zeroed("light_tree.centroid_bounds", 32, STORAGE)?,
            sorter,
            layout,
            bounds_pipeline,
            morton_pipeline,
            leaves_pipeline,
            internal_pipeline,
            cone_pipeline,
            normal_pipeline,
            morton_sorted_pipeline,
            substitute_pipeline,
            light_count: 0,
        })
    }

    /// Largest light count [`GpuLightTree::build`] accepts.
    pub fn capacity(&self) -> u32 {
        self.capacity
    }

    /// `N`, the light count of the last build.
    pub fn light_count(&self) -> u32 {
        self.light_count
    }

    /// `P`: the light count rounded up to a power of two (0 without lights).
    pub fn leaf_count(&self) -> u32 {
        if self.light_count == 0 {
            0
        } else {
            self.light_count.next_power_of_two()
        }
    }

    /// `log2(P) + 1` levels (0 without lights).
    pub fn levels(&self) -> u32 {
        match self.leaf_count() {
            0 => 0,
            p => p.trailing_zeros() + 1,
        }
    }

    /// Number of nodes of the current tree, `2P − 1` (0 without lights).
    pub fn node_count(&self) -> u32 {
        (2 * self.leaf_count()).saturating_sub(1)
    }

    /// Rebuilds the tree over the first `count` lights of `prims` (an
    /// `array<LightPrim>` with `STORAGE` usage), recording one profiler
    /// phase per step ([`PHASES`]) and submitting each. The nodes are ready
    /// for any work submitted afterwards; nothing is read back. `count == 0`
    /// dispatches nothing (no tree).
    pub fn build(
        &mut self,
        gpu: &Gpu,
        prims: &wgpu::Buffer,
        count: u32,
        profiler: &mut Profiler,
    ) -> Result<()> {
        if count > self.capacity {
            bail!(
                "{count} lights exceed the light tree's capacity of {}; create it with a larger capacity",
                self.capacity
            );
        }
        let prim_bytes = count as u64 * std::mem::size_of::<LightPrim>() as u64;
        if prims.size() < prim_bytes {
            bail!(
                "the light buffer holds {} bytes, {count} lights need {prim_bytes}",
                prims.size()
            );
        }
        if !prims.usage().contains(wgpu::BufferUsages::STORAGE) {
            bail!("the light buffer lacks STORAGE usage");
        }
        self.light_count = count;
        if count == 0 {
            return Ok(());
        }
        let p = self.leaf_count();
        let leaf_level = self.levels() - 1;

        // Entry 0: the per-light kernels; entries 1..: one per internal
        // dispatch (source level, levels built).
        let mut steps = Vec::new();
        let mut src = leaf_level;
        while src > 0 {
            let k = src.min(WG.trailing_zeros());
            steps.push((src, k));
            src -= k;
        }
        // Then one entry per cone level, leaf_level − 1 down to 0, and
        // one per substitute level, leaf_level down to 0.
        let cone_levels: Vec<u32> = match self.cones {
            Some(_) => (0..leaf_level).rev().collect(),
            None => Vec::new(),
        };
        let substitute_levels: Vec<u32> = match self.substitutes {
            Some(_) => (0..=leaf_level).rev().collect(),
            None => Vec::new(),
        };
        let stride = (std::mem::size_of::<BuildParams>() as u64)
            .next_multiple_of(gpu.limits.min_uniform_buffer_offset_alignment as u64);
        let params_count = 1 + steps.len() + cone_levels.len() + substitute_levels.len();
        let mut bytes = vec![0u8; stride as usize * params_count];
        let entry = |src_level: u32, levels_up: u32| BuildParams {
            n: count,
            leaf_count: p,
            zero: 0,
            src_level,
            levels_up,
            cones: self.cones.is_some() as u32,
            _pad: [0; 2],
        };
        let entries = std::iter::once(entry(0, 0))
            .chain(steps.iter().map(|&(s, k)| entry(s, k)))
            .chain(cone_levels.iter().map(|&l| entry(l, 0)))
            .chain(substitute_levels.iter().map(|&l| entry(l, 0)));
        for (i, e) in entries.enumerate() {
            let at = i * stride as usize;
            bytes[at..at + std::mem::size_of::<BuildParams>()]
                .copy_from_slice(bytemuck::bytes_of(&e));
        }
        let params = gpu.buffer_from::<u8>("light_tree.params", &bytes, gpu.uniform_usage())?;
        fn binding(b: u32, buffer: &wgpu::Buffer) -> wgpu::BindGroupEntry<'_> {
            wgpu::BindGroupEntry {
                binding: b,
                resource: buffer.as_entire_binding(),
            }
        }
        let group = |i: usize| {
            gpu.device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("light_tree.group"),
                layout: &self.layout,
                entries: &[
                    wgpu::BindGroupEntry {
                        binding: 0,
                        resource: wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                            buffer: &params,
                            offset: stride * i as u64,
                            size: wgpu::BufferSize::new(std::mem::size_of::<BuildParams>() as u64),
                        }),
                    },
                    binding(1, prims),
                    binding(2, &self.centroid_bounds),
                    binding(3, &self.sorted_codes),
                    binding(4, &self.sorted_ids),
                    binding(5, &self.nodes),
                    binding(6, &self.leaf_of_light),
                    binding(7, self.cones.as_ref().unwrap_or(&self.no_cones)),
                    binding(8, self.substitutes.as_ref().unwrap_or(&self.no_substitutes)),
                ],
            })
        };
        let per_light = group(0);
        let light_groups = gpu.dispatch_dims(count.div_ceil(WG));
        let leaf_groups = gpu.dispatch_dims(p.div_ceil(WG));

        let single = |profiler: &mut Profiler,
                      phase: &str,
                      pipeline: &wgpu::ComputePipeline,
                      (gx, gy): (u32, u32),
                      clear: Option<&wgpu::Buffer>| {
            profiler.phase(phase, |encoder, timestamps| {
                if let Some(b) = clear {
                    encoder.clear_buffer(b, 0, None);
                }
                let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                    label: Some(phase),
                    timestamp_writes: timestamps,
                });
                pass.set_pipeline(pipeline);
                pass.set_bind_group(0, &per_light, &[]);
                pass.dispatch_workgroups(gx, gy, 1);
            })
        };

        // A stable radix sort of (codes, ids) on `bits` bits, in place.
        let sort = |profiler: &mut Profiler, phase: &str, bits: u32| -> Result<()> {
            let mut sorted = Ok(());
            profiler.phase(phase, |encoder, timestamps| {
                sorted = self.sorter.sort(
                    gpu,
                    encoder,
                    timestamps,
                    &self.sorted_codes,
                    &self.sorted_ids,
                    count,
                    bits,
                );
            })?;
            sorted
        };
        gpu.scoped("building the light tree", || {
            single(
                profiler,
                PHASES[0],
                &self.bounds_pipeline,
                light_groups,
                Some(&self.centroid_bounds),
            )?;
            if self.substitutes.is_some() {
                // (normal code, id) first; the Morton pass below is stable.
                single(
                    profiler,
                    PHASES[6],
                    &self.normal_pipeline,
                    light_groups,
                    None,
                )?;
                sort(profiler, PHASES[7], substitute::NORMAL_BITS)?;
            }
            let morton = if self.substitutes.is_some() {
                &self.morton_sorted_pipeline
            } else {
                &self.morton_pipeline
            };
            single(profiler, PHASES[1], morton, light_groups, None)?;
            sort(profiler, PHASES[2], CODE_BITS)?;
            single(
                profiler,
                PHASES[3],
                &self.leaves_pipeline,
                leaf_groups,
                None,
            )?;
            let internal: Vec<_> = (1..=steps.len()).map(group).collect();
            if !steps.is_empty() {
                profiler.phase(PHASES[4], |encoder, timestamps| {
                    let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                        label: Some(PHASES[4]),
                        timestamp_writes: timestamps,
                    });
                    pass.set_pipeline(&self.internal_pipeline);
                    for (&(src, k), g) in steps.iter().zip(&internal) {
                        let (gx, gy) = gpu.dispatch_dims(1 << (src - k));
                        pass.set_bind_group(0, g, &[]);
                        pass.dispatch_workgroups(gx, gy, 1);
                    }
                })?;
            }
            // One dispatch per level, each with its own parameter entry
            // (from `first` on), in one profiler phase.
            let per_level = |profiler: &mut Profiler,
                             phase: &str,
                             pipeline: &wgpu::ComputePipeline,
                             levels: &[u32],
                             first: usize|
             -> Result<()> {
                if levels.is_empty() {
                    return Ok(());
                }
                let groups: Vec<_> = (first..first + levels.len()).map(group).collect();
                profiler.phase(phase, |encoder, timestamps| {
                    let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                        label: Some(phase),
                        timestamp_writes: timestamps,
                    });
                    pass.set_pipeline(pipeline);
                    for (&level, g) in levels.iter().zip(&groups) {
                        let (gx, gy) = gpu.dispatch_dims((1u32 << level).div_ceil(WG));
                        pass.set_bind_group(0, g, &[]);
                        pass.dispatch_workgroups(gx, gy, 1);
                    }
                })
            };
            let first = 1 + steps.len();
            per_level(
                profiler,
                PHASES[5],
                &self.cone_pipeline,
                &cone_levels,
                first,
            )?;
            let first = first + cone_levels.len();
            per_level(
                profiler,
                PHASES[8],
                &self.substitute_pipeline,
                &substitute_levels,
                first,
            )?;
            Ok(())
        })
    }

    /// [`GpuLightTree::build`] with its own profiler; waits for the GPU and
    /// returns the phase times.
    pub fn build_timed(
        &mut self,
        gpu: &Gpu,
        prims: &wgpu::Buffer,
        count: u32,
    ) -> Result<BuildTimes> {
        let mut profiler = Profiler::new(gpu);
        self.build(gpu, prims, count, &mut profiler)?;
        Ok(BuildTimes::from_phases(&profiler.finish()?))
    }
}
