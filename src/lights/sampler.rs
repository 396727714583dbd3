//! The light-sampler contract (pbrt-v4's `LightSampler`): `sample(ctx, u)`
//! picks one light with its probability, `pmf(ctx, light)` gives the same
//! probability independently; the [`Structure`] a kind samples and the
//! [`Technique`] interface of the structures built on the CPU. This module
//! imports no technique; the techniques depend on it, the registry of
//! kinds ([`super::registry`]) names them, and
//! [`super::factory::new_sampler`] builds one by kind:
//!
//! | kind | sampler | paper |
//! |---|---|---|
//! | `uniform` | [`UniformSampler`](super::simple::UniformSampler) | "random sampling" baseline (§4) |
//! | `power` | [`PowerSampler`](super::simple::alias::PowerSampler) (alias table, `I_i/ΣI`) | pbrt-v4 |
//! | `tree_nocut` | [`TreeSampler`](super::tree::cut::TreeSampler) over a [`PerfectTree`](super::tree::perfect::PerfectTree), cut = root | §3.2 |
//! | `tree` | same, with a greedy cut per pixel block: under [`CutSampling::Subtrees`] (the default) one light from each cut subtree per evaluation, under `Mixture` one pick from the cut | §3.2–3.3, §4 |
//! | `tree_cone` | `tree` with orientation cones ([`Importance::Cones`]) | §3.1 + Conty & Kulla 2018 |
//! | `unbalanced_nocut` | [`TreeSampler`](super::tree::cut::TreeSampler) with cones over a SAOH [`LightBvh`](super::bvh::LightBvh), cut = root | §4, pbrt-v4 |
//! | `unbalanced` | same, with a greedy cut | §4, pbrt-v4 |
//! | `unbalanced_nocone` | a cone-free SAH BVH with a greedy cut | §4 |
//! | `tree2` | [`TreeSampler`](super::tree::cut::TreeSampler) with cones and a greedy cut over the two-level tree ([`super::two_level`]: a perfect tree per mesh / light set, a SAOH BVH over their roots), in the BVH's layout | §3.1 |
//! | `sst` | [`SstSampler`](super::substitute::SstSampler) over the radix tree of (Morton, normal) codes ([`super::substitute::radix`]), `tree_cone` descent from the root, stopping at the first suitable substitute (biased) | Tatzgern et al. 2020 |
//! | `sst_nosub` | the same with substitution off: a leaf-only (unbiased) tree sampler | Tatzgern et al. 2020 |
//! | `sst_perfect` | `sst` over a perfect tree with equal-count splits in the same order, built on the GPU (an ablation, ours) | — |
//! | `lgh` | no picker: the lighting grid hierarchy ([`super::lgh`]) sums over grid lights and picks S shadow samples (biased) | Lin & Yuksel 2019 |
//!
//! A sampler's pmf is an f64 product of the f32 probabilities the
//! sampling decisions use, so `sample(s, u).pmf == pmf(s, light)` exactly.
//!
//! The kinds are the lines of the registry ([`super::registry`]).

use super::importance::Shading;
use super::light_params::{LightParams, SamplerBuffers};
use super::LightPrim;
use crate::gpu::Gpu;
use anyhow::Result;

/// Which node importance a tree sampler uses (computed by
/// [`Importance::of`](super::tree::cut::Importance::of)).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Importance {
    /// The paper's: bounds and intensity only (`tree`, `tree_nocut`,
    /// `unbalanced_nocone`).
    Plain,
    /// With the orientation cones and the clamped near distance
    /// (`tree_cone`, `unbalanced`, `unbalanced_nocut`).
    Cones,
}

/// The split cost of an unbalanced BVH build ([`super::bvh`]'s module
/// docs).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Cost {
    /// Surface area heuristic (bounds only).
    Sah,
    /// Surface area orientation heuristic (bounds, cones, intensity).
    Saoh,
}
use std::fmt;
use std::str::FromStr;

/// One sampled light and the probability of having picked it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LightSample {
    pub light: u32,
    pub pmf: f64,
}

/// Picks one light for a shading point with one random number.
pub trait LightSampler {
    /// A light for `s` with `u ∈ [0, 1)`, or `None` when no light can
    /// contribute (no lights, or every candidate has zero importance).
    fn sample(&self, s: &Shading, u: f32) -> Option<LightSample>;
    /// The probability that `sample(s, ·)` returns `light`.
    fn pmf(&self, s: &Shading, light: u32) -> f64;
}

/// The node layouts the WGSL descents read (`wgsl/lights/sample.wgsl`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Layout {
    /// The perfect tree's implicit layout: `2P − 1` nodes level by level,
    /// the leaf slot of each light in `light_index`.
    Perfect,
    /// The light BVH's explicit layout: `INTERNAL_BIT | left` children in
    /// pairs, each light's leaf node and then each node's parent in
    /// `light_index`.
    Bvh,
}

