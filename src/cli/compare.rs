//! `mdas compare`: MDAS against Halton at equal time (or light samplers
//! against each other with `--samplers`).

use super::*;

#[derive(clap::Args)]
pub(crate) struct CompareArgs {
    /// Scene file (TOML).
    pub(crate) scene: PathBuf,
    /// MDAS samples per pixel (average, may be fractional; default: the
    /// scene's [mdas] spp). Its measured time is the equal-time target.
    #[arg(long, conflicts_with = "time_ms")]
    pub(crate) spp: Option<f32>,
    /// Instead of MDAS's time at --spp, give both methods (with
    /// --samplers: every method) this budget (milliseconds; every spp
    /// is searched).
    #[arg(long)]
    pub(crate) time_ms: Option<f64>,
    /// Light sampler of the compared renders of a many_light scene,
    /// overriding its [integrand] sampler (an error for other
    /// integrands); the reference keeps the scene's own.
    #[arg(long, value_name = "NAME", conflicts_with = "samplers")]
    pub(crate) sampler: Option<SamplerKind>,
    /// How the compared renders' shadow rays are answered, overriding the
    /// scene's [integrand] visibility: bvh or voxel (approximate; its
    /// bias then shows against the reference, which always uses the BVH).
    #[arg(long, value_name = "BACKEND", conflicts_with = "samplers")]
    pub(crate) visibility: Option<VisibilityKind>,
    /// Compare these light samplers (comma-separated: uniform, power,
    /// tree_nocut, tree, tree_cone, unbalanced, unbalanced_nocut,
    /// unbalanced_nocone, sst, sst_nosub, lgh) under Halton at
    /// equal time; MDAS with `tree` sets the target (or --time-ms). The
    /// scene's integrand must be many_light.
    #[arg(long, value_name = "NAMES", value_delimiter = ',')]
    pub(crate) samplers: Option<Vec<SamplerKind>>,
    /// Seeds per method (MDAS from its seed on, Halton from --seed on,
    /// skipping the reference's): the report gives each method's mean
    /// RelMSE with a 95% interval, its bias and variance, and the ratio's
    /// interval. Not with --samplers (one seed each there).
    #[arg(long, default_value_t = 3, conflicts_with = "samplers",
          value_parser = clap::value_parser!(u32).range(1..=64))]
    pub(crate) seeds: u32,
    /// Inset of the figure, as x,y,w,h in film pixels (repeatable; default:
    /// two insets where the methods' errors differ most).
    #[arg(long, value_name = "X,Y,W,H", value_parser = parse_crop, conflicts_with = "samplers")]
    pub(crate) crop: Vec<mdas::compare::figure::Crop>,
    /// Also render MDAS-uniform (α = 0, one candidate: MDAS's grid and
    /// reconstruction without value-driven sampling) at MDAS's spp and
    /// seeds, and report what adaptivity buys (RelMSE MDAS/MDAS-uniform).
    #[arg(long, conflicts_with = "samplers")]
    pub(crate) uniform: bool,
    #[command(flatten)]
    pub(crate) common: ExperimentArgs,
}

fn parse_crop(s: &str) -> Result<mdas::compare::figure::Crop, String> {
    mdas::compare::figure::Crop::parse(s).map_err(|e| format!("{e:#}"))
}

pub(crate) fn run(args: CompareArgs, ui: Ui) -> Result<()> {
    let CompareArgs {
        scene,
        spp,
        time_ms,
        sampler,
        visibility,
        samplers,
        seeds,
        crop,
        uniform,
        common,
    } = args;
    let out = common
        .out
        .clone()
        .unwrap_or_else(|| default_dir(&scene, "compare"));
    let mdas_params = |p: MdasParams| {
        common
            .mdas
            .params(p, common.reference.scale, spp, common.seed)
    };
    let setup = common.setup(ui, scene, out.clone(), &mdas_params);
    let budget = time_ms.map_or(
        mdas::compare::Budget::MdasSpp,
        mdas::compare::Budget::TimeMs,
    );
    let report = match samplers {
        Some(samplers) => mdas::compare::compare_samplers(
            Gpu::shared()?,
            &mdas::compare::SamplersSpec {
                setup,
                budget,
                max_spp: common.max_spp,
                samplers,
            },
        )?,
        None => mdas::compare::compare_with(
            Gpu::shared()?,
            &mdas::compare::CompareSpec {
                setup,
                budget,
                max_spp: common.max_spp,
                seeds,
                crops: crop,
                uniform,
            },
            IntegrandOverrides {
                sampler,
                visibility,
            },
        )?,
    };
    ui.result(mdas::compare::report::table(&report));
    ui.note(format!(
        "wrote {} files to {}",
        report.files.len(),
        out.display()
    ));
    ui.json(&report)
}
