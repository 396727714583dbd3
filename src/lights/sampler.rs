//! The light-sampler contract (pbrt-v4's `LightSampler`): `sample(ctx, u)`
//! picks one light with its probability, `pmf(ctx, light)` gives the same
//! probability independently; and the sampler names ([`SamplerKind`]).
//! This module depends on little more than [`Shading`]; the implementations
//! depend on it, and [`super::factory::new_sampler`] builds one by kind:
//!
//! | kind | sampler | paper |
//! |---|---|---|
//! | `uniform` | [`UniformSampler`](super::factory::UniformSampler) | "random sampling" baseline (§4) |
//! | `power` | [`PowerSampler`](super::alias::PowerSampler) (alias table, `I_i/ΣI`) | pbrt-v4 |
//! | `tree_nocut` | [`TreeSampler`](super::cut::TreeSampler) over a [`PerfectTree`](super::perfect::PerfectTree), cut = root | §3.2 |
//! | `tree` | same, with a greedy cut per pixel block: under [`CutSampling::Subtrees`] (the default) one light from each cut subtree per evaluation, under `Mixture` one pick from the cut | §3.2–3.3, §4 |
//! | `tree_cone` | `tree` with orientation cones ([`Importance::Cones`]) | §3.1 + Conty & Kulla 2018 |
//! | `unbalanced_nocut` | [`TreeSampler`](super::cut::TreeSampler) with cones over a SAOH [`LightBvh`](super::bvh::LightBvh), cut = root | §4, pbrt-v4 |
//! | `unbalanced` | same, with a greedy cut | §4, pbrt-v4 |
//! | `unbalanced_nocone` | a cone-free SAH BVH with a greedy cut | §4 |
//! | `tree2` | [`TreeSampler`](super::cut::TreeSampler) with cones and a greedy cut over the two-level tree ([`super::two_level`]: a perfect tree per mesh / light set, a SAOH BVH over their roots), in the BVH's layout | §3.1 |
//! | `sst` | [`SstSampler`](super::substitute::SstSampler): a perfect tree sorted with normal codes, `tree_cone` descent from the root, stopping at the first suitable substitute (biased) | Tatzgern et al. 2020 |
//! | `sst_nosub` | the same with substitution off: a leaf-only (unbiased) tree sampler | Tatzgern et al. 2020 |
//! | `lgh` | no picker: the lighting grid hierarchy ([`super::lgh`]) sums over grid lights and picks S shadow samples (biased) | Lin & Yuksel 2019 |
//!
//! A sampler's pmf is an f64 product of the f32 probabilities the
//! sampling decisions use, so `sample(s, u).pmf == pmf(s, light)` exactly.

use super::importance::Shading;

/// Which node importance a tree sampler uses (computed by
/// [`Importance::of`](super::cut::Importance::of)).
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

/// Which sampler; the names are the CLI's and the scene file's.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum SamplerKind {
    Uniform,
    Power,
    TreeNoCut,
    Tree,
    TreeCone,
    Unbalanced,
    UnbalancedNoCut,
    UnbalancedNoCone,
    Tree2,
    Sst,
    SstNoSub,
    Lgh,
}

impl SamplerKind {
    /// Every kind: the pickers, then `lgh`.
    pub const ALL: [SamplerKind; 12] = {
        let mut all = [SamplerKind::Lgh; 12];
        let mut i = 0;
        while i < Self::PICKERS.len() {
            all[i] = Self::PICKERS[i];
            i += 1;
        }
        all
    };

    /// The kinds that pick one light per sample with a probability (the
    /// [`LightSampler`] contract): all but `lgh`, which sums over grid
    /// lights ([`super::lgh`]).
    pub const PICKERS: [SamplerKind; 11] = [
        SamplerKind::Uniform,
        SamplerKind::Power,
        SamplerKind::TreeNoCut,
        SamplerKind::Tree,
        SamplerKind::TreeCone,
        SamplerKind::Unbalanced,
        SamplerKind::UnbalancedNoCut,
        SamplerKind::UnbalancedNoCone,
        SamplerKind::Tree2,
        SamplerKind::Sst,
        SamplerKind::SstNoSub,
    ];

