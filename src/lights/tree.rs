//! Real-time stochastic lightcuts (Lin & Yuksel, *Real-Time Stochastic
//! Lightcuts*, I3D 2020): the perfect light tree and the cuts sampled over
//! any binary light tree.
//!
//! * [`perfect`] — the CPU oracle of the perfect tree (§3.1, §4), sorted
//!   by Morton code; the layout is in [`crate::lights`]' module docs.
//! * [`gpu_build`] — the same tree built on the GPU every frame, bit for
//!   bit (`wgsl/lights/bounds.wgsl`, `morton.wgsl`, `tree_build.wgsl`); it
//!   also builds the substitute tree's order and substitutes for `sst`.
//! * [`cut`] — the [`LightTree`](cut::LightTree) view of a node layout,
//!   the greedy cut and [`TreeSampler`](cut::TreeSampler), the CPU oracle
//!   of the tree kinds (`tree_nocut`, `tree`, `tree_cone`; the BVH and
//!   two-level kinds sample through it too).
//! * [`gpu`] — the upload of a perfect tree into the samplers' bindings.
//!
//! The WGSL samplers are `wgsl/lights/sample.wgsl` (`light_descend`,
//! `light_sample_subtree`, `select_cut`, …) behind the generated kind
//! predicates.

pub mod cut;
pub mod gpu;
pub mod gpu_build;
pub mod perfect;
