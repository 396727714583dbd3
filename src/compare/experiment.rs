//! `mdas compare`: MDAS against Halton at equal time on one scene (MDAS
//! paper §5), with every image, heat map and `report.json` written to one
//! directory.
//!
//! 1. Validate everything that needs no render: repeats, the time budget,
//!    the scene, MDAS's parameters against the integrand (a budget below
//!    its initial sample count fails here), then the output directory
//!    (created and probed for writing).
//! 2. The reference: Halton at `ref_spp` (`session::reference`, cached).
//! 3. Timing ([`super::measure`]): MDAS at its spp, then Halton's budget search
//!    at MDAS's median time ([`super::halton_at_equal_time`]). With
//!    [`Budget::TimeMs`] both methods get the same target and both are
//!    searched ([`super::search_equal_time`]; MDAS from the smallest spp its
//!    initial grid allows, and it is an error if even that is slower than
//!    the budget). Then interleaved rounds around the bracket give the
//!    target (MDAS's fastest round) and Halton's time fit, and each method
//!    is rendered with `--seeds` seeds ([`super::intervals`]).
//! 4. An untimed MDAS render with the sample-density read-back.
//! 5. Only then files are written, into the run's staging directory
//!    ([`crate::atomic::StagedDir`], made before any GPU work), and moved
//!    into `--out` as one unit, `report.json` last: a failure anywhere
//!    leaves the previous run's files untouched.
//!
//! The images written for a searched method are those of the bracketing
//! run nearer to the target time (`equal_time.*.image_run`), each the
//! first seed's; the methods' `relmse` are the means over seeds at those
//! runs' budgets, and the ratio uses Halton's RelMSE at the fitted spp.

use super::equal_time::{EqualTime, HaltonRun, TimeFit};
use super::heatmap;
use super::inputs::*;
use super::intervals;
use super::outputs::{write_outputs, CompareOutputs, Written};
use super::progress::{bar, spinner};
use super::report::*;
use super::seeds::SeedStats;
use super::timing::{halton_search, nearer, time_mdas, MdasTiming};
use crate::atomic::StagedDir;
use crate::gpu::Gpu;
use crate::image_io;
use crate::integrand::Integrand;
use crate::integrator::mdas::MdasParams;
use crate::integrator::{Halton, Mdas};
use crate::scene_file::SceneFile;
use crate::session::{self, IntegrandOverrides};
use anyhow::{bail, Context, Result};
use indicatif::ProgressBar;
use std::collections::BTreeMap;
use std::path::Path;

/// [`compare`] on an integrand built in code against a reference image
/// given with it (a closed form, or a render made elsewhere): the same
/// budget search, interleaved timing, seeds and intervals, report, images,
/// heat maps and figure, written as one unit into `spec.setup.out`.
/// `spec.setup`'s scene, scale, reference spp, cache directory and
/// parameter mapping are not used (the subject carries them);
/// [`Setup::new`] fills them. `examples/custom_integrand.rs` runs it
/// (`make test` runs that example, so this sketch is not compiled again
/// as a doc test):
///
/// ```ignore
/// # fn run(gpu: &mdas::gpu::Gpu, integrand: &dyn mdas::integrand::Integrand, exact: &[[f32; 3]]) -> anyhow::Result<()> {
/// use mdas::compare::{compare_integrand, Budget, CompareSpec, ReferenceSource, Setup, Subject};
/// use mdas::integrator::mdas::MdasParams;
/// let identity = |p| p;
/// let setup = Setup::new("my integrand", "out/mine".into(), &identity);
/// let spec = CompareSpec::new(setup, Budget::MdasSpp);
/// let subject = Subject {
///     name: "my integrand".into(),
///     scene_file: None,
///     integrand,
///     mdas: MdasParams { spp: 8.0, ..MdasParams::for_film(integrand.film()) },
///     reference: exact,
///     reference_source: ReferenceSource::Exact("closed form".into()),
///     sampler: None,
///     reference_sampler: None,
///     visibility: None,
/// };
/// let report = compare_integrand(gpu, &spec, &subject)?;
/// println!("MDAS/Halton RelMSE at equal time: {:.3}", report.equal_time.relmse_ratio);
/// # Ok(()) }
/// ```
pub fn compare_integrand(gpu: &Gpu, spec: &CompareSpec, subject: &Subject) -> Result<Report> {
    spec.setup.check()?;
    check_budget(spec.budget)?;
    check_reference(subject)?;
    let checked = check_inputs(spec, subject.mdas, subject.integrand, &subject.name)?;
    let staged = StagedDir::new(&spec.setup.out)?;
    compare_subject(gpu, spec, subject, checked, staged)
}

