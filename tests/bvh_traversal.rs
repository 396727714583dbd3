//! GPU CWBVH traversal (`wgsl/shared/bvh.wgsl`) against CPU brute force.
//!
//! Every test builds a scene, uploads it, traces at least 10,000 rays on
//! the GPU with `TraceKernel` (closest hit and any hit) and checks each
//! against `BuiltScene::brute_force_*`, which runs the same watertight
//! triangle test (src/accel/cpu.rs) over every triangle, moved to the
//! world at the ray's time. The rays mix: random origins and directions,
//! rays aimed at random surface points, axis-aligned directions with +0.0
//! and −0.0 components, rays starting exactly on a triangle, rays starting
//! inside closed boxes, finite and infinite t_max, unnormalized directions.
//!
//! Agreement rule (see [`compare`]): the triangle ids must be equal and
//! the distances equal within [`T_TOL`] (for a moving instance, equal to
//! the CPU's world-space or object-space evaluation, see
//! [`object_space_t`]), except for *ties* — rays where the
//! two answers are both right up to rounding: two triangles at the same
//! distance (a shared edge or vertex, coincident faces), or a hit that
//! sits on a triangle's boundary (a barycentric within [`BARY_TOL`] of 0)
//! or at t_min / t_max within tolerance, which one side's rounding keeps
//! and the other's drops. Ties must be rare (asserted per test).
//!
//! The GPU tests fail, never skip, without an adapter (lavapipe is fine).

mod common;

use common::gpu;
use glam::{Quat, Vec3};
use mdas::accel::cpu::{ray_t_min, ShearedRay};
use mdas::accel::{BuiltScene, GpuScene, HitRecord, Ray, TraceKernel, BVH_MAX_STEPS, MISS};
use mdas::film::Film;
use mdas::scene::shapes::{self, TriMesh};
use mdas::scene::{Camera, Checker, Keyframe, Light, Material, Mesh, Scene};
use rand::rngs::StdRng;
use rand::{RngExt, SeedableRng};

/// Distance tolerance, relative to max(1, t). Both sides evaluate the same
/// f32 expressions on coordinates of magnitude ≤ 10; they differ only by
/// FMA contraction and division rounding on the GPU (a few ulps, ~1e-6
/// relative) and, for moving instances, by where the rigid transform is
/// applied (the GPU moves the ray into object space, the CPU moves the
/// vertices to the world: a few ulps of the coordinates, ~1e-6 · 10,
/// magnified at grazing incidence). 1e-4 leaves two orders of magnitude
/// of headroom while still telling apart surfaces 1e-3 apart.
const T_TOL: f32 = 1e-4;

/// A hit whose smallest barycentric is below this lies on the triangle's
/// boundary to within rounding of U, V, W (relative error ~1e-6 for well
/// shaped triangles, larger for slivers).
const BARY_TOL: f32 = 1e-4;

// ---------------------------------------------------------------- scenes

fn scene_of(materials: Vec<Material>, meshes: Vec<Mesh>) -> Scene {
    Scene {
        film: Film {
            width: 64,
            height: 48,
        },
        camera: Camera {
            position: Vec3::new(0.0, 1.0, -6.0),
            look_at: Vec3::ZERO,
            up: Vec3::Y,
            fov_y: 40.0,
            aperture_radius: 0.0,
            focus_distance: 6.0,
            shutter_open: 0.0,
            shutter_close: 1.0,
        },
        background: Vec3::ZERO,
        materials,
        meshes,
        lights: Vec::new(),
        point_light_sets: Vec::new(),
    }
}

fn material(name: &str, albedo: Vec3) -> Material {
    Material {
        name: name.into(),
        albedo,
        emission: Vec3::ZERO,
        checker: None,
        one_sided: false,
        uv_checker: None,
    }
}

fn mesh(name: &str, m: TriMesh, material: u32, motion: Vec<Keyframe>) -> Mesh {
    Mesh {
        name: name.into(),
        positions: m.positions,
        indices: m.indices,
        normals: m.normals,
        uvs: Vec::new(),
        material,
        motion,
    }
}

fn ground() -> TriMesh {
    shapes::quad([
        Vec3::new(-5.0, 0.0, -5.0),
        Vec3::new(-5.0, 0.0, 5.0),
        Vec3::new(5.0, 0.0, 5.0),
        Vec3::new(5.0, 0.0, -5.0),
    ])
}

/// The axis-aligned box of scene (a) (its bottom face lies on the ground).
const BOX_MIN: Vec3 = Vec3::new(-2.0, 0.0, -1.0);
const BOX_MAX: Vec3 = Vec3::new(-0.5, 1.5, 0.5);

fn box_sphere_quad() -> Scene {
    scene_of(
        vec![
            material("white", Vec3::splat(0.7)),
            material("red", Vec3::new(0.7, 0.1, 0.1)),
        ],
        vec![
            mesh("ground", ground(), 0, vec![]),
            mesh("box", shapes::cuboid(BOX_MIN, BOX_MAX), 1, vec![]),
            mesh(
                "sphere",
                shapes::uv_sphere(Vec3::new(1.2, 1.0, 0.0), 1.0, 48, 24),
                0,
                vec![],
            ),
        ],
    )
}

fn triangle_soup(n: usize, seed: u64) -> Scene {
    let mut rng = StdRng::seed_from_u64(seed);
    let mut m = TriMesh::default();
    for i in 0..n as u32 {
        let centre = Vec3::new(
            rng.random_range(-2.0..2.0),
            rng.random_range(-2.0..2.0),
            rng.random_range(-2.0..2.0),
        );
        let size = 0.02 + 0.8 * rng.random::<f32>().powi(3);
        for _ in 0..3 {
            m.positions.push(centre + size * random_unit(&mut rng));
        }
        m.indices.push([3 * i, 3 * i + 1, 3 * i + 2]);
    }
    scene_of(
        vec![material("grey", Vec3::splat(0.5))],
        vec![mesh("soup", m, 0, vec![])],
    )
}

/// A lumpy sphere: a UV sphere with 2·256·195 = 99,840 triangles whose
/// radius varies smoothly, plus the ground.
fn lumpy_sphere() -> Scene {
    let mut m = shapes::uv_sphere(Vec3::ZERO, 1.0, 256, 196);
    for p in &mut m.positions {
        let r = 1.0 + 0.15 * (5.0 * p.x).sin() * (4.0 * p.y).cos() + 0.05 * (17.0 * p.z).sin();
        *p = *p * r + Vec3::new(0.0, 1.3, 0.0);
    }
    scene_of(
        vec![material("grey", Vec3::splat(0.5))],
        vec![
            mesh("lumpy", m, 0, vec![]),
            mesh("ground", ground(), 0, vec![]),
        ],
    )
}

/// Static ground and box, a box turning and sliding through three
/// keyframes at uneven times, and a sphere moving between two keyframes
/// inside the shutter [0, 1] (so rays before 0.3 see it clamped).
fn moving_scene() -> Scene {
    let spin = vec![
        Keyframe {
            time: 0.0,
            translation: Vec3::new(-1.5, 1.0, 0.0),
            rotation: Quat::IDENTITY,
        },
        Keyframe {
            time: 0.15,
            translation: Vec3::new(-0.5, 1.4, 0.3),
            rotation: Quat::from_rotation_y(1.2) * Quat::from_rotation_x(0.4),
        },
        Keyframe {
            time: 1.0,
            translation: Vec3::new(1.5, 0.8, -0.2),
            rotation: Quat::from_rotation_z(2.5) * Quat::from_rotation_y(-0.7),
        },
    ];
    let slide = vec![
        Keyframe {
            time: 0.3,
            translation: Vec3::new(0.0, 0.6, 2.0),
            rotation: Quat::from_rotation_x(0.3),
        },
        Keyframe {
            time: 0.9,
            translation: Vec3::new(0.5, 2.0, 1.0),
            rotation: Quat::from_rotation_x(-2.9),
        },
    ];
    scene_of(
        vec![
            material("white", Vec3::splat(0.7)),
            material("blue", Vec3::new(0.1, 0.1, 0.7)),
        ],
        vec![
            mesh("ground", ground(), 0, vec![]),
            mesh(
                "box",
                shapes::cuboid(Vec3::new(2.0, 0.0, 2.0), Vec3::new(3.0, 1.0, 3.0)),
                0,
                vec![],
            ),
            mesh(
                "spinner",
                shapes::cuboid(Vec3::new(-0.6, -0.3, -0.4), Vec3::new(0.6, 0.3, 0.4)),
                1,
                spin,
            ),
            mesh(
                "slider",
                shapes::uv_sphere(Vec3::new(0.2, 0.0, 0.0), 0.5, 24, 12),
                1,
                slide,
            ),
        ],
    )
}

