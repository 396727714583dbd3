//! Pixel-adaptive Halton (`crate::integrator::adaptive`, Blender Cycles'
//! rule) as the third method of `mdas compare` (issue 65, item 3): the
//! question a user brings is whether multidimensional adaptivity (MDAS)
//! beats simple pixel adaptivity.
//!
//! - **Parameters**: `mdas render --integrator adaptive`'s defaults
//!   ([`AdaptiveParams::new`], Cycles' own): noise threshold 0.01, min
//!   samples 64, a check every 16 samples (the first at 80), at most
//!   4096 samples a pixel. Its budget (`spp`) is an average over the
//!   film; a render stops earlier when every pixel has converged.
//! - **Seeds**: Halton's (`--seed` on, skipping the reference's), so no
//!   render reuses the reference's random shifts; below its first check
//!   its image at a seed is Halton's at that seed (bit for bit where the
//!   budget is a multiple of the samples per invocation, else up to the
//!   order of float sums).
//! - **Equal time** ([`search`]): its budget is searched so its time
//!   matches the comparison's target (MDAS's fastest round, or
//!   `--time-ms`), as Halton's and MDAS's are. Its time stops growing once
//!   every pixel has converged: a render that spends less than its budget
//!   renders the same image at every larger budget, so the search stops
//!   there, and when that time is still below the target its converged
//!   render is the one compared and the report says so
//!   ([`AdaptiveSearch::converged_spp`]). The budget compared is the
//!   bracketing run nearer the target; its RelMSE is the mean over the
//!   seeds at that budget.
//! - **Equal samples**: at MDAS's spp (rounded), the budget the other two
//!   get; it may spend less (`spp_used`).
//! - **Intervals**: adaptive/Halton at equal time as MDAS/Halton's
//!   ([`intervals::ratio_ci95`]: adaptive's seeds, Halton's two budgets'
//!   seeds and the target's rounds resampled); adaptive/Halton at equal
//!   samples and MDAS/adaptive: percentile bootstraps over both methods'
//!   seeds, each resampled on its own (conservative where the two share
//!   Halton's seeds).

use super::equal_time::{interpolate_log_log, measure, search_equal_time, EqualTime, HaltonRun};
use super::intervals;
use super::search_report::SearchReport;
use super::seeds::{bootstrap_ci95, mean, SeedStats};
use crate::gpu::Gpu;
use crate::integrand::Integrand;
use crate::integrator::adaptive::{AdaptiveHalton, AdaptiveParams};
use crate::integrator::Integrator;
use crate::metrics;
use anyhow::Result;
use indicatif::ProgressBar;
use serde::Serialize;

/// Its name in the report's `methods` and its files (`adaptive.exr`, …).
pub const NAME: &str = "adaptive";

/// The parameters `compare` renders it with: `render`'s defaults.
pub fn params(spp: f64, seed: u32) -> AdaptiveParams {
    AdaptiveParams::new(spp, seed)
}

/// Its budget search at a target time.
pub struct AdaptiveSearch {
    pub eq: EqualTime,
    /// The smallest budget searched whose render spent less than the
    /// budget (every pixel converged or at its cap): every larger budget
    /// renders the same image, and runs at larger budgets were not
    /// rendered again.
    pub converged_spp: Option<u32>,
}

/// Searches adaptive's budget (from 1 spp to `max_spp`) whose time is
/// `target_ms` ([`search_equal_time`]), with its plateau (module docs).
#[allow(clippy::too_many_arguments)]
pub fn search(
    gpu: &Gpu,
    adaptive: &mut AdaptiveHalton,
    integrand: &dyn Integrand,
    reference: &[[f32; 3]],
    target_ms: f64,
    repeats: u32,
    max_spp: u32,
    progress: &ProgressBar,
) -> Result<AdaptiveSearch> {
    let film = integrand.film();
    let pixels = film.width as u64 * film.height as u64;
    search_plateau(target_ms, max_spp, &mut |spp| {
        progress.set_message(format!("{NAME} {spp} spp ({repeats} repeats)"));
        adaptive.set_spp(f64::from(spp))?;
        let measured = measure(gpu, adaptive, integrand, repeats)?;
        let error = metrics::compare(&measured.render.image, reference)?;
        let stopped = measured.render.samples < adaptive.params.budget(pixels);
        let run = HaltonRun {
            spp,
            measured,
            error,
        };
        Ok((run, stopped))
    })
}

