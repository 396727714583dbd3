//! Stochastic substitute trees (Tatzgern, Mayr, Kerbl & Steinberger,
//! *Stochastic Substitute Trees for Real-Time Global Illumination*, I3D
//! 2020): the CPU oracle of the trees, their substitute distributions and
//! the sampler (`sst`, `sst_nosub`, `sst_perfect`).
//!
//! # The trees
//!
//! Leaves sorted by (Morton code, [`normal_code`], light id) — the
//! paper's `C = M ⊕ N ⊕ id` (eq. 4): lights close together come first,
//! then lights facing the same way. `sst` and `sst_nosub` build the
//! paper's binary radix tree over these keys ([`radix`]: each node one
//! Morton cell, then one normal class); `sst_perfect` a perfect light tree
//! (`src/lights/mod.rs` layout, [`build`]) with equal-count splits over
//! the same order, built on the GPU too (an ablation, ours). Beside every
//! node (same index) lies a [`Substitute`]: the node's lights as one
//! Gaussian emitter. The sampler ([`SstSampler`]) takes either tree
//! ([`SubstituteLayout`]).
//!
//! # Substitute distributions (paper §3.2, eq. 1–2)
//!
//! With `c` the node's scalar intensity (the luminance the tree sums):
//!
//! * mean `p = (c₁p₁ + c₂p₂)/(c₁ + c₂)` (eq. 1), computed as
//!   `p₁ + (p₂ − p₁)·c₂/(c₁ + c₂)`;
//! * normal `n = normalize(c₁n₁ + c₂n₂)` (the paper's "linearly
//!   interpolated based on the child contributions");
//! * the positional covariance `Σ = Σᵢ cᵢ(Σᵢ + ΔᵢΔᵢᵀ)/(c₁ + c₂)`,
//!   `Δᵢ = pᵢ − p`. The paper keeps only the diagonal of `Σ` in the frame
//!   of the cluster's plane (eq. 2) and notes that diverging child normals
//!   "partially invalidate the local variance values during merging"; the
//!   full world-space covariance merges exactly whatever the normals, and
//!   its diagonal in any frame — `σ_z² = nᵀΣn` along the normal — is what
//!   eq. 2 computes when the child frames agree (6 floats instead of 3);
//! * the normal similarity `ν = ν₁ν₂·max(n₁·n₂, 0)` (leaves: 1);
//! * the summed RGB on-axis intensity (the substitute emits it).
//!
//! A child with `c = 0` drops out (the parent is the other child's
//! distribution): a dark VPL does not make its neighbours unsuitable. Only
//! VPLs have substitutes: a point light (no normal) or an emissive triangle
//! has `ν = 0`, and so has every node above it.
//!
//! A node is **suitable** (eq. 3) when it is internal, `c > 0`,
//! `ν ≥ ν_min` and `σ_z ≤ σ_max` ([`SubstituteParams`], the paper's 0.5
//! and 0.1 by default).
//!
//! # Sampling (paper §4)
//!
//! From the root, the `tree_cone` descent (node importance with the
//! orientation cones, the clamped near distance and eq. 2's average of
//! the minimum- and maximum-distance probabilities, so a shading point
//! inside a box never gets a distance-free weight) with one random number;
//! the descent *stops* at the first suitable node (`sst`), or only at a
//! leaf (`sst_nosub`: an unbiased tree sampler over the lights). At a
//! stop on a suitable node the light is a *substitute VPL*: a position
//! drawn from `N(p, Σ)` (three inverse-normal-CDF variates `z`, `p + Lz`
//! with `L` the Cholesky factor of `Σ`, so `σ_z` is used, not dropped),
//! clamped to the node's box, emitting the node's summed intensity in a
//! cosine lobe about `n`. The estimate divides by the probability of
//! stopping at that node. This is biased by design: the substitute is not
//! the node's lights. The node's importance still bounds the substitute
//! (its position stays in the box and its normal, an average of normals in
//! the node's cone, in the cone when the cone is narrower than a
//! hemisphere — which `ν ≥ ν_min > 0` implies for its children).

