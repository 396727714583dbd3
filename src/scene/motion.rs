//! Rigid keyframe motion: interpolation and swept bounds (CPU side).
//!
//! A moving mesh has keyframes (time, translation T, rotation R) sorted by
//! time; at scene time τ its object-space point p is at `R(τ)·p + T(τ)` in
//! the world. Between keyframes k and k+1, with s = (τ − τ_k)/(τ_{k+1} − τ_k),
//! T is interpolated linearly and R by spherical linear interpolation along
//! the shorter arc (the sign of q_{k+1} is flipped when q_k·q_{k+1} < 0).
//! Before the first and after the last keyframe the end keyframe holds.
//!
//! Slerp is evaluated without trigonometry by Eberly's polynomial
//! (D. Eberly 2011, "A Fast and Accurate Algorithm for Computing SLERP",
//! JGGGT 15(3)): sin(tθ)/sin θ as a degree-8 series in (cos θ − 1) with a
//! tuned last coefficient, max error about 1e-7 over the whole shorter
//! arc, then normalized. WGSL's acos/sin may be as loose as the Vulkan
//! spec allows (lavapipe's acos is off by ~1e-4 rad), which would move an
//! instance by 1e-4 of its size between GPU and CPU; the polynomial uses
//! only multiply-adds, so both sides agree to rounding. [`transform_at`]
//! mirrors `instance_transform_at` in `wgsl/shared/scene.wgsl` operation
//! for operation.
//!
//! [`swept_bounds`] bounds an instance over *all* times (hence over any
//! shutter): the union of the object box transformed at every keyframe
//! and, for every pair of consecutive keyframes whose rotations differ, the
//! box around the translation segment [T_k, T_{k+1}] grown by the radius r
//! of the object box's bounding sphere about the rotation centre (the
//! object-space origin). That is conservative: |R(s)·p| = |p| ≤ r for any
//! rotation, and T(s) stays on the segment, so R(s)·p + T(s) lies in the
//! segment ⊕ ball(r). When the rotations are equal the motion is a pure
//! translation and the box of the endpoint boxes is already exact.

use glam::{Quat, Vec3, Vec4};
use obvhs::aabb::Aabb;

use super::Keyframe;

/// Eberly's 1 + μ for the last series term (the paper's FPU constant).
const SLERP_ONE_PLUS_MU: f64 = 1.901_107_453_517_3;

/// Series coefficients u_i = 1/(i(2i+1)), v_i = i/(2i+1), i = 1..8, the
/// last scaled by 1 + μ. Computed in f64 and rounded once, as WGSL's
/// abstract-float constants are.
const SLERP_U: [f32; 8] = {
    let mut u = [0.0; 8];
    let mut i = 0;
    while i < 8 {
        let n = (i + 1) as f64;
        let scale = if i == 7 { SLERP_ONE_PLUS_MU } else { 1.0 };
        u[i] = (scale / (n * (2.0 * n + 1.0))) as f32;
        i += 1;
    }
    u
};
const SLERP_V: [f32; 8] = {
    let mut v = [0.0; 8];
    let mut i = 0;
    while i < 8 {
        let n = (i + 1) as f64;
        let scale = if i == 7 { SLERP_ONE_PLUS_MU } else { 1.0 };
        v[i] = (scale * n / (2.0 * n + 1.0)) as f32;
        i += 1;
    }
    v
};

/// A rigid transform world = R·p + T.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Rigid {
    /// Unit quaternion, xyzw.
    pub rotation: Vec4,
    pub translation: Vec3,
}

impl Rigid {
    pub const IDENTITY: Rigid = Rigid {
        rotation: Vec4::W,
        translation: Vec3::ZERO,
    };

    /// R·p + T.
    pub fn apply_point(&self, p: Vec3) -> Vec3 {
        quat_rotate(self.rotation, p) + self.translation
    }

    /// R·v.
    pub fn apply_vector(&self, v: Vec3) -> Vec3 {
        quat_rotate(self.rotation, v)
    }

