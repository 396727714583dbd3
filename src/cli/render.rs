//! `mdas render`: one image with Halton or MDAS, timed, optionally
//! measured against a reference EXR.

use super::*;
use mdas::integrator::mdas::config::Config;
use mdas::integrator::mdas::MAX_ITERATIONS_DEFAULT;

/// The largest Halton `--spp` of `render` (every whole number up to it is
/// exact in the f32 the flag is parsed as).
const MAX_HALTON_SPP: u32 = 1 << 24;

#[derive(clap::Args)]
pub(crate) struct RenderArgs {
    /// Scene file: TOML, or a Mitsuba 3 XML file (.xml); see docs/scene-format.md.
    pub(crate) scene: PathBuf,
    /// Sampling method.
    #[arg(long, value_enum, default_value = "halton")]
    pub(crate) integrator: IntegratorKind,
    /// Samples per pixel. Halton: a whole number in 1..=2^24 (default 16); MDAS: the
    /// average budget, may be fractional (default: the scene's [mdas] spp);
    /// adaptive: the average budget, may be fractional (default 16).
    #[arg(long)]
    pub(crate) spp: Option<f32>,
    /// Random seed; same seed, same image on one adapter (default: 0 for
    /// Halton and adaptive, the scene's [mdas] seed for MDAS).
    #[arg(long)]
    pub(crate) seed: Option<u32>,
    /// Output path: X.exr writes the linear EXR (with method, spp, seed and
    /// time in its header) and an sRGB X.png beside it; X.png writes only
    /// the PNG. Default: out/<scene>-<integrator>.exr.
    #[arg(short, long)]
    pub(crate) output: Option<PathBuf>,
    /// Render at this fraction of the scene's film size (same camera), e.g. 0.25.
    #[arg(long, default_value_t = 1.0)]
    pub(crate) scale: f32,
    /// Reference EXR to measure RelMSE, MSE, MAE and FLIP against (same
    /// size as the render).
    #[arg(long)]
    pub(crate) reference: Option<PathBuf>,
    // The help lists the registry's kinds (lights::registry::REGISTRY).
    #[arg(long, value_name = "NAME", help = super::sampler_help(
        "Light sampler of a many_light scene, overriding its [integrand] sampler",
        " (an error for other integrands; docs/light-sampling.md)",
    ))]
    pub(crate) sampler: Option<SamplerKind>,
    /// How shadow rays are answered, overriding the scene's [integrand]
    /// visibility: bvh (exact) or voxel (the constant-time voxelization
    /// array of Wang, Meng & Popescu; approximate, built on the GPU from
    /// the scene's voxel_directions, voxel_resolution and voxel_skip).
    #[arg(long, value_name = "BACKEND")]
    pub(crate) visibility: Option<VisibilityKind>,
    #[command(flatten)]
    pub(crate) cuts: CutArgs,
    /// Render once untimed first, so that the printed times are warm:
    /// CPU drivers (lavapipe) compile a pipeline at its first dispatch,
    /// inside the GPU timestamps of a cold render.
    #[arg(long)]
    pub(crate) warmup: bool,
    /// Render a sequence of frames of a many_light scene: A..B (B
    /// excluded) or A..=B. Frame f is at scene time `time + f ·
    /// frame_duration` of the scene's [integrand] and rotates its random
    /// choices; the lights, the light tree (or BVH, grid) and the cuts are
    /// made again every frame (tree2 sorts its bottom levels once, in
    /// object space), all else is reused. Writes X.NNNN.exr (and
    /// .png) per frame for -o X.exr, and X.frames.csv with every frame's
    /// set-up (light build, cuts, VPLs) and render times. The seed is the
    /// same every frame.
    #[arg(long, value_name = "A..B", value_parser = FrameRange::parse)]
    pub(crate) frames: Option<FrameRange>,
    /// Scene time between frames, overriding the scene's [integrand]
    /// frame_duration (default 1/30); only with --frames.
    #[arg(long, value_name = "T")]
    pub(crate) frame_duration: Option<f32>,
    #[command(flatten)]
    pub(crate) mdas: MdasArgs,
}