/// What the checks before any render find out: MDAS's least spp and each
/// method's seeds.
struct Checked {
    min_spp: u32,
    mdas_seeds: Vec<u32>,
    halton_seeds: Vec<u32>,
}

/// The checks of step 1 that concern MDAS, the crops and the seeds.
fn check_inputs(
    spec: &CompareSpec,
    params: MdasParams,
    integrand: &dyn Integrand,
    name: &str,
) -> Result<Checked> {
    let min_spp = check_mdas(params, spec.budget, integrand, name)?;
    let film = integrand.film();
    super::figure::check_crops(&spec.crops, film.width, film.height)?;
    let (mdas_seeds, halton_seeds) = intervals::seed_plan(
        spec.seeds,
        params.seed,
        spec.setup.halton_seed,
        spec.setup.ref_seed,
    )?;
    Ok(Checked {
        min_spp,
        mdas_seeds,
        halton_seeds,
    })
}

/// The smallest whole spp MDAS accepts with `params` (its budget must hold
/// the initial samples, 2^(d·b+2e)·l; 1 with an automatic grid, which
/// fits any budget).
pub fn mdas_min_spp(params: MdasParams, integrand: &dyn Integrand) -> Result<u32> {
    if params.auto_grid {
        return Ok(1);
    }
    let film = integrand.film();
    let pixels = film.width as u64 * film.height as u64;
    let bits = integrand.dims() * params.bits_per_dim + 2 * params.extra_image_bits;
    let initial = (1u64 << bits.min(40)) * params.initial_samples_per_cell as u64;
    let spp = initial.div_ceil(pixels).max(1);
    if spp > u32::MAX as u64 {
        bail!("MDAS's initial grid ({initial} samples) is far beyond any budget");
    }
    Ok(spp as u32)
}

/// Runs the comparison and writes everything (see the module docs) as one
/// unit ([`crate::atomic::StagedDir`]): on failure the output directory
/// keeps the previous run's files, and one this call created is removed.
pub fn compare(gpu: &Gpu, spec: &CompareSpec) -> Result<Report> {
    compare_with(gpu, spec, IntegrandOverrides::default())
}

/// [`compare`] with the compared renders' `[integrand]` overridden
/// (`mdas compare --sampler`); the reference keeps the scene's own table
/// (`session::reference`).
pub fn compare_with(
    gpu: &Gpu,
    spec: &CompareSpec,
    overrides: IntegrandOverrides,
) -> Result<Report> {
    run_compare(gpu, spec, overrides)
}

/// A `--time-ms` budget must be a positive time.
pub(crate) fn check_budget(budget: Budget) -> Result<()> {
    if let Budget::TimeMs(t) = budget {
        if !(t.is_finite() && t > 0.0) {
            bail!("--time-ms must be a positive number of milliseconds, got {t}");
        }
    }
    Ok(())
}

/// Checks that MDAS with `params` can render `integrand` under `budget`
/// (at its spp, or at the least spp its initial grid allows); returns that
/// least spp.
pub(crate) fn check_mdas(
    params: MdasParams,
    budget: Budget,
    integrand: &dyn Integrand,
    name: &str,
) -> Result<u32> {
    let min_spp = mdas_min_spp(params, integrand)?;
    let check_spp = match budget {
        Budget::MdasSpp => params.spp,
        Budget::TimeMs(_) => min_spp as f32,
    };
    Mdas::new(MdasParams {
        spp: check_spp,
        ..params
    })?
    .config(integrand)
    .with_context(|| format!("MDAS cannot render {name} at spp {check_spp}"))?;
    Ok(min_spp)
}

