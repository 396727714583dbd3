//! `mdas tune`: MDAS over a grid of parameter values, each configuration
//! over several seeds, against Halton at equal samples and at equal time —
//! the search the MDAS paper ran "exhaustively over many different
//! configurations" (§5.1), with each figure's interval and bias.
//!
//! 1. Validation: every configuration of the grid (the cartesian product
//!    of the `--grid` values over the scene's parameters) is checked
//!    against the integrand; those that cannot run (an initial grid above
//!    the budget, a Morton code too wide) are listed as skipped, with the
//!    reason, before any render.
//! 2. The reference (cached, as `compare`'s).
//! 3. Halton at ½, 1, 2 and 4 × the budget, each over `seeds` seeds after
//!    one untimed render: each budget's RelMSE (mean, 95% interval) and
//!    fastest render time, and a time fit (`equal_time::TimeFit`).
//! 4. Each configuration at the budget over its seeds, after one untimed
//!    render: RelMSE (mean, interval), relative bias per channel with its
//!    interval, the MSE's bias²/variance split, and its fastest render.
//! 5. Ratios: at equal samples, RelMSE over Halton's at the budget; at
//!    equal time, over Halton's at the spp the fit gives for the
//!    configuration's time, interpolated log–log between the bracketing
//!    budgets' means (none, and a flag, when that spp lies outside ½…4 ×).
//!    Times are the fastest of each method's renders, not interleaved
//!    rounds as in `compare`: the ranking is a search, `compare` is the
//!    measurement to publish.
//!
//! Rows are ranked by the equal-time ratio (configurations without one
//! last), or by RelMSE with `equal_samples`. The best row is also printed
//! as an `[mdas]` table ready to paste into the scene file.

use super::inputs::{check_reference, ReferenceSource, Setup, Subject};
use super::intervals::seed_plan;
use super::progress::bar;
use super::seeds::SeedStats;
use super::tune_report::write_tune;
pub use super::tune_report::{
    csv, finish, mdas_table, table, HaltonPoint, Head, Measured, TuneReport, TuneRow, CSV_HEADER,
};
use crate::atomic::StagedDir;
use crate::gpu::Gpu;
use crate::image_io;
use crate::integrand::Integrand;
use crate::integrator::mdas::params::Param;
use crate::integrator::mdas::{MdasParams, PARAMS};
use crate::integrator::{Halton, Integrator, Mdas};
use crate::session;
use anyhow::{bail, Context, Result};
use indicatif::ProgressBar;
use std::collections::BTreeMap;

/// The `[mdas]` keys a grid may vary: the registry's tunable ones
/// ([`PARAMS`]; `split` and `reconstruction` take the rule names, stored
/// as their index in the rule's names).
pub fn grid_keys() -> impl Iterator<Item = &'static Param> {
    PARAMS.iter().filter(|p| p.tunable)
}

/// Most configurations one run may hold.
pub const MAX_CONFIGS: usize = 512;

/// Halton's budgets, as multiples of MDAS's.
const HALTON_FACTORS: [f64; 4] = [0.5, 1.0, 2.0, 4.0];

/// The grid without `--grid`: α from the paper's direct-lighting value to
/// today's default and beyond, sf from the paper's range, ε at the default
/// and ten times it — 4 × 3 × 2 = 24 configurations.
pub fn default_grid() -> Vec<(String, Vec<f64>)> {
    vec![
        ("alpha".into(), vec![0.0, 1.0 / 64.0, 1.0 / 16.0, 0.25]),
        ("scale_factor".into(), vec![1.0 / 16.0, 0.25, 1.0]),
        ("epsilon".into(), vec![0.01, 0.1]),
    ]
}

/// Parses `KEY=V1,V2,...` (a key of [`grid_keys`]; numbers, or a rule's
/// names).
pub fn parse_grid_entry(s: &str) -> Result<(String, Vec<f64>)> {
    let (key, values) = s
        .split_once('=')
        .with_context(|| format!("grid entry '{s}' is not KEY=V1,V2,..."))?;
    let key = key.trim();
    let Some(param) = grid_keys().find(|p| p.key == key) else {
        let keys: Vec<&str> = grid_keys().map(|p| p.key).collect();
        bail!(
            "grid entry '{s}': unknown key '{key}', expected one of {}",
            keys.join(", ")
        );
    };
    let values: Vec<f64> = values
        .split(',')
        .map(|v| {
            param
                .parse(v)
                .map_err(|e| anyhow::anyhow!("grid entry '{s}': {e}"))
        })
        .collect::<Result<_>>()?;
    if values.is_empty() {
        bail!("grid entry '{s}' has no values");
    }
    Ok((key.to_string(), values))
}

