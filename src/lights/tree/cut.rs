//! Stochastic lightcuts over a binary light tree (real-time stochastic
//! lightcuts §3.2–3.3; Yuksel 2019): a *cut* is a set of nodes that covers
//! every light exactly once. The paper's estimator draws one light from
//! each subtree of the cut, by hierarchical importance sampling (eq. 1–2
//! at every internal node) from the cut node down to a leaf, and sums
//! each light's contribution divided by its probability within its
//! subtree ([`TreeSampler::sample_subtree`]): n cut nodes, n light
//! samples, the lights stratified by the cut. The one-pick view
//! ([`LightSampler`] for [`TreeSampler`], the `mixture` ablation) instead
//! picks one cut node with the cut probabilities (eq. 2 generalized to n
//! nodes, not in the paper) and descends from it, one random number
//! throughout.
//!
//! The cut is chosen greedily for a *representative* shading point (one
//! per k×k pixel block on the GPU, "cut sharing" §3.3): starting from the
//! root, the refinable node (internal, `I > 0`) with the largest key
//! `W/max(dmin², (10⁻³·D)²)` (D the diagonal of the root's box; the
//! authors' key, finite inside a box) is replaced by its two children
//! until the cut holds `cut_size` nodes. With `cut_size = 1`
//! the cut is the root: plain hierarchical sampling ("no cuts").
//!
//! [`LightTree`] abstracts the two node layouts: the perfect tree
//! (children by index arithmetic) and the unbalanced BVH (explicit child
//! links); [`TreeSampler`] works on either, with or without the trees'
//! orientation cones ([`Importance`]).
//!
//! The probability of a light (`pmf`) repeats exactly the f32 operations
//! of `sample` along the light's path and multiplies the same f32
//! probabilities in the same order in f64, so both give the same number.

use super::perfect::PerfectTree;
use crate::lights::importance::{
    choose_child, choose_cut_node, cut_key, cut_key_floor2, cut_probabilities, node_importance,
    p_left, NodeImportance, Shading,
};
use crate::lights::sampler::{LightSample, LightSampler};
use crate::lights::{LightCone, TreeNode, NO_LIGHT};

/// Largest cut a sampler supports (the WGSL cut arrays have this size).
pub const MAX_CUT: u32 = 64;

/// A binary light tree as the samplers see it.
pub trait LightTree {
    /// All nodes; node 0 is the root.
    fn nodes(&self) -> &[TreeNode];
    /// The orientation bound of every node (same indices as `nodes`).
    fn cones(&self) -> &[LightCone];
    /// Children `(left, right)` of an internal node; `None` for a leaf.
    fn children(&self, node: usize) -> Option<(usize, usize)>;
    /// Parent of a node; `None` for the root.
    fn parent(&self, node: usize) -> Option<usize>;
    /// The leaf node of a light; `None` for an unknown id.
    fn leaf_of_light(&self, light: u32) -> Option<usize>;
    /// Number of real lights.
    fn light_count(&self) -> u32;
    /// The light id stored in a leaf.
    fn leaf_light(&self, node: usize) -> u32;
}

impl LightTree for PerfectTree {
    fn nodes(&self) -> &[TreeNode] {
        &self.nodes
    }
    fn cones(&self) -> &[LightCone] {
        &self.cones
    }
    fn children(&self, node: usize) -> Option<(usize, usize)> {
        (!self.is_leaf(node)).then(|| (2 * node + 1, 2 * node + 2))
    }
    fn parent(&self, node: usize) -> Option<usize> {
        (node > 0).then(|| (node - 1) / 2)
    }
    fn leaf_of_light(&self, light: u32) -> Option<usize> {
        (light < self.light_count()).then(|| self.node_of_light(light))
    }
    fn light_count(&self) -> u32 {
        self.sorted.len() as u32
    }
    fn leaf_light(&self, node: usize) -> u32 {
        self.nodes[node].id
    }
}

pub use crate::lights::sampler::Importance;

impl Importance {
    /// The importance of `node` of `tree` at `s`.
    pub fn of<T: LightTree + ?Sized>(self, tree: &T, node: usize, s: &Shading) -> NodeImportance {
        let cone = match self {
            Importance::Plain => None,
            Importance::Cones => Some(&tree.cones()[node]),
        };
        node_importance(&tree.nodes()[node], cone, s)
    }
}

