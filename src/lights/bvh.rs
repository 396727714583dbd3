//! The unbalanced light tree: a binary BVH over the lights' bounds built on
//! the CPU with binned SAH, one light per leaf — the paper's "unbalanced
//! tree" baseline (real-time stochastic lightcuts §4, Figures 7–8; the
//! paper clusters agglomeratively, this uses the cheaper top-down SAH).
//!
//! # Layout (32-byte [`TreeNode`]s, node 0 = root)
//!
//! * leaf: `id` = the light id (`< INTERNAL_BIT`);
//! * internal: `id = INTERNAL_BIT | left`, the right child is `left + 1`
//!   (children are allocated in pairs, always after their parent);
//! * bounds and intensity as in the perfect tree: leaves from their light,
//!   internal nodes gathered bottom-up (`min`/`max`, `I(left) + I(right)`).
//!
//! `parent[node]` (`NO_LIGHT` for the root) and `leaf_of_light[light]`
//! (a node index) answer pmf queries by walking up from a leaf.
//!
//! # Build
//!
//! Top-down, iterative: a node's lights are split by the cheapest of
//! [`BINS`]−1 planes per axis of their centroid bounds under the surface
//! area heuristic `A(L)·n_L + A(R)·n_R`, the areas taken of boxes grown by
//! one bin width of the largest axis (so that point lights, whose boxes
//! have no area, are still clustered by proximity). Coincident centroids, or a node
//! deeper than [`SAH_DEPTH`], are split at the median instead, so the tree
//! depth never exceeds `SAH_DEPTH + 32` levels ([`MAX_DEPTH`]). The build
//! is deterministic (stable partitions, ties broken by light id).

use super::perfect::{gather, leaf_node};
use super::{cut::LightTree, LightPrim, TreeNode, NO_LIGHT};
use glam::Vec3;

/// Marks an internal node's `id`; the low 31 bits are its left child.
pub const INTERNAL_BIT: u32 = 0x8000_0000;
/// SAH bins per axis.
pub const BINS: usize = 16;
/// Depth from which nodes are split at the median.
pub const SAH_DEPTH: u32 = 40;
/// Upper bound of the number of nodes on a root-to-leaf path.
pub const MAX_DEPTH: u32 = SAH_DEPTH + 33;

/// A binary light BVH (module docs).
#[derive(Clone, Debug, PartialEq)]
pub struct LightBvh {
    pub nodes: Vec<TreeNode>,
    /// Parent of each node, [`NO_LIGHT`] for the root.
    pub parent: Vec<u32>,
    /// Leaf node of each light id.
    pub leaf_of_light: Vec<u32>,
    /// Largest number of nodes on a root-to-leaf path.
    pub depth: u32,
}

#[derive(Clone, Copy)]
struct Aabb {
    min: Vec3,
    max: Vec3,
}

impl Aabb {
    const EMPTY: Aabb = Aabb {
        min: Vec3::splat(f32::INFINITY),
        max: Vec3::splat(f32::NEG_INFINITY),
    };
    fn grow(&mut self, lo: Vec3, hi: Vec3) {
        self.min = self.min.min(lo);
        self.max = self.max.max(hi);
    }
    /// Surface area of the box grown by `pad` along every axis, so flat
    /// and point-like boxes (point lights, lights in a plane) still weigh
    /// by their size.
    fn area(&self, pad: f32) -> f32 {
        let d = (self.max - self.min).max(Vec3::ZERO) + Vec3::splat(pad);
        2.0 * (d.x * d.y + d.y * d.z + d.z * d.x)
    }
}

/// Builds the BVH; `None` for zero lights.
pub fn build(prims: &[LightPrim]) -> Option<LightBvh> {
    let n = prims.len();
    if n == 0 {
        return None;
    }
    assert!(n < INTERNAL_BIT as usize, "at most 2^31 − 1 lights");
    let centroid: Vec<Vec3> = prims.iter().map(|p| p.centroid()).collect();
    let mut order: Vec<u32> = (0..n as u32).collect();
    let mut nodes = vec![TreeNode::EMPTY; 2 * n - 1];
    let mut parent = vec![NO_LIGHT; 2 * n - 1];
    let mut leaf_of_light = vec![0u32; n];
    let mut next = 1usize;
    let mut max_depth = 1;
    // (node, first, end, depth) — depth counts nodes from the root.
    let mut stack = vec![(0usize, 0usize, n, 1u32)];
    while let Some((node, first, end, depth)) = stack.pop() {
        max_depth = max_depth.max(depth);
        if end - first == 1 {
            let id = order[first];
            nodes[node].id = id;
            leaf_of_light[id as usize] = node as u32;
            continue;
        }
        let mid = split(prims, &centroid, &mut order[first..end], depth) + first;
        let left = next;
        next += 2;
        nodes[node].id = INTERNAL_BIT | left as u32;
        parent[left] = node as u32;
        parent[left + 1] = node as u32;
        stack.push((left + 1, mid, end, depth + 1));
        stack.push((left, first, mid, depth + 1));
    }
    debug_assert_eq!(next, 2 * n - 1);
    // Children always follow their parent: gather in reverse index order.
    for i in (0..nodes.len()).rev() {
        let id = nodes[i].id;
        nodes[i] = if id & INTERNAL_BIT != 0 {
            let l = (id & !INTERNAL_BIT) as usize;
            TreeNode {
                id,
                ..gather(&nodes[l], &nodes[l + 1])
            }
        } else {
            leaf_node(&prims[id as usize], id)
        };
    }
    Some(LightBvh {
        nodes,
        parent,
        leaf_of_light,
        depth: max_depth,
    })
}

