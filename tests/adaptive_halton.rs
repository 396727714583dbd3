//! Per-pixel adaptive Halton with Cycles' rule (src/integrator/adaptive.rs):
//! convergence of a constant, determinism, a known answer, the schedule
//! against the CPU oracle (`adaptive::simulate`), the budget, non-finite
//! samples, and Halton's samples below the first check.

mod common;

use common::{gpu, halton_point, image_bits, TestIntegrand};
use mdas::film::Film;
use mdas::gpu::shader::Wgsl;
use mdas::integrand::{point_wgsl, Integrand};
use mdas::integrator::adaptive::{self, AdaptiveParams};
use mdas::integrator::{AdaptiveHalton, Halton, Integrator, Render};

/// An integrand given by its WGSL body (no bindings).
struct Inline {
    film: Film,
    dims: u32,
    body: &'static str,
}

impl Integrand for Inline {
    fn name(&self) -> &'static str {
        "inline"
    }
    fn dims(&self) -> u32 {
        self.dims
    }
    fn film(&self) -> Film {
        self.film
    }
    fn wgsl(&self) -> Wgsl {
        point_wgsl().part(("adaptive_test.wgsl", self.body))
    }
}

fn render(integrand: &dyn Integrand, params: AdaptiveParams) -> (Render, Vec<u32>) {
    let mut a = AdaptiveHalton::new(params).unwrap();
    let r = a.render(gpu(), integrand).unwrap();
    let counts = a.sample_counts().to_vec();
    assert_eq!(counts.iter().map(|&c| c as u64).sum::<u64>(), r.samples);
    (r, counts)
}

const CONSTANT: &str = "
fn integrand(p: ptr<function, IntegrandPoint>) -> vec3<f32> {
    return vec3<f32>(0.25, 0.5, 2.0);
}";

#[test]
fn a_constant_converges_at_the_first_check_and_is_exact() {
    let film = Film {
        width: 13,
        height: 7,
    };
    let integrand = Inline {
        film,
        dims: 3,
        body: CONSTANT,
    };
    // Cycles' defaults: min 64, so the first check after 80 samples (its
    // need_filter on 0-based sample 79); then min 16: after 32.
    for (min_spp, first) in [(None, 80u32), (Some(16), 32)] {
        let mut params = AdaptiveParams::new(1000.0, 3);
        if let Some(m) = min_spp {
            params.min_spp = m;
        }
        assert_eq!(params.first_check(), first);
        let (r, counts) = render(&integrand, params);
        assert!(counts.iter().all(|&c| c == first), "{counts:?}");
        assert_eq!(r.samples, first as u64 * 91);
        assert_eq!(r.nonfinite, 0);
        // Sums of `first` copies of 0.25, 0.5, 2 are exact in f32.
        assert!(
            r.image.iter().all(|p| *p == [0.25, 0.5, 2.0]),
            "{:?}",
            r.image[0]
        );
    }
}

/// Noisy everywhere: f = 25 on 4 % of u0, else 0 (case 4), pixel mean 1.
fn noisy(film: Film) -> TestIntegrand {
    TestIntegrand::new(gpu(), 4, 3, film)
}

#[test]
fn same_seed_same_bits_other_seed_differs() {
    let film = Film {
        width: 11,
        height: 6,
    };
    let integrand = TestIntegrand::new(gpu(), 3, 3, film);
    let params = |seed| AdaptiveParams {
        min_spp: 8,
        ..AdaptiveParams::new(200.0, seed)
    };
    let (a, ca) = render(&integrand, params(5));
    let (b, cb) = render(&integrand, params(5));
    let (c, _) = render(&integrand, params(6));
    assert_eq!(image_bits(&a), image_bits(&b));
    assert_eq!(ca, cb);
    assert_eq!(a.samples, b.samples);
    assert_ne!(image_bits(&a), image_bits(&c));
    // Noise everywhere too.
    let n = noisy(film);
    let (a, _) = render(&n, params(1));
    let (b, _) = render(&n, params(1));
    assert_eq!(image_bits(&a), image_bits(&b));
}