// ------------------------------------------------------------------ rays

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

/// World bounds of the scene over the shutter (sampled times).
fn scene_bounds(built: &BuiltScene) -> (Vec3, Vec3) {
    let (mut lo, mut hi) = (Vec3::splat(f32::MAX), Vec3::splat(f32::MIN));
    for prim in 0..built.triangle_count() {
        for time in [0.0, 0.15, 0.5, 1.0] {
            for v in built.triangle_world(prim, time) {
                lo = lo.min(v);
                hi = hi.max(v);
            }
        }
    }
    (lo, hi)
}

struct RayGen<'a> {
    built: &'a BuiltScene,
    rng: StdRng,
    lo: Vec3,
    hi: Vec3,
    moving: bool,
}

impl<'a> RayGen<'a> {
    fn new(built: &'a BuiltScene, seed: u64) -> Self {
        let (lo, hi) = scene_bounds(built);
        let moving = built.instances.iter().any(|i| i.key_count > 0);
        RayGen {
            built,
            rng: StdRng::seed_from_u64(seed),
            lo,
            hi,
            moving,
        }
    }

    /// Scene time: mostly inside the shutter [0, 1], 10 % outside (clamped
    /// motion), for moving scenes.
    fn time(&mut self) -> f32 {
        if !self.moving {
            return 0.0;
        }
        if self.rng.random::<f32>() < 0.1 {
            self.rng.random_range(-0.5..1.5)
        } else {
            self.rng.random::<f32>()
        }
    }

    fn point_in_bounds(&mut self, grow: f32) -> Vec3 {
        let size = self.hi - self.lo;
        let u = Vec3::new(self.rng.random(), self.rng.random(), self.rng.random());
        self.lo - grow * size + u * size * (1.0 + 2.0 * grow)
    }

    fn t_max(&mut self) -> f32 {
        if self.rng.random::<f32>() < 0.3 {
            self.rng.random_range(0.0..(self.hi - self.lo).length())
        } else {
            f32::INFINITY
        }
    }

    /// A point on a random triangle at `time` and that triangle.
    fn surface_point(&mut self, time: f32) -> (Vec3, u32) {
        let prim = self.rng.random_range(0..self.built.triangle_count());
        let [a, b, c] = self.built.triangle_world(prim, time);
        let (mut u, mut v) = (self.rng.random::<f32>(), self.rng.random::<f32>());
        if u + v > 1.0 {
            (u, v) = (1.0 - u, 1.0 - v);
        }
        (a + u * (b - a) + v * (c - a), prim)
    }

    fn ray(origin: Vec3, dir: Vec3, t_max: f32, time: f32) -> Ray {
        Ray {
            origin: origin.into(),
            t_max,
            dir: dir.into(),
            time,
        }
    }

    /// Random origins around the scene, uniformly random directions.
    fn random(&mut self, n: usize) -> Vec<Ray> {
        (0..n)
            .map(|_| {
                let (o, d, t, time) = (
                    self.point_in_bounds(0.2),
                    random_unit(&mut self.rng),
                    self.t_max(),
                    self.time(),
                );
                Self::ray(o, d, t, time)
            })
            .collect()
    }

    /// Rays from random origins aimed at random surface points; half of
    /// the directions are left unnormalized.
    fn aimed(&mut self, n: usize) -> Vec<Ray> {
        (0..n)
            .map(|i| {
                let time = self.time();
                let o = self.point_in_bounds(0.3);
                let (target, _) = self.surface_point(time);
                let d = if i % 2 == 0 {
                    (target - o).normalize()
                } else {
                    target - o
                };
                let t_max = self.t_max();
                Self::ray(o, d, t_max, time)
            })
            .collect()
    }

    /// Axis-aligned directions, every combination of +0.0 / −0.0 in the
    /// other two components.
    fn axis_aligned(&mut self, n: usize) -> Vec<Ray> {
        (0..n)
            .map(|i| {
                let axis = i % 3;
                let sign = if (i / 3) % 2 == 0 { 1.0 } else { -1.0 };
                let zeros = (i / 6) % 4;
                let mut d = Vec3::new(
                    if zeros & 1 == 0 { 0.0 } else { -0.0 },
                    if zeros & 2 == 0 { 0.0 } else { -0.0 },
                    if zeros & 1 == 0 { -0.0 } else { 0.0 },
                );
                d[axis] = sign;
                let (o, t_max, time) = (self.point_in_bounds(0.2), self.t_max(), self.time());
                Self::ray(o, d, t_max, time)
            })
            .collect()
    }

    /// Rays starting exactly on a triangle (the point computed in f32),
    /// random directions.
    fn on_surface(&mut self, n: usize) -> Vec<Ray> {
        (0..n)
            .map(|_| {
                let time = self.time();
                let (o, _) = self.surface_point(time);
                let (d, t_max) = (random_unit(&mut self.rng), self.t_max());
                Self::ray(o, d, t_max, time)
            })
            .collect()
    }

    /// Rays starting inside the box [lo, hi].
    fn inside_box(&mut self, n: usize, lo: Vec3, hi: Vec3) -> Vec<Ray> {
        (0..n)
            .map(|_| {
                let u = Vec3::new(self.rng.random(), self.rng.random(), self.rng.random());
                let o = lo + u * (hi - lo);
                let (d, t_max, time) = (random_unit(&mut self.rng), self.t_max(), self.time());
                Self::ray(o, d, t_max, time)
            })
            .collect()
    }
}

// ------------------------------------------------------------ comparison

#[derive(Debug, Default)]
struct Report {
    rays: usize,
    hits: usize,
    any_hits: usize,
    ties: usize,
    any_ties: usize,
    max_steps: u32,
    mean_steps: f64,
}

fn t_close(a: f32, b: f32) -> bool {
    a == b || (a - b).abs() <= T_TOL * a.abs().max(b.abs()).max(1.0)
}

fn on_boundary(bary: [f32; 2]) -> bool {
    let b0 = 1.0 - bary[0] - bary[1];
    b0.min(bary[0]).min(bary[1]) <= BARY_TOL
}

/// Brute force on all cores.
fn brute_force(built: &BuiltScene, rays: &[Ray]) -> Vec<(HitRecord, bool)> {
    let threads = std::thread::available_parallelism().map_or(2, |n| n.get());
    let chunk = rays.len().div_ceil(threads).max(1);
    std::thread::scope(|s| {
        let handles: Vec<_> = rays
            .chunks(chunk)
            .map(|c| {
                // Any hit from the closest: both are the one loop over every
                // triangle accepting t_min < t < the current bound (t_max
                // first), so a triangle is accepted by the any-hit loop iff
                // the closest one exists (`brute_force_any_is_the_closest_hit`
                // checks it on rays of every kind).
                s.spawn(move || {
                    c.iter()
                        .map(|r| {
                            let closest = built.brute_force_closest(r);
                            (closest, closest.is_hit())
                        })
                        .collect::<Vec<_>>()
                })
            })
            .collect();
        handles
            .into_iter()
            .flat_map(|h| h.join().expect("brute-force thread"))
            .collect()
    })
}

/// The hit distance of `prim` computed the GPU's way for a moving
/// instance: the ray moved into object space. The CPU oracle moves the
/// triangle to the world instead; the two agree to rounding except at
/// grazing incidence, where a position difference δ moves the hit by
/// δ/|cos θ| along the ray (e.g. cos θ = 7e-4 turns 1e-6 into 1.5e-3).
/// Either answer is the exact result of the same rigid motion up to f32
/// rounding, so either is accepted.
fn object_space_t(built: &BuiltScene, ray: &Ray, prim: u32) -> Option<f32> {
    let inst = built.triangle_instance(prim);
    if built.instances[inst as usize].key_count == 0 {
        return None;
    }
    let x = built.instance_transform_at(inst, ray.time);
    let (o, d) = (Vec3::from(ray.origin), Vec3::from(ray.dir));
    ShearedRay::new(x.inverse_point(o), x.inverse_vector(d))
        .intersect(built.triangle_stored(prim), ray_t_min(o, d), f32::INFINITY)
        .map(|(t, _)| t)
}

