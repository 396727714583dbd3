//! The GPU radix sort and the GPU perfect light tree against their CPU
//! references: `sort_by_key` (stable) and `lights::tree::perfect::build`, bit for
//! bit.

mod common;

use mdas::gpu::buffer::STORAGE;
use mdas::gpu::radix_sort::RadixSort;
use mdas::gpu::Gpu;
use rand::rngs::StdRng;
use rand::{RngExt, SeedableRng};

/// Sorts `(keys, ids)` on the GPU by the low `key_bits` bits.
fn gpu_sort(gpu: &Gpu, sorter: &RadixSort, keys: &[u32], key_bits: u32) -> (Vec<u32>, Vec<u32>) {
    let values: Vec<u32> = (0..keys.len() as u32).collect();
    let k = gpu.buffer_from("test.sort.keys", keys, STORAGE).unwrap();
    let v = gpu
        .buffer_from("test.sort.values", &values, STORAGE)
        .unwrap();
    gpu.scoped("test sort", || {
        let mut encoder = gpu.device.create_command_encoder(&Default::default());
        sorter.sort(gpu, &mut encoder, None, &k, &v, keys.len() as u32, key_bits)?;
        gpu.queue.submit([encoder.finish()]);
        Ok(())
    })
    .unwrap();
    (
        gpu.read_buffer(&k, keys.len()).unwrap(),
        gpu.read_buffer(&v, keys.len()).unwrap(),
    )
}

/// The stable CPU sort by the masked key.
fn cpu_sort(keys: &[u32], key_bits: u32) -> (Vec<u32>, Vec<u32>) {
    let mask = if key_bits >= 32 {
        u32::MAX
    } else {
        (1u32 << key_bits) - 1
    };
    let mut pairs: Vec<(u32, u32)> = keys.iter().copied().zip(0..).collect();
    pairs.sort_by_key(|&(k, _)| k & mask);
    pairs.into_iter().unzip()
}

fn check_sort(gpu: &Gpu, sorter: &RadixSort, keys: &[u32], key_bits: u32, what: &str) {
    let (gk, gv) = gpu_sort(gpu, sorter, keys, key_bits);
    let (ck, cv) = cpu_sort(keys, key_bits);
    assert!(
        gk == ck,
        "{what}: keys differ (n = {}, bits = {key_bits})",
        keys.len()
    );
    assert!(
        gv == cv,
        "{what}: values differ (n = {}, bits = {key_bits})",
        keys.len()
    );
}

#[test]
fn radix_sort_matches_stable_cpu_sort() {
    let gpu = common::gpu();
    let sorter = RadixSort::new(gpu, 1 << 20).unwrap();
    let mut rng = StdRng::seed_from_u64(6);
    for n in [0usize, 1, 2, 255, 256, 257, 2047, 2048, 2049, 5000, 100_003] {
        let random: Vec<u32> = (0..n).map(|_| rng.random::<u32>() >> 2).collect();
        check_sort(gpu, &sorter, &random, 30, "random 30-bit");
        // Few distinct keys: long runs of equal keys test stability.
        let few: Vec<u32> = (0..n).map(|_| rng.random_range(0..5u32) << 27).collect();
        check_sort(gpu, &sorter, &few, 30, "five distinct keys");
    }
    for n in [0usize, 1, 255, 256, 257, 4099] {
        let equal = vec![0x2aaa_aaaau32; n];
        check_sort(gpu, &sorter, &equal, 30, "all equal");
        let sorted: Vec<u32> = (0..n as u32).map(|i| i * 7).collect();
        check_sort(gpu, &sorter, &sorted, 30, "already sorted");
        let reversed: Vec<u32> = sorted.iter().rev().copied().collect();
        check_sort(gpu, &sorter, &reversed, 30, "reversed");
    }
    // Bits above key_bits travel along but do not order; odd pass counts
    // (a copy back) and full 32-bit keys.
    let wide: Vec<u32> = (0..3001).map(|_| rng.random::<u32>()).collect();
    for bits in [0, 1, 4, 5, 12, 30, 31, 32] {
        check_sort(gpu, &sorter, &wide, bits, "wide keys");
    }
}

#[test]
fn radix_sort_one_million() {
    let gpu = common::gpu();
    let n = 1 << 20;
    let sorter = RadixSort::new(gpu, n).unwrap();
    let mut rng = StdRng::seed_from_u64(7);
    let keys: Vec<u32> = (0..n).map(|_| rng.random::<u32>() >> 2).collect();
    check_sort(gpu, &sorter, &keys, 30, "1M random");
}

