//! A light set sampled on the CPU and on the GPU, every sampler kind: the
//! CPU samplers (`mdas::lights`) and the WGSL ones that the `many_light`
//! integrand calls (`wgsl/lights/sample.wgsl`, run here in a batch by
//! `BatchSampler`) must pick the same light with the same probability for
//! the same shading point and random number.
//!
//! ```text
//! cargo run --release --example light_sampler [LIGHTS] [QUERIES]
//! ```
//!
//! Defaults: 2,000 lights (point lights, one-sided emissive triangles and
//! VPLs on three walls, some dark) and 4,096 queries. WGSL's division
//! need not be correctly rounded (2.5 ulp), so a `u` within a few ulp of
//! a decision boundary may go either way: such picks are counted apart
//! (a differing pick counts as one when the CPU picks the GPU's light for
//! some `u` within ±64 ulp) and must stay rare (≤ 0.5 %); any other
//! difference, or a pmf off by more than a relative 1e-5, fails the run.

use anyhow::{bail, Context, Result};
use glam::Vec3;
use mdas::gpu::Gpu;
use mdas::lights::gpu_sampler::{BatchSampler, CutLayout, GpuPick, GpuSamplerData, SampleQuery};
use mdas::lights::substitute::radix::RadixTree;
use mdas::lights::substitute::{self, SstSampler, SubstituteLayout, SubstituteParams};
use mdas::lights::{new_sampler, LightPrim, SamplerKind, Shading};
use rand::rngs::StdRng;
use rand::{RngExt, SeedableRng};

fn main() -> Result<()> {
    let mut args = std::env::args().skip(1);
    let lights: usize = match args.next() {
        Some(s) => s.parse().context("LIGHTS must be a whole number")?,
        None => 2000,
    };
    let count: usize = match args.next() {
        Some(s) => s.parse().context("QUERIES must be a whole number")?,
        None => 4096,
    };
    let mut rng = StdRng::seed_from_u64(1);
    let prims = light_set(&mut rng, lights);
    let queries: Vec<SampleQuery> = (0..count)
        .map(|_| {
            let p = Vec3::new(
                rng.random_range(-4.5..4.5),
                rng.random_range(-4.5..4.5),
                rng.random_range(-4.5..4.5),
            );
            SampleQuery {
                p: p.into(),
                u: rng.random(),
                n: unit(&mut rng).into(),
                block: 0,
            }
        })
        .collect();

    let gpu = Gpu::shared()?;
    let batch = BatchSampler::new(gpu)?;
    // One block: every cut is [root] until a cut pre-pass fills it, so
    // the CPU samplers descend from the root too.
    let cuts = CutLayout::for_film(1, 1, 1, 1);
    println!(
        "{} lights, {count} queries on {}",
        prims.len(),
        gpu.info.name
    );
    println!("| sampler | lights | substitutes | none | boundary | largest pmf difference |");
    println!("|---|---:|---:|---:|---:|---:|");
    let mut failed = Vec::new();
    for kind in SamplerKind::PICKERS {
        let data = GpuSamplerData::new(gpu, kind, &prims, None, cuts)?;
        let gpu_picks = batch.sample(gpu, &data, &queries)?;
        let cpu = CpuSampler::new(kind, &prims);
        let (mut lights, mut subs, mut none, mut boundary, mut worst) = (0, 0, 0, 0, 0.0f64);
        for (q, g) in queries.iter().zip(&gpu_picks) {
            let s = Shading {
                p: Vec3::from(q.p),
                n: Vec3::from(q.n),
            };
            let c = cpu.sample(&s, q.u);
            match g {
                GpuPick::None => none += 1,
                GpuPick::Light { .. } => lights += 1,
                GpuPick::Substitute { .. } => subs += 1,
            }
            if same_choice(&c, g) {
                worst = worst.max(pmf_difference(&c, g));
            } else if (-64i32..=64).any(|k| {
                let u = f32::from_bits((q.u.to_bits() as i32 + k).max(0) as u32);
                u < 1.0 && same_choice(&cpu.sample(&s, u), g)
            }) {
                boundary += 1;
            } else {
                failed.push(format!(
                    "{kind}: at {s:?}, u = {}: CPU {c:?}, GPU {g:?}",
                    q.u
                ));
            }
        }
        println!("| {kind} | {lights} | {subs} | {none} | {boundary} | {worst:.1e} |");
        if worst > 1e-5 {
            failed.push(format!("{kind}: pmfs differ by a relative {worst:.2e}"));
        }
        if boundary * 200 > count {
            failed.push(format!("{kind}: {boundary} boundary cases of {count}"));
        }
    }
    if !failed.is_empty() {
        bail!(
            "the GPU samplers disagree with the CPU's:\n{}",
            failed.join("\n")
        );
    }
    println!("every sampler picks on the GPU as on the CPU");
    Ok(())
}

