//! The two-level light tree (`tree2`; real-time stochastic lightcuts §3.1,
//! its Bistro results): a perfect tree per group of lights (one emissive
//! mesh, one light set, the point lights, the VPLs;
//! [`super::scene_lights::light_groups`]), each sorted by Morton codes over
//! *its own* bounds, and on top the SAOH BVH over the groups' roots
//! ([`super::bvh::build_over`]: their boxes, intensities and cones, split
//! at their box centres). A single perfect tree quantizes every light
//! against the bounds of all of them, so the triangles of a small lamp
//! share Morton cells with a large window nearby and their order
//! interleaves; two levels keep each mesh together.
//!
//! The paper's top level is a perfect tree too; here it is not, because
//! over a few dozen roots of very different sizes a perfect tree in Morton
//! order of their centres pairs a lamp with a window or a sign metres away
//! and leaves loose bounds at the top (on `street_lights` the median
//! relative variance of the unshadowed one-sample estimator was 5.55 with
//! it and is 1.97 with the SAOH top, the CPU SAOH BVH over all lights
//! 1.92; BENCHMARKS.md). The top level costs microseconds: it is built
//! over one box per group.
//!
//! The combined tree is not perfect (bottom levels differ in depth), so it
//! is stored in the unbalanced BVH's layout ([`super::bvh`]: explicit left
//! child, right = left + 1, `parent` and `leaf_of_light` for pmf queries)
//! and sampled by the same code on the CPU and in WGSL, with cones (merged
//! in the same pairwise order as the intensities) and cuts. Bogus leaves of
//! the bottom levels are dropped: a node with one non-empty child is that
//! child (its node, bounds, intensity and cone are the child's exactly), so
//! over one group the pmfs are the perfect tree's (`tree_cone` without a
//! cut), and over one light per group the SAOH BVH's (`unbalanced`).

use super::bvh::{self, Cost, LightBvh, INTERNAL_BIT, MAX_DEPTH};
use super::cut::LightTree;
use super::perfect::{self, gather};
use super::{LightCone, LightPrim, TreeNode, NO_LIGHT};
use glam::Vec3;
use std::ops::Range;

/// A node of the tree under construction.
struct Temp {
    node: TreeNode,
    cone: LightCone,
    children: Option<(usize, usize)>,
}

/// Builds the two-level tree over `prims` with the groups `groups`: ranges
/// of light ids that partition `0..prims.len()` in order (empty ranges are
/// allowed and skipped). `None` for zero lights.
///
/// # Panics
///
/// When `groups` do not partition the ids in order.
pub fn build(prims: &[LightPrim], groups: &[Range<u32>]) -> Option<LightBvh> {
    let n = prims.len();
    let mut next = 0u32;
    for g in groups {
        assert!(
            g.start == next && g.end >= g.start,
            "groups must partition the light ids in order: {groups:?}"
        );
        next = g.end;
    }
    assert_eq!(next as usize, n, "groups must cover all {n} lights");
    if n == 0 {
        return None;
    }
    assert!(n < INTERNAL_BIT as usize, "at most 2^31 − 1 lights");
    let mut arena: Vec<Temp> = Vec::new();

    // Bottom levels: one perfect tree per non-empty group.
    let mut roots: Vec<usize> = Vec::new();
    for g in groups.iter().filter(|g| !g.is_empty()) {
        let sub = &prims[g.start as usize..g.end as usize];
        let tree = perfect::build(sub).expect("a non-empty group");
        let root = import(&tree.nodes, &tree.cones, 0, g.start, &mut arena)
            .expect("a group's tree has a light");
        roots.push(root);
    }

    // Top level: the SAOH BVH over the roots (their boxes, intensities
    // and cones; split at their box centres).
    let leaves: Vec<TreeNode> = roots
        .iter()
        .enumerate()
        .map(|(i, &r)| TreeNode {
            id: i as u32,
            ..arena[r].node
        })
        .collect();
    let cones: Vec<LightCone> = roots.iter().map(|&r| arena[r].cone).collect();
    let centre: Vec<Vec3> = leaves
        .iter()
        .map(|b| 0.5 * (Vec3::from(b.min) + Vec3::from(b.max)))
        .collect();
    let bottom = groups
        .iter()
        .map(|g| perfect_levels(g.len()))
        .max()
        .unwrap_or(1);
    let top = bvh::build_over(&leaves, &cones, &centre, Cost::Saoh, top_sah_depth(bottom));
    let root = graft(&top, 0, &roots, &mut arena);
    Some(flatten(&arena, root, n))
}