#[test]
fn radix_sort_refuses_over_capacity() {
    let gpu = common::gpu();
    let sorter = RadixSort::new(gpu, 100).unwrap();
    let k = gpu.buffer_zeroed("test.sort.k", 4 * 101, STORAGE).unwrap();
    let mut encoder = gpu.device.create_command_encoder(&Default::default());
    let err = sorter
        .sort(gpu, &mut encoder, None, &k, &k, 101, 30)
        .unwrap_err();
    assert!(err.to_string().contains("capacity"), "{err}");
    let small = gpu.buffer_zeroed("test.sort.small", 16, STORAGE).unwrap();
    let err = sorter
        .sort(gpu, &mut encoder, None, &small, &k, 100, 30)
        .unwrap_err();
    assert!(err.to_string().contains("keys buffer"), "{err}");
}

// ---- the perfect light tree ----

use glam::Vec3;
use mdas::gpu::Profiler;
use mdas::lights::tree::gpu_build::{BuildTimes, GpuLightTree};
use mdas::lights::{morton, tree::perfect, LightCone, LightPrim, TreeNode};

/// `n` lights in `[-s, s]^3`: points, VPLs and triangles (edges up to
/// `s/10`) at random, with RGB emission in `[0, 4)`.
fn random_lights(rng: &mut StdRng, n: usize, s: f32) -> Vec<LightPrim> {
    let v = |rng: &mut StdRng, r: f32| {
        Vec3::new(
            rng.random_range(-r..r),
            rng.random_range(-r..r),
            rng.random_range(-r..r),
        )
    };
    (0..n)
        .map(|_| {
            let p = v(rng, s);
            let e = Vec3::new(
                rng.random_range(0.0..4.0),
                rng.random_range(0.0..4.0),
                rng.random_range(0.0..4.0),
            );
            match rng.random_range(0..5) {
                0 | 1 => LightPrim::point(p, e),
                2 => LightPrim::vpl(p, v(rng, 1.0).normalize_or(Vec3::Y), e),
                _ => LightPrim::triangle(p, p + v(rng, s / 10.0), p + v(rng, s / 10.0), e),
            }
        })
        .collect()
}

/// `prims` moved into the plane y = `y` (a zero-extent axis).
fn in_plane_y(prims: Vec<LightPrim>, y: f32) -> Vec<LightPrim> {
    prims
        .into_iter()
        .map(|mut l| {
            l.p0[1] = y;
            l.p1[1] = y;
            l.p2[1] = y;
            l
        })
        .collect()
}

struct Built {
    nodes: Vec<TreeNode>,
    cones: Option<Vec<LightCone>>,
    leaf_of_light: Vec<u32>,
    sorted_ids: Vec<u32>,
    sorted_codes: Vec<u32>,
}

fn gpu_build(gpu: &Gpu, tree: &mut GpuLightTree, prims: &[LightPrim]) -> Built {
    let buffer = gpu
        .buffer_from("test.lights", prims, wgpu::BufferUsages::STORAGE)
        .unwrap();
    let mut profiler = Profiler::new(gpu);
    tree.build(gpu, &buffer, prims.len() as u32, &mut profiler)
        .unwrap();
    let times = BuildTimes::from_phases(&profiler.finish().unwrap());
    assert!(times.total().is_finite(), "{times:?}");
    let n = prims.len();
    Built {
        nodes: gpu
            .read_buffer(&tree.nodes, tree.node_count() as usize)
            .unwrap(),
        cones: tree
            .cones
            .as_ref()
            .map(|c| gpu.read_buffer(c, tree.node_count() as usize).unwrap()),
        leaf_of_light: gpu.read_buffer(&tree.leaf_of_light, n).unwrap(),
        sorted_ids: gpu.read_buffer(&tree.sorted_ids, n).unwrap(),
        sorted_codes: gpu.read_buffer(&tree.sorted_codes, n).unwrap(),
    }
}

