//! The WGSL light samplers (`wgsl/lights/sample.wgsl`) against the CPU
//! samplers, for every kind, on a CPU-built tree uploaded directly and on
//! the tree the GPU builder produces.
//!
//! A kernel evaluates `light_sample`, `light_pmf` of the sampled light and
//! `light_pmf` of a random probe light for 4096 (shading point, u) pairs.
//! The GPU's f32 division and square root need not be correctly rounded
//! (WGSL allows 2.5 ulp), so a decision can flip when `u` lies within a few
//! ulp of a boundary: a differing pick counts as such a boundary case when
//! the CPU sampler picks the GPU's light for some `u` within ±64 ulp; those
//! must be rare (≤ 0.5%), any other difference fails. The pmfs of equal
//! picks and of the probes must agree to a relative 1e-5.

mod common;
mod light_scenes;

use bytemuck::{Pod, Zeroable};
use glam::Vec3;
use light_scenes::vpl_walls;
use mdas::gpu::buffer::STORAGE;
use mdas::gpu::shader::{storage_entry, Wgsl};
use mdas::gpu::{Gpu, Profiler};
use mdas::lights::bvh;
use mdas::lights::gpu_sampler::{cut_capacity, CutLayout, GpuSamplerData, TreeSource};
use mdas::lights::sampler::Structure;
use mdas::lights::substitute::{
    self, SstSampler, Substitute, SubstituteLayout, SubstituteParams, SUBSTITUTE_BIT,
};
use mdas::lights::tree::cut::{Importance, LightTree, MAX_CUT};
use mdas::lights::tree::gpu_build::GpuLightTree;
use mdas::lights::tree::perfect;
use mdas::lights::two_level;
use mdas::lights::two_level::gpu::GpuTwoLevel;
use mdas::lights::{
    new_sampler, select_cut, CutSampling, LightSampler, PowerSampler, SamplerKind, Shading,
    TreeSampler, UniformSampler,
};
use mdas::lights::{LightCone, LightPrim, LightSample, TreeNode, NO_LIGHT};
use rand::rngs::StdRng;
use rand::{RngExt, SeedableRng};

const QUERIES: usize = 4096;
const BLOCKS: u32 = 64;
const CUT_SIZE: u32 = 16;

#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
struct Query {
    p: [f32; 3],
    u: f32,
    n: [f32; 3],
    cut_base: u32,
    probe: u32,
    /// The subtree of the cut to draw from (`light_sample_subtree`), or
    /// `MIXTURE` for `light_sample`.
    subtree: u32,
    _pad: [u32; 2],
}

/// `Query::subtree` of the one-pick probes.
const MIXTURE: u32 = u32::MAX;

#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
struct Answer {
    light: u32,
    pmf_m: f32,
    pmf_e: i32,
    sampled_m: f32,
    sampled_e: i32,
    probe_m: f32,
    probe_e: i32,
    _pad: u32,
}

/// The sampling and cut-selection probes: `tests/kernels/light_sampler_probe.wgsl`.
const KERNEL: &str = include_str!("kernels/light_sampler_probe.wgsl");

#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
struct Rep {
    p: [f32; 3],
    _p0: u32,
    n: [f32; 3],
    _p1: u32,
}

fn pmf_value(m: f32, e: i32) -> f64 {
    m as f64 * 2f64.powi(e)
}

fn rel_diff(a: f64, b: f64) -> f64 {
    if a == b {
        0.0
    } else {
        (a - b).abs() / a.abs().max(b.abs())
    }
}

fn scene(rng: &mut StdRng, n: usize) -> Vec<LightPrim> {
    (0..n)
        .map(|i| {
            let c = Vec3::new(
                rng.random_range(-5.0..5.0),
                rng.random_range(-5.0..5.0),
                rng.random_range(-5.0..5.0),
            );
            let e = if i % 11 == 10 {
                Vec3::ZERO
            } else {
                Vec3::new(rng.random(), rng.random(), rng.random()) * 5.0
            };
            if i % 4 == 0 {
                let d = Vec3::new(rng.random(), rng.random(), rng.random()) * 0.5;
                LightPrim::triangle(
                    c,
                    c + Vec3::new(d.x, 0.0, 0.0),
                    c + Vec3::new(0.0, d.y, d.z),
                    e,
                )
            } else if i % 4 == 1 {
                LightPrim::vpl(c, unit(rng), e)
            } else {
                LightPrim::point(c, e)
            }
        })
        .collect()
}

