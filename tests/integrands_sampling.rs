//! Chi-square goodness-of-fit of the integrands' sampling routines, run
//! in WGSL on the GPU (tests/kernels/sampling_warps.wgsl) on independent
//! uniform inputs from a fixed-seed CPU generator:
//!
//! - the thin lens: `camera_ray`'s lens point (concentric disk map),
//!   uniform on the disk of the aperture radius;
//! - the shutter: `shutter_time`, uniform on [shutter_open, shutter_close);
//! - `sample_cosine_hemisphere` in the frame `frame_from_normal(n)`,
//!   density cosθ/π around n, for several normals (including n = −z, where
//!   the frame construction switches branch);
//! - `sample_emitter` (area lights): triangle pmf ∝ luminance(L_e)·area,
//!   uniform within each triangle, and the returned pdf_area equal to the
//!   independently computed pmf/area.
//!
//! Cells are chosen to have exactly known probabilities (equal-area rings
//! × sectors of the disk; cos²θ × φ cells of the hemisphere, as
//! P(cosθ ≥ c) = 1 − c² under the cosine density; 4² congruent
//! sub-triangles per triangle). Cells with expected count < 5 are pooled
//! (as in pbrt-v4's chi-square test).
//!
//! Statistics, fixed before the seeds were run: each case draws
//! [`SEEDS`] = 20 independent batches of [`SAMPLES`] inputs, batch k of
//! case c from the seed 1000·c + k (cases 1 lens, 2 shutter, 3 emitter,
//! 4–7 the cosine hemisphere's normals). Each batch gives a chi-square
//! p-value; under a correct sampler the 20 p-values are uniform on [0, 1],
//! which a Kolmogorov–Smirnov test checks (`stats::ks_uniform`). A case
//! fails when the KS p-value is below α_i = 1 − (1 − α)^{1/T}, α = 1 % over
//! all T = 7 cases (Šidák): a correct implementation fails this file with
//! probability 1 %. One seed per case could not keep that α; twenty make a
//! distribution of p-values, not one draw of it.

mod common;
mod stats;

use common::gpu;
use glam::Vec3;
use mdas::accel::{BuiltScene, GpuScene};
use mdas::gpu::shader::{bind_buffers, storage_entry, uniform_entry};
use mdas::integrand::scene_wgsl;
use mdas::scene_file;
use mdas::scene_file::SceneFile;
use rand::rngs::StdRng;
use rand::{RngExt, SeedableRng};
use stats::gamma_q;
use std::f64::consts::PI;
use std::path::Path;

const ALPHA: f64 = 0.01;
const TESTS: f64 = 7.0;
/// Inputs per batch.
const SAMPLES: usize = 50_000;
/// Batches (seeds) per case.
const SEEDS: usize = 20;

fn alpha_each() -> f64 {
    1.0 - (1.0 - ALPHA).powf(1.0 / TESTS)
}

const SCENE: &str = r#"
[film]
width = 16
height = 12
[camera]
position = [0.3, 1, 4]
look_at = [0, 0.2, 0]
up = [0, 1, 0]
fov_y = 40
aperture_radius = 0.5
focus_distance = 3
shutter_open = 0.25
shutter_close = 2
[[material]]
name = "warm"
albedo = [0, 0, 0]
emission = [1, 2, 0.5]
[[shape]]
type = "triangle"
material = "warm"
vertices = [[0, 0, 0], [2, 0, 0], [0, 1, 0.5]]
[[light]]
type = "quad"
corners = [[-1, 2, -1], [0, 2, -1], [0, 2, 0], [-1, 2, 0]]
radiance = [5, 5, 5]
[[light]]
type = "quad"
corners = [[1, 3, 1], [1, 3, 2.5], [3, 3, 2.5], [3, 3, 1]]
radiance = [0.5, 0.25, 0.5]
"#;

fn test_scene() -> SceneFile {
    scene_file::parse(SCENE, Path::new("warps.toml")).unwrap()
}

#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct WarpParams {
    normal: [f32; 3],
    count: u32,
}

