//! Per-pixel adaptive Halton with Blender Cycles' adaptive-sampling rule
//! — the sampler practitioners use, as a third method beside [`Halton`]
//! and MDAS (issue 65, item 3).
//!
//! Samples are [`Halton`]'s: sample `i` of a pixel is the pixel's Halton
//! point `i` with the same Cranley–Patterson rotation (the shared
//! `wgsl/shared/halton_point.wgsl`), and a pixel continues its sequence
//! where it stopped (indices 0, 1, 2, … of that pixel). A pixel's value is
//! the mean of its finite samples (box filter, docs/conventions.md).
//!
//! # What follows Cycles
//!
//! Cycles 3.0 and later (`intern/cycles/kernel/film/adaptive_sampling.h`,
//! `integrator/adaptive_sampling.cpp`, `scene/integrator.cpp`; the rule is
//! Dammertz et al. 2010, "A hierarchical automatic stopping condition for
//! Monte Carlo global illumination", §2.1, applied per pixel):
//!
//! - Two accumulations per pixel: all samples (I) and the class-A half
//!   (A, Cycles' AUX pass). Class A is Cycles' split, sample index `i` with
//!   `popcount(i & 0xaaaaaaaa)` odd (Christensen et al.'s progressive
//!   multi-jittered split): every aligned block of four indices has two of
//!   each class. (The odd indices would be a poor half for Halton: the
//!   base-2 film x of every odd index lies in the right half of the pixel,
//!   so I − A would measure the pixel's horizontal gradient.)
//! - The error: `Σ_c |I_c − A_c| / (0.0001 + n)` with I and A the means
//!   (Cycles scales both sums by 1/samples; its AUX pass holds 2 × the
//!   class-A sum), and n = √(I_r + I_g + I_b) where that sum is below 1,
//!   the sum itself from 1 up. No other factor of the sample count: the
//!   pre-3.0 rule (`error < threshold · N` on sums, a √N scaling) was
//!   replaced by the means and a threshold multiplied by 5.
//! - Converged when error < 5 × `threshold` (Cycles multiplies the user's
//!   noise threshold by 5, "an arbitrary factor"; its default threshold is
//!   0.01, [`DEFAULT_THRESHOLD`]).
//! - The minimum: `min_spp` defaults to Cycles' automatic
//!   `max(4, ⌈16 / threshold^0.3⌉)` (64 at 0.01, [`cycles_min_spp`]); a
//!   given value is raised to 4 as in Cycles. The check runs after a
//!   sample count N with N − 1 > min_spp and N a multiple of `step` (16):
//!   Cycles' `need_filter` on the 0-based sample index, so the first
//!   check at min_spp = 64 is after 80 samples ([`first_check`]).
//! - A pixel found converged takes no more samples and is not tested
//!   again, unless the dilation reopens it. The unconverged mask is dilated
//!   by one pixel in x, then in y (Cycles' `filter_x`/`filter_y`): a 3×3
//!   box, so a converged pixel beside (or diagonal to) an unconverged one
//!   takes the next round too.
//! - Sampling stops when every pixel has converged, or at the budget.
//!
//! # What departs
//!
//! - Budget: Cycles stops every pixel at `max samples` (and a time
//!   limit). Here the knob is equal-time's: `spp` is the average number
//!   of samples per pixel the render may spend, `⌊spp · pixels⌋` in all,
//!   beside a per-pixel cap `spp_max` (Cycles' max samples, default 4096).
//!   When a round would overrun the budget, every wanting pixel gets
//!   ⌊budget left / pixels wanting⌋ samples instead, and what remains goes
//!   one sample each to the first wanting pixels in row-major order; no
//!   check follows a shortened round. Below the first check's cost
//!   (`first_check · pixels`) the render is Halton's samples, spread evenly.
//! - Non-finite samples are excluded from both sums and counted
//!   ([`Render::nonfinite`]), as [`Halton`] does; Cycles zeroes them. I
//!   and A are then the means over finite samples; a mean with none is 0.
//! - No exposure (1), no progressive noise floor (Cycles' viewport), no
//!   tiles: the film is one tile.
//!
//! # On the GPU
//!
//! Rounds of `step` samples per wanting pixel (the first round takes the
//! first check's count at once). Each round compacts the wanting pixels
//! into a list (`reduce`, `scan`, `apply`: reduce-then-scan, no look-back,
//! as MDAS's allocation), whose totals (pixels, samples) the host reads to
//! size the round and keep the budget; `evaluate` runs (entry, slot)
//! invocations of up to [`SAMPLES_PER_INVOCATION`]-style loops like
//! Halton's, `accumulate` adds the slots in order (Kahan-compensated, no
//! atomics: the image is a deterministic function of the integrand,
//! parameters and seed on a given adapter), then `check` and `dilate`.
//! One host round trip per round. The WGSL: `wgsl/adaptive.wgsl` (the
//! declarations both modules share), `adaptive_control.wgsl` (the control
//! kernels, no integrand) and `adaptive_evaluate.wgsl` (over the integrand). [`simulate`] is the CPU oracle of the
//! whole schedule.
//!
//! Phases (equal-time accounting): `evaluate`, `accumulate` and `adaptive`
//! (compaction, convergence test, dilation).
//!
//! [`SAMPLES_PER_INVOCATION`]: super::halton::default_samples_per_invocation
//! [`Halton`]: super::Halton
//! [`Halton::with_samples_per_invocation`]: super::Halton::with_samples_per_invocation

