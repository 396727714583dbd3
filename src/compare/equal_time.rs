//! Timing renders and matching Halton's budget to another method's time.
//!
//! [`measure`] renders once to warm up (pipeline compilation, caches),
//! then `repeats` more times, and keeps the per-phase **median** of the
//! repeats (GPU timestamps where the adapter has them, else the wall clock
//! with a device sync; see `gpu::profiler`). The image is the last run's —
//! renders are deterministic, so every run's image is the same.
//!
//! [`halton_at_equal_time`] finds Halton sample counts whose measured total
//! time brackets a target time T: a first probe at `spp = 1` (or a method's
//! smallest budget, [`search_equal_time`]) gives a linear
//! time model t(spp) ≈ a + b·spp, which seeds a bisection over integer spp
//! until the bracket [lo, hi] is tight (hi − lo ≤ max(1, lo/32)) or the
//! target lies outside what spp can reach. The RelMSE at exactly T is
//! interpolated between the bracketing runs in log–log space (RelMSE of a
//! converging estimator is close to a power of the time), and reported with
//! both bracketing runs so the interpolation can be checked.

use crate::gpu::profiler::PhaseTimes;
use crate::gpu::Gpu;
use crate::integrand::Integrand;
use crate::integrator::{Halton, Integrator, Render};
use crate::metrics::{self, ErrorStats};
use anyhow::{bail, Result};

/// A render with its median per-phase times over the timed repeats.
#[derive(Clone, Debug)]
pub struct Measured {
    pub render: Render,
    pub times: PhaseTimes,
}

impl Measured {
    pub fn total_ms(&self) -> f64 {
        self.times.total()
    }
}

/// Median per phase of several runs' times.
fn median_times(runs: &[PhaseTimes]) -> PhaseTimes {
    let mut out = PhaseTimes::default();
    if let Some(first) = runs.first() {
        for (name, _) in &first.0 {
            let v: Vec<f64> = runs.iter().map(|r| r.get(name).unwrap_or(0.0)).collect();
            out.add(name, median(&v));
        }
    }
    out
}

/// Warm-up run, then `repeats` timed runs; per-phase medians.
pub fn measure(
    gpu: &Gpu,
    integrator: &mut dyn Integrator,
    integrand: &dyn Integrand,
    repeats: u32,
) -> Result<Measured> {
    if repeats == 0 {
        bail!("--repeats must be at least 1");
    }
    let mut render = integrator.render(gpu, integrand)?;
    let mut runs = Vec::with_capacity(repeats as usize);
    for _ in 0..repeats {
        render = integrator.render(gpu, integrand)?;
        runs.push(render.times.clone());
    }
    let times = median_times(&runs);
    Ok(Measured { render, times })
}

/// One run of an equal-time search (Halton's, or any method's through
/// [`search_equal_time`]).
#[derive(Clone, Debug)]
pub struct HaltonRun {
    pub spp: u32,
    pub measured: Measured,
    pub error: ErrorStats,
}

#[cfg(test)]
impl HaltonRun {
    /// A run of a one-pixel film at `spp` whose evaluate phase took `ms`,
    /// with RelMSE `relmse` (unit tests of the searches and intervals).
    pub(crate) fn for_test(spp: u32, ms: f64, relmse: f64) -> Self {
        let mut times = crate::gpu::profiler::PhaseTimes::default();
        times.add("evaluate", ms);
        HaltonRun {
            spp,
            measured: Measured {
                render: crate::integrator::Render {
                    film: crate::film::Film {
                        width: 1,
                        height: 1,
                    },
                    image: vec![[0.0; 3]],
                    samples: spp as u64,
                    nonfinite: 0,
                    times: times.clone(),
                    clock: crate::gpu::profiler::Clock::GpuTimestamps,
                    gpu_bytes: 0,
                },
                times,
            },
            error: ErrorStats {
                relmse,
                mse: 0.0,
                mae: 0.0,
                nonfinite_pixels: 0,
                pixels: 1,
            },
        }
    }
}

