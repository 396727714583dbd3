//! `mdas` command-line interface. Run `mdas --help`.

use anyhow::{bail, Result};
use clap::{Parser, Subcommand, ValueEnum};
use indicatif::{ProgressBar, ProgressStyle};
use mdas::app::IntegrandOverrides;
use mdas::app::{self, ReferenceSpec};
use mdas::gpu::Gpu;
use mdas::integrator::mdas::MdasParams;
use mdas::integrator::{Halton, Integrator, Mdas, Render};
use mdas::lights::sampler::SamplerKind;
use mdas::{compare, image_io, metrics};
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

#[derive(Clone, Copy, Debug, PartialEq, ValueEnum)]
enum IntegratorKind {
    /// Halton quasi-Monte Carlo with per-pixel Cranley–Patterson shifts.
    Halton,
    /// Multidimensional adaptive sampling (parameters from the scene's [mdas] table).
    Mdas,
}

impl IntegratorKind {
    fn name(self) -> &'static str {
        match self {
            IntegratorKind::Halton => "halton",
            IntegratorKind::Mdas => "mdas",
        }
    }
}

/// Overrides of the scene's `[mdas]` table (MDAS paper §5.1).
#[derive(clap::Args, Debug, Default)]
struct MdasArgs {
    /// MDAS: Morton bits per dimension of the initial grid (b).
    #[arg(long)]
    bits_per_dim: Option<u32>,
    /// MDAS: extra Morton bits of the two film axes (e). Without it, the
    /// scene's e is lowered by round(log2(1/F)) at --scale F.
    #[arg(long)]
    extra_image_bits: Option<u32>,
    /// MDAS: samples per initial grid cell (l).
    #[arg(long)]
    initial_samples_per_cell: Option<u32>,
    /// MDAS: scale sf of the film axes in the sampling domain (not the film --scale).
    #[arg(long)]
    scale_factor: Option<f32>,
    /// MDAS: exponent α of the stochastic leaf selection (E/E_max)^α ≥ ξ.
    #[arg(long)]
    alpha: Option<f32>,
    /// MDAS: best-candidate tries per inserted sample.
    #[arg(long)]
    candidates: Option<u32>,
    /// MDAS: samples a leaf holds before it splits.
    #[arg(long)]
    max_samples_per_leaf: Option<u32>,
}

