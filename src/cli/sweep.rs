//! `mdas sweep`: RelMSE against time over a range of budgets.

use super::*;

#[derive(clap::Args)]
pub(crate) struct SweepArgs {
    /// Scene file: TOML, or a Mitsuba 3 XML file (.xml; the subset in docs/scene-format.md).
    pub(crate) scene: PathBuf,
    /// Budgets, samples per pixel, for every method (MDAS budgets below
    /// its initial sample count are skipped; pixel-adaptive Halton's is
    /// the average it may spend).
    #[arg(long, value_delimiter = ',', default_value = "1,2,4,8,16,32")]
    pub(crate) spps: Vec<u32>,
    /// Seeds per point (MDAS from its seed on, Halton from --seed on,
    /// skipping the reference's): each point's RelMSE is their mean, with
    /// a 95% interval drawn as an error bar; the time is the first seed's.
    #[arg(long, default_value_t = 3, value_parser = clap::value_parser!(u32).range(1..=64))]
    pub(crate) seeds: u32,
    /// Measure only part I of N: points ⌊(I−1)·P/N⌋ up to ⌊I·P/N⌋ of the
    /// P points (MDAS's budgets, then Halton's, then adaptive's), written as
    /// sweep-part.json in --out (required); `mdas merge` joins the N parts
    /// into the sweep one process writes (scripts/slurm/).
    #[arg(long, value_name = "I/N", requires = "out")]
    pub(crate) part: Option<session::parts::Part>,
    /// The methods swept, comma-separated: halton and mdas always;
    /// adaptive (pixel-adaptive Halton, `render --integrator adaptive`'s
    /// defaults, Halton's seeds) unless left out (`--methods halton,mdas`).
    #[arg(
        long,
        value_name = "NAMES",
        value_delimiter = ',',
        default_value = "halton,mdas,adaptive"
    )]
    pub(crate) methods: Vec<IntegratorKind>,
    #[command(flatten)]
    pub(crate) common: ExperimentArgs,
}

pub(crate) fn run(args: SweepArgs, ui: Ui) -> Result<()> {
    let SweepArgs {
        scene,
        spps,
        seeds,
        part,
        methods,
        common,
    } = args;
    super::compare::check_methods(&methods)?;
    let out = common
        .out
        .clone()
        .unwrap_or_else(|| default_dir(&scene, "sweep"));
    let mdas_params = |p: MdasParams| {
        common
            .mdas
            .params(p, common.reference.scale, None, common.seed)
    };
    let spec = mdas::compare::sweep::SweepSpec {
        setup: common.setup(ui, scene, out.clone(), &mdas_params),
        spps,
        seeds,
        adaptive: methods.contains(&IntegratorKind::Adaptive),
    };
    if let Some(part) = part {
        let record = mdas::compare::sweep::sweep_part(Gpu::shared()?, &spec, part)?;
        ui.result(mdas::compare::sweep::csv(&record.result.rows));
        ui.note(format!(
            "wrote part {}/{} (points {}..{} of {}) to {}",
            part.index,
            part.count,
            record.first,
            record.end,
            record.points.len(),
            out.join(mdas::compare::sweep::PART_FILE).display()
        ));
        return ui.json(&record);
    }
    let result = mdas::compare::sweep::sweep(Gpu::shared()?, &spec)?;
    ui.result(mdas::compare::sweep::csv(&result.rows));
    if !result.mdas_skipped.is_empty() {
        ui.note(format!(
            "MDAS skipped at spp {:?} (below its initial sample count)",
            result.mdas_skipped
        ));
    }
    ui.note(format!(
        "wrote sweep.csv, sweep.json, sweep.svg, sweep.png and index.html to {}",
        out.display()
    ));
    ui.json(&result)
}
