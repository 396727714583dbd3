//! The CPU oracle: the ray–triangle test of `wgsl/shared/bvh.wgsl` in Rust,
//! and brute-force closest / any hit over a [`BuiltScene`].
//!
//! **Triangle test.** Watertight ray–triangle intersection (Woop, Benthin &
//! Wald 2013, "Watertight Ray/Triangle Intersection", JCGT 2(1)): the ray
//! is made the +z axis of a sheared frame (kz = dominant direction axis,
//! kx, ky the next two, swapped when d[kz] < 0 to keep the winding), the
//! vertices are translated and sheared into it, and the scaled
//! barycentrics U, V, W are 2D edge functions. A hit needs U, V, W all ≥ 0
//! or all ≤ 0 — zeros included, so a ray through an edge or vertex shared
//! by two triangles hits *both* (no cracks); which one a closest-hit query
//! reports then depends on the order triangles are tested (`t < best`
//! keeps the first), which is why GPU and CPU may name different
//! triangles at exactly the same t. det = U + V + W = 0 (the ray in the
//! triangle's plane, or a degenerate triangle) misses. Both faces are hit
//! (no culling). The paper's double-precision fallback for U, V or W = 0
//! is omitted (WGSL has no f64); the sign test alone keeps edges closed.
//!
//! **t range.** A hit counts when `t_min < t < t_max` with
//! `t_min = T_MIN_REL · max(1, ‖o‖∞) / ‖d‖∞` ([`ray_t_min`]): a distance
//! of 1e-5 relative to the origin's magnitude (a few hundred ulps, so a
//! ray leaving a surface point computed in f32 does not re-hit that surface
//! unless it leaves within about 0.6° of grazing), converted to the ray's
//! parameter. `t` is in units of |d|: directions need not be normalized.
//! The GPU computes t_min from the world-space ray once and uses it in
//! every instance (rigid transforms preserve t).

use glam::{Vec2, Vec3};

use super::build::BuiltScene;
use super::trace::{HitRecord, Ray, MISS};
use crate::scene::motion::Rigid;

/// Relative ray epsilon, see the module docs. Generated into WGSL as
/// `BVH_T_MIN_REL_BITS` by [`super::GpuScene::wgsl`].
pub const T_MIN_REL: f32 = 1e-5;

/// Smallest accepted hit distance for a ray, in units of |dir|.
pub fn ray_t_min(origin: Vec3, dir: Vec3) -> f32 {
    T_MIN_REL * origin.abs().max_element().max(1.0) / dir.abs().max_element()
}

/// A ray prepared for the watertight test: permuted axes and shear.
#[derive(Clone, Copy, Debug)]
pub struct ShearedRay {
    pub origin: Vec3,
    /// (kx, ky, kz).
    pub k: [usize; 3],
    /// (Sx, Sy, Sz) = (d[kx]/d[kz], d[ky]/d[kz], 1/d[kz]).
    pub shear: Vec3,
}

impl ShearedRay {
    /// Same as `sheared_ray` in bvh.wgsl.
    pub fn new(origin: Vec3, dir: Vec3) -> ShearedRay {
        let a = dir.abs();
        let kz = if a.x > a.y && a.x > a.z {
            0
        } else if a.y > a.z {
            1
        } else {
            2
        };
        let mut kx = (kz + 1) % 3;
        let mut ky = (kx + 1) % 3;
        if dir[kz] < 0.0 {
            std::mem::swap(&mut kx, &mut ky);
        }
        let shear = Vec3::new(dir[kx] / dir[kz], dir[ky] / dir[kz], 1.0 / dir[kz]);
        ShearedRay {
            origin,
            k: [kx, ky, kz],
            shear,
        }
    }

    /// The hit (t, barycentrics of v1 and v2) with t_min < t < t_max, if
    /// any. Same operations as `intersect_triangle` in bvh.wgsl.
    pub fn intersect(&self, v: [Vec3; 3], t_min: f32, t_max: f32) -> Option<(f32, Vec2)> {
        let [kx, ky, kz] = self.k;
        let s = self.shear;
        let a = v[0] - self.origin;
        let b = v[1] - self.origin;
        let c = v[2] - self.origin;
        let ax = a[kx] - s.x * a[kz];
        let ay = a[ky] - s.y * a[kz];
        let bx = b[kx] - s.x * b[kz];
        let by = b[ky] - s.y * b[kz];
        let cx = c[kx] - s.x * c[kz];
        let cy = c[ky] - s.y * c[kz];
        let u = cx * by - cy * bx;
        let v_ = ax * cy - ay * cx;
        let w = bx * ay - by * ax;
        if (u < 0.0 || v_ < 0.0 || w < 0.0) && (u > 0.0 || v_ > 0.0 || w > 0.0) {
            return None;
        }
        let det = u + v_ + w;
        if det == 0.0 {
            return None;
        }
        let az = s.z * a[kz];
        let bz = s.z * b[kz];
        let cz = s.z * c[kz];
        let rcp_det = 1.0 / det;
        let t = (u * az + v_ * bz + w * cz) * rcp_det;
        if !(t > t_min && t < t_max) {
            return None;
        }
        Some((t, Vec2::new(v_ * rcp_det, w * rcp_det)))
    }
}

impl BuiltScene {
    /// Closest hit by testing every triangle, transformed to the world at
    /// the ray's time. `t = ray.t_max` and `prim = MISS` on a miss;
    /// `any_hit` is set when something was hit.
    pub fn brute_force_closest(&self, ray: &Ray) -> HitRecord {
        self.brute_force(ray, false)
    }

    /// Whether any triangle is hit with t_min < t < t_max.
    pub fn brute_force_any(&self, ray: &Ray) -> bool {
        self.brute_force(ray, true).is_hit()
    }

    fn brute_force(&self, ray: &Ray, any_hit: bool) -> HitRecord {
        let (o, d) = (Vec3::from(ray.origin), Vec3::from(ray.dir));
        let sheared = ShearedRay::new(o, d);
        let t_min = ray_t_min(o, d);
        let transforms: Vec<Option<Rigid>> = (0..self.instances.len() as u32)
            .map(|i| {
                (self.instances[i as usize].key_count > 0)
                    .then(|| self.instance_transform_at(i, ray.time))
            })
            .collect();
        let mut hit = HitRecord {
            t: ray.t_max,
            prim: MISS,
            ..Default::default()
        };
        for prim in 0..self.triangle_count() {
            let mut v = self.triangle_stored(prim);
            if let Some(x) = &transforms[self.triangle_instance(prim) as usize] {
                v = v.map(|p| x.apply_point(p));
            }
            if let Some((t, bary)) = sheared.intersect(v, t_min, hit.t) {
                hit = HitRecord {
                    t,
                    prim,
                    bary: bary.into(),
                    any_hit: 1,
                    ..Default::default()
                };
                if any_hit {
                    break;
                }
            }
        }
        hit
    }
}