fn unit(rng: &mut StdRng) -> Vec3 {
    loop {
        let v = Vec3::new(rng.random(), rng.random(), rng.random()) * 2.0 - Vec3::ONE;
        if v.length() > 0.1 && v.length() <= 1.0 {
            return v.normalize();
        }
    }
}

/// Block representatives, queries near them (a block's pixels), and the
/// CPU cut of every block.
#[derive(Clone)]
struct Setup {
    prims: Vec<LightPrim>,
    reps: Vec<Shading>,
    queries: Vec<Query>,
}

fn setup(seed: u64, n: usize) -> Setup {
    let mut rng = StdRng::seed_from_u64(seed);
    let prims = scene(&mut rng, n);
    setup_prims(rng, prims)
}

fn setup_prims(mut rng: StdRng, prims: Vec<LightPrim>) -> Setup {
    let n = prims.len();
    let reps: Vec<_> = (0..BLOCKS)
        .map(|b| Shading {
            p: Vec3::new(
                rng.random_range(-6.0..6.0),
                rng.random_range(-6.0..6.0),
                rng.random_range(-6.0..6.0),
            ),
            // A few blocks without a normal.
            n: if b % 16 == 5 {
                Vec3::ZERO
            } else {
                unit(&mut rng)
            },
        })
        .collect();
    let queries = (0..QUERIES)
        .map(|i| {
            let b = i as u32 % BLOCKS;
            let rep = reps[b as usize];
            let mut p = rep.p + (Vec3::new(rng.random(), rng.random(), rng.random()) - 0.5) * 0.4;
            if i % 97 == 0 {
                p = Vec3::from(prims[i % n].p0); // exactly on a light
            }
            let nrm = if rep.n == Vec3::ZERO {
                Vec3::ZERO
            } else {
                (rep.n + unit(&mut rng) * 0.2).normalize()
            };
            Query {
                p: p.into(),
                u: rng.random(),
                n: nrm.into(),
                cut_base: b * CUT_SIZE,
                probe: rng.random_range(0..n as u32),
                subtree: MIXTURE,
                _pad: [0; 2],
            }
        })
        .collect();
    Setup {
        prims,
        reps,
        queries,
    }
}

struct Harness {
    /// The shaders' cut capacity (`GpuSamplerData::wgsl_for_cuts`).
    capacity: u32,
    layout0: wgpu::BindGroupLayout,
    layout1: wgpu::BindGroupLayout,
    sample: wgpu::ComputePipeline,
    cut: wgpu::ComputePipeline,
}

impl Harness {
    fn new(gpu: &Gpu) -> Harness {
        Self::with_capacity(gpu, MAX_CUT)
    }

    fn with_capacity(gpu: &Gpu, capacity: u32) -> Harness {
        let layout0 = gpu.bind_group_layout(
            "test.lights.layout0",
            &[
                storage_entry(0, true),
                storage_entry(1, false),
                storage_entry(2, true),
                storage_entry(3, false),
            ],
        );
        let layout1 =
            gpu.bind_group_layout("test.lights.layout1", &GpuSamplerData::layout_entries());
        let source: Wgsl = GpuSamplerData::wgsl_for_cuts(capacity)
            .part(("tests/kernels/light_sampler_probe.wgsl", KERNEL));
        let sample = gpu
            .compute_pipeline(
                "test.lights.sample",
                &source,
                "sample_main",
                &[&layout0, &layout1],
            )
            .unwrap();
        let cut = gpu
            .compute_pipeline(
                "test.lights.cut",
                &source,
                "cut_main",
                &[&layout0, &layout1],
            )
            .unwrap();
        Harness {
            capacity,
            layout0,
            layout1,
            sample,
            cut,
        }
    }

