//! MDAS against known answers: convergence on scene-free integrands and on
//! `area_light_plane`, a win over Halton on a sharp edge, hard cases
//! (sparse, NaN/Inf, 1e-6…1e6, α extremes, tiny and odd films, d = 3 and 8,
//! budget = initial samples, iteration cap) and determinism.

mod common;
mod mdas_support;

use common::{gpu, TestIntegrand};
use mdas::film::Film;
use mdas::integrator::mdas::MdasParams;
use mdas::integrator::{Halton, Integrator, Mdas};
use mdas_support::*;

fn linear_reference(film: Film) -> Vec<[f32; 3]> {
    (0..film.height)
        .flat_map(|j| (0..film.width).map(move |i| [i as f32 + 0.5, j as f32 + 0.5, 0.5]))
        .collect()
}

/// f = (x, y, u0) (film coordinates in pixels): leaves shrink as samples
/// are added and the estimate converges. The yardstick is a closed form:
/// N independent uniform samples per pixel (over the pixel × [0, 1) in
/// u0) give each channel variance (1/12)/N (a unit-width uniform), so
/// their expected RelMSE is the mean over pixels and channels of
/// (1/12)/N / (r² + 0.01), r the pixel's reference value
/// ([`independent_sampling_relmse`]). MDAS, whose leaves stratify every
/// axis, must stay below it at 4, 16 and 64 spp (so it converges at least
/// as 1/N). Measured (mean of 3 seeds): 1.5e-2, 2.2e-3, 3.5e-4 against
/// 3.2e-2, 7.9e-3, 2.0e-3: a factor 2–6 below, where single seeds differ
/// from their mean by at most 11 %.
#[test]
fn linear_integrand_converges_with_spp() {
    let film = Film {
        width: 16,
        height: 12,
    };
    let reference = linear_reference(film);
    for spp in [4.0f32, 16.0, 64.0] {
        let error = (0..3)
            .map(|seed| {
                let e = relmse(
                    &render(0, 3, film, params(1, 2, 1, spp, seed)).image,
                    &reference,
                );
                eprintln!("  seed {seed}: {e:.3e}");
                e
            })
            .sum::<f64>()
            / 3.0;
        let yardstick = independent_sampling_relmse(&reference, spp as f64, |_| 1.0 / 12.0);
        eprintln!("{spp} spp: RelMSE {error:.2e}, independent sampling {yardstick:.2e}");
        assert!(
            error < yardstick,
            "RelMSE at {spp} spp: {error:.3e} against {yardstick:.3e} for independent sampling"
        );
    }
}

/// The sharp edge 0.8x + 0.6y = 7.3 (test case 3) at equal sample count.
/// RelMSE per render is heavy-tailed (12 seeds at 32 spp: MDAS 2.8e-4 …
/// 2.8e-3, Halton 8.2e-4 … 3.4e-3), so the means are taken over 12 seeds
/// at 32 and 64 spp: measured MDAS/Halton = 0.65 and 0.69; the relative
/// standard error of each mean is ~16%, that of the pooled ratio ~12%, so
/// "MDAS below Halton" holds with a margin of about 3σ. (At 16 spp, 0.7
/// initial samples per pixel, the two tie.)
#[test]
fn mdas_beats_halton_on_a_sharp_edge() {
    let film = Film {
        width: 16,
        height: 12,
    };
    let reference = edge_image(film);
    let integrand = TestIntegrand::new(gpu(), 3, 3, film);
    let (mut mdas, mut halton) = (0.0, 0.0);
    for spp in [32u32, 64] {
        for seed in 0..12 {
            let p = params(1, 2, 1, spp as f32, seed);
            mdas += relmse(&render(3, 3, film, p).image, &reference);
            let h = Halton::new(spp, seed).render(gpu(), &integrand).unwrap();
            halton += relmse(&h.image, &reference);
        }
    }
    eprintln!(
        "mean RelMSE over seeds and spp: MDAS {:.3e}, Halton {:.3e}",
        mdas / 24.0,
        halton / 24.0
    );
    assert!(
        mdas < halton,
        "MDAS RelMSE {} vs Halton {}",
        mdas / 24.0,
        halton / 24.0
    );
}

