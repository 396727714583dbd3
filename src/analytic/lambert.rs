//! Lambert's polygon formula: the irradiance from a planar polygon of
//! uniform radiance, with horizon clipping.

use glam::DVec3;

/// Irradiance at point `p` with surface normal `n` (need not be unit length)
/// from a planar polygonal emitter of uniform radiance `radiance`, by
/// Lambert's formula
///
/// ```text
/// E(p) = (L/2) · |Σ_k θ_k · (n · normalize(r_k × r_{k+1}))|,   r_k = v_k − p,
/// ```
///
/// θ_k being the angle between r_k and r_{k+1} (computed as
/// `atan2(|r_k × r_{k+1}|, r_k · r_{k+1})`, accurate for small and large
/// angles).
///
/// Conventions and special cases:
///
/// - The emitter is **one-sided**: its normal is the vector area of the
///   polygon, which for a convex polygon points along (v1 − v0) × (v2 − v0)
///   (counter-clockwise seen from the lit side, as in docs/conventions.md
///   "Materials"). A point `p` on the back side or in the emitter's plane
///   gets 0. With that orientation
///   the sum above is negative, so E = −(L/2)·Σ; tiny negative values from
///   rounding are clamped to 0.
/// - **Horizon clipping is implemented**: if part of the polygon lies below
///   the receiver's tangent plane (v − p) · n < 0, the polygon is clipped to
///   the upper half-space first (Sutherland–Hodgman against one plane), which
///   makes the formula exact in every configuration. In `area_light_plane` the
///   light lies entirely above the square, so this path is not taken there.
/// - Fewer than 3 vertices or a zero-area polygon give 0. A zero (or
///   non-finite) `n` gives NaN, and non-finite inputs propagate as NaN.
/// - The polygon should be planar and simple (not self-intersecting); for a
///   non-planar one the result is the formula's value, not a physical answer.
pub fn lambert_polygon_irradiance(p: DVec3, n: DVec3, verts: &[DVec3], radiance: f64) -> f64 {
    if verts.len() < 3 {
        return 0.0;
    }
    let n = n.normalize_or_zero();
    if n == DVec3::ZERO {
        return f64::NAN;
    }
    let area_vector = polygon_area_vector(verts);
    if area_vector.length_squared() == 0.0 {
        return 0.0;
    }
    let centroid = verts.iter().copied().sum::<DVec3>() / verts.len() as f64;
    if (p - centroid).dot(area_vector) <= 0.0 {
        // Behind the one-sided emitter, or in its plane.
        return 0.0;
    }

    let sum = if verts.iter().all(|&v| (v - p).dot(n) >= 0.0) {
        signed_edge_sum(p, n, verts)
    } else {
        let clipped = clip_to_upper_half_space(p, n, verts);
        if clipped.len() < 3 {
            return 0.0;
        }
        signed_edge_sum(p, n, &clipped)
    };
    radiance * (-0.5 * sum).max(0.0)
}

/// Twice the vector area of a (closed) polygon, Σ (v_k − v_0) × (v_{k+1} − v_0):
/// normal to a planar polygon, pointing to the side from which it is seen
/// counter-clockwise.
pub(super) fn polygon_area_vector(verts: &[DVec3]) -> DVec3 {
    let v0 = verts[0];
    verts
        .windows(2)
        .map(|edge| (edge[0] - v0).cross(edge[1] - v0))
        .sum()
}

/// Σ_k θ_k (n · ĉ_k) with c_k = r_k × r_{k+1}; edges through p are skipped.
pub(super) fn signed_edge_sum(p: DVec3, n: DVec3, verts: &[DVec3]) -> f64 {
    let count = verts.len();
    let mut sum = 0.0;
    for k in 0..count {
        let a = verts[k] - p;
        let b = verts[(k + 1) % count] - p;
        let c = a.cross(b);
        let c_length = c.length();
        if c_length > 0.0 {
            let theta = c_length.atan2(a.dot(b));
            sum += theta * n.dot(c) / c_length;
        }
    }
    sum
}

/// Clips a polygon to the half-space (v − p) · n ≥ 0, keeping its orientation.
pub(super) fn clip_to_upper_half_space(p: DVec3, n: DVec3, verts: &[DVec3]) -> Vec<DVec3> {
    let mut clipped = Vec::with_capacity(verts.len() + 1);
    for k in 0..verts.len() {
        let current = verts[k];
        let next = verts[(k + 1) % verts.len()];
        let d_current = (current - p).dot(n);
        let d_next = (next - p).dot(n);
        if d_current >= 0.0 {
            clipped.push(current);
        }
        if (d_current >= 0.0) != (d_next >= 0.0) {
            let t = d_current / (d_current - d_next);
            clipped.push(current + (next - current) * t);
        }
    }
    clipped
}
