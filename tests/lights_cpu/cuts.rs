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
        let floor2 = mdas::lights::importance::cut_key_floor2(&t.nodes()[0]);
        let key = |c: usize| mdas::lights::importance::cut_key(&imp.of(t, c, s), floor2);
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
/// intensity padding in the perfect trees; nodes whose W is 0 at the point
/// have key 0 and tie) and on a symmetric one with an exact tie between
/// the root's children.
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
            let floor2 = mdas::lights::importance::cut_key_floor2(&t.nodes[0]);
            let key = |c| mdas::lights::importance::cut_key(&imp.of(&t, c, &s), floor2);
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
    let floor2 = mdas::lights::importance::cut_key_floor2(&t.nodes[0]);
    let key = |c| mdas::lights::importance::cut_key(&Importance::Plain.of(&t, c, &s), floor2);
    assert_eq!(key(1), key(2), "the case needs a tie");
    let mut c = select_cut(&t, Importance::Plain, &s, 3);
    c.sort_unstable();
    assert_eq!(c, vec![2, 3, 4]);
}

/// The cut samplers of every kind with cuts (the paper's estimator draws
/// one light per cut node): the perfect tree with plain importance and
/// with cones, the SAOH BVH with cones, the SAH BVH without, and the
/// two-level tree over three groups; each with a greedy cut of `size` at
/// `rep`.
fn cut_estimators(
    prims: &[LightPrim],
    rep: &Shading,
    size: u32,
) -> Vec<(String, Box<dyn Subtrees>)> {
    let perfect = perfect::build(prims).unwrap();
    let two = two_level::build(prims, &chunks(prims.len(), 3)).unwrap();
    vec![
        (
            "tree".into(),
            Box::new(TreeSampler::with_cut_at(
                perfect.clone(),
                Importance::Plain,
                rep,
                size,
            )),
        ),
        (
            "tree_cone".into(),
            Box::new(TreeSampler::with_cut_at(
                perfect,
                Importance::Cones,
                rep,
                size,
            )),
        ),
        (
            "unbalanced".into(),
            Box::new(TreeSampler::with_cut_at(
                bvh::build(prims, Cost::Saoh).unwrap(),
                Importance::Cones,
                rep,
                size,
            )),
        ),
        (
            "unbalanced_nocone".into(),
            Box::new(TreeSampler::with_cut_at(
                bvh::build(prims, Cost::Sah).unwrap(),
                Importance::Plain,
                rep,
                size,
            )),
        ),
        (
            "tree2".into(),
            Box::new(TreeSampler::with_cut_at(two, Importance::Cones, rep, size)),
        ),
    ]
}

/// The paper's estimator's view of a cut sampler, for trait objects.
trait Subtrees {
    fn cut_len(&self) -> usize;
    /// The probability that the descent from cut node `j` ends on a dead
    /// branch (both children W = 0) or a padding leaf, from the child
    /// probabilities in f64.
    fn dead_mass(&self, s: &Shading, j: usize) -> f64;
    fn sample_subtree(&self, s: &Shading, j: usize, u: f32) -> Option<mdas::lights::LightSample>;
    fn subtree_pmf(&self, s: &Shading, light: u32) -> Option<(usize, f64)>;
}

impl<T: LightTree> Subtrees for TreeSampler<T> {
    fn cut_len(&self) -> usize {
        self.cut.len()
    }
    fn dead_mass(&self, s: &Shading, j: usize) -> f64 {
        fn go<T: LightTree>(t: &TreeSampler<T>, s: &Shading, node: usize) -> f64 {
            let Some((l, r)) = t.tree.children(node) else {
                // A padding leaf (a cut node of the perfect tree's padding).
                return if t.tree.leaf_light(node) == NO_LIGHT {
                    1.0
                } else {
                    0.0
                };
            };
            let imp = |n| t.importance.of(&t.tree, n, s);
            match mdas::lights::importance::p_left(&imp(l), &imp(r)) {
                None => 1.0,
                Some(p) => {
                    let p = p as f64;
                    let a = if p > 0.0 { p * go(t, s, l) } else { 0.0 };
                    let b = if p < 1.0 {
                        (1.0 - p) * go(t, s, r)
                    } else {
                        0.0
                    };
                    a + b
                }
            }
        }
        go(self, s, self.cut[j] as usize)
    }
    fn sample_subtree(&self, s: &Shading, j: usize, u: f32) -> Option<mdas::lights::LightSample> {
        TreeSampler::sample_subtree(self, s, j, u)
    }
    fn subtree_pmf(&self, s: &Shading, light: u32) -> Option<(usize, f64)> {
        TreeSampler::subtree_pmf(self, s, light)
    }
}