/// Whether the GPU and CPU closest hits are both right up to rounding
/// (see the module docs). Where both hit but one of them at t_min within
/// T_TOL (a ray leaving a surface, whose own or a neighbouring triangle
/// sits at the self-intersection threshold: which side of it a hit lands
/// on is rounding, and moving instances round in object space), the
/// other side's farther hit is as right.
fn is_tie(ray: &Ray, gpu: &HitRecord, cpu: &HitRecord) -> bool {
    let t_min = ray_t_min(ray.origin.into(), ray.dir.into());
    let marginal_t = |t: f32| t_close(t, ray.t_max) || t_close(t, t_min);
    match (gpu.is_hit(), cpu.is_hit()) {
        (true, true) => t_close(gpu.t, cpu.t) || t_close(gpu.t.min(cpu.t), t_min),
        (true, false) => on_boundary(gpu.bary) || marginal_t(gpu.t),
        (false, true) => on_boundary(cpu.bary) || marginal_t(cpu.t),
        (false, false) => unreachable!(),
    }
}

/// Traces `rays` on the GPU and checks them against brute force; panics on
/// any disagreement that is not a tie.
fn compare(scene: &Scene, rays: &[Ray]) -> Report {
    let built = BuiltScene::new(scene).expect("BVH build");
    compare_built(scene, &built, rays)
}

fn compare_built(scene: &Scene, built: &BuiltScene, rays: &[Ray]) -> Report {
    let gpu = gpu();
    let gpu_scene = GpuScene::upload(gpu, scene, built, scene.film).expect("scene upload");
    let kernel = TraceKernel::new(gpu, &gpu_scene).expect("trace kernel");
    let gpu_hits = kernel.run(gpu, &gpu_scene, rays).expect("GPU trace");
    let cpu_hits = brute_force(built, rays);
    assert_eq!(gpu_hits.len(), rays.len());

    let mut report = Report {
        rays: rays.len(),
        ..Default::default()
    };
    let mut failures = Vec::new();
    let mut steps = 0u64;
    for (i, ((ray, g), (c, c_any))) in rays.iter().zip(&gpu_hits).zip(&cpu_hits).enumerate() {
        report.hits += c.is_hit() as usize;
        report.any_hits += *c_any as usize;
        report.max_steps = report.max_steps.max(g.steps_closest).max(g.steps_any);
        steps += g.steps_closest as u64;

        let exact = g.prim == c.prim
            && (!c.is_hit()
                || t_close(g.t, c.t)
                || object_space_t(built, ray, g.prim).is_some_and(|t| t_close(g.t, t)));
        let tie = !exact && is_tie(ray, g, c);
        if !exact {
            if tie {
                report.ties += 1;
            } else {
                failures.push(format!(
                    "ray {i} {ray:?}: GPU prim {} t {} bary {:?}, CPU prim {} t {} bary {:?}",
                    g.prim as i64, g.t, g.bary, c.prim as i64, c.t, c.bary
                ));
            }
        }
        if (g.any_hit == 1) != *c_any {
            // Any hit may differ only where the closest hit is itself a tie
            // or the CPU's nearest hit sits at t_max within tolerance.
            let unbounded = built.brute_force_closest(&Ray {
                t_max: f32::INFINITY,
                ..*ray
            });
            if tie
                || (unbounded.is_hit() && t_close(unbounded.t, ray.t_max))
                || (exact && on_boundary(c.bary))
            {
                report.any_ties += 1;
            } else {
                failures.push(format!(
                    "ray {i} {ray:?}: GPU any-hit {} but CPU {}",
                    g.any_hit, c_any
                ));
            }
        }
    }
    report.mean_steps = steps as f64 / rays.len().max(1) as f64;
    assert!(
        failures.is_empty(),
        "{} of {} rays disagree with brute force, e.g.:\n{}",
        failures.len(),
        rays.len(),
        failures
            .iter()
            .take(10)
            .cloned()
            .collect::<Vec<_>>()
            .join("\n")
    );
    assert!(
        report.max_steps < BVH_MAX_STEPS,
        "a ray used {} traversal steps, at the budget {BVH_MAX_STEPS}",
        report.max_steps
    );
    eprintln!("{report:?}");
    report
}

/// Ties must stay rare: at most 0.2 % of the rays (they need a ray to
/// meet an edge or a t bound to within rounding).
fn assert_few_ties(report: &Report) {
    let allowed = report.rays / 500;
    assert!(
        report.ties <= allowed,
        "{} closest-hit ties in {} rays",
        report.ties,
        report.rays
    );
    assert!(
        report.any_ties <= allowed,
        "{} any-hit ties in {} rays",
        report.any_ties,
        report.rays
    );
}

/// Hits and misses both well represented, so the comparison means something.
fn assert_mixed(report: &Report) {
    assert!(report.hits > report.rays / 5, "too few hits: {report:?}");
    assert!(
        report.hits < report.rays * 19 / 20,
        "too few misses: {report:?}"
    );
}

// ----------------------------------------------------------------- tests

#[test]
fn struct_sizes_match_wgsl() {
    use mdas::accel::*;
    use std::mem::size_of;
    assert_eq!(size_of::<SceneUniforms>(), 128);
    assert_eq!(size_of::<GpuMaterial>(), 80);
    assert_eq!(size_of::<GpuEmitter>(), 16);
    assert_eq!(size_of::<GpuLight>(), 48);
    assert_eq!(size_of::<GpuInstance>(), 16);
    assert_eq!(size_of::<GpuKeyframe>(), 32);
    assert_eq!(size_of::<Ray>(), 32);
    assert_eq!(size_of::<HitRecord>(), 32);
}

/// Issue 18 item 4: a pile of coincident triangles (one face written many
/// times) is refused before the BVH build. 80,000 copies once took 96 s to
/// fail with a stack-depth error; the check is linear, so this run takes
/// milliseconds (no timing is asserted: a slow run shows in the suite's
/// wall time, not as a flaky failure). The static meshes share one BLAS,
/// so copies spread over two meshes are one pile too; 16 copies pass.
#[test]
fn coincident_triangles_are_refused_before_the_build() {
    let face = shapes::triangle([Vec3::ZERO, Vec3::X, Vec3::Y]);
    let copies = |n: usize| TriMesh::new(face.positions.clone(), vec![[0, 1, 2]; n]);
    let white = || vec![material("white", Vec3::splat(0.7))];
    let scene = scene_of(white(), vec![mesh("pile", copies(80_000), 0, vec![])]);
    let e = format!("{:#}", BuiltScene::new(&scene).unwrap_err());
    assert!(
        e.contains("80000 triangles share") && e.contains("'pile'"),
        "{e}"
    );
    let split = scene_of(
        white(),
        vec![
            mesh("a", copies(9), 0, vec![]),
            mesh("b", copies(8), 0, vec![]),
        ],
    );
    let e = format!("{:#}", BuiltScene::new(&split).unwrap_err());
    assert!(e.contains("17 triangles share"), "{e}");
    let ok = scene_of(white(), vec![mesh("ok", copies(16), 0, vec![])]);
    assert!(BuiltScene::new(&ok).is_ok());
}

#[test]
fn box_sphere_quad_matches_brute_force() {
    let scene = box_sphere_quad();
    let built = BuiltScene::new(&scene).unwrap();
    let mut gen = RayGen::new(&built, 1);
    let mut rays = gen.random(3000);
    rays.extend(gen.aimed(3000));
    rays.extend(gen.axis_aligned(2400));
    rays.extend(gen.on_surface(1600));
    rays.extend(gen.inside_box(1000, BOX_MIN, BOX_MAX));
    let report = compare_built(&scene, &built, &rays);
    assert_few_ties(&report);
    assert_mixed(&report);
}

/// The CPU oracle's any-hit query is its closest-hit query's `is_hit`
/// (one loop, the same acceptance), which `brute_force` relies on to run
/// the loop once per ray: checked on every kind of ray, on static and
/// moving scenes, with finite and infinite `t_max`.
#[test]
fn brute_force_any_is_the_closest_hit() {
    for (scene, seed) in [(box_sphere_quad(), 11), (moving_scene(), 12)] {
        let built = BuiltScene::new(&scene).unwrap();
        let mut gen = RayGen::new(&built, seed);
        let mut rays = gen.random(500);
        rays.extend(gen.aimed(500));
        rays.extend(gen.axis_aligned(300));
        rays.extend(gen.on_surface(300));
        rays.extend(gen.inside_box(200, BOX_MIN, BOX_MAX));
        let (mut hits, mut misses) = (0, 0);
        for r in &rays {
            let any = built.brute_force_any(r);
            assert_eq!(any, built.brute_force_closest(r).is_hit(), "{r:?}");
            if any {
                hits += 1;
            } else {
                misses += 1;
            }
        }
        assert!(hits > 100 && misses > 100, "{hits} hits, {misses} misses");
    }
}

