//! Parallel multidimensional adaptive sampling (Meister & Hachisuka 2022,
//! "Lightweight Multidimensional Adaptive Sampling for GPU Ray Tracing")
//! as WGSL compute kernels.
//!
//! The domain is the film, scaled to [0, sf·W) × [0, sf·H) (`scale_factor`,
//! §5.1), times [0, 1)^(d−2). It is partitioned into leaves (axis-aligned
//! boxes, no tree stored, §4) that each hold a few samples; the image is the
//! piecewise-constant approximation integrated over every pixel (eq. 7), or,
//! with `reconstruction = "pixel"` ([`Reconstruction::Pixel`], not in the
//! paper), each pixel's part of a leaf estimated from the leaf's samples in
//! that pixel, pulled toward the leaf mean, so that a leaf wider than a
//! pixel does not spread one value across a film-space edge inside it;
//! with `"sampled"` ([`Reconstruction::Sampled`], also not in the paper) a
//! leaf's part of a pixel where it has no sample counts only where no leaf
//! sampled that pixel; with `"shrinkage"` ([`Reconstruction::Shrinkage`],
//! the default of a scene without a table, not in the paper) as
//! `"sampled"`, each pixel's estimate shrunk toward the leaf mean by a κ
//! the leaf's own samples give (an analysis of variance by pixel).
//!
//! | phase (`Render::times`) | kernel | paper |
//! |---|---|---|
//! | `initial` | [`initial`]: Morton grid, l stratified samples per cell | §4.1 |
//! | `evaluate` | [`evaluate`]: the integrand at new samples only | — |
//! | `error` | [`error`]: contrast error of changed leaves, E_max | eq. 4, §4.2 |
//! | `adaptive` | [`adapt`] + [`scan`] + [`plan`]: selection, best candidate, median split; the loop's bookkeeping | §4.2 |
//! | `reconstruction` | [`stats`] + [`reconstruct`]: max \|f\| and non-finite count, exact-overlap splatting (box or per pixel), fixed point | eq. 7, §4.3 |
//!
//! The driver ([`Mdas::render`]) runs initial + evaluate, then iterations of
//! error → adaptive → evaluate until the budget N = round(spp × pixels) is
//! reached (the last iteration is trimmed to exactly N), no leaf can be
//! selected (all collapsed), or [`Mdas::max_iterations`] have run; then
//! reconstruction. `Render::samples` is the achieved count.
//!
//! The loop runs on the GPU: the leaf and sample counts, the iteration and
//! the range to evaluate live in a state buffer that [`plan`] advances after
//! every iteration, writing the next dispatches' indirect arguments (zero
//! once done). The host records iterations in submissions of 2, 4, 8, …
//! up to 32 and reads the state once per submission (progress and the stop
//! test), never inside an iteration; with an observer
//! ([`Mdas::render_observed`]) it submits after every error pass instead.
//! [`Mdas::last_pass_times`] splits the adaptive phase into its passes and
//! evaluate into the initial samples' and the adaptive ones'.
//! [`Mdas::render_with_density`] also returns the samples per pixel of the
//! final leaves (each leaf's samples spread over the pixels its film box
//! overlaps, by overlap area; [`debug::Snapshot::sample_density`]), for the
//! density maps of `mdas compare`.
//!
//! ## Parameters (`[mdas]` table, [`MdasParams`])
//!
//! One registry, [`params::PARAMS`], names every parameter with its range,
//! the default of a scene without the key and a doc line; `mdas render
//! --help` prints them, and `docs/scene-format.md` has the table (checked
//! against the registry by `params`' tests). The initial grid (b, e, l) is
//! chosen per render from the film and budget when a scene gives none of
//! its keys ([`params::auto_grid`]).
//!
//! Integrands of 3..=16 dimensions are supported.
//!
//! ## Storage (bytes per sample)
//!
//! Coordinates are 16-bit quanta relative to the sample's Morton cell (a
//! cell is 2^16 quanta wide on every axis, so a film axis with b + e = 8 is
//! resolved to 2⁻²⁴ of its side, as fine as f32), and a leaf is stored only
//! as its cell, its box in those quanta, its samples' indices and its
//! error:
//!
//! * sample: ⌈d/2⌉ words of coordinates + 3 f32 value = 20 B at 3D and 4D,
//!   28 B at 8D;
//! * leaf: cell + header (slot 0, 4-bit count, collapsed bit) + error,
//!   the words every pass reads for every leaf, and in a second buffer,
//!   read only for the leaves that change, d box words (lo | hi) and
//!   sample slots 1 … m − 1 = (2 + d + m)·4 B: 40 B at 4D and m = 4, 56 B
//!   at 8D. Slot m (m + 1 samples) occurs only in a trimmed last
//!   iteration, after which no error is computed: it lives in the error
//!   word;
//! * at most L ≤ C + (N − C·min(l, h))/h leaves, h = ⌊(m+1)/2⌋ ([`config`]);
//!   with the paper's l = m = 4 that is N/2: 20 + 20 = 40 B per sample at
//!   4D (38 B with the linked sample lists this replaced, which cost a
//!   chain of dependent loads per leaf, see below); with l = 1 the leaf
//!   share is larger (up to 60 B when N = C);
//! * per pixel 32 B of fixed-point accumulators, placed in the coordinate
//!   buffer (dead once the last sample is placed) when it is large enough
//!   (spp·⌈d/2⌉ ≥ 8), else allocated; plus 8 B per 256 leaves of scan
//!   totals and 184 B of counters, state, indirect arguments and
//!   parameters.
//!
//! `Render::gpu_bytes` reports the total actually allocated.
//!
//! The four arrays that grow with the budget (leaves, boxes, sample
//! coordinates, values) are paged ([`pages::Pages`]): while one fits the
//! adapter's largest storage binding it is one binding, indexed directly;
//! beyond that it is split into power-of-two pages, one binding each,
//! reached through generated accessors. So the capacity is the device's
//! memory and its storage buffers per shader stage (lavapipe: 32, the
//! integrand's included), not its largest binding (lavapipe: 128 MiB,
//! which held `cornell_pt` at 1024² to 8 spp; it now takes 48).
//!
//! ## Work packing in the leaf passes (issue 10)
//!
//! The error, count and apply passes run one invocation per leaf, but only
//! some leaves have work: the changed (DIRTY) ones in error, the selected
//! ones in count and apply. Each pass lists those leaves of its workgroup
//! in workgroup memory and the first invocations take one listed leaf
//! each, so the costly part runs on packed invocations rather than on
//! scattered lanes of every SIMD group or warp. Lists built with
//! workgroup atomics have no fixed order; it changes nothing, because what
//! a listed leaf computes depends on the leaf alone and the workgroup's
//! totals (selected, splits, the error maximum) are order-independent,
//! while slots still come from the deterministic scan in leaf order. A
//! leaf's sample indices are stored inline in its record (slot 0 in the
//! header, slots 1 … m after its box), so a pass loads them and
//! then the samples with independent loads, into arrays indexed only in
//! loops of constant length (registers, not memory); a linked list of
//! samples cost one dependent load per sample.
//!
//! ## Departures from the reference CUDA code (issue #3)
//!
//! Errors are recomputed after every insertion (a changed leaf is marked
//! DIRTY); NaN/Inf samples are counted and excluded (error, E_max, means,
//! reconstruction) on their bits; capacities are checked before any work
//! and iterations are capped; the last iteration is trimmed to the budget;
//! random numbers are hashes of (leaf, iteration, stream, seed); allocation
//! is a deterministic reduce-then-scan and reconstruction a fixed-point
//! integer sum, so a seed gives the same bits on a given adapter; a leaf
//! that cannot be split at its object median (all samples in one quantum)
//! is marked collapsed and is never selected again.
//!
//! ## Bias (issue 11; BENCHMARKS.md, "MDAS's bias against its variance gain")
//!
//! MDAS decides where to sample from the sample values, and a leaf's
//! estimate is the mean of the samples it holds, so it is biased (Kirk &
//! Arvo 1991), dark on path tracing: a lucky bright sample draws more
//! samples around itself and is diluted, while the leaves whose samples
//! missed keep their dark estimates. Three decisions look at values or
//! at the samples' positions, and each adds its part (measured on
//! `cornell_pt`, 1/8 scale, 32 spp):
//!
//! * the selection (E/E_max)^α ≥ ξ: −0.5 % … −5.9 % for α = 1/64 … 1 at
//!   ε = 0.01; ε = 1 (selection closer to leaf volume) cuts it 2–4×;
//! * the split axis under `split = "contrast"`: −0.6 % at α = 0, because
//!   a lone bright sample always lands on the side with fewer samples;
//!   `split = "trimmed"` ([`SplitRule::Trimmed`]) leaves the leaf's most
//!   outlying sample out of that choice, and the bias goes to −0.04 %;
//! * best-candidate placement (new samples far from the old ones, so not
//!   uniform in the leaf): −0.15 %.
//!
//! MDAS-uniform (α = 0, one candidate, the extent rule) decides nothing
//! from values and is unbiased within its interval; `tests/mdas_bias.rs`
//! pins these on closed-form cases over seeds.