/// What a kind's CPU sampler is built with, from its registry row.
#[derive(Clone, Copy, Debug)]
pub struct CpuOptions<'a> {
    pub importance: Importance,
    /// The representative shading point and cut size of a kind with cuts
    /// (`None`: from the root).
    pub cut_at: Option<(&'a Shading, u32)>,
    /// The descent stops at suitable substitutes.
    pub substitutes: bool,
}

/// A technique built on the CPU whose nodes one of the WGSL descents
/// reads ([`Layout`]): everything the CPU factory and the GPU upload need,
/// so that such a technique is its folder and one registry line
/// (`Structure::Technique(&its::TECHNIQUE)`; docs/architecture.md). The
/// structures with a GPU build or WGSL of their own are
/// [`Structure`]'s other variants.
pub trait Technique: Sync {
    /// Its name in messages.
    fn name(&self) -> &'static str;
    /// The node layout its GPU upload fills.
    fn layout(&self) -> Layout;
    /// Whether it uploads a substitute per node (binding 23).
    fn substitutes(&self) -> bool {
        false
    }
    /// The CPU sampler over `prims` (at least one light).
    fn sampler(
        &self,
        prims: &[LightPrim],
        o: &CpuOptions<'_>,
    ) -> Box<dyn LightSampler + Send + Sync>;
    /// Builds the structure over `prims` (at least one, `params.count`
    /// of them) and uploads it into the samplers' bindings (cones only
    /// when `cones`).
    fn upload(
        &self,
        gpu: &Gpu,
        prims: &[LightPrim],
        cones: bool,
        params: &mut LightParams,
        out: &mut SamplerBuffers,
    ) -> Result<()>;
}

/// The light structure a kind samples: what the CPU factory
/// ([`super::factory::new_sampler`]) and the GPU upload
/// (`gpu_sampler::GpuSamplerData::new`) build for it.
#[derive(Clone, Copy)]
pub enum Structure {
    /// No structure: every light with probability 1/N.
    Uniform,
    /// An alias table over the lights' power.
    Power,
    /// The perfect light tree (`tree/perfect.rs`), implicit layout.
    PerfectTree,
    /// The perfect tree sorted with normal codes, a substitute per node
    /// (`substitute.rs`), implicit layout.
    SubstituteTree,
    /// A technique built on the CPU and read by the WGSL descent of its
    /// [`Layout`] (`substitute/radix.rs`: the paper's substitute tree).
    Technique(&'static dyn Technique),
    /// An unbalanced BVH over the lights built with this split cost
    /// (`bvh.rs`), explicit children.
    Bvh(Cost),
    /// The two-level tree (`two_level.rs`), in the BVH's layout.
    TwoLevel,
    /// The lighting grid hierarchy (`lgh.rs`): sums, picks no light.
    Grid,
}

impl PartialEq for Structure {
    fn eq(&self, other: &Structure) -> bool {
        use Structure::*;
        match (self, other) {
            (Technique(a), Technique(b)) => std::ptr::addr_eq(*a, *b),
            (Bvh(a), Bvh(b)) => a == b,
            (a, b) => std::mem::discriminant(a) == std::mem::discriminant(b),
        }
    }
}

impl Eq for Structure {}

impl fmt::Debug for Structure {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        use Structure::*;
        match self {
            Uniform => f.write_str("Uniform"),
            Power => f.write_str("Power"),
            PerfectTree => f.write_str("PerfectTree"),
            SubstituteTree => f.write_str("SubstituteTree"),
            Technique(t) => write!(f, "Technique({})", t.name()),
            Bvh(c) => write!(f, "Bvh({c:?})"),
            TwoLevel => f.write_str("TwoLevel"),
            Grid => f.write_str("Grid"),
        }
    }
}

/// How the kinds with cuts ([`SamplerKind::uses_cut`](super::registry::SamplerKind::uses_cut)) estimate from a
/// pixel's cut: the scene key `cut_sampling`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum CutSampling {
    /// One light from each subtree of the pixel's share of the cut, each
    /// divided by its own probability within its subtree, summed: the
    /// cut stratifies the lights (real-time stochastic lightcuts §2.2 and
    /// §4, "we pick a cut with n subtrees"; Yuksel 2019). An evaluation
    /// traces one shadow ray per subtree, so a cut of n nodes costs n light
    /// samples.
    #[default]
    Subtrees,
    /// One light per evaluation: a cut node drawn with the cut
    /// probabilities (eq. 2 generalized to the cut's nodes), then a descent
    /// below it. Unbiased, but not the paper's estimator: it keeps no
    /// stratification. An ablation.
    Mixture,
}

impl CutSampling {
    pub const ALL: [CutSampling; 2] = [CutSampling::Subtrees, CutSampling::Mixture];

    pub fn name(self) -> &'static str {
        match self {
            CutSampling::Subtrees => "subtrees",
            CutSampling::Mixture => "mixture",
        }
    }
}

impl fmt::Display for CutSampling {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for CutSampling {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        Self::ALL
            .into_iter()
            .find(|k| k.name() == s)
            .ok_or_else(|| format!("unknown cut_sampling '{s}': expected one of subtrees, mixture"))
    }
}