/// Area of the unit pixel (i, j) where 0.8·x + 0.6·y < 7.3 (case 3):
/// the square clipped by the half-plane (Sutherland–Hodgman), shoelace.
fn edge_area(i: u32, j: u32) -> f64 {
    let (x0, y0) = (i as f64, j as f64);
    let square = [
        (x0, y0),
        (x0 + 1.0, y0),
        (x0 + 1.0, y0 + 1.0),
        (x0, y0 + 1.0),
    ];
    let g = |p: (f64, f64)| 7.3 - 0.8 * p.0 - 0.6 * p.1;
    let mut poly = Vec::new();
    for k in 0..4 {
        let (a, b) = (square[k], square[(k + 1) % 4]);
        let (ga, gb) = (g(a), g(b));
        if ga >= 0.0 {
            poly.push(a);
        }
        if (ga >= 0.0) != (gb >= 0.0) {
            let t = ga / (ga - gb);
            poly.push((a.0 + t * (b.0 - a.0), a.1 + t * (b.1 - a.1)));
        }
    }
    let n = poly.len();
    (0..n)
        .map(|k| {
            let (a, b) = (poly[k], poly[(k + 1) % n]);
            a.0 * b.1 - b.0 * a.1
        })
        .sum::<f64>()
        .abs()
        / 2.0
}

fn relmse(image: &[[f32; 3]], reference: &[f64]) -> f64 {
    image
        .iter()
        .zip(reference)
        .map(|(p, &r)| {
            p.iter()
                .map(|&x| (x as f64 - r).powi(2) / (r * r + 0.01))
                .sum::<f64>()
        })
        .sum::<f64>()
        / (3 * image.len()) as f64
}

#[test]
fn known_answer_on_a_sharp_edge() {
    // Case 3: f = 1 left of the line 0.8x + 0.6y = 7.3, 0 right of it;
    // a pixel's mean is the area of its part left of the line.
    let film = Film {
        width: 16,
        height: 12,
    };
    let integrand = TestIntegrand::new(gpu(), 3, 3, film);
    let reference: Vec<f64> = (0..film.height)
        .flat_map(|j| (0..film.width).map(move |i| edge_area(i, j)))
        .collect();
    let params = AdaptiveParams::new(400.0, 17);
    let (r, counts) = render(&integrand, params);
    // Pixels wholly on one side see one value: converged at the first
    // check, exact.
    for (k, &a) in reference.iter().enumerate() {
        if a == 0.0 || a == 1.0 {
            assert_eq!(r.image[k], [a as f32; 3], "pixel {k}");
        }
    }
    // The bound: with n independent uniform samples a pixel of mean m has
    // variance m(1 − m)/n, so at n ≥ 80 (every pixel's first check) the
    // expected RelMSE of i.i.d. sampling is at most
    //   B = mean over pixels of m(1 − m) / (80 · (m² + 0.01)).
    // The Cranley–Patterson-rotated Halton estimate of each pixel is
    // unbiased at a fixed n and, on an edge, its variance falls faster
    // than 1/n; the edge pixels take more than 80 samples. So the
    // RelMSE must come out below B itself (the stopping rule's bias
    // included), and far below it in practice.
    let bound = reference
        .iter()
        .map(|&m| m * (1.0 - m) / (80.0 * (m * m + 0.01)))
        .sum::<f64>()
        / reference.len() as f64;
    let e = relmse(&r.image, &reference);
    let edge: Vec<usize> = (0..reference.len())
        .filter(|&k| reference[k] > 0.0 && reference[k] < 1.0)
        .collect();
    let edge_spp = edge.iter().map(|&k| counts[k] as f64).sum::<f64>() / edge.len() as f64;
    eprintln!(
        "edge: RelMSE {e:.3e} (bound {bound:.3e}), {} edge pixels at {edge_spp:.0} spp, {} samples",
        edge.len(),
        r.samples
    );
    assert!(e < bound, "RelMSE {e} against bound {bound}");
    // Adaptivity put the samples on the edge.
    assert!(edge_spp > 80.0);
    // And the film's total is close: |Σ error| ≤ 3 · √(Σ m(1−m)/80).
    let total: f64 = r.image.iter().map(|p| p[0] as f64).sum();
    let exact: f64 = reference.iter().sum();
    let sigma = (reference.iter().map(|&m| m * (1.0 - m)).sum::<f64>() / 80.0).sqrt();
    assert!(
        (total - exact).abs() <= 3.0 * sigma,
        "{total} vs {exact} ± {sigma}"
    );
}

