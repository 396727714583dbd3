//! The unbalanced light tree: a binary BVH over the lights' bounds built on
//! the CPU, one light per leaf — the paper's "unbalanced tree" baseline
//! (real-time stochastic lightcuts §4, Figures 7–8; the paper clusters
//! agglomeratively, this splits top-down with binned costs). Two costs
//! ([`Cost`]): the surface area orientation heuristic of Conty & Kulla 2018
//! (pbrt-v4's light BVH), which keeps lights that face different ways
//! apart, for the `unbalanced` kinds that sample with cones; and the plain
//! surface area heuristic for the cone-free `unbalanced_nocone`.
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
//! [`BINS`]−1 planes per axis of their centroid bounds, the areas taken of
//! boxes grown by one bin width of the largest axis (so that point lights,
//! whose boxes have no area, are still clustered by proximity):
//!
//! * SAH: `A(L)·n_L + A(R)·n_R`;
//! * SAOH: `Σ_side I·M_Ω·A·K_r` over both sides, with `I` the side's
//!   intensity, `M_Ω` the solid-angle measure of its cone (Conty & Kulla
//!   eq. 1: `2π(1 − cos θ_o) + π/2·(2θ_w sin θ_o − cos(θ_o − 2θ_w) −
//!   2θ_o sin θ_o + cos θ_o)`, `θ_w = min(θ_o + θ_e, π)`) and
//!   `K_r = (largest extent)/(extent along the split axis)` of the node's
//!   bounds, which discourages slicing a long node across its short side.
//!
//! Every node carries its cone ([`LightCone::union`] of its children's, in
//! the order the intensities are summed). Coincident centroids, or a node
//! deeper than [`SAH_DEPTH`], are split at the median instead, so the tree
//! depth never exceeds `SAH_DEPTH + 32` levels ([`MAX_DEPTH`]). The build
//! is deterministic (stable partitions, ties broken by light id; of splits
//! of equal cost the first found is kept: x before y before z, lower
//! planes first).

use super::tree::perfect::{gather, leaf_node};
use super::{tree::cut::LightTree, LightCone, LightPrim, TreeNode, NO_LIGHT};
use glam::Vec3;

pub mod gpu;

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
    /// Orientation bound of each node.
    pub cones: Vec<LightCone>,
}

pub use super::sampler::Cost;

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

/// Builds the BVH with the split cost `cost`; `None` for zero lights.
pub fn build(prims: &[LightPrim], cost: Cost) -> Option<LightBvh> {
    let n = prims.len();
    if n == 0 {
        return None;
    }
    assert!(n < INTERNAL_BIT as usize, "at most 2^31 − 1 lights");
    let leaves: Vec<TreeNode> = (0..n as u32)
        .map(|id| leaf_node(&prims[id as usize], id))
        .collect();
    let centroid: Vec<Vec3> = prims.iter().map(|p| p.centroid()).collect();
    let cones: Vec<LightCone> = prims.iter().map(LightCone::of_prim).collect();
    Some(build_over(&leaves, &cones, &centroid, cost, SAH_DEPTH))
}

/// The BVH over items with the leaf nodes `leaves` (bounds and intensity;
/// `leaves[i].id` must be `i`), orientation bounds `cones` and split
/// points `centroid`, as [`build`] builds it over lights but splitting at
/// the median from depth `sah_depth` on (so the depth is at most
/// `sah_depth + 33`): the two-level tree builds its top level over the
/// groups' roots with it.
///
/// # Panics
///
/// When the slices are empty or their lengths differ.
pub(crate) fn build_over(
    leaves: &[TreeNode],
    cones: &[LightCone],
    centroid: &[Vec3],
    cost: Cost,
    sah_depth: u32,
) -> LightBvh {
    let n = leaves.len();
    assert!(n > 0 && cones.len() == n && centroid.len() == n);
    let info = Info {
        leaves,
        centroid,
        cones,
        cost,
        sah_depth,
    };
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
        let mid = split(&info, &mut order[first..end], depth) + first;
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
    let mut node_cones = vec![LightCone::EMPTY; nodes.len()];
    for i in (0..nodes.len()).rev() {
        let id = nodes[i].id;
        if id & INTERNAL_BIT != 0 {
            let l = (id & !INTERNAL_BIT) as usize;
            nodes[i] = TreeNode {
                id,
                ..gather(&nodes[l], &nodes[l + 1])
            };
            node_cones[i] = node_cones[l].union(&node_cones[l + 1]);
        } else {
            nodes[i] = leaves[id as usize];
            node_cones[i] = cones[id as usize];
        }
    }
    LightBvh {
        nodes,
        parent,
        leaf_of_light,
        depth: max_depth,
        cones: node_cones,
    }
}