use super::importance::{choose_child, choose_cut_node, cut_probabilities, p_left, Shading};
use super::sampler::{LightSample, LightSampler};
use super::tree::cut::{Importance, LightTree};
use super::tree::perfect::{self, PerfectTree};
use super::{morton, LightPrim, KIND_VPL};
use bytemuck::{Pod, Zeroable};
use glam::Vec3;

pub mod gpu;
pub mod gpu_build;
pub mod radix;

/// A GPU light pick `SUBSTITUTE_BIT | node` is node's substitute
/// (`LightPick.light` in `wgsl/lights/sample.wgsl`); so a substitute tree
/// holds at most [`MAX_LIGHTS`] lights (node indices below `2^31`).
pub const SUBSTITUTE_BIT: u32 = 1 << 31;
/// Most lights of a substitute tree.
pub const MAX_LIGHTS: u32 = 1 << 30;

/// Bits of [`normal_code`].
pub const NORMAL_BITS: u32 = 9;

/// The paper's 9-bit normal code (§3.3, Fig. 3): the octant (3 bits: x, y,
/// z negative), then 3 levels of 4-way midpoint subdivision of the octant's
/// triangle (2 bits each: corner x, y, z, or the centre triangle). Exact
/// and equal on CPU and GPU: only absolute values, one order of additions,
/// doublings (exact) and one subtraction per level. A zero normal (points,
/// triangles) has code 0.
pub fn normal_code(n: [f32; 3]) -> u32 {
    let octant = ((n[0] < 0.0) as u32) << 2 | ((n[1] < 0.0) as u32) << 1 | (n[2] < 0.0) as u32;
    let (mut a, mut b, mut c) = (n[0].abs(), n[1].abs(), n[2].abs());
    let s = (a + b) + c;
    if s.is_nan() || s <= 0.0 || s.is_infinite() {
        return 0;
    }
    let mut code = octant;
    for _ in 0..3 {
        // Barycentric coordinates (a, b, c)/s; each level keeps the sum s.
        let child = if 2.0 * a >= s {
            a = 2.0 * a - s;
            b *= 2.0;
            c *= 2.0;
            0
        } else if 2.0 * b >= s {
            a *= 2.0;
            b = 2.0 * b - s;
            c *= 2.0;
            1
        } else if 2.0 * c >= s {
            a *= 2.0;
            b *= 2.0;
            c = 2.0 * c - s;
            2
        } else {
            a = s - 2.0 * a;
            b = s - 2.0 * b;
            c = s - 2.0 * c;
            3
        };
        code = code << 2 | child;
    }
    code
}

/// The normal of a light for [`normal_code`]: a VPL's, else zero.
pub fn prim_normal(prim: &LightPrim) -> [f32; 3] {
    if prim.kind == KIND_VPL {
        prim.p1
    } else {
        [0.0; 3]
    }
}

/// Light ids sorted by (Morton code, normal code, light id).
pub fn sort_lights(prims: &[LightPrim]) -> Vec<u32> {
    let codes = morton::codes(prims);
    // 30 + 9 + 32 bits: a u128 key.
    let mut keys: Vec<u128> = codes
        .iter()
        .zip(prims)
        .enumerate()
        .map(|(id, (&m, p))| {
            let key = (m as u128) << NORMAL_BITS | normal_code(prim_normal(p)) as u128;
            key << 32 | id as u128
        })
        .collect();
    keys.sort_unstable();
    keys.into_iter().map(|k| k as u32).collect()
}

/// A node's substitute distribution (64 bytes; `Substitute` in
/// `wgsl/lights/substitute.wgsl`). The covariance is world-space:
/// `[xx, yy, zz]` in `cov_diag`, the off-diagonals apart.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct Substitute {
    /// Intensity-weighted mean position.
    pub mean: [f32; 3],
    /// Normal similarity ν ∈ [0, 1].
    pub nu: f32,
    /// Intensity-weighted mean normal, unit (zero when it cancels).
    pub normal: [f32; 3],
    pub cov_xy: f32,
    pub cov_diag: [f32; 3],
    pub cov_xz: f32,
    /// Summed RGB on-axis intensity (W/sr).
    pub emission: [f32; 3],
    pub cov_yz: f32,
}