/// `p` with `key` set to `v`, a value of the key's kind
/// ([`Param::check_kind`]; the ranges are `validate`'s, checked against
/// the integrand before any render). A key of the initial grid fixes the
/// grid: every key of it takes the (resolved) value the render would have
/// chosen.
fn with_value(p: MdasParams, key: &str, v: f64) -> Result<MdasParams> {
    let param = grid_keys()
        .find(|p| p.key == key)
        .with_context(|| format!("unknown grid key '{key}'"))?;
    param
        .check_kind(v)
        .map_err(|why| anyhow::anyhow!("{key} = {v}: {why}"))?;
    let mut p = p;
    param.set(&mut p, v);
    Ok(p)
}

/// One configuration of a grid: its label, its values by key, and its
/// parameters or why they cannot be made.
type Configuration = (String, BTreeMap<String, f64>, Result<MdasParams>);

/// Every configuration of `grid` over `base`, in grid order (the first key
/// varies slowest).
fn configurations(base: MdasParams, grid: &[(String, Vec<f64>)]) -> Result<Vec<Configuration>> {
    let count = grid.iter().map(|(_, v)| v.len()).product::<usize>();
    if count > MAX_CONFIGS {
        bail!("the grid has {count} configurations, at most {MAX_CONFIGS}");
    }
    let mut keys: Vec<&str> = grid.iter().map(|(k, _)| k.as_str()).collect();
    keys.sort_unstable();
    if keys.windows(2).any(|w| w[0] == w[1]) {
        bail!("a grid key is given twice");
    }
    let mut out = Vec::with_capacity(count);
    for index in 0..count {
        let mut rest = index;
        let mut values = BTreeMap::new();
        let mut label = Vec::new();
        let mut params = Ok(base);
        for (key, vs) in grid.iter().rev() {
            let v = vs[rest % vs.len()];
            rest /= vs.len();
            values.insert(key.clone(), v);
            params = params.and_then(|p| with_value(p, key, v));
        }
        for (key, _) in grid {
            let v = values[key];
            let shown = grid_keys()
                .find(|p| p.key == key)
                .map_or_else(|| v.to_string(), |p| p.format(v));
            label.push(format!("{key}={shown}"));
        }
        out.push((label.join(" "), values, params));
    }
    Ok(out)
}

/// Inputs of [`tune`].
pub struct TuneSpec<'a> {
    /// The scene, reference, seeds and output (`setup.mdas_params` gives
    /// the base configuration, its spp the budget; `repeats` is unused).
    pub setup: Setup<'a>,
    pub grid: Vec<(String, Vec<f64>)>,
    /// Seeds per configuration and per Halton budget (1..=64).
    pub seeds: u32,
    /// Rank by RelMSE at equal samples instead of the equal-time ratio.
    pub equal_samples: bool,
}

/// Runs the search on the setup's scene; writes `tune.json` and
/// `tune.csv` in `setup.out`.
pub fn tune(gpu: &Gpu, spec: &TuneSpec) -> Result<TuneReport> {
    let setup = &spec.setup;
    setup.check()?;
    let staged = StagedDir::new(&setup.out)?;
    let prepared = session::prepare(gpu, &setup.scene, setup.scale)?;
    let integrand = prepared.integrand.as_ref();
    // An automatic grid resolved at this film and budget, so that a grid
    // key of it (`extra_image_bits`, …) starts from the render's own choice.
    let base = (setup.mdas_params)(prepared.scene.mdas).resolved(integrand.film());
    // The grid is checked before the reference is rendered.
    let (runnable, skipped) = runnable(base, &spec.grid, integrand)?;
    let (reference, path, cached) = setup.reference(gpu)?;
    let subject = setup.scene_subject(integrand, base, &reference, path, cached);
    tune_subject(gpu, spec, &subject, (runnable, skipped), staged)
}

/// [`tune`] on an integrand built in code against a reference given with
/// it (`compare::compare_integrand` explains the [`Subject`]): the grid
/// varies `subject.mdas`, whose spp is the budget and whose seed is
/// MDAS's first. The setup's scene, scale, reference spp, cache and
/// parameter mapping are not used. `tests/compare.rs` runs it on a closed
/// form.
pub fn tune_integrand(gpu: &Gpu, spec: &TuneSpec, subject: &Subject) -> Result<TuneReport> {
    spec.setup.check()?;
    check_reference(subject)?;
    let plan = runnable(subject.mdas, &spec.grid, subject.integrand)?;
    let staged = StagedDir::new(&spec.setup.out)?;
    tune_subject(gpu, spec, subject, plan, staged)
}

