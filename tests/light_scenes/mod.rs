//! Light sets shared by the CPU and GPU light-sampler tests.
#![allow(dead_code)]

use glam::Vec3;
use mdas::lights::LightPrim;
use rand::rngs::StdRng;
use rand::RngExt;

/// A uniformly distributed unit vector.
fn unit(rng: &mut StdRng) -> Vec3 {
    loop {
        let v = Vec3::new(rng.random(), rng.random(), rng.random()) * 2.0 - Vec3::ONE;
        if v.length() > 0.1 && v.length() <= 1.0 {
            return v.normalize();
        }
    }
}

/// VPLs on three walls of a box (x = −5 facing +x, y = −5 facing +y,
/// z = 5 facing −z): every fifth is lifted off its wall by up to 0.3 and
/// tilted, every ninth is dark. A substitute tree over them has suitable
/// nodes on the walls, unsuitable ones across them, and many VPLs that
/// share a normal exactly.
pub fn vpl_walls(rng: &mut StdRng, n: usize) -> Vec<LightPrim> {
    (0..n)
        .map(|i| {
            let (a, b) = (
                rng.random_range(-5.0..5.0f32),
                rng.random_range(-5.0..5.0f32),
            );
            let lift = if i % 5 == 4 {
                rng.random_range(0.0..0.3)
            } else {
                0.0
            };
            let (p, mut nrm) = match i % 3 {
                0 => (Vec3::new(-5.0 + lift, a, b), Vec3::X),
                1 => (Vec3::new(a, -5.0 + lift, b), Vec3::Y),
                _ => (Vec3::new(a, b, 5.0 - lift), Vec3::NEG_Z),
            };
            if lift > 0.0 {
                nrm = (nrm + unit(rng) * 0.5).normalize();
            }
            let e = if i % 9 == 8 {
                Vec3::ZERO
            } else {
                Vec3::new(rng.random(), rng.random(), rng.random()) * 2.0
            };
            LightPrim::vpl(p, nrm, e)
        })
        .collect()
}
