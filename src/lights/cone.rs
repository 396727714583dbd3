//! Orientation bounds of lights and light-tree nodes ("cones", Conty &
//! Kulla 2018; pbrt-v4's `LightBounds`): every light below a node emits
//! only in directions within `θ_o` of the axis `w` (or of `−w` too when
//! two-sided), and its emission falls to zero beyond a further `θ_e`.
//!
//! | light | axis | `θ_o` | `θ_e` |
//! |---|---|---|---|
//! | isotropic point light | any | π (every direction) | π/2 |
//! | degenerate (zero-area) triangle | any | π | π/2 |
//! | virtual point light (a cosine lobe) | its normal | 0 (+ [`SLACK`]) | π/2 |
//! | one-sided Lambertian triangle | its normal | 0 (+ [`SLACK`]) | π/2 |
//! | a node | from [`LightCone::union`] | covers its children | min of the children's |
//!
//! # Representation
//!
//! `θ_o` is stored as the pair `(cos θ_o, sin θ_o)` (`θ_o ∈ [0, π]`), so
//! that merging never takes `acos` of a cosine near 1 (ill-conditioned: an
//! ulp of `cos θ` is `3·10⁻⁴` rad at `θ = 0`) and builds need no
//! transcendental function: every angle below is a unit pair `(cos, sin)`,
//! added and subtracted with the angle-sum identities and renormalised.
//! WGSL does not round `sqrt` and division exactly, so the GPU build's
//! cones may differ from these in the last bits; every cone is therefore
//! widened by [`SLACK`] when it is built, which covers such rounding many
//! times over, and the GPU cones are compared with these with a stated
//! tolerance (`tests/light_tree_gpu.rs`), never used as exact.
//!
//! # Union (pbrt-v4's `Union(DirectionCone, DirectionCone)`, without `acos`)
//!
//! Empty cones drop out; if either cone covers every direction, so does
//! the union. With `θ_d` the angle between the axes: if `θ_d + θ_b ≤ θ_a`
//! the union is `a` (and symmetrically `b`); antiparallel axes give every
//! direction; otherwise the axis turns from `w_a` toward `w_b` by
//! `θ_r = (θ_d + θ_b − θ_a)/2`. Whatever axis `w` came out, the spread is
//! then recomputed from it as `max(θ_a + ∠(w, w_a), θ_b + ∠(w, w_b))`, so
//! the union contains both cones by the triangle inequality however the
//! axis was rounded, and widened by [`SLACK`]; a spread reaching π is
//! every direction. `θ_e` is the smaller of the two (the larger angle),
//! two-sided if either is.

use super::{LightPrim, KIND_TRIANGLE, KIND_VPL};
use bytemuck::{Pod, Zeroable};
use glam::Vec3;

/// Angle added to every built cone (radians, `2^-16`): a conservative
/// widening that covers the rounding of the f32 build on any device.
pub const SLACK: f32 = 1.0 / 65536.0;

/// `cos θ_o` of an empty cone (no light below the node).
pub const EMPTY_COS: f32 = 2.0;

/// An orientation bound (module docs), 32 bytes as uploaded to the GPU
/// (`LightCone` in `wgsl/lights/cone.wgsl`).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct LightCone {
    /// Unit axis `w` (meaningless for empty and whole-sphere cones).
    pub axis: [f32; 3],
    /// `cos θ_o`; −1 for every direction, [`EMPTY_COS`] for no light.
    pub cos_o: f32,
    /// `sin θ_o ≥ 0`.
    pub sin_o: f32,
    /// `cos θ_e`.
    pub cos_e: f32,
    /// 1 when the lights may emit about `−w` as well.
    pub two_sided: u32,
    /// 1 when a point light lies below: its irradiance has no bound near
    /// it, so the samplers' near-distance clamp does not apply
    /// ([`super::importance::NEAR_CLAMP`]).
    pub points: u32,
}

/// An angle in `[0, 2π)` as the unit pair `(cos, sin)`.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Angle {
    c: f32,
    s: f32,
}

