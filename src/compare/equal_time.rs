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
            let mut v: Vec<f64> = runs.iter().map(|r| r.get(name).unwrap_or(0.0)).collect();
            v.sort_by(f64::total_cmp);
            let m = if v.len() % 2 == 1 {
                v[v.len() / 2]
            } else {
                0.5 * (v[v.len() / 2 - 1] + v[v.len() / 2])
            };
            out.add(name, m);
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
}
