//! `mdas bench`: the cost of MDAS against Halton at the same sample count,
//! phase by phase (issue 10's table).
//!
//! Per scene: one warm-up render of each method (lavapipe compiles a
//! pipeline at its first dispatch, inside the timestamps), then `repeats`
//! rounds of MDAS and Halton renders, interleaved so that a change of
//! machine load hits both. Each figure is the median over the rounds: GPU
//! time per phase (`Render::times`) and the wall-clock time of the whole
//! `render` call (submissions, read-backs and host waits included). Both
//! methods take N = spp × pixels samples: MDAS with the scene's `[mdas]`
//! parameters (at `--scale`, [`crate::session::mdas_params_at_scale`]), Halton
//! with the same whole spp.

use super::equal_time::median;
use crate::gpu::Gpu;
use crate::integrator::{Halton, Integrator, Mdas, Render};
use crate::session;
use anyhow::{bail, Result};
use serde::Serialize;
use std::path::Path;
use std::time::Instant;

/// MDAS phases in the order the table prints them.
pub const MDAS_PHASES: [&str; 5] = ["initial", "evaluate", "error", "adaptive", "reconstruction"];
/// The parts of the adaptive phase ([`Mdas::last_pass_times`]).
pub const ADAPTIVE_PARTS: [&str; 3] = ["adaptive/count", "adaptive/scan", "adaptive/apply"];

/// The parts of the evaluate phase: the initial grid's samples, then the
/// adaptive ones.
pub const EVALUATE_PARTS: [&str; 2] = ["evaluate/initial", "evaluate/adaptive"];

/// One scene's medians.
#[derive(Clone, Debug, Serialize)]
pub struct PhaseBench {
    pub scene: String,
    pub width: u32,
    pub height: u32,
    pub spp: u32,
    /// Samples each method took (MDAS may stop below its budget; Halton
    /// takes exactly spp × pixels).
    pub mdas_samples: u64,
    pub halton_samples: u64,
    /// Median GPU milliseconds per MDAS phase ([`MDAS_PHASES`]).
    pub mdas_phases_ms: Vec<(String, f64)>,
    /// Median GPU milliseconds of each part of the adaptive phase
    /// ([`ADAPTIVE_PARTS`]).
    pub mdas_adaptive_parts_ms: Vec<(String, f64)>,
    /// Median GPU milliseconds of each part of the evaluate phase
    /// ([`EVALUATE_PARTS`]), and the samples of the first (the rest of
    /// `mdas_samples` are the second's).
    pub mdas_evaluate_parts_ms: Vec<(String, f64)>,
    pub mdas_initial_samples: u64,
    /// Median of each render's summed GPU phase times.
    pub mdas_ms: f64,
    pub halton_ms: f64,
    /// Median wall-clock milliseconds of the `render` call.
    pub mdas_wall_ms: f64,
    pub halton_wall_ms: f64,
    pub mdas_iterations: u32,
    pub mdas_gpu_bytes_per_sample: f64,
    pub repeats: u32,
    pub adapter: String,
}

impl PhaseBench {
    pub fn mdas_phase_ms(&self, name: &str) -> f64 {
        self.mdas_phases_ms
            .iter()
            .find(|(n, _)| n == name)
            .map_or(0.0, |(_, t)| *t)
    }

    /// MDAS whole render over Halton's, GPU time.
    pub fn ratio(&self) -> f64 {
        self.mdas_ms / self.halton_ms
    }

    /// ns per sample of MDAS's evaluate phase over Halton's whole render.
    pub fn evaluate_ratio(&self) -> f64 {
        ns_per_sample(self.mdas_phase_ms("evaluate"), self.mdas_samples)
            / ns_per_sample(self.halton_ms, self.halton_samples)
    }

    /// ns per sample of MDAS's initial samples and of its adaptive ones
    /// (0 where a part took no sample).
    pub fn evaluate_parts_ns(&self) -> (f64, f64) {
        let ms = |name: &str| {
            self.mdas_evaluate_parts_ms
                .iter()
                .find(|(n, _)| n == name)
                .map_or(0.0, |(_, t)| *t)
        };
        let adaptive = self.mdas_samples.saturating_sub(self.mdas_initial_samples);
        let ns = |ms: f64, n: u64| if n == 0 { 0.0 } else { ns_per_sample(ms, n) };
        (
            ns(ms(EVALUATE_PARTS[0]), self.mdas_initial_samples),
            ns(ms(EVALUATE_PARTS[1]), adaptive),
        )
    }

    /// Every MDAS phase but evaluate, over Halton's whole render.
    pub fn overhead_ratio(&self) -> f64 {
        (self.mdas_ms - self.mdas_phase_ms("evaluate")) / self.halton_ms
    }
}

pub fn ns_per_sample(ms: f64, samples: u64) -> f64 {
    ms * 1e6 / samples.max(1) as f64
}

fn timed(
    gpu: &Gpu,
    integrator: &mut dyn Integrator,
    integrand: &dyn crate::integrand::Integrand,
) -> Result<(Render, f64)> {
    let start = Instant::now();
    let render = integrator.render(gpu, integrand)?;
    Ok((render, start.elapsed().as_secs_f64() * 1e3))
}

