//! CPU tests of many-light sampling (src/lights): exact Morton codes, the
//! perfect-tree oracle, the light BVH, cuts, and every sampler's pmf
//! (consistency, normalization, unbiasedness, chi-square goodness of fit),
//! on random scenes and on hard cases.
//!
//! Statistics (fixed seeds, so the outcome is deterministic):
//! * chi-square: `M = 200,000` selections per case, cells with expected
//!   count < 5 pooled (pbrt's rule), plus a "no light" cell with the
//!   probability `1 − Σ pmf` that sampling returns `None`; dof = cells − 1;
//!   overall significance 1e-3, Bonferroni-corrected over the number of
//!   cases of the test (α = 1e-3 / cases).
//! * estimator check (pbrt): `E[1/(pmf(X)·N₊)] = 1` where `N₊` counts the
//!   lights with `pmf > 0` (a `None` sample contributes 0), checked on
//!   `65,536` stratified `u` to 6 standard errors.

#[path = "../light_scenes/mod.rs"]
mod light_scenes;
#[path = "../stats/mod.rs"]
mod stats;

mod cones;
mod cuts;
mod grid_hierarchy;
mod hard_cases;
mod light_bvh;
mod morton_codes;
mod perfect_tree;
mod samplers;
mod substitute_trees;
mod tree2;

// The helpers each part shares with the others.
use cones::*;
use light_bvh::*;
use samplers::*;

use glam::{Vec3, Vec4};
use light_scenes::vpl_walls;
use mdas::lights::bvh::{self, Cost, LightBvh, INTERNAL_BIT, MAX_DEPTH};
use mdas::lights::importance::{node_importance, ONE_MINUS_EPSILON};
use mdas::lights::morton::{codes, exponent, morton30, quantize_axis};
use mdas::lights::substitute::{
    self, SstSampler, Stop, Substitute, SubstituteLayout, SubstituteParams,
};
use mdas::lights::tree::cut::{Importance, LightTree, MAX_CUT};
use mdas::lights::tree::perfect::{self, gather, PerfectTree};
use mdas::lights::two_level::{self, BottomLevels};
use mdas::lights::{
    new_sampler, select_cut, LightSampler, PowerSampler, SamplerKind, Shading, TreeSampler,
    UniformSampler,
};
use mdas::lights::{LightPrim, TreeNode, NO_LIGHT};
use mdas::scene::motion::Rigid;
use rand::rngs::StdRng;
use rand::{RngExt, SeedableRng};
use stats::gamma_q;

// ---------------------------------------------------------------- helpers

fn random_scene(rng: &mut StdRng, n: usize) -> Vec<LightPrim> {
    (0..n)
        .map(|_| {
            let c = Vec3::new(
                rng.random_range(-5.0..5.0),
                rng.random_range(-5.0..5.0),
                rng.random_range(-5.0..5.0),
            );
            let e = if rng.random::<f32>() < 0.1 {
                Vec3::ZERO
            } else {
                Vec3::new(
                    rng.random_range(0.0..10.0),
                    rng.random_range(0.0..10.0),
                    rng.random_range(0.0..10.0),
                )
            };
            let kind = rng.random::<f32>();
            if kind < 0.55 {
                LightPrim::point(c, e)
            } else if kind < 0.7 {
                LightPrim::vpl(c, random_unit(rng), e)
            } else {
                let mut v = || {
                    c + Vec3::new(
                        rng.random_range(-0.5..0.5),
                        rng.random_range(-0.5..0.5),
                        rng.random_range(-0.5..0.5),
                    )
                };
                let (a, b, d) = (v(), v(), v());
                LightPrim::triangle(a, b, d, e)
            }
        })
        .collect()
}

fn random_unit(rng: &mut StdRng) -> Vec3 {
    loop {
        let v = Vec3::new(
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
        );
        let l = v.length();
        if l > 0.1 && l <= 1.0 {
            return v / l;
        }
    }
}

fn random_shading(rng: &mut StdRng) -> Shading {
    Shading {
        p: Vec3::new(
            rng.random_range(-6.0..6.0),
            rng.random_range(-6.0..6.0),
            rng.random_range(-6.0..6.0),
        ),
        n: random_unit(rng),
    }
}