/// The inputs of case `case`: [`SEEDS`] batches of [`SAMPLES`], batch k
/// from the seed 1000·case + k. Output i belongs to batch i / SAMPLES.
fn uniforms(case: u64) -> Vec<[f32; 2]> {
    (0..SEEDS as u64)
        .flat_map(|k| {
            let mut rng = StdRng::seed_from_u64(1000 * case + k);
            (0..SAMPLES).map(move |_| [rng.random::<f32>(), rng.random::<f32>()])
        })
        .collect()
}

/// Per-batch counts over `cells` cells.
fn batch_counts(cells: usize) -> Vec<Vec<u64>> {
    vec![vec![0u64; cells]; SEEDS]
}

/// Runs warp `warp` of the kernel on `inputs`: two vec4 per input.
fn run_warp(warp: u32, normal: Vec3, inputs: &[[f32; 2]]) -> Vec<[[f32; 4]; 2]> {
    let gpu = gpu();
    let scene = test_scene();
    let gpu_scene = GpuScene::new(gpu, &scene.scene, scene.scene.film).unwrap();
    let layout = gpu.bind_group_layout(
        "test.warps.layout",
        &[
            uniform_entry(0),
            storage_entry(1, true),
            storage_entry(2, false),
        ],
    );
    let source = scene_wgsl().constant("WARP", warp).part((
        "tests/kernels/sampling_warps.wgsl",
        include_str!("kernels/sampling_warps.wgsl"),
    ));
    let pipeline = gpu
        .compute_pipeline("test.warps", &source, "main", &[&layout, &gpu_scene.layout])
        .unwrap();
    let params = gpu.uniform(
        "test.warps.params",
        &WarpParams {
            normal: normal.normalize().into(),
            count: inputs.len() as u32,
        },
    );
    let usage = mdas::gpu::buffer::STORAGE;
    let input = gpu.buffer_from("test.warps.inputs", inputs, usage).unwrap();
    let output = gpu
        .buffer_zeroed("test.warps.outputs", 32 * inputs.len() as u64, usage)
        .unwrap();
    let group = bind_buffers(gpu, "test.warps", &layout, &[&params, &input, &output]);
    gpu.scoped("warp test kernel", || {
        let mut encoder = gpu.device.create_command_encoder(&Default::default());
        {
            let mut pass = encoder.begin_compute_pass(&Default::default());
            pass.set_pipeline(&pipeline);
            pass.set_bind_group(0, &group, &[]);
            pass.set_bind_group(1, &gpu_scene.bind_group, &[]);
            pass.dispatch_workgroups((inputs.len() as u32).div_ceil(64), 1, 1);
        }
        gpu.queue.submit([encoder.finish()]);
        Ok(())
    })
    .unwrap();
    gpu.read_buffer(&output, inputs.len()).unwrap()
}

// ------------------------------------------------------------ statistics

/// The chi-square p-value of every batch's counts against the cell
/// probabilities (cells with expected count < 5 pooled), and the
/// Kolmogorov–Smirnov test of those p-values against uniform: asserts its
/// p-value ≥ α_i (module docs) and returns it.
fn chi_square(name: &str, batches: &[Vec<u64>], probability: &[f64]) -> f64 {
    assert_eq!(batches.len(), SEEDS);
    let ps: Vec<f64> = batches
        .iter()
        .map(|observed| chi_square_p(name, observed, probability).2)
        .collect();
    let (d, p) = stats::ks_uniform(&ps);
    let min = ps.iter().copied().fold(1.0, f64::min);
    println!("{name}: {SEEDS} batches, smallest χ² p {min:.3}, KS D = {d:.3}, p = {p:.3}");
    assert!(
        p >= alpha_each(),
        "{name}: the batches' χ² p-values are not uniform (KS D = {d:.3}, p = {p:.2e} < α = {:.2e}; p-values {ps:.3?})",
        alpha_each()
    );
    p
}

