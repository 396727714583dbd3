//! The two-level tree (`tree2`): invariants, groups, moved and instanced bottom levels.

use super::*;

/// The light ids of the leaves below `node` of a light BVH, left to
/// right.
pub(crate) fn lights_below(t: &LightBvh, node: usize) -> Vec<u32> {
    let mut out = Vec::new();
    let mut stack = vec![node];
    while let Some(x) = stack.pop() {
        match t.children(x) {
            Some((l, r)) => stack.extend([r, l]),
            None => out.push(t.nodes[x].id),
        }
    }
    out
}

/// The two-level tree (`tree2`) is a valid light BVH whatever the groups
/// (one, many, singletons, empty ones), deterministic, with cones bounding
/// every light below; and each group's lights fill one subtree: the
/// lowest common ancestor of a group's leaves has exactly that group's
/// lights below it.
#[test]
fn two_level_tree_invariants_and_groups_stay_together() {
    assert!(two_level::build(&[], &[]).is_none());
    assert!(two_level::build(&[], &[0..0, 0..0]).is_none());
    let mut rng = StdRng::seed_from_u64(17);
    for n in [1usize, 2, 3, 7, 300, 1000] {
        let mut prims = random_triangles(&mut rng, n);
        prims.extend(random_scene(&mut rng, n / 3));
        let n = prims.len();
        let singletons: Vec<_> = (0..n as u32).map(|i| i..i + 1).collect();
        for groups in [
            chunks(n, 1),
            chunks(n, 2),
            chunks(n, 5),
            chunks(n, 9),
            singletons,
        ] {
            let what = format!("{n} lights, {} groups", groups.len());
            let t = two_level::build(&prims, &groups).unwrap();
            check_bvh(&prims, &t);
            check_cones_bound_their_lights(&prims, &t, &what);
            assert_eq!(two_level::build(&prims, &groups).unwrap(), t, "{what}");
            let below = |node: usize| lights_below(&t, node);
            // `depth` is the longest root-to-leaf path, in nodes.
            let longest = (0..n as u32)
                .map(|i| {
                    let mut node = t.leaf_of_light(i);
                    let mut d = 0;
                    while let Some(x) = node {
                        d += 1;
                        node = t.parent(x);
                    }
                    d
                })
                .max()
                .unwrap();
            assert_eq!(t.depth, longest, "{what}");
            for g in groups.iter().filter(|g| !g.is_empty()) {
                // Walk up from the group's first leaf until the subtree
                // holds all of the group.
                let mut node = t.leaf_of_light(g.start).unwrap();
                while below(node).len() < g.len() {
                    node = t.parent(node).unwrap();
                }
                let mut ids = below(node);
                ids.sort_unstable();
                assert_eq!(ids, g.clone().collect::<Vec<_>>(), "{what}: group {g:?}");
            }
        }
    }
}

/// The top level is the SAOH BVH over the groups' roots: with one point
/// light per group (a root's box is its light's point, its centre the
/// light's centroid) the two-level tree samples exactly like the
/// `unbalanced` SAOH BVH over the lights — every light's pmf equal bit for
/// bit at random shading points (the same splits, nodes, cones and
/// decisions, only stored in another order).
#[test]
fn tree2_over_singleton_groups_samples_like_the_saoh_bvh() {
    let mut rng = StdRng::seed_from_u64(29);
    for n in [1usize, 2, 3, 17, 200] {
        let prims: Vec<LightPrim> = random_scene(&mut rng, n)
            .into_iter()
            .filter(|p| p.kind == mdas::lights::KIND_POINT)
            .collect();
        let n = prims.len();
        if n == 0 {
            continue;
        }
        let two = TreeSampler::new(
            two_level::build(&prims, &chunks(n, n)).unwrap(),
            Importance::Cones,
        );
        let saoh = TreeSampler::new(bvh::build(&prims, Cost::Saoh).unwrap(), Importance::Cones);
        for _ in 0..8 {
            let s = random_shading(&mut rng);
            for i in 0..n as u32 {
                assert_eq!(two.pmf(&s, i), saoh.pmf(&s, i), "{n} lights, light {i}");
            }
        }
    }
}