/// One light per subtree: a draw from subtree j is a light below cut node
/// j, with exactly the pmf `subtree_pmf` gives it; within each subtree the
/// pmfs sum to 1 minus the probability of a dead branch (`dead_mass`, to
/// 1e-6), and the stratified draws that draw nothing are at most that
/// probability plus their resolution (M = 4096 strata: the set of u that
/// draw nothing is a union of intervals, and each end of one seen can move
/// the measured fraction by at most 1/M). Dead intervals narrower than a
/// stratum may go unseen, and with the box bound (F = 0 for boxes below
/// the tangent plane) there can be several, so the fraction is not
/// bounded from below.
#[test]
fn each_cut_subtree_samples_its_own_lights_with_their_pmf() {
    let mut rng = StdRng::seed_from_u64(21);
    let m = 4096u32;
    for n in [7, 60, 300] {
        let prims = random_scene(&mut rng, n);
        for _ in 0..3 {
            let rep = random_shading(&mut rng);
            let s = Shading {
                p: rep.p + Vec3::splat(0.3),
                n: rep.n,
            };
            for size in [4, 16] {
                for (name, est) in cut_estimators(&prims, &rep, size) {
                    let mut sums = vec![0.0f64; est.cut_len()];
                    for l in 0..n as u32 {
                        if let Some((j, p)) = est.subtree_pmf(&s, l) {
                            assert!((0.0..=1.0 + 1e-6).contains(&p), "{name}: pmf {p}");
                            sums[j] += p;
                        }
                    }
                    for (j, &sum) in sums.iter().enumerate() {
                        let (mut none, mut ends, mut last) = (0u32, 0u32, false);
                        for k in 0..m {
                            let u = (k as f32 + 0.5) / m as f32;
                            let drawn = est.sample_subtree(&s, j, u);
                            ends += (drawn.is_none() != last) as u32;
                            last = drawn.is_none();
                            match drawn {
                                Some(ls) => {
                                    assert_eq!(
                                        est.subtree_pmf(&s, ls.light),
                                        Some((j, ls.pmf)),
                                        "{name}/cut{size}: subtree {j}, u = {u}"
                                    );
                                    assert!(ls.pmf > 0.0, "{name}: a light of pmf 0 drawn");
                                }
                                None => none += 1,
                            }
                        }
                        let dead = est.dead_mass(&s, j);
                        assert!(
                            (sum + dead - 1.0).abs() <= 1e-6,
                            "{name}/cut{size}: subtree {j}: Σ pmf {sum} + P(dead) {dead} != 1"
                        );
                        let seen = none as f64 / m as f64;
                        assert!(
                            seen <= dead + (ends + 1) as f64 / m as f64 + 1e-9,
                            "{name}/cut{size}: subtree {j}: drew none {seen}, P(dead) {dead}"
                        );
                    }
                }
            }
        }
    }
}

