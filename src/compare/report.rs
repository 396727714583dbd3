//! `report.json` of `mdas compare`: what was compared, how long each
//! method took per phase, its error against the reference, and the
//! equal-time RelMSE ratio MDAS/Halton (docs/conventions.md "Equal time", "RelMSE").
//!
//! Times are milliseconds, medians over the timed repeats after a warm-up
//! (`compare::equal_time::measure`); `time_ms.total` is the sum of the
//! phases. `relmse`/`mse` follow `metrics::compare`; `nonfinite` counts
//! non-finite samples and `nonfinite_pixels` non-finite pixels.

use super::equal_time::{HaltonRun, TimeFit};
use super::intervals::Interleaved;
pub use super::search_report::{BracketRun, SearchReport};
use super::seeds::SeedStats;
use crate::gpu::profiler::PhaseTimes;
use crate::provenance::Provenance;
use serde::Serialize;
use std::collections::BTreeMap;

/// The version of `report.json`'s layout ([`Report::schema_version`]):
/// raised when a field is removed, renamed or changes meaning (adding a
/// field does not raise it). docs/report-schema.md describes version 2
/// (2: pixel-adaptive Halton is the third entry of `methods`, before
/// `mdas-uniform`).
pub const REPORT_SCHEMA_VERSION: u32 = 2;

/// The whole report.
#[derive(Clone, Debug, Serialize)]
pub struct Report {
    /// [`REPORT_SCHEMA_VERSION`]: what a reader checks before it trusts
    /// the fields below.
    pub schema_version: u32,
    pub scene: String,
    pub scale: f32,
    /// The light sampler of the compared renders (`many_light` scenes:
    /// `--sampler` or the scene's own; absent for other integrands and in
    /// `compare --samplers`, whose method names carry it).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub sampler: Option<String>,
    /// The compared renders' shadow rays when they are not exact: voxel
    /// visibility and its parameters (the reference always uses the BVH
    /// unless `reference --visibility voxel` made it); absent for the BVH.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub visibility: Option<String>,
    pub film: FilmReport,
    pub seed: Seeds,
    pub adapter: String,
    pub backend: String,
    /// `"gpu timestamps"` or `"wall clock"`.
    pub clock: String,
    /// Crate version.
    pub version: String,
    pub repeats: u32,
    pub reference: ReferenceReport,
    /// MDAS first, then Halton (the bracketing run nearer to equal time),
    /// then pixel-adaptive Halton (`adaptive`, unless left out), then
    /// `mdas-uniform` (`--uniform`). `compare --samplers`: `mdas+tree`, then `halton+<sampler>` per
    /// listed sampler, in the order listed.
    pub methods: Vec<MethodReport>,
    pub equal_time: EqualTimeReport,
    pub maps: MapsReport,
    /// Every file written, relative to the output directory.
    pub files: BTreeMap<String, String>,
    /// What is needed to rerun it (`mdas compare`; absent for `--samplers`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub provenance: Option<Provenance>,
}

#[derive(Clone, Copy, Debug, Serialize)]
pub struct FilmReport {
    pub width: u32,
    pub height: u32,
}

/// Log ranges of the PNG colour maps (`compare::heatmap`).
#[derive(Clone, Copy, Debug, Serialize)]
pub struct MapsReport {
    pub colormap: &'static str,
    pub relmse_range: (f32, f32),
    /// Samples per pixel at the two ends of the density map (absent when
    /// none is written: `compare --samplers`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub density_range: Option<(f32, f32)>,
    /// The linear range of the FLIP maps (`mdas compare`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub flip_range: Option<(f32, f32)>,
}

#[derive(Clone, Copy, Debug, Serialize)]
pub struct Seeds {
    pub halton: u32,
    pub mdas: u32,
    pub reference: u32,
}

