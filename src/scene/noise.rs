//! Deterministic procedural noise for the `heightfield` and `blob` shapes:
//! an own integer hash, so the same seed gives the same geometry on every
//! platform and crate version.

use glam::{Vec2, Vec3};

/// PCG-style integer hash (Jarzynski & Olano 2020).
fn pcg(v: u32) -> u32 {
    let state = v.wrapping_mul(747_796_405).wrapping_add(2_891_336_453);
    let word = ((state >> ((state >> 28) + 4)) ^ state).wrapping_mul(277_803_737);
    (word >> 22) ^ word
}

fn hash3(x: i32, y: i32, z: i32, seed: u32) -> u32 {
    pcg((x as u32).wrapping_add(pcg(
        (y as u32).wrapping_add(pcg((z as u32).wrapping_add(pcg(seed))))
    )))
}

fn fade(t: f32) -> f32 {
    t * t * t * (t * (t * 6.0 - 15.0) + 10.0)
}

/// Improved-Perlin gradient noise in about [−1, 1]; 0 at lattice points.
pub fn gradient_noise3(p: Vec3, seed: u32) -> f32 {
    #[rustfmt::skip]
    const GRAD: [[f32; 3]; 12] = [
        [1.0, 1.0, 0.0], [-1.0, 1.0, 0.0], [1.0, -1.0, 0.0], [-1.0, -1.0, 0.0],
        [1.0, 0.0, 1.0], [-1.0, 0.0, 1.0], [1.0, 0.0, -1.0], [-1.0, 0.0, -1.0],
        [0.0, 1.0, 1.0], [0.0, -1.0, 1.0], [0.0, 1.0, -1.0], [0.0, -1.0, -1.0],
    ];
    let cell = p.floor();
    let f = p - cell;
    let (ix, iy, iz) = (cell.x as i32, cell.y as i32, cell.z as i32);
    let corner = |dx: i32, dy: i32, dz: i32| {
        let g = GRAD[(hash3(
            ix.wrapping_add(dx),
            iy.wrapping_add(dy),
            iz.wrapping_add(dz),
            seed,
        ) % 12) as usize];
        Vec3::from(g).dot(f - Vec3::new(dx as f32, dy as f32, dz as f32))
    };
    let (u, v, w) = (fade(f.x), fade(f.y), fade(f.z));
    let lerp = |a: f32, b: f32, t: f32| a + t * (b - a);
    let x00 = lerp(corner(0, 0, 0), corner(1, 0, 0), u);
    let x10 = lerp(corner(0, 1, 0), corner(1, 1, 0), u);
    let x01 = lerp(corner(0, 0, 1), corner(1, 0, 1), u);
    let x11 = lerp(corner(0, 1, 1), corner(1, 1, 1), u);
    lerp(lerp(x00, x10, v), lerp(x01, x11, v), w)
}

/// Fractal sum of `octaves` (≥ 1) gradient-noise octaves, each at twice
/// the frequency and half the weight of the previous, normalized and
/// clamped to [−1, 1].
pub fn fbm3(p: Vec3, octaves: u32, seed: u32) -> f32 {
    let (mut sum, mut norm, mut weight, mut scale) = (0.0, 0.0, 1.0, 1.0);
    for o in 0..octaves.max(1) {
        sum += weight * gradient_noise3(scale * p, seed.wrapping_add(o.wrapping_mul(0x9E37_79B9)));
        norm += weight;
        weight *= 0.5;
        scale *= 2.0;
    }
    (sum / norm).clamp(-1.0, 1.0)
}

/// Cobblestone profile in [0, 1]: Worley cells (one jittered feature point
/// per unit cell) with height rising from 0 on the border between the two
/// nearest feature points (F2 − F1 = 0) to 1 inside, rounded.
pub fn cells2(p: Vec2, seed: u32) -> f32 {
    let cell = p.floor();
    let (cx, cz) = (cell.x as i32, cell.y as i32);
    let (mut f1, mut f2) = (f32::INFINITY, f32::INFINITY);
    for dz in -1..=1 {
        for dx in -1..=1 {
            let (x, z) = (cx.wrapping_add(dx), cz.wrapping_add(dz));
            let h = hash3(x, z, 0x51ED, seed);
            let jitter = Vec2::new((h & 0xFFFF) as f32, (h >> 16) as f32) / 65535.0;
            let feature = Vec2::new(x as f32, z as f32) + 0.15 + 0.7 * jitter;
            let d = p.distance(feature);
            if d < f1 {
                f2 = f1;
                f1 = d;
            } else if d < f2 {
                f2 = d;
            }
        }
    }
    let t = ((f2 - f1) / 0.4).clamp(0.0, 1.0);
    t * (2.0 - t)
}
