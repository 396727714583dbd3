//! Ray tracing throughput of the CWBVH traversal (`wgsl/shared/bvh.wgsl`)
//! and the obvhs build time.
//!
//! Scenes: the Cornell box (`scenes/cornell.toml`, or the same geometry built
//! in code when the file is missing or fails to load) and a procedural lumpy
//! sphere of 1,001,472 triangles over a ground quad. Rays: primary rays
//! through every pixel centre of a 640×480 pinhole camera
//! (docs/conventions.md "Primary ray"), traced for the closest hit; shadow
//! rays from each primary hit point to a point on the light, traced with the
//! any-hit query (t_max just short of the light). Each iteration is one
//! dispatch plus a device wait, so the figures include submission overhead;
//! throughput is reported in rays/s (criterion "elements"). The 1M-triangle
//! BVH build (all obvhs PLOC builds, `BuiltScene::new`) is timed on its own.
//!
//! Run: `cargo bench --bench trace`. Sample size 10 and short measurement
//! windows keep the whole run to a couple of minutes on lavapipe.

use std::path::Path;
use std::time::Duration;

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use glam::{Affine3A, Vec3};
use mdas::accel::trace::pinhole_rays;
use mdas::accel::{BuiltScene, GpuScene, HitRecord, Ray, TraceKernel, TraceMode};
use mdas::film::Film;
use mdas::gpu::buffer::STORAGE;
use mdas::gpu::Gpu;
use mdas::scene::shapes::{self, TriMesh};
use mdas::scene::{Camera, Material, Mesh, Scene};

const FILM: Film = Film {
    width: 640,
    height: 480,
};

fn material(name: &str, albedo: Vec3, emission: Vec3) -> Material {
    Material {
        name: name.into(),
        albedo,
        emission,
        checker: None,
        one_sided: false,
        uv_checker: None,
    }
}

fn mesh(name: &str, m: TriMesh, material: u32) -> Mesh {
    Mesh {
        name: name.into(),
        positions: m.positions,
        indices: m.indices,
        normals: m.normals,
        uvs: Vec::new(),
        material,
        motion: Vec::new(),
    }
}

fn scene_of(camera: Camera, materials: Vec<Material>, meshes: Vec<Mesh>) -> Scene {
    Scene {
        film: FILM,
        camera,
        background: Vec3::ZERO,
        materials,
        meshes,
        lights: Vec::new(),
        point_light_sets: Vec::new(),
    }
}

fn pinhole(position: Vec3, look_at: Vec3, fov_y: f32) -> Camera {
    Camera {
        position,
        look_at,
        up: Vec3::Y,
        fov_y,
        aperture_radius: 0.0,
        focus_distance: 1.0,
        shutter_open: 0.0,
        shutter_close: 1.0,
    }
}

/// `scenes/cornell.toml`, or the same room built here.
fn cornell() -> Scene {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell.toml");
    match mdas::scene_file::load(&path) {
        Ok(file) => return file.scene,
        Err(e) => eprintln!(
            "trace bench: {} did not load ({e}); using the built-in Cornell box",
            path.display()
        ),
    }
    let s = 5.55;
    let q = |c: [[f32; 3]; 4]| shapes::quad(c.map(Vec3::from));
    let block = |height: f32, angle: f32, at: Vec3| {
        let mut m = shapes::cuboid(
            Vec3::new(-0.825, 0.0, -0.825),
            Vec3::new(0.825, height, 0.825),
        );
        m.transform(&Affine3A::from_rotation_translation(
            glam::Quat::from_rotation_y(angle.to_radians()),
            at,
        ));
        m
    };
    scene_of(
        pinhole(
            Vec3::new(2.78, 2.73, -8.0),
            Vec3::new(2.78, 2.73, 0.0),
            39.3,
        ),
        vec![
            material("white", Vec3::splat(0.73), Vec3::ZERO),
            material("red", Vec3::new(0.65, 0.05, 0.05), Vec3::ZERO),
            material("green", Vec3::new(0.12, 0.45, 0.15), Vec3::ZERO),
            material("light", Vec3::ZERO, Vec3::new(17.0, 12.0, 4.0)),
        ],
        vec![
            mesh(
                "floor",
                q([[0.0, 0.0, 0.0], [0.0, 0.0, s], [s, 0.0, s], [s, 0.0, 0.0]]),
                0,
            ),
            mesh(
                "ceiling",
                q([[0.0, s, 0.0], [s, s, 0.0], [s, s, s], [0.0, s, s]]),
                0,
            ),
            mesh(
                "back_wall",
                q([[0.0, 0.0, s], [0.0, s, s], [s, s, s], [s, 0.0, s]]),
                0,
            ),
            mesh(
                "red_wall",
                q([[s, 0.0, 0.0], [s, 0.0, s], [s, s, s], [s, s, 0.0]]),
                1,
            ),
            mesh(
                "green_wall",
                q([[0.0, 0.0, 0.0], [0.0, s, 0.0], [0.0, s, s], [0.0, 0.0, s]]),
                2,
            ),
            mesh(
                "short_block",
                block(1.65, -17.0, Vec3::new(1.855, 0.0, 1.69)),
                0,
            ),
            mesh(
                "tall_block",
                block(3.3, 17.0, Vec3::new(3.685, 0.0, 3.5125)),
                0,
            ),
            mesh(
                "light",
                q([
                    [2.13, 5.54, 2.27],
                    [3.43, 5.54, 2.27],
                    [3.43, 5.54, 3.32],
                    [2.13, 5.54, 3.32],
                ]),
                3,
            ),
        ],
    )
}

