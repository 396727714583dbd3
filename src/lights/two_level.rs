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
//! child, right = left + 1, `parent` and `leaf_of_light` for pmf queries;
//! the top level in the first slots, then one block per group, so that a
//! GPU can gather the bottom levels in place every frame: [`GpuPlan`])
//! and sampled by the same code on the CPU and in WGSL, with cones (merged
//! in the same pairwise order as the intensities) and cuts. Bogus leaves of
//! the bottom levels are dropped: a node with one non-empty child is that
//! child (its node, bounds, intensity and cone are the child's exactly), so
//! over one group the pmfs are the perfect tree's (`tree_cone` without a
//! cut), and over one light per group the SAOH BVH's (`unbalanced`).
//!
//! A sequence of frames sorts each group once ([`BottomLevels`]): a
//! bottom level's shape depends only on its leaf order, which for lights
//! that keep their arrangement (static, or a mesh under rigid motion) is
//! sorted once in object space; each frame gathers the nodes again over
//! the frame's lights in that order.

use super::bvh::{self, Cost, LightBvh, INTERNAL_BIT, MAX_DEPTH};
use super::tree::cut::LightTree;
use super::tree::perfect::{self, gather, leaf_node};
use super::{LightCone, LightPrim, TreeNode, NO_LIGHT};
use glam::Vec3;
use std::collections::HashMap;
use std::ops::Range;

/// The GPU build of `tree2` from the plan.
pub mod gpu;
mod plan;
pub use plan::*;

/// A node of the tree under construction.
#[derive(Clone, Copy, Debug)]
struct Temp {
    node: TreeNode,
    cone: LightCone,
    children: Option<(usize, usize)>,
}

/// Builds the two-level tree over `prims` with the groups `groups`: ranges
/// of light ids that partition `0..prims.len()` in order (empty ranges are
/// allowed and skipped). `None` for zero lights. Every group is sorted
/// here; a sequence of frames sorts its groups once with
/// [`BottomLevels`].
///
/// # Panics
///
/// When `groups` do not partition the ids in order.
pub fn build(prims: &[LightPrim], groups: &[Range<u32>]) -> Option<LightBvh> {
    check_partition(groups, prims.len());
    let orders: Vec<Vec<Slot>> = groups
        .iter()
        .map(|g| sorted_order(&prims[g.start as usize..g.end as usize]))
        .collect();
    assemble(prims, groups, |i, g, arena| {
        place(&orders[i], prims, g.start, arena)
    })
}

/// Asserts that `groups` partition the ids `0..n` in order.
fn check_partition(groups: &[Range<u32>], n: usize) {
    let mut next = 0u32;
    for g in groups {
        assert!(
            g.start == next && g.end >= g.start,
            "groups must partition the light ids in order: {groups:?}"
        );
        next = g.end;
    }
    assert_eq!(next as usize, n, "groups must cover all {n} lights");
}

/// One node of a bottom level's shape, in post order (children before
/// their parent, the root last).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Slot {
    /// The light with this id within its group.
    Leaf(u32),
    /// The parent of the slots at these positions of the same list.
    Join(u32, u32),
}

/// The shape of the perfect tree over `lights` sorted by (Morton code over
/// their own bounds, id): [`perfect_order`] of [`perfect::sort_lights`].
fn sorted_order(lights: &[LightPrim]) -> Vec<Slot> {
    perfect_order(&perfect::sort_lights(lights))
}

/// The shape of the perfect tree over a group's lights in the leaf order
/// `sorted` with its bogus parts dropped: a node whose right half holds
/// only bogus leaves is its left child (the left half of a node with any
/// real leaf always has one). Post order, so [`place`] can gather each
/// node from its children as it goes.
fn perfect_order(sorted: &[u32]) -> Vec<Slot> {
    fn visit(sorted: &[u32], first: usize, size: usize, out: &mut Vec<Slot>) -> u32 {
        if size == 1 {
            out.push(Slot::Leaf(sorted[first]));
            return out.len() as u32 - 1;
        }
        let half = size / 2;
        let left = visit(sorted, first, half, out);
        if first + half >= sorted.len() {
            return left;
        }
        let right = visit(sorted, first + half, half, out);
        out.push(Slot::Join(left, right));
        out.len() as u32 - 1
    }
    let mut out = Vec::with_capacity((2 * sorted.len()).saturating_sub(1));
    if !sorted.is_empty() {
        visit(sorted, 0, sorted.len().next_power_of_two(), &mut out);
    }
    out
}