impl Angle {
    const ZERO: Angle = Angle { c: 1.0, s: 0.0 };

    /// The angle of `(c, s)` (any positive length).
    fn new(c: f32, s: f32) -> Angle {
        let len = (c * c + s * s).sqrt();
        Angle {
            c: c / len,
            s: s / len,
        }
    }

    fn add(self, o: Angle) -> Angle {
        Angle::new(self.c * o.c - self.s * o.s, self.s * o.c + self.c * o.s)
    }

    fn sub(self, o: Angle) -> Angle {
        Angle::new(self.c * o.c + self.s * o.s, self.s * o.c - self.c * o.s)
    }

    /// Half of an angle in `(0, 2π)`, from whichever of the two half-angle
    /// vectors `(1 + c, s)` and `(s, 1 − c)` is well conditioned. An angle
    /// within 1.4e-3 rad below 2π or at 0 (`s ≤ 0`, `c ≥ 0.999999`) halves
    /// to 0: in [`LightCone::union`] it is `θ_d + θ_b − θ_a`, which the
    /// containment tests have found ≥ 0, so such a value is that 0 pushed
    /// below it by rounding (halving it as an angle near 2π turned the axis
    /// around, and `(1, 0)` itself gave 0/0: NaN cones over VPLs sharing a
    /// normal). A true value near 2π needs `θ_d + θ_b ≥ π`, which the
    /// union then resolves to the whole sphere anyway.
    fn half(self) -> Angle {
        if self.s <= 0.0 && self.c >= 0.999_999 {
            return Angle::ZERO;
        }
        if self.s > 0.0 && self.c >= 0.0 {
            Angle::new(1.0 + self.c, self.s)
        } else {
            Angle::new(self.s, 1.0 - self.c)
        }
    }
}

/// Whether `a ≤ b` for `a, b ∈ [0, π]`: the sign of `sin(b − a)` (its
/// cosines would not do: near 0 they all round to 1, and two axes 2e-5
/// rad apart looked like one, so a union came out narrower than its
/// children), or where that is 0 (equal angles, or 0 and π) of
/// `cos a − cos b`.
fn angle_le(a: Angle, b: Angle) -> bool {
    let d = b.s * a.c - b.c * a.s;
    if d != 0.0 {
        d > 0.0
    } else {
        a.c >= b.c
    }
}

/// Whether `a + b ≥ π` for `a, b ∈ [0, π]` (`a ≥ π − b ⇔ cos a ≤ −cos b`).
fn sum_reaches_pi(a: Angle, b: Angle) -> bool {
    a.c <= -b.c
}

/// The angle between two unit vectors as a pair.
fn angle_between(u: Vec3, v: Vec3) -> Angle {
    let s = u.cross(v).length();
    let c = u.dot(v);
    if s == 0.0 && c == 0.0 {
        return Angle::ZERO;
    }
    Angle::new(c, s)
}

impl LightCone {
    /// No light.
    pub const EMPTY: LightCone = LightCone {
        axis: [0.0, 0.0, 1.0],
        cos_o: EMPTY_COS,
        sin_o: 0.0,
        cos_e: 1.0,
        two_sided: 0,
        points: 0,
    };

    /// Every direction, with `θ_e = π/2` (a degenerate triangle).
    pub const SPHERE: LightCone = LightCone {
        axis: [0.0, 0.0, 1.0],
        cos_o: -1.0,
        sin_o: 0.0,
        cos_e: 0.0,
        two_sided: 0,
        points: 0,
    };

    /// An isotropic point light: every direction, a point.
    pub const POINT: LightCone = LightCone {
        points: 1,
        ..LightCone::SPHERE
    };

    pub fn is_empty(&self) -> bool {
        self.cos_o > 1.0
    }

    /// Whether the cone covers every direction.
    pub fn is_sphere(&self) -> bool {
        self.cos_o <= -1.0
    }

    fn spread(&self) -> Angle {
        Angle {
            c: self.cos_o,
            s: self.sin_o,
        }
    }