/// `reconstruction = "pixel"` against the paper's box on the same edge
/// (test case 3) when leaves are wider than pixels (e = 1: initial cells of
/// 8 × 6 pixels; sf = 1/16, so splits favour the third axis and the film
/// boxes stay wide). The rule only changes the reconstruction, so each
/// seed renders the same samples both ways and the comparison is paired:
/// d = RelMSE(box) − RelMSE(pixel) over 12 seeds, one-sided t-test at
/// α = 0.001 (t₁₁ = 4.025): mean(d) > 4.025·sd(d)/√12. Away from the edge
/// the two agree exactly (a constant leaf), so d measures the edge alone.
#[test]
fn pixel_reconstruction_keeps_an_edge_inside_wide_leaves() {
    use mdas::integrator::mdas::Reconstruction;
    let film = Film {
        width: 16,
        height: 12,
    };
    let reference = edge_image(film);
    let seeds = 12;
    let d: Vec<f64> = (0..seeds)
        .map(|seed| {
            let mut p = params(1, 1, 4, 16.0, seed);
            p.scale_factor = 1.0 / 16.0;
            let boxed = relmse(&render(3, 3, film, p).image, &reference);
            p.reconstruction = Reconstruction::Pixel;
            let pixel = relmse(&render(3, 3, film, p).image, &reference);
            eprintln!("seed {seed}: RelMSE box {boxed:.3e}, pixel {pixel:.3e}");
            boxed - pixel
        })
        .collect();
    let n = seeds as f64;
    let mean = d.iter().sum::<f64>() / n;
    let sd = (d.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt();
    assert!(
        mean > 4.025 * sd / n.sqrt(),
        "box − pixel RelMSE: mean {mean:.3e}, sd {sd:.3e} over {seeds} seeds"
    );
}

/// The scene test: `scenes/tests/shadow_edge.toml`, whose only
/// feature is a penumbra about 6 pixels wide (a step over the light's two
/// dimensions), at 16 spp with the scene's `[mdas]` parameters (the box
/// reconstruction: the per-pixel one measured 1.00 here), against a
/// 1,024-spp Halton reference (its own error, ~1e-6, is far below the
/// compared renders'). Measured with a 4,096-spp reference on lavapipe:
/// MDAS 2.33, 2.39, 2.07 (e-4) and Halton 2.82, 2.87, 2.81 (e-4) for seeds
/// 1–3; the seed-to-seed spread of MDAS is ~0.15e-4, so the standard error
/// of the ratio of the 3-seed means (0.80) is ~0.04 and the bound 0.9
/// leaves 2.5σ. (On `scenes/tests/box_shadow.toml`, whose error sits on
/// film-space silhouettes, MDAS loses instead: BENCHMARKS.md.)
#[test]
fn mdas_beats_halton_on_a_shadow_edge_scene() {
    let gpu = gpu();
    let prepared = mdas::session::prepare(
        gpu,
        std::path::Path::new("scenes/tests/shadow_edge.toml"),
        1.0,
    )
    .unwrap();
    let integrand = prepared.integrand.as_ref();
    let reference = Halton::new(1024, 99).render(gpu, integrand).unwrap().image;
    let (mut mdas, mut halton) = (0.0, 0.0);
    for seed in 1..=3 {
        let p = MdasParams {
            seed,
            ..prepared.scene.mdas
        };
        mdas += relmse(
            &Mdas::new(p).unwrap().render(gpu, integrand).unwrap().image,
            &reference,
        ) / 3.0;
        let h = Halton::new(16, seed).render(gpu, integrand).unwrap();
        halton += relmse(&h.image, &reference) / 3.0;
    }
    eprintln!("mean RelMSE of seeds 1-3 at 16 spp: MDAS {mdas:.3e}, Halton {halton:.3e}");
    assert!(
        mdas < 0.9 * halton,
        "MDAS RelMSE {mdas:.3e} vs Halton {halton:.3e} (ratio {:.2})",
        mdas / halton
    );
}

/// `area_light_plane` at half resolution against a 256-spp Halton render of
/// the same integrand (Halton is unbiased; its RelMSE at 256 spp is far
/// below MDAS's at 4–16 spp). The error must fall with spp.
#[test]
fn area_light_plane_converges_to_a_halton_reference() {
    let gpu = gpu();
    let prepared = mdas::session::prepare(
        gpu,
        std::path::Path::new("scenes/area_light_plane.toml"),
        0.5,
    )
    .unwrap();
    let integrand = prepared.integrand.as_ref();
    let reference = Halton::new(256, 99).render(gpu, integrand).unwrap().image;
    let errors: Vec<f64> = [2.0f32, 8.0, 32.0]
        .iter()
        .map(|&spp| {
            relmse(
                &Mdas::new(params(1, 3, 1, spp, 4))
                    .unwrap()
                    .render(gpu, integrand)
                    .unwrap()
                    .image,
                &reference,
            )
        })
        .collect();
    assert!(
        errors[1] < errors[0] && errors[2] < errors[1],
        "RelMSE at 2, 8, 32 spp: {errors:?}"
    );
}

/// Against the closed form (`analytic::area_light_plane_image`): the
/// RelMSE falls from 2 to 8 to 32 spp, and the mean of 4 independent
/// 32-spp renders is closer than one (MDAS is biased, but its variance
/// part still averages out).
#[test]
fn area_light_plane_converges_to_the_closed_form() {
    let gpu = gpu();
    let prepared = mdas::session::prepare(
        gpu,
        std::path::Path::new("scenes/area_light_plane.toml"),
        0.5,
    )
    .unwrap();
    let f = prepared.film;
    let exact = mdas::analytic::area_light_plane_image(f.width, f.height);
    let mut errors = Vec::new();
    let mut mean_of_renders = vec![[0.0f32; 3]; exact.len()];
    for spp in [2.0f32, 8.0, 32.0] {
        let r = Mdas::new(params(1, 3, 1, spp, 4))
            .unwrap()
            .render(gpu, prepared.integrand.as_ref())
            .unwrap();
        errors.push(relmse(&r.image, &exact));
    }
    for seed in 0..4 {
        let r = Mdas::new(params(1, 3, 1, 32.0, seed))
            .unwrap()
            .render(gpu, prepared.integrand.as_ref())
            .unwrap();
        for (a, x) in mean_of_renders.iter_mut().zip(&r.image) {
            for c in 0..3 {
                a[c] += x[c] / 4.0;
            }
        }
    }
    assert!(
        errors[1] < errors[0] && errors[2] < errors[1],
        "RelMSE at 2, 8, 32 spp: {errors:?}"
    );
    assert!(
        relmse(&mean_of_renders, &exact) < errors[2],
        "the mean of 4 renders is no closer"
    );
}

/// NaN on u0 < ¼ and +Inf on ¼ ≤ u0 < ⅜, 1 elsewhere: the non-finite samples
/// are counted (about ⅜ of the initial ones, which are stratified, fewer
/// later as those leaves have no contrast) and excluded, so every pixel is
/// the weighted mean of 1s (= 1 up to the fixed-point rounding, ~1e-15).
#[test]
fn nonfinite_samples_are_counted_and_excluded() {
    let film = Film {
        width: 10,
        height: 6,
    };
    let r = render(1, 3, film, params(1, 2, 1, 12.0, 8));
    assert_eq!(r.samples, 720);
    let initial = 128.0 * 3.0 / 8.0;
    assert!(
        r.nonfinite as f64 >= 0.5 * initial && r.nonfinite < r.samples / 2,
        "non-finite samples: {}",
        r.nonfinite
    );
    assert_eq!(r.nonfinite_pixels(), 0);
    assert!(
        r.image
            .iter()
            .all(|p| p.iter().all(|&c| (c - 1.0).abs() < 1e-6)),
        "{:?}",
        r.image
    );
}

/// 1e6 on columns 0–3, 1e-6 elsewhere, with cells one pixel wide (b + e =
/// 4 bits on a 16-pixel axis) so no leaf straddles x = 4. Pixels must keep
/// both magnitudes: the fixed-point quantum is 2⁻⁶⁰·2^⌈log2 1e6⌉ ≈ 9e-13,
/// at most ~20 truncated terms per pixel give < 2e-11 absolute error, and
/// f32 rounding adds 1e-7 relative: 1e-6 ± 2e-11 is tested as ±1e-4
/// relative, 1e6 as ±1e-6 relative.
#[test]
fn values_from_1e_minus_6_to_1e6_are_kept() {
    let film = Film {
        width: 16,
        height: 5,
    };
    let r = render(5, 3, film, params(1, 3, 1, 16.0, 1));
    for j in 0..film.height {
        for i in 0..film.width {
            let p = r.image[(j * film.width + i) as usize];
            let expect = if i < 4 { 1e6 } else { 1e-6 };
            let tol = if i < 4 { 1e-6 } else { 1e-4 };
            assert!(
                p.iter()
                    .all(|&c| ((c as f64 - expect) / expect).abs() < tol),
                "pixel ({i},{j}) = {p:?}"
            );
        }
    }
    // 1e6 on u0 < 0.2 and 1e-6 elsewhere: finite, between the extremes.
    let r = render(
        2,
        3,
        Film {
            width: 6,
            height: 4,
        },
        params(1, 1, 1, 20.0, 2),
    );
    assert!(r.image.iter().all(|p| p
        .iter()
        .all(|&c| c.is_finite() && (1e-6..=1e6).contains(&c))));
}

/// f = 25 on the slab |u0 − ½| < 0.02, 0 elsewhere (pixel mean 1). MDAS is a
/// biased estimator here: leaves whose samples all missed the slab have no
/// contrast and are rarely refined, while those that hit it are refined and
/// lose their (positive) estimation error — measured image means 0.6 at
/// α = ¼ and 1.1–1.4 at α = 0 (best-candidate points favour box faces, and
/// the slab sits on the cell face u0 = ½). The test asks for a finite,
/// non-negative image whose mean is within a factor 3 of 1.
#[test]
fn integrand_zero_over_most_of_the_domain() {
    let film = Film {
        width: 8,
        height: 6,
    };
    for alpha in [0.0f32, 0.25] {
        let mut p = params(1, 2, 1, 64.0, 1);
        p.alpha = alpha;
        let r = render(4, 3, film, p);
        assert_eq!(r.samples, 64 * 48);
        assert!(r
            .image
            .iter()
            .all(|p| p.iter().all(|&c| c.is_finite() && c >= 0.0)));
        let mean = r.image.iter().map(|p| p[0] as f64).sum::<f64>() / 48.0;
        assert!(
            (1.0 / 3.0..3.0).contains(&mean),
            "α = {alpha}: image mean {mean}"
        );
    }
}

#[test]
fn alpha_zero_and_eight_meet_the_budget() {
    let film = Film {
        width: 16,
        height: 12,
    };
    let reference = edge_image(film);
    for alpha in [0.0f32, 8.0] {
        let mut p = params(1, 2, 1, 8.0, 1);
        p.alpha = alpha;
        let mut mdas = Mdas::new(p).unwrap();
        let r = mdas
            .render(gpu(), &TestIntegrand::new(gpu(), 3, 3, film))
            .unwrap();
        let stats = mdas.last_stats().unwrap();
        assert_eq!(r.samples, 8 * 192, "α = {alpha}: {stats:?}");
        // α = 0 selects every leaf each iteration, so each adds at least
        // the 128 initial leaves' worth of samples: ≤ (1536 − 128)/128 = 11
        // iterations.
        if alpha == 0.0 {
            assert!(stats.iterations <= 11, "{stats:?}");
        }
        // A sane image from the budget: below the expected RelMSE of one
        // independent sample per pixel (closed form, 0.147). Not of eight
        // (0.018): RelMSE here is ruled by the few pixels the edge barely
        // covers (reference near 0, denominator 0.01), so single renders
        // are heavy-tailed; seeds 1–5 measured 1.7e-2 … 8.1e-2 at α = 0
        // and 5.8e-3 … 2.4e-2 at α = 8, the worst 1.8× below the bound.
        let e = relmse(&r.image, &reference);
        let yardstick = independent_sampling_relmse(&reference, 1.0, |c| c * (1.0 - c));
        eprintln!("α = {alpha}: RelMSE {e:.2e}, independent sampling {yardstick:.2e}");
        assert!(e < yardstick, "α = {alpha}: RelMSE {e} against {yardstick}");
    }
}

/// 1×1: the single pixel averages (½, ½, ½); the piecewise-constant
/// estimate of a linear function over 64 samples is within 0.05.
/// 333×77 (odd sizes, cells not aligned to pixels): RelMSE of the linear
/// integrand 4.5e-3 at 4 spp, which must be below 4 independent samples
/// per pixel (closed form, 2.7e-2; over 25,641 pixels the spread between
/// seeds is small). The same film with a budget of
/// one sample in one cell (b = e = 0) is one leaf over all 25,641 pixels,
/// more than one reconstruction dispatch splats (PIXELS_PER_PASS): every
/// pixel must still get the leaf's value with weight 1.
#[test]
fn one_pixel_and_odd_films() {
    let r = render(
        0,
        3,
        Film {
            width: 1,
            height: 1,
        },
        params(1, 0, 1, 64.0, 3),
    );
    assert_eq!(r.samples, 64);
    assert!(
        r.image[0].iter().all(|&c| (c - 0.5).abs() < 0.05),
        "{:?}",
        r.image[0]
    );
    let film = Film {
        width: 333,
        height: 77,
    };
    let r = render(0, 3, film, params(1, 6, 1, 4.0, 3));
    assert_eq!(r.samples, 4 * 333 * 77);
    assert_eq!(r.nonfinite_pixels(), 0);
    let reference = linear_reference(film);
    let e = relmse(&r.image, &reference);
    let yardstick = independent_sampling_relmse(&reference, 4.0, |_| 1.0 / 12.0);
    eprintln!("333×77 RelMSE at 4 spp: {e:.2e}, independent sampling {yardstick:.2e}");
    assert!(e < yardstick, "333×77 RelMSE {e} against {yardstick}");
    let r = render(0, 3, film, params(0, 0, 1, 1.0 / (333.0 * 77.0), 3));
    assert_eq!(r.samples, 1);
    let first = r.image[0];
    assert!(first.iter().all(|c| c.is_finite()));
    assert!(
        r.image.iter().all(|p| p
            .iter()
            .zip(&first)
            .all(|(a, b)| (a - b).abs() <= 1e-6 * b.abs())),
        "pixels differ"
    );
}

/// d = 8 and 16 (u1… unused by the integrand: leaves also split along
/// them, so the film is refined more slowly than at d = 3). Each must
/// still beat 32 independent samples per pixel (closed form, 4.5e-3):
/// seeds 1–6 measured 1.9e-3 … 3.7e-3 at d = 8 and 2.0e-3 … 3.9e-3 at
/// d = 16 (this test's seed 1 is the worst, 13 % below).
#[test]
fn eight_dimensions() {
    let film = Film {
        width: 8,
        height: 6,
    };
    let reference = linear_reference(film);
    let r8 = render(0, 8, film, params(0, 2, 1, 32.0, 1));
    let r3 = render(0, 3, film, params(0, 2, 1, 32.0, 1));
    assert_eq!(r8.samples, 32 * 48);
    let (e8, e3) = (relmse(&r8.image, &reference), relmse(&r3.image, &reference));
    let yardstick = independent_sampling_relmse(&reference, 32.0, |_| 1.0 / 12.0);
    eprintln!("independent sampling at 32 spp: {yardstick:.2e}");
    assert!(
        e8 < yardstick && e3 < yardstick,
        "RelMSE d=8 {e8}, d=3 {e3} against {yardstick}"
    );
    // The most the integrand contract allows: d = 16.
    let r16 = render(0, 16, film, params(0, 2, 1, 32.0, 1));
    assert_eq!(r16.samples, 32 * 48);
    let e16 = relmse(&r16.image, &reference);
    eprintln!("RelMSE at 32 spp: d=3 {e3:.2e}, d=8 {e8:.2e}, d=16 {e16:.2e}");
    assert!(e16 < yardstick, "RelMSE d=16 {e16} against {yardstick}");
}

/// Budget = initial samples: no adaptive iteration runs; the image is the
/// stratified initial estimate.
#[test]
fn budget_equal_to_the_initial_samples() {
    let film = Film {
        width: 8,
        height: 8,
    };
    let mut mdas = Mdas::new(params(1, 2, 2, 4.0, 5)).unwrap();
    let r = mdas
        .render(gpu(), &TestIntegrand::new(gpu(), 0, 3, film))
        .unwrap();
    let stats = mdas.last_stats().unwrap();
    assert_eq!(
        (r.samples, stats.initial_samples, stats.iterations),
        (256, 256, 0)
    );
    assert!(relmse(&r.image, &linear_reference(film)) < 5e-2);
}

#[test]
fn iteration_cap_stops_below_the_budget_and_reports_it() {
    let film = Film {
        width: 16,
        height: 12,
    };
    let mut p = params(1, 2, 1, 16.0, 1);
    p.alpha = 8.0;
    let mut mdas = Mdas::new(p).unwrap().with_max_iterations(2);
    let r = mdas
        .render(gpu(), &TestIntegrand::new(gpu(), 3, 3, film))
        .unwrap();
    let stats = mdas.last_stats().unwrap();
    // 128 initial samples; α = 8 selects few leaves per iteration.
    assert_eq!(stats.iterations, 2);
    assert!(
        r.samples > 128 && r.samples < 16 * 192,
        "samples {}",
        r.samples
    );
}

#[test]
fn same_seed_same_bits_other_seed_differs() {
    let film = Film {
        width: 20,
        height: 9,
    };
    let bits = |r: &mdas::integrator::Render| {
        r.image
            .iter()
            .flat_map(|p| p.map(f32::to_bits))
            .collect::<Vec<_>>()
    };
    let a = render(3, 4, film, params(1, 2, 1, 9.5, 9));
    let b = render(3, 4, film, params(1, 2, 1, 9.5, 9));
    let c = render(3, 4, film, params(1, 2, 1, 9.5, 10));
    assert_eq!(a.samples, (9.5f64 * 180.0).round() as u64);
    assert_eq!(bits(&a), bits(&b));
    assert_ne!(bits(&a), bits(&c));
}

#[test]
fn render_reports_phases_and_memory() {
    let film = Film {
        width: 16,
        height: 16,
    };
    let r = render(0, 4, film, params(1, 2, 4, 16.0, 1));
    for phase in ["initial", "evaluate", "error", "adaptive", "reconstruction"] {
        assert!(
            r.times.get(phase).is_some(),
            "phase {phase} missing: {:?}",
            r.times
        );
    }
    // 4D, l = m = 4 (the paper's setting): 20 B per sample (coordinates
    // 8, value 12) + 40 B per leaf (cell, header, error, 4 box words, 3
    // more sample slots) for at most N/2 leaves; the 32 B/pixel
    // accumulators live in the coordinate buffer (16 spp · 8 B ≥ 32 B);
    // scan totals, counters and parameters add < 0.1 B.
    let per_sample = r.gpu_bytes as f64 / r.samples as f64;
    assert!(per_sample < 40.1, "{per_sample} B per sample");
}

/// Exact pixel means of test case 7: 400 × the overlap of pixel (i, j)
/// with the lamp [5.3, 7.6) × [4.2, 5.5).
fn lamp_image(film: Film) -> Vec<[f32; 3]> {
    let overlap = |lo: f64, hi: f64, p: u32| (hi.min(p as f64 + 1.0) - lo.max(p as f64)).max(0.0);
    (0..film.height)
        .flat_map(|j| {
            (0..film.width)
                .map(move |i| [(400.0 * overlap(5.3, 7.6, i) * overlap(4.2, 5.5, j)) as f32; 3])
        })
        .collect()
}

/// A small lamp of radiance 400 on black (test case 7, exact pixel means),
/// with the defaults of a scene that has no `[mdas]` table, at 8 spp: the
/// `street_lights` failure of issue 48, where leaves and the per-pixel
/// reconstruction carried a lamp's mean onto the black pixels beside it
/// (RelMSE 26–32 against Halton's 0.5 there). Over 48 seeds MDAS's mean
/// RelMSE must stay within 2× Halton's at the same spp (the issue's "no
/// scene worse than 2×"). Measured over seeds 0–47: 1.674e-3 against
/// Halton's 1.134e-3, 1.48×, with the defaults (α = 2, the paced
/// selection, Kronecker initial offsets, the `shrinkage` reconstruction;
/// 1.66e-3 with `sampled`, 1.36× with random offsets). The
/// means of the three blocks of 16 seeds spread from 1.27e-3 to 1.94e-3,
/// so the standard error of the 48-seed mean is about 0.19e-3 (ratio
/// ±0.17) and 2× sits about 3σ above the measured ratio; 16 seeds could
/// not resolve the bound (2.02× on seeds 0–15), nor could 4 (2.2× on
/// seeds 0–3). Earlier, over 16 seeds: α = 1/4 unpaced 1.49×, α = 2
/// unpaced 1.28×, paced 1.69×. The `pixel` reconstruction with κ = 1 on
/// the same grid, the old
/// default's way of filling pixels, is checked to leak: it must read over
/// 4× Halton's, so the bound is one this mechanism can fail (measured
/// over 48 seeds: 317, 2.8e5×).

#[test]
fn small_bright_lamp_does_not_leak_onto_black_pixels() {
    use mdas::integrator::mdas::Reconstruction;
    let gpu = gpu();
    let film = Film {
        width: 16,
        height: 12,
    };
    let exact = lamp_image(film);
    let integrand = TestIntegrand::new(gpu, 7, 3, film);
    let mean = |f: &dyn Fn(u32) -> Vec<[f32; 3]>| {
        (0..48).map(|s| relmse(&f(s), &exact)).sum::<f64>() / 48.0
    };
    let defaults = MdasParams {
        spp: 8.0,
        ..MdasParams::for_film(film)
    };
    let mdas = mean(&|seed| {
        let p = MdasParams { seed, ..defaults };
        Mdas::new(p).unwrap().render(gpu, &integrand).unwrap().image
    });
    let leaky = mean(&|seed| {
        let p = MdasParams {
            seed,
            reconstruction: Reconstruction::Pixel,
            pixel_prior: 1.0,
            ..defaults
        };
        Mdas::new(p).unwrap().render(gpu, &integrand).unwrap().image
    });
    let halton = mean(&|seed| Halton::new(8, seed).render(gpu, &integrand).unwrap().image);
    eprintln!("RelMSE: MDAS {mdas:.3e}, pixel κ = 1 {leaky:.3e}, Halton {halton:.3e}");
    assert!(
        mdas <= 2.0 * halton,
        "MDAS {mdas:.3e} against Halton {halton:.3e}"
    );
    assert!(
        leaky > 4.0 * halton,
        "pixel κ = 1 {leaky:.3e} against Halton {halton:.3e}"
    );
}