/// (χ², degrees of freedom, p-value) with pooling as above.
fn chi_square_p(name: &str, observed: &[u64], probability: &[f64]) -> (f64, i64, f64) {
    assert_eq!(observed.len(), probability.len());
    let total: u64 = observed.iter().sum();
    let n = total as f64;
    let mut cells: Vec<(f64, f64)> = observed
        .iter()
        .zip(probability)
        .map(|(&o, &p)| (p * n, o as f64))
        .collect();
    for (e, o) in &cells {
        assert!(
            *e > 0.0 || *o == 0.0,
            "{name}: {o} samples in a cell of probability 0"
        );
    }
    cells.sort_by(|a, b| a.0.total_cmp(&b.0));
    let (mut chi2, mut dof, mut pool_e, mut pool_o) = (0.0, 0i64, 0.0, 0.0);
    for (e, o) in cells {
        if e == 0.0 {
            continue;
        }
        if e < 5.0 || pool_e > 0.0 && pool_e < 5.0 {
            pool_e += e;
            pool_o += o;
            continue;
        }
        chi2 += (o - e) * (o - e) / e;
        dof += 1;
    }
    if pool_e > 0.0 {
        chi2 += (pool_o - pool_e) * (pool_o - pool_e) / pool_e;
        dof += 1;
    }
    let dof = dof - 1;
    (chi2, dof, gamma_q(dof as f64 / 2.0, chi2 / 2.0))
}

#[test]
fn chi_square_helper_matches_known_quantiles() {
    // The KS helper at the tabulated 5 % point for n = 20 (D = 0.29408),
    // and for a perfectly uniform and a degenerate sample.
    let even: Vec<f64> = (0..20).map(|i| (i as f64 + 0.5) / 20.0).collect();
    assert!((stats::ks_uniform(&even).1 - 1.0).abs() < 1e-12);
    let mut at_5 = vec![0.0; 20];
    // 20 points with D = 0.29408 exactly: the first 6 at 0, the rest spread
    // over (0.3, 1) so that F_n − F peaks at 6/20 − 0.00592.
    for (i, x) in at_5.iter_mut().enumerate() {
        *x = if i < 6 {
            0.00592
        } else {
            0.3 + 0.7 * (i as f64 - 5.5) / 14.5
        };
    }
    let (d, p) = stats::ks_uniform(&at_5);
    assert!((d - 0.29408).abs() < 1e-9, "D = {d}");
    assert!((p - 0.05).abs() < 0.002, "p = {p}");
    assert!(stats::ks_uniform(&[0.0; 20]).1 < 1e-9);
    // Q(k/2, x/2) at tabulated chi-square critical values.
    assert!((gamma_q(0.5, 3.841_458_820_694_124 / 2.0) - 0.05).abs() < 1e-9);
    assert!((gamma_q(5.0, 23.209_251_158_954_36 / 2.0) - 0.01).abs() < 1e-9);
    // Even degrees of freedom have closed forms: Q(1, x) = e^−x and
    // Q(5, x) = e^−x·Σ_{k<5} x^k/k! (both branches of gamma_q).
    assert!((gamma_q(1.0, 10.0) - (-10f64).exp()).abs() < 1e-15);
    assert!((gamma_q(5.0, 2.0) - 7.0 * (-2f64).exp()).abs() < 1e-12);
}

// ------------------------------------------------------------------ tests

const RINGS: usize = 8;
const SECTORS: usize = 16;

/// Cell of a disk point (unit radius): equal-area rings × sectors.
fn disk_cell(x: f64, y: f64) -> usize {
    let r2 = (x * x + y * y).min(1.0 - 1e-12);
    let ring = ((r2 * RINGS as f64) as usize).min(RINGS - 1);
    let phi = y.atan2(x).rem_euclid(2.0 * PI);
    let sector = ((phi / (2.0 * PI) * SECTORS as f64) as usize).min(SECTORS - 1);
    ring * SECTORS + sector
}