    fn with_spread(&self, axis: Vec3, spread: Angle) -> LightCone {
        LightCone {
            axis: axis.into(),
            cos_o: spread.c,
            sin_o: spread.s,
            ..*self
        }
    }

    /// `θ_o` widened by [`SLACK`], every direction when that reaches π.
    fn widened(self) -> LightCone {
        let slack = Angle {
            c: SLACK.cos(),
            s: SLACK.sin(),
        };
        if self.is_sphere() || sum_reaches_pi(self.spread(), slack) {
            return LightCone {
                cos_o: -1.0,
                sin_o: 0.0,
                ..self
            };
        }
        self.with_spread(Vec3::from(self.axis), self.spread().add(slack))
    }

    /// The cone of one light primitive (module docs table), widened.
    pub fn of_prim(prim: &LightPrim) -> LightCone {
        if prim.kind == KIND_VPL {
            // A cosine lobe about the normal, singular as a point.
            let n = Vec3::from(prim.p1);
            if !n.is_finite() || n.length_squared() == 0.0 {
                return LightCone::POINT;
            }
            return LightCone {
                axis: n.normalize().into(),
                cos_o: 1.0,
                sin_o: 0.0,
                ..LightCone::POINT
            }
            .widened();
        }
        if prim.kind != KIND_TRIANGLE {
            return LightCone::POINT;
        }
        let (a, b, c) = (
            Vec3::from(prim.p0),
            Vec3::from(prim.p1),
            Vec3::from(prim.p2),
        );
        // Scaled by its largest component before normalising, so that
        // tiny and huge triangles neither underflow nor overflow.
        let n = (b - a).cross(c - a);
        let m = n.abs().max_element();
        if m == 0.0 || !m.is_finite() {
            return LightCone::SPHERE;
        }
        let n = n / m;
        LightCone {
            axis: (n / n.length()).into(),
            cos_o: 1.0,
            sin_o: 0.0,
            ..LightCone::SPHERE
        }
        .widened()
    }

    /// The union of two cones (module docs), widened.
    pub fn union(&self, b: &LightCone) -> LightCone {
        let a = self;
        if a.is_empty() {
            return *b;
        }
        if b.is_empty() {
            return *a;
        }
        let base = LightCone {
            cos_e: a.cos_e.min(b.cos_e),
            two_sided: a.two_sided | b.two_sided,
            points: a.points | b.points,
            ..*a
        };
        let sphere = LightCone {
            cos_o: -1.0,
            sin_o: 0.0,
            ..base
        };
        if a.is_sphere() || b.is_sphere() {
            return sphere;
        }
        let (wa, wb) = (Vec3::from(a.axis), Vec3::from(b.axis));
        let (ta, tb) = (a.spread(), b.spread());
        let td = angle_between(wa, wb);
        // One cone inside the other.
        if !sum_reaches_pi(td, tb) && angle_le(td.add(tb), ta) {
            return base.with_spread(wa, ta).widened();
        }
        if !sum_reaches_pi(td, ta) && angle_le(td.add(ta), tb) {
            return base.with_spread(wb, tb).widened();
        }
        let normal = wa.cross(wb);
        if normal.length_squared() == 0.0 {
            return sphere; // antiparallel axes
        }
        // Turn w_a toward w_b by θ_r = (θ_d + θ_b − θ_a)/2.
        let tr = td.add(tb).sub(ta).half();
        let u = normal.cross(wa).normalize();
        let w = (wa * tr.c + u * tr.s).normalize();
        let (da, db) = (angle_between(w, wa), angle_between(w, wb));
        if sum_reaches_pi(ta, da) || sum_reaches_pi(tb, db) {
            return sphere;
        }
        let (sa, sb) = (ta.add(da), tb.add(db));
        let spread = if angle_le(sb, sa) { sa } else { sb };
        base.with_spread(w, spread).widened()
    }