use super::halton::{default_samples_per_invocation, within_loop_budget};
use super::{Integrator, Render};
use crate::film::Film;
use crate::gpu::buffer::{Readback, STORAGE};
use crate::gpu::profiler::Profiler;
use crate::gpu::shader::{storage_entry, uniform_entry, Wgsl};
use crate::gpu::Gpu;
use crate::integrand::{Integrand, MAX_DIMS};
use crate::wgsl_file;
use anyhow::{bail, Result};

/// Cycles' default noise threshold.
pub const DEFAULT_THRESHOLD: f32 = 0.01;
/// Cycles multiplies the user's threshold by this before testing.
pub const CYCLES_THRESHOLD_FACTOR: f32 = 5.0;
/// Cycles' adaptive step: a check every this many samples.
pub const DEFAULT_STEP: u32 = 16;
/// Cycles' default max samples.
pub const DEFAULT_SPP_MAX: u32 = 4096;
/// Largest per-pixel cap: finite counts are kept in f32.
pub const MAX_SPP: u32 = 1 << 24;

/// Target invocations per evaluate dispatch (entries × slots).
const TARGET_INVOCATIONS: u64 = 1 << 20;
const WG: u32 = 64;
const SCAN_WG: u32 = 256;
/// Uniform-buffer dynamic offsets must be multiples of this.
const PARAMS_STRIDE: u64 = 256;

/// Cycles' automatic minimum sample count for a noise threshold:
/// `max(4, ⌈16 / threshold^0.3⌉)` (0.1 → 32, 0.01 → 64, 0.001 → 128).
pub fn cycles_min_spp(threshold: f32) -> u32 {
    if threshold > 0.0 {
        ((16.0f32 / threshold.powf(0.3)).ceil() as u32).max(4)
    } else {
        4
    }
}

/// The sample count after which the first check runs: the smallest
/// multiple N of `step` with N − 1 > `min_spp` (Cycles' `need_filter`
/// on 0-based indices; with a power-of-two step, `((min + 1) | (step − 1)) + 1`).
pub fn first_check(min_spp: u32, step: u32) -> u32 {
    step * ((min_spp + 1) / step + 1)
}

