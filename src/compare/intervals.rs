//! Seeds and intervals for `mdas compare` (issue "comparisons a researcher
//! can trust"): each method is rendered with K seeds, and the equal-time
//! estimate rests on a time model of every Halton run instead of one
//! bracket.
//!
//! - MDAS: the timed run (its seed first) and K − 1 untimed renders with
//!   the next seeds, same budget.
//! - Timing ([`interleaved`]): after the budget search has found the
//!   neighbourhood ([`super::search_equal_time`]), MDAS (when its time is
//!   the target) and Halton at five budgets around the bracket (×½ … ×2)
//!   are timed in interleaved rounds, each round one render of each, so a
//!   slow spell of the machine hits every budget alike. The target is
//!   MDAS's fastest round; Halton's time is fitted as a + b·spp to each
//!   budget's fastest round ([`TimeFit`], Theil–Sen), and the spp at the
//!   target is read off the fit. (Noise only adds time; the minima are
//!   what three identical runs agree on.)
//! - Halton's RelMSE at that spp: the seed means at the whole spp on
//!   either side, interpolated log–log in spp ([`halton_at_target`]).
//! - The ratio's 95% interval is a percentile bootstrap over MDAS's seeds,
//!   the two Halton budgets' seeds and MDAS's round times, with the fit
//!   held fixed (a resampled target moves the spp only between the two
//!   whole budgets, so timing noise beyond them is not propagated).
//! - Equal samples: Halton at MDAS's spp (rounded), over K seeds.
//!
//! Halton seeds skip the reference's seed, so no compared render shares
//! the reference's random shifts.

use super::equal_time::{interpolate_log_log, median, EqualTime, TimeFit};
use super::seeds::{bootstrap_ci95, mean, SeedStats};
use crate::gpu::Gpu;
use crate::integrand::Integrand;
use crate::integrator::{Halton, Integrator, Mdas};
use anyhow::{bail, Result};
use indicatif::ProgressBar;

/// Most seeds `--seeds` accepts.
pub const MAX_SEEDS: u32 = 64;

/// The seeds of each method: `k` consecutive ones from each method's
/// base seed, Halton's skipping `ref_seed`.
pub fn seed_plan(
    k: u32,
    mdas_seed: u32,
    halton_seed: u32,
    ref_seed: u32,
) -> Result<(Vec<u32>, Vec<u32>)> {
    if !(1..=MAX_SEEDS).contains(&k) {
        bail!("--seeds must be in 1..={MAX_SEEDS}, got {k}");
    }
    let mdas = (0..k).map(|i| mdas_seed.wrapping_add(i)).collect();
    let halton = (0u32..)
        .map(|i| halton_seed.wrapping_add(i))
        .filter(|&s| s != ref_seed)
        .take(k as usize)
        .collect();
    Ok((mdas, halton))
}

/// `mdas` (at its budget) over `seeds`; `first` is the image already
/// rendered with `seeds[0]`.
pub fn mdas_over_seeds(
    gpu: &Gpu,
    mdas: &mut Mdas,
    first: &[[f32; 3]],
    seeds: &[u32],
    integrand: &dyn Integrand,
    reference: &[[f32; 3]],
    progress: &ProgressBar,
) -> Result<SeedStats> {
    let mut images = vec![first.to_vec()];
    for &s in &seeds[1..] {
        mdas.set_seed(s);
        images.push(mdas.render(gpu, integrand)?.image);
        progress.inc(1);
    }
    stats(&images, reference)
}

/// Halton at `spp` over `seeds` (one `halton` for every call, so its
/// pipelines compile once); `first`, when given, is the image of
/// `seeds[0]` already rendered.
#[allow(clippy::too_many_arguments)]
pub fn halton_over_seeds(
    gpu: &Gpu,
    halton: &mut Halton,
    spp: u32,
    first: Option<&[[f32; 3]]>,
    seeds: &[u32],
    integrand: &dyn Integrand,
    reference: &[[f32; 3]],
    progress: &ProgressBar,
) -> Result<SeedStats> {
    let mut images: Vec<Vec<[f32; 3]>> = first.map(|f| vec![f.to_vec()]).unwrap_or_default();
    halton.spp = spp;
    for &s in &seeds[images.len()..] {
        halton.seed = s;
        images.push(halton.render(gpu, integrand)?.image);
        progress.inc(1);
    }
    stats(&images, reference)
}