/// Watertightness on the GPU: rays from inside the closed box aimed at
/// points on its triangles' edges and at its vertices must all hit it
/// (which of the triangles sharing the edge is reported is a tie).
#[test]
fn rays_through_shared_edges_never_slip_through() {
    let scene = box_sphere_quad();
    let built = BuiltScene::new(&scene).unwrap();
    let box_prims: Vec<u32> = (0..built.triangle_count())
        .filter(|&p| built.source[p as usize][0] == 1)
        .collect();
    let mut rng = StdRng::seed_from_u64(9);
    let rays: Vec<Ray> = (0..10_000)
        .map(|i| {
            let u = Vec3::new(rng.random(), rng.random(), rng.random());
            let o = BOX_MIN + (0.05 + 0.9 * u) * (BOX_MAX - BOX_MIN);
            let v = built.triangle_world(box_prims[rng.random_range(0..box_prims.len())], 0.0);
            let k = rng.random_range(0..3);
            let target = if i % 4 == 0 {
                v[k]
            } else {
                v[k] + rng.random::<f32>() * (v[(k + 1) % 3] - v[k])
            };
            Ray {
                origin: o.into(),
                t_max: f32::INFINITY,
                dir: (target - o).into(),
                time: 0.0,
            }
        })
        .collect();
    let gpu = gpu();
    let gpu_scene = GpuScene::upload(gpu, &scene, &built, scene.film).unwrap();
    let hits = TraceKernel::new(gpu, &gpu_scene)
        .unwrap()
        .run(gpu, &gpu_scene, &rays)
        .unwrap();
    for (ray, h) in rays.iter().zip(&hits) {
        assert!(
            h.is_hit() && h.any_hit == 1,
            "{ray:?} slipped through the box: {h:?}"
        );
        // The target is at t = 1; the box's bottom face coincides with the
        // ground, so the hit may be a ground triangle at that same t.
        assert!(h.t <= 1.0 + 1e-4, "{ray:?} left the box: {h:?}");
    }
    let report = compare_built(&scene, &built, &rays);
    assert_eq!(report.hits, rays.len());
    // Every ray meets an edge or vertex, so ties are expected here; they
    // were each checked to be at equal t by compare_built.
    eprintln!("edge rays: {} ties of {}", report.ties, report.rays);
}

#[test]
fn triangle_soup_matches_brute_force() {
    let scene = triangle_soup(3000, 2);
    let built = BuiltScene::new(&scene).unwrap();
    let mut gen = RayGen::new(&built, 2);
    let mut rays = gen.random(4000);
    rays.extend(gen.aimed(3000));
    rays.extend(gen.axis_aligned(1500));
    rays.extend(gen.on_surface(1500));
    let report = compare_built(&scene, &built, &rays);
    assert_few_ties(&report);
    assert_mixed(&report);
}

#[test]
fn hundred_thousand_triangle_mesh_matches_brute_force() {
    let scene = lumpy_sphere();
    assert!(scene.triangle_count() >= 99_000);
    let built = BuiltScene::new(&scene).unwrap();
    let mut gen = RayGen::new(&built, 3);
    let mut rays = gen.random(3000);
    rays.extend(gen.aimed(3500));
    rays.extend(gen.axis_aligned(1500));
    rays.extend(gen.on_surface(2000));
    let report = compare_built(&scene, &built, &rays);
    assert_few_ties(&report);
    assert_mixed(&report);
}

#[test]
fn moving_instances_match_brute_force_at_each_ray_time() {
    let scene = moving_scene();
    let built = BuiltScene::new(&scene).unwrap();
    assert_eq!(built.instances.len(), 3, "static BLAS + two moving BLASes");
    let mut gen = RayGen::new(&built, 4);
    let mut rays = gen.random(3000);
    rays.extend(gen.aimed(4000));
    rays.extend(gen.axis_aligned(1500));
    rays.extend(gen.on_surface(1500));
    // Rays at exactly the keyframe times.
    for (i, r) in rays.iter_mut().enumerate().step_by(25) {
        r.time = [0.0, 0.15, 0.3, 0.9, 1.0][i % 5];
    }
    let report = compare_built(&scene, &built, &rays);
    assert_few_ties(&report);
    assert_mixed(&report);
}

#[test]
fn empty_scene_misses_everything() {
    let mut scene = scene_of(vec![material("grey", Vec3::splat(0.5))], vec![]);
    let mut gen_rng = StdRng::seed_from_u64(5);
    let rays: Vec<Ray> = (0..10_000)
        .map(|_| Ray {
            origin: (random_unit(&mut gen_rng) * 3.0).into(),
            t_max: f32::INFINITY,
            dir: random_unit(&mut gen_rng).into(),
            time: 0.0,
        })
        .collect();
    for with_empty_mesh in [false, true] {
        if with_empty_mesh {
            scene
                .meshes
                .push(mesh("nothing", TriMesh::default(), 0, vec![]));
        }
        let built = BuiltScene::new(&scene).unwrap();
        assert_eq!(built.triangle_count(), 0);
        let gpu = gpu();
        let gpu_scene = GpuScene::upload(gpu, &scene, &built, scene.film).unwrap();
        let hits = TraceKernel::new(gpu, &gpu_scene)
            .unwrap()
            .run(gpu, &gpu_scene, &rays)
            .unwrap();
        assert!(hits
            .iter()
            .all(|h| h.prim == MISS && h.any_hit == 0 && h.t == f32::INFINITY));
    }
}

#[test]
fn single_triangle_scene() {
    let tri = shapes::triangle([
        Vec3::new(-1.0, -1.0, 0.0),
        Vec3::new(1.0, -1.0, 0.0),
        Vec3::new(0.0, 1.0, 0.0),
    ]);
    let scene = scene_of(
        vec![material("grey", Vec3::splat(0.5))],
        vec![mesh("tri", tri, 0, vec![])],
    );
    let mut rng = StdRng::seed_from_u64(6);
    let rays: Vec<Ray> = (0..10_000)
        .map(|_| {
            let o = Vec3::new(
                rng.random_range(-2.0..2.0),
                rng.random_range(-2.0..2.0),
                -3.0,
            );
            let target = Vec3::new(
                rng.random_range(-1.5..1.5),
                rng.random_range(-1.5..1.5),
                0.0,
            );
            Ray {
                origin: o.into(),
                t_max: f32::INFINITY,
                dir: (target - o).into(),
                time: 0.0,
            }
        })
        .collect();
    let report = compare(&scene, &rays);
    assert_few_ties(&report);
    assert_mixed(&report);
}

#[test]
fn watertight_test_hits_a_shared_edge_from_both_sides() {
    // Two triangles sharing the edge x = 0; a ray through the edge hits both.
    let (a, b, c, d) = (
        Vec3::new(0.0, -1.0, 0.0),
        Vec3::new(0.0, 1.0, 0.0),
        Vec3::new(-1.0, 0.0, 0.0),
        Vec3::new(1.0, 0.0, 0.0),
    );
    let ray = ShearedRay::new(Vec3::new(0.0, 0.25, -1.0), Vec3::new(0.0, 0.0, 1.0));
    assert!(ray.intersect([a, b, c], 0.0, f32::INFINITY).is_some());
    assert!(ray.intersect([b, a, d], 0.0, f32::INFINITY).is_some());
    // Hits at t <= t_min are rejected.
    let on_surface = ShearedRay::new(Vec3::new(0.1, 0.1, 0.0), Vec3::new(0.3, 0.2, 1.0));
    assert!(on_surface
        .intersect([a, b, d], 1e-5, f32::INFINITY)
        .is_none());
}

