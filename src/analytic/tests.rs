use super::lambert::*;
use super::quadrature::*;
use super::*;

const W: u32 = AREA_LIGHT_PLANE_WIDTH;
const H: u32 = AREA_LIGHT_PLANE_HEIGHT;

fn relative_difference(a: f64, b: f64) -> f64 {
    if a == b {
        0.0
    } else {
        (a - b).abs() / a.abs().max(b.abs())
    }
}

/// E below the centre of a square of side a at height h (derivation: each
/// of the four edges, seen from p, subtends θ = 2·atan(s/√(s²+h²)) with
/// s = a/2, and |n·ĉ| = s/√(s²+h²); Lambert's formula gives
/// E = (L/2)·4·θ·|n·ĉ| = 4L·q·atan(q), q = a/√(a²+4h²); this equals π L
/// times four corner form factors of the a/2 × a/2 quadrants).
fn square_centre_irradiance(side: f64, h: f64, radiance: f64) -> f64 {
    let q = side / (side * side + 4.0 * h * h).sqrt();
    4.0 * radiance * q * q.atan()
}

/// Brute-force E(p) from a parallelogram emitter v0, v0+e1, v0+e1+e2,
/// v0+e2 (normal e1 × e2, one-sided), by tensor Gauss–Legendre over the
/// emitter's area of L·max(0, cosθ_p)·max(0, cosθ_e)/d².
fn brute_force_irradiance(
    p: DVec3,
    n: DVec3,
    quad: &[DVec3; 4],
    radiance: f64,
    subcells: u32,
    order: usize,
) -> f64 {
    let n = n.normalize();
    let v0 = quad[0];
    let e1 = quad[1] - quad[0];
    let e2 = quad[3] - quad[0];
    let normal = e1.cross(e2);
    let area = normal.length();
    let emitter_normal = normal / area;
    let quadrature = PixelQuadrature {
        rule: GaussLegendre::new(order),
        subcells,
        dense_samples: 1,
    };
    let integrand = |s: f64, t: f64| {
        let w = v0 + s * e1 + t * e2 - p;
        let d2 = w.length_squared();
        let d = d2.sqrt();
        let cos_receiver = (n.dot(w) / d).max(0.0);
        let cos_emitter = (-emitter_normal.dot(w) / d).max(0.0);
        radiance * cos_receiver * cos_emitter / d2 * area
    };
    quadrature.integrate_smooth(integrand, 0.0, 1.0, 0.0, 1.0)
}

#[test]
fn gauss_legendre_integrates_polynomials_exactly() {
    for order in [1usize, 2, 5, 8, 16, 32] {
        let rule = GaussLegendre::new(order);
        let weight_sum: f64 = rule.weights.iter().sum();
        assert!((weight_sum - 2.0).abs() < 1e-14, "order {order}");
        // ∫_{-1}^{1} x^k dx for k up to 2·order − 1.
        for k in 0..(2 * order) {
            let exact = if k % 2 == 1 {
                0.0
            } else {
                2.0 / (k as f64 + 1.0)
            };
            let approx: f64 = rule
                .nodes
                .iter()
                .zip(&rule.weights)
                .map(|(x, w)| w * x.powi(k as i32))
                .sum();
            assert!((approx - exact).abs() < 1e-13, "order {order}, x^{k}");
        }
    }
}

#[test]
fn irradiance_below_centre_matches_closed_form() {
    for h in [0.05, 0.25, 1.0, 2.0, 10.0, 1000.0] {
        let p = DVec3::new(0.0, 2.0 - h, 0.0);
        let e = lambert_polygon_irradiance(p, DVec3::Y, &LIGHT_VERTICES, LIGHT_RADIANCE);
        let exact = square_centre_irradiance(1.0, h, LIGHT_RADIANCE);
        assert!(
            relative_difference(e, exact) < 1e-12,
            "h={h}: {e} vs {exact}"
        );
    }
    // At h = 2 (the scene's plane): q = 1/√17, E = 40 q atan q ≈ 2.3084.
    let e = lambert_polygon_irradiance(DVec3::ZERO, DVec3::Y, &LIGHT_VERTICES, 10.0);
    assert!((e - 2.308_4).abs() < 1e-4, "{e}");
    // Far away it tends to L·A·h²/h⁴ (a point source of intensity L·A).
    let far = lambert_polygon_irradiance(
        DVec3::new(0.0, -998.0, 0.0),
        DVec3::Y,
        &LIGHT_VERTICES,
        10.0,
    );
    assert!(relative_difference(far, 10.0 / 1000.0f64.powi(2)) < 1e-5);
}