impl Substitute {
    /// The distribution of one light: a VPL is a point with `ν = 1`; other
    /// lights get `ν = 0` and no normal (never part of a substitute).
    pub fn of_prim(prim: &LightPrim) -> Substitute {
        let vpl = prim.kind == KIND_VPL;
        Substitute {
            mean: prim.centroid().into(),
            nu: if vpl { 1.0 } else { 0.0 },
            normal: prim_normal(prim),
            emission: prim.emission,
            ..Default::default()
        }
    }

    /// The covariance as a symmetric matrix (columns).
    pub fn covariance(&self) -> [[f32; 3]; 3] {
        let [xx, yy, zz] = self.cov_diag;
        [
            [xx, self.cov_xy, self.cov_xz],
            [self.cov_xy, yy, self.cov_yz],
            [self.cov_xz, self.cov_yz, zz],
        ]
    }

    /// `σ_z² = nᵀΣn`, the variance along the normal.
    pub fn sigma_z2(&self) -> f32 {
        let n = Vec3::from(self.normal);
        let c = self.covariance();
        let sn = Vec3::new(
            c[0][0] * n.x + c[1][0] * n.y + c[2][0] * n.z,
            c[0][1] * n.x + c[1][1] * n.y + c[2][1] * n.z,
            c[0][2] * n.x + c[1][2] * n.y + c[2][2] * n.z,
        );
        n.dot(sn)
    }

    /// The lower Cholesky factor `L` of `Σ` (`Σ = LLᵀ`), rows; a pivot
    /// that rounding leaves ≤ 0 gives a zero column (degenerate,
    /// e.g. coplanar or collinear lights).
    pub fn cholesky(&self) -> [[f32; 3]; 3] {
        let c = self.covariance();
        let l00 = c[0][0].max(0.0).sqrt();
        let (l10, l20) = if l00 > 0.0 {
            (c[0][1] / l00, c[0][2] / l00)
        } else {
            (0.0, 0.0)
        };
        let l11 = (c[1][1] - l10 * l10).max(0.0).sqrt();
        let l21 = if l11 > 0.0 {
            (c[1][2] - l20 * l10) / l11
        } else {
            0.0
        };
        let l22 = (c[2][2] - l20 * l20 - l21 * l21).max(0.0).sqrt();
        [[l00, 0.0, 0.0], [l10, l11, 0.0], [l20, l21, l22]]
    }

    /// The substitute position for three uniforms `u` (module docs):
    /// `p + L·z`, `z` standard normal by [`inverse_normal_cdf`], clamped
    /// to `[lo, hi]`.
    pub fn sample_position(&self, u: [f32; 3], lo: Vec3, hi: Vec3) -> Vec3 {
        let z = u.map(inverse_normal_cdf);
        let l = self.cholesky();
        let d = Vec3::new(
            l[0][0] * z[0],
            l[1][0] * z[0] + l[1][1] * z[1],
            l[2][0] * z[0] + l[2][1] * z[1] + l[2][2] * z[2],
        );
        (Vec3::from(self.mean) + d).clamp(lo, hi)
    }
}