    pub fn name(self) -> &'static str {
        match self {
            SamplerKind::Uniform => "uniform",
            SamplerKind::Power => "power",
            SamplerKind::TreeNoCut => "tree_nocut",
            SamplerKind::Tree => "tree",
            SamplerKind::TreeCone => "tree_cone",
            SamplerKind::Unbalanced => "unbalanced",
            SamplerKind::UnbalancedNoCut => "unbalanced_nocut",
            SamplerKind::UnbalancedNoCone => "unbalanced_nocone",
            SamplerKind::Tree2 => "tree2",
            SamplerKind::Sst => "sst",
            SamplerKind::SstNoSub => "sst_nosub",
            SamplerKind::Lgh => "lgh",
        }
    }

    /// All names, comma-separated.
    pub fn names() -> String {
        Self::ALL.map(|k| k.name()).join(", ")
    }

    /// The value of `light_params.kind` in WGSL (the index in [`Self::ALL`]).
    pub fn index(self) -> u32 {
        Self::ALL.iter().position(|&k| k == self).unwrap() as u32
    }

    /// Whether the kind picks one light per sample ([`Self::PICKERS`]).
    pub fn picks_lights(self) -> bool {
        self != SamplerKind::Lgh
    }

    /// Whether the kind samples a light tree (the perfect tree, the
    /// substitute tree, a BVH or the two-level tree).
    pub fn uses_tree(self) -> bool {
        self.uses_perfect_tree() || self.uses_bvh()
    }

    /// Whether the kind samples from per-block cuts.
    pub fn uses_cut(self) -> bool {
        matches!(
            self,
            SamplerKind::Tree
                | SamplerKind::TreeCone
                | SamplerKind::Unbalanced
                | SamplerKind::UnbalancedNoCone
                | SamplerKind::Tree2
        )
    }

    /// Whether the kind samples a perfect tree (the substitute tree is one).
    pub fn uses_perfect_tree(self) -> bool {
        matches!(
            self,
            SamplerKind::Tree
                | SamplerKind::TreeNoCut
                | SamplerKind::TreeCone
                | SamplerKind::Sst
                | SamplerKind::SstNoSub
        )
    }

    /// Whether the kind samples the substitute tree (leaves sorted with
    /// normal codes, a [`Substitute`](super::substitute::Substitute) per
    /// node).
    pub fn uses_substitute_tree(self) -> bool {
        matches!(self, SamplerKind::Sst | SamplerKind::SstNoSub)
    }

    /// Whether a descent stops at a suitable node's substitute (`sst`;
    /// `sst_nosub` descends to a light like the perfect tree).
    pub fn stops_at_substitutes(self) -> bool {
        self == SamplerKind::Sst
    }

    /// Whether the kind's estimate is biased: `sst` (a sample may be a
    /// substitute instead of a light; its [`LightSampler`] view returns only
    /// the samples that stop at a light, so its light pmfs sum to less than
    /// one) and `lgh` (grid lights stand in for the lights).
    pub fn is_biased(self) -> bool {
        matches!(self, SamplerKind::Sst | SamplerKind::Lgh)
    }

    /// Whether the kind samples a tree in the unbalanced BVH's layout
    /// (explicit children): the BVH kinds and `tree2`.
    pub fn uses_bvh(self) -> bool {
        matches!(
            self,
            SamplerKind::Unbalanced
                | SamplerKind::UnbalancedNoCut
                | SamplerKind::UnbalancedNoCone
                | SamplerKind::Tree2
        )
    }

    /// Whether the kind's node importance uses orientation cones.
    pub fn uses_cones(self) -> bool {
        matches!(
            self,
            SamplerKind::TreeCone
                | SamplerKind::Unbalanced
                | SamplerKind::UnbalancedNoCut
                | SamplerKind::Tree2
                | SamplerKind::Sst
                | SamplerKind::SstNoSub
        )
    }

    /// The node importance of the tree kinds.
    pub fn importance(self) -> Importance {
        if self.uses_cones() {
            Importance::Cones
        } else {
            Importance::Plain
        }
    }

    /// The split cost of the BVH kinds' build.
    pub fn bvh_cost(self) -> Cost {
        if self.uses_cones() {
            Cost::Saoh
        } else {
            Cost::Sah
        }
    }
}

impl fmt::Display for SamplerKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// How the kinds with cuts ([`SamplerKind::uses_cut`]) estimate from a
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

/// A sampler name that is not one of [`SamplerKind::ALL`].
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("unknown light sampler '{0}': expected one of {names}", names = SamplerKind::names())]
pub struct UnknownSampler(pub String);

impl FromStr for SamplerKind {
    type Err = UnknownSampler;
    fn from_str(s: &str) -> Result<Self, UnknownSampler> {
        Self::ALL
            .into_iter()
            .find(|k| k.name() == s)
            .ok_or_else(|| UnknownSampler(s.to_string()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip() {
        for k in SamplerKind::ALL {
            assert_eq!(k.to_string().parse::<SamplerKind>(), Ok(k));
            assert!(UnknownSampler(String::new()).to_string().contains(k.name()));
            assert_eq!(SamplerKind::ALL[k.index() as usize], k);
        }
        let e = "trees".parse::<SamplerKind>().unwrap_err().to_string();
        assert!(
            e.contains("'trees'") && e.contains("unbalanced_nocut"),
            "{e}"
        );
    }
}