#[test]
fn irradiance_matches_brute_force_off_centre() {
    let points = [
        DVec3::new(0.0, 0.0, 0.0),
        DVec3::new(0.5, 0.0, 0.5),
        DVec3::new(0.3, 0.0, -0.2),
        DVec3::new(3.0, 0.0, -2.0),
        DVec3::new(-9.5, 0.0, 9.5),
        DVec3::new(0.1, 1.5, 0.2),
        DVec3::new(-0.7, 1.2, 0.4),
    ];
    for p in points {
        let e = lambert_polygon_irradiance(p, DVec3::Y, &LIGHT_VERTICES, LIGHT_RADIANCE);
        let brute = brute_force_irradiance(p, DVec3::Y, &LIGHT_VERTICES, LIGHT_RADIANCE, 16, 16);
        assert!(e > 0.0);
        assert!(relative_difference(e, brute) < 1e-10, "{p}: {e} vs {brute}");
    }
    // A tilted receiver whose hemisphere still contains the whole light.
    let p = DVec3::new(2.0, 0.0, 1.0);
    let n = DVec3::new(-0.3, 1.0, -0.2);
    let e = lambert_polygon_irradiance(p, n, &LIGHT_VERTICES, LIGHT_RADIANCE);
    let brute = brute_force_irradiance(p, n, &LIGHT_VERTICES, LIGHT_RADIANCE, 16, 16);
    assert!(relative_difference(e, brute) < 1e-10, "{e} vs {brute}");
}

#[test]
fn irradiance_clips_to_the_receiver_hemisphere() {
    // Receiver facing +x just below the light: exactly half the light
    // (x > 0) is above its horizon. The kink is at s = 1/2, a sub-cell
    // boundary, so the brute force stays very accurate.
    let p = DVec3::new(0.0, 1.5, 0.0);
    let n = DVec3::X;
    let e = lambert_polygon_irradiance(p, n, &LIGHT_VERTICES, LIGHT_RADIANCE);
    let brute = brute_force_irradiance(p, n, &LIGHT_VERTICES, LIGHT_RADIANCE, 16, 16);
    assert!(e > 0.0);
    assert!(relative_difference(e, brute) < 1e-10, "{e} vs {brute}");

    // A diagonal horizon: the kink cuts through cells, so use many small
    // cells (error O(cell size²)).
    let p = DVec3::new(0.2, 1.0, 0.1);
    let n = DVec3::new(1.0, 1.0, 0.3);
    let e = lambert_polygon_irradiance(p, n, &LIGHT_VERTICES, LIGHT_RADIANCE);
    let brute = brute_force_irradiance(p, n, &LIGHT_VERTICES, LIGHT_RADIANCE, 256, 2);
    assert!(relative_difference(e, brute) < 1e-5, "{e} vs {brute}");

    // Light entirely below the horizon.
    let e = lambert_polygon_irradiance(DVec3::new(0.0, 1.0, 0.0), -DVec3::Y, &LIGHT_VERTICES, 10.0);
    assert_eq!(e, 0.0);
}

#[test]
fn irradiance_is_one_sided_and_handles_degenerate_input() {
    // Above the downward-facing light, or in its plane: nothing.
    for p in [DVec3::new(0.0, 3.0, 0.0), DVec3::new(0.2, 2.0, 5.0)] {
        assert_eq!(
            lambert_polygon_irradiance(p, -DVec3::Y, &LIGHT_VERTICES, 10.0),
            0.0
        );
        assert_eq!(
            lambert_polygon_irradiance(p, DVec3::Y, &LIGHT_VERTICES, 10.0),
            0.0
        );
    }
    // Reversing the vertex order flips the emitting side.
    let mut reversed = LIGHT_VERTICES;
    reversed.reverse();
    let above = lambert_polygon_irradiance(DVec3::new(0.1, 3.0, 0.2), -DVec3::Y, &reversed, 10.0);
    let below =
        lambert_polygon_irradiance(DVec3::new(0.1, 1.0, 0.2), DVec3::Y, &LIGHT_VERTICES, 10.0);
    assert!(relative_difference(above, below) < 1e-13);
    assert_eq!(
        lambert_polygon_irradiance(DVec3::new(0.1, 1.0, 0.2), DVec3::Y, &reversed, 10.0),
        0.0
    );

    assert_eq!(
        lambert_polygon_irradiance(DVec3::ZERO, DVec3::Y, &LIGHT_VERTICES[..2], 10.0),
        0.0
    );
    let collinear = [
        DVec3::new(0.0, 2.0, 0.0),
        DVec3::new(1.0, 2.0, 0.0),
        DVec3::new(2.0, 2.0, 0.0),
    ];
    assert_eq!(
        lambert_polygon_irradiance(DVec3::ZERO, DVec3::Y, &collinear, 10.0),
        0.0
    );
    assert!(lambert_polygon_irradiance(DVec3::ZERO, DVec3::ZERO, &LIGHT_VERTICES, 10.0).is_nan());
    // The normal need not be unit length.
    let unit = lambert_polygon_irradiance(DVec3::ZERO, DVec3::Y, &LIGHT_VERTICES, 10.0);
    let scaled = lambert_polygon_irradiance(DVec3::ZERO, 7.0 * DVec3::Y, &LIGHT_VERTICES, 10.0);
    assert_eq!(unit, scaled);
}

