//! The radix substitute tree built on the GPU
//! (`lights::substitute::gpu_build`) against its CPU oracle
//! (`lights::substitute::radix::build`), bit for bit: leaf order, nodes
//! (bounds, intensity, id), parents, each light's leaf, depth, cones and
//! substitutes. Runs on the process's adapter (lavapipe without a GPU); a
//! missing adapter fails the test.

mod common;

use bytemuck::Pod;
use glam::Vec3;
use mdas::gpu::buffer::STORAGE;
use mdas::gpu::Gpu;
use mdas::lights::substitute::gpu_build::GpuRadixTree;
use mdas::lights::substitute::radix::{self, RadixTree};
use mdas::lights::LightPrim;
use rand::rngs::StdRng;
use rand::{RngExt, SeedableRng};

/// Lights that exercise every path: VPLs with random and with shared
/// normals (nested and disjoint cones, equal keys), VPLs at shared
/// positions (duplicate keys, zero spread), points and triangles (no
/// normal: their own class, sphere cones), small and large triangles, dark
/// lights (a child with intensity 0 drops out of a merge), and positions
/// on a coarse grid or anywhere in a box.
fn lights(seed: u64, n: usize) -> Vec<LightPrim> {
    let mut rng = StdRng::seed_from_u64(seed);
    let shared = [
        Vec3::X,
        -Vec3::Y,
        Vec3::new(0.6, 0.8, 0.0),
        Vec3::new(0.3, -0.2, 0.9).normalize(),
    ];
    let grid = seed.is_multiple_of(2);
    let mut positions: Vec<Vec3> = Vec::new();
    (0..n)
        .map(|i| {
            let p = if !positions.is_empty() && rng.random_range(0..5) == 0 {
                positions[rng.random_range(0..positions.len())]
            } else if grid {
                Vec3::new(
                    rng.random_range(0..5) as f32 * 0.25,
                    rng.random_range(0..3) as f32,
                    rng.random_range(0..4) as f32 * 1.5,
                )
            } else {
                Vec3::new(
                    rng.random_range(-3.0..3.0),
                    rng.random_range(0.0..2.0),
                    rng.random_range(-1.0..5.0),
                )
            };
            positions.push(p);
            let dark = rng.random_range(0..10) == 0;
            let e = if dark {
                Vec3::ZERO
            } else {
                Vec3::new(
                    rng.random_range(0.1..4.0),
                    rng.random_range(0.1..4.0),
                    rng.random_range(0.1..4.0),
                )
            };
            match (i as u64 + seed) % 7 {
                0 => LightPrim::point(p, e),
                1 => {
                    let s = rng.random_range(0.001..0.5);
                    let d = |rng: &mut StdRng| {
                        Vec3::new(
                            rng.random_range(-s..s),
                            rng.random_range(-s..s),
                            rng.random_range(-s..s),
                        )
                    };
                    let (a, b) = (d(&mut rng), d(&mut rng));
                    LightPrim::triangle(p, p + a, p + b, e)
                }
                2 | 3 => LightPrim::vpl(p, shared[rng.random_range(0..shared.len())], e),
                _ => {
                    let v = Vec3::new(
                        rng.random_range(-1.0..1.0),
                        rng.random_range(-1.0..1.0),
                        rng.random_range(-1.0..1.0),
                    );
                    LightPrim::vpl(p, v.normalize_or(Vec3::Z), e)
                }
            }
        })
        .collect()
}

fn words<T: Pod>(x: &T) -> &[u32] {
    bytemuck::cast_slice(std::slice::from_ref(x))
}

/// The first element of `what` whose bits differ, with both values.
fn same_bits<T: Pod + std::fmt::Debug>(what: &str, n: usize, gpu: &[T], cpu: &[T]) {
    assert_eq!(gpu.len(), cpu.len(), "n = {n}: {what} count");
    if let Some(i) = (0..cpu.len()).find(|&i| words(&gpu[i]) != words(&cpu[i])) {
        panic!(
            "n = {n}: {what} {i} differs ({} of {} differ)\n  GPU {:?}\n  CPU {:?}",
            (0..cpu.len())
                .filter(|&i| words(&gpu[i]) != words(&cpu[i]))
                .count(),
            cpu.len(),
            gpu[i],
            cpu[i]
        );
    }
}

fn check(gpu: &Gpu, tree: &mut GpuRadixTree, prims: &[LightPrim]) {
    let n = prims.len();
    let buffer = gpu.buffer_from("test.lights", prims, STORAGE).unwrap();
    tree.build_timed(gpu, &buffer, n as u32).unwrap();
    let g: RadixTree = tree.read_back(gpu).unwrap().expect("a tree");
    let c = radix::build(prims).expect("a tree");
    assert_eq!(g.sorted, c.sorted, "n = {n}: leaf order");
    assert_eq!(g.bvh.parent, c.bvh.parent, "n = {n}: parents");
    assert_eq!(g.bvh.leaf_of_light, c.bvh.leaf_of_light, "n = {n}: leaves");
    assert_eq!(g.bvh.depth, c.bvh.depth, "n = {n}: depth");
    same_bits("node", n, &g.bvh.nodes, &c.bvh.nodes);
    same_bits("cone", n, &g.bvh.cones, &c.bvh.cones);
    same_bits("substitute", n, &g.substitutes, &c.substitutes);
}

