//! The command line: clap types shared by the subcommands, one module per
//! subcommand (its arguments and its `run`), and small helpers for output
//! paths. `main.rs` only parses and dispatches.

pub(crate) mod bench;
pub(crate) mod compare;
pub(crate) mod frames;
pub(crate) mod reference;
pub(crate) mod render;
pub(crate) mod scene;
pub(crate) mod sweep;
pub(crate) mod tune;
pub(crate) mod view;

pub(crate) use anyhow::{bail, Result};
pub(crate) use clap::{Parser, Subcommand, ValueEnum};
pub(crate) use indicatif::{ProgressBar, ProgressStyle};
pub(crate) use mdas::accel::voxel::VisibilityKind;
pub(crate) use mdas::gpu::Gpu;
use mdas::integrator::mdas::params::{Kind, Param};
pub(crate) use mdas::integrator::mdas::MdasParams;
use mdas::integrator::mdas::PARAMS;
pub(crate) use mdas::integrator::{
    AdaptiveHalton, AdaptiveParams, Halton, Integrator, Mdas, Render,
};
pub(crate) use mdas::lights::registry::SamplerKind;
pub(crate) use mdas::lights::sampler::CutSampling;
pub(crate) use mdas::scene_file::SceneFile;
pub(crate) use mdas::session::{self, IntegrandOverrides, ReferenceSpec};
pub(crate) use mdas::{image_io, metrics};
pub(crate) use std::path::{Path, PathBuf};

#[derive(Parser)]
#[command(
    name = "mdas",
    version,
    about = "GPU multidimensional adaptive sampling and Halton QMC renderer (wgpu/WGSL)",
    long_about = "Renders TOML scenes by Monte Carlo integration on the GPU (any wgpu adapter: a \
                  real GPU, or Mesa's lavapipe CPU driver) and measures error against references.\n\n\
                  Conventions (README.md, docs/): a pixel's value is the mean radiance over its \
                  footprint; images are linear RGB in EXR (a sRGB PNG is written beside for eyes); \
                  RelMSE = mean over pixels and channels of (x − ref)² / (ref² + 0.01).\n\n\
                  Output: results go to stdout, progress bars and notes to stderr. --json makes \
                  stdout one JSON document (every subcommand); --quiet drops bars and notes.\n\n\
                  Environment: MDAS_ADAPTER=<substring> picks an adapter by name; WGPU_BACKEND \
                  restricts backends (e.g. vulkan).\n\n\
                  Input limits: a scene file ≤ 16 MiB, an OBJ ≤ 1 GiB and an MTL ≤ 64 MiB (regular files); a film \
                  side ≤ 16384 and ≤ 2^26 pixels; a scene ≤ 2^25 triangles in all, at most 16 sharing \
                  one centre; a Mitsuba scene ≤ 256 documents and 16 MiB with its includes, and \
                  ≤ 16 MiB of $parameter text; ≤ 2^24 light-set lights; coordinates within ±1e9; an EXR read ≤ 2^28 \
                  pixels. Outputs land whole or not at all (an interrupt removes partial ones)."
)]
pub(crate) struct Cli {
    /// Print the result as one JSON document on stdout (human-readable
    /// text moves to stderr).
    #[arg(long, global = true)]
    pub(crate) json: bool,
    /// No progress bars and no notes; results, warnings and errors only.
    #[arg(short, long, global = true)]
    pub(crate) quiet: bool,
    #[command(subcommand)]
    pub(crate) command: Command,
}

/// Where output goes (`--json`, `--quiet`): results on stdout, notes and
/// progress on stderr.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Ui {
    pub(crate) json: bool,
    pub(crate) quiet: bool,
}

impl Ui {
    /// A note (what is being done, where files went): stderr, unless quiet.
    pub(crate) fn note(&self, text: impl std::fmt::Display) {
        if !self.quiet {
            eprintln!("{text}");
        }
    }

