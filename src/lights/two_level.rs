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
use super::cut::LightTree;
use super::perfect::{self, gather, leaf_node};
use super::{LightCone, LightPrim, TreeNode, NO_LIGHT};
use glam::Vec3;
use std::collections::HashMap;
use std::ops::Range;

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

/// A destination of [`GpuPlan`] with this bit set is group root `d & !ROOT_BIT`
/// (the roots are read back for the top level), else a node slot.
pub const ROOT_BIT: u32 = 0x8000_0000;

/// One non-empty group of a [`GpuPlan`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PlanGroup {
    /// The slot of its root's left child (the right one is next), or
    /// `None` for a group of one light, whose root is its leaf.
    pub root_left: Option<u32>,
    /// The light of a one-light group (unused otherwise).
    pub lone_light: u32,
}

/// The fixed part of a sequence's two-level tree, for a GPU to gather
/// every frame ([`super::gpu_two_level`]): [`flatten`] puts every bottom
/// level below its root at slots that depend only on the group sizes, and
/// a group whose leaf order is fixed ([`BottomLevels`]) has a fixed shape,
/// so for a frame's lights a GPU can write those nodes with no sort and no
/// host in between — the leaves from the lights, then each height's joins
/// from the one below — and the host builds only the top level, over the
/// groups' roots (read back: a few dozen nodes), as [`BottomLevels::tree`]
/// builds it. [`GpuPlan::tree_on_cpu`] runs the plan on the CPU and equals
/// [`BottomLevels::tree`] bit for bit.
#[derive(Clone, Debug)]
pub struct GpuPlan {
    /// Slots of the top level, `2G − 1` over the `G` non-empty groups.
    pub top_slots: u32,
    /// `2N − 1` nodes over `N` lights.
    pub node_count: u32,
    /// (destination, light id): every bottom level's leaves.
    pub leaves: Vec<[u32; 2]>,
    /// `joins[h − 1]`: (destination, left child's slot) of the bottom
    /// levels' nodes of height `h` (leaves have height 0).
    pub joins: Vec<Vec<[u32; 2]>>,
    /// The non-empty groups, in order.
    pub groups: Vec<PlanGroup>,
    /// The leaf slot of every light; a one-light group's is set per frame.
    pub leaf_of_light: Vec<u32>,
    /// The parent of every slot; the top level's slots and the children of
    /// the groups' roots are set per frame.
    pub parent: Vec<u32>,
    /// Levels of the deepest bottom level ([`top_sah_depth`]).
    bottom_levels: u32,
}

/// The top level of one frame ([`GpuPlan::top`]): slots `0..top_slots`.
#[derive(Clone, Debug, PartialEq)]
pub struct TopLevel {
    pub nodes: Vec<TreeNode>,
    pub cones: Vec<LightCone>,
    pub parent: Vec<u32>,
    /// The slot of each group's root.
    pub root_slot: Vec<u32>,
}