/// What a report says of `visibility`: nothing for the exact BVH.
pub(crate) fn voxel_note(visibility: crate::accel::Visibility) -> Option<String> {
    visibility.is_voxel().then(|| visibility.describe())
}

/// Writes `report.json` (atomically) into `out`.
pub(crate) fn write_report(out: &Path, report: &Report) -> Result<()> {
    let json = serde_json::to_string_pretty(report)?;
    image_io::write_atomic(&out.join("report.json"), |temp| {
        std::fs::write(temp, json.as_bytes()).map_err(Into::into)
    })
}

fn run_compare(gpu: &Gpu, spec: &CompareSpec, overrides: IntegrandOverrides) -> Result<Report> {
    // 1. Validation, before any render or file.
    spec.setup.check()?;
    check_budget(spec.budget)?;
    let overrides = IntegrandOverrides {
        frame: spec.setup.frame,
        ..overrides
    };
    let scene = SceneFile::load(&spec.setup.scene)?;
    for w in scene.integrand.light_warnings(&scene.scene) {
        eprintln!("warning: {w}");
    }
    let staged = StagedDir::new(&spec.setup.out)?;
    let reference_sampler = session::light_sampler(&scene.integrand);
    let prepared =
        session::prepare_loaded(gpu, scene, &spec.setup.scene, spec.setup.scale, overrides)?;
    let sampler = session::light_sampler(&prepared.scene.integrand);
    let integrand = prepared.integrand.as_ref();
    let params = (spec.setup.mdas_params)(prepared.scene.mdas);
    let name = spec.setup.scene.display().to_string();
    let checked = check_inputs(spec, params, integrand, &name)?;

    // 2. Reference.
    let (reference, path, cached) = spec.setup.reference(gpu)?;
    let subject = Subject {
        sampler: sampler.map(|k| k.to_string()),
        reference_sampler: reference_sampler.map(|k| k.to_string()),
        visibility: voxel_note(prepared.scene.visibility),
        ..spec
            .setup
            .scene_subject(integrand, params, &reference, path, cached)
    };
    compare_subject(gpu, spec, &subject, checked, staged)
}

/// Steps 3–5 of the module docs on a subject that passed
/// [`check_inputs`], writing into `staged`: the searches, the interleaved
/// timing, the seeds, the density map, then the files and the report.
fn compare_subject(
    gpu: &Gpu,
    spec: &CompareSpec,
    subject: &Subject,
    checked: Checked,
    staged: StagedDir,
) -> Result<Report> {
    let searched = search(gpu, spec, subject, checked.min_spp)?;
    let mut timed = time_interleaved(gpu, spec, subject, &searched)?;
    let seeded = over_seeds(gpu, spec, subject, &checked, &searched, &mut timed)?;
    let third = spec
        .adaptive
        .then(|| third_method(gpu, spec, subject, &checked, &searched, &timed, &seeded))
        .transpose()?;
    // 4. Sample density of the MDAS run (untimed; same seed, same image).
    timed.status.set_message("mdas sample density");
    let (_, density) = Mdas::new(MdasParams {
        spp: searched.mdas_spp as f32,
        ..subject.mdas
    })?
    .render_with_density(gpu, subject.integrand)?;
    timed.status.inc(1);
    timed.status.finish_and_clear();
    report(
        gpu,
        spec,
        subject,
        &checked,
        &searched,
        timed,
        seeded,
        third.as_ref(),
        &density,
        staged,
    )
}

/// Step 3d: pixel-adaptive Halton at the target time and at equal samples
/// ([`super::adaptive`]), with Halton's seeds.
fn third_method(
    gpu: &Gpu,
    spec: &CompareSpec,
    subject: &Subject,
    checked: &Checked,
    searched: &Searched,
    timed: &Timed,
    seeded: &Seeded,
) -> Result<super::adaptive::Third> {
    super::adaptive::run(
        gpu,
        &super::adaptive::Inputs {
            integrand: subject.integrand,
            reference: subject.reference,
            seeds: &checked.halton_seeds,
            repeats: spec.setup.repeats,
            max_spp: spec.max_spp,
            target_ms: timed.target_ms,
            target_times: &timed.target_times,
            halton_fit: timed.halton_fit.as_ref(),
            halton_spp: timed.halton_spp,
            halton_n0: &seeded.halton_n0,
            halton_n1: &seeded.halton_n1,
            halton_relmse: seeded.halton_relmse,
            mdas: &seeded.mdas,
            equal_spp: (searched.mdas_spp.round() as u32).max(1),
            halton_equal: &seeded.halton_equal,
        },
        &timed.status,
    )
}