/// Adds the bottom level of shape `order` over the lights `base + id` of
/// `prims` to `arena` and returns its root: leaves from the lights
/// (bounds, intensity, cone), every other node gathered from its children
/// (bounds, intensity sum, cone union in the same pairwise order). Equal,
/// field for field, to the perfect tree's nodes over the same leaf order
/// ([`perfect::build_sorted`]): a bogus leaf adds nothing to a gather
/// (empty bounds, 0 intensity, empty cone), so a node with one real child
/// is that child.
fn place(order: &[Slot], prims: &[LightPrim], base: u32, arena: &mut Vec<Temp>) -> usize {
    let offset = arena.len();
    for slot in order {
        let temp = match *slot {
            Slot::Leaf(id) => {
                let prim = &prims[(base + id) as usize];
                Temp {
                    node: leaf_node(prim, base + id),
                    cone: LightCone::of_prim(prim),
                    children: None,
                }
            }
            Slot::Join(l, r) => {
                let (l, r) = (offset + l as usize, offset + r as usize);
                Temp {
                    node: gather(&arena[l].node, &arena[r].node),
                    cone: arena[l].cone.union(&arena[r].cone),
                    children: Some((l, r)),
                }
            }
        };
        arena.push(temp);
    }
    arena.len() - 1
}

/// Adds a copy of the bottom level `placed` (placed over lights with ids
/// from 0 into an empty arena) for the lights `base + id` to `arena` and
/// returns its root: the nodes of [`place`] over equal lights, without
/// gathering them again.
fn copy_placed(placed: &[Temp], base: u32, arena: &mut Vec<Temp>) -> usize {
    let offset = arena.len();
    arena.extend(placed.iter().map(|t| match t.children {
        Some((l, r)) => Temp {
            children: Some((l + offset, r + offset)),
            ..*t
        },
        None => Temp {
            node: TreeNode {
                id: t.node.id + base,
                ..t.node
            },
            ..*t
        },
    }));
    arena.len() - 1
}

/// The two-level tree over `prims` with the partition `groups` (checked
/// by the caller); `place_group(i, group, arena)` adds non-empty group
/// `i`'s bottom level to `arena` and returns its root.
fn assemble(
    prims: &[LightPrim],
    groups: &[Range<u32>],
    mut place_group: impl FnMut(usize, &Range<u32>, &mut Vec<Temp>) -> usize,
) -> Option<LightBvh> {
    let n = prims.len();
    if n == 0 {
        return None;
    }
    assert!(n < INTERNAL_BIT as usize, "at most 2^31 − 1 lights");
    let mut arena: Vec<Temp> = Vec::with_capacity(2 * n);

    // Bottom levels: one perfect tree per non-empty group.
    let roots: Vec<usize> = groups
        .iter()
        .enumerate()
        .filter(|(_, g)| !g.is_empty())
        .map(|(i, g)| place_group(i, g, &mut arena))
        .collect();

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
    Some(flatten(&arena, root, &roots, n))
}

/// The part of `tree2` that a sequence of frames shares (the paper's
/// bottom levels that "remain constant", §4, and the instancing that two
/// levels allow, §3.1): the leaf order of every group whose lights keep
/// their arrangement from frame to frame — static lights, and a mesh's
/// triangles under its rigid keyframe motion, which moves them all by one
/// rotation and translation — sorted once, by Morton codes over the
/// group's *object-space* lights. Each frame ([`BottomLevels::tree`])
/// gathers those bottom levels again over the frame's lights in the fixed
/// order (bounds, intensities and cones exact for the frame; no Morton
/// codes, no sort) — or, for a group whose lights are exactly its
/// object-space lights (it did not move), copies the bottom level placed
/// once — and builds the top level. Groups whose lights move
/// independently (orbiting light sets, the VPLs) are sorted every frame,
/// as [`build`] sorts all of them.
///
/// The order comes from the object space, not from any one frame, so
/// frame `f` of a sequence is the same tree whichever frame the sequence
/// started at. Groups with equal object-space lights (a mesh light placed
/// at several transforms) share one sorted order. For lights that do not
/// move, the tree equals [`build`]'s bit for bit.
#[derive(Clone, Debug)]
pub struct BottomLevels {
    groups: Vec<Range<u32>>,
    /// Per group, the index in `shapes` of its fixed shape; `None`: sorted
    /// every frame.
    shape: Vec<Option<usize>>,
    shapes: Vec<Shape>,
}

