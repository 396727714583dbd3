//! `mdas sweep`: RelMSE against time for MDAS, Halton and pixel-adaptive
//! Halton ([`super::adaptive`], unless left out) over a list of budgets
//! (samples per pixel; adaptive's is the average it may spend, and its
//! `samples` what it spent), written as `sweep.csv`, `sweep.json` (the
//! rows and the run's provenance) and a log–log plot, `sweep.svg` and
//! `sweep.png` (time on x, RelMSE on y, each point labelled with its spp)
//! — speed against error in one picture. Each point's time is a
//! [`measure`]d run of the method's first seed (warm-up, median of the
//! repeats); its RelMSE is the mean over `seeds` seeds (the first and
//! `seeds − 1` more untimed renders; Halton's and adaptive's skip the
//! reference's seed)
//! with a 95% Student-t interval, drawn as an error bar. MDAS budgets
//! below its initial sample count are skipped and listed in the result.

use super::equal_time::measure;
use super::experiment::mdas_min_spp;
use super::inputs::{check_reference, ReferenceSource, Setup, Subject};
use super::intervals::seed_plan;
use super::plot::{loglog_svg, svg_to_png, Series};
use super::seeds::mean_ci95;
use crate::atomic::StagedDir;
use crate::gpu::Gpu;
use crate::image_io;
use crate::integrator::adaptive::AdaptiveHalton;
use crate::integrator::mdas::MdasParams;
use crate::integrator::{Halton, Integrator, Mdas};
use crate::metrics;
use crate::session;
use anyhow::{bail, Result};

/// Inputs of [`sweep`].
pub struct SweepSpec<'a> {
    pub setup: Setup<'a>,
    /// Budgets, samples per pixel, for both methods.
    pub spps: Vec<u32>,
    /// Seeds per point (1..=64).
    pub seeds: u32,
    /// Also pixel-adaptive Halton at every budget (`--methods`).
    pub adaptive: bool,
}

/// One measured point.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct SweepRow {
    pub method: String,
    pub spp: u32,
    pub samples: u64,
    pub time_ms: f64,
    /// Mean over the seeds, and its 95% interval ([relmse; 2] for one seed).
    pub relmse: f64,
    #[serde(deserialize_with = "super::seeds::de_interval")]
    pub relmse_ci95: [f64; 2],
    /// Mean over the seeds.
    pub mse: f64,
    pub seeds: Vec<u32>,
}

/// The points, the MDAS budgets skipped (below its initial samples) and
/// the run's provenance: `sweep.json`.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct SweepResult {
    pub scene: String,
    pub scale: f32,
    /// The Halton reference's spp (0 for an exact reference).
    pub reference_spp: u32,
    pub reference_seed: u32,
    /// How an exact reference was made ([`sweep_integrand`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub reference_exact: Option<String>,
    pub repeats: u32,
    pub rows: Vec<SweepRow>,
    pub mdas_skipped: Vec<u32>,
    pub provenance: crate::provenance::Provenance,
    /// A sweep merged from parts (`mdas merge`): each part's command line,
    /// time and points; `provenance` is then the first part's, with the
    /// merge's command line and time.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub merged_from: Option<Vec<crate::provenance::PartProvenance>>,
}

pub const CSV_HEADER: &str = "method,spp,samples,time_ms,relmse,relmse_lo,relmse_hi,mse,seeds";

pub fn csv(rows: &[SweepRow]) -> String {
    super::csv_table::csv_text(
        CSV_HEADER,
        rows.iter().map(|r| {
            vec![
                r.method.clone(),
                r.spp.to_string(),
                r.samples.to_string(),
                r.time_ms.to_string(),
                r.relmse.to_string(),
                r.relmse_ci95[0].to_string(),
                r.relmse_ci95[1].to_string(),
                r.mse.to_string(),
                r.seeds.len().to_string(),
            ]
        }),
    )
}

/// Runs the sweep on a scene file and writes `sweep.csv`, `sweep.json`,
/// `sweep.svg` and `sweep.png` in `spec.out`, as one unit.
pub fn sweep(gpu: &Gpu, spec: &SweepSpec) -> Result<SweepResult> {
    check_spps(spec)?;
    let staged = StagedDir::new(&spec.setup.out)?;
    let prepared = session::prepare(gpu, &spec.setup.scene, spec.setup.scale)?;
    let integrand = prepared.integrand.as_ref();
    let params = (spec.setup.mdas_params)(prepared.scene.mdas);
    let plan = plan(spec, params, integrand)?;
    let (reference, path, cached) = spec.setup.reference(gpu)?;
    let subject = spec
        .setup
        .scene_subject(integrand, params, &reference, path, cached);
    sweep_subject(gpu, spec, &subject, plan, staged)
}

