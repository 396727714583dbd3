//! Hard cases: one light, zero lights, coincident, coplanar and zero-intensity lights, dead branches, deep trees.

use super::*;

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
    // Two lights below a tilted surface (x + y = 0) whose common box
    // reaches above it, to the corner (4, 4, 0): the root looks alive, both
    // children are dead. (With an axis normal no such pair exists for the
    // box bound: the union box rises no higher than its children.)
    let pair = [
        LightPrim::point(Vec3::new(-5.0, 4.0, 0.0), Vec3::ONE),
        LightPrim::point(Vec3::new(4.0, -5.0, 0.0), Vec3::ONE),
    ];
    let tilted = Shading {
        p: Vec3::ZERO,
        n: Vec3::new(1.0, 1.0, 0.0).normalize(),
    };
    for (prims, s) in [(&below[..], s), (&pair[..], tilted)] {
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
    assert!(node_importance(&t.nodes[0], None, &tilted).w > 0.0);
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