/// Runs bracketing a target time, and the RelMSE interpolated at it.
#[derive(Clone, Debug)]
pub struct EqualTime {
    pub target_ms: f64,
    /// The run with the largest spp whose time is ≤ target (or the smallest
    /// spp tried, when even that is slower).
    pub lo: HaltonRun,
    /// The run with the smallest spp whose time is ≥ target (or = lo when
    /// the target is below the time of one sample per pixel, or above
    /// `max_spp`'s).
    pub hi: HaltonRun,
    /// RelMSE at exactly `target_ms`, interpolated log–log between lo and hi
    /// (lo's or hi's own value when the target lies outside the bracket).
    pub relmse: f64,
}

/// Log–log interpolation of y at x between (x0, y0) and (x1, y1); clamps
/// to the nearer end outside [x0, x1].
pub fn interpolate_log_log(x: f64, (x0, y0): (f64, f64), (x1, y1): (f64, f64)) -> f64 {
    if x1 <= x0 || x <= x0 || y0 <= 0.0 || y1 <= 0.0 {
        return if x >= x1 { y1 } else { y0 };
    }
    if x >= x1 {
        return y1;
    }
    let s = (x.ln() - x0.ln()) / (x1.ln() - x0.ln());
    (y0.ln() + s * (y1.ln() - y0.ln())).exp()
}

/// Halton at the spp whose time matches `target_ms` (see the module docs).
pub fn halton_at_equal_time(
    gpu: &Gpu,
    integrand: &dyn Integrand,
    reference: &[[f32; 3]],
    target_ms: f64,
    seed: u32,
    repeats: u32,
    max_spp: u32,
) -> Result<EqualTime> {
    // One integrator for the whole search, so its pipelines compile once.
    let mut halton = Halton::new(1, seed);
    search_equal_time(target_ms, 1, max_spp, &mut |spp| {
        halton.spp = spp;
        let measured = measure(gpu, &mut halton, integrand, repeats)?;
        let error = metrics::compare(&measured.render.image, reference)?;
        Ok(HaltonRun {
            spp,
            measured,
            error,
        })
    })
}

/// The budget search of [`halton_at_equal_time`] over any method whose
/// cost grows with a whole spp: `run(spp)` measures one budget, the search
/// starts at `min_spp` (the smallest budget the method accepts) and never
/// exceeds `max_spp`.
pub fn search_equal_time(
    target_ms: f64,
    min_spp: u32,
    max_spp: u32,
    run: &mut dyn FnMut(u32) -> Result<HaltonRun>,
) -> Result<EqualTime> {
    if !(target_ms.is_finite() && target_ms > 0.0) {
        bail!("equal-time target must be a positive time, got {target_ms} ms");
    }
    let min_spp = min_spp.max(1);
    let max_spp = max_spp.max(min_spp);
    let mut lo = run(min_spp)?;
    if lo.measured.total_ms() >= target_ms || max_spp <= min_spp {
        let relmse = lo.error.relmse;
        return Ok(EqualTime {
            target_ms,
            hi: lo.clone(),
            lo,
            relmse,
        });
    }
    // Linear model through (0, 0) and the probe: overestimate slightly so the
    // first guess tends to land above the target and close the bracket.
    let per_spp = (lo.measured.total_ms() / min_spp as f64).max(1e-9);
    let mut hi: Option<HaltonRun> = None;
    let mut guess = ((1.1 * target_ms / per_spp).ceil() as u64)
        .max(min_spp as u64 + 1)
        .min(max_spp as u64) as u32;
    loop {
        let r = run(guess)?;
        if r.measured.total_ms() <= target_ms {
            lo = r;
        } else {
            hi = Some(r);
        }
        let upper = hi.as_ref().map_or(max_spp, |h| h.spp);
        let tight = upper - lo.spp <= (lo.spp / 32).max(1);
        if tight || (hi.is_none() && lo.spp >= max_spp) {
            break;
        }
        guess = match &hi {
            // Bisect inside the bracket.
            Some(h) => lo.spp + (h.spp - lo.spp) / 2,
            // Still below the target: extrapolate from lo's rate, at least double.
            None => {
                let rate = lo.measured.total_ms() / lo.spp as f64;
                ((1.1 * target_ms / rate).ceil() as u64)
                    .max(2 * lo.spp as u64)
                    .min(max_spp as u64) as u32
            }
        };
    }
    let hi = hi.unwrap_or_else(|| lo.clone());
    let relmse = interpolate_log_log(
        target_ms,
        (lo.measured.total_ms(), lo.error.relmse),
        (hi.measured.total_ms(), hi.error.relmse),
    );
    Ok(EqualTime {
        target_ms,
        lo,
        hi,
        relmse,
    })
}

