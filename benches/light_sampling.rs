//! Light-sampling cost of the `many_light` integrand per sampler: the
//! frame set-up (VPL generation where the scene has VPLs, GPU light-tree
//! build phases, CPU builds, cut pre-pass) and
//! the time per sample of a Halton render (one camera ray, one light
//! selection, one shadow ray), on the known-answer plane with 4,096 point
//! lights, `cornell_lights`, the isotropic VPL stand-in and `vpl_atrium`
//! with its 100,000 generated VPLs.
//!
//! Method: each (scene, sampler) integrand is set up once (set-up times from
//! its own profiler), then rendered with Halton at `SPP` samples per pixel:
//! one warm-up render, then `RUNS` timed renders; the figure is the median
//! total GPU time (timestamps where the adapter has them). The difference
//! to `uniform` on the same scene is the selection's own cost: the rays
//! are the same in number. Output: one table row per (scene, sampler).
//!
//! Run: `cargo bench --bench light_sampling` (a few minutes on lavapipe;
//! `MDAS_BENCH_SCALE=1` for full films on a GPU).

use mdas::accel::GpuScene;
use mdas::app;
use mdas::gpu::Gpu;
use mdas::integrand::IntegrandSpec;
use mdas::integrand::ManyLight;
use mdas::integrand::ManyLightSpec;
use mdas::integrator::{Halton, Integrator};
use mdas::lights::sampler::SamplerKind;
use std::path::Path;
use std::sync::Arc;

const SPP: u32 = 4;
const RUNS: usize = 3;

fn main() -> anyhow::Result<()> {
    let gpu = Gpu::shared()?;
    let scale: f32 = std::env::var("MDAS_BENCH_SCALE").map_or(0.25, |s| s.parse().unwrap());
    println!(
        "adapter: {} ({:?}), {SPP} spp, median of {RUNS}",
        gpu.info.name, gpu.info.backend
    );
    println!("| scene | film | lights | sampler | set-up ms (VPLs / build / cuts) | render ms | ns/sample | vs uniform |");
    println!("|---|---|---:|---|---:|---:|---:|---:|");
    for (file, s) in [
        ("scenes/tests/point_lights_plane.toml", 1.0),
        ("scenes/cornell_lights.toml", scale),
        ("scenes/tests/vpl_atrium_points.toml", scale),
        ("scenes/vpl_atrium.toml", scale),
    ] {
        let loaded = mdas::scene_file::load(Path::new(file))?;
        let scene = &loaded.scene;
        let film = app::scaled_film(scene.film, s)?;
        let IntegrandSpec::ManyLight(spec) = &loaded.integrand else {
            anyhow::bail!("{file} is not a many_light scene")
        };
        let gpu_scene = Arc::new(GpuScene::new(gpu, scene, film)?);
        let mut uniform_ns = None;
        for kind in SamplerKind::ALL {
            let spec = ManyLightSpec {
                sampler: kind,
                ..spec.clone()
            };
            let integrand = ManyLight::new(gpu, scene, gpu_scene.clone(), film, &spec)?;
            let setup = integrand.setup_times();
            let cuts = setup.get("many_light.cuts").unwrap_or(0.0);
            let vpls = setup.get("many_light.vpl").unwrap_or(0.0);
            let build = setup.total() - cuts - vpls;
            let mut halton = Halton::new(SPP, 1);
            halton.render(gpu, &integrand)?;
            let mut times: Vec<f64> = (0..RUNS)
                .map(|_| halton.render(gpu, &integrand).map(|r| r.times.total()))
                .collect::<anyhow::Result<_>>()?;
            times.sort_by(f64::total_cmp);
            let ms = times[RUNS / 2];
            let samples = SPP as f64 * film.width as f64 * film.height as f64;
            let ns = ms * 1e6 / samples;
            let base = *uniform_ns.get_or_insert(ns);
            println!(
                "| `{}` | {}×{} | {} | {kind} | {vpls:.2} / {:.2} / {:.2} | {ms:.1} | {ns:.0} | {:+.0} ns |",
                Path::new(file).file_stem().unwrap().to_string_lossy(),
                film.width,
                film.height,
                integrand.light_count(),
                build,
                cuts,
                ns - base
            );
        }
    }
    Ok(())
}
