//! `mdas` command-line interface. Run `mdas --help`.

use anyhow::{bail, Result};
use clap::{Parser, Subcommand, ValueEnum};
use indicatif::{ProgressBar, ProgressStyle};
use mdas::app::{self, ReferenceSpec};
use mdas::gpu::Gpu;
use mdas::integrator::{Halton, Integrator, Render};
use mdas::{image_io, metrics};
use std::path::{Path, PathBuf};
use std::process::ExitCode;

#[derive(Parser)]
#[command(
    name = "mdas",
    version,
    about = "GPU multidimensional adaptive sampling and Halton QMC renderer (wgpu/WGSL)",
    long_about = "Renders TOML scenes by Monte Carlo integration on the GPU (any wgpu adapter: a \
                  real GPU, or Mesa's lavapipe CPU driver) and measures error against references.\n\n\
                  Conventions (shared/DESIGN.md): a pixel's value is the mean radiance over its \
                  footprint; images are linear RGB in EXR (a sRGB PNG is written beside for eyes); \
                  RelMSE = mean over pixels and channels of (x − ref)² / (ref² + 0.01).\n\n\
                  Environment: MDAS_ADAPTER=<substring> picks an adapter by name; WGPU_BACKEND \
                  restricts backends (e.g. vulkan)."
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Clone, Copy, Debug, ValueEnum)]
enum IntegratorKind {
    /// Halton quasi-Monte Carlo with per-pixel Cranley–Patterson shifts.
    Halton,
}

#[derive(Subcommand)]
enum Command {
    /// Render a scene and write OUT.exr (linear) and OUT.png (sRGB).
    Render {
        /// Scene file (TOML; see docs/scene-format.md).
        scene: PathBuf,
        /// Sampling method.
        #[arg(long, value_enum, default_value = "halton")]
        integrator: IntegratorKind,
        /// Samples per pixel (at least 1).
        #[arg(long, default_value_t = 16, value_parser = clap::value_parser!(u32).range(1..))]
        spp: u32,
        /// Seed of the per-pixel random shifts; same seed, same image (on one adapter).
        #[arg(long, default_value_t = 0)]
        seed: u32,
        /// Output EXR path (the PNG goes beside it). Default: out/<scene>-<integrator>.exr.
        #[arg(short, long)]
        output: Option<PathBuf>,
        /// Render at this fraction of the scene's film size (same camera), e.g. 0.25.
        #[arg(long, default_value_t = 1.0)]
        scale: f32,
        /// Reference EXR to measure RelMSE and MSE against (same size as the render).
        #[arg(long)]
        reference: Option<PathBuf>,
    },
    /// Render (or fetch from the cache) a high-spp Halton reference image.
    Reference {
        /// Scene file (TOML).
        scene: PathBuf,
        /// Samples per pixel of the reference (at least 1).
        #[arg(long, default_value_t = 65536, value_parser = clap::value_parser!(u32).range(1..))]
        spp: u32,
        /// Render at this fraction of the scene's film size (same camera).
        #[arg(long, default_value_t = 1.0)]
        scale: f32,
        /// Seed of the reference's random shifts.
        #[arg(long, default_value_t = 0)]
        seed: u32,
        /// Cache directory; references are keyed by a hash of the scene file and these parameters.
        #[arg(long, default_value = ".cache/references")]
        cache: PathBuf,
        /// Also copy the reference to this EXR path (and a PNG beside it).
        #[arg(short, long)]
        output: Option<PathBuf>,
    },
    /// Print the GPU adapter, backend, features in use and key limits.
    Info,
}

fn main() -> ExitCode {
    match run(Cli::parse()) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::FAILURE
        }
    }
}

