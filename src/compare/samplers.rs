//! `mdas compare --samplers`: light samplers of a `many_light` scene
//! against each other at equal time under Halton, with MDAS (sampler
//! `tree`) setting the target, in `mdas compare`'s report format.
//!
//! 1. Validate everything that needs no render: repeats, seeds, the time
//!    budget, the sampler list (at least one, no repeats), the scene (its
//!    integrand must be `many_light`), one integrand per sampler (all on
//!    one uploaded scene), MDAS's parameters against the `tree` integrand,
//!    then the output directory.
//! 2. The reference: Halton at `ref_spp` with the scene's own sampler
//!    (`session::reference`, cached; every unbiased sampler estimates the same
//!    image, and a biased scene sampler, `sst` or `lgh`, is replaced by `tree`).
//! 3. The target time: MDAS with `tree` at its spp ([`Budget::MdasSpp`]),
//!    or `--time-ms` for all, MDAS+tree searched too ([`Budget::TimeMs`]).
//! 4. Each listed sampler: Halton's budget search at the target
//!    ([`super::timing::halton_search`], one Halton integrator per
//!    search).
//!    With `seeds` K ≥ 2, each search's two bracketing budgets are then
//!    rendered with Halton's other K − 1 seeds ([`SamplerSeeds`]): means
//!    at the target, and at the budget nearer it the relative bias per
//!    channel and the MSE's bias²/variance split over the K images.
//! 5. Files, each atomically, `report.json` last: `reference`, `mdas-tree`
//!    and `halton-<sampler>` images (EXR + PNG) with their RelMSE heat maps
//!    `relmse-mdas-tree`, `relmse-halton-<sampler>` (no density map).
//!
//! In the report, `methods` holds `mdas+tree` then `halton+<sampler>` per
//! sampler (the bracketing run nearer in time, as in `mdas compare`);
//! `equal_time.relmse_ratio` is MDAS+tree over `halton+tree` when `tree`
//! is listed, else over the first listed sampler (`equal_time.baseline`
//! names it); `equal_time.samplers` gives each sampler's light samples per
//! evaluation (a cut kind under `cut_sampling = "subtrees"` traces one
//! shadow ray per cut node; the table prints light samples per pixel beside
//! each bracket's spp), its RelMSE and MSE interpolated log–log at exactly
//! the target time, its search brackets and its MSE relative to
//! `uniform`'s (when listed).

use super::equal_time::{interpolate_log_log, EqualTime};
use super::experiment::{check_budget, check_mdas, write_report};
use super::heatmap;
use super::inputs::{Budget, Setup};
use super::intervals;
use super::outputs::{reference_attributes, Files};
use super::progress::spinner;
use super::report::*;
use super::seeds::{bootstrap_ci95, mean, SeedStats};
use super::timing::{halton_search, nearer, time_mdas, MdasTiming};
use crate::accel::GpuScene;
use crate::atomic::StagedDir;
use crate::gpu::Gpu;
use crate::integrand::Integrand;
use crate::integrand::IntegrandSpec;
use crate::integrator::mdas::MdasParams;
use crate::lights::registry::SamplerKind;
use crate::scene_file::SceneFile;
use crate::session;
use anyhow::{bail, Result};
use std::sync::Arc;

/// The sampler MDAS runs with.
pub const MDAS_SAMPLER: SamplerKind = SamplerKind::Tree;

/// Inputs of [`compare_samplers`].
pub struct SamplersSpec<'a> {
    pub setup: Setup<'a>,
    /// The target time: MDAS+tree at its spp, or a fixed budget for all.
    pub budget: Budget,
    /// Upper end of the spp searches.
    pub max_spp: u32,
    /// The samplers to compare under Halton, in report order.
    pub samplers: Vec<SamplerKind>,
    /// Seeds per sampler (1: the search's run alone; K ≥ 2: each
    /// sampler's two bracketing budgets over K seeds, [`SamplerSeeds`]).
    pub seeds: u32,
    /// `[integrand]` overrides of every compared render (`--cut-size`,
    /// `--cut-sampling`; the sampler is each listed one, the frame the
    /// setup's); the reference keeps the scene's own table.
    pub overrides: session::IntegrandOverrides,
}

