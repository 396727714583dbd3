//! MDAS parameter validation and capacity checks: every invalid
//! combination is an error that names the parameter, raised before any GPU
//! work.

mod common;
mod mdas_support;

use common::{gpu, TestIntegrand};
use mdas::film::Film;
use mdas::integrator::mdas::MdasParams;
use mdas::integrator::{Integrator, Mdas};
use mdas_support::params;

fn new_err(p: MdasParams) -> String {
    format!(
        "{:#}",
        Mdas::new(p).err().expect("parameters should be rejected")
    )
}

#[test]
fn invalid_parameters_are_rejected_by_new() {
    let ok = params(1, 2, 1, 8.0, 0);
    assert!(Mdas::new(ok).is_ok());
    assert!(Mdas::new(MdasParams::default()).is_ok());
    type Edit = Box<dyn Fn(&mut MdasParams)>;
    let cases: Vec<(&str, Edit)> = vec![
        (
            "max_samples_per_leaf",
            Box::new(|p| p.max_samples_per_leaf = 1),
        ),
        (
            "max_samples_per_leaf",
            Box::new(|p| p.max_samples_per_leaf = 15),
        ),
        (
            "initial_samples_per_cell",
            Box::new(|p| p.initial_samples_per_cell = 0),
        ),
        (
            "initial_samples_per_cell",
            Box::new(|p| p.initial_samples_per_cell = 5),
        ),
        ("candidates", Box::new(|p| p.candidates = 0)),
        ("candidates", Box::new(|p| p.candidates = 65)),
        ("alpha", Box::new(|p| p.alpha = -0.5)),
        ("alpha", Box::new(|p| p.alpha = f32::NAN)),
        ("scale_factor", Box::new(|p| p.scale_factor = 0.0)),
        ("scale_factor", Box::new(|p| p.scale_factor = f32::INFINITY)),
        ("spp", Box::new(|p| p.spp = 0.0)),
        ("spp", Box::new(|p| p.spp = f32::NAN)),
        ("epsilon", Box::new(|p| p.epsilon = 0.0)),
        ("epsilon", Box::new(|p| p.epsilon = f32::INFINITY)),
        ("extra_image_bits", Box::new(|p| p.extra_image_bits = 13)),
    ];
    for (key, change) in cases {
        let mut p = ok;
        change(&mut p);
        let e = new_err(p);
        assert!(
            e.contains(key),
            "error for a bad {key} does not name it: {e}"
        );
    }
}

fn render_err(p: MdasParams, dims: u32, film: Film) -> String {
    let gpu = gpu();
    let integrand = TestIntegrand::new(gpu, 0, dims, film);
    let e = Mdas::new(p)
        .unwrap()
        .render(gpu, &integrand)
        .expect_err("render should fail");
    format!("{e:#}")
}

#[test]
fn invalid_combinations_with_the_integrand_are_rejected_at_render() {
    let film = Film {
        width: 8,
        height: 8,
    };
    // Budget below the initial samples: 2^(3·1 + 2·2) cells × 1 > 1 × 64.
    let e = render_err(params(1, 2, 1, 1.0, 0), 3, film);
    assert!(e.contains("initial samples") && e.contains("spp"), "{e}");
    // Morton code too wide: 8·3 + 2·2 = 28 bits.
    let e = render_err(params(3, 2, 1, 8.0, 0), 8, film);
    assert!(e.contains("Morton") && e.contains("28"), "{e}");
    // Too few or too many dimensions.
    for dims in [2, 17] {
        let e = render_err(params(0, 1, 1, 8.0, 0), dims, film);
        assert!(e.contains("dimensions"), "{e}");
    }
    // Budget beyond the 27-bit sample index.
    let e = render_err(
        params(0, 1, 1, 3.0e6, 0),
        3,
        Film {
            width: 8,
            height: 8,
        },
    );
    assert!(e.contains("exceeds"), "{e}");
}

/// The capacity check. The arrays that grow with the budget are paged, so
/// a binding limit one byte below what the samples' coordinates need
/// splits them into more pages instead of refusing the render; what is
/// refused, before any GPU work, is a layout needing more storage buffers
/// than the adapter allows per shader stage, or accumulators (32 B per
/// pixel, never paged) beyond one binding. The render path refuses the
/// same way: a page cap that splits the arrays into more bindings than the
/// adapter has fails in `Mdas::render`'s own check.
#[test]
fn capacity_is_checked_against_the_adapter_before_any_work() {
    let gpu = gpu();
    let film = Film {
        width: 256,
        height: 256,
    };
    let mut mdas = Mdas::new(params(1, 4, 1, 7.0, 0)).unwrap();
    let integrand = TestIntegrand::new(gpu, 0, 3, film);
    let cfg = mdas.config(&integrand).unwrap();
    assert!(cfg.check_limits(&gpu.limits).is_ok());
    let tight = wgpu::Limits {
        max_storage_buffer_binding_size: cfg.samples_bytes() - 1,
        ..gpu.limits.clone()
    };
    let paged = cfg.clone().for_limits(&tight, None).unwrap();
    assert_eq!(paged.pages.count[1], 2, "{:?}", paged.pages);
    assert!(paged.pages.extra() >= 1);

    let few = wgpu::Limits {
        max_storage_buffers_per_shader_stage: 8 + paged.pages.extra() - 1,
        ..tight.clone()
    };
    let e = format!("{:#}", cfg.check_limits(&few).unwrap_err());
    assert!(
        e.contains("MDAS capacity") && e.contains("storage buffers") && e.contains("MiB"),
        "{e}"
    );
    let small_binding = wgpu::Limits {
        max_storage_buffer_binding_size: cfg.accum_bytes() - 1,
        max_storage_buffers_per_shader_stage: 1000,
        ..gpu.limits.clone()
    };
    let e = format!("{:#}", cfg.check_limits(&small_binding).unwrap_err());
    assert!(e.contains("'mdas.accum'"), "{e}");

    // On the adapter: pages of 64 bytes need thousands of bindings.
    mdas = mdas.with_max_page_bytes(64);
    let e = format!("{:#}", mdas.render(gpu, &integrand).err().unwrap());
    assert!(
        e.contains("MDAS capacity") && e.contains("storage buffers"),
        "{e}"
    );
}