    /// The human-readable result: stdout, or stderr under --json (where
    /// stdout holds the JSON document); shown under --quiet too, unless
    /// --json is given as well.
    pub(crate) fn result(&self, text: impl std::fmt::Display) {
        if !self.json {
            to_stdout(&text.to_string());
        } else if !self.quiet {
            eprint!("{text}");
        }
    }

    /// The JSON document, under --json.
    pub(crate) fn json(&self, value: &impl serde::Serialize) -> Result<()> {
        if self.json {
            to_stdout(&(serde_json::to_string_pretty(value)? + "\n"));
        }
        Ok(())
    }

    /// Whether to draw progress bars.
    pub(crate) fn progress(&self) -> bool {
        !self.quiet
    }

    /// A bar of `len` steps drawn only once the work has taken a second
    /// (short renders stay silent); `advance(done)` moves it.
    pub(crate) fn delayed_bar(&self, len: u64, template: &str) -> DelayedBar {
        let bar = ProgressBar::hidden();
        bar.set_length(len);
        bar.set_style(ProgressStyle::with_template(template).expect("valid template"));
        DelayedBar {
            bar,
            start: std::time::Instant::now(),
            enabled: self.progress(),
        }
    }
}

/// Writes to stdout; a closed pipe (`mdas info | head -1`) ends the
/// output quietly instead of panicking as `print!` would.
fn to_stdout(text: &str) {
    use std::io::Write;
    let mut out = std::io::stdout().lock();
    if let Err(e) = out.write_all(text.as_bytes()).and_then(|()| out.flush()) {
        if e.kind() != std::io::ErrorKind::BrokenPipe {
            eprintln!("error: cannot write to stdout: {e}");
        }
    }
}

/// See [`Ui::delayed_bar`].
#[derive(Clone)]
pub(crate) struct DelayedBar {
    bar: ProgressBar,
    start: std::time::Instant,
    enabled: bool,
}

impl DelayedBar {
    pub(crate) fn advance(&self, done: u64) {
        if self.enabled
            && self.bar.is_hidden()
            && self.start.elapsed() > std::time::Duration::from_secs(1)
        {
            self.bar
                .set_draw_target(indicatif::ProgressDrawTarget::stderr());
        }
        self.bar.set_position(done);
    }

    pub(crate) fn finish(&self) {
        self.bar.finish_and_clear();
    }
}

#[derive(Clone, Copy, Debug, PartialEq, ValueEnum)]
pub(crate) enum IntegratorKind {
    /// Halton quasi-Monte Carlo with per-pixel Cranley–Patterson shifts.
    Halton,
    /// Multidimensional adaptive sampling (parameters from the scene's [mdas] table).
    Mdas,
    /// Per-pixel adaptive Halton with Blender Cycles' rule (noise threshold
    /// 0.01, 64 samples before a check every 16, at most 4096 a pixel);
    /// --spp is the average budget per pixel, as MDAS's.
    Adaptive,
}

impl IntegratorKind {
    pub(crate) fn name(self) -> &'static str {
        match self {
            IntegratorKind::Halton => "halton",
            IntegratorKind::Mdas => "mdas",
            IntegratorKind::Adaptive => "adaptive",
        }
    }
}

/// Frames `start .. start + count`, from `A..B` (B excluded) or `A..=B`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct FrameRange {
    pub(crate) start: u32,
    /// At least 1.
    pub(crate) count: u32,
}

impl FrameRange {
    /// Parses `A..B` or `A..=B` (whole numbers, a non-empty range).
    pub(crate) fn parse(text: &str) -> std::result::Result<FrameRange, String> {
        let (a, b, inclusive) = if let Some((a, b)) = text.split_once("..=") {
            (a, b, true)
        } else if let Some((a, b)) = text.split_once("..") {
            (a, b, false)
        } else {
            return Err(format!(
                "expected A..B (frames A to B − 1) or A..=B, e.g. 0..512; got '{text}'"
            ));
        };
        let number = |s: &str| {
            s.trim()
                .parse::<u32>()
                .map_err(|_| format!("'{s}' is not a frame number (0..=4294967295) in '{text}'"))
        };
        let (a, b) = (number(a)?, number(b)?);
        let end = u64::from(b) + u64::from(inclusive);
        if end <= u64::from(a) {
            return Err(format!("'{text}' holds no frame"));
        }
        let count = u32::try_from(end - u64::from(a))
            .map_err(|_| format!("'{text}' holds more than 2^32 − 1 frames"))?;
        Ok(FrameRange { start: a, count })
    }

