//! `mdas sweep`: RelMSE against time for MDAS and Halton over a list of
//! budgets (samples per pixel), written as `sweep.csv` and a log–log plot,
//! `sweep.svg` and `sweep.png` (time on x, RelMSE on y) — speed against error in one
//! picture. Each point is a [`measure`]d run (warm-up, median of the
//! repeats). MDAS budgets below its initial sample count are skipped and
//! listed in the result.

use super::equal_time::measure;
use super::experiment::{check_out_dir, mdas_min_spp, Setup};
use super::plot::{loglog_svg, svg_to_png, Series};
use crate::app;
use crate::gpu::Gpu;
use crate::image_io;
use crate::integrator::mdas::MdasParams;
use crate::integrator::{Halton, Integrator, Mdas};
use crate::metrics;
use anyhow::{bail, Result};

/// Inputs of [`sweep`].
pub struct SweepSpec<'a> {
    pub setup: Setup<'a>,
    /// Budgets, samples per pixel, for both methods.
    pub spps: Vec<u32>,
}

/// One measured point.
#[derive(Clone, Debug, serde::Serialize)]
pub struct SweepRow {
    pub method: &'static str,
    pub spp: u32,
    pub samples: u64,
    pub time_ms: f64,
    pub relmse: f64,
    pub mse: f64,
}

/// The points, and the MDAS budgets skipped (below its initial samples).
pub struct SweepResult {
    pub rows: Vec<SweepRow>,
    pub mdas_skipped: Vec<u32>,
}

pub const CSV_HEADER: &str = "method,spp,samples,time_ms,relmse,mse";

pub fn csv(rows: &[SweepRow]) -> String {
    let mut s = format!("{CSV_HEADER}\n");
    for r in rows {
        s += &format!(
            "{},{},{},{},{},{}\n",
            r.method, r.spp, r.samples, r.time_ms, r.relmse, r.mse
        );
    }
    s
}

/// Runs the sweep and writes `sweep.csv`, `sweep.svg` and `sweep.png` in
/// `spec.out`.
pub fn sweep(gpu: &Gpu, spec: &SweepSpec) -> Result<SweepResult> {
    super::experiment::cleaning_up(&spec.setup.out, || run_sweep(gpu, spec))
}

fn run_sweep(gpu: &Gpu, spec: &SweepSpec) -> Result<SweepResult> {
    spec.setup.check()?;
    if spec.spps.is_empty() || spec.spps.contains(&0) {
        bail!("--spps must list positive samples per pixel");
    }
    let prepared = app::prepare(gpu, &spec.setup.scene, spec.setup.scale)?;
    let integrand = prepared.integrand.as_ref();
    let params = (spec.setup.mdas_params)(prepared.scene.mdas);
    let min_spp = mdas_min_spp(params, integrand)?;
    let (mdas_spps, mdas_skipped): (Vec<u32>, Vec<u32>) =
        spec.spps.iter().partition(|&&s| s >= min_spp);
    for &spp in &mdas_spps {
        Mdas::new(MdasParams {
            spp: spp as f32,
            ..params
        })?
        .config(integrand)?;
    }
    check_out_dir(&spec.setup.out)?;
    let (reference, _, _) = spec.setup.reference(gpu)?;
    let bar = super::experiment::bar(
        spec.setup.progress,
        (spec.spps.len() + mdas_spps.len()) as u64,
        "sweep {bar:40} {pos}/{len} runs {msg} [{elapsed_precise} < {eta}]",
    );
    let mut rows = Vec::new();
    let mut point = |method: &'static str, spp: u32, integrator: &mut dyn Integrator| {
        bar.set_message(format!("{method} {spp} spp"));
        let m = measure(gpu, integrator, integrand, spec.setup.repeats)?;
        let e = metrics::compare(&m.render.image, &reference)?;
        rows.push(SweepRow {
            method,
            spp,
            samples: m.render.samples,
            time_ms: m.total_ms(),
            relmse: e.relmse,
            mse: e.mse,
        });
        bar.inc(1);
        anyhow::Ok(())
    };
    // One integrator per method, so pipelines compile once.
    let mut mdas = Mdas::new(params)?;
    for &spp in &mdas_spps {
        mdas.set_spp(spp as f32)?;
        point("mdas", spp, &mut mdas)?;
    }
    let mut halton = Halton::new(1, spec.setup.halton_seed);
    for &spp in &spec.spps {
        halton.spp = spp;
        point("halton", spp, &mut halton)?;
    }
    bar.finish_and_clear();

    let series = |method: &str| -> Vec<(f64, f64)> {
        rows.iter()
            .filter(|r| r.method == method)
            .map(|r| (r.time_ms, r.relmse))
            .collect()
    };
    let title = format!(
        "{} at scale {}",
        spec.setup.scene.display(),
        spec.setup.scale
    );
    let svg = loglog_svg(
        &title,
        "time (ms, median)",
        "RelMSE",
        &[
            Series {
                name: "MDAS",
                colour: "#d62728",
                points: series("mdas"),
            },
            Series {
                name: "Halton",
                colour: "#1f77b4",
                points: series("halton"),
            },
        ],
    );
    let text = csv(&rows);
    image_io::write_atomic(&spec.setup.out.join("sweep.csv"), |t| {
        std::fs::write(t, text.as_bytes()).map_err(Into::into)
    })?;
    let png = svg_to_png(&svg)?;
    image_io::write_atomic(&spec.setup.out.join("sweep.svg"), |t| {
        std::fs::write(t, svg.as_bytes()).map_err(Into::into)
    })?;
    image_io::write_atomic(&spec.setup.out.join("sweep.png"), |t| {
        std::fs::write(t, &png).map_err(Into::into)
    })?;
    Ok(SweepResult { rows, mdas_skipped })
}