/// A grid's configurations that can run (label, values, parameters).
type Runnable = Vec<(String, BTreeMap<String, f64>, MdasParams)>;

/// A grid's configurations that can run on `integrand`, and those that
/// cannot with why; an error when none can.
type Plan = (Runnable, Vec<(String, String)>);

fn runnable(
    base: MdasParams,
    grid: &[(String, Vec<f64>)],
    integrand: &dyn Integrand,
) -> Result<Plan> {
    let mut runnable = Vec::new();
    let mut skipped = Vec::new();
    for (label, values, params) in configurations(base, grid)? {
        match params.and_then(|p| {
            Mdas::new(p)?.config(integrand)?;
            Ok(p)
        }) {
            Ok(p) => runnable.push((label, values, p)),
            Err(e) => skipped.push((label, format!("{e:#}"))),
        }
    }
    if runnable.is_empty() {
        bail!(
            "no configuration of the grid can run: {}",
            skipped
                .iter()
                .map(|(l, e)| format!("{l} ({e})"))
                .collect::<Vec<_>>()
                .join("; ")
        );
    }
    Ok((runnable, skipped))
}

fn tune_subject(
    gpu: &Gpu,
    spec: &TuneSpec,
    subject: &Subject,
    plan: Plan,
    staged: StagedDir,
) -> Result<TuneReport> {
    let (head, runnable) = head(gpu, spec, subject, plan)?;
    let items = head.budgets.len() + runnable.len();
    let (halton, measured) = measure(gpu, spec, subject, &head, &runnable, 0..items)?;
    let report = finish(head, halton, measured, None);
    write_tune(staged.path(), &report)?;
    crate::viewer::write_page(staged.path())?;
    staged.commit("tune.json")?;
    Ok(report)
}

/// The report's render-free fields, and the configurations to measure.
fn head(
    gpu: &Gpu,
    spec: &TuneSpec,
    subject: &Subject,
    (runnable, skipped): Plan,
) -> Result<(Head, Runnable)> {
    let setup = &spec.setup;
    let (integrand, base) = (subject.integrand, subject.mdas);
    let (mdas_seeds, halton_seeds) =
        seed_plan(spec.seeds, base.seed, setup.halton_seed, setup.ref_seed)?;
    let (reference_spp, reference_path, reference_exact) = match &subject.reference_source {
        ReferenceSource::Halton { spp, path, .. } => (*spp, path.display().to_string(), None),
        ReferenceSource::Exact(how) => (0, String::new(), Some(how.clone())),
    };
    let head = Head {
        scene: subject.name.clone(),
        scale: setup.scale,
        spp: base.spp,
        mdas_seeds,
        halton_seeds,
        reference_spp,
        reference_seed: setup.ref_seed,
        reference_path,
        reference_exact,
        equal_samples: spec.equal_samples,
        grid: spec.grid.clone(),
        budgets: halton_budgets(base.spp),
        skipped,
        provenance: match subject.scene_file {
            Some(file) => crate::provenance::Provenance::new(gpu, file, integrand, Some(base))?,
            None => crate::provenance::Provenance::of_integrand(gpu, integrand, Some(base)),
        },
    };
    Ok((head, runnable))
}

/// The search's work items `items` of Halton's budgets followed by the
/// configurations: the Halton points and the measured configurations among
/// them, in order.
fn measure(
    gpu: &Gpu,
    spec: &TuneSpec,
    subject: &Subject,
    head: &Head,
    runnable: &Runnable,
    items: std::ops::Range<usize>,
) -> Result<(Vec<HaltonPoint>, Vec<Measured>)> {
    let (integrand, reference) = (subject.integrand, subject.reference);
    let b = head.budgets.len();
    let budgets = &head.budgets[items.start.min(b)..items.end.min(b)];
    let configs = &runnable[items.start.max(b) - b..items.end.max(b) - b];
    let progress = bar(
        spec.setup.progress,
        items.len() as u64 * (spec.seeds as u64 + 1),
        "tune {bar:30} {pos}/{len} renders: {msg} [{elapsed_precise} < {eta}]",
    );
    let mut halton = Halton::new(1, head.halton_seeds[0]);
    let mut points = Vec::with_capacity(budgets.len());
    for &spp in budgets {
        progress.set_message(format!("halton {spp} spp"));
        halton.spp = spp;
        let (stats, time_ms) = over_seeds(
            gpu,
            &mut halton,
            integrand,
            reference,
            &head.halton_seeds,
            &progress,
            |h, s| h.seed = s,
        )?;
        points.push(HaltonPoint {
            spp,
            relmse: stats.relmse,
            relmse_ci95: stats.relmse_ci95,
            relative_bias: stats.relative_bias,
            time_ms,
        });
    }
    let mut measured = Vec::with_capacity(configs.len());
    for (label, values, params) in configs {
        progress.set_message(label.clone());
        let mut mdas = Mdas::new(*params)?;
        let (s, time_ms) = over_seeds(
            gpu,
            &mut mdas,
            integrand,
            reference,
            &head.mdas_seeds,
            &progress,
            Mdas::set_seed,
        )?;
        measured.push(Measured {
            label: label.clone(),
            values: values.clone(),
            params: *params,
            relmse: s.relmse,
            relmse_ci95: s.relmse_ci95,
            relative_bias: s.relative_bias,
            relative_bias_ci95: s.relative_bias_ci95,
            mse_bias2: s.mse_bias2,
            mse_variance: s.mse_variance,
            time_ms,
        });
    }
    progress.finish_and_clear();
    Ok((points, measured))
}