    pub(crate) fn iter(self) -> impl Iterator<Item = u32> {
        (0..self.count).map(move |i| self.start + i)
    }
}

/// Overrides of the scene's `[mdas]` table (MDAS paper §5.1): one flag per
/// tunable key of the registry ([`mdas::integrator::mdas::PARAMS`]), with
/// its doc line and range as `--help`.
#[derive(Clone, Debug, Default)]
pub(crate) struct MdasArgs {
    /// The flags given, with their values, in registry order.
    values: Vec<(&'static Param, f64)>,
}

/// The flags' `--help` heading.
const MDAS_HEADING: &str = "MDAS parameters (override the scene's [mdas] table)";

impl clap::Args for MdasArgs {
    fn augment_args(cmd: clap::Command) -> clap::Command {
        PARAMS.iter().filter(|p| p.tunable).fold(cmd, |cmd, p| {
            let value_name = match p.kind {
                Kind::Int => "N",
                Kind::Number => "X",
                Kind::Rule(_) => "RULE",
            };
            let parser = move |s: &str| -> Result<f64, String> {
                let v = p.parse(s)?;
                if p.kind == Kind::Int && (v.fract() != 0.0 || v < 0.0 || v > f64::from(u32::MAX)) {
                    return Err(format!("'{s}' is not a whole number ≥ 0"));
                }
                Ok(v)
            };
            let arg = clap::Arg::new(p.key)
                .long(p.key.replace('_', "-"))
                .value_name(value_name)
                .help(match p.kind {
                    Kind::Rule(_) => format!("{} [scene default: {}]", p.doc, p.default_text()),
                    _ => format!(
                        "{} [{}; scene default: {}]",
                        p.doc,
                        p.range_text(),
                        p.default_text()
                    ),
                })
                .help_heading(MDAS_HEADING);
            let arg = match p.kind {
                Kind::Rule(names) => arg.value_parser(clap::builder::TypedValueParser::map(
                    clap::builder::PossibleValuesParser::new(names),
                    move |s: String| names.iter().position(|&n| n == s).unwrap_or(0) as f64,
                )),
                _ => arg.value_parser(parser),
            };
            cmd.arg(arg)
        })
    }

    fn augment_args_for_update(cmd: clap::Command) -> clap::Command {
        Self::augment_args(cmd)
    }
}

impl clap::FromArgMatches for MdasArgs {
    fn from_arg_matches(matches: &clap::ArgMatches) -> Result<Self, clap::Error> {
        let values = PARAMS
            .iter()
            .filter(|p| p.tunable)
            .filter_map(|p| matches.get_one::<f64>(p.key).map(|&v| (p, v)))
            .collect();
        Ok(MdasArgs { values })
    }

    fn update_from_arg_matches(&mut self, matches: &clap::ArgMatches) -> Result<(), clap::Error> {
        *self = Self::from_arg_matches(matches)?;
        Ok(())
    }
}

impl MdasArgs {
    /// The flags given, by name (`--alpha`, …).
    pub(crate) fn given(&self) -> Vec<String> {
        self.values.iter().map(|(p, _)| p.flag()).collect()
    }