/// What `render --json` prints.
#[derive(serde::Serialize)]
struct RenderRecord {
    scene: String,
    method: &'static str,
    width: u32,
    height: u32,
    seed: u32,
    spp: f64,
    samples: u64,
    nonfinite_samples: u64,
    nonfinite_pixels: usize,
    time_ms: f64,
    phases_ms: Vec<(String, f64)>,
    clock: &'static str,
    gpu_bytes: u64,
    #[serde(skip_serializing_if = "Option::is_none")]
    error: Option<ErrorRecord>,
    files: Vec<String>,
    provenance: mdas::provenance::Provenance,
}

/// Error against `--reference`.
#[derive(serde::Serialize)]
struct ErrorRecord {
    reference: String,
    relmse: f64,
    mse: f64,
    mae: f64,
    flip: f64,
    nonfinite_pixels: u64,
}

pub(crate) fn run(args: RenderArgs, ui: Ui) -> Result<()> {
    // Fail on bad input before any GPU work.
    check_sampling(args.integrator, args.spp, &args.mdas)?;
    if args.frame_duration.is_some() {
        bail!("--frame-duration sets the time between frames; it needs --frames");
    }
    let RenderArgs {
        scene,
        integrator,
        spp,
        seed,
        output,
        scale,
        reference,
        sampler,
        visibility,
        cuts,
        warmup,
        frames: _,
        frame_duration: _,
        mdas,
    } = args;
    let output = output.unwrap_or_else(|| default_output(&scene, integrator.name()));
    check_output(&output)?;
    let inputs: Vec<&Path> = std::iter::once(scene.as_path())
        .chain(reference.as_deref())
        .collect();
    check_not_input(&output, &inputs)?;
    let loaded = SceneFile::load(&scene)?;
    warn_unlit(&loaded);
    let film = session::scaled_film(loaded.scene.film, scale)?;
    let reference_image = match &reference {
        Some(r) => Some(read_reference(r, film)?),
        None => None,
    };
    // Again, now that the scene's meshes and material libraries have been
    // read: -o must not name any of them either.
    check_output(&output)?;
    let gpu = Gpu::shared()?;
    let overrides = IntegrandOverrides {
        sampler,
        visibility,
        frame: None,
        cut_size: cuts.cut_size,
        cut_sampling: cuts.cut_sampling,
    };
    if let mdas::accel::Visibility::Voxel(p) = overrides.visibility(&loaded) {
        // The array is built with the scene upload: seconds to minutes on
        // a CPU driver for a large scene.
        ui.note(format!(
            "building the voxel visibility array ({}) for {} triangles…",
            p.describe(),
            loaded.scene.triangle_count()
        ));
    }
    let prepared = session::prepare_loaded(gpu, loaded, &scene, scale, overrides)?;
    debug_assert_eq!(film, prepared.film);
    // A bar once the render has taken a second (Halton then waits for the
    // GPU every few dispatches to report; MDAS reads its state anyway).
    let bar = ui.delayed_bar(
        1000,
        "render {bar:40} {percent}% [{elapsed_precise} < {eta}]",
    );
    let mdas_params = mdas.params(prepared.scene.mdas, scale, spp, seed);
    let (mut sampler, seed) = integrator_for(
        integrator,
        spp,
        seed,
        mdas_params,
        ui.progress().then_some(&bar),
    )?;
    let mut light_sampler = session::light_sampler(&prepared.scene.integrand)
        .map_or_else(String::new, |k| format!(", sampler {k}"));
    if prepared.scene.visibility.is_voxel() {
        light_sampler += &format!(", shadows {}", prepared.scene.visibility.describe());
    }
    ui.note(format!(
        "{}: {}×{} px, {} triangles, integrand {} ({}D{light_sampler}), {}, adapter {}",
        scene.display(),
        film.width,
        film.height,
        prepared.scene.scene.triangle_count(),
        prepared.integrand.name(),
        prepared.integrand.dims(),
        integrator.name(),
        gpu.info.name
    ));
    if integrator == IntegratorKind::Mdas {
        ui.note(describe_grid(mdas_params, film, prepared.integrand.dims())?);
        if let Some(w) = slow_selection_warning(&mdas_params) {
            eprintln!("warning: {w}");
        }
    }
    if warmup {
        sampler.render(gpu, prepared.integrand.as_ref())?;
    }
    let render = sampler.render(gpu, prepared.integrand.as_ref())?;
    bar.finish();
    ui.result(render_line(&render));
    warn_image(&render);
    if !warmup && gpu.info.device_type == wgpu::DeviceType::Cpu {
        ui.note(
            "(cold: this CPU driver compiles pipelines at their first dispatch, inside these times; --warmup or `mdas bench` time warm renders)",
        );
    }
    let mut error = None;
    if let Some(ref_image) = reference_image {
        let (w, h) = (film.width, film.height);
        let e = metrics::compare(&render.image, &ref_image)?;
        let flip = metrics::flip(
            &render.image,
            &ref_image,
            w,
            h,
            metrics::DEFAULT_PIXELS_PER_DEGREE,
        )?;
        ui.result(format!(
            "RelMSE {:.6e}  MSE {:.6e}  MAE {:.6e}  FLIP {:.4}  non-finite pixels {}\n",
            e.relmse, e.mse, e.mae, flip.mean, e.nonfinite_pixels
        ));
        error = Some(ErrorRecord {
            reference: reference
                .as_ref()
                .map_or_else(String::new, |r| r.display().to_string()),
            relmse: e.relmse,
            mse: e.mse,
            mae: e.mae,
            flip: flip.mean,
            nonfinite_pixels: e.nonfinite_pixels,
        });
    }
    let attributes = session::render_attributes(integrator.name(), seed, &render, &scene);
    let files = session::write_outputs_with(&output, film, &render.image, &attributes)?;
    let names: Vec<String> = files.iter().map(|f| f.display().to_string()).collect();
    ui.note(format!("wrote {}", names.join(" and ")));
    ui.json(&RenderRecord {
        scene: scene.display().to_string(),
        method: integrator.name(),
        width: film.width,
        height: film.height,
        seed,
        spp: render.samples as f64 / (f64::from(film.width) * f64::from(film.height)),
        samples: render.samples,
        nonfinite_samples: render.nonfinite,
        nonfinite_pixels: render.nonfinite_pixels(),
        time_ms: render.times.total(),
        phases_ms: render.times.0.clone(),
        clock: render.clock.name(),
        gpu_bytes: render.gpu_bytes,
        error,
        files: names,
        provenance: mdas::provenance::Provenance::new(
            gpu,
            &scene,
            prepared.integrand.as_ref(),
            (integrator == IntegratorKind::Mdas).then_some(mdas_params),
        )?,
    })
}