    /// Runs both kernels; returns the answers and, per block, the GPU cut.
    fn run(&self, gpu: &Gpu, data: &GpuSamplerData, s: &Setup) -> (Vec<Answer>, Vec<Vec<u32>>) {
        gpu.scoped("light sampler test", || {
            let queries = gpu.buffer_from("test.lights.queries", &s.queries, STORAGE)?;
            let answers = gpu.buffer_zeroed(
                "test.lights.answers",
                (QUERIES * size_of::<Answer>()) as u64,
                STORAGE,
            )?;
            let reps: Vec<Rep> = s
                .reps
                .iter()
                .map(|r| Rep {
                    p: r.p.into(),
                    n: r.n.into(),
                    ..Default::default()
                })
                .collect();
            let reps = gpu.buffer_from("test.lights.reps", &reps, STORAGE)?;
            let stride = self.capacity as usize + 1;
            let cut_words = BLOCKS as usize * stride;
            let cuts = gpu.buffer_zeroed("test.lights.cuts", 4 * cut_words as u64, STORAGE)?;
            let bind0 = mdas::gpu::shader::bind_buffers(
                gpu,
                "test.lights.bind0",
                &self.layout0,
                &[&queries, &answers, &reps, &cuts],
            );
            let bind1 = gpu.device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("test.lights.bind1"),
                layout: &self.layout1,
                entries: &data.bind_group_entries(),
            });
            let mut enc = gpu.device.create_command_encoder(&Default::default());
            {
                let mut pass = enc.begin_compute_pass(&Default::default());
                pass.set_bind_group(0, &bind0, &[]);
                pass.set_bind_group(1, &bind1, &[]);
                pass.set_pipeline(&self.sample);
                pass.dispatch_workgroups((QUERIES as u32).div_ceil(64), 1, 1);
                pass.set_pipeline(&self.cut);
                pass.dispatch_workgroups(BLOCKS.div_ceil(64), 1, 1);
            }
            gpu.queue.submit([enc.finish()]);
            let answers = gpu.read_buffer::<Answer>(&answers, QUERIES)?;
            let words = gpu.read_buffer::<u32>(&cuts, cut_words)?;
            let cuts = words
                .chunks(stride)
                .map(|c| c[..c[stride - 1] as usize].to_vec())
                .collect();
            Ok((answers, cuts))
        })
        .unwrap()
    }
}

fn shading(q: &Query) -> Shading {
    Shading {
        p: Vec3::from(q.p),
        n: Vec3::from(q.n),
    }
}

/// Compares GPU answers with the CPU samplers (`cpu` of the query's index).
fn compare<'a>(
    name: &str,
    answers: &[Answer],
    s: &Setup,
    cpu: &dyn Fn(u32) -> &'a dyn LightSampler,
) {
    let (mut boundary, mut picks) = (0, 0);
    for (i, (q, a)) in s.queries.iter().zip(answers).enumerate() {
        let sampler = cpu(i as u32);
        let sh = shading(q);
        let want = sampler.sample(&sh, q.u);
        let got_light = (a.light != NO_LIGHT).then_some(a.light);
        picks += got_light.is_some() as u32;
        if want.map(|w| w.light) != got_light {
            // A boundary case if the CPU reaches the GPU's pick within ±64 ulp.
            let near = (-64i32..=64).any(|k| {
                let u = f32::from_bits((q.u.to_bits() as i32 + k).max(0) as u32);
                u < 1.0 && sampler.sample(&sh, u).map(|w| w.light) == got_light
            });
            assert!(
                near,
                "{name}: query {i} (u = {}) CPU picks {want:?}, GPU {got_light:?}",
                q.u
            );
            boundary += 1;
        } else if let Some(w) = want {
            let g = pmf_value(a.pmf_m, a.pmf_e);
            assert!(
                rel_diff(w.pmf, g) < 1e-5,
                "{name}: query {i}: light {} pmf CPU {} GPU {g}",
                w.light,
                w.pmf
            );
        }
        if let Some(l) = got_light {
            // The GPU's own sample pmf and pmf query agree.
            let (g, p) = (
                pmf_value(a.pmf_m, a.pmf_e),
                pmf_value(a.sampled_m, a.sampled_e),
            );
            assert!(
                rel_diff(g, p) < 1e-6,
                "{name}: query {i}: light {l}: {g} vs {p}"
            );
            assert!(g > 0.0, "{name}: query {i}: GPU pmf 0");
        }
        let want_probe = sampler.pmf(&sh, q.probe);
        let got_probe = pmf_value(a.probe_m, a.probe_e);
        assert!(
            rel_diff(want_probe, got_probe) < 1e-5,
            "{name}: query {i}: pmf of light {}: CPU {want_probe} GPU {got_probe}",
            q.probe
        );
    }
    eprintln!("{name}: {picks} picks, {boundary} boundary cases of {QUERIES}");
    assert!(
        picks > QUERIES as u32 / 4,
        "{name}: too few picks to test anything"
    );
    assert!(
        boundary * 200 <= QUERIES,
        "{name}: {boundary} boundary cases"
    );
}

