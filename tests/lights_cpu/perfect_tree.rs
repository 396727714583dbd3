//! The perfect-tree oracle's invariants.

use super::*;

pub(crate) fn check_perfect_tree(prims: &[LightPrim], t: &PerfectTree) {
    let n = prims.len();
    let p = n.next_power_of_two();
    assert_eq!(t.leaf_count as usize, p);
    assert_eq!(t.levels, p.trailing_zeros() + 1);
    assert_eq!(t.nodes.len(), 2 * p - 1);
    assert_eq!(t.sorted.len(), n);
    // sorted is a permutation sorted by (code, id); leaf_of_light inverts it.
    let c = codes(prims);
    let mut seen = vec![false; n];
    for (slot, &id) in t.sorted.iter().enumerate() {
        assert!(!seen[id as usize]);
        seen[id as usize] = true;
        assert_eq!(t.leaf_of_light[id as usize] as usize, slot);
        if slot > 0 {
            let prev = t.sorted[slot - 1];
            assert!((c[prev as usize], prev) < (c[id as usize], id));
        }
        let leaf = &t.nodes[t.leaf_node_index(slot as u32)];
        assert_eq!(leaf.id, id);
        assert_eq!(leaf.intensity, prims[id as usize].intensity());
        assert_eq!(Vec3::from(leaf.min), prims[id as usize].bounds_min());
        assert_eq!(Vec3::from(leaf.max), prims[id as usize].bounds_max());
    }
    // Bogus leaves.
    for slot in n..p {
        assert_eq!(t.nodes[p - 1 + slot], TreeNode::EMPTY);
    }
    // Internal nodes: the gather of their children, and the union of the
    // real leaves below them (the bogus ones drop out).
    for i in 0..p - 1 {
        let node = &t.nodes[i];
        assert_eq!(*node, gather(&t.nodes[2 * i + 1], &t.nodes[2 * i + 2]));
        assert_eq!(node.id, NO_LIGHT);
        let level = perfect::level_of(i);
        let span = 1usize << (t.levels - 1 - level);
        let first = (i + 1) * span - p; // first leaf slot below i
        let real: Vec<_> = (first..first + span).filter(|&s| s < n).collect();
        if real.is_empty() {
            assert!(node.is_empty() && node.intensity == 0.0);
            continue;
        }
        for a in 0..3 {
            let lo = real
                .iter()
                .map(|&s| t.nodes[p - 1 + s].min[a])
                .fold(f32::INFINITY, f32::min);
            let hi = real
                .iter()
                .map(|&s| t.nodes[p - 1 + s].max[a])
                .fold(f32::NEG_INFINITY, f32::max);
            assert_eq!((node.min[a], node.max[a]), (lo, hi));
        }
        let sum: f64 = real
            .iter()
            .map(|&s| t.nodes[p - 1 + s].intensity as f64)
            .sum();
        assert!((node.intensity as f64 - sum).abs() <= 1e-5 * sum.max(1e-30));
    }
}

#[test]
fn perfect_tree_invariants() {
    assert!(perfect::build(&[]).is_none());
    let mut rng = StdRng::seed_from_u64(2);
    for n in [1, 2, 3, 5, 1000, 4097] {
        let prims = random_scene(&mut rng, n);
        let t = perfect::build(&prims).unwrap();
        check_perfect_tree(&prims, &t);
        // Deterministic.
        assert_eq!(perfect::build(&prims).unwrap(), t);
    }
    // Coincident lights: sorted by id.
    let same = vec![LightPrim::point(Vec3::ONE, Vec3::ONE); 6];
    let t = perfect::build(&same).unwrap();
    assert_eq!(t.sorted, (0..6).collect::<Vec<_>>());
    check_perfect_tree(&same, &t);
}