/// [`sweep`] on an integrand built in code against a reference given with
/// it (`compare::compare_integrand` explains the [`Subject`]); the
/// setup's scene, scale, reference spp, cache and parameter mapping are
/// not used.
pub fn sweep_integrand(gpu: &Gpu, spec: &SweepSpec, subject: &Subject) -> Result<SweepResult> {
    check_spps(spec)?;
    check_reference(subject)?;
    let plan = plan(spec, subject.mdas, subject.integrand)?;
    let staged = StagedDir::new(&spec.setup.out)?;
    sweep_subject(gpu, spec, subject, plan, staged)
}

/// The checks of the budgets list that need no scene.
fn check_spps(spec: &SweepSpec) -> Result<()> {
    spec.setup.check()?;
    if spec.spps.is_empty() || spec.spps.contains(&0) {
        bail!("--spps must list positive samples per pixel");
    }
    if let Some(twice) = spec
        .spps
        .iter()
        .find(|&s| spec.spps.iter().filter(|&t| t == s).count() > 1)
    {
        bail!("--spps lists {twice} more than once; each budget is measured once");
    }
    Ok(())
}

/// The budgets MDAS can take and those below its initial samples, and each
/// method's seeds, checked before any render.
struct Plan {
    mdas_spps: Vec<u32>,
    mdas_skipped: Vec<u32>,
    mdas_seeds: Vec<u32>,
    halton_seeds: Vec<u32>,
}

fn plan(
    spec: &SweepSpec,
    params: MdasParams,
    integrand: &dyn crate::integrand::Integrand,
) -> Result<Plan> {
    let min_spp = mdas_min_spp(params, integrand)?;
    let (mdas_seeds, halton_seeds) = seed_plan(
        spec.seeds,
        params.seed,
        spec.setup.halton_seed,
        spec.setup.ref_seed,
    )?;
    let (mdas_spps, mdas_skipped): (Vec<u32>, Vec<u32>) =
        spec.spps.iter().partition(|&&s| s >= min_spp);
    for &spp in &mdas_spps {
        Mdas::new(MdasParams {
            spp: spp as f32,
            ..params
        })?
        .config(integrand)?;
    }
    Ok(Plan {
        mdas_spps,
        mdas_skipped,
        mdas_seeds,
        halton_seeds,
    })
}

/// The sweep of a checked subject, written into `staged`.
fn sweep_subject(
    gpu: &Gpu,
    spec: &SweepSpec,
    subject: &Subject,
    plan: Plan,
    staged: StagedDir,
) -> Result<SweepResult> {
    let points = points(&plan, spec);
    let rows = measure_points(gpu, spec, subject, &plan, &points)?;
    let result = result(gpu, spec, subject, plan, rows)?;
    write_sweep(staged.path(), &result)?;
    crate::viewer::write_page(staged.path())?;
    staged.commit("sweep.json")?;
    Ok(result)
}

/// The sweep's points, in the order of its rows: MDAS's budgets, then
/// Halton's, then adaptive's.
fn points(plan: &Plan, spec: &SweepSpec) -> Vec<(String, u32)> {
    points_of(&plan.mdas_spps, &spec.spps, spec.adaptive)
}

/// The points of a sweep of `spps` whose MDAS budgets are `mdas_spps`
/// (`mdas merge` checks a part's against them).
pub fn points_of(mdas_spps: &[u32], spps: &[u32], adaptive: bool) -> Vec<(String, u32)> {
    let mdas = mdas_spps.iter().map(|&s| ("mdas".to_string(), s));
    let halton = spps.iter().map(|&s| ("halton".to_string(), s));
    let third = spps
        .iter()
        .filter(|_| adaptive)
        .map(|&s| (super::adaptive::NAME.to_string(), s));
    mdas.chain(halton).chain(third).collect()
}

