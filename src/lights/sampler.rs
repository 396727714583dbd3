//! The light-sampler contract (pbrt-v4's `LightSampler`): `sample(ctx, u)`
//! picks one light with its probability, `pmf(ctx, light)` gives the same
//! probability independently. Implementations:
//!
//! | kind | sampler | paper |
//! |---|---|---|
//! | `uniform` | [`UniformSampler`] | "random sampling" baseline (§4) |
//! | `power` | [`PowerSampler`] (alias table, `I_i/ΣI`) | pbrt-v4 |
//! | `tree_nocut` | [`TreeSampler`] over a [`PerfectTree`], cut = root | §3.2 |
//! | `tree` | same, with a greedy cut per pixel block | §3.2–3.3 |
//! | `unbalanced_nocut` | [`TreeSampler`] over a [`LightBvh`], cut = root | §4 |
//! | `unbalanced` | same, with a greedy cut | §4 |
//!
//! A sampler's pmf is an f64 product of the f32 probabilities the
//! sampling decisions use, so `sample(s, u).pmf == pmf(s, light)` exactly.

pub use super::alias::{AliasEntry, PowerSampler};
use super::bvh::{self, LightBvh};
pub use super::cut::{select_cut, LightTree, TreeSampler};
pub use super::importance::Shading;
use super::perfect::{self, PerfectTree};
use super::LightPrim;
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
    Unbalanced,
    UnbalancedNoCut,
}

impl SamplerKind {
    pub const ALL: [SamplerKind; 6] = [
        SamplerKind::Uniform,
        SamplerKind::Power,
        SamplerKind::TreeNoCut,
        SamplerKind::Tree,
        SamplerKind::Unbalanced,
        SamplerKind::UnbalancedNoCut,
    ];

    pub fn name(self) -> &'static str {
        match self {
            SamplerKind::Uniform => "uniform",
            SamplerKind::Power => "power",
            SamplerKind::TreeNoCut => "tree_nocut",
            SamplerKind::Tree => "tree",
            SamplerKind::Unbalanced => "unbalanced",
            SamplerKind::UnbalancedNoCut => "unbalanced_nocut",
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

    /// Whether the kind samples from per-block cuts.
    pub fn uses_cut(self) -> bool {
        matches!(self, SamplerKind::Tree | SamplerKind::Unbalanced)
    }

    /// Whether the kind samples the perfect tree.
    pub fn uses_perfect_tree(self) -> bool {
        matches!(self, SamplerKind::Tree | SamplerKind::TreeNoCut)
    }

    /// Whether the kind samples the unbalanced BVH.
    pub fn uses_bvh(self) -> bool {
        matches!(self, SamplerKind::Unbalanced | SamplerKind::UnbalancedNoCut)
    }
}

impl fmt::Display for SamplerKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
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

/// Every light with probability `1/N`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct UniformSampler {
    pub count: u32,
}

impl LightSampler for UniformSampler {
    fn sample(&self, _s: &Shading, u: f32) -> Option<LightSample> {
        if self.count == 0 {
            return None;
        }
        let light = ((u * self.count as f32).floor() as u32).min(self.count - 1);
        Some(LightSample {
            light,
            pmf: 1.0 / self.count as f64,
        })
    }

    fn pmf(&self, _s: &Shading, light: u32) -> f64 {
        if light < self.count {
            1.0 / self.count as f64
        } else {
            0.0
        }
    }
}

/// The unbalanced-tree sampler.
pub type UnbalancedSampler = TreeSampler<LightBvh>;

/// A CPU sampler of `kind` over `prims`. `cut_at` = (representative
/// shading point, cut size) selects the cut of the `tree` and `unbalanced`
/// kinds (without it they sample from the root); the other kinds ignore it.
/// Zero lights give a sampler that never returns a light.
pub fn new_sampler(
    kind: SamplerKind,
    prims: &[LightPrim],
    cut_at: Option<(&Shading, u32)>,
) -> Box<dyn LightSampler + Send + Sync> {
    fn tree<T: LightTree + Send + Sync + 'static>(
        t: T,
        cut_at: Option<(&Shading, u32)>,
    ) -> Box<dyn LightSampler + Send + Sync> {
        match cut_at {
            Some((s, size)) => Box::new(TreeSampler::with_cut_at(t, s, size)),
            None => Box::new(TreeSampler::new(t)),
        }
    }
    if prims.is_empty() {
        return Box::new(UniformSampler { count: 0 });
    }
    let cut_at = cut_at.filter(|_| kind.uses_cut());
    match kind {
        SamplerKind::Uniform => Box::new(UniformSampler {
            count: prims.len() as u32,
        }),
        SamplerKind::Power => Box::new(PowerSampler::new(prims)),
        SamplerKind::Tree | SamplerKind::TreeNoCut => {
            tree::<PerfectTree>(perfect::build(prims).unwrap(), cut_at)
        }
        SamplerKind::Unbalanced | SamplerKind::UnbalancedNoCut => {
            tree::<LightBvh>(bvh::build(prims).unwrap(), cut_at)
        }
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