/// The search of [`search`] over `run(spp)`, which measures a budget and
/// says whether the render spent less than it (then every larger budget
/// renders the same image: it is not run again, and the search sees its
/// time as flat).
pub fn search_plateau(
    target_ms: f64,
    max_spp: u32,
    run: &mut dyn FnMut(u32) -> Result<(HaltonRun, bool)>,
) -> Result<AdaptiveSearch> {
    let mut converged: Option<HaltonRun> = None;
    let mut eq = search_equal_time(target_ms, 1, max_spp, &mut |spp| {
        if let Some(c) = converged.as_ref().filter(|c| spp >= c.spp) {
            return Ok(HaltonRun { spp, ..c.clone() });
        }
        let (r, stopped) = run(spp)?;
        if stopped {
            converged = Some(r.clone());
        }
        Ok(r)
    })?;
    // Runs beyond the plateau were the converged run under another label.
    if let Some(c) = &converged {
        for r in [&mut eq.lo, &mut eq.hi] {
            if r.spp > c.spp {
                *r = c.clone();
            }
        }
        eq.relmse = interpolate_log_log(
            target_ms,
            (eq.lo.measured.total_ms(), eq.lo.error.relmse),
            (eq.hi.measured.total_ms(), eq.hi.error.relmse),
        );
    }
    Ok(AdaptiveSearch {
        eq,
        converged_spp: converged.map(|c| c.spp),
    })
}

/// Adaptive at one budget over seeds.
#[derive(Clone, Debug)]
pub struct AdaptiveAt {
    /// The budget (average samples per pixel it may spend).
    pub spp: u32,
    pub stats: SeedStats,
    /// Samples per pixel it spent, mean over the seeds.
    pub spp_used: f64,
}

/// `adaptive` at `spp` over `seeds`; `first`, when given, is the image
/// and sample count of `seeds[0]` already rendered.
#[allow(clippy::too_many_arguments)]
pub fn over_seeds(
    gpu: &Gpu,
    adaptive: &mut AdaptiveHalton,
    spp: u32,
    first: Option<(&[[f32; 3]], u64)>,
    seeds: &[u32],
    integrand: &dyn Integrand,
    reference: &[[f32; 3]],
    progress: &ProgressBar,
) -> Result<AdaptiveAt> {
    let film = integrand.film();
    let pixels = film.width as f64 * film.height as f64;
    let mut images: Vec<Vec<[f32; 3]>> = Vec::new();
    let mut samples: Vec<u64> = Vec::new();
    if let Some((image, n)) = first {
        images.push(image.to_vec());
        samples.push(n);
    }
    adaptive.set_spp(f64::from(spp))?;
    for &s in &seeds[images.len()..] {
        adaptive.set_seed(s);
        let r = adaptive.render(gpu, integrand)?;
        images.push(r.image);
        samples.push(r.samples);
        progress.inc(1);
    }
    let views: Vec<&[[f32; 3]]> = images.iter().map(|v| v.as_slice()).collect();
    Ok(AdaptiveAt {
        spp,
        stats: SeedStats::new(&views, reference)?,
        spp_used: samples.iter().sum::<u64>() as f64 / samples.len() as f64 / pixels,
    })
}

/// Bootstrap interval of mean(a) / mean(b) over two methods' seeds, each
/// resampled on its own.
pub fn ratio_ci95(a: &SeedStats, b: &SeedStats) -> [f64; 2] {
    bootstrap_ci95(&[&a.relmse_per_seed, &b.relmse_per_seed], |r| {
        mean(&r[0]) / mean(&r[1])
    })
}

/// Bootstrap interval of mean(a) / mean(b) where seed i of both methods is
/// the same seed (adaptive and Halton at equal samples): the seeds are
/// resampled together, so two methods that render the same images at
/// every seed get exactly [1, 1]. Seed lists of different lengths fall
/// back to [`ratio_ci95`].
pub fn paired_ratio_ci95(a: &SeedStats, b: &SeedStats) -> [f64; 2] {
    let (x, y) = (&a.relmse_per_seed, &b.relmse_per_seed);
    if x.len() != y.len() {
        return ratio_ci95(a, b);
    }
    let index: Vec<f64> = (0..x.len()).map(|i| i as f64).collect();
    bootstrap_ci95(&[&index], |r| {
        let pick = |v: &[f64]| mean(&r[0].iter().map(|&i| v[i as usize]).collect::<Vec<_>>());
        pick(x) / pick(y)
    })
}

