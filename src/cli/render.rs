//! `mdas render`: one image with Halton or MDAS, timed, optionally
//! measured against a reference EXR.

use super::*;

/// The largest Halton `--spp` of `render` (every whole number up to it is
/// exact in the f32 the flag is parsed as).
const MAX_HALTON_SPP: u32 = 1 << 24;

#[derive(clap::Args)]
pub(crate) struct RenderArgs {
    /// Scene file (TOML; see docs/scene-format.md).
    pub(crate) scene: PathBuf,
    /// Sampling method.
    #[arg(long, value_enum, default_value = "halton")]
    pub(crate) integrator: IntegratorKind,
    /// Samples per pixel. Halton: a whole number in 1..=2^24 (default 16); MDAS: the
    /// average budget, may be fractional (default: the scene's [mdas] spp).
    #[arg(long)]
    pub(crate) spp: Option<f32>,
    /// Random seed; same seed, same image on one adapter (default: 0 for
    /// Halton, the scene's [mdas] seed for MDAS).
    #[arg(long)]
    pub(crate) seed: Option<u32>,
    /// Output EXR path (the PNG goes beside it). Default: out/<scene>-<integrator>.exr.
    #[arg(short, long)]
    pub(crate) output: Option<PathBuf>,
    /// Render at this fraction of the scene's film size (same camera), e.g. 0.25.
    #[arg(long, default_value_t = 1.0)]
    pub(crate) scale: f32,
    /// Reference EXR to measure RelMSE and MSE against (same size as the render).
    #[arg(long)]
    pub(crate) reference: Option<PathBuf>,
    /// Light sampler of a many_light scene, overriding its [integrand]
    /// sampler: uniform, power, tree_nocut, tree, unbalanced or
    /// unbalanced_nocut (an error for other integrands).
    #[arg(long, value_name = "NAME")]
    pub(crate) sampler: Option<SamplerKind>,
    /// Render once untimed first, so that the printed times are warm:
    /// CPU drivers (lavapipe) compile a pipeline at its first dispatch,
    /// inside the GPU timestamps of a cold render.
    #[arg(long)]
    pub(crate) warmup: bool,
    #[command(flatten)]
    pub(crate) mdas: MdasArgs,
}

pub(crate) fn run(args: RenderArgs) -> Result<()> {
    let RenderArgs {
        scene,
        integrator,
        spp,
        seed,
        output,
        scale,
        reference,
        sampler,
        warmup,
        mdas,
    } = args;
    let output = output.unwrap_or_else(|| default_output(&scene, integrator.name()));
    // Fail on bad input before any GPU work.
    check_output(&output)?;
    if let Some(s) = spp {
        if !(s.is_finite() && s > 0.0) {
            bail!("--spp must be positive, got {s}");
        }
        if integrator == IntegratorKind::Halton && s.fract() != 0.0 {
            bail!("--spp must be a whole number of samples per pixel for Halton, got {s}");
        }
        // Above 2^24 an f32 no longer holds every whole number, and
        // 4294967297 parsed as f32 would saturate to u32::MAX spp.
        if integrator == IntegratorKind::Halton && s > MAX_HALTON_SPP as f32 {
            bail!("--spp must be at most {MAX_HALTON_SPP} for Halton, got {s}");
        }
    }
    let reference = reference.map(|r| image_io::read_exr(&r)).transpose()?;
    let gpu = Gpu::shared()?;
    let prepared = app::prepare_with(gpu, &scene, scale, IntegrandOverrides { sampler })?;
    let film = prepared.film;
    let mut sampler: Box<dyn Integrator> = match integrator {
        IntegratorKind::Halton => {
            Box::new(Halton::new(spp.map_or(16, |s| s as u32), seed.unwrap_or(0)))
        }
        IntegratorKind::Mdas => Box::new(Mdas::new(mdas.params(
            prepared.scene.mdas,
            scale,
            spp,
            seed,
        ))?),
    };
    let light_sampler = app::light_sampler(&prepared.scene.integrand)
        .map_or_else(String::new, |k| format!(", sampler {k}"));
    println!(
        "{}: {}×{} px, {} triangles, integrand {} ({}D{light_sampler}), {}, adapter {}",
        scene.display(),
        film.width,
        film.height,
        prepared.scene.scene.triangle_count(),
        prepared.integrand.name(),
        prepared.integrand.dims(),
        integrator.name(),
        gpu.info.name
    );
    if warmup {
        sampler.render(gpu, prepared.integrand.as_ref())?;
    }
    let render = sampler.render(gpu, prepared.integrand.as_ref())?;
    print_render(&render);
    if !warmup && gpu.info.device_type == wgpu::DeviceType::Cpu {
        println!(
            "(cold: this CPU driver compiles pipelines at their first dispatch, inside these times; --warmup or `mdas bench` time warm renders)"
        );
    }
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

fn print_render(render: &Render) {
    let phases: Vec<String> = render
        .times
        .0
        .iter()
        .map(|(n, t)| format!("{n} {t:.2} ms"))
        .collect();
    println!(
        "{} samples ({:.2} spp) in {:.2} ms ({}; {:?}), {:.3} Msamples/s, {} non-finite samples, {:.1} MiB GPU",
        render.samples,
        render.samples as f64 / (render.film.width as f64 * render.film.height as f64),
        render.times.total(),
        phases.join(", "),
        render.clock,
        render.samples as f64 / render.times.total().max(1e-9) / 1e3,
        render.nonfinite,
        render.gpu_bytes as f64 / 1048576.0
    );
}