/// Step 3: MDAS's run (or its search under a time budget) and Halton's
/// search for MDAS's time.
struct Searched {
    mdas_main: HaltonRun,
    mdas_spp: f64,
    mdas_search: Option<EqualTime>,
    halton_eq: EqualTime,
    /// The bracketing Halton run nearer to the target: its images are
    /// written.
    halton_main: HaltonRun,
}

fn search(gpu: &Gpu, spec: &CompareSpec, subject: &Subject, min_spp: u32) -> Result<Searched> {
    let status = spinner(spec.setup.progress);
    let MdasTiming {
        run: mdas_main,
        spp: mdas_spp,
        search: mdas_search,
        target_ms,
    } = time_mdas(
        gpu,
        subject.mdas,
        min_spp,
        subject.integrand,
        subject.reference,
        &spec.setup,
        spec.budget,
        spec.max_spp,
        &status,
        "mdas",
    )?;
    let halton_eq = halton_search(
        gpu,
        subject.integrand,
        subject.reference,
        target_ms,
        &spec.setup,
        spec.max_spp,
        &status,
        "halton",
    )?;
    let halton_main = nearer(&halton_eq).clone();
    status.finish_and_clear();
    Ok(Searched {
        mdas_main,
        mdas_spp,
        mdas_search,
        halton_eq,
        halton_main,
    })
}

/// Step 3b: interleaved timing around the bracket (module docs of
/// `intervals`), and the integrators the seeds reuse.
struct Timed {
    timing: intervals::Interleaved,
    halton_fit: Option<TimeFit>,
    target_ms: f64,
    target_times: Vec<f64>,
    /// Halton's spp at the target time.
    halton_spp: f64,
    /// The spread of MDAS's timed rounds (`Budget::MdasSpp` only).
    target_spread: Option<f64>,
    flags: Vec<String>,
    /// One MDAS and one Halton for the rounds and the seeds, so their
    /// pipelines compile once.
    mdas: Mdas,
    halton: Halton,
    /// From here on the number of renders is known: a bar with an ETA
    /// (its length grows once the seeds' budgets are known).
    status: ProgressBar,
}

fn time_interleaved(
    gpu: &Gpu,
    spec: &CompareSpec,
    subject: &Subject,
    searched: &Searched,
) -> Result<Timed> {
    let budgets = intervals::budgets_around(searched.halton_eq.hi.spp, spec.max_spp);
    let rounds = spec.setup.repeats.max(intervals::MIN_ROUNDS);
    let mdas_rounds = matches!(spec.budget, Budget::MdasSpp) as u64;
    let status = bar(
        spec.setup.progress,
        rounds as u64 * (mdas_rounds + budgets.len() as u64),
        "compare {bar:30} {pos}/{len} renders: {msg} [{elapsed_precise} < {eta}]",
    );
    status.set_message("interleaved timing");
    let mut mdas = Mdas::new(MdasParams {
        spp: searched.mdas_spp as f32,
        ..subject.mdas
    })?;
    let mut halton = Halton::new(1, spec.setup.halton_seed);
    let timing = intervals::interleaved(
        gpu,
        match spec.budget {
            Budget::MdasSpp => Some(&mut mdas),
            Budget::TimeMs(_) => None,
        },
        &mut halton,
        &budgets,
        rounds,
        subject.integrand,
        &status,
    )?;
    let halton_fit = timing.fit();
    let (target_ms, target_times) = match spec.budget {
        Budget::MdasSpp => (timing.mdas_fastest(), timing.mdas_ms.clone()),
        Budget::TimeMs(t) => (t, vec![t]),
    };
    let mut flags = Vec::new();
    let halton_spp = intervals::spp_at_target(
        &searched.halton_eq,
        halton_fit.as_ref(),
        target_ms,
        &mut flags,
    );
    flags.extend(halton_fit.iter().flat_map(|f| f.flags.clone()));
    let target_spread = matches!(spec.budget, Budget::MdasSpp).then(|| timing.mdas_spread());
    if let Some(s) = target_spread {
        if s > super::equal_time::MAX_SPREAD {
            flags.push(format!(
                "MDAS's timed rounds spread {:.0}% of their median (limit {:.0}%)",
                100.0 * s,
                100.0 * super::equal_time::MAX_SPREAD
            ));
        }
    }
    Ok(Timed {
        timing,
        halton_fit,
        target_ms,
        target_times,
        halton_spp,
        target_spread,
        flags,
        mdas,
        halton,
        status,
    })
}