/// Cycles' per-pixel error from the mean of all finite samples `i` and
/// that of the class-A ones `a` (module docs).
pub fn pixel_error(i: [f64; 3], a: [f64; 3]) -> f64 {
    let difference = (i[0] - a[0]).abs() + (i[1] - a[1]).abs() + (i[2] - a[2]).abs();
    let intensity = i[0] + i[1] + i[2];
    let norm = if intensity < 1.0 {
        intensity.sqrt()
    } else {
        intensity
    };
    difference / (0.0001 + norm)
}

/// Cycles' split of the sample indices into two classes.
pub fn class_a(index: u32) -> bool {
    (index & 0xaaaa_aaaa).count_ones() & 1 == 1
}

/// The unconverged mask dilated by one pixel in x, then in y (Cycles'
/// two filter passes): a pixel is set if any pixel of its 3×3
/// neighbourhood inside the film is.
pub fn dilate(film: Film, unconverged: &[bool]) -> Vec<bool> {
    let (w, h) = (film.width as usize, film.height as usize);
    let mut x_pass = vec![false; w * h];
    for y in 0..h {
        for x in 0..w {
            let lo = x.saturating_sub(1);
            let hi = (x + 1).min(w - 1);
            x_pass[y * w + x] = (lo..=hi).any(|xx| unconverged[y * w + xx]);
        }
    }
    let mut out = vec![false; w * h];
    for y in 0..h {
        let lo = y.saturating_sub(1);
        let hi = (y + 1).min(h - 1);
        for x in 0..w {
            out[y * w + x] = (lo..=hi).any(|yy| x_pass[yy * w + x]);
        }
    }
    out
}

/// The adaptive integrator's parameters.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AdaptiveParams {
    /// Average samples per pixel the render may spend: at most
    /// ⌊spp · pixels⌋ in all (the equal-time knob).
    pub spp: f64,
    /// Samples one pixel may take at most (Cycles' max samples).
    pub spp_max: u32,
    /// The noise threshold, as Cycles' user setting (tested ×5).
    pub threshold: f32,
    /// Samples before adaptivity (Cycles' min samples; raised to 4).
    pub min_spp: u32,
    /// Samples between checks (Cycles: 16).
    pub step: u32,
    pub seed: u32,
}

impl AdaptiveParams {
    /// Cycles' defaults (threshold 0.01, min 64, step 16, max 4096) at a
    /// budget of `spp` samples per pixel on average.
    pub fn new(spp: f64, seed: u32) -> Self {
        AdaptiveParams {
            spp,
            spp_max: DEFAULT_SPP_MAX,
            threshold: DEFAULT_THRESHOLD,
            min_spp: cycles_min_spp(DEFAULT_THRESHOLD),
            step: DEFAULT_STEP,
            seed,
        }
    }

    /// Sets the threshold and Cycles' automatic minimum for it.
    pub fn with_threshold(mut self, threshold: f32) -> Self {
        self.threshold = threshold;
        self.min_spp = cycles_min_spp(threshold);
        self
    }

    /// The total budget for a film of `pixels` pixels.
    pub fn budget(&self, pixels: u64) -> u64 {
        ((self.spp * pixels as f64).floor() as u64).min(self.spp_max as u64 * pixels)
    }

    fn effective_min(&self) -> u32 {
        self.min_spp.max(4)
    }

    /// The sample count of the first check.
    pub fn first_check(&self) -> u32 {
        first_check(self.effective_min(), self.step)
    }

    fn validate(&self) -> Result<()> {
        if !(self.spp.is_finite() && self.spp > 0.0) {
            bail!("spp must be a positive number, got {}", self.spp);
        }
        if self.spp_max == 0 || self.spp_max > MAX_SPP {
            bail!("spp_max must be in 1..={MAX_SPP}, got {}", self.spp_max);
        }
        if !(self.threshold.is_finite() && self.threshold >= 0.0) {
            bail!(
                "threshold must be a non-negative number, got {}",
                self.threshold
            );
        }
        if self.step == 0 || self.step > 1 << 16 {
            bail!("step must be in 1..=65536, got {}", self.step);
        }
        if self.min_spp > MAX_SPP {
            bail!("min_spp must be at most {MAX_SPP}, got {}", self.min_spp);
        }
        Ok(())
    }
}

