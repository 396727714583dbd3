use super::*;

fn node(min: [f32; 3], max: [f32; 3], intensity: f32) -> TreeNode {
    TreeNode {
        min,
        intensity,
        max,
        id: 0,
    }
}

#[test]
fn distances_and_bound() {
    let s = Shading {
        p: Vec3::ZERO,
        n: Vec3::Y,
    };
    let imp = node_importance(&node([1.0, 0.0, 0.0], [2.0, 1.0, 0.0], 2.0), None, &s);
    assert_eq!(imp.dmin2, 1.0);
    assert_eq!(imp.dmax2, 5.0);
    assert!(imp.w > 0.0 && imp.w <= 2.0);
    // Entirely below the surface: F = 0.
    let below = node_importance(&node([-1.0, -3.0, -1.0], [1.0, -2.0, 1.0], 1.0), None, &s);
    assert_eq!(below.w, 0.0);
    assert!(below.dmin2 > 0.0);
    // Inside: dmin² = 0, F = 1.
    let inside = node_importance(&node([-1.0; 3], [1.0; 3], 3.0), None, &s);
    assert_eq!((inside.dmin2, inside.w), (0.0, 3.0));
    assert_eq!(
        node_importance(&TreeNode::EMPTY, None, &s),
        NodeImportance::default()
    );
}

/// Distances from a shading point off the origin and off every face
/// (the box [1, 2] × [0, 1] × [0, 0] from (3, −1, 0.5)): per axis the
/// nearest gaps are 1, 1, 0.5 and the farthest 2, 2, 0.5.
#[test]
fn distances_from_a_point_beside_the_box() {
    let s = Shading {
        p: Vec3::new(3.0, -1.0, 0.5),
        n: Vec3::ZERO,
    };
    let imp = node_importance(&node([1.0, 0.0, 0.0], [2.0, 1.0, 0.0], 2.0), None, &s);
    assert_eq!((imp.dmin2, imp.dmax2, imp.w), (2.25, 8.25, 2.0));
    // Beside the other faces: (0, 2, −1) gives gaps 1, 1, 1 and 2, 2, 1.
    let s = Shading {
        p: Vec3::new(0.0, 2.0, -1.0),
        n: Vec3::ZERO,
    };
    let imp = node_importance(&node([1.0, 0.0, 0.0], [2.0, 1.0, 0.0], 2.0), None, &s);
    assert_eq!((imp.dmin2, imp.dmax2), (3.0, 9.0));
}

/// A node of zero intensity is dead whatever its bounds; the cone
/// kinds clamp the near distance of a non-point node to r²/16 (r its
/// half-diagonal), not that of a node over points.
#[test]
fn dead_nodes_and_the_near_clamp() {
    let s = Shading {
        p: Vec3::ZERO,
        n: Vec3::Y,
    };
    let zero = node([-1.0; 3], [1.0; 3], 0.0);
    assert_eq!(node_importance(&zero, None, &s), NodeImportance::default());
    assert_eq!(
        node_importance(&zero, Some(&LightCone::SPHERE), &s),
        NodeImportance::default()
    );
    // x inside the box [−1, 3]³: r² = 3·2² = 12, so dmin² = 12/16.
    let b = node([-1.0; 3], [3.0; 3], 1.0);
    let imp = node_importance(&b, Some(&LightCone::SPHERE), &s);
    assert_eq!(imp.dmin2, 0.75);
    let imp = node_importance(&b, Some(&LightCone::POINT), &s);
    assert_eq!(imp.dmin2, 0.0);
}

#[test]
fn child_rules() {
    let a = NodeImportance {
        dmin2: 1.0,
        dmax2: 4.0,
        w: 1.0,
    };
    let dead = NodeImportance::default();
    assert_eq!(p_left(&a, &dead), Some(1.0));
    assert_eq!(p_left(&dead, &a), Some(0.0));
    assert_eq!(p_left(&dead, &dead), None);
    assert_eq!(p_left(&a, &a), Some(0.5));
    let inside = NodeImportance {
        dmin2: 0.0,
        dmax2: 4.0,
        w: 1.0,
    };
    // p_min = 1 (only the box around x counts), p_max = 1/2.
    assert_eq!(p_left(&inside, &a), Some(0.75));
    let (left, p, u) = choose_child(0.25, 0.5);
    assert_eq!((left, p, u), (false, 0.75, 1.0 / 3.0));
    assert!(choose_child(1.0, ONE_MINUS_EPSILON).0);
    assert!(!choose_child(0.0, 0.0).0);
}

