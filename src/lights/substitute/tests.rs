//! Unit tests of `substitute`.

use super::*;

/// A GPU pick `SUBSTITUTE_BIT | node` (`wgsl/lights/sample.wgsl`): one
/// bit, clear in every node index of a tree of at most `MAX_LIGHTS`
/// lights (nodes < 2·MAX_LIGHTS − 1), so a pick is never `NO_LIGHT`
/// and decodes to its node.
#[test]
fn substitute_picks_decode_to_their_node() {
    assert_eq!(SUBSTITUTE_BIT.count_ones(), 1);
    for node in [0, 1, MAX_LIGHTS - 1, MAX_LIGHTS, 2 * MAX_LIGHTS - 2] {
        assert_eq!(node & SUBSTITUTE_BIT, 0, "{node}");
        let pick = SUBSTITUTE_BIT | node;
        assert_ne!(pick, super::super::NO_LIGHT);
        assert_eq!(pick & !SUBSTITUTE_BIT, node);
    }
}

#[test]
fn normal_codes_by_octant_and_corner() {
    assert_eq!(normal_code([0.0, 0.0, 1.0]) >> 6, 0);
    assert_eq!(normal_code([0.0, 0.0, -1.0]) >> 6, 1);
    assert_eq!(normal_code([-1.0, 0.0, 0.0]) >> 6, 4);
    // +z: corner z (2) at every level.
    assert_eq!(normal_code([0.0, 0.0, 1.0]) & 63, 0b10_10_10);
    // +x: corner x (0) at every level.
    assert_eq!(normal_code([1.0, 0.0, 0.0]) & 63, 0);
    // The octant's centre: the centre triangle, then its centre again.
    assert_eq!(normal_code([1.0, 1.0, 1.0]) & 63, 0b11_11_11);
    assert_eq!(normal_code([0.0; 3]), 0);
    // Scale-free.
    let n = [0.3, -0.5, 0.81];
    assert_eq!(normal_code(n), normal_code(n.map(|x| x * 4.0)));
}

/// Codes worked by hand on normals whose coordinates (and their sums
/// and doublings) are exact in f32, so that every level's choice is
/// decided exactly, ties included (a coordinate of exactly half the
/// sum takes its corner, the first such in x, y, z order).
#[test]
fn normal_codes_worked_by_hand() {
    // (1/8, 3/4, 1/8): corner y (1); then (1/4, 1/2, 1/4): y on the
    // tie (1); then (1/2, 0, 1/2): x on the tie (0).
    assert_eq!(normal_code([0.125, 0.75, 0.125]), 0b01_01_00);
    // (1/4, 1/4, 1/2): z (2), then (1/2, 1/2, 0): x (0), then
    // (0, 1, 0): y (1).
    assert_eq!(normal_code([0.25, 0.25, 0.5]), 0b10_00_01);
    // (3/8, 3/8, 1/4): no coordinate reaches 1/2, the centre (3),
    // which maps to (1 − 2a, 1 − 2b, 1 − 2c) = (1/4, 1/4, 1/2): z (2),
    // then x (0).
    assert_eq!(normal_code([0.375, 0.375, 0.25]), 0b11_10_00);
    // Octant bits: x negative 4, y 2, z 1.
    assert_eq!(
        normal_code([-0.125, 0.75, -0.125]),
        (0b101 << 6) | 0b01_01_00
    );
    assert_eq!(normal_code([0.25, -0.25, 0.5]), (0b010 << 6) | 0b10_00_01);
    // The sum s, not a coordinate, is the scale: doubled, the same.
    assert_eq!(normal_code([0.75, 0.75, 0.5]), 0b11_10_00);
    // Not a direction: NaN, infinite, or a sum that overflows.
    assert_eq!(normal_code([f32::NAN, 0.0, 1.0]), 0);
    assert_eq!(normal_code([f32::INFINITY, 0.0, 0.0]), 0);
    assert_eq!(normal_code([3e38, 3e38, 3e38]), 0);
}

