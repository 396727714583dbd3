//! Halton quasi-Monte Carlo integrator — the baseline MDAS is compared to.
//!
//! Sample `i` of a pixel has coordinates Φ_{b_k}(i) in dimension k, with
//! b_k the k-th prime (2, 3, 5, …, 53: up to [`MAX_DIMS`] dimensions),
//! each toroidally shifted (Cranley–Patterson rotation) by a hash of
//! (pixel, k, seed). Dimensions 0–1 place the film point inside the pixel;
//! the pixel value is the mean of the finite samples with indices 0..spp.
//!
//! Radical inverses are computed in exact integer arithmetic: the base-b
//! digits of the 32-bit index are reversed into two integers whose
//! denominators b^n fit in 32 bits, and only the final quotient is formed in
//! f32 (a few roundings, ≤ 3·2⁻²⁴ absolute error; correct for every u32
//! index — unlike digit-by-digit float accumulation, which drifts).
//!
//! Work is split so that no invocation loops long (lavapipe silently ends a
//! shader's loops after 65,535 iterations): each dispatch evaluates
//! `samples_per_invocation` samples per (pixel, slot) invocation and writes
//! a partial sum per slot; an accumulate kernel adds the slots, in order,
//! into a Kahan-compensated f32 sum per pixel. No atomics: the image is a
//! deterministic function of (integrand, spp, seed, samples per invocation)
//! on a given adapter.
//!
//! Samples per invocation ([`Halton::with_samples_per_invocation`]): a GPU
//! takes one, in a kernel with no loop around the integrand
//! (`evaluate_single`); a CPU driver takes up to [`SAMPLES_PER_INVOCATION`]
//! in a loop. On an H200 (2026-12-04, BENCHMARKS.md) the loop of 8 made
//! Halton's samples 1.2–2.2× slower on the paper's scenes and 2.4×
//! (uniform light picks) to 3.4× (light-tree walks) slower on
//! `cornell_lights` than one sample per invocation without the loop; on
//! lavapipe an invocation of one sample costs about as much as one of
//! eight.
//!
//! Phases (equal-time accounting, docs/conventions.md): `evaluate` (tracing and
//! shading) and `accumulate`.

use super::{Integrator, Render};
use crate::gpu::profiler::Profiler;
use crate::gpu::shader::{storage_entry, uniform_entry, Wgsl};
use crate::gpu::{buffer::STORAGE, Gpu};
use crate::integrand::{Integrand, MAX_DIMS};
use crate::wgsl_file;
use anyhow::{bail, Result};

/// Samples one invocation evaluates per dispatch: bounds per-invocation
/// loop counts (each sample traces a couple of rays).
const SAMPLES_PER_INVOCATION: u32 = 8;
/// Loop iterations one invocation may run (lavapipe's cap is 65,535):
/// an integrand that states its [`Integrand::loop_iterations`] gets
/// `LOOP_BUDGET / iterations` samples per invocation (at least 1, at most
/// [`SAMPLES_PER_INVOCATION`]).
pub const LOOP_BUDGET: u32 = 60_000;
/// Target invocations per dispatch (pixels × slots).
const TARGET_INVOCATIONS: u64 = 1 << 20;
/// Chunks between progress reports (each report waits for the GPU).
const PROGRESS_EVERY: u32 = 8;
const WORKGROUP_SIZE: u32 = 64;
/// Uniform-buffer dynamic offsets must be multiples of this (WebGPU minimum).
const PARAMS_STRIDE: u64 = 256;

/// One chunk's uniform, `HaltonParams` in `wgsl/halton.wgsl` (public for
/// `tests/shader_interfaces.rs`, which compares the two layouts).
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub struct HaltonParams {
    pub width: u32,
    pub height: u32,
    pub dims: u32,
    pub seed: u32,
    /// One past the last sample index of the render.
    pub spp: u32,
    pub first_index: u32,
    pub samples_per_invocation: u32,
    pub slots: u32,
    pub row_invocations: u32,
    pub _pad: [u32; 3],
}