/// Sizes 1, 2, 3, powers of two and their neighbours, and a few
/// thousand lights; two seeds each (grid and box positions). One tree of
/// the largest capacity serves every size, so a build must not depend on
/// what an earlier, larger build left in its buffers.
#[test]
fn gpu_radix_tree_equals_the_cpu_tree_bit_for_bit() {
    let gpu = common::gpu();
    let sizes = [
        4097usize, 1, 2, 3, 4, 5, 7, 8, 9, 31, 64, 100, 257, 1000, 3001,
    ];
    let mut tree = GpuRadixTree::new(gpu, sizes[0] as u32).unwrap();
    for &n in &sizes {
        for seed in [n as u64 * 2, n as u64 * 2 + 1] {
            check(gpu, &mut tree, &lights(seed, n));
        }
    }
}

/// Every light at one position with one normal: all keys equal, so the
/// tree is split by leaf index alone (Karras's tie-break), and every
/// substitute has zero spread.
#[test]
fn gpu_radix_tree_of_equal_keys() {
    let gpu = common::gpu();
    let p = Vec3::new(0.5, 1.0, -2.0);
    let prims: Vec<LightPrim> = (0..300)
        .map(|i| LightPrim::vpl(p, Vec3::Y, Vec3::splat(1.0 + (i % 3) as f32)))
        .collect();
    let mut tree = GpuRadixTree::new(gpu, prims.len() as u32).unwrap();
    check(gpu, &mut tree, &prims);
}

/// `div_rn` and `sqrt_rn` (`wgsl/lights/exact.wgsl`) against Rust's f32
/// `/` and `sqrt` (IEEE, round to nearest even), bit for bit: random bit
/// patterns over the normal range (quotients and roots normal), exact
/// quotients and squares (the sticky bit zero), halfway-looking
/// significands, and the special values that take the native path.
#[test]
fn exact_division_and_square_root_round_as_rust_does() {
    const KERNEL: &str = "
@group(0) @binding(0) var<storage, read> xs: array<vec2<f32>>;
@group(0) @binding(1) var<storage, read_write> out: array<vec2<f32>>;
@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x;
    if (i >= arrayLength(&xs)) {
        return;
    }
    out[i] = vec2<f32>(div_rn(xs[i].x, xs[i].y), sqrt_rn(xs[i].x));
}
";
    let gpu = common::gpu();
    let mut rng = StdRng::seed_from_u64(7);
    let normal = |rng: &mut StdRng, lo: u32, hi: u32| {
        f32::from_bits(rng.random_range(lo..hi) << 23 | rng.random_range(0..1u32 << 23))
            * if rng.random_range(0..2) == 0 {
                1.0
            } else {
                -1.0
            }
    };
    let mut xs: Vec<[f32; 2]> = Vec::new();
    for _ in 0..60_000 {
        // Exponents 40..214: every quotient normal.
        xs.push([normal(&mut rng, 40, 214), normal(&mut rng, 40, 214)]);
        // Short significands: exact quotients and squares.
        let short = |rng: &mut StdRng| {
            (rng.random_range(1..4096u32) as f32) * 2f32.powi(rng.random_range(-20..20))
        };
        let (a, b) = (short(&mut rng), short(&mut rng));
        xs.push([a * b, b]);
        xs.push([a * a, a]);
        // Significands of all ones and of a single bit.
        let e = rng.random_range(100..150u32) << 23;
        xs.push([f32::from_bits(e | 0x7f_ffff), f32::from_bits(e | 1)]);
    }
    for special in [
        0.0f32,
        -0.0,
        1.0,
        4.0,
        2.0,
        f32::INFINITY,
        f32::MAX,
        f32::MIN_POSITIVE,
    ] {
        xs.push([special, 3.0]);
        xs.push([3.0, special]);
    }
    let words = |v: &[[f32; 2]]| {
        v.iter()
            .flat_map(|p| p.map(f32::to_bits))
            .collect::<Vec<u32>>()
    };
    let source = mdas::lights::tree::gpu_build::prim_wgsl()
        .part((
            "lights/exact.wgsl",
            include_str!("../wgsl/lights/exact.wgsl"),
        ))
        .part(("test", KERNEL));
    let layout = gpu.bind_group_layout(
        "test.exact.layout",
        &[
            mdas::gpu::shader::storage_entry(0, true),
            mdas::gpu::shader::storage_entry(1, false),
        ],
    );
    let pipeline = gpu
        .compute_pipeline("test.exact", &source, "main", &[&layout])
        .unwrap();
    let input = gpu.buffer_from("test.exact.in", &xs, STORAGE).unwrap();
    let output = gpu
        .buffer_zeroed("test.exact.out", 8 * xs.len() as u64, STORAGE)
        .unwrap();
    let group = gpu.device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: None,
        layout: &layout,
        entries: &[
            wgpu::BindGroupEntry {
                binding: 0,
                resource: input.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: 1,
                resource: output.as_entire_binding(),
            },
        ],
    });
    let mut encoder = gpu.device.create_command_encoder(&Default::default());
    {
        let mut pass = encoder.begin_compute_pass(&Default::default());
        pass.set_pipeline(&pipeline);
        pass.set_bind_group(0, &group, &[]);
        pass.dispatch_workgroups((xs.len() as u32).div_ceil(64), 1, 1);
    }
    gpu.queue.submit([encoder.finish()]);
    let got: Vec<[f32; 2]> = gpu.read_buffer(&output, xs.len()).unwrap();
    let want: Vec<[f32; 2]> = xs.iter().map(|&[a, b]| [a / b, a.sqrt()]).collect();
    let (g, w) = (words(&got), words(&want));
    let bad: Vec<usize> = (0..g.len())
        .filter(|&k| {
            g[k] != w[k] && !(f32::from_bits(g[k]).is_nan() && f32::from_bits(w[k]).is_nan())
        })
        .collect();
    assert!(
        bad.is_empty(),
        "{} of {} results differ; first: {:?} → GPU {:?}, Rust {:?}",
        bad.len(),
        g.len(),
        xs[bad[0] / 2],
        got[bad[0] / 2],
        want[bad[0] / 2]
    );
}