/// Runs the test kernel `entry` of `source` (which includes the scene's
/// WGSL) with one workgroup per query: `queries` at @group(0) @binding(0),
/// an output of `words` f32 at binding 1, the scene at @group(1); returns
/// the output.
fn run_scene_kernel<Q: bytemuck::Pod>(
    gpu_scene: &GpuScene,
    source: &mdas::gpu::shader::Wgsl,
    entry: &str,
    queries: &[Q],
    words: usize,
) -> Vec<f32> {
    let gpu = gpu();
    gpu.scoped(entry, || {
        use mdas::gpu::buffer::STORAGE;
        use mdas::gpu::shader::{bind_buffers, storage_entry};
        let layout = gpu.bind_group_layout(
            "test.scene_kernel",
            &[storage_entry(0, true), storage_entry(1, false)],
        );
        let pipeline = gpu.compute_pipeline(entry, source, entry, &[&layout, &gpu_scene.layout])?;
        let q = gpu.buffer_from("test.queries", queries, STORAGE)?;
        let o = gpu.buffer_zeroed("test.out", 4 * words as u64, STORAGE)?;
        let bind = bind_buffers(gpu, "test.scene_kernel", &layout, &[&q, &o]);
        let mut enc = gpu.device.create_command_encoder(&Default::default());
        {
            let mut pass = enc.begin_compute_pass(&Default::default());
            pass.set_pipeline(&pipeline);
            pass.set_bind_group(0, &bind, &[]);
            pass.set_bind_group(1, &gpu_scene.bind_group, &[]);
            pass.dispatch_workgroups(queries.len() as u32, 1, 1);
        }
        gpu.queue.submit([enc.finish()]);
        gpu.read_buffer::<f32>(&o, words)
    })
    .unwrap()
}

/// The scene bindings as WGSL reads them equal what the host wrote:
/// uniforms, materials, emitters, lights, and `triangle_world` /
/// `triangle_material` agree with the CPU.
#[test]
fn scene_bindings_read_back_in_wgsl() {
    let mut scene = moving_scene();
    scene.materials.push(Material {
        name: "lamp".into(),
        albedo: Vec3::new(0.1, 0.2, 0.3),
        emission: Vec3::new(4.0, 3.0, 2.0),
        checker: Some(Checker {
            albedo2: Vec3::new(0.9, 0.8, 0.7),
            scale: 0.25,
        }),
        one_sided: true,
        uv_checker: None,
    });
    let lamp = scene.materials.len() as u32 - 1;
    scene.meshes.push(mesh(
        "lamp",
        shapes::quad([
            Vec3::new(-0.5, 3.0, -0.5),
            Vec3::new(0.5, 3.0, -0.5),
            Vec3::new(0.5, 3.0, 0.5),
            Vec3::new(-0.5, 3.0, 0.5),
        ]),
        lamp,
        vec![],
    ));
    scene.lights = vec![
        Light::Point {
            position: Vec3::new(1.0, 2.0, 3.0),
            intensity: Vec3::new(5.0, 6.0, 7.0),
        },
        Light::Directional {
            direction: Vec3::new(0.0, -2.0, 0.0),
            irradiance: Vec3::new(0.5, 0.25, 0.125),
        },
    ];
    scene.camera.aperture_radius = 0.05;
    scene.camera.shutter_open = 0.1;
    scene.camera.shutter_close = 0.7;
    let film = Film {
        width: 40,
        height: 30,
    };
    let built = BuiltScene::new(&scene).unwrap();
    let gpu = gpu();
    let gpu_scene = GpuScene::upload(gpu, &scene, &built, film).unwrap();
    let emitters = mdas::accel::emitter_table(&scene, &built);
    assert_eq!(emitters.len(), 2);
    assert_eq!(emitters.last().unwrap().cdf, 1.0);
    assert!((emitters.iter().map(|e| e.pmf).sum::<f32>() - 1.0).abs() < 1e-6);
    for e in &emitters {
        assert_eq!(built.triangle_material(e.prim), lamp);
    }
    // `source` maps global triangles back to the scene's meshes.
    for prim in 0..built.triangle_count() {
        let [m, t] = built.source[prim as usize];
        let mesh = &scene.meshes[m as usize];
        let stored = built.triangle_stored(prim);
        let indices = mesh.indices[t as usize];
        assert_eq!(stored, indices.map(|i| mesh.positions[i as usize]));
    }

    let mut rng = StdRng::seed_from_u64(8);
    let queries: Vec<[u32; 2]> = (0..256)
        .map(|_| {
            [
                rng.random_range(0..built.triangle_count()),
                rng.random_range(-0.3f32..1.3).to_bits(),
            ]
        })
        .collect();
    let source = GpuScene::wgsl().part((
        "tests/kernels/scene_dump.wgsl",
        include_str!("kernels/scene_dump.wgsl"),
    ));
    let out = run_scene_kernel(
        &gpu_scene,
        &source,
        "dump",
        &queries,
        64 + 10 * queries.len(),
    );

    let expected_uniforms: &[f32] = bytemuck::cast_slice(bytemuck::bytes_of(&gpu_scene.uniforms));
    assert_eq!(&out[..28], &expected_uniforms[..28]);
    let u = &gpu_scene.uniforms;
    assert_eq!(u.cam_aspect, 40.0 / 30.0);
    assert_eq!(u.shutter, [0.1, 0.7]);
    assert_eq!(u.emitter_count, 2);
    assert_eq!(u.light_count, 2);
    assert_eq!(u.triangle_count, built.triangle_count());
    assert_eq!(
        &out[28..38],
        &[0.1, 0.2, 0.3, 0.25, 4.0, 3.0, 2.0, 0.9, 0.8, 0.7]
    );
    assert_eq!(out[38].to_bits(), emitters[1].prim);
    assert_eq!(
        &out[39..42],
        &[emitters[1].cdf, emitters[1].pmf, emitters[1].area]
    );
    assert_eq!(out[42].to_bits(), 0);
    assert_eq!(&out[43..49], &[1.0, 2.0, 3.0, 5.0, 6.0, 7.0]);
    assert_eq!(out[49].to_bits(), 1);
    assert_eq!(&out[50..56], &[0.0, -1.0, 0.0, 0.5, 0.25, 0.125]);
    assert_eq!(out[56].to_bits(), 1, "the lamp's one_sided flag");
    for (i, q) in queries.iter().enumerate() {
        let got = &out[64 + 10 * i..64 + 10 * i + 10];
        let want = built.triangle_world(q[0], f32::from_bits(q[1]));
        for k in 0..3 {
            let g = Vec3::new(got[3 * k], got[3 * k + 1], got[3 * k + 2]);
            assert!(
                g.distance(want[k]) < 1e-5 * want[k].length().max(1.0),
                "triangle_world({}, {}) vertex {k}: GPU {g} CPU {}",
                q[0],
                f32::from_bits(q[1]),
                want[k]
            );
        }
        assert_eq!(got[9].to_bits(), built.triangle_material(q[0]));
    }
}

/// Issue 19: shading normals (an OBJ's `vn`) survive the BVH's reordering
/// and read back on the GPU. `moving_scene` gets normals on the static box
/// (a random unit normal per vertex), on the moving sphere (radial, so they
/// must turn with its keyframes) and all-zero ones on a static quad; the
/// ground stays flat. Each triangle's record holds its own corners'
/// normals (none for flat or all-zero meshes), and for random triangles,
/// barycentrics (inside and outside the triangle) and times the GPU's
/// `triangle_shading_normal` equals the CPU twin
/// `BuiltScene::shading_normal`, which falls back to the geometric normal.
#[test]
fn shading_normals_read_back_in_wgsl() {
    let mut scene = moving_scene();
    let mut rng = StdRng::seed_from_u64(19);
    let box_mesh = &mut scene.meshes[1];
    box_mesh.normals = (0..box_mesh.positions.len())
        .map(|_| random_unit(&mut rng))
        .collect();
    let sphere = &mut scene.meshes[3];
    sphere.normals = sphere
        .positions
        .iter()
        .map(|p| (*p - Vec3::new(0.2, 0.0, 0.0)).normalize())
        .collect();
    let mut zero = mesh(
        "zero normals",
        shapes::quad([
            Vec3::new(-0.5, 3.0, -0.5),
            Vec3::new(0.5, 3.0, -0.5),
            Vec3::new(0.5, 3.0, 0.5),
            Vec3::new(-0.5, 3.0, 0.5),
        ]),
        0,
        vec![],
    );
    zero.normals = vec![Vec3::ZERO; 4];
    scene.meshes.push(zero);
    let built = BuiltScene::new(&scene).unwrap();
    let mut with_normals = 0;
    for prim in 0..built.triangle_count() {
        let [m, t] = built.source[prim as usize];
        let mesh = &scene.meshes[m as usize];
        let got = built.triangle_normals(prim);
        if m == 1 || m == 3 {
            let want = mesh.indices[t as usize].map(|i| mesh.normals[i as usize].normalize());
            assert_eq!(got, Some(want), "mesh {m} triangle {t}");
            with_normals += 1;
        } else {
            assert_eq!(got, None, "mesh {m} triangle {t}");
        }
    }
    assert_eq!(
        with_normals,
        built.normals.len() / mdas::accel::build::RECORD_ROWS
    );

    #[repr(C)]
    #[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
    struct Query {
        prim: u32,
        time: f32,
        bary: [f32; 2],
    }
    let queries: Vec<Query> = (0..512)
        .map(|_| Query {
            prim: rng.random_range(0..built.triangle_count()),
            time: rng.random_range(-0.3f32..1.3),
            bary: [
                rng.random_range(-0.2f32..1.0),
                rng.random_range(-0.2f32..1.0),
            ],
        })
        .collect();
    let gpu = gpu();
    let gpu_scene = GpuScene::upload(gpu, &scene, &built, scene.film).unwrap();
    let source = GpuScene::wgsl().part((
        "tests/kernels/shading_normal.wgsl",
        include_str!("kernels/shading_normal.wgsl"),
    ));
    let out = run_scene_kernel(
        &gpu_scene,
        &source,
        "shading_normal",
        &queries,
        3 * queries.len(),
    );
    let mut smooth = 0;
    for (i, q) in queries.iter().enumerate() {
        let got = Vec3::new(out[3 * i], out[3 * i + 1], out[3 * i + 2]);
        let want = built.shading_normal(q.prim, q.bary, q.time);
        // Unit vectors from the same f32 arithmetic up to FMA contraction
        // and the slerp's rounding: a few ulps.
        assert!(
            got.distance(want) < 1e-5,
            "triangle {} at {:?}, time {}: GPU {got} CPU {want}",
            q.prim,
            q.bary,
            q.time
        );
        let [a, b, c] = built.triangle_world(q.prim, q.time);
        if want.dot((b - a).cross(c - a).normalize()) < 1.0 - 1e-4 {
            smooth += 1;
        }
    }
    // The queries exercised the interpolation, not only the fallback.
    assert!(smooth > 100, "{smooth} of {} queries smooth", queries.len());
}

