//! CPU light samplers by kind: [`new_sampler`], the one dispatch on the
//! kind's [`Structure`] (each sampler lives in its technique's folder:
//! `simple/`, `tree/`, `bvh`, `two_level/`, `substitute/`).

use super::bvh::{self, LightBvh};
use super::importance::Shading;
use super::registry::SamplerKind;
use super::sampler::{CpuOptions, LightSampler, Structure};
use super::simple::{alias::PowerSampler, UniformSampler};
use super::substitute::{self, SstSampler, SubstituteParams};
use super::tree::cut::{Importance, LightTree, TreeSampler};
use super::tree::perfect::{self, PerfectTree};
use super::two_level;
use super::LightPrim;

/// The unbalanced-tree sampler.
pub type UnbalancedSampler = TreeSampler<LightBvh>;

/// A CPU sampler of `kind` over `prims`. `cut_at` = (representative
/// shading point, cut size) selects the cut of the kinds with cuts
/// (without it they sample from the root); the other kinds ignore it.
/// Zero lights give a sampler that never returns a light. `sst` uses the
/// default [`SubstituteParams`]; its samples that stop at a substitute
/// are `None` here (a substitute is not a light).
///
/// # Panics
///
/// For `lgh`, which picks no single light ([`SamplerKind::picks_lights`];
/// its CPU oracle is [`super::lgh`]).
pub fn new_sampler(
    kind: SamplerKind,
    prims: &[LightPrim],
    cut_at: Option<(&Shading, u32)>,
) -> Box<dyn LightSampler + Send + Sync> {
    fn tree<T: LightTree + Send + Sync + 'static>(
        t: T,
        importance: Importance,
        cut_at: Option<(&Shading, u32)>,
    ) -> Box<dyn LightSampler + Send + Sync> {
        match cut_at {
            Some((s, size)) => Box::new(TreeSampler::with_cut_at(t, importance, s, size)),
            None => Box::new(TreeSampler::new(t, importance)),
        }
    }
    assert!(
        kind.picks_lights(),
        "'{kind}' picks no single light: its CPU oracle is lights::lgh"
    );
    if prims.is_empty() {
        return Box::new(UniformSampler { count: 0 });
    }
    let cut_at = cut_at.filter(|_| kind.uses_cut());
    match kind.structure() {
        Structure::Uniform => Box::new(UniformSampler {
            count: prims.len() as u32,
        }),
        Structure::Power => Box::new(PowerSampler::new(prims)),
        Structure::PerfectTree => {
            tree::<PerfectTree>(perfect::build(prims).unwrap(), kind.importance(), cut_at)
        }
        Structure::Bvh(cost) => {
            tree::<LightBvh>(bvh::build(prims, cost).unwrap(), kind.importance(), cut_at)
        }
        // Without group information: one group, the perfect tree's order
        // (`two_level::build` with the scene's groups is what renders use).
        Structure::TwoLevel => tree::<LightBvh>(
            two_level::build(prims, std::slice::from_ref(&(0..prims.len() as u32))).unwrap(),
            kind.importance(),
            cut_at,
        ),
        Structure::SubstituteTree => Box::new(SstSampler {
            tree: substitute::build(prims).unwrap(),
            params: kind.stops_at_substitutes().then(SubstituteParams::default),
        }),
        Structure::Technique(t) => t.sampler(
            prims,
            &CpuOptions {
                importance: kind.importance(),
                cut_at,
                substitutes: kind.stops_at_substitutes(),
            },
        ),
        Structure::Grid => unreachable!("asserted above"),
    }
}
