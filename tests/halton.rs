//! Halton integrator: exact radical inverses (CPU oracle), elementary-
//! interval stratification, Cranley–Patterson shifts, known pixel means,
//! non-finite handling and determinism.

mod common;

use common::{cp_shift, gpu, image_bits, radical_inverse_exact, TestIntegrand, PRIMES};
use mdas::film::Film;
use mdas::gpu::shader::{bind_buffers, storage_entry, Wgsl};
use mdas::integrand::MAX_DIMS;
use mdas::integrator::{Halton, Integrator};
use mdas::wgsl_file;
use rand::{RngExt, SeedableRng};

#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct Query {
    dim: u32,
    index: u32,
    pixel: u32,
    seed: u32,
}

/// Runs tests/kernels/halton_points.wgsl: (raw radical inverse, shifted sample).
fn gpu_points(queries: &[Query]) -> (Vec<f32>, Vec<f32>) {
    let gpu = gpu();
    let layout = gpu.bind_group_layout(
        "test.halton.layout",
        &[
            storage_entry(0, true),
            storage_entry(1, false),
            storage_entry(2, false),
        ],
    );
    let source = Wgsl::new()
        .part(wgsl_file!("shared/rng.wgsl"))
        .part(wgsl_file!("shared/sampling.wgsl"))
        .part(wgsl_file!("shared/halton.wgsl"))
        .part((
            "tests/kernels/halton_points.wgsl",
            include_str!("kernels/halton_points.wgsl"),
        ));
    let pipeline = gpu
        .compute_pipeline("test.halton", &source, "main", &[&layout])
        .unwrap();
    let usage = mdas::gpu::buffer::STORAGE;
    let q = gpu
        .buffer_from("test.halton.queries", queries, usage)
        .unwrap();
    let raw = gpu
        .buffer_zeroed("test.halton.raw", 4 * queries.len() as u64, usage)
        .unwrap();
    let shifted = gpu
        .buffer_zeroed("test.halton.shifted", 4 * queries.len() as u64, usage)
        .unwrap();
    let group = bind_buffers(gpu, "test.halton", &layout, &[&q, &raw, &shifted]);
    gpu.scoped("halton test kernel", || {
        let mut encoder = gpu.device.create_command_encoder(&Default::default());
        {
            let mut pass = encoder.begin_compute_pass(&Default::default());
            pass.set_pipeline(&pipeline);
            pass.set_bind_group(0, &group, &[]);
            pass.dispatch_workgroups((queries.len() as u32).div_ceil(64), 1, 1);
        }
        gpu.queue.submit([encoder.finish()]);
        Ok(())
    })
    .unwrap();
    (
        gpu.read_buffer(&raw, queries.len()).unwrap(),
        gpu.read_buffer(&shifted, queries.len()).unwrap(),
    )
}

#[test]
fn radical_inverse_matches_exact_rationals_at_large_indices() {
    let mut rng = rand::rngs::StdRng::seed_from_u64(7);
    let mut queries = Vec::new();
    for dim in 0..MAX_DIMS {
        let special = [
            0,
            1,
            2,
            3,
            255,
            256,
            65535,
            65536,
            (1 << 24) - 1,
            1 << 24,
            (1 << 24) + 1,
            1 << 31,
            u32::MAX - 1,
            u32::MAX,
        ];
        let random: Vec<u32> = (0..500)
            .map(|_| rng.random_range((1u32 << 24)..=u32::MAX))
            .collect();
        for index in special.into_iter().chain(random).chain(0..200) {
            queries.push(Query {
                dim,
                index,
                pixel: rng.random(),
                seed: rng.random(),
            });
        }
    }
    let (raw, shifted) = gpu_points(&queries);
    // Bound: the quotient of two exactly reversed integers formed with at most
    // four f32 roundings, each ≤ 2⁻²⁴ relative, on a value < 1.
    let tolerance = 4.0 * 2f64.powi(-24);
    for (i, q) in queries.iter().enumerate() {
        let exact = radical_inverse_exact(PRIMES[q.dim as usize], q.index);
        let got = raw[i] as f64;
        assert!(
            got < 1.0,
            "Φ must stay below 1: dim {} index {} gave {got}",
            q.dim,
            q.index
        );
        assert!(
            (got - exact).abs() <= tolerance,
            "dim {} (base {}) index {}: GPU {got} vs exact {exact}",
            q.dim,
            PRIMES[q.dim as usize],
            q.index
        );
        // The Cranley–Patterson rotation is a toroidal shift by the hash of
        // (pixel, dim, seed); the CPU oracle reproduces it to f32 rounding.
        let expect = (exact + cp_shift(q.pixel, q.dim, q.seed)).fract();
        let d = (shifted[i] as f64 - expect).abs();
        assert!(
            d.min(1.0 - d) <= 2.0 * tolerance,
            "shifted sample {i}: {} vs {expect}",
            shifted[i]
        );
        assert!((0.0..1.0).contains(&(shifted[i] as f64)));
    }
}