/// Adaptive against Halton and MDAS at one budget (`report.json`:
/// `equal_time.adaptive`, `equal_time.equal_samples.adaptive`).
#[derive(Clone, Debug, Serialize)]
pub struct AdaptiveReport {
    /// The budget: average samples per pixel it may spend.
    pub spp: u32,
    /// Samples per pixel it spent, mean over the seeds.
    pub spp_used: f64,
    /// Mean RelMSE over the seeds, and its 95% interval (Student t).
    pub relmse: f64,
    pub relmse_ci95: [f64; 2],
    /// Adaptive's RelMSE over Halton's (below 1: pixel adaptivity wins),
    /// and its 95% bootstrap interval.
    pub adaptive_over_halton: f64,
    pub adaptive_over_halton_ci95: [f64; 2],
    /// MDAS's RelMSE over adaptive's (below 1: MDAS wins), and its 95%
    /// bootstrap interval.
    pub mdas_over_adaptive: f64,
    pub mdas_over_adaptive_ci95: [f64; 2],
    /// What a reader should know of this run (a budget below the first
    /// check, a render that converged before the target time).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub notes: Vec<String>,
}

/// The parameters it ran with (`equal_time.adaptive.params`).
#[derive(Clone, Copy, Debug, Serialize)]
pub struct ParamsReport {
    pub threshold: f32,
    pub min_spp: u32,
    pub step: u32,
    /// The sample count of the first check: below it no pixel adapts.
    pub first_check: u32,
    pub spp_max: u32,
}

impl From<&AdaptiveParams> for ParamsReport {
    fn from(p: &AdaptiveParams) -> Self {
        ParamsReport {
            threshold: p.threshold,
            min_spp: p.min_spp,
            step: p.step,
            first_check: p.first_check(),
            spp_max: p.spp_max,
        }
    }
}

/// Adaptive at equal time: its search and the comparison at the budget
/// compared.
#[derive(Clone, Debug, Serialize)]
pub struct AdaptiveTimeReport {
    #[serde(flatten)]
    pub at: AdaptiveReport,
    /// The compared run's time (the bracketing run nearer the target).
    pub time_ms: f64,
    /// Its budget search at the target time.
    pub search: SearchReport,
    /// The smallest budget searched at which it spent less than its
    /// budget (every pixel converged); absent when none did.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub converged_spp: Option<u32>,
    pub params: ParamsReport,
}

/// The notes of adaptive at `at` with `params`: below the first check no
/// pixel adapts.
pub fn notes(at: &AdaptiveAt, params: &AdaptiveParams) -> Vec<String> {
    let first = params.first_check();
    if at.spp < first {
        vec![format!(
            "its budget ({} spp) is below its first check ({first} samples a pixel: min samples {} then a check every {}): no pixel adapted, its images are Halton's at its seeds (up to the order of float sums)",
            at.spp, params.min_spp, params.step
        )]
    } else {
        Vec::new()
    }
}

/// The console lines of the third method.
pub fn table_lines(
    time: Option<&AdaptiveTimeReport>,
    samples: Option<(u32, &AdaptiveReport)>,
) -> String {
    let ci = |[lo, hi]: [f64; 2]| format!("[{lo:.4}, {hi:.4}]");
    let mut out = String::new();
    let line = |what: &str, a: &AdaptiveReport| {
        format!(
            "{what}: adaptive {} spp (spent {:.2}) RelMSE {:.4e} [{:.4e}, {:.4e}]; adaptive/Halton {:.4} {}; MDAS/adaptive {:.4} {}\n",
            a.spp,
            a.spp_used,
            a.relmse,
            a.relmse_ci95[0],
            a.relmse_ci95[1],
            a.adaptive_over_halton,
            ci(a.adaptive_over_halton_ci95),
            a.mdas_over_adaptive,
            ci(a.mdas_over_adaptive_ci95),
        )
    };
    if let Some(t) = time {
        let p = &t.params;
        out += &format!(
            "pixel-adaptive Halton (Cycles' rule: threshold {}, min {} spp, a check every {}, at most {} a pixel); searched {} spp ({:.3} ms) and {} spp ({:.3} ms)\n",
            p.threshold,
            p.min_spp,
            p.step,
            p.spp_max,
            t.search.lo.spp,
            t.search.lo.time_ms,
            t.search.hi.spp,
            t.search.hi.time_ms
        );
        out += &line(
            &format!(
                "equal time {:.3} ms (its run {:.3} ms)",
                t.search.target_ms, t.time_ms
            ),
            &t.at,
        );
        if t.converged_spp.is_some() && !t.search.bracketed {
            out += &format!(
                "adaptive CONVERGED before the target time ({:.3} ms, see the note); its errors are those of its converged render\n",
                t.time_ms
            );
        } else if !t.search.bracketed {
            out += &format!(
                "NOT AT EQUAL TIME: adaptive's search did not reach {:.3} ms (its runs took {:.3} ms at {} spp to {:.3} ms at {} spp); its errors are those of its nearest run\n",
                t.search.target_ms, t.search.lo.time_ms, t.search.lo.spp, t.search.hi.time_ms, t.search.hi.spp
            );
        }
        for n in &t.at.notes {
            out += &format!("note: adaptive at equal time: {n}\n");
        }
    }
    if let Some((spp, a)) = samples {
        out += &line(&format!("equal samples at {spp} spp"), a);
        for n in &a.notes {
            out += &format!("note: adaptive at equal samples: {n}\n");
        }
    }
    out
}