/// The reflectance bound against its closed form. The node is the
/// segment [3, 5] × {0} × {0} seen from the origin with the normal
/// θ away from +x in the xy plane: along n the box reaches at most
/// a_max = 5·cos θ, and along the tangent in the xy plane it is at
/// least 3·sin θ away (the other tangent is z, where the segment has
/// gap 0), so F = 5·cos θ / sqrt(25·cos²θ + 9·sin²θ) for θ < 90°, 0
/// beyond. (The old sphere bound gave cos(θ − asin(1/4)) here; the box
/// bound separates the largest a from the smallest tangent gaps, which
/// is why it is not the exact cos θ of every direction to the segment.)
/// The f64 closed form shares no code with the bound. Tolerance 1e-6
/// relative (a dozen f32 roundings).
#[test]
fn reflectance_bound_over_the_box_known_answers() {
    let seg = node([3.0, 0.0, 0.0], [5.0, 0.0, 0.0], 1.0);
    let at = |p: Vec3, n: Vec3| {
        reflectance_bound(
            &seg,
            &Shading {
                p,
                n: n.normalize(),
            },
        )
    };
    for theta_deg in [10.0f64, 30.0, 45.0, 60.0, 89.0] {
        let t = theta_deg.to_radians();
        let n = Vec3::new(t.cos() as f32, t.sin() as f32, 0.0);
        let (c, s) = (t.cos(), t.sin());
        let want = 5.0 * c / (25.0 * c * c + 9.0 * s * s).sqrt();
        let got = at(Vec3::ZERO, n) as f64;
        assert!(
            (got - want).abs() < 1e-6 * want,
            "θ = {theta_deg}°: F = {got}, closed form {want}"
        );
        // Conservative: at least the true cosine, cos θ.
        assert!(got >= c - 1e-7, "θ = {theta_deg}°: F = {got} < cos θ = {c}");
    }
    // The segment on the tangent plane (n = +y) or behind it: 0.
    assert_eq!(at(Vec3::ZERO, Vec3::Y), 0.0);
    assert_eq!(at(Vec3::ZERO, Vec3::new(-1.0, 0.2, 0.0)), 0.0);
    // No normal: 1.
    assert_eq!(reflectance_bound(&seg, &Shading::default()), 1.0);
    // From the segment's end (3, 0, 0) every direction to it is +x: a
    // normal facing away gets 0 (the sphere bound said 1 here: the
    // point lies on the sphere, and "inside the sphere" was 1), …
    let end = Vec3::new(3.0, 0.0, 0.0);
    assert_eq!(at(end, Vec3::new(-0.6, 0.8, 0.0)), 0.0);
    // … a normal facing it 1 (the point is on the box: the tangent
    // gaps are 0).
    assert_eq!(at(end, Vec3::new(0.6, 0.8, 0.0)), 1.0);
    // Inside a solid box: 1 whatever the normal.
    let cube = node([-1.0; 3], [1.0; 3], 1.0);
    let inside = |n: Vec3| reflectance_bound(&cube, &Shading { p: Vec3::ZERO, n });
    assert_eq!(inside(Vec3::new(0.6, -0.8, 0.0)), 1.0);
    assert_eq!(inside(-Vec3::Z), 1.0);
}

/// The closed form x·(a, b, c) ↦ a/sqrt(a² + b² + c²) of the clamped
/// cosine from `x` with normal `n` toward `y`, in f64.
fn cosine_to(x: Vec3, n: Vec3, y: [f64; 3]) -> Option<f64> {
    let d = [y[0] - x.x as f64, y[1] - x.y as f64, y[2] - x.z as f64];
    let len = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
    (len > 1e-9).then(|| {
        let n = n.as_dvec3();
        ((n.x * d[0] + n.y * d[1] + n.z * d[2]) / len).max(0.0)
    })
}