/// The code of a direction by geometry, in f64: the octant's triangle
/// (vertices x, y, z) cut into its four children (corner x, corner y,
/// corner z, the centre with vertices opposite x, y, z), the child
/// holding the point found from its barycentric coordinates in the
/// current triangle (a 3×3 solve), first on ties as the code does.
/// `None` when a coordinate lies within 1e-5 of 1/2 (f32 may decide
/// either way there).
fn normal_code_by_geometry(n: [f64; 3]) -> Option<u32> {
    let octant = ((n[0] < 0.0) as u32) << 2 | ((n[1] < 0.0) as u32) << 1 | (n[2] < 0.0) as u32;
    let a = n.map(f64::abs);
    let sum = a[0] + a[1] + a[2];
    let p = a.map(|x| x / sum);
    let mut v = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    let mid = |a: [f64; 3], b: [f64; 3]| [0, 1, 2].map(|i| 0.5 * (a[i] + b[i]));
    let mut code = octant;
    for _ in 0..3 {
        // λ with Σ λ_k v_k = p by Cramer's rule (columns v_k).
        let det = |m: [[f64; 3]; 3]| {
            m[0][0] * (m[1][1] * m[2][2] - m[2][1] * m[1][2])
                - m[1][0] * (m[0][1] * m[2][2] - m[2][1] * m[0][2])
                + m[2][0] * (m[0][1] * m[1][2] - m[1][1] * m[0][2])
        };
        let d = det(v);
        let lambda = [0, 1, 2].map(|k| {
            let mut m = v;
            m[k] = p;
            det(m) / d
        });
        if lambda.iter().any(|l| (l - 0.5).abs() < 1e-5) {
            return None;
        }
        let (child, next) = if lambda[0] >= 0.5 {
            (0, [v[0], mid(v[0], v[1]), mid(v[0], v[2])])
        } else if lambda[1] >= 0.5 {
            (1, [mid(v[0], v[1]), v[1], mid(v[1], v[2])])
        } else if lambda[2] >= 0.5 {
            (2, [mid(v[0], v[2]), mid(v[1], v[2]), v[2]])
        } else {
            (3, [mid(v[1], v[2]), mid(v[0], v[2]), mid(v[0], v[1])])
        };
        code = code << 2 | child;
        v = next;
    }
    Some(code)
}

/// The normal code of 20,000 random directions (every octant, every
/// child at every level) equals the geometric construction's.
#[test]
fn normal_codes_match_the_geometric_subdivision() {
    use rand::rngs::StdRng;
    use rand::{RngExt, SeedableRng};
    let mut rng = StdRng::seed_from_u64(7);
    let mut children = [[0u32; 4]; 3];
    let mut checked = 0;
    for _ in 0..20_000 {
        let n: [f32; 3] = std::array::from_fn(|_| rng.random_range(-1.0f32..1.0));
        let Some(want) = normal_code_by_geometry(n.map(f64::from)) else {
            continue;
        };
        assert_eq!(normal_code(n), want, "{n:?}");
        for (level, seen) in children.iter_mut().enumerate() {
            seen[(want >> (4 - 2 * level) & 3) as usize] += 1;
        }
        checked += 1;
    }
    assert!(checked > 19_000, "{checked}");
    assert!(children.iter().flatten().all(|&k| k > 1000), "{children:?}");
}

fn with_covariance(c: [[f32; 3]; 3], normal: [f32; 3]) -> Substitute {
    Substitute {
        cov_diag: [c[0][0], c[1][1], c[2][2]],
        cov_xy: c[0][1],
        cov_xz: c[0][2],
        cov_yz: c[1][2],
        normal,
        ..Default::default()
    }
}

