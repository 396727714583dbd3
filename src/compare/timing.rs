//! The timed steps `compare` and `compare --samplers` share: MDAS's run
//! under a budget (the equal-time target) and Halton's budget search at a
//! target time.

use super::equal_time::{measure, search_equal_time, EqualTime, HaltonRun};
use super::inputs::{Budget, Setup};
use crate::gpu::Gpu;
use crate::integrand::Integrand;
use crate::integrator::mdas::MdasParams;
use crate::integrator::{Halton, Mdas};
use crate::metrics;
use anyhow::{bail, Result};
use indicatif::ProgressBar;

/// Measures MDAS at `spp` (an average, may be fractional).
fn run_mdas(
    gpu: &Gpu,
    mdas: &mut Mdas,
    spp: f32,
    integrand: &dyn Integrand,
    reference: &[[f32; 3]],
    repeats: u32,
) -> Result<HaltonRun> {
    mdas.set_spp(spp)?;
    let measured = measure(gpu, mdas, integrand, repeats)?;
    let error = metrics::compare(&measured.render.image, reference)?;
    Ok(HaltonRun {
        spp: spp.round() as u32,
        measured,
        error,
    })
}

/// MDAS's timed run under a budget, and the equal-time target it sets.
pub(crate) struct MdasTiming {
    /// The run whose image is written (the nearer bracketing run when
    /// searched).
    pub run: HaltonRun,
    /// Its spp (MDAS's own, may be fractional, when not searched).
    pub spp: f64,
    /// The budget search (`Budget::TimeMs` only).
    pub search: Option<EqualTime>,
    pub target_ms: f64,
}

/// Times MDAS under `budget`: at its spp (the target is its time), or
/// searched at `--time-ms` from `min_spp` (an error if even that is slower).
#[allow(clippy::too_many_arguments)]
pub(crate) fn time_mdas(
    gpu: &Gpu,
    params: MdasParams,
    min_spp: u32,
    integrand: &dyn Integrand,
    reference: &[[f32; 3]],
    setup: &Setup,
    budget: Budget,
    max_spp: u32,
    status: &ProgressBar,
    label: &str,
) -> Result<MdasTiming> {
    // One integrator for every budget, so its pipelines compile once.
    let mut mdas = Mdas::new(params)?;
    let mut mdas_run = |spp: f32| {
        status.set_message(format!("{label} {spp} spp ({} repeats)", setup.repeats));
        run_mdas(gpu, &mut mdas, spp, integrand, reference, setup.repeats)
    };
    Ok(match budget {
        Budget::MdasSpp => {
            let run = mdas_run(params.spp)?;
            let target_ms = run.measured.total_ms();
            MdasTiming {
                run,
                spp: params.spp as f64,
                search: None,
                target_ms,
            }
        }
        Budget::TimeMs(t) => {
            let eq = search_equal_time(t, min_spp, max_spp, &mut |spp| mdas_run(spp as f32))?;
            if eq.lo.measured.total_ms() > t {
                bail!(
                    "--time-ms {t} is below the time MDAS needs for its initial samples ({:.3} ms at {} spp, the least its initial grid allows)",
                    eq.lo.measured.total_ms(),
                    eq.lo.spp
                );
            }
            let run = nearer(&eq).clone();
            MdasTiming {
                spp: run.spp as f64,
                run,
                search: Some(eq),
                target_ms: t,
            }
        }
    })
}

/// Halton's budget search at `target_ms` on `integrand` (one integrator
/// for the whole search, so its pipelines compile once).
#[allow(clippy::too_many_arguments)]
pub(crate) fn halton_search(
    gpu: &Gpu,
    integrand: &dyn Integrand,
    reference: &[[f32; 3]],
    target_ms: f64,
    setup: &Setup,
    max_spp: u32,
    status: &ProgressBar,
    label: &str,
) -> Result<EqualTime> {
    let mut halton = Halton::new(1, setup.halton_seed);
    search_equal_time(target_ms, 1, max_spp, &mut |spp| {
        status.set_message(format!("{label} {spp} spp ({} repeats)", setup.repeats));
        halton.spp = spp;
        let measured = measure(gpu, &mut halton, integrand, setup.repeats)?;
        let error = metrics::compare(&measured.render.image, reference)?;
        Ok(HaltonRun {
            spp,
            measured,
            error,
        })
    })
}

/// The bracketing run nearer to the target time.
pub(crate) fn nearer(eq: &EqualTime) -> &HaltonRun {
    let t = eq.target_ms;
    if (t - eq.lo.measured.total_ms()).abs() <= (eq.hi.measured.total_ms() - t).abs() {
        &eq.lo
    } else {
        &eq.hi
    }
}
