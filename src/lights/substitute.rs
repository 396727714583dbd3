//! Stochastic substitute trees (Tatzgern et al. 2020,
//! `shared/papers/stochastic-substitute-trees.txt`): the CPU oracle of the
//! tree, its substitute distributions and its sampler (`sst`, `sst_nosub`).
//!
//! # The tree
//!
//! A perfect light tree (`src/lights/mod.rs` layout) whose leaves are
//! sorted by (Morton code, [`normal_code`], light id) — the paper's
//! `C = M ⊕ N ⊕ id` (eq. 4): lights close together come first, then lights
//! facing the same way. Beside every node (same index) lies a
//! [`Substitute`]: the node's lights as one Gaussian emitter.
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

use super::cut::{Importance, LightTree};
use super::importance::{choose_child, choose_cut_node, cut_probabilities, p_left, Shading};
use super::perfect::{self, PerfectTree};
use super::sampler::{LightSample, LightSampler};
use super::{morton, LightPrim, KIND_VPL};
use bytemuck::{Pod, Zeroable};
use glam::Vec3;

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

impl SubstituteTree {
    /// Whether the descent stops at `node` under `params` (`None`: never
    /// at an internal node).
    pub fn stops_at(&self, node: usize, params: Option<&SubstituteParams>) -> bool {
        match (self.tree.is_leaf(node), params) {
            (true, _) => true,
            (false, Some(q)) => {
                q.suitable(&self.substitutes[node], self.tree.nodes[node].intensity)
            }
            (false, None) => false,
        }
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

/// The `sst` sampler (`params: None` = `sst_nosub`).
#[derive(Clone, Debug)]
pub struct SstSampler {
    pub tree: SubstituteTree,
    pub params: Option<SubstituteParams>,
}

impl SstSampler {
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
        let bogus = self.tree.tree.is_leaf(node) && self.tree.leaf_light(node) == super::NO_LIGHT;
        (!bogus).then_some(Stop { node, pmf })
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
                if !(self.tree.tree.is_leaf(node) && self.tree.leaf_light(node) == super::NO_LIGHT)
                {
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
impl LightSampler for SstSampler {
    fn sample(&self, s: &Shading, u: f32) -> Option<LightSample> {
        let stop = SstSampler::sample(self, s, u)?;
        self.tree.tree.is_leaf(stop.node).then(|| LightSample {
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
mod tests {
    use super::*;

    /// A GPU pick `SUBSTITUTE_BIT | node` (`wgsl/lights/sample.wgsl`): one
    /// bit, clear in every node index of a tree of at most `MAX_LIGHTS`
    /// lights (nodes < 2·MAX_LIGHTS − 1), so a pick is never `NO_LIGHT`
    /// and decodes to its node.
    #[test]
    fn substitute_picks_decode_to_their_node() {
        assert_eq!(SUBSTITUTE_BIT.count_ones(), 1);
        for node in [0, 1, MAX_LIGHTS - 1, MAX_LIGHTS, 2 * MAX_LIGHTS - 2] {
            assert_eq!(node & SUBSTITUTE_BIT, 0, "{node}");
            let pick = SUBSTITUTE_BIT | node;
            assert_ne!(pick, super::super::NO_LIGHT);
            assert_eq!(pick & !SUBSTITUTE_BIT, node);
        }
    }

    #[test]
    fn normal_codes_by_octant_and_corner() {
        assert_eq!(normal_code([0.0, 0.0, 1.0]) >> 6, 0);
        assert_eq!(normal_code([0.0, 0.0, -1.0]) >> 6, 1);
        assert_eq!(normal_code([-1.0, 0.0, 0.0]) >> 6, 4);
        // +z: corner z (2) at every level.
        assert_eq!(normal_code([0.0, 0.0, 1.0]) & 63, 0b10_10_10);
        // +x: corner x (0) at every level.
        assert_eq!(normal_code([1.0, 0.0, 0.0]) & 63, 0);
        // The octant's centre: the centre triangle, then its centre again.
        assert_eq!(normal_code([1.0, 1.0, 1.0]) & 63, 0b11_11_11);
        assert_eq!(normal_code([0.0; 3]), 0);
        // Scale-free.
        let n = [0.3, -0.5, 0.81];
        assert_eq!(normal_code(n), normal_code(n.map(|x| x * 4.0)));
    }

    /// Codes worked by hand on normals whose coordinates (and their sums
    /// and doublings) are exact in f32, so that every level's choice is
    /// decided exactly, ties included (a coordinate of exactly half the
    /// sum takes its corner, the first such in x, y, z order).
    #[test]
    fn normal_codes_worked_by_hand() {
        // (1/8, 3/4, 1/8): corner y (1); then (1/4, 1/2, 1/4): y on the
        // tie (1); then (1/2, 0, 1/2): x on the tie (0).
        assert_eq!(normal_code([0.125, 0.75, 0.125]), 0b01_01_00);
        // (1/4, 1/4, 1/2): z (2), then (1/2, 1/2, 0): x (0), then
        // (0, 1, 0): y (1).
        assert_eq!(normal_code([0.25, 0.25, 0.5]), 0b10_00_01);
        // (3/8, 3/8, 1/4): no coordinate reaches 1/2, the centre (3),
        // which maps to (1 − 2a, 1 − 2b, 1 − 2c) = (1/4, 1/4, 1/2): z (2),
        // then x (0).
        assert_eq!(normal_code([0.375, 0.375, 0.25]), 0b11_10_00);
        // Octant bits: x negative 4, y 2, z 1.
        assert_eq!(
            normal_code([-0.125, 0.75, -0.125]),
            (0b101 << 6) | 0b01_01_00
        );
        assert_eq!(normal_code([0.25, -0.25, 0.5]), (0b010 << 6) | 0b10_00_01);
        // The sum s, not a coordinate, is the scale: doubled, the same.
        assert_eq!(normal_code([0.75, 0.75, 0.5]), 0b11_10_00);
        // Not a direction: NaN, infinite, or a sum that overflows.
        assert_eq!(normal_code([f32::NAN, 0.0, 1.0]), 0);
        assert_eq!(normal_code([f32::INFINITY, 0.0, 0.0]), 0);
        assert_eq!(normal_code([3e38, 3e38, 3e38]), 0);
    }

    /// The code of a direction by geometry, in f64: the octant's triangle
    /// (vertices x, y, z) cut into its four children (corner x, corner y,
    /// corner z, the centre with vertices opposite x, y, z), the child
    /// holding the point found from its barycentric coordinates in the
    /// current triangle (a 3×3 solve), first on ties as the code does.
    /// `None` when a coordinate lies within 1e-5 of 1/2 (f32 may decide
    /// either way there).
    fn normal_code_by_geometry(n: [f64; 3]) -> Option<u32> {
        let octant = ((n[0] < 0.0) as u32) << 2 | ((n[1] < 0.0) as u32) << 1 | (n[2] < 0.0) as u32;
        let a = n.map(f64::abs);
        let sum = a[0] + a[1] + a[2];
        let p = a.map(|x| x / sum);
        let mut v = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
        let mid = |a: [f64; 3], b: [f64; 3]| [0, 1, 2].map(|i| 0.5 * (a[i] + b[i]));
        let mut code = octant;
        for _ in 0..3 {
            // λ with Σ λ_k v_k = p by Cramer's rule (columns v_k).
            let det = |m: [[f64; 3]; 3]| {
                m[0][0] * (m[1][1] * m[2][2] - m[2][1] * m[1][2])
                    - m[1][0] * (m[0][1] * m[2][2] - m[2][1] * m[0][2])
                    + m[2][0] * (m[0][1] * m[1][2] - m[1][1] * m[0][2])
            };
            let d = det(v);
            let lambda = [0, 1, 2].map(|k| {
                let mut m = v;
                m[k] = p;
                det(m) / d
            });
            if lambda.iter().any(|l| (l - 0.5).abs() < 1e-5) {
                return None;
            }
            let (child, next) = if lambda[0] >= 0.5 {
                (0, [v[0], mid(v[0], v[1]), mid(v[0], v[2])])
            } else if lambda[1] >= 0.5 {
                (1, [mid(v[0], v[1]), v[1], mid(v[1], v[2])])
            } else if lambda[2] >= 0.5 {
                (2, [mid(v[0], v[2]), mid(v[1], v[2]), v[2]])
            } else {
                (3, [mid(v[1], v[2]), mid(v[0], v[2]), mid(v[0], v[1])])
            };
            code = code << 2 | child;
            v = next;
        }
        Some(code)
    }

    /// The normal code of 20,000 random directions (every octant, every
    /// child at every level) equals the geometric construction's.
    #[test]
    fn normal_codes_match_the_geometric_subdivision() {
        use rand::rngs::StdRng;
        use rand::{RngExt, SeedableRng};
        let mut rng = StdRng::seed_from_u64(7);
        let mut children = [[0u32; 4]; 3];
        let mut checked = 0;
        for _ in 0..20_000 {
            let n: [f32; 3] = std::array::from_fn(|_| rng.random_range(-1.0f32..1.0));
            let Some(want) = normal_code_by_geometry(n.map(f64::from)) else {
                continue;
            };
            assert_eq!(normal_code(n), want, "{n:?}");
            for (level, seen) in children.iter_mut().enumerate() {
                seen[(want >> (4 - 2 * level) & 3) as usize] += 1;
            }
            checked += 1;
        }
        assert!(checked > 19_000, "{checked}");
        assert!(children.iter().flatten().all(|&k| k > 1000), "{children:?}");
    }

    fn with_covariance(c: [[f32; 3]; 3], normal: [f32; 3]) -> Substitute {
        Substitute {
            cov_diag: [c[0][0], c[1][1], c[2][2]],
            cov_xy: c[0][1],
            cov_xz: c[0][2],
            cov_yz: c[1][2],
            normal,
            ..Default::default()
        }
    }

    /// Eq. 3 at its boundaries (ν_min = 1/2, σ_max = 0.1, so σ_max² is
    /// the f32 product 0.1·0.1): ν = ν_min and σ_z² = σ_max² are suitable,
    /// the next f32 beyond either is not, nor is a dark node; σ_z is the
    /// variance along the normal (z here), not across it.
    #[test]
    fn suitability_at_the_boundaries_of_eq_3() {
        let q = SubstituteParams::default();
        let max2 = 0.1f32 * 0.1;
        let node = |nu: f32, zz: f32| Substitute {
            nu,
            ..with_covariance(
                [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, zz]],
                [0.0, 0.0, 1.0],
            )
        };
        assert!(q.suitable(&node(0.5, max2), 1.0));
        assert!(q.suitable(&node(1.0, 0.0), f32::MIN_POSITIVE));
        assert!(!q.suitable(&node(0.5, max2), 0.0));
        assert!(!q.suitable(&node(0.5f32.next_down(), max2), 1.0));
        assert!(!q.suitable(&node(0.5, max2.next_up()), 1.0));
        assert!(!q.suitable(&node(0.5, 0.05), 1.0));
        assert!(!q.suitable(&node(0.25, 0.5), 1.0));
        // A wider σ_max admits it; a stricter ν_min refuses it.
        let wide = SubstituteParams {
            nu_min: 0.5,
            sigma_max: 0.5,
        };
        assert!(wide.suitable(&node(0.5, 0.25), 1.0));
        assert!(!wide.suitable(&node(0.5, 0.25f32.next_up()), 1.0));
        let strict = SubstituteParams {
            nu_min: 0.75,
            sigma_max: 0.1,
        };
        assert!(!strict.suitable(&node(0.5, 0.0), 1.0));
    }

    /// The sort against its definition, a sort of (Morton code, normal
    /// code, id) tuples: 600 VPLs and points on 40 positions (so Morton
    /// codes tie and the normal code decides) with 5 normals (so those tie
    /// too and the id decides).
    #[test]
    fn lights_sort_by_morton_then_normal_then_id() {
        use rand::rngs::StdRng;
        use rand::{RngExt, SeedableRng};
        let mut rng = StdRng::seed_from_u64(11);
        let spots: Vec<Vec3> = (0..40)
            .map(|_| Vec3::new(rng.random(), rng.random(), rng.random()))
            .collect();
        let normals = [
            Vec3::X,
            -Vec3::Y,
            Vec3::new(0.6, 0.0, 0.8),
            Vec3::Z,
            Vec3::new(-0.48, 0.6, -0.64),
        ];
        let prims: Vec<LightPrim> = (0..600)
            .map(|_| {
                let p = spots[rng.random_range(0..spots.len())];
                match rng.random_range(0..6usize) {
                    5 => LightPrim::point(p, Vec3::ONE),
                    k => LightPrim::vpl(p, normals[k], Vec3::ONE),
                }
            })
            .collect();
        let codes = morton::codes(&prims);
        let mut want: Vec<u32> = (0..prims.len() as u32).collect();
        want.sort_by_key(|&i| {
            (
                codes[i as usize],
                normal_code(prim_normal(&prims[i as usize])),
                i,
            )
        });
        assert_eq!(sort_lights(&prims), want);
    }

    /// The tree view of a substitute tree over 5 lights (8 leaves, 3
    /// bogus): 5 lights, each in the leaf that holds it; children and
    /// parents of the 15-node perfect tree; the nodes and cones its own.
    #[test]
    fn the_tree_view_is_the_perfect_trees() {
        let prims: Vec<LightPrim> = (0..5)
            .map(|i| LightPrim::vpl(Vec3::new(i as f32, 0.0, 0.0), Vec3::Y, Vec3::ONE))
            .collect();
        let t = build(&prims).unwrap();
        let view: &dyn LightTree = &t;
        assert_eq!(view.light_count(), 5);
        assert_eq!((view.nodes().len(), view.cones().len()), (15, 15));
        for light in 0..5 {
            let leaf = view.leaf_of_light(light).expect("every light has a leaf");
            assert_eq!(view.leaf_light(leaf), light);
            assert_eq!(view.children(leaf), None);
        }
        assert_eq!(view.leaf_of_light(5), None);
        assert_eq!(
            (view.children(0), view.children(2)),
            (Some((1, 2)), Some((5, 6)))
        );
        assert_eq!(
            (view.parent(0), view.parent(6), view.parent(9)),
            (None, Some(2), Some(4))
        );
    }

    /// A symmetric positive definite matrix with every off-diagonal
    /// non-zero (leading minors 4, 11, 20.75).
    const SPD: [[f32; 3]; 3] = [[4.0, 1.0, 0.5], [1.0, 3.0, -0.25], [0.5, -0.25, 2.0]];

    /// σ_z² = nᵀΣn against the f64 product; L·Lᵀ = Σ with L lower
    /// triangular, and the degenerate pivots give zero columns instead of
    /// 0/0. Tolerance: f32 rounding of a few operations on entries ≤ 4
    /// (1e-5).
    #[test]
    fn variance_along_the_normal_and_the_cholesky_factor() {
        let n = [1.0f32 / 3.0, 2.0 / 3.0, 2.0 / 3.0];
        let s = with_covariance(SPD, n);
        let mut want = 0.0f64;
        for r in 0..3 {
            for c in 0..3 {
                want += n[r] as f64 * SPD[r][c] as f64 * n[c] as f64;
            }
        }
        assert!(
            ((s.sigma_z2() as f64) - want).abs() < 1e-5,
            "{} vs {want}",
            s.sigma_z2()
        );
        let reproduces = |c: [[f32; 3]; 3]| {
            let l = with_covariance(c, [0.0; 3]).cholesky();
            for r in 0..3 {
                for k in r + 1..3 {
                    assert_eq!(l[r][k], 0.0, "upper entry {r}{k} of {l:?}");
                }
                for k in 0..3 {
                    let llt: f64 = (0..3).map(|j| l[r][j] as f64 * l[k][j] as f64).sum();
                    assert!(
                        (llt - c[r][k] as f64).abs() < 1e-5,
                        "LLᵀ[{r}][{k}] = {llt}, Σ {c:?}"
                    );
                }
            }
            l
        };
        let l = reproduces(SPD);
        assert_eq!((l[0][0], l[1][0], l[2][0]), (2.0, 0.5, 0.25));
        // No spread along x: the first pivot is 0 and its column too.
        let l = reproduces([[0.0, 0.0, 0.0], [0.0, 4.0, 2.0], [0.0, 2.0, 5.0]]);
        assert_eq!(l, [[0.0; 3], [0.0, 2.0, 0.0], [0.0, 1.0, 2.0]]);
        // y fully correlated with x: the second pivot is 0.
        let l = reproduces([[4.0, 2.0, 0.0], [2.0, 1.0, 0.0], [0.0, 0.0, 9.0]]);
        assert_eq!(l, [[2.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 3.0]]);
    }

    /// p + L·z with z = Φ⁻¹(u): u = 1/2 gives z = 0 exactly (the mean),
    /// u = Φ(1) a unit step along one column of L, and the box clamps.
    /// Tolerance: Φ⁻¹'s error at Φ(1) (2e-4, as its own test) times |L|.
    #[test]
    fn substitute_positions_follow_the_cholesky_columns() {
        let mut s = with_covariance(SPD, [0.0, 1.0, 0.0]);
        s.mean = [1.0, -2.0, 3.0];
        let (lo, hi) = (Vec3::splat(-10.0), Vec3::splat(10.0));
        let mean = Vec3::from(s.mean);
        assert_eq!(s.sample_position([0.5; 3], lo, hi), mean);
        let l = s.cholesky();
        let one = 0.841_344_7;
        for axis in 0..3 {
            let mut u = [0.5; 3];
            u[axis] = one;
            let column = Vec3::new(l[0][axis], l[1][axis], l[2][axis]);
            let got = s.sample_position(u, lo, hi);
            assert!(
                (got - (mean + column)).abs().max_element() < 2e-4 * 2.0,
                "column {axis}: {got} vs {}",
                mean + column
            );
        }
        // Clamped to a box ±1/8 about the mean (the step is 2, 1/2, 1/4).
        let tight = s.sample_position([one, 0.5, 0.5], mean - 0.125, mean + 0.125);
        assert_eq!(tight, Vec3::new(1.125, -1.875, 3.125));
    }

    /// One merge against the f64 moments of its two children: the mean
    /// and the covariance of the mixture (the children's own covariances
    /// plus the spread of their means), the normal as the normalized
    /// weighted sum, ν = ν₁ν₂·max(n₁·n₂, 0), the summed emission; then
    /// merges of four points in a tree against the f64 weighted moments
    /// of the points (moments merge exactly). Tolerance: f32 rounding of
    /// values ≤ 30 (1e-5 relative).
    #[test]
    fn merged_moments_are_the_mixtures() {
        let vpl = |p: [f32; 3], n: [f32; 3], e: [f32; 3]| {
            Substitute::of_prim(&LightPrim::vpl(
                Vec3::from(p),
                Vec3::from(n).normalize(),
                Vec3::from(e),
            ))
        };
        let mut a = vpl([1.0, 2.0, -1.0], [0.0, 1.0, 0.2], [1.0, 2.0, 3.0]);
        a.cov_diag = [0.5, 0.25, 1.0];
        a.cov_xy = 0.125;
        a.cov_xz = -0.0625;
        a.cov_yz = 0.03125;
        a.nu = 0.75;
        let mut b = vpl([-2.0, 0.5, 3.0], [0.3, 1.0, 0.0], [0.5, 0.5, 0.5]);
        b.nu = 0.5;
        let (ca, cb) = (3.0f32, 2.0f32);
        let m = merge(&a, ca, &b, cb);
        let (ta, tb) = (0.6f64, 0.4f64);
        let f = |v: [f32; 3]| v.map(|x| x as f64);
        let (pa, pb) = (f(a.mean), f(b.mean));
        let mean: [f64; 3] = std::array::from_fn(|k| ta * pa[k] + tb * pb[k]);
        let (ca_m, cb_m) = (a.covariance(), b.covariance());
        for r in 0..3 {
            assert!(
                (m.mean[r] as f64 - mean[r]).abs() < 1e-5 * 4.0,
                "mean {:?}",
                m.mean
            );
            for c in 0..3 {
                let want = ta * (ca_m[r][c] as f64 + (pa[r] - mean[r]) * (pa[c] - mean[c]))
                    + tb * (cb_m[r][c] as f64 + (pb[r] - mean[r]) * (pb[c] - mean[c]));
                let got = m.covariance()[r][c] as f64;
                assert!(
                    (got - want).abs() < 1e-5 * 30.0,
                    "cov[{r}][{c}] {got} vs {want}"
                );
            }
        }
        let (na, nb) = (Vec3::from(a.normal), Vec3::from(b.normal));
        let n = (na * ca + nb * cb).normalize();
        assert!(
            (Vec3::from(m.normal) - n).abs().max_element() < 1e-6,
            "{:?}",
            m.normal
        );
        assert!((m.nu - 0.75 * 0.5 * na.dot(nb)).abs() < 1e-6, "ν {}", m.nu);
        assert_eq!(m.emission, [1.5, 2.5, 3.5]);
        // Normals more than 90° apart: ν = 0; opposite with equal weights:
        // no normal at all.
        let back = vpl([0.0; 3], [0.0, -1.0, -0.2], [1.0; 3]);
        assert_eq!(merge(&a, 1.0, &back, 2.0).nu, 0.0);
        let up = vpl([0.0; 3], [0.0, 1.0, 0.0], [1.0; 3]);
        let down = vpl([1.0; 3], [0.0, -1.0, 0.0], [1.0; 3]);
        let none = merge(&up, 1.0, &down, 1.0);
        assert_eq!((none.normal, none.nu), ([0.0; 3], 0.0));

        // Four points merged as a tree against their f64 moments.
        let points = [
            ([0.0f32, 0.0, 0.0], 1.0f32),
            ([2.0, 1.0, -1.0], 2.0),
            ([-1.0, 3.0, 0.5], 0.5),
            ([1.0, -2.0, 2.0], 4.0),
        ];
        let s: Vec<Substitute> = points
            .iter()
            .map(|&(p, _)| vpl(p, [0.0, 1.0, 0.0], [1.0; 3]))
            .collect();
        let left = merge(&s[0], points[0].1, &s[1], points[1].1);
        let right = merge(&s[2], points[2].1, &s[3], points[3].1);
        let root = merge(
            &left,
            points[0].1 + points[1].1,
            &right,
            points[2].1 + points[3].1,
        );
        let total: f64 = points.iter().map(|&(_, c)| c as f64).sum();
        let mean: [f64; 3] = std::array::from_fn(|k| {
            points
                .iter()
                .map(|&(p, c)| c as f64 * p[k] as f64)
                .sum::<f64>()
                / total
        });
        for r in 0..3 {
            assert!((root.mean[r] as f64 - mean[r]).abs() < 1e-5 * 4.0);
            for c in 0..3 {
                let want: f64 = points
                    .iter()
                    .map(|&(p, w)| w as f64 * (p[r] as f64 - mean[r]) * (p[c] as f64 - mean[c]))
                    .sum::<f64>()
                    / total;
                let got = root.covariance()[r][c] as f64;
                assert!(
                    (got - want).abs() < 1e-5 * 30.0,
                    "root cov[{r}][{c}] {got} vs {want}"
                );
            }
        }
    }

    /// A child of intensity 0 (or NaN) drops out: the parent is the other
    /// child, and nothing when both are dark.
    #[test]
    fn dark_children_drop_out_of_a_merge() {
        let mut a = Substitute::of_prim(&LightPrim::vpl(Vec3::ONE, Vec3::Y, Vec3::ONE));
        a.cov_diag = [1.0, 2.0, 3.0];
        let b = Substitute::of_prim(&LightPrim::vpl(-Vec3::ONE, Vec3::X, Vec3::splat(2.0)));
        assert_eq!(merge(&a, 0.0, &b, 2.0), b);
        assert_eq!(merge(&a, f32::NAN, &b, 2.0), b);
        assert_eq!(merge(&a, -1.0, &b, 2.0), b);
        assert_eq!(merge(&a, 2.0, &b, 0.0), a);
        assert_eq!(merge(&a, 2.0, &b, f32::NAN), a);
        assert_eq!(merge(&a, 0.0, &b, 0.0), Substitute::default());
        assert_eq!(merge(&a, f32::NAN, &b, -1.0), Substitute::default());
    }

    #[test]
    fn inverse_normal_cdf_matches_known_quantiles() {
        // Φ⁻¹ at 0.5, 0.975, 0.8413447 (1σ), 0.0013499 (−3σ).
        for (u, z) in [
            (0.5, 0.0),
            (0.975, 1.959_964),
            (0.841_344_7, 1.0),
            (0.001_349_9, -3.0),
        ] {
            assert!((inverse_normal_cdf(u) - z).abs() < 2e-4, "{u}");
        }
        assert!(inverse_normal_cdf(0.0).is_finite() && inverse_normal_cdf(0.0) < -5.0);
        assert!(inverse_normal_cdf(0.999_999_94).is_finite());
    }

    /// Φ in f64: ½ + ∫₀^z φ by composite Simpson (1,024 intervals per unit
    /// of z: error ≤ (h⁴/180)·|z|·max|φ⁗| < 1e-13 for |z| ≤ 7).
    fn normal_cdf(z: f64) -> f64 {
        let n = ((z.abs() * 1024.0).ceil() as usize + 2) & !1;
        let h = z / n as f64;
        let phi = |t: f64| (-0.5 * t * t).exp() / (2.0 * std::f64::consts::PI).sqrt();
        let mut sum = phi(0.0) + phi(z);
        for i in 1..n {
            sum += phi(i as f64 * h) * if i % 2 == 1 { 4.0 } else { 2.0 };
        }
        0.5 + sum * h / 3.0
    }

    /// Φ⁻¹ against an f64 inversion of Φ (bisection to 1e-13) over the
    /// whole range (at the u its f32 argument represents), both branches of the approximation (w < 5 below |z| ≈
    /// 2.9): within 1e-6 relative + 1e-7 absolute, the single-precision
    /// erf⁻¹'s stated ~3.7e-7 relative error (Giles 2010) plus the f32
    /// roundings of 2u − 1, the logarithm and the products.
    #[test]
    fn inverse_normal_cdf_matches_an_f64_inversion() {
        let exact = |u: f64| {
            let (mut lo, mut hi) = (-7.0f64, 7.0f64);
            while hi - lo > 1e-13 {
                let mid = 0.5 * (lo + hi);
                if normal_cdf(mid) < u {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            0.5 * (lo + hi)
        };
        let mut us: Vec<f32> = (1..256).map(|k| k as f32 / 256.0).collect();
        us.extend([
            1e-6, 1e-5, 1e-4, 1e-3, 0.002, 0.998, 0.9999, 0.99999, 0.999_999,
        ]);
        for u in us {
            // At the u that the f32 argument 2u − 1 represents: its
            // rounding near the tails (ulp 6e-8 against 1 − |x| = 2e-6 at
            // u = 1e-6) is the input's, not the approximation's.
            let x = 2.0 * u - 1.0;
            let z = exact((x as f64 + 1.0) / 2.0);
            let got = inverse_normal_cdf(u) as f64;
            let err = (got - z).abs();
            assert!(err <= 1e-6 * z.abs() + 1e-7, "Φ⁻¹({u}) = {got}, exact {z}");
        }
    }
}