/// Swept instance bounds contain the moving object at every time.
#[test]
fn swept_bounds_contain_the_motion() {
    let scene = moving_scene();
    let built = BuiltScene::new(&scene).unwrap();
    for inst in 0..built.instances.len() as u32 {
        let keys = built.instance_keys(inst);
        let prims: Vec<u32> = (0..built.triangle_count())
            .filter(|&p| built.triangle_instance(p) == inst)
            .collect();
        let mut local = obvhs::aabb::Aabb::empty();
        for &p in &prims {
            for v in built.triangle_stored(p) {
                local.extend(v.into());
            }
        }
        let bounds = mdas::scene::motion::swept_bounds(&keys, &local);
        for step in 0..=400 {
            let time = -0.2 + 1.4 * step as f32 / 400.0;
            for &p in &prims {
                for v in built.triangle_world(p, time) {
                    assert!(
                        bounds.contains_point(v.into()),
                        "instance {inst} at {time}: {v} outside {bounds:?}"
                    );
                }
            }
        }
    }
}

// ------------------------------------------------------ voxel visibility
//
// The second shadow-ray backend (src/accel/voxel.rs): the GPU build equals
// the CPU oracle bit for bit, the GPU query agrees with the CPU query, and
// the approximation behaves as the paper's rules say it must — never
// occluded in empty space, always behind a wall, exact along on-grid axes
// away from border voxels — with its error against exact visibility
// measured on a test scene.

use mdas::accel::voxel::{self, Visibility, VoxelLayout, VoxelParams};
use mdas::accel::TraceMode;

fn voxel_upload(scene: &Scene, params: VoxelParams) -> (BuiltScene, GpuScene) {
    let built = BuiltScene::new(scene).expect("BVH build");
    let gpu_scene =
        GpuScene::upload_with(gpu(), scene, &built, scene.film, Visibility::Voxel(params))
            .expect("voxel upload");
    (built, gpu_scene)
}

fn voxel_answers(gpu_scene: &GpuScene, rays: &[Ray]) -> Vec<bool> {
    let gpu = gpu();
    TraceKernel::new(gpu, gpu_scene)
        .unwrap()
        .run_mode(gpu, gpu_scene, rays, TraceMode::Voxel)
        .unwrap()
        .iter()
        .map(|h| h.any_hit != 0)
        .collect()
}

fn params(directions: u32, resolution: u32) -> VoxelParams {
    VoxelParams {
        directions,
        resolution,
        skip: 1,
    }
}

#[test]
fn voxel_build_equals_the_cpu_oracle_bit_for_bit() {
    let cases = [
        ("box_sphere_quad", box_sphere_quad(), params(6, 32)),
        ("box_sphere_quad", box_sphere_quad(), params(5, 64)),
        ("moving", moving_scene(), params(7, 32)),
        ("soup", triangle_soup(400, 9), params(4, 64)),
    ];
    for (name, scene, p) in cases {
        let (built, gpu_scene) = voxel_upload(&scene, p);
        let layout = gpu_scene.voxel_layout.as_ref().unwrap();
        let gpu_bits = gpu_scene.read_voxel_bits(gpu()).unwrap();
        let cpu_bits = voxel::build_cpu(&built, layout);
        assert_eq!(gpu_bits.len(), cpu_bits.len());
        let differ = gpu_bits
            .iter()
            .zip(&cpu_bits)
            .filter(|(a, b)| a != b)
            .count();
        let set: u32 = cpu_bits.iter().map(|w| w.count_ones()).sum();
        assert_eq!(
            differ,
            0,
            "{name} {}: {differ} of {} words differ (first at {:?})",
            p.describe(),
            cpu_bits.len(),
            gpu_bits.iter().zip(&cpu_bits).position(|(a, b)| a != b)
        );
        assert!(set > 1000, "{name}: only {set} voxels set");
    }
}

/// Random segments (finite and infinite, at random scene times) answered
/// by the GPU and by the CPU oracle. They may disagree only where the
/// GPU's acos/atan2 (accurate to a few ulps, not correctly rounded) put a
/// direction on the other side of a rounding boundary between two
/// voxelizations, or FMA contraction moves a coordinate across a voxel
/// boundary: both need a value within ~1e-6 of a boundary, about 1e-5 of
/// all queries here (2e-5 rad of ~0.3 rad per step times a few checks);
/// allowed: 0.1 %.
#[test]
fn voxel_queries_match_the_cpu_oracle() {
    let scene = moving_scene();
    let p = params(8, 32);
    let (built, gpu_scene) = voxel_upload(&scene, p);
    let layout = gpu_scene.voxel_layout.clone().unwrap();
    let bits = gpu_scene.read_voxel_bits(gpu()).unwrap();
    let (lo, hi) = scene_bounds(&built);
    let mut rng = StdRng::seed_from_u64(21);
    let point = |rng: &mut StdRng| {
        Vec3::new(
            rng.random_range(lo.x..hi.x),
            rng.random_range(lo.y..hi.y),
            rng.random_range(lo.z..hi.z),
        )
    };
    let rays: Vec<Ray> = (0..20_000)
        .map(|i| {
            let a = point(&mut rng);
            let b = point(&mut rng);
            let infinite = i % 4 == 0;
            Ray {
                origin: a.into(),
                t_max: if infinite { 3.0e38 } else { 1.0 },
                dir: if infinite { (b - a).normalize() } else { b - a }.into(),
                time: rng.random_range(0.0..1.0),
            }
        })
        .collect();
    let gpu_answers = voxel_answers(&gpu_scene, &rays);
    let mut differ = 0;
    let mut occluded = 0;
    for (r, &g) in rays.iter().zip(&gpu_answers) {
        let c = voxel::occluded(
            &built,
            &layout,
            &bits,
            &voxel::Segment {
                origin: r.origin.into(),
                dir: r.dir.into(),
                t_max: r.t_max,
                time: r.time,
                n_origin: Vec3::ZERO,
                n_end: Vec3::ZERO,
            },
        );
        differ += usize::from(c != g);
        occluded += usize::from(c);
    }
    assert!(
        differ <= rays.len() / 1000,
        "{differ} of {} queries differ",
        rays.len()
    );
    assert!(
        occluded > rays.len() / 10 && occluded < rays.len() * 9 / 10,
        "{occluded} of {} occluded: the test needs both answers",
        rays.len()
    );
}