/// Eq. 3 at its boundaries (ν_min = 1/2, σ_max = 0.1, so σ_max² is
/// the f32 product 0.1·0.1): ν = ν_min and σ_z² = σ_max² are suitable,
/// the next f32 beyond either is not, nor is a dark node; σ_z is the
/// variance along the normal (z here), not across it.
#[test]
fn suitability_at_the_boundaries_of_eq_3() {
    let q = SubstituteParams::default();
    let max2 = 0.1f32 * 0.1;
    let node = |nu: f32, zz: f32| Substitute {
        nu,
        ..with_covariance(
            [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, zz]],
            [0.0, 0.0, 1.0],
        )
    };
    assert!(q.suitable(&node(0.5, max2), 1.0));
    assert!(q.suitable(&node(1.0, 0.0), f32::MIN_POSITIVE));
    assert!(!q.suitable(&node(0.5, max2), 0.0));
    assert!(!q.suitable(&node(0.5f32.next_down(), max2), 1.0));
    assert!(!q.suitable(&node(0.5, max2.next_up()), 1.0));
    assert!(!q.suitable(&node(0.5, 0.05), 1.0));
    assert!(!q.suitable(&node(0.25, 0.5), 1.0));
    // A wider σ_max admits it; a stricter ν_min refuses it.
    let wide = SubstituteParams {
        nu_min: 0.5,
        sigma_max: 0.5,
    };
    assert!(wide.suitable(&node(0.5, 0.25), 1.0));
    assert!(!wide.suitable(&node(0.5, 0.25f32.next_up()), 1.0));
    let strict = SubstituteParams {
        nu_min: 0.75,
        sigma_max: 0.1,
    };
    assert!(!strict.suitable(&node(0.5, 0.0), 1.0));
}

/// The sort against its definition, a sort of (Morton code, normal
/// code, id) tuples: 600 VPLs and points on 40 positions (so Morton
/// codes tie and the normal code decides) with 5 normals (so those tie
/// too and the id decides).
#[test]
fn lights_sort_by_morton_then_normal_then_id() {
    use rand::rngs::StdRng;
    use rand::{RngExt, SeedableRng};
    let mut rng = StdRng::seed_from_u64(11);
    let spots: Vec<Vec3> = (0..40)
        .map(|_| Vec3::new(rng.random(), rng.random(), rng.random()))
        .collect();
    let normals = [
        Vec3::X,
        -Vec3::Y,
        Vec3::new(0.6, 0.0, 0.8),
        Vec3::Z,
        Vec3::new(-0.48, 0.6, -0.64),
    ];
    let prims: Vec<LightPrim> = (0..600)
        .map(|_| {
            let p = spots[rng.random_range(0..spots.len())];
            match rng.random_range(0..6usize) {
                5 => LightPrim::point(p, Vec3::ONE),
                k => LightPrim::vpl(p, normals[k], Vec3::ONE),
            }
        })
        .collect();
    let codes = morton::codes(&prims);
    let mut want: Vec<u32> = (0..prims.len() as u32).collect();
    want.sort_by_key(|&i| {
        (
            codes[i as usize],
            normal_code(prim_normal(&prims[i as usize])),
            i,
        )
    });
    assert_eq!(sort_lights(&prims), want);
}

/// The tree view of a substitute tree over 5 lights (8 leaves, 3
/// bogus): 5 lights, each in the leaf that holds it; children and
/// parents of the 15-node perfect tree; the nodes and cones its own.
#[test]
fn the_tree_view_is_the_perfect_trees() {
    let prims: Vec<LightPrim> = (0..5)
        .map(|i| LightPrim::vpl(Vec3::new(i as f32, 0.0, 0.0), Vec3::Y, Vec3::ONE))
        .collect();
    let t = build(&prims).unwrap();
    let view: &dyn LightTree = &t;
    assert_eq!(view.light_count(), 5);
    assert_eq!((view.nodes().len(), view.cones().len()), (15, 15));
    for light in 0..5 {
        let leaf = view.leaf_of_light(light).expect("every light has a leaf");
        assert_eq!(view.leaf_light(leaf), light);
        assert_eq!(view.children(leaf), None);
    }
    assert_eq!(view.leaf_of_light(5), None);
    assert_eq!(
        (view.children(0), view.children(2)),
        (Some((1, 2)), Some((5, 6)))
    );
    assert_eq!(
        (view.parent(0), view.parent(6), view.parent(9)),
        (None, Some(2), Some(4))
    );
}

/// A symmetric positive definite matrix with every off-diagonal
/// non-zero (leading minors 4, 11, 20.75).
const SPD: [[f32; 3]; 3] = [[4.0, 1.0, 0.5], [1.0, 3.0, -0.25], [0.5, -0.25, 2.0]];

