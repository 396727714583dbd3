//! Equal-time machinery: timing medians and Halton budget matching.

mod common;
mod mdas_support;

use common::gpu;
use mdas::compare::{halton_at_equal_time, measure};
use mdas::integrator::Halton;
use mdas::session;
use std::path::Path;

#[test]
fn halton_budget_search_brackets_the_target_time() {
    let gpu = gpu();
    let prepared = session::prepare(gpu, Path::new("scenes/area_light_plane.toml"), 0.25).unwrap();
    let (w, h) = (prepared.film.width, prepared.film.height);
    let reference = mdas::analytic::area_light_plane_image(w, h);
    // Target: the time Halton itself needs at 24 spp.
    let target = measure(gpu, &mut Halton::new(24, 0), prepared.integrand.as_ref(), 3).unwrap();
    let t = target.total_ms();
    let eq = halton_at_equal_time(
        gpu,
        prepared.integrand.as_ref(),
        &reference,
        t,
        0,
        3,
        1 << 16,
    )
    .unwrap();
    let (lo, hi) = (&eq.lo, &eq.hi);
    // The target (24 spp's time) lies far inside 1..=65536 spp: the search
    // must bracket it.
    assert!(lo.spp < hi.spp, "no bracket: {} and {} spp", lo.spp, hi.spp);
    assert!(
        lo.measured.total_ms() <= t && t <= hi.measured.total_ms(),
        "{} ≤ {t} ≤ {}",
        lo.measured.total_ms(),
        hi.measured.total_ms()
    );
    let (a, b) = (
        lo.error.relmse.min(hi.error.relmse),
        lo.error.relmse.max(hi.error.relmse),
    );
    assert!(
        a <= eq.relmse && eq.relmse <= b,
        "interpolated {} outside [{a}, {b}]",
        eq.relmse
    );
    // Timing noise on a shared CPU device is large, but the matched budget
    // must be of the right magnitude.
    assert!(
        (4..=144).contains(&lo.spp),
        "matched spp {} for a 24-spp target",
        lo.spp
    );
    assert_eq!(lo.measured.render.samples, (w * h * lo.spp) as u64);
}

/// The seed intervals are calibrated: Halton (unbiased: its random shifts
/// make every pixel estimate unbiased) over 3 seeds, against the exact
/// image of the closed-form scene, gives a relative-bias interval that
/// covers 0 (the true bias) in at least 18 of 20 repetitions with
/// distinct seeds, as a 95% interval should (the bar is ≥ 90%;
/// P(≥ 18 of 20 | 95%) = 0.92). The seeds are fixed, so the outcome is
/// deterministic. The bias/variance split adds up to the mean MSE.
#[test]
fn seed_intervals_cover_the_exact_answer() {
    use mdas::compare::seeds::SeedStats;
    use mdas::integrator::Integrator;
    let gpu = gpu();
    let prepared = session::prepare(gpu, Path::new("scenes/area_light_plane.toml"), 0.25).unwrap();
    let (w, h) = (prepared.film.width, prepared.film.height);
    let exact = mdas::analytic::area_light_plane_image(w, h);
    let mut halton = Halton::new(4, 0);
    let mut covered = 0;
    for rep in 0..20u32 {
        let images: Vec<Vec<[f32; 3]>> = (0..3)
            .map(|s| {
                halton.seed = 100 + 3 * rep + s;
                halton
                    .render(gpu, prepared.integrand.as_ref())
                    .unwrap()
                    .image
            })
            .collect();
        let views: Vec<&[[f32; 3]]> = images.iter().map(|v| v.as_slice()).collect();
        let s = SeedStats::new(&views, &exact).unwrap();
        let [lo, hi] = s.relative_bias_ci95[0];
        if lo <= 0.0 && 0.0 <= hi {
            covered += 1;
        }
        assert!((s.mse_bias2 + s.mse_variance - s.mse).abs() <= 1e-12 * s.mse);
        assert!(s.relmse_ci95[0] <= s.relmse && s.relmse <= s.relmse_ci95[1]);
    }
    assert!(
        covered >= 18,
        "the interval covered the true bias {covered} times of 20"
    );
}