#[test]
fn camera_follows_design_conventions() {
    let camera = Camera::area_light_plane();
    // r is exactly +x, so the far edge projects onto a film row.
    assert_eq!(camera.right, DVec3::X);
    assert_eq!(camera.up.x, 0.0);
    assert!(camera.up.y > 0.0);
    // The film centre looks at look_at.
    let (w, h) = (f64::from(W), f64::from(H));
    let centre = trace_plane(camera.position, camera.direction(0.5 * w, 0.5 * h, w, h)).unwrap();
    assert!(centre.length() < 1e-12, "{centre}");
    // Film x grows to the right (+x), film y grows downward (toward the camera).
    let right = trace_plane(camera.position, camera.direction(0.75 * w, 0.5 * h, w, h)).unwrap();
    assert!(right.x > 0.0);
    let lower = trace_plane(camera.position, camera.direction(0.5 * w, 0.75 * h, w, h)).unwrap();
    assert!(lower.z > 0.0);
    // project() inverts direction().
    let (x, y) = camera.project(right, w, h).unwrap();
    assert!((x - 0.75 * w).abs() < 1e-9 && (y - 0.5 * h).abs() < 1e-9);
    // Centre pixel radiance is ρ/π times the closed-form E at h = 2.
    let film = AreaLightPlaneFilm::new(W, H);
    let expected = PLANE_ALBEDO / std::f64::consts::PI * square_centre_irradiance(1.0, 2.0, 10.0);
    assert!(relative_difference(film.radiance(0.5 * w, 0.5 * h), expected) < 1e-12);
}

#[test]
fn light_and_side_edges_are_out_of_view() {
    for (width, height) in [(W, H), (64, 48), (256, 192)] {
        let camera = Camera::area_light_plane();
        let (w, h) = (f64::from(width), f64::from(height));
        for corner in LIGHT_VERTICES {
            // In front of the camera but above the top of the film.
            let (_, y) = camera.project(corner, w, h).unwrap();
            assert!(y < 0.0, "light corner {corner} projects to film y = {y}");
        }
        // The side edges x = ±10 (for z from the far edge to just in front
        // of the camera) project left/right of the film, and the near
        // edge z = 10 is behind the camera.
        for k in 0..=1000 {
            let z = -10.0 + 13.99 * f64::from(k) / 1000.0;
            for x_edge in [-10.0, 10.0] {
                if let Some((x, _)) = camera.project(DVec3::new(x_edge, 0.0, z), w, h) {
                    assert!(
                        x < 0.0 || x > w,
                        "side edge point ({x_edge}, 0, {z}) at film x = {x}"
                    );
                }
            }
        }
        assert!(camera.project(DVec3::new(0.0, 0.0, 10.0), w, h).is_none());
        // The far edge is inside the film, below the horizon.
        let film = AreaLightPlaneFilm::new(width, height);
        let horizon_y = camera
            .project(camera.position + DVec3::new(0.0, 0.0, -1.0), w, h)
            .unwrap()
            .1;
        assert!(0.0 < horizon_y && horizon_y < film.far_edge_y && film.far_edge_y < h);
    }
    let film = AreaLightPlaneFilm::new(W, H);
    assert!(
        (film.far_edge_y - 37.70).abs() < 0.01,
        "{}",
        film.far_edge_y
    );
}

#[test]
fn pixels_are_zero_above_the_far_edge_and_positive_below() {
    let image = area_light_plane_image(W, H);
    assert_eq!(image.len(), (W * H) as usize);
    let far_edge_y = AreaLightPlaneFilm::new(W, H).far_edge_y;
    for j in 0..H {
        for i in 0..W {
            let v = image[(j * W + i) as usize];
            assert!(v[0] == v[1] && v[1] == v[2]);
            assert!(v[0].is_finite());
            if f64::from(j + 1) <= far_edge_y {
                assert_eq!(v[0], 0.0, "pixel ({i}, {j}) above the far edge");
            } else {
                assert!(v[0] > 0.0, "pixel ({i}, {j}) sees the plane");
            }
        }
    }
    // Rows above the horizon (y ≈ 33.5) are in particular all zero.
    assert!(image[..(33 * W) as usize].iter().all(|v| v[0] == 0.0));
    // The brightest pixels are near the centre (below the light).
    let centre = image[(48 * W + 64) as usize][0];
    let corner = image[(95 * W) as usize][0];
    assert!(centre > corner);
}