fn stats(images: &[Vec<[f32; 3]>], reference: &[[f32; 3]]) -> Result<SeedStats> {
    let views: Vec<&[[f32; 3]]> = images.iter().map(|v| v.as_slice()).collect();
    SeedStats::new(&views, reference)
}

/// MDAS-uniform: `params` with α = 0 and one candidate (every leaf is
/// selected every iteration and its new sample is uniform in it: MDAS's
/// grid, splits and reconstruction without value-driven sampling), timed
/// as [`super::measure`] with `seeds[0]`, then over `seeds`: the run (as
/// a Halton run is reported) and its statistics.
#[allow(clippy::too_many_arguments)]
pub fn uniform_over_seeds(
    gpu: &Gpu,
    params: crate::integrator::mdas::MdasParams,
    seeds: &[u32],
    repeats: u32,
    integrand: &dyn Integrand,
    reference: &[[f32; 3]],
    progress: &ProgressBar,
) -> Result<(super::HaltonRun, SeedStats)> {
    let mut mdas = Mdas::new(crate::integrator::mdas::MdasParams {
        alpha: 0.0,
        candidates: 1,
        seed: seeds[0],
        ..params
    })?;
    let measured = super::measure(gpu, &mut mdas, integrand, repeats)?;
    progress.inc(1);
    let error = crate::metrics::compare(&measured.render.image, reference)?;
    let first = measured.render.image.clone();
    let stats = mdas_over_seeds(
        gpu, &mut mdas, &first, seeds, integrand, reference, progress,
    )?;
    let run = super::HaltonRun {
        spp: params.spp.round() as u32,
        measured,
        error,
    };
    Ok((run, stats))
}

/// Timed rounds of the interleaved measurement.
pub const MIN_ROUNDS: u32 = 9;

/// The interleaved timing of [`interleaved`].
#[derive(Clone, Debug, serde::Serialize)]
pub struct Interleaved {
    /// MDAS's total per round (empty when the target is a fixed budget).
    pub mdas_ms: Vec<f64>,
    /// Halton's budgets and their totals per round.
    pub halton: Vec<(u32, Vec<f64>)>,
}

/// Budgets around `center`: ×½, ×1/√2, ×1, ×√2, ×2, whole, in 1..=max_spp.
pub fn budgets_around(center: u32, max_spp: u32) -> Vec<u32> {
    let mut b: Vec<u32> = [
        0.5,
        std::f64::consts::FRAC_1_SQRT_2,
        1.0,
        std::f64::consts::SQRT_2,
        2.0,
    ]
    .iter()
    .map(|f| ((center as f64 * f).round() as u32).clamp(1, max_spp.max(1)))
    .collect();
    b.dedup();
    b
}

/// The fastest of `v`: timing noise on a busy or shared machine only adds
/// time, so the minimum over interleaved rounds estimates the undisturbed
/// cost better than the median (on lavapipe, round times of one budget
/// spread 20–50% while the minima are reproducible).
fn fastest(v: &[f64]) -> f64 {
    v.iter().copied().fold(f64::INFINITY, f64::min)
}

/// (max − min) / median; 0 when there is nothing to spread (no rounds, or a
/// median that is not positive). One round spreads 0 by the arithmetic.
fn spread(v: &[f64]) -> f64 {
    let m = median(v);
    let (lo, hi) = v
        .iter()
        .fold((f64::INFINITY, 0.0f64), |(a, b), &x| (a.min(x), b.max(x)));
    if m.is_nan() || m <= 0.0 {
        0.0
    } else {
        (hi - lo) / m
    }
}

/// Times `mdas` (when given) and `halton` at each of `budgets` in `rounds`
/// interleaved rounds, after one untimed render of each (module docs);
/// `progress` advances by one per timed render.
pub fn interleaved(
    gpu: &Gpu,
    mut mdas: Option<&mut Mdas>,
    halton: &mut Halton,
    budgets: &[u32],
    rounds: u32,
    integrand: &dyn Integrand,
    progress: &ProgressBar,
) -> Result<Interleaved> {
    halton.spp = budgets[0];
    if let Some(m) = mdas.as_deref_mut() {
        m.render(gpu, integrand)?;
    }
    halton.render(gpu, integrand)?;
    let mut out = Interleaved {
        mdas_ms: Vec::new(),
        halton: budgets.iter().map(|&b| (b, Vec::new())).collect(),
    };
    for _ in 0..rounds {
        if let Some(m) = mdas.as_deref_mut() {
            out.mdas_ms.push(m.render(gpu, integrand)?.times.total());
            progress.inc(1);
        }
        for (spp, times) in &mut out.halton {
            halton.spp = *spp;
            times.push(halton.render(gpu, integrand)?.times.total());
            progress.inc(1);
        }
    }
    Ok(out)
}