/// Builds on the GPU and checks every node bit for bit against the oracle.
fn check_tree(gpu: &Gpu, tree: &mut GpuLightTree, prims: &[LightPrim], what: &str) {
    let got = gpu_build(gpu, tree, prims);
    let want = perfect::build(prims).expect("at least one light");
    assert_eq!(tree.levels(), want.levels, "{what}: levels");
    assert_eq!(tree.leaf_count(), want.leaf_count, "{what}: leaf count");
    assert_eq!(tree.light_count(), prims.len() as u32);
    let mut codes = morton::codes(prims);
    codes.sort_unstable();
    assert!(
        got.sorted_codes == codes,
        "{what}: sorted Morton codes differ"
    );
    assert!(got.sorted_ids == want.sorted, "{what}: leaf order differs");
    assert!(
        got.leaf_of_light == want.leaf_of_light,
        "{what}: leaf_of_light differs"
    );
    assert_eq!(got.nodes.len(), want.nodes.len(), "{what}: node count");
    let bits = |n: &TreeNode| -> [u32; 8] { bytemuck::cast(*n) };
    for (i, (g, w)) in got.nodes.iter().zip(&want.nodes).enumerate() {
        assert!(
            bits(g) == bits(w),
            "{what}: node {i} (level {}) differs:\n  gpu {g:?}\n  cpu {w:?}",
            perfect::level_of(i)
        );
    }
    if let Some(cones) = &got.cones {
        check_cones(cones, &want.cones, what);
    }
}

/// Largest difference, in radians, between a GPU cone and the oracle's in
/// axis and spread: rounding differences of a few ulp per operation (WGSL's
/// `sqrt` and division are not exact) on unit vectors, accumulated over at
/// most 21 merges, stay below 1e-5; 1e-4 leaves room for a driver's
/// `normalize`. A cone whose spread is within 1e-3 of π is compared by
/// spread only (its axis hardly matters).
const CONE_TOLERANCE: f32 = 1e-4;

/// One GPU cone `g` against the oracle's `w` (cone `i` of `what`): the
/// spreads and, unless the spread is within 1e-3 of π, the axes within
/// [`CONE_TOLERANCE`], `cos_e` and sidedness equal. Returns the spread's
/// difference and the axes' angle (`None` for a near-sphere).
fn check_cone(g: &LightCone, w: &LightCone, i: usize, what: &str) -> (f32, Option<f32>) {
    let spread = |c: &LightCone| c.sin_o.atan2(c.cos_o);
    let (ga, wa) = (Vec3::from(g.axis), Vec3::from(w.axis));
    let axis = ga.cross(wa).length().atan2(ga.dot(wa));
    let d = (spread(g) - spread(w)).abs();
    let wide = spread(w) > std::f32::consts::PI - 1e-3;
    assert!(
        d <= CONE_TOLERANCE && (wide || axis <= CONE_TOLERANCE),
        "{what}: cone {i}: spread differs by {d}, axis by {axis}:\n  gpu {g:?}\n  cpu {w:?}"
    );
    assert_eq!(
        (g.cos_e, g.two_sided),
        (w.cos_e, w.two_sided),
        "{what}: cone {i}"
    );
    (d, (!wide).then_some(axis))
}

/// The GPU's cones against the oracle's, and conservative on their own:
/// every node's cone contains its children's.
fn check_cones(got: &[LightCone], want: &[LightCone], what: &str) {
    assert_eq!(got.len(), want.len(), "{what}: cone count");
    let (mut max_spread, mut max_axis) = (0f32, 0f32);
    for (i, (g, w)) in got.iter().zip(want).enumerate() {
        assert_eq!(
            g.is_empty(),
            w.is_empty(),
            "{what}: cone {i}: {g:?} vs {w:?}"
        );
        if w.is_empty() {
            continue;
        }
        let (d, axis) = check_cone(g, w, i, what);
        max_spread = max_spread.max(d);
        max_axis = max_axis.max(axis.unwrap_or(0.0));
        if i < got.len() / 2 {
            for child in [2 * i + 1, 2 * i + 2] {
                assert!(
                    g.contains(&got[child], 1e-6),
                    "{what}: cone {i} does not contain its child {child}"
                );
            }
        }
    }
    eprintln!("{what}: GPU cones within {max_spread:e} rad (spread), {max_axis:e} rad (axis)");
}