    /// Whether every direction of `inner` lies in this cone, up to `tol`
    /// radians (tests).
    pub fn contains(&self, inner: &LightCone, tol: f32) -> bool {
        if inner.is_empty() || self.is_sphere() {
            return true;
        }
        if self.is_empty() || inner.is_sphere() {
            return false;
        }
        let (u, v) = (Vec3::from(self.axis), Vec3::from(inner.axis));
        let d = u.cross(v).length().atan2(u.dot(v));
        let t_in = inner.sin_o.atan2(inner.cos_o);
        let t_out = self.sin_o.atan2(self.cos_o);
        d + t_in <= t_out + tol
            && self.cos_e <= inner.cos_e + tol
            && (self.two_sided >= inner.two_sided)
    }

    /// Upper bound of the emitted fraction `cos θ'` toward a point `x` of
    /// the lights in a node with bounding-sphere centre `c` and radius `r`
    /// (pbrt-v4's `LightBounds::Importance` without distance and surface
    /// terms; `docs/light-sampling.md` "Emission bound"): 1 inside the
    /// sphere or for a whole-sphere cone, 0 when no direction toward the
    /// sphere is within `θ_o + θ_e` of the axis. Same f32 operations as
    /// `light_emission_bound` in `wgsl/lights/sample.wgsl`.
    pub fn emission_bound(&self, c: [f32; 3], r: f32, x: [f32; 3]) -> f32 {
        if self.cos_o <= -1.0 {
            return 1.0;
        }
        let v: [f32; 3] = std::array::from_fn(|a| x[a] - c[a]);
        let dist = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        if dist <= r {
            return 1.0;
        }
        let w = self.axis;
        let mut cos_w = (w[0] * v[0] + w[1] * v[1] + w[2] * v[2]) / dist;
        if self.two_sided != 0 {
            cos_w = cos_w.abs();
        }
        let sin_w = (1.0 - cos_w * cos_w).max(0.0).sqrt();
        // θ_x = max(θ_w − θ_o, 0).
        let (cos_x, sin_x) = if cos_w > self.cos_o {
            (1.0, 0.0)
        } else {
            (
                cos_w * self.cos_o + sin_w * self.sin_o,
                sin_w * self.cos_o - cos_w * self.sin_o,
            )
        };
        // θ' = max(θ_x − θ_b, 0), θ_b the sphere's half-angle.
        let sin_b = r / dist;
        let cos_b = (1.0 - sin_b * sin_b).max(0.0).sqrt();
        let cos_p = if cos_x > cos_b {
            1.0
        } else {
            cos_x * cos_b + sin_x * sin_b
        };
        if cos_p <= self.cos_e {
            0.0
        } else {
            cos_p
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cone(axis: Vec3, theta: f32) -> LightCone {
        LightCone {
            axis: axis.normalize().into(),
            cos_o: theta.cos(),
            sin_o: theta.sin(),
            ..LightCone::SPHERE
        }
    }

    #[test]
    fn unions_of_simple_cones() {
        let a = cone(Vec3::Z, 0.0);
        let b = cone(Vec3::X, 0.0);
        let u = a.union(&b);
        // Two perpendicular directions: axis halfway, spread π/4.
        let t = u.sin_o.atan2(u.cos_o);
        assert!((t - std::f32::consts::FRAC_PI_4).abs() < 2.0 * SLACK, "{t}");
        assert!(u.contains(&a, 0.0) && u.contains(&b, 0.0));
        // Nested: the outer cone, widened.
        let big = cone(Vec3::Z, 1.0);
        let small = cone(Vec3::new(0.1, 0.0, 1.0), 0.2);
        let n = big.union(&small);
        assert_eq!(n.axis, big.axis);
        assert!((n.sin_o.atan2(n.cos_o) - 1.0 - SLACK).abs() < 1e-6);
        // Antiparallel and wide cones: every direction.
        assert!(a.union(&cone(-Vec3::Z, 0.0)).is_sphere());
        assert!(cone(Vec3::Z, 2.0).union(&cone(-Vec3::Z, 1.2)).is_sphere());
        assert_eq!(LightCone::EMPTY.union(&a), a);
        assert_eq!(a.union(&LightCone::EMPTY), a);
        assert!(a.union(&LightCone::SPHERE).is_sphere());
    }

    /// Narrow cones whose axes differ by less than an ulp of a cosine near
    /// 1 (3e-4 rad): the union still contains both. Comparing the angles by
    /// their cosines, which all round to 1 here, once took `a` to contain
    /// `b` and kept `a`'s 2^-16 spread for axes 2e-5 apart (found on the
    /// two triangles of a quad on `cornell_lights`' spheres).
    #[test]
    fn unions_of_nearly_parallel_narrow_cones_contain_both() {
        for k in [1.0e-6f32, 5.0e-6, 2.0e-5, 6.0e-5, 2.0e-4, 1.0e-3] {
            for spread in [0.0, SLACK, 1.0e-4] {
                let a = cone(Vec3::new(0.3, -0.2, 0.9), spread).widened();
                let wa = Vec3::from(a.axis);
                let u = wa.any_orthonormal_vector();
                let b = cone(wa + u * k, spread).widened();
                let c = a.union(&b);
                assert!(
                    c.contains(&a, 1e-7) && c.contains(&b, 1e-7),
                    "axes {k} rad apart, spread {spread}: {c:?} of {a:?} and {b:?}"
                );
                assert!(angle_le(a.spread(), c.spread()) && angle_le(b.spread(), c.spread()));
            }
        }
        // The comparison itself, at both ends of [0, π].
        let at = |t: f32| Angle::new(t.cos(), t.sin());
        assert!(angle_le(at(1.0e-5), at(2.0e-5)) && !angle_le(at(2.0e-5), at(1.0e-5)));
        let pi = Angle { c: -1.0, s: 0.0 };
        assert!(angle_le(Angle::ZERO, pi) && !angle_le(pi, Angle::ZERO));
        assert!(angle_le(at(0.5), at(0.5)) && angle_le(at(3.1), at(3.13)));
    }

    /// `half` picks whichever half-angle formula is well conditioned:
    /// `(1 + c, s)` on (0, π/2], `(s, 1 − c)` beyond. Near π the first
    /// loses most of `1 + c`'s digits (c ≈ −1). Checked on (0, π], where
    /// `union` calls it (`θ_d + θ_b − θ_a`; larger values resolve to the
    /// whole sphere), against the half, in f64, of the angle the f32 pair
    /// itself holds (so the pair's own rounding is not counted), to a few
    /// ulps.
    #[test]
    fn half_angles_are_accurate_up_to_pi() {
        for k in 1..=2048 {
            let t = k as f64 / 4096.0 * std::f64::consts::TAU;
            let a = Angle::new(t.cos() as f32, t.sin() as f32);
            if a.s <= 0.0 && a.c >= 0.999_999 {
                continue; // halves to 0 by design (see `half`)
            }
            let h = a.half();
            let held = (a.s as f64)
                .atan2(a.c as f64)
                .rem_euclid(std::f64::consts::TAU);
            let (c, s) = ((held / 2.0).cos(), (held / 2.0).sin());
            assert!(
                (h.c as f64 - c).abs() < 4e-7 && (h.s as f64 - s).abs() < 4e-7,
                "half of {t}: ({}, {}) against ({c}, {s})",
                h.c,
                h.s
            );
        }
    }

    /// A spread within the slack of π becomes exactly the whole sphere,
    /// stored as (−1, 0), not an angle wrapped past π. (cos θ_o rounds to
    /// −1 there while sin θ_o does not; `SLACK.cos()` rounds to 1 in f32,
    /// so "θ_o + SLACK ≥ π" and "cos θ_o = −1" are the same test.)
    #[test]
    fn widening_to_pi_gives_the_whole_sphere() {
        for theta in [
            std::f32::consts::PI - SLACK / 2.0,
            std::f32::consts::PI - SLACK,
        ] {
            let c = cone(Vec3::Z, theta);
            assert!(c.sin_o > 0.0);
            let w = c.widened();
            assert_eq!((w.cos_o, w.sin_o), (-1.0, 0.0), "θ_o = {theta}");
            assert_eq!((w.axis, w.cos_e), (c.axis, c.cos_e));
        }
        // Below π by more than the slack: a cone, widened by the slack.
        let c = cone(Vec3::Z, 3.0).widened();
        assert!(!c.is_sphere());
        assert!((c.sin_o.atan2(c.cos_o) - 3.0 - SLACK).abs() < 1e-6);
    }

    /// A VPL whose normal is unusable (zero, infinite or NaN) bounds
    /// like an isotropic point, never with a NaN axis.
    #[test]
    fn vpls_without_a_usable_normal_are_points() {
        for n in [
            Vec3::ZERO,
            Vec3::new(f32::INFINITY, 0.0, 0.0),
            Vec3::new(0.0, f32::NAN, 1.0),
        ] {
            let prim = LightPrim::vpl(Vec3::ONE, n, Vec3::ONE);
            assert_eq!(LightCone::of_prim(&prim), LightCone::POINT, "normal {n}");
        }
        let c = LightCone::of_prim(&LightPrim::vpl(
            Vec3::ONE,
            Vec3::new(0.0, 3.0, 0.0),
            Vec3::ONE,
        ));
        assert_eq!((c.axis, c.points), ([0.0, 1.0, 0.0], 1));
    }

    /// A triangle's cone is about its unit face normal (counter-clockwise
    /// winding) at any scale: tiny and huge triangles neither underflow
    /// nor overflow; a degenerate or non-finite one bounds as the whole
    /// sphere.
    #[test]
    fn triangle_cones_at_every_scale() {
        let normal = Vec3::new(1.0, 2.0, 2.0) / 3.0;
        // Two edges perpendicular to the normal.
        let (e1, e2) = (Vec3::new(2.0, -1.0, 0.0), Vec3::new(2.0, 4.0, -5.0));
        assert!(e1.dot(normal).abs() < 1e-6 && e2.dot(normal).abs() < 1e-6);
        assert!(e1.cross(e2).dot(normal) > 0.0);
        for scale in [1.0, 1e-15, 1e18] {
            let o = Vec3::new(0.5, -0.25, 2.0) * scale;
            let prim = LightPrim::triangle(o, o + e1 * scale, o + e2 * scale, Vec3::ONE);
            let c = LightCone::of_prim(&prim);
            let axis = Vec3::from(c.axis);
            assert!(
                (axis - normal).length() < 1e-6,
                "scale {scale}: axis {axis} against {normal}"
            );
            assert!(
                !c.is_sphere() && c.cos_o > SLACK.cos() - 1e-6,
                "scale {scale}: {c:?}"
            );
            assert_eq!((c.two_sided, c.points), (0, 0));
        }
        let flat = LightPrim::triangle(Vec3::ZERO, Vec3::X, 2.0 * Vec3::X, Vec3::ONE);
        assert_eq!(LightCone::of_prim(&flat), LightCone::SPHERE);
        let inf = Vec3::new(f32::INFINITY, 0.0, 0.0);
        let far = LightPrim::triangle(Vec3::ZERO, inf, Vec3::Y, Vec3::ONE);
        assert_eq!(LightCone::of_prim(&far), LightCone::SPHERE);
    }

    /// The union keeps the larger emission angle (the smaller cos θ_e),
    /// is two-sided or over points if either cone is, and stores the whole
    /// sphere as (−1, 0) whatever the inputs' spreads.
    #[test]
    fn unions_merge_emission_sides_and_points() {
        let a = LightCone {
            cos_e: 0.2,
            ..cone(Vec3::Z, 0.3)
        };
        let b = LightCone {
            cos_e: 0.6,
            ..cone(Vec3::X, 0.1)
        };
        for (x, y) in [(a, b), (b, a)] {
            assert_eq!(x.union(&y).cos_e, 0.2);
        }
        for (sa, sb) in [(0, 0), (0, 1), (1, 0), (1, 1)] {
            let (x, y) = (
                LightCone {
                    two_sided: sa,
                    points: sb,
                    ..a
                },
                LightCone {
                    two_sided: sb,
                    points: sa,
                    ..b
                },
            );
            let u = x.union(&y);
            assert_eq!((u.two_sided, u.points), (sa | sb, sa | sb), "{x:?} ∪ {y:?}");
        }
        // Antiparallel axes: every direction, exactly (−1, 0).
        let u = cone(Vec3::Z, 0.5).union(&cone(-Vec3::Z, 0.5));
        assert_eq!((u.cos_o, u.sin_o), (-1.0, 0.0));
    }

    /// `contains` (the tests' check of every union) refuses what it must:
    /// a wider spread, an axis turned away, a wider emission angle, a
    /// two-sided cone in a one-sided one; and accepts what it must.
    #[test]
    fn containment_refuses_what_sticks_out() {
        let outer = cone(Vec3::Z, 0.5);
        assert!(outer.contains(&cone(Vec3::Z, 0.5), 0.0));
        assert!(outer.contains(&cone(Vec3::new(0.1, 0.0, 1.0), 0.3), 0.0));
        assert!(!outer.contains(&cone(Vec3::Z, 0.6), 0.0));
        assert!(outer.contains(&cone(Vec3::Z, 0.6), 0.2));
        assert!(!outer.contains(&cone(Vec3::new(1.0, 0.0, 1.0), 0.3), 0.0));
        let wider_e = LightCone {
            cos_e: outer.cos_e - 0.5,
            ..cone(Vec3::Z, 0.1)
        };
        assert!(!outer.contains(&wider_e, 0.0));
        let slightly = LightCone {
            cos_e: outer.cos_e - 0.1,
            ..wider_e
        };
        assert!(outer.contains(&slightly, 0.2) && !outer.contains(&slightly, 0.05));
        let two = LightCone {
            two_sided: 1,
            ..cone(Vec3::Z, 0.1)
        };
        assert!(!outer.contains(&two, 0.0));
        assert!(
            LightCone::SPHERE.contains(&outer, 0.0) && !outer.contains(&LightCone::SPHERE, 0.0)
        );
        assert!(outer.contains(&LightCone::EMPTY, 0.0) && !LightCone::EMPTY.contains(&outer, 0.0));
        // Not even a single direction along the empty cone's stored axis.
        let along = LightCone {
            cos_e: LightCone::EMPTY.cos_e,
            ..cone(Vec3::from(LightCone::EMPTY.axis), 0.0)
        };
        assert!(!LightCone::EMPTY.contains(&along, 0.0));
    }

    #[test]
    fn emission_bound_of_a_triangle_cone() {
        let c = cone(Vec3::Z, 0.0);
        // In front on the axis: 1; behind: 0; at 60° from the axis: cos 60°.
        assert_eq!(c.emission_bound([0.0; 3], 0.0, [0.0, 0.0, 2.0]), 1.0);
        assert_eq!(c.emission_bound([0.0; 3], 0.0, [0.0, 0.0, -2.0]), 0.0);
        let x = [3f32.sqrt(), 0.0, 1.0];
        assert!((c.emission_bound([0.0; 3], 0.0, x) - 0.5).abs() < 1e-6);
        // A sphere of radius 1 at distance 2 subtends 30°: cos(60° − 30°).
        let b = c.emission_bound([0.0; 3], 1.0, [2.0 * 60f32.to_radians().sin(), 0.0, 1.0]);
        assert!((b - 30f32.to_radians().cos()).abs() < 1e-5, "{b}");
        // 20° from the axis, inside the sphere's 30° half-angle: θ' = 0.
        let x = [
            2.0 * 20f32.to_radians().sin(),
            0.0,
            2.0 * 20f32.to_radians().cos(),
        ];
        assert_eq!(c.emission_bound([0.0; 3], 1.0, x), 1.0);
        // Inside the sphere, or a two-sided cone seen from behind: 1.
        assert_eq!(c.emission_bound([0.0; 3], 3.0, [0.0, 0.0, -2.0]), 1.0);
        let two = LightCone { two_sided: 1, ..c };
        assert_eq!(two.emission_bound([0.0; 3], 0.0, [0.0, 0.0, -2.0]), 1.0);
    }
}