pub mod adapt;
pub mod config;
pub mod cpu_oracle;
pub mod debug;
pub mod error;
pub mod evaluate;
pub mod gpu_params;
pub mod initial;
pub mod morton;
pub mod pages;
pub mod params;
pub mod plan;
pub mod reconstruct;
mod run;
pub mod scan;
pub mod stats;
mod words;

use super::{Integrator, Render};
use crate::gpu::buffer::{Readback, STORAGE};
use crate::gpu::profiler::{PhaseTimes, Profiler};
use crate::gpu::shader::Wgsl;
use crate::gpu::Gpu;
use crate::integrand::Integrand;
use anyhow::Result;
use config::Config;
use debug::Snapshot;
use gpu_params::{eval_min_groups, GpuParams, Grid};
pub use params::{
    validate, InitialOffsets, MdasParams, ParamError, Reconstruction, SplitRule, PARAMS,
};
pub(crate) use words::{counter, state};

/// Iterations after which a render stops even below its budget.
pub const MAX_ITERATIONS_DEFAULT: u32 = 1024;

/// Iterations recorded into the first submission of the loop; each later
/// submission records twice as many, up to [`MAX_BATCH`]. Iterations
/// recorded past the end dispatch zero workgroups ([`plan`]).
const FIRST_BATCH: u32 = 2;
const MAX_BATCH: u32 = 32;