impl MdasArgs {
    /// The scene's parameters (adjusted for `scale`) with the flags applied.
    fn params(
        &self,
        scene: MdasParams,
        scale: f32,
        spp: Option<f32>,
        seed: Option<u32>,
    ) -> MdasParams {
        let p = app::mdas_params_at_scale(scene, scale);
        MdasParams {
            bits_per_dim: self.bits_per_dim.unwrap_or(p.bits_per_dim),
            extra_image_bits: self.extra_image_bits.unwrap_or(p.extra_image_bits),
            initial_samples_per_cell: self
                .initial_samples_per_cell
                .unwrap_or(p.initial_samples_per_cell),
            scale_factor: self.scale_factor.unwrap_or(p.scale_factor),
            alpha: self.alpha.unwrap_or(p.alpha),
            candidates: self.candidates.unwrap_or(p.candidates),
            max_samples_per_leaf: self.max_samples_per_leaf.unwrap_or(p.max_samples_per_leaf),
            spp: spp.unwrap_or(p.spp),
            seed: seed.unwrap_or(p.seed),
        }
    }
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
        /// Samples per pixel. Halton: a whole number in 1..=2^24 (default 16); MDAS: the
        /// average budget, may be fractional (default: the scene's [mdas] spp).
        #[arg(long)]
        spp: Option<f32>,
        /// Random seed; same seed, same image on one adapter (default: 0 for
        /// Halton, the scene's [mdas] seed for MDAS).
        #[arg(long)]
        seed: Option<u32>,
        /// Output EXR path (the PNG goes beside it). Default: out/<scene>-<integrator>.exr.
        #[arg(short, long)]
        output: Option<PathBuf>,
        /// Render at this fraction of the scene's film size (same camera), e.g. 0.25.
        #[arg(long, default_value_t = 1.0)]
        scale: f32,
        /// Reference EXR to measure RelMSE and MSE against (same size as the render).
        #[arg(long)]
        reference: Option<PathBuf>,
        /// Light sampler of a many_light scene, overriding its [integrand]
        /// sampler: uniform, power, tree_nocut, tree, unbalanced or
        /// unbalanced_nocut (an error for other integrands).
        #[arg(long, value_name = "NAME")]
        sampler: Option<SamplerKind>,
        /// Render once untimed first, so that the printed times are warm:
        /// CPU drivers (lavapipe) compile a pipeline at its first dispatch,
        /// inside the GPU timestamps of a cold render.
        #[arg(long)]
        warmup: bool,
        #[command(flatten)]
        mdas: MdasArgs,
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
        /// Light sampler of a many_light scene, overriding its [integrand]
        /// sampler (an error for other integrands). Every sampler converges
        /// to the same image; a sampler other than the scene's is part of
        /// the cache key. `mdas compare` always uses the scene's own.
        #[arg(long, value_name = "NAME")]
        sampler: Option<SamplerKind>,
    },
    /// MDAS against Halton at equal time: images, RelMSE heat maps, MDAS
    /// sample density and report.json in --out (DESIGN.md "Equal time").
    /// With --samplers: light samplers of a many_light scene against each
    /// other under Halton at MDAS+tree's time (halton-<sampler> and
    /// mdas-tree images, RelMSE heat maps, report.json).
    Compare {
        /// Scene file (TOML).
        scene: PathBuf,
        /// MDAS samples per pixel (average, may be fractional; default: the
        /// scene's [mdas] spp). Its measured time is the equal-time target.
        #[arg(long, conflicts_with = "time_ms")]
        spp: Option<f32>,
        /// Instead of MDAS's time at --spp, give both methods (with
        /// --samplers: every method) this budget (milliseconds; every spp
        /// is searched).
        #[arg(long)]
        time_ms: Option<f64>,
        /// Light sampler of the compared renders of a many_light scene,
        /// overriding its [integrand] sampler (an error for other
        /// integrands); the reference keeps the scene's own.
        #[arg(long, value_name = "NAME", conflicts_with = "samplers")]
        sampler: Option<SamplerKind>,
        /// Compare these light samplers (comma-separated: uniform, power,
        /// tree_nocut, tree, unbalanced, unbalanced_nocut) under Halton at
        /// equal time; MDAS with `tree` sets the target (or --time-ms). The
        /// scene's integrand must be many_light.
        #[arg(long, value_name = "NAMES", value_delimiter = ',')]
        samplers: Option<Vec<SamplerKind>>,
        #[command(flatten)]
        common: CompareArgs,
        /// Also print report.json to stdout (the table goes to stderr).
        #[arg(long)]
        json: bool,
    },
    /// RelMSE against time for MDAS and Halton over a range of budgets:
    /// sweep.csv and a log-log plot, sweep.svg and sweep.png, in --out.
    Sweep {
        /// Scene file (TOML).
        scene: PathBuf,
        /// Budgets, samples per pixel, for both methods (MDAS budgets below
        /// its initial sample count are skipped).
        #[arg(long, value_delimiter = ',', default_value = "1,2,4,8,16,32")]
        spps: Vec<u32>,
        #[command(flatten)]
        common: CompareArgs,
    },
    /// Time MDAS against Halton at the same sample count, phase by phase:
    /// one warm-up render each, then interleaved rounds; medians of GPU
    /// time per phase and of the wall clock (a Markdown table on stdout).
    Bench {
        /// Scene files (TOML).
        #[arg(required = true)]
        scenes: Vec<PathBuf>,
        /// Render at this fraction of each scene's film size.
        #[arg(long, default_value_t = 0.25)]
        scale: f32,
        /// Samples per pixel for both methods (default: the scene's [mdas]
        /// spp, which must then be a whole number).
        #[arg(long, value_parser = clap::value_parser!(u32).range(1..))]
        spp: Option<u32>,
        /// Timed rounds (one MDAS and one Halton render each) after the warm-up.
        #[arg(long, default_value_t = 3, value_parser = clap::value_parser!(u32).range(1..))]
        repeats: u32,
        /// Also write the figures as JSON to this file.
        #[arg(long)]
        json: Option<PathBuf>,
    },
    /// Print the GPU adapter, backend, features in use and key limits.
    Info,
}