/// The checks of --integrator, --spp and the MDAS flags that need no file.
pub(crate) fn check_sampling(
    integrator: IntegratorKind,
    spp: Option<f32>,
    mdas: &MdasArgs,
) -> Result<()> {
    let ignored = mdas.given();
    if integrator != IntegratorKind::Mdas && !ignored.is_empty() {
        bail!(
            "{} set{} MDAS parameters, but --integrator is {}; add --integrator mdas",
            ignored.join(", "),
            if ignored.len() == 1 { "s" } else { "" },
            integrator.name()
        );
    }
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
    Ok(())
}

/// The integrator of `render`, with its seed (Halton: `seed` or 0; MDAS:
/// `params.seed`), reporting its progress in `bar` when given.
pub(crate) fn integrator_for(
    integrator: IntegratorKind,
    spp: Option<f32>,
    seed: Option<u32>,
    params: MdasParams,
    bar: Option<&DelayedBar>,
) -> Result<(Box<dyn Integrator>, u32)> {
    Ok(match integrator {
        IntegratorKind::Halton => {
            let seed = seed.unwrap_or(0);
            let mut h = Halton::new(spp.map_or(16, |s| s as u32), seed);
            if let Some(b) = bar {
                let b = b.clone();
                h = h.with_progress(Box::new(move |done, spp| {
                    b.advance(done as u64 * 1000 / spp.max(1) as u64)
                }));
            }
            (Box::new(h), seed)
        }
        IntegratorKind::Mdas => {
            let mut m = Mdas::new(params)?;
            if let Some(b) = bar {
                let b = b.clone();
                m = m.with_progress(Box::new(move |done, budget| {
                    b.advance(done.min(budget) * 1000 / budget.max(1))
                }));
            }
            (Box::new(m), params.seed)
        }
        IntegratorKind::Adaptive => {
            let seed = seed.unwrap_or(0);
            let params = AdaptiveParams::new(spp.map_or(16.0, |s| s as f64), seed);
            (Box::new(AdaptiveHalton::new(params)?), seed)
        }
    })
}