#[test]
fn halton_2d_points_fill_every_elementary_interval_once() {
    // The first 2^a·3^b points of (Φ₂, Φ₃) put exactly one point in every
    // box [i/2^a, (i+1)/2^a) × [j/3^b, (j+1)/3^b) — for every such shape.
    for (a, b) in [(3u32, 2u32), (5, 1), (1, 4), (4, 3), (6, 2)] {
        let (nx, ny) = (2usize.pow(a), 3usize.pow(b));
        let n = nx * ny;
        let offset = 7 * n as u32; // any block of n consecutive aligned indices works
        let queries: Vec<Query> = (0..n as u32)
            .flat_map(|i| {
                (0..2).map(move |dim| Query {
                    dim,
                    index: offset + i,
                    pixel: 0,
                    seed: 0,
                })
            })
            .collect();
        let (raw, _) = gpu_points(&queries);
        let mut count = vec![0u32; n];
        for i in 0..n {
            let (x, y) = (raw[2 * i] as f64, raw[2 * i + 1] as f64);
            let cell = (x * nx as f64).floor() as usize + nx * (y * ny as f64).floor() as usize;
            count[cell] += 1;
        }
        assert!(
            count.iter().all(|&c| c == 1),
            "2^{a}×3^{b} boxes: counts {count:?}"
        );
    }
}

/// Samples per invocation the tests run with: the loop-free kernel a GPU
/// takes and the loop of 8 a CPU driver takes (both run on any adapter).
const PER_INVOCATION: [u32; 2] = [1, 8];

fn render_with(
    case: u32,
    dims: u32,
    film: Film,
    spp: u32,
    seed: u32,
    per_invocation: u32,
) -> mdas::integrator::Render {
    let gpu = gpu();
    let integrand = TestIntegrand::new(gpu, case, dims, film);
    Halton::new(spp, seed)
        .with_samples_per_invocation(per_invocation)
        .render(gpu, &integrand)
        .unwrap()
}

/// Renders with each of [`PER_INVOCATION`].
fn renders(case: u32, dims: u32, film: Film, spp: u32, seed: u32) -> Vec<mdas::integrator::Render> {
    PER_INVOCATION
        .iter()
        .map(|&n| render_with(case, dims, film, spp, seed, n))
        .collect()
}

fn render(case: u32, dims: u32, film: Film, spp: u32, seed: u32) -> mdas::integrator::Render {
    let gpu = gpu();
    let integrand = TestIntegrand::new(gpu, case, dims, film);
    Halton::new(spp, seed).render(gpu, &integrand).unwrap()
}

/// Stratification bounds used below: the points of a pixel with indices in
/// an aligned block [k·bⁿ, (k+1)·bⁿ) have first coordinates Φ_b that put
/// exactly one point in each interval [c/bⁿ, (c+1)/bⁿ); a toroidal shift
/// keeps one point per shifted interval. So an interval of length L holds
/// between ⌊L·bⁿ⌋ − 1 and ⌈L·bⁿ⌉ + 1 of them (it cuts at most two cells).
#[test]
fn pixel_value_is_the_mean_over_the_footprint() {
    // f = (x, y, u0): pixel (i, j) averages to (i + ½, j + ½, ½).
    // With spp = 256 = 2⁸, dimension 0 (Φ₂) is exactly stratified in 256
    // cells: each point is within one cell of its cell's midpoint, so the
    // mean is within 2/256 of ½. Dimension 1 (Φ₃): the first 243 = 3⁵ points
    // are stratified (within 2/243), the other 13 anywhere in [0,1):
    // |mean − ½| ≤ 13/512 + 2/243.
    let film = Film {
        width: 33,
        height: 7,
    };
    let spp = 256;
    for r in renders(0, 3, film, spp, 3) {
        assert_eq!(r.samples, 33 * 7 * 256);
        assert_eq!(r.nonfinite, 0);
        for j in 0..film.height {
            for i in 0..film.width {
                let p = r.image[(j * film.width + i) as usize];
                let f32_slack = 1e-5 * (i + j + 1) as f32;
                let tol_x = 2.0 / 256.0 + f32_slack;
                let tol_y = 13.0 / 512.0 + 2.0 / 243.0 + f32_slack;
                assert!(
                    (p[0] - (i as f32 + 0.5)).abs() <= tol_x,
                    "pixel ({i},{j}) x mean {}",
                    p[0]
                );
                assert!(
                    (p[1] - (j as f32 + 0.5)).abs() <= tol_y,
                    "pixel ({i},{j}) y mean {}",
                    p[1]
                );
                assert!((0.0..1.0).contains(&p[2]));
            }
        }
    }
}

