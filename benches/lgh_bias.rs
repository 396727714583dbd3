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
//! A second table splits the shadow part (the cascade, the scene's α) at
//! every `STRIDE`-th hit point with exact shadow rays (the BVH's any-hit
//! query): each candidate grid light's lights — all of a level-1 grid
//! light's (its 8 cells, trilinear weight w at its vertex), 16 drawn down
//! the cascade for a coarser one (the build's weights w·W, then w·‖I‖) —
//! get a ray each, and their visibility is averaged two ways: by each
//! light's share of the grid light's intensity (w·‖I‖, what one shadow ray
//! stands for) and by its own contribution at the point (w·f, distance
//! and cosine included). Both are summed with the grid lights' f, beside
//! the exact visibility fraction T = Σ f V / Σ f over every light (256
//! lights per point drawn ∝ their exact f).
//!
//! Run: `cargo bench --bench lgh_bias` (env: SCENES, a space-separated
//! list; SCALES, one film scale per scene; STRIDE, default 4). Prints
//! markdown tables.

use anyhow::Result;
use glam::Vec3;
use mdas::accel::trace::pinhole_rays;
use mdas::accel::{BuiltScene, GpuScene, Ray, TraceKernel, TraceMode, MISS};
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

/// The exact visibility fraction T = Σ f_l V_l / Σ f_l over every light
/// (f the exact unshadowed contribution), summed over `points`: per point
/// `TRUTH_DRAWS` stratified draws of a light with probability f_l/Σf, one
/// exact shadow ray each. Returns (Σ f, Σ f·T̂).
fn true_visibility(
    gpu: &Gpu,
    kernel: &TraceKernel,
    scene: &GpuScene,
    prims: &[LightPrim],
    clamp2: f32,
    points: &[Point],
) -> Result<(f64, f64)> {
    let emitters: Vec<Emitter> = prims.iter().map(|l| Emitter::light(l, clamp2)).collect();
    let mut rays = Vec::new();
    let mut owner = Vec::new();
    let mut totals = Vec::new();
    for (k, &(x, n)) in points.iter().enumerate() {
        let f: Vec<f64> = emitters.iter().map(|e| luminance(e.eval(x, n))).collect();
        let total: f64 = f.iter().sum();
        totals.push(total);
        if total <= 0.0 {
            continue;
        }
        let o = offset_origin(x, n);
        let (mut cum, mut i) = (0.0, 0);
        for m in 0..TRUTH_DRAWS {
            let goal = (m as f64 + 0.5) / TRUTH_DRAWS as f64 * total;
            while i + 1 < f.len() && cum + f[i] <= goal {
                cum += f[i];
                i += 1;
            }
            let p = Vec3::from(prims[i].p0);
            rays.push(Ray {
                origin: o.into(),
                t_max: 1.0 - 1e-4,
                dir: (p - o).into(),
                time: 0.0,
            });
            owner.push(k);
        }
    }
    let hits = kernel.run_mode(gpu, scene, &rays, TraceMode::Any)?;
    let mut visible = vec![0u32; points.len()];
    for (h, &k) in hits.iter().zip(&owner) {
        if h.any_hit == 0 {
            visible[k] += 1;
        }
    }
    let sum_f: f64 = totals.iter().sum();
    let sum_ft: f64 = totals
        .iter()
        .zip(&visible)
        .map(|(t, &v)| t * f64::from(v) / f64::from(TRUTH_DRAWS))
        .sum();
    Ok((sum_f, sum_ft))
}

/// Light draws per point for [`true_visibility`].
const TRUTH_DRAWS: u32 = 256;

/// `offset_origin` of shading.wgsl.
fn offset_origin(x: Vec3, n: Vec3) -> Vec3 {
    let scale = x.abs().max_element().max(1.0);
    x + n * (1e-4 * scale)
}

