//! Many-light direct lighting: light samples chosen by a many-light
//! sampler ([`crate::lights`]; real-time stochastic lightcuts and its
//! baselines) — one per evaluation, or, for the kinds with cuts under
//! `cut_sampling = "subtrees"` (the default, the paper's estimator), one
//! from each subtree of the pixel's share of its block's cut, each divided
//! by its probability within its subtree and summed (n shadow rays for a
//! cut of n nodes; subtree 0 takes the evaluation's random numbers, subtree
//! j > 0 them rotated by its own random offset per pixel — uniform, so
//! every term stays unbiased, and stratified over the pixel's samples:
//! `ml_subtree_u`, `tree::cut::subtree_random`).
//!
//! Dimensions: 0–1 film point (raster units); 2 selects the light through
//! the sampler (`light_sample`, so MDAS adapts over the selection too);
//! 3–4, present only when the scene has emissive triangles, are a uniform
//! point on the selected triangle; with the `sst` sampler, 3–5 are the
//! Gaussian position of a selected substitute ([`crate::lights::substitute`]),
//! so MDAS adapts over them too. The `lgh` sampler sums over grid lights
//! instead ([`crate::lights::lgh`]): 2 stratifies its shadow picks, 3–5
//! jitter them, and with emissive triangles (not grid lights) 6 picks one
//! triangle uniformly and 7–8 a point on it. The estimator is
//! L_e(x) + ρ(x)/π · C(y) · cosθ_x · V(x, y) / pmf(light), with
//! C = I/d² for a point light, C = L_e·cosθ_y·area/d² for a triangle
//! (one-sided: 0 behind it) and C = I_0·cosθ_v/max(d², clamp²) for a VPL
//! (a cosine lobe about its normal, 0 behind it). The camera ray is a
//! pinhole ray at the frame time `time` of the `[integrand]` table;
//! shading normals (the geometric normal, or the mesh's interpolated vertex
//! normals) face the viewer (two-sided reflection) and are what the
//! sampler bounds use.
//!
//! # Frames
//!
//! [`ManyLight::new`] sets up one frame: the light primitives at the frame
//! time ([`crate::lights::scene_lights::light_prims`]), followed, when the
//! `[integrand]` asks for VPLs, by the VPLs traced from them on the GPU
//! ([`crate::lights::vpl`], profiler phase `many_light.vpl`; read back and
//! appended), are uploaded; the tree kinds build their perfect light tree
//! **on the GPU** ([`GpuLightTree`], with cones for `tree_cone`), `sst`
//! and `sst_nosub` their radix substitute tree **on the GPU**
//! ([`GpuRadixTree`], bit for bit the CPU oracle's), the
//! `unbalanced` kinds build their BVH on the CPU, `tree2` its two-level
//! tree (one bottom level per light group of
//! [`crate::lights::scene_lights::light_groups`], the VPLs as one more;
//! the groups' leaf orders sorted once per sequence in object space,
//! [`crate::lights::scene_lights::bottom_levels`]) with its bottom levels
//! gathered **on the GPU** ([`GpuTwoLevel`]) when every group keeps its
//! shape and there are no VPLs, else on the CPU, `power` its alias
//! table.
//! Kinds with cuts (`tree`, `tree_cone`, `unbalanced`,
//! `unbalanced_nocone`, `tree2`) then run
//! the cut-sharing pre-pass (paper §3.3): one invocation per k×k pixel
//! block picks a representative pixel at random (a hash of the block and
//! the frame number), traces its primary ray through the pixel centre and
//! stores `select_cut` of that shading point; every sample in the block
//! samples through that cut. A representative ray that hits nothing keeps
//! the cut [root]. The set-up times are in [`ManyLight::setup_times`];
//! integrators time only the evaluation.
//!
//! A sequence (`mdas render --frames`) keeps one `ManyLight` and calls
//! [`ManyLight::set_frame`] per frame: the lights, the light structure and
//! the cuts are made again, as the paper does every frame, into the same
//! buffers where their size cannot change; shaders, layouts and the
//! integrators' pipelines are reused.
//!
//! Interleaved sampling (paper §3.4, `interleave = m`, off by default):
//! pixel i of each m×m sub-block samples only the cut nodes
//! [⌊p·n/m²⌋, ⌊(p+1)·n/m²⌋) with p = (i + frame) mod m² (eq. 3 with the
//! per-frame rotation), and its estimate is scaled by m². Per pixel this is
//! biased (it estimates m² times its share of the lights); averaged over a
//! sub-block of equal lighting it is the whole cut's — the paper filters
//! the image afterwards, which mdas does not.