impl Interleaved {
    /// MDAS's fastest round.
    pub fn mdas_fastest(&self) -> f64 {
        fastest(&self.mdas_ms)
    }

    /// MDAS's spread over the rounds.
    pub fn mdas_spread(&self) -> f64 {
        spread(&self.mdas_ms)
    }

    /// Halton's time fit over the budgets' fastest rounds (each with its
    /// rounds' spread, for the flags).
    pub fn fit(&self) -> Option<TimeFit> {
        let runs: Vec<(u32, f64, f64)> = self
            .halton
            .iter()
            .map(|(s, t)| (*s, fastest(t), spread(t)))
            .collect();
        TimeFit::new(&runs)
    }
}

/// The spp at `target_ms` from the fit (else linear in time between the
/// search's bracketing runs), at least 1, with a flag when it lies outside
/// the timed budgets (an extrapolation).
pub fn spp_at_target(
    eq: &EqualTime,
    fit: Option<&TimeFit>,
    target_ms: f64,
    flags: &mut Vec<String>,
) -> f64 {
    let (lo, hi) = (eq.lo.spp as f64, eq.hi.spp as f64);
    let (lo_t, hi_t) = (eq.lo.measured.total_ms(), eq.hi.measured.total_ms());
    let spp = match fit.and_then(|f| f.spp_at(target_ms).map(|s| (f, s))) {
        Some((f, s)) => {
            let (min, max) = (f.points[0].0 as f64, f.points[f.points.len() - 1].0 as f64);
            if s < min || s > max {
                flags.push(format!(
                    "the time fit puts {target_ms:.3} ms at {s:.1} spp, outside the timed budgets {min}–{max}"
                ));
            }
            s
        }
        None if hi_t > lo_t => lo + (hi - lo) * (target_ms - lo_t) / (hi_t - lo_t),
        None => lo,
    };
    spp.max(1.0)
}

/// Halton's RelMSE at a real `spp`, from the seed statistics at the whole
/// budgets `n0 = ⌊spp⌋` and `n0 + 1`, interpolated log–log in spp.
pub fn halton_at_target(spp: f64, n0: &SeedStats, n1: &SeedStats) -> f64 {
    let s0 = spp.floor().max(1.0);
    interpolate_log_log(spp, (s0, n0.relmse), (s0 + 1.0, n1.relmse))
}

/// 95% bootstrap interval of MDAS's RelMSE over Halton's at the target:
/// resamples MDAS's per-seed RelMSEs, the two Halton budgets', and
/// `target_ms` (MDAS's round times, whose fastest is the target, or the one
/// fixed budget), the fit and the target's spp bracket [n0, n0 + 1] held
/// fixed.
pub fn ratio_ci95(
    fit: Option<&TimeFit>,
    spp: f64,
    target_ms: &[f64],
    mdas: &SeedStats,
    n0: &SeedStats,
    n1: &SeedStats,
) -> [f64; 2] {
    let s0 = spp.floor().max(1.0);
    let groups: [&[f64]; 4] = [
        &mdas.relmse_per_seed,
        &n0.relmse_per_seed,
        &n1.relmse_per_seed,
        target_ms,
    ];
    bootstrap_ci95(&groups, |r| {
        let s = fit
            .and_then(|f| f.spp_at(fastest(&r[3])))
            .unwrap_or(spp)
            .clamp(s0, s0 + 1.0);
        mean(&r[0]) / interpolate_log_log(s, (s0, mean(&r[1])), (s0 + 1.0, mean(&r[2])))
    })
}