/// The top level keeps a distant group apart: four groups of two point
/// lights spanning x ∈ [4.7, 5.4], [−9.1, −8.5], [3.9, 6.3] and [4.5, 5.5]
/// (centres 5.05, −8.8, 5.1, 5.0). The SAOH splits the far group 1 from
/// the three near x = 5 at the root (a perfect tree in Morton order of the
/// centres, the paper's top level, paired {1, 3} and {0, 2}, putting a node
/// 14 m wide above group 3).
#[test]
fn two_level_top_level_splits_off_a_distant_group() {
    let spans = [(4.7, 5.4), (-9.1, -8.5), (3.9, 6.3), (4.5, 5.5)];
    let prims: Vec<LightPrim> = spans
        .into_iter()
        .flat_map(|(a, b)| {
            [
                LightPrim::point(Vec3::new(a, 0.0, 0.0), Vec3::ONE),
                LightPrim::point(Vec3::new(b, 0.0, 0.0), Vec3::ONE),
            ]
        })
        .collect();
    let t = two_level::build(&prims, &chunks(8, 4)).unwrap();
    let (l, r) = t.children(0).unwrap();
    // The groups (lights 2g and 2g + 1) below a node.
    let below = |node: usize| -> Vec<u32> {
        let mut groups: Vec<u32> = lights_below(&t, node).iter().map(|id| id / 2).collect();
        groups.sort_unstable();
        groups.dedup();
        groups
    };
    let mut halves = [below(l), below(r)];
    halves.sort();
    assert_eq!(halves, [vec![0, 2, 3], vec![1]]);
}

#[test]
#[should_panic(expected = "groups must partition")]
fn two_level_groups_must_partition_the_ids() {
    let prims = vec![LightPrim::point(Vec3::ZERO, Vec3::ONE); 4];
    two_level::build(&prims, &[0..2, 3..4]);
}

/// Over one group the two-level tree is the perfect tree with its bogus
/// leaves dropped: every light's pmf equals `tree_cone`'s without a cut,
/// exactly (the same nodes, cones and decisions), at random shading
/// points, for light counts that are and are not powers of two.
#[test]
fn tree2_over_one_group_samples_like_tree_cone() {
    let mut rng = StdRng::seed_from_u64(23);
    for n in [1usize, 2, 5, 64, 300] {
        let mut prims = random_triangles(&mut rng, n);
        prims.extend(random_scene(&mut rng, n / 2));
        let n = prims.len();
        let two = TreeSampler::new(
            two_level::build(&prims, &chunks(n, 1)).unwrap(),
            Importance::Cones,
        );
        let perfect = TreeSampler::new(perfect::build(&prims).unwrap(), Importance::Cones);
        for _ in 0..8 {
            let s = random_shading(&mut rng);
            for i in 0..n as u32 {
                assert_eq!(two.pmf(&s, i), perfect.pmf(&s, i), "{n} lights, light {i}");
            }
        }
    }
}

/// `p` moved by the rigid transform `r` as a frame moves a mesh's
/// triangles (every vertex by `apply_point`; a VPL's normal by
/// `apply_vector`).
pub(crate) fn moved(p: &LightPrim, r: &Rigid) -> LightPrim {
    let at = |a: [f32; 3]| r.apply_point(Vec3::from(a));
    let e = Vec3::from(p.emission);
    match p.kind {
        mdas::lights::KIND_TRIANGLE => LightPrim::triangle(at(p.p0), at(p.p1), at(p.p2), e),
        mdas::lights::KIND_VPL => LightPrim::vpl(at(p.p0), r.apply_vector(p.p1.into()), e),
        _ => LightPrim::point(at(p.p0), e),
    }
}