#[derive(Clone, Debug, Serialize)]
pub struct ReferenceReport {
    pub spp: u32,
    /// Its own RelMSE, estimated from Halton's at the equal-time bracket
    /// scaled by spp / ref_spp (the Monte Carlo rate; quasi-Monte Carlo
    /// converges faster, so this errs high).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub relmse_estimate: Option<f64>,
    /// Set when that estimate is not far below the compared methods'.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub flag: Option<String>,
    /// The cached reference EXR this comparison used (empty for an exact
    /// reference).
    pub path: String,
    pub cached: bool,
    /// Set for a reference that was not rendered by sampling (a library
    /// comparison against a closed form, `compare_integrand`): how it was
    /// made. `spp` is then 0 and no estimate of its error is made.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub exact: Option<String>,
    /// Its light sampler (`many_light` scenes): always the scene file's
    /// own, whatever `--sampler`/`--samplers` the compared renders use.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub sampler: Option<String>,
}

/// One method's measured run.
#[derive(Clone, Debug, Serialize)]
pub struct MethodReport {
    pub name: String,
    /// Samples per pixel asked for (MDAS: an average, may be fractional;
    /// adaptive: its budget, an average it may stop below).
    pub spp: f64,
    /// Samples per pixel spent, mean over `seeds` (adaptive only).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub spp_used: Option<f64>,
    /// Integrand evaluations performed.
    pub samples: u64,
    /// Median milliseconds per phase, and `total`.
    pub time_ms: BTreeMap<String, f64>,
    pub samples_per_s: f64,
    /// RelMSE and MSE: the mean over `seeds` when several were rendered,
    /// else the written image's own (= `image_relmse`, `image_mse`).
    pub relmse: f64,
    pub mse: f64,
    /// Mean absolute error (`metrics`), as `relmse`.
    pub mae: f64,
    /// The written image's own RelMSE, MSE and MAE (its seed is `seeds[0]`).
    pub image_relmse: f64,
    pub image_mse: f64,
    pub image_mae: f64,
    /// The written image's mean FLIP (`metrics::flip`, LDR on its PNG
    /// values; `mdas compare` only).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub image_flip: Option<f64>,
    /// The seeds rendered, the written image's first (`mdas compare`).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub seeds: Vec<u32>,
    /// Bias and noise over `seeds` (`compare::seeds`).
    #[serde(flatten, skip_serializing_if = "Option::is_none")]
    pub over_seeds: Option<SeedStats>,
    /// Non-finite samples.
    pub nonfinite: u64,
    pub nonfinite_pixels: u64,
    /// The image file (EXR) of this run, in the output directory.
    pub image: String,
}

impl MethodReport {
    pub fn new(name: &str, spp: f64, run: &HaltonRun, image: &str) -> MethodReport {
        let r = &run.measured.render;
        let total = run.measured.total_ms();
        MethodReport {
            name: name.to_string(),
            spp,
            spp_used: None,
            samples: r.samples,
            time_ms: time_map(&run.measured.times),
            samples_per_s: r.samples as f64 / (total / 1e3).max(1e-12),
            relmse: run.error.relmse,
            mse: run.error.mse,
            mae: run.error.mae,
            image_relmse: run.error.relmse,
            image_mse: run.error.mse,
            image_mae: run.error.mae,
            image_flip: None,
            seeds: Vec::new(),
            over_seeds: None,
            nonfinite: r.nonfinite,
            nonfinite_pixels: run.error.nonfinite_pixels,
            image: image.to_string(),
        }
    }

    pub fn total_ms(&self) -> f64 {
        self.time_ms["total"]
    }

    /// This method over several seeds: `relmse` and `mse` become the means.
    pub fn with_seeds(mut self, seeds: &[u32], s: &SeedStats) -> MethodReport {
        self.seeds = seeds.to_vec();
        self.relmse = s.relmse;
        self.mse = s.mse;
        self.mae = s.mae;
        self.over_seeds = Some(s.clone());
        self
    }

    /// The written image's mean FLIP.
    pub fn with_flip(mut self, flip: f64) -> MethodReport {
        self.image_flip = Some(flip);
        self
    }
}

/// Phases by name plus `total` (their sum).
pub fn time_map(times: &PhaseTimes) -> BTreeMap<String, f64> {
    let mut m: BTreeMap<String, f64> = times.0.iter().cloned().collect();
    m.insert("total".into(), times.total());
    m
}