/// The MDAS integrator.
pub struct Mdas {
    params: MdasParams,
    max_iterations: u32,
    /// Cap on a page of the paged arrays (default: the adapter's largest
    /// storage binding).
    max_page_bytes: Option<u64>,
    /// Override of [`Config::eval_per_invocation`].
    eval_per_invocation: Option<u32>,
    /// Override of [`gpu_params::eval_min_groups`].
    eval_min_groups: Option<u32>,
    /// Override of [`Config::unroll_loops`].
    unroll_loops: Option<bool>,
    /// Statistics of the last render.
    last: Option<RunStats>,
    /// Its GPU times with the parts of phases apart ("adaptive/count").
    last_passes: Option<PhaseTimes>,
    progress: Option<Progress>,
}

/// Progress callback: (samples taken, budget), called after every
/// submission of iterations (the driver reads the state then anyway).
pub type Progress = Box<dyn FnMut(u64, u64)>;

/// What a render did besides its image.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RunStats {
    pub iterations: u32,
    pub leaves: u32,
    pub collapsed: u32,
    pub budget: u32,
    pub initial_samples: u32,
}

#[derive(Clone)]
struct Pipelines {
    initial: wgpu::ComputePipeline,
    error: wgpu::ComputePipeline,
    count: wgpu::ComputePipeline,
    scan: wgpu::ComputePipeline,
    apply: wgpu::ComputePipeline,
    prime: wgpu::ComputePipeline,
    plan: wgpu::ComputePipeline,
    evaluate: wgpu::ComputePipeline,
    stats: wgpu::ComputePipeline,
    fixed_scale: wgpu::ComputePipeline,
    reconstruct: wgpu::ComputePipeline,
}

/// Pipelines, bind group 0 and the indirect arguments of one render.
pub struct Kernels {
    pipes: Pipelines,
    group0: wgpu::BindGroup,
    /// Indirect dispatch arguments ([`plan`]): workgroups over the leaves,
    /// then over the samples to evaluate.
    args: wgpu::Buffer,
    /// `args` as storage, for plan.wgsl (bind group 1).
    args_group: wgpu::BindGroup,
}

/// The buffers of one render.
struct Buffers {
    params: wgpu::Buffer,
    /// The pages of each paged array (`pages::Pages`).
    leaves: Vec<wgpu::Buffer>,
    boxes: Vec<wgpu::Buffer>,
    samples: Vec<wgpu::Buffer>,
    values: Vec<wgpu::Buffer>,
    counters: wgpu::Buffer,
    state: wgpu::Buffer,
    accum: wgpu::Buffer,
}

impl Mdas {
    /// Validates everything that does not depend on the integrand.
    pub fn new(params: MdasParams) -> Result<Mdas> {
        validate(&params)?;
        Ok(Mdas {
            params,
            max_iterations: MAX_ITERATIONS_DEFAULT,
            max_page_bytes: None,
            eval_per_invocation: None,
            eval_min_groups: None,
            unroll_loops: None,
            last: None,
            last_passes: None,
            progress: None,
        })
    }