/// What a split looks at.
struct Info<'a> {
    leaves: &'a [TreeNode],
    centroid: &'a [Vec3],
    cones: &'a [LightCone],
    cost: Cost,
    sah_depth: u32,
}

/// The lights of one bin, or of one side of a split.
#[derive(Clone, Copy)]
struct Side {
    bounds: Aabb,
    count: usize,
    intensity: f32,
    cone: LightCone,
}

impl Side {
    const EMPTY: Side = Side {
        bounds: Aabb::EMPTY,
        count: 0,
        intensity: 0.0,
        cone: LightCone::EMPTY,
    };

    fn add(&mut self, o: &Side) {
        self.bounds.grow(o.bounds.min, o.bounds.max);
        self.count += o.count;
        self.intensity += o.intensity;
        self.cone = self.cone.union(&o.cone);
    }

    /// The side's cost term (module docs); `k_r` is the node's `K_r`.
    fn cost(&self, cost: Cost, pad: f32, k_r: f32) -> f32 {
        let area = self.bounds.area(pad);
        match cost {
            Cost::Sah => area * self.count as f32,
            Cost::Saoh => self.intensity * orientation_measure(&self.cone) * area * k_r,
        }
    }
}

/// `M_Ω` of a cone (Conty & Kulla 2018 eq. 1; module docs).
pub fn orientation_measure(cone: &LightCone) -> f32 {
    use std::f32::consts::PI;
    let theta_o = cone.sin_o.atan2(cone.cos_o);
    let theta_e = cone.cos_e.clamp(-1.0, 1.0).acos();
    let theta_w = (theta_o + theta_e).min(PI);
    2.0 * PI * (1.0 - cone.cos_o)
        + PI / 2.0
            * (2.0 * theta_w * cone.sin_o
                - (theta_o - 2.0 * theta_w).cos()
                - 2.0 * theta_o * cone.sin_o
                + cone.cos_o)
}