/// The shadow table (module docs), summed over `points`: for the level-1
/// candidates and for the coarser ones, Σ f_i·V̄ω_i, Σ f_i·V̄f_i and Σ f_i;
/// and Σ f over every candidate.
#[allow(clippy::too_many_arguments)]
fn shadow_weighting(
    gpu: &Gpu,
    kernel: &TraceKernel,
    scene: &GpuScene,
    h: &lgh::Lgh,
    prims: &[LightPrim],
    params: &LghParams,
    clamp2: f32,
    points: &[Point],
) -> Result<([[f64; 3]; 2], f64)> {
    // Per shadow ray: its candidate grid light and the light's two weights.
    struct Share {
        cand: usize,
        omega: f64,
        f: f64,
    }
    let g = &h.grid;
    let c = g.cells();
    let mut rays = Vec::new();
    let mut shares = Vec::new();
    let mut cand_f = Vec::new();
    let mut all_f = 0.0;
    for (k, &(x, n)) in points.iter().enumerate() {
        for cand in h.candidates(prims, params, clamp2, x, n) {
            all_f += luminance(cand.f);
            if cand.level == 0 {
                continue;
            }
            let gl = &h.lights[cand.id as usize];
            let r = g.res(gl.level);
            let top = [gl.vertex % r, (gl.vertex / r) % r, gl.vertex / (r * r)];
            let index = cand_f.len();
            cand_f.push((gl.level, luminance(cand.f)));
            // A level-1 grid light: all its lights. A coarser one: the
            // lights under DRAWS descents (each light drawn with its share
            // of the grid light's intensity, so its ω-weight is 1).
            let starts: Vec<([u32; 3], f64)> = if gl.level == 1 {
                vec![(top, -1.0)]
            } else {
                (0..DRAWS)
                    .filter_map(|m| {
                        let u = ((m as f64 + 0.5) / DRAWS as f64 + 0.618_034 * (k as f64)) % 1.0;
                        descend(h, gl.level, top, u)
                    })
                    .collect()
            };
            for (v, left) in starts {
                let sampled = left >= 0.0;
                let mut ls = Vec::new();
                for delta in 0..8u32 {
                    let d = [delta & 1, (delta >> 1) & 1, (delta >> 2) & 1];
                    if (0..3).any(|a| v[a] < d[a] || v[a] - d[a] >= c) {
                        continue;
                    }
                    let cell = [v[0] - d[0], v[1] - d[1], v[2] - d[2]];
                    let [start, end] = h.cells[(cell[0] + c * (cell[1] + c * cell[2])) as usize];
                    for &i in &h.sorted[start as usize..end as usize] {
                        let l = &prims[i as usize];
                        let p = Vec3::from(l.p0);
                        let (_, t) = g.cell_of(1, p);
                        let w = f64::from(lgh::LghGrid::trilinear(t, delta));
                        let omega = w * luminance(Vec3::from(l.emission));
                        if omega <= 0.0 {
                            continue;
                        }
                        let f = w * luminance(Emitter::light(l, clamp2).eval(x, n));
                        ls.push((p, omega, f));
                    }
                }
                // A descent ends at one light drawn by ω among the vertex's:
                // it stands for the grid light with ω-weight 1 and f-weight
                // f/ω.
                let picks: Vec<(Vec3, f64, f64)> = if sampled {
                    let total: f64 = ls.iter().map(|l| l.1).sum();
                    let u = left * total;
                    let mut cum = 0.0;
                    ls.iter()
                        .find(|l| {
                            cum += l.1;
                            u < cum
                        })
                        .or(ls.last())
                        .map(|&(p, om, f)| vec![(p, 1.0, f / om)])
                        .unwrap_or_default()
                } else {
                    ls
                };
                for (p, omega, f) in picks {
                    let o = offset_origin(x, n);
                    rays.push(Ray {
                        origin: o.into(),
                        t_max: 1.0 - 1e-4,
                        dir: (p - o).into(),
                        time: 0.0,
                    });
                    shares.push(Share {
                        cand: index,
                        omega,
                        f,
                    });
                }
            }
        }
    }
    let hits = kernel.run_mode(gpu, scene, &rays, TraceMode::Any)?;
    // Per candidate: Σω, ΣωV, Σf, ΣfV.
    let mut sums = vec![[0f64; 4]; cand_f.len()];
    for (s, hit) in shares.iter().zip(&hits) {
        let visible = if hit.any_hit != 0 { 0.0 } else { 1.0 };
        let a = &mut sums[s.cand];
        a[0] += s.omega;
        a[1] += s.omega * visible;
        a[2] += s.f;
        a[3] += s.f * visible;
    }
    // Per level (1, 2+): Σ f·V̄ω, Σ f·V̄f, Σ f; and Σ f over all.
    let mut out = [[0.0; 3]; 2];
    for (a, &(level, f)) in sums.iter().zip(&cand_f) {
        if a[0] <= 0.0 {
            continue;
        }
        let o = &mut out[(level > 1) as usize];
        o[0] += f * a[1] / a[0];
        // A grid light none of whose lights faces the point: its lights'
        // own weights are all zero, so fall back on the intensity share.
        o[1] += f * if a[2] > 0.0 { a[3] / a[2] } else { a[1] / a[0] };
        o[2] += f;
    }
    Ok((out, all_f))
}