#[test]
fn thin_lens_samples_are_uniform_on_the_aperture() {
    let out = run_warp(0, Vec3::Z, &uniforms(1));
    let mut counts = batch_counts(RINGS * SECTORS);
    for (i, o) in out.iter().enumerate() {
        let (x, y) = (o[0][0] as f64, o[0][1] as f64);
        assert!(
            x * x + y * y <= 1.0 + 1e-5,
            "lens point ({x}, {y}) outside the aperture"
        );
        counts[i / SAMPLES][disk_cell(x, y)] += 1;
    }
    chi_square(
        "lens",
        &counts,
        &vec![1.0 / (RINGS * SECTORS) as f64; RINGS * SECTORS],
    );
}

#[test]
fn shutter_times_are_uniform_over_the_shutter() {
    let (open, close) = (0.25f64, 2.0f64);
    let out = run_warp(1, Vec3::Z, &uniforms(2));
    let bins = 64;
    let mut counts = batch_counts(bins);
    for (i, o) in out.iter().enumerate() {
        let t = o[0][0] as f64;
        assert!(
            (open..close + 1e-6).contains(&t),
            "time {t} outside the shutter"
        );
        let b = (((t - open) / (close - open)) * bins as f64) as usize;
        counts[i / SAMPLES][b.min(bins - 1)] += 1;
    }
    chi_square("shutter", &counts, &vec![1.0 / bins as f64; bins]);
}

#[test]
fn cosine_hemisphere_has_density_cos_over_pi_around_any_normal() {
    let normals = [
        Vec3::Y,
        Vec3::NEG_Z,
        Vec3::new(0.3, -0.5, 0.8),
        Vec3::new(-1.0, 0.0, -1e-3),
    ];
    for (k, n) in normals.iter().enumerate() {
        let n = n.normalize();
        let out = run_warp(2, n, &uniforms(4 + k as u64));
        // Our own frame around n: the distribution is symmetric about n,
        // so any frame gives equally likely φ sectors.
        let helper = if n.x.abs() < 0.9 { Vec3::X } else { Vec3::Y };
        let t = n.cross(helper).normalize();
        let b = n.cross(t);
        let mut counts = batch_counts(RINGS * SECTORS);
        for (i, o) in out.iter().enumerate() {
            let w = Vec3::new(o[0][0], o[0][1], o[0][2]);
            assert!((w.length() - 1.0).abs() < 1e-4, "|ω| = {}", w.length());
            let cos = w.dot(n) as f64;
            assert!(cos >= -1e-5, "direction below the surface: cosθ = {cos}");
            let cos2 = cos.clamp(0.0, 1.0).powi(2);
            let ring = ((cos2 * RINGS as f64) as usize).min(RINGS - 1);
            let phi = (w.dot(b) as f64)
                .atan2(w.dot(t) as f64)
                .rem_euclid(2.0 * PI);
            let sector = ((phi / (2.0 * PI) * SECTORS as f64) as usize).min(SECTORS - 1);
            counts[i / SAMPLES][ring * SECTORS + sector] += 1;
        }
        chi_square(
            &format!("cosine hemisphere around {n}"),
            &counts,
            &vec![1.0 / (RINGS * SECTORS) as f64; RINGS * SECTORS],
        );
        // Power check: one batch must reject the uniform hemisphere
        // (P(cosθ < c) = c), whose ring probabilities differ by ≤ 2×.
        let uniform: Vec<f64> = (0..RINGS * SECTORS)
            .map(|c| {
                let ring = (c / SECTORS) as f64;
                (((ring + 1.0) / RINGS as f64).sqrt() - (ring / RINGS as f64).sqrt())
                    / SECTORS as f64
            })
            .collect();
        let (_, _, p) = chi_square_p("uniform hemisphere", &counts[0], &uniform);
        assert!(
            p < 1e-9,
            "the test cannot tell cosine from uniform: p = {p}"
        );
    }
}

/// Sub-triangle cell (of SUB² congruent ones) of barycentrics (b1, b2);
/// None if the point is outside the triangle.
const SUB: usize = 4;