/// Repeat spreads above this fraction of the median are flagged: the
/// machine was busy or the clock is coarse for such short renders.
pub const MAX_SPREAD: f64 = 0.25;

/// The median of `v`, the mean of the middle two for an even count; NaN
/// when `v` is empty.
pub fn median(v: &[f64]) -> f64 {
    let mut v = v.to_vec();
    v.sort_by(f64::total_cmp);
    match v.len() {
        0 => f64::NAN,
        n if n % 2 == 1 => v[n / 2],
        n => 0.5 * (v[n / 2 - 1] + v[n / 2]),
    }
}

/// Halton's time as a straight line in spp, t ≈ a + b·spp, fitted to every
/// run of a budget search (each a median over repeats), so the equal-time
/// budget rests on all of them rather than on the two that bracket the
/// target. Rendering time is linear in the sample count up to fixed costs,
/// which `a` absorbs. The fit is Theil–Sen (b the median of the pairwise
/// slopes, a the median of t − b·spp), which one slow run out of five (a
/// busy CPU driver) does not move, where least squares would.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct TimeFit {
    /// Fixed cost, ms.
    pub a: f64,
    /// Cost per spp, ms.
    pub b: f64,
    /// The runs it was fitted to, (spp, ms), by spp.
    pub points: Vec<(u32, f64)>,
    /// Largest |measured − fitted| / fitted over the points.
    pub max_residual: f64,
    /// What makes the fit or its runs suspect (empty when none).
    pub flags: Vec<String>,
}

impl TimeFit {
    /// Fits `runs` (spp, median ms, repeat spread); `None` with fewer than
    /// two distinct spp.
    pub fn new(runs: &[(u32, f64, f64)]) -> Option<TimeFit> {
        let mut points: Vec<(u32, f64)> = runs.iter().map(|&(s, t, _)| (s, t)).collect();
        points.sort_by_key(|p| p.0);
        points.dedup_by_key(|p| p.0);
        if points.len() < 2 {
            return None;
        }
        let mut slopes = Vec::new();
        for (i, p) in points.iter().enumerate() {
            for q in &points[i + 1..] {
                slopes.push((q.1 - p.1) / (q.0 as f64 - p.0 as f64));
            }
        }
        let b = median(&slopes);
        let a = median(
            &points
                .iter()
                .map(|p| p.1 - b * p.0 as f64)
                .collect::<Vec<_>>(),
        );
        let max_residual = points
            .iter()
            .map(|&(s, t)| {
                let f = a + b * s as f64;
                (t - f).abs() / f.abs().max(1e-12)
            })
            .fold(0.0, f64::max);
        let mut flags = Vec::new();
        if b <= 0.0 {
            flags.push(format!(
                "time does not grow with spp (fitted {b:.4} ms per spp)"
            ));
        }
        for w in points.windows(2) {
            if w[1].1 < w[0].1 {
                flags.push(format!(
                    "{} spp took {:.3} ms, less than {} spp's {:.3} ms",
                    w[1].0, w[1].1, w[0].0, w[0].1
                ));
            }
        }
        for &(s, _, spread) in runs {
            if spread > MAX_SPREAD {
                flags.push(format!(
                    "{s} spp: repeat times spread {:.0}% of their median (limit {:.0}%)",
                    100.0 * spread,
                    100.0 * MAX_SPREAD
                ));
            }
        }
        Some(TimeFit {
            a,
            b,
            points,
            max_residual,
            flags,
        })
    }