/// Options shared by `compare` and `sweep`.
#[derive(clap::Args, Debug)]
struct CompareArgs {
    /// Render at this fraction of the scene's film size (same camera);
    /// the reference uses the same scale.
    #[arg(long, default_value_t = 1.0)]
    scale: f32,
    /// Samples per pixel of the Halton reference.
    #[arg(long, default_value_t = 65536, value_parser = clap::value_parser!(u32).range(1..))]
    ref_spp: u32,
    /// Seed of the reference (differs from the compared Halton's by default,
    /// so their errors are independent).
    #[arg(long, default_value_t = 1)]
    ref_seed: u32,
    /// Reference cache directory (as `mdas reference --cache`).
    #[arg(long, default_value = ".cache/references")]
    cache: PathBuf,
    /// Seed of the compared renders (default: 0 for Halton, the scene's
    /// [mdas] seed for MDAS).
    #[arg(long)]
    seed: Option<u32>,
    /// Timed runs per measurement, after one warm-up; times are medians.
    #[arg(long, default_value_t = 3)]
    repeats: u32,
    /// Largest spp a budget search may try.
    #[arg(long, default_value_t = 65536)]
    max_spp: u32,
    /// Output directory. Default: out/compare-<scene> (sweep: out/sweep-<scene>).
    #[arg(long)]
    out: Option<PathBuf>,
    #[command(flatten)]
    mdas: MdasArgs,
}

impl CompareArgs {
    /// The shared inputs of `compare` and `sweep`.
    fn setup<'a>(
        &self,
        scene: PathBuf,
        out: PathBuf,
        mdas_params: &'a dyn Fn(MdasParams) -> MdasParams,
    ) -> compare::Setup<'a> {
        compare::Setup {
            scene,
            scale: self.scale,
            ref_spp: self.ref_spp,
            ref_seed: self.ref_seed,
            cache_dir: self.cache.clone(),
            halton_seed: self.seed.unwrap_or(0),
            repeats: self.repeats,
            out,
            progress: true,
            mdas_params,
        }
    }
}

fn main() -> ExitCode {
    quiet_headless_vulkan();
    match run(Cli::parse()) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::FAILURE
        }
    }
}

/// Mesa's Vulkan window-system code prints "error: XDG_RUNTIME_DIR is
/// invalid or not set" on headless machines although mdas needs no window
/// system. Give it a private, empty runtime directory when none is set.
/// Runs first in `main`, before any thread exists, as `set_var` requires.
fn quiet_headless_vulkan() {
    if std::env::var_os("XDG_RUNTIME_DIR").is_some() {
        return;
    }
    let user = std::env::var("USER").unwrap_or_default();
    let dir = std::env::temp_dir().join(format!("mdas-xdg-runtime-{user}"));
    #[cfg(unix)]
    {
        use std::os::unix::fs::DirBuilderExt;
        let made = std::fs::DirBuilder::new().mode(0o700).create(&dir);
        if made.is_ok() || dir.is_dir() {
            std::env::set_var("XDG_RUNTIME_DIR", &dir);
        }
    }
}

