//! The GPU plan of `tree2`: what the GPU build needs to place each
//! group's bottom level and graft the top level, derived from the CPU
//! build's shapes.

use super::*;

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
/// every frame ([`super::gpu`]): [`flatten`] puts every bottom
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