/// σ_z² = nᵀΣn against the f64 product; L·Lᵀ = Σ with L lower
/// triangular, and the degenerate pivots give zero columns instead of
/// 0/0. Tolerance: f32 rounding of a few operations on entries ≤ 4
/// (1e-5).
#[test]
fn variance_along_the_normal_and_the_cholesky_factor() {
    let n = [1.0f32 / 3.0, 2.0 / 3.0, 2.0 / 3.0];
    let s = with_covariance(SPD, n);
    let mut want = 0.0f64;
    for r in 0..3 {
        for c in 0..3 {
            want += n[r] as f64 * SPD[r][c] as f64 * n[c] as f64;
        }
    }
    assert!(
        ((s.sigma_z2() as f64) - want).abs() < 1e-5,
        "{} vs {want}",
        s.sigma_z2()
    );
    let reproduces = |c: [[f32; 3]; 3]| {
        let l = with_covariance(c, [0.0; 3]).cholesky();
        for r in 0..3 {
            for k in r + 1..3 {
                assert_eq!(l[r][k], 0.0, "upper entry {r}{k} of {l:?}");
            }
            for k in 0..3 {
                let llt: f64 = (0..3).map(|j| l[r][j] as f64 * l[k][j] as f64).sum();
                assert!(
                    (llt - c[r][k] as f64).abs() < 1e-5,
                    "LLᵀ[{r}][{k}] = {llt}, Σ {c:?}"
                );
            }
        }
        l
    };
    let l = reproduces(SPD);
    assert_eq!((l[0][0], l[1][0], l[2][0]), (2.0, 0.5, 0.25));
    // No spread along x: the first pivot is 0 and its column too.
    let l = reproduces([[0.0, 0.0, 0.0], [0.0, 4.0, 2.0], [0.0, 2.0, 5.0]]);
    assert_eq!(l, [[0.0; 3], [0.0, 2.0, 0.0], [0.0, 1.0, 2.0]]);
    // y fully correlated with x: the second pivot is 0.
    let l = reproduces([[4.0, 2.0, 0.0], [2.0, 1.0, 0.0], [0.0, 0.0, 9.0]]);
    assert_eq!(l, [[2.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 3.0]]);
}

/// p + L·z with z = Φ⁻¹(u): u = 1/2 gives z = 0 exactly (the mean),
/// u = Φ(1) a unit step along one column of L, and the box clamps.
/// Tolerance: Φ⁻¹'s error at Φ(1) (2e-4, as its own test) times |L|.
#[test]
fn substitute_positions_follow_the_cholesky_columns() {
    let mut s = with_covariance(SPD, [0.0, 1.0, 0.0]);
    s.mean = [1.0, -2.0, 3.0];
    let (lo, hi) = (Vec3::splat(-10.0), Vec3::splat(10.0));
    let mean = Vec3::from(s.mean);
    assert_eq!(s.sample_position([0.5; 3], lo, hi), mean);
    let l = s.cholesky();
    let one = 0.841_344_7;
    for axis in 0..3 {
        let mut u = [0.5; 3];
        u[axis] = one;
        let column = Vec3::new(l[0][axis], l[1][axis], l[2][axis]);
        let got = s.sample_position(u, lo, hi);
        assert!(
            (got - (mean + column)).abs().max_element() < 2e-4 * 2.0,
            "column {axis}: {got} vs {}",
            mean + column
        );
    }
    // Clamped to a box ±1/8 about the mean (the step is 2, 1/2, 1/4).
    let tight = s.sample_position([one, 0.5, 0.5], mean - 0.125, mean + 0.125);
    assert_eq!(tight, Vec3::new(1.125, -1.875, 3.125));
}