fn run(cli: Cli) -> Result<()> {
    match cli.command {
        Command::Info => {
            println!("mdas {}", env!("CARGO_PKG_VERSION"));
            println!("{}", Gpu::shared()?.describe());
            Ok(())
        }
        Command::Render {
            scene,
            integrator,
            spp,
            seed,
            output,
            scale,
            reference,
        } => {
            let IntegratorKind::Halton = integrator;
            let output = output.unwrap_or_else(|| default_output(&scene, "halton"));
            // Fail on bad input before any GPU work.
            check_output(&output)?;
            let reference = reference.map(|r| image_io::read_exr(&r)).transpose()?;
            let gpu = Gpu::shared()?;
            let prepared = app::prepare(gpu, &scene, scale)?;
            let film = prepared.film;
            println!(
                "{}: {}×{} px, {} triangles, integrand {} ({}D), halton {spp} spp, adapter {}",
                scene.display(),
                film.width,
                film.height,
                prepared.scene.triangle_count(),
                prepared.integrand.name(),
                prepared.integrand.dims(),
                gpu.info.name
            );
            let mut halton = Halton::new(spp, seed);
            let render = halton.render(gpu, prepared.integrand.as_ref())?;
            print_render(&render);
            if let Some((w, h, ref_image)) = reference {
                if (w, h) != (film.width, film.height) {
                    bail!(
                        "reference is {w}×{h} but the render is {}×{}",
                        film.width,
                        film.height
                    );
                }
                let e = metrics::compare(&render.image, &ref_image)?;
                println!(
                    "RelMSE {:.6e}  MSE {:.6e}  non-finite pixels {}",
                    e.relmse, e.mse, e.nonfinite_pixels
                );
            }
            let png = app::write_outputs(&output, film, &render.image)?;
            println!("wrote {} and {}", output.display(), png.display());
            Ok(())
        }
        Command::Reference {
            scene,
            spp,
            scale,
            seed,
            cache,
            output,
        } => {
            if let Some(out) = &output {
                check_output(out)?;
            }
            let gpu = Gpu::shared()?;
            let bar = ProgressBar::new(spp as u64);
            bar.set_style(
                ProgressStyle::with_template(
                    "reference {bar:40} {pos}/{len} spp [{elapsed_precise} < {eta}]",
                )
                .expect("valid template"),
            );
            let b = bar.clone();
            let spec = ReferenceSpec { spp, scale, seed };
            let (film, image, path, cached) = app::reference(
                gpu,
                &scene,
                spec,
                &cache,
                Some(Box::new(move |done, _| b.set_position(done as u64))),
            )?;
            bar.finish_and_clear();
            println!(
                "reference {}×{} at {spp} spp: {} ({})",
                film.width,
                film.height,
                path.display(),
                if cached { "cached" } else { "rendered" }
            );
            if let Some(out) = output {
                let png = app::write_outputs(&out, film, &image)?;
                println!("wrote {} and {}", out.display(), png.display());
            }
            Ok(())
        }
    }
}

fn default_output(scene: &Path, integrator: &str) -> PathBuf {
    let stem = scene
        .file_stem()
        .and_then(|s| s.to_str())
        .unwrap_or("render");
    PathBuf::from("out").join(format!("{stem}-{integrator}.exr"))
}

/// An output must be an `.exr` path whose directory exists or can be made.
fn check_output(path: &Path) -> Result<()> {
    if path.extension().and_then(|e| e.to_str()) != Some("exr") {
        bail!(
            "output '{}' must end in .exr (a .png is written beside it)",
            path.display()
        );
    }
    ensure_parent(path)
}

fn ensure_parent(path: &Path) -> Result<()> {
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        if !dir.exists() {
            std::fs::create_dir_all(dir).map_err(|e| {
                anyhow::anyhow!("cannot create output directory {}: {e}", dir.display())
            })?;
        }
    }
    Ok(())
}

fn print_render(render: &Render) {
    let phases: Vec<String> = render
        .times
        .0
        .iter()
        .map(|(n, t)| format!("{n} {t:.2} ms"))
        .collect();
    println!(
        "{} samples in {:.2} ms ({}; {:?}), {:.3} Msamples/s, {} non-finite samples",
        render.samples,
        render.times.total(),
        phases.join(", "),
        render.clock,
        render.samples as f64 / render.times.total().max(1e-9) / 1e3,
        render.nonfinite
    );
}
