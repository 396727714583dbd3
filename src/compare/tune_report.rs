//! What `mdas tune` reports (`tune.json`, `tune.csv`, the console
//! table) and how its measurements become the ranked report: Halton's
//! time fit, each configuration's ratios at equal samples and at equal
//! time, the ranking and the best `[mdas]` table ([`finish`]). One process
//! and a merge of parts (`mdas merge`) both end here.

use super::equal_time::{interpolate_log_log, TimeFit};
use crate::image_io;
use crate::integrator::mdas::params::Param;
use crate::integrator::mdas::{MdasParams, PARAMS};
use crate::provenance::{PartProvenance, Provenance};
use anyhow::Result;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::Path;

/// Halton at one budget.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct HaltonPoint {
    pub spp: u32,
    pub relmse: f64,
    #[serde(deserialize_with = "super::seeds::de_interval")]
    pub relmse_ci95: [f64; 2],
    pub relative_bias: [f64; 3],
    /// Fastest render (ms).
    pub time_ms: f64,
}

/// One configuration's figures: its measurements (written inline in
/// `tune.json`) and its ratios to Halton.
#[derive(Clone, Debug, Serialize)]
pub struct TuneRow {
    #[serde(flatten)]
    pub measured: Measured,
    /// RelMSE over Halton's at the same spp.
    pub equal_samples_ratio: f64,
    /// Halton's spp at this time from the fit, its RelMSE there, and the
    /// ratio (absent when the spp lies outside Halton's budgets).
    pub equal_time_halton_spp: Option<f64>,
    pub equal_time_halton_relmse: Option<f64>,
    pub equal_time_ratio: Option<f64>,
}

/// One configuration as measured over its seeds, before the ratios that
/// need Halton's points.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Measured {
    pub label: String,
    pub values: BTreeMap<String, f64>,
    pub params: MdasParams,
    pub relmse: f64,
    #[serde(deserialize_with = "super::seeds::de_interval")]
    pub relmse_ci95: [f64; 2],
    pub relative_bias: [f64; 3],
    #[serde(deserialize_with = "super::seeds::de_intervals3")]
    pub relative_bias_ci95: [[f64; 2]; 3],
    pub mse_bias2: f64,
    pub mse_variance: f64,
    /// Fastest render (ms).
    pub time_ms: f64,
}

/// What a search is before it is measured: the report's fields that do not
/// depend on a render (a part carries them so that a merge can check the
/// parts belong together).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Head {
    pub scene: String,
    pub scale: f32,
    pub spp: f32,
    pub mdas_seeds: Vec<u32>,
    pub halton_seeds: Vec<u32>,
    pub reference_spp: u32,
    pub reference_seed: u32,
    pub reference_path: String,
    pub reference_exact: Option<String>,
    pub equal_samples: bool,
    pub grid: Vec<(String, Vec<f64>)>,
    /// Halton's budgets, ascending.
    pub budgets: Vec<u32>,
    pub skipped: Vec<(String, String)>,
    pub provenance: Provenance,
}

/// The report of Halton's `halton` points (one per budget of `head`) and
/// the `measured` configurations: Halton's time fit, every ratio, the
/// ranking and the best row as a table.
pub fn finish(
    head: Head,
    halton: Vec<HaltonPoint>,
    measured: Vec<Measured>,
    merged_from: Option<Vec<PartProvenance>>,
) -> TuneReport {
    let runs: Vec<(u32, f64, f64)> = halton.iter().map(|p| (p.spp, p.time_ms, 0.0)).collect();
    let fit = TimeFit::new(&runs);
    let mut flags: Vec<String> = fit.iter().flat_map(|f| f.flags.clone()).collect();
    let equal_spp = (head.spp.round() as u32).max(1);
    let halton_at_budget = halton
        .iter()
        .find(|p| p.spp == equal_spp)
        .map(|p| p.relmse)
        .expect("the budget is one of Halton's");
    let mut rows = Vec::with_capacity(measured.len());
    for m in measured {
        let halton_spp = fit.as_ref().and_then(|f| f.spp_at(m.time_ms));
        let halton_relmse = halton_spp.and_then(|x| halton_relmse_at(&halton, x));
        if halton_spp.is_some() && halton_relmse.is_none() {
            flags.push(format!(
                "{}: Halton's spp at its time ({:.1}) lies outside the budgets {:?}",
                m.label,
                halton_spp.unwrap_or(f64::NAN),
                head.budgets
            ));
        }
        rows.push(TuneRow {
            equal_samples_ratio: m.relmse / halton_at_budget,
            equal_time_halton_spp: halton_spp,
            equal_time_halton_relmse: halton_relmse,
            equal_time_ratio: halton_relmse.map(|h| m.relmse / h),
            measured: m,
        });
    }
    rank(&mut rows, head.equal_samples);
    let best_table = rows.first().map(|r| mdas_table(&r.measured.params));
    TuneReport {
        scene: head.scene,
        scale: head.scale,
        spp: head.spp,
        mdas_seeds: head.mdas_seeds,
        halton_seeds: head.halton_seeds,
        reference_spp: head.reference_spp,
        reference_seed: head.reference_seed,
        reference_path: head.reference_path,
        reference_exact: head.reference_exact,
        ranking: if head.equal_samples {
            "relmse at equal samples"
        } else {
            "relmse ratio at equal time"
        },
        grid: head.grid,
        halton,
        halton_fit: fit,
        rows,
        skipped: head.skipped,
        best_table,
        flags,
        provenance: head.provenance,
        merged_from,
    }
}