/// The lights of each group `groups[i]` moved by `rigid[i]`.
pub(crate) fn moved_groups(
    lights: &[LightPrim],
    groups: &[std::ops::Range<u32>],
    rigid: &[Rigid],
) -> Vec<LightPrim> {
    groups
        .iter()
        .zip(rigid)
        .flat_map(|(g, r)| {
            lights[g.start as usize..g.end as usize]
                .iter()
                .map(|p| moved(p, r))
        })
        .collect()
}

/// A rotation uniform over SO(3) (a unit quaternion: a point uniform in
/// the 4D unit ball, normalized) and a translation in [−20, 20]³.
pub(crate) fn random_rigid(rng: &mut StdRng) -> Rigid {
    let rotation = loop {
        let q = Vec4::new(
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
        );
        if (0.01..=1.0).contains(&q.length_squared()) {
            break q.normalize();
        }
    };
    Rigid {
        rotation,
        translation: Vec3::new(
            rng.random_range(-20.0..20.0),
            rng.random_range(-20.0..20.0),
            rng.random_range(-20.0..20.0),
        ),
    }
}

/// For lights that do not move, the bottom levels sorted once give the
/// tree `two_level::build` sorts in full, bit for bit — with every group
/// sorted once, with every other group sorted per frame, and with the
/// frame's lights past the groups (the VPLs) as one more group.
#[test]
fn two_level_bottom_levels_of_lights_that_stay_put_are_the_full_build() {
    assert!(BottomLevels::new(vec![], &[]).tree(&[]).is_none());
    let mut rng = StdRng::seed_from_u64(31);
    for n in [1usize, 2, 7, 300, 1000] {
        let mut prims = random_triangles(&mut rng, n);
        prims.extend(random_scene(&mut rng, n / 3));
        let n = prims.len();
        for k in [1, 5, n] {
            let groups = chunks(n, k);
            let what = format!("{n} lights, {k} groups");
            let full = two_level::build(&prims, &groups).unwrap();
            let object: Vec<Option<&[LightPrim]>> = groups
                .iter()
                .map(|g| Some(&prims[g.start as usize..g.end as usize]))
                .collect();
            let once = BottomLevels::new(groups.clone(), &object);
            assert_eq!(once.tree(&prims).unwrap(), full, "{what}");
            let some: Vec<Option<&[LightPrim]>> = object
                .iter()
                .enumerate()
                .map(|(i, o)| o.filter(|_| i % 2 == 0))
                .collect();
            let mixed = BottomLevels::new(groups.clone(), &some);
            assert_eq!(
                mixed.tree(&prims).unwrap(),
                full,
                "{what}, every other group"
            );
            let last = groups.len() - 1;
            let tail = BottomLevels::new(groups[..last].to_vec(), &object[..last]);
            assert_eq!(
                tail.tree(&prims).unwrap(),
                full,
                "{what}, the last group as VPLs"
            );
        }
    }
}