    /// The scene's parameters (adjusted for `scale`) with the flags applied
    /// (a flag of the initial grid fixes the grid: `auto_grid` off).
    pub(crate) fn params(
        &self,
        scene: MdasParams,
        scale: f32,
        spp: Option<f32>,
        seed: Option<u32>,
    ) -> MdasParams {
        let mut p = session::mdas_params_at_scale(scene, scale);
        for &(param, v) in &self.values {
            param.set(&mut p, v);
        }
        MdasParams {
            spp: spp.unwrap_or(p.spp),
            seed: seed.unwrap_or(p.seed),
            ..p
        }
    }
}

#[derive(Subcommand)]
pub(crate) enum Command {
    /// Render a scene and write OUT.exr (linear) and OUT.png (sRGB), or only
    /// OUT.png with `-o OUT.png`.
    Render(render::RenderArgs),
    /// Render (or fetch from the cache) a high-spp Halton reference image;
    /// with --part I/N, only the I-th share of its samples (for a job
    /// array; `mdas merge` joins the parts).
    Reference(reference::ReferenceArgs),
    /// Join the parts of a run into what one process writes: a reference's
    /// (`mdas reference --part I/N -o PART.exr`) into its cache entry,
    /// within f32 rounding; a sweep's or a search's (`mdas sweep|tune
    /// --part I/N --out DIR`) into sweep.json or tune.json in -o, equal
    /// field for field but the measured times. Refuses parts of different
    /// runs, a part given twice, a missing part or a damaged file, and then
    /// writes nothing.
    Merge(reference::MergeArgs),
    /// MDAS against Halton at equal time: images, RelMSE heat maps, MDAS
    /// sample density, figure.png and report.json in --out
    /// (docs/comparisons.md).
    /// With --samplers: light samplers of a many_light scene against each
    /// other under Halton at MDAS+tree's time (halton-<sampler> and
    /// mdas-tree images, RelMSE heat maps, report.json).
    Compare(compare::CompareArgs),
    /// RelMSE against time for MDAS and Halton over a range of budgets:
    /// sweep.csv and a log-log plot, sweep.svg and sweep.png, in --out.
    Sweep(sweep::SweepArgs),
    /// MDAS over a grid of [mdas] values (α, ε, sf, ...), each over seeds,
    /// against Halton at equal samples and at equal time: a ranked table
    /// with intervals and bias, the best as an [mdas] table, tune.json and
    /// tune.csv in --out (docs/comparisons.md).
    Tune(tune::TuneArgs),
    /// Time MDAS against Halton at the same sample count, phase by phase:
    /// one warm-up render each, then interleaved rounds; medians of GPU
    /// time per phase and of the wall clock (a Markdown table on stdout).
    Bench(bench::BenchArgs),
    /// Print the GPU adapter, backend, features in use and key limits.
    Info,
    /// Scene-file tools: `scene random` generates a random scene for an integrand, the same per seed.
    Scene(scene::SceneArgs),
    /// Write index.html again in an output directory of compare, sweep or
    /// tune: one self-contained page (images, maps, figures, provenance)
    /// to open in a browser (docs/comparisons.md).
    View(view::ViewArgs),
    /// Print a shell completion script on stdout, generated from these
    /// definitions: `mdas completions bash > /etc/bash_completion.d/mdas`,
    /// `mdas completions zsh > ~/.zfunc/_mdas`, `mdas completions fish >
    /// ~/.config/fish/completions/mdas.fish`.
    Completions {
        #[arg(value_enum)]
        shell: clap_complete::Shell,
    },
    /// Print the man page (roff) on stdout, generated from these
    /// definitions: `mdas man > mdas.1 && man ./mdas.1`.
    Man,
}

/// The film scale and the reference of an experiment (`compare`, `sweep`,
/// `tune`).
#[derive(clap::Args, Debug)]
pub(crate) struct ReferenceArgs {
    /// Render at this fraction of the scene's film size (same camera);
    /// the reference uses the same scale.
    #[arg(long, default_value_t = 1.0)]
    pub(crate) scale: f32,
    /// Samples per pixel of the Halton reference.
    #[arg(long, default_value_t = 65536, value_parser = clap::value_parser!(u32).range(1..))]
    pub(crate) ref_spp: u32,
    /// Seed of the reference (differs from the compared Halton's by default,
    /// so their errors are independent; `mdas reference` renders with the
    /// same default, so a reference made ahead of time is found).
    #[arg(long, default_value_t = mdas::session::DEFAULT_REFERENCE_SEED)]
    pub(crate) ref_seed: u32,
    /// Reference cache directory (as `mdas reference --cache`).
    #[arg(long, default_value = ".cache/references")]
    pub(crate) cache: PathBuf,
}

impl ReferenceArgs {
    /// The experiment's [`mdas::compare::Setup`] with these.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn setup<'a>(
        &self,
        ui: Ui,
        scene: PathBuf,
        out: PathBuf,
        halton_seed: u32,
        repeats: u32,
        mdas_params: &'a dyn Fn(MdasParams) -> MdasParams,
    ) -> mdas::compare::Setup<'a> {
        mdas::compare::Setup {
            scene,
            scale: self.scale,
            ref_spp: self.ref_spp,
            ref_seed: self.ref_seed,
            cache_dir: self.cache.clone(),
            halton_seed,
            repeats,
            out,
            progress: ui.progress(),
            mdas_params,
            frame: None,
        }
    }
}