/// Step 3c: each method over the seeds, the equal-time and equal-samples
/// ratios with their intervals, and the reference's own error.
struct Seeded {
    mdas: SeedStats,
    /// Halton at the written run's budget.
    halton_main: SeedStats,
    /// Halton interpolated at the target's spp, from the whole budgets
    /// either side of it.
    halton_relmse: f64,
    halton_n0: SeedStats,
    halton_n1: SeedStats,
    /// Halton at equal samples.
    halton_equal: SeedStats,
    ratio_ci95: [f64; 2],
    uniform: Option<(HaltonRun, SeedStats)>,
    equal_samples: EqualSamplesReport,
    ref_estimate: Option<f64>,
    ref_flag: Option<String>,
}

fn over_seeds(
    gpu: &Gpu,
    spec: &CompareSpec,
    subject: &Subject,
    checked: &Checked,
    searched: &Searched,
    timed: &mut Timed,
) -> Result<Seeded> {
    let (integrand, reference) = (subject.integrand, subject.reference);
    let status = &timed.status;
    // MDAS at its run's budget, Halton at the written run's budget, at the
    // whole spp either side of the target's and at MDAS's spp (equal
    // samples), each over `spec.seeds` seeds.
    let n0 = timed.halton_spp.floor().max(1.0) as u32;
    let equal_spp = (searched.mdas_spp.round() as u32).max(1);
    let halton_budgets: std::collections::BTreeSet<u32> =
        [searched.halton_main.spp, n0, n0 + 1, equal_spp].into();
    let k = spec.seeds as u64;
    // MDAS's and the written Halton run's first seeds are rendered.
    status.inc_length((k - 1) * 2 + k * (halton_budgets.len() as u64 - 1) + 1);
    if spec.uniform {
        status.inc_length(k);
    }
    status.set_message(format!("seeds ({} per method)", spec.seeds));
    let mdas_stats = intervals::mdas_over_seeds(
        gpu,
        &mut timed.mdas,
        &searched.mdas_main.measured.render.image,
        &checked.mdas_seeds,
        integrand,
        reference,
        status,
    )?;
    let mut cache: BTreeMap<u32, SeedStats> = BTreeMap::new();
    let halton = &mut timed.halton;
    let mut halton_stats = |spp: u32, first: Option<&[[f32; 3]]>| -> Result<SeedStats> {
        if let Some(s) = cache.get(&spp) {
            return Ok(s.clone());
        }
        let s = intervals::halton_over_seeds(
            gpu,
            halton,
            spp,
            first,
            &checked.halton_seeds,
            integrand,
            reference,
            status,
        )?;
        cache.insert(spp, s.clone());
        Ok(s)
    };
    let main_stats = halton_stats(
        searched.halton_main.spp,
        Some(&searched.halton_main.measured.render.image),
    )?;
    let (n0_stats, n1_stats) = (halton_stats(n0, None)?, halton_stats(n0 + 1, None)?);
    let halton_relmse = intervals::halton_at_target(timed.halton_spp, &n0_stats, &n1_stats);
    let ratio_ci95 = intervals::ratio_ci95(
        timed.halton_fit.as_ref(),
        timed.halton_spp,
        &timed.target_times,
        &mdas_stats,
        &n0_stats,
        &n1_stats,
    );
    let equal_stats = halton_stats(equal_spp, None)?;
    let uniform = if spec.uniform {
        status.set_message("mdas-uniform");
        Some(intervals::uniform_over_seeds(
            gpu,
            MdasParams {
                spp: searched.mdas_spp as f32,
                ..subject.mdas
            },
            &checked.mdas_seeds,
            spec.setup.repeats,
            integrand,
            reference,
            status,
        )?)
    } else {
        None
    };
    let ratio = |a: &SeedStats, b: &SeedStats| {
        super::seeds::bootstrap_ci95(&[&a.relmse_per_seed, &b.relmse_per_seed], |r| {
            super::seeds::mean(&r[0]) / super::seeds::mean(&r[1])
        })
    };
    let equal_samples = EqualSamplesReport {
        adaptivity_ratio: uniform.as_ref().map(|(_, u)| mdas_stats.relmse / u.relmse),
        adaptivity_ratio_ci95: uniform.as_ref().map(|(_, u)| ratio(&mdas_stats, u)),
        spp: equal_spp,
        mdas_relmse: mdas_stats.relmse,
        mdas_relmse_ci95: mdas_stats.relmse_ci95,
        halton_relmse: equal_stats.relmse,
        halton_relmse_ci95: equal_stats.relmse_ci95,
        relmse_ratio: mdas_stats.relmse / equal_stats.relmse,
        relmse_ratio_ci95: ratio(&mdas_stats, &equal_stats),
        adaptive: None,
    };
    let (ref_estimate, ref_flag) = match &subject.reference_source {
        ReferenceSource::Halton { spp, .. } => {
            let (estimate, flag) = intervals::reference_check(
                &n0_stats,
                n0,
                *spp,
                mdas_stats.relmse.min(halton_relmse),
            );
            (Some(estimate), flag)
        }
        ReferenceSource::Exact(_) => (None, None),
    };
    timed.flags.extend(ref_flag.clone());
    Ok(Seeded {
        mdas: mdas_stats,
        halton_main: main_stats,
        halton_relmse,
        halton_n0: n0_stats,
        halton_n1: n1_stats,
        halton_equal: equal_stats,
        ratio_ci95,
        uniform,
        equal_samples,
        ref_estimate,
        ref_flag,
    })
}