/// Groups moved by rigid transforms keep the leaf order sorted once in
/// object space, and the frame's tree is still exact for the frame: a
/// valid light BVH whose every internal node gathers its children (bounds,
/// intensity), cones bounding every light below, each group in one
/// subtree in its object-space order; and sampling through it is
/// consistent (sample pmf = pmf(light)), normalized, and reaches every
/// light that can contribute. The world-space sort differs from the
/// object-space one in these frames, so a per-frame sort would fail the
/// order check.
#[test]
fn two_level_moved_bottom_levels_keep_their_order_and_bound_the_frame() {
    let mut rng = StdRng::seed_from_u64(37);
    let mut object = random_triangles(&mut rng, 500);
    object.extend(random_scene(&mut rng, 200));
    let groups = vec![0..500u32, 500..700];
    let slices: Vec<Option<&[LightPrim]>> = groups
        .iter()
        .map(|g| Some(&object[g.start as usize..g.end as usize]))
        .collect();
    let bottoms = BottomLevels::new(groups.clone(), &slices);
    let object_order: Vec<Vec<u32>> = groups
        .iter()
        .map(|g| {
            let sub = &object[g.start as usize..g.end as usize];
            perfect::sort_lights(sub)
                .into_iter()
                .map(|i| i + g.start)
                .collect()
        })
        .collect();
    let mut resorted = false;
    for frame in 0..4 {
        // In frame 0 the first group stays in object space (its bottom
        // level is copied, the other one gathered again).
        let rigid: Vec<Rigid> = (0..groups.len())
            .map(|g| {
                if frame == 0 && g == 0 {
                    Rigid::IDENTITY
                } else {
                    random_rigid(&mut rng)
                }
            })
            .collect();
        let prims = moved_groups(&object, &groups, &rigid);
        let what = format!("frame {frame}");
        let t = bottoms.tree(&prims).unwrap();
        check_bvh(&prims, &t);
        check_cones_bound_their_lights(&prims, &t, &what);
        for (g, order) in groups.iter().zip(&object_order) {
            let mut node = t.leaf_of_light(g.start).unwrap();
            while lights_below(&t, node).len() < g.len() {
                node = t.parent(node).unwrap();
            }
            assert_eq!(&lights_below(&t, node), order, "{what}: group {g:?}");
            let world: Vec<u32> = perfect::sort_lights(&prims[g.start as usize..g.end as usize])
                .into_iter()
                .map(|i| i + g.start)
                .collect();
            resorted |= &world != order;
        }
        let sampler = TreeSampler::new(t, Importance::Cones);
        for _ in 0..4 {
            let s = random_shading(&mut rng);
            let none = check_consistency(&what, &sampler, &s, 4096);
            let sum = pmf_sum(&sampler, &s, prims.len());
            // Σ pmf + P(None) = 1 (P(None) estimated on 4098 points), as
            // in `pmf_consistency_normalization_and_unbiasedness`.
            assert!(sum <= 1.0 + 1e-5, "{what}: Σ pmf = {sum}");
            assert!(
                (sum + none - 1.0).abs() < 2e-3,
                "{what}: Σ pmf {sum} + none {none}"
            );
            for (i, prim) in prims.iter().enumerate() {
                if contributes(prim, &s) {
                    assert!(
                        sampler.pmf(&s, i as u32) > 0.0,
                        "{what}: light {i} has pmf 0"
                    );
                }
            }
        }
    }
    assert!(resorted, "the frames never changed the Morton order");
}

/// Groups with equal object-space lights (one mesh light placed at
/// several transforms) share one sorted order; a group that differs in
/// one light's emission gets its own, and groups sorted every frame none.
#[test]
fn two_level_instanced_groups_share_one_sorted_order() {
    let mut rng = StdRng::seed_from_u64(41);
    let lamp = random_triangles(&mut rng, 64);
    let mut other = lamp.clone();
    other[5].emission[0] += 1.0;
    let lights: Vec<LightPrim> = [&lamp, &lamp, &other, &lamp, &lamp]
        .into_iter()
        .flatten()
        .copied()
        .collect();
    let groups = chunks(lights.len(), 5);
    let object = [
        Some(&lamp[..]),
        Some(&lamp[..]),
        Some(&other[..]),
        Some(&lamp[..]),
        None,
    ];
    let b = BottomLevels::new(groups.clone(), &object);
    assert_eq!(b.shared_orders(), 2);
    // Placed at five transforms: one valid tree over all the instances.
    let rigid: Vec<Rigid> = (0..5).map(|_| random_rigid(&mut rng)).collect();
    let prims = moved_groups(&lights, &groups, &rigid);
    let t = b.tree(&prims).unwrap();
    check_bvh(&prims, &t);
    check_cones_bound_their_lights(&prims, &t, "instances");
}