/// Merges two children of scalar intensities `ca`, `cb` (module docs).
pub fn merge(a: &Substitute, ca: f32, b: &Substitute, cb: f32) -> Substitute {
    if cb.is_nan() || cb <= 0.0 {
        return if ca > 0.0 { *a } else { Substitute::default() };
    }
    if ca.is_nan() || ca <= 0.0 {
        return *b;
    }
    let w = ca + cb;
    let (ta, tb) = (ca / w, cb / w);
    let (pa, pb) = (Vec3::from(a.mean), Vec3::from(b.mean));
    // p_a + t_b·(p_b − p_a): equal child means give exactly that mean (and
    // a zero Δ), so coincident or axis-aligned coplanar lights keep a zero
    // spread where they have none.
    let mean = pa + (pb - pa) * tb;
    let m = Vec3::from(a.normal) * ca + Vec3::from(b.normal) * cb;
    let len = m.length();
    let (normal, nu) = if len > 0.0 {
        let cos = Vec3::from(a.normal).dot(Vec3::from(b.normal));
        ((m / len).into(), a.nu * b.nu * cos.max(0.0))
    } else {
        ([0.0; 3], 0.0)
    };
    let (da, db) = (pa - mean, pb - mean);
    let second = |s: &Substitute, d: Vec3| {
        let c = s.covariance();
        [
            c[0][0] + d.x * d.x,
            c[1][1] + d.y * d.y,
            c[2][2] + d.z * d.z,
            c[0][1] + d.x * d.y,
            c[0][2] + d.x * d.z,
            c[1][2] + d.y * d.z,
        ]
    };
    let (sa, sb) = (second(a, da), second(b, db));
    let cov: [f32; 6] = std::array::from_fn(|k| ta * sa[k] + tb * sb[k]);
    Substitute {
        mean: mean.into(),
        nu,
        normal,
        cov_xy: cov[3],
        cov_diag: [cov[0], cov[1], cov[2]],
        cov_xz: cov[4],
        emission: (Vec3::from(a.emission) + Vec3::from(b.emission)).into(),
        cov_yz: cov[5],
    }
}

/// `√2·erf⁻¹(2u − 1)`: a standard normal variate from `u ∈ [0, 1)`
/// (Giles 2010's single-precision erf⁻¹, relative error ~1e-7; `2u − 1`
/// clamped to `±(1 − 2⁻²⁴)`, so |z| ≤ 5.4). The same operations as
/// `sst_inverse_normal_cdf` in `wgsl/lights/substitute.wgsl`.
pub fn inverse_normal_cdf(u: f32) -> f32 {
    let x = (2.0 * u - 1.0).clamp(-0.999_999_94, 0.999_999_94);
    let mut w = -((1.0 - x) * (1.0 + x)).ln();
    let p = if w < 5.0 {
        w -= 2.5;
        let mut p = 2.810_226_4e-8;
        for k in [
            3.432_739_4e-7,
            -3.523_387_7e-6,
            -4.391_506_5e-6,
            2.185_808_7e-4,
            -1.253_725e-3,
            -4.177_681_6e-3,
            0.246_640_73,
            1.501_409_4,
        ] {
            p = k + p * w;
        }
        p
    } else {
        w = w.sqrt() - 3.0;
        let mut p = -2.002_142_6e-4;
        for k in [
            1.009_505_6e-4,
            1.349_343_2e-3,
            -3.673_428_4e-3,
            5.739_507_7e-3,
            -7.622_461_3e-3,
            9.438_870_5e-3,
            1.001_674,
            2.832_976_8,
        ] {
            p = k + p * w;
        }
        p
    };
    std::f32::consts::SQRT_2 * p * x
}

/// Suitability thresholds of eq. 3 (`[integrand]` keys `sst_nu_min`,
/// `sst_sigma_max`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SubstituteParams {
    /// ν_min: least normal similarity (paper 0.5).
    pub nu_min: f32,
    /// σ_max: largest standard deviation along the normal, scene units
    /// (paper 0.1).
    pub sigma_max: f32,
}

impl Default for SubstituteParams {
    fn default() -> Self {
        SubstituteParams {
            nu_min: 0.5,
            sigma_max: 0.1,
        }
    }
}

impl SubstituteParams {
    /// Eq. 3 for a node of intensity `c` (internal nodes only: the caller
    /// checks). `σ_z ≤ σ_max` is tested as `σ_z² ≤ σ_max²`.
    pub fn suitable(&self, s: &Substitute, c: f32) -> bool {
        c > 0.0 && s.nu >= self.nu_min && s.sigma_z2() <= self.sigma_max * self.sigma_max
    }
}

/// A perfect tree sorted with normal codes and its substitutes.
#[derive(Clone, Debug, PartialEq)]
pub struct SubstituteTree {
    pub tree: PerfectTree,
    /// One per node, indexed like `tree.nodes`.
    pub substitutes: Vec<Substitute>,
}