/// The file a tune part writes in its output directory.
pub const PART_FILE: &str = "tune-part.json";

/// The format tag of [`TunePart`].
pub const PART_FORMAT: &str = "mdas tune part 1";

/// `tune-part.json`: part `part` of `parts` of a search — its share
/// `first..end` of the work items (Halton's budgets, then the runnable
/// configurations), measured as one process measures them, and what a
/// merge checks to know that the parts belong together.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct TunePart {
    pub format: String,
    pub part: u32,
    pub parts: u32,
    /// Every runnable configuration's label, in the search's order.
    pub configurations: Vec<String>,
    pub first: u32,
    pub end: u32,
    /// SHA-256 of the reference's pixels ([`session::pixels_sha256`]).
    pub reference_sha256: String,
    pub head: Head,
    /// This part's Halton points and configurations, in order.
    pub halton: Vec<HaltonPoint>,
    pub measured: Vec<Measured>,
}

/// Measures part `part` of the search on the setup's scene — work items
/// ⌊(I − 1)·W/N⌋ .. ⌊I·W/N⌋ of its W items (Halton's budgets, then the
/// configurations) — and writes [`PART_FILE`] in the setup's output
/// directory.
pub fn tune_part(gpu: &Gpu, spec: &TuneSpec, part: session::parts::Part) -> Result<TunePart> {
    let setup = &spec.setup;
    setup.check()?;
    let staged = StagedDir::new(&setup.out)?;
    let prepared = session::prepare(gpu, &setup.scene, setup.scale)?;
    let integrand = prepared.integrand.as_ref();
    let base = (setup.mdas_params)(prepared.scene.mdas).resolved(integrand.film());
    let plan = runnable(base, &spec.grid, integrand)?;
    let items = halton_budgets(base.spp).len() + plan.0.len();
    if part.count as usize > items {
        bail!(
            "{} parts of a search of {items} renders sets (Halton's budgets and the configurations): every part needs one (at most {items} parts)",
            part.count
        );
    }
    let range = part.range(items as u32);
    let (reference, path, cached) = setup.reference(gpu)?;
    let reference_sha256 = session::pixels_sha256(&reference);
    let subject = setup.scene_subject(integrand, base, &reference, path, cached);
    let (head, runnable) = head(gpu, spec, &subject, plan)?;
    let span = range.start as usize..range.end as usize;
    let (halton, measured) = measure(gpu, spec, &subject, &head, &runnable, span)?;
    let record = TunePart {
        format: PART_FORMAT.into(),
        part: part.index,
        parts: part.count,
        configurations: runnable.iter().map(|c| c.0.clone()).collect(),
        first: range.start,
        end: range.end,
        reference_sha256,
        head,
        halton,
        measured,
    };
    let json = serde_json::to_string_pretty(&record)?;
    image_io::write_atomic(&staged.path().join(PART_FILE), |t| {
        std::fs::write(t, json.as_bytes()).map_err(Into::into)
    })?;
    staged.commit(PART_FILE)?;
    Ok(record)
}

/// Halton's budgets around `spp` ([`HALTON_FACTORS`]), whole, distinct.
pub(super) fn halton_budgets(spp: f32) -> Vec<u32> {
    let mut b: Vec<u32> = HALTON_FACTORS
        .iter()
        .map(|f| ((f64::from(spp) * f).round() as u32).max(1))
        .collect();
    b.push((spp.round() as u32).max(1));
    b.sort_unstable();
    b.dedup();
    b
}