/// `sst` and `sst_nosub` render from the GPU build: on a VPL scene the
/// frame's set-up runs its phases and no CPU build, and the buffers the
/// sampler binds (nodes, index table, cones, substitutes) are those of
/// the CPU oracle over the frame's lights, bit for bit; after
/// `set_frame` too.
#[test]
fn sst_renders_from_the_gpu_build() {
    use mdas::integrand::{IntegrandSpec, ManyLight};
    use mdas::lights::registry::SamplerKind;
    use mdas::lights::substitute::gpu_build::PHASES;
    let gpu = common::gpu();
    let scene =
        mdas::scene_file::SceneFile::load(std::path::Path::new("scenes/tests/moving_lights.toml"))
            .unwrap();
    let IntegrandSpec::ManyLight(spec) = &scene.integrand else {
        panic!("not a many_light scene")
    };
    let film = scene.scene.film;
    let gpu_scene =
        std::sync::Arc::new(mdas::accel::GpuScene::new(gpu, &scene.scene, film).unwrap());
    for kind in [SamplerKind::Sst, SamplerKind::SstNoSub] {
        let spec = mdas::integrand::ManyLightSpec {
            sampler: kind,
            ..spec.clone()
        };
        let mut ml = ManyLight::new(gpu, &scene.scene, gpu_scene.clone(), film, &spec).unwrap();
        for frame in [None, Some(3)] {
            if let Some(f) = frame {
                ml.set_frame(gpu, &scene.scene, f).unwrap();
            }
            let times = ml.setup_times();
            assert!(times.get(PHASES[5]).is_some(), "{kind}: {times:?}");
            assert!(
                times.get("many_light.cpu_build").is_none(),
                "{kind}: {times:?}"
            );
            let prims = ml.lights();
            assert!(prims.len() > 100, "{kind}: {} lights", prims.len());
            let c = radix::build(prims).unwrap();
            let data = ml.sampler_data();
            let n = prims.len();
            let m = 2 * n - 1;
            let nodes: Vec<mdas::lights::TreeNode> = gpu.read_buffer(&data.nodes, m).unwrap();
            let index: Vec<u32> = gpu.read_buffer(&data.index, n + m).unwrap();
            let cones: Vec<mdas::lights::LightCone> = gpu.read_buffer(&data.cones, m).unwrap();
            let subs: Vec<mdas::lights::substitute::Substitute> =
                gpu.read_buffer(&data.substitutes, m).unwrap();
            let table: Vec<u32> = c
                .bvh
                .leaf_of_light
                .iter()
                .chain(&c.bvh.parent)
                .copied()
                .collect();
            assert_eq!(data.params.node_count as usize, m, "{kind}");
            assert_eq!(index, table, "{kind} {frame:?}: index table");
            same_bits("node", n, &nodes, &c.bvh.nodes);
            same_bits("cone", n, &cones, &c.bvh.cones);
            same_bits("substitute", n, &subs, &c.substitutes);
        }
    }
}