/// The paper's estimator Σ_j f(l_j)/pmf_j(l_j) is unbiased for Σ f over
/// the lights it can draw (pmf > 0), with the GPU's random numbers:
/// subtree 0 uses u, subtree j > 0 u rotated by a number hashed from the pixel and j
/// (`subtree_random`, `ml_subtree_u`). f is a random positive weight per
/// light; 65,536 stratified u; the mean must lie within 6 standard errors
/// (the estimates are i.i.d. only in their stratum, which makes the
/// standard error conservative).
#[test]
fn the_cut_estimator_is_unbiased() {
    use mdas::lights::tree::cut::subtree_random;
    let mut rng = StdRng::seed_from_u64(22);
    let m = 65_536u32;
    for n in [60, 300] {
        let prims = random_scene(&mut rng, n);
        let f: Vec<f64> = (0..n).map(|_| rng.random_range(0.1..10.0)).collect();
        for _ in 0..2 {
            let rep = random_shading(&mut rng);
            for (name, est) in cut_estimators(&prims, &rep, 8) {
                let live: f64 = (0..n as u32)
                    .filter(|&l| est.subtree_pmf(&rep, l).is_some_and(|(_, p)| p > 0.0))
                    .map(|l| f[l as usize])
                    .sum();
                if live == 0.0 {
                    continue;
                }
                let xs: Vec<f64> = (0..m)
                    .map(|k| {
                        let u = (k as f32 + 0.5) / m as f32;
                        (0..est.cut_len())
                            .filter_map(|j| {
                                let uj = subtree_random([u, 0.5, 0.5, 0.5], [3, 5], j as u32)[0];
                                est.sample_subtree(&rep, j, uj)
                            })
                            .map(|ls| f[ls.light as usize] / ls.pmf)
                            .sum::<f64>()
                            / live
                    })
                    .collect();
                let (mean, se) = mean_se(&xs);
                assert!(
                    (mean - 1.0).abs() <= 6.0 * se + 1e-9,
                    "{name} ({n} lights): E[Σ f/pmf]/Σf = {mean} ± {se}"
                );
            }
        }
    }
}

/// The contribution of light `l` at `s` up to the BSDF: `I·cos θ_x/d²` for
/// a point, `I·cos θ_v·cos θ_x/max(d², 10⁻⁴)` for a VPL (normal `p1`), 0
/// at `d = 0`; `cos θ_x = max(0, n·ω)`.
fn contribution(l: &LightPrim, s: &Shading) -> f64 {
    let d = (Vec3::from(l.p0) - s.p).as_dvec3();
    let d2 = d.length_squared();
    if d2 == 0.0 {
        return 0.0;
    }
    let w = d / d2.sqrt();
    let cos_x = s.n.as_dvec3().dot(w).max(0.0);
    let i = l.intensity() as f64;
    if l.kind == mdas::lights::KIND_VPL {
        let cos_v = Vec3::from(l.p1).as_dvec3().dot(-w).max(0.0);
        i * cos_v * cos_x / d2.max(1e-4)
    } else {
        i * cos_x / d2
    }
}