/// Samples an invocation evaluates in a loop by default on `gpu`:
/// [`SAMPLES_PER_INVOCATION`] on a CPU adapter (lavapipe), whose cost per
/// invocation is about that of eight samples, and 1 on a GPU, which wants
/// no loop around the integrand (module docs). MDAS's evaluate pass takes
/// the same ([`crate::integrator::mdas::config::Config::eval_per_invocation`]).
pub fn default_samples_per_invocation(gpu: &Gpu) -> u32 {
    if gpu.info.device_type == wgpu::DeviceType::Cpu {
        SAMPLES_PER_INVOCATION
    } else {
        1
    }
}

/// `n` lowered so that n samples of `integrand` stay within
/// [`LOOP_BUDGET`] loop iterations (its [`Integrand::loop_iterations`]).
pub fn within_loop_budget(n: u32, integrand: &dyn Integrand) -> u32 {
    match integrand.loop_iterations() {
        0 => n.max(1),
        iterations => (LOOP_BUDGET / iterations).clamp(1, n.max(1)),
    }
}

/// Progress callback: (samples per pixel done, spp).
pub type Progress = Box<dyn FnMut(u32, u32)>;

pub struct Halton {
    pub spp: u32,
    pub seed: u32,
    /// Index of the first sample of each pixel: the render takes samples
    /// `first..first + spp` of the sequence ([`Halton::with_first_sample`]).
    pub first: u32,
    /// Samples per invocation: `None` chooses by adapter (module docs).
    per_invocation: Option<u32>,
    progress: Option<Progress>,
}

impl Halton {
    pub fn new(spp: u32, seed: u32) -> Self {
        Halton {
            spp,
            seed,
            first: 0,
            per_invocation: None,
            progress: None,
        }
    }

    /// Evaluates at most `n` samples per invocation (1: the loop-free
    /// kernel) instead of the adapter's default (module docs); an
    /// integrand's [`Integrand::loop_iterations`] can lower it further.
    /// The samples are the same; only the order of their f32 sums changes.
    pub fn with_samples_per_invocation(mut self, n: u32) -> Self {
        self.per_invocation = Some(n.max(1));
        self
    }

    /// The samples per invocation this integrator takes on `gpu` for
    /// `integrand`, before they are spread evenly over the slots.
    pub fn samples_per_invocation(&self, gpu: &Gpu, integrand: &dyn Integrand) -> u32 {
        let n = self
            .per_invocation
            .unwrap_or_else(|| default_samples_per_invocation(gpu));
        within_loop_budget(n, integrand)
    }

    /// Takes samples `first..first + spp` of each pixel's sequence instead
    /// of `0..spp`: a share of a larger render (`mdas reference --part`),
    /// whose shares together take exactly the samples of the whole.
    pub fn with_first_sample(mut self, first: u32) -> Self {
        self.first = first;
        self
    }

    /// Reports progress every few dispatches (waiting for the GPU to do so).
    pub fn with_progress(mut self, progress: Progress) -> Self {
        self.progress = Some(progress);
        self
    }

    fn layout(gpu: &Gpu) -> wgpu::BindGroupLayout {
        gpu.bind_group_layout("mdas.halton.layout", &layout_entries())
    }

    /// The evaluate and accumulate kernels, built once per process
    /// ([`Gpu::compute_pipeline`] keeps them).
    fn pipelines(
        gpu: &Gpu,
        integrand: &dyn Integrand,
        single: bool,
    ) -> Result<(wgpu::ComputePipeline, wgpu::ComputePipeline)> {
        let layout = Self::layout(gpu);
        let source = source(integrand.wgsl());
        let layouts = crate::integrand::kernel_layouts(&layout, integrand);
        let label = format!("mdas.halton.evaluate[{}]", integrand.name());
        let entry = if single {
            "evaluate_single"
        } else {
            "evaluate"
        };
        let evaluate = gpu.compute_pipeline(&label, &source, entry, &layouts)?;
        let accumulate =
            gpu.compute_pipeline("mdas.halton.accumulate", &source, "accumulate", &layouts)?;
        Ok((evaluate, accumulate))
    }
}