    pub fn params(&self) -> &MdasParams {
        &self.params
    }

    /// Changes the budget (samples per pixel) and keeps the compiled
    /// pipelines, which do not depend on it: a budget search or a sweep
    /// compiles them once.
    pub fn set_spp(&mut self, spp: f32) -> Result<()> {
        let params = MdasParams { spp, ..self.params };
        validate(&params)?;
        self.params = params;
        Ok(())
    }

    /// Changes the seed and keeps the compiled pipelines (the seed is a
    /// uniform): renders of one setting over several seeds compile once.
    pub fn set_seed(&mut self, seed: u32) {
        self.params.seed = seed;
    }

    /// Caps the number of adaptive iterations (default
    /// [`MAX_ITERATIONS_DEFAULT`]); a render that hits it stops below its
    /// budget and reports the samples it took.
    pub fn with_max_iterations(mut self, n: u32) -> Self {
        self.max_iterations = n.max(1);
        self
    }

    /// Splits the arrays that grow with the budget into pages of at most
    /// `bytes` (rounded down to a power of two) even where the adapter
    /// would bind them whole: the paged kernels then run on small renders
    /// (tests compare them with unpaged renders bit for bit).
    pub fn with_max_page_bytes(mut self, bytes: u64) -> Self {
        self.max_page_bytes = Some(bytes);
        self
    }

    /// Reports (samples, budget) after every iteration.
    pub fn with_progress(mut self, progress: Progress) -> Self {
        self.progress = Some(progress);
        self
    }

    pub fn max_iterations(&self) -> u32 {
        self.max_iterations
    }

    /// Iterations, leaves and collapsed leaves of the last render.
    pub fn last_stats(&self) -> Option<RunStats> {
        self.last
    }

    /// The last render's GPU times with the parts of phases apart:
    /// "adaptive/count", "adaptive/scan", "adaptive/apply" (apply and the
    /// GPU loop's bookkeeping), and "evaluate/initial" (the grid's
    /// samples), "evaluate/adaptive" (every iteration's); `Render::times`
    /// folds them into "adaptive" and "evaluate".
    pub fn last_pass_times(&self) -> Option<&PhaseTimes> {
        self.last_passes.as_ref()
    }

    /// The derived sizes a render of `integrand` would use, or the error
    /// that makes it impossible (no GPU work), with every array on one
    /// binding: [`Mdas::config_for`] pages them for an adapter and checks
    /// its limits, as a render does.
    pub fn config(&self, integrand: &dyn Integrand) -> Result<Config> {
        Config::new(
            self.params,
            integrand.dims(),
            integrand.film(),
            self.max_iterations,
        )
    }

    /// The configuration a render of `integrand` on `gpu` uses: paged
    /// for the adapter's limits and checked against them.
    pub fn config_for(&self, gpu: &Gpu, integrand: &dyn Integrand) -> Result<Config> {
        let mut cfg = self
            .config(integrand)?
            .for_limits(&gpu.limits, self.max_page_bytes)?;
        cfg.eval_per_invocation = super::halton::within_loop_budget(
            self.eval_per_invocation
                .unwrap_or_else(|| super::halton::default_samples_per_invocation(gpu)),
            integrand,
        );
        cfg.unroll_loops = self
            .unroll_loops
            .unwrap_or(gpu.info.device_type != wgpu::DeviceType::Cpu);
        Ok(cfg)
    }

    /// Aims every evaluate dispatch at `n` workgroups or more (fewer
    /// samples per invocation where needed) instead of the adapter's
    /// default ([`gpu_params::eval_min_groups`]); the image is the same.
    pub fn with_eval_min_groups(mut self, n: u32) -> Self {
        self.eval_min_groups = Some(n.max(1));
        self
    }

    /// Lets the compiler unroll the count pass's loops, or not, instead of
    /// the adapter's default ([`Config::unroll_loops`]); the image is the
    /// same.
    pub fn with_unrolled_loops(mut self, unroll: bool) -> Self {
        self.unroll_loops = Some(unroll);
        self
    }

    /// Evaluates at most `n` samples per invocation in the evaluate pass
    /// instead of the adapter's default ([`Config::eval_per_invocation`]);
    /// the image is the same.
    pub fn with_eval_per_invocation(mut self, n: u32) -> Self {
        self.eval_per_invocation = Some(n.max(1));
        self
    }

    /// Group 0's layout for `cfg`'s pages (one per page count: [`Gpu`]
    /// keeps layouts).
    fn layout(gpu: &Gpu, cfg: &Config) -> wgpu::BindGroupLayout {
        let entries = gpu_params::layout_entries(cfg.pages.extra());
        gpu.bind_group_layout("mdas.mdas.layout", &entries)
    }