fn cut_layout() -> CutLayout {
    CutLayout {
        cut_size: CUT_SIZE,
        block_size: 8,
        blocks_per_row: BLOCKS,
        block_rows: 1,
        interleave: 1,
        frame: 0,
        sampling: CutSampling::Subtrees,
    }
}

/// Uploads the CPU cuts of every block; returns them.
fn upload_cpu_cuts<T: LightTree>(
    gpu: &Gpu,
    data: &GpuSamplerData,
    tree: &T,
    importance: Importance,
    s: &Setup,
) -> Vec<Vec<u32>> {
    let cuts: Vec<_> = s
        .reps
        .iter()
        .map(|r| select_cut(tree, importance, r, CUT_SIZE))
        .collect();
    let mut flat = vec![NO_LIGHT; (BLOCKS * CUT_SIZE) as usize];
    for (b, c) in cuts.iter().enumerate() {
        flat[b * CUT_SIZE as usize..][..c.len()].copy_from_slice(c);
    }
    data.write_cuts(gpu, &flat).unwrap();
    cuts
}

/// GPU cuts equal the CPU's except where near-equal keys may order
/// differently: at most 2 blocks of 64.
fn compare_cuts(name: &str, gpu_cuts: &[Vec<u32>], cpu_cuts: &[Vec<u32>]) {
    let differ = gpu_cuts
        .iter()
        .zip(cpu_cuts)
        .filter(|(g, c)| g != c)
        .count();
    eprintln!("{name}: {differ} of {BLOCKS} GPU cuts differ from the CPU's");
    assert!(differ <= 2, "{name}: {differ} cuts differ");
}

/// The CPU samplers of a tree kind, one per block (its CPU cuts uploaded to
/// `data`) or one from the root.
fn tree_samplers<T: LightTree + Clone>(
    gpu: &Gpu,
    data: &GpuSamplerData,
    tree: &T,
    s: &Setup,
) -> Vec<TreeSampler<T>> {
    let imp = data.kind.importance();
    if !data.kind.uses_cut() {
        return vec![TreeSampler::new(tree.clone(), imp)];
    }
    upload_cpu_cuts(gpu, data, tree, imp, s)
        .into_iter()
        .map(|c| TreeSampler::with_cut(tree.clone(), imp, c))
        .collect()
}

/// Subtree `j` of a cut sampler, the paper's estimator's draw
/// ([`TreeSampler::sample_subtree`], the GPU's `light_sample_subtree`); the
/// pmf of a light is its probability within its own subtree, whichever
/// that is (`subtree_pmf`, `light_pmf_subtree`).
struct Subtree<'a, T: LightTree> {
    sampler: &'a TreeSampler<T>,
    j: usize,
}

impl<T: LightTree> LightSampler for Subtree<'_, T> {
    fn sample(&self, s: &Shading, u: f32) -> Option<LightSample> {
        (self.j < self.sampler.cut.len())
            .then(|| self.sampler.sample_subtree(s, self.j, u))
            .flatten()
    }

    fn pmf(&self, s: &Shading, light: u32) -> f64 {
        self.sampler.subtree_pmf(s, light).map_or(0.0, |(_, p)| p)
    }
}

/// The paper's cut estimator on the GPU against the CPU: query i draws
/// from subtree `(i / BLOCKS) mod CUT_SIZE` of its block's cut (`samplers`,
/// one per block, whose cuts `data` holds), and queries the pmfs within
/// subtrees.
fn check_subtrees<T: LightTree>(
    gpu: &Gpu,
    h: &Harness,
    name: &str,
    data: &GpuSamplerData,
    samplers: &[TreeSampler<T>],
    s: &Setup,
) {
    let views: Vec<Subtree<T>> = (0..QUERIES as u32)
        .map(|i| Subtree {
            sampler: &samplers[(i % BLOCKS) as usize],
            j: (i / BLOCKS % CUT_SIZE) as usize,
        })
        .collect();
    let mut subtrees = s.clone();
    for (i, q) in subtrees.queries.iter_mut().enumerate() {
        q.subtree = i as u32 / BLOCKS % CUT_SIZE;
    }
    let (answers, _) = h.run(gpu, data, &subtrees);
    let cpu = |i: u32| -> &dyn LightSampler { &views[i as usize] };
    compare(
        &format!("{name}, one light per subtree"),
        &answers,
        &subtrees,
        &cpu,
    );
}