/// One merge against the f64 moments of its two children: the mean
/// and the covariance of the mixture (the children's own covariances
/// plus the spread of their means), the normal as the normalized
/// weighted sum, ν = ν₁ν₂·max(n₁·n₂, 0), the summed emission; then
/// merges of four points in a tree against the f64 weighted moments
/// of the points (moments merge exactly). Tolerance: f32 rounding of
/// values ≤ 30 (1e-5 relative).
#[test]
fn merged_moments_are_the_mixtures() {
    let vpl = |p: [f32; 3], n: [f32; 3], e: [f32; 3]| {
        Substitute::of_prim(&LightPrim::vpl(
            Vec3::from(p),
            Vec3::from(n).normalize(),
            Vec3::from(e),
        ))
    };
    let mut a = vpl([1.0, 2.0, -1.0], [0.0, 1.0, 0.2], [1.0, 2.0, 3.0]);
    a.cov_diag = [0.5, 0.25, 1.0];
    a.cov_xy = 0.125;
    a.cov_xz = -0.0625;
    a.cov_yz = 0.03125;
    a.nu = 0.75;
    let mut b = vpl([-2.0, 0.5, 3.0], [0.3, 1.0, 0.0], [0.5, 0.5, 0.5]);
    b.nu = 0.5;
    let (ca, cb) = (3.0f32, 2.0f32);
    let m = merge(&a, ca, &b, cb);
    let (ta, tb) = (0.6f64, 0.4f64);
    let f = |v: [f32; 3]| v.map(|x| x as f64);
    let (pa, pb) = (f(a.mean), f(b.mean));
    let mean: [f64; 3] = std::array::from_fn(|k| ta * pa[k] + tb * pb[k]);
    let (ca_m, cb_m) = (a.covariance(), b.covariance());
    for r in 0..3 {
        assert!(
            (m.mean[r] as f64 - mean[r]).abs() < 1e-5 * 4.0,
            "mean {:?}",
            m.mean
        );
        for c in 0..3 {
            let want = ta * (ca_m[r][c] as f64 + (pa[r] - mean[r]) * (pa[c] - mean[c]))
                + tb * (cb_m[r][c] as f64 + (pb[r] - mean[r]) * (pb[c] - mean[c]));
            let got = m.covariance()[r][c] as f64;
            assert!(
                (got - want).abs() < 1e-5 * 30.0,
                "cov[{r}][{c}] {got} vs {want}"
            );
        }
    }
    let (na, nb) = (Vec3::from(a.normal), Vec3::from(b.normal));
    let n = (na * ca + nb * cb).normalize();
    assert!(
        (Vec3::from(m.normal) - n).abs().max_element() < 1e-6,
        "{:?}",
        m.normal
    );
    assert!((m.nu - 0.75 * 0.5 * na.dot(nb)).abs() < 1e-6, "ν {}", m.nu);
    assert_eq!(m.emission, [1.5, 2.5, 3.5]);
    // Normals more than 90° apart: ν = 0; opposite with equal weights:
    // no normal at all.
    let back = vpl([0.0; 3], [0.0, -1.0, -0.2], [1.0; 3]);
    assert_eq!(merge(&a, 1.0, &back, 2.0).nu, 0.0);
    let up = vpl([0.0; 3], [0.0, 1.0, 0.0], [1.0; 3]);
    let down = vpl([1.0; 3], [0.0, -1.0, 0.0], [1.0; 3]);
    let none = merge(&up, 1.0, &down, 1.0);
    assert_eq!((none.normal, none.nu), ([0.0; 3], 0.0));

    // Four points merged as a tree against their f64 moments.
    let points = [
        ([0.0f32, 0.0, 0.0], 1.0f32),
        ([2.0, 1.0, -1.0], 2.0),
        ([-1.0, 3.0, 0.5], 0.5),
        ([1.0, -2.0, 2.0], 4.0),
    ];
    let s: Vec<Substitute> = points
        .iter()
        .map(|&(p, _)| vpl(p, [0.0, 1.0, 0.0], [1.0; 3]))
        .collect();
    let left = merge(&s[0], points[0].1, &s[1], points[1].1);
    let right = merge(&s[2], points[2].1, &s[3], points[3].1);
    let root = merge(
        &left,
        points[0].1 + points[1].1,
        &right,
        points[2].1 + points[3].1,
    );
    let total: f64 = points.iter().map(|&(_, c)| c as f64).sum();
    let mean: [f64; 3] = std::array::from_fn(|k| {
        points
            .iter()
            .map(|&(p, c)| c as f64 * p[k] as f64)
            .sum::<f64>()
            / total
    });
    for r in 0..3 {
        assert!((root.mean[r] as f64 - mean[r]).abs() < 1e-5 * 4.0);
        for c in 0..3 {
            let want: f64 = points
                .iter()
                .map(|&(p, w)| w as f64 * (p[r] as f64 - mean[r]) * (p[c] as f64 - mean[c]))
                .sum::<f64>()
                / total;
            let got = root.covariance()[r][c] as f64;
            assert!(
                (got - want).abs() < 1e-5 * 30.0,
                "root cov[{r}][{c}] {got} vs {want}"
            );
        }
    }
}