/// The reference's RelMSE estimated from Halton's at `spp` (scaled as
/// 1/spp), and a flag when it is not at least ten times below `smallest`,
/// the smaller of the compared methods' RelMSEs.
pub fn reference_check(
    halton: &SeedStats,
    spp: u32,
    ref_spp: u32,
    smallest: f64,
) -> (f64, Option<String>) {
    let estimate = halton.relmse * spp as f64 / ref_spp.max(1) as f64;
    let flag = (estimate > 0.1 * smallest).then(|| {
        format!(
            "the reference's own RelMSE (≈ {estimate:.2e}, Halton's at {spp} spp scaled by {spp}/{ref_spp}) is not far below the methods' ({smallest:.2e}): raise --ref-spp"
        )
    });
    (estimate, flag)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn seeds_are_consecutive_and_halton_skips_the_reference() {
        let (m, h) = seed_plan(3, 7, 0, 1).unwrap();
        assert_eq!(m, [7, 8, 9]);
        assert_eq!(h, [0, 2, 3]);
        let (m, _) = seed_plan(2, u32::MAX, 5, 1).unwrap();
        assert_eq!(m, [u32::MAX, 0]);
        assert!(seed_plan(0, 0, 0, 1).is_err());
        assert!(seed_plan(MAX_SEEDS + 1, 0, 0, 1).is_err());
    }

    fn stats_of(per_seed: &[f64]) -> SeedStats {
        SeedStats::with_relmse(per_seed)
    }

    /// A Halton run at `spp` that took `ms`.
    fn run_at(spp: u32, ms: f64) -> crate::compare::HaltonRun {
        crate::compare::HaltonRun::for_test(spp, ms, 0.0)
    }

    #[test]
    fn budgets_are_halves_to_doubles_rounded_clamped_and_distinct() {
        assert_eq!(budgets_around(10, 100), [5, 7, 10, 14, 20]);
        // 141 and 200 clamp to 120 and merge.
        assert_eq!(budgets_around(100, 120), [50, 71, 100, 120]);
        // ½ and 1/√2 of 1 round to 0 and clamp to 1.
        assert_eq!(budgets_around(1, 100), [1, 2]);
        assert_eq!(budgets_around(6, 0), [1]);
    }

    #[test]
    fn fastest_and_spread_of_rounds() {
        assert_eq!(fastest(&[3.0, 1.5, 2.0]), 1.5);
        assert_eq!(fastest(&[]), f64::INFINITY);
        // (4 − 1) / median 2.
        assert_eq!(spread(&[2.0, 4.0, 1.0]), 1.5);
        assert_eq!(spread(&[5.0]), 0.0);
        assert_eq!(spread(&[]), 0.0);
        assert_eq!(spread(&[0.0, 0.0, 0.0]), 0.0);
        // Two rounds: (3 − 1) / median 2.
        assert_eq!(spread(&[1.0, 3.0]), 1.0);
        let rounds = Interleaved {
            mdas_ms: vec![3.0, 2.0, 6.0],
            // 1 ms + 2 ms per spp at the fastest rounds.
            halton: vec![(4, vec![10.0, 9.0, 11.0]), (8, vec![17.0, 18.0, 20.0])],
        };
        assert_eq!(rounds.mdas_fastest(), 2.0);
        // (6 − 2) / median 3.
        assert_eq!(rounds.mdas_spread(), 4.0 / 3.0);
        let fit = rounds.fit().unwrap();
        assert_eq!((fit.a, fit.b), (1.0, 2.0));
        assert_eq!(fit.points, [(4, 9.0), (8, 17.0)]);
    }

    #[test]
    fn halton_relmse_between_whole_budgets_is_a_power_law() {
        // RelMSE 0.1 at 4 spp and 0.08 at 5: at 4.5 spp, log–log linear.
        let (n0, n1) = (stats_of(&[0.1]), stats_of(&[0.08]));
        let t = (4.5f64 / 4.0).ln() / (5.0f64 / 4.0).ln();
        let want = (0.1f64.ln() + t * (0.08f64.ln() - 0.1f64.ln())).exp();
        assert!((halton_at_target(4.5, &n0, &n1) - want).abs() < 1e-15);
        assert_eq!(halton_at_target(4.0, &n0, &n1), 0.1);
        // Below one spp the bracket is [1, 2].
        assert_eq!(halton_at_target(0.5, &n0, &n1), 0.1);
    }

    #[test]
    fn spp_at_target_reads_the_fit_and_flags_extrapolation() {
        let eq = EqualTime {
            target_ms: 0.0,
            lo: run_at(4, 9.0),
            hi: run_at(8, 17.0),
            relmse: 0.0,
        };
        let fit = TimeFit::new(&[(4, 9.0, 0.0), (8, 17.0, 0.0)]).unwrap();
        let mut flags = Vec::new();
        assert_eq!(spp_at_target(&eq, Some(&fit), 13.0, &mut flags), 6.0);
        assert!(flags.is_empty());
        // 21 ms is 10 spp: beyond the timed 8.
        assert_eq!(spp_at_target(&eq, Some(&fit), 21.0, &mut flags), 10.0);
        assert_eq!(flags.len(), 1);
        assert!(flags[0].contains("outside the timed budgets 4–8"));
        // 5 ms is 2 spp: below the timed 4.
        assert_eq!(spp_at_target(&eq, Some(&fit), 5.0, &mut flags), 2.0);
        assert_eq!(flags.len(), 2);
        // Exactly at the timed budgets is inside them.
        assert_eq!(spp_at_target(&eq, Some(&fit), 9.0, &mut flags), 4.0);
        assert_eq!(spp_at_target(&eq, Some(&fit), 17.0, &mut flags), 8.0);
        assert_eq!(flags.len(), 2);
        // Without a fit: linear between the bracket's runs; at least 1.
        let mut flags = Vec::new();
        assert_eq!(spp_at_target(&eq, None, 11.0, &mut flags), 5.0);
        assert_eq!(spp_at_target(&eq, None, -100.0, &mut flags), 1.0);
        let flat = EqualTime {
            hi: run_at(8, 9.0),
            ..eq.clone()
        };
        assert_eq!(spp_at_target(&flat, None, 11.0, &mut flags), 4.0);
        assert!(flags.is_empty());
    }

    #[test]
    fn ratio_interval_covers_the_seed_spread() {
        // Constant seeds: the interval is the point, MDAS over Halton.
        let ci = ratio_ci95(
            None,
            4.0,
            &[10.0],
            &stats_of(&[0.5, 0.5, 0.5]),
            &stats_of(&[2.0, 2.0]),
            &stats_of(&[1.0, 1.0]),
        );
        assert_eq!(ci, [0.25, 0.25]);
        // Halton at 4.5 spp is between its two budgets' values.
        let ci = ratio_ci95(
            None,
            4.5,
            &[10.0],
            &stats_of(&[1.0]),
            &stats_of(&[2.0]),
            &stats_of(&[1.0]),
        );
        let halfway = 1.0 / interpolate_log_log(4.5, (4.0, 2.0), (5.0, 1.0));
        assert!((ci[0] - halfway).abs() < 1e-12 && ci[1] == ci[0], "{ci:?}");
        // With a fit, the resampled target time moves the spp: MDAS at 9 ms
        // is 4 spp and at 11 ms 5 spp (1 + 2·spp), so the interval spans
        // Halton's two budgets.
        let fit = TimeFit::new(&[(4, 9.0, 0.0), (5, 11.0, 0.0)]).unwrap();
        let ci = ratio_ci95(
            Some(&fit),
            4.0,
            &[9.0, 11.0],
            &stats_of(&[1.0]),
            &stats_of(&[2.0]),
            &stats_of(&[1.0]),
        );
        assert_eq!(ci, [0.5, 1.0]);
        // MDAS's seeds spread the interval.
        let ci = ratio_ci95(
            None,
            4.0,
            &[10.0],
            &stats_of(&[0.2, 0.4, 0.6, 0.8]),
            &stats_of(&[1.0]),
            &stats_of(&[1.0]),
        );
        assert!(
            ci[0] < 0.4 && ci[1] > 0.6 && ci[0] >= 0.2 && ci[1] <= 0.8,
            "{ci:?}"
        );
    }

    #[test]
    fn reference_flag() {
        let s = |r: f64| stats_of(&[r]);
        // 1e-2 at 16 spp → 1e-2·16/4096 ≈ 3.9e-5: far below 1e-3.
        let (e, flag) = reference_check(&s(1e-2), 16, 4096, 1e-3);
        assert!((e - 1e-2 * 16.0 / 4096.0).abs() < 1e-15 && flag.is_none());
        // A 64-spp reference against 16-spp methods: flagged.
        let (_, flag) = reference_check(&s(1e-2), 16, 64, 5e-3);
        assert!(flag.unwrap().contains("raise --ref-spp"));
        // Exactly ten times below (0.5·1/4 = 0.125 = 0.1·1.25, exact in
        // binary) is far enough.
        let (e, flag) = reference_check(&s(0.5), 1, 4, 1.25);
        assert!(e == 0.125 && flag.is_none());
    }
}