/// Reorders `ids` (≥ 2 lights) into two non-empty groups and returns the
/// size of the first.
fn split(prims: &[LightPrim], centroid: &[Vec3], ids: &mut [u32], depth: u32) -> usize {
    let mut cb = Aabb::EMPTY;
    for &i in ids.iter() {
        cb.grow(centroid[i as usize], centroid[i as usize]);
    }
    let extent = cb.max - cb.min;
    let axis = extent.max_position();
    if extent[axis] <= 0.0 || depth >= SAH_DEPTH {
        return median_split(centroid, ids, axis);
    }
    let pad = extent[axis] / BINS as f32;
    let bin_of = |c: Vec3, a: usize| -> usize {
        let t = (c[a] - cb.min[a]) / extent[a] * BINS as f32;
        (t as usize).min(BINS - 1)
    };
    // (cost, axis, split): lights in bins < split go left.
    let mut best: Option<(f32, usize, usize)> = None;
    for a in 0..3 {
        if extent[a] <= 0.0 {
            continue;
        }
        let mut boxes = [Aabb::EMPTY; BINS];
        let mut counts = [0usize; BINS];
        for &i in ids.iter() {
            let b = bin_of(centroid[i as usize], a);
            counts[b] += 1;
            let p = &prims[i as usize];
            boxes[b].grow(p.bounds_min(), p.bounds_max());
        }
        // Suffix sweep for the right sides, prefix sweep for the left.
        let mut right_area = [0.0f32; BINS];
        let mut right_count = [0usize; BINS];
        let (mut acc, mut cnt) = (Aabb::EMPTY, 0);
        for b in (1..BINS).rev() {
            acc.grow(boxes[b].min, boxes[b].max);
            cnt += counts[b];
            right_area[b] = acc.area(pad);
            right_count[b] = cnt;
        }
        let (mut acc, mut cnt) = (Aabb::EMPTY, 0);
        for s in 1..BINS {
            acc.grow(boxes[s - 1].min, boxes[s - 1].max);
            cnt += counts[s - 1];
            if cnt == 0 || right_count[s] == 0 {
                continue;
            }
            let cost = acc.area(pad) * cnt as f32 + right_area[s] * right_count[s] as f32;
            if best.is_none_or(|(c, _, _)| cost < c) {
                best = Some((cost, a, s));
            }
        }
    }
    let Some((_, a, s)) = best else {
        return median_split(centroid, ids, axis);
    };
    let (left, right): (Vec<u32>, Vec<u32>) = ids
        .iter()
        .partition(|&&i| bin_of(centroid[i as usize], a) < s);
    let k = left.len();
    ids[..k].copy_from_slice(&left);
    ids[k..].copy_from_slice(&right);
    k
}

/// Sorts by (centroid on `axis`, id) and splits in the middle.
fn median_split(centroid: &[Vec3], ids: &mut [u32], axis: usize) -> usize {
    ids.sort_unstable_by(|&a, &b| {
        centroid[a as usize][axis]
            .total_cmp(&centroid[b as usize][axis])
            .then(a.cmp(&b))
    });
    ids.len() / 2
}

impl LightTree for LightBvh {
    fn nodes(&self) -> &[TreeNode] {
        &self.nodes
    }
    fn children(&self, node: usize) -> Option<(usize, usize)> {
        let id = self.nodes[node].id;
        (id & INTERNAL_BIT != 0).then(|| {
            let l = (id & !INTERNAL_BIT) as usize;
            (l, l + 1)
        })
    }
    fn parent(&self, node: usize) -> Option<usize> {
        let p = self.parent[node];
        (p != NO_LIGHT).then_some(p as usize)
    }
    fn leaf_of_light(&self, light: u32) -> Option<usize> {
        self.leaf_of_light.get(light as usize).map(|&n| n as usize)
    }
    fn light_count(&self) -> u32 {
        self.leaf_of_light.len() as u32
    }
    fn leaf_light(&self, node: usize) -> u32 {
        self.nodes[node].id
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn two_clusters_split_apart() {
        let mut prims = Vec::new();
        for i in 0..4 {
            prims.push(LightPrim::point(
                Vec3::new(i as f32 * 0.1, 0.0, 0.0),
                Vec3::ONE,
            ));
            prims.push(LightPrim::point(
                Vec3::new(10.0 + i as f32 * 0.1, 0.0, 0.0),
                Vec3::ONE,
            ));
        }
        let bvh = build(&prims).unwrap();
        assert_eq!(bvh.nodes.len(), 15);
        let (l, r) = bvh.children(0).unwrap();
        assert!(bvh.nodes[l].max[0] < 1.0 && bvh.nodes[r].min[0] > 9.0);
        assert_eq!(bvh.nodes[0].intensity, 8.0);
        assert_eq!(bvh.depth, 4);
    }

    #[test]
    fn coincident_lights_split_at_the_median() {
        let prims = vec![LightPrim::point(Vec3::ONE, Vec3::ONE); 9];
        let bvh = build(&prims).unwrap();
        assert_eq!(bvh.depth, 5);
        for (light, &leaf) in bvh.leaf_of_light.iter().enumerate() {
            assert_eq!(bvh.nodes[leaf as usize].id, light as u32);
        }
    }
}