/// `compare_integrand`, `sweep_integrand` and `tune_integrand`: the
/// equal-time experiment, the budget sweep and the grid search on an
/// integrand built in
/// code, against an exact image given with it (the test integrand's edge,
/// whose pixel means are exact polygon areas). A reference of the wrong
/// size or with a non-finite pixel is refused before the output directory
/// exists; a valid one gives a report that records the reference as exact
/// (no spp, no error estimate), a provenance without a scene digest, and
/// the files of `mdas compare`.
#[test]
fn compare_integrand_runs_on_an_integrand_built_in_code() {
    use mdas::compare::{compare_integrand, Budget, CompareSpec, ReferenceSource, Setup, Subject};
    use mdas::film::Film;
    use mdas::integrator::mdas::MdasParams;
    let gpu = gpu();
    let film = Film {
        width: 16,
        height: 12,
    };
    let edge = common::TestIntegrand::new(gpu, 3, 3, film);
    let exact = mdas_support::edge_image(film);
    let dir = std::env::temp_dir().join(format!("mdas-compare-integrand-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let out = dir.join("out");
    let identity = |p| p;
    let spec = CompareSpec {
        seeds: 2,
        ..CompareSpec::new(Setup::new("edge", out.clone(), &identity), Budget::MdasSpp)
    };
    let subject = |reference: &'static [[f32; 3]]| Subject {
        name: "edge".into(),
        scene_file: None,
        integrand: &edge,
        mdas: MdasParams {
            spp: 8.0,
            ..MdasParams::for_film(film)
        },
        reference,
        reference_source: ReferenceSource::Exact("polygon areas".into()),
        sampler: None,
        reference_sampler: None,
        visibility: None,
    };
    let short: &'static [[f32; 3]] = exact[1..].to_vec().leak();
    let e = format!(
        "{:#}",
        compare_integrand(gpu, &spec, &subject(short)).unwrap_err()
    );
    assert!(e.contains("191 pixels") && e.contains("16×12 = 192"), "{e}");
    let mut bad = exact.clone();
    bad[5][1] = f32::NAN;
    let e = format!(
        "{:#}",
        compare_integrand(gpu, &spec, &subject(bad.leak())).unwrap_err()
    );
    assert!(e.contains("pixel 5 is not finite"), "{e}");
    assert!(
        !out.exists(),
        "a refused comparison created {}",
        out.display()
    );

    let report = compare_integrand(gpu, &spec, &subject(exact.clone().leak())).unwrap();
    assert_eq!(report.scene, "edge");
    assert_eq!(report.reference.exact.as_deref(), Some("polygon areas"));
    assert_eq!(report.reference.spp, 0);
    assert!(report.reference.relmse_estimate.is_none());
    let provenance = report.provenance.as_ref().unwrap();
    assert!(provenance.scene_sha256.is_none());
    assert_eq!(provenance.integrand, "test");
    let eq = &report.equal_time;
    assert!(eq.mdas_relmse > 0.0 && eq.halton_relmse > 0.0);
    assert_eq!(eq.relmse_ratio, eq.mdas_relmse / eq.halton_relmse);
    for file in [
        "report.json",
        "figure.png",
        "reference.exr",
        "mdas.exr",
        "halton.exr",
        "index.html",
    ] {
        assert!(out.join(file).is_file(), "{file} missing");
    }
    // The page lands with the run and is listed with its files.
    assert_eq!(report.files["page"], "index.html");

    // The sweep on the same subject: a point per method and budget, MDAS's
    // budgets below its initial grid skipped, the reference recorded as
    // exact, the files written.
    let sweep_out = dir.join("sweep");
    let sweep_spec = mdas::compare::SweepSpec {
        setup: Setup::new("edge", sweep_out.clone(), &identity),
        spps: vec![4, 8],
        seeds: 2,
        adaptive: true,
    };
    let sweep =
        mdas::compare::sweep_integrand(gpu, &sweep_spec, &subject(exact.clone().leak())).unwrap();
    let points = |m: &str| sweep.rows.iter().filter(|r| r.method == m).count();
    // The initial grid at each budget (an automatic grid is chosen per
    // budget, a fixed one is the same at both).
    let initial = |spp: u32| {
        let p = MdasParams {
            spp: spp as f32,
            ..subject(short).mdas
        };
        mdas::integrator::Mdas::new(p)
            .unwrap()
            .config(&edge)
            .map_or(u32::MAX, |c| c.initial_samples)
    };
    let mdas_points = [4u32, 8].iter().filter(|&&s| s * 192 >= initial(s)).count();
    assert!(
        mdas_points > 0,
        "no MDAS point: {} initial samples",
        initial(8)
    );
    assert_eq!(points("mdas"), mdas_points);
    assert_eq!(sweep.mdas_skipped.len(), 2 - mdas_points);
    assert_eq!(points("halton"), 2);
    // Pixel-adaptive Halton at each budget, over Halton's seeds; below its
    // first check it spends the whole budget.
    assert_eq!(points("adaptive"), 2);
    for r in sweep.rows.iter().filter(|r| r.method == "adaptive") {
        assert_eq!(r.samples, u64::from(r.spp) * 192);
        let halton = sweep
            .rows
            .iter()
            .find(|h| h.method == "halton" && h.spp == r.spp)
            .unwrap();
        assert_eq!(r.seeds, halton.seeds);
    }
    assert_eq!(sweep.reference_exact.as_deref(), Some("polygon areas"));
    assert!(sweep.provenance.scene_sha256.is_none());
    assert!(sweep
        .rows
        .iter()
        .all(|r| r.relmse > 0.0 && r.relmse.is_finite()));
    for file in ["sweep.csv", "sweep.json", "sweep.png"] {
        assert!(sweep_out.join(file).is_file(), "{file} missing");
    }

    // `tune` on the same subject: one row per grid configuration, the
    // Halton points around the budget, the reference recorded as exact.
    // A grid with no configuration that can run is refused before the
    // output directory exists.
    let tune_out = dir.join("tune");
    let tune_spec = |grid: &str| mdas::compare::TuneSpec {
        setup: Setup::new("edge", tune_out.clone(), &identity),
        grid: vec![mdas::compare::tune::parse_grid_entry(grid).unwrap()],
        seeds: 2,
        equal_samples: true,
    };
    let e = format!(
        "{:#}",
        mdas::compare::tune_integrand(
            gpu,
            &tune_spec("max_samples_per_leaf=1"),
            &subject(exact.clone().leak())
        )
        .unwrap_err()
    );
    assert!(e.contains("no configuration of the grid can run"), "{e}");
    assert!(
        !tune_out.exists(),
        "a refused tune created {}",
        tune_out.display()
    );
    let tune = mdas::compare::tune_integrand(
        gpu,
        &tune_spec("reconstruction=box,pixel"),
        &subject(exact.leak()),
    )
    .unwrap();
    let mut labels: Vec<&str> = tune
        .rows
        .iter()
        .map(|r| r.measured.label.as_str())
        .collect();
    labels.sort_unstable();
    assert_eq!(labels, ["reconstruction=box", "reconstruction=pixel"]);
    assert_eq!(tune.reference_exact.as_deref(), Some("polygon areas"));
    assert_eq!((tune.reference_spp, tune.scene.as_str()), (0, "edge"));
    assert!(tune.provenance.scene_sha256.is_none());
    assert!(!tune.halton.is_empty());
    assert!(tune
        .rows
        .iter()
        .all(|r| r.measured.relmse > 0.0 && r.equal_samples_ratio.is_finite()));
    for file in ["tune.csv", "tune.json"] {
        assert!(tune_out.join(file).is_file(), "{file} missing");
    }
    let _ = std::fs::remove_dir_all(&dir);
}