/// The comparison at equal time.
#[derive(Clone, Debug, Serialize)]
pub struct EqualTimeReport {
    /// `"mdas"`: the target is MDAS's measured total at its spp;
    /// `"budget"`: `--time-ms` gave both methods the same target.
    pub mode: String,
    pub target_ms: f64,
    /// MDAS's RelMSE at the target time (its own in `"mdas"` mode, else
    /// interpolated like Halton's).
    pub mdas_relmse: f64,
    /// Halton's RelMSE interpolated at exactly the target time.
    pub halton_relmse: f64,
    /// `mdas_relmse / halton_relmse`: below 1 means MDAS wins.
    pub relmse_ratio: f64,
    pub halton: SearchReport,
    /// MDAS's budget search (`"budget"` mode only).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub mdas: Option<SearchReport>,
    /// `compare --samplers`: the Halton method that `halton`,
    /// `halton_relmse` and `relmse_ratio` are about (`halton+tree` when
    /// `tree` is listed, else the first listed sampler's).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub baseline: Option<String>,
    /// `compare --samplers`: every listed sampler under Halton at the
    /// target time, in the order listed.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub samplers: Option<Vec<SamplerReport>>,
    /// 95% interval of `relmse_ratio`: percentile bootstrap over both
    /// methods' seeds and (mode `"mdas"`) MDAS's timing rounds.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub relmse_ratio_ci95: Option<[f64; 2]>,
    /// Halton's time against spp, fitted to every run of its search.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub halton_fit: Option<TimeFit>,
    /// The (real) Halton spp the fit gives at the target; `halton_relmse`
    /// is the seed means at the whole spp either side, interpolated log–log
    /// in spp at it.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub halton_spp: Option<f64>,
    /// The interleaved timing rounds the target and the fit come from.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub interleaved: Option<Interleaved>,
    /// (max − min) / median of MDAS's round times (mode `"mdas"`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub target_spread: Option<f64>,
    /// What makes this measurement suspect (empty: nothing noticed).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub flags: Vec<String>,
    /// The same methods at equal samples per pixel.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub equal_samples: Option<EqualSamplesReport>,
    /// Pixel-adaptive Halton at the target time (`mdas compare`, unless
    /// left out): its search, its RelMSE and its ratios to Halton and MDAS.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub adaptive: Option<super::adaptive::AdaptiveTimeReport>,
}

/// MDAS against Halton at the same samples per pixel (Halton at MDAS's spp,
/// rounded to a whole number), over the same number of seeds.
#[derive(Clone, Debug, Serialize)]
pub struct EqualSamplesReport {
    pub spp: u32,
    pub mdas_relmse: f64,
    pub mdas_relmse_ci95: [f64; 2],
    pub halton_relmse: f64,
    pub halton_relmse_ci95: [f64; 2],
    /// `mdas_relmse / halton_relmse`, and its bootstrap interval.
    pub relmse_ratio: f64,
    pub relmse_ratio_ci95: [f64; 2],
    /// With `compare --uniform`: MDAS's RelMSE over MDAS-uniform's (α = 0,
    /// one candidate) at the same spp and seeds — what value-driven
    /// sampling buys over the grid and reconstruction alone — and its
    /// bootstrap interval.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub adaptivity_ratio: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub adaptivity_ratio_ci95: Option<[f64; 2]>,
    /// Pixel-adaptive Halton at the same budget (it may spend less).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub adaptive: Option<super::adaptive::AdaptiveReport>,
}

/// One light sampler under Halton at the equal-time target
/// (`compare --samplers`).
#[derive(Clone, Debug, Serialize)]
pub struct SamplerReport {
    /// The sampler's name (`SamplerKind`).
    pub sampler: String,
    /// Its entry in `methods`: `halton+<sampler>`.
    pub method: String,
    /// Light samples (shadow rays toward lights) per evaluation
    /// ([`crate::integrand::ManyLightSpec::light_samples_per_eval`]): light
    /// samples per pixel are this times the spp.
    pub light_samples_per_eval: f64,
    /// RelMSE at exactly the target time (= `search.relmse`: log–log
    /// interpolation between the bracketing runs).
    pub relmse: f64,
    /// MSE at exactly the target time (= `search.mse`, interpolated
    /// log–log like RelMSE).
    pub mse: f64,
    /// `mse` / the `uniform` sampler's `mse` (present when `uniform` is
    /// listed): below 1 means fewer squared errors than uniform light
    /// selection at equal time.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub mse_vs_uniform: Option<f64>,
    /// Halton's budget search with this sampler.
    pub search: SearchReport,
    /// With `--seeds K` (K ≥ 2): the same budgets over K seeds.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub seeds: Option<SamplerSeeds>,
}

