//! MDAS per-phase timings at 4D with ~1M and ~4M samples, on the process's
//! adapter (a GPU if present, else lavapipe), using a cheap scene-free
//! integrand (f = (x, y, u0): contrast everywhere, so every phase works).
//!
//! Each criterion sample is one full render; the bench reports the total
//! and, per phase, the median of the `Render::times` figures (GPU
//! timestamps where the adapter has them, else wall clock around a device
//! sync), plus GPU bytes per sample. The same films are also rendered with
//! Halton at the same 8 spp (group `halton_4d_*`: evaluate + accumulate),
//! the baseline of the equal-time comparisons. Run: `cargo bench --bench mdas`.

use criterion::{criterion_group, criterion_main, Criterion};
use mdas::compare::phases::ADAPTIVE_PARTS;
use mdas::film::Film;
use mdas::gpu::shader::{bind_buffers, storage_entry, Wgsl};
use mdas::gpu::Gpu;
use mdas::integrand::{point_wgsl, Integrand};
use mdas::integrator::mdas::MdasParams;
use mdas::integrator::{Halton, Integrator, Mdas, Render};
use std::time::Duration;

/// Test case 0 of tests/kernels/test_integrands.wgsl.
struct Linear {
    film: Film,
    layout: wgpu::BindGroupLayout,
    group: wgpu::BindGroup,
}

impl Linear {
    fn new(gpu: &Gpu, film: Film) -> Self {
        let layout = gpu.bind_group_layout("bench.integrand.layout", &[storage_entry(0, true)]);
        let buffer = gpu
            .buffer_from::<u32>("bench.integrand.unused", &[], wgpu::BufferUsages::STORAGE)
            .unwrap();
        let group = bind_buffers(gpu, "bench.integrand", &layout, &[&buffer]);
        Linear {
            film,
            layout,
            group,
        }
    }
}

impl Integrand for Linear {
    fn name(&self) -> &'static str {
        "linear"
    }
    fn dims(&self) -> u32 {
        4
    }
    fn film(&self) -> Film {
        self.film
    }
    fn wgsl(&self) -> Wgsl {
        point_wgsl().constant("TEST_CASE", 0).part((
            "tests/kernels/test_integrands.wgsl",
            include_str!("../tests/kernels/test_integrands.wgsl"),
        ))
    }
    fn layout(&self) -> Option<&wgpu::BindGroupLayout> {
        Some(&self.layout)
    }
    fn bind_group(&self) -> Option<&wgpu::BindGroup> {
        Some(&self.group)
    }
}

const PHASES: [&str; 5] = ["initial", "evaluate", "error", "adaptive", "reconstruction"];

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(|a, b| a.partial_cmp(b).unwrap());
    v[v.len() / 2]
}

/// Criterion group `name` of whole renders (one warm-up first); returns
/// every timed render, for the per-phase medians, and with MDAS the times
/// of the adaptive phase's parts of each ([`ADAPTIVE_PARTS`] order).
///
fn timed_renders(
    c: &mut Criterion,
    name: &str,
    mut render: impl FnMut() -> (Render, Option<Vec<f64>>),
) -> (Render, Vec<Render>, Vec<Vec<f64>>) {
    let (warm, _) = render();
    let mut renders = Vec::new();
    let mut parts = Vec::new();
    let mut group = c.benchmark_group(name);
    group
        .sample_size(10)
        .warm_up_time(Duration::from_millis(1))
        .measurement_time(Duration::from_secs(1));
    group.bench_function("render", |b| {
        b.iter_custom(|iters| {
            let start = std::time::Instant::now();
            for _ in 0..iters {
                let (r, p) = render();
                renders.push(r);
                parts.extend(p);
            }
            start.elapsed()
        })
    });
    group.finish();
    (warm, renders, parts)
}

fn bench(c: &mut Criterion) {
    let gpu = Gpu::shared().expect("benches need a wgpu adapter");
    eprintln!("{}", gpu.describe());
    // 4D, spp 8, l = m = 4 (paper §5.1), b = 1; e sets the initial quarter.
    for (label, width, height, extra) in [("1M", 512u32, 256u32, 6u32), ("4M", 1024, 512, 7)] {
        let film = Film { width, height };
        let integrand = Linear::new(gpu, film);
        let params = MdasParams {
            bits_per_dim: 1,
            extra_image_bits: extra,
            initial_samples_per_cell: 4,
            scale_factor: 1.0,
            alpha: 0.25,
            candidates: 4,
            max_samples_per_leaf: 4,
            epsilon: mdas::integrator::mdas::params::EPSILON,
            split: mdas::integrator::mdas::SplitRule::Extent,
            reconstruction: mdas::integrator::mdas::Reconstruction::Box,
            pixel_prior: mdas::integrator::mdas::params::PIXEL_PRIOR,
            pace: 0.0,
            initial_offsets: mdas::integrator::mdas::InitialOffsets::Random,
            spp: 8.0,
            seed: 1,
            auto_grid: false,
        };
        let mut mdas = Mdas::new(params).unwrap();
        let (warm, renders, parts) = timed_renders(c, &format!("mdas_4d_{label}"), || {
            let r = mdas.render(gpu, &integrand).unwrap();
            let times = mdas.last_pass_times().unwrap();
            let parts = ADAPTIVE_PARTS
                .iter()
                .map(|p| times.get(p).unwrap_or(0.0))
                .collect();
            (r, Some(parts))
        });
        let stats = mdas.last_stats().unwrap();
        eprintln!(
            "mdas 4D {label}: {} samples ({} initial), {} iterations, {} leaves, {:.1} GPU bytes/sample, clock {:?}, {} renders",
            warm.samples,
            stats.initial_samples,
            stats.iterations,
            stats.leaves,
            warm.gpu_bytes as f64 / warm.samples as f64,
            warm.clock,
            renders.len()
        );
        for phase in PHASES {
            let ms = median(
                renders
                    .iter()
                    .map(|r| r.times.get(phase).unwrap_or(0.0))
                    .collect(),
            );
            eprintln!("  {phase:<15} {ms:9.2} ms (median)");
        }
        let sampling: f64 = ["initial", "error", "adaptive", "reconstruction"]
            .iter()
            .map(|p| {
                median(
                    renders
                        .iter()
                        .map(|r| r.times.get(p).unwrap_or(0.0))
                        .collect(),
                )
            })
            .sum();
        eprintln!("  sampling total  {sampling:9.2} ms (median sum)");
        for (i, part) in ADAPTIVE_PARTS.iter().enumerate() {
            let ms = median(parts.iter().map(|p| p[i]).collect());
            eprintln!("  {part:<15} {ms:9.2} ms (median)");
        }

        let mut halton = Halton::new(8, 1);
        let (_, halton_renders, _) = timed_renders(c, &format!("halton_4d_{label}"), || {
            (halton.render(gpu, &integrand).unwrap(), None)
        });
        let total = median(halton_renders.iter().map(|r| r.times.total()).collect());
        eprintln!(
            "halton 4D {label}: {} samples, {total:.2} ms (median GPU total: evaluate + accumulate)",
            halton_renders[0].samples
        );
    }
}

criterion_group!(benches, bench);
criterion_main!(benches);