fn run(cli: Cli) -> Result<()> {
    match cli.command {
        Command::Compare {
            scene,
            spp,
            time_ms,
            sampler,
            samplers,
            common,
            json,
        } => {
            let out = common
                .out
                .clone()
                .unwrap_or_else(|| default_dir(&scene, "compare"));
            let mdas_params = |p: MdasParams| common.mdas.params(p, common.scale, spp, common.seed);
            let setup = common.setup(scene, out.clone(), &mdas_params);
            let budget = time_ms.map_or(compare::Budget::MdasSpp, compare::Budget::TimeMs);
            let report = match samplers {
                Some(samplers) => compare::compare_samplers(
                    Gpu::shared()?,
                    &compare::SamplersSpec {
                        setup,
                        budget,
                        max_spp: common.max_spp,
                        samplers,
                    },
                )?,
                None => compare::compare_with(
                    Gpu::shared()?,
                    &compare::CompareSpec {
                        setup,
                        budget,
                        max_spp: common.max_spp,
                    },
                    IntegrandOverrides { sampler },
                )?,
            };
            let table = compare::report::table(&report);
            if json {
                eprint!("{table}");
                println!("{}", serde_json::to_string_pretty(&report)?);
            } else {
                print!("{table}");
                println!("wrote {} files to {}", report.files.len(), out.display());
            }
            Ok(())
        }
        Command::Sweep {
            scene,
            spps,
            common,
        } => {
            let out = common
                .out
                .clone()
                .unwrap_or_else(|| default_dir(&scene, "sweep"));
            let mdas_params =
                |p: MdasParams| common.mdas.params(p, common.scale, None, common.seed);
            let spec = compare::sweep::SweepSpec {
                setup: common.setup(scene, out.clone(), &mdas_params),
                spps,
            };
            let result = compare::sweep::sweep(Gpu::shared()?, &spec)?;
            print!("{}", compare::sweep::csv(&result.rows));
            if !result.mdas_skipped.is_empty() {
                println!(
                    "MDAS skipped at spp {:?} (below its initial sample count)",
                    result.mdas_skipped
                );
            }
            println!(
                "wrote {}, {} and {}",
                out.join("sweep.csv").display(),
                out.join("sweep.svg").display(),
                out.join("sweep.png").display()
            );
            Ok(())
        }
        Command::Bench {
            scenes,
            scale,
            spp,
            repeats,
            json,
        } => {
            if let Some(path) = &json {
                ensure_parent(path)?;
            }
            let gpu = Gpu::shared()?;
            eprintln!("adapter {}", gpu.info.name);
            let mut rows = Vec::new();
            for scene in &scenes {
                eprintln!(
                    "{}: warm-up, then {repeats} interleaved rounds",
                    scene.display()
                );
                rows.push(compare::phases::bench_scene(
                    gpu, scene, scale, spp, repeats,
                )?);
            }
            print!("{}", compare::phases::table(&rows));
            if let Some(path) = &json {
                let text = serde_json::to_string_pretty(&rows)?;
                image_io::write_atomic(path, |tmp| Ok(std::fs::write(tmp, &text)?))?;
                eprintln!("wrote {}", path.display());
            }
            Ok(())
        }
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
            sampler,
            warmup,
            mdas,
        } => {
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
        Command::Reference {
            scene,
            spp,
            scale,
            seed,
            cache,
            output,
            sampler,
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
            let (film, image, path, cached) = app::reference_with(
                gpu,
                &scene,
                spec,
                IntegrandOverrides { sampler },
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

fn default_dir(scene: &Path, what: &str) -> PathBuf {
    let stem = scene
        .file_stem()
        .and_then(|s| s.to_str())
        .unwrap_or("scene");
    PathBuf::from("out").join(format!("{what}-{stem}"))
}

fn default_output(scene: &Path, integrator: &str) -> PathBuf {
    let stem = scene
        .file_stem()
        .and_then(|s| s.to_str())
        .unwrap_or("render");
    PathBuf::from("out").join(format!("{stem}-{integrator}.exr"))
}

/// An output must be an `.exr` path whose directory exists or can be made.
/// The largest Halton `--spp` of `render` (every whole number up to it is
/// exact in the f32 the flag is parsed as).
const MAX_HALTON_SPP: u32 = 1 << 24;

fn check_output(path: &Path) -> Result<()> {
    app::check_exr_path(path)?;
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