/// Adds the subtree of perfect-tree node `i` (leaf ids offset by `base`)
/// to `arena` without its bogus parts; `None` when it holds no light.
fn import(
    nodes: &[TreeNode],
    cones: &[LightCone],
    i: usize,
    base: u32,
    arena: &mut Vec<Temp>,
) -> Option<usize> {
    if nodes[i].is_empty() {
        return None;
    }
    let leaves = nodes.len().div_ceil(2);
    if i + 1 >= leaves {
        arena.push(Temp {
            node: TreeNode {
                id: base + nodes[i].id,
                ..nodes[i]
            },
            cone: cones[i],
            children: None,
        });
        return Some(arena.len() - 1);
    }
    let left = import(nodes, cones, 2 * i + 1, base, arena);
    let right = import(nodes, cones, 2 * i + 2, base, arena);
    match (left, right) {
        (Some(l), Some(r)) => {
            arena.push(Temp {
                node: nodes[i],
                cone: cones[i],
                children: Some((l, r)),
            });
            Some(arena.len() - 1)
        }
        (one, None) | (None, one) => one,
    }
}

/// The depth from which the top level splits at the median when the
/// deepest bottom level has `bottom` levels (≤ 32: a perfect tree over
/// fewer than 2^31 lights): the top level is at most its SAH depth + 33
/// levels deep and its leaves are the bottom levels' roots, so the whole
/// tree stays within [`MAX_DEPTH`], the bound of the WGSL loops.
fn top_sah_depth(bottom: u32) -> u32 {
    (MAX_DEPTH + 1).saturating_sub(33 + bottom)
}

/// The number of levels of a perfect tree over `n` ≥ 1 leaves (a lone
/// leaf is one level).
fn perfect_levels(n: usize) -> u32 {
    n.next_power_of_two().ilog2() + 1
}

/// Adds the top-level tree's node `node` over the group roots `roots` to
/// `arena`: its leaves are the roots, its internal nodes joins.
fn graft(top: &LightBvh, node: usize, roots: &[usize], arena: &mut Vec<Temp>) -> usize {
    match top.children(node) {
        None => roots[top.nodes[node].id as usize],
        Some((l, r)) => {
            let l = graft(top, l, roots, arena);
            let r = graft(top, r, roots, arena);
            join(Some(l), Some(r), arena).expect("two subtrees")
        }
    }
}

/// The parent of two top-level subtrees (either may be absent).
fn join(left: Option<usize>, right: Option<usize>, arena: &mut Vec<Temp>) -> Option<usize> {
    match (left, right) {
        (Some(l), Some(r)) => {
            let node = gather(&arena[l].node, &arena[r].node);
            let cone = arena[l].cone.union(&arena[r].cone);
            arena.push(Temp {
                node,
                cone,
                children: Some((l, r)),
            });
            Some(arena.len() - 1)
        }
        (one, None) | (None, one) => one,
    }
}

/// The BVH layout of the tree at `root`: node 0 the root, children in
/// pairs after their parent (breadth first).
fn flatten(arena: &[Temp], root: usize, n: usize) -> LightBvh {
    let mut nodes = vec![TreeNode::EMPTY; 2 * n - 1];
    let mut cones = vec![LightCone::EMPTY; 2 * n - 1];
    let mut parent = vec![NO_LIGHT; 2 * n - 1];
    let mut leaf_of_light = vec![NO_LIGHT; n];
    let mut depth_of = vec![1u32; 2 * n - 1];
    // (arena index, output slot)
    let mut queue = std::collections::VecDeque::from([(root, 0usize)]);
    let mut used = 1usize;
    let mut depth = 1;
    while let Some((t, slot)) = queue.pop_front() {
        let temp = &arena[t];
        cones[slot] = temp.cone;
        depth = depth.max(depth_of[slot]);
        match temp.children {
            None => {
                nodes[slot] = temp.node;
                leaf_of_light[temp.node.id as usize] = slot as u32;
            }
            Some((l, r)) => {
                let left = used;
                used += 2;
                nodes[slot] = TreeNode {
                    id: INTERNAL_BIT | left as u32,
                    ..temp.node
                };
                for (child, at) in [(l, left), (r, left + 1)] {
                    parent[at] = slot as u32;
                    depth_of[at] = depth_of[slot] + 1;
                    queue.push_back((child, at));
                }
            }
        }
    }
    assert_eq!(used, 2 * n - 1, "a full binary tree over {n} leaves");
    assert!(depth <= MAX_DEPTH, "two-level tree depth {depth}");
    LightBvh {
        nodes,
        parent,
        leaf_of_light,
        depth,
        cones,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn top_level_depth_keeps_the_tree_within_the_wgsl_bound() {
        for bottom in 1..=32 {
            let top = top_sah_depth(bottom) + 33;
            assert!(top + bottom - 1 <= MAX_DEPTH, "bottom {bottom}");
            assert!(top_sah_depth(bottom) >= 9, "bottom {bottom}");
        }
    }

    #[test]
    fn perfect_levels_counts_the_root_and_the_leaves() {
        let levels: Vec<u32> = [1, 2, 3, 4, 5, 8, 9].map(perfect_levels).to_vec();
        assert_eq!(levels, [1, 2, 3, 3, 4, 4, 5]);
    }
}
