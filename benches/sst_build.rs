//! The stochastic substitute tree's radix build (`sst`, `sst_nosub`;
//! issue 66 item 3): the CPU oracle (`lights::substitute::radix::build`)
//! against the GPU build (`lights::substitute::gpu_build::GpuRadixTree`,
//! bit for bit the same tree) for 40k, 100k and 1M lights, on the
//! process's adapter (a GPU if present, else lavapipe). The CPU figure is
//! the whole build on one thread (keys, sort, tree, bounds, cones,
//! substitutes); the GPU figure a full build submitted and waited for
//! ([`GpuRadixTree::build_timed`]; the lights already on the GPU, as the
//! renderer has them). After criterion's figures the bench prints the
//! median of every GPU phase. Lights: three quarters VPLs with random
//! normals, the rest points and small triangles, uniform in a box.
//! Run: `cargo bench --bench sst_build` (`-- cpu` or `-- gpu` for one
//! side, `-- 100k` for one size).

use criterion::{criterion_group, criterion_main, Criterion};
use glam::Vec3;
use mdas::compare::equal_time::median;
use mdas::gpu::Gpu;
use mdas::lights::substitute::gpu_build::{GpuRadixTree, PHASES};
use mdas::lights::substitute::radix;
use mdas::lights::LightPrim;
use rand::rngs::StdRng;
use rand::{RngExt, SeedableRng};
use std::time::Duration;

fn lights(n: usize) -> Vec<LightPrim> {
    let mut rng = StdRng::seed_from_u64(n as u64);
    let v = |rng: &mut StdRng, r: f32| {
        Vec3::new(
            rng.random_range(-r..r),
            rng.random_range(-r..r),
            rng.random_range(-r..r),
        )
    };
    (0..n)
        .map(|i| {
            let p = v(&mut rng, 10.0);
            match i % 8 {
                0 => LightPrim::point(p, Vec3::ONE),
                1 => {
                    let (a, b) = (v(&mut rng, 0.1), v(&mut rng, 0.1));
                    LightPrim::triangle(p, p + a, p + b, Vec3::ONE)
                }
                _ => LightPrim::vpl(p, v(&mut rng, 1.0).normalize_or(Vec3::Y), Vec3::ONE),
            }
        })
        .collect()
}

fn bench(c: &mut Criterion) {
    let gpu = Gpu::shared().expect("benches need a wgpu adapter");
    eprintln!("{}", gpu.describe());
    let mut rows = Vec::new();
    for (size, n) in [("40k", 40_000usize), ("100k", 100_000), ("1M", 1 << 20)] {
        let prims = lights(n);
        let mut group = c.benchmark_group(format!("sst_build_{size}"));
        group
            .sample_size(10)
            .warm_up_time(Duration::from_millis(1))
            .measurement_time(Duration::from_secs(2));
        group.bench_function("cpu", |b| b.iter(|| radix::build(&prims).unwrap()));
        let buffer = gpu
            .buffer_from("bench.lights", &prims, wgpu::BufferUsages::STORAGE)
            .unwrap();
        let mut tree = GpuRadixTree::new(gpu, n as u32).unwrap();
        let mut times = Vec::new();
        group.bench_function("gpu", |b| {
            // Warm-up outside the timing: pipelines and first-touch memory.
            tree.build_timed(gpu, &buffer, n as u32).unwrap();
            b.iter_custom(|iters| {
                let start = std::time::Instant::now();
                for _ in 0..iters {
                    times.push(tree.build_timed(gpu, &buffer, n as u32).unwrap());
                }
                start.elapsed()
            })
        });
        group.finish();
        // (NaN when criterion's filter skipped the measurement.)
        let phase = |name: &str| {
            median(
                &times
                    .iter()
                    .map(|t| t.get(name).unwrap_or(0.0))
                    .collect::<Vec<_>>(),
            )
        };
        let total = median(&times.iter().map(|t| t.total()).collect::<Vec<_>>());
        rows.push((size, PHASES.map(phase), total, times.len()));
    }
    let clock = mdas::gpu::Profiler::new(gpu).clock();
    eprintln!("\nsst radix tree GPU build, median ms per phase ({clock:?}):");
    eprintln!("| lights | {} | total | builds |", PHASES.join(" | "));
    eprintln!("|---:|{}---:|---:|", "---:|".repeat(PHASES.len()));
    for (size, p, total, builds) in rows {
        let cells: Vec<String> = p.iter().map(|t| format!("{t:.3}")).collect();
        eprintln!("| {size} | {} | {total:.3} | {builds} |", cells.join(" | "));
    }
}

criterion_group!(benches, bench);
criterion_main!(benches);
