//! The GPU side of the light samplers: the buffers of `@group(1)` bindings
//! 16–23 that `wgsl/lights/sample.wgsl` reads, their layout entries and the
//! WGSL to include.
//!
//! | binding | WGSL | contents |
//! |---|---|---|
//! | 16 | `light_nodes: array<TreeNode>` | perfect tree (CPU-built or from the GPU build) or the unbalanced BVH |
//! | 17 | `light_prims: array<LightPrim>` | the lights |
//! | 18 | `light_index: array<u32>` | perfect: leaf slot per light; BVH: leaf node per light, then parent per node; power: f32 bits of each pmf |
//! | 19 | `light_alias: array<AliasEntry>` | power: the alias table |
//! | 20 | `light_cuts: array<u32>` | tree kinds with cuts: `cut_size` nodes per k×k block, `NO_LIGHT`-padded |
//! | 21 | `light_params: LightParams` | uniform: counts, kind, tree shape, cut layout |
//! | 22 | `light_cones: array<LightCone>` | cone kinds: the orientation bound of every node, same indices as `light_nodes` |
//! | 23 | `light_substitutes: array<Substitute>` | `sst`, `sst_nosub`: the substitute distribution of every node, same indices as `light_nodes` |
//!
//! Unused bindings hold one zeroed element. The cuts buffer is writable
//! (`STORAGE | COPY_DST`): a cut pre-pass binds it read-write in its own
//! group and fills it with `select_cut`, or [`GpuSamplerData::write_cuts`]
//! uploads CPU cuts. The sampling pass binds it read-only.

use super::bvh::{self, LightBvh, INTERNAL_BIT};
use super::importance::NEAR_CLAMP;
use super::lgh::gpu::GpuLgh;
use super::lgh::{self, GridLight};
pub use super::light_params::LightParams;
use super::light_params::SamplerBuffers;
use super::registry::SamplerKind;
use super::sampler::{CutSampling, Layout, Structure};
use super::simple::{self, alias::AliasEntry};
use super::substitute::gpu_build::GpuRadixTree;
use super::substitute::{self, Substitute, SubstituteParams, SubstituteTree};
use super::tree::cut::MAX_CUT;
use super::tree::gpu::GpuTreeBuffers;
use super::tree::perfect::{self, PerfectTree};
use super::tree::{self, gpu_build};
use super::two_level;
use super::two_level::gpu::GpuTwoLevel;
use super::{LightCone, LightPrim, TreeNode, NO_LIGHT};
use crate::gpu::buffer::STORAGE;
use crate::gpu::shader::{storage_entry, uniform_entry, Wgsl};
use crate::gpu::Gpu;
use crate::wgsl_file;
use anyhow::{bail, Result};
use bytemuck::{Pod, Zeroable};

/// First binding of the light samplers in `@group(1)`.
pub const FIRST_BINDING: u32 = 16;

impl LightParams {
    /// Sets `sst`'s suitability thresholds.
    pub fn set_substitute_params(&mut self, q: &SubstituteParams) {
        self.sst_nu_min = q.nu_min;
        self.sst_sigma_max2 = q.sigma_max * q.sigma_max;
    }
}

/// How the film is tiled into cut-sharing blocks (§3.3).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct CutLayout {
    /// Nodes per cut, 1..=[`MAX_CUT`].
    pub cut_size: u32,
    /// Block side k in pixels.
    pub block_size: u32,
    pub blocks_per_row: u32,
    pub block_rows: u32,
    /// Interleaved sampling: m×m sub-blocks (1 = off); m divides k.
    pub interleave: u32,
    /// Frame number rotating the interleaved assignment.
    pub frame: u32,
    /// The estimator of the kinds with cuts.
    pub sampling: CutSampling,
}

impl CutLayout {
    /// k×k blocks covering a `width × height` film.
    pub fn for_film(width: u32, height: u32, block_size: u32, cut_size: u32) -> Self {
        let block_size = block_size.max(1);
        CutLayout {
            cut_size,
            block_size,
            blocks_per_row: width.div_ceil(block_size),
            block_rows: height.div_ceil(block_size),
            interleave: 1,
            frame: 0,
            sampling: CutSampling::Subtrees,
        }
    }

    /// With the estimator `sampling` for the kinds with cuts.
    pub fn sampled(self, sampling: CutSampling) -> Self {
        CutLayout { sampling, ..self }
    }