use super::ManyLightSpec;
use super::{scene_wgsl, Integrand};
use crate::accel::GpuScene;
use crate::film::Film;
use crate::gpu::buffer::STORAGE;
use crate::gpu::profiler::PhaseTimes;
use crate::gpu::shader::{storage_entry, Wgsl};
use crate::gpu::{Gpu, Profiler};
use crate::kernel_base::RAY_ITERATIONS;
use crate::lights::bvh;
use crate::lights::gpu_sampler::{
    cut_capacity, CutLayout, GpuSamplerData, TreeSource, FIRST_BINDING,
};
use crate::lights::lgh::gpu::GpuLgh;
use crate::lights::registry::SamplerKind;
use crate::lights::sampler::{CutSampling, Structure};
use crate::lights::scene_lights::{self, light_prims};
use crate::lights::substitute::gpu_build::GpuRadixTree;
use crate::lights::tree::cut::MAX_CUT;
use crate::lights::tree::gpu_build::GpuLightTree;
use crate::lights::two_level::gpu::GpuTwoLevel;
use crate::lights::two_level::BottomLevels;
use crate::lights::vpl::{self, VplGenerator};
use crate::lights::{LightPrim, KIND_TRIANGLE};
use crate::scene::Scene;
use crate::wgsl_file;
use anyhow::{bail, Context, Result};
use std::sync::Arc;

/// An upper bound on the loop iterations of one evaluation that draws one
/// light per subtree of its share of the cut (the kinds with cuts under
/// [`CutSampling::Subtrees`]) or `light_samples` > 1 lights (0 otherwise):
/// a typical ray's traversal for the camera ray and each shadow ray, and
/// per light a descent (and the cut lookups). A pixel's share holds at
/// most ⌈n/m²⌉ of the n nodes.
fn subtree_loop_iterations(spec: &ManyLightSpec) -> u32 {
    let (rays, per_subtree) =
        if spec.sampler.uses_cut() && spec.cut_sampling == CutSampling::Subtrees {
            let m2 = spec.interleave.max(1).pow(2) as u64;
            let rays = (spec.cut_size as u64).div_ceil(m2);
            (rays, bvh::MAX_DEPTH as u64 + 2 * MAX_CUT as u64)
        } else if spec.light_samples > 1 && spec.sampler.structure() != Structure::Grid {
            // `light_samples` picks, each a descent from the root.
            (spec.light_samples as u64, bvh::MAX_DEPTH as u64)
        } else {
            return 0;
        };
    (RAY_ITERATIONS * (rays + 1) + rays * per_subtree).min(u32::MAX as u64) as u32
}

/// Workgroup size of the cut pre-pass.
const CUT_WG: u32 = 64;

