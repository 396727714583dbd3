//! The light BVH's invariants.

use super::*;

pub(crate) fn check_bvh(prims: &[LightPrim], b: &LightBvh) {
    let n = prims.len();
    assert_eq!(b.nodes.len(), 2 * n - 1);
    assert_eq!(b.parent[0], NO_LIGHT);
    assert!(b.depth <= MAX_DEPTH);
    let mut leaves = vec![false; n];
    for (i, node) in b.nodes.iter().enumerate() {
        match b.children(i) {
            Some((l, r)) => {
                assert!(l > i && r == l + 1 && r < b.nodes.len());
                assert_eq!((b.parent[l] as usize, b.parent[r] as usize), (i, i));
                assert_eq!(node.id, INTERNAL_BIT | l as u32);
                let g = gather(&b.nodes[l], &b.nodes[r]);
                assert_eq!(
                    (node.min, node.max, node.intensity),
                    (g.min, g.max, g.intensity)
                );
            }
            None => {
                let id = node.id as usize;
                assert!(!leaves[id]);
                leaves[id] = true;
                assert_eq!(b.leaf_of_light[id] as usize, i);
                assert_eq!(node.intensity, prims[id].intensity());
            }
        }
    }
    assert!(leaves.iter().all(|&x| x));
}

#[test]
fn bvh_invariants() {
    for cost in [Cost::Sah, Cost::Saoh] {
        assert!(bvh::build(&[], cost).is_none());
        let mut rng = StdRng::seed_from_u64(3);
        for n in [1, 2, 3, 5, 1000] {
            let prims = random_scene(&mut rng, n);
            let b = bvh::build(&prims, cost).unwrap();
            check_bvh(&prims, &b);
            assert_eq!(bvh::build(&prims, cost).unwrap(), b);
        }
        // Lights on a line, exponentially spaced: the depth stays bounded.
        let line: Vec<_> = (0..300)
            .map(|i| LightPrim::point(Vec3::new(1.1f32.powi(i), 0.0, 0.0), Vec3::ONE))
            .collect();
        let b = bvh::build(&line, cost).unwrap();
        check_bvh(&line, &b);
        let same = vec![LightPrim::point(Vec3::ONE, Vec3::ONE); 33];
        let b = bvh::build(&same, cost).unwrap();
        check_bvh(&same, &b);
        assert_eq!(b.depth, 7);
    }
}