    /// R⁻¹·(p − T).
    pub fn inverse_point(&self, p: Vec3) -> Vec3 {
        quat_rotate(conjugate(self.rotation), p - self.translation)
    }

    /// R⁻¹·v.
    pub fn inverse_vector(&self, v: Vec3) -> Vec3 {
        quat_rotate(conjugate(self.rotation), v)
    }
}

fn conjugate(q: Vec4) -> Vec4 {
    Vec4::new(-q.x, -q.y, -q.z, q.w)
}

/// Rotates `v` by the unit quaternion `q` (xyzw): t = 2 q⃗ × v,
/// v' = v + w·t + q⃗ × t. Same formula as `quat_rotate` in scene.wgsl.
pub fn quat_rotate(q: Vec4, v: Vec3) -> Vec3 {
    let u = q.truncate();
    let t = 2.0 * u.cross(v);
    v + q.w * t + u.cross(t)
}

/// sin(tθ)/sin θ by Eberly's series, xm1 = cos θ − 1 (Horner form, the
/// same order of operations as `slerp_weight` in scene.wgsl).
fn slerp_weight(t: f32, xm1: f32) -> f32 {
    let t2 = t * t;
    let mut c = 1.0;
    for i in (0..8).rev() {
        c = 1.0 + (SLERP_U[i] * t2 - SLERP_V[i]) * xm1 * c;
    }
    t * c
}

/// Shortest-arc slerp, as `quat_slerp` in scene.wgsl.
pub fn quat_slerp(a: Vec4, b: Vec4, s: f32) -> Vec4 {
    let mut b = b;
    let mut d = a.dot(b);
    if d < 0.0 {
        b = -b;
        d = -d;
    }
    let xm1 = d - 1.0;
    (a * slerp_weight(1.0 - s, xm1) + b * slerp_weight(s, xm1)).normalize()
}

/// The transform of a mesh with `keys` (sorted by time, unit rotations) at
/// scene time `time`; identity for no keyframes. Mirrors
/// `instance_transform_at` in scene.wgsl.
pub fn transform_at(keys: &[Keyframe], time: f32) -> Rigid {
    let key = |k: &Keyframe| Rigid {
        rotation: Vec4::from(k.rotation),
        translation: k.translation,
    };
    let Some(first) = keys.first() else {
        return Rigid::IDENTITY;
    };
    let last = keys.last().expect("non-empty");
    if keys.len() == 1 || time <= first.time {
        return key(first);
    }
    if time >= last.time {
        return key(last);
    }
    // first.time < time < last.time: segment i has keys[i].time <= time < keys[i+1].time.
    let mut i = 0;
    while i + 2 < keys.len() && keys[i + 1].time <= time {
        i += 1;
    }
    let (a, b) = (&keys[i], &keys[i + 1]);
    let s = (time - a.time) / (b.time - a.time);
    Rigid {
        rotation: quat_slerp(Vec4::from(a.rotation), Vec4::from(b.rotation), s),
        translation: a.translation.lerp(b.translation, s),
    }
}

/// Keyframes sorted by time (stable) with unit rotations: the form
/// [`transform_at`] and the GPU expect.
pub fn normalized_keys(keys: &[Keyframe]) -> Vec<Keyframe> {
    let mut keys = keys.to_vec();
    keys.sort_by(|a, b| a.time.total_cmp(&b.time));
    for k in &mut keys {
        k.rotation = if k.rotation.length_squared() > 0.0 {
            k.rotation.normalize()
        } else {
            Quat::IDENTITY
        };
    }
    keys
}