/// A wall 8 × 8 at z = 0 (and, in the second scene, nothing at all):
/// segments from z ≤ −1 to z ≥ 1 through the wall's middle are always
/// occluded; segments that stay at z ≤ −1.5 never are, nor is anything in
/// an empty scene. 12 directions (15° steps, rows within 10.6° of the
/// segment) at 32³ (voxels 0.35 wide): a row strays at most
/// 2.9·sin 10.6° + 0.25 < 0.8 from its segment over these lengths.
#[test]
fn empty_space_is_never_occluded_and_a_wall_always_is() {
    let wall = shapes::quad([
        Vec3::new(-4.0, -4.0, 0.0),
        Vec3::new(4.0, -4.0, 0.0),
        Vec3::new(4.0, 4.0, 0.0),
        Vec3::new(-4.0, 4.0, 0.0),
    ]);
    let walled = scene_of(
        vec![material("grey", Vec3::splat(0.5))],
        vec![mesh("wall", wall, 0, vec![])],
    );
    let empty = scene_of(vec![material("grey", Vec3::splat(0.5))], vec![]);
    let mut rng = StdRng::seed_from_u64(4);
    let mut at = |z: std::ops::Range<f32>| {
        Vec3::new(
            rng.random_range(-2.0..2.0),
            rng.random_range(-2.0..2.0),
            rng.random_range(z),
        )
    };
    let segment = |a: Vec3, b: Vec3| Ray {
        origin: a.into(),
        t_max: 1.0,
        dir: (b - a).into(),
        time: 0.0,
    };
    let through: Vec<Ray> = (0..5000)
        .map(|_| segment(at(-3.0..-1.0), at(1.0..3.0)))
        .collect();
    let beside: Vec<Ray> = (0..5000)
        .map(|_| segment(at(-3.0..-1.5), at(-3.0..-1.5)))
        .collect();
    let (_, gpu_scene) = voxel_upload(&walled, params(12, 32));
    let answers = voxel_answers(&gpu_scene, &through);
    assert!(
        answers.iter().all(|&o| o),
        "a segment through the wall passed"
    );
    let answers = voxel_answers(&gpu_scene, &beside);
    assert!(
        !answers.iter().any(|&o| o),
        "a segment beside the wall was occluded"
    );
    let (_, gpu_scene) = voxel_upload(&empty, params(12, 32));
    let all: Vec<Ray> = through.iter().chain(&beside).copied().collect();
    assert!(!voxel_answers(&gpu_scene, &all).iter().any(|&o| o));
}

/// Along the array's on-grid axes (±x: θ = 90°, φ = 0; ±y: θ = φ = 90°;
/// ±z: θ = 0, all on the grid for an even n), a row is a box of voxels
/// around the segment, so against walls perpendicular to the axes the
/// answer is exact — unless the segment passes within 1.5 voxels of a
/// wall's edge (a border voxel, partly covered), runs within 1.5 voxels of
/// a wall parallel to it, or ends within 2 + skip + ½ voxels of a wall it
/// faces (the self-occlusion rule). Those are left out; every other
/// answer must equal the exact (brute-force) one.
#[test]
fn on_grid_axes_are_exact_away_from_border_voxels() {
    // Walls perpendicular to z, x and y at off-grid positions.
    let wall = |axis: usize, at: f32, lo: [f32; 2], hi: [f32; 2]| {
        let corner = |a: f32, b: f32| {
            let mut p = [0.0; 3];
            p[axis] = at;
            p[(axis + 1) % 3] = a;
            p[(axis + 2) % 3] = b;
            Vec3::from(p)
        };
        (
            shapes::quad([
                corner(lo[0], lo[1]),
                corner(hi[0], lo[1]),
                corner(hi[0], hi[1]),
                corner(lo[0], hi[1]),
            ]),
            (axis, at, lo, hi),
        )
    };
    let walls = [
        wall(2, 0.37, [-2.1, -1.3], [1.7, 2.2]),
        wall(2, -1.61, [-0.9, -2.4], [2.3, 0.6]),
        wall(0, 1.13, [-2.2, -1.9], [1.4, 2.6]),
        wall(1, -0.71, [-1.7, -2.3], [2.5, 1.1]),
    ];
    let scene = scene_of(
        vec![material("grey", Vec3::splat(0.5))],
        walls
            .iter()
            .enumerate()
            .map(|(i, (m, _))| mesh(&format!("wall{i}"), m.clone(), 0, vec![]))
            .collect(),
    );
    let p = params(8, 64);
    let (built, gpu_scene) = voxel_upload(&scene, p);
    // Voxels are boxes; direction 0's grid is axis-aligned (a = x, b = y,
    // u = z), its scales the voxels per unit along each axis (in the other
    // on-grid directions too): take the widest voxel as h.
    let layout = gpu_scene.voxel_layout.as_ref().unwrap();
    let f = layout.frame(&layout.objects[0], 0);
    let h = [f.a[0], f.b[1], f.u[2]]
        .iter()
        .map(|s| 1.0 / s.abs())
        .fold(0.0f32, f32::max);
    let mut rng = StdRng::seed_from_u64(8);
    let mut rays = Vec::new();
    while rays.len() < 8000 {
        let axis = rng.random_range(0..3usize);
        let sign = if rng.random::<bool>() { 1.0 } else { -1.0 };
        let o = Vec3::new(
            rng.random_range(-3.0..3.0),
            rng.random_range(-3.0..3.0),
            rng.random_range(-3.0..3.0),
        );
        let length = rng.random_range(0.5..5.0);
        let mut d = Vec3::ZERO;
        d[axis] = sign;
        let end = o + d * length;
        let clear = walls.iter().all(|(_, (w, at, lo, hi))| {
            let (a, b) = ((w + 1) % 3, (w + 2) % 3);
            if *w == axis {
                // Facing the wall: endpoints far enough from its plane, and
                // the segment's line far from the wall's edges.
                let ends = (o[*w] - at).abs().min((end[*w] - at).abs()) > (3.5 + 0.5) * h;
                let edges = [(a, 0), (b, 1)].iter().all(|&(c, k)| {
                    (o[c] - lo[k]).abs() > 1.5 * h && (o[c] - hi[k]).abs() > 1.5 * h
                });
                ends && edges
            } else {
                // Parallel to the wall: far from its plane.
                (o[*w] - at).abs() > 1.5 * h
            }
        });
        if clear {
            rays.push(Ray {
                origin: o.into(),
                t_max: length,
                dir: d.into(),
                time: 0.0,
            });
        }
    }
    let answers = voxel_answers(&gpu_scene, &rays);
    let mut hidden = 0;
    for (r, &v) in rays.iter().zip(&answers) {
        let exact = built.brute_force_any(r);
        assert_eq!(v, exact, "ray {r:?}: voxel {v}, exact {exact}");
        hidden += usize::from(exact);
    }
    assert!(
        hidden > 500 && hidden < rays.len() - 500,
        "{hidden} of {} hidden: the test needs both answers",
        rays.len()
    );
}

/// The size of an array is checked before any work: the paper's 2°, 128³
/// configuration (2,025 MiB for one object) is refused under a 128 MiB
/// binding limit (lavapipe's) with its size and the largest that fit —
/// 90×90 at 32³ (31.6 MiB; 64³ would need 253 MiB) or 22×22 at 128³
/// (121 MiB; 23×23 would need 132 MiB).
#[test]
fn an_array_too_large_is_refused_with_its_size_and_what_fits() {
    let scene = box_sphere_quad();
    let built = BuiltScene::new(&scene).unwrap();
    let layout = VoxelLayout::new(&built, VoxelParams::PAPER).unwrap();
    assert_eq!(layout.bytes(), 90 * 90 * 128 * 128 * 128 / 8);
    let err = layout.check_fits(128 << 20).unwrap_err().to_string();
    for part in [
        "needs 2025.0 MiB",
        "allows 128.0 MiB",
        "90×90 directions (2°) at 32³",
        "22×22 directions (8.182°) at 128³",
    ] {
        assert!(err.contains(part), "{err:?} lacks {part:?}");
    }
    assert!(layout.check_fits(4 << 30).is_ok());
    let bad = VoxelParams {
        resolution: 48,
        ..VoxelParams::default()
    };
    assert!(VoxelLayout::new(&built, bad).is_err());
}

fn voxel_answers_with_normals(
    gpu_scene: &GpuScene,
    rays: &[Ray],
    normals: &[[f32; 4]],
) -> Vec<bool> {
    let gpu = gpu();
    TraceKernel::new(gpu, gpu_scene)
        .unwrap()
        .run_with_normals(gpu, gpu_scene, rays, Some(normals), TraceMode::Voxel)
        .unwrap()
        .iter()
        .map(|h| h.any_hit != 0)
        .collect()
}