/// Builds the substitute tree; `None` for zero lights.
pub fn build(prims: &[LightPrim]) -> Option<SubstituteTree> {
    if prims.is_empty() {
        return None;
    }
    assert!(prims.len() <= MAX_LIGHTS as usize, "at most 2^30 lights");
    let tree = perfect::build_sorted(prims, sort_lights(prims));
    let p = tree.leaf_count as usize;
    let mut substitutes = vec![Substitute::default(); 2 * p - 1];
    for (slot, &id) in tree.sorted.iter().enumerate() {
        substitutes[p - 1 + slot] = Substitute::of_prim(&prims[id as usize]);
    }
    for i in (0..p - 1).rev() {
        let (l, r) = (2 * i + 1, 2 * i + 2);
        substitutes[i] = merge(
            &substitutes[l],
            tree.nodes[l].intensity,
            &substitutes[r],
            tree.nodes[r].intensity,
        );
    }
    Some(SubstituteTree { tree, substitutes })
}

impl LightTree for SubstituteTree {
    fn nodes(&self) -> &[super::TreeNode] {
        &self.tree.nodes
    }
    fn cones(&self) -> &[super::LightCone] {
        &self.tree.cones
    }
    fn children(&self, node: usize) -> Option<(usize, usize)> {
        self.tree.children(node)
    }
    fn parent(&self, node: usize) -> Option<usize> {
        LightTree::parent(&self.tree, node)
    }
    fn leaf_of_light(&self, light: u32) -> Option<usize> {
        LightTree::leaf_of_light(&self.tree, light)
    }
    fn light_count(&self) -> u32 {
        LightTree::light_count(&self.tree)
    }
    fn leaf_light(&self, node: usize) -> u32 {
        self.tree.leaf_light(node)
    }
}

impl SubstituteLayout for SubstituteTree {
    fn substitutes(&self) -> &[Substitute] {
        &self.substitutes
    }
}

/// A light tree with a [`Substitute`] beside every node: the radix tree
/// of `sst` ([`radix::RadixTree`]) or the perfect tree of `sst_perfect`
/// ([`SubstituteTree`]).
pub trait SubstituteLayout: LightTree {
    /// One per node, indexed like [`LightTree::nodes`].
    fn substitutes(&self) -> &[Substitute];

    /// Whether the descent stops at `node` under `params` (`None`: never
    /// at an internal node).
    fn stops_at(&self, node: usize, params: Option<&SubstituteParams>) -> bool {
        match (self.children(node), params) {
            (None, _) => true,
            (Some(_), Some(q)) => {
                q.suitable(&self.substitutes()[node], self.nodes()[node].intensity)
            }
            (Some(_), None) => false,
        }
    }

    /// Whether `node` is a leaf without a light (the perfect tree's
    /// padding).
    fn is_bogus(&self, node: usize) -> bool {
        self.children(node).is_none() && self.leaf_light(node) == super::NO_LIGHT
    }
}

/// Where an `sst` descent stopped and with which probability.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Stop {
    /// The node: a leaf (its light is `tree.leaf_light(node)`) or a
    /// suitable internal node (a substitute).
    pub node: usize,
    pub pmf: f64,
}

/// The `sst` sampler over a tree with substitutes (`params: None` =
/// `sst_nosub`): the radix tree of `sst` or the perfect tree of
/// `sst_perfect` (the default type, as before the radix tree).
#[derive(Clone, Debug)]
pub struct SstSampler<T: SubstituteLayout = SubstituteTree> {
    pub tree: T,
    pub params: Option<SubstituteParams>,
}