    /// With interleaved sampling over `m`×`m` sub-blocks at `frame`.
    pub fn interleaved(self, m: u32, frame: u32) -> Self {
        CutLayout {
            interleave: m.max(1),
            frame,
            ..self
        }
    }

    pub fn blocks(&self) -> u32 {
        self.blocks_per_row * self.block_rows
    }
}

/// Where the tree of a tree kind comes from.
pub enum TreeSource<'a> {
    /// A perfect tree built on the CPU.
    Perfect(&'a PerfectTree),
    /// A perfect tree built on the GPU: its `2P − 1` nodes, the leaf slot
    /// of each light and, for the cone kinds, the nodes' cones (the
    /// buffers are bound as they are).
    PerfectGpu {
        nodes: &'a wgpu::Buffer,
        leaf_of_light: &'a wgpu::Buffer,
        cones: Option<&'a wgpu::Buffer>,
        substitutes: Option<&'a wgpu::Buffer>,
    },
    /// A substitute tree built on the CPU.
    Substitute(&'a SubstituteTree),
    /// The unbalanced BVH.
    Bvh(&'a LightBvh),
    /// `tree2` built on the GPU ([`GpuTwoLevel`]): its buffers are bound
    /// as they are.
    TwoLevelGpu(&'a GpuTwoLevel),
    /// `sst`'s radix substitute tree built on the GPU ([`GpuRadixTree`]):
    /// its buffers are bound as they are.
    RadixGpu(&'a GpuRadixTree),
    /// The lighting grid hierarchy (`lgh`), built on the GPU into its own
    /// buffers; its parameters fill the `lgh_*` fields.
    Lgh(&'a GpuLgh),
}

/// The buffers of bindings 16–23 for one sampler kind.
pub struct GpuSamplerData {
    pub kind: SamplerKind,
    pub params: LightParams,
    pub nodes: wgpu::Buffer,
    pub cones: wgpu::Buffer,
    pub substitutes: wgpu::Buffer,
    /// `lgh`: the grid lights (binding 24).
    pub lgh_lights: wgpu::Buffer,
    pub prims: wgpu::Buffer,
    pub index: wgpu::Buffer,
    pub alias: wgpu::Buffer,
    pub cuts: wgpu::Buffer,
    pub uniform: wgpu::Buffer,
}

impl GpuSamplerData {
    /// Uploads what `kind` needs. `tree` supplies the tree of the tree
    /// kinds (`None`: built here on the CPU from `prims`); `cuts` sizes the
    /// cut buffer (only the kinds with cuts allocate one per block; it
    /// starts with every cut = [root]).
    pub fn new(
        gpu: &Gpu,
        kind: SamplerKind,
        prims: &[LightPrim],
        tree: Option<TreeSource<'_>>,
        cuts: CutLayout,
    ) -> Result<Self> {
        if !(1..=MAX_CUT).contains(&cuts.cut_size) {
            bail!("cut_size must be in 1..={MAX_CUT}, got {}", cuts.cut_size);
        }
        let n = prims.len() as u32;
        let mut params = LightParams {
            count: n,
            kind: kind.index(),
            cut_size: if kind.uses_cut() { cuts.cut_size } else { 1 },
            block_size: cuts.block_size.max(1),
            blocks_per_row: cuts.blocks_per_row,
            interleave: if kind.uses_cut() {
                cuts.interleave.max(1)
            } else {
                1
            },
            frame: cuts.frame,
            cut_mixture: (kind.uses_cut() && cuts.sampling == CutSampling::Mixture) as u32,
            ..Default::default()
        };
        params.set_substitute_params(&SubstituteParams::default());
        let mut out = SamplerBuffers::default();
        if n > 0 {
            Self::upload(gpu, kind, prims, tree, &mut params, &mut out)?;
        }
        let cut_entries = if kind.uses_cut() && n > 0 {
            let mut c = vec![NO_LIGHT; (cuts.blocks() * cuts.cut_size) as usize];
            for b in 0..cuts.blocks() as usize {
                c[b * cuts.cut_size as usize] = 0;
            }
            c
        } else {
            Vec::new()
        };
        fn or_empty<T: Pod>(gpu: &Gpu, b: Option<wgpu::Buffer>) -> Result<wgpu::Buffer> {
            b.map_or_else(|| SamplerBuffers::upload::<T>(gpu, "unused", &[]), Ok)
        }
        Ok(GpuSamplerData {
            kind,
            params,
            nodes: or_empty::<TreeNode>(gpu, out.nodes)?,
            cones: or_empty::<LightCone>(gpu, out.cones)?,
            substitutes: or_empty::<Substitute>(gpu, out.substitutes)?,
            lgh_lights: or_empty::<GridLight>(gpu, out.lgh_lights)?,
            prims: SamplerBuffers::upload(gpu, "prims", prims)?,
            index: or_empty::<u32>(gpu, out.index)?,
            alias: or_empty::<AliasEntry>(gpu, out.alias)?,
            cuts: SamplerBuffers::upload(gpu, "cuts", &cut_entries)?,
            uniform: gpu.uniform("lights.sampler.params", &params),
        })
    }

    /// The one dispatch on the kind's [`Structure`]: each technique's
    /// upload (in its folder) fills `out` and its part of `params` for
    /// `n ≥ 1` lights, from `tree` when given (the GPU builds, or a CPU
    /// structure built with more than the lights, as `tree2`'s groups)
    /// or built here from `prims`.
    fn upload(
        gpu: &Gpu,
        kind: SamplerKind,
        prims: &[LightPrim],
        tree: Option<TreeSource<'_>>,
        params: &mut LightParams,
        out: &mut SamplerBuffers,
    ) -> Result<()> {
        let cones = kind.uses_cones();
        let other = |want: &str| -> Result<()> {
            bail!("sampler '{kind}' needs {want}, got another structure")
        };
        match (kind.structure(), tree) {
            (Structure::Uniform, _) => Ok(()),
            (Structure::Power, _) => simple::gpu::upload_power(gpu, prims, params, out),
            (Structure::PerfectTree, None) => {
                let t = perfect::build(prims).unwrap();
                tree::gpu::upload(gpu, &t, cones, params, out)
            }
            (Structure::PerfectTree, Some(TreeSource::Perfect(t))) => {
                tree::gpu::upload(gpu, t, cones, params, out)
            }
            (
                Structure::PerfectTree,
                Some(TreeSource::PerfectGpu {
                    nodes,
                    leaf_of_light,
                    cones: gpu_cones,
                    substitutes: None,
                }),
            ) => tree::gpu::bind(
                GpuTreeBuffers {
                    nodes,
                    leaf_of_light,
                    cones: gpu_cones,
                },
                cones,
                params,
                out,
            ),
            (Structure::PerfectTree, Some(_)) => other("a perfect tree without substitutes"),
            (Structure::SubstituteTree, None) => {
                let t = substitute::build(prims).unwrap();
                substitute::gpu::upload(gpu, &t, cones, params, out)
            }
            (Structure::SubstituteTree, Some(TreeSource::Substitute(t))) => {
                substitute::gpu::upload(gpu, t, cones, params, out)
            }
            (
                Structure::SubstituteTree,
                Some(TreeSource::PerfectGpu {
                    nodes,
                    leaf_of_light,
                    cones: gpu_cones,
                    substitutes: Some(subs),
                }),
            ) => {
                let t = GpuTreeBuffers {
                    nodes,
                    leaf_of_light,
                    cones: gpu_cones,
                };
                tree::gpu::bind(t, cones, params, out)?;
                substitute::gpu::bind(subs, params, out)
            }
            (Structure::SubstituteTree, Some(_)) => other("a substitute tree"),
            (Structure::Technique(t), None) => t.upload(gpu, prims, cones, params, out),
            (Structure::Technique(t), Some(TreeSource::RadixGpu(r)))
                if t.layout() == Layout::Bvh && t.substitutes() =>
            {
                r.bind(cones, params, out)
            }
            (Structure::Technique(t), Some(_)) => {
                bail!("sampler '{kind}' builds its {} itself", t.name())
            }
            (Structure::Bvh(cost), None) => {
                let b = bvh::build(prims, cost).unwrap();
                bvh::gpu::upload(gpu, &b, cones, params, out)
            }
            (Structure::Bvh(_) | Structure::TwoLevel, Some(TreeSource::Bvh(b))) => {
                bvh::gpu::upload(gpu, b, cones, params, out)
            }
            (Structure::Bvh(_), Some(_)) => other("a light BVH"),
            // tree2 without groups: one group (factory.rs).
            (Structure::TwoLevel, None) => {
                let n = prims.len() as u32;
                let b = two_level::build(prims, std::slice::from_ref(&(0..n))).unwrap();
                bvh::gpu::upload(gpu, &b, cones, params, out)
            }
            (Structure::TwoLevel, Some(TreeSource::TwoLevelGpu(t))) => t.bind(params, out),
            (Structure::TwoLevel, Some(_)) => other("a two-level tree"),
            (Structure::Grid, Some(TreeSource::Lgh(h))) => h.bind(params, out),
            (Structure::Grid, _) => bail!("sampler '{kind}' needs its grid hierarchy (GpuLgh)"),
        }
    }

    /// Sets `sst`'s suitability thresholds (uploaded with the next
    /// [`Self::set_time`]).
    pub fn set_substitute_params(&mut self, q: &SubstituteParams) {
        self.params.set_substitute_params(q);
    }

    /// Sets the frame time the kernels read from `light_params.time`.
    pub fn set_time(&mut self, gpu: &Gpu, time: f32) {
        self.params.time = time;
        gpu.queue
            .write_buffer(&self.uniform, 0, bytemuck::bytes_of(&self.params));
    }

    /// Uploads cuts: `cut_size` node indices per block (`NO_LIGHT`-padded),
    /// blocks row-major.
    pub fn write_cuts(&self, gpu: &Gpu, cuts: &[u32]) -> Result<()> {
        if !self.kind.uses_cut() {
            bail!("sampler '{}' has no cuts", self.kind);
        }
        let bytes: &[u8] = bytemuck::cast_slice(cuts);
        if bytes.len() as u64 > self.cuts.size() {
            bail!("{} cut entries do not fit the cut buffer", cuts.len());
        }
        gpu.queue.write_buffer(&self.cuts, 0, bytes);
        Ok(())
    }

    /// Layout entries of bindings 16–23 (compute, read-only storage and a
    /// uniform), to merge into a `@group(1)` layout.
    pub fn layout_entries() -> Vec<wgpu::BindGroupLayoutEntry> {
        let mut e: Vec<_> = (0..5)
            .map(|i| storage_entry(FIRST_BINDING + i, true))
            .collect();
        e.push(uniform_entry(FIRST_BINDING + 5));
        e.push(storage_entry(FIRST_BINDING + 6, true));
        e.push(storage_entry(FIRST_BINDING + 7, true));
        e.push(storage_entry(FIRST_BINDING + 8, true));
        e
    }

    /// Bind group entries matching [`Self::layout_entries`].
    pub fn bind_group_entries(&self) -> Vec<wgpu::BindGroupEntry<'_>> {
        [
            &self.nodes,
            &self.prims,
            &self.index,
            &self.alias,
            &self.cuts,
            &self.uniform,
            &self.cones,
            &self.substitutes,
            &self.lgh_lights,
        ]
        .into_iter()
        .enumerate()
        .map(|(i, b)| wgpu::BindGroupEntry {
            binding: FIRST_BINDING + i as u32,
            resource: b.as_entire_binding(),
        })
        .collect()
    }

    /// The WGSL of the samplers: the light structs
    /// ([`gpu_build::prim_wgsl`]: `lights/light_prim.wgsl` and
    /// `lights/cone.wgsl` with their constants, `NO_LIGHT` among them), the bindings and `light_sample`, `light_pmf`,
    /// `select_cut`, with the constants they use.
    pub fn wgsl() -> Wgsl {
        Self::wgsl_for_cuts(MAX_CUT)
    }

    /// [`GpuSamplerData::wgsl`] with the shaders' cut arrays sized for cuts
    /// of at most `capacity` nodes ([`cut_capacity`]): the arrays the cut
    /// probabilities and the cut pre-pass index at run time live in
    /// per-invocation memory, and on an H200 sizing them for the scene's
    /// 8-node cuts instead of 64 made a tree sample 6 % cheaper
    /// (BENCHMARKS.md, 2026-12-04). The samplers' results are the same for
    /// any capacity ≥ the cut size.
    pub fn wgsl_for_cuts(capacity: u32) -> Wgsl {
        assert!(
            (1..=MAX_CUT).contains(&capacity),
            "cut capacity {capacity} outside 1..={MAX_CUT}"
        );
        let mut w = gpu_build::prim_wgsl()
            .constant("MAX_CUT", capacity)
            .constant("LIGHT_MAX_DEPTH", bvh::MAX_DEPTH)
            .constant("LIGHT_INTERNAL_BIT", INTERNAL_BIT)
            .constant("LIGHT_NEAR_CLAMP_BITS", NEAR_CLAMP.to_bits())
            .constant("LIGHT_SUBSTITUTE_BIT", substitute::SUBSTITUTE_BIT);
        for k in SamplerKind::ALL {
            w = w.constant(&kind_constant(k), k.index());
        }
        w.constant("LGH_MAX_SHADOWS", lgh::MAX_SHADOW_SAMPLES)
            .part(wgsl_file!("lights/lgh_light.wgsl"))
            .part(wgsl_file!("lights/bindings.wgsl"))
            .part(("lights/kinds.wgsl (generated)", kinds_wgsl()))
            .part(wgsl_file!("lights/sample.wgsl"))
            .part(wgsl_file!("lights/lgh.wgsl"))
    }
}

/// The WGSL constant of kind `k`'s index: `LIGHT_KIND_` and its name.
pub(crate) fn kind_constant(k: SamplerKind) -> String {
    format!("LIGHT_KIND_{}", k.name().to_uppercase())
}

/// The kind predicates of `sample.wgsl`, generated from [`SamplerKind`]'s
/// (one list of which kind does what): each a test of
/// `light_params.kind` against the kinds for which the Rust predicate
/// holds.
pub fn kinds_wgsl() -> String {
    type Predicate = (&'static str, fn(SamplerKind) -> bool);
    let predicates: [Predicate; 5] = [
        ("light_uses_tree", SamplerKind::uses_tree),
        ("light_uses_bvh", SamplerKind::uses_bvh),
        ("light_uses_cut", SamplerKind::uses_cut),
        ("light_uses_cones", SamplerKind::uses_cones),
        ("light_substitutes_on", SamplerKind::stops_at_substitutes),
    ];
    let mut out = String::new();
    for (name, holds) in predicates {
        let kinds: Vec<String> = SamplerKind::ALL
            .into_iter()
            .filter(|&k| holds(k))
            .map(|k| format!("k == {}", kind_constant(k)))
            .collect();
        let test = if kinds.is_empty() {
            "false".to_string()
        } else {
            kinds.join(" || ")
        };
        out += &format!(
            "fn {name}() -> bool {{\n    let k = light_params.kind;\n    return {test};\n}}\n\n"
        );
    }
    out
}

/// The cut capacity of the shaders for cuts of `cut_size` nodes: the next
/// power of two (so scenes share a few pipelines), at most [`MAX_CUT`].
pub fn cut_capacity(cut_size: u32) -> u32 {
    cut_size.clamp(1, MAX_CUT).next_power_of_two().min(MAX_CUT)
}

/// One query of [`BatchSampler`] (`SampleQuery` in
/// `wgsl/lights/sample_batch.wgsl`): a shading point, its unit normal
/// facing the outgoing direction (zero: no normal), `u ∈ [0, 1)` and the
/// cut-sharing block whose cut it samples (the kinds with cuts; a new
/// [`GpuSamplerData`]'s cuts are all [root] until a cut pre-pass or
/// [`GpuSamplerData::write_cuts`] fills them).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct SampleQuery {
    pub p: [f32; 3],
    pub u: f32,
    pub n: [f32; 3],
    pub block: u32,
}

/// The kernel's raw answer to one query (`SampleAnswer` in
/// `wgsl/lights/sample_batch.wgsl`), which [`BatchSampler::sample`] turns
/// into a [`GpuPick`]: `light` as `LightPick.light`, pmf = `pmf_m·2^pmf_e`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct SampleAnswer {
    pub light: u32,
    pub pmf_m: f32,
    pub pmf_e: i32,
    pub _pad: u32,
}

/// What the GPU sampler picked for one [`SampleQuery`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum GpuPick {
    /// No light can contribute (or no lights).
    None,
    /// A light and the probability of picking it.
    Light { light: u32, pmf: f64 },
    /// `sst`: the substitute of tree node `node` and the probability of
    /// stopping there.
    Substitute { node: u32, pmf: f64 },
}

/// Runs the WGSL light samplers (`light_sample` of
/// `wgsl/lights/sample.wgsl`) on a batch of queries: the GPU side of a
/// sampler as a library call, to check a CPU sampler against it or to
/// study a sampler's choices (`examples/light_sampler.rs`).
pub struct BatchSampler {
    layout0: wgpu::BindGroupLayout,
    layout1: wgpu::BindGroupLayout,
    pipeline: wgpu::ComputePipeline,
}

impl BatchSampler {
    /// The kernel's WGSL: the samplers' and `lights/sample_batch.wgsl`.
    pub fn source() -> Wgsl {
        GpuSamplerData::wgsl().part(wgsl_file!("lights/sample_batch.wgsl"))
    }

    /// Group 0 of the kernel: the queries (read) and the answers.
    pub fn layout_entries() -> Vec<wgpu::BindGroupLayoutEntry> {
        vec![storage_entry(0, true), storage_entry(1, false)]
    }

    /// Compiles the kernel (one for every sampler kind: the kind is a
    /// uniform of [`GpuSamplerData`]).
    pub fn new(gpu: &Gpu) -> Result<BatchSampler> {
        let layout =
            |label, entries: &[wgpu::BindGroupLayoutEntry]| gpu.bind_group_layout(label, entries);
        let layout0 = layout("lights.batch.group0", &Self::layout_entries());
        let layout1 = layout("lights.batch.group1", &GpuSamplerData::layout_entries());
        let pipeline = gpu.compute_pipeline(
            "lights.batch",
            &Self::source(),
            "sample_batch",
            &[&layout0, &layout1],
        )?;
        Ok(BatchSampler {
            layout0,
            layout1,
            pipeline,
        })
    }

    /// One sample of `data`'s sampler per query, in query order.
    pub fn sample(
        &self,
        gpu: &Gpu,
        data: &GpuSamplerData,
        queries: &[SampleQuery],
    ) -> Result<Vec<GpuPick>> {
        if queries.is_empty() {
            return Ok(Vec::new());
        }
        let blocks = data.cuts.size() / 4 / data.params.cut_size.max(1) as u64;
        if data.kind.uses_cut() {
            if let Some(q) = queries.iter().find(|q| q.block as u64 >= blocks) {
                bail!(
                    "query block {} beyond the sampler's {blocks} cut blocks",
                    q.block
                );
            }
        }
        let answers = gpu.scoped("sampling a batch of lights", || {
            let qbuf = gpu.buffer_from("lights.batch.queries", queries, STORAGE)?;
            let abuf = gpu.buffer_zeroed(
                "lights.batch.answers",
                (queries.len() * size_of::<SampleAnswer>()) as u64,
                STORAGE,
            )?;
            let group0 = crate::gpu::shader::bind_buffers(
                gpu,
                "lights.batch.group0",
                &self.layout0,
                &[&qbuf, &abuf],
            );
            let group1 = gpu.device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("lights.batch.group1"),
                layout: &self.layout1,
                entries: &data.bind_group_entries(),
            });
            let mut encoder = gpu.device.create_command_encoder(&Default::default());
            {
                let mut pass = encoder.begin_compute_pass(&Default::default());
                pass.set_pipeline(&self.pipeline);
                pass.set_bind_group(0, &group0, &[]);
                pass.set_bind_group(1, &group1, &[]);
                let (gx, gy) = gpu.dispatch_dims((queries.len() as u32).div_ceil(64));
                pass.dispatch_workgroups(gx, gy, 1);
            }
            gpu.queue.submit([encoder.finish()]);
            gpu.read_buffer::<SampleAnswer>(&abuf, queries.len())
        })?;
        Ok(answers
            .iter()
            .map(|a| {
                let pmf = a.pmf_m as f64 * 2f64.powi(a.pmf_e);
                if a.light == NO_LIGHT {
                    GpuPick::None
                } else if data.kind.uses_substitute_tree()
                    && a.light & substitute::SUBSTITUTE_BIT != 0
                {
                    GpuPick::Substitute {
                        node: a.light & !substitute::SUBSTITUTE_BIT,
                        pmf,
                    }
                } else {
                    GpuPick::Light {
                        light: a.light,
                        pmf,
                    }
                }
            })
            .collect())
    }
}
