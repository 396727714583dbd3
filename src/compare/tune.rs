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

use super::equal_time::{interpolate_log_log, TimeFit};
use super::inputs::{check_reference, ReferenceSource, Setup, Subject};
use super::intervals::seed_plan;
use super::progress::bar;
use super::seeds::SeedStats;
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
use serde::Serialize;
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

/// Halton at one budget.
#[derive(Clone, Debug, Serialize)]
pub struct HaltonPoint {
    pub spp: u32,
    pub relmse: f64,
    pub relmse_ci95: [f64; 2],
    pub relative_bias: [f64; 3],
    /// Fastest render (ms).
    pub time_ms: f64,
}

/// One configuration's figures.
#[derive(Clone, Debug, Serialize)]
pub struct TuneRow {
    pub label: String,
    pub values: BTreeMap<String, f64>,
    pub params: MdasParams,
    pub relmse: f64,
    pub relmse_ci95: [f64; 2],
    pub relative_bias: [f64; 3],
    pub relative_bias_ci95: [[f64; 2]; 3],
    pub mse_bias2: f64,
    pub mse_variance: f64,
    /// Fastest render (ms).
    pub time_ms: f64,
    /// RelMSE over Halton's at the same spp.
    pub equal_samples_ratio: f64,
    /// Halton's spp at this time from the fit, its RelMSE there, and the
    /// ratio (absent when the spp lies outside Halton's budgets).
    pub equal_time_halton_spp: Option<f64>,
    pub equal_time_halton_relmse: Option<f64>,
    pub equal_time_ratio: Option<f64>,
}