impl<T: SubstituteLayout> SstSampler<T> {
    /// The stop for `u ∈ [0, 1)`; `None` on a dead branch or a bogus leaf.
    /// The same f32 operations as `light_descend` in WGSL.
    pub fn sample(&self, s: &Shading, u: f32) -> Option<Stop> {
        let imp = |n| Importance::Cones.of(&self.tree, n, s);
        // The cut [root], as the GPU samples the no-cut kinds.
        let probs = cut_probabilities(&[imp(0)])?;
        let (_, mut u) = choose_cut_node(&probs, u);
        let mut pmf = probs[0] as f64;
        let mut node = 0usize;
        while !self.tree.stops_at(node, self.params.as_ref()) {
            let (l, r) = self.tree.children(node).expect("internal");
            let p = p_left(&imp(l), &imp(r))?;
            let (left, p_taken, u_next) = choose_child(p, u);
            pmf *= p_taken as f64;
            u = u_next;
            node = if left { l } else { r };
        }
        (!self.tree.is_bogus(node)).then_some(Stop { node, pmf })
    }

    /// The probability that [`Self::sample`] stops at `node` (0 for nodes
    /// below a stop, and for internal nodes that are not stops).
    pub fn stop_pmf(&self, s: &Shading, node: usize) -> f64 {
        if !self.tree.stops_at(node, self.params.as_ref()) {
            return 0.0;
        }
        let mut path = vec![node];
        while let Some(p) = self.tree.parent(*path.last().unwrap()) {
            path.push(p);
        }
        let Some(probs) = cut_probabilities(&[Importance::Cones.of(&self.tree, 0, s)]) else {
            return 0.0;
        };
        let mut pmf = probs[0] as f64;
        for step in path.windows(2).rev() {
            let (child, parent) = (step[0], step[1]);
            if self.tree.stops_at(parent, self.params.as_ref()) {
                return 0.0;
            }
            let (l, r) = self.tree.children(parent).expect("internal");
            let imp = |n| Importance::Cones.of(&self.tree, n, s);
            let Some(p) = p_left(&imp(l), &imp(r)) else {
                return 0.0;
            };
            pmf *= if child == l { p } else { 1.0 - p } as f64;
        }
        pmf
    }

    /// Every stop with probability > 0 at `s`, and the probability that
    /// the descent ends on a dead branch instead (no stop: [`Self::sample`]
    /// returns `None`); the two add up to one. Exhaustive: for tests and
    /// small trees.
    pub fn stops(&self, s: &Shading) -> (Vec<Stop>, f64) {
        let mut out = Vec::new();
        let mut dead = 0.0;
        let Some(probs) = cut_probabilities(&[Importance::Cones.of(&self.tree, 0, s)]) else {
            return (out, 1.0);
        };
        let mut stack = vec![(0usize, probs[0] as f64)];
        while let Some((node, pmf)) = stack.pop() {
            if pmf == 0.0 {
                continue;
            }
            if self.tree.stops_at(node, self.params.as_ref()) {
                if !self.tree.is_bogus(node) {
                    out.push(Stop { node, pmf });
                }
                continue;
            }
            let (l, r) = self.tree.children(node).expect("internal");
            let imp = |n| Importance::Cones.of(&self.tree, n, s);
            match p_left(&imp(l), &imp(r)) {
                Some(p) => {
                    stack.push((l, pmf * p as f64));
                    stack.push((r, pmf * (1.0 - p) as f64));
                }
                None => dead += pmf,
            }
        }
        (out, dead)
    }
}

/// The light-picking view ([`super::factory::new_sampler`]): a stop at a
/// substitute is no light (`None`), so for `sst` the light pmfs sum to
/// one minus the substitutes' share; for `sst_nosub` to one.
impl<T: SubstituteLayout> LightSampler for SstSampler<T> {
    fn sample(&self, s: &Shading, u: f32) -> Option<LightSample> {
        let stop = SstSampler::sample(self, s, u)?;
        self.tree
            .children(stop.node)
            .is_none()
            .then(|| LightSample {
                light: self.tree.leaf_light(stop.node),
                pmf: stop.pmf,
            })
    }

    fn pmf(&self, s: &Shading, light: u32) -> f64 {
        match LightTree::leaf_of_light(&self.tree, light) {
            Some(leaf) => self.stop_pmf(s, leaf),
            None => 0.0,
        }
    }
}

#[cfg(test)]
mod tests;