/// Every sampler variant: the six kinds, the cut kinds with cuts of 4 and
/// 16 nodes chosen at `rep` (a representative point of the block).
fn samplers(
    prims: &[LightPrim],
    rep: &Shading,
) -> Vec<(String, Box<dyn LightSampler + Send + Sync>)> {
    let mut v = Vec::new();
    for kind in SamplerKind::PICKERS {
        if kind.is_biased() {
            // sst: its substitutes are tested in "substitute trees" below.
            continue;
        }
        if kind.uses_cut() {
            for size in [4, 16] {
                v.push((
                    format!("{kind}/cut{size}"),
                    new_sampler(kind, prims, Some((rep, size))),
                ));
            }
            if kind == SamplerKind::Tree2 {
                // The factory's tree2 has one group; scenes have several.
                let t = two_level::build(prims, &chunks(prims.len(), 3)).unwrap();
                v.push((
                    "tree2/groups".into(),
                    Box::new(TreeSampler::new(t.clone(), Importance::Cones)),
                ));
                v.push((
                    "tree2/groups/cut8".into(),
                    Box::new(TreeSampler::with_cut_at(t, Importance::Cones, rep, 8)),
                ));
            }
        } else {
            v.push((kind.to_string(), new_sampler(kind, prims, None)));
        }
    }
    v
}

/// `0..n` in `k` contiguous groups of nearly equal size (empty ones
/// included when `n < k`).
fn chunks(n: usize, k: usize) -> Vec<std::ops::Range<u32>> {
    (0..k)
        .map(|i| (i * n / k) as u32..((i + 1) * n / k) as u32)
        .collect()
}

/// The mean of `xs` and its standard error (sample variance with n − 1).
fn mean_se(xs: &[f64]) -> (f64, f64) {
    let n = xs.len() as f64;
    let mean = xs.iter().sum::<f64>() / n;
    let var = xs.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0);
    (mean, (var / n).sqrt())
}

/// `Σ_lights pmf`.
fn pmf_sum(s: &dyn LightSampler, sh: &Shading, n: usize) -> f64 {
    (0..n as u32).map(|i| s.pmf(sh, i)).sum()
}

/// Chi-square p-value of observed counts against expected counts, pooling
/// cells with expected < 5. Panics if a cell with expected 0 was observed.
fn chi_square_p(observed: &[u64], expected: &[f64]) -> (f64, usize) {
    let mut cells: Vec<(f64, u64)> = Vec::new();
    let (mut pool_e, mut pool_o) = (0.0, 0u64);
    for (&o, &e) in observed.iter().zip(expected) {
        assert!(
            e > 0.0 || o == 0,
            "a cell of probability 0 was drawn {o} times"
        );
        if e < 5.0 {
            pool_e += e;
            pool_o += o;
        } else {
            cells.push((e, o));
        }
    }
    if pool_e >= 5.0 || cells.is_empty() {
        cells.push((pool_e, pool_o));
    } else if pool_e > 0.0 {
        let last = cells.last_mut().unwrap();
        last.0 += pool_e;
        last.1 += pool_o;
    }
    let dof = cells.len().saturating_sub(1);
    if dof == 0 {
        return (1.0, 0);
    }
    let chi2: f64 = cells.iter().map(|&(e, o)| (o as f64 - e).powi(2) / e).sum();
    (gamma_q(dof as f64 / 2.0, chi2 / 2.0), dof)
}

/// Sample-vs-pmf checks on one sampler at one shading point over
/// `strata` stratified `u` plus the edges: each sample's pmf equals
/// `pmf(light)` exactly and is positive; returns the fraction of `None`.
fn check_consistency(name: &str, s: &dyn LightSampler, sh: &Shading, strata: u32) -> f64 {
    let mut none = 0u32;
    let us = (0..strata)
        .map(|k| (k as f32 + 0.5) / strata as f32)
        .chain([0.0, ONE_MINUS_EPSILON]);
    for u in us {
        match s.sample(sh, u) {
            Some(ls) => {
                let q = s.pmf(sh, ls.light);
                assert_eq!(
                    ls.pmf, q,
                    "{name}: sample pmf != pmf(light {}) at u = {u}",
                    ls.light
                );
                assert!(ls.pmf > 0.0 && ls.pmf.is_finite(), "{name}: pmf {}", ls.pmf);
            }
            None => none += 1,
        }
    }
    none as f64 / (strata + 2) as f64
}
