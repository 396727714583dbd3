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
//! half small triangles, uniform in a cube. Then the lighting grid
//! hierarchy's build for the same sizes (`bench_lgh`). Run: `cargo bench
//! --bench light_tree`.

use criterion::{criterion_group, criterion_main, Criterion};
use glam::Vec3;
use mdas::gpu::Gpu;
use mdas::lights::tree::gpu_build::{BuildTimes, GpuLightTree};
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

/// The median (NaN when criterion's filter skipped the measurement).
fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(|a, b| a.partial_cmp(b).unwrap());
    v.get(v.len() / 2).copied().unwrap_or(f64::NAN)
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

/// The lighting grid hierarchy's GPU build (`lights::lgh::gpu`; the LGH
/// paper's Table 2 row "Hierarchy Construction": 7.0 / 9.2 / 12.1 / 32.0 ms
/// for 1K / 10K / 100K / 1M VPLs on an RTX 2080) with the default level
/// count. Lights: half points, half VPLs (random normals), uniform in a
/// cube.
fn bench_lgh(c: &mut Criterion) {
    use mdas::lights::lgh::gpu::{GpuLgh, PHASES};
    use mdas::lights::lgh::LghParams;
    let gpu = Gpu::shared().expect("benches need a wgpu adapter");
    let mut rows = Vec::new();
    for (size, n) in [
        ("1k", 1_000usize),
        ("10k", 10_000),
        ("100k", 100_000),
        ("1M", 1 << 20),
    ] {
        let prims: Vec<LightPrim> = lights(n)
            .into_iter()
            .map(|l| match l.kind {
                mdas::lights::KIND_TRIANGLE => {
                    let n = Vec3::from(l.p1) - Vec3::from(l.p0);
                    LightPrim::vpl(Vec3::from(l.p0), n.normalize_or(Vec3::Y), Vec3::ONE)
                }
                _ => l,
            })
            .collect();
        let buffer = gpu
            .buffer_from("bench.lights", &prims, wgpu::BufferUsages::STORAGE)
            .unwrap();
        let lgh = GpuLgh::new(gpu, &prims, &LghParams::default()).unwrap();
        let build = || {
            let mut profiler = mdas::gpu::Profiler::new(gpu);
            lgh.build(gpu, &buffer, &mut profiler).unwrap();
            profiler.finish().unwrap()
        };
        build(); // warm-up
        let mut times = Vec::new();
        let mut group = c.benchmark_group(format!("lgh_build_{size}"));
        group
            .sample_size(10)
            .warm_up_time(Duration::from_millis(1))
            .measurement_time(Duration::from_secs(2));
        group.bench_function("build", |b| {
            b.iter_custom(|iters| {
                let start = std::time::Instant::now();
                for _ in 0..iters {
                    times.push(build());
                }
                start.elapsed()
            })
        });
        group.finish();
        let phase = |name: &str| median(times.iter().map(|t| t.get(name).unwrap_or(0.0)).collect());
        let total = median(times.iter().map(|t| t.total()).collect());
        let grid_lights = lgh.read(gpu).unwrap().1;
        rows.push((
            size,
            lgh.grid.levels,
            grid_lights,
            PHASES.map(phase),
            total,
            times.len(),
        ));
    }
    eprintln!("\nlighting grid hierarchy build, median ms per phase (lgh.grid on the host):");
    eprintln!("| lights | levels | grid lights | grid | keys | sort | cells | level 1 | levels ≥ 2 | total | builds |");
    eprintln!("|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|");
    for (size, levels, count, p, total, builds) in rows {
        eprintln!(
            "| {size} | {levels} | {count} | {:.3} | {:.3} | {:.3} | {:.3} | {:.3} | {:.3} | {total:.3} | {builds} |",
            p[0], p[1], p[2], p[3], p[4], p[5]
        );
    }
}

criterion_group!(benches, bench, bench_lgh);
criterion_main!(benches);