/// `integrator` over `seeds` after one untimed render: the statistics and
/// the fastest render's time.
fn over_seeds<I: Integrator>(
    gpu: &Gpu,
    integrator: &mut I,
    integrand: &dyn Integrand,
    reference: &[[f32; 3]],
    seeds: &[u32],
    progress: &ProgressBar,
    set_seed: impl Fn(&mut I, u32),
) -> Result<(SeedStats, f64)> {
    set_seed(integrator, seeds[0]);
    integrator.render(gpu, integrand)?;
    progress.inc(1);
    let mut images = Vec::with_capacity(seeds.len());
    let mut fastest = f64::INFINITY;
    for &seed in seeds {
        set_seed(integrator, seed);
        let r = integrator.render(gpu, integrand)?;
        fastest = fastest.min(r.times.total());
        images.push(r.image);
        progress.inc(1);
    }
    let views: Vec<&[[f32; 3]]> = images.iter().map(Vec::as_slice).collect();
    Ok((SeedStats::new(&views, reference)?, fastest))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::integrator::mdas::SplitRule;

    #[test]
    fn grid_entries_parse_or_name_what_is_wrong() {
        assert_eq!(
            parse_grid_entry("alpha=0, 0.25").unwrap(),
            ("alpha".to_string(), vec![0.0, 0.25])
        );
        let e = format!("{:#}", parse_grid_entry("alfa=1").unwrap_err());
        assert!(
            e.contains("unknown key 'alfa'") && e.contains("epsilon"),
            "{e}"
        );
        assert!(parse_grid_entry("alpha").is_err());
        assert!(parse_grid_entry("alpha=x").is_err());
        assert!(parse_grid_entry("alpha=nan").is_err());
        assert_eq!(
            parse_grid_entry("split=extent,contrast,trimmed").unwrap().1,
            vec![0.0, 1.0, 2.0]
        );
        assert!(parse_grid_entry("split=median").is_err());
        assert_eq!(
            parse_grid_entry("reconstruction=box,pixel").unwrap().1,
            vec![0.0, 1.0]
        );
        assert!(parse_grid_entry("reconstruction=gauss").is_err());
    }

    #[test]
    fn the_grid_is_the_cartesian_product_in_order() {
        let grid = vec![
            ("alpha".to_string(), vec![0.0, 0.5]),
            ("candidates".to_string(), vec![1.0, 4.0, 2.5]),
        ];
        let configs = configurations(MdasParams::default(), &grid).unwrap();
        assert_eq!(configs.len(), 6);
        let labels: Vec<&str> = configs.iter().map(|c| c.0.as_str()).collect();
        assert_eq!(labels[0], "alpha=0 candidates=1");
        assert_eq!(labels[1], "alpha=0 candidates=4");
        assert_eq!(labels[3], "alpha=0.5 candidates=1");
        let p = configs[4].2.as_ref().unwrap();
        assert_eq!((p.alpha, p.candidates), (0.5, 4));
        // A fractional integer is that configuration's error, not the run's.
        assert!(configs[2].2.is_err() && configs[5].2.is_err());
        let twice = vec![grid[0].clone(), grid[0].clone()];
        assert!(configurations(MdasParams::default(), &twice).is_err());
        let big = vec![("alpha".to_string(), vec![0.0; MAX_CONFIGS + 1])];
        assert!(configurations(MdasParams::default(), &big).is_err());
    }

    #[test]
    fn split_rules_round_trip_through_the_grid() {
        let grid = vec![parse_grid_entry("split=trimmed,extent,contrast").unwrap()];
        let configs = configurations(MdasParams::default(), &grid).unwrap();
        for ((label, _, p), rule) in
            configs
                .iter()
                .zip([SplitRule::Trimmed, SplitRule::Extent, SplitRule::Contrast])
        {
            assert_eq!(label, &format!("split={rule}"));
            assert_eq!(p.as_ref().unwrap().split, rule);
        }
        let beyond = vec![("split".to_string(), vec![3.0])];
        assert!(configurations(MdasParams::default(), &beyond).unwrap()[0]
            .2
            .is_err());
    }

    #[test]
    fn halton_budgets_are_whole_and_distinct() {
        assert_eq!(halton_budgets(8.0), vec![4, 8, 16, 32]);
        assert_eq!(halton_budgets(1.0), vec![1, 2, 4]);
        assert_eq!(halton_budgets(6.5), vec![3, 7, 13, 26]);
    }
}
