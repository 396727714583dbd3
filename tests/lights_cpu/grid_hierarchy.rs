//! The lighting grid hierarchy's CPU oracle.

use super::*;

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
