//! Cuts: they partition the lights and are the greedy cut.

use super::*;

/// Each of the tree's `lights` lights lies below exactly one cut node.
pub(crate) fn check_cut_covers<T: LightTree>(t: &T, lights: usize, cut: &[u32]) {
    assert_eq!(t.light_count() as usize, lights);
    for light in 0..lights as u32 {
        let mut node = t.leaf_of_light(light);
        let mut hits = 0;
        while let Some(x) = node {
            hits += cut.iter().filter(|&&c| c as usize == x).count();
            node = t.parent(x);
        }
        assert_eq!(hits, 1, "light {light} under {hits} cut nodes of {cut:?}");
    }
}

#[test]
fn cuts_partition_the_lights() {
    let mut rng = StdRng::seed_from_u64(4);
    for n in [1, 2, 5, 37, 300] {
        let prims = random_scene(&mut rng, n);
        let t = perfect::build(&prims).unwrap();
        let b = bvh::build(&prims, Cost::Saoh).unwrap();
        for i in 0..6 {
            let s = random_shading(&mut rng);
            let imp = [Importance::Plain, Importance::Cones][i % 2];
            for size in [1, 2, 3, 8, MAX_CUT] {
                let c = select_cut(&t, imp, &s, size);
                assert!(c.len() <= size as usize);
                check_cut_covers(&t, n, &c);
                let c = select_cut(&b, imp, &s, size);
                assert!(c.len() <= size as usize);
                check_cut_covers(&b, n, &c);
                // The BVH has no zero-intensity padding: a full cut unless
                // lights ran out (refinable nodes need I > 0).
                if b.nodes[0].intensity > 0.0 && prims.iter().all(|p| p.intensity() > 0.0) {
                    assert_eq!(c.len(), (size as usize).min(n));
                }
            }
        }
    }
}

#[test]
fn cut_refines_the_node_with_the_largest_key() {
    // Lights far apart: the cut refines around the representative point.
    let prims: Vec<_> = (0..16)
        .map(|i| LightPrim::point(Vec3::new(i as f32 * 10.0, 0.0, 0.0), Vec3::ONE))
        .collect();
    let t = perfect::build(&prims).unwrap();
    let s = Shading {
        p: Vec3::new(0.0, 1.0, 0.0),
        n: Vec3::ZERO,
    };
    let cut = select_cut(&t, Importance::Plain, &s, 5);
    // The leaf nearest (x = 0, slot 0 = node 15) must be in the cut.
    assert!(cut.contains(&15), "{cut:?}");
    let nodes: Vec<_> = cut.iter().map(|&c| t.nodes[c as usize]).collect();
    // The farthest half (node 2) is never refined.
    assert!(cut.contains(&2), "{cut:?} {nodes:?}");
}

/// The greedy cut as docs/light-sampling.md states it, written as a plain
/// search: starting from the root, `size − 1` times refine the cut node
/// with the largest key among the refinable ones (internal, intensity > 0),
/// the smaller node index on a tie; stop early when none is refinable.
/// Returned sorted (`select_cut`'s order is its own business).
pub(crate) fn greedy_cut_oracle<T: LightTree>(
    t: &T,
    imp: Importance,
    s: &Shading,
    size: u32,
) -> Vec<u32> {
    let mut cut = vec![0usize];
    while cut.len() < size as usize {
        let refinable = cut
            .iter()
            .copied()
            .filter(|&c| t.children(c).is_some() && t.nodes()[c].intensity > 0.0);
        let key = |c: usize| mdas::lights::importance::cut_key(&imp.of(t, c, s));
        // Largest key; on equal keys the smaller index (compared as
        // (key, −index)).
        let Some(best) = refinable.max_by(|&a, &b| {
            key(a)
                .partial_cmp(&key(b))
                .expect("keys of refinable nodes are not NaN")
                .then(b.cmp(&a))
        }) else {
            break;
        };
        let (l, r) = t.children(best).unwrap();
        cut.retain(|&c| c != best);
        cut.extend([l, r]);
    }
    let mut cut: Vec<u32> = cut.into_iter().map(|c| c as u32).collect();
    cut.sort_unstable();
    cut
}

/// `select_cut` against [`greedy_cut_oracle`] on random scenes (zero-
/// intensity padding in the perfect trees; shading points inside node
/// bounds, whose key is +∞, give ties) and on a symmetric one with an exact
/// tie between the root's children.
#[test]
fn cut_is_the_greedy_cut_with_ties_to_the_smaller_node() {
    let mut rng = StdRng::seed_from_u64(41);
    let mut ties = 0;
    for n in [2, 5, 37, 300] {
        let prims = random_scene(&mut rng, n);
        let t = perfect::build(&prims).unwrap();
        let b = bvh::build(&prims, Cost::Saoh).unwrap();
        // `parent` inverts `children` (the pmf walks up with it).
        for tree in [&t as &dyn LightTree, &b] {
            assert_eq!(tree.parent(0), None);
            for node in 0..tree.nodes().len() {
                if let Some((l, r)) = tree.children(node) {
                    assert_eq!((tree.parent(l), tree.parent(r)), (Some(node), Some(node)));
                }
            }
        }
        for i in 0..8 {
            let s = random_shading(&mut rng);
            let imp = [Importance::Plain, Importance::Cones][i % 2];
            for size in [2, 3, 8, 33, MAX_CUT] {
                let mut c = select_cut(&t, imp, &s, size);
                c.sort_unstable();
                assert_eq!(
                    c,
                    greedy_cut_oracle(&t, imp, &s, size),
                    "perfect, {n} lights, size {size}"
                );
                let mut c = select_cut(&b, imp, &s, size);
                c.sort_unstable();
                assert_eq!(
                    c,
                    greedy_cut_oracle(&b, imp, &s, size),
                    "bvh, {n} lights, size {size}"
                );
            }
            let key = |c| mdas::lights::importance::cut_key(&imp.of(&t, c, &s));
            ties += usize::from(key(1) == key(2));
        }
    }
    assert!(ties > 0, "no tie between the root's children was exercised");

    // Four equal lights symmetric about the shading point: the root's
    // children have equal keys, so a cut of 3 refines node 1, not node 2.
    let prims: Vec<_> = [-3.0f32, -1.0, 1.0, 3.0]
        .iter()
        .map(|&x| LightPrim::point(Vec3::new(x, 0.0, 0.0), Vec3::ONE))
        .collect();
    let t = perfect::build(&prims).unwrap();
    let s = Shading {
        p: Vec3::new(0.0, 2.0, 0.0),
        n: Vec3::ZERO,
    };
    let key = |c| mdas::lights::importance::cut_key(&Importance::Plain.of(&t, c, &s));
    assert_eq!(key(1), key(2), "the case needs a tie");
    let mut c = select_cut(&t, Importance::Plain, &s, 3);
    c.sort_unstable();
    assert_eq!(c, vec![2, 3, 4]);
}