/// Benchmarks one scene at `scale` (`spp`: the scene's `[mdas]` spp when
/// `None`; it must be a whole number, as Halton's is).
pub fn bench_scene(
    gpu: &Gpu,
    scene: &Path,
    scale: f32,
    spp: Option<u32>,
    repeats: u32,
) -> Result<PhaseBench> {
    if repeats == 0 {
        bail!("--repeats must be at least 1");
    }
    let prepared = session::prepare(gpu, scene, scale)?;
    let mut params = session::mdas_params_at_scale(prepared.scene.mdas, scale);
    let spp = match spp {
        Some(s) => s,
        None if params.spp.fract() == 0.0 && params.spp >= 1.0 => params.spp as u32,
        None => bail!(
            "{}: the scene's [mdas] spp {} is not a whole number; pass --spp",
            scene.display(),
            params.spp
        ),
    };
    params.spp = spp as f32;
    let integrand = prepared.integrand.as_ref();
    let mut mdas = Mdas::new(params)?;
    let mut halton = Halton::new(spp, 0);
    // Warm-up: pipelines compiled and first dispatches done.
    timed(gpu, &mut mdas, integrand)?;
    timed(gpu, &mut halton, integrand)?;

    let mut phases: Vec<Vec<f64>> = vec![Vec::new(); MDAS_PHASES.len()];
    let mut parts: Vec<Vec<f64>> = vec![Vec::new(); ADAPTIVE_PARTS.len()];
    let mut eval_parts: Vec<Vec<f64>> = vec![Vec::new(); EVALUATE_PARTS.len()];
    let (mut mdas_ms, mut halton_ms, mut mdas_wall, mut halton_wall) =
        (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    let (mut mdas_samples, mut halton_samples, mut bytes) = (0, 0, 0);
    for _ in 0..repeats {
        let (m, wall) = timed(gpu, &mut mdas, integrand)?;
        for (i, name) in MDAS_PHASES.iter().enumerate() {
            phases[i].push(m.times.get(name).unwrap_or(0.0));
        }
        if let Some(passes) = mdas.last_pass_times() {
            for (i, name) in ADAPTIVE_PARTS.iter().enumerate() {
                parts[i].push(passes.get(name).unwrap_or(0.0));
            }
            for (i, name) in EVALUATE_PARTS.iter().enumerate() {
                eval_parts[i].push(passes.get(name).unwrap_or(0.0));
            }
        }
        mdas_ms.push(m.times.total());
        mdas_wall.push(wall);
        (mdas_samples, bytes) = (m.samples, m.gpu_bytes);
        let (h, wall) = timed(gpu, &mut halton, integrand)?;
        halton_ms.push(h.times.total());
        halton_wall.push(wall);
        halton_samples = h.samples;
    }
    Ok(PhaseBench {
        scene: scene.display().to_string(),
        width: prepared.film.width,
        height: prepared.film.height,
        spp,
        mdas_samples,
        halton_samples,
        mdas_phases_ms: MDAS_PHASES
            .iter()
            .zip(phases)
            .map(|(n, v)| (n.to_string(), median(&v)))
            .collect(),
        mdas_adaptive_parts_ms: ADAPTIVE_PARTS
            .iter()
            .zip(parts)
            .map(|(n, v)| (n.to_string(), median(&v)))
            .collect(),
        mdas_evaluate_parts_ms: EVALUATE_PARTS
            .iter()
            .zip(eval_parts)
            .map(|(n, v)| (n.to_string(), median(&v)))
            .collect(),
        mdas_initial_samples: mdas
            .last_stats()
            .map_or(0, |s| u64::from(s.initial_samples.min(s.budget))),
        mdas_ms: median(&mdas_ms),
        halton_ms: median(&halton_ms),
        mdas_wall_ms: median(&mdas_wall),
        halton_wall_ms: median(&halton_wall),
        mdas_iterations: mdas.last_stats().map_or(0, |s| s.iterations),
        mdas_gpu_bytes_per_sample: bytes as f64 / mdas_samples.max(1) as f64,
        repeats,
        adapter: gpu.info.name.clone(),
    })
}

/// The Markdown table of [`bench_scene`] results.
pub fn table(rows: &[PhaseBench]) -> String {
    let mut out = String::from(
        "| scene | film | spp | MDAS GPU ms (initial / evaluate / error / adaptive / reconstruction) | adaptive: count / scan / apply | Halton GPU ms | MDAS/Halton | evaluate ns/sample: MDAS, Halton (ratio) | MDAS evaluate ns/sample: initial, adaptive | overhead / Halton | wall ms MDAS, Halton | iterations | B/sample |\n\
         |---|---|---:|---|---|---:|---:|---|---|---:|---|---:|---:|\n",
    );
    for r in rows {
        let phases: Vec<String> = MDAS_PHASES
            .iter()
            .map(|n| format!("{:.1}", r.mdas_phase_ms(n)))
            .collect();
        let parts: Vec<String> = r
            .mdas_adaptive_parts_ms
            .iter()
            .map(|(_, t)| format!("{t:.2}"))
            .collect();
        let (initial_ns, adaptive_ns) = r.evaluate_parts_ns();
        out += &format!(
            "| `{}` | {}×{} | {} | {:.1} ({}) | {} | {:.1} | {:.2} | {:.0}, {:.0} ({:.2}) | {:.0}, {:.0} | {:.2} | {:.1}, {:.1} | {} | {:.1} |\n",
            r.scene,
            r.width,
            r.height,
            r.spp,
            r.mdas_ms,
            phases.join(" / "),
            parts.join(" / "),
            r.halton_ms,
            r.ratio(),
            ns_per_sample(r.mdas_phase_ms("evaluate"), r.mdas_samples),
            ns_per_sample(r.halton_ms, r.halton_samples),
            r.evaluate_ratio(),
            initial_ns,
            adaptive_ns,
            r.overhead_ratio(),
            r.mdas_wall_ms,
            r.halton_wall_ms,
            r.mdas_iterations,
            r.mdas_gpu_bytes_per_sample,
        );
    }
    out
}
