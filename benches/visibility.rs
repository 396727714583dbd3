//! Voxel visibility (issue 15, `src/accel/voxel.rs`) against exact BVH
//! shadow rays: build time, memory, shadow queries per second, and the
//! paper's error measures ε_v and ε_s.
//!
//! For each scene: shading points are the first hits of one primary ray
//! through each pixel centre of the scene's camera at `--scale`-like film
//! `SCALE` (default 1/4); lights are `LIGHTS` (default 256) lights drawn at
//! random from the scene's light set (for a `many_light` scene the
//! integrand's own list, VPLs included; else its emissive triangles and
//! point lights), a random point on each triangle. A pair casts a shadow
//! ray only when the light faces the point and the point the light (what
//! the integrands do); the ray is the integrands' (origin offset along the
//! normal, stopping 10⁻⁴ short), with the normals of the surfaces at both
//! ends for the voxel query's self-occlusion rule (a point light has none).
//! Exact answers: the BVH's any-hit query.
//! Per pixel, ε_v = (false visible + false hidden)/rays and
//! ε_s = (false visible − false hidden)/rays (Wang et al., §6.1); the
//! table gives the means over pixels of ε_v and |ε_s|, and the mean signed
//! ε_s (the bias of the shadow value).
//!
//! Throughput: both queries over the same rays, already on the device, one
//! dispatch plus a wait each, `REPEATS` (default 5) interleaved pairs after
//! a warm-up, medians.
//!
//! Run: `cargo bench --bench visibility` (env: SCENES, a space-separated
//! list; CONFIGS, e.g. "30x64 22x128 12x128"; SCALE; LIGHTS; REPEATS).
//! Prints a markdown table.

use anyhow::Result;
use glam::Vec3;
use mdas::accel::trace::pinhole_rays;
use mdas::accel::voxel::{Visibility, VoxelParams};
use mdas::accel::{BuiltScene, GpuScene, HitRecord, Ray, TraceKernel, TraceMode};
use mdas::gpu::buffer::STORAGE;
use mdas::gpu::Gpu;
use mdas::integrand::{IntegrandSpec, ManyLight};
use mdas::lights::{LightPrim, KIND_TRIANGLE, KIND_VPL};
use mdas::session;
use rand::rngs::StdRng;
use rand::{RngExt, SeedableRng};
use std::path::Path;
use std::sync::Arc;
use std::time::Instant;

fn env_or(name: &str, default: &str) -> String {
    std::env::var(name).unwrap_or_else(|_| default.to_string())
}

/// `offset_origin` of shading.wgsl.
fn offset_origin(x: Vec3, n: Vec3) -> Vec3 {
    let scale = x.abs().max_element().max(1.0);
    x + n * (1e-4 * scale)
}

/// A light point with its facing test.
struct LightPoint {
    p: Vec3,
    /// Emitting side for triangles and VPLs; zero for isotropic points.
    n: Vec3,
}

fn light_points(lights: &[LightPrim], count: usize, rng: &mut StdRng) -> Vec<LightPoint> {
    let count = if lights.is_empty() { 0 } else { count };
    (0..count)
        .map(|_| {
            let l = &lights[rng.random_range(0..lights.len())];
            let (p0, p1, p2) = (Vec3::from(l.p0), Vec3::from(l.p1), Vec3::from(l.p2));
            match l.kind {
                KIND_TRIANGLE => {
                    let (mut a, mut b) = (rng.random::<f32>(), rng.random::<f32>());
                    if a + b > 1.0 {
                        (a, b) = (1.0 - a, 1.0 - b);
                    }
                    LightPoint {
                        p: p0 + a * (p1 - p0) + b * (p2 - p0),
                        n: (p1 - p0).cross(p2 - p0).normalize_or_zero(),
                    }
                }
                KIND_VPL => LightPoint { p: p0, n: p1 },
                _ => LightPoint {
                    p: p0,
                    n: Vec3::ZERO,
                },
            }
        })
        .collect()
}

struct Pairs {
    rays: Vec<Ray>,
    /// Per ray, the normals at its origin and at its light end (zero for
    /// a point light).
    normals: Vec<[f32; 4]>,
    /// Pixel of each ray.
    pixel: Vec<u32>,
    pixels: usize,
}