/// F never falls below the true maximum of the clamped cosine over the
/// box, checked against dense sampling (a 17³ lattice through the box,
/// faces and corners included, plus 2,000 uniform points) on 3,000
/// random boxes (some flat along one or two axes), shading points
/// (outside, near, on the faces of and inside the box) and unit
/// normals. The sampled maximum is at most the true one, so F ≥ it is
/// necessary; the slack 1e-5 covers f32 rounding of F and of the
/// inputs. Also: F ≤ 1, and the bound is not vacuous (F < 1 in most
/// cases with the point outside).
#[test]
fn reflectance_bound_is_conservative_over_random_boxes() {
    use rand::rngs::StdRng;
    use rand::{RngExt, SeedableRng};
    let mut rng = StdRng::seed_from_u64(66);
    let mut below_one = 0;
    let mut outside = 0;
    for case in 0..3000 {
        let c: [f32; 3] = std::array::from_fn(|_| rng.random_range(-3.0..3.0));
        let mut h: [f32; 3] = std::array::from_fn(|_| rng.random_range(0.0..2.0));
        if case % 5 == 1 {
            h[case % 3] = 0.0;
        }
        if case % 7 == 2 {
            h[(case + 1) % 3] = 0.0;
            h[(case + 2) % 3] = 0.0;
        }
        let b = node(
            std::array::from_fn(|a| c[a] - h[a]),
            std::array::from_fn(|a| c[a] + h[a]),
            1.0,
        );
        let mut p = Vec3::new(
            rng.random_range(-6.0..6.0),
            rng.random_range(-6.0..6.0),
            rng.random_range(-6.0..6.0),
        );
        match case % 4 {
            // On a face (clamped onto the box, then one axis to a side).
            1 => {
                let a = rng.random_range(0..3usize);
                p = Vec3::from_array(std::array::from_fn(|k| p[k].clamp(b.min[k], b.max[k])));
                p[a] = if rng.random::<bool>() {
                    b.min[a]
                } else {
                    b.max[a]
                };
            }
            // Inside (or on a flat box).
            2 => {
                p = Vec3::from_array(std::array::from_fn(|k| {
                    rng.random_range(b.min[k]..=b.max[k])
                }))
            }
            _ => {}
        }
        let n = loop {
            let v = Vec3::new(
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
            );
            if v.length() > 0.1 && v.length() <= 1.0 {
                break v.normalize();
            }
        };
        let f = reflectance_bound(&b, &Shading { p, n }) as f64;
        assert!((0.0..=1.0).contains(&f), "F = {f}");
        let lerp = |a: usize, t: f64| b.min[a] as f64 + t * (b.max[a] - b.min[a]) as f64;
        let m = 16;
        let mut best = 0.0f64;
        for i in 0..=m {
            for j in 0..=m {
                for k in 0..=m {
                    let y = [
                        lerp(0, i as f64 / m as f64),
                        lerp(1, j as f64 / m as f64),
                        lerp(2, k as f64 / m as f64),
                    ];
                    best = best.max(cosine_to(p, n, y).unwrap_or(0.0));
                }
            }
        }
        for _ in 0..2000 {
            let y = std::array::from_fn(|a| lerp(a, rng.random::<f64>()));
            best = best.max(cosine_to(p, n, y).unwrap_or(0.0));
        }
        assert!(
            f >= best - 1e-5,
            "case {case}: box {b:?}, x = {p}, n = {n}: F = {f} < sampled max {best}"
        );
        let inside = (0..3).all(|a| b.min[a] <= p[a] && p[a] <= b.max[a]);
        if !inside {
            outside += 1;
            below_one += usize::from(f < 1.0);
        }
    }
    assert!(
        below_one * 2 > outside,
        "F < 1 in only {below_one} of {outside} cases outside the box"
    );
}