/// The greedy cut of at most `cut_size` (1..=[`MAX_CUT`]) nodes for the
/// representative shading point `s` (docs/light-sampling.md "Cuts").
pub fn select_cut<T: LightTree + ?Sized>(
    tree: &T,
    importance: Importance,
    s: &Shading,
    cut_size: u32,
) -> Vec<u32> {
    assert!(
        (1..=MAX_CUT).contains(&cut_size),
        "cut_size must be in 1..={MAX_CUT}, got {cut_size}"
    );
    let nodes = tree.nodes();
    let mut cut = vec![0u32];
    let floor2 = cut_key_floor2(&nodes[0]);
    // Keys of the cut nodes (NaN = not refinable), kept beside the cut.
    let key = |node: usize| -> f32 {
        match tree.children(node) {
            Some(_) if nodes[node].intensity > 0.0 => {
                cut_key(&importance.of(tree, node, s), floor2)
            }
            _ => f32::NAN,
        }
    };
    let mut keys = vec![key(0)];
    while cut.len() < cut_size as usize {
        let mut best: Option<usize> = None;
        for (j, &k) in keys.iter().enumerate() {
            if k.is_nan() {
                continue;
            }
            best = match best {
                Some(b) if !(k > keys[b] || (k == keys[b] && cut[j] < cut[b])) => Some(b),
                _ => Some(j),
            };
        }
        let Some(b) = best else { break };
        let (l, r) = tree
            .children(cut[b] as usize)
            .expect("refinable nodes are internal");
        cut[b] = l as u32;
        keys[b] = key(l);
        cut.push(r as u32);
        keys.push(key(r));
    }
    cut
}

/// The random numbers of subtree `j` under the paper's estimator at film
/// pixel `px` on the GPU (`ml_subtree_u` of `wgsl/many_light.wgsl`, bit
/// for bit): subtree 0 takes the evaluation's own `u`; subtree `j > 0`
/// takes `u` rotated mod 1 by four numbers hashed from `px` and `j` with
/// `shared/rng.wgsl`'s hashes. Each subtree draws with its own random
/// offset (the authors draw a new number per cut node) and keeps the
/// stratification of the pixel's sequence (hashing `u` itself cost 6–12 %
/// more variance, BENCHMARKS.md); each number stays uniform in `[0, 1)`,
/// which keeps each term unbiased.
pub fn subtree_random(u: [f32; 4], px: [u32; 2], j: u32) -> [f32; 4] {
    use crate::rng::{hash3, hash_u32};
    if j == 0 {
        return u;
    }
    let key = hash3(px[0], px[1], j);
    let unit = |x: u32| (x >> 8) as f32 * (1.0 / 16_777_216.0);
    let r =
        [0u32, 0x9e37_79b9, 0x3c6e_f372, 0xdaa6_6d2b].map(|k| unit(hash_u32(key.wrapping_add(k))));
    std::array::from_fn(|c| {
        let x = u[c] + r[c];
        x - x.floor()
    })
}

/// Hierarchical importance sampling below `node` with `u`, the pmf so far
/// multiplied by every child probability taken. `None` on a dead branch.
fn descend<T: LightTree + ?Sized>(
    tree: &T,
    importance: Importance,
    mut node: usize,
    s: &Shading,
    mut u: f32,
    mut pmf: f64,
) -> Option<LightSample> {
    while let Some((l, r)) = tree.children(node) {
        let p = p_left(&importance.of(tree, l, s), &importance.of(tree, r, s))?;
        let (left, p_taken, u_next) = choose_child(p, u);
        pmf *= p_taken as f64;
        u = u_next;
        node = if left { l } else { r };
    }
    let light = tree.leaf_light(node);
    (light != NO_LIGHT).then_some(LightSample { light, pmf })
}

/// Stochastic-lightcut sampler over a light tree and one cut (`[0]` = no cut).
#[derive(Clone, Debug)]
pub struct TreeSampler<T: LightTree = PerfectTree> {
    pub tree: T,
    pub importance: Importance,
    /// Node indices of the cut, in selection order.
    pub cut: Vec<u32>,
}

impl<T: LightTree> TreeSampler<T> {
    /// Sampling from the root (no cut).
    pub fn new(tree: T, importance: Importance) -> Self {
        Self::with_cut(tree, importance, vec![0])
    }

    /// Sampling from a given cut (which must cover every light once).
    pub fn with_cut(tree: T, importance: Importance, cut: Vec<u32>) -> Self {
        TreeSampler {
            tree,
            importance,
            cut,
        }
    }

    /// Sampling from the greedy cut for the representative point `s`.
    pub fn with_cut_at(tree: T, importance: Importance, s: &Shading, cut_size: u32) -> Self {
        let cut = select_cut(&tree, importance, s, cut_size);
        Self::with_cut(tree, importance, cut)
    }

