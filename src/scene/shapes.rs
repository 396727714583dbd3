//! Tessellation of the scene file's shapes into counter-clockwise triangle
//! meshes (geometric normal `(v1 − v0) × (v2 − v0)`, docs/conventions.md
//! "Materials"); the `heightfield` and `blob` generators take their noise
//! from [`super::noise`].
//!
//! Every function here is pure: parameters in, [`TriMesh`] out, no I/O and
//! no validation beyond what keeps the arithmetic defined — the scene-file
//! loader ([`crate::scene_file`]) checks ranges first and reports errors with
//! file positions. Triangle counts are known before building (the
//! `*_triangles` functions), so the loader can refuse absurd sizes before
//! allocating.
//!
//! | shape        | triangles                          | normals                    |
//! |--------------|------------------------------------|----------------------------|
//! | [`quad`]     | 2: (c0,c1,c2), (c0,c2,c3)          | (c1−c0)×(c2−c0)            |
//! | [`triangle`] | 1                                  | (v1−v0)×(v2−v0)            |
//! | [`cuboid`]   | 12                                 | outward                    |
//! | [`uv_sphere`]| 2·segments·(rings−1)               | outward                    |
//! | [`disk`]     | segments (a fan)                   | along `normal`             |
//! | [`lathe`]    | ≤ 2·segments·(points−1)            | right of the profile's travel (outward for bottom-to-top profiles) |
//! | [`heightfield`] | 2·nx·nz                         | +y side                    |
//! | [`blob`]     | 20·4^subdivisions                  | outward                    |

use super::noise::{cells2, fbm3};
use glam::{Affine3A, Vec2, Vec3};
use std::collections::HashMap;
use std::f32::consts::{PI, TAU};
use std::hash::{BuildHasherDefault, Hasher};

/// An indexed triangle mesh, counter-clockwise winding.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TriMesh {
    pub positions: Vec<Vec3>,
    pub indices: Vec<[u32; 3]>,
    /// Shading normals, one per position (an OBJ's `vn`), or empty: the
    /// geometric normal shades. They change only how a surface reflects;
    /// the geometric normal still decides which side emits
    /// (docs/conventions.md "Materials").
    pub normals: Vec<Vec3>,
}

impl TriMesh {
    /// A mesh without shading normals.
    pub fn new(positions: Vec<Vec3>, indices: Vec<[u32; 3]>) -> TriMesh {
        TriMesh {
            positions,
            indices,
            normals: Vec::new(),
        }
    }

    /// Vertices of triangle `t`.
    pub fn triangle(&self, t: usize) -> [Vec3; 3] {
        let [a, b, c] = self.indices[t];
        [
            self.positions[a as usize],
            self.positions[b as usize],
            self.positions[c as usize],
        ]
    }

    /// Unnormalized geometric normal of triangle `t` (length = 2·area).
    pub fn face_normal(&self, t: usize) -> Vec3 {
        let [a, b, c] = self.triangle(t);
        (b - a).cross(c - a)
    }

    /// Total surface area (f64 accumulation).
    pub fn area(&self) -> f64 {
        (0..self.indices.len())
            .map(|t| 0.5 * self.face_normal(t).length() as f64)
            .sum()
    }

    /// Signed enclosed volume (divergence theorem); positive for a closed
    /// mesh whose normals point outward.
    pub fn signed_volume(&self) -> f64 {
        (0..self.indices.len())
            .map(|t| {
                let [a, b, c] = self.triangle(t).map(|v| v.as_dvec3());
                a.dot(b.cross(c)) / 6.0
            })
            .sum()
    }

    /// Whether at least one triangle has non-zero area.
    pub fn has_area(&self) -> bool {
        (0..self.indices.len()).any(|t| {
            let n = self.face_normal(t);
            n.is_finite() && n.length_squared() > 0.0
        })
    }