#[test]
fn tree_matches_cpu_oracle_bit_for_bit() {
    let gpu = common::gpu();
    let mut tree = GpuLightTree::new(gpu, 20_000, true).unwrap();
    let mut rng = StdRng::seed_from_u64(61);
    for n in [1usize, 2, 3, 5, 255, 256, 257, 1000, 12_146] {
        let prims = random_lights(&mut rng, n, 10.0);
        check_tree(gpu, &mut tree, &prims, &format!("{n} random lights"));
    }
    // Coordinates over many binades: centroids divide by 3 at every exponent.
    let mut prims = Vec::new();
    for k in -30..30 {
        prims.extend(random_lights(&mut rng, 50, 2f32.powi(k)));
    }
    check_tree(gpu, &mut tree, &prims, "many scales");
    // Triangles only, all facing roughly down (a ceiling of tilted
    // panels): narrow cones on every level, merged by the general rule.
    let panels: Vec<LightPrim> = (0..3000)
        .map(|_| {
            let c = Vec3::new(
                rng.random_range(-8.0..8.0),
                rng.random_range(2.0..3.0),
                rng.random_range(-8.0..8.0),
            );
            let tilt = Vec3::new(
                rng.random_range(-0.3..0.3),
                0.0,
                rng.random_range(-0.3..0.3),
            );
            LightPrim::triangle(c, c + Vec3::X * 0.2 + tilt, c + Vec3::Z * 0.2, Vec3::ONE)
        })
        .collect();
    check_tree(gpu, &mut tree, &panels, "tilted panels");
}

#[test]
fn tree_degenerate_light_sets() {
    let gpu = common::gpu();
    let mut tree = GpuLightTree::new(gpu, 5000, true).unwrap();
    let mut rng = StdRng::seed_from_u64(62);

    // Every light at one point: all codes equal (zero extents), id order.
    let same: Vec<LightPrim> = (0..700)
        .map(|i| LightPrim::point(Vec3::new(1.5, -2.0, 3.25), Vec3::splat(i as f32 * 0.01)))
        .collect();
    check_tree(gpu, &mut tree, &same, "coincident lights");

    // Clusters of coincident lights among others: runs of equal codes.
    let mut clusters = random_lights(&mut rng, 1500, 5.0);
    for i in 0..1500 {
        if i % 3 == 0 {
            clusters[i] = clusters[i / 30];
        }
    }
    check_tree(gpu, &mut tree, &clusters, "clusters of coincident lights");

    // All lights in the plane y = 2.5: a zero-extent axis.
    let plane = in_plane_y(random_lights(&mut rng, 3000, 8.0), 2.5);
    check_tree(gpu, &mut tree, &plane, "lights in one plane");

    // Zero intensities: black lights, degenerate (zero-area) triangles,
    // and a whole tree of them.
    let mut dark = random_lights(&mut rng, 999, 3.0);
    for (i, l) in dark.iter_mut().enumerate() {
        if i % 4 == 0 {
            l.emission = [0.0; 3];
        } else if i % 4 == 1 && l.kind == mdas::lights::KIND_TRIANGLE {
            l.p2 = l.p1;
        }
    }
    check_tree(gpu, &mut tree, &dark, "zero-intensity lights");
    for l in &mut dark {
        l.emission = [0.0; 3];
    }
    check_tree(gpu, &mut tree, &dark, "all lights black");
}

#[test]
fn tree_rebuilds_per_frame_and_handles_no_lights() {
    let gpu = common::gpu();
    let mut tree = GpuLightTree::new(gpu, 4096, false).unwrap();
    let mut rng = StdRng::seed_from_u64(63);
    // A large tree, then a smaller one with other lights in the same
    // buffers (stale nodes and leaf slots must not leak), then a third.
    let frames = [
        random_lights(&mut rng, 4096, 10.0),
        random_lights(&mut rng, 1100, 1.0),
        random_lights(&mut rng, 3, 100.0),
    ];
    for (f, prims) in frames.iter().enumerate() {
        check_tree(gpu, &mut tree, prims, &format!("frame {f}"));
    }
    // No lights: no tree, nothing dispatched.
    let empty = gpu
        .buffer_zeroed("test.no_lights", 64, wgpu::BufferUsages::STORAGE)
        .unwrap();
    let times = tree.build_timed(gpu, &empty, 0).unwrap();
    assert_eq!(times.total(), 0.0);
    assert_eq!(
        (tree.levels(), tree.leaf_count(), tree.node_count()),
        (0, 0, 0)
    );
    // Over capacity and a short light buffer: errors before any work.
    let small = gpu
        .buffer_from("test.lights", &frames[2], wgpu::BufferUsages::STORAGE)
        .unwrap();
    let err = tree.build_timed(gpu, &small, 4097).unwrap_err();
    assert!(err.to_string().contains("capacity"), "{err}");
    let err = tree.build_timed(gpu, &small, 4).unwrap_err();
    assert!(err.to_string().contains("bytes"), "{err}");
}