/// What the third method's step of `compare` needs from the others.
pub(crate) struct Inputs<'a> {
    pub integrand: &'a dyn Integrand,
    pub reference: &'a [[f32; 3]],
    pub seeds: &'a [u32],
    pub repeats: u32,
    pub max_spp: u32,
    pub target_ms: f64,
    pub target_times: &'a [f64],
    pub halton_fit: Option<&'a super::equal_time::TimeFit>,
    /// Halton's (real) spp at the target and its seed statistics at the
    /// whole budgets either side of it.
    pub halton_spp: f64,
    pub halton_n0: &'a SeedStats,
    pub halton_n1: &'a SeedStats,
    /// Halton's RelMSE interpolated at the target.
    pub halton_relmse: f64,
    pub mdas: &'a SeedStats,
    /// Equal samples: the budget and Halton there.
    pub equal_spp: u32,
    pub halton_equal: &'a SeedStats,
}

/// The third method's results in `compare`.
pub(crate) struct Third {
    /// The written run (first seed, the budget compared at equal time).
    pub run: HaltonRun,
    pub stats: SeedStats,
    /// Its samples per pixel in that run.
    pub counts: Vec<f32>,
    pub time: AdaptiveTimeReport,
    pub samples: AdaptiveReport,
}

/// Runs the third method's step (module docs): search at the target,
/// seeds at the budget compared and at equal samples, the written run's
/// sample counts.
pub(crate) fn run(gpu: &Gpu, i: &Inputs, progress: &ProgressBar) -> Result<Third> {
    let mut adaptive = AdaptiveHalton::new(params(1.0, i.seeds[0]))?;
    let p = adaptive.params;
    let found = search(
        gpu,
        &mut adaptive,
        i.integrand,
        i.reference,
        i.target_ms,
        i.repeats,
        i.max_spp,
        progress,
    )?;
    let run = super::timing::nearer(&found.eq).clone();
    let k = i.seeds.len() as u64;
    progress.inc_length(2 * k);
    progress.set_message(format!("{NAME} seeds"));
    adaptive.set_seed(i.seeds[0]);
    let at_time = over_seeds(
        gpu,
        &mut adaptive,
        run.spp,
        Some((&run.measured.render.image, run.measured.render.samples)),
        i.seeds,
        i.integrand,
        i.reference,
        progress,
    )?;
    // The written run again, for its sample counts (deterministic: the
    // same image).
    adaptive.set_seed(i.seeds[0]);
    adaptive.set_spp(f64::from(run.spp))?;
    adaptive.render(gpu, i.integrand)?;
    let counts: Vec<f32> = adaptive.sample_counts().iter().map(|&c| c as f32).collect();
    progress.inc(1);
    let at_samples = over_seeds(
        gpu,
        &mut adaptive,
        i.equal_spp,
        None,
        i.seeds,
        i.integrand,
        i.reference,
        progress,
    )?;
    let time_ratio_ci95 = intervals::ratio_ci95(
        i.halton_fit,
        i.halton_spp,
        i.target_times,
        &at_time.stats,
        i.halton_n0,
        i.halton_n1,
    );
    let report = |at: &AdaptiveAt, halton: f64, halton_ci95: [f64; 2]| AdaptiveReport {
        spp: at.spp,
        spp_used: at.spp_used,
        relmse: at.stats.relmse,
        relmse_ci95: at.stats.relmse_ci95,
        adaptive_over_halton: at.stats.relmse / halton,
        adaptive_over_halton_ci95: halton_ci95,
        mdas_over_adaptive: i.mdas.relmse / at.stats.relmse,
        mdas_over_adaptive_ci95: ratio_ci95(i.mdas, &at.stats),
        notes: notes(at, &p),
    };
    let mut at = report(&at_time, i.halton_relmse, time_ratio_ci95);
    let search = SearchReport::new(&found.eq);
    if let Some(c) = found.converged_spp.filter(|_| !search.bracketed) {
        let film = i.integrand.film();
        at.notes.push(format!(
            "it converged (every pixel met its threshold or its cap) spending {:.2} spp of a budget of {c} spp in {:.3} ms, before the target {:.3} ms: its converged render is compared",
            run.measured.render.samples as f64 / (film.width as f64 * film.height as f64),
            run.measured.total_ms(),
            i.target_ms
        ));
    }
    let time = AdaptiveTimeReport {
        at,
        time_ms: run.measured.total_ms(),
        search,
        converged_spp: found.converged_spp,
        params: (&p).into(),
    };
    let samples = report(
        &at_samples,
        i.halton_equal.relmse,
        paired_ratio_ci95(&at_samples.stats, i.halton_equal),
    );
    Ok(Third {
        run,
        stats: at_time.stats,
        counts,
        time,
        samples,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A run at `spp` that took `ms` with RelMSE 1/spp.
    fn run_at(spp: u32, ms: f64) -> HaltonRun {
        HaltonRun::for_test(spp, ms, 1.0 / spp as f64)
    }

    /// A method whose every pixel converges after 100 samples: 1 ms per
    /// spp up to 100 spp, then flat (a budget above 100 is not spent).
    fn plateau(rendered: &mut Vec<u32>) -> impl FnMut(u32) -> Result<(HaltonRun, bool)> + '_ {
        move |spp| {
            rendered.push(spp);
            let used = spp.min(100);
            let mut r = run_at(spp, f64::from(used));
            r.measured.render.samples = used as u64;
            r.error.relmse = 1.0 / f64::from(used);
            Ok((r, spp > 100))
        }
    }

    /// Below the plateau the search brackets the target as Halton's does;
    /// beyond it the search stops rendering at the first budget that was
    /// not spent, reports that budget's run for both ends, and marks the
    /// target as not reached.
    #[test]
    fn the_search_stops_at_the_plateau() {
        let mut rendered = Vec::new();
        let s = search_plateau(40.5, 4096, &mut plateau(&mut rendered)).unwrap();
        assert_eq!((s.eq.lo.spp, s.eq.hi.spp), (40, 41));
        assert_eq!(s.converged_spp, None);
        let mut rendered = Vec::new();
        let s = search_plateau(1000.0, 4096, &mut plateau(&mut rendered)).unwrap();
        let c = s.converged_spp.expect("the plateau was found");
        assert!(c > 100, "{c}");
        assert_eq!((s.eq.lo.spp, s.eq.hi.spp), (c, c));
        assert_eq!(s.eq.lo.measured.render.samples, 100);
        assert_eq!(s.eq.relmse, 0.01);
        // Nothing at or above the converged budget was rendered again.
        assert_eq!(
            rendered.iter().filter(|&&r| r >= c).count(),
            1,
            "{rendered:?}"
        );
        assert!(rendered.len() <= 4, "{rendered:?}");
    }

    fn stats_of(per_seed: &[f64]) -> SeedStats {
        SeedStats::with_relmse(per_seed)
    }

    /// The same images at every seed: the paired interval is the point 1,
    /// the unpaired one is not; a constant factor is the paired point.
    #[test]
    fn paired_ratios_of_the_same_seeds() {
        let a = stats_of(&[1.0, 2.0, 4.0, 8.0]);
        assert_eq!(paired_ratio_ci95(&a, &a), [1.0, 1.0]);
        let [lo, hi] = ratio_ci95(&a, &a);
        assert!(lo < 0.9 && hi > 1.1, "{lo} {hi}");
        let half = stats_of(&[0.5, 1.0, 2.0, 4.0]);
        assert_eq!(paired_ratio_ci95(&half, &a), [0.5, 0.5]);
        let short = stats_of(&[1.0, 2.0]);
        assert_eq!(paired_ratio_ci95(&short, &a), ratio_ci95(&short, &a));
    }

    /// Below the first check (80 samples with Cycles' defaults) the note
    /// says no pixel adapted; at it, nothing is said.
    #[test]
    fn notes_below_the_first_check() {
        let p = params(8.0, 0);
        let at = |spp| AdaptiveAt {
            spp,
            stats: stats_of(&[1.0]),
            spp_used: f64::from(spp),
        };
        let n = notes(&at(79), &p);
        assert_eq!(n.len(), 1);
        assert!(n[0].contains("below its first check (80 samples"), "{n:?}");
        assert!(notes(&at(80), &p).is_empty());
    }
}
