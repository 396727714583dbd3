//! CPU tests of many-light sampling (src/lights): exact Morton codes, the
//! perfect-tree oracle, the light BVH, cuts, and every sampler's pmf
//! (consistency, normalization, unbiasedness, chi-square goodness of fit),
//! on random scenes and on hard cases.
//!
//! Statistics (fixed seeds, so the outcome is deterministic):
//! * chi-square: `M = 200,000` selections per case, cells with expected
//!   count < 5 pooled (pbrt's rule), plus a "no light" cell with the
//!   probability `1 − Σ pmf` that sampling returns `None`; dof = cells − 1;
//!   overall significance 1e-3, Bonferroni-corrected over the number of
//!   cases of the test (α = 1e-3 / cases).
//! * estimator check (pbrt): `E[1/(pmf(X)·N₊)] = 1` where `N₊` counts the
//!   lights with `pmf > 0` (a `None` sample contributes 0), checked on
//!   `65,536` stratified `u` to 6 standard errors.

mod light_scenes;
mod stats;

use glam::{Vec3, Vec4};
use light_scenes::vpl_walls;
use mdas::lights::bvh::{self, Cost, LightBvh, INTERNAL_BIT, MAX_DEPTH};
use mdas::lights::cut::{Importance, LightTree, MAX_CUT};
use mdas::lights::importance::{node_importance, ONE_MINUS_EPSILON};
use mdas::lights::morton::{codes, exponent, morton30, quantize_axis};
use mdas::lights::perfect::{self, gather, PerfectTree};
use mdas::lights::substitute::{self, SstSampler, Stop, Substitute, SubstituteParams};
use mdas::lights::two_level::{self, BottomLevels};
use mdas::lights::{
    new_sampler, select_cut, LightSampler, PowerSampler, SamplerKind, Shading, TreeSampler,
    UniformSampler,
};
use mdas::lights::{LightPrim, TreeNode, NO_LIGHT};
use mdas::scene::motion::Rigid;
use rand::rngs::StdRng;
use rand::{RngExt, SeedableRng};
use stats::gamma_q;

// ---------------------------------------------------------------- helpers

fn random_scene(rng: &mut StdRng, n: usize) -> Vec<LightPrim> {
    (0..n)
        .map(|_| {
            let c = Vec3::new(
                rng.random_range(-5.0..5.0),
                rng.random_range(-5.0..5.0),
                rng.random_range(-5.0..5.0),
            );
            let e = if rng.random::<f32>() < 0.1 {
                Vec3::ZERO
            } else {
                Vec3::new(
                    rng.random_range(0.0..10.0),
                    rng.random_range(0.0..10.0),
                    rng.random_range(0.0..10.0),
                )
            };
            let kind = rng.random::<f32>();
            if kind < 0.55 {
                LightPrim::point(c, e)
            } else if kind < 0.7 {
                LightPrim::vpl(c, random_unit(rng), e)
            } else {
                let mut v = || {
                    c + Vec3::new(
                        rng.random_range(-0.5..0.5),
                        rng.random_range(-0.5..0.5),
                        rng.random_range(-0.5..0.5),
                    )
                };
                let (a, b, d) = (v(), v(), v());
                LightPrim::triangle(a, b, d, e)
            }
        })
        .collect()
}

fn random_unit(rng: &mut StdRng) -> Vec3 {
    loop {
        let v = Vec3::new(
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
        );
        let l = v.length();
        if l > 0.1 && l <= 1.0 {
            return v / l;
        }
    }
}

fn random_shading(rng: &mut StdRng) -> Shading {
    Shading {
        p: Vec3::new(
            rng.random_range(-6.0..6.0),
            rng.random_range(-6.0..6.0),
            rng.random_range(-6.0..6.0),
        ),
        n: random_unit(rng),
    }
}

/// Every sampler variant: the six kinds, the cut kinds with cuts of 4 and
/// 16 nodes chosen at `rep` (a representative point of the block).
fn samplers(
    prims: &[LightPrim],
    rep: &Shading,
) -> Vec<(String, Box<dyn LightSampler + Send + Sync>)> {
    let mut v = Vec::new();
    for kind in SamplerKind::PICKERS {
        if kind.is_biased() {
            // sst: its substitutes are tested in "substitute trees" below.
            continue;
        }
        if kind.uses_cut() {
            for size in [4, 16] {
                v.push((
                    format!("{kind}/cut{size}"),
                    new_sampler(kind, prims, Some((rep, size))),
                ));
            }
            if kind == SamplerKind::Tree2 {
                // The factory's tree2 has one group; scenes have several.
                let t = two_level::build(prims, &chunks(prims.len(), 3)).unwrap();
                v.push((
                    "tree2/groups".into(),
                    Box::new(TreeSampler::new(t.clone(), Importance::Cones)),
                ));
                v.push((
                    "tree2/groups/cut8".into(),
                    Box::new(TreeSampler::with_cut_at(t, Importance::Cones, rep, 8)),
                ));
            }
        } else {
            v.push((kind.to_string(), new_sampler(kind, prims, None)));
        }
    }
    v
}

/// `0..n` in `k` contiguous groups of nearly equal size (empty ones
/// included when `n < k`).
fn chunks(n: usize, k: usize) -> Vec<std::ops::Range<u32>> {
    (0..k)
        .map(|i| (i * n / k) as u32..((i + 1) * n / k) as u32)
        .collect()
}

/// `Σ_lights pmf`.
fn pmf_sum(s: &dyn LightSampler, sh: &Shading, n: usize) -> f64 {
    (0..n as u32).map(|i| s.pmf(sh, i)).sum()
}

/// Chi-square p-value of observed counts against expected counts, pooling
/// cells with expected < 5. Panics if a cell with expected 0 was observed.
fn chi_square_p(observed: &[u64], expected: &[f64]) -> (f64, usize) {
    let mut cells: Vec<(f64, u64)> = Vec::new();
    let (mut pool_e, mut pool_o) = (0.0, 0u64);
    for (&o, &e) in observed.iter().zip(expected) {
        assert!(
            e > 0.0 || o == 0,
            "a cell of probability 0 was drawn {o} times"
        );
        if e < 5.0 {
            pool_e += e;
            pool_o += o;
        } else {
            cells.push((e, o));
        }
    }
    if pool_e >= 5.0 || cells.is_empty() {
        cells.push((pool_e, pool_o));
    } else if pool_e > 0.0 {
        let last = cells.last_mut().unwrap();
        last.0 += pool_e;
        last.1 += pool_o;
    }
    let dof = cells.len().saturating_sub(1);
    if dof == 0 {
        return (1.0, 0);
    }
    let chi2: f64 = cells.iter().map(|&(e, o)| (o as f64 - e).powi(2) / e).sum();
    (gamma_q(dof as f64 / 2.0, chi2 / 2.0), dof)
}

/// Sample-vs-pmf checks on one sampler at one shading point over
/// `strata` stratified `u` plus the edges: each sample's pmf equals
/// `pmf(light)` exactly and is positive; returns the fraction of `None`.
fn check_consistency(name: &str, s: &dyn LightSampler, sh: &Shading, strata: u32) -> f64 {
    let mut none = 0u32;
    let us = (0..strata)
        .map(|k| (k as f32 + 0.5) / strata as f32)
        .chain([0.0, ONE_MINUS_EPSILON]);
    for u in us {
        match s.sample(sh, u) {
            Some(ls) => {
                let q = s.pmf(sh, ls.light);
                assert_eq!(
                    ls.pmf, q,
                    "{name}: sample pmf != pmf(light {}) at u = {u}",
                    ls.light
                );
                assert!(ls.pmf > 0.0 && ls.pmf.is_finite(), "{name}: pmf {}", ls.pmf);
            }
            None => none += 1,
        }
    }
    none as f64 / (strata + 2) as f64
}

// ---------------------------------------------------------------- Morton

/// Reference quantization through f64 and log2 (an independent path).
fn quantize_reference(c: f32, lo: f32, hi: f32) -> u32 {
    let e = hi - lo;
    if e == 0.0 {
        return 0;
    }
    let big_e = (e as f64).log2().floor() as i32;
    let d = (c - lo) as f64;
    ((d * 2f64.powi(9 - big_e)).floor() as u32).min(1023)
}

#[test]
fn morton_quantization_matches_an_f64_reference() {
    let mut rng = StdRng::seed_from_u64(1);
    let scales = [1e-40f32, 1e-30, 1e-3, 1.0, 7.3, 1e6, 1e30];
    for &scale in &scales {
        for _ in 0..2000 {
            let lo = rng.random_range(-1.0f32..1.0) * scale;
            let hi = lo + rng.random::<f32>() * scale;
            let c = lo + (hi - lo) * rng.random::<f32>();
            let c = c.clamp(lo, hi);
            assert_eq!(
                quantize_axis(c, lo, hi),
                quantize_reference(c, lo, hi),
                "c={c:e} lo={lo:e} hi={hi:e}"
            );
        }
    }
    // Subnormal extents: the exponent comes from the bits.
    for bits in [1u32, 2, 3, 0x1234, 0x7fffff] {
        let e = f32::from_bits(bits);
        assert_eq!(exponent(e), (e as f64).log2().floor() as i32);
        assert_eq!(quantize_axis(e, 0.0, e), quantize_reference(e, 0.0, e));
        assert!(quantize_axis(e, 0.0, e) >= 512);
    }
    // Extents of exactly a power of two reach cell 512, just below it 1023.
    assert_eq!(quantize_axis(8.0, 0.0, 8.0), 512);
    assert_eq!(quantize_axis(7.999_999_5, 0.0, 7.999_999_5), 1023);
}