#[test]
fn tree_of_one_million_lights() {
    let gpu = common::gpu();
    let n = 1 << 20;
    let mut tree = GpuLightTree::new(gpu, n, true).unwrap();
    let mut rng = StdRng::seed_from_u64(64);
    let prims = random_lights(&mut rng, n as usize, 50.0);
    check_tree(gpu, &mut tree, &prims, "1M lights");
}

// ---- the exact per-light arithmetic of wgsl/lights/light_prim.wgsl ----

/// Runs `prim_centroid` and `prim_intensity` over `prims` on the GPU.
fn gpu_prim_quantities(gpu: &Gpu, prims: &[LightPrim]) -> Vec<[u32; 4]> {
    use mdas::gpu::shader::{bind_buffers, storage_entry, uniform_entry};
    let source = mdas::lights::tree::gpu_build::prim_wgsl().part((
        "tests/kernels/prim_quantities.wgsl",
        include_str!("kernels/prim_quantities.wgsl"),
    ));
    let layout = gpu.bind_group_layout(
        "test.prim.layout",
        &[
            uniform_entry(0),
            storage_entry(1, true),
            storage_entry(2, false),
        ],
    );
    let pipeline = gpu
        .compute_pipeline("test.prim", &source, "main", &[&layout])
        .unwrap();
    let zero = gpu.uniform("test.prim.zero", &[0u32; 4]);
    let input = gpu
        .buffer_from("test.prim.in", prims, wgpu::BufferUsages::STORAGE)
        .unwrap();
    let out = gpu
        .buffer_zeroed("test.prim.out", 16 * prims.len() as u64, STORAGE)
        .unwrap();
    let group = bind_buffers(gpu, "test.prim", &layout, &[&zero, &input, &out]);
    let mut encoder = gpu.device.create_command_encoder(&Default::default());
    {
        let mut pass = encoder.begin_compute_pass(&Default::default());
        pass.set_pipeline(&pipeline);
        pass.set_bind_group(0, &group, &[]);
        pass.dispatch_workgroups((prims.len() as u32).div_ceil(64), 1, 1);
    }
    gpu.queue.submit([encoder.finish()]);
    gpu.read_buffer(&out, prims.len()).unwrap()
}

#[test]
fn per_light_arithmetic_is_exact() {
    let gpu = common::gpu();
    let mut rng = StdRng::seed_from_u64(65);
    // A normal f32 with a random mantissa and sign and an exponent field in
    // [3, 250] (no overflow in the sums below, no subnormal quotient).
    let any = |rng: &mut StdRng| {
        let field = rng.random_range(3u32..=250);
        f32::from_bits((rng.random::<u32>() & 0x807f_ffff) | (field << 23))
    };
    let mut prims = Vec::new();
    // Division by 3 at every exponent: p1 = p2 = 0, so the centroid is p0 / 3.
    for _ in 0..50_000 {
        let p = Vec3::new(any(&mut rng), any(&mut rng), any(&mut rng));
        prims.push(LightPrim::point(p, Vec3::ZERO));
        prims.last_mut().unwrap().p1 = [0.0; 3];
        prims.last_mut().unwrap().p2 = [0.0; 3];
    }
    // Mantissas that end in the rounding boundaries of x / 3.
    for m in 0..3000u32 {
        let x = f32::from_bits((100 << 23) | (m * 2797 % 0x80_0000));
        prims.push(LightPrim::point(Vec3::splat(x), Vec3::ONE));
        prims.last_mut().unwrap().p1 = [0.0; 3];
        prims.last_mut().unwrap().p2 = [0.0; 3];
    }
    // Triangles and points at many scales: centroids, luminance, cross
    // products and areas (products that a driver could fuse into fmas).
    for _ in 0..50_000 {
        let s = 2f32.powi(rng.random_range(-20..20));
        let v = |rng: &mut StdRng| {
            Vec3::new(
                rng.random_range(-s..s),
                rng.random_range(-s..s),
                rng.random_range(-s..s),
            )
        };
        let e = Vec3::new(
            rng.random_range(0.0..100.0),
            rng.random_range(0.0..100.0),
            rng.random_range(0.0..100.0),
        );
        let (a, b, c) = (v(&mut rng), v(&mut rng), v(&mut rng));
        prims.push(LightPrim::triangle(a, b, c, e));
        prims.push(LightPrim::point(a, e));
    }
    let got = gpu_prim_quantities(gpu, &prims);
    let mut bad = 0;
    for (i, (l, g)) in prims.iter().zip(&got).enumerate() {
        let c = l.centroid();
        let want = [
            c.x.to_bits(),
            c.y.to_bits(),
            c.z.to_bits(),
            l.intensity().to_bits(),
        ];
        if *g != want {
            if bad < 5 {
                eprintln!("light {i} {l:?}: gpu {g:x?}, cpu {want:x?}");
            }
            bad += 1;
        }
    }
    assert_eq!(bad, 0, "{bad} of {} lights differ", prims.len());
}