pub struct ManyLight {
    scene: Arc<GpuScene>,
    film: Film,
    kind: SamplerKind,
    /// The `[integrand]` table of the sequence's frame 0
    /// ([`ManyLight::new_at_frame`]).
    spec: ManyLightSpec,
    /// The current frame's lights: the scene's, then the VPLs.
    prims: Vec<LightPrim>,
    triangles: bool,
    sampler: GpuSamplerData,
    layout: wgpu::BindGroupLayout,
    bind_group: wgpu::BindGroup,
    setup: PhaseTimes,
    /// The GPU-built tree (its buffers are bound in `bind_group`); rebuilt
    /// in place for every frame.
    tree: Option<GpuLightTree>,
    /// `sst`'s radix substitute tree, built on the GPU into the buffers
    /// bound in `bind_group`; rebuilt in place for every frame.
    radix: Option<GpuRadixTree>,
    /// `tree2` gathered on the GPU (groups of a fixed shape, no VPLs).
    two_level: Option<GpuTwoLevel>,
    /// The VPL kernel, kept for the next frame.
    vpl: Option<VplGenerator>,
    /// The cut pre-pass's pipeline and group-0 layout, built at the first
    /// frame and reused.
    cut_pass: Option<(wgpu::ComputePipeline, wgpu::BindGroupLayout)>,
    /// `lgh`: the loop iterations of one evaluation.
    loop_iterations: u32,
    /// `tree2`: the bottom levels' leaf orders, sorted once for the
    /// sequence ([`BottomLevels`]).
    bottoms: Option<BottomLevels>,
}

/// The light structures of one frame ([`ManyLight::build_sampler`]).
struct Built {
    sampler: GpuSamplerData,
    tree: Option<GpuLightTree>,
    radix: Option<GpuRadixTree>,
    two_level: Option<GpuTwoLevel>,
    loop_iterations: u32,
    cpu_build_ms: Option<f64>,
}

/// The integrand's WGSL for sampler `kind`, with or without emissive
/// triangles (dimensions 3–4); `sst` (and `sst_perfect`) use dimensions
/// 3–5 for substitutes,
/// `lgh` sums over its grid lights (dimensions 2–5, and 6–8 for a
/// triangle, [`ManyLight::dims`]).
/// Every other kind shares one source: the kind, the frame time and the
/// frame number are uniforms (`LightParams`). Device-free, see
/// [`super::path::source`].
pub fn source(triangles: bool, kind: SamplerKind) -> Wgsl {
    source_for_cuts(triangles, kind, MAX_CUT)
}

/// [`source`] with the cut arrays sized for cuts of at most `capacity`
/// nodes ([`GpuSamplerData::wgsl_for_cuts`]).
pub fn source_for_cuts(triangles: bool, kind: SamplerKind, capacity: u32) -> Wgsl {
    scene_wgsl()
        .include(&GpuSamplerData::wgsl_for_cuts(capacity))
        .constant("ML_TRIANGLES", triangles as u32)
        .constant("ML_SUBSTITUTES", kind.stops_at_substitutes() as u32)
        .constant("ML_LGH", (kind.structure() == Structure::Grid) as u32)
        .part(wgsl_file!("shared/rng.wgsl"))
        .part(wgsl_file!("many_light.wgsl"))
}

/// Group 1 of the evaluation and of the cut pre-pass: the scene's bindings
/// 0–7, then the samplers' 16–21.
pub fn layout_entries() -> Vec<wgpu::BindGroupLayoutEntry> {
    let mut entries = GpuScene::layout_entries();
    entries.extend(GpuSamplerData::layout_entries());
    entries
}

/// The cut pre-pass over `blocks` blocks: the integrand's WGSL
/// ([`source`]) followed by `many_light_cuts.wgsl`.
pub fn cuts_source(integrand: Wgsl, blocks: u32) -> Wgsl {
    integrand
        .constant("CUT_WG", CUT_WG)
        .constant("CUT_BLOCKS", blocks)
        .include(&Wgsl::new().part(wgsl_file!("shared/rng.wgsl")))
        .part(wgsl_file!("many_light_cuts.wgsl"))
}

/// Group 0 of the cut pre-pass: the cut buffer it fills.
pub fn cuts_layout_entries() -> Vec<wgpu::BindGroupLayoutEntry> {
    vec![storage_entry(0, false)]
}