/// `tune.json`.
#[derive(Clone, Debug, Serialize)]
pub struct TuneReport {
    pub scene: String,
    pub scale: f32,
    pub spp: f32,
    pub mdas_seeds: Vec<u32>,
    pub halton_seeds: Vec<u32>,
    /// The Halton reference's spp (0 for an exact reference).
    pub reference_spp: u32,
    pub reference_seed: u32,
    /// Where the Halton reference is cached (empty for an exact one).
    pub reference_path: String,
    /// How an exact reference was made ([`tune_integrand`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub reference_exact: Option<String>,
    pub ranking: &'static str,
    pub grid: Vec<(String, Vec<f64>)>,
    pub halton: Vec<HaltonPoint>,
    pub halton_fit: Option<TimeFit>,
    /// Ranked, best first.
    pub rows: Vec<TuneRow>,
    /// Configurations that cannot run, and why.
    pub skipped: Vec<(String, String)>,
    /// The best row as an `[mdas]` table.
    pub best_table: Option<String>,
    pub flags: Vec<String>,
    pub provenance: crate::provenance::Provenance,
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

/// A grid's configurations that can run on `integrand` (label, values,
/// parameters), and those that cannot with why; an error when none can.
type Plan = (
    Vec<(String, BTreeMap<String, f64>, MdasParams)>,
    Vec<(String, String)>,
);

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
    (runnable, skipped): Plan,
    staged: StagedDir,
) -> Result<TuneReport> {
    let setup = &spec.setup;
    let (integrand, reference, base) = (subject.integrand, subject.reference, subject.mdas);
    let (mdas_seeds, halton_seeds) =
        seed_plan(spec.seeds, base.seed, setup.halton_seed, setup.ref_seed)?;
    let (reference_spp, reference_path, reference_exact) = match &subject.reference_source {
        ReferenceSource::Halton { spp, path, .. } => (*spp, path.display().to_string(), None),
        ReferenceSource::Exact(how) => (0, String::new(), Some(how.clone())),
    };

    let k = spec.seeds as u64;
    let budgets = halton_budgets(base.spp);
    let progress = bar(
        setup.progress,
        (budgets.len() as u64 + runnable.len() as u64) * (k + 1),
        "tune {bar:30} {pos}/{len} renders: {msg} [{elapsed_precise} < {eta}]",
    );

    // Halton at each budget.
    let mut halton = Halton::new(budgets[0], halton_seeds[0]);
    let mut halton_points = Vec::new();
    for &spp in &budgets {
        progress.set_message(format!("halton {spp} spp"));
        halton.spp = spp;
        let (stats, time_ms) = over_seeds(
            gpu,
            &mut halton,
            integrand,
            reference,
            &halton_seeds,
            &progress,
            |h, s| h.seed = s,
        )?;
        halton_points.push(HaltonPoint {
            spp,
            relmse: stats.relmse,
            relmse_ci95: stats.relmse_ci95,
            relative_bias: stats.relative_bias,
            time_ms,
        });
    }
    let runs: Vec<(u32, f64, f64)> = halton_points
        .iter()
        .map(|p| (p.spp, p.time_ms, 0.0))
        .collect();
    let fit = TimeFit::new(&runs);
    let mut flags: Vec<String> = fit.iter().flat_map(|f| f.flags.clone()).collect();
    let equal_spp = (base.spp.round() as u32).max(1);
    let halton_at_budget = halton_points
        .iter()
        .find(|p| p.spp == equal_spp)
        .map(|p| p.relmse)
        .expect("the budget is one of Halton's");

    // Each configuration.
    let mut rows = Vec::new();
    for (label, values, params) in runnable {
        progress.set_message(label.clone());
        let mut mdas = Mdas::new(params)?;
        let (s, time_ms) = over_seeds(
            gpu,
            &mut mdas,
            integrand,
            reference,
            &mdas_seeds,
            &progress,
            Mdas::set_seed,
        )?;
        let halton_spp = fit.as_ref().and_then(|f| f.spp_at(time_ms));
        let halton_relmse = halton_spp.and_then(|x| halton_relmse_at(&halton_points, x));
        if halton_spp.is_some() && halton_relmse.is_none() {
            flags.push(format!(
                "{label}: Halton's spp at its time ({:.1}) lies outside the budgets {:?}",
                halton_spp.unwrap_or(f64::NAN),
                budgets
            ));
        }
        rows.push(TuneRow {
            label,
            values,
            params,
            relmse: s.relmse,
            relmse_ci95: s.relmse_ci95,
            relative_bias: s.relative_bias,
            relative_bias_ci95: s.relative_bias_ci95,
            mse_bias2: s.mse_bias2,
            mse_variance: s.mse_variance,
            time_ms,
            equal_samples_ratio: s.relmse / halton_at_budget,
            equal_time_halton_spp: halton_spp,
            equal_time_halton_relmse: halton_relmse,
            equal_time_ratio: halton_relmse.map(|h| s.relmse / h),
        });
    }
    progress.finish_and_clear();
    rank(&mut rows, spec.equal_samples);
    let best_table = rows.first().map(|r| mdas_table(&r.params));
    let report = TuneReport {
        scene: subject.name.clone(),
        scale: setup.scale,
        spp: base.spp,
        mdas_seeds,
        halton_seeds,
        reference_spp,
        reference_seed: setup.ref_seed,
        reference_path,
        reference_exact,
        ranking: if spec.equal_samples {
            "relmse at equal samples"
        } else {
            "relmse ratio at equal time"
        },
        grid: spec.grid.clone(),
        halton: halton_points,
        halton_fit: fit,
        rows,
        skipped,
        best_table,
        flags,
        provenance: match subject.scene_file {
            Some(file) => crate::provenance::Provenance::new(gpu, file, integrand, Some(base))?,
            None => crate::provenance::Provenance::of_integrand(gpu, integrand, Some(base)),
        },
    };
    let json = serde_json::to_string_pretty(&report)?;
    image_io::write_atomic(&staged.path().join("tune.csv"), |t| {
        std::fs::write(t, csv(&report.rows)).map_err(Into::into)
    })?;
    image_io::write_atomic(&staged.path().join("tune.json"), |t| {
        std::fs::write(t, json).map_err(Into::into)
    })?;
    staged.commit("tune.json")?;
    Ok(report)
}

