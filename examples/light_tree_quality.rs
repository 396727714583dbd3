//! How well each light sampler's pmf follows the light, without noise,
//! visibility or cut sharing: at the shading points a grid of primary rays
//! hits (CPU brute force), the relative variance of the one-sample
//! estimator of unshadowed direct light,
//! `V = Σ_i f_i² / p_i / (Σ_i f_i)² − 1` (0 when p ∝ f), with `f_i` the
//! luminance light `i` would bring (points: `I·cosθ/d²`; triangles at their
//! centroid: `L·A·cosθ·cosθ'/d²`, one-sided) and `p_i` the sampler's pmf
//! (the tree kinds from their root: no cut). Seed-free: every run prints the
//! same table. `tree2` uses the scene's light groups with their leaf orders
//! sorted once in object space, as a render does; `tree2 (sort at t)` sorts
//! them at the frame time instead (the same tree where nothing moves).
//!
//! ```text
//! cargo run --release --example light_tree_quality SCENE [GRID_WIDTH] [KINDS]
//! ```
//!
//! Defaults: a 48-ray-wide grid and the kinds `uniform, power, tree_cone,
//! unbalanced, tree2`. Scenes with VPLs are measured without them (they are
//! traced on the GPU).

use anyhow::{bail, Context, Result};
use glam::Vec3;
use mdas::accel::{BuiltScene, Ray};
use mdas::lights::scene_lights::{bottom_levels, light_groups, light_prims};
use mdas::lights::tree::cut::{Importance, TreeSampler};
use mdas::lights::{
    new_sampler, two_level, LightPrim, LightSampler, SamplerKind, Shading, KIND_TRIANGLE,
};
use mdas::scene_file::SceneFile;

fn main() -> Result<()> {
    let mut args = std::env::args().skip(1);
    let Some(path) = args.next() else {
        bail!("usage: light_tree_quality SCENE [GRID_WIDTH] [KINDS]");
    };
    let width: u32 = match args.next() {
        Some(s) => s.parse().context("GRID_WIDTH must be a whole number")?,
        None => 48,
    };
    let kinds: Vec<SamplerKind> = match args.next() {
        Some(s) => s
            .split(',')
            .map(|k| k.parse::<SamplerKind>())
            .collect::<Result<_, _>>()?,
        None => vec![
            SamplerKind::Uniform,
            SamplerKind::Power,
            SamplerKind::TreeCone,
            SamplerKind::Unbalanced,
            SamplerKind::Tree2,
        ],
    };
    let file = SceneFile::load(path.as_ref())?;
    let time = match &file.integrand {
        mdas::integrand::IntegrandSpec::ManyLight(m) => m.time,
        _ => 0.0,
    };
    let prims = light_prims(&file.scene, time);
    if prims.is_empty() {
        bail!("{path} has no lights for the many-light samplers");
    }
    let points = shading_points(&file, width, time)?;
    println!(
        "{path}: {} lights in {} groups, {} shading points (grid {width} wide), time {time}",
        prims.len(),
        light_groups(&file.scene).len(),
        points.len()
    );
    println!(
        "{:<18} {:>10} {:>10} {:>10} {:>10} {:>8}",
        "sampler", "mean V", "median V", "p90 V", "max V", "p = 0"
    );
    let mut rows: Vec<(String, Box<dyn LightSampler>)> = Vec::new();
    for kind in kinds {
        if !kind.picks_lights() {
            bail!("'{kind}' picks no single light");
        }
        if kind == SamplerKind::Tree2 {
            let tree = bottom_levels(&file.scene).tree(&prims).context("lights")?;
            rows.push((
                kind.name().into(),
                Box::new(TreeSampler::new(tree, Importance::Cones)),
            ));
            let tree = two_level::build(&prims, &light_groups(&file.scene)).context("lights")?;
            rows.push((
                "tree2 (sort at t)".into(),
                Box::new(TreeSampler::new(tree, Importance::Cones)),
            ));
        } else {
            rows.push((kind.name().into(), new_sampler(kind, &prims, None)));
        }
    }
    for (name, sampler) in rows {
        let mut v = Vec::new();
        let mut missed = 0;
        for s in &points {
            let f: Vec<f64> = prims.iter().map(|l| contribution(l, s)).collect();
            let total: f64 = f.iter().sum();
            if total <= 0.0 {
                continue;
            }
            let mut m2 = 0.0;
            for (i, &fi) in f.iter().enumerate() {
                if fi > 0.0 {
                    let p = sampler.pmf(s, i as u32);
                    if p > 0.0 {
                        m2 += fi * fi / p;
                    } else {
                        missed += 1;
                    }
                }
            }
            v.push(m2 / (total * total) - 1.0);
        }
        v.sort_by(f64::total_cmp);
        let at = |q: f64| v[((v.len() - 1) as f64 * q).round() as usize];
        println!(
            "{:<18} {:>10.3} {:>10.3} {:>10.3} {:>10.3} {:>8}",
            name,
            v.iter().sum::<f64>() / v.len() as f64,
            at(0.5),
            at(0.9),
            at(1.0),
            missed
        );
    }
    Ok(())
}