fn shadow_pairs(
    built: &BuiltScene,
    primary: &[Ray],
    hits: &[HitRecord],
    lights: &[LightPoint],
) -> Pairs {
    let mut rays = Vec::new();
    let mut normals = Vec::new();
    let mut pixel = Vec::new();
    let mut pixels = 0;
    for (ray, h) in primary.iter().zip(hits) {
        if !h.is_hit() {
            continue;
        }
        let d = Vec3::from(ray.dir);
        let x = Vec3::from(ray.origin) + h.t * d;
        let [a, b, c] = built.triangle_world(h.prim, 0.0);
        let mut n = (b - a).cross(c - a).normalize_or_zero();
        if n.dot(d) > 0.0 {
            n = -n;
        }
        let origin = offset_origin(x, n);
        let before = rays.len();
        for l in lights {
            let to = l.p - origin;
            let dist = to.length();
            if dist <= 0.0 || n.dot(to) <= 0.0 || (l.n != Vec3::ZERO && l.n.dot(to) >= 0.0) {
                continue;
            }
            rays.push(Ray {
                origin: origin.into(),
                t_max: dist * (1.0 - 1e-4),
                dir: (to / dist).into(),
                time: 0.0,
            });
            normals.push(n.extend(0.0).to_array());
            normals.push(l.n.extend(0.0).to_array());
            pixel.push(pixels as u32);
        }
        if rays.len() > before {
            pixels += 1;
        }
    }
    Pairs {
        rays,
        normals,
        pixel,
        pixels,
    }
}

struct Errors {
    eps_v: f64,
    eps_s_abs: f64,
    eps_s: f64,
    hidden: f64,
}

fn errors(pairs: &Pairs, exact: &[bool], voxel: &[bool]) -> Errors {
    let n = pairs.pixels;
    let mut fv = vec![0u32; n];
    let mut fh = vec![0u32; n];
    let mut total = vec![0u32; n];
    let mut hidden = 0usize;
    for ((&p, &e), &v) in pairs.pixel.iter().zip(exact).zip(voxel) {
        let p = p as usize;
        total[p] += 1;
        fv[p] += u32::from(e && !v);
        fh[p] += u32::from(!e && v);
        hidden += usize::from(e);
    }
    let mean = |f: &dyn Fn(usize) -> f64| (0..n).map(f).sum::<f64>() / n.max(1) as f64;
    Errors {
        eps_v: mean(&|i| (fv[i] + fh[i]) as f64 / total[i] as f64),
        eps_s_abs: mean(&|i| (fv[i] as f64 - fh[i] as f64).abs() / total[i] as f64),
        eps_s: mean(&|i| (fv[i] as f64 - fh[i] as f64) / total[i] as f64),
        hidden: hidden as f64 / exact.len().max(1) as f64,
    }
}