/// Halton's budgets around `spp` ([`HALTON_FACTORS`]), whole, distinct.
fn halton_budgets(spp: f32) -> Vec<u32> {
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

/// Halton's mean RelMSE at `spp`, log–log between the bracketing budgets
/// (`None` outside them).
fn halton_relmse_at(points: &[HaltonPoint], spp: f64) -> Option<f64> {
    let inside = |p: &&HaltonPoint| f64::from(p.spp) <= spp;
    let lo = points.iter().rev().find(inside)?;
    let hi = points.iter().find(|p| f64::from(p.spp) >= spp)?;
    if lo.spp == hi.spp {
        return Some(lo.relmse);
    }
    Some(interpolate_log_log(
        spp,
        (f64::from(lo.spp), lo.relmse),
        (f64::from(hi.spp), hi.relmse),
    ))
}

/// Best first: by equal-time ratio (rows without one last, by RelMSE), or
/// by RelMSE.
fn rank(rows: &mut [TuneRow], equal_samples: bool) {
    rows.sort_by(|a, b| {
        let key = |r: &TuneRow| {
            if equal_samples {
                (0, r.relmse)
            } else {
                r.equal_time_ratio.map_or((1, r.relmse), |x| (0, x))
            }
        };
        let (ka, kb) = (key(a), key(b));
        ka.0.cmp(&kb.0).then(ka.1.total_cmp(&kb.1))
    });
}

/// `p` as an `[mdas]` table (every key of [`PARAMS`] but `seed`, in the
/// registry's order). An automatic grid (`auto_grid`) is written as a
/// comment, so that the table keeps choosing it per render.
pub fn mdas_table(p: &MdasParams) -> String {
    let row = |param: &Param| {
        let mut one = toml::Table::new();
        one.insert(param.key.into(), param.toml(param.get(p)));
        toml::to_string(&one).expect("a one-key table serializes")
    };
    let mut out = String::from("[mdas]\n");
    if p.auto_grid {
        out += "# initial grid chosen per render from the film and budget; here:\n";
    }
    for param in PARAMS.iter().filter(|q| q.key != "seed") {
        let line = row(param);
        if p.auto_grid && param.grid {
            out += &format!("# {line}");
        } else {
            out += &line;
        }
    }
    out
}

pub const CSV_HEADER: &str = "rank,label,relmse,relmse_lo,relmse_hi,bias_r,bias_g,bias_b,mse_bias2,mse_variance,time_ms,equal_samples_ratio,equal_time_ratio";

/// The ranked rows as CSV (an empty field where a row has no equal-time
/// ratio).
pub fn csv(rows: &[TuneRow]) -> String {
    let mut s = format!("{CSV_HEADER}\n");
    for (i, r) in rows.iter().enumerate() {
        s += &format!(
            "{},\"{}\",{},{},{},{},{},{},{},{},{},{},{}\n",
            i + 1,
            r.label,
            r.relmse,
            r.relmse_ci95[0],
            r.relmse_ci95[1],
            r.relative_bias[0],
            r.relative_bias[1],
            r.relative_bias[2],
            r.mse_bias2,
            r.mse_variance,
            r.time_ms,
            r.equal_samples_ratio,
            r.equal_time_ratio
                .map_or_else(String::new, |x| x.to_string())
        );
    }
    s
}

/// The console table: Halton's budgets, then the ranked configurations.
pub fn table(report: &TuneReport) -> String {
    let mut out = format!(
        "{} at scale {}, {} spp, {} seeds per row, reference {} spp; ranked by {}\n",
        report.scene,
        report.scale,
        report.spp,
        report.mdas_seeds.len(),
        report.reference_spp,
        report.ranking
    );
    for p in &report.halton {
        out += &format!(
            "halton {:>5} spp: RelMSE {:.4e} [{:.3e}, {:.3e}], {:.2} ms\n",
            p.spp, p.relmse, p.relmse_ci95[0], p.relmse_ci95[1], p.time_ms
        );
    }
    let w = report
        .rows
        .iter()
        .map(|r| r.label.chars().count())
        .max()
        .unwrap_or(6)
        .max(13);
    out += &format!(
        "{:>4} {:<w$} {:>11} {:>23} {:>22} {:>9} {:>8} {:>8}\n",
        "rank", "configuration", "RelMSE", "95% interval", "bias R/G/B", "ms", "eq.spp", "eq.time"
    );
    let pct = |x: f64| format!("{:+.2}%", 100.0 * x);
    for (i, r) in report.rows.iter().enumerate() {
        out += &format!(
            "{:>4} {:<w$} {:>11.4e} {:>23} {:>22} {:>9.2} {:>8.3} {:>8}\n",
            i + 1,
            r.label,
            r.relmse,
            format!("[{:.3e}, {:.3e}]", r.relmse_ci95[0], r.relmse_ci95[1]),
            format!(
                "{}/{}/{}",
                pct(r.relative_bias[0]),
                pct(r.relative_bias[1]),
                pct(r.relative_bias[2])
            ),
            r.time_ms,
            r.equal_samples_ratio,
            r.equal_time_ratio
                .map_or_else(|| "–".into(), |x| format!("{x:.3}"))
        );
    }
    for (label, why) in &report.skipped {
        out += &format!("skipped {label}: {why}\n");
    }
    for f in &report.flags {
        out += &format!("warning: {f}\n");
    }
    if let Some(t) = &report.best_table {
        out += &format!("best configuration:\n{t}");
    }
    out
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
    fn halton_interpolation_and_budgets() {
        let p = |spp, relmse| HaltonPoint {
            spp,
            relmse,
            relmse_ci95: [relmse; 2],
            relative_bias: [0.0; 3],
            time_ms: 1.0,
        };
        let points = [p(4, 4e-2), p(8, 2e-2), p(16, 1e-2)];
        // RelMSE ∝ 1/spp is exact under log–log interpolation.
        assert!((halton_relmse_at(&points, 5.0).unwrap() - 0.032).abs() < 1e-12);
        assert_eq!(halton_relmse_at(&points, 8.0), Some(2e-2));
        assert_eq!(halton_relmse_at(&points, 3.9), None);
        assert_eq!(halton_relmse_at(&points, 16.1), None);
        assert_eq!(halton_budgets(8.0), vec![4, 8, 16, 32]);
        assert_eq!(halton_budgets(1.0), vec![1, 2, 4]);
        assert_eq!(halton_budgets(6.5), vec![3, 7, 13, 26]);
    }

    #[test]
    fn ranking_puts_rows_without_a_ratio_last() {
        let row = |label: &str, relmse: f64, ratio: Option<f64>| TuneRow {
            label: label.into(),
            values: BTreeMap::new(),
            params: MdasParams::default(),
            relmse,
            relmse_ci95: [relmse; 2],
            relative_bias: [0.0; 3],
            relative_bias_ci95: [[0.0; 2]; 3],
            mse_bias2: 0.0,
            mse_variance: 0.0,
            time_ms: 1.0,
            equal_samples_ratio: 1.0,
            equal_time_halton_spp: None,
            equal_time_halton_relmse: None,
            equal_time_ratio: ratio,
        };
        let mut rows = vec![
            row("a", 1e-3, None),
            row("b", 3e-3, Some(0.9)),
            row("c", 2e-3, Some(0.5)),
        ];
        rank(&mut rows, false);
        let order: Vec<&str> = rows.iter().map(|r| r.label.as_str()).collect();
        assert_eq!(order, ["c", "b", "a"]);
        rank(&mut rows, true);
        let order: Vec<&str> = rows.iter().map(|r| r.label.as_str()).collect();
        assert_eq!(order, ["a", "c", "b"]);
        let t = mdas_table(&MdasParams::default());
        assert!(
            t.starts_with("[mdas]\n") && t.contains("epsilon = 0.01\n"),
            "{t}"
        );
    }
}