#[test]
fn morton_codes_of_degenerate_sets() {
    // All lights in the plane y = 2: the y bits are 0.
    let prims: Vec<_> = (0..16)
        .map(|i| LightPrim::point(Vec3::new(i as f32, 2.0, (i * 7 % 5) as f32), Vec3::ONE))
        .collect();
    for c in codes(&prims) {
        assert_eq!(c & 0o2222222222, 0, "y bits of {c:o}");
    }
    // Coincident lights: one code, 0.
    let same = vec![LightPrim::point(Vec3::splat(3.0), Vec3::ONE); 5];
    assert_eq!(codes(&same), vec![0; 5]);
    // Two lights on the x axis: lo → 0, hi → cell 512 of x.
    let two = [
        LightPrim::point(Vec3::ZERO, Vec3::ONE),
        LightPrim::point(Vec3::X, Vec3::ONE),
    ];
    assert_eq!(codes(&two), vec![0, morton30([512, 0, 0])]);
    assert_eq!(morton30([512, 0, 0]), 1 << 29);
    assert!(codes(&[]).is_empty());
}

#[test]
fn struct_sizes_match_the_wgsl_layout() {
    assert_eq!(size_of::<TreeNode>(), 32);
    // 4 × (vec3<f32> + u32): the WGSL struct in wgsl/lights/light_prim.wgsl.
    assert_eq!(size_of::<LightPrim>(), 64);
}

// ---------------------------------------------------------------- perfect tree