/// A sampler at equal time over seeds (`compare --samplers --seeds K`):
/// Halton at the search's two bracketing budgets, each rendered with K
/// seeds (Halton's from `--seed` on, skipping the reference's; the
/// search's own run is the first), the per-seed means interpolated log–log
/// in time at the target as `search` interpolates one seed. Intervals are
/// 95 % percentile bootstraps over the seeds of every budget involved.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct SamplerSeeds {
    pub count: u32,
    pub relmse: f64,
    pub relmse_ci95: [f64; 2],
    pub mse: f64,
    pub mse_ci95: [f64; 2],
    /// `mse` / uniform's `mse` over the same seeds (when `uniform` is
    /// listed), and its interval: both samplers' budgets resampled, each
    /// on its own, which is conservative (the samplers share Halton's
    /// seeds, so their errors are correlated); exactly 1 for `uniform`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub mse_vs_uniform: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub mse_vs_uniform_ci95: Option<[f64; 2]>,
    /// The bracketing budget nearer the target (spp), at which the K seeds'
    /// images give the bias and the MSE split below.
    pub bias_spp: u32,
    /// Per channel: the mean image's sum over the reference's, minus 1, and
    /// its 95 % interval over the seeds ([`super::seeds::SeedStats`]). An
    /// unbiased sampler's interval holds 0, up to the reference's own
    /// noise; a biased one's (`sst`, `lgh`) need not.
    pub relative_bias: [f64; 3],
    pub relative_bias_ci95: [[f64; 2]; 3],
    /// The MSE at that budget, mean over seeds, split into the squared
    /// error of the mean image (bias², which still holds the mean's own
    /// variance/K and the reference's noise) and the variance over seeds.
    pub mse_bias2: f64,
    pub mse_variance: f64,
}