/// The defaults of a scene without an `[mdas]` table fit any film and
/// dimension count at 1 spp: the grid chosen for the render never holds
/// more than the budget, and a render takes the whole budget.
#[test]
fn film_defaults_fit_one_spp_on_any_film() {
    let gpu = gpu();
    for (w, h) in [(1, 1), (3, 2), (16, 12), (128, 128), (640, 360), (97, 1000)] {
        let film = Film {
            width: w,
            height: h,
        };
        let p = MdasParams {
            spp: 1.0,
            ..MdasParams::for_film(film)
        };
        assert!(p.auto_grid);
        let r = p.resolved(film);
        let initial = u64::from(r.initial_samples_per_cell) << (2 * r.extra_image_bits);
        assert!(
            initial <= u64::from(w * h),
            "{w}×{h}: e = {}, {initial} initial samples",
            r.extra_image_bits
        );
        for dims in [3, 4, 7] {
            if (w * h > 20_000) && dims != 4 {
                continue; // the large films once, to keep the test short
            }
            let integrand = TestIntegrand::new(gpu, 0, dims, film);
            let render = Mdas::new(p).unwrap().render(gpu, &integrand).unwrap();
            assert_eq!(render.samples, u64::from(w * h), "{w}×{h}, {dims}D");
        }
    }
}

/// The automatic grid (issue 48) over films and budgets: it never holds
/// more than [`AUTO_INITIAL_SHARE`] of the budget (all of it only for a
/// budget below two samples), its cells are no wider than a pixel
/// whenever the budget gives each pixel-wide cell a sample within that
/// share, they hold [`AUTO_MIN_SAMPLES_PER_CELL`] or more when the grid is
/// finer than a pixel, and l stays within its range; `resolved` raises m
/// to l + 1 and leaves a fixed grid alone.
#[test]
fn automatic_grid_fits_the_budget_and_the_pixels() {
    use mdas::integrator::mdas::params::{
        auto_grid, AUTO_INITIAL_SHARE, AUTO_MAX_SAMPLES_PER_CELL, AUTO_MIN_SAMPLES_PER_CELL,
    };
    for (w, h) in [
        (1, 1),
        (3, 2),
        (16, 12),
        (128, 96),
        (96, 128),
        (1000, 97),
        (1920, 1080),
        (4096, 4096),
    ] {
        let pixels = f64::from(w) * f64::from(h);
        let pixel_fine = f64::from(w.max(h)).log2().ceil() as u32;
        for spp in [
            0.01f32, 0.5, 1.0, 2.0, 3.0, 4.5, 8.0, 16.0, 32.0, 64.0, 1024.0,
        ] {
            let budget = (f64::from(spp) * pixels).round().max(1.0);
            let film = Film {
                width: w,
                height: h,
            };
            let (e, l) = auto_grid(film, spp);
            let initial = f64::from(l) * 4f64.powi(e as i32);
            let case = format!("{w}×{h} at {spp} spp: e = {e}, l = {l}");
            assert!((1..=AUTO_MAX_SAMPLES_PER_CELL).contains(&l), "{case}");
            assert!(e <= 13, "{case}");
            assert!(initial <= budget, "{case}");
            if budget >= 2.0 {
                assert!(initial <= AUTO_INITIAL_SHARE * budget, "{case}");
            }
            let fits_pixel_fine = AUTO_INITIAL_SHARE * budget >= 4f64.powi(pixel_fine as i32);
            if budget >= 2.0 {
                assert_eq!(e >= pixel_fine, fits_pixel_fine, "{case}");
            }
            if e > pixel_fine {
                assert!(l >= AUTO_MIN_SAMPLES_PER_CELL, "{case}");
            }
            let p = MdasParams {
                spp,
                max_samples_per_leaf: 4,
                ..MdasParams::for_film(film)
            };
            let r = p.resolved(film);
            assert_eq!(
                (
                    r.bits_per_dim,
                    r.extra_image_bits,
                    r.initial_samples_per_cell
                ),
                (0, e, l)
            );
            assert_eq!(r.max_samples_per_leaf, (l + 1).max(4), "{case}");
            let fixed = MdasParams {
                auto_grid: false,
                ..p
            };
            assert_eq!(fixed.resolved(film), fixed);
        }
    }
}