/// One distinct object-space arrangement of a group's lights.
#[derive(Clone, Debug)]
struct Shape {
    /// The lights in object space, in id order.
    object: Vec<LightPrim>,
    /// Their bottom level's shape, sorted once.
    order: Vec<Slot>,
    /// That bottom level placed over `object` (light ids and children
    /// from 0): a frame whose lights equal `object` (they did not move)
    /// copies it instead of gathering it again.
    placed: Vec<Temp>,
}

impl BottomLevels {
    /// The bottom levels of the groups `groups` (a partition of the ids
    /// `0..n` in order, as [`build`] takes); `object[i]`: group `i`'s
    /// lights in object space, in id order (`Some` for a group whose
    /// lights keep their arrangement), or `None` (sorted every frame).
    ///
    /// # Panics
    ///
    /// When `groups` do not partition `0..n` in order, or an object-space
    /// list's length differs from its group's.
    pub fn new(groups: Vec<Range<u32>>, object: &[Option<&[LightPrim]>]) -> BottomLevels {
        let n = groups.last().map_or(0, |g| g.end) as usize;
        check_partition(&groups, n);
        assert_eq!(
            groups.len(),
            object.len(),
            "one object-space list per group"
        );
        let mut shapes: Vec<Shape> = Vec::new();
        let mut seen: HashMap<&[u8], usize> = HashMap::new();
        let shape = groups
            .iter()
            .zip(object)
            .map(|(g, lights)| {
                let lights = (*lights)?;
                assert_eq!(lights.len(), g.len(), "group {g:?}'s object-space lights");
                Some(*seen.entry(bytes(lights)).or_insert_with(|| {
                    let order = sorted_order(lights);
                    let mut placed = Vec::with_capacity(order.len());
                    if !lights.is_empty() {
                        place(&order, lights, 0, &mut placed);
                    }
                    shapes.push(Shape {
                        object: lights.to_vec(),
                        order,
                        placed,
                    });
                    shapes.len() - 1
                }))
            })
            .collect();
        BottomLevels {
            groups,
            shape,
            shapes,
        }
    }

    /// The number of lights the groups cover.
    pub fn light_count(&self) -> usize {
        self.groups.last().map_or(0, |g| g.end) as usize
    }

    /// The number of sorted orders kept: one per distinct object-space
    /// shape (the groups sorted every frame have none).
    pub fn shared_orders(&self) -> usize {
        self.shapes.len()
    }

    /// The two-level tree over one frame's lights: the groups' lights
    /// first (where the frame puts them), then any further lights (the
    /// frame's VPLs) as one more group, sorted every frame. `None` for
    /// zero lights.
    ///
    /// # Panics
    ///
    /// When `prims` has fewer lights than the groups cover.
    pub fn tree(&self, prims: &[LightPrim]) -> Option<LightBvh> {
        let covered = self.light_count();
        assert!(
            prims.len() >= covered,
            "{} lights for groups covering {covered}",
            prims.len()
        );
        let mut groups = self.groups.clone();
        if prims.len() > covered {
            groups.push(covered as u32..prims.len() as u32);
        }
        assemble(prims, &groups, |i, g, arena| {
            let lights = &prims[g.start as usize..g.end as usize];
            match self
                .shape
                .get(i)
                .copied()
                .flatten()
                .map(|s| &self.shapes[s])
            {
                // Equal bytes (not floats: −0 and 0 bound differently).
                Some(shape) if bytes(&shape.object) == bytes(lights) => {
                    copy_placed(&shape.placed, g.start, arena)
                }
                Some(shape) => place(&shape.order, prims, g.start, arena),
                None => place(&sorted_order(lights), prims, g.start, arena),
            }
        })
    }
}