/// A UV sphere with 2·1024·489 = 1,001,472 triangles and a smoothly
/// varying radius, over a ground quad.
fn lumpy_million() -> Scene {
    let mut m = shapes::uv_sphere(Vec3::ZERO, 1.0, 1024, 490);
    for p in &mut m.positions {
        let r = 1.0
            + 0.15 * (5.0 * p.x).sin() * (4.0 * p.y).cos()
            + 0.03 * (37.0 * p.z).sin() * (23.0 * p.x).cos();
        *p = *p * r + Vec3::new(0.0, 1.3, 0.0);
    }
    let ground = shapes::quad([
        Vec3::new(-5.0, 0.0, -5.0),
        Vec3::new(-5.0, 0.0, 5.0),
        Vec3::new(5.0, 0.0, 5.0),
        Vec3::new(5.0, 0.0, -5.0),
    ]);
    scene_of(
        pinhole(Vec3::new(0.0, 2.0, -4.5), Vec3::new(0.0, 1.2, 0.0), 45.0),
        vec![material("grey", Vec3::splat(0.5), Vec3::ZERO)],
        vec![mesh("lumpy", m, 0), mesh("ground", ground, 0)],
    )
}

/// Shadow rays from each primary hit to a point on the light (jittered
/// over `light_size` with a fixed pattern), stopping just short of it.
fn shadow_rays(primary: &[Ray], hits: &[HitRecord], light: Vec3, light_size: Vec3) -> Vec<Ray> {
    primary
        .iter()
        .zip(hits)
        .enumerate()
        .filter(|(_, (_, h))| h.is_hit())
        .map(|(k, (ray, h))| {
            let p = Vec3::from(ray.origin) + h.t * Vec3::from(ray.dir);
            let jitter = Vec3::new((k % 7) as f32 / 6.0, 0.5, (k % 5) as f32 / 4.0) - 0.5;
            let target = light + jitter * light_size;
            Ray {
                origin: p.into(),
                t_max: 1.0 - 1e-3,
                dir: (target - p).into(),
                time: 0.0,
            }
        })
        .collect()
}

struct Bench {
    gpu: &'static Gpu,
    scene: GpuScene,
    kernel: TraceKernel,
}

impl Bench {
    fn new(scene: &Scene) -> Bench {
        let gpu = Gpu::shared().expect("the trace bench needs a GPU adapter (lavapipe is enough)");
        let scene = GpuScene::new(gpu, scene, FILM).expect("scene upload");
        let kernel = TraceKernel::new(gpu, &scene).expect("trace kernel");
        Bench { gpu, scene, kernel }
    }

    /// Benchmarks one query over `rays`, with the rays already on the GPU.
    fn run(&self, c: &mut Criterion, group: &str, name: &str, rays: &[Ray], mode: TraceMode) {
        let gpu = self.gpu;
        let ray_buffer = gpu.buffer_from("bench.rays", rays, STORAGE).expect("rays");
        let hit_buffer = gpu
            .buffer_zeroed(
                "bench.hits",
                (rays.len() * std::mem::size_of::<HitRecord>()) as u64,
                STORAGE,
            )
            .expect("hits");
        let mut g = c.benchmark_group(group);
        g.throughput(Throughput::Elements(rays.len() as u64));
        g.bench_function(BenchmarkId::new(name, rays.len()), |b| {
            b.iter(|| {
                self.kernel
                    .dispatch(
                        gpu,
                        &self.scene,
                        &ray_buffer,
                        &hit_buffer,
                        rays.len() as u32,
                        mode,
                    )
                    .expect("dispatch");
                gpu.wait().expect("wait");
            })
        });
        g.finish();
    }
}

fn trace_scene(c: &mut Criterion, group: &str, scene: &Scene, light: Vec3, light_size: Vec3) {
    let bench = Bench::new(scene);
    let s = bench.scene.stats;
    eprintln!(
        "{group}: {} triangles, {} instances, {} nodes, stack depth {}, build {:.1} ms, {:.1} MiB on '{}'",
        s.triangles,
        s.instances,
        s.nodes,
        s.stack_depth,
        s.build_ms,
        s.gpu_bytes as f64 / 1048576.0,
        bench.gpu.info.name
    );
    let primary = pinhole_rays(&scene.camera, FILM);
    let hits = bench
        .kernel
        .run(bench.gpu, &bench.scene, &primary)
        .expect("primary trace");
    let shadow = shadow_rays(&primary, &hits, light, light_size);
    bench.run(c, group, "primary_closest", &primary, TraceMode::Closest);
    bench.run(c, group, "shadow_any", &shadow, TraceMode::Any);
}

fn cornell_box(c: &mut Criterion) {
    let scene = cornell();
    trace_scene(
        c,
        "trace/cornell",
        &scene,
        Vec3::new(2.78, 5.53, 2.795),
        Vec3::new(1.3, 0.0, 1.05),
    );
}

fn million_triangles(c: &mut Criterion) {
    let scene = lumpy_million();
    assert!(scene.triangle_count() >= 1_000_000);
    trace_scene(
        c,
        "trace/lumpy_1m",
        &scene,
        Vec3::new(3.0, 6.0, -3.0),
        Vec3::splat(0.5),
    );

    let mut g = c.benchmark_group("build/lumpy_1m");
    g.throughput(Throughput::Elements(scene.triangle_count() as u64));
    g.bench_function("obvhs_cwbvh", |b| {
        b.iter(|| BuiltScene::new(&scene).expect("build"))
    });
    g.finish();
}

criterion_group! {
    name = benches;
    config = Criterion::default()
        .sample_size(10)
        .warm_up_time(Duration::from_secs(1))
        .measurement_time(Duration::from_secs(4));
    targets = cornell_box, million_triangles
}
criterion_main!(benches);