    /// Apply an affine map to every vertex. A mirroring map (negative
    /// determinant) would turn the normals inside out, so the winding is
    /// reversed to keep them on the same side of the surface.
    /// Shading normals go through the inverse transpose and are normalized
    /// again (a zero normal stays zero).
    pub fn transform(&mut self, m: &Affine3A) {
        for p in &mut self.positions {
            *p = m.transform_point3(*p);
        }
        let normal_map = m.matrix3.inverse().transpose();
        for n in &mut self.normals {
            *n = (normal_map * *n).normalize_or_zero();
        }
        if m.matrix3.determinant() < 0.0 {
            for tri in &mut self.indices {
                tri.swap(1, 2);
            }
        }
    }
}

/// The most triangles that may share one bounding-box centre. A BVH
/// builder separates triangles by their centres, so a pile of coincident
/// ones (the same face written many times) cannot be split: obvhs then
/// peels them off a few at a time, in time quadratic in the pile and to a
/// depth the GPU traversal stack cannot hold (80,000 copies of one face
/// took 96 s to fail). A real mesh has at most a few faces with the same
/// centre (a face and its reverse), so 16 refuses only broken input.
pub const MAX_COINCIDENT_TRIANGLES: usize = 16;

/// The largest set of triangles sharing one bounding-box centre, when it
/// has more than [`MAX_COINCIDENT_TRIANGLES`] members.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CoincidentTriangles {
    /// How many triangles share the centre.
    pub count: usize,
    /// The first two of them (indices in the iteration order).
    pub first: [usize; 2],
    pub centre: Vec3,
}

/// Finds piles of triangles with one bounding-box centre (see
/// [`MAX_COINCIDENT_TRIANGLES`]) in linear time. The centre is
/// `(min + max) / 2` of the vertices, which does not depend on their order.
pub fn coincident_triangles(
    triangles: impl Iterator<Item = [Vec3; 3]>,
) -> Option<CoincidentTriangles> {
    let mut seen: HashMap<[u32; 3], (usize, usize, usize), BuildHasherDefault<SplitMix>> =
        HashMap::default();
    let mut worst: Option<CoincidentTriangles> = None;
    for (t, [a, b, c]) in triangles.enumerate() {
        let centre = (a.min(b).min(c) + a.max(b).max(c)) * 0.5;
        // +0.0 and −0.0 are one point.
        let key = (centre + Vec3::ZERO).to_array().map(f32::to_bits);
        let entry = seen.entry(key).or_insert((0, t, t));
        entry.0 += 1;
        if entry.0 == 2 {
            entry.2 = t;
        }
        if entry.0 > MAX_COINCIDENT_TRIANGLES && worst.is_none_or(|w| entry.0 > w.count) {
            worst = Some(CoincidentTriangles {
                count: entry.0,
                first: [entry.1, entry.2],
                centre,
            });
        }
    }
    worst
}

impl std::fmt::Display for CoincidentTriangles {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{} triangles share the centre ({}, {}, {}) (the first two are triangles {} and {}, counting from 0); \
             a BVH cannot separate more than {} coincident triangles — remove the duplicate faces",
            self.count,
            self.centre.x,
            self.centre.y,
            self.centre.z,
            self.first[0],
            self.first[1],
            MAX_COINCIDENT_TRIANGLES
        )
    }
}

/// Two triangles (c0, c1, c2), (c0, c2, c3); normal (c1 − c0) × (c2 − c0).
pub fn quad(corners: [Vec3; 4]) -> TriMesh {
    TriMesh::new(corners.to_vec(), vec![[0, 1, 2], [0, 2, 3]])
}

/// One triangle; normal (v1 − v0) × (v2 − v0).
pub fn triangle(vertices: [Vec3; 3]) -> TriMesh {
    TriMesh::new(vertices.to_vec(), vec![[0, 1, 2]])
}