/// The self-occlusion rule: a segment leaving a floor never counts the
/// floor's own voxels when the query has the floor's normal. Shading
/// points on a 16 × 16 floor (a box of height 2 in a far corner gives the
/// grid its height), point lights 1.5–5 away at elevations 12°–80°, and
/// segments from the floor to a parallel ceiling quad (both normals):
/// nothing lies between, so every answer must be "visible". With the
/// 6° steps of the default array a row is within 4.3° of its segment and
/// the midpoint ≥ 0.15 above the floor (≥ 5 voxel heights), so the rule
/// alone decides; without normals (skip only) the same floor does shadow
/// itself at grazing angles, which the test also shows.
#[test]
fn a_surface_never_shadows_itself_given_its_normal() {
    let floor = shapes::quad([
        Vec3::new(-8.0, 0.0, -8.0),
        Vec3::new(-8.0, 0.0, 8.0),
        Vec3::new(8.0, 0.0, 8.0),
        Vec3::new(8.0, 0.0, -8.0),
    ]);
    let ceiling = shapes::quad([
        Vec3::new(-8.0, 1.7, -8.0),
        Vec3::new(8.0, 1.7, -8.0),
        Vec3::new(8.0, 1.7, 8.0),
        Vec3::new(-8.0, 1.7, 8.0),
    ]);
    let scene = scene_of(
        vec![material("grey", Vec3::splat(0.5))],
        vec![
            mesh("floor", floor, 0, vec![]),
            mesh("ceiling", ceiling, 0, vec![]),
            mesh(
                "box",
                shapes::cuboid(Vec3::new(6.0, 0.0, 6.0), Vec3::new(7.0, 2.0, 7.0)),
                0,
                vec![],
            ),
        ],
    );
    let (built, gpu_scene) = voxel_upload(&scene, VoxelParams::default());
    let mut rng = StdRng::seed_from_u64(12);
    let (mut rays, mut normals) = (Vec::new(), Vec::new());
    let up = [0.0, 1.0, 0.0, 0.0];
    let down = [0.0, -1.0, 0.0, 0.0];
    while rays.len() < 20_000 {
        let p = Vec3::new(
            rng.random_range(-7.0..4.0),
            1e-4,
            rng.random_range(-7.0..4.0),
        );
        let to_ceiling = rays.len() % 2 == 1;
        let (q, n_end) = if to_ceiling {
            let q = Vec3::new(
                rng.random_range(-7.0..4.0),
                1.7,
                rng.random_range(-7.0..4.0),
            );
            (q, down)
        } else {
            let azimuth = rng.random_range(0.0..std::f32::consts::TAU);
            let elevation = rng.random_range(12.0f32..80.0).to_radians();
            let d = rng.random_range(1.5..5.0);
            let dir = Vec3::new(
                elevation.cos() * azimuth.cos(),
                elevation.sin(),
                elevation.cos() * azimuth.sin(),
            );
            (p + d * dir, [0.0; 4])
        };
        // Clear of the box, and point lights well under the ceiling (a
        // light within a voxel of a surface is hidden by it).
        if q.x > 5.0 || q.z > 5.0 || q.x < -7.5 || q.z < -7.5 || (!to_ceiling && q.y > 1.0) {
            continue;
        }
        if to_ceiling && (q - p).normalize().y < 12f32.to_radians().sin() {
            continue;
        }
        rays.push(Ray {
            origin: p.into(),
            t_max: 1.0 - 1e-4,
            dir: (q - p).into(),
            time: 0.0,
        });
        normals.push(up);
        normals.push(n_end);
    }
    assert!(
        rays.iter().all(|r| !built.brute_force_any(r)),
        "the scene must leave every segment visible"
    );
    let with = voxel_answers_with_normals(&gpu_scene, &rays, &normals);
    let hidden = with.iter().filter(|&&o| o).count();
    assert_eq!(
        hidden,
        0,
        "{hidden} of {} segments shadowed by their own surfaces",
        rays.len()
    );
    let without = voxel_answers(&gpu_scene, &rays);
    let hidden = without.iter().filter(|&&o| o).count();
    assert!(
        hidden > 0,
        "without normals the floor should shadow itself somewhere"
    );
}

/// ε_v and ε_s (Wang et al. §6.1) of the default array against exact
/// visibility on `box_sphere_quad` with its moving-instance twin: shading
/// points on the surfaces seen from the camera, point lights in the free
/// space above, the integrands' rays and normals. The measured figures
/// (fixed seeds, so deterministic up to the GPU's rounding) are ε_v 3.0 %,
/// ε_s −2.9 % on the static scene and 1.6 %, −1.6 % on the moving one (the
/// paper: ε_v 1.2–5.7 % at 2° and 128³; ours is 6° and 64³): almost all
/// false shadows, the conservative voxels being fatter than the
/// geometry. The bounds, about twice those, catch a regression of the
/// build or the query that still passes the exact-case tests above.
#[test]
fn voxel_error_against_exact_visibility_is_bounded() {
    for (name, scene, bound_v) in [
        ("box_sphere_quad", box_sphere_quad(), 0.06),
        ("moving", moving_scene(), 0.035),
    ] {
        let (built, gpu_scene) = voxel_upload(&scene, VoxelParams::default());
        let gpu = gpu();
        let kernel = TraceKernel::new(gpu, &gpu_scene).unwrap();
        let mut rng = StdRng::seed_from_u64(30);
        // Shading points: closest hits of rays from the camera.
        let cam = Vec3::new(0.0, 2.5, -6.0);
        let primary: Vec<Ray> = (0..400)
            .map(|_| {
                let target = Vec3::new(
                    rng.random_range(-3.0..3.0),
                    rng.random_range(0.0..2.0),
                    rng.random_range(-1.5..1.5),
                );
                Ray {
                    origin: cam.into(),
                    t_max: f32::INFINITY,
                    dir: (target - cam).normalize().into(),
                    time: 0.3,
                }
            })
            .collect();
        let hits = kernel.run(gpu, &gpu_scene, &primary).unwrap();
        let lights: Vec<Vec3> = (0..64)
            .map(|_| {
                Vec3::new(
                    rng.random_range(-4.0..4.0),
                    rng.random_range(2.6..4.0),
                    rng.random_range(-3.0..3.0),
                )
            })
            .collect();
        let (mut rays, mut normals) = (Vec::new(), Vec::new());
        for (r, h) in primary.iter().zip(&hits) {
            if !h.is_hit() {
                continue;
            }
            let d = Vec3::from(r.dir);
            let x = Vec3::from(r.origin) + h.t * d;
            let [a, b, c] = built.triangle_world(h.prim, r.time);
            let mut n = (b - a).cross(c - a).normalize();
            if n.dot(d) > 0.0 {
                n = -n;
            }
            let o = x + n * 1e-4 * x.abs().max_element().max(1.0);
            for &l in &lights {
                if n.dot(l - o) <= 0.0 {
                    continue;
                }
                rays.push(Ray {
                    origin: o.into(),
                    t_max: 1.0 - 1e-4,
                    dir: (l - o).into(),
                    time: r.time,
                });
                normals.push(n.extend(0.0).to_array());
                normals.push([0.0; 4]);
            }
        }
        let exact: Vec<bool> = kernel
            .run_mode(gpu, &gpu_scene, &rays, TraceMode::Any)
            .unwrap()
            .iter()
            .map(|h| h.any_hit != 0)
            .collect();
        let voxel = voxel_answers_with_normals(&gpu_scene, &rays, &normals);
        let false_visible = exact.iter().zip(&voxel).filter(|(&e, &v)| e && !v).count();
        let false_hidden = exact.iter().zip(&voxel).filter(|(&e, &v)| !e && v).count();
        let hidden = exact.iter().filter(|&&e| e).count();
        let n = rays.len() as f64;
        let eps_v = (false_visible + false_hidden) as f64 / n;
        let eps_s = (false_visible as f64 - false_hidden as f64) / n;
        eprintln!(
            "{name}: {} rays, {:.1} % hidden, ε_v {:.2} %, ε_s {:+.2} %",
            rays.len(),
            100.0 * hidden as f64 / n,
            100.0 * eps_v,
            100.0 * eps_s
        );
        assert!(hidden as f64 > 0.05 * n, "{name}: the test needs shadows");
        assert!(eps_v <= bound_v, "{name}: ε_v {eps_v}");
        assert!(eps_s.abs() <= bound_v, "{name}: ε_s {eps_s}");
    }
}