/// A child of intensity 0 (or NaN) drops out: the parent is the other
/// child, and nothing when both are dark.
#[test]
fn dark_children_drop_out_of_a_merge() {
    let mut a = Substitute::of_prim(&LightPrim::vpl(Vec3::ONE, Vec3::Y, Vec3::ONE));
    a.cov_diag = [1.0, 2.0, 3.0];
    let b = Substitute::of_prim(&LightPrim::vpl(-Vec3::ONE, Vec3::X, Vec3::splat(2.0)));
    assert_eq!(merge(&a, 0.0, &b, 2.0), b);
    assert_eq!(merge(&a, f32::NAN, &b, 2.0), b);
    assert_eq!(merge(&a, -1.0, &b, 2.0), b);
    assert_eq!(merge(&a, 2.0, &b, 0.0), a);
    assert_eq!(merge(&a, 2.0, &b, f32::NAN), a);
    assert_eq!(merge(&a, 0.0, &b, 0.0), Substitute::default());
    assert_eq!(merge(&a, f32::NAN, &b, -1.0), Substitute::default());
}

#[test]
fn inverse_normal_cdf_matches_known_quantiles() {
    // Φ⁻¹ at 0.5, 0.975, 0.8413447 (1σ), 0.0013499 (−3σ).
    for (u, z) in [
        (0.5, 0.0),
        (0.975, 1.959_964),
        (0.841_344_7, 1.0),
        (0.001_349_9, -3.0),
    ] {
        assert!((inverse_normal_cdf(u) - z).abs() < 2e-4, "{u}");
    }
    assert!(inverse_normal_cdf(0.0).is_finite() && inverse_normal_cdf(0.0) < -5.0);
    assert!(inverse_normal_cdf(0.999_999_94).is_finite());
}

/// Φ in f64: ½ + ∫₀^z φ by composite Simpson (1,024 intervals per unit
/// of z: error ≤ (h⁴/180)·|z|·max|φ⁗| < 1e-13 for |z| ≤ 7).
fn normal_cdf(z: f64) -> f64 {
    let n = ((z.abs() * 1024.0).ceil() as usize + 2) & !1;
    let h = z / n as f64;
    let phi = |t: f64| (-0.5 * t * t).exp() / (2.0 * std::f64::consts::PI).sqrt();
    let mut sum = phi(0.0) + phi(z);
    for i in 1..n {
        sum += phi(i as f64 * h) * if i % 2 == 1 { 4.0 } else { 2.0 };
    }
    0.5 + sum * h / 3.0
}