/// Axis-aligned box, 12 triangles, normals outward.
pub fn cuboid(min: Vec3, max: Vec3) -> TriMesh {
    // Corner k has x from bit 0, y from bit 1, z from bit 2.
    let positions = (0..8)
        .map(|k| {
            Vec3::new(
                if k & 1 != 0 { max.x } else { min.x },
                if k & 2 != 0 { max.y } else { min.y },
                if k & 4 != 0 { max.z } else { min.z },
            )
        })
        .collect();
    // Each face counter-clockwise seen from outside: −x, +x, −y, +y, −z, +z.
    const FACES: [[u32; 4]; 6] = [
        [0, 4, 6, 2],
        [1, 3, 7, 5],
        [0, 1, 5, 4],
        [2, 6, 7, 3],
        [0, 2, 3, 1],
        [4, 5, 7, 6],
    ];
    let indices = FACES
        .iter()
        .flat_map(|&[a, b, c, d]| [[a, b, c], [a, c, d]])
        .collect();
    TriMesh::new(positions, indices)
}

pub fn uv_sphere_triangles(segments: u64, rings: u64) -> u64 {
    2 * segments * rings.saturating_sub(1)
}

/// UV sphere: a vertex at each pole and `rings − 1` latitude rings of
/// `segments` vertices. Normals outward. Needs segments ≥ 3, rings ≥ 2.
pub fn uv_sphere(center: Vec3, radius: f32, segments: u32, rings: u32) -> TriMesh {
    let (s, r) = (segments as usize, rings as usize);
    let mut positions = Vec::with_capacity(2 + s * (r - 1));
    // Colatitude θ from +y, longitude φ counter-clockwise about +y.
    let dir = |theta: f32, phi: f32| {
        Vec3::new(
            theta.sin() * phi.cos(),
            theta.cos(),
            -theta.sin() * phi.sin(),
        )
    };
    positions.push(center + radius * Vec3::Y);
    for k in 1..r {
        let theta = PI * k as f32 / r as f32;
        for j in 0..s {
            positions.push(center + radius * dir(theta, TAU * j as f32 / s as f32));
        }
    }
    positions.push(center - radius * Vec3::Y);
    let south = (positions.len() - 1) as u32;
    let ring = |k: usize, j: usize| (1 + (k - 1) * s + j % s) as u32;

    let mut indices = Vec::with_capacity(uv_sphere_triangles(s as u64, r as u64) as usize);
    for j in 0..s {
        indices.push([0, ring(1, j), ring(1, j + 1)]);
    }
    for k in 1..r - 1 {
        for j in 0..s {
            let (a, b) = (ring(k, j), ring(k, j + 1));
            let (c, d) = (ring(k + 1, j), ring(k + 1, j + 1));
            indices.push([a, c, d]);
            indices.push([a, d, b]);
        }
    }
    for j in 0..s {
        indices.push([ring(r - 1, j), south, ring(r - 1, j + 1)]);
    }
    TriMesh::new(positions, indices)
}

/// Flat disk, a fan of `segments` triangles around the center, facing
/// `normal` (need not be normalized, must be nonzero).
pub fn disk(center: Vec3, normal: Vec3, radius: f32, segments: u32) -> TriMesh {
    let n = normal.normalize();
    let (t, _) = n.any_orthonormal_pair();
    let b = n.cross(t); // t × b = n
    let s = segments as usize;
    let mut positions = Vec::with_capacity(s + 1);
    positions.push(center);
    for j in 0..s {
        let phi = TAU * j as f32 / s as f32;
        positions.push(center + radius * (phi.cos() * t + phi.sin() * b));
    }
    let indices = (0..s)
        .map(|j| [0, 1 + j as u32, 1 + ((j + 1) % s) as u32])
        .collect();
    TriMesh::new(positions, indices)
}

pub fn lathe_triangles(points: u64, segments: u64) -> u64 {
    2 * segments * points.saturating_sub(1)
}

