//! Integrand throughput on the MDAS paper's seven stand-in scenes
//! (`scenes/{pool,chess,street,dragon,cobblestone,cornell_pt,breakfast}.toml`):
//! samples/s and rays/s (camera + secondary: bounce, shadow, occlusion
//! rays) of a Halton render at a reduced film size.
//!
//! Method: each scene is loaded at `SCALE` of its film size (BVH build not
//! timed) and rendered with Halton at `SPP` samples per pixel: one warm-up
//! render, then `RUNS` timed renders; the figure is the median of the
//! renders' total GPU time (evaluate + accumulate phases; GPU timestamps
//! where the adapter has them, wall clock with a device sync otherwise).
//! Rays per render are counted exactly by a kernel
//! (`tests/kernels/count_rays.wgsl`) that evaluates the same Halton points
//! and reads the integrand's ray counter, so rays/s = counted rays / median
//! time. "Worst steps/sample" is the most BVH traversal loop iterations
//! one sample took (all its rays together): Halton evaluates up to 8
//! samples per invocation and lavapipe silently ends an invocation's loops
//! after 65,535 iterations, so 8× this must stay well below that. Output:
//! one table row per scene, on stdout.
//!
//! Run: `cargo bench --bench integrands` (a few minutes on lavapipe;
//! `MDAS_BENCH_SCALE=0.25` for larger films on a GPU).

use mdas::gpu::shader::{bind_buffers, storage_entry, uniform_entry};
use mdas::gpu::Gpu;
use mdas::integrand::Integrand;
use mdas::integrator::{Halton, Integrator};
use mdas::session;
use std::path::Path;

const SCENES: [&str; 7] = [
    "pool",
    "chess",
    "street",
    "dragon",
    "cobblestone",
    "cornell_pt",
    "breakfast",
];
const SPP: u32 = 4;
const RUNS: usize = 5;
const SEED: u32 = 1;

#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct CountParams {
    width: u32,
    height: u32,
    dims: u32,
    seed: u32,
    spp: u32,
    _pad: [u32; 3],
}

/// Rays the integrand traces for Halton samples 0..SPP of every pixel,
/// and the most traversal loop iterations one sample took.
fn count_rays(gpu: &Gpu, integrand: &dyn Integrand) -> anyhow::Result<(u64, u32)> {
    let film = integrand.film();
    let pixels = film.width * film.height;
    let layout = gpu.bind_group_layout(
        "bench.count_rays.layout",
        &[uniform_entry(0), storage_entry(1, false)],
    );
    let source = mdas::integrator::halton::with_halton_points(
        integrand.wgsl(),
        (
            "tests/kernels/count_rays.wgsl",
            include_str!("../tests/kernels/count_rays.wgsl"),
        ),
    );
    let pipeline = gpu.compute_pipeline(
        "bench.count_rays",
        &source,
        "main",
        &mdas::integrand::kernel_layouts(&layout, integrand),
    )?;
    let params = gpu.uniform(
        "bench.count_rays.params",
        &CountParams {
            width: film.width,
            height: film.height,
            dims: integrand.dims(),
            seed: SEED,
            spp: SPP,
            _pad: [0; 3],
        },
    );
    let rays = gpu.buffer_zeroed(
        "bench.count_rays.counts",
        16 * pixels as u64,
        mdas::gpu::buffer::STORAGE,
    )?;
    let group = bind_buffers(gpu, "bench.count_rays", &layout, &[&params, &rays]);
    gpu.scoped("counting rays", || {
        let mut encoder = gpu.device.create_command_encoder(&Default::default());
        {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("bench.count_rays"),
                timestamp_writes: None,
            });
            pass.set_pipeline(&pipeline);
            pass.set_bind_group(0, &group, &[]);
            mdas::integrand::bind_integrand(&mut pass, integrand);
            pass.dispatch_workgroups(pixels.div_ceil(64), 1, 1);
        }
        gpu.queue.submit([encoder.finish()]);
        Ok(())
    })?;
    let counts: Vec<[u32; 4]> = gpu.read_buffer(&rays, pixels as usize)?;
    let nonfinite: u64 = counts.iter().map(|c| c[2] as u64).sum();
    if nonfinite > 0 {
        anyhow::bail!("{nonfinite} non-finite samples");
    }
    let worst = counts.iter().map(|c| c[1]).max().unwrap_or(0);
    Ok((counts.iter().map(|c| c[0] as u64).sum(), worst))
}

fn main() -> anyhow::Result<()> {
    let gpu = Gpu::shared()?;
    let scale: f32 = std::env::var("MDAS_BENCH_SCALE").map_or(Ok(0.125), |s| s.parse())?;
    println!(
        "integrand throughput, Halton {SPP} spp, film scale {scale}, median of {RUNS} renders, device: {}",
        gpu.info.name
    );
    println!(
        "| scene | integrand | d | film | triangles | rays/sample | worst steps/sample | ms | Msamples/s | Mrays/s |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|");
    for name in SCENES {
        let path = format!("scenes/{name}.toml");
        let prepared = session::prepare(gpu, Path::new(&path), scale)?;
        let integrand = prepared.integrand.as_ref();
        let mut halton = Halton::new(SPP, SEED);
        halton.render(gpu, integrand)?; // warm-up: pipelines, caches
        let mut ms: Vec<f64> = (0..RUNS)
            .map(|_| halton.render(gpu, integrand).map(|r| r.times.total()))
            .collect::<anyhow::Result<_>>()?;
        ms.sort_by(f64::total_cmp);
        let median = ms[RUNS / 2];
        let (rays, worst_steps) = count_rays(gpu, integrand)?;
        let film = prepared.film;
        let samples = film.width as u64 * film.height as u64 * SPP as u64;
        println!(
            "| {name} | {} | {} | {}×{} | {} | {:.2} | {worst_steps} | {:.1} | {:.3} | {:.3} |",
            integrand.name(),
            integrand.dims(),
            film.width,
            film.height,
            prepared.scene.scene.triangle_count(),
            rays as f64 / samples as f64,
            median,
            samples as f64 / median / 1e3,
            rays as f64 / median / 1e3,
        );
    }
    Ok(())
}
