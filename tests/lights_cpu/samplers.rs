//! Every sampler's pmf: consistency, normalization, unbiasedness and chi-square goodness of fit.

use super::*;

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
pub(crate) fn contributes(light: &LightPrim, s: &Shading) -> bool {
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
            let (mean, se) = mean_se(&xs);
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
pub(crate) fn check_per_light(name: &str, counts: &[u64], expected: &[f64], draws: f64) {
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