/// Smooth, pixel-varying noise with a CPU twin: intensities below and
/// above 1, so that pixels converge at different checks.
const WAVY: &str = "
fn integrand(p: ptr<function, IntegrandPoint>) -> vec3<f32> {
    let f = (*p).film;
    let c = 0.1 + 1.2 * (0.5 + 0.5 * sin(0.9 * f.x + 1.7 * f.y));
    let t = 6.2831853 * (3.7 * (*p).u[0] + 1.3 * fract(f.x) + 0.7 * fract(f.y));
    return c * vec3<f32>(1.0 + sin(t), 1.0 + sin(t + 2.0), 1.0 + 0.5 * sin(2.0 * t));
}";

fn wavy_cpu(film: Film, seed: u32) -> impl FnMut(u32, u32) -> Option<[f64; 3]> {
    move |pixel, index| {
        let (i, j) = (pixel % film.width, pixel / film.width);
        let fx = halton_point(0, index, pixel, seed);
        let fy = halton_point(1, index, pixel, seed);
        let u0 = halton_point(2, index, pixel, seed);
        let (x, y) = (i as f64 + fx, j as f64 + fy);
        let c = 0.1 + 1.2 * (0.5 + 0.5 * (0.9 * x + 1.7 * y).sin());
        let t = std::f64::consts::TAU * (3.7 * u0 + 1.3 * fx + 0.7 * fy);
        Some([
            c * (1.0 + t.sin()),
            c * (1.0 + (t + 2.0).sin()),
            c * (1.0 + 0.5 * (2.0 * t).sin()),
        ])
    }
}

#[test]
fn sample_counts_match_the_cpu_oracle() {
    let film = Film {
        width: 12,
        height: 9,
    };
    let integrand = Inline {
        film,
        dims: 3,
        body: WAVY,
    };
    // Threshold and seed chosen (with the oracle alone) for pixels that
    // stop at many different checks while no decision lies within 10⁻³
    // of the threshold: 14 checks, pixels stopping at 64 to 304 samples.
    let seed = 7;
    // Unlimited (the rule ends it), then a budget that cuts it short.
    for spp in [4096.0, 60.0] {
        let params = AdaptiveParams {
            min_spp: 8,
            spp_max: 512,
            ..AdaptiveParams::new(spp, seed).with_threshold(0.02)
        };
        let oracle = adaptive::simulate(&params, film, wavy_cpu(film, seed));
        let (r, counts) = render(&integrand, params);
        let distinct: std::collections::BTreeSet<u32> = oracle.counts.iter().copied().collect();
        eprintln!(
            "spp {spp}: {} checks, margin {:.2e}, counts {distinct:?}",
            oracle.checks, oracle.margin
        );
        // The GPU sums in f32 and the oracle in f64: a decision closer to
        // the threshold than this could go either way.
        assert!(
            oracle.margin > 1e-3,
            "a decision within {} of the threshold",
            oracle.margin
        );
        assert_eq!(r.samples, oracle.samples, "spp {spp}");
        assert_eq!(counts, oracle.counts, "spp {spp}");
        if spp > 1000.0 {
            assert!(distinct.len() >= 3, "pixels should stop at several counts");
        }
    }
}

#[test]
fn the_budget_is_never_exceeded() {
    let film = Film {
        width: 9,
        height: 5,
    };
    let pixels = 45u64;
    let integrand = noisy(film);
    for spp in [1.0, 7.5, 80.0, 100.0, 333.3] {
        for threshold in [0.0f32, 0.01] {
            let params = AdaptiveParams {
                threshold,
                ..AdaptiveParams::new(spp, 2)
            };
            let budget = params.budget(pixels);
            assert_eq!(budget, (spp * pixels as f64).floor() as u64);
            let (r, counts) = render(&integrand, params);
            assert!(r.samples <= budget, "spp {spp}: {} > {budget}", r.samples);
            if threshold == 0.0 {
                // Nothing converges: the budget is spent exactly and evenly.
                assert_eq!(r.samples, budget);
                let (lo, hi) = (counts.iter().min().unwrap(), counts.iter().max().unwrap());
                assert!(hi - lo <= 1, "spp {spp}: {lo}..{hi}");
            }
        }
    }
    // The per-pixel cap.
    let params = AdaptiveParams {
        threshold: 0.0,
        spp_max: 100,
        ..AdaptiveParams::new(1000.0, 2)
    };
    let (r, counts) = render(&integrand, params);
    assert!(counts.iter().all(|&c| c == 100));
    assert_eq!(r.samples, 100 * pixels);
    // A cap below the first check (80): no check, every pixel at the cap.
    let params = AdaptiveParams {
        spp_max: 40,
        ..AdaptiveParams::new(1000.0, 2)
    };
    let (r, counts) = render(&integrand, params);
    assert!(counts.iter().all(|&c| c == 40), "{counts:?}");
    assert_eq!(r.samples, 40 * pixels);
    assert!(r.image.iter().all(|p| p.iter().all(|c| c.is_finite())));
}