/// MDAS's initial grid and the parameters that shape it, from the
/// configuration the render itself resolves for `film` (an automatic grid
/// is chosen there).
pub(crate) fn describe_grid(
    params: MdasParams,
    film: mdas::film::Film,
    dims: u32,
) -> Result<String> {
    let cfg = Config::new(params, dims, film, MAX_ITERATIONS_DEFAULT)?;
    let p = cfg.params;
    let cells = 1u64 << (p.bits_per_dim + p.extra_image_bits).min(31);
    Ok(format!(
        "MDAS grid{}: {cells}×{cells} film cells of {:.2}×{:.2} px (b = {}, e = {}), l = {} samples per cell ({:.0} % of the budget), m = {}, α = {}, reconstruction {} (κ = {})",
        if p.auto_grid { " (automatic)" } else { "" },
        film.width as f64 / cells as f64,
        film.height as f64 / cells as f64,
        p.bits_per_dim,
        p.extra_image_bits,
        p.initial_samples_per_cell,
        100.0 * f64::from(cfg.initial_samples) / f64::from(cfg.budget.max(1)),
        p.max_samples_per_leaf,
        p.alpha,
        p.reconstruction,
        p.pixel_prior,
    ))
}

/// A large α under the paper's selection rule (`pace = 0`) takes few
/// leaves per iteration, so the render runs many small iterations (α = 64
/// on a 16×12 film at 8 spp: about 1,000, seconds where α = 1/4 takes
/// milliseconds; issue 54 item 3). The paced selection keeps α's order
/// of leaves in a few iterations.
pub(crate) fn slow_selection_warning(p: &mdas::integrator::mdas::MdasParams) -> Option<String> {
    (p.pace == 0.0 && p.alpha > 4.0).then(|| {
        format!(
            "alpha = {} with pace = 0 (the paper's selection rule) takes few leaves per iteration: \
             expect many small adaptive iterations; --pace 0.5 takes half the samples left per iteration",
            p.alpha
        )
    })
}

/// Warnings about the image itself: every pixel 0, and pixels that are
/// not finite (an accumulation that overflowed shows here even when every
/// sample was finite).
pub(crate) fn warn_image(render: &Render) {
    if render.image.iter().all(|p| *p == [0.0; 3]) {
        eprintln!("warning: every pixel of the image is 0 (black)");
    }
    let bad = render.nonfinite_pixels();
    if bad > 0 {
        eprintln!(
            "warning: {bad} pixel(s) are not finite ({} non-finite samples)",
            render.nonfinite
        );
    }
}

fn render_line(render: &Render) -> String {
    let phases: Vec<String> = render
        .times
        .0
        .iter()
        .map(|(n, t)| format!("{n} {t:.2} ms"))
        .collect();
    format!(
        "{} samples ({:.2} spp) in {:.2} ms ({}; {:?}), {:.3} Msamples/s, {} non-finite samples, {:.1} MiB GPU",
        render.samples,
        render.samples as f64 / (render.film.width as f64 * render.film.height as f64),
        render.times.total(),
        phases.join(", "),
        render.clock,
        render.samples as f64 / render.times.total().max(1e-9) / 1e3,
        render.nonfinite,
        render.gpu_bytes as f64 / 1048576.0
    ) + "\n"
}