/// The luminance light `l` brings to `s` without visibility (module docs).
fn contribution(l: &LightPrim, s: &Shading) -> f64 {
    let e = mdas::lights::luminance(Vec3::from(l.emission)) as f64;
    if l.kind == KIND_TRIANGLE {
        let (a, b, c) = (Vec3::from(l.p0), Vec3::from(l.p1), Vec3::from(l.p2));
        let n = (b - a).cross(c - a);
        let area = 0.5 * n.length() as f64;
        let d = (a + b + c) / 3.0 - s.p;
        let d2 = d.length_squared() as f64;
        let w = d.normalize();
        let cos_x = w.dot(s.n).max(0.0) as f64;
        let cos_y = (-w).dot(n.normalize()).max(0.0) as f64;
        e * area * cos_x * cos_y / d2
    } else {
        let d = Vec3::from(l.p0) - s.p;
        let cos_x = d.normalize().dot(s.n).max(0.0) as f64;
        e * cos_x / d.length_squared() as f64
    }
}

/// The first hits of primary rays through the centres of a `width`-wide grid
/// over the film (the pinhole camera of docs/conventions.md "Primary ray"),
/// with their geometric normals facing the camera.
fn shading_points(file: &SceneFile, width: u32, time: f32) -> Result<Vec<Shading>> {
    let scene = &file.scene;
    let built = BuiltScene::new(scene)?;
    let c = scene.camera;
    let f = (c.look_at - c.position).normalize();
    let r = f.cross(c.up).normalize();
    let u = r.cross(f);
    let (w, h) = (scene.film.width as f32, scene.film.height as f32);
    let height = ((width as f32) * h / w).round().max(1.0) as u32;
    let t = (c.fov_y.to_radians() * 0.5).tan();
    let mut out = Vec::new();
    for j in 0..height {
        for i in 0..width {
            let x = (i as f32 + 0.5) / width as f32;
            let y = (j as f32 + 0.5) / height as f32;
            let dir = (f + (2.0 * x - 1.0) * t * (w / h) * r + (1.0 - 2.0 * y) * t * u).normalize();
            let ray = Ray {
                origin: c.position.into(),
                t_max: f32::INFINITY,
                dir: dir.into(),
                time,
            };
            let hit = built.brute_force_closest(&ray);
            if !hit.is_hit() {
                continue;
            }
            let [a, b, cc] = built.triangle_world(hit.prim, time);
            let mut n = (b - a).cross(cc - a).normalize();
            if n.dot(dir) > 0.0 {
                n = -n;
            }
            out.push(Shading {
                p: c.position + dir * hit.t,
                n,
            });
        }
    }
    Ok(out)
}