/// Step 5: the files, then the report, written last.
#[allow(clippy::too_many_arguments)]
fn report(
    gpu: &Gpu,
    spec: &CompareSpec,
    subject: &Subject,
    checked: &Checked,
    searched: &Searched,
    timed: Timed,
    seeded: Seeded,
    third: Option<&super::adaptive::Third>,
    density: &[f32],
    staged: StagedDir,
) -> Result<Report> {
    let (integrand, params) = (subject.integrand, subject.mdas);
    let film = integrand.film();
    let (mdas_main, mdas_spp, halton_main) = (
        &searched.mdas_main,
        searched.mdas_spp,
        &searched.halton_main,
    );
    let initial_samples = timed.mdas.config(integrand)?.initial_samples as u64;
    let Written {
        mut files,
        flips,
        density_range,
    } = write_outputs(&CompareOutputs {
        spec,
        out: staged.path(),
        film,
        subject,
        mdas: &mdas_main.measured.render,
        mdas_seed: params.seed,
        mdas_spp,
        mdas_stats: &seeded.mdas,
        initial_samples,
        halton: &halton_main.measured.render,
        halton_spp: halton_main.spp,
        halton_stats: &seeded.halton_main,
        uniform: seeded.uniform.as_ref().map(|(run, _)| &run.measured.render),
        adaptive: third.map(|t| super::outputs::ThirdOutput {
            render: &t.run.measured.render,
            seed: checked.halton_seeds[0],
            spp: t.run.spp,
            spp_used: t.time.at.spp_used,
            stats: &t.stats,
            counts: &t.counts,
        }),
        density,
        target_ms: timed.target_ms,
        ratio: seeded.mdas.relmse / seeded.halton_relmse,
        ratio_ci95: seeded.ratio_ci95,
    })?;
    files.insert("report".into(), "report.json".into());
    files.insert("page".into(), crate::viewer::PAGE.into());
    // MDAS at the target: the seed mean (its own run's budget in mode
    // "mdas"; the nearer bracketing run's under a time budget).
    let mdas_relmse = seeded.mdas.relmse;
    let report = Report {
        schema_version: super::report::REPORT_SCHEMA_VERSION,
        scene: subject.name.clone(),
        scale: spec.setup.scale,
        sampler: subject.sampler.clone(),
        visibility: subject.visibility.clone(),
        film: FilmReport {
            width: film.width,
            height: film.height,
        },
        seed: Seeds {
            halton: spec.setup.halton_seed,
            mdas: params.seed,
            reference: spec.setup.ref_seed,
        },
        adapter: gpu.info.name.clone(),
        backend: format!("{:?}", gpu.info.backend),
        clock: mdas_main.measured.render.clock.name().into(),
        version: env!("CARGO_PKG_VERSION").into(),
        repeats: spec.setup.repeats,
        reference: match &subject.reference_source {
            ReferenceSource::Halton { spp, path, cached } => ReferenceReport {
                spp: *spp,
                relmse_estimate: seeded.ref_estimate,
                flag: seeded.ref_flag,
                path: path.display().to_string(),
                cached: *cached,
                sampler: subject.reference_sampler.clone(),
                exact: None,
            },
            ReferenceSource::Exact(how) => ReferenceReport {
                spp: 0,
                relmse_estimate: None,
                flag: None,
                path: String::new(),
                cached: false,
                sampler: subject.reference_sampler.clone(),
                exact: Some(how.clone()),
            },
        },
        methods: vec![
            MethodReport::new("mdas", mdas_spp, mdas_main, "mdas.exr")
                .with_seeds(&checked.mdas_seeds, &seeded.mdas)
                .with_flip(flips[0]),
            MethodReport::new("halton", halton_main.spp as f64, halton_main, "halton.exr")
                .with_seeds(&checked.halton_seeds, &seeded.halton_main)
                .with_flip(flips[1]),
        ]
        .into_iter()
        .chain(third.map(|t| {
            let name = super::adaptive::NAME;
            let mut m = MethodReport::new(name, t.run.spp as f64, &t.run, &format!("{name}.exr"))
                .with_seeds(&checked.halton_seeds, &t.stats);
            m.image_flip = flips.get(2).copied();
            m.spp_used = Some(t.time.at.spp_used);
            m
        }))
        .chain(seeded.uniform.as_ref().map(|(run, stats)| {
            MethodReport::new("mdas-uniform", mdas_spp, run, "mdas-uniform.exr")
                .with_seeds(&checked.mdas_seeds, stats)
        }))
        .collect(),
        equal_time: EqualTimeReport {
            mode: match spec.budget {
                Budget::MdasSpp => "mdas",
                Budget::TimeMs(_) => "budget",
            }
            .into(),
            target_ms: timed.target_ms,
            mdas_relmse,
            halton_relmse: seeded.halton_relmse,
            relmse_ratio: mdas_relmse / seeded.halton_relmse,
            halton: SearchReport::new(&searched.halton_eq),
            mdas: searched.mdas_search.as_ref().map(SearchReport::new),
            baseline: None,
            samplers: None,
            relmse_ratio_ci95: Some(seeded.ratio_ci95),
            halton_fit: timed.halton_fit,
            halton_spp: Some(timed.halton_spp),
            interleaved: Some(timed.timing),
            target_spread: timed.target_spread,
            flags: timed.flags,
            equal_samples: Some(EqualSamplesReport {
                adaptive: third.map(|t| t.samples.clone()),
                ..seeded.equal_samples
            }),
            adaptive: third.map(|t| t.time.clone()),
        },
        maps: MapsReport {
            colormap: "viridis, log scale (FLIP maps: linear)",
            relmse_range: heatmap::RELMSE_RANGE,
            density_range: Some(density_range),
            flip_range: Some(super::outputs::FLIP_RANGE),
        },
        files,
        provenance: Some({
            let mdas = Some(MdasParams {
                spp: mdas_spp as f32,
                ..params
            });
            match subject.scene_file {
                Some(file) => crate::provenance::Provenance::new(gpu, file, integrand, mdas)?,
                None => crate::provenance::Provenance::of_integrand(gpu, integrand, mdas),
            }
        }),
    };
    write_report(staged.path(), &report)?;
    crate::viewer::write_page(staged.path())?;
    staged.commit("report.json")?;
    Ok(report)
}