    fn args_layout(gpu: &Gpu) -> wgpu::BindGroupLayout {
        gpu.bind_group_layout("mdas.mdas.args.layout", &gpu_params::args_layout_entries())
    }

    /// The kernels for `cfg` and `integrand`, built once per process
    /// ([`Gpu::compute_pipeline`] keeps them).
    fn pipelines(gpu: &Gpu, cfg: &Config, integrand: &dyn Integrand) -> Result<Pipelines> {
        let layout = Self::layout(gpu, cfg);
        let args_layout = Self::args_layout(gpu);
        let base = cfg.base_wgsl();
        let eval_source = evaluate::source(&base, integrand.wgsl());
        let own = |label: &str, source: &Wgsl, entry: &str| {
            gpu.compute_pipeline(label, source, entry, &[&layout])
        };
        let adapt_source = adapt::source(&base);
        let plan_source = plan::source(&base);
        let stats_source = stats::source(&base);
        let with_args = |label: &str, entry: &str| {
            gpu.compute_pipeline(label, &plan_source, entry, &[&layout, &args_layout])
        };
        let p = Pipelines {
            initial: own("mdas.mdas.initial", &initial::source(&base), "initial")?,
            error: own("mdas.mdas.error", &error::source(&base), "error")?,
            count: own("mdas.mdas.adapt.count", &adapt_source, "count")?,
            scan: own("mdas.mdas.scan", &scan::source(&base), "scan")?,
            apply: own("mdas.mdas.adapt.apply", &adapt_source, "apply")?,
            prime: with_args("mdas.mdas.plan.prime", "prime")?,
            plan: with_args("mdas.mdas.plan", "plan")?,
            stats: own("mdas.mdas.stats", &stats_source, "stats")?,
            fixed_scale: own("mdas.mdas.stats.fixed_scale", &stats_source, "fixed_scale")?,
            // The one kernel with the integrand's buffers on top of the
            // pages: the first to exceed the adapter's storage buffers.
            evaluate: gpu
                .compute_pipeline(
                    &format!("mdas.mdas.evaluate[{}]", integrand.name()),
                    &eval_source,
                    "evaluate",
                    &crate::integrand::kernel_layouts(&layout, integrand),
                )
                .map_err(|e| {
                    if cfg.pages.extra() == 0 {
                        return e;
                    }
                    let own = pages::BASE_STORAGE_BINDINGS + cfg.pages.extra();
                    e.context(format!(
                        "MDAS capacity: {} samples need {own} storage buffers ({} pages beyond one per array) \
                         and the integrand '{}' binds its own on top; this adapter allows {} per shader stage: \
                         reduce the resolution or spp",
                        cfg.budget,
                        cfg.pages.extra(),
                        integrand.name(),
                        gpu.limits.max_storage_buffers_per_shader_stage
                    ))
                })?,
            reconstruct: own(
                "mdas.mdas.reconstruct",
                &reconstruct::source(&base),
                "reconstruct",
            )?,
        };
        Ok(p)
    }

    /// Renders like [`Integrator::render`], handing `observe` a read-back
    /// [`Snapshot`] after every error pass and one after the last
    /// iteration (for invariant and oracle tests; slow).
    #[doc(hidden)]
    pub fn render_observed(
        &mut self,
        gpu: &Gpu,
        integrand: &dyn Integrand,
        observe: &mut dyn FnMut(&Snapshot),
    ) -> Result<Render> {
        self.run(gpu, integrand, Some(observe), false)
    }

    /// Renders like [`Integrator::render`] and also returns the per-pixel
    /// sample density of the final leaves ([`Snapshot::sample_density`],
    /// row-major, samples per pixel). Reads the final state back once, so
    /// use it for figures, not for timing.
    pub fn render_with_density(
        &mut self,
        gpu: &Gpu,
        integrand: &dyn Integrand,
    ) -> Result<(Render, Vec<f32>)> {
        let mut density = Vec::new();
        let render = {
            let mut observe = |s: &Snapshot| density = s.sample_density();
            self.run(gpu, integrand, Some(&mut observe), true)?
        };
        Ok((render, density))
    }
}

impl Integrator for Mdas {
    fn name(&self) -> &'static str {
        "mdas"
    }

    fn render(&mut self, gpu: &Gpu, integrand: &dyn Integrand) -> Result<Render> {
        self.run(gpu, integrand, None, false)
    }
}