#[test]
fn image_is_symmetric_about_the_vertical_centre_line() {
    let image = area_light_plane_image(W, H);
    for j in 0..H {
        for i in 0..W / 2 {
            let a = f64::from(image[(j * W + i) as usize][0]);
            let b = f64::from(image[(j * W + (W - 1 - i)) as usize][0]);
            assert!(relative_difference(a, b) < 1e-6, "({i}, {j}): {a} vs {b}");
        }
    }
}

#[test]
fn pixel_means_match_a_much_higher_order_rule() {
    let film = AreaLightPlaneFilm::new(W, H);
    let standard = PixelQuadrature::standard(W, H);
    let high = PixelQuadrature {
        rule: GaussLegendre::new(16),
        subcells: 8,
        dense_samples: 256,
    };
    let pixels = [
        (64, 48), // below the light
        (63, 47),
        (0, 95),   // bottom-left corner
        (127, 95), // bottom-right corner
        (64, 95),
        (20, 40), // near the far edge, grazing
        (100, 38),
        (5, 37), // straddles the far edge
        (64, 37),
    ];
    for (i, j) in pixels {
        let a = film.pixel_mean(i, j, &standard);
        let b = film.pixel_mean(i, j, &high);
        assert!(b > 0.0);
        assert!(
            relative_difference(a, b) < 1e-9,
            "pixel ({i}, {j}): {a} vs {b}"
        );
    }
    // Coarser films (a `--scale` render) use proportionally more sub-cells.
    for (width, height, i, j) in [
        (64, 48, 32, 24),
        (64, 48, 10, 19),
        (64, 48, 2, 18), // straddles the far edge
        (32, 24, 16, 23),
        (32, 24, 5, 9), // straddles the far edge
    ] {
        let film = AreaLightPlaneFilm::new(width, height);
        let a = film.pixel_mean(i, j, &PixelQuadrature::standard(width, height));
        let b = film.pixel_mean(i, j, &high);
        assert!(b > 0.0);
        assert!(
            relative_difference(a, b) < 1e-9,
            "{width}x{height} pixel ({i}, {j}): {a} vs {b}"
        );
    }
    // The public per-pixel function agrees with the image.
    let image = area_light_plane_image(W, H);
    for (i, j) in pixels {
        let p = area_light_plane_pixel(i, j, W, H);
        assert_eq!(p[0] as f32, image[(j * W + i) as usize][0]);
    }
}

#[test]
fn far_edge_row_matches_brute_force_without_the_edge_split() {
    // Midpoint rule over the whole footprint (many rows, since the
    // discontinuity is horizontal), not using far_edge_y at all.
    let film = AreaLightPlaneFilm::new(W, H);
    for i in [3u32, 64, 90] {
        let j = 37u32;
        let (rows, columns) = (8192u32, 16u32);
        let mut sum = 0.0;
        for sy in 0..rows {
            let y = f64::from(j) + (f64::from(sy) + 0.5) / f64::from(rows);
            for sx in 0..columns {
                let x = f64::from(i) + (f64::from(sx) + 0.5) / f64::from(columns);
                sum += film.radiance(x, y);
            }
        }
        let brute = sum / f64::from(rows * columns);
        let exact = area_light_plane_pixel(i, j, W, H)[0];
        assert!(
            relative_difference(exact, brute) < 5e-4,
            "pixel ({i}, {j}): {exact} vs {brute}"
        );
    }
}

#[test]
fn scaled_render_averages_the_full_resolution_pixels() {
    // At half resolution, a pixel's footprint is a 2×2 block of the
    // full-resolution film, so its mean is the mean of those four pixels.
    let full = area_light_plane_image(W, H);
    let half = area_light_plane_image(W / 2, H / 2);
    assert_eq!(half.len(), (W * H / 4) as usize);
    for j in 0..H / 2 {
        for i in 0..W / 2 {
            let block: f64 = [(0, 0), (1, 0), (0, 1), (1, 1)]
                .iter()
                .map(|(di, dj)| f64::from(full[((2 * j + dj) * W + 2 * i + di) as usize][0]))
                .sum::<f64>()
                / 4.0;
            let value = f64::from(half[(j * W / 2 + i) as usize][0]);
            assert!(
                (value - block).abs() <= 1e-6 * value.abs().max(1e-6),
                "half-res pixel ({i}, {j}): {value} vs {block}"
            );
        }
    }
}

#[test]
fn empty_film_is_handled() {
    assert!(area_light_plane_image(0, 96).is_empty());
    assert!(area_light_plane_image(128, 0).is_empty());
    assert!(area_light_plane_pixel(0, 0, 0, 96)[0].is_nan());
}