    fn cut_importance(&self, s: &Shading) -> Vec<NodeImportance> {
        self.cut
            .iter()
            .map(|&c| self.importance.of(&self.tree, c as usize, s))
            .collect()
    }
}

impl<T: LightTree> TreeSampler<T> {
    /// The paper's estimator ([`CutSampling::Subtrees`](crate::lights::sampler::CutSampling::Subtrees)): the light drawn
    /// from subtree `j` of the cut with `u` (a descent from `cut[j]`), its
    /// pmf the probability within that subtree (the product of the child
    /// probabilities below the cut node). `None` on a dead subtree.
    ///
    /// Σ_j f(l_j)/pmf_j over the cut estimates Σ_l f(l) without bias: every
    /// light lies below exactly one cut node.
    pub fn sample_subtree(&self, s: &Shading, j: usize, u: f32) -> Option<LightSample> {
        descend(&self.tree, self.importance, self.cut[j] as usize, s, u, 1.0)
    }

    /// The cut node above `light` (its index in the cut) and the
    /// probability that [`Self::sample_subtree`] of that node returns
    /// `light`; `None` for an unknown light or one below no cut node.
    pub fn subtree_pmf(&self, s: &Shading, light: u32) -> Option<(usize, f64)> {
        let (j, path) = self.path_to_cut(light)?;
        Some((j, self.path_pmf(s, &path, 1.0)))
    }

    /// The path from the leaf of `light` up to the cut node above it, and
    /// that node's index in the cut.
    fn path_to_cut(&self, light: u32) -> Option<(usize, Vec<usize>)> {
        let mut path = vec![self.tree.leaf_of_light(light)?];
        loop {
            let top = *path.last().unwrap();
            if let Some(j) = self.cut.iter().position(|&c| c as usize == top) {
                return Some((j, path));
            }
            // No parent: not below the cut, so not a valid cut.
            path.push(self.tree.parent(top)?);
        }
    }

    /// `pmf` times the child probabilities along `path` (leaf first),
    /// multiplied top-down as sampling multiplies them.
    fn path_pmf(&self, s: &Shading, path: &[usize], mut pmf: f64) -> f64 {
        for step in path.windows(2).rev() {
            let (child, node) = (step[0], step[1]);
            let (l, r) = self.tree.children(node).expect("path nodes are internal");
            let imp = |n| self.importance.of(&self.tree, n, s);
            let Some(p) = p_left(&imp(l), &imp(r)) else {
                return 0.0;
            };
            pmf *= if child == l { p } else { 1.0 - p } as f64;
        }
        pmf
    }
}

/// The one-pick view ([`CutSampling::Mixture`](crate::lights::sampler::CutSampling::Mixture)): a cut node drawn with the
/// cut probabilities, then a descent below it.
impl<T: LightTree> LightSampler for TreeSampler<T> {
    fn sample(&self, s: &Shading, u: f32) -> Option<LightSample> {
        let probs = cut_probabilities(&self.cut_importance(s))?;
        let (j, u) = choose_cut_node(&probs, u);
        descend(
            &self.tree,
            self.importance,
            self.cut[j] as usize,
            s,
            u,
            probs[j] as f64,
        )
    }

    fn pmf(&self, s: &Shading, light: u32) -> f64 {
        let Some((j, path)) = self.path_to_cut(light) else {
            return 0.0;
        };
        let Some(probs) = cut_probabilities(&self.cut_importance(s)) else {
            return 0.0;
        };
        self.path_pmf(s, &path, probs[j] as f64)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lights::{tree::perfect, LightPrim};
    use glam::Vec3;

    #[test]
    fn cut_of_four_lights() {
        let prims: Vec<_> = (0..4)
            .map(|i| LightPrim::point(Vec3::new(i as f32, 0.0, 0.0), Vec3::ONE))
            .collect();
        let tree = perfect::build(&prims).unwrap();
        let s = Shading {
            p: Vec3::new(0.0, 1.0, 0.0),
            n: Vec3::ZERO,
        };
        let cut = |size| select_cut(&tree, Importance::Plain, &s, size);
        assert_eq!(cut(1), vec![0]);
        assert_eq!(cut(2), vec![1, 2]);
        // Node 1 (lights at x = 0, 1) is closer: refined first.
        assert_eq!(cut(3), vec![3, 2, 4]);
        assert_eq!(cut(64), vec![3, 5, 4, 6]);
    }
}