impl BottomLevels {
    /// The plan of a GPU gather of these bottom levels, or `None` when a
    /// group is sorted every frame (an orbiting light set) or there are no
    /// lights. Lights beyond the groups (VPLs) are not in it: with them,
    /// [`BottomLevels::tree`] is the way.
    pub fn gpu_plan(&self) -> Option<GpuPlan> {
        let n = self.light_count();
        if n == 0 {
            return None;
        }
        let groups: Vec<(&Range<u32>, &Shape)> = self
            .groups
            .iter()
            .zip(&self.shape)
            .filter(|(g, _)| !g.is_empty())
            .map(|(g, s)| Some((g, &self.shapes[(*s)?])))
            .collect::<Option<_>>()?;
        let top_slots = 2 * groups.len() as u32 - 1;
        let node_count = 2 * n as u32 - 1;
        let mut plan = GpuPlan {
            top_slots,
            node_count,
            leaves: Vec::with_capacity(n),
            joins: Vec::new(),
            groups: Vec::with_capacity(groups.len()),
            leaf_of_light: vec![NO_LIGHT; n],
            parent: vec![NO_LIGHT; node_count as usize],
            bottom_levels: 1,
        };
        let mut base = top_slots;
        for (k, (g, shape)) in groups.into_iter().enumerate() {
            let order = &shape.order;
            plan.bottom_levels = plan.bottom_levels.max(perfect_levels(g.len()));
            // Breadth-first positions within the group, as `flatten` walks.
            let root = order.len() - 1;
            let mut bfs = vec![0u32; order.len()];
            let mut queue = vec![root];
            let mut q = 0;
            while q < queue.len() {
                if let Slot::Join(l, r) = order[queue[q]] {
                    for c in [l, r] {
                        bfs[c as usize] = queue.len() as u32;
                        queue.push(c as usize);
                    }
                }
                q += 1;
            }
            let dest = |s: usize| {
                if s == root {
                    ROOT_BIT | k as u32
                } else {
                    base + bfs[s] - 1
                }
            };
            let mut height = vec![0usize; order.len()];
            for (s, slot) in order.iter().enumerate() {
                match *slot {
                    Slot::Leaf(id) => {
                        let light = g.start + id;
                        plan.leaves.push([dest(s), light]);
                        if s != root {
                            plan.leaf_of_light[light as usize] = dest(s);
                        }
                    }
                    Slot::Join(l, r) => {
                        let (l, r) = (l as usize, r as usize);
                        debug_assert_eq!(dest(r), dest(l) + 1, "siblings in pairs");
                        height[s] = 1 + height[l].max(height[r]);
                        if plan.joins.len() < height[s] {
                            plan.joins.resize(height[s], Vec::new());
                        }
                        plan.joins[height[s] - 1].push([dest(s), dest(l)]);
                        if s != root {
                            plan.parent[dest(l) as usize] = dest(s);
                            plan.parent[dest(r) as usize] = dest(s);
                        }
                    }
                }
            }
            plan.groups.push(match order[root] {
                Slot::Join(l, _) => PlanGroup {
                    root_left: Some(dest(l as usize)),
                    lone_light: NO_LIGHT,
                },
                Slot::Leaf(id) => PlanGroup {
                    root_left: None,
                    lone_light: g.start + id,
                },
            });
            base += 2 * g.len() as u32 - 2;
        }
        debug_assert_eq!(base, node_count);
        Some(plan)
    }
}

impl GpuPlan {
    /// The top level over the groups' roots `roots` (nodes as the gather
    /// writes them: an internal root's id is `INTERNAL_BIT |` its left
    /// child, a lone leaf's its light) and their cones: the SAOH BVH of
    /// [`build`], laid out breadth first from slot 0.
    ///
    /// # Panics
    ///
    /// When `roots` or `cones` do not hold one entry per group.
    pub fn top(&self, roots: &[TreeNode], cones: &[LightCone]) -> TopLevel {
        let g = self.groups.len();
        assert!(roots.len() == g && cones.len() == g, "one root per group");
        let mut arena: Vec<Temp> = roots
            .iter()
            .zip(cones)
            .map(|(&node, &cone)| Temp {
                node,
                cone,
                children: None,
            })
            .collect();
        let leaves: Vec<TreeNode> = roots
            .iter()
            .enumerate()
            .map(|(i, r)| TreeNode { id: i as u32, ..*r })
            .collect();
        let centre: Vec<Vec3> = roots
            .iter()
            .map(|b| 0.5 * (Vec3::from(b.min) + Vec3::from(b.max)))
            .collect();
        let top = bvh::build_over(
            &leaves,
            cones,
            &centre,
            Cost::Saoh,
            top_sah_depth(self.bottom_levels),
        );
        let ids: Vec<usize> = (0..g).collect();
        let root = graft(&top, 0, &ids, &mut arena);
        let t = self.top_slots as usize;
        let mut out = TopLevel {
            nodes: vec![TreeNode::EMPTY; t],
            cones: vec![LightCone::EMPTY; t],
            parent: vec![NO_LIGHT; t],
            root_slot: vec![0; g],
        };
        let mut order = vec![root];
        let mut q = 0;
        while q < order.len() {
            let temp = arena[order[q]];
            out.cones[q] = temp.cone;
            out.nodes[q] = temp.node;
            if let Some((l, r)) = temp.children {
                out.nodes[q].id = INTERNAL_BIT | order.len() as u32;
                for c in [l, r] {
                    out.parent[order.len()] = q as u32;
                    order.push(c);
                }
            } else {
                out.root_slot[order[q]] = q as u32;
            }
            q += 1;
        }
        assert_eq!(order.len(), t, "a full binary tree over {g} roots");
        out
    }