// ------------------------------------------------ lighting grid hierarchy

/// The GPU build of the lighting grid hierarchy (`lights::lgh::gpu`)
/// against its CPU oracle (`lights::lgh::build`): the sorted light ids and
/// cell ranges exactly, the same vertices holding grid lights, and every
/// grid light's sums within 1e-4 of the oracle's (relative to its own
/// magnitude: W, |e|, W·h for the first moments about its vertex, W·h² for
/// the second; the kernels may contract products into fmas and divide
/// with WGSL's 2.5-ulp division: measured differences ~1e-6).
mod lgh_gpu {
    use super::*;
    use mdas::lights::lgh::gpu::GpuLgh;
    use mdas::lights::lgh::{self, LghParams};

    fn check(prims: &[LightPrim], levels: u32, what: &str) {
        let gpu = common::gpu();
        let params = LghParams {
            levels,
            ..LghParams::default()
        };
        let h = GpuLgh::new(gpu, prims, &params).unwrap();
        let buffer = gpu
            .buffer_from("test.lgh.prims", prims, STORAGE)
            .unwrap_or_else(|_| {
                gpu.buffer_from("test.lgh.prims", &[LightPrim::default()], STORAGE)
                    .unwrap()
            });
        let mut profiler = Profiler::new(gpu);
        h.build(gpu, &buffer, &mut profiler).unwrap();
        let times = profiler.finish().unwrap();
        for phase in mdas::lights::lgh::gpu::PHASES {
            assert!(times.get(phase).is_some(), "{what}: no time for {phase}");
        }
        let (got, count) = h.read(gpu).unwrap();
        let want = lgh::build(prims, levels).unwrap();
        assert_eq!(got.grid, want.grid, "{what}: grid");
        assert_eq!(got.sorted, want.sorted, "{what}: sorted ids");
        assert_eq!(got.cells, want.cells, "{what}: cell ranges");
        assert_eq!(
            count as usize,
            want.lights.len(),
            "{what}: grid light count"
        );
        let g = &want.grid;
        for level in 1..=g.levels {
            let r = g.res(level);
            let hl = g.h(level);
            for z in 0..r {
                for y in 0..r {
                    for x in 0..r {
                        let v = [x, y, z];
                        let (a, b) = (got.light_at(level, v), want.light_at(level, v));
                        let (a, b) = match (a, b) {
                            (None, None) => continue,
                            (Some(a), Some(b)) => (a, b),
                            _ => panic!("{what}: level {level} vertex {v:?}: {a:?} vs {b:?}"),
                        };
                        assert_eq!((a.vertex, a.level), (b.vertex, b.level), "{what}");
                        let close = |x: f32, y: f32, scale: f32, name: &str| {
                            assert!(
                                (x - y).abs() <= 1e-4 * (y.abs() + scale),
                                "{what}: level {level} vertex {v:?} {name}: {x} vs {y}"
                            );
                        };
                        close(a.w, b.w, 0.0, "W");
                        close(a.iso, b.iso, b.w, "iso");
                        for k in 0..3 {
                            close(a.e[k], b.e[k], b.e.iter().sum(), "e");
                            close(a.p[k], b.p[k], b.w * hl, "P");
                            close(a.q[k], b.q[k], b.w * hl * hl, "Q");
                            close(a.n[k], b.n[k], b.w, "N");
                        }
                    }
                }
            }
        }
    }