/// Group 0 of both kernels (`wgsl/halton.wgsl`): the chunk's parameters
/// at 0 (one uniform buffer, a dynamic offset per chunk), then the partial
/// sums, the accumulators and their compensation, read-write.
pub fn layout_entries() -> Vec<wgpu::BindGroupLayoutEntry> {
    let mut params = uniform_entry(0);
    if let wgpu::BindingType::Buffer {
        has_dynamic_offset, ..
    } = &mut params.ty
    {
        *has_dynamic_offset = true;
    }
    vec![
        params,
        storage_entry(1, false),
        storage_entry(2, false),
        storage_entry(3, false),
    ]
}

/// The Halton kernels' WGSL over an integrand's WGSL (`Integrand::wgsl`).
pub fn source(integrand: Wgsl) -> Wgsl {
    with_halton_points(integrand, wgsl_file!("halton.wgsl"))
}

/// The integrand's WGSL, then the shared Halton point functions, then
/// `kernel`: the Halton kernel, or a test or bench kernel that replays the
/// same points.
pub fn with_halton_points(integrand: Wgsl, kernel: (&'static str, &'static str)) -> Wgsl {
    integrand
        .include(
            &Wgsl::new()
                .part(wgsl_file!("shared/rng.wgsl"))
                .part(wgsl_file!("shared/sampling.wgsl")),
        )
        .part(wgsl_file!("shared/halton.wgsl"))
        .part(wgsl_file!("shared/halton_point.wgsl"))
        .part(kernel)
}