/// The CPU side of one kind, answering in the GPU's terms.
enum CpuSampler {
    Lights(Box<dyn mdas::lights::LightSampler + Send + Sync>),
    Substitutes(SstSampler),
    Radix(SstSampler<RadixTree>),
}

impl CpuSampler {
    fn new(kind: SamplerKind, prims: &[LightPrim]) -> CpuSampler {
        if kind.uses_substitute_tree() && kind.uses_bvh() {
            CpuSampler::Radix(SstSampler {
                tree: substitute::radix::build(prims).expect("lights"),
                params: kind.stops_at_substitutes().then(SubstituteParams::default),
            })
        } else if kind.uses_substitute_tree() {
            CpuSampler::Substitutes(SstSampler {
                tree: substitute::build(prims).expect("lights"),
                params: kind.stops_at_substitutes().then(SubstituteParams::default),
            })
        } else {
            CpuSampler::Lights(new_sampler(kind, prims, None))
        }
    }

    fn sample(&self, s: &Shading, u: f32) -> GpuPick {
        match self {
            CpuSampler::Lights(l) => match l.sample(s, u) {
                Some(ls) => GpuPick::Light {
                    light: ls.light,
                    pmf: ls.pmf,
                },
                None => GpuPick::None,
            },
            CpuSampler::Substitutes(t) => stop_pick(t, s, u),
            CpuSampler::Radix(t) => stop_pick(t, s, u),
        }
    }
}

/// An `sst` stop as the GPU answers it: a leaf's light or a substitute.
fn stop_pick<T: SubstituteLayout>(t: &SstSampler<T>, s: &Shading, u: f32) -> GpuPick {
    match t.sample(s, u) {
        None => GpuPick::None,
        Some(stop) if t.tree.children(stop.node).is_none() => GpuPick::Light {
            light: t.tree.leaf_light(stop.node),
            pmf: stop.pmf,
        },
        Some(stop) => GpuPick::Substitute {
            node: stop.node as u32,
            pmf: stop.pmf,
        },
    }
}

fn same_choice(a: &GpuPick, b: &GpuPick) -> bool {
    match (a, b) {
        (GpuPick::None, GpuPick::None) => true,
        (GpuPick::Light { light: x, .. }, GpuPick::Light { light: y, .. }) => x == y,
        (GpuPick::Substitute { node: x, .. }, GpuPick::Substitute { node: y, .. }) => x == y,
        _ => false,
    }
}

fn pmf_difference(a: &GpuPick, b: &GpuPick) -> f64 {
    let pmf = |p: &GpuPick| match *p {
        GpuPick::None => 0.0,
        GpuPick::Light { pmf, .. } | GpuPick::Substitute { pmf, .. } => pmf,
    };
    let (x, y) = (pmf(a), pmf(b));
    if x == y {
        0.0
    } else {
        (x - y).abs() / x.abs().max(y.abs())
    }
}

/// A uniformly distributed unit vector.
fn unit(rng: &mut StdRng) -> Vec3 {
    loop {
        let v = Vec3::new(rng.random(), rng.random(), rng.random()) * 2.0 - Vec3::ONE;
        if v.length() > 0.1 && v.length() <= 1.0 {
            return v.normalize();
        }
    }
}

/// Point lights and small triangles in a 10-unit cube, and VPLs on three
/// of its walls (the substitute tree finds planar clusters there); every
/// eleventh light is dark.
fn light_set(rng: &mut StdRng, n: usize) -> Vec<LightPrim> {
    (0..n)
        .map(|i| {
            let c = Vec3::new(
                rng.random_range(-5.0..5.0),
                rng.random_range(-5.0..5.0),
                rng.random_range(-5.0..5.0),
            );
            let e = if i % 11 == 10 {
                Vec3::ZERO
            } else {
                Vec3::new(rng.random(), rng.random(), rng.random()) * 3.0
            };
            match i % 4 {
                0 => LightPrim::point(c, e),
                1 => {
                    let d = Vec3::new(rng.random(), rng.random(), rng.random()) * 0.5;
                    LightPrim::triangle(
                        c,
                        c + Vec3::new(d.x, 0.0, 0.0),
                        c + Vec3::new(0.0, d.y, d.z),
                        e,
                    )
                }
                _ => {
                    // On the wall x = −5, y = −5 or z = 5, facing in.
                    let (p, nrm) = match i % 3 {
                        0 => (Vec3::new(-5.0, c.y, c.z), Vec3::X),
                        1 => (Vec3::new(c.x, -5.0, c.z), Vec3::Y),
                        _ => (Vec3::new(c.x, c.y, 5.0), Vec3::NEG_Z),
                    };
                    LightPrim::vpl(p, nrm, e)
                }
            }
        })
        .collect()
}