/// Issue 66 item 1: a shading point inside the box of a node whose lights
/// contribute nothing there must not starve the lights that do. Three
/// scenes, each with a cluster A around the point x whose lights give 0
/// at x and a cluster B above that gives > 0:
/// * A: VPLs on the floor (y = 0) around x, facing up, x on the floor
///   with n = +y: every ω to them is in the tangent plane (the case of a
///   floor cluster coplanar with a floor representative);
/// * A: VPLs on a 3×3×3 lattice around x, each facing away from x: x is
///   inside A's solid box, where W_A > 0 whatever the bound;
/// * A: the floor cluster with x exactly on one of its VPLs.
///
/// For every cut kind (`cut_estimators`), cuts of 1 (the root), 2, 4 and 8
/// chosen at x itself and at a point beside it: every light with f > 0
/// has pmf > 0 in its subtree (so the paper's estimator is unbiased for
/// Σ f), and the estimator's mean over 16,384 stratified u (the GPU's
/// numbers per subtree, `subtree_random` at one pixel) is Σ f within 6 standard errors.
/// The setup asserts that in the perfect tree some internal node holding
/// only lights of A has x inside its box.
#[test]
fn the_descent_does_not_starve_lights_beside_a_dead_box_around_the_point() {
    use mdas::lights::tree::cut::subtree_random;
    let up = Vec3::Y;
    let ceiling: Vec<LightPrim> = (0..9)
        .map(|i| {
            let (a, b) = ((i % 3) as f32 - 1.0, (i / 3) as f32 - 1.0);
            LightPrim::vpl(Vec3::new(a, 2.0, b), -up, Vec3::splat(3.0))
        })
        .collect();
    let floor: Vec<LightPrim> = (0..16)
        .map(|i| {
            let (a, b) = ((i % 4) as f32 - 1.5, (i / 4) as f32 - 1.5);
            LightPrim::vpl(Vec3::new(0.5 * a, 0.0, 0.5 * b), up, Vec3::splat(5.0))
        })
        .collect();
    let x = Vec3::new(0.1, 0.0, 0.13);
    let lattice: Vec<LightPrim> = (0..27)
        .filter(|&i| i != 13)
        .map(|i| {
            let o = Vec3::new(
                (i % 3) as f32 - 1.0,
                ((i / 3) % 3) as f32 - 1.0,
                (i / 9) as f32 - 1.0,
            );
            LightPrim::vpl(x + 0.4 * o, o.normalize(), Vec3::splat(5.0))
        })
        .collect();
    let scenes = [
        (
            "floor",
            [floor.clone(), ceiling.clone()].concat(),
            Shading { p: x, n: up },
        ),
        (
            "away",
            [lattice, ceiling.clone()].concat(),
            Shading { p: x, n: up },
        ),
        (
            "on a VPL",
            [floor.clone(), ceiling].concat(),
            Shading {
                p: Vec3::from(floor[5].p0),
                n: up,
            },
        ),
    ];
    let m = 16_384u32;
    for (scene, prims, s) in &scenes {
        let f: Vec<f64> = prims.iter().map(|l| contribution(l, s)).collect();
        let total: f64 = f.iter().sum();
        assert!(total > 0.0);
        // The setup: a dead-at-x node around x in the perfect tree.
        let t = perfect::build(prims).unwrap();
        let under = |node: usize| -> Vec<u32> {
            let mut stack = vec![node];
            let mut out = vec![];
            while let Some(k) = stack.pop() {
                match t.children(k) {
                    Some((l, r)) => stack.extend([l, r]),
                    None if t.leaf_light(k) != NO_LIGHT => out.push(t.leaf_light(k)),
                    None => {}
                }
            }
            out
        };
        let dead_box_around_x = (0..t.nodes.len()).any(|k| {
            let b = &t.nodes[k];
            let lights = under(k);
            t.children(k).is_some()
                && lights.len() >= 2
                && lights.iter().all(|&l| f[l as usize] == 0.0)
                && (0..3).all(|a| b.min[a] <= s.p[a] && s.p[a] <= b.max[a])
        });
        assert!(
            dead_box_around_x,
            "{scene}: the case needs a dead box around x"
        );
        for rep in [
            *s,
            Shading {
                p: s.p + Vec3::new(0.3, 0.0, -0.2),
                n: up,
            },
        ] {
            for size in [1, 2, 4, 8] {
                for (name, est) in cut_estimators(prims, &rep, size) {
                    for (l, &fl) in f.iter().enumerate() {
                        if fl > 0.0 {
                            let p = est.subtree_pmf(s, l as u32).map_or(0.0, |(_, p)| p);
                            assert!(
                                p > 0.0,
                                "{scene}, {name}/cut{size}: light {l} (f = {fl}) has pmf {p}"
                            );
                        }
                    }
                    let xs: Vec<f64> = (0..m)
                        .map(|k| {
                            let u = (k as f32 + 0.5) / m as f32;
                            (0..est.cut_len())
                                .filter_map(|j| {
                                    let uj =
                                        subtree_random([u, 0.5, 0.5, 0.5], [3, 5], j as u32)[0];
                                    est.sample_subtree(s, j, uj)
                                })
                                .map(|ls| f[ls.light as usize] / ls.pmf)
                                .sum::<f64>()
                                / total
                        })
                        .collect();
                    let (mean, se) = mean_se(&xs);
                    // 1e-6: the u-intervals that draw a light have the
                    // width of its f32 pmf only to within f32 rounding.
                    assert!(
                        (mean - 1.0).abs() <= 6.0 * se + 1e-6,
                        "{scene}, {name}/cut{size}: E[Σ f/pmf]/Σf = {mean} ± {se}"
                    );
                }
            }
        }
    }
}