    #[test]
    fn gpu_build_matches_the_cpu_oracle() {
        let mut rng = StdRng::seed_from_u64(51);
        // Points, VPLs and triangles (not grid lights: sorted last).
        let mixed = random_lights(&mut rng, 4000, 6.0);
        check(
            &mixed,
            0,
            "mixed points, VPLs and triangles, default levels",
        );
        check(&mixed, 6, "mixed, 6 levels");
        check(&mixed[..1], 3, "one light");
        let same: Vec<LightPrim> = (0..200)
            .map(|i| {
                LightPrim::point(
                    Vec3::new(1.0, -2.0, 0.5),
                    Vec3::splat(0.01 * (i % 5) as f32),
                )
            })
            .collect();
        check(&same, 4, "200 lights at one point, some dark");
        let plane: Vec<LightPrim> = (0..3000)
            .map(|_| {
                let p = Vec3::new(
                    rng.random_range(-2.0..2.0),
                    0.25,
                    rng.random_range(-3.0..3.0),
                );
                LightPrim::vpl(p, Vec3::Y, Vec3::new(0.2, 0.1, 0.05))
            })
            .collect();
        check(&plane, 0, "VPLs on a plane");
        check(&[], 0, "no lights");
    }
}

// ---- the two-level tree's bottom levels (tree2) ----

use mdas::lights::bvh::{LightBvh, INTERNAL_BIT};
use mdas::lights::scene_lights;
use mdas::lights::two_level::gpu::GpuTwoLevel;
use mdas::lights::two_level::BottomLevels;
use mdas::scene_file;

/// The GPU-gathered tree read back: nodes, cones, then `leaf_of_light`
/// and the parents, as the sampler binds them.
fn gpu_two_level(
    gpu: &Gpu,
    t: &GpuTwoLevel,
    prims: &wgpu::Buffer,
) -> (Vec<TreeNode>, Vec<LightCone>, Vec<u32>) {
    let mut profiler = Profiler::new(gpu);
    t.build(gpu, prims, &mut profiler).unwrap();
    let times = profiler.finish().unwrap();
    for phase in mdas::lights::two_level::gpu::PHASES {
        assert!(
            times.get(phase).is_some_and(f64::is_finite),
            "{phase}: {times:?}"
        );
    }
    let m = t.node_count() as usize;
    (
        gpu.read_buffer(&t.nodes, m).unwrap(),
        gpu.read_buffer(&t.cones, m).unwrap(),
        gpu.read_buffer(&t.index, t.light_count() as usize + m)
            .unwrap(),
    )
}

/// The GPU's two-level tree against [`BottomLevels::tree`]: every node
/// bit for bit (bounds, intensity, child or light), `leaf_of_light` and
/// the parents exactly, the cones within [`CONE_TOLERANCE`] and each
/// containing its children's (the top level is built from the GPU's roots,
/// so a tie in its SAOH split could in principle move; none does here).
fn check_two_level(got: &(Vec<TreeNode>, Vec<LightCone>, Vec<u32>), want: &LightBvh, what: &str) {
    let (nodes, cones, index) = got;
    let bits = |n: &TreeNode| -> [u32; 8] { bytemuck::cast(*n) };
    assert_eq!(nodes.len(), want.nodes.len(), "{what}: node count");
    for (i, (g, w)) in nodes.iter().zip(&want.nodes).enumerate() {
        assert!(
            bits(g) == bits(w),
            "{what}: node {i} differs:\n  gpu {g:?}\n  cpu {w:?}"
        );
    }
    let table: Vec<u32> = want
        .leaf_of_light
        .iter()
        .chain(&want.parent)
        .copied()
        .collect();
    assert!(*index == table, "{what}: leaf_of_light or parents differ");
    let mut worst = 0f32;
    assert_eq!(cones.len(), want.cones.len(), "{what}: cone count");
    for (i, (g, w)) in cones.iter().zip(&want.cones).enumerate() {
        let (d, axis) = check_cone(g, w, i, what);
        worst = worst.max(d).max(axis.unwrap_or(0.0));
        let id = nodes[i].id;
        if id & INTERNAL_BIT != 0 {
            let l = (id & !INTERNAL_BIT) as usize;
            for c in [l, l + 1] {
                assert!(
                    g.contains(&cones[c], 1e-6),
                    "{what}: cone {i} does not contain its child {c}:\n  {g:?}\n  {:?}\n  cpu {w:?} contains its child: {}\n  {:?}",
                    cones[c], w.contains(&want.cones[c], 1e-6), want.cones[c]
                );
            }
        }
    }
    eprintln!("{what}: GPU cones within {worst:e} rad");
}

