//! One MDAS render: buffers, the initial pass, the GPU-driven iteration
//! loop recorded in batches, statistics and reconstruction.

use super::*;

impl Mdas {
    pub(super) fn run(
        &mut self,
        gpu: &Gpu,
        integrand: &dyn Integrand,
        mut observe: Option<&mut dyn FnMut(&Snapshot)>,
        final_only: bool,
    ) -> Result<Render> {
        let cfg = self.config_for(gpu, integrand)?;
        let pipes = Self::pipelines(gpu, &cfg, integrand)?;
        let layout = Self::layout(gpu, &cfg);
        let args_layout = Self::args_layout(gpu);
        // The parameters as this render resolved them (an automatic grid chosen).
        let p = cfg.params;

        let mut progress = self.progress.take();
        let result = gpu.scoped("MDAS render", || {
            let gp = GpuParams {
                seed: p.seed,
                budget: cfg.budget,
                max_iterations: cfg.max_iterations,
                max_groups: gpu.limits.max_compute_workgroups_per_dimension.max(1),
                width: cfg.film.width,
                height: cfg.film.height,
                select_all: (p.alpha == 0.0) as u32,
                scale_factor: p.scale_factor,
                inv_alpha: if p.alpha > 0.0 { 1.0 / p.alpha } else { 0.0 },
                epsilon: p.epsilon,
                pixel_prior: p.pixel_prior,
                pace: p.pace,
                pace_floor: pace_floor(p.pace, cfg.budget - cfg.initial_samples.min(cfg.budget)),
                eval_min_groups: self.eval_min_groups.unwrap_or_else(|| eval_min_groups(gpu)),
                ..Default::default()
            };
            let paged = |array: usize| -> Result<Vec<wgpu::Buffer>> {
                let name = pages::PAGED_ARRAYS[array].0;
                (0..cfg.pages.count[array])
                    .map(|page| {
                        let label = format!("mdas.{name}[{page}]");
                        gpu.buffer_zeroed(&label, cfg.page_bytes(array, page), STORAGE)
                    })
                    .collect()
            };
            let bufs = Buffers {
                params: gpu.uniform("mdas.params", &gp),
                leaves: paged(0)?,
                samples: paged(1)?,
                values: paged(2)?,
                boxes: paged(3)?,
                counters: gpu.buffer_zeroed("mdas.counters", Config::COUNTERS_BYTES, STORAGE)?,
                state: gpu.buffer_zeroed("mdas.state", Config::STATE_BYTES, STORAGE)?,
                accum: if cfg.accum_in_samples() {
                    gpu.buffer_zeroed("mdas.placeholder", 16, STORAGE)?
                } else {
                    gpu.buffer_zeroed("mdas.accum", cfg.accum_bytes(), STORAGE)?
                },
            };
            let partials = gpu.buffer_zeroed("mdas.partials", cfg.partials_bytes(), STORAGE)?;
            let args = gpu.buffer_zeroed(
                "mdas.args",
                Config::ARGS_BYTES,
                STORAGE | wgpu::BufferUsages::INDIRECT,
            )?;
            // Bindings 0–8, then the extra pages in `PAGED_ARRAYS` order.
            let extra_pages: Vec<&wgpu::Buffer> =
                [&bufs.leaves, &bufs.samples, &bufs.values, &bufs.boxes]
                    .into_iter()
                    .flat_map(|pages| &pages[1..])
                    .collect();
            let bind = |label: &str, samples: &wgpu::Buffer, accum: &wgpu::Buffer| {
                let base = [
                    &bufs.params,
                    &bufs.leaves[0],
                    samples,
                    &bufs.values[0],
                    &partials,
                    &bufs.counters,
                    accum,
                    &bufs.boxes[0],
                    &bufs.state,
                ];
                let all: Vec<&wgpu::Buffer> = base
                    .into_iter()
                    .chain(extra_pages.iter().copied())
                    .collect();
                crate::gpu::shader::bind_buffers(gpu, label, &layout, &all)
            };
            let group0 = bind("mdas.group0", &bufs.samples[0], &bufs.accum);
            // Reconstruction binds the accumulators in place of the samples'
            // coordinates when they fit there (binding a buffer twice as
            // writable storage is not allowed, so samples get a placeholder).
            // (With paged coordinates, their first page: `accum_in_samples`.)
            let accum = if cfg.accum_in_samples() {
                &bufs.samples[0]
            } else {
                &bufs.accum
            };
            let samples_in_rec = if cfg.accum_in_samples() {
                &bufs.accum
            } else {
                &bufs.samples[0]
            };
            let group_reconstruct = bind("mdas.group0.reconstruct", samples_in_rec, accum);
            let args_group =
                crate::gpu::shader::bind_buffers(gpu, "mdas.args", &args_layout, &[&args]);
            let mut k = Kernels {
                pipes,
                group0,
                args,
                args_group,
            };
            let mut profiler = Profiler::new(gpu);
            let clock = profiler.clock();
            let read_state =
                || -> Result<State> { Ok(State(gpu.read_buffer(&bufs.state, state::LEN)?)) };
            // The first `words` words of a paged array.
            let read_paged = |pages: &[wgpu::Buffer], words: usize| -> Result<Vec<u32>> {
                let per = cfg.pages.words() as usize;
                let mut out = Vec::with_capacity(words);
                for (page, buffer) in pages.iter().enumerate() {
                    let start = page * per;
                    if start >= words {
                        break;
                    }
                    out.extend(gpu.read_buffer::<u32>(buffer, (words - start).min(per))?);
                }
                Ok(out)
            };
            let read_counters =
                || -> Result<Vec<u32>> { gpu.read_buffer(&bufs.counters, counter::LEN) };

            // The iteration state before the first iteration: the grid's
            // cells are the leaves, its samples are to be evaluated.
            let mut initial_state = [0u32; state::LEN];
            initial_state[state::LEAVES] = cfg.cells;
            initial_state[state::SAMPLES] = cfg.initial_samples;
            initial_state[state::ITERATION] = 1;
            initial_state[state::EVAL_COUNT] = cfg.initial_samples;
            initial_state[state::DONE] = (cfg.initial_samples >= cfg.budget) as u32;
            initial_state[state::INV_PACE] = 1f32.to_bits();
            gpu.queue
                .write_buffer(&bufs.state, 0, bytemuck::cast_slice(&initial_state));

            // Initial grid and its samples.
            let mut batch = profiler.batch("mdas.initial");
            batch.phase("initial", |e, ts| {
                let mut pass = e.begin_compute_pass(&pass("mdas.initial", ts));
                initial::record(&mut pass, &k, Grid::new(gpu, cfg.cells));
                plan::record_prime(&mut pass, &k);
            })?;
            // Evaluate's two parts (`mdas bench` reports their cost per
            // sample apart): the initial grid's samples, then the adaptive
            // ones of every iteration.
            batch.phase("evaluate/initial", |e, ts| {
                evaluate::record(
                    &mut e.begin_compute_pass(&pass("mdas.evaluate", ts)),
                    &k,
                    integrand,
                )
            })?;

            let snapshot = |is_final: bool, state: &State| -> Result<Snapshot> {
                let (n, leaves) = (state.samples(), state.leaves());
                Ok(Snapshot {
                    iteration: state.iteration(),
                    is_final,
                    params: p,
                    dims: cfg.dims,
                    film: cfg.film,
                    budget: cfg.budget,
                    leaf_count: leaves,
                    sample_count: n,
                    emax_bits: read_counters()?[counter::EMAX],
                    inv_alpha: gp.inv_alpha,
                    inv_pace: state.inv_pace(),
                    select_all: gp.select_all != 0,
                    epsilon: gp.epsilon,
                    // The snapshot keeps one record per leaf: meta, box, slots.
                    leaves: {
                        let meta = read_paged(&bufs.leaves, (leaves * cfg.leaf_stride) as usize)?;
                        let boxes = read_paged(&bufs.boxes, (leaves * cfg.box_stride()) as usize)?;
                        meta.chunks(cfg.leaf_stride as usize)
                            .zip(boxes.chunks(cfg.box_stride() as usize))
                            .flat_map(|(m, b)| m.iter().chain(b).copied())
                            .collect()
                    },
                    samples: read_paged(&bufs.samples, (n * cfg.sample_stride) as usize)?,
                    values: read_paged(&bufs.values, 3 * n as usize)?,
                })
            };

            // Iterations error → adaptive → evaluate, recorded in batches
            // that grow from FIRST_BATCH to MAX_BATCH; the host reads the
            // state once per batch (progress and the stop test). An
            // observer needs the state after each error pass, so it gets
            // one iteration per batch and a submission after the error pass.
            let observing = observe.is_some() && !final_only;
            let mut batch_size = if observing { 1 } else { FIRST_BATCH };
            let mut state = State(initial_state.to_vec());
            while !state.done() {
                for _ in 0..batch_size {
                    batch.phase("error", |e, ts| {
                        error::record(&mut e.begin_compute_pass(&pass("mdas.error", ts)), &k)
                    })?;
                    if observing {
                        batch.submit();
                        let state = read_state()?;
                        if let Some(observe) = observe.as_mut() {
                            observe(&snapshot(false, &state)?);
                        }
                        batch = profiler.batch("mdas.iteration");
                    }
                    // The adaptive phase in three timed parts (BENCHMARKS.md
                    // splits them): count → scan → apply + plan.
                    batch.phase("adaptive/count", |e, ts| {
                        adapt::record_count(
                            &mut e.begin_compute_pass(&pass("mdas.adapt.count", ts)),
                            &k,
                        )
                    })?;
                    batch.phase("adaptive/scan", |e, ts| {
                        scan::record(&mut e.begin_compute_pass(&pass("mdas.scan", ts)), &k)
                    })?;
                    batch.phase("adaptive/apply", |e, ts| {
                        let mut pass = e.begin_compute_pass(&pass("mdas.adapt.apply", ts));
                        adapt::record_apply(&mut pass, &k);
                        plan::record(&mut pass, &k);
                    })?;
                    batch.phase("evaluate/adaptive", |e, ts| {
                        evaluate::record(
                            &mut e.begin_compute_pass(&pass("mdas.evaluate", ts)),
                            &k,
                            integrand,
                        )
                    })?;
                }
                batch.submit();
                state = read_state()?;
                if let Some(report) = progress.as_mut() {
                    report(state.samples() as u64, cfg.budget as u64);
                }
                batch = profiler.batch("mdas.iteration");
                batch_size = if observing {
                    1
                } else {
                    (batch_size * 2).min(MAX_BATCH)
                };
            }
            if let Some(observe) = observe.as_mut() {
                observe(&snapshot(true, &state)?);
            }

            // Statistics of the samples, then reconstruction.
            let (n, leaves) = (state.samples(), state.leaves());
            batch.phase("reconstruction", |e, ts| {
                stats::record(
                    &mut e.begin_compute_pass(&pass("mdas.stats", ts)),
                    &k,
                    gpu,
                    n,
                )
            })?;
            batch.submit();
            k.group0 = group_reconstruct;
            let grid = Grid::new(gpu, leaves);
            let mut gp = gp;
            for pass_index in 0..cfg.reconstruct_passes {
                gp.pass_offset = pass_index * config::PIXELS_PER_PASS;
                gpu.queue
                    .write_buffer(&bufs.params, 0, bytemuck::bytes_of(&gp));
                profiler.phase("reconstruction", |e, ts| {
                    if pass_index == 0 {
                        e.clear_buffer(accum, 0, Some(cfg.accum_bytes()));
                    }
                    reconstruct::record(
                        &mut e.begin_compute_pass(&pass("mdas.reconstruct", ts)),
                        &k,
                        grid,
                    )
                })?;
            }
            let passes = profiler.finish_detailed()?;
            // One submission copies back the state (its fixed-point
            // exponent, written by stats.wgsl), the counters and the sums.
            let state = Readback::<u32>::new(gpu, &bufs.state, state::LEN)?;
            let counters = Readback::<u32>::new(gpu, &bufs.counters, counter::LEN)?;
            let sums = Readback::<u32>::new(gpu, accum, 8 * cfg.pixels() as usize)?;
            let mut encoder = gpu.device.create_command_encoder(&Default::default());
            for copy in [&state, &counters, &sums] {
                copy.record(&mut encoder);
            }
            gpu.queue.submit([encoder.finish()]);
            let state = State(state.finish(gpu)?);
            let counters = counters.finish(gpu)?;
            let words = sums.finish(gpu)?;
            let image = reconstruct::resolve(&words, state.fixed_exp());
            let stats = RunStats {
                // No iteration runs when the initial samples are the budget.
                iterations: if cfg.initial_samples < cfg.budget {
                    state.iteration()
                } else {
                    0
                },
                leaves,
                collapsed: counters[counter::COLLAPSED],
                budget: cfg.budget,
                initial_samples: cfg.initial_samples,
            };
            let render = Render {
                film: cfg.film,
                image,
                samples: n as u64,
                nonfinite: counters[counter::NONFINITE] as u64,
                times: passes.folded(),
                clock,
                gpu_bytes: cfg.gpu_bytes(),
            };
            Ok((render, stats, passes))
        });
        self.progress = progress;
        let (render, stats, passes) = result?;
        self.last = Some(stats);
        self.last_passes = Some(passes);
        Ok(render)
    }
}