    /// The entries of the table `leaf_of_light ++ parent` (`N + 2N − 1`
    /// entries, as the samplers bind it) that frame `top` sets, as
    /// (position, value): the top level's parents and, below each group's
    /// root, the links to where the top level put it. The rest of the
    /// table is the plan's `leaf_of_light` and `parent`.
    pub fn links<'a>(&'a self, top: &'a TopLevel) -> impl Iterator<Item = (usize, u32)> + 'a {
        let n = self.leaf_of_light.len();
        let parents = top.parent.iter().enumerate().map(move |(s, &p)| (n + s, p));
        let below = self
            .groups
            .iter()
            .zip(&top.root_slot)
            .flat_map(move |(group, &slot)| {
                let (first, second) = match group.root_left {
                    Some(l) => ((n + l as usize, slot), Some((n + l as usize + 1, slot))),
                    None => ((group.lone_light as usize, slot), None),
                };
                std::iter::once(first).chain(second)
            });
        parents.chain(below)
    }

    /// The plan run on the CPU over one frame's lights: the leaves, each
    /// height's joins, then [`GpuPlan::top`] and [`GpuPlan::links`] — the
    /// oracle of the GPU gather, and equal to [`BottomLevels::tree`] bit
    /// for bit.
    pub fn tree_on_cpu(&self, prims: &[LightPrim]) -> LightBvh {
        let total = self.node_count as usize;
        let g = self.groups.len();
        let mut nodes = vec![TreeNode::EMPTY; total];
        let mut cones = vec![LightCone::EMPTY; total];
        let mut roots = vec![TreeNode::EMPTY; g];
        let mut root_cones = vec![LightCone::EMPTY; g];
        let mut store = |dest: u32,
                         node: TreeNode,
                         cone: LightCone,
                         nodes: &mut [TreeNode],
                         cones: &mut [LightCone]| {
            if dest & ROOT_BIT != 0 {
                roots[(dest & !ROOT_BIT) as usize] = node;
                root_cones[(dest & !ROOT_BIT) as usize] = cone;
            } else {
                nodes[dest as usize] = node;
                cones[dest as usize] = cone;
            }
        };
        for &[dest, light] in &self.leaves {
            let prim = &prims[light as usize];
            store(
                dest,
                leaf_node(prim, light),
                LightCone::of_prim(prim),
                &mut nodes,
                &mut cones,
            );
        }
        for level in &self.joins {
            for &[dest, l] in level {
                let (l, r) = (l as usize, l as usize + 1);
                let node = TreeNode {
                    id: INTERNAL_BIT | l as u32,
                    ..gather(&nodes[l], &nodes[r])
                };
                let cone = cones[l].union(&cones[r]);
                store(dest, node, cone, &mut nodes, &mut cones);
            }
        }
        let top = self.top(&roots, &root_cones);
        nodes[..top.nodes.len()].copy_from_slice(&top.nodes);
        cones[..top.cones.len()].copy_from_slice(&top.cones);
        let mut table: Vec<u32> = self
            .leaf_of_light
            .iter()
            .chain(&self.parent)
            .copied()
            .collect();
        for (at, value) in self.links(&top) {
            table[at] = value;
        }
        let parent = table.split_off(self.leaf_of_light.len());
        let leaf_of_light = table;
        let mut depth_of = vec![1u32; total];
        for s in 1..total {
            depth_of[s] = depth_of[parent[s] as usize] + 1;
        }
        LightBvh {
            nodes,
            parent,
            leaf_of_light,
            depth: depth_of.into_iter().max().unwrap_or(1),
            cones,
        }
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

    /// The breadth-first layout as first written (one pass, a queue of
    /// arena nodes), the oracle of [`flatten`]'s two passes.
    fn flatten_reference(arena: &[Temp], root: usize, n: usize) -> LightBvh {
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

    /// The tree below `node` of `bvh` in pre-order, as (node with its
    /// child link dropped, cone, leaf light or `NO_LIGHT`): equal for two
    /// layouts of one tree.
    fn preorder(bvh: &LightBvh, node: usize, out: &mut Vec<(TreeNode, LightCone, u32)>) {
        let n = bvh.nodes[node];
        if n.id & INTERNAL_BIT == 0 {
            out.push((n, bvh.cones[node], n.id));
            return;
        }
        out.push((TreeNode { id: 0, ..n }, bvh.cones[node], NO_LIGHT));
        let l = (n.id & !INTERNAL_BIT) as usize;
        for c in [l, l + 1] {
            assert_eq!(bvh.parent[c] as usize, node, "parent of {c}");
            preorder(bvh, c, out);
        }
    }

    /// The slots of the tree below `node`, `node` excluded.
    fn slots_below(bvh: &LightBvh, node: usize, out: &mut Vec<usize>) {
        let id = bvh.nodes[node].id;
        if id & INTERNAL_BIT != 0 {
            let l = (id & !INTERNAL_BIT) as usize;
            for c in [l, l + 1] {
                out.push(c);
                slots_below(bvh, c, out);
            }
        }
    }

    /// Bottom levels of 1 to 300 random lights (some of one light),
    /// chained under joins into trees of very uneven depth.
    fn chained_groups(groups: usize, seed: u64) -> (Vec<LightPrim>, Vec<Temp>, usize, Vec<usize>) {
        use rand::rngs::StdRng;
        use rand::{RngExt, SeedableRng};
        let mut rng = StdRng::seed_from_u64(seed);
        let mut prims = Vec::new();
        let mut arena = Vec::new();
        let mut root = None;
        let mut roots = Vec::new();
        for k in 0..groups {
            let base = prims.len() as u32;
            let count = if k % 4 == 3 {
                1
            } else {
                rng.random_range(1..300)
            };
            for _ in 0..count {
                let p = Vec3::new(rng.random(), rng.random(), rng.random()) * 10.0;
                prims.push(LightPrim::triangle(p, p + Vec3::X, p + Vec3::Y, Vec3::ONE));
            }
            let lights = &prims[base as usize..];
            let r = place(&sorted_order(lights), &prims, base, &mut arena);
            roots.push(r);
            root = join(root, Some(r), &mut arena);
        }
        (prims, arena, root.unwrap(), roots)
    }

    /// [`flatten`] lays out the same tree as the one-pass breadth-first
    /// walk (same nodes, cones and leaves in pre-order, parents and
    /// `leaf_of_light` consistent), with the top level in the first
    /// `2G − 1` slots and each group's nodes below its root in one block
    /// per group, in group order, of `2·n_g − 2` slots.
    #[test]
    fn flatten_lays_out_the_tree_with_one_block_per_group() {
        for (groups, seed) in [(1usize, 47), (2, 48), (5, 49), (9, 50)] {
            let (prims, arena, root, roots) = chained_groups(groups, seed);
            let n = prims.len();
            let ours = flatten(&arena, root, &roots, n);
            let reference = flatten_reference(&arena, root, n);
            let (mut a, mut b) = (Vec::new(), Vec::new());
            preorder(&ours, 0, &mut a);
            preorder(&reference, 0, &mut b);
            assert_eq!(a, b, "{groups} groups");
            assert_eq!(ours.depth, reference.depth);
            assert_eq!(ours.parent[0], NO_LIGHT);
            for (light, &slot) in ours.leaf_of_light.iter().enumerate() {
                assert_eq!(ours.nodes[slot as usize].id, light as u32);
            }
            // Find each group's root slot: the top level is the first
            // 2G − 1 slots in breadth-first order.
            let top = 2 * groups - 1;
            let mut base = top;
            let mut start = 0usize;
            for &r in &roots {
                let size = arena_leaves(&arena, r);
                let light = arena_first_leaf(&arena, r) as usize;
                // The group's root: the ancestor of its first light's leaf
                // that is a top slot.
                let mut slot = ours.leaf_of_light[light] as usize;
                while slot >= top {
                    slot = ours.parent[slot] as usize;
                }
                let mut below = Vec::new();
                slots_below(&ours, slot, &mut below);
                below.sort_unstable();
                let expected: Vec<usize> = (base..base + 2 * size - 2).collect();
                assert_eq!(below, expected, "group at {start}, {groups} groups");
                base += 2 * size - 2;
                start += size;
            }
            assert_eq!(base, 2 * n - 1);
        }
    }

    fn arena_leaves(arena: &[Temp], t: usize) -> usize {
        match arena[t].children {
            None => 1,
            Some((l, r)) => arena_leaves(arena, l) + arena_leaves(arena, r),
        }
    }

    fn arena_first_leaf(arena: &[Temp], t: usize) -> u32 {
        match arena[t].children {
            None => arena[t].node.id,
            Some((l, _)) => arena_first_leaf(arena, l),
        }
    }

    /// The GPU plan run on the CPU builds [`BottomLevels::tree`]'s tree
    /// bit for bit: groups of one to 300 lights (empty groups between
    /// them), at their object-space positions (the copied bottom levels)
    /// and after a rigid move of every other group (gathered again).
    #[test]
    fn gpu_plan_on_the_cpu_equals_the_bottom_levels_tree() {
        use rand::rngs::StdRng;
        use rand::{RngExt, SeedableRng};
        let mut rng = StdRng::seed_from_u64(61);
        for groups in [1usize, 2, 3, 7, 12] {
            let mut object = Vec::new();
            let mut ranges = Vec::new();
            for k in 0..groups {
                let count = match k % 5 {
                    1 => 1,
                    3 => 0,
                    _ => rng.random_range(2..300),
                };
                let start = object.len() as u32;
                let centre = Vec3::new(rng.random(), rng.random(), rng.random()) * 20.0;
                for _ in 0..count {
                    let p = centre + Vec3::new(rng.random(), rng.random(), rng.random());
                    let e = Vec3::splat(rng.random_range(0.1..4.0));
                    let q = p + Vec3::new(rng.random(), rng.random(), 0.3);
                    prims_push(
                        &mut object,
                        p,
                        q,
                        p + Vec3::new(0.2, rng.random(), rng.random()),
                        e,
                    );
                }
                ranges.push(start..object.len() as u32);
            }
            let lists: Vec<Option<&[LightPrim]>> = ranges
                .iter()
                .map(|g| Some(&object[g.start as usize..g.end as usize]))
                .collect();
            let bottoms = BottomLevels::new(ranges.clone(), &lists);
            let plan = bottoms.gpu_plan().expect("every group keeps its shape");
            assert_eq!(
                plan.tree_on_cpu(&object),
                bottoms.tree(&object).unwrap(),
                "{groups} groups at rest"
            );
            // Every other group turned and moved rigidly.
            let rot = glam::Quat::from_axis_angle(Vec3::new(1.0, 2.0, 0.5).normalize(), 0.7);
            let mut frame = object.clone();
            for (k, g) in ranges.iter().enumerate() {
                if k % 2 == 0 {
                    for l in &mut frame[g.start as usize..g.end as usize] {
                        for v in [&mut l.p0, &mut l.p1, &mut l.p2] {
                            *v = (rot * Vec3::from(*v) + Vec3::new(3.0, -1.0, 2.0)).into();
                        }
                    }
                }
            }
            assert_eq!(
                plan.tree_on_cpu(&frame),
                bottoms.tree(&frame).unwrap(),
                "{groups} groups moved"
            );
        }
    }

    fn prims_push(out: &mut Vec<LightPrim>, a: Vec3, b: Vec3, c: Vec3, e: Vec3) {
        out.push(LightPrim::triangle(a, b, c, e));
    }

    /// No plan where a group is sorted every frame.
    #[test]
    fn gpu_plan_needs_every_group_fixed() {
        let lights: Vec<LightPrim> = (0..4)
            .map(|i| LightPrim::point(Vec3::splat(i as f32), Vec3::ONE))
            .collect();
        let fixed = BottomLevels::new(vec![0..2, 2..4], &[Some(&lights[..2]), Some(&lights[2..])]);
        assert!(fixed.gpu_plan().is_some());
        let orbiting = BottomLevels::new(vec![0..2, 2..4], &[Some(&lights[..2]), None]);
        assert!(orbiting.gpu_plan().is_none());
    }
}