impl ManyLight {
    /// Sets up one frame of `scene` (its `[integrand]` table is `spec`) for
    /// rendering over `film`; `gpu_scene` must be the same scene's upload
    /// for the same film. The sampler is `spec.sampler`. Later frames of a
    /// sequence reuse everything built here: [`ManyLight::set_frame`].
    pub fn new(
        gpu: &Gpu,
        scene: &Scene,
        gpu_scene: Arc<GpuScene>,
        film: Film,
        spec: &ManyLightSpec,
    ) -> Result<ManyLight> {
        Self::new_at_frame(gpu, scene, gpu_scene, film, spec, 0)
    }

    /// [`ManyLight::new`] at frame `f` of the sequence `spec` starts
    /// (`spec.at_frame(f)`): the same image, but [`ManyLight::set_frame`]
    /// then counts frames from `spec`, so frame `g` of a sequence started
    /// here is bit-identical to frame `g` of one started at frame 0.
    pub fn new_at_frame(
        gpu: &Gpu,
        scene: &Scene,
        gpu_scene: Arc<GpuScene>,
        film: Film,
        base: &ManyLightSpec,
        f: u32,
    ) -> Result<ManyLight> {
        let spec = &base.at_frame(f);
        let kind = spec.sampler;
        let mut profiler = Profiler::new(gpu);
        let vpl = if spec.vpl.paths > 0 {
            Some(VplGenerator::new(gpu)?)
        } else {
            None
        };
        let prims = frame_lights(gpu, scene, &gpu_scene, spec, vpl.as_ref(), &mut profiler)?;
        let triangles = prims.iter().any(|l| l.kind == KIND_TRIANGLE);
        // tree2 sorts its bottom levels once per sequence, in object
        // space; the first frame's CPU build time includes it.
        let start = std::time::Instant::now();
        let bottoms =
            (kind.structure() == Structure::TwoLevel).then(|| scene_lights::bottom_levels(scene));
        let sort_ms = start.elapsed().as_secs_f64() * 1e3;
        let mut built =
            Self::build_sampler(gpu, spec, &prims, bottoms.as_ref(), film, &mut profiler)
                .map_err(|e| name_light_sets(e, scene, prims.len(), kind))?;
        if bottoms.is_some() {
            // On the GPU path the sort is the first frame's only CPU build.
            *built.cpu_build_ms.get_or_insert(0.0) += sort_ms;
        }
        let layout = gpu.bind_group_layout("many_light.group1", &layout_entries());
        let bind_group = Self::bind_group(gpu, &layout, &gpu_scene, &built.sampler);
        let mut this = ManyLight {
            scene: gpu_scene,
            film,
            kind,
            spec: base.clone(),
            prims,
            triangles,
            sampler: built.sampler,
            layout,
            bind_group,
            setup: PhaseTimes::default(),
            tree: built.tree,
            radix: built.radix,
            two_level: built.two_level,
            vpl,
            cut_pass: None,
            loop_iterations: built.loop_iterations,
            bottoms,
        };
        this.finish_frame(gpu, spec, profiler, built.cpu_build_ms)?;
        Ok(this)
    }

