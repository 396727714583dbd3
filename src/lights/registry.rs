//! The sampler registry: one `registry!` line per kind generates
//! [`SamplerKind`] and [`REGISTRY`]. A line names the kind, the
//! [`Structure`] it samples and whether it cuts, uses cones, stops at
//! substitutes and is biased, with a few words for `--help`; every
//! predicate below, both factories, the WGSL's kind predicates and the
//! CLI read the row. A kind over an existing structure is one line; a
//! technique built on the CPU and read by an existing WGSL descent is its
//! module (with its `mod` line) and one line (`Structure::Technique`;
//! docs/architecture.md shows both diffs). This module sits above the techniques (it names
//! them); the contract ([`super::sampler`]) sits below.

use super::sampler::{Cost, Importance, Layout, Structure};
use std::fmt;
use std::str::FromStr;

/// One row of the registry: everything that decides what a kind is.
#[derive(Clone, Copy, Debug)]
pub struct Entry {
    pub kind: SamplerKind,
    /// The name in scene files, on the command line and in reports.
    pub name: &'static str,
    pub structure: Structure,
    /// Samples from per-block cuts.
    pub cut: bool,
    /// The node importance uses orientation cones.
    pub cones: bool,
    /// A descent stops at a suitable node's substitute.
    pub substitutes: bool,
    /// The estimate is biased.
    pub biased: bool,
    /// A few words for `--help`.
    pub help: &'static str,
}

/// The sampler registry: one line per kind, generating [`SamplerKind`]
/// (its variants in the lines' order, which is `light_params.kind` in the
/// WGSL) and [`REGISTRY`]. A kind that combines a structure, cuts, cones
/// and substitutes as the existing ones do is one line here: every
/// predicate, both factories, the WGSL's kind predicates and `--help`
/// read its row, and the suites that run on every kind test it.
macro_rules! registry {
    ($($kind:ident: $name:literal, $structure:expr,
       [cut $cut:literal, cones $cones:literal, substitutes $subs:literal, biased $biased:literal],
       $help:literal;)*) => {
        /// Which sampler; the names are the CLI's and the scene file's
        /// ([`REGISTRY`]).
        #[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
        pub enum SamplerKind {
            $($kind,)*
        }

        /// Every kind's row, in [`SamplerKind`]'s order.
        pub const REGISTRY: &[Entry] = &[$(Entry {
            kind: SamplerKind::$kind,
            name: $name,
            structure: $structure,
            cut: $cut,
            cones: $cones,
            substitutes: $subs,
            biased: $biased,
            help: $help,
        },)*];
    };
}

#[rustfmt::skip]
registry! {
    Uniform: "uniform", Structure::Uniform,
        [cut false, cones false, substitutes false, biased false], "every light alike";
    Power: "power", Structure::Power,
        [cut false, cones false, substitutes false, biased false], "by power, an alias table";
    TreeNoCut: "tree_nocut", Structure::PerfectTree,
        [cut false, cones false, substitutes false, biased false], "the perfect light tree from its root";
    Tree: "tree", Structure::PerfectTree,
        [cut true, cones false, substitutes false, biased false],
        "real-time stochastic lightcuts: a cut per block, one light per cut subtree";
    TreeCone: "tree_cone", Structure::PerfectTree,
        [cut true, cones true, substitutes false, biased false], "tree with orientation cones";
    Unbalanced: "unbalanced", Structure::Bvh(Cost::Saoh),
        [cut true, cones true, substitutes false, biased false], "a SAOH light BVH with cuts";
    UnbalancedNoCut: "unbalanced_nocut", Structure::Bvh(Cost::Saoh),
        [cut false, cones true, substitutes false, biased false], "the SAOH light BVH from its root";
    UnbalancedNoCone: "unbalanced_nocone", Structure::Bvh(Cost::Sah),
        [cut true, cones false, substitutes false, biased false], "a cone-free SAH light BVH with cuts";
    Tree2: "tree2", Structure::TwoLevel,
        [cut true, cones true, substitutes false, biased false], "two-level tree: perfect per mesh, SAOH on top";
    Sst: "sst", Structure::Technique(&super::substitute::radix::RADIX_SUBSTITUTE_TREE),
        [cut false, cones true, substitutes true, biased true],
        "stochastic substitute trees over the paper's radix tree; biased";
    SstNoSub: "sst_nosub", Structure::Technique(&super::substitute::radix::RADIX_SUBSTITUTE_TREE),
        [cut false, cones true, substitutes false, biased false], "the radix substitute tree without substitution";
    SstPerfect: "sst_perfect", Structure::SubstituteTree,
        [cut false, cones true, substitutes true, biased true],
        "sst over an equal-count perfect tree, built on the GPU (ablation); biased";
    Lgh: "lgh", Structure::Grid,
        [cut false, cones false, substitutes false, biased true], "lighting grid hierarchy; biased";
}