/// Runs the probes of `data` and compares them with the CPU over `tree`:
/// samples, pmfs and (kinds with cuts) the GPU's own cut selection.
fn check_kind<T: LightTree + Clone + 'static>(
    gpu: &Gpu,
    h: &Harness,
    name: &str,
    data: &GpuSamplerData,
    tree: &T,
    s: &Setup,
) {
    let samplers = tree_samplers(gpu, data, tree, s);
    let (answers, gpu_cuts) = h.run(gpu, data, s);
    let cpu = |i: u32| -> &dyn LightSampler { &samplers[(i % BLOCKS) as usize % samplers.len()] };
    compare(name, &answers, s, &cpu);
    if data.kind.uses_cut() && s.prims.len() >= 4 * CUT_SIZE as usize {
        check_subtrees(gpu, h, name, data, &samplers, s);
    }
    if data.kind.uses_cut() {
        let imp = data.kind.importance();
        let want: Vec<_> = s
            .reps
            .iter()
            .map(|r| select_cut(tree, imp, r, CUT_SIZE))
            .collect();
        compare_cuts(name, &gpu_cuts, &want);
    } else {
        assert!(gpu_cuts.iter().all(|c| c == &[0]), "{name}: {gpu_cuts:?}");
    }
}

#[test]
fn gpu_samplers_match_the_cpu() {
    let gpu = common::gpu();
    let h = Harness::new(gpu);
    check_every_kind(gpu, &h, &[(1, 1), (2, 5), (3, 300)]);
}

/// The shaders as a scene builds them, with cut arrays sized for its cuts
/// (`cut_capacity`) rather than for 64 nodes, sample exactly as the CPU.
#[test]
fn gpu_samplers_with_tight_cut_arrays_match_the_cpu() {
    assert_eq!(cut_capacity(CUT_SIZE), CUT_SIZE);
    let gpu = common::gpu();
    let h = Harness::with_capacity(gpu, cut_capacity(CUT_SIZE));
    check_every_kind(gpu, &h, &[(4, 300)]);
}

#[test]
fn cut_capacity_is_the_next_power_of_two_up_to_max_cut() {
    let want = [
        (0, 1),
        (1, 1),
        (3, 4),
        (8, 8),
        (9, 16),
        (33, 64),
        (64, 64),
        (65, 64),
    ];
    for (size, capacity) in want {
        assert_eq!(cut_capacity(size), capacity, "cut_size {size}");
    }
}