#[test]
fn nonfinite_samples_are_counted_and_excluded() {
    // u0 is Φ₅ over 125 = 5³ points per pixel: the non-finite interval
    // [0, 3/8) (NaN below ¼, +Inf up to 3/8) spans 46.875 cells, so each
    // pixel has between 45 and 48 non-finite samples.
    let film = Film {
        width: 16,
        height: 16,
    };
    let spp = 125;
    for r in renders(1, 3, film, spp, 11) {
        let pixels = 16 * 16;
        assert!(
            (45 * pixels..=48 * pixels).contains(&r.nonfinite),
            "non-finite samples {} outside [{}, {}]",
            r.nonfinite,
            45 * pixels,
            48 * pixels
        );
        assert!(
            r.image.iter().all(|p| p.iter().all(|&c| c == 1.0)),
            "finite samples are all 1"
        );
        assert_eq!(r.nonfinite_pixels(), 0);
    }
}

#[test]
fn extreme_dynamic_range_is_accumulated_without_loss() {
    // f = 1e6 where u0 < 0.2, else 1e-6: the interval spans exactly 25 of
    // the 125 stratification cells of Φ₅, so each pixel sees 24..=26 spikes
    // and its mean lies in [24, 26]·1e6/125 (+ at most 1e-6).
    let film = Film {
        width: 8,
        height: 8,
    };
    for r in renders(2, 3, film, 125, 5) {
        for p in &r.image {
            assert!(
                p[0] >= 24.0e6 / 125.0 && p[0] <= 26.0e6 / 125.0 + 1.0,
                "pixel mean {}",
                p[0]
            );
            assert_eq!(p[1], p[0]);
        }
    }
}

#[test]
fn same_seed_same_bits_and_other_seed_differs() {
    let film = Film {
        width: 20,
        height: 9,
    };
    let a = render(0, 4, film, 37, 9);
    let b = render(0, 4, film, 37, 9);
    let c = render(0, 4, film, 37, 10);
    assert_eq!(image_bits(&a), image_bits(&b));
    assert_ne!(image_bits(&a), image_bits(&c));
}

#[test]
fn spp_not_divisible_by_the_chunking_is_exact() {
    // Odd spp exercise partial chunks: the sample count must still be exact.
    let film = Film {
        width: 3,
        height: 2,
    };
    for spp in [1u32, 7, 9, 1000] {
        for r in renders(0, 3, film, spp, 1) {
            assert_eq!(r.samples, 6 * spp as u64);
            assert_eq!(r.nonfinite, 0);
        }
    }
}

#[test]
fn loop_free_kernel_takes_the_same_samples() {
    // One sample per invocation (`evaluate_single`) and a loop of 8
    // (`evaluate`) evaluate the same Halton points and count the same
    // non-finite ones; only the order of the f32 additions differs. The
    // summands are non-negative, so each pixel's sum is within spp·ε
    // (relative) of the exact one either way: within 2·spp·ε of each other.
    let film = Film {
        width: 13,
        height: 7,
    };
    let spp = 37;
    for case in [0u32, 1, 6] {
        let r = renders(case, 4, film, spp, 9);
        let (a, b) = (&r[0], &r[1]);
        assert_eq!(a.samples, b.samples);
        assert_eq!(a.nonfinite, b.nonfinite, "case {case}");
        if case == 1 {
            assert!(a.nonfinite > 0, "case 1 has non-finite samples");
        }
        for (k, (p, q)) in a.image.iter().zip(&b.image).enumerate() {
            for c in 0..3 {
                let tol = 2.0 * spp as f32 * f32::EPSILON * p[c].abs().max(q[c].abs());
                assert!(
                    (p[c] - q[c]).abs() <= tol,
                    "case {case} pixel {k} channel {c}: {} against {}",
                    p[c],
                    q[c]
                );
            }
        }
    }
}