/// How many kinds pick lights.
const PICKER_COUNT: usize = {
    let (mut i, mut k) = (0, 0);
    while i < REGISTRY.len() {
        if !matches!(REGISTRY[i].structure, Structure::Grid) {
            k += 1;
        }
        i += 1;
    }
    k
};

impl SamplerKind {
    /// Every kind, in the registry's order.
    pub const ALL: [SamplerKind; REGISTRY.len()] = {
        let mut all = [SamplerKind::Uniform; REGISTRY.len()];
        let mut i = 0;
        while i < REGISTRY.len() {
            all[i] = REGISTRY[i].kind;
            i += 1;
        }
        all
    };

    /// The kinds that pick one light per sample with a probability (the
    /// [`LightSampler`] contract): all but those over the grid hierarchy
    /// (`lgh`), which sums over grid lights ([`super::lgh`]).
    pub const PICKERS: [SamplerKind; PICKER_COUNT] = {
        let mut out = [SamplerKind::Uniform; PICKER_COUNT];
        let (mut i, mut k) = (0, 0);
        while i < REGISTRY.len() {
            if !matches!(REGISTRY[i].structure, Structure::Grid) {
                out[k] = REGISTRY[i].kind;
                k += 1;
            }
            i += 1;
        }
        assert!(k == out.len(), "PICKERS counts every kind that picks");
        out
    };

