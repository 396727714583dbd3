//! Unit tests of `two_level`.

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