    /// Moves to another frame of the same scene: `spec.at_frame(f)` for
    /// the `spec` given to [`ManyLight::new`] or
    /// [`ManyLight::new_at_frame`] (time `time + f ·
    /// frame_duration`, frame number `frame + f`). The frame's lights are
    /// recomputed at its time (VPLs traced again), the light structure is
    /// built again and the cut pre-pass runs again, as the paper does once
    /// per frame. The shaders, the bind group layout and, for the kinds
    /// built on the GPU (`tree*`, `sst*`, `tree2` gathered on the
    /// GPU) and `uniform`, every buffer are reused, so an integrator's
    /// pipelines stay valid; the CPU-built kinds (`power`, `unbalanced*`,
    /// `tree2` with VPLs or orbiting light sets) and
    /// `lgh`, whose
    /// structures change size with the lights, upload new ones. The VPLs keep their seed
    /// (`vpl_seed`): they move with the lights, not with the frame number. The result is the image of
    /// `ManyLight::new` with `spec.at_frame(f)`, bit for bit.
    /// [`ManyLight::setup_times`] then holds this frame's set-up.
    pub fn set_frame(&mut self, gpu: &Gpu, scene: &Scene, f: u32) -> Result<()> {
        let spec = self.spec.at_frame(f);
        let mut profiler = Profiler::new(gpu);
        let prims = frame_lights(
            gpu,
            scene,
            &self.scene,
            &spec,
            self.vpl.as_ref(),
            &mut profiler,
        )?;
        if prims.len() != self.prims.len() {
            bail!(
                "frame {} has {} lights and the first frame {}: a sequence keeps its light count",
                spec.frame,
                prims.len(),
                self.prims.len()
            );
        }
        let mut cpu_build_ms = None;
        match &mut self.tree {
            Some(tree) => gpu.scoped("many_light set-up", || {
                gpu.queue
                    .write_buffer(&self.sampler.prims, 0, bytemuck::cast_slice(&prims));
                tree.build(gpu, &self.sampler.prims, prims.len() as u32, &mut profiler)
            })?,
            None if self.radix.is_some() => gpu.scoped("many_light set-up", || {
                gpu.queue
                    .write_buffer(&self.sampler.prims, 0, bytemuck::cast_slice(&prims));
                let radix = self.radix.as_mut().expect("matched");
                radix.build(gpu, &self.sampler.prims, prims.len() as u32, &mut profiler)
            })?,
            None if self.two_level.is_some() => gpu.scoped("many_light set-up", || {
                gpu.queue
                    .write_buffer(&self.sampler.prims, 0, bytemuck::cast_slice(&prims));
                let two_level = self.two_level.as_ref().expect("matched");
                two_level.build(gpu, &self.sampler.prims, &mut profiler)
            })?,
            None if self.kind.structure() == Structure::Uniform => {
                if !prims.is_empty() {
                    gpu.queue
                        .write_buffer(&self.sampler.prims, 0, bytemuck::cast_slice(&prims));
                }
            }
            None => {
                let built = Self::build_sampler(
                    gpu,
                    &spec,
                    &prims,
                    self.bottoms.as_ref(),
                    self.film,
                    &mut profiler,
                )?;
                self.bind_group = Self::bind_group(gpu, &self.layout, &self.scene, &built.sampler);
                self.sampler = built.sampler;
                self.loop_iterations = built.loop_iterations;
                cpu_build_ms = built.cpu_build_ms;
            }
        }
        self.prims = prims;
        self.finish_frame(gpu, &spec, profiler, cpu_build_ms)
    }

    /// Frame `spec`'s parameters, its cut pre-pass and its set-up times.
    fn finish_frame(
        &mut self,
        gpu: &Gpu,
        spec: &ManyLightSpec,
        mut profiler: Profiler,
        cpu_build_ms: Option<f64>,
    ) -> Result<()> {
        self.sampler.params.frame = spec.frame;
        self.sampler.params.light_samples = spec.light_samples;
        // set_time uploads the whole parameter block, the clamp with it.
        self.sampler.params.vpl_clamp2 = spec.vpl.clamp * spec.vpl.clamp;
        self.sampler.set_substitute_params(&spec.sst);
        self.sampler.set_time(gpu, spec.time);
        if self.kind.uses_cut() && !self.prims.is_empty() {
            // The shaders were built for frame 0's cut size (`wgsl`).
            if cut_capacity(spec.cut_size) > cut_capacity(self.spec.cut_size) {
                bail!(
                    "cut_size {} of this frame exceeds the sequence's {}",
                    spec.cut_size,
                    self.spec.cut_size
                );
            }
            let cuts =
                CutLayout::for_film(self.film.width, self.film.height, spec.block, spec.cut_size)
                    .sampled(spec.cut_sampling);
            self.select_cuts(gpu, cuts, &mut profiler)?;
        }
        self.setup = profiler.finish()?;
        if let Some(ms) = cpu_build_ms {
            self.setup.add("many_light.cpu_build", ms);
        }
        Ok(())
    }