/// A box wholly on or below the tangent plane gets F = 0, hence W = 0:
/// boxes with a face on the plane of an axis normal (exact: every
/// n·(y − x) is 0 or negative in f32 too), and boxes below a random
/// tilted plane by a margin (every corner at least 1e-3 below it,
/// which f32 rounding cannot cross). The same boxes a little above the
/// plane get F > 0.
#[test]
fn reflectance_bound_is_zero_below_the_tangent_plane() {
    use rand::rngs::StdRng;
    use rand::{RngExt, SeedableRng};
    let mut rng = StdRng::seed_from_u64(67);
    let axes = [Vec3::X, Vec3::Y, Vec3::Z, -Vec3::X, -Vec3::Y, -Vec3::Z];
    for case in 0..600 {
        let n = axes[case % 6];
        let lo: [f32; 3] = std::array::from_fn(|_| rng.random_range(-3.0..3.0));
        let hi: [f32; 3] = std::array::from_fn(|a| lo[a] + rng.random_range(0.0..2.0));
        let b = node(lo, hi, 1.0);
        // x on the plane of the box's face toward n, or beyond it.
        let a = case % 3;
        let mut p = Vec3::new(
            rng.random_range(-6.0..6.0),
            rng.random_range(-6.0..6.0),
            rng.random_range(-6.0..6.0),
        );
        let sign = n[a];
        let face = if sign > 0.0 { hi[a] } else { lo[a] };
        p[a] = face
            + sign
                * if case % 2 == 0 {
                    0.0
                } else {
                    rng.random_range(0.0..2.0)
                };
        let s = Shading { p, n };
        assert_eq!(reflectance_bound(&b, &s), 0.0, "{b:?} from {p} along {n}");
        assert_eq!(node_importance(&b, None, &s).w, 0.0);
        // Raise x' plane below the box's far side: F > 0.
        let far = if sign > 0.0 { lo[a] } else { hi[a] };
        let mut q = p;
        q[a] = far - sign * 0.5;
        let f = reflectance_bound(&b, &Shading { p: q, n });
        assert!(f > 0.0, "{b:?} from {q} along {n}: F = {f}");
    }
    for _ in 0..600 {
        let n = Vec3::new(
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
        )
        .normalize();
        let p = Vec3::new(
            rng.random_range(-3.0..3.0),
            rng.random_range(-3.0..3.0),
            rng.random_range(-3.0..3.0),
        );
        // A box around a centre `depth` below the plane (moved along
        // it at random), small enough that every corner stays at
        // least 1e-3 below: n·(±h) ≤ Σ|n_a|·h_a ≤ depth − 1e-3.
        let depth = rng.random_range(0.01..3.0f32);
        let w = Vec3::new(
            rng.random_range(-2.0..2.0),
            rng.random_range(-2.0..2.0),
            rng.random_range(-2.0..2.0),
        );
        let c = p - depth * n + (w - n * n.dot(w));
        let reach = (depth - 1e-3) / (n.x.abs() + n.y.abs() + n.z.abs());
        let h = Vec3::new(
            rng.random_range(0.0..=reach),
            rng.random_range(0.0..=reach),
            rng.random_range(0.0..=reach),
        );
        let b = node((c - h).to_array(), (c + h).to_array(), 1.0);
        for i in 0..8 {
            let y = Vec3::new(
                if i & 1 == 0 { b.min[0] } else { b.max[0] },
                if i & 2 == 0 { b.min[1] } else { b.max[1] },
                if i & 4 == 0 { b.min[2] } else { b.max[2] },
            );
            assert!(n.as_dvec3().dot((y - p).as_dvec3()) < -5e-4, "setup");
        }
        assert_eq!(reflectance_bound(&b, &Shading { p, n }), 0.0);
    }
}