/// How one round is sized from the pixels that want samples (`wanting`)
/// and the samples they ask for (`asked`), with `remaining` of the budget
/// left: (samples per pixel, whether it is a full round).
fn size_round(full: u32, wanting: u64, asked: u64, remaining: u64) -> (u32, bool) {
    if asked <= remaining {
        (full, true)
    } else {
        ((remaining / wanting).max(1).min(full as u64) as u32, false)
    }
}

/// What [`simulate`] returns.
#[derive(Clone, Debug)]
pub struct Simulation {
    /// Samples each pixel took.
    pub counts: Vec<u32>,
    /// Samples taken in all.
    pub samples: u64,
    /// The smallest |error / (5 · threshold) − 1| over every test made
    /// (∞ if none): how far the closest decision was from flipping.
    pub margin: f64,
    /// Checks made.
    pub checks: u32,
}

/// The CPU oracle: the whole schedule of [`AdaptiveHalton`] (rounds,
/// budget, caps, tests, dilation) in f64, with `sample(pixel, index)` the
/// integrand's value at the pixel's Halton sample (None: non-finite).
pub fn simulate(
    params: &AdaptiveParams,
    film: Film,
    mut sample: impl FnMut(u32, u32) -> Option<[f64; 3]>,
) -> Simulation {
    let pixels = film.width as usize * film.height as usize;
    let limit = CYCLES_THRESHOLD_FACTOR as f64 * params.threshold as f64;
    let mut counts = vec![0u32; pixels];
    let mut active = vec![true; pixels];
    // (Σ f, finite count) over all samples and over the class-A ones.
    let mut whole = vec![([0.0f64; 3], 0u64); pixels];
    let mut half = vec![([0.0f64; 3], 0u64); pixels];
    let mut remaining = params.budget(pixels as u64);
    let n0 = params.first_check();
    let mut started = false;
    let mut samples = 0u64;
    let mut margin = f64::INFINITY;
    let mut checks = 0;
    let want = |k: u32, counts: &[u32], active: &[bool]| -> Vec<u32> {
        (0..pixels)
            .map(|p| {
                if active[p] && counts[p] < params.spp_max {
                    k.min(params.spp_max - counts[p])
                } else {
                    0
                }
            })
            .collect()
    };
    while remaining > 0 {
        let full = if started { params.step } else { n0 };
        let asks = want(full, &counts, &active);
        let wanting = asks.iter().filter(|&&k| k > 0).count() as u64;
        if wanting == 0 {
            break;
        }
        let asked: u64 = asks.iter().map(|&k| k as u64).sum();
        let (k, is_full) = size_round(full, wanting, asked, remaining);
        let asks = want(k, &counts, &active);
        let mut prefix = 0u64;
        for p in 0..pixels {
            if asks[p] == 0 {
                continue;
            }
            let take = (asks[p] as u64).min(remaining.saturating_sub(prefix)) as u32;
            prefix += asks[p] as u64;
            for index in counts[p]..counts[p] + take {
                if let Some(f) = sample(p as u32, index) {
                    let add = |(sum, n): &mut ([f64; 3], u64)| {
                        for (s, v) in sum.iter_mut().zip(f) {
                            *s += v;
                        }
                        *n += 1;
                    };
                    add(&mut whole[p]);
                    if class_a(index) {
                        add(&mut half[p]);
                    }
                }
            }
            counts[p] += take;
            samples += take as u64;
        }
        remaining = params.budget(pixels as u64) - samples;
        if !is_full {
            continue;
        }
        started = true;
        checks += 1;
        let mean = |(s, n): ([f64; 3], u64)| {
            if n > 0 {
                s.map(|x| x / n as f64)
            } else {
                [0.0; 3]
            }
        };
        let unconverged: Vec<bool> = (0..pixels)
            .map(|p| {
                if !active[p] {
                    return false;
                }
                let e = pixel_error(mean(whole[p]), mean(half[p]));
                margin = margin.min((e / limit - 1.0).abs());
                // NaN (a negative intensity) is unconverged, as on the GPU.
                e >= limit || e.is_nan()
            })
            .collect();
        active = dilate(film, &unconverged);
    }
    Simulation {
        counts,
        samples,
        margin,
        checks,
    }
}