    /// The kind's registry row.
    pub fn entry(self) -> &'static Entry {
        &REGISTRY[self as usize]
    }

    pub fn name(self) -> &'static str {
        self.entry().name
    }

    /// All names, comma-separated.
    pub fn names() -> String {
        Self::ALL.map(|k| k.name()).join(", ")
    }

    /// Every name with its help, for `--help`.
    pub fn help() -> String {
        REGISTRY
            .iter()
            .map(|e| format!("{} ({})", e.name, e.help))
            .collect::<Vec<_>>()
            .join(", ")
    }

    /// The value of `light_params.kind` in WGSL (the index in [`Self::ALL`]).
    pub fn index(self) -> u32 {
        self as u32
    }

    /// The structure the kind samples.
    pub fn structure(self) -> Structure {
        self.entry().structure
    }

    /// Whether the kind picks one light per sample ([`Self::PICKERS`]).
    pub fn picks_lights(self) -> bool {
        self.structure() != Structure::Grid
    }

    /// Whether the kind samples a light tree (the perfect tree, the
    /// substitute trees, a BVH or the two-level tree).
    pub fn uses_tree(self) -> bool {
        self.uses_perfect_tree() || self.uses_bvh()
    }

    /// The node layout of a tree kind (`None` for the others).
    pub fn layout(self) -> Option<Layout> {
        match self.structure() {
            Structure::PerfectTree | Structure::SubstituteTree => Some(Layout::Perfect),
            Structure::Bvh(_) | Structure::TwoLevel => Some(Layout::Bvh),
            Structure::Technique(t) => Some(t.layout()),
            Structure::Uniform | Structure::Power | Structure::Grid => None,
        }
    }

    /// Whether the many-light integrand builds the kind's tree on the GPU
    /// every frame (the perfect tree, with substitutes for `sst_perfect`).
    pub fn builds_tree_on_gpu(self) -> bool {
        matches!(
            self.structure(),
            Structure::PerfectTree | Structure::SubstituteTree
        )
    }

    /// Whether the many-light integrand builds the kind's radix
    /// substitute tree on the GPU every frame (`sst`, `sst_nosub`;
    /// [`super::substitute::gpu_build`]).
    pub fn builds_radix_tree_on_gpu(self) -> bool {
        self.structure() == Structure::Technique(&super::substitute::radix::RADIX_SUBSTITUTE_TREE)
    }

    /// Whether the kind samples from per-block cuts.
    pub fn uses_cut(self) -> bool {
        self.entry().cut
    }

    /// Whether the kind samples a tree in the perfect tree's implicit
    /// layout (`sst_perfect`'s substitute tree is one).
    pub fn uses_perfect_tree(self) -> bool {
        self.layout() == Some(Layout::Perfect)
    }

    /// Whether the kind samples a substitute tree (leaves sorted with
    /// normal codes, a [`Substitute`](super::substitute::Substitute) per
    /// node): the radix tree (`sst`, `sst_nosub`) or the perfect tree
    /// (`sst_perfect`).
    pub fn uses_substitute_tree(self) -> bool {
        match self.structure() {
            Structure::SubstituteTree => true,
            Structure::Technique(t) => t.substitutes(),
            _ => false,
        }
    }

    /// Whether a descent stops at a suitable node's substitute (`sst`;
    /// `sst_nosub` descends to a light like the perfect tree).
    pub fn stops_at_substitutes(self) -> bool {
        self.entry().substitutes
    }

    /// Whether the kind's estimate is biased: `sst` (a sample may be a
    /// substitute instead of a light; its [`LightSampler`](super::sampler::LightSampler) view returns only
    /// the samples that stop at a light, so its light pmfs sum to less than
    /// one) and `lgh` (grid lights stand in for the lights).
    pub fn is_biased(self) -> bool {
        self.entry().biased
    }

    /// Whether the kind samples a tree in the unbalanced BVH's layout
    /// (explicit children): the BVH kinds, `tree2` and the radix
    /// substitute tree.
    pub fn uses_bvh(self) -> bool {
        self.layout() == Some(Layout::Bvh)
    }

    /// Whether the kind's node importance uses orientation cones.
    pub fn uses_cones(self) -> bool {
        self.entry().cones
    }

    /// The node importance of the tree kinds.
    pub fn importance(self) -> Importance {
        if self.uses_cones() {
            Importance::Cones
        } else {
            Importance::Plain
        }
    }

    /// The split cost of the kind's BVH build (a BVH kind's own; else SAOH
    /// with cones, SAH without, as the two-level tree's top is built).
    pub fn bvh_cost(self) -> Cost {
        match self.structure() {
            Structure::Bvh(cost) => cost,
            _ if self.uses_cones() => Cost::Saoh,
            _ => Cost::Sah,
        }
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

#[cfg(test)]
mod tests {
    use super::*;

    /// The registry's rows are consistent: unique names in snake case,
    /// substitutes only on the substitute tree, cuts only on trees, the
    /// biased kinds exactly those that stop at substitutes or sum over the
    /// grid, and the pickers every kind but the grid's.
    #[test]
    fn registry_rows_are_consistent() {
        for (i, e) in REGISTRY.iter().enumerate() {
            assert_eq!(e.kind as usize, i, "{}", e.name);
            assert!(
                e.name
                    .chars()
                    .all(|c| c.is_ascii_lowercase() || c.is_ascii_digit() || c == '_'),
                "{}",
                e.name
            );
            assert!(
                REGISTRY[..i].iter().all(|f| f.name != e.name),
                "{} twice",
                e.name
            );
            assert!(
                !e.substitutes || e.kind.uses_substitute_tree(),
                "{}",
                e.name
            );
            assert!(
                !e.cut || e.kind.uses_tree(),
                "{} cuts without a tree",
                e.name
            );
            assert_eq!(
                e.biased,
                e.substitutes || e.structure == Structure::Grid,
                "{}",
                e.name
            );
            assert_eq!(
                SamplerKind::PICKERS.contains(&e.kind),
                e.structure != Structure::Grid
            );
            assert!(!e.help.is_empty() && SamplerKind::help().contains(e.help));
        }
    }

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