/// Options shared by `compare` and `sweep`.
#[derive(clap::Args, Debug)]
pub(crate) struct ExperimentArgs {
    #[command(flatten)]
    pub(crate) reference: ReferenceArgs,
    /// Seed of the compared renders (default: 0 for Halton, the scene's
    /// [mdas] seed for MDAS).
    #[arg(long)]
    pub(crate) seed: Option<u32>,
    /// Timed runs per measurement, after one warm-up. A sweep's times and
    /// a budget search's runs are medians of them; compare's equal-time
    /// target comes from max(repeats, 9) interleaved rounds of MDAS and
    /// the bracketing Halton budgets, each method's fastest round.
    #[arg(long, default_value_t = 3)]
    pub(crate) repeats: u32,
    /// Largest spp a budget search may try (at least 1). When a search
    /// cannot reach the target time within it, the report says the times
    /// are not equal.
    #[arg(long, default_value_t = 65536,
          value_parser = clap::value_parser!(u32).range(1..))]
    pub(crate) max_spp: u32,
    /// Output directory. Default: out/compare-<scene> (sweep: out/sweep-<scene>).
    #[arg(long)]
    pub(crate) out: Option<PathBuf>,
    #[command(flatten)]
    pub(crate) mdas: MdasArgs,
}

impl ExperimentArgs {
    /// The shared inputs of `compare` and `sweep`.
    pub(crate) fn setup<'a>(
        &self,
        ui: Ui,
        scene: PathBuf,
        out: PathBuf,
        mdas_params: &'a dyn Fn(MdasParams) -> MdasParams,
    ) -> mdas::compare::Setup<'a> {
        self.reference.setup(
            ui,
            scene,
            out,
            self.seed.unwrap_or(0),
            self.repeats,
            mdas_params,
        )
    }
}

pub(crate) fn default_dir(scene: &Path, what: &str) -> PathBuf {
    let stem = scene
        .file_stem()
        .and_then(|s| s.to_str())
        .unwrap_or("scene");
    PathBuf::from("out").join(format!("{what}-{stem}"))
}

pub(crate) fn default_output(scene: &Path, integrator: &str) -> PathBuf {
    let stem = scene
        .file_stem()
        .and_then(|s| s.to_str())
        .unwrap_or("render");
    PathBuf::from("out").join(format!("{stem}-{integrator}.exr"))
}

/// An output must be an `.exr` or `.png` path whose directory exists or
/// can be made and is writable, and whose files are not directories.
pub(crate) fn check_output(path: &Path) -> Result<()> {
    let (exr, png) = session::output_files(path)?;
    ensure_parent(path)?;
    for file in exr.iter().chain([&png]) {
        mdas::atomic::check_writable(file)?;
    }
    Ok(())
}