/// One dispatch's uniform, `AdaptiveParams` in `wgsl/adaptive.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
pub struct AdaptiveGpuParams {
    pub width: u32,
    pub height: u32,
    pub dims: u32,
    pub seed: u32,
    pub round_samples: u32,
    pub remaining: u32,
    pub spp_max: u32,
    pub entries: u32,
    pub first_slot: u32,
    pub slots: u32,
    pub samples_per_invocation: u32,
    pub threshold: f32,
    pub pixel_groups: u32,
    pub _pad: [u32; 3],
}

/// Per-pixel adaptive Halton (module docs).
pub struct AdaptiveHalton {
    pub params: AdaptiveParams,
    per_invocation: Option<u32>,
    /// Samples each pixel took in the last render.
    counts: Vec<u32>,
}

impl AdaptiveHalton {
    pub fn new(params: AdaptiveParams) -> Result<Self> {
        params.validate()?;
        Ok(AdaptiveHalton {
            params,
            per_invocation: None,
            counts: Vec::new(),
        })
    }

    /// Evaluates at most `n` samples per invocation (1: the loop-free
    /// kernel) instead of the adapter's default, as
    /// [`Halton::with_samples_per_invocation`].
    pub fn with_samples_per_invocation(mut self, n: u32) -> Self {
        self.per_invocation = Some(n.max(1));
        self
    }

    /// Sets the seed of the next render.
    pub fn set_seed(&mut self, seed: u32) {
        self.params.seed = seed;
    }

    /// Sets the average budget per pixel of the next render.
    pub fn set_spp(&mut self, spp: f64) -> Result<()> {
        AdaptiveParams { spp, ..self.params }.validate()?;
        self.params.spp = spp;
        Ok(())
    }

    /// Samples each pixel took in the last render, row-major.
    pub fn sample_counts(&self) -> &[u32] {
        &self.counts
    }
}

/// Group 0 of the control kernels (`wgsl/adaptive_control.wgsl`).
pub fn control_layout_entries() -> Vec<wgpu::BindGroupLayoutEntry> {
    let mut v = evaluate_layout_entries();
    v.extend((3..7).map(|b| storage_entry(b, false)));
    v
}

/// Group 0 of the evaluate kernels: the parameters, the partial sums and
/// the list (few bindings, leaving the integrand room).
pub fn evaluate_layout_entries() -> Vec<wgpu::BindGroupLayoutEntry> {
    let mut params = uniform_entry(0);
    if let wgpu::BindingType::Buffer {
        has_dynamic_offset, ..
    } = &mut params.ty
    {
        *has_dynamic_offset = true;
    }
    vec![params, storage_entry(1, false), storage_entry(2, false)]
}

/// The control kernels' WGSL.
pub fn control_source() -> Wgsl {
    Wgsl::new()
        .part(wgsl_file!("adaptive.wgsl"))
        .part(wgsl_file!("adaptive_control.wgsl"))
}

/// The evaluate kernels' WGSL over an integrand's.
pub fn evaluate_source(integrand: Wgsl) -> Wgsl {
    super::halton::with_halton_points(integrand, wgsl_file!("adaptive.wgsl"))
        .part(wgsl_file!("adaptive_evaluate.wgsl"))
}