/// Writes `tune.csv` and `tune.json` of `report` into `dir` (a run's
/// staging directory).
pub(crate) fn write_tune(dir: &Path, report: &TuneReport) -> Result<()> {
    let json = serde_json::to_string_pretty(report)?;
    image_io::write_atomic(&dir.join("tune.csv"), |t| {
        std::fs::write(t, csv(&report.rows)).map_err(Into::into)
    })?;
    image_io::write_atomic(&dir.join("tune.json"), |t| {
        std::fs::write(t, json).map_err(Into::into)
    })
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
    pub provenance: Provenance,
    /// A search merged from parts (`mdas merge`): each part's command line
    /// and time; `provenance` is then the first part's, with the merge's
    /// command line and time.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub merged_from: Option<Vec<PartProvenance>>,
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
                (0, r.measured.relmse)
            } else {
                r.equal_time_ratio
                    .map_or((1, r.measured.relmse), |x| (0, x))
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
/// ratio; a label quoted where it has a comma, a quote or a line break).
pub fn csv(rows: &[TuneRow]) -> String {
    super::csv_table::csv_text(
        CSV_HEADER,
        rows.iter().enumerate().map(|(i, r)| {
            let m = &r.measured;
            vec![
                (i + 1).to_string(),
                m.label.clone(),
                m.relmse.to_string(),
                m.relmse_ci95[0].to_string(),
                m.relmse_ci95[1].to_string(),
                m.relative_bias[0].to_string(),
                m.relative_bias[1].to_string(),
                m.relative_bias[2].to_string(),
                m.mse_bias2.to_string(),
                m.mse_variance.to_string(),
                m.time_ms.to_string(),
                r.equal_samples_ratio.to_string(),
                r.equal_time_ratio
                    .map_or_else(String::new, |x| x.to_string()),
            ]
        }),
    )
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
        .map(|r| r.measured.label.chars().count())
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
            r.measured.label,
            r.measured.relmse,
            format!(
                "[{:.3e}, {:.3e}]",
                r.measured.relmse_ci95[0], r.measured.relmse_ci95[1]
            ),
            format!(
                "{}/{}/{}",
                pct(r.measured.relative_bias[0]),
                pct(r.measured.relative_bias[1]),
                pct(r.measured.relative_bias[2])
            ),
            r.measured.time_ms,
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

    #[test]
    fn halton_interpolation() {
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
    }

    fn row(label: &str, relmse: f64, ratio: Option<f64>) -> TuneRow {
        TuneRow {
            measured: Measured {
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
            },
            equal_samples_ratio: 1.0,
            equal_time_halton_spp: None,
            equal_time_halton_relmse: None,
            equal_time_ratio: ratio,
        }
    }

    /// `tune.csv` quotes a label with a comma or a double quote (issue 67
    /// item 7): the row keeps its 13 fields and the label reads back as
    /// it was; other fields are written as before.
    #[test]
    fn a_label_with_a_comma_and_a_quote_keeps_its_row() {
        let label = r#"split="median, then mean" alpha=0.5"#;
        let text = csv(&[row("alpha=0", 1e-3, None), row(label, 2e-3, Some(0.5))]);
        let lines: Vec<&str> = text.lines().collect();
        assert_eq!(lines[0], CSV_HEADER);
        assert_eq!(lines[1], "1,alpha=0,0.001,0.001,0.001,0,0,0,0,0,1,1,");
        let mut reader = ::csv::Reader::from_reader(text.as_bytes());
        let header = reader.headers().unwrap().clone();
        assert_eq!(header.len(), 13);
        let rows: Vec<::csv::StringRecord> = reader.records().map(|r| r.unwrap()).collect();
        assert_eq!(rows.len(), 2);
        assert!(rows.iter().all(|r| r.len() == 13), "{text}");
        assert_eq!(&rows[0][1], "alpha=0");
        assert_eq!(&rows[1][1], label);
        assert_eq!(
            (&rows[1][0], &rows[1][2], &rows[1][12]),
            ("2", "0.002", "0.5")
        );
    }

    #[test]
    fn ranking_puts_rows_without_a_ratio_last() {
        let mut rows = vec![
            row("a", 1e-3, None),
            row("b", 3e-3, Some(0.9)),
            row("c", 2e-3, Some(0.5)),
        ];
        rank(&mut rows, false);
        let order: Vec<&str> = rows.iter().map(|r| r.measured.label.as_str()).collect();
        assert_eq!(order, ["c", "b", "a"]);
        rank(&mut rows, true);
        let order: Vec<&str> = rows.iter().map(|r| r.measured.label.as_str()).collect();
        assert_eq!(order, ["a", "c", "b"]);
        let t = mdas_table(&MdasParams::default());
        assert!(
            t.starts_with("[mdas]\n") && t.contains("epsilon = 0.01\n"),
            "{t}"
        );
    }
}