    /// The (real) spp whose fitted time is `ms`; `None` when the fit does
    /// not grow with spp.
    pub fn spp_at(&self, ms: f64) -> Option<f64> {
        (self.b > 0.0).then(|| (ms - self.a) / self.b)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn log_log_interpolation_is_exact_on_power_laws() {
        // RelMSE = 3·t^−1: interpolation in log–log space is exact.
        let f = |t: f64| 3.0 / t;
        for t in [2.0, 3.5, 7.9] {
            let y = interpolate_log_log(t, (2.0, f(2.0)), (8.0, f(8.0)));
            assert!((y - f(t)).abs() < 1e-12 * f(t));
        }
        assert_eq!(interpolate_log_log(1.0, (2.0, 5.0), (8.0, 1.0)), 5.0);
        assert_eq!(interpolate_log_log(9.0, (2.0, 5.0), (8.0, 1.0)), 1.0);
    }

    #[test]
    fn medians_per_phase() {
        let runs: Vec<PhaseTimes> = [3.0, 1.0, 2.0]
            .iter()
            .map(|&t| PhaseTimes(vec![("a".into(), t), ("b".into(), 10.0 * t)]))
            .collect();
        let m = median_times(&runs);
        assert_eq!(m.get("a"), Some(2.0));
        assert_eq!(m.get("b"), Some(20.0));
    }

    /// An injected timing table: a clean line fits exactly; a bracket whose
    /// time falls as spp grows (56 spp 28.5 ms, 57 spp 53.7 ms reversed, as
    /// seen in the wild) and a wide repeat spread are flagged.
    #[test]
    fn time_fit_and_its_flags() {
        let clean = TimeFit::new(&[(1, 3.0, 0.01), (4, 9.0, 0.02), (8, 17.0, 0.0)]).unwrap();
        assert!((clean.a - 1.0).abs() < 1e-12 && (clean.b - 2.0).abs() < 1e-12);
        assert!(clean.flags.is_empty(), "{:?}", clean.flags);
        assert!(clean.max_residual < 1e-12);
        assert_eq!(clean.spp_at(11.0), Some(5.0));
        let bad = TimeFit::new(&[(1, 5.0, 0.1), (56, 53.7, 0.1), (57, 28.5, 0.6)]).unwrap();
        assert_eq!(bad.flags.len(), 2, "{:?}", bad.flags);
        assert!(bad.flags[0].contains("57 spp took 28.500 ms, less than 56 spp"));
        assert!(bad.flags[1].contains("57 spp: repeat times spread 60%"));
        // One slow run of five leaves the fit on the other four's line.
        let outlier = TimeFit::new(&[
            (1, 3.0, 0.0),
            (2, 5.0, 0.0),
            (4, 9.0, 0.0),
            (5, 30.0, 0.0),
            (8, 17.0, 0.0),
        ])
        .unwrap();
        assert!(
            (outlier.b - 2.0).abs() < 1e-12 && (outlier.a - 1.0).abs() < 1e-12,
            "{outlier:?}"
        );
        assert!((outlier.max_residual - 19.0 / 11.0).abs() < 1e-12);
        let flat = TimeFit::new(&[(2, 10.0, 0.0), (4, 9.0, 0.0)]).unwrap();
        assert!(flat.flags[0].contains("does not grow"));
        assert_eq!(flat.spp_at(10.0), None);
        assert!(TimeFit::new(&[(3, 1.0, 0.0), (3, 2.0, 0.0)]).is_none());
    }
}