struct Pipes {
    reduce: wgpu::ComputePipeline,
    scan: wgpu::ComputePipeline,
    apply: wgpu::ComputePipeline,
    accumulate: wgpu::ComputePipeline,
    check: wgpu::ComputePipeline,
    dilate: wgpu::ComputePipeline,
    evaluate: wgpu::ComputePipeline,
}

impl Integrator for AdaptiveHalton {
    fn name(&self) -> &'static str {
        "adaptive"
    }

    fn render(&mut self, gpu: &Gpu, integrand: &dyn Integrand) -> Result<Render> {
        let p = self.params;
        p.validate()?;
        let film = integrand.film();
        let dims = integrand.dims();
        if !(2..=MAX_DIMS).contains(&dims) {
            bail!(
                "integrand '{}' has {dims} dimensions; adaptive Halton supports 2..={MAX_DIMS}",
                integrand.name()
            );
        }
        let pixels = film.width as u64 * film.height as u64;
        if pixels == 0 {
            bail!("empty film {}×{}", film.width, film.height);
        }
        let n0 = p.first_check();
        let biggest_round = n0.max(p.step).min(p.spp_max) as u64;
        if pixels * biggest_round >= u32::MAX as u64 {
            bail!(
                "film of {pixels} pixels at {biggest_round} samples a round is too large for the u32 sample prefix"
            );
        }
        let budget = p.budget(pixels);

        let per_invocation = within_loop_budget(
            self.per_invocation
                .unwrap_or_else(|| default_samples_per_invocation(gpu)),
            integrand,
        );
        let max_slots = biggest_round.div_ceil(per_invocation as u64);
        let max_invocations = (pixels * max_slots).min(TARGET_INVOCATIONS.max(pixels));
        let groups_count = pixels.div_ceil(SCAN_WG as u64);
        let max_chunks = max_slots.div_ceil((TARGET_INVOCATIONS / pixels).clamp(1, max_slots));

        let control = gpu.bind_group_layout("mdas.adaptive.control", &control_layout_entries());
        let eval_layout =
            gpu.bind_group_layout("mdas.adaptive.evaluate", &evaluate_layout_entries());
        let csrc = control_source();
        let pipe = |entry: &str| {
            gpu.compute_pipeline(&format!("mdas.adaptive.{entry}"), &csrc, entry, &[&control])
        };
        let esrc = evaluate_source(integrand.wgsl());
        let eval_entry = if per_invocation == 1 {
            "evaluate_single"
        } else {
            "evaluate"
        };
        let pipes = Pipes {
            reduce: pipe("reduce")?,
            scan: pipe("scan")?,
            apply: pipe("apply")?,
            accumulate: pipe("accumulate")?,
            check: pipe("check")?,
            dilate: pipe("dilate")?,
            evaluate: gpu.compute_pipeline(
                &format!("mdas.adaptive.evaluate[{}]", integrand.name()),
                &esrc,
                eval_entry,
                &crate::integrand::kernel_layouts(&eval_layout, integrand),
            )?,
        };

        gpu.scoped("adaptive Halton render", || {
            let entries = 1 + max_chunks;
            let params_buf = gpu.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("mdas.adaptive.params"),
                size: entries * PARAMS_STRIDE,
                usage: gpu.uniform_usage() | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            });
            let partial =
                gpu.buffer_zeroed("mdas.adaptive.partial", max_invocations * 32, STORAGE)?;
            let list = gpu.buffer_zeroed("mdas.adaptive.list", pixels * 16, STORAGE)?;
            let sums = gpu.buffer_zeroed("mdas.adaptive.sums", pixels * 64, STORAGE)?;
            let state0: Vec<u32> = (0..pixels).flat_map(|_| [0u32, 1, 0, 0]).collect();
            let state = gpu.buffer_from("mdas.adaptive.state", &state0, STORAGE)?;
            let groups = gpu.buffer_zeroed("mdas.adaptive.groups", groups_count * 8, STORAGE)?;
            let totals = gpu.buffer_zeroed("mdas.adaptive.totals", 16, STORAGE)?;
            let params_binding = wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                buffer: &params_buf,
                offset: 0,
                size: std::num::NonZeroU64::new(std::mem::size_of::<AdaptiveGpuParams>() as u64),
            });
            let bind = |layout: &wgpu::BindGroupLayout, bufs: &[&wgpu::Buffer]| {
                let mut e = vec![wgpu::BindGroupEntry {
                    binding: 0,
                    resource: params_binding.clone(),
                }];
                e.extend(bufs.iter().enumerate().map(|(i, b)| wgpu::BindGroupEntry {
                    binding: i as u32 + 1,
                    resource: b.as_entire_binding(),
                }));
                gpu.device.create_bind_group(&wgpu::BindGroupDescriptor {
                    label: Some("mdas.adaptive.group0"),
                    layout,
                    entries: &e,
                })
            };
            let g_control = bind(
                &control,
                &[&partial, &list, &sums, &state, &groups, &totals],
            );
            let g_eval = bind(&eval_layout, &[&partial, &list]);

            let base = AdaptiveGpuParams {
                width: film.width,
                height: film.height,
                dims,
                seed: p.seed,
                spp_max: p.spp_max,
                samples_per_invocation: per_invocation,
                threshold: CYCLES_THRESHOLD_FACTOR * p.threshold,
                pixel_groups: groups_count as u32,
                ..Default::default()
            };
            let write = |index: u64, value: &AdaptiveGpuParams| {
                gpu.queue.write_buffer(
                    &params_buf,
                    index * PARAMS_STRIDE,
                    bytemuck::bytes_of(value),
                );
            };
            let (pgx, pgy) = gpu.dispatch_dims(groups_count as u32);
            let pixel_dims = gpu.dispatch_dims(pixels.div_ceil(WG as u64) as u32);

            let mut profiler = Profiler::new(gpu);
            let clock = profiler.clock();
            // Compacts the wanting pixels at `k` samples each; returns
            // (pixels wanting, samples asked).
            let compact = |profiler: &mut Profiler, k: u32, remaining: u64| -> Result<(u64, u64)> {
                write(
                    0,
                    &AdaptiveGpuParams {
                        round_samples: k,
                        remaining: remaining.min(u32::MAX as u64) as u32,
                        ..base
                    },
                );
                let readback = Readback::<u32>::new(gpu, &totals, 2)?;
                let mut batch = profiler.batch("adaptive");
                batch.phase("adaptive", |encoder, timestamps| {
                    let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                        label: Some("mdas.adaptive.compact"),
                        timestamp_writes: timestamps,
                    });
                    pass.set_bind_group(0, &g_control, &[0]);
                    pass.set_pipeline(&pipes.reduce);
                    pass.dispatch_workgroups(pgx, pgy, 1);
                    pass.set_pipeline(&pipes.scan);
                    pass.dispatch_workgroups(1, 1, 1);
                    pass.set_pipeline(&pipes.apply);
                    pass.dispatch_workgroups(pgx, pgy, 1);
                })?;
                readback.record(batch.encoder());
                batch.submit();
                let t = readback.finish(gpu)?;
                Ok((t[0] as u64, t[1] as u64))
            };

            let mut remaining = budget;
            let mut samples = 0u64;
            let mut started = false;
            while remaining > 0 {
                let full = if started { p.step } else { n0 };
                let (wanting, asked) = compact(&mut profiler, full, remaining)?;
                if wanting == 0 {
                    break;
                }
                let (k, is_full) = size_round(full, wanting, asked, remaining);
                let asked = if is_full {
                    asked
                } else {
                    compact(&mut profiler, k, remaining)?.1
                };
                let used = asked.min(remaining);
                // Evaluate and accumulate in chunks of slots.
                // No pixel takes more than spp_max in a round.
                let slots = k.min(p.spp_max).div_ceil(per_invocation) as u64;
                let per_chunk = (TARGET_INVOCATIONS / wanting).clamp(1, slots);
                let chunks = slots.div_ceil(per_chunk);
                for c in 0..chunks {
                    let first = c * per_chunk;
                    let n = per_chunk.min(slots - first);
                    write(
                        1 + c,
                        &AdaptiveGpuParams {
                            entries: wanting as u32,
                            first_slot: first as u32,
                            slots: n as u32,
                            ..base
                        },
                    );
                }
                let mut batch = profiler.batch("adaptive round");
                for c in 0..chunks {
                    let n = per_chunk.min(slots - c * per_chunk);
                    let offset = [((1 + c) * PARAMS_STRIDE) as u32];
                    let (gx, gy) = gpu.dispatch_dims((wanting * n).div_ceil(WG as u64) as u32);
                    batch.phase("evaluate", |encoder, timestamps| {
                        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                            label: Some("mdas.adaptive.evaluate"),
                            timestamp_writes: timestamps,
                        });
                        pass.set_pipeline(&pipes.evaluate);
                        pass.set_bind_group(0, &g_eval, &offset);
                        crate::integrand::bind_integrand(&mut pass, integrand);
                        pass.dispatch_workgroups(gx, gy, 1);
                    })?;
                    let (ax, ay) = gpu.dispatch_dims(wanting.div_ceil(WG as u64) as u32);
                    batch.phase("accumulate", |encoder, timestamps| {
                        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                            label: Some("mdas.adaptive.accumulate"),
                            timestamp_writes: timestamps,
                        });
                        pass.set_pipeline(&pipes.accumulate);
                        pass.set_bind_group(0, &g_control, &offset);
                        pass.dispatch_workgroups(ax, ay, 1);
                    })?;
                }
                samples += used;
                remaining -= used;
                if is_full {
                    started = true;
                    batch.phase("adaptive", |encoder, timestamps| {
                        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                            label: Some("mdas.adaptive.check"),
                            timestamp_writes: timestamps,
                        });
                        pass.set_bind_group(0, &g_control, &[0]);
                        pass.set_pipeline(&pipes.check);
                        pass.dispatch_workgroups(pixel_dims.0, pixel_dims.1, 1);
                        pass.set_pipeline(&pipes.dilate);
                        pass.dispatch_workgroups(pixel_dims.0, pixel_dims.1, 1);
                    })?;
                }
                batch.submit();
            }
            let times = profiler.finish()?;
            let sums: Vec<[f32; 4]> = gpu.read_buffer(&sums, 4 * pixels as usize)?;
            let state: Vec<u32> = gpu.read_buffer(&state, 4 * pixels as usize)?;
            self.counts = state.chunks(4).map(|s| s[0]).collect();
            let counted: u64 = self.counts.iter().map(|&c| c as u64).sum();
            if counted != samples {
                bail!("adaptive Halton: pixels counted {counted} samples, the rounds {samples}");
            }
            let mut finite_total = 0u64;
            let image = sums
                .chunks(4)
                .map(|s| {
                    let s = s[0];
                    finite_total += s[3] as u64;
                    if s[3] > 0.0 {
                        [s[0] / s[3], s[1] / s[3], s[2] / s[3]]
                    } else {
                        [f32::NAN; 3]
                    }
                })
                .collect();
            Ok(Render {
                film,
                image,
                samples,
                nonfinite: samples - finite_total,
                times,
                clock,
                gpu_bytes: entries * PARAMS_STRIDE
                    + max_invocations * 32
                    + pixels * (16 + 64 + 16)
                    + groups_count * 8
                    + 16,
            })
        })
    }
}

#[cfg(test)]
mod tests;
