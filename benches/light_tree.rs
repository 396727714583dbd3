//! GPU perfect light tree build time per phase (real-time stochastic
//! lightcuts Table 1) for 1k, 10k, 100k and 1M lights, on the process's
//! adapter (a GPU if present, else lavapipe).
//!
//! Each size is built without and with orientation cones (`tree` against
//! `tree_cone`: the cost of cones is the difference). Each criterion sample
//! is one full build ([`GpuLightTree::build_timed`]: bounds, Morton codes,
//! sort, leaves, internal levels and, with cones, the cone levels, each
//! submitted and timed by the profiler). After criterion's figure the bench prints the
//! median of every phase over all builds (GPU timestamps where the adapter
//! has them, else wall clock around a device sync). Lights: half points,
//! half small triangles, uniform in a cube. Run: `cargo bench --bench light_tree`.

use criterion::{criterion_group, criterion_main, Criterion};
use glam::Vec3;
use mdas::gpu::Gpu;
use mdas::lights::gpu_build::{BuildTimes, GpuLightTree};
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
            if i % 2 == 0 {
                LightPrim::point(p, Vec3::ONE)
            } else {
                let (a, b) = (v(&mut rng, 0.1), v(&mut rng, 0.1));
                LightPrim::triangle(p, p + a, p + b, Vec3::ONE)
            }
        })
        .collect()
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(|a, b| a.partial_cmp(b).unwrap());
    v[v.len() / 2]
}

fn bench(c: &mut Criterion) {
    let gpu = Gpu::shared().expect("benches need a wgpu adapter");
    eprintln!("{}", gpu.describe());
    let mut rows = Vec::new();
    let sizes = [
        ("1k", 1_000u32),
        ("10k", 10_000),
        ("100k", 100_000),
        ("1M", 1 << 20),
    ];
    for ((size, n), cones) in sizes.into_iter().flat_map(|s| [(s, false), (s, true)]) {
        let label = if cones {
            format!("{size} +cones")
        } else {
            size.to_string()
        };
        let prims = lights(n as usize);
        let buffer = gpu
            .buffer_from("bench.lights", &prims, wgpu::BufferUsages::STORAGE)
            .unwrap();
        let mut tree = GpuLightTree::new(gpu, n, cones).unwrap();
        tree.build_timed(gpu, &buffer, n).unwrap(); // warm-up
        let mut times: Vec<BuildTimes> = Vec::new();
        let mut group = c.benchmark_group(format!("light_tree_{}", label.replace(" +", "_")));
        group
            .sample_size(10)
            .warm_up_time(Duration::from_millis(1))
            .measurement_time(Duration::from_secs(2));
        group.bench_function("build", |b| {
            b.iter_custom(|iters| {
                let start = std::time::Instant::now();
                for _ in 0..iters {
                    times.push(tree.build_timed(gpu, &buffer, n).unwrap());
                }
                start.elapsed()
            })
        });
        group.finish();
        let m = |f: fn(&BuildTimes) -> f64| median(times.iter().map(f).collect());
        rows.push((
            label,
            [
                m(|t| t.bounds),
                m(|t| t.morton),
                m(|t| t.sort),
                m(|t| t.leaves),
                m(|t| t.internal),
                m(|t| t.cones),
                m(|t| t.total()),
            ],
            times.len(),
        ));
    }
    let clock = mdas::gpu::Profiler::new(gpu).clock();
    eprintln!("\nlight tree build, median ms per phase ({clock:?}):");
    eprintln!("| lights | bounds | morton | sort | leaves | internal | cones | total | builds |");
    eprintln!("|---:|---:|---:|---:|---:|---:|---:|---:|---:|");
    for (label, t, count) in rows {
        eprintln!(
            "| {label} | {:.3} | {:.3} | {:.3} | {:.3} | {:.3} | {:.3} | {:.3} | {count} |",
            t[0], t[1], t[2], t[3], t[4], t[5], t[6]
        );
    }
}

criterion_group!(benches, bench);
criterion_main!(benches);