/// World bounds of an object with object-space bounds `local` under the
/// motion `keys` at every time (see the module docs), padded by a relative
/// 1e-5 of its size for the rounding of the ray transform.
pub fn swept_bounds(keys: &[Keyframe], local: &Aabb) -> Aabb {
    if keys.is_empty() {
        return *local;
    }
    let (lo, hi) = (Vec3::from(local.min), Vec3::from(local.max));
    let corners = (0..8).map(|c| {
        Vec3::new(
            if c & 1 == 0 { lo.x } else { hi.x },
            if c & 2 == 0 { lo.y } else { hi.y },
            if c & 4 == 0 { lo.z } else { hi.z },
        )
    });
    let radius = corners.clone().map(|p| p.length()).fold(0.0f32, f32::max);
    let mut bounds = Aabb::empty();
    for k in keys {
        let rigid = Rigid {
            rotation: Vec4::from(k.rotation),
            translation: k.translation,
        };
        for p in corners.clone() {
            bounds.extend(rigid.apply_point(p).into());
        }
    }
    for pair in keys.windows(2) {
        let (a, b) = (&pair[0], &pair[1]);
        if Vec4::from(a.rotation).dot(Vec4::from(b.rotation)).abs() < 1.0 {
            bounds.extend((a.translation.min(b.translation) - Vec3::splat(radius)).into());
            bounds.extend((a.translation.max(b.translation) + Vec3::splat(radius)).into());
        }
    }
    let size = Vec3::from(bounds.max - bounds.min);
    let scale = Vec3::from(bounds.min.abs().max(bounds.max.abs()))
        .max_element()
        .max(size.max_element());
    let pad = glam::Vec3A::splat(1e-5 * scale);
    Aabb::new(bounds.min - pad, bounds.max + pad)
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Quat;
    use rand::rngs::StdRng;
    use rand::{RngExt, SeedableRng};

    fn random_unit(rng: &mut StdRng) -> Vec3 {
        loop {
            let v = Vec3::new(
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
            );
            let l = v.length_squared();
            if l > 1e-4 && l <= 1.0 {
                return v / l.sqrt();
            }
        }
    }

    /// The trig-free slerp agrees with glam's slerp to ~1e-6 and keeps the
    /// shortest arc; keyframe clamping and segment choice follow the scene's
    /// definition.
    #[test]
    fn keyframe_interpolation_matches_slerp() {
        let mut rng = StdRng::seed_from_u64(10);
        for _ in 0..2000 {
            let a = Quat::from_axis_angle(random_unit(&mut rng), rng.random_range(-3.1..3.1));
            let b = Quat::from_axis_angle(random_unit(&mut rng), rng.random_range(-3.1..3.1));
            let s = rng.random::<f32>();
            let ours = quat_slerp(Vec4::from(a), Vec4::from(b), s);
            let glam = Vec4::from(a.slerp(b, s));
            assert!(
                ours.dot(glam).abs() > 1.0 - 1e-6,
                "slerp({a}, {b}, {s}) = {ours} vs glam {glam}"
            );
        }
        let keys = vec![
            Keyframe {
                time: 0.2,
                translation: Vec3::X,
                rotation: Quat::IDENTITY,
            },
            Keyframe {
                time: 0.5,
                translation: Vec3::Y,
                rotation: Quat::from_rotation_z(1.0),
            },
            Keyframe {
                time: 0.6,
                translation: Vec3::Z,
                rotation: Quat::from_rotation_z(2.0),
            },
        ];
        assert_eq!(transform_at(&keys, -1.0).translation, Vec3::X);
        assert_eq!(transform_at(&keys, 5.0).translation, Vec3::Z);
        let mid = transform_at(&keys, 0.35);
        assert!((mid.translation - Vec3::new(0.5, 0.5, 0.0)).length() < 1e-6);
        assert!(
            (mid.apply_vector(Vec3::X) - Vec3::new(0.5f32.cos(), 0.5f32.sin(), 0.0)).length()
                < 1e-6
        );
        let late = transform_at(&keys, 0.55);
        assert!(
            (late.apply_vector(Vec3::X) - Vec3::new(1.5f32.cos(), 1.5f32.sin(), 0.0)).length()
                < 1e-6
        );
    }
}