/// Measures `points` (a run of [`points`]), in order.
fn measure_points(
    gpu: &Gpu,
    spec: &SweepSpec,
    subject: &Subject,
    plan: &Plan,
    points: &[(String, u32)],
) -> Result<Vec<SweepRow>> {
    let (integrand, reference, params) = (subject.integrand, subject.reference, subject.mdas);
    let bar = super::progress::bar(
        spec.setup.progress,
        points.len() as u64,
        "sweep {bar:40} {pos}/{len} points {msg} [{elapsed_precise} < {eta}]",
    );
    let mut rows = Vec::with_capacity(points.len());
    // One integrator per method, so pipelines compile once.
    let mut mdas = Mdas::new(params)?;
    let mut halton = Halton::new(1, spec.setup.halton_seed);
    let mut adaptive = AdaptiveHalton::new(super::adaptive::params(1.0, spec.setup.halton_seed))?;
    for (method, spp) in points {
        let spp = *spp;
        bar.set_message(format!("{method} {spp} spp"));
        let row = if method == super::adaptive::NAME {
            adaptive.set_spp(f64::from(spp))?;
            point(
                gpu,
                spec,
                integrand,
                reference,
                super::adaptive::NAME,
                spp,
                &plan.halton_seeds,
                &mut adaptive,
                AdaptiveHalton::set_seed,
            )?
        } else if method == "mdas" {
            mdas.set_spp(spp as f32)?;
            point(
                gpu,
                spec,
                integrand,
                reference,
                "mdas",
                spp,
                &plan.mdas_seeds,
                &mut mdas,
                Mdas::set_seed,
            )?
        } else {
            halton.spp = spp;
            point(
                gpu,
                spec,
                integrand,
                reference,
                "halton",
                spp,
                &plan.halton_seeds,
                &mut halton,
                |h, s| h.seed = s,
            )?
        };
        rows.push(row);
        bar.inc(1);
    }
    bar.finish_and_clear();
    Ok(rows)
}

/// `sweep.json` of measured `rows`.
fn result(
    gpu: &Gpu,
    spec: &SweepSpec,
    subject: &Subject,
    plan: Plan,
    rows: Vec<SweepRow>,
) -> Result<SweepResult> {
    let (reference_spp, reference_exact) = match &subject.reference_source {
        ReferenceSource::Halton { spp, .. } => (*spp, None),
        ReferenceSource::Exact(how) => (0, Some(how.clone())),
    };
    let (integrand, params) = (subject.integrand, subject.mdas);
    Ok(SweepResult {
        scene: subject.name.clone(),
        scale: spec.setup.scale,
        reference_spp,
        reference_seed: spec.setup.ref_seed,
        reference_exact,
        repeats: spec.setup.repeats,
        rows,
        mdas_skipped: plan.mdas_skipped,
        provenance: match subject.scene_file {
            Some(file) => crate::provenance::Provenance::new(gpu, file, integrand, Some(params))?,
            None => crate::provenance::Provenance::of_integrand(gpu, integrand, Some(params)),
        },
        merged_from: None,
    })
}

/// Writes `sweep.csv`, `sweep.svg`, `sweep.png` and `sweep.json` of
/// `result` into `dir` (a run's staging directory).
pub(crate) fn write_sweep(dir: &std::path::Path, result: &SweepResult) -> Result<()> {
    let rows = &result.rows;
    let series = |method: &'static str, name: &'static str, colour: &'static str| {
        let rows: Vec<&SweepRow> = rows.iter().filter(|r| r.method == method).collect();
        Series {
            name,
            colour,
            points: rows.iter().map(|r| (r.time_ms, r.relmse)).collect(),
            errors: rows.iter().map(|r| r.relmse_ci95).collect(),
            labels: rows.iter().map(|r| format!("{} spp", r.spp)).collect(),
        }
    };
    // A scene file's sweep names its scale; an integrand built in code
    // has no scene file to digest.
    let title = match result.provenance.scene_sha256 {
        Some(_) => format!("{} at scale {}", result.scene, result.scale),
        None => result.scene.clone(),
    };
    let svg = loglog_svg(
        &title,
        "time (ms, median)",
        "RelMSE",
        &[
            series("mdas", "MDAS", "#d62728"),
            series("halton", "Halton", "#1f77b4"),
            series(super::adaptive::NAME, "adaptive", "#2ca02c"),
        ]
        .into_iter()
        .filter(|s| !s.points.is_empty() || s.name != "adaptive")
        .collect::<Vec<_>>(),
    );
    let text = csv(rows);
    image_io::write_atomic(&dir.join("sweep.csv"), |t| {
        std::fs::write(t, text.as_bytes()).map_err(Into::into)
    })?;
    let png = svg_to_png(&svg)?;
    image_io::write_atomic(&dir.join("sweep.svg"), |t| {
        std::fs::write(t, svg.as_bytes()).map_err(Into::into)
    })?;
    image_io::write_atomic(&dir.join("sweep.png"), |t| {
        std::fs::write(t, &png).map_err(Into::into)
    })?;
    let json = serde_json::to_string_pretty(result)?;
    image_io::write_atomic(&dir.join("sweep.json"), |t| {
        std::fs::write(t, json.as_bytes()).map_err(Into::into)
    })
}