/// Reorders `ids` (≥ 2 lights) into two non-empty groups and returns the
/// size of the first.
fn split(info: &Info, ids: &mut [u32], depth: u32) -> usize {
    let centroid = info.centroid;
    let mut cb = Aabb::EMPTY;
    let mut nb = Aabb::EMPTY;
    for &i in ids.iter() {
        cb.grow(centroid[i as usize], centroid[i as usize]);
        let leaf = &info.leaves[i as usize];
        nb.grow(leaf.min.into(), leaf.max.into());
    }
    let extent = cb.max - cb.min;
    let axis = extent.max_position();
    if extent[axis] <= 0.0 || depth >= info.sah_depth {
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
        let k_r = k_r(&nb, pad, a);
        let mut bins = [Side::EMPTY; BINS];
        for &i in ids.iter() {
            let leaf = &info.leaves[i as usize];
            let mut bounds = Aabb::EMPTY;
            bounds.grow(leaf.min.into(), leaf.max.into());
            bins[bin_of(centroid[i as usize], a)].add(&Side {
                bounds,
                count: 1,
                intensity: leaf.intensity,
                cone: info.cones[i as usize],
            });
        }
        // Suffix sweep for the right sides, prefix sweep for the left.
        let mut right_cost = [0.0f32; BINS];
        let mut right_count = [0usize; BINS];
        let mut acc = Side::EMPTY;
        for b in (1..BINS).rev() {
            acc.add(&bins[b]);
            right_cost[b] = acc.cost(info.cost, pad, k_r);
            right_count[b] = acc.count;
        }
        let mut acc = Side::EMPTY;
        for s in 1..BINS {
            acc.add(&bins[s - 1]);
            if acc.count == 0 || right_count[s] == 0 {
                continue;
            }
            let cost = acc.cost(info.cost, pad, k_r) + right_cost[s];
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

/// `K_r` of a node with bounds `node` for a split along `axis`: its largest
/// extent over its extent along `axis`, each grown by `pad` (module docs).
fn k_r(node: &Aabb, pad: f32, axis: usize) -> f32 {
    let extent = (node.max - node.min).max(Vec3::ZERO) + Vec3::splat(pad);
    extent.max_element() / extent[axis]
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
    fn cones(&self) -> &[LightCone] {
        &self.cones
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
        let bvh = build(&prims, Cost::Sah).unwrap();
        assert_eq!(bvh.nodes.len(), 15);
        let (l, r) = bvh.children(0).unwrap();
        assert!(bvh.nodes[l].max[0] < 1.0 && bvh.nodes[r].min[0] > 9.0);
        assert_eq!(bvh.nodes[0].intensity, 8.0);
        assert_eq!(bvh.depth, 4);
    }

    /// From depth `sah_depth` on, `build_over` splits at the median: a
    /// chain of lights at x = 16^i, which the binned SAOH peels one light
    /// per level (12 deep over 12 lights), is a balanced tree of depth
    /// ⌈log2 12⌉ + 1 = 5 with `sah_depth` 1, and deeper than that but at
    /// most `sah_depth` + ⌈log2 12⌉ + 1 in between.
    #[test]
    fn build_over_splits_at_the_median_from_its_sah_depth() {
        let prims: Vec<LightPrim> = (0..12)
            .map(|i| LightPrim::point(Vec3::new(16f32.powi(i), 0.0, 0.0), Vec3::ONE))
            .collect();
        let leaves: Vec<TreeNode> = (0..12).map(|i| leaf_node(&prims[i], i as u32)).collect();
        let cones: Vec<LightCone> = prims.iter().map(LightCone::of_prim).collect();
        let centroid: Vec<Vec3> = prims.iter().map(|p| p.centroid()).collect();
        let depth = |sah_depth| build_over(&leaves, &cones, &centroid, Cost::Saoh, sah_depth).depth;
        assert_eq!(build(&prims, Cost::Saoh).unwrap().depth, 12);
        assert_eq!(depth(SAH_DEPTH), 12);
        assert_eq!(depth(1), 5);
        for sah_depth in 2..8 {
            let d = depth(sah_depth);
            assert!(
                d > 5 && d <= sah_depth + 5,
                "sah_depth {sah_depth}: depth {d}"
            );
        }
    }

    /// The padded box's area is its surface area 2(xy + yz + zx) with `pad`
    /// added to every side length (an empty box: pad alone).
    #[test]
    fn padded_box_area_is_the_surface_area() {
        let b = Aabb {
            min: Vec3::ZERO,
            max: Vec3::new(1.0, 2.0, 3.0),
        };
        assert_eq!(b.area(0.0), 22.0);
        assert_eq!(b.area(1.0), 52.0);
        let point = Aabb {
            min: Vec3::ONE,
            max: Vec3::ONE,
        };
        assert_eq!(point.area(2.0), 24.0);
        assert_eq!(Aabb::EMPTY.area(1.0), 6.0);
    }

    /// A side's cost is the module docs' term — SAH A·n, SAOH I·M_Ω·A·K_r
    /// — and `add` sums counts and intensities and grows the bounds.
    #[test]
    fn side_costs_are_the_documented_terms() {
        let cone = LightCone::of_prim(&LightPrim::point(Vec3::ZERO, Vec3::ONE));
        let m = orientation_measure(&cone);
        assert!(m > 1.0 && m.is_finite(), "{m}");
        let a = Side {
            bounds: Aabb {
                min: Vec3::ZERO,
                max: Vec3::new(1.0, 2.0, 3.0),
            },
            count: 2,
            intensity: 3.0,
            cone,
        };
        assert_eq!(a.cost(Cost::Sah, 0.0, 7.0), 44.0);
        assert_eq!(a.cost(Cost::Saoh, 0.0, 1.5), 3.0 * m * 22.0 * 1.5);
        let b = Side {
            bounds: Aabb {
                min: Vec3::new(1.0, -1.0, 0.0),
                max: Vec3::new(2.0, 2.0, 3.0),
            },
            count: 1,
            intensity: 0.5,
            cone,
        };
        let mut s = a;
        s.add(&b);
        assert_eq!((s.count, s.intensity), (3, 3.5));
        assert_eq!(s.bounds.min, Vec3::new(0.0, -1.0, 0.0));
        assert_eq!(s.bounds.max, Vec3::new(2.0, 2.0, 3.0));
    }

    /// `K_r`: the largest padded extent over the one along the axis.
    #[test]
    fn k_r_is_the_largest_extent_over_the_axis_extent() {
        let node = Aabb {
            min: Vec3::new(1.0, 1.0, 1.0),
            max: Vec3::new(9.0, 2.0, 4.0),
        };
        assert_eq!(k_r(&node, 0.0, 0), 1.0);
        assert_eq!(k_r(&node, 0.0, 1), 8.0);
        assert_eq!(k_r(&node, 1.0, 1), 4.5);
        assert_eq!(k_r(&node, 1.0, 2), 2.25);
    }

    /// Of splits of equal cost the first is kept: three equal point lights
    /// at x = 0, 1, 2 split {0} | {1, 2} and {0, 1} | {2} at exactly the
    /// same cost (the same two terms, summed in the other order), and the
    /// root's left child is light 0 alone.
    #[test]
    fn equal_cost_splits_keep_the_first() {
        let prims: Vec<LightPrim> = (0..3)
            .map(|i| LightPrim::point(Vec3::new(i as f32, 0.0, 0.0), Vec3::ONE))
            .collect();
        for cost in [Cost::Sah, Cost::Saoh] {
            let bvh = build(&prims, cost).unwrap();
            let (l, _) = bvh.children(0).unwrap();
            assert_eq!(bvh.nodes[l].id, 0, "{cost:?}");
        }
    }

    /// The lights go to the side the chosen plane's cost counted them on:
    /// 16 equal point lights at x = 0, 1, …, 15 fall one per bin, the
    /// cheapest plane (A·n ∝ Σ n·length along x: 8·7 + 8·7) is between
    /// bins 7 and 8, and the root's children hold 8 lights each.
    #[test]
    fn lights_are_partitioned_at_the_costed_plane() {
        let prims: Vec<LightPrim> = (0..16)
            .map(|i| LightPrim::point(Vec3::new(i as f32, 0.0, 0.0), Vec3::ONE))
            .collect();
        for cost in [Cost::Sah, Cost::Saoh] {
            let bvh = build(&prims, cost).unwrap();
            let (l, r) = bvh.children(0).unwrap();
            assert_eq!(bvh.nodes[l].max[0], 7.0, "{cost:?}");
            assert_eq!(bvh.nodes[r].min[0], 8.0, "{cost:?}");
        }
    }

    #[test]
    fn coincident_lights_split_at_the_median() {
        let prims = vec![LightPrim::point(Vec3::ONE, Vec3::ONE); 9];
        let bvh = build(&prims, Cost::Sah).unwrap();
        assert_eq!(bvh.depth, 5);
        for (light, &leaf) in bvh.leaf_of_light.iter().enumerate() {
            assert_eq!(bvh.nodes[leaf as usize].id, light as u32);
        }
    }
}