/// W = F·G·I with an orientation cone, against the closed form: the
/// node is the square [−1, 1] × {2} × [−1, 1] (centre (0, 2, 0),
/// r = √2) emitting downward (axis −y, θ_o = 0, θ_e = 90°), seen from
/// x = (4, 0, 0) with normal +y. F is over the box: the square reaches
/// a_max = 2 along n, and is at least 3 away along the tangent −x (0
/// along z, which it straddles), so F = 2/√13 — here the exact largest
/// cosine, at the square's point (1, 2, 0). G is over the sphere: the
/// centre is θ_w = atan2(4, 2) from the axis, the sphere's half-angle
/// θ_b = asin(√2/√20), G = cos(θ_w − θ_b) = cos 45°. So W = I·2/√13·
/// cos 45° (with the old sphere bound F was cos 45° as well: W = I/2).
/// The near clamp r²/16 = 1/8 is below dmin² = 9 + 4 = 13 and leaves
/// it. Tolerance 1e-6 relative (f32 rounding of a dozen operations).
#[test]
fn cone_importance_is_the_product_of_both_bounds() {
    let square = node([-1.0, 2.0, -1.0], [1.0, 2.0, 1.0], 3.0);
    let cone = LightCone {
        axis: [0.0, -1.0, 0.0],
        cos_o: 1.0,
        sin_o: 0.0,
        cos_e: 0.0,
        two_sided: 0,
        points: 0,
    };
    let s = Shading {
        p: Vec3::new(4.0, 0.0, 0.0),
        n: Vec3::Y,
    };
    let imp = node_importance(&square, Some(&cone), &s);
    let theta = (4.0f64).atan2(2.0);
    let theta_b = (2.0f64.sqrt() / 20.0f64.sqrt()).asin();
    let want = 3.0 * (2.0 / 13.0f64.sqrt()) * (theta - theta_b).cos();
    assert!(
        ((imp.w as f64) - want).abs() < 1e-6 * want,
        "W = {}, closed form {want}",
        imp.w
    );
    assert!((want - 3.0 * (2.0 / 13.0f64.sqrt()) * 0.5f64.sqrt()).abs() < 1e-12);
    // dmin²: gaps 3, 2, 0; dmax²: 5, 2, 1.
    assert_eq!((imp.dmin2, imp.dmax2), (13.0, 30.0));
    // The same node emitting upward faces away from x: W = 0.
    let up = LightCone {
        axis: [0.0, 1.0, 0.0],
        ..cone
    };
    assert_eq!(node_importance(&square, Some(&up), &s).w, 0.0);
    // Two-sided, it emits toward x again.
    let both = LightCone { two_sided: 1, ..up };
    assert_eq!(node_importance(&square, Some(&both), &s).w, imp.w);
}

/// The fallback of eq. 2 when both weighted distances vanish (x inside
/// both boxes): W_j/(W_j + W_k) for that half, the ordinary rule for
/// the other. Here p_min falls back to 1/2 and p_max = 4/(4 + 1), so
/// p_left = 0.65.
#[test]
fn p_left_falls_back_to_the_weights_inside_both_boxes() {
    let imp = |dmin2: f32, dmax2: f32, w: f32| NodeImportance { dmin2, dmax2, w };
    let (j, k) = (imp(0.0, 1.0, 1.0), imp(0.0, 4.0, 1.0));
    assert_eq!(p_left(&j, &k), Some(0.5 * (0.5 + 0.8)));
    // Equal weighted distances (W_j·d_k = W_k·d_j = 2) are an ordinary
    // tie, 1/2, not the fallback's W_j/(W_j + W_k) = 1/3.
    let (near, far) = (imp(1.0, 1.0, 1.0), imp(2.0, 2.0, 2.0));
    assert_eq!(p_left(&near, &far), Some(0.5));
    // At u = p_left exactly the right child is taken, with u = 0.
    assert_eq!(choose_child(0.25, 0.25), (false, 0.75, 0.0));
}