/// `tree2` gathered on the GPU equals the CPU's, frame after frame, on the
/// two scenes it is for: `cornell_lights` (12 meshes of 1,000 triangles,
/// all moving: every node gathered anew) and `street_lights` (56 static
/// meshes of 2 to 224 triangles), plus random groups with lone lights.
#[test]
fn two_level_tree_gathered_on_the_gpu_matches_the_cpu() {
    let gpu = common::gpu();
    for (file, times) in [
        ("scenes/cornell_lights.toml", &[0.0f32, 0.37, 1.5, 3.99][..]),
        ("scenes/street_lights.toml", &[0.0][..]),
    ] {
        let scene = scene_file::load(std::path::Path::new(file)).unwrap().scene;
        let bottoms = scene_lights::bottom_levels(&scene);
        let t =
            GpuTwoLevel::new(gpu, bottoms.gpu_plan().expect("groups of a fixed shape")).unwrap();
        let n = bottoms.light_count();
        let buffer = gpu
            .buffer_zeroed("test.tree2.lights", (n * 64) as u64, STORAGE)
            .unwrap();
        for &time in times {
            let prims = scene_lights::light_prims(&scene, time);
            gpu.queue
                .write_buffer(&buffer, 0, bytemuck::cast_slice(&prims));
            let got = gpu_two_level(gpu, &t, &buffer);
            check_two_level(
                &got,
                &bottoms.tree(&prims).unwrap(),
                &format!("{file} at t = {time}"),
            );
        }
    }
    // Random groups: sizes 1 to 700, every third a lone light.
    let mut rng = StdRng::seed_from_u64(67);
    let mut prims = Vec::new();
    let mut groups = Vec::new();
    for k in 0..20 {
        let start = prims.len() as u32;
        let count = if k % 3 == 2 {
            1
        } else {
            rng.random_range(2..700)
        };
        prims.extend(random_lights(&mut rng, count, 4.0 + k as f32));
        groups.push(start..prims.len() as u32);
    }
    check_groups(gpu, &prims, groups, "20 random groups");
}

/// The light groups `groups` over `prims` (their object space as they
/// are), gathered on the GPU, against the CPU's build of them.
fn check_groups(gpu: &Gpu, prims: &[LightPrim], groups: Vec<std::ops::Range<u32>>, what: &str) {
    let object: Vec<Option<&[LightPrim]>> = groups
        .iter()
        .map(|g| Some(&prims[g.start as usize..g.end as usize]))
        .collect();
    let bottoms = BottomLevels::new(groups.clone(), &object);
    let t = GpuTwoLevel::new(gpu, bottoms.gpu_plan().expect("a plan")).unwrap();
    let buffer = gpu
        .buffer_from("test.tree2.groups", prims, STORAGE)
        .unwrap();
    let got = gpu_two_level(gpu, &t, &buffer);
    check_two_level(&got, &bottoms.tree(prims).unwrap(), what);
}

/// `tree2`'s GPU gather on hard cases, each against the CPU build as
/// above: one light in all; one group (the top level is its root alone);
/// empty groups between others; a group of coincident lights (equal
/// codes); zero-intensity lights and zero-area triangles, and a group of
/// nothing but them; every light in one plane.
#[test]
fn two_level_gather_hard_cases() {
    let gpu = common::gpu();
    let mut rng = StdRng::seed_from_u64(68);
    let check = |prims: &[LightPrim], groups, what: &str| check_groups(gpu, prims, groups, what);
    let one = random_lights(&mut rng, 1, 2.0);
    check(&one, std::iter::once(0..1).collect(), "one light");
    let many = random_lights(&mut rng, 777, 3.0);
    check(&many, std::iter::once(0..777).collect(), "one group");
    check(
        &many,
        vec![0..0, 0..300, 300..300, 300..301, 301..777, 777..777],
        "empty groups between others",
    );
    let mut same = random_lights(&mut rng, 600, 3.0);
    for l in &mut same[100..400] {
        *l = LightPrim::point(Vec3::new(0.5, 1.0, -0.25), Vec3::splat(0.3));
    }
    check(&same, vec![0..100, 100..400, 400..600], "coincident lights");
    let mut dark = random_lights(&mut rng, 900, 3.0);
    for (i, l) in dark.iter_mut().enumerate() {
        if i % 4 == 0 || i >= 600 {
            l.emission = [0.0; 3];
        } else if i % 4 == 1 && l.kind == mdas::lights::KIND_TRIANGLE {
            l.p2 = l.p1;
        }
    }
    check(
        &dark,
        vec![0..300, 300..600, 600..900],
        "zero-intensity lights and a black group",
    );
    let plane = in_plane_y(random_lights(&mut rng, 800, 5.0), 2.5);
    check(&plane, vec![0..250, 250..800], "lights in one plane");
}