/// Every picking kind on lights from each `(seed, count)`: samples, pmfs
/// and cuts against the CPU.
fn check_every_kind(gpu: &Gpu, h: &Harness, cases: &[(u64, usize)]) {
    for &(seed, n) in cases {
        let s = setup(seed, n);
        let tree = perfect::build(&s.prims).unwrap();
        for kind in SamplerKind::PICKERS {
            let name = format!("{kind} ({n} lights)");
            let technique = matches!(kind.structure(), Structure::Technique(_));
            if technique && kind.uses_substitute_tree() {
                // The radix substitute tree builds its own tree on upload:
                // the same as this one.
                let t = substitute::radix::build(&s.prims).unwrap();
                let data = GpuSamplerData::new(gpu, kind, &s.prims, None, cut_layout()).unwrap();
                check_substitutes(gpu, h, &name, &data, &t, &s, 0);
            } else if technique {
                // Any other technique built on the CPU: against its own
                // CPU sampler (from the root; cuts would need their check).
                assert!(
                    !kind.uses_cut(),
                    "{kind}: a technique with cuts needs its check here"
                );
                let data = GpuSamplerData::new(gpu, kind, &s.prims, None, cut_layout()).unwrap();
                let sampler = new_sampler(kind, &s.prims, None);
                let (answers, gpu_cuts) = h.run(gpu, &data, &s);
                compare(&name, &answers, &s, &|_| {
                    sampler.as_ref() as &dyn LightSampler
                });
                assert!(gpu_cuts.iter().all(|c| c == &[0]), "{name}: {gpu_cuts:?}");
            } else if kind.uses_substitute_tree() {
                let t = substitute::build(&s.prims).unwrap();
                let source = Some(TreeSource::Substitute(&t));
                let data = GpuSamplerData::new(gpu, kind, &s.prims, source, cut_layout()).unwrap();
                check_substitutes(gpu, h, &name, &data, &t, &s, 0);
            } else if kind.uses_bvh() {
                let bvh = if kind == SamplerKind::Tree2 {
                    // Three groups of lights (empty ones for n < 3).
                    let groups: Vec<_> = (0..3)
                        .map(|i| (i * n / 3) as u32..((i + 1) * n / 3) as u32)
                        .collect();
                    two_level::build(&s.prims, &groups).unwrap()
                } else {
                    bvh::build(&s.prims, kind.bvh_cost()).unwrap()
                };
                let source = Some(TreeSource::Bvh(&bvh));
                let data = GpuSamplerData::new(gpu, kind, &s.prims, source, cut_layout()).unwrap();
                check_kind(gpu, h, &name, &data, &bvh, &s);
            } else if kind.uses_perfect_tree() {
                let source = Some(TreeSource::Perfect(&tree));
                let data = GpuSamplerData::new(gpu, kind, &s.prims, source, cut_layout()).unwrap();
                check_kind(gpu, h, &name, &data, &tree, &s);
            } else {
                let data = GpuSamplerData::new(gpu, kind, &s.prims, None, cut_layout()).unwrap();
                let sampler: Box<dyn LightSampler> = match kind {
                    SamplerKind::Uniform => Box::new(UniformSampler { count: n as u32 }),
                    _ => Box::new(PowerSampler::new(&s.prims)),
                };
                let (answers, gpu_cuts) = h.run(gpu, &data, &s);
                compare(&name, &answers, &s, &|_| sampler.as_ref());
                assert!(gpu_cuts.iter().all(|c| c.is_empty()), "{name}");
            }
        }
    }
}

/// The perfect-tree kinds on the GPU-built tree. The nodes equal the CPU
/// oracle's bit for bit; the cones are the GPU's own (within a tolerance of
/// the oracle's, `tests/light_tree_gpu.rs`), so the CPU samples with the
/// GPU's cones read back.
#[test]
fn gpu_built_tree_samples_like_the_cpu_tree() {
    let gpu = common::gpu();
    let h = Harness::new(gpu);
    let s = setup(4, 1000);
    let n = s.prims.len() as u32;
    let mut built = GpuLightTree::new(gpu, n, true).unwrap();
    let prims = gpu
        .buffer_from("test.lights.prims", &s.prims, STORAGE)
        .unwrap();
    built
        .build(gpu, &prims, n, &mut Profiler::new(gpu))
        .unwrap();
    let mut tree = perfect::build(&s.prims).unwrap();
    tree.cones = gpu
        .read_buffer::<LightCone>(built.cones.as_ref().unwrap(), tree.nodes.len())
        .unwrap();
    for kind in [
        SamplerKind::TreeNoCut,
        SamplerKind::Tree,
        SamplerKind::TreeCone,
    ] {
        let source = TreeSource::PerfectGpu {
            nodes: &built.nodes,
            leaf_of_light: &built.leaf_of_light,
            cones: built.cones.as_ref(),
            substitutes: None,
        };
        let data = GpuSamplerData::new(gpu, kind, &s.prims, Some(source), cut_layout()).unwrap();
        let name = format!("{kind} on the GPU-built tree");
        check_kind(gpu, &h, &name, &data, &tree, &s);
    }
}