    /// Builds the light structure of `spec.sampler` over one frame's
    /// lights, timed into `profiler` (GPU builds) or the returned
    /// `cpu_build_ms` (CPU builds, on the wall clock).
    fn build_sampler(
        gpu: &Gpu,
        spec: &ManyLightSpec,
        prims: &[LightPrim],
        bottoms: Option<&BottomLevels>,
        film: Film,
        profiler: &mut Profiler,
    ) -> Result<Built> {
        let kind = spec.sampler;
        let n = u32::try_from(prims.len()).context("more than 2^32 lights")?;
        let cuts = CutLayout::for_film(film.width, film.height, spec.block, spec.cut_size)
            .interleaved(spec.interleave, spec.frame)
            .sampled(spec.cut_sampling);
        gpu.scoped("many_light set-up", || {
            if kind.structure() == Structure::Grid {
                // The hierarchy is sized on the host and built on the GPU
                // from the sampler's copy of the lights.
                let h = GpuLgh::new(gpu, prims, &spec.lgh)?;
                let sampler =
                    GpuSamplerData::new(gpu, kind, prims, Some(TreeSource::Lgh(&h)), cuts)?;
                h.build(gpu, &sampler.prims, profiler)?;
                Ok(Built {
                    sampler,
                    tree: None,
                    radix: None,
                    two_level: None,
                    loop_iterations: h.loop_iterations().min(u32::MAX as u64) as u32,
                    cpu_build_ms: None,
                })
            } else if kind.builds_tree_on_gpu() && n > 0 {
                // The tree is built from the sampler's own copy of the
                // lights (one upload), into the buffers the sampler binds.
                let mut tree = if kind.uses_substitute_tree() {
                    GpuLightTree::with_substitutes(gpu, n)?
                } else {
                    GpuLightTree::new(gpu, n, kind.uses_cones())?
                };
                let sampler = GpuSamplerData::new(
                    gpu,
                    kind,
                    prims,
                    Some(TreeSource::PerfectGpu {
                        nodes: &tree.nodes,
                        leaf_of_light: &tree.leaf_of_light,
                        cones: tree.cones.as_ref(),
                        substitutes: tree.substitutes.as_ref(),
                    }),
                    cuts,
                )?;
                tree.build(gpu, &sampler.prims, n, profiler)?;
                Ok(Built {
                    sampler,
                    tree: Some(tree),
                    radix: None,
                    two_level: None,
                    loop_iterations: 0,
                    cpu_build_ms: None,
                })
            } else if kind.builds_radix_tree_on_gpu() && n > 0 {
                // sst's radix tree, as the perfect tree: from the
                // sampler's copy of the lights into the buffers it binds.
                let mut radix = GpuRadixTree::new(gpu, n)?;
                let sampler = GpuSamplerData::new(
                    gpu,
                    kind,
                    prims,
                    Some(TreeSource::RadixGpu(&radix)),
                    cuts,
                )?;
                radix.build(gpu, &sampler.prims, n, profiler)?;
                Ok(Built {
                    sampler,
                    tree: None,
                    radix: Some(radix),
                    two_level: None,
                    loop_iterations: 0,
                    cpu_build_ms: None,
                })
            } else if let Some(plan) = bottoms
                .filter(|b| {
                    kind.structure() == Structure::TwoLevel
                        && n > 0
                        && b.light_count() == prims.len()
                })
                .and_then(BottomLevels::gpu_plan)
            {
                // tree2 whose groups keep their shape and no VPLs: the
                // bottom levels gathered on the GPU every frame, the top
                // level on the host (GpuTwoLevel).
                let two_level = GpuTwoLevel::new(gpu, plan)?;
                let sampler = GpuSamplerData::new(
                    gpu,
                    kind,
                    prims,
                    Some(TreeSource::TwoLevelGpu(&two_level)),
                    cuts,
                )?;
                two_level.build(gpu, &sampler.prims, profiler)?;
                Ok(Built {
                    sampler,
                    tree: None,
                    radix: None,
                    two_level: Some(two_level),
                    loop_iterations: 0,
                    cpu_build_ms: None,
                })
            } else {
                // CPU-built structures (BVH, two-level tree, alias table)
                // are part of the set-up time, measured on the wall clock.
                let start = std::time::Instant::now();
                let sampler = if kind.structure() == Structure::TwoLevel && n > 0 {
                    // One bottom level per light group of the scene, and
                    // the frame's VPLs as one more.
                    let tree = bottoms
                        .expect("tree2 has its bottom levels")
                        .tree(prims)
                        .expect("n > 0 lights");
                    GpuSamplerData::new(gpu, kind, prims, Some(TreeSource::Bvh(&tree)), cuts)?
                } else {
                    GpuSamplerData::new(gpu, kind, prims, None, cuts)?
                };
                Ok(Built {
                    sampler,
                    tree: None,
                    radix: None,
                    two_level: None,
                    loop_iterations: 0,
                    cpu_build_ms: Some(start.elapsed().as_secs_f64() * 1e3),
                })
            }
        })
    }