/// Checks a sampler list: not empty, no sampler twice.
pub fn check_samplers(samplers: &[SamplerKind]) -> Result<()> {
    if samplers.is_empty() {
        bail!(
            "--samplers needs at least one light sampler (of {})",
            SamplerKind::names()
        );
    }
    for (i, k) in samplers.iter().enumerate() {
        if samplers[..i].contains(k) {
            bail!("--samplers lists '{k}' twice");
        }
    }
    Ok(())
}

/// The Halton method whose RelMSE `relmse_ratio` divides by: `tree` when
/// listed, else the first sampler.
pub fn baseline(samplers: &[SamplerKind]) -> SamplerKind {
    if samplers.contains(&MDAS_SAMPLER) {
        MDAS_SAMPLER
    } else {
        samplers[0]
    }
}

/// Runs the comparison and writes everything (see the module docs) as one
/// unit ([`crate::atomic::StagedDir`]).
pub fn compare_samplers(gpu: &Gpu, spec: &SamplersSpec) -> Result<Report> {
    run(gpu, spec)
}

fn run(gpu: &Gpu, spec: &SamplersSpec) -> Result<Report> {
    let setup = &spec.setup;
    // 1. Validation, before any render or file.
    setup.check()?;
    check_budget(spec.budget)?;
    check_samplers(&spec.samplers)?;
    let (_, halton_seeds) = intervals::seed_plan(spec.seeds, 0, setup.halton_seed, setup.ref_seed)?;
    let mut scene = SceneFile::load(&setup.scene)?;
    let own = match &scene.integrand {
        IntegrandSpec::ManyLight(m) => m.sampler,
        other => bail!(
            "--samplers compares light samplers of the many_light integrand, but {} uses '{}'",
            setup.scene.display(),
            other.type_name()
        ),
    };
    let film = session::scaled_film(scene.scene.film, setup.scale)?;
    let staged = StagedDir::new(&setup.out)?;
    let gpu_scene = Arc::new(GpuScene::with_visibility(
        gpu,
        &scene.scene,
        film,
        scene.visibility,
    )?);
    // One integrand per sampler (plus MDAS's tree if not listed), sharing
    // the uploaded scene.
    let mut kinds = spec.samplers.clone();
    if !kinds.contains(&MDAS_SAMPLER) {
        kinds.push(MDAS_SAMPLER);
    }
    let original = scene.integrand.clone();
    // Per sampler: its integrand and its light samples per evaluation.
    let mut integrands: Vec<(SamplerKind, Box<dyn Integrand>, f64)> = Vec::new();
    for &kind in &kinds {
        let overrides = session::IntegrandOverrides {
            frame: setup.frame,
            sampler: Some(kind),
            ..spec.overrides
        };
        scene.integrand = overrides.apply(&original, &setup.scene)?;
        let IntegrandSpec::ManyLight(m) = &scene.integrand else {
            unreachable!("checked above: the scene's integrand is many_light");
        };
        let light_samples = m.light_samples_per_eval(kind);
        integrands.push((
            kind,
            session::integrand_on(gpu, &scene, gpu_scene.clone(), film)?,
            light_samples,
        ));
    }
    scene.integrand = original;
    let entry_of = |kind: SamplerKind| {
        integrands
            .iter()
            .find(|(k, ..)| *k == kind)
            .expect("an integrand per sampler")
    };
    let integrand_of = |kind: SamplerKind| -> &dyn Integrand { entry_of(kind).1.as_ref() };
    let mdas_integrand = integrand_of(MDAS_SAMPLER);
    let params = (setup.mdas_params)(scene.mdas);
    let min_spp = check_mdas(
        params,
        spec.budget,
        mdas_integrand,
        &setup.scene.display().to_string(),
    )?;

    // 2. Reference (the scene's own sampler).
    let (reference, ref_path, cached) = setup.reference(gpu)?;

    // 3. The target time.
    let status = spinner(setup.progress);
    let MdasTiming {
        run: mdas_main,
        spp: mdas_spp,
        search: mdas_search,
        target_ms,
    } = time_mdas(
        gpu,
        params,
        min_spp,
        mdas_integrand,
        &reference,
        setup,
        spec.budget,
        spec.max_spp,
        &status,
        "mdas+tree",
    )?;

    // 4. Halton per sampler.
    let mut searches: Vec<(SamplerKind, EqualTime)> = Vec::new();
    for &kind in &spec.samplers {
        let label = format!("halton+{kind}");
        let eq = halton_search(
            gpu,
            integrand_of(kind),
            &reference,
            target_ms,
            setup,
            spec.max_spp,
            &status,
            &label,
        )?;
        searches.push((kind, eq));
    }
    // 4b. Each sampler's brackets over the seeds.
    let per_seed: Vec<Option<BracketSeeds>> = if spec.seeds > 1 {
        status.inc_length(2 * (spec.seeds as u64 - 1) * searches.len() as u64);
        searches
            .iter()
            .map(|(kind, eq)| {
                status.set_message(format!("halton+{kind}: {} seeds", spec.seeds));
                bracket_seeds(
                    gpu,
                    integrand_of(*kind),
                    eq,
                    &halton_seeds,
                    &reference,
                    &status,
                )
                .map(Some)
            })
            .collect::<Result<_>>()?
    } else {
        vec![None; searches.len()]
    };
    status.finish_and_clear();

    // 5. Files, report last.
    let (w, h) = (film.width, film.height);
    let mut files = Files::new(staged.path(), film);
    files.image(
        "reference",
        "reference",
        &reference,
        &reference_attributes(setup.ref_spp, setup.ref_seed),
    )?;
    let mdas_image = &mdas_main.measured.render.image;
    files.image(
        "mdas_tree",
        "mdas-tree",
        mdas_image,
        &session::render_attributes(
            "mdas+tree",
            params.seed,
            &mdas_main.measured.render,
            &setup.scene,
        ),
    )?;
    files.relmse_map("mdas_tree", "mdas-tree", mdas_image, &reference)?;
    let mut methods = vec![MethodReport::new(
        "mdas+tree",
        mdas_spp,
        &mdas_main,
        "mdas-tree.exr",
    )];
    for (kind, eq) in &searches {
        let run = nearer(eq);
        let name = format!("halton-{kind}");
        let key = format!("halton_{kind}");
        files.image(
            &key,
            &name,
            &run.measured.render.image,
            &session::render_attributes(
                &format!("halton+{kind}"),
                setup.halton_seed,
                &run.measured.render,
                &setup.scene,
            ),
        )?;
        files.relmse_map(&key, &name, &run.measured.render.image, &reference)?;
        methods.push(MethodReport::new(
            &format!("halton+{kind}"),
            run.spp as f64,
            run,
            &format!("{name}.exr"),
        ));
    }
    files.list.insert("report".into(), "report.json".into());
    files.list.insert("page".into(), crate::viewer::PAGE.into());

    let reports: Vec<(SamplerKind, SearchReport)> = searches
        .iter()
        .map(|(k, eq)| (*k, SearchReport::new(eq)))
        .collect();
    let uniform_mse = reports
        .iter()
        .find(|(k, _)| *k == SamplerKind::Uniform)
        .map(|(_, r)| r.mse);
    let uniform_seeds = spec
        .samplers
        .iter()
        .position(|&k| k == SamplerKind::Uniform)
        .and_then(|i| per_seed[i].as_ref());
    let samplers: Vec<SamplerReport> = reports
        .iter()
        .zip(&per_seed)
        .map(|((k, r), b)| SamplerReport {
            sampler: k.to_string(),
            method: format!("halton+{k}"),
            light_samples_per_eval: entry_of(*k).2,
            relmse: r.relmse,
            mse: r.mse,
            mse_vs_uniform: uniform_mse.map(|u| r.mse / u),
            search: r.clone(),
            seeds: b.as_ref().map(|b| b.report(uniform_seeds)),
        })
        .collect();
    let base = baseline(&spec.samplers);
    let halton_report = reports
        .iter()
        .find(|(k, _)| *k == base)
        .expect("the baseline is listed")
        .1
        .clone();
    let mdas_report = mdas_search.as_ref().map(SearchReport::new);
    let mdas_relmse = mdas_report
        .as_ref()
        .map_or(mdas_main.error.relmse, |m| m.relmse);
    let report = Report {
        schema_version: super::report::REPORT_SCHEMA_VERSION,
        scene: setup.scene.display().to_string(),
        scale: setup.scale,
        sampler: None,
        visibility: super::experiment::voxel_note(scene.visibility),
        film: FilmReport {
            width: w,
            height: h,
        },
        seed: Seeds {
            halton: setup.halton_seed,
            mdas: params.seed,
            reference: setup.ref_seed,
        },
        adapter: gpu.info.name.clone(),
        backend: format!("{:?}", gpu.info.backend),
        clock: mdas_main.measured.render.clock.name().into(),
        version: env!("CARGO_PKG_VERSION").into(),
        repeats: setup.repeats,
        reference: ReferenceReport {
            spp: setup.ref_spp,
            path: ref_path.display().to_string(),
            cached,
            sampler: Some(own.to_string()),
            relmse_estimate: None,
            flag: None,
            exact: None,
        },
        methods,
        equal_time: EqualTimeReport {
            mode: match spec.budget {
                Budget::MdasSpp => "mdas",
                Budget::TimeMs(_) => "budget",
            }
            .into(),
            target_ms,
            mdas_relmse,
            halton_relmse: halton_report.relmse,
            relmse_ratio: mdas_relmse / halton_report.relmse,
            halton: halton_report,
            mdas: mdas_report,
            baseline: Some(format!("halton+{base}")),
            samplers: Some(samplers),
            relmse_ratio_ci95: None,
            halton_fit: None,
            halton_spp: None,
            interleaved: None,
            target_spread: None,
            flags: Vec::new(),
            equal_samples: None,
            adaptive: None,
        },
        maps: MapsReport {
            colormap: "viridis, log scale",
            relmse_range: heatmap::RELMSE_RANGE,
            density_range: None,
            flip_range: None,
        },
        files: files.list,
        provenance: Some(crate::provenance::Provenance::new(
            gpu,
            &setup.scene,
            mdas_integrand,
            Some(MdasParams {
                spp: mdas_spp as f32,
                ..params
            }),
        )?),
    };
    write_report(staged.path(), &report)?;
    crate::viewer::write_page(staged.path())?;
    staged.commit("report.json")?;
    Ok(report)
}