/// `tree2` gathered on the GPU (`GpuTwoLevel`, bound as it is) samples
/// like the CPU sampler over `BottomLevels::tree`'s tree, whose nodes and
/// links the GPU's equal bit for bit (`tests/light_tree_gpu.rs`); the CPU
/// samples with the GPU's cones read back, as for the perfect tree above.
#[test]
fn gpu_gathered_two_level_tree_samples_like_the_cpu_tree() {
    let gpu = common::gpu();
    let h = Harness::new(gpu);
    let s = setup(5, 1000);
    // Four groups, one of them a lone light.
    let groups = vec![0..400u32, 400..401, 401..750, 750..1000];
    let object: Vec<Option<&[LightPrim]>> = groups
        .iter()
        .map(|g| Some(&s.prims[g.start as usize..g.end as usize]))
        .collect();
    let bottoms = two_level::BottomLevels::new(groups.clone(), &object);
    let built = GpuTwoLevel::new(gpu, bottoms.gpu_plan().unwrap()).unwrap();
    let kind = SamplerKind::Tree2;
    let data = GpuSamplerData::new(
        gpu,
        kind,
        &s.prims,
        Some(TreeSource::TwoLevelGpu(&built)),
        cut_layout(),
    )
    .unwrap();
    built
        .build(gpu, &data.prims, &mut Profiler::new(gpu))
        .unwrap();
    let mut tree = bottoms.tree(&s.prims).unwrap();
    let nodes: Vec<TreeNode> = gpu.read_buffer(&built.nodes, tree.nodes.len()).unwrap();
    assert!(nodes == tree.nodes, "the GPU's nodes equal the CPU's");
    tree.cones = gpu
        .read_buffer::<LightCone>(&built.cones, tree.nodes.len())
        .unwrap();
    check_kind(gpu, &h, "tree2 gathered on the GPU", &data, &tree, &s);
}

#[test]
fn zero_lights_sample_nothing_on_the_gpu() {
    let gpu = common::gpu();
    let h = Harness::new(gpu);
    let mut s = setup(5, 1);
    s.prims.clear();
    for q in &mut s.queries {
        q.probe = 0;
    }
    for kind in SamplerKind::PICKERS {
        let data = GpuSamplerData::new(gpu, kind, &[], None, cut_layout()).unwrap();
        let (answers, cuts) = h.run(gpu, &data, &s);
        assert!(
            answers
                .iter()
                .all(|a| a.light == NO_LIGHT && a.probe_m == 0.0),
            "{kind}"
        );
        assert!(cuts.iter().all(|c| c.is_empty()), "{kind}");
    }
}

/// `sst`, `sst_nosub` and `sst_perfect` as the GPU answers: a stop at a
/// leaf is its light, a stop at a substitute `SUBSTITUTE_BIT | node`.
struct StopCodes<T: SubstituteLayout>(SstSampler<T>);

impl<T: SubstituteLayout> LightSampler for StopCodes<T> {
    fn sample(&self, s: &Shading, u: f32) -> Option<LightSample> {
        let stop = self.0.sample(s, u)?;
        let t = &self.0.tree;
        let light = if t.children(stop.node).is_none() {
            t.leaf_light(stop.node)
        } else {
            SUBSTITUTE_BIT | stop.node as u32
        };
        Some(LightSample {
            light,
            pmf: stop.pmf,
        })
    }
    fn pmf(&self, s: &Shading, light: u32) -> f64 {
        LightSampler::pmf(&self.0, s, light)
    }
}

/// The GPU's `sst`/`sst_nosub` picks against the CPU's; at least
/// `min_substitutes` of them must be substitutes (so the test exercises
/// them).
fn check_substitutes<T: SubstituteLayout + Clone>(
    gpu: &Gpu,
    h: &Harness,
    name: &str,
    data: &GpuSamplerData,
    tree: &T,
    s: &Setup,
    min_substitutes: usize,
) {
    let cpu = StopCodes(SstSampler {
        tree: tree.clone(),
        params: data
            .kind
            .stops_at_substitutes()
            .then(SubstituteParams::default),
    });
    let (answers, gpu_cuts) = h.run(gpu, data, s);
    compare(name, &answers, s, &|_| &cpu as &dyn LightSampler);
    assert!(gpu_cuts.iter().all(|c| c == &[0]), "{name}: {gpu_cuts:?}");
    let subs = answers
        .iter()
        .filter(|a| a.light != NO_LIGHT && a.light & SUBSTITUTE_BIT != 0)
        .count();
    eprintln!("{name}: {subs} substitute picks");
    assert!(subs >= min_substitutes, "{name}: {subs} substitute picks");
    if !data.kind.stops_at_substitutes() {
        assert_eq!(subs, 0, "{name}");
    }
}