#[test]
fn nonfinite_samples_are_counted_and_excluded() {
    // Case 1: NaN on u0 < ¼, +Inf on [¼, ⅜), else 1. The finite samples
    // are all 1 in both halves: every pixel converges at the first check.
    let film = Film {
        width: 10,
        height: 6,
    };
    let integrand = TestIntegrand::new(gpu(), 1, 3, film);
    let (r, counts) = render(&integrand, AdaptiveParams::new(500.0, 11));
    assert!(counts.iter().all(|&c| c == 80), "{counts:?}");
    assert!(r.image.iter().all(|p| *p == [1.0; 3]));
    assert_eq!(r.nonfinite_pixels(), 0);
    // u0 is Φ₅ (shifted): 75 = 3·5² of the 80 samples are stratified in
    // 25 cells each, the interval spans 9.375 cells, so each block of 25
    // has 8..=11; the other 5 samples anything: 24..=38 per pixel.
    let per_pixel = r.nonfinite as f64 / 60.0;
    assert!((24.0..=38.0).contains(&per_pixel), "{per_pixel}");
}

#[test]
fn below_the_first_check_it_is_halton() {
    // A budget of 8 spp never reaches the first check (80): every pixel
    // takes samples 0..8 of its sequence, as Halton at 8 spp does, summed
    // in the same order.
    let film = Film {
        width: 9,
        height: 7,
    };
    let integrand = TestIntegrand::new(gpu(), 3, 4, film);
    for per_invocation in [1, 8] {
        let mut a = AdaptiveHalton::new(AdaptiveParams::new(8.0, 3))
            .unwrap()
            .with_samples_per_invocation(per_invocation);
        let r = a.render(gpu(), &integrand).unwrap();
        let h = Halton::new(8, 3)
            .with_samples_per_invocation(per_invocation)
            .render(gpu(), &integrand)
            .unwrap();
        assert_eq!(r.samples, h.samples);
        assert_eq!(image_bits(&r), image_bits(&h), "{per_invocation}");
    }
}

/// `compare`'s budget search for pixel-adaptive Halton on the constant,
/// whose every pixel converges at the first check (80 samples): at a
/// target time far beyond that render's, the search finds the plateau (a
/// budget it did not spend), compares the converged render at both ends
/// of its bracket, below the target time.
#[test]
fn compare_search_stops_at_the_plateau_of_a_converged_render() {
    use mdas::compare::adaptive::{params, search};
    let film = Film {
        width: 16,
        height: 12,
    };
    let integrand = Inline {
        film,
        dims: 3,
        body: CONSTANT,
    };
    let exact = vec![[0.25f32, 0.5, 2.0]; 192];
    let mut a = AdaptiveHalton::new(params(200.0, 0)).unwrap();
    let converged = mdas::compare::measure(gpu(), &mut a, &integrand, 1)
        .unwrap()
        .total_ms();
    let bar = indicatif::ProgressBar::hidden();
    let s = search(
        gpu(),
        &mut a,
        &integrand,
        &exact,
        50.0 * converged,
        1,
        4096,
        &bar,
    )
    .unwrap();
    let c = s.converged_spp.expect("the plateau was not found");
    assert!(c > 80, "converged at a budget of {c}");
    assert_eq!((s.eq.lo.spp, s.eq.hi.spp), (c, c));
    assert_eq!(s.eq.lo.measured.render.samples, 80 * 192);
    assert!(s.eq.lo.measured.total_ms() < s.eq.target_ms);
}
