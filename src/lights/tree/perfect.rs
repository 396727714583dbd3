//! CPU oracle of the perfect light tree (real-time stochastic lightcuts
//! §3.1, §4): lights sorted by (Morton code, light id) fill the leaf level,
//! bogus leaves pad it to a power of two, and internal nodes gather their
//! children bottom-up (bounds = union of non-empty child bounds, intensity =
//! `I(left) + I(right)` in f32). The layout is fixed by `src/lights/mod.rs`:
//! level `ℓ` occupies nodes `[2^ℓ − 1, 2^(ℓ+1) − 1)`, children of `i` are
//! `2i + 1` and `2i + 2`, leaf slot `s` is node `P − 1 + s`.
//!
//! The GPU builder must produce these nodes bit for bit; this module is its
//! reference.

use crate::lights::{morton, LightCone, LightPrim, TreeNode, NO_LIGHT};

/// A perfect light tree over `N ≥ 1` lights.
#[derive(Clone, Debug, PartialEq)]
pub struct PerfectTree {
    /// `2P − 1` nodes, level by level.
    pub nodes: Vec<TreeNode>,
    /// Number of levels `L + 1 = log2(P) + 1`.
    pub levels: u32,
    /// `P`: the light count rounded up to a power of two.
    pub leaf_count: u32,
    /// Light id of each real leaf slot (`N` entries; slots `N..P` are bogus).
    pub sorted: Vec<u32>,
    /// Leaf slot of each light id.
    pub leaf_of_light: Vec<u32>,
    /// Orientation bound of each node (same indices as `nodes`; bogus
    /// leaves [`LightCone::EMPTY`]), merged in the same pairwise order as
    /// the intensities. Only the cone kinds read them.
    pub cones: Vec<LightCone>,
}

/// First node index of level `level` (`2^level − 1`).
pub fn level_start(level: u32) -> usize {
    (1usize << level) - 1
}

/// Level of node `node` (`floor(log2(node + 1))`).
pub fn level_of(node: usize) -> u32 {
    usize::BITS - 1 - (node + 1).leading_zeros()
}

/// Parent of a non-root node.
pub fn parent(node: usize) -> usize {
    debug_assert!(node > 0);
    (node - 1) / 2
}

/// Leaf node of one light (no tree needed for the layout's arithmetic).
pub fn leaf_node(prim: &LightPrim, id: u32) -> TreeNode {
    TreeNode {
        min: prim.bounds_min().into(),
        intensity: prim.intensity(),
        max: prim.bounds_max().into(),
        id,
    }
}

/// Gathers two children into their parent: componentwise min/max (EMPTY
/// bounds drop out since EMPTY_MIN > any real coordinate > EMPTY_MAX) and
/// the f32 sum of intensities.
pub fn gather(left: &TreeNode, right: &TreeNode) -> TreeNode {
    TreeNode {
        min: std::array::from_fn(|a| left.min[a].min(right.min[a])),
        intensity: left.intensity + right.intensity,
        max: std::array::from_fn(|a| left.max[a].max(right.max[a])),
        id: NO_LIGHT,
    }
}

/// Light ids sorted by (Morton code, light id).
pub fn sort_lights(prims: &[LightPrim]) -> Vec<u32> {
    let codes = morton::codes(prims);
    let mut keys: Vec<u64> = codes
        .iter()
        .enumerate()
        .map(|(id, &c)| ((c as u64) << 32) | id as u64)
        .collect();
    keys.sort_unstable();
    keys.into_iter().map(|k| k as u32).collect()
}

/// Builds the perfect tree; `None` for zero lights.
pub fn build(prims: &[LightPrim]) -> Option<PerfectTree> {
    if prims.is_empty() {
        return None;
    }
    Some(build_sorted(prims, sort_lights(prims)))
}