/// The substitute tree built on the GPU: nodes and leaf order bit for bit
/// the CPU's (sorted by Morton code, then normal code, then id); the
/// substitutes within a relative 1e-5 of the oracle's (their merges divide
/// and take square roots, which WGSL does not round exactly); and `sst`
/// on it samples like the CPU over the GPU's own substitutes; and the
/// radix tree of `sst` and `sst_nosub` (built on the CPU) samples on the
/// GPU as on the CPU.
#[test]
fn gpu_substitute_trees_match_the_cpu() {
    let gpu = common::gpu();
    let h = Harness::new(gpu);
    let mut rng = StdRng::seed_from_u64(9);
    let prims = vpl_walls(&mut rng, 3000);
    let s = setup_prims(rng, prims);
    let n = s.prims.len() as u32;
    let mut built = GpuLightTree::with_substitutes(gpu, n).unwrap();
    let prims = gpu
        .buffer_from("test.lights.prims", &s.prims, STORAGE)
        .unwrap();
    built
        .build(gpu, &prims, n, &mut Profiler::new(gpu))
        .unwrap();
    let mut oracle = substitute::build(&s.prims).unwrap();
    let count = oracle.tree.nodes.len();
    let nodes = gpu.read_buffer::<TreeNode>(&built.nodes, count).unwrap();
    let ids = gpu
        .read_buffer::<u32>(&built.sorted_ids, n as usize)
        .unwrap();
    assert_eq!(ids, oracle.tree.sorted, "leaf order");
    if let Some(i) = (0..count).find(|&i| nodes[i] != oracle.tree.nodes[i]) {
        panic!(
            "GPU node {i} differs from the oracle's: {:?} vs {:?}",
            nodes[i], oracle.tree.nodes[i]
        );
    }
    let leaf_of_light = gpu
        .read_buffer::<u32>(&built.leaf_of_light, n as usize)
        .unwrap();
    assert_eq!(leaf_of_light, oracle.tree.leaf_of_light);
    let subs = gpu
        .read_buffer::<Substitute>(built.substitutes.as_ref().unwrap(), count)
        .unwrap();
    let mut worst = 0.0f32;
    for (i, (g, c)) in subs.iter().zip(&oracle.substitutes).enumerate() {
        let ga: [f32; 16] = bytemuck::cast(*g);
        let ca: [f32; 16] = bytemuck::cast(*c);
        // Words: mean 0–2, ν 3, normal 4–6, covariances 7–11 and 15,
        // emission 12–14.
        let scale = |k: usize, c: f32| match k {
            0..=2 => 10.0,
            3..=6 => 1.0,
            12..=14 => c.abs().max(1.0),
            _ => 100.0,
        };
        for k in 0..16 {
            let d = (ga[k] - ca[k]).abs() / scale(k, ca[k]);
            worst = worst.max(d);
            assert!(d < 1e-5, "node {i} word {k}: GPU {} CPU {}", ga[k], ca[k]);
        }
    }
    eprintln!("largest scaled substitute difference GPU/CPU: {worst:e}");
    oracle.tree.cones = gpu
        .read_buffer::<LightCone>(built.cones.as_ref().unwrap(), count)
        .unwrap();
    oracle.substitutes = subs;
    // sst_perfect, the one kind over this tree.
    let kind = SamplerKind::SstPerfect;
    let source = TreeSource::PerfectGpu {
        nodes: &built.nodes,
        leaf_of_light: &built.leaf_of_light,
        cones: built.cones.as_ref(),
        substitutes: built.substitutes.as_ref(),
    };
    let data = GpuSamplerData::new(gpu, kind, &s.prims, Some(source), cut_layout()).unwrap();
    let name = format!("{kind} on the GPU-built substitute tree");
    check_substitutes(gpu, &h, &name, &data, &oracle, &s, QUERIES / 10);
    // sst and sst_nosub over the radix tree of the same walls: sst must
    // stop at substitutes as often.
    let radix = substitute::radix::build(&s.prims).unwrap();
    for kind in [SamplerKind::Sst, SamplerKind::SstNoSub] {
        let data = GpuSamplerData::new(gpu, kind, &s.prims, None, cut_layout()).unwrap();
        let min = if kind.stops_at_substitutes() {
            QUERIES / 10
        } else {
            0
        };
        check_substitutes(
            gpu,
            &h,
            &format!("{kind} (radix tree)"),
            &data,
            &radix,
            &s,
            min,
        );
    }
}
