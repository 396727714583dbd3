//! The area of a film rectangle on one side of a line: the closed form of
//! any integrand that is a step across a straight film-space edge (a
//! silhouette, a shadow boundary seen head-on, a moving edge at one
//! instant), for known-answer tests and `examples/custom_integrand.rs`.

/// Area of the rectangle [x0, x0 + w] × [y0, y0 + h] where
/// `normal · p < c`: the rectangle clipped by the half-plane
/// (Sutherland–Hodgman against one line) and measured by the shoelace
/// formula, in f64. Exact up to rounding for any line, including ones
/// through a corner or along a side (a point on the line counts as
/// inside; the set of such points has no area). `normal` need not be
/// unit length; a zero normal gives the whole area when 0 < c and 0
/// otherwise. The pixel (i, j) of the raster convention
/// (docs/conventions.md "Raster") is
/// `half_plane_area([i, j], [1, 1], …)`, and its mean over a step of
/// values a (inside) and b (outside) is `b + (a − b)·area`.
///
/// ```
/// use mdas::analytic::half_plane_area;
/// // The diagonal x + y < 1 halves the unit square.
/// assert!((half_plane_area([0.0, 0.0], [1.0, 1.0], [1.0, 1.0], 1.0) - 0.5).abs() < 1e-15);
/// // x < 0.25 keeps a quarter of it.
/// assert!((half_plane_area([0.0, 0.0], [1.0, 1.0], [1.0, 0.0], 0.25) - 0.25).abs() < 1e-15);
/// ```
pub fn half_plane_area(origin: [f64; 2], size: [f64; 2], normal: [f64; 2], c: f64) -> f64 {
    let [x0, y0] = origin;
    let [w, h] = size;
    let corners = [(x0, y0), (x0 + w, y0), (x0 + w, y0 + h), (x0, y0 + h)];
    // g ≥ 0 inside (on the line counts as inside).
    let g = |(x, y): (f64, f64)| c - (normal[0] * x + normal[1] * y);
    let mut poly = Vec::with_capacity(5);
    for k in 0..4 {
        let (a, b) = (corners[k], corners[(k + 1) % 4]);
        let (ga, gb) = (g(a), g(b));
        if ga >= 0.0 {
            poly.push(a);
        }
        if (ga >= 0.0) != (gb >= 0.0) {
            let s = ga / (ga - gb);
            poly.push((a.0 + s * (b.0 - a.0), a.1 + s * (b.1 - a.1)));
        }
    }
    let n = poly.len();
    (0..n)
        .map(|k| {
            let (p, q) = (poly[k], poly[(k + 1) % n]);
            p.0 * q.1 - q.0 * p.1
        })
        .sum::<f64>()
        .abs()
        / 2.0
}

#[cfg(test)]
mod tests {
    use super::half_plane_area;

    /// Against the independent closed form of a vertical or horizontal
    /// line (a clamped length times the other side) and against the
    /// complement: area(n, c) + area(−n, −c) = w·h for any line.
    #[test]
    fn axis_lines_and_complements() {
        let (o, s) = ([2.0, -1.0], [3.0, 0.5]);
        for t in [-1.0, 2.0, 2.7, 4.5, 5.0, 6.0] {
            let want = (t - 2.0f64).clamp(0.0, 3.0) * 0.5;
            assert!(
                (half_plane_area(o, s, [1.0, 0.0], t) - want).abs() < 1e-12,
                "x < {t}"
            );
            // The same line written with a scaled normal.
            let scaled = half_plane_area(o, s, [4.0, 0.0], 4.0 * t);
            assert!((scaled - want).abs() < 1e-12, "4x < 4·{t}");
        }
        for t in [-2.0, -1.0, -0.8, -0.5, 0.0] {
            let want = (t + 1.0f64).clamp(0.0, 0.5) * 3.0;
            assert!(
                (half_plane_area(o, s, [0.0, 1.0], t) - want).abs() < 1e-12,
                "y < {t}"
            );
        }
        for (n, c) in [([0.8, 0.6], 1.3), ([-0.3, 2.0], -1.1), ([1.0, -1.0], 3.9)] {
            let sum = half_plane_area(o, s, n, c) + half_plane_area(o, s, [-n[0], -n[1]], -c);
            assert!((sum - 1.5).abs() < 1e-12, "{n:?} {c}: {sum}");
        }
        assert_eq!(half_plane_area(o, s, [0.0, 0.0], 1.0), 1.5);
        assert_eq!(half_plane_area(o, s, [0.0, 0.0], -1.0), 0.0);
    }

    /// A diagonal through the square's corners, and a general line against
    /// the triangle it cuts off (area ½·a·b with a, b the intercepts).
    #[test]
    fn diagonals_and_corner_triangles() {
        let unit = ([0.0, 0.0], [1.0, 1.0]);
        assert!((half_plane_area(unit.0, unit.1, [1.0, -1.0], 0.0) - 0.5).abs() < 1e-15);
        // x/a + y/b < 1 with a = 0.6, b = 0.3: the corner triangle.
        let (a, b) = (0.6, 0.3);
        let area = half_plane_area(unit.0, unit.1, [1.0 / a, 1.0 / b], 1.0);
        assert!((area - 0.5 * a * b).abs() < 1e-15, "{area}");
    }
}
