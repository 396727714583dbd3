//! Unit tests of `voxel`.

use super::oracle::{cross3, sub3};
use super::*;
use rand::rngs::StdRng;
use rand::{RngExt, SeedableRng};

/// Whether the triangle meets the box [−h, h]³, by clipping the
/// triangle polygon against the box's six planes (Sutherland–Hodgman)
/// in f64: an oracle independent of the separating-axis test.
fn clipped_meets_box(v: [[f32; 3]; 3], h: f64) -> bool {
    let mut poly: Vec<[f64; 3]> = v.iter().map(|p| p.map(|c| c as f64)).collect();
    for axis in 0..3 {
        for sign in [1.0, -1.0] {
            // Keep sign·p[axis] ≤ h.
            let inside = |p: &[f64; 3]| sign * p[axis] <= h;
            let mut out = Vec::new();
            for k in 0..poly.len() {
                let (a, b) = (poly[k], poly[(k + 1) % poly.len()]);
                if inside(&a) {
                    out.push(a);
                }
                if inside(&a) != inside(&b) {
                    let t = (h - sign * a[axis]) / (sign * (b[axis] - a[axis]));
                    out.push([0, 1, 2].map(|c| a[c] + t * (b[c] - a[c])));
                }
            }
            poly = out;
            if poly.is_empty() {
                return false;
            }
        }
    }
    true
}

/// The voxelization is conservative up to touching and tight: against
/// the clipping oracle over a whole 32³ grid, every voxel the triangle
/// meets with a 10⁻³-voxel margin inside is set, and every set voxel's
/// box grown by 10⁻³ meets the triangle. Random triangles of every size
/// (slivers, huge ones reaching outside the grid, tiny ones).
#[test]
fn voxelization_is_conservative_and_tight_against_clipping() {
    let mut rng = StdRng::seed_from_u64(11);
    let res = 32u32;
    let (mut set_total, mut tested) = (0usize, 0usize);
    for t in 0..120 {
        let size = [0.3f32, 3.0, 20.0, 60.0][t % 4];
        let centre: [f32; 3] = std::array::from_fn(|_| rng.random_range(2.0..30.0));
        let q: [[f32; 3]; 3] = std::array::from_fn(|_| {
            std::array::from_fn(|c| centre[c] + size * rng.random_range(-1.0..1.0f32))
        });
        let mut set = vec![false; (res * res * res) as usize];
        voxelize_triangle(q, res, None, |x, y, z| {
            set[((z * res + y) * res + x) as usize] = true;
        });
        for z in 0..res {
            for y in 0..res {
                for x in 0..res {
                    let c = [x, y, z].map(|i| i as f32 + 0.5);
                    let v = q.map(|p| sub3(p, c));
                    let is_set = set[((z * res + y) * res + x) as usize];
                    if clipped_meets_box(v, 0.5 - 1e-3) {
                        assert!(is_set, "triangle {t} {q:?}: voxel {x},{y},{z} missed");
                    }
                    if is_set {
                        assert!(
                            clipped_meets_box(v, 0.5 + 1e-3),
                            "triangle {t} {q:?}: voxel {x},{y},{z} set but apart"
                        );
                        set_total += 1;
                    }
                    tested += 1;
                }
            }
        }
    }
    assert!(set_total > 10_000, "{set_total} of {tested} set");
}

/// Tiles of TILE columns partition a triangle's columns: their union
/// is the whole footprint's voxels, in any direction.
#[test]
fn tiles_cover_the_footprint() {
    let q = [[1.3, 2.2, 3.1], [40.0, 7.5, 12.0], [9.0, 50.0, 30.0]];
    let res = 64;
    let mut whole = Vec::new();
    voxelize_triangle(q, res, None, |x, y, z| whole.push([x, y, z]));
    let mut tiled = Vec::new();
    let t = TILE as i32;
    for ti in 0..4 {
        for tj in 0..4 {
            // Columns counted from the footprint's low corner, as the kernel does.
            let cols = [[ti * t, ti * t + t - 1], [tj * t, tj * t + t - 1]];
            let lo = |axis: usize| q.iter().map(|p| p[axis]).fold(f32::MAX, f32::min);
            let n = cross3(sub3(q[1], q[0]), sub3(q[2], q[0]));
            let k = (0..3)
                .max_by(|&a, &b| n[a].abs().partial_cmp(&n[b].abs()).unwrap().then(b.cmp(&a)))
                .unwrap();
            let (i, j) = match k {
                0 => (1, 2),
                1 => (0, 2),
                _ => (0, 1),
            };
            let (li, lj) = (lo(i).floor() as i32, lo(j).floor() as i32);
            let cols = [
                [li + cols[0][0], li + cols[0][1]],
                [lj + cols[1][0], lj + cols[1][1]],
            ];
            voxelize_triangle(q, res, Some(cols), |x, y, z| tiled.push([x, y, z]));
        }
    }
    whole.sort();
    tiled.sort();
    assert!(!whole.is_empty());
    assert_eq!(whole, tiled);
}

/// Every direction maps to a voxelization whose row axis is within
/// k/√2 of it (up to sign), the bound of rounding θ and φ to the
/// nearest step; on-grid directions map to themselves.
#[test]
fn direction_index_picks_a_row_axis_within_half_a_diagonal_step() {
    let mut rng = StdRng::seed_from_u64(3);
    for n in [1u32, 6, 30, 90] {
        let frames: Vec<[f32; 3]> = axes(n).iter().map(|f| f[2].map(|c| c as f32)).collect();
        let k = std::f32::consts::PI / n as f32;
        let bound = (k / std::f32::consts::SQRT_2).min(std::f32::consts::FRAC_PI_2) + 1e-4;
        for _ in 0..20_000 {
            let d = Vec3::new(
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
            );
            if d.length() < 1e-3 {
                continue;
            }
            let v = direction_index(n, d);
            let u = Vec3::from(frames[v as usize]);
            let angle = d.normalize().dot(u).abs().min(1.0).acos();
            // Near the pole a step of φ moves u by less: the bound holds.
            assert!(angle <= bound, "n {n}, d {d}: {angle} > {bound}");
        }
        for (v, f) in frames.iter().enumerate() {
            let u = Vec3::from(*f);
            let got = direction_index(n, u);
            let same = Vec3::from(frames[got as usize]);
            assert!(
                got == v as u32 || same.dot(u).abs() > 1.0 - 1e-6,
                "n {n}: frame {v} maps to {got}"
            );
        }
    }
}