/// Descents per coarse grid light.
const DRAWS: u32 = 16;

/// The level-1 vertex reached from vertex `v` of `level` by drawing, level
/// by level, one of the grid lights below it was gathered from, with
/// probability w·W (the cascade's gather), and the random number left;
/// `None` if there is none.
fn descend(h: &lgh::Lgh, level: u32, v: [u32; 3], u: f64) -> Option<([u32; 3], f64)> {
    let g = &h.grid;
    let (mut v, mut u) = (v, u);
    for l in (2..=level).rev() {
        let fine = g.res(l - 1);
        let lo = v.map(|x| (2 * x).saturating_sub(3));
        let hi = v.map(|x| (2 * x + 3).min(fine - 1));
        let mut options = Vec::new();
        for z in lo[2]..=hi[2] {
            for y in lo[1]..=hi[1] {
                for x in lo[0]..=hi[0] {
                    let Some(gl) = h.light_at(l - 1, [x, y, z]) else {
                        continue;
                    };
                    let upos = g.vertex_pos(l - 1, [x, y, z]);
                    let (cell, t) = g.cell_of(l, gl.centre(upos));
                    let d = [0, 1, 2].map(|a| v[a].wrapping_sub(cell[a]));
                    if d.iter().any(|&e| e > 1) {
                        continue;
                    }
                    let w = f64::from(lgh::LghGrid::trilinear(t, d[0] | (d[1] << 1) | (d[2] << 2)))
                        * f64::from(gl.w);
                    if w > 0.0 {
                        options.push(([x, y, z], w));
                    }
                }
            }
        }
        let total: f64 = options.iter().map(|o| o.1).sum();
        if total <= 0.0 {
            return None;
        }
        let goal = u * total;
        let mut cum = 0.0;
        let mut pick = options[options.len() - 1];
        for o in &options {
            if goal < cum + o.1 {
                u = (goal - cum) / o.1;
                pick = *o;
                break;
            }
            cum += o.1;
        }
        v = pick.0;
    }
    Some((v, u))
}

fn main() -> Result<()> {
    let gpu = Gpu::shared()?;
    let scenes = env_or(
        "SCENES",
        "scenes/tests/vpl_atrium_points.toml scenes/lights_1m.toml",
    );
    let scales = env_or("SCALES", "1 0.125");
    let stride: usize = env_or("STRIDE", "4").parse()?;
    let mut weighting = Vec::new();
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
        let sparse: Vec<Point> = points.iter().step_by(stride.max(1)).copied().collect();
        let cascade = lgh::build(&prims, spec.lgh.levels)?;
        let w = shadow_weighting(
            gpu, &kernel, &gpu_scene, &cascade, &prims, &spec.lgh, clamp2, &sparse,
        )?;
        let t = true_visibility(gpu, &kernel, &gpu_scene, &prims, clamp2, &sparse)?;
        weighting.push((file.to_string(), spec.lgh.alpha, sparse.len(), w, t));
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
    println!("\nGrid lights' visibility weighted by intensity share (what a shadow ray stands for) and by each light's own contribution (exact), every {stride}-th hit point (level 1: all its lights; coarser: {DRAWS} descents each):\n");
    println!("| scene | α | points | levels | share of Σf | V̄ by intensity share | V̄ by contribution | ratio − 1 |");
    println!("|---|---:|---:|---|---:|---:|---:|---:|");
    for (file, alpha, n, (levels, all), (sum_f, sum_ft)) in weighting {
        for (name, [by_omega, by_f, f]) in ["1", "2+"].iter().zip(levels) {
            println!(
                "| `{file}` | {alpha} | {n} | {name} | {:.1} % | {:.4} | {:.4} | {:+.2} % |",
                100.0 * f / all,
                by_omega / f,
                by_f / f,
                100.0 * (by_omega / by_f - 1.0)
            );
        }
        let [a, b] = levels;
        let f = a[2] + b[2];
        println!(
            "| `{file}` | {alpha} | {n} | model, all levels | | {:.4} | {:.4} | {:+.2} % |",
            (a[0] + b[0]) / f,
            (a[1] + b[1]) / f,
            100.0 * ((a[0] + b[0]) / (a[1] + b[1]) - 1.0)
        );
        println!(
            "| `{file}` | {alpha} | {n} | exact (every light, {TRUTH_DRAWS} draws ∝ f per point) | | | {:.4} | |",
            sum_ft / sum_f
        );
    }
    Ok(())
}