    /// Group 1: the scene's bindings, then the sampler's.
    fn bind_group(
        gpu: &Gpu,
        layout: &wgpu::BindGroupLayout,
        scene: &GpuScene,
        sampler: &GpuSamplerData,
    ) -> wgpu::BindGroup {
        let mut e = scene.bind_group_entries();
        e.extend(sampler.bind_group_entries());
        gpu.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("many_light.group1"),
            layout,
            entries: &e,
        })
    }

    /// The cut-sharing pre-pass: fills the cut buffer, one cut per block.
    /// Its pipeline is built at the first frame and kept.
    fn select_cuts(&mut self, gpu: &Gpu, cuts: CutLayout, profiler: &mut Profiler) -> Result<()> {
        gpu.scoped("many_light cut selection", || {
            if self.cut_pass.is_none() {
                let layout0 =
                    gpu.bind_group_layout("many_light.cuts.group0", &cuts_layout_entries());
                let source = cuts_source(self.wgsl(), cuts.blocks());
                let pipeline = gpu.compute_pipeline(
                    "many_light.cuts",
                    &source,
                    "select_cuts",
                    &[&layout0, &self.layout],
                )?;
                self.cut_pass = Some((pipeline, layout0));
            }
            let (pipeline, layout0) = self.cut_pass.as_ref().expect("built above");
            // Group 1 as for sampling, except that the cut buffer (written
            // here through group 0) is replaced by a dummy at its binding.
            let dummy = gpu.buffer_zeroed("many_light.cuts.dummy", 4, STORAGE)?;
            let cut_binding = FIRST_BINDING + 4;
            let mut e = self.scene.bind_group_entries();
            e.extend(self.sampler.bind_group_entries().into_iter().map(|mut x| {
                if x.binding == cut_binding {
                    x.resource = dummy.as_entire_binding();
                }
                x
            }));
            let group1 = gpu.device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("many_light.cuts.group1"),
                layout: &self.layout,
                entries: &e,
            });
            let group0 = gpu.device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("many_light.cuts.group0"),
                layout: layout0,
                entries: &[wgpu::BindGroupEntry {
                    binding: 0,
                    resource: self.sampler.cuts.as_entire_binding(),
                }],
            });
            let (gx, gy) = gpu.dispatch_dims(cuts.blocks().div_ceil(CUT_WG));
            profiler.phase("many_light.cuts", |encoder, timestamps| {
                let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                    label: Some("many_light.cuts"),
                    timestamp_writes: timestamps,
                });
                pass.set_pipeline(pipeline);
                pass.set_bind_group(0, &group0, &[]);
                pass.set_bind_group(1, &group1, &[]);
                pass.dispatch_workgroups(gx, gy, 1);
            })
        })
    }

    pub fn sampler(&self) -> SamplerKind {
        self.kind
    }

    pub fn light_count(&self) -> u32 {
        self.prims.len() as u32
    }

    /// The sampler's buffers (bindings 16–24) as the frame bound them.
    pub fn sampler_data(&self) -> &GpuSamplerData {
        &self.sampler
    }

    /// The frame's light list as the sampler sees it: the scene's lights at
    /// the frame time, then the frame's VPLs (light id = index).
    pub fn lights(&self) -> &[LightPrim] {
        &self.prims
    }

    /// GPU (or wall-clock) times of the frame's set-up: the light tree's
    /// build phases (`light_tree.*`), CPU builds and the cut pre-pass.
    pub fn setup_times(&self) -> &PhaseTimes {
        &self.setup
    }
}