fn sub_triangle(b1: f64, b2: f64) -> Option<usize> {
    if b1 < -1e-4 || b2 < -1e-4 || b1 + b2 > 1.0 + 1e-4 {
        return None;
    }
    let (a, c) = (
        b1.clamp(0.0, 1.0) * SUB as f64,
        b2.clamp(0.0, 1.0) * SUB as f64,
    );
    let (i, j) = ((a as usize).min(SUB - 1), (c as usize).min(SUB - 1));
    let (i, j) = if i + j > SUB - 1 {
        // On the hypotenuse up to rounding: the last upward cell of the row.
        (i, SUB - 1 - i)
    } else {
        (i, j)
    };
    let up = a - i as f64 + (c - j as f64) <= 1.0 || i + j == SUB - 1;
    // Upward cells: i + j ≤ SUB − 1; downward cells: i + j ≤ SUB − 2.
    Some((i * SUB + j) * 2 + usize::from(!up))
}

#[test]
fn emitter_samples_follow_power_times_area_and_are_uniform_on_each_triangle() {
    let scene = test_scene();
    let built = BuiltScene::new(&scene.scene).unwrap();
    // The emissive triangles and their probabilities, computed here.
    let lum = |c: Vec3| c.dot(Vec3::new(0.2126, 0.7152, 0.0722)) as f64;
    let mut tris: Vec<(u32, [Vec3; 3], f64, f64)> = Vec::new(); // prim, vertices, weight, area
    for prim in 0..built.triangle_count() {
        let le = scene.scene.materials[built.triangle_material(prim) as usize].emission;
        if le.max_element() > 0.0 {
            let v = built.triangle_world(prim, 0.0);
            let area = 0.5 * (v[1] - v[0]).cross(v[2] - v[0]).length() as f64;
            tris.push((prim, v, lum(le) * area, area));
        }
    }
    assert_eq!(tris.len(), 5);
    let total: f64 = tris.iter().map(|t| t.2).sum();

    let out = run_warp(3, Vec3::Z, &uniforms(3));
    let cells_per = SUB * SUB * 2;
    let mut counts = batch_counts(tris.len() * cells_per);
    let mut probability = vec![0.0; tris.len() * cells_per];
    for (t, tri) in tris.iter().enumerate() {
        for i in 0..SUB {
            for j in 0..SUB {
                let base = t * cells_per + (i * SUB + j) * 2;
                if i + j < SUB {
                    probability[base] = tri.2 / total / (SUB * SUB) as f64;
                }
                if i + j + 1 < SUB {
                    probability[base + 1] = tri.2 / total / (SUB * SUB) as f64;
                }
            }
        }
    }
    for (i, o) in out.iter().enumerate() {
        let prim = o[0][3].to_bits();
        let t = tris
            .iter()
            .position(|x| x.0 == prim)
            .unwrap_or_else(|| panic!("sampled triangle {prim} is not emissive"));
        let (_, v, weight, area) = tris[t];
        // The pdf the integrand divides by equals pmf/area computed here.
        let pdf = weight / total / area;
        assert!(
            ((o[1][0] as f64) - pdf).abs() <= 1e-5 * pdf,
            "pdf_area {} vs {pdf}",
            o[1][0]
        );
        let y = Vec3::new(o[0][0], o[0][1], o[0][2]);
        let (e1, e2, w) = (v[1] - v[0], v[2] - v[0], y - v[0]);
        let (d00, d01, d11) = (e1.dot(e1) as f64, e1.dot(e2) as f64, e2.dot(e2) as f64);
        let (d20, d21) = (w.dot(e1) as f64, w.dot(e2) as f64);
        let det = d00 * d11 - d01 * d01;
        let b1 = (d11 * d20 - d01 * d21) / det;
        let b2 = (d00 * d21 - d01 * d20) / det;
        let off_plane = (w.dot(e1.cross(e2).normalize())).abs();
        assert!(
            off_plane < 1e-4,
            "point {y} is {off_plane} off its triangle's plane"
        );
        let cell = sub_triangle(b1, b2)
            .unwrap_or_else(|| panic!("point {y} outside triangle {prim} ({b1}, {b2})"));
        counts[i / SAMPLES][t * cells_per + cell] += 1;
    }
    chi_square("emitter", &counts, &probability);
}