/// The state buffer as read back.
struct State(Vec<u32>);

impl State {
    fn leaves(&self) -> u32 {
        self.0[state::LEAVES]
    }

    fn samples(&self) -> u32 {
        self.0[state::SAMPLES]
    }

    fn iteration(&self) -> u32 {
        self.0[state::ITERATION]
    }

    fn done(&self) -> bool {
        self.0[state::DONE] != 0
    }

    /// 1/c of the paced selection for the current iteration (plan.wgsl).
    fn inv_pace(&self) -> f32 {
        f32::from_bits(self.0[state::INV_PACE])
    }

    /// The exponent the reconstruction scaled colours by (stats.wgsl).
    fn fixed_exp(&self) -> i32 {
        self.0[state::FIXED_EXP] as i32
    }
}

/// The fewest samples a paced iteration aims to place (`pace_floor` of
/// plan.wgsl): a quarter of what its share takes of the value-driven
/// samples at the start, so that the geometric shrinking of the share
/// ends in a few iterations; 0 without pacing.
fn pace_floor(pace: f32, adaptive: u32) -> u32 {
    if pace > 0.0 {
        ((f64::from(pace) / 4.0 * f64::from(adaptive)).ceil() as u32).max(1)
    } else {
        0
    }
}

fn pass<'a>(
    label: &'static str,
    ts: Option<wgpu::ComputePassTimestampWrites<'a>>,
) -> wgpu::ComputePassDescriptor<'a> {
    wgpu::ComputePassDescriptor {
        label: Some(label),
        timestamp_writes: ts,
    }
}