/// One sampler's two bracketing budgets over seeds: per seed, RelMSE and
/// MSE at each, and the times and target to interpolate at; and the bias
/// and MSE split over the seeds at the budget nearer the target.
#[derive(Clone)]
struct BracketSeeds {
    target_ms: f64,
    times: [f64; 2],
    relmse: [Vec<f64>; 2],
    mse: [Vec<f64>; 2],
    nearer_spp: u32,
    nearer: SeedStats,
}

/// Halton at `eq`'s lo and hi budgets over `seeds` (the search's own runs,
/// rendered with `seeds[0]`, are the first seed's).
fn bracket_seeds(
    gpu: &Gpu,
    integrand: &dyn Integrand,
    eq: &EqualTime,
    seeds: &[u32],
    reference: &[[f32; 3]],
    status: &indicatif::ProgressBar,
) -> Result<BracketSeeds> {
    let mut halton = crate::integrator::Halton::new(1, seeds[0]);
    let mut relmse: [Vec<f64>; 2] = Default::default();
    let mut mse: [Vec<f64>; 2] = Default::default();
    let near = nearer(eq);
    let mut near_images = vec![near.measured.render.image.clone()];
    for (i, run) in [&eq.lo, &eq.hi].into_iter().enumerate() {
        relmse[i].push(run.error.relmse);
        mse[i].push(run.error.mse);
        halton.spp = run.spp;
        for &seed in &seeds[1..] {
            halton.seed = seed;
            let image = crate::integrator::Integrator::render(&mut halton, gpu, integrand)?.image;
            let e = crate::metrics::compare(&image, reference)?;
            relmse[i].push(e.relmse);
            mse[i].push(e.mse);
            if std::ptr::eq(run, near) {
                near_images.push(image);
            }
            status.inc(1);
        }
    }
    let images: Vec<&[[f32; 3]]> = near_images.iter().map(Vec::as_slice).collect();
    Ok(BracketSeeds {
        target_ms: eq.target_ms,
        times: [eq.lo.measured.total_ms(), eq.hi.measured.total_ms()],
        relmse,
        mse,
        nearer_spp: near.spp,
        nearer: SeedStats::new(&images, reference)?,
    })
}

