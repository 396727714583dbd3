//! Orientation cones bound their lights; cone kinds skip lights facing away.

use super::*;

/// `n` one-sided triangles: half facing roughly up (a ceiling of panels,
/// normals within ~35° of +y), half facing anywhere, so that the trees'
/// cones range from narrow to the whole sphere.
pub(crate) fn random_triangles(rng: &mut StdRng, n: usize) -> Vec<LightPrim> {
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
pub(crate) fn angle(u: Vec3, v: Vec3) -> f32 {
    u.cross(v).length().atan2(u.dot(v))
}

/// Every node's cone holds the emission direction of every light below it
/// (triangle and VPL normals within θ_o of the axis; points only under a
/// whole-sphere cone; points and VPLs set the `points` flag), checked leaf
/// by leaf up to the root.
pub(crate) fn check_cones_bound_their_lights<T: LightTree>(prims: &[LightPrim], t: &T, what: &str) {
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
