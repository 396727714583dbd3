//! The two-level perfect light tree (`tree2`; real-time stochastic
//! lightcuts §3.1, its Bistro results): a perfect tree per group of lights
//! (one emissive mesh, one light set, the point lights, the VPLs;
//! [`super::scene_lights::light_groups`]), each sorted by Morton codes over
//! *its own* bounds, and a perfect tree over the groups' roots on top,
//! sorted by the roots' centroids over their bounds. A single perfect tree
//! quantizes every light against the bounds of all of them, so the
//! triangles of a small lamp share Morton cells with a large window nearby
//! and their order interleaves; two levels keep each mesh together.
//!
//! The combined tree is not perfect (bottom levels differ in depth), so it
//! is stored in the unbalanced BVH's layout ([`super::bvh`]: explicit left
//! child, right = left + 1, `parent` and `leaf_of_light` for pmf queries)
//! and sampled by the same code on the CPU and in WGSL, with cones (merged
//! in the same pairwise order as the intensities) and cuts. Bogus leaves of
//! either level are dropped: a node with one non-empty child is that child
//! (its node, bounds, intensity and cone are the child's exactly), so over
//! one group the pmfs are the perfect tree's (`tree_cone` without a cut).

use super::bvh::{LightBvh, INTERNAL_BIT, MAX_DEPTH};
use super::morton::{morton30, quantize_axis};
use super::perfect::{self, gather};
use super::{LightCone, LightPrim, TreeNode, NO_LIGHT};
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

    // Top level: a perfect tree over the roots, in Morton order of their
    // box centres over the centres' bounds (ties by group order).
    let centre = |i: usize| -> [f32; 3] {
        let b = &arena[i].node;
        std::array::from_fn(|a| 0.5 * b.min[a] + 0.5 * b.max[a])
    };
    let (mut lo, mut hi) = ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]);
    for &r in &roots {
        let c = centre(r);
        for a in 0..3 {
            lo[a] = lo[a].min(c[a]);
            hi[a] = hi[a].max(c[a]);
        }
    }
    let mut keyed: Vec<(u32, usize, usize)> = roots
        .iter()
        .enumerate()
        .map(|(g, &r)| {
            let c = centre(r);
            let code = morton30(std::array::from_fn(|a| quantize_axis(c[a], lo[a], hi[a])));
            (code, g, r)
        })
        .collect();
    keyed.sort_unstable();
    let mut level: Vec<Option<usize>> = keyed.into_iter().map(|(_, _, r)| Some(r)).collect();
    level.resize(level.len().next_power_of_two(), None);
    while level.len() > 1 {
        level = level
            .chunks(2)
            .map(|pair| join(pair[0], pair[1], &mut arena))
            .collect();
    }
    let root = level[0].expect("at least one light");
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