/// Surface of revolution: `profile` points (x = radius ≥ 0, y = height)
/// revolved about the vertical axis through `center`. A point of radius 0
/// becomes a single pole vertex, so a profile that starts and ends on the
/// axis gives a closed surface. Normals point to the right of the
/// profile's direction of travel in the (radius, height) half-plane:
/// outward for a profile listed from bottom to top.
pub fn lathe(profile: &[Vec2], segments: u32, center: Vec3) -> TriMesh {
    let s = segments as usize;
    let mut positions = Vec::new();
    // First vertex of each profile point's ring, and whether it is a pole.
    let mut rings = Vec::with_capacity(profile.len());
    for p in profile {
        let first = positions.len() as u32;
        if p.x == 0.0 {
            positions.push(center + Vec3::new(0.0, p.y, 0.0));
            rings.push((first, true));
        } else {
            for j in 0..s {
                let phi = TAU * j as f32 / s as f32;
                positions.push(center + Vec3::new(p.x * phi.cos(), p.y, -p.x * phi.sin()));
            }
            rings.push((first, false));
        }
    }
    let at =
        |(first, pole): (u32, bool), j: usize| if pole { first } else { first + (j % s) as u32 };
    let mut indices = Vec::new();
    for w in rings.windows(2) {
        let (lo, hi) = (w[0], w[1]);
        if lo.1 && hi.1 {
            continue;
        }
        for j in 0..s {
            // Around (φ increasing) × along the profile = outward for an
            // upward profile.
            let (a, b, c, d) = (at(lo, j), at(lo, j + 1), at(hi, j + 1), at(hi, j));
            if !lo.1 {
                indices.push([a, b, c]);
            }
            if !hi.1 {
                indices.push([a, c, d]);
            }
        }
    }
    TriMesh::new(positions, indices)
}

/// Which procedural height function a heightfield uses.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum HeightNoise {
    /// Fractal gradient noise in [−1, 1] ([`fbm3`]).
    Fbm,
    /// Rounded Voronoi cells in [0, 1] with grooves between them
    /// ([`cells2`]): cobblestones.
    Cells,
}

/// Parameters of a [`heightfield`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Heightfield {
    /// Corners of the grid in world x, z.
    pub min: Vec2,
    pub max: Vec2,
    /// Number of cells along x and z (≥ 1 each).
    pub resolution: [u32; 2],
    pub base_y: f32,
    pub amplitude: f32,
    /// Noise features per world unit.
    pub frequency: f32,
    pub octaves: u32,
    pub seed: u32,
    pub noise: HeightNoise,
}

pub fn heightfield_triangles(nx: u64, nz: u64) -> u64 {
    2 * nx * nz
}

/// Grid of `nx·nz` cells over [min.x, max.x] × [min.z, max.z] with
/// y = base_y + amplitude·noise(frequency·(x, z)); normals face +y.
pub fn heightfield(h: &Heightfield) -> TriMesh {
    let [nx, nz] = h.resolution.map(|n| n as usize);
    let mut positions = Vec::with_capacity((nx + 1) * (nz + 1));
    for k in 0..=nz {
        let z = h.min.y + (h.max.y - h.min.y) * k as f32 / nz as f32;
        for i in 0..=nx {
            let x = h.min.x + (h.max.x - h.min.x) * i as f32 / nx as f32;
            let q = h.frequency * Vec2::new(x, z);
            let value = match h.noise {
                HeightNoise::Fbm => fbm3(Vec3::new(q.x, 0.5, q.y), h.octaves, h.seed),
                HeightNoise::Cells => cells2(q, h.seed),
            };
            positions.push(Vec3::new(x, h.base_y + h.amplitude * value, z));
        }
    }
    let v = |i: usize, k: usize| (k * (nx + 1) + i) as u32;
    let mut indices = Vec::with_capacity(2 * nx * nz);
    for k in 0..nz {
        for i in 0..nx {
            // (+z edge) × (diagonal) = +y.
            indices.push([v(i, k), v(i, k + 1), v(i + 1, k + 1)]);
            indices.push([v(i, k), v(i + 1, k + 1), v(i + 1, k)]);
        }
    }
    TriMesh::new(positions, indices)
}

pub fn icosphere_triangles(subdivisions: u32) -> u64 {
    20u64.saturating_mul(4u64.saturating_pow(subdivisions))
}

