//! The lighting grid hierarchy's bias without shadows (issue 49 item 2):
//! at the first hit of one primary ray per pixel, the grid hierarchy's
//! unshadowed sum `Σ f` over its candidates (`lights::lgh`, the CPU oracle
//! of the GPU's shading) against the exact unshadowed sum over every
//! light, `Σᵢ Iᵢ cosθ / d²` (the same emitter model), for both ways of
//! gathering the coarse levels — the cascade the GPU builds and the
//! paper's levels from S₁ (`lgh::Coarse`) — at α = 1 and 2. The render's
//! whole bias (with shadow rays, over seeds: BENCHMARKS.md) minus this
//! unshadowed part is what the shadow estimate adds.
//!
//! The table gives, per scene and variant, the relative bias of the
//! summed luminance over the hit points (the film's sum, albedo left out:
//! each pixel weighs by its irradiance) and the mean over pixels of the
//! absolute relative error (pixels whose exact sum is below 10⁻³ of the
//! mean left out of that mean).
//!
//! Run: `cargo bench --bench lgh_bias` (env: SCENES, a space-separated
//! list; SCALES, one film scale per scene). Prints a markdown table.

use anyhow::Result;
use glam::Vec3;
use mdas::accel::trace::pinhole_rays;
use mdas::accel::{BuiltScene, GpuScene, TraceKernel, TraceMode, MISS};
use mdas::gpu::Gpu;
use mdas::integrand::{IntegrandSpec, ManyLight};
use mdas::lights::lgh::{self, Coarse, Emitter, LghParams};
use mdas::lights::LightPrim;
use mdas::session;
use std::path::Path;
use std::sync::Arc;

fn env_or(name: &str, default: &str) -> String {
    std::env::var(name).unwrap_or_else(|_| default.to_string())
}

fn luminance(c: Vec3) -> f64 {
    f64::from(0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z)
}

/// A shading point: position and unit normal facing the camera.
type Point = (Vec3, Vec3);

/// The exact unshadowed luminance at each point, over every light.
fn exact(prims: &[LightPrim], clamp2: f32, points: &[Point]) -> Vec<f64> {
    let emitters: Vec<Emitter> = prims.iter().map(|l| Emitter::light(l, clamp2)).collect();
    parallel(points, |&(x, n)| {
        luminance(
            emitters
                .iter()
                .fold(Vec3::ZERO, |acc, e| acc + e.eval(x, n)),
        )
    })
}

/// `f` over `points` on every core, in order.
fn parallel(points: &[Point], f: impl Fn(&Point) -> f64 + Sync) -> Vec<f64> {
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get());
    let chunk = points.len().div_ceil(threads).max(1);
    std::thread::scope(|s| {
        let handles: Vec<_> = points
            .chunks(chunk)
            .map(|c| s.spawn(|| c.iter().map(&f).collect::<Vec<f64>>()))
            .collect();
        handles
            .into_iter()
            .flat_map(|h| h.join().expect("worker"))
            .collect()
    })
}

fn main() -> Result<()> {
    let gpu = Gpu::shared()?;
    let scenes = env_or(
        "SCENES",
        "scenes/tests/vpl_atrium_points.toml scenes/lights_1m.toml",
    );
    let scales = env_or("SCALES", "1 0.125");
    let scales: Vec<f32> = scales
        .split_whitespace()
        .map(str::parse)
        .collect::<Result<_, _>>()?;
    println!("device: {} ({:?})\n", gpu.info.name, gpu.info.backend);
    println!("| scene (film) | lights | levels | coarse levels | α | unshadowed bias (film sum) | mean abs. rel. error per pixel | CPU build ms |");
    println!("|---|---:|---:|---|---:|---:|---:|---:|");
    for (k, file) in scenes.split_whitespace().enumerate() {
        let loaded = mdas::scene_file::load(Path::new(file))?;
        let scene = &loaded.scene;
        let scale = scales.get(k).copied().unwrap_or(1.0);
        let film = session::scaled_film(scene.film, scale)?;
        let built = BuiltScene::new(scene)?;
        let gpu_scene = Arc::new(GpuScene::upload(gpu, scene, &built, film)?);
        let kernel = TraceKernel::new(gpu, &gpu_scene)?;
        let rays = pinhole_rays(&scene.camera, film);
        let hits = kernel.run_mode(gpu, &gpu_scene, &rays, TraceMode::Closest)?;
        let IntegrandSpec::ManyLight(spec) = &loaded.integrand else {
            anyhow::bail!("{file} is not a many_light scene");
        };
        let prims = ManyLight::new(gpu, scene, gpu_scene.clone(), film, spec)?
            .lights()
            .to_vec();
        let clamp2 = spec.vpl.clamp * spec.vpl.clamp;
        let points: Vec<Point> = rays
            .iter()
            .zip(&hits)
            .filter(|(_, h)| h.prim != MISS)
            .map(|(r, h)| {
                let dir = Vec3::from(r.dir);
                let x = Vec3::from(r.origin) + h.t * dir;
                let v = |i: usize| Vec3::from_slice(&built.triangles[3 * h.prim as usize + i][..3]);
                let n = (v(1) - v(0)).cross(v(2) - v(0)).normalize();
                (x, if n.dot(dir) > 0.0 { -n } else { n })
            })
            .collect();
        let truth = exact(&prims, clamp2, &points);
        let mean = truth.iter().sum::<f64>() / truth.len().max(1) as f64;
        for coarse in [Coarse::Cascade, Coarse::FromS1] {
            let start = std::time::Instant::now();
            let h = lgh::build_with(&prims, spec.lgh.levels, coarse)?;
            let build_ms = start.elapsed().as_secs_f64() * 1e3;
            for alpha in [1.0f32, 2.0] {
                let params = LghParams { alpha, ..spec.lgh };
                let est = parallel(&points, |&(x, n)| {
                    let f = h
                        .candidates(&prims, &params, clamp2, x, n)
                        .iter()
                        .fold(Vec3::ZERO, |a, c| a + c.f);
                    luminance(f)
                });
                let bias = est.iter().sum::<f64>() / truth.iter().sum::<f64>() - 1.0;
                let lit: Vec<(f64, f64)> = est
                    .iter()
                    .zip(&truth)
                    .filter(|(_, &t)| t > 1e-3 * mean)
                    .map(|(&e, &t)| (e, t))
                    .collect();
                let rel = lit.iter().map(|(e, t)| (e / t - 1.0).abs()).sum::<f64>()
                    / lit.len().max(1) as f64;
                println!(
                    "| `{file}` ({}×{}) | {} | {} | {coarse:?} | {alpha} | {:+.2} % | {:.2} % | {build_ms:.0} |",
                    film.width,
                    film.height,
                    prims.len(),
                    h.grid.levels,
                    100.0 * bias,
                    100.0 * rel,
                );
            }
        }
    }
    Ok(())
}
