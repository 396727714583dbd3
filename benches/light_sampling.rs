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
//! are the same in number (except for `lgh`, which sums over its grid
//! lights and casts S shadow rays: it runs with S = 0, 1, 4 and 16).
//! Output: one table row per (scene, sampler).
//!
//! For the scenes with VPLs it also prints `sst`'s mean stop depth (the
//! substitute-tree paper's Fig. 5 measure: 15 for SST against 20 for
//! stochastic lightcuts at 100k VPLs) and its share of stops at
//! substitutes, on the radix tree and on `sst_perfect`'s perfect tree, on
//! the CPU oracle over the frame's lights: 16 draws at each of 2,000
//! shading points placed at VPLs (points on lit diffuse surfaces, lifted
//! 1 mm along their normals) — a proxy for the camera's shading points.
//! The perfect tree's leaves all sit at depth log2(P).
//!
//! Run: `cargo bench --bench light_sampling` (a few minutes on lavapipe;
//! `MDAS_BENCH_SCALE=1` for full films on a GPU; `MDAS_BENCH_STOPS_ONLY=1`
//! prints only the stop statistics).

use glam::Vec3;
use mdas::accel::GpuScene;
use mdas::gpu::Gpu;
use mdas::integrand::IntegrandSpec;
use mdas::integrand::ManyLight;
use mdas::integrand::ManyLightSpec;
use mdas::integrator::{Halton, Integrator};
use mdas::lights::registry::SamplerKind;
use mdas::lights::substitute::{self, SstSampler, SubstituteLayout};
use mdas::lights::{LightPrim, Shading, KIND_VPL};
use mdas::session;
use rand::rngs::StdRng;
use rand::{RngExt, SeedableRng};
use std::path::Path;
use std::sync::Arc;

const SPP: u32 = 4;
const RUNS: usize = 3;

fn main() -> anyhow::Result<()> {
    let gpu = Gpu::shared()?;
    let scale: f32 = std::env::var("MDAS_BENCH_SCALE").map_or(0.25, |s| s.parse().unwrap());
    let stops_only = std::env::var_os("MDAS_BENCH_STOPS_ONLY").is_some();
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
        ("scenes/tests/vpl_spheres.toml", scale),
    ] {
        let loaded = mdas::scene_file::load(Path::new(file))?;
        let scene = &loaded.scene;
        let film = session::scaled_film(scene.film, s)?;
        let IntegrandSpec::ManyLight(spec) = &loaded.integrand else {
            anyhow::bail!("{file} is not a many_light scene")
        };
        let gpu_scene = Arc::new(GpuScene::new(gpu, scene, film)?);
        if stops_only {
            let ml = ManyLight::new(gpu, scene, gpu_scene, film, spec)?;
            if let Some(d) = stop_depth(ml.lights(), spec) {
                println!("`{file}`: {d}");
            }
            continue;
        }
        let mut uniform_ns = None;
        let mut depths = Vec::new();
        // Every picker, then the grid hierarchy with 0 (unshadowed), 1, 4
        // and 16 shadow rays per sample.
        let variants = SamplerKind::PICKERS
            .into_iter()
            .map(|k| (k, None))
            .chain([0, 1, 4, 16].map(|s| (SamplerKind::Lgh, Some(s))));
        for (kind, shadows) in variants {
            let mut spec = ManyLightSpec {
                sampler: kind,
                ..spec.clone()
            };
            if let Some(s) = shadows {
                spec.lgh.shadow_samples = s;
            }
            let name = match shadows {
                Some(s) => format!("{kind} (S = {s})"),
                None => kind.to_string(),
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
            if kind == SamplerKind::Sst {
                depths.push(stop_depth(integrand.lights(), &spec));
            }
            println!(
                "| `{}` | {}×{} | {} | {name} | {vpls:.2} / {:.2} / {:.2} | {ms:.1} | {ns:.0} | {:+.0} ns |",
                Path::new(file).file_stem().unwrap().to_string_lossy(),
                film.width,
                film.height,
                integrand.light_count(),
                build,
                cuts,
                ns - base
            );
        }
        for d in depths.into_iter().flatten() {
            println!("\n`{file}`: {d}\n");
        }
    }
    Ok(())
}

/// `sst`'s stops over shading points at the frame's VPLs (module docs)
/// on the paper's radix tree (`sst`) and on the perfect tree
/// (`sst_perfect`), or `None` without VPLs.
fn stop_depth(prims: &[LightPrim], spec: &ManyLightSpec) -> Option<String> {
    let vpls: Vec<&LightPrim> = prims.iter().filter(|p| p.kind == KIND_VPL).collect();
    if vpls.is_empty() {
        return None;
    }
    let radix = substitute::radix::build(prims)?;
    let deepest = radix.bvh.depth - 1;
    let perfect = substitute::build(prims)?;
    let leaves = perfect.tree.levels - 1;
    Some(format!(
        "sst {} (its deepest leaf at {deepest}); sst_perfect {} (leaves at {leaves})",
        stops(radix, &vpls, spec),
        stops(perfect, &vpls, spec)
    ))
}

/// The mean stop depth, the share of stops at substitutes and of draws on
/// dead branches of `sst` over `tree`: 16 draws at each of 2,000 shading
/// points at VPLs.
fn stops<T: SubstituteLayout>(tree: T, vpls: &[&LightPrim], spec: &ManyLightSpec) -> String {
    let sampler = SstSampler {
        tree,
        params: Some(spec.sst),
    };
    let mut rng = StdRng::seed_from_u64(1);
    let (mut depth, mut stops, mut substitutes, mut draws) = (0u64, 0u64, 0u64, 0u64);
    for _ in 0..2000 {
        let v = vpls[rng.random_range(0..vpls.len())];
        let n = Vec3::from(v.p1);
        let sh = Shading {
            p: Vec3::from(v.p0) + n * 1e-3,
            n,
        };
        for _ in 0..16 {
            draws += 1;
            if let Some(stop) = sampler.sample(&sh, rng.random()) {
                let mut node = stop.node;
                while let Some(p) = sampler.tree.parent(node) {
                    depth += 1;
                    node = p;
                }
                stops += 1;
                substitutes += sampler.tree.children(stop.node).is_some() as u64;
            }
        }
    }
    format!(
        "mean stop depth {:.2}, {:.1} % of stops at substitutes, {:.1} % of draws on a dead branch",
        depth as f64 / stops.max(1) as f64,
        100.0 * substitutes as f64 / stops.max(1) as f64,
        100.0 * (draws - stops) as f64 / draws as f64
    )
}