impl Integrator for Halton {
    fn name(&self) -> &'static str {
        "halton"
    }

    fn render(&mut self, gpu: &Gpu, integrand: &dyn Integrand) -> Result<Render> {
        let film = integrand.film();
        let dims = integrand.dims();
        if !(2..=MAX_DIMS).contains(&dims) {
            bail!(
                "integrand '{}' has {dims} dimensions; Halton supports 2..={MAX_DIMS}",
                integrand.name()
            );
        }
        if self.spp == 0 {
            bail!("spp must be at least 1");
        }
        let Some(end) = self.first.checked_add(self.spp) else {
            bail!(
                "samples {}..{} + {} are beyond the sequence's 2^32",
                self.first,
                self.first,
                self.spp
            );
        };
        let pixels = film.width as u64 * film.height as u64;
        if pixels == 0 {
            bail!("empty film {}×{}", film.width, film.height);
        }

        // Work decomposition: `slots` invocations per pixel per dispatch.
        // As few slots as the samples per invocation allow, the samples
        // spread evenly over them: 9 spp as 5 + 4, not 8 + 1 (on lavapipe a
        // slot of one sample cost as much as a full one: 9 spp took 1.6×
        // the time of 8).
        let per_invocation = self.samples_per_invocation(gpu, integrand);
        let max_slots = self.spp.div_ceil(per_invocation) as u64;
        let spi = self.spp.div_ceil(max_slots as u32);
        let slots = (TARGET_INVOCATIONS / pixels).clamp(1, max_slots) as u32;
        let per_chunk = slots * spi;
        let chunks = self.spp.div_ceil(per_chunk);
        let invocations = pixels * slots as u64;
        let groups = invocations.div_ceil(WORKGROUP_SIZE as u64);
        if groups > u32::MAX as u64 {
            bail!("film of {pixels} pixels is too large to dispatch");
        }
        let (gx, gy) = gpu.dispatch_dims(groups as u32);
        let row_invocations = gx * WORKGROUP_SIZE;
        let acc_groups = pixels.div_ceil(WORKGROUP_SIZE as u64) as u32;
        let (acc_gx, acc_gy) = (acc_groups.min(gx), acc_groups.div_ceil(gx));

        let (evaluate, accumulate) = Self::pipelines(gpu, integrand, spi == 1)?;
        let layout = Self::layout(gpu);

        gpu.scoped("Halton render", || {
            let params: Vec<u8> = (0..chunks)
                .flat_map(|c| {
                    let p = HaltonParams {
                        width: film.width,
                        height: film.height,
                        dims,
                        seed: self.seed,
                        spp: end,
                        first_index: self.first + c * per_chunk,
                        samples_per_invocation: spi,
                        slots,
                        row_invocations,
                        _pad: [0; 3],
                    };
                    let mut bytes = bytemuck::bytes_of(&p).to_vec();
                    bytes.resize(PARAMS_STRIDE as usize, 0);
                    bytes
                })
                .collect();
            let params_buf = gpu.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("mdas.halton.params"),
                size: params.len() as u64,
                usage: gpu.uniform_usage() | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            });
            gpu.queue.write_buffer(&params_buf, 0, &params);
            let partial = gpu.buffer_zeroed("mdas.halton.partial", invocations * 16, STORAGE)?;
            let accum = gpu.buffer_zeroed("mdas.halton.accum", pixels * 16, STORAGE)?;
            let comp = gpu.buffer_zeroed("mdas.halton.compensation", pixels * 16, STORAGE)?;
            let group0 = gpu.device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("mdas.halton.group0"),
                layout: &layout,
                entries: &[
                    wgpu::BindGroupEntry {
                        binding: 0,
                        resource: wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                            buffer: &params_buf,
                            offset: 0,
                            size: std::num::NonZeroU64::new(
                                std::mem::size_of::<HaltonParams>() as u64
                            ),
                        }),
                    },
                    wgpu::BindGroupEntry {
                        binding: 1,
                        resource: partial.as_entire_binding(),
                    },
                    wgpu::BindGroupEntry {
                        binding: 2,
                        resource: accum.as_entire_binding(),
                    },
                    wgpu::BindGroupEntry {
                        binding: 3,
                        resource: comp.as_entire_binding(),
                    },
                ],
            });

            let mut profiler = Profiler::new(gpu);
            let clock = profiler.clock();
            for chunk in 0..chunks {
                let offset = [(chunk as u64 * PARAMS_STRIDE) as u32];
                profiler.phase("evaluate", |encoder, timestamps| {
                    let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                        label: Some("mdas.halton.evaluate"),
                        timestamp_writes: timestamps,
                    });
                    pass.set_pipeline(&evaluate);
                    pass.set_bind_group(0, &group0, &offset);
                    crate::integrand::bind_integrand(&mut pass, integrand);
                    pass.dispatch_workgroups(gx, gy, 1);
                })?;
                profiler.phase("accumulate", |encoder, timestamps| {
                    let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                        label: Some("mdas.halton.accumulate"),
                        timestamp_writes: timestamps,
                    });
                    pass.set_pipeline(&accumulate);
                    pass.set_bind_group(0, &group0, &offset);
                    crate::integrand::bind_integrand(&mut pass, integrand);
                    pass.dispatch_workgroups(acc_gx, acc_gy, 1);
                })?;
                let done = chunk + 1;
                if let Some(progress) = self.progress.as_mut() {
                    if done % PROGRESS_EVERY == 0 || done == chunks {
                        gpu.wait()?;
                        progress((done * per_chunk).min(self.spp), self.spp);
                    }
                }
            }
            let times = profiler.finish()?;
            let sums: Vec<[f32; 4]> = gpu.read_buffer(&accum, pixels as usize)?;
            let mut finite_total = 0u64;
            let image = sums
                .iter()
                .map(|s| {
                    finite_total += s[3] as u64;
                    let n = s[3];
                    if n > 0.0 {
                        [s[0] / n, s[1] / n, s[2] / n]
                    } else {
                        [f32::NAN; 3]
                    }
                })
                .collect();
            let samples = pixels * self.spp as u64;
            Ok(Render {
                film,
                image,
                samples,
                nonfinite: samples - finite_total,
                times,
                clock,
                gpu_bytes: params.len() as u64 + invocations * 16 + 2 * pixels * 16,
            })
        })
    }
}
