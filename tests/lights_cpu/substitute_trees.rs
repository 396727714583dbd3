//! Stochastic substitute trees: moments, hard cases, stops and their pmfs.

use super::*;

/// The f64 intensity-weighted mean and covariance of `prims` (weights: the
/// tree's scalar intensity).
pub(crate) fn weighted_moments(prims: &[LightPrim]) -> ([f64; 3], [[f64; 3]; 3]) {
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
        let radix = substitute::radix::build(&prims).unwrap();
        for (what, cones) in [
            ("perfect", &perfect.cones),
            ("substitute", &sst.tree.cones),
            ("radix substitute", &radix.bvh.cones),
        ] {
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
    hard_cases(substitute::radix::build);
    hard_cases(substitute::build);
}

fn hard_cases<T: SubstituteLayout>(build: fn(&[LightPrim]) -> Option<T>) {
    let params = Some(SubstituteParams::default());
    let sh = Shading {
        p: Vec3::new(0.3, 0.5, 0.2),
        n: Vec3::ZERO,
    };
    // One VPL.
    let one = [LightPrim::vpl(Vec3::ZERO, Vec3::Y, Vec3::ONE)];
    let s = SstSampler {
        tree: build(&one).unwrap(),
        params,
    };
    assert_eq!(s.sample(&sh, 0.7), Some(Stop { node: 0, pmf: 1.0 }));
    assert_eq!(LightSampler::sample(&s, &sh, 0.7).unwrap().light, 0);

    // Coincident VPLs: mean exactly the point after the box clamp.
    let at = Vec3::new(1.25, -0.5, 3.0);
    let same: Vec<_> = (0..37)
        .map(|i| LightPrim::vpl(at, Vec3::Z, Vec3::splat(0.1 + i as f32 * 0.01)))
        .collect();
    let t = build(&same).unwrap();
    assert_eq!(t.substitutes()[0].cholesky(), [[0.0; 3]; 3]);
    let (lo, hi) = (Vec3::from(t.nodes()[0].min), Vec3::from(t.nodes()[0].max));
    for u in [[0.0, 0.5, 0.9], [0.999, 0.001, 0.5]] {
        assert_eq!(t.substitutes()[0].sample_position(u, lo, hi), at);
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
    let t = build(&planes).unwrap();
    assert_eq!(t.substitutes()[0].nu, 0.0);
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
        substitutes += s.tree.children(st.node).is_some() as u32;
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
    let t = build(&mixed).unwrap();
    let (mean, _) = weighted_moments(&bright);
    for (got, want) in t.substitutes()[0].mean.iter().zip(mean) {
        assert!((*got as f64 - want).abs() < 1e-5);
    }
    assert!(t.substitutes()[0].sigma_z2() < 1e-10);
    assert!(SubstituteParams::default().suitable(&t.substitutes()[0], t.nodes()[0].intensity));
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
    // The paper's radix tree (`sst`) and the perfect tree (`sst_perfect`).
    let radix = substitute::radix::build(&prims).unwrap();
    check_stops(radix, &prims, &mut rng);
    check_stops(substitute::build(&prims).unwrap(), &prims, &mut rng);
}

fn check_stops<T: SubstituteLayout + Clone>(tree: T, prims: &[LightPrim], rng: &mut StdRng) {
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
            n: random_unit(rng),
        };
        let (stops, dead) = sst.stops(&sh);
        let total: f64 = stops.iter().map(|s| s.pmf).sum();
        assert!(
            (total + dead - 1.0).abs() < 1e-5,
            "case {case}: Σ {total} + dead {dead}"
        );
        for st in &stops {
            assert_eq!(sst.stop_pmf(&sh, st.node), st.pmf, "case {case}");
            if tree.children(st.node).is_some() {
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
            .all(|st| tree.children(st.node).is_none()));
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