fn parse_config(s: &str) -> VoxelParams {
    let (n, r) = s.split_once('x').expect("CONFIGS entries look like 30x64");
    VoxelParams {
        directions: n.parse().expect("directions"),
        resolution: r.parse().expect("resolution"),
        skip: env_or("SKIP", "1").parse().expect("SKIP"),
    }
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn main() -> Result<()> {
    // `cargo bench` passes --bench; nothing else is read from the arguments.
    let gpu = Gpu::shared()?;
    let scenes = env_or(
        "SCENES",
        "scenes/tests/box_shadow.toml scenes/cornell_lights.toml scenes/vpl_atrium.toml",
    );
    let configs: Vec<VoxelParams> = env_or("CONFIGS", "30x64 22x128")
        .split_whitespace()
        .map(parse_config)
        .collect();
    let scale: f32 = env_or("SCALE", "0.25").parse()?;
    let light_count: usize = env_or("LIGHTS", "256").parse()?;
    let repeats: usize = env_or("REPEATS", "5").parse()?;
    println!(
        "device: {} ({:?}); {light_count} lights per shading point, film scale {scale}, {repeats} interleaved repeats\n",
        gpu.info.name, gpu.info.backend
    );
    println!("| scene | triangles | config | build ms | MiB | shadow rays | hidden | ε_v | mean abs ε_s | mean ε_s | BVH Mrays/s | voxel Mrays/s | voxel / BVH |");
    println!("|---|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|");
    for file in scenes.split_whitespace() {
        let loaded = mdas::scene_file::load(Path::new(file))?;
        let scene = &loaded.scene;
        let film = session::scaled_film(scene.film, scale)?;
        let built = BuiltScene::new(scene)?;
        let exact_scene = Arc::new(GpuScene::upload(gpu, scene, &built, film)?);
        let kernel = TraceKernel::new(gpu, &exact_scene)?;
        let primary = pinhole_rays(&scene.camera, film);
        let hits = kernel.run_mode(gpu, &exact_scene, &primary, TraceMode::Closest)?;
        let prims = match &loaded.integrand {
            IntegrandSpec::ManyLight(spec) => {
                ManyLight::new(gpu, scene, exact_scene.clone(), film, spec)?
                    .lights()
                    .to_vec()
            }
            _ => mdas::lights::scene_lights::light_prims(scene, 0.0),
        };
        let mut rng = StdRng::seed_from_u64(15);
        let lights = light_points(&prims, light_count, &mut rng);
        let pairs = shadow_pairs(&built, &primary, &hits, &lights);
        let exact: Vec<bool> = kernel
            .run_mode(gpu, &exact_scene, &pairs.rays, TraceMode::Any)?
            .iter()
            .map(|h| h.any_hit != 0)
            .collect();
        let count = pairs.rays.len();
        let ray_buffer = gpu.buffer_from("bench.rays", &pairs.rays, STORAGE)?;
        let normal_buffer = gpu.buffer_from("bench.normals", &pairs.normals, STORAGE)?;
        let hit_buffer = gpu.buffer_zeroed(
            "bench.hits",
            (count * std::mem::size_of::<HitRecord>()) as u64,
            STORAGE,
        )?;
        for &params in &configs {
            let voxel_scene =
                match GpuScene::upload_with(gpu, scene, &built, film, Visibility::Voxel(params)) {
                    Ok(s) => s,
                    Err(e) => {
                        println!("| `{file}` | | {} | refused: {e:#} |", params.describe());
                        continue;
                    }
                };
            let voxel: Vec<bool> = kernel
                .run_with_normals(
                    gpu,
                    &voxel_scene,
                    &pairs.rays,
                    Some(&pairs.normals),
                    TraceMode::Voxel,
                )?
                .iter()
                .map(|h| h.any_hit != 0)
                .collect();
            let e = errors(&pairs, &exact, &voxel);
            let time = |s: &GpuScene, mode| -> Result<f64> {
                let start = Instant::now();
                kernel.dispatch_with_normals(
                    gpu,
                    s,
                    &ray_buffer,
                    (mode == TraceMode::Voxel).then_some(&normal_buffer),
                    &hit_buffer,
                    count as u32,
                    mode,
                )?;
                gpu.wait()?;
                Ok(start.elapsed().as_secs_f64())
            };
            time(&exact_scene, TraceMode::Any)?;
            time(&voxel_scene, TraceMode::Voxel)?;
            let (mut bvh, mut vox) = (Vec::new(), Vec::new());
            for _ in 0..repeats {
                bvh.push(time(&exact_scene, TraceMode::Any)?);
                vox.push(time(&voxel_scene, TraceMode::Voxel)?);
            }
            let (bvh, vox) = (median(bvh), median(vox));
            let s = voxel_scene.stats;
            println!(
                "| `{file}` | {} | {}, skip {} | {:.0} | {:.1} | {count} | {:.1} % | {:.2} % | {:.2} % | {:+.2} % | {:.1} | {:.1} | {:.1}× |",
                s.triangles,
                params.describe(),
                params.skip,
                s.voxel_build_ms,
                s.voxel_bytes as f64 / 1048576.0,
                100.0 * e.hidden,
                100.0 * e.eps_v,
                100.0 * e.eps_s_abs,
                100.0 * e.eps_s,
                count as f64 / bvh / 1e6,
                count as f64 / vox / 1e6,
                bvh / vox,
            );
        }
    }
    Ok(())
}