/// The file a sweep part writes in its output directory.
pub const PART_FILE: &str = "sweep-part.json";

/// The format tag of [`SweepPart`].
pub const PART_FORMAT: &str = "mdas sweep part 1";

/// `sweep-part.json`: part `part` of `parts` of a sweep — its share of
/// the points (`first..end` of `points`, contiguous) measured as one
/// process measures them, and everything a merge checks to know that the
/// parts belong together (`mdas merge`, [`super::merge`]).
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct SweepPart {
    pub format: String,
    pub part: u32,
    pub parts: u32,
    /// Every point of the whole sweep (method, spp), in its rows' order.
    pub points: Vec<(String, u32)>,
    pub first: u32,
    pub end: u32,
    /// The sweep's budgets and seeds per point, as given.
    pub spps: Vec<u32>,
    pub seeds: u32,
    /// SHA-256 of the reference's pixels ([`session::pixels_sha256`]).
    pub reference_sha256: String,
    /// The sweep as one process writes it, with this part's rows only.
    pub result: SweepResult,
}

/// Measures part `part` of the sweep of a scene file — points
/// ⌊(I − 1)·P/N⌋ .. ⌊I·P/N⌋ of its P points — and writes
/// [`PART_FILE`] in the setup's output directory.
pub fn sweep_part(gpu: &Gpu, spec: &SweepSpec, part: session::parts::Part) -> Result<SweepPart> {
    check_spps(spec)?;
    let staged = StagedDir::new(&spec.setup.out)?;
    let prepared = session::prepare(gpu, &spec.setup.scene, spec.setup.scale)?;
    let integrand = prepared.integrand.as_ref();
    let params = (spec.setup.mdas_params)(prepared.scene.mdas);
    let plan = plan(spec, params, integrand)?;
    let points = points(&plan, spec);
    if part.count as usize > points.len() {
        bail!(
            "{} parts of a sweep of {} points: every part needs a point (at most {} parts)",
            part.count,
            points.len(),
            points.len()
        );
    }
    let range = part.range(points.len() as u32);
    let (reference, path, cached) = spec.setup.reference(gpu)?;
    let reference_sha256 = session::pixels_sha256(&reference);
    let subject = spec
        .setup
        .scene_subject(integrand, params, &reference, path, cached);
    let mine = &points[range.start as usize..range.end as usize];
    let rows = measure_points(gpu, spec, &subject, &plan, mine)?;
    let record = SweepPart {
        format: PART_FORMAT.into(),
        part: part.index,
        parts: part.count,
        points: points.clone(),
        first: range.start,
        end: range.end,
        spps: spec.spps.clone(),
        seeds: spec.seeds,
        reference_sha256,
        result: result(gpu, spec, &subject, plan, rows)?,
    };
    let json = serde_json::to_string_pretty(&record)?;
    image_io::write_atomic(&staged.path().join(PART_FILE), |t| {
        std::fs::write(t, json.as_bytes()).map_err(Into::into)
    })?;
    staged.commit(PART_FILE)?;
    Ok(record)
}

/// One point: the time of the first seed ([`measure`]), then every seed's
/// error (the first seed's from the timed render).
#[allow(clippy::too_many_arguments)]
fn point<I: Integrator>(
    gpu: &Gpu,
    spec: &SweepSpec,
    integrand: &dyn crate::integrand::Integrand,
    reference: &[[f32; 3]],
    method: &'static str,
    spp: u32,
    seeds: &[u32],
    integrator: &mut I,
    set_seed: impl Fn(&mut I, u32),
) -> Result<SweepRow> {
    set_seed(integrator, seeds[0]);
    let m = measure(gpu, integrator, integrand, spec.setup.repeats)?;
    let mut errors = vec![metrics::compare(&m.render.image, reference)?];
    for &seed in &seeds[1..] {
        set_seed(integrator, seed);
        let image = integrator.render(gpu, integrand)?.image;
        errors.push(metrics::compare(&image, reference)?);
    }
    let relmse: Vec<f64> = errors.iter().map(|e| e.relmse).collect();
    let (relmse, relmse_ci95) = mean_ci95(&relmse);
    Ok(SweepRow {
        method: method.into(),
        spp,
        samples: m.render.samples,
        time_ms: m.total_ms(),
        relmse,
        relmse_ci95,
        mse: errors.iter().map(|e| e.mse).sum::<f64>() / errors.len() as f64,
        seeds: seeds.to_vec(),
    })
}