/// The bytes of `lights`.
fn bytes(lights: &[LightPrim]) -> &[u8] {
    bytemuck::cast_slice(lights)
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

/// The layout of the tree at `root` whose bottom levels are rooted at
/// `roots` (arena nodes, in group order): the top level first, breadth
/// first from node 0 (the root) down to the group roots, then each group's
/// bottom level without its root, in group order, breadth first within
/// the group, children in pairs after their parent throughout. A group's
/// nodes below its root sit at slots that depend only on the group sizes,
/// not on the top level (the GPU gathers them there every frame,
/// [`GpuPlan`]). Two passes: the breadth-first walk over the children
/// alone (8 bytes a node, so the walk's scattered reads stay in cache)
/// gives every arena node its slot, then the arena is read in its own
/// order and each node written to its slot.
fn flatten(arena: &[Temp], root: usize, roots: &[usize], n: usize) -> LightBvh {
    const LEAF: (u32, u32) = (u32::MAX, u32::MAX);
    let total = 2 * n - 1;
    let kids: Vec<(u32, u32)> = arena
        .iter()
        .map(|t| t.children.map_or(LEAF, |(l, r)| (l as u32, r as u32)))
        .collect();
    let mut is_root = vec![false; arena.len()];
    for &r in roots {
        is_root[r] = true;
    }
    // Pass 1: slots, parents and depths. `order[k]` is the arena node of
    // slot k; the queue is `order` itself (slots are handed out in the
    // order nodes are reached). The top level's walk stops at the group
    // roots; each group's walk then starts from its root's children.
    let mut order = Vec::with_capacity(total);
    let mut slot_of = vec![u32::MAX; arena.len()];
    let mut parent = vec![NO_LIGHT; total];
    let mut depth_of = vec![1u32; total];
    let mut left_of = vec![0u32; total];
    // Gives the children of the node at `slot` the next two slots.
    let mut expand = |slot: usize, order: &mut Vec<u32>, slot_of: &mut [u32]| {
        let (l, r) = kids[order[slot] as usize];
        if (l, r) == LEAF {
            return;
        }
        let left = order.len();
        left_of[slot] = left as u32;
        for (child, at) in [(l, left), (r, left + 1)] {
            slot_of[child as usize] = at as u32;
            parent[at] = slot as u32;
            depth_of[at] = depth_of[slot] + 1;
            order.push(child);
        }
    };
    order.push(root as u32);
    slot_of[root] = 0;
    let mut next = 0;
    while next < order.len() {
        if !is_root[order[next] as usize] {
            expand(next, &mut order, &mut slot_of);
        }
        next += 1;
    }
    for &r in roots {
        expand(slot_of[r] as usize, &mut order, &mut slot_of);
        while next < order.len() {
            expand(next, &mut order, &mut slot_of);
            next += 1;
        }
    }
    assert_eq!(order.len(), total, "a full binary tree over {n} leaves");
    let depth = depth_of.iter().copied().max().unwrap_or(1);
    assert!(depth <= MAX_DEPTH, "two-level tree depth {depth}");
    // Pass 2: the nodes, in arena order.
    let mut nodes = vec![TreeNode::EMPTY; total];
    let mut cones = vec![LightCone::EMPTY; total];
    let mut leaf_of_light = vec![NO_LIGHT; n];
    for (t, temp) in arena.iter().enumerate() {
        let slot = slot_of[t];
        if slot == u32::MAX {
            continue; // not below the root
        }
        let slot = slot as usize;
        cones[slot] = temp.cone;
        nodes[slot] = match temp.children {
            None => {
                leaf_of_light[temp.node.id as usize] = slot as u32;
                temp.node
            }
            Some(_) => TreeNode {
                id: INTERNAL_BIT | left_of[slot],
                ..temp.node
            },
        };
    }
    LightBvh {
        nodes,
        parent,
        leaf_of_light,
        depth,
        cones,
    }
}

#[cfg(test)]
mod tests;