/// Builds the perfect tree with the lights in the leaf order `sorted` (a
/// permutation of `0..N`, `N ≥ 1`): [`build`] sorts by (Morton code, id),
/// the substitute tree ([`crate::lights::substitute`]) by (Morton code, normal
/// code, id).
pub fn build_sorted(prims: &[LightPrim], sorted: Vec<u32>) -> PerfectTree {
    let n = prims.len();
    assert!(n > 0 && sorted.len() == n, "a permutation of N >= 1 lights");
    assert!(n <= 1 << 31, "at most 2^31 lights");
    let p = n.next_power_of_two();
    let levels = p.trailing_zeros() + 1;
    let mut leaf_of_light = vec![0u32; n];
    for (slot, &id) in sorted.iter().enumerate() {
        leaf_of_light[id as usize] = slot as u32;
    }

    let mut nodes = vec![TreeNode::EMPTY; 2 * p - 1];
    for (slot, &id) in sorted.iter().enumerate() {
        nodes[p - 1 + slot] = leaf_node(&prims[id as usize], id);
    }
    let mut cones = vec![LightCone::EMPTY; 2 * p - 1];
    for (slot, &id) in sorted.iter().enumerate() {
        cones[p - 1 + slot] = LightCone::of_prim(&prims[id as usize]);
    }
    for i in (0..p - 1).rev() {
        nodes[i] = gather(&nodes[2 * i + 1], &nodes[2 * i + 2]);
        cones[i] = cones[2 * i + 1].union(&cones[2 * i + 2]);
    }
    PerfectTree {
        nodes,
        levels,
        leaf_count: p as u32,
        sorted,
        leaf_of_light,
        cones,
    }
}

impl PerfectTree {
    /// Number of real lights `N`.
    pub fn light_count(&self) -> u32 {
        self.sorted.len() as u32
    }

    /// Node index of leaf slot `slot`.
    pub fn leaf_node_index(&self, slot: u32) -> usize {
        self.leaf_count as usize - 1 + slot as usize
    }

    /// Node index of the leaf holding light `light`.
    pub fn node_of_light(&self, light: u32) -> usize {
        self.leaf_node_index(self.leaf_of_light[light as usize])
    }

    /// Whether `node` is a leaf.
    pub fn is_leaf(&self, node: usize) -> bool {
        node >= self.leaf_count as usize - 1
    }

    /// The nodes of level `level` (root = 0).
    pub fn level(&self, level: u32) -> &[TreeNode] {
        &self.nodes[level_start(level)..level_start(level + 1)]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    #[test]
    fn layout_helpers() {
        assert_eq!(level_start(0), 0);
        assert_eq!(level_start(3), 7);
        assert_eq!(level_of(0), 0);
        assert_eq!(level_of(1), 1);
        assert_eq!(level_of(2), 1);
        assert_eq!(level_of(6), 2);
        assert_eq!(level_of(7), 3);
        assert_eq!(parent(5), 2);
        assert_eq!(parent(6), 2);
    }

    #[test]
    fn three_lights() {
        let prims = [
            LightPrim::point(Vec3::new(1.0, 0.0, 0.0), Vec3::ONE),
            LightPrim::point(Vec3::new(0.0, 0.0, 0.0), Vec3::splat(2.0)),
            LightPrim::point(Vec3::new(0.0, 1.0, 0.0), Vec3::splat(3.0)),
        ];
        let t = build(&prims).unwrap();
        assert_eq!((t.levels, t.leaf_count, t.nodes.len()), (3, 4, 7));
        // Codes: light 1 at the origin = 0, light 2 (y) < light 0 (x).
        assert_eq!(t.sorted, vec![1, 2, 0]);
        assert_eq!(t.leaf_of_light, vec![2, 0, 1]);
        assert_eq!(t.nodes[6], TreeNode::EMPTY);
        assert_eq!(t.nodes[2].min, [1.0, 0.0, 0.0]);
        assert_eq!(t.nodes[0].max, [1.0, 1.0, 0.0]);
        assert!((t.nodes[0].intensity - 6.0).abs() < 1e-5);
        assert!(build(&[]).is_none());
        // Levels: the root, then 2, then the 4 leaves (the bogus one last).
        assert_eq!(t.level(0), &t.nodes[0..1]);
        assert_eq!(t.level(1), &t.nodes[1..3]);
        assert_eq!(t.level(2), &t.nodes[3..7]);
        assert_eq!(t.level(2)[3], TreeNode::EMPTY);
    }
}