fn check_perfect_tree(prims: &[LightPrim], t: &PerfectTree) {
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

// ---------------------------------------------------------------- BVH

fn check_bvh(prims: &[LightPrim], b: &LightBvh) {
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

// ---------------------------------------------------------------- two-level tree

/// The light ids of the leaves below `node` of a light BVH, left to
/// right.
fn lights_below(t: &LightBvh, node: usize) -> Vec<u32> {
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
fn moved(p: &LightPrim, r: &Rigid) -> LightPrim {
    let at = |a: [f32; 3]| r.apply_point(Vec3::from(a));
    let e = Vec3::from(p.emission);
    match p.kind {
        mdas::lights::KIND_TRIANGLE => LightPrim::triangle(at(p.p0), at(p.p1), at(p.p2), e),
        mdas::lights::KIND_VPL => LightPrim::vpl(at(p.p0), r.apply_vector(p.p1.into()), e),
        _ => LightPrim::point(at(p.p0), e),
    }
}

/// The lights of each group `groups[i]` moved by `rigid[i]`.
fn moved_groups(
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
fn random_rigid(rng: &mut StdRng) -> Rigid {
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

// ---------------------------------------------------------------- cuts

/// Each of the tree's `lights` lights lies below exactly one cut node.
fn check_cut_covers<T: LightTree>(t: &T, lights: usize, cut: &[u32]) {
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
fn greedy_cut_oracle<T: LightTree>(t: &T, imp: Importance, s: &Shading, size: u32) -> Vec<u32> {
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

// ---------------------------------------------------------------- samplers

#[test]
fn sampler_names() {
    for k in SamplerKind::ALL {
        assert_eq!(k.to_string().parse::<SamplerKind>().unwrap(), k);
    }
    let err = "lightcuts".parse::<SamplerKind>().unwrap_err().to_string();
    for name in [
        "uniform",
        "power",
        "tree_nocut",
        "tree",
        "unbalanced",
        "unbalanced_nocut",
        "lgh",
    ] {
        assert!(err.contains(name), "{err}");
    }
}

/// Whether `light` can give a non-zero contribution at `s`, from the
/// geometry alone (no tree, bound or importance code): non-zero emission;
/// the receiver's clamped cosine max(0, n·ω) positive toward some point of
/// the light (any direction when n = 0); and the light emitting toward
/// `s` — a point everywhere, a VPL into the half-space its normal faces
/// (cosine lobe), a triangle from its front side (n_t = (v1 − v0) ×
/// (v2 − v0)). For a triangle the receiver's cosine is linear over it, so
/// its largest value is at a vertex.
fn contributes(light: &LightPrim, s: &Shading) -> bool {
    let lit = |c: Vec3| s.n == Vec3::ZERO || s.n.dot(c - s.p) > 0.0;
    let e = Vec3::from(light.emission);
    if e.max_element() <= 0.0 {
        return false;
    }
    let (a, b, c) = (
        Vec3::from(light.p0),
        Vec3::from(light.p1),
        Vec3::from(light.p2),
    );
    match light.kind {
        mdas::lights::KIND_POINT => lit(a),
        mdas::lights::KIND_VPL => b.dot(s.p - a) > 0.0 && lit(a),
        _ => {
            let normal = (b - a).cross(c - a);
            normal.dot(s.p - a) > 0.0 && (lit(a) || lit(b) || lit(c))
        }
    }
}

#[test]
fn pmf_consistency_normalization_and_unbiasedness() {
    let mut rng = StdRng::seed_from_u64(5);
    for n in [1, 2, 5, 37, 200] {
        let prims = random_scene(&mut rng, n);
        for _ in 0..4 {
            let s = random_shading(&mut rng);
            let mut rep = s;
            rep.p += Vec3::new(0.3, -0.2, 0.1);
            for (name, sampler) in samplers(&prims, &rep) {
                let none = check_consistency(&name, sampler.as_ref(), &s, 4096);
                let sum = pmf_sum(sampler.as_ref(), &s, n);
                // Σ pmf + P(None) = 1 (P(None) estimated on 4098 points).
                assert!(sum <= 1.0 + 1e-5, "{name}: Σ pmf = {sum}");
                assert!(
                    (sum + none - 1.0).abs() < 2e-3,
                    "{name}: Σ pmf {sum} + none {none}"
                );
                // Unbiasedness: every light that can contribute at s —
                // decided from the geometry alone (`contributes`), points,
                // VPLs and triangles alike — has pmf > 0.
                for i in 0..n as u32 {
                    let prim = &prims[i as usize];
                    let live = name == "uniform" || contributes(prim, &s);
                    if live {
                        assert!(
                            sampler.pmf(&s, i) > 0.0,
                            "{name}: light {i} (kind {}) contributes but has pmf 0",
                            prim.kind
                        );
                    }
                }
            }
        }
    }
}

#[test]
fn estimator_of_the_live_light_count() {
    let mut rng = StdRng::seed_from_u64(6);
    let prims = random_scene(&mut rng, 60);
    let m = 65_536u32;
    for _ in 0..3 {
        let s = random_shading(&mut rng);
        for (name, sampler) in samplers(&prims, &s) {
            let live = (0..60).filter(|&i| sampler.pmf(&s, i) > 0.0).count() as f64;
            if live == 0.0 {
                continue;
            }
            let xs: Vec<f64> = (0..m)
                .map(|k| {
                    let u = (k as f32 + 0.5) / m as f32;
                    sampler
                        .sample(&s, u)
                        .map_or(0.0, |ls| 1.0 / (ls.pmf * live))
                })
                .collect();
            let mean = xs.iter().sum::<f64>() / m as f64;
            let var = xs.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (m - 1) as f64;
            let se = (var / m as f64).sqrt();
            assert!(
                (mean - 1.0).abs() <= 6.0 * se + 1e-9,
                "{name}: E[1/(pmf·N+)] = {mean} ± {se}"
            );
        }
    }
}

/// Per light, as pbrt-v4 tests its light samplers, over `draws` = M
/// samples: count_i/(M·p_i) = 1
/// within a binomial bound, for every light expected at least 100 times;
/// lights expected fewer times are pooled into one group, tested the same
/// way when its expectation reaches 100, else allowed at most 100 + 6·√100
/// draws. A chi-square statistic pools small cells and can hide one light
/// drawn at the wrong rate among many; this cannot. z = 5.5 two-sided:
/// the normal tail is 3.8e-8 per test (the binomial's, at an expectation
/// ≥ 100, at most 3e-7: its Poisson limit's), over fewer than 3,000
/// lights and groups in the test below: family α below 1e-3.
fn check_per_light(name: &str, counts: &[u64], expected: &[f64], draws: f64) {
    const Z: f64 = 5.5;
    let z_of = |c: f64, e: f64| {
        let p = (e / draws).min(1.0);
        (c - e).abs() / (draws * p * (1.0 - p)).sqrt().max(1e-12)
    };
    let (mut pooled_c, mut pooled_e) = (0.0, 0.0);
    for (i, (&c, &e)) in counts.iter().zip(expected).enumerate() {
        if e >= 100.0 {
            let z = z_of(c as f64, e);
            assert!(
                z <= Z,
                "{name}: light {i} drawn {c} times, expected {e:.1} (z = {z:.1})"
            );
        } else {
            pooled_c += c as f64;
            pooled_e += e;
        }
    }
    if pooled_e >= 100.0 {
        let z = z_of(pooled_c, pooled_e);
        assert!(
            z <= Z,
            "{name}: rare lights drawn {pooled_c} times, expected {pooled_e:.1}"
        );
    } else {
        assert!(
            pooled_c <= 160.0,
            "{name}: rare lights drawn {pooled_c} times, expected {pooled_e:.1}"
        );
    }
}

#[test]
fn chi_square_of_selection_frequencies() {
    const M: u64 = 200_000;
    let mut rng = StdRng::seed_from_u64(7);
    let mut cases = Vec::new();
    for n in [3, 20, 150] {
        let prims = random_scene(&mut rng, n);
        for _ in 0..2 {
            let s = random_shading(&mut rng);
            let mut rep = s;
            rep.p += Vec3::new(-0.4, 0.2, 0.5);
            cases.push((prims.clone(), s, rep));
        }
    }
    let tests = cases.len() * samplers(&cases[0].0, &cases[0].2).len();
    let alpha = 1e-3 / tests as f64;
    for (prims, s, rep) in &cases {
        let n = prims.len();
        for (name, sampler) in samplers(prims, rep) {
            let mut counts = vec![0u64; n + 1];
            for _ in 0..M {
                let u: f32 = rng.random();
                match sampler.sample(s, u) {
                    Some(ls) => counts[ls.light as usize] += 1,
                    None => counts[n] += 1,
                }
            }
            let mut expected: Vec<f64> = (0..n as u32)
                .map(|i| sampler.pmf(s, i) * M as f64)
                .collect();
            let sum: f64 = expected.iter().sum::<f64>() / M as f64;
            expected.push((1.0 - sum).max(0.0) * M as f64);
            let (p, dof) = chi_square_p(&counts, &expected);
            assert!(
                p >= alpha,
                "{name}, {n} lights: chi-square p = {p:e} < {alpha:e} (dof {dof})"
            );
            check_per_light(&name, &counts[..n], &expected[..n], M as f64);
            // The baselines' pmfs from their definitions, not the sampler:
            // uniform 1/N, power ∝ the light's scalar intensity.
            let total: f64 = prims.iter().map(|l| l.intensity() as f64).sum();
            for (i, l) in prims.iter().enumerate() {
                let want = match name.as_str() {
                    "uniform" => 1.0 / n as f64,
                    "power" => l.intensity() as f64 / total,
                    _ => continue,
                };
                let got = sampler.pmf(s, i as u32);
                assert!(
                    (got - want).abs() <= 1e-6 * want,
                    "{name}: light {i} pmf {got}, {want}"
                );
            }
        }
    }
}

// ---------------------------------------------------------------- hard cases

#[test]
fn one_light() {
    let prims = [LightPrim::point(Vec3::new(0.0, 2.0, 0.0), Vec3::ONE)];
    let up = Shading {
        p: Vec3::ZERO,
        n: Vec3::Y,
    };
    let down = Shading {
        p: Vec3::ZERO,
        n: -Vec3::Y,
    };
    for kind in SamplerKind::PICKERS {
        let s = new_sampler(kind, &prims, Some((&up, 8)));
        for u in [0.0, 0.5, ONE_MINUS_EPSILON] {
            let ls = s.sample(&up, u).unwrap();
            assert_eq!((ls.light, ls.pmf), (0, 1.0), "{kind}");
            // Facing away: the trees know, uniform and power do not.
            let away = s.sample(&down, u);
            if matches!(kind, SamplerKind::Uniform | SamplerKind::Power) {
                assert_eq!(away.unwrap().pmf, 1.0);
            } else {
                assert!(away.is_none(), "{kind}");
                assert_eq!(s.pmf(&down, 0), 0.0);
            }
        }
        assert_eq!(s.pmf(&up, 1), 0.0);
    }
}

/// A larger cut changes the pmf of exactly the kinds that sample from
/// cuts (docs/light-sampling.md: the `_nocut` variants, `uniform`,
/// `power` and the substitute trees do not), and `uses_cut` says so.
#[test]
fn the_cut_size_changes_exactly_the_kinds_with_cuts() {
    let mut rng = StdRng::seed_from_u64(77);
    let prims = random_scene(&mut rng, 37);
    let rep = random_shading(&mut rng);
    let points: Vec<Shading> = (0..4).map(|_| random_shading(&mut rng)).collect();
    for kind in SamplerKind::PICKERS {
        let root = new_sampler(kind, &prims, Some((&rep, 1)));
        let cut = new_sampler(kind, &prims, Some((&rep, 16)));
        let differs = points
            .iter()
            .any(|s| (0..37).any(|i| root.pmf(s, i) != cut.pmf(s, i)));
        let with_cuts = [
            SamplerKind::Tree,
            SamplerKind::TreeCone,
            SamplerKind::Unbalanced,
            SamplerKind::UnbalancedNoCone,
            SamplerKind::Tree2,
        ];
        assert_eq!(differs, with_cuts.contains(&kind), "{kind}");
        assert_eq!(kind.uses_cut(), differs, "{kind}");
    }
}

/// `lgh` picks no single light: the CPU factory refuses it with the
/// reason (not an unreachable arm).
#[test]
#[should_panic(expected = "picks no single light")]
fn the_cpu_factory_refuses_lgh() {
    let prims = [LightPrim::point(Vec3::new(0.0, 2.0, 0.0), Vec3::ONE)];
    new_sampler(SamplerKind::Lgh, &prims, None);
}

#[test]
fn zero_lights_never_sample() {
    let s = Shading::default();
    for kind in SamplerKind::PICKERS {
        let sampler = new_sampler(kind, &[], Some((&s, 4)));
        assert!(sampler.sample(&s, 0.5).is_none());
        assert_eq!(sampler.pmf(&s, 0), 0.0);
    }
}

#[test]
fn coincident_lights_follow_their_intensities() {
    let prims: Vec<_> = (0..7)
        .map(|i| LightPrim::point(Vec3::new(1.0, 3.0, -2.0), Vec3::splat(i as f32 + 1.0)))
        .collect();
    let total: f32 = prims.iter().map(|p| p.intensity()).sum();
    let s = Shading {
        p: Vec3::ZERO,
        n: Vec3::Y,
    };
    for (name, sampler) in samplers(&prims, &s) {
        check_consistency(&name, sampler.as_ref(), &s, 1024);
        if name == "uniform" {
            continue;
        }
        for (i, p) in prims.iter().enumerate() {
            let want = (p.intensity() / total) as f64;
            let got = sampler.pmf(&s, i as u32);
            assert!(
                (got - want).abs() < 1e-6,
                "{name}: light {i}: {got} vs {want}"
            );
        }
    }
}

#[test]
fn lights_in_one_plane_and_points_on_lights() {
    let mut rng = StdRng::seed_from_u64(8);
    let prims: Vec<_> = (0..50)
        .map(|_| {
            LightPrim::point(
                Vec3::new(
                    rng.random_range(-3.0..3.0),
                    0.0,
                    rng.random_range(-3.0..3.0),
                ),
                Vec3::splat(rng.random_range(0.1..2.0)),
            )
        })
        .collect();
    let on_light = Vec3::from(prims[7].p0);
    let points = [
        // In the plane, inside every box that spans it.
        Shading {
            p: Vec3::new(0.1, 0.0, 0.2),
            n: Vec3::Y,
        },
        // Exactly on a light, normal in the plane.
        Shading {
            p: on_light,
            n: Vec3::X,
        },
        // On a light without a normal.
        Shading {
            p: on_light,
            n: Vec3::ZERO,
        },
        // Above the plane.
        Shading {
            p: Vec3::new(0.0, 1.0, 0.0),
            n: -Vec3::Y,
        },
    ];
    for s in &points {
        for (name, sampler) in samplers(&prims, s) {
            let none = check_consistency(&name, sampler.as_ref(), s, 2048);
            let sum = pmf_sum(sampler.as_ref(), s, prims.len());
            assert!(sum.is_finite() && sum <= 1.0 + 1e-5, "{name}: Σ pmf {sum}");
            assert!((sum + none - 1.0).abs() < 2e-3, "{name}: {sum} + {none}");
        }
    }
    // On the light without a normal: that light is inside its own leaf box,
    // so the trees sample it with positive probability.
    let s = points[2];
    for (name, sampler) in samplers(&prims, &s) {
        assert!(sampler.pmf(&s, 7) > 0.0, "{name}");
    }
}

#[test]
fn zero_intensity_lights_are_never_picked() {
    let mut rng = StdRng::seed_from_u64(9);
    let mut prims = random_scene(&mut rng, 40);
    for (i, p) in prims.iter_mut().enumerate() {
        if i % 3 == 0 {
            p.emission = [0.0; 3];
        }
    }
    let s = random_shading(&mut rng);
    for (name, sampler) in samplers(&prims, &s) {
        if name == "uniform" {
            continue;
        }
        for i in (0..40).step_by(3) {
            assert_eq!(sampler.pmf(&s, i), 0.0, "{name}: light {i}");
        }
        for k in 0..5000 {
            if let Some(ls) = sampler.sample(&s, (k as f32 + 0.5) / 5000.0) {
                assert_ne!(ls.light % 3, 0, "{name}");
            }
        }
    }
    // All zero: power and the trees sample nothing.
    let dark: Vec<_> = prims
        .iter()
        .map(|p| LightPrim {
            emission: [0.0; 3],
            ..*p
        })
        .collect();
    for (name, sampler) in samplers(&dark, &s) {
        if name != "uniform" {
            assert!(sampler.sample(&s, 0.3).is_none(), "{name}");
            assert_eq!(pmf_sum(sampler.as_ref(), &s, 40), 0.0, "{name}");
        }
    }
}

#[test]
fn dead_branches_return_no_light() {
    let s = Shading {
        p: Vec3::ZERO,
        n: Vec3::Y,
    };
    // Every light below the surface.
    let mut rng = StdRng::seed_from_u64(10);
    let below: Vec<_> = (0..30)
        .map(|_| {
            LightPrim::point(
                Vec3::new(
                    rng.random_range(-5.0..5.0),
                    rng.random_range(-5.0..-0.1),
                    rng.random_range(-5.0..5.0),
                ),
                Vec3::ONE,
            )
        })
        .collect();
    // Two lights below the surface whose common box reaches the shading
    // point (the root looks alive, both children are dead).
    let pair = [
        LightPrim::point(Vec3::new(-10.0, -1.0, 0.0), Vec3::ONE),
        LightPrim::point(Vec3::new(10.0, -1.0, 0.0), Vec3::ONE),
    ];
    for prims in [&below[..], &pair[..]] {
        for (name, sampler) in samplers(prims, &s) {
            if name == "uniform" || name == "power" {
                continue;
            }
            for k in 0..256 {
                assert!(sampler.sample(&s, k as f32 / 256.0).is_none(), "{name}");
            }
            assert_eq!(pmf_sum(sampler.as_ref(), &s, prims.len()), 0.0, "{name}");
        }
    }
    let t = perfect::build(&pair).unwrap();
    assert!(node_importance(&t.nodes[0], None, &s).w > 0.0);
}

#[test]
fn deep_trees_keep_finite_positive_pmfs() {
    let n = (1 << 20) + 3; // 22 levels
    let mut rng = StdRng::seed_from_u64(11);
    let prims: Vec<_> = (0..n)
        .map(|_| {
            LightPrim::point(
                Vec3::new(
                    rng.random_range(-100.0..100.0),
                    rng.random_range(0.0..100.0),
                    rng.random_range(-100.0..100.0),
                ),
                Vec3::splat(rng.random_range(0.01..1.0)),
            )
        })
        .collect();
    let t = perfect::build(&prims).unwrap();
    assert_eq!(t.levels, 22);
    let s = Shading {
        p: Vec3::new(0.0, -1.0, 0.0),
        n: Vec3::Y,
    };
    let far = Shading {
        p: Vec3::new(500.0, -1.0, 500.0),
        n: Vec3::Y,
    };
    let samplers: Vec<(&str, Box<dyn LightSampler>)> = vec![
        (
            "tree_nocut",
            Box::new(TreeSampler::new(t.clone(), Importance::Plain)),
        ),
        (
            "tree/cut32",
            Box::new(TreeSampler::with_cut_at(
                t.clone(),
                Importance::Plain,
                &s,
                32,
            )),
        ),
        (
            "tree_cone/cut32",
            Box::new(TreeSampler::with_cut_at(t, Importance::Cones, &s, 32)),
        ),
    ];
    for (name, sampler) in &samplers {
        for sh in [&s, &far] {
            let mut min_pmf = f64::INFINITY;
            for k in 0..500 {
                let ls = sampler.sample(sh, (k as f32 + 0.5) / 500.0).expect(name);
                assert_eq!(ls.pmf, sampler.pmf(sh, ls.light), "{name}");
                min_pmf = min_pmf.min(ls.pmf);
            }
            assert!(min_pmf > 0.0 && min_pmf.is_finite(), "{name}: {min_pmf}");
            // The farthest light from the cut's corner still has a pmf > 0.
            let p = sampler.pmf(sh, n as u32 - 1);
            assert!(p > 0.0 && p.is_finite() && p < 1e-3, "{name}: {p}");
        }
    }
}

#[test]
fn baselines_match_their_definitions() {
    let s = Shading::default();
    let u = UniformSampler { count: 7 };
    assert_eq!(u.sample(&s, ONE_MINUS_EPSILON).unwrap().light, 6);
    assert_eq!(u.sample(&s, 0.0).unwrap().light, 0);
    assert_eq!(u.pmf(&s, 3), 1.0 / 7.0);
    let p = PowerSampler::from_weights(&[1.0, 0.0, 3.0]);
    assert_eq!(p.pmf(&s, 0), 0.25);
    assert_eq!(p.pmf(&s, 2), 0.75);
    for k in 0..1000 {
        let ls = p.sample(&s, k as f32 / 1000.0).unwrap();
        assert_ne!(ls.light, 1);
    }
    // u·n landing exactly on a zero-weight light's entry (v = 0, q = 0)
    // must take the alias: 1/3 in f32 times 3 rounds to 1.0.
    assert_eq!(p.sample(&s, 1.0 / 3.0).unwrap().light, 2);
    let q = PowerSampler::from_weights(&[0.0, 1.0]);
    assert_eq!(q.sample(&s, 0.0).unwrap().light, 1);
}

/// Vose's table over random weights with zeros, including the entries
/// rounding leaves over: an entry reaches its own light only if that light
/// has weight (q > 0), and its alias only if the alias has weight (q < 1);
/// and the table reproduces the pmf exactly as a mixture: Σ over entries
/// of q_i·[own = j] + (1 − q_i)·[alias = j], divided by n, is w_j / Σ w
/// within f32 rounding of the q's (n · 2⁻²⁴ relative per entry).
#[test]
fn alias_table_never_reaches_a_zero_weight_light() {
    let mut rng = StdRng::seed_from_u64(23);
    for case in 0..20_000 {
        let n = rng.random_range(1..40usize);
        let weights: Vec<f32> = (0..n)
            .map(|_| {
                if rng.random_bool(0.3) {
                    0.0
                } else {
                    // Magnitudes over many octaves, so that rounding in the
                    // table's f64 sums leaves entries over.
                    rng.random_range(0.0f32..1.0) * 10f32.powi(rng.random_range(-3..4))
                }
            })
            .collect();
        let total: f64 = weights.iter().map(|&w| w as f64).sum();
        let p = PowerSampler::from_weights(&weights);
        if total <= 0.0 {
            assert!(p.table.is_empty(), "case {case}");
            continue;
        }
        let mut mix = vec![0.0f64; n];
        for (i, e) in p.table.iter().enumerate() {
            let a = e.alias as usize;
            assert!(
                e.q <= 0.0 || weights[i] > 0.0,
                "case {case}: entry {i} keeps its zero-weight light (q = {}) in {weights:?}",
                e.q
            );
            assert!(
                e.q >= 1.0 || weights[a] > 0.0,
                "case {case}: entry {i} aliases zero-weight light {a} in {weights:?}"
            );
            mix[i] += e.q as f64;
            mix[a] += 1.0 - e.q as f64;
        }
        for j in 0..n {
            let want = weights[j] as f64 / total;
            let got = mix[j] / n as f64;
            assert!(
                (got - want).abs()
                    <= 4.0 * n as f64 * f64::from(f32::EPSILON) * want.max(1.0 / n as f64),
                "case {case}: light {j} mixture {got} vs pmf {want}"
            );
        }
    }
}

// ---------------------------------------------------------------- cones

/// `n` one-sided triangles: half facing roughly up (a ceiling of panels,
/// normals within ~35° of +y), half facing anywhere, so that the trees'
/// cones range from narrow to the whole sphere.
fn random_triangles(rng: &mut StdRng, n: usize) -> Vec<LightPrim> {
    (0..n)
        .map(|i| {
            let c = Vec3::new(
                rng.random_range(-5.0..5.0),
                rng.random_range(-5.0..5.0),
                rng.random_range(-5.0..5.0),
            );
            let normal = if i % 2 == 0 {
                (Vec3::Y + random_unit(rng) * 0.6).normalize()
            } else {
                random_unit(rng)
            };
            let t = normal.any_orthonormal_vector();
            let b = normal.cross(t);
            let size = rng.random_range(0.05..0.5);
            let e = Vec3::splat(rng.random_range(0.5..5.0));
            // Counter-clockwise about `normal`: (p1 − p0) × (p2 − p0) ∥ normal.
            LightPrim::triangle(c, c + t * size, c + b * size, e)
        })
        .collect()
}

/// Angle between two unit vectors (well conditioned near 0 and π).
fn angle(u: Vec3, v: Vec3) -> f32 {
    u.cross(v).length().atan2(u.dot(v))
}

/// Every node's cone holds the emission direction of every light below it
/// (triangle and VPL normals within θ_o of the axis; points only under a
/// whole-sphere cone; points and VPLs set the `points` flag), checked leaf
/// by leaf up to the root.
fn check_cones_bound_their_lights<T: LightTree>(prims: &[LightPrim], t: &T, what: &str) {
    assert_eq!(t.light_count() as usize, prims.len(), "{what}");
    for light in 0..prims.len() as u32 {
        let prim = &prims[light as usize];
        // The emission axis: a VPL's normal, a triangle's face normal.
        let normal = if prim.kind == mdas::lights::KIND_VPL {
            Vec3::from(prim.p1)
        } else {
            (Vec3::from(prim.p1) - Vec3::from(prim.p0))
                .cross(Vec3::from(prim.p2) - Vec3::from(prim.p0))
                .normalize()
        };
        let mut node = t.leaf_of_light(light);
        while let Some(x) = node {
            let c = &t.cones()[x];
            if prim.kind == mdas::lights::KIND_POINT {
                assert!(c.is_sphere(), "{what}: node {x} over a point light: {c:?}");
                assert_eq!(c.points, 1, "{what}: node {x} over a point light");
            } else if prim.kind == mdas::lights::KIND_VPL && c.points != 1 {
                panic!("{what}: node {x} over a VPL without the points flag");
            } else if !c.is_sphere() {
                let spread = c.sin_o.atan2(c.cos_o);
                let a = angle(Vec3::from(c.axis), normal);
                assert!(
                    a <= spread,
                    "{what}: light {light} at {a} rad from node {x}'s axis, spread {spread}"
                );
            }
            if let Some((l, r)) = t.children(x) {
                for child in [l, r] {
                    assert!(c.contains(&t.cones()[child], 0.0), "{what}: node {x}");
                }
            }
            node = t.parent(x);
        }
    }
}

#[test]
fn cones_bound_every_light_below() {
    let mut rng = StdRng::seed_from_u64(21);
    for n in [1, 2, 7, 300, 4000] {
        let mut prims = random_triangles(&mut rng, n);
        let tris = prims.clone();
        prims.extend(random_scene(&mut rng, n / 4));
        for (what, set) in [("triangles", &tris), ("mixed", &prims)] {
            let t = perfect::build(set).unwrap();
            check_cones_bound_their_lights(set, &t, &format!("perfect, {n} {what}"));
            for cost in [Cost::Sah, Cost::Saoh] {
                let b = bvh::build(set, cost).unwrap();
                check_cones_bound_their_lights(set, &b, &format!("{cost:?}, {n} {what}"));
            }
        }
    }
    // A ceiling of panels all facing down: every cone stays narrow.
    let panels: Vec<_> = (0..256)
        .map(|i| {
            let c = Vec3::new((i % 16) as f32, 3.0, (i / 16) as f32);
            LightPrim::triangle(c, c + Vec3::X * 0.5, c + Vec3::Z * 0.5, Vec3::ONE)
        })
        .collect();
    let t = perfect::build(&panels).unwrap();
    let root = t.cones[0];
    assert!(angle(Vec3::from(root.axis), -Vec3::Y) < 1e-6, "{root:?}");
    let spread = root.sin_o.atan2(root.cos_o);
    // Widened by SLACK once per level (9 levels) and no more.
    assert!(
        spread > 0.0 && spread <= 10.0 * mdas::lights::cone::SLACK,
        "{spread}"
    );
}

#[test]
fn cone_unions_contain_both_cones() {
    let mut rng = StdRng::seed_from_u64(22);
    for i in 0..20_000 {
        let cone = |rng: &mut StdRng| {
            let theta: f32 = match i % 4 {
                0 => 0.0,
                1 => rng.random_range(0.0..1e-3),
                _ => rng.random_range(0.0..std::f32::consts::PI),
            };
            mdas::lights::LightCone {
                axis: random_unit(rng).into(),
                cos_o: theta.cos(),
                sin_o: theta.sin(),
                ..mdas::lights::LightCone::SPHERE
            }
        };
        let (a, b) = (cone(&mut rng), cone(&mut rng));
        let u = a.union(&b);
        assert!(
            u.contains(&a, 0.0) && u.contains(&b, 0.0),
            "{a:?} ∪ {b:?} = {u:?}"
        );
        // Never wider than the two cones side by side need (plus slack).
        let (ta, tb) = (a.sin_o.atan2(a.cos_o), b.sin_o.atan2(b.cos_o));
        let need = ((ta + tb + angle(Vec3::from(a.axis), Vec3::from(b.axis))) / 2.0)
            .max(ta)
            .max(tb);
        if !u.is_sphere() {
            let got = u.sin_o.atan2(u.cos_o);
            assert!(got <= need + 1e-4, "{a:?} ∪ {b:?}: {got} > {need}");
        }
    }
}

/// The cone kinds give pmf 0 to every triangle the shading point sees from
/// behind by more than twice its box's half-diagonal r (the bound looks
/// from the box's centre, up to r off the triangle's plane, at a sphere of
/// radius r) and pmf > 0 to every triangle that can light it (in front of its
/// plane, some vertex above the shading point's tangent plane); the
/// cone-free kinds give the back-facing ones a positive pmf.
#[test]
fn cone_kinds_skip_lights_facing_away() {
    let mut rng = StdRng::seed_from_u64(23);
    let prims = random_triangles(&mut rng, 400);
    let mut away_total = 0;
    for _ in 0..12 {
        let s = random_shading(&mut rng);
        let mut rep = s;
        rep.p += Vec3::new(0.2, 0.1, -0.3);
        let classes: Vec<(bool, bool)> = prims
            .iter()
            .map(|p| {
                let (a, b, c) = (Vec3::from(p.p0), Vec3::from(p.p1), Vec3::from(p.p2));
                let normal = (b - a).cross(c - a).normalize();
                let centre = p.centroid();
                let r = 0.5 * (p.bounds_max() - p.bounds_min()).length();
                let h = normal.dot(s.p - centre);
                let above = [a, b, c].iter().any(|v| s.n.dot(*v - s.p) > 1e-4);
                let live = h > 1e-4 && above;
                // The bound looks from the box's centre, up to r off the
                // plane, at a sphere of radius r: behind by more than 2r.
                let away = h < -(2.01 * r + 1e-3);
                (live, away)
            })
            .collect();
        away_total += classes.iter().filter(|c| c.1).count();
        for kind in SamplerKind::PICKERS {
            if kind.uses_cut() && kind != SamplerKind::TreeCone && kind != SamplerKind::Unbalanced
                || kind.is_biased()
            {
                continue;
            }
            let sampler = new_sampler(kind, &prims, Some((&rep, 16)));
            let mut away_positive = 0;
            for (i, &(live, away)) in classes.iter().enumerate() {
                let pmf = sampler.pmf(&s, i as u32);
                if live {
                    assert!(pmf > 0.0, "{kind}: live light {i} has pmf 0");
                }
                if away {
                    if kind.uses_cones() {
                        assert_eq!(pmf, 0.0, "{kind}: light {i} faces away");
                    }
                    away_positive += (pmf > 0.0) as usize;
                }
            }
            if matches!(kind, SamplerKind::Uniform | SamplerKind::Power) {
                assert_eq!(away_positive, classes.iter().filter(|c| c.1).count());
            }
        }
    }
    assert!(away_total > 500, "too few back-facing cases: {away_total}");
}

// ---------------------------------------------------------------- substitute trees

/// The f64 intensity-weighted mean and covariance of `prims` (weights: the
/// tree's scalar intensity).
fn weighted_moments(prims: &[LightPrim]) -> ([f64; 3], [[f64; 3]; 3]) {
    let w: Vec<f64> = prims.iter().map(|p| p.intensity() as f64).collect();
    let total: f64 = w.iter().sum();
    let pos = |p: &LightPrim| p.p0.map(|x| x as f64);
    let mut mean = [0.0; 3];
    for (p, w) in prims.iter().zip(&w) {
        for (m, x) in mean.iter_mut().zip(pos(p)) {
            *m += w * x / total;
        }
    }
    let mut cov = [[0.0; 3]; 3];
    for (p, w) in prims.iter().zip(&w) {
        let d: [f64; 3] = std::array::from_fn(|a| pos(p)[a] - mean[a]);
        for r in 0..3 {
            for c in 0..3 {
                cov[r][c] += w * d[r] * d[c] / total;
            }
        }
    }
    (mean, cov)
}

/// Cone unions over many VPLs that share a normal (walls of a box) stay
/// finite: `θ_d + θ_b − θ_a` rounding to (or just below) 0 once gave 0/0 in
/// the half angle, NaN cones and NaN node importances (found by the
/// substitute-tree tests). Both trees that carry cones are checked.
#[test]
fn cones_over_vpls_sharing_normals_are_finite() {
    for seed in [9, 10, 11] {
        let mut rng = StdRng::seed_from_u64(seed);
        let prims = vpl_walls(&mut rng, 3000);
        let perfect = perfect::build(&prims).unwrap();
        let sst = substitute::build(&prims).unwrap();
        for (what, cones) in [("perfect", &perfect.cones), ("substitute", &sst.tree.cones)] {
            for (i, c) in cones.iter().enumerate() {
                let words = [c.axis[0], c.axis[1], c.axis[2], c.cos_o, c.sin_o, c.cos_e];
                assert!(
                    words.iter().all(|w| w.is_finite()),
                    "seed {seed}: {what} tree node {i}: {c:?}"
                );
            }
        }
    }
}

/// Coplanar VPLs facing one way: the root's substitute has exactly the
/// weighted moments (f64 reference; tolerance: f32 rounding of ~12 merge
/// levels, 1e-5 of the extent for the mean and 1e-4 of the extent² for
/// the covariance), no spread along the normal (σ_z² below 1e-9 of the
/// extent²: the plane y = 2 is exact in f32, only the mean's rounding moves
/// off it), ν = 1 and the summed emission. The root is suitable, so every
/// sample stops there with probability 1.
#[test]
fn substitute_moments_are_exact_for_coplanar_vpls() {
    let mut rng = StdRng::seed_from_u64(31);
    let prims: Vec<_> = (0..1000)
        .map(|_| {
            let p = Vec3::new(
                rng.random_range(-4.0..4.0),
                2.0,
                rng.random_range(-1.0..3.0),
            );
            let e = Vec3::new(rng.random(), rng.random(), rng.random()) * 3.0;
            LightPrim::vpl(p, Vec3::Y, e)
        })
        .collect();
    let t = substitute::build(&prims).unwrap();
    let root = &t.substitutes[0];
    let (mean, cov) = weighted_moments(&prims);
    let extent = 8.0;
    for a in 0..3 {
        assert!(
            (root.mean[a] as f64 - mean[a]).abs() < 1e-5 * extent,
            "mean {a}: {:?} vs {mean:?}",
            root.mean
        );
    }
    let got = root.covariance();
    for r in 0..3 {
        for c in 0..3 {
            assert!(
                (got[r][c] as f64 - cov[r][c]).abs() < 1e-4 * extent * extent,
                "cov[{r}][{c}] {} vs {}",
                got[r][c],
                cov[r][c]
            );
        }
    }
    assert!(
        (root.sigma_z2().abs() as f64) < 1e-9 * extent * extent,
        "{}",
        root.sigma_z2()
    );
    assert!(
        root.nu >= 1.0 - 1e-6 && root.normal == [0.0, 1.0, 0.0],
        "{root:?}"
    );
    let sum = prims
        .iter()
        .fold(Vec3::ZERO, |s, p| s + Vec3::from(p.emission));
    assert!((Vec3::from(root.emission) - sum).abs().max_element() < 1e-4 * sum.max_element());
    let sampler = SstSampler {
        tree: t,
        params: Some(SubstituteParams::default()),
    };
    let sh = Shading {
        p: Vec3::new(0.5, 5.0, 1.0),
        n: -Vec3::Y,
    };
    for u in [0.0, 0.3, ONE_MINUS_EPSILON] {
        assert_eq!(sampler.sample(&sh, u), Some(Stop { node: 0, pmf: 1.0 }));
    }
    // Far below the plane, which emits upward, the cone bound is 0: no
    // stop at all.
    let below = Shading {
        p: Vec3::new(0.5, -100.0, 1.0),
        n: Vec3::Y,
    };
    assert_eq!(sampler.sample(&below, 0.5), None);
}

/// Hard cases: one VPL (the root is its leaf: never a substitute), all
/// VPLs at one point (a zero covariance: the substitute sits exactly
/// there), two facing planes (ν = 0 where they meet: no stop mixes them),
/// dark VPLs (they drop out of the moments and are never reached).
#[test]
fn substitute_hard_cases() {
    let params = Some(SubstituteParams::default());
    let sh = Shading {
        p: Vec3::new(0.3, 0.5, 0.2),
        n: Vec3::ZERO,
    };
    // One VPL.
    let one = [LightPrim::vpl(Vec3::ZERO, Vec3::Y, Vec3::ONE)];
    let s = SstSampler {
        tree: substitute::build(&one).unwrap(),
        params,
    };
    assert_eq!(s.sample(&sh, 0.7), Some(Stop { node: 0, pmf: 1.0 }));
    assert_eq!(LightSampler::sample(&s, &sh, 0.7).unwrap().light, 0);

    // Coincident VPLs: mean exactly the point after the box clamp.
    let at = Vec3::new(1.25, -0.5, 3.0);
    let same: Vec<_> = (0..37)
        .map(|i| LightPrim::vpl(at, Vec3::Z, Vec3::splat(0.1 + i as f32 * 0.01)))
        .collect();
    let t = substitute::build(&same).unwrap();
    assert_eq!(t.substitutes[0].cholesky(), [[0.0; 3]; 3]);
    let (lo, hi) = (
        Vec3::from(t.tree.nodes[0].min),
        Vec3::from(t.tree.nodes[0].max),
    );
    for u in [[0.0, 0.5, 0.9], [0.999, 0.001, 0.5]] {
        assert_eq!(t.substitutes[0].sample_position(u, lo, hi), at);
    }
    let s = SstSampler { tree: t, params };
    let front = Shading {
        p: at + Vec3::new(0.2, 0.1, 2.0),
        n: -Vec3::Z,
    };
    assert_eq!(s.sample(&front, 0.4), Some(Stop { node: 0, pmf: 1.0 }));

    // Two facing planes, y = 0 facing up and y = 1 facing down.
    let mut rng = StdRng::seed_from_u64(5);
    let planes: Vec<_> = (0..512)
        .map(|i| {
            let (x, z) = (rng.random_range(0.0..1.0), rng.random_range(0.0..1.0));
            if i % 2 == 0 {
                LightPrim::vpl(Vec3::new(x, 0.0, z), Vec3::Y, Vec3::ONE)
            } else {
                LightPrim::vpl(Vec3::new(x, 1.0, z), -Vec3::Y, Vec3::ONE)
            }
        })
        .collect();
    let t = substitute::build(&planes).unwrap();
    assert_eq!(t.substitutes[0].nu, 0.0);
    let s = SstSampler { tree: t, params };
    let (stops, dead) = s.stops(&sh);
    let total: f64 = stops.iter().map(|st| st.pmf).sum();
    assert!((total + dead - 1.0).abs() < 1e-6, "{total} + {dead}");
    let mut substitutes = 0;
    for st in &stops {
        // The lights below a stop all lie on one plane.
        let mut ys = Vec::new();
        let mut stack = vec![st.node];
        while let Some(k) = stack.pop() {
            match s.tree.children(k) {
                Some((l, r)) => stack.extend([l, r]),
                None if s.tree.leaf_light(k) != NO_LIGHT => {
                    ys.push(planes[s.tree.leaf_light(k) as usize].p0[1])
                }
                None => {}
            }
        }
        assert!(
            ys.iter().all(|&y| y == ys[0]),
            "stop {} mixes the planes",
            st.node
        );
        substitutes += !s.tree.tree.is_leaf(st.node) as u32;
    }
    assert!(substitutes > 0, "no substitute between the planes");

    // Dark VPLs with scattered normals among coplanar bright ones: the
    // root's moments are the bright ones', and it stays suitable.
    let mixed: Vec<_> = (0..300)
        .map(|i| {
            let p = Vec3::new(rng.random_range(0.0..2.0), 0.5, rng.random_range(0.0..2.0));
            if i % 3 == 0 {
                LightPrim::vpl(p + Vec3::Y * 0.7, random_unit(&mut rng), Vec3::ZERO)
            } else {
                LightPrim::vpl(p, Vec3::Y, Vec3::splat(0.5))
            }
        })
        .collect();
    let bright: Vec<_> = mixed
        .iter()
        .copied()
        .filter(|p| p.intensity() > 0.0)
        .collect();
    let t = substitute::build(&mixed).unwrap();
    let (mean, _) = weighted_moments(&bright);
    for (got, want) in t.substitutes[0].mean.iter().zip(mean) {
        assert!((*got as f64 - want).abs() < 1e-5);
    }
    assert!(t.substitutes[0].sigma_z2() < 1e-10);
    assert!(SubstituteParams::default().suitable(&t.substitutes[0], t.tree.nodes[0].intensity));
    let s = SstSampler {
        tree: t,
        params: None,
    };
    for st in s
        .stops(&Shading {
            p: Vec3::new(1.0, 3.0, 1.0),
            n: -Vec3::Y,
        })
        .0
    {
        assert!(mixed[s.tree.leaf_light(st.node) as usize].intensity() > 0.0);
    }
}

/// `sst` on walls of VPLs at 16 shading points: the stop probabilities and
/// the dead-branch probability sum to one, each sample's pmf is exactly `stop_pmf` of its node, and the
/// frequencies of 200,000 draws fit the stop pmfs (chi-square, α = 1e-3/16,
/// a "no stop" cell of the dead-branch probability). `sst_nosub` gives every light the
/// pmf of the `tree_cone` descent from the root over the same tree (it *is*
/// that unbiased sampler) and never stops above a leaf.
#[test]
fn substitute_stops_sum_to_one_and_fit_their_pmfs() {
    let mut rng = StdRng::seed_from_u64(77);
    let prims = vpl_walls(&mut rng, 1500);
    let tree = substitute::build(&prims).unwrap();
    let sst = SstSampler {
        tree: tree.clone(),
        params: Some(SubstituteParams::default()),
    };
    let nosub = SstSampler {
        tree: tree.clone(),
        params: None,
    };
    let cone_tree = TreeSampler::new(tree.clone(), Importance::Cones);
    let mut substitute_mass = 0.0;
    for case in 0..16 {
        let sh = Shading {
            p: Vec3::new(
                rng.random_range(-4.5..4.5),
                rng.random_range(-4.5..4.5),
                rng.random_range(-4.5..4.5),
            ),
            n: random_unit(&mut rng),
        };
        let (stops, dead) = sst.stops(&sh);
        let total: f64 = stops.iter().map(|s| s.pmf).sum();
        assert!(
            (total + dead - 1.0).abs() < 1e-5,
            "case {case}: Σ {total} + dead {dead}"
        );
        for st in &stops {
            assert_eq!(sst.stop_pmf(&sh, st.node), st.pmf, "case {case}");
            if !tree.tree.is_leaf(st.node) {
                substitute_mass += st.pmf / 16.0;
            }
        }
        // Frequencies.
        const M: usize = 200_000;
        let index: std::collections::HashMap<usize, usize> =
            stops.iter().enumerate().map(|(i, s)| (s.node, i)).collect();
        let mut observed = vec![0u64; stops.len() + 1];
        for _ in 0..M {
            let u: f32 = rng.random();
            match sst.sample(&sh, u) {
                Some(st) => {
                    assert_eq!(st.pmf, sst.stop_pmf(&sh, st.node));
                    observed[index[&st.node]] += 1;
                }
                None => observed[stops.len()] += 1,
            }
        }
        let mut expected: Vec<f64> = stops.iter().map(|s| s.pmf * M as f64).collect();
        expected.push(dead * M as f64);
        let (p, dof) = chi_square_p(&observed, &expected);
        assert!(
            p > 1e-3 / 16.0,
            "case {case}: chi-square p = {p} ({dof} dof)"
        );
        // sst_nosub is the cone tree sampler from the root.
        for light in (0..prims.len() as u32).step_by(7) {
            assert_eq!(
                LightSampler::pmf(&nosub, &sh, light),
                cone_tree.pmf(&sh, light),
                "case {case}: light {light}"
            );
        }
        assert!(nosub
            .stops(&sh)
            .0
            .iter()
            .all(|st| tree.tree.is_leaf(st.node)));
    }
    // The walls are planar: substitutes take a real share of the samples.
    assert!(substitute_mass > 0.2, "substitutes take {substitute_mass}");
}

/// Substitute positions follow N(mean, Σ): 20,000 draws of a substitute with
/// a full (correlated) covariance inside a large box have a sample mean
/// within 5 standard errors of `mean` per axis and a sample covariance
/// within 5 standard errors of Σ (SE of a variance σ²·√(2/n), of a
/// covariance √((σᵢ²σⱼ² + σᵢⱼ²)/n) for a Gaussian).
#[test]
fn substitute_positions_follow_their_gaussian() {
    let sub = Substitute {
        mean: [1.0, -2.0, 0.5],
        cov_diag: [0.5, 0.2, 0.01],
        cov_xy: 0.15,
        cov_xz: -0.02,
        cov_yz: 0.01,
        ..Default::default()
    };
    let mut rng = StdRng::seed_from_u64(8);
    const N: usize = 20_000;
    let big = Vec3::splat(100.0);
    let pts: Vec<Vec3> = (0..N)
        .map(|_| sub.sample_position([rng.random(), rng.random(), rng.random()], -big, big))
        .collect();
    let mean = pts.iter().fold(Vec3::ZERO, |s, p| s + *p) / N as f32;
    let want = sub.covariance();
    for a in 0..3 {
        let se = (want[a][a] as f64 / N as f64).sqrt();
        assert!(
            ((mean[a] - sub.mean[a]) as f64).abs() < 5.0 * se,
            "mean {a}: {mean}"
        );
        for b in 0..3 {
            let c: f64 = pts
                .iter()
                .map(|p| ((p[a] - mean[a]) * (p[b] - mean[b])) as f64)
                .sum::<f64>()
                / (N - 1) as f64;
            let w = want[a][b] as f64;
            let se = ((want[a][a] * want[b][b]) as f64 + w * w).sqrt() / (N as f64).sqrt();
            assert!(
                (c - w).abs() < 5.0 * se,
                "cov[{a}][{b}] = {c}, want {w} (se {se})"
            );
        }
    }
    // Clamped to the box.
    let lo = Vec3::new(0.9, -2.1, 0.4);
    let hi = Vec3::new(1.1, -1.9, 0.6);
    for p in
        (0..100).map(|_| sub.sample_position([rng.random(), rng.random(), rng.random()], lo, hi))
    {
        assert!(p.cmpge(lo).all() && p.cmple(hi).all(), "{p}");
    }
}

// ------------------------------------------------ lighting grid hierarchy

mod lgh_oracle {
    //! The CPU oracle of the lighting grid hierarchy (`lights::lgh`):
    //! blending, conservation through the levels, exactness for one light,
    //! the shadow picks' pmf, and the hard cases.
    use super::*;
    use mdas::lights::lgh::{self, Emitter, Lgh, LghGrid, LghParams};
    use mdas::lights::luminance;

    /// Points in a box and VPLs on walls, random colours; every ninth VPL
    /// dark (vpl_walls).
    fn mixed(rng: &mut StdRng, n: usize) -> Vec<LightPrim> {
        let mut prims = vpl_walls(rng, n / 2);
        for _ in 0..n - n / 2 {
            let p = Vec3::new(
                rng.random_range(-4.0..4.0),
                rng.random_range(-4.0..4.0),
                rng.random_range(-4.0..4.0),
            );
            let c = Vec3::new(rng.random(), rng.random(), rng.random());
            prims.push(LightPrim::point(p, c));
        }
        prims
    }

    /// The blending functions form a partition of unity at every distance,
    /// including the breakpoints r/2, r and 2r of every level, for any
    /// level count, α and finest level, and each lies in [0, 1]: the sum
    /// is exact up to the rounding of 2d/r − 1 + 2 − d/r (two ulps, 1e-6).
    #[test]
    fn blend_weights_sum_to_one() {
        for levels in 1..=6 {
            let grid = LghGrid {
                lo: Vec3::ZERO,
                levels,
                h1: 0.37,
                inv_h1: 1.0 / 0.37,
            };
            for first in [0, 1] {
                for alpha in [0.25f32, 0.5, 1.0, 2.0, 3.7] {
                    let mut ds: Vec<f32> = (0..4000).map(|i| i as f32 * 0.01).collect();
                    for l in 0..=levels {
                        let r = alpha * grid.h(l);
                        ds.extend([0.5 * r, r, 2.0 * r]);
                    }
                    for d in ds {
                        let mut sum = 0.0;
                        for l in first..=levels {
                            let b = grid.blend(alpha, first, l, d);
                            assert!((0.0..=1.0).contains(&b), "B_{l}({d}) = {b}");
                            sum += b;
                        }
                        assert!(
                            (sum - 1.0).abs() <= 1e-6,
                            "L = {levels}, first {first}, α = {alpha}, d = {d}: Σ B = {sum}"
                        );
                    }
                }
            }
        }
    }

    /// Per-level sums of the grid lights in f64.
    #[derive(Default)]
    struct Totals {
        e: [f64; 3],
        w: f64,
        first: [f64; 3],
        second: [f64; 3],
        n: [f64; 3],
        iso: f64,
        count: usize,
    }

    fn level_totals(h: &Lgh, level: u32) -> Totals {
        let g = &h.grid;
        let r = g.res(level);
        let mut t = Totals::default();
        for z in 0..r {
            for y in 0..r {
                for x in 0..r {
                    let Some(gl) = h.light_at(level, [x, y, z]) else {
                        continue;
                    };
                    assert_eq!(gl.level, level);
                    assert_eq!(gl.vertex, g.vertex_index(level, [x, y, z]));
                    assert!(gl.w > 0.0);
                    let v = g.vertex_pos(level, [x, y, z]).as_dvec3();
                    t.count += 1;
                    t.w += gl.w as f64;
                    t.iso += gl.iso as f64;
                    for a in 0..3 {
                        let (p, q) = (gl.p[a] as f64, gl.q[a] as f64);
                        t.e[a] += gl.e[a] as f64;
                        t.n[a] += gl.n[a] as f64;
                        // Moments about the origin from moments about v.
                        t.first[a] += p + gl.w as f64 * v[a];
                        t.second[a] += q + 2.0 * v[a] * p + gl.w as f64 * v[a] * v[a];
                    }
                }
            }
        }
        t
    }

    /// Every level carries all the light: Σ e = Σ I, Σ W = Σ ‖I‖, and the
    /// first and second moments Σ ω p and Σ ω p² (trilinear weights sum to
    /// one and reproduce linear functions; the moves between vertices are
    /// exact in real arithmetic), the VPLs' Σ ω n and the points' Σ ω.
    /// Tolerance: 1e-4 relative to each total's scale (f32 sums of ~10^4
    /// terms through ≤ 6 levels: measured ≤ 2e-6).
    #[test]
    fn every_level_conserves_intensity_and_moments() {
        let mut rng = StdRng::seed_from_u64(41);
        for (n, levels) in [(3000, 0), (3000, 5), (257, 2), (20, 1)] {
            let prims = mixed(&mut rng, n);
            let h = lgh::build(&prims, levels).unwrap();
            let mut want = Totals::default();
            let mut scale2 = 0.0;
            for l in &prims {
                let i = Vec3::from(l.emission).as_dvec3();
                let w = luminance(Vec3::from(l.emission)) as f64;
                if w <= 0.0 {
                    continue;
                }
                let p = Vec3::from(l.p0).as_dvec3();
                want.w += w;
                for a in 0..3 {
                    want.e[a] += i[a];
                    want.first[a] += w * p[a];
                    want.second[a] += w * p[a] * p[a];
                    if l.kind == mdas::lights::KIND_VPL {
                        want.n[a] += w * l.p1[a] as f64;
                    }
                }
                if l.kind != mdas::lights::KIND_VPL {
                    want.iso += w;
                }
                scale2 += w * p.length_squared();
            }
            let scale1 = scale2.sqrt() * want.w.sqrt();
            for level in 1..=h.grid.levels {
                let t = level_totals(&h, level);
                let what = format!("{n} lights, L = {}, level {level}", h.grid.levels);
                assert!(t.count > 0, "{what}: no grid light");
                if level == h.grid.levels {
                    assert!(t.count <= 8, "{what}: {} top lights", t.count);
                }
                let close = |a: f64, b: f64, scale: f64, name: &str| {
                    assert!(
                        (a - b).abs() <= 1e-4 * scale,
                        "{what}: {name} {a} vs {b} (scale {scale})"
                    );
                };
                close(t.w, want.w, want.w, "W");
                close(t.iso, want.iso, want.w, "iso");
                for a in 0..3 {
                    close(t.e[a], want.e[a], want.e.iter().sum(), "e");
                    close(t.first[a], want.first[a], scale1, "Σ ω p");
                    close(t.second[a], want.second[a], scale2, "Σ ω p²");
                    close(t.n[a], want.n[a], want.w, "Σ ω n");
                }
            }
        }
    }

    /// One light (a point or a VPL): every level's grid lights sit at the
    /// light, so the blended sum U equals the light's own contribution
    /// at any shading point, for any α and finest level, without the
    /// paper's distance clamp (relative 1e-5: the centres are the light's
    /// position up to f32 rounding).
    #[test]
    fn one_light_is_exact_at_every_level() {
        let mut rng = StdRng::seed_from_u64(42);
        let lights = [
            LightPrim::point(Vec3::new(0.3, 1.7, -2.2), Vec3::new(2.0, 1.0, 0.5)),
            LightPrim::vpl(
                Vec3::new(-1.0, 0.25, 0.5),
                Vec3::new(0.0, 0.6, 0.8),
                Vec3::new(1.0, 3.0, 2.0),
            ),
        ];
        for l in lights {
            for levels in [1, 3, 7] {
                let h = lgh::build(&[l], levels).unwrap();
                for level in 1..=levels {
                    let r = h.grid.res(level);
                    for z in 0..r {
                        for y in 0..r {
                            for x in 0..r {
                                if let Some(g) = h.light_at(level, [x, y, z]) {
                                    let c = g.centre(h.grid.vertex_pos(level, [x, y, z]));
                                    assert!((c - Vec3::from(l.p0)).length() < 1e-5);
                                }
                            }
                        }
                    }
                }
                for _ in 0..200 {
                    let x = Vec3::new(
                        rng.random_range(-6.0..6.0),
                        rng.random_range(-6.0..6.0),
                        rng.random_range(-6.0..6.0),
                    );
                    let n = unit(&mut rng);
                    let params = LghParams {
                        levels,
                        alpha: rng.random_range(0.3..3.0),
                        level0: rng.random(),
                        shadow_samples: 4,
                        clamp: 0.0,
                    };
                    let u: Vec3 = h
                        .candidates(&[l], &params, 0.0, x, n)
                        .iter()
                        .map(|c| c.f)
                        .sum();
                    let exact = Emitter::light(&l, 0.0).eval(x, n);
                    assert!(
                        (u - exact).length() <= 1e-5 * exact.length() + 1e-12,
                        "L = {levels}: U {u} vs {exact} at {x}"
                    );
                }
            }
        }
    }

    fn unit(rng: &mut StdRng) -> Vec3 {
        loop {
            let v = Vec3::new(
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
            );
            if v.length_squared() > 1e-3 && v.length_squared() <= 1.0 {
                return v.normalize();
            }
        }
    }

    /// Choosing one of the S stratified picks uniformly is choosing a
    /// candidate with probability ‖f‖/F: chi-square over 200,000 draws at
    /// three shading points (cells with expected count < 5 pooled),
    /// p > 1e-4 each.
    #[test]
    fn shadow_picks_follow_their_pmf() {
        let mut rng = StdRng::seed_from_u64(43);
        let prims = mixed(&mut rng, 1500);
        let h = lgh::build(&prims, 0).unwrap();
        let params = LghParams::default();
        for x in [
            Vec3::ZERO,
            Vec3::new(3.0, -4.5, 1.0),
            Vec3::new(-4.9, 2.0, 4.9),
        ] {
            let n = Vec3::new(0.3, 0.9, 0.1).normalize();
            let cands = h.candidates(&prims, &params, 0.0, x, n);
            assert!(cands.len() > 20, "{} candidates", cands.len());
            let total: f64 = cands.iter().map(|c| c.lum as f64).sum();
            const M: u64 = 200_000;
            let mut counts = vec![0u64; cands.len()];
            for _ in 0..M {
                let picks = lgh::pick(&cands, 4, rng.random());
                assert_eq!(picks.len(), 4);
                counts[picks[rng.random_range(0..4usize)]] += 1;
            }
            let expected: Vec<f64> = cands
                .iter()
                .map(|c| M as f64 * c.lum as f64 / total)
                .collect();
            let (p, dof) = chi_square_p(&counts, &expected);
            assert!(p > 1e-4, "at {x}: chi-square p = {p} ({dof} dof)");
        }
    }

    /// Hard cases: no lights; all lights at one point (one cell, zero
    /// extent); dark lights; VPLs on a plane (a zero-variance axis);
    /// shading points on a light and on a grid vertex; an emissive triangle
    /// (not a grid light).
    #[test]
    fn hard_cases() {
        // No lights: one level, no grid light, no candidate.
        let h = lgh::build(&[], 0).unwrap();
        assert!(h.lights.is_empty());
        assert!(h
            .candidates(&[], &LghParams::default(), 0.0, Vec3::ZERO, Vec3::Y)
            .is_empty());

        // 100 lights at one point, some dark: U is their sum exactly (the
        // grid lights all sit at the point).
        let p = Vec3::new(1.0, 2.0, 3.0);
        let prims: Vec<LightPrim> = (0..100)
            .map(|i| {
                LightPrim::point(
                    p,
                    Vec3::splat(if i % 7 == 0 { 0.0 } else { 0.01 * i as f32 }),
                )
            })
            .collect();
        let h = lgh::build(&prims, 3).unwrap();
        assert!(h.lights.iter().all(|g| g.w > 0.0));
        let x = Vec3::new(0.0, 0.0, 0.0);
        let n = (p - x).normalize();
        let exact: Vec3 = prims
            .iter()
            .map(|l| Emitter::light(l, 0.0).eval(x, n))
            .sum();
        // Without the paper's clamp (it moves grid lights' 1/d²).
        let unclamped = LghParams {
            clamp: 0.0,
            ..LghParams::default()
        };
        let u: Vec3 = h
            .candidates(&prims, &unclamped, 0.0, x, n)
            .iter()
            .map(|c| c.f)
            .sum();
        assert!(
            (u - exact).length() <= 1e-5 * exact.length(),
            "{u} vs {exact}"
        );
        assert!(h.lights.iter().all(|g| {
            let e = g.emitter(Vec3::ZERO, 0.0, 0.0);
            e.sigma.is_finite() && e.sigma.max_element() < 1e-3
        }));

        // VPLs on the plane y = 0.5, facing up: σ_y vanishes (never NaN).
        let mut rng = StdRng::seed_from_u64(44);
        let plane: Vec<LightPrim> = (0..2000)
            .map(|_| {
                let q = Vec3::new(
                    rng.random_range(-3.0..3.0),
                    0.5,
                    rng.random_range(-3.0..3.0),
                );
                LightPrim::vpl(q, Vec3::Y, Vec3::splat(0.1))
            })
            .collect();
        let h = lgh::build(&plane, 0).unwrap();
        for level in 1..=h.grid.levels {
            let r = h.grid.res(level);
            for z in 0..r {
                for y in 0..r {
                    for x in 0..r {
                        if let Some(g) = h.light_at(level, [x, y, z]) {
                            let e = g.emitter(h.grid.vertex_pos(level, [x, y, z]), 0.0, 0.0);
                            assert!(e.sigma.is_finite() && e.pos.is_finite());
                            assert!(e.sigma.y <= 1e-4 * h.grid.h(level), "σ_y {}", e.sigma.y);
                            assert!((e.pos.y - 0.5).abs() < 1e-5);
                            assert!((e.n - Vec3::Y).length() < 1e-5 && e.iso == 0.0);
                        }
                    }
                }
            }
        }
        // Shading on a light and on a grid vertex: finite, non-negative.
        let params = LghParams {
            level0: true,
            ..LghParams::default()
        };
        for x in [
            Vec3::from(plane[0].p0),
            h.grid.vertex_pos(1, [1, 0, 1]),
            h.grid.lo,
        ] {
            for c in h.candidates(&plane, &params, 0.0, x, Vec3::Y) {
                assert!(c.f.is_finite() && c.f.min_element() >= 0.0, "{c:?}");
            }
        }

        // Triangles are not grid lights: they sort after every cell and
        // leave the grid as it is without them.
        let tri = LightPrim::triangle(Vec3::splat(50.0), Vec3::X, Vec3::Y, Vec3::ONE);
        let with: Vec<LightPrim> = std::iter::once(tri).chain(plane.iter().copied()).collect();
        let a = lgh::build(&with, 0).unwrap();
        let b = lgh::build(&plane, 0).unwrap();
        assert_eq!((a.grid, &a.lights, &a.index), (b.grid, &b.lights, &b.index));
        assert_eq!(a.sorted.last(), Some(&0));
        let shifted: Vec<u32> = b.sorted.iter().map(|i| i + 1).collect();
        assert_eq!(&a.sorted[..plane.len()], &shifted[..]);
    }
}