impl BracketSeeds {
    /// log–log in time at the target, as [`SearchReport::new`] does.
    fn at_target(&self, lo: f64, hi: f64) -> f64 {
        interpolate_log_log(self.target_ms, (self.times[0], lo), (self.times[1], hi))
    }

    fn report(&self, uniform: Option<&BracketSeeds>) -> SamplerSeeds {
        let at = |v: &[Vec<f64>; 2]| self.at_target(mean(&v[0]), mean(&v[1]));
        let ci = |v: &[Vec<f64>; 2]| {
            bootstrap_ci95(&[&v[0], &v[1]], |r| {
                self.at_target(mean(&r[0]), mean(&r[1]))
            })
        };
        let vs = uniform.map(|u| {
            if std::ptr::eq(u, self) {
                return (1.0, [1.0, 1.0]); // uniform against itself
            }
            let ratio = at(&self.mse) / u.at_target(mean(&u.mse[0]), mean(&u.mse[1]));
            let ci = bootstrap_ci95(&[&self.mse[0], &self.mse[1], &u.mse[0], &u.mse[1]], |r| {
                self.at_target(mean(&r[0]), mean(&r[1])) / u.at_target(mean(&r[2]), mean(&r[3]))
            });
            (ratio, ci)
        });
        SamplerSeeds {
            count: self.relmse[0].len() as u32,
            relmse: at(&self.relmse),
            relmse_ci95: ci(&self.relmse),
            mse: at(&self.mse),
            mse_ci95: ci(&self.mse),
            mse_vs_uniform: vs.map(|v| v.0),
            mse_vs_uniform_ci95: vs.map(|v| v.1),
            bias_spp: self.nearer_spp,
            relative_bias: self.nearer.relative_bias,
            relative_bias_ci95: self.nearer.relative_bias_ci95,
            mse_bias2: self.nearer.mse_bias2,
            mse_variance: self.nearer.mse_variance,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sampler_lists() {
        use SamplerKind::*;
        assert!(check_samplers(&[]).is_err());
        assert!(check_samplers(&[Uniform, Tree, Uniform]).is_err());
        assert!(check_samplers(&[Uniform, Power, Tree]).is_ok());
        assert_eq!(baseline(&[Uniform, Power, Tree]), Tree);
        assert_eq!(baseline(&[Power, Uniform]), Power);
    }
}