/// Refuses an output that would overwrite one of the run's inputs (`render
/// scene.exr -o scene.exr`, or `-o` naming the `--reference`).
pub(crate) fn check_not_input(output: &Path, inputs: &[&Path]) -> Result<()> {
    let (exr, png) = session::output_files(output)?;
    for file in exr.iter().chain([&png]) {
        // The directory exists (check_output); the file may not yet.
        let canonical = |p: &Path| {
            let dir = p.parent().filter(|d| !d.as_os_str().is_empty());
            let dir = dir.unwrap_or(Path::new(".")).canonicalize().ok()?;
            Some(dir.join(p.file_name()?))
        };
        for input in inputs {
            if canonical(file).is_some() && canonical(file) == canonical(input) {
                bail!(
                    "output {} would overwrite the input {}; choose another -o",
                    file.display(),
                    input.display()
                );
            }
        }
    }
    Ok(())
}

/// Prints the scene's warnings: what loading ignored (textures of OBJ
/// materials) and an integrand that can see no light.
pub(crate) fn warn_unlit(scene: &SceneFile) {
    for w in scene
        .warnings
        .iter()
        .cloned()
        .chain(scene.integrand.light_warnings(&scene.scene))
    {
        eprintln!("warning: {w}");
    }
}

/// A `--reference` EXR, read and checked against the film before any GPU
/// work: the right size and finite everywhere (an error against a NaN
/// pixel is not a measurement).
pub(crate) fn read_reference(path: &Path, film: mdas::film::Film) -> Result<Vec<[f32; 3]>> {
    let (w, h, image) = image_io::read_exr(path)?;
    if (w, h) != (film.width, film.height) {
        bail!(
            "reference {} is {w}×{h} but the render is {}×{} (use the same --scale as the reference)",
            path.display(),
            film.width,
            film.height
        );
    }
    let bad = image
        .iter()
        .filter(|p| !p.iter().all(|c| c.is_finite()))
        .count();
    if bad > 0 {
        bail!(
            "reference {} has {bad} non-finite pixel(s); a reference must be finite everywhere",
            path.display()
        );
    }
    Ok(image)
}

pub(crate) fn ensure_parent(path: &Path) -> Result<()> {
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        if !dir.exists() {
            std::fs::create_dir_all(dir).map_err(|e| {
                anyhow::anyhow!("cannot create output directory {}: {e}", dir.display())
            })?;
        }
    }
    Ok(())
}

/// `--sampler`'s help: `lead`, every kind of the registry with its few
/// words, `tail`.
pub(crate) fn sampler_help(lead: &str, tail: &str) -> String {
    format!("{lead}: {}{tail}", SamplerKind::help())
}

/// The kinds with cuts, comma-separated.
fn cut_kinds() -> String {
    SamplerKind::ALL
        .into_iter()
        .filter(|k| k.uses_cut())
        .map(|k| k.name())
        .collect::<Vec<_>>()
        .join(", ")
}

/// Light-cut overrides of a many_light scene's [integrand] (`render`,
/// `compare`).
#[derive(clap::Args, Clone, Copy, Debug, Default)]
pub(crate) struct CutArgs {
    // The kinds with cuts come from the registry (lights::registry::REGISTRY).
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u32).range(1..=64), help = format!(
        "Light-cut size n of a many_light scene (1..=64), overriding its [integrand] cut_size; \
         the kinds with cuts ({}) under --cut-sampling subtrees draw n light samples per \
         evaluation",
        cut_kinds()
    ))]
    pub(crate) cut_size: Option<u32>,
    /// How the kinds with cuts sample the cut, overriding the scene's
    /// cut_sampling: subtrees (one light from each subtree of the cut,
    /// summed: real-time stochastic lightcuts) or mixture (one light per
    /// evaluation from the cut's mixture: an ablation).
    #[arg(long, value_name = "RULE")]
    pub(crate) cut_sampling: Option<CutSampling>,
}