/// Φ⁻¹ against an f64 inversion of Φ (bisection to 1e-13) over the
/// whole range (at the u its f32 argument represents), both branches of the approximation (w < 5 below |z| ≈
/// 2.9): within 1e-6 relative + 1e-7 absolute, the single-precision
/// erf⁻¹'s stated ~3.7e-7 relative error (Giles 2010) plus the f32
/// roundings of 2u − 1, the logarithm and the products.
#[test]
fn inverse_normal_cdf_matches_an_f64_inversion() {
    let exact = |u: f64| {
        let (mut lo, mut hi) = (-7.0f64, 7.0f64);
        while hi - lo > 1e-13 {
            let mid = 0.5 * (lo + hi);
            if normal_cdf(mid) < u {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        0.5 * (lo + hi)
    };
    let mut us: Vec<f32> = (1..256).map(|k| k as f32 / 256.0).collect();
    us.extend([
        1e-6, 1e-5, 1e-4, 1e-3, 0.002, 0.998, 0.9999, 0.99999, 0.999_999,
    ]);
    for u in us {
        // At the u that the f32 argument 2u − 1 represents: its
        // rounding near the tails (ulp 6e-8 against 1 − |x| = 2e-6 at
        // u = 1e-6) is the input's, not the approximation's.
        let x = 2.0 * u - 1.0;
        let z = exact((x as f64 + 1.0) / 2.0);
        let got = inverse_normal_cdf(u) as f64;
        let err = (got - z).abs();
        assert!(err <= 1e-6 * z.abs() + 1e-7, "Φ⁻¹({u}) = {got}, exact {z}");
    }
}

/// Lights for the radix tree: VPLs on a coarse grid of positions (so
/// several share a Morton cell, and some a whole key), with normals from
/// a few directions, plus point lights (no normal) among them.
fn radix_lights(seed: u64, n: usize) -> Vec<LightPrim> {
    use rand::rngs::StdRng;
    use rand::{RngExt, SeedableRng};
    let mut rng = StdRng::seed_from_u64(seed);
    let normals = [
        Vec3::X,
        Vec3::Y,
        -Vec3::Y,
        Vec3::new(0.6, 0.8, 0.0),
        Vec3::Z,
    ];
    (0..n)
        .map(|_| {
            let p = Vec3::new(
                rng.random_range(0..4) as f32,
                rng.random_range(0..3) as f32 * 0.5,
                rng.random_range(0..4) as f32 * 2.0,
            );
            match rng.random_range(0..6) {
                5 => LightPrim::point(p, Vec3::ONE),
                k => LightPrim::vpl(p, normals[k], Vec3::splat(0.5 + k as f32)),
            }
        })
        .collect()
}

/// The radix tree is the radix tree of its keys: with the leaves in key
/// order, every internal node covers a contiguous run `[first, last]`,
/// all of whose keys share the node's δ(first, last)-bit prefix, and its
/// children split the run exactly where neighbours differ at that bit
/// (δ(s, s + 1) = δ(first, last)), each child's prefix strictly longer.
/// Also: `2N − 1` nodes, every light in one leaf, parents that agree with
/// the children, a depth within the bound, and the gathered node data.
#[test]
fn radix_nodes_split_where_their_keys_first_differ() {
    use super::radix::{self, delta, KEY_BITS};
    for (seed, n) in [(1, 1), (2, 2), (3, 3), (4, 17), (5, 300), (6, 1000)] {
        let prims = radix_lights(seed, n);
        let t = radix::build(&prims).unwrap();
        let (sorted, keys) = radix::sorted_keys(&prims);
        assert_eq!(t.sorted, sorted);
        assert!(keys.iter().all(|&k| k >> KEY_BITS == 0));
        assert_eq!(t.bvh.nodes.len(), 2 * n - 1, "n = {n}");
        let slot_of: Vec<usize> = {
            let mut s = vec![0; n];
            for (slot, &id) in sorted.iter().enumerate() {
                s[id as usize] = slot;
            }
            s
        };
        // Each node's run of leaf slots, children first (reverse index).
        let mut run = vec![(usize::MAX, 0usize); t.bvh.nodes.len()];
        for i in (0..t.bvh.nodes.len()).rev() {
            match t.children(i) {
                None => {
                    let light = t.leaf_light(i);
                    assert_eq!(t.bvh.leaf_of_light[light as usize] as usize, i);
                    run[i] = (slot_of[light as usize], slot_of[light as usize]);
                }
                Some((l, r)) => {
                    assert!(l > i && r == l + 1);
                    assert_eq!(LightTree::parent(&t, l), Some(i));
                    assert_eq!(LightTree::parent(&t, r), Some(i));
                    let ((f, s), (s1, last)) = (run[l], run[r]);
                    assert_eq!(s + 1, s1, "node {i}: children not contiguous");
                    run[i] = (f, last);
                    let d = delta(&keys, f, last as isize);
                    assert!((f..=last).all(|j| delta(&keys, f, j as isize) >= d));
                    assert_eq!(delta(&keys, s, s1 as isize), d, "node {i}: split");
                    for (a, b) in [(f, s), (s1, last)] {
                        assert!(a == b || delta(&keys, a, b as isize) > d);
                    }
                    let g = crate::lights::tree::perfect::gather(&t.bvh.nodes[l], &t.bvh.nodes[r]);
                    assert_eq!((t.bvh.nodes[i].min, t.bvh.nodes[i].max), (g.min, g.max));
                    assert_eq!(t.bvh.nodes[i].intensity, g.intensity);
                }
            }
        }
        assert_eq!(run[0], (0, n - 1));
        assert_eq!(LightTree::parent(&t, 0), None);
        let bound = KEY_BITS + (n as u32).next_power_of_two().trailing_zeros() + 1;
        assert!(t.bvh.depth <= bound, "depth {} > {bound}", t.bvh.depth);
    }
}

/// A light without a normal has a class of its own, after every
/// direction of its Morton cell: it never shares a key with a VPL (the
/// 9-bit code alone gives both 0), so no radix node below their cell mixes
/// them, and the ν = 0 of such a mix stays at the cell.
#[test]
fn lights_without_normals_have_their_own_class() {
    use super::radix::{self, normal_class};
    let p = Vec3::new(1.0, 2.0, 3.0);
    let vpl = LightPrim::vpl(p, Vec3::X, Vec3::ONE);
    let point = LightPrim::point(p, Vec3::ONE);
    assert_eq!(
        normal_code(prim_normal(&point)),
        normal_code(prim_normal(&vpl))
    );
    assert_ne!(normal_class(&point), normal_class(&vpl));
    assert_eq!(normal_class(&point), 1 << NORMAL_BITS);
    let prims = [point, vpl, point, vpl];
    let t = radix::build(&prims).unwrap();
    // Root: the two classes; below it, two VPLs (ν = 1) and two points.
    let (l, r) = t.children(0).unwrap();
    let ids = |n: usize| {
        let (a, b) = t.children(n).unwrap();
        let mut v = [t.leaf_light(a), t.leaf_light(b)];
        v.sort();
        v
    };
    assert_eq!((ids(l), ids(r)), ([1, 3], [0, 2]));
    assert_eq!(t.substitutes[l].nu, 1.0);
    assert_eq!(t.substitutes[r].nu, 0.0);
}

/// Karras's per-node construction (Fig. 4), which a GPU runs one thread
/// per internal node, builds the same tree as the top-down split: the
/// runs and splits of its N − 1 internal nodes, each found from its own
/// index alone, are the top-down tree's.
#[test]
fn karras_per_node_ranges_match_the_top_down_tree() {
    use super::radix::{self, delta, split};
    for (seed, n) in [(11, 2), (12, 9), (13, 257), (14, 800)] {
        let prims = radix_lights(seed, n);
        let (_, keys) = radix::sorted_keys(&prims);
        let mut top_down = Vec::new();
        let mut stack = vec![(0usize, n - 1)];
        while let Some((f, l)) = stack.pop() {
            if f == l {
                continue;
            }
            let s = split(&keys, f, l);
            top_down.push((f, l, s));
            stack.push((f, s));
            stack.push((s + 1, l));
        }
        let mut karras: Vec<(usize, usize, usize)> = (0..n - 1)
            .map(|i| {
                let k = |j: isize| delta(&keys, i, j);
                let i_ = i as isize;
                let d: isize = if k(i_ + 1) > k(i_ - 1) { 1 } else { -1 };
                let dmin = k(i_ - d);
                let mut lmax = 2isize;
                while k(i_ + lmax * d) > dmin {
                    lmax *= 2;
                }
                let (mut len, mut t) = (0isize, lmax / 2);
                while t >= 1 {
                    if k(i_ + (len + t) * d) > dmin {
                        len += t;
                    }
                    t /= 2;
                }
                let j = i_ + len * d;
                let dnode = k(j);
                let (mut s, mut div) = (0isize, 2isize);
                loop {
                    let t = (len + div - 1) / div;
                    if k(i_ + (s + t) * d) > dnode {
                        s += t;
                    }
                    if t == 1 {
                        break;
                    }
                    div *= 2;
                }
                let gamma = i_ + s * d + d.min(0);
                (i.min(j as usize), i.max(j as usize), gamma as usize)
            })
            .collect();
        top_down.sort_unstable();
        karras.sort_unstable();
        assert_eq!(karras, top_down, "n = {n}");
    }
}