/// Unit icosphere: an icosahedron whose triangles are split in four
/// `subdivisions` times, new vertices pushed onto the unit sphere.
/// Vertices are shared (no cracks); normals outward.
pub fn icosphere(subdivisions: u32) -> TriMesh {
    let t = (1.0 + 5f32.sqrt()) / 2.0;
    let mut positions: Vec<Vec3> = [
        [-1.0, t, 0.0],
        [1.0, t, 0.0],
        [-1.0, -t, 0.0],
        [1.0, -t, 0.0],
        [0.0, -1.0, t],
        [0.0, 1.0, t],
        [0.0, -1.0, -t],
        [0.0, 1.0, -t],
        [t, 0.0, -1.0],
        [t, 0.0, 1.0],
        [-t, 0.0, -1.0],
        [-t, 0.0, 1.0],
    ]
    .iter()
    .map(|&p| Vec3::from(p).normalize())
    .collect();
    #[rustfmt::skip]
    let mut indices: Vec<[u32; 3]> = vec![
        [0, 11, 5], [0, 5, 1], [0, 1, 7], [0, 7, 10], [0, 10, 11],
        [1, 5, 9], [5, 11, 4], [11, 10, 2], [10, 7, 6], [7, 1, 8],
        [3, 9, 4], [3, 4, 2], [3, 2, 6], [3, 6, 8], [3, 8, 9],
        [4, 9, 5], [2, 4, 11], [6, 2, 10], [8, 6, 7], [9, 8, 1],
    ];
    for _ in 0..subdivisions {
        // V − E + F = 2 with E = 3F/2: each edge adds one vertex.
        let edges = indices.len() * 3 / 2;
        positions.reserve(edges);
        let mut midpoint: HashMap<u64, u32, BuildHasherDefault<SplitMix>> =
            HashMap::with_capacity_and_hasher(edges, Default::default());
        let mut mid = |a: u32, b: u32, positions: &mut Vec<Vec3>| {
            let key = (a.min(b) as u64) << 32 | a.max(b) as u64;
            *midpoint.entry(key).or_insert_with(|| {
                let p = (positions[a as usize] + positions[b as usize]).normalize();
                positions.push(p);
                (positions.len() - 1) as u32
            })
        };
        let mut next = Vec::with_capacity(indices.len() * 4);
        for &[a, b, c] in &indices {
            let ab = mid(a, b, &mut positions);
            let bc = mid(b, c, &mut positions);
            let ca = mid(c, a, &mut positions);
            next.extend([[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
        }
        indices = next;
    }
    TriMesh::new(positions, indices)
}

/// Noise displacement of a [`blob`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BlobNoise {
    /// Relative radius displacement: r = radius·(1 + amplitude·fbm), in [0, 1).
    pub amplitude: f32,
    /// Noise features per unit of the undisplaced unit sphere.
    pub frequency: f32,
    pub octaves: u32,
    pub seed: u32,
}

/// Organic closed surface: an [`icosphere`] whose vertex at unit direction
/// d sits at center + radius·(1 + amplitude·fbm3(frequency·d))·d.
pub fn blob(center: Vec3, radius: f32, subdivisions: u32, noise: &BlobNoise) -> TriMesh {
    let mut mesh = icosphere(subdivisions);
    let displace = |chunk: &[Vec3]| -> Vec<Vec3> {
        chunk
            .iter()
            .map(|&d| {
                center
                    + radius
                        * (1.0
                            + noise.amplitude
                                * fbm3(noise.frequency * d, noise.octaves, noise.seed))
                        * d
            })
            .collect()
    };
    // Each vertex is independent: split the noise work across threads
    // (the result does not depend on the split).
    let threads = std::thread::available_parallelism()
        .map_or(1, |n| n.get())
        .min(16);
    let chunk = mesh.positions.len().div_ceil(threads).max(4096);
    mesh.positions = std::thread::scope(|scope| {
        let parts: Vec<_> = mesh
            .positions
            .chunks(chunk)
            .map(|part| {
                (
                    part,
                    std::thread::Builder::new().spawn_scoped(scope, move || displace(part)),
                )
            })
            .collect();
        // A thread that could not start, or failed, is done here instead.
        parts
            .into_iter()
            .flat_map(|(part, handle)| {
                handle
                    .ok()
                    .and_then(|h| h.join().ok())
                    .unwrap_or_else(|| displace(part))
            })
            .collect()
    });
    mesh
}

/// splitmix64 finalizer as a `Hasher` for the midpoint map (edge keys are
/// one u64; std's SipHash is several times slower for 10⁶ inserts).
#[derive(Default)]
struct SplitMix(u64);

impl Hasher for SplitMix {
    fn finish(&self) -> u64 {
        self.0
    }
    fn write(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.write_u64(self.0 ^ b as u64);
        }
    }
    fn write_u64(&mut self, n: u64) {
        let mut z = n.wrapping_add(0x9E37_79B9_7F4A_7C15);
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        self.0 = z ^ (z >> 31);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every face normal points away from `center` (convex shapes).
    fn all_outward(m: &TriMesh, center: Vec3) -> bool {
        (0..m.indices.len()).all(|t| {
            let [a, b, c] = m.triangle(t);
            m.face_normal(t).dot((a + b + c) / 3.0 - center) > 0.0
        })
    }

    #[test]
    fn quad_normal_follows_ccw_rule() {
        let m = quad([Vec3::ZERO, Vec3::X, Vec3::new(1.0, 0.0, -1.0), Vec3::NEG_Z]);
        for t in 0..2 {
            assert!(m.face_normal(t).normalize().abs_diff_eq(Vec3::Y, 1e-6));
        }
        assert!((m.area() - 1.0).abs() < 1e-6);
    }

    #[test]
    fn cuboid_has_12_outward_triangles() {
        let (min, max) = (Vec3::new(-1.0, 0.0, 2.0), Vec3::new(2.0, 1.0, 4.0));
        let m = cuboid(min, max);
        assert_eq!(m.indices.len(), 12);
        assert!(all_outward(&m, (min + max) / 2.0));
        assert!((m.area() - 2.0 * (3.0 * 1.0 + 3.0 * 2.0 + 1.0 * 2.0)).abs() < 1e-5);
        assert!((m.signed_volume() - 6.0).abs() < 1e-5);
    }

    #[test]
    fn sphere_area_approaches_4_pi_r2_with_outward_normals() {
        let (c, r) = (Vec3::new(1.0, 2.0, 3.0), 0.5);
        let mut previous_error = f64::INFINITY;
        for (segments, rings) in [(8, 4), (32, 16), (128, 64)] {
            let m = uv_sphere(c, r, segments, rings);
            assert_eq!(
                m.indices.len() as u64,
                uv_sphere_triangles(segments as u64, rings as u64)
            );
            assert!(all_outward(&m, c));
            let exact = 4.0 * std::f64::consts::PI * (r as f64).powi(2);
            let error = (m.area() - exact).abs() / exact;
            assert!(error < previous_error);
            previous_error = error;
        }
        assert!(previous_error < 1e-3, "{previous_error}");
    }

    #[test]
    fn disk_faces_its_normal() {
        let n = Vec3::new(1.0, -2.0, 0.5);
        let m = disk(Vec3::ONE, n, 2.0, 64);
        assert_eq!(m.indices.len(), 64);
        for t in 0..m.indices.len() {
            assert!(m
                .face_normal(t)
                .normalize()
                .abs_diff_eq(n.normalize(), 1e-4));
        }
        let exact = std::f64::consts::PI * 4.0;
        assert!((m.area() - exact).abs() / exact < 0.01);
    }

    #[test]
    fn lathe_closed_cylinder_is_closed_and_outward() {
        let (h, r, s) = (2.0, 0.5, 256);
        let profile = [
            Vec2::new(0.0, 0.0),
            Vec2::new(r, 0.0),
            Vec2::new(r, h),
            Vec2::new(0.0, h),
        ];
        let c = Vec3::new(3.0, -1.0, 0.0);
        let m = lathe(&profile, s, c);
        // Fans at both poles (s each) + one quad band (2s).
        assert_eq!(m.indices.len(), 4 * s as usize);
        assert!(m.indices.len() as u64 <= lathe_triangles(4, s as u64));
        assert!(all_outward(&m, c + Vec3::new(0.0, h / 2.0, 0.0)));
        let pi = std::f64::consts::PI;
        let (r, h) = (r as f64, h as f64);
        assert!((m.signed_volume() - pi * r * r * h).abs() / (pi * r * r * h) < 1e-3);
        assert!((m.area() - (2.0 * pi * r * r + 2.0 * pi * r * h)).abs() < 1e-2);
        // Closed: every edge is used exactly once in each direction.
        let mut edges = std::collections::HashSet::new();
        for &[a, b, c] in &m.indices {
            for e in [(a, b), (b, c), (c, a)] {
                assert!(edges.insert(e), "edge {e:?} used twice in one direction");
            }
        }
        assert!(edges.iter().all(|&(a, b)| edges.contains(&(b, a))));
    }

    #[test]
    fn lathe_reversed_profile_points_inward() {
        let profile = [
            Vec2::new(0.0, 1.0),
            Vec2::new(1.0, 1.0),
            Vec2::new(1.0, 0.0),
            Vec2::new(0.0, 0.0),
        ];
        assert!(lathe(&profile, 16, Vec3::ZERO).signed_volume() < 0.0);
    }

    #[test]
    fn heightfield_normals_up_and_deterministic() {
        for noise in [HeightNoise::Fbm, HeightNoise::Cells] {
            let h = Heightfield {
                min: Vec2::new(-2.0, -1.0),
                max: Vec2::new(2.0, 3.0),
                resolution: [40, 30],
                base_y: 0.5,
                amplitude: 0.1,
                frequency: 2.0,
                octaves: 4,
                seed: 7,
                noise,
            };
            let m = heightfield(&h);
            assert_eq!(m.indices.len() as u64, heightfield_triangles(40, 30));
            assert_eq!(m.positions.len(), 41 * 31);
            assert!((0..m.indices.len()).all(|t| m.face_normal(t).y > 0.0));
            assert!(m.positions.iter().all(|p| (p.y - 0.5).abs() <= 0.1 + 1e-6));
            assert_eq!(m, heightfield(&h));
            assert_ne!(m, heightfield(&Heightfield { seed: 8, ..h }));
        }
    }

    #[test]
    fn icosphere_is_closed_outward_and_shares_vertices() {
        for s in 0..4 {
            let m = icosphere(s);
            assert_eq!(m.indices.len() as u64, icosphere_triangles(s));
            // Euler: V = F/2 + 2 for a closed triangle mesh of genus 0.
            assert_eq!(m.positions.len(), m.indices.len() / 2 + 2);
            assert!(all_outward(&m, Vec3::ZERO));
            assert!(m.positions.iter().all(|p| (p.length() - 1.0).abs() < 1e-6));
        }
        let exact = 4.0 * std::f64::consts::PI;
        assert!((icosphere(5).area() - exact).abs() / exact < 1e-3);
    }

    #[test]
    fn blob_is_displaced_outward_closed_and_deterministic() {
        let noise = BlobNoise {
            amplitude: 0.3,
            frequency: 2.0,
            octaves: 4,
            seed: 3,
        };
        let c = Vec3::new(0.0, 1.0, 0.0);
        let m = blob(c, 2.0, 4, &noise);
        assert_eq!(m.indices.len(), 20 * 256);
        let radii: Vec<f32> = m.positions.iter().map(|p| p.distance(c)).collect();
        assert!(radii
            .iter()
            .all(|&r| (2.0 * 0.7 - 1e-4..=2.0 * 1.3 + 1e-4).contains(&r)));
        let spread =
            radii.iter().cloned().fold(0.0, f32::max) - radii.iter().cloned().fold(9.0, f32::min);
        assert!(
            spread > 0.2,
            "noise should displace the surface, spread {spread}"
        );
        assert!(m.signed_volume() > 0.0);
        assert_eq!(m, blob(c, 2.0, 4, &noise));
    }

    #[test]
    fn noise_is_bounded_and_varies() {
        let mut values = Vec::new();
        for i in 0..2000 {
            let p = Vec3::new(
                i as f32 * 0.137,
                i as f32 * 0.071 - 40.0,
                (i % 17) as f32 * 0.31,
            );
            let v = fbm3(p, 5, 11);
            assert!((-1.0..=1.0).contains(&v));
            values.push(v);
            let c = cells2(Vec2::new(p.x, p.y), 11);
            assert!((0.0..=1.0).contains(&c));
        }
        let mean = values.iter().sum::<f32>() / values.len() as f32;
        let var = values.iter().map(|v| (v - mean).powi(2)).sum::<f32>() / values.len() as f32;
        assert!(mean.abs() < 0.1 && var > 1e-3, "mean {mean} var {var}");
    }

    /// The pile detector keys on the bounding-box centre, so vertex order
    /// and the sign of zero do not hide a copy; no generated shape trips it.
    #[test]
    fn coincident_triangle_piles_are_found_and_real_shapes_pass() {
        let (a, b, c) = (Vec3::new(-0.0, 1.0, 0.0), Vec3::X, Vec3::new(0.0, 0.0, 2.0));
        let orders = [[a, b, c], [b, c, a], [c, a, b], [a, c, b]];
        let mut pile: Vec<[Vec3; 3]> = vec![[Vec3::ONE, Vec3::Y, Vec3::Z]];
        pile.extend((0..MAX_COINCIDENT_TRIANGLES).map(|i| orders[i % 4]));
        assert_eq!(coincident_triangles(pile.iter().copied()), None);
        pile.push([a.with_x(0.0), b, c]);
        let found = coincident_triangles(pile.iter().copied()).unwrap();
        assert_eq!(found.count, MAX_COINCIDENT_TRIANGLES + 1);
        assert_eq!(found.first, [1, 2]);
        assert_eq!(found.centre, Vec3::new(0.5, 0.5, 1.0));
        let noise = BlobNoise {
            amplitude: 0.2,
            frequency: 2.0,
            octaves: 3,
            seed: 1,
        };
        for m in [
            cuboid(Vec3::ZERO, Vec3::ONE),
            uv_sphere(Vec3::ZERO, 1.0, 64, 32),
            icosphere(5),
            blob(Vec3::ZERO, 1.0, 4, &noise),
            disk(Vec3::ZERO, Vec3::Y, 1.0, 64),
        ] {
            let tris = (0..m.indices.len()).map(|t| m.triangle(t));
            assert_eq!(coincident_triangles(tris), None);
        }
    }

    #[test]
    fn mirroring_transform_keeps_normals_outward() {
        let mut m = cuboid(Vec3::ZERO, Vec3::ONE);
        m.transform(&Affine3A::from_scale(Vec3::new(-1.0, 2.0, 1.0)));
        assert!(all_outward(&m, Vec3::new(-0.5, 1.0, 0.5)));
    }

    /// Shading normals go through the inverse transpose: under a
    /// non-uniform scale and a mirror, a normal stays perpendicular to the
    /// transformed surface, unit, and on the same side as the (rewound)
    /// geometric normal; a zero normal stays zero.
    #[test]
    fn transform_maps_shading_normals_by_the_inverse_transpose() {
        // A tilted triangle whose vertex normals are its face normal, and a
        // fourth, unused vertex with a zero normal.
        let mut m = triangle([
            Vec3::ZERO,
            Vec3::new(1.0, 0.0, 1.0),
            Vec3::new(0.0, 1.0, 0.5),
        ]);
        let n = m.face_normal(0).normalize();
        m.positions.push(Vec3::ONE);
        m.normals = vec![n, n, n, Vec3::ZERO];
        for matrix in [
            Affine3A::from_scale(Vec3::new(3.0, 0.5, 1.0)),
            Affine3A::from_scale_rotation_translation(
                Vec3::new(-2.0, 1.0, 0.25),
                glam::Quat::from_rotation_y(0.7),
                Vec3::new(1.0, 2.0, 3.0),
            ),
        ] {
            let mut t = m.clone();
            t.transform(&matrix);
            let face = t.face_normal(0).normalize();
            for v in 0..3 {
                let ns = t.normals[v];
                assert!((ns.length() - 1.0).abs() < 1e-6, "{ns}");
                assert!(ns.dot(face) > 1.0 - 1e-5, "{ns} vs face normal {face}");
            }
            assert_eq!(t.normals[3], Vec3::ZERO);
        }
    }
}