/// The table `mdas compare` prints.
pub fn table(report: &Report) -> String {
    let mut phases: Vec<&str> = Vec::new();
    for m in &report.methods {
        for k in m.time_ms.keys() {
            if k != "total" && !phases.contains(&k.as_str()) {
                phases.push(k);
            }
        }
    }
    let reference = match &report.reference.exact {
        Some(how) => format!("exact reference ({how})"),
        None => format!("reference {} spp", report.reference.spp),
    };
    let mut out = format!(
        "{} at {}×{} (scale {}), {reference}, {} on {} ({})\n",
        report.scene,
        report.film.width,
        report.film.height,
        report.scale,
        report.clock,
        report.adapter,
        report.backend
    );
    if let Some(v) = &report.visibility {
        out += &format!("shadow rays: {v} (the reference's: the BVH)\n");
    }
    let nw = report
        .methods
        .iter()
        .map(|m| m.name.chars().count())
        .max()
        .unwrap_or(0)
        .max(8);
    out += &format!("{:<nw$} {:>9} {:>11}", "method", "spp", "samples");
    for p in &phases {
        out += &format!(" {:>18}", format!("{p} ms"));
    }
    out += &format!(
        " {:>10} {:>11} {:>11} {:>11} {:>11} {:>7}\n",
        "total ms", "Msamples/s", "RelMSE", "MSE", "MAE", "FLIP"
    );
    for m in &report.methods {
        out += &format!("{:<nw$} {:>9.3} {:>11}", m.name, m.spp, m.samples);
        for p in &phases {
            match m.time_ms.get(*p) {
                Some(t) => out += &format!(" {t:>18.3}"),
                None => out += &format!(" {:>18}", "–"),
            }
        }
        out += &format!(
            " {:>10.3} {:>11.3} {:>11.4e} {:>11.4e} {:>11.4e} {:>7}\n",
            m.total_ms(),
            m.samples_per_s / 1e6,
            m.relmse,
            m.mse,
            m.mae,
            m.image_flip
                .map_or_else(|| "–".to_string(), |f| format!("{f:.4}"))
        );
    }
    let e = &report.equal_time;
    let h = &e.halton;
    let (mdas_name, halton_name) = match &e.baseline {
        Some(b) => ("mdas+tree", b.as_str()),
        None => ("MDAS", "Halton"),
    };
    out += &format!(
        "equal time {:.3} ms ({}): {halton_name}'s search brackets {} spp ({:.3} ms, RelMSE {:.4e}) and {} spp ({:.3} ms, RelMSE {:.4e}){}; {halton_name} RelMSE at the target {:.4e}\n",
        e.target_ms,
        e.mode,
        h.lo.spp,
        h.lo.time_ms,
        h.lo.relmse,
        h.hi.spp,
        h.hi.time_ms,
        h.hi.relmse,
        if h.target_ms == e.target_ms {
            String::new()
        } else {
            format!(" of {:.3} ms", h.target_ms)
        },
        e.halton_relmse
    );
    if let Some(m) = &e.mdas {
        out += &format!(
            "{mdas_name} brackets {} spp ({:.3} ms) and {} spp ({:.3} ms), interpolated RelMSE {:.4e}\n",
            m.lo.spp, m.lo.time_ms, m.hi.spp, m.hi.time_ms, m.relmse
        );
    }
    // Searches that could not reach the target: say so plainly.
    let unequal: Vec<(&str, &SearchReport)> = std::iter::once((halton_name, h))
        .chain(e.mdas.as_ref().map(|m| (mdas_name, m)))
        .chain(
            e.samplers
                .iter()
                .flatten()
                .map(|s| (s.method.as_str(), &s.search)),
        )
        .filter(|(_, s)| !s.bracketed)
        .collect();
    for (name, s) in &unequal {
        out += &format!(
            "NOT AT EQUAL TIME: {name}'s search did not reach {:.3} ms (its runs took {:.3} ms at {} spp to {:.3} ms at {} spp; raise --max-spp or lower --time-ms); its errors are those of its nearest run\n",
            s.target_ms, s.lo.time_ms, s.lo.spp, s.hi.time_ms, s.hi.spp
        );
    }
    if let Some(samplers) = &e.samplers {
        let sw = samplers
            .iter()
            .map(|s| s.method.chars().count())
            .max()
            .unwrap_or(0)
            .max(8);
        out += &format!(
            "{:<sw$} {:>11} {:>11} {:>11} {:>11}  {}\n",
            "at equal time",
            "RelMSE",
            "MSE",
            "MSE/uniform",
            "lights/eval",
            "Halton brackets: spp, light samples/px (ms)"
        );
        for s in samplers {
            let vs = s
                .mse_vs_uniform
                .map_or_else(|| "–".to_string(), |v| format!("{v:.4}"));
            let bracket = |r: &BracketRun| {
                format!(
                    "{}, {} ({:.3})",
                    r.spp,
                    (r.spp as f64 * s.light_samples_per_eval).round(),
                    r.time_ms
                )
            };
            let brackets = format!("{} – {}", bracket(&s.search.lo), bracket(&s.search.hi));
            out += &format!(
                "{:<sw$} {:>11.4e} {:>11.4e} {:>11} {:>11}  {}\n",
                s.method, s.relmse, s.mse, vs, s.light_samples_per_eval, brackets
            );
        }
        if let Some(k) = samplers
            .iter()
            .find_map(|s| s.seeds.as_ref().map(|o| o.count))
        {
            out += &format!(
                "{:<sw$} {:>25} {:>25} {:>25}\n",
                format!("over {k} seeds"),
                "RelMSE [95%]",
                "MSE [95%]",
                "MSE/uniform [95%]"
            );
            let ci = |v: f64, c: [f64; 2], e: bool| {
                if e {
                    format!("{v:.3e} [{:.2e}, {:.2e}]", c[0], c[1])
                } else {
                    format!("{v:.3} [{:.3}, {:.3}]", c[0], c[1])
                }
            };
            for s in samplers {
                if let Some(o) = &s.seeds {
                    let vs = match (o.mse_vs_uniform, o.mse_vs_uniform_ci95) {
                        (Some(v), Some(c)) => ci(v, c, false),
                        _ => "–".to_string(),
                    };
                    out += &format!(
                        "{:<sw$} {:>25} {:>25} {:>25}\n",
                        s.method,
                        ci(o.relmse, o.relmse_ci95, true),
                        ci(o.mse, o.mse_ci95, true),
                        vs
                    );
                }
            }
            out += &format!(
                "{:<sw$} {:>8}  {:<62} {:>9}\n",
                format!("bias over {k} seeds"),
                "at spp",
                "relative bias R / G / B [95%]",
                "bias²/MSE"
            );
            let pct = |v: f64, c: [f64; 2]| {
                format!(
                    "{:+.2}% [{:+.2}, {:+.2}]",
                    100.0 * v,
                    100.0 * c[0],
                    100.0 * c[1]
                )
            };
            for s in samplers {
                if let Some(o) = &s.seeds {
                    let b = (0..3)
                        .map(|c| pct(o.relative_bias[c], o.relative_bias_ci95[c]))
                        .collect::<Vec<_>>()
                        .join(" / ");
                    let total = o.mse_bias2 + o.mse_variance;
                    let share = if total > 0.0 {
                        format!("{:.1}%", 100.0 * o.mse_bias2 / total)
                    } else {
                        "–".to_string()
                    };
                    out += &format!(
                        "{:<sw$} {:>8}  {:<62} {:>9}\n",
                        s.method, o.bias_spp, b, share
                    );
                }
            }
        }
    }
    for m in &report.methods {
        if let Some(o) = &m.over_seeds {
            let b = o.relative_bias.map(|x| format!("{:+.2}%", 100.0 * x));
            out += &format!(
                "{} over {} seeds: RelMSE {:.4e} [{:.4e}, {:.4e}], bias R/G/B {}/{}/{}, MSE {:.4e} = bias² {:.4e} + variance {:.4e}\n",
                m.name,
                m.seeds.len(),
                m.relmse,
                o.relmse_ci95[0],
                o.relmse_ci95[1],
                b[0],
                b[1],
                b[2],
                m.mse,
                o.mse_bias2,
                o.mse_variance
            );
        }
    }
    if let Some(fit) = &e.halton_fit {
        out += &format!(
            "{halton_name} time fit {:.3} ms + {:.4} ms/spp over {} budgets (worst residual {:.1}%){}\n",
            fit.a,
            fit.b,
            fit.points.len(),
            100.0 * fit.max_residual,
            e.halton_spp
                .map_or_else(String::new, |s| format!(": {s:.2} spp at the target"))
        );
    }
    if let Some(spread) = e.target_spread {
        out += &format!(
            "{mdas_name} timed rounds spread {:.1}% of their median\n",
            100.0 * spread
        );
    }
    let interval = |ci: Option<[f64; 2]>| {
        ci.map_or_else(String::new, |[lo, hi]| format!(" [{lo:.4}, {hi:.4}]"))
    };
    out += &format!(
        "equal-time RelMSE ratio {mdas_name}/{halton_name}: {:.4}{} ({:+.1}%){}\n",
        e.relmse_ratio,
        interval(e.relmse_ratio_ci95),
        100.0 * (e.relmse_ratio - 1.0),
        if unequal.is_empty() {
            ""
        } else {
            " — NOT at equal time (see above)"
        }
    );
    if let Some(q) = &e.equal_samples {
        out += &format!(
            "equal-samples RelMSE ratio at {} spp: {:.4}{} ({mdas_name} {:.4e}, {halton_name} {:.4e})\n",
            q.spp,
            q.relmse_ratio,
            interval(Some(q.relmse_ratio_ci95)),
            q.mdas_relmse,
            q.halton_relmse
        );
        if let (Some(r), Some(ci)) = (q.adaptivity_ratio, q.adaptivity_ratio_ci95) {
            out += &format!(
                "what adaptivity buys: RelMSE MDAS/MDAS-uniform (α = 0, one candidate) at {} spp: {r:.4}{}\n",
                q.spp,
                interval(Some(ci))
            );
        }
    }
    if e.adaptive.is_some() {
        out += &super::adaptive::table_lines(
            e.adaptive.as_ref(),
            e.equal_samples
                .as_ref()
                .and_then(|q| q.adaptive.as_ref().map(|a| (q.spp, a))),
        );
    }
    for flag in e.flags.iter() {
        out += &format!("warning: {flag}\n");
    }
    out
}