/// The authors' finite key W / max(dmin², floor²) (the old key was +∞
/// for dmin² = 0, whatever W).
#[test]
fn cut_keys() {
    let imp = |dmin2: f32, w: f32| NodeImportance {
        dmin2,
        dmax2: 9.0,
        w,
    };
    let floor2 = 0.25;
    assert_eq!(cut_key(&imp(4.0, 2.0), floor2), 0.5);
    // Inside the box: W over the floor, not +∞.
    assert_eq!(cut_key(&imp(0.0, 2.0), floor2), 8.0);
    assert_eq!(cut_key(&imp(0.125, 2.0), floor2), 8.0);
    // W = 0 gives 0, inside the box too.
    assert_eq!(cut_key(&imp(4.0, 0.0), floor2), 0.0);
    assert_eq!(cut_key(&imp(0.0, 0.0), floor2), 0.0);
    assert_eq!(cut_key(&imp(0.0, 0.0), 0.0), 0.0);
    // No floor (lights at one point) inside the box: the largest f32;
    // an overflowing quotient is capped there too.
    assert_eq!(cut_key(&imp(0.0, 2.0), 0.0), f32::MAX);
    assert_eq!(cut_key(&imp(1e-30, 1e30), 0.0), f32::MAX);
    // The floor: (10⁻³ · diagonal)², the diagonal of [0, 3] × [0, 4] ×
    // {1} being 5; 0 for EMPTY bounds.
    let root = node([0.0, 0.0, 1.0], [3.0, 4.0, 1.0], 1.0);
    let e = 1e-3f32 * 5.0;
    assert_eq!(cut_key_floor2(&root), e * e);
    assert_eq!(cut_key_floor2(&TreeNode::EMPTY), 0.0);
}

/// Cut node probabilities against eq. 2 over n nodes worked by hand.
#[test]
fn cut_probabilities_known_answers() {
    let imp = |dmin2: f32, dmax2: f32, w: f32| NodeImportance { dmin2, dmax2, w };
    let close = |got: &[f32], want: &[f64]| {
        assert_eq!(got.len(), want.len());
        for (g, w) in got.iter().zip(want) {
            assert!(((*g as f64) - w).abs() < 1e-6, "{got:?} against {want:?}");
        }
    };
    // Outside every box; a dead node (all 0) takes no share and is not
    // "inside" although its dmin² is 0. W/W_max = 1, 1/2, 0:
    // p_min ∝ 1, 1/8, 0 → 8/9, 1/9; p_max ∝ 1/4, 1/8 → 2/3, 1/3.
    let dead = NodeImportance::default();
    let p = cut_probabilities(&[imp(1.0, 4.0, 2.0), imp(4.0, 4.0, 1.0), dead]).unwrap();
    close(&p, &[7.0 / 9.0, 2.0 / 9.0, 0.0]);
    // x inside the first box: p_min is all that node's; p_max ∝ (1/3)/4,
    // 1/9, 0 → 3/7, 4/7.
    let p = cut_probabilities(&[imp(0.0, 4.0, 1.0), imp(1.0, 9.0, 3.0), dead]).unwrap();
    close(&p, &[5.0 / 7.0, 2.0 / 7.0, 0.0]);
    // Inside a dim box (W = 1e-10) beside a bright one only 1e-6 away
    // (dmin² = 1e-12): p_min is still all the box around x's, not the
    // 1e-20-clamped inverse square's (which would give the bright node
    // 99 %); p_max ∝ 1e-10, 1 → [1e-10, 1]/(1 + 1e-10).
    let p = cut_probabilities(&[imp(0.0, 4.0, 1e-10), imp(1e-12, 4.0, 1.0)]).unwrap();
    close(&p, &[0.5 * (1.0 + 1e-10), 0.5]);
    // Inside two live boxes: p_min splits by W alone (1 : 3).
    let p = cut_probabilities(&[imp(0.0, 4.0, 1.0), imp(0.0, 4.0, 3.0)]).unwrap();
    close(&p, &[0.25, 0.75]);
    // Intensities near f32's limit stay finite (weights are divided by
    // the largest before they are summed): the first example scaled.
    let p = cut_probabilities(&[imp(1.0, 4.0, 2e38), imp(4.0, 4.0, 1e38), dead]).unwrap();
    close(&p, &[7.0 / 9.0, 2.0 / 9.0, 0.0]);
    // Every node dead: none.
    assert_eq!(cut_probabilities(&[dead, dead]), None);
}

#[test]
fn cut_node_choice() {
    let probs = [0.25, 0.0, 0.75];
    assert_eq!(choose_cut_node(&probs, 0.0), (0, 0.0));
    assert_eq!(choose_cut_node(&probs, 0.25), (2, 0.0));
    assert_eq!(choose_cut_node(&probs, ONE_MINUS_EPSILON).0, 2);
    // Rounding that leaves the CDF below u: the last live node.
    assert_eq!(choose_cut_node(&[0.5, 0.4999, 0.0], 0.99995).0, 1);
}