/// One frame's light list: the scene's lights at `spec.time`, then, when
/// `spec` asks for VPLs, the VPLs traced from them on the GPU (profiler
/// phase `many_light.vpl`; read back and appended).
fn frame_lights(
    gpu: &Gpu,
    scene: &Scene,
    gpu_scene: &GpuScene,
    spec: &ManyLightSpec,
    generator: Option<&VplGenerator>,
    profiler: &mut Profiler,
) -> Result<Vec<LightPrim>> {
    let mut prims = light_prims(scene, spec.time);
    if let Some(generator) = generator {
        let sources = vpl::sources(scene, &prims);
        let sphere = vpl::scene_sphere(scene, spec.time);
        let vpls = generator.generate(
            gpu, gpu_scene, &sources, sphere, &spec.vpl, spec.time, profiler,
        )?;
        prims.extend(vpls);
    }
    Ok(prims)
}

impl Integrand for ManyLight {
    fn name(&self) -> &'static str {
        "many_light"
    }

    fn dims(&self) -> u32 {
        if self.kind.structure() == Structure::Grid {
            if self.triangles {
                9
            } else {
                6
            }
        } else if self.kind.stops_at_substitutes() {
            6
        } else if self.triangles {
            5
        } else {
            3
        }
    }

    fn film(&self) -> Film {
        self.film
    }

    fn loop_iterations(&self) -> u32 {
        self.loop_iterations
            .max(subtree_loop_iterations(&self.spec))
    }

    fn wgsl(&self) -> Wgsl {
        source_for_cuts(self.triangles, self.kind, cut_capacity(self.spec.cut_size))
    }

    fn layout(&self) -> Option<&wgpu::BindGroupLayout> {
        Some(&self.layout)
    }

    fn bind_group(&self) -> Option<&wgpu::BindGroup> {
        Some(&self.bind_group)
    }
}

/// An adapter-limit error of the light structure names the light sets
/// when they sized it (issue 54 item 8): the buffer's label alone does
/// not say which key to lower. Errors that already name their
/// `[integrand]` key (VPLs, the grid hierarchy's levels) pass unchanged.
fn name_light_sets(
    e: anyhow::Error,
    scene: &Scene,
    lights: usize,
    kind: SamplerKind,
) -> anyhow::Error {
    let from_sets: usize = scene.point_light_sets.iter().map(|s| s.lights.len()).sum();
    let over_limit = e
        .chain()
        .any(|c| c.to_string().contains("per storage buffer"));
    let named = e.chain().any(|c| c.to_string().starts_with("[integrand]"));
    if from_sets == 0 || !over_limit || named {
        return e;
    }
    e.context(format!(
        "[[light_set]]: the scene's light sets generate {from_sets} lights ({lights} lights in \
         all), more than sampler '{kind}' fits on this adapter; lower a light set's count \
         (resolution for a grid)"
    ))
}
