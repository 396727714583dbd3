//! `mdas tune`: MDAS over a grid of `[mdas]` values against Halton.

use super::*;

#[derive(clap::Args)]
pub(crate) struct TuneArgs {
    /// Scene file: TOML, or a Mitsuba 3 XML file (.xml; the subset in docs/scene-format.md).
    pub(crate) scene: PathBuf,
    /// MDAS's budget, samples per pixel (default: the scene's [mdas] spp).
    #[arg(long)]
    pub(crate) spp: Option<f32>,
    /// A grid axis, KEY=V1,V2,... (repeatable; KEY is any [mdas] key with
    /// a flag under "MDAS parameters" below, in its TOML spelling, e.g.
    /// alpha=1,2 or split=extent,trimmed). Default:
    /// alpha=0,0.015625,0.0625,0.25 scale_factor=0.0625,0.25,1
    /// epsilon=0.01,0.1 (24 configurations). Keys not in the grid keep
    /// the scene's values (after --scale and the MDAS flags).
    #[arg(long, value_name = "KEY=V,...", value_parser = parse_grid)]
    pub(crate) grid: Vec<(String, Vec<f64>)>,
    /// Seeds per configuration and per Halton budget (MDAS from its seed
    /// on, Halton from --seed on, skipping the reference's).
    #[arg(long, default_value_t = 3, value_parser = clap::value_parser!(u32).range(1..=64))]
    pub(crate) seeds: u32,
    /// Rank by RelMSE at equal samples instead of the RelMSE ratio at
    /// equal time.
    #[arg(long)]
    pub(crate) equal_samples: bool,
    /// Measure only part I of N: work items ⌊(I−1)·W/N⌋ up to ⌊I·W/N⌋ of
    /// the W items (Halton's budgets, then the runnable configurations),
    /// written as tune-part.json in --out (required); `mdas merge` joins
    /// the N parts into the search one process writes (scripts/slurm/).
    #[arg(long, value_name = "I/N", requires = "out")]
    pub(crate) part: Option<session::parts::Part>,
    #[command(flatten)]
    pub(crate) reference: ReferenceArgs,
    /// First seed of Halton's renders (default 0).
    #[arg(long, default_value_t = 0)]
    pub(crate) seed: u32,
    /// Output directory (tune.json, tune.csv). Default: out/tune-<scene>.
    #[arg(long)]
    pub(crate) out: Option<PathBuf>,
    #[command(flatten)]
    pub(crate) mdas: MdasArgs,
}

fn parse_grid(s: &str) -> Result<(String, Vec<f64>), String> {
    mdas::compare::tune::parse_grid_entry(s).map_err(|e| format!("{e:#}"))
}

pub(crate) fn run(args: TuneArgs, ui: Ui) -> Result<()> {
    let TuneArgs {
        scene,
        spp,
        grid,
        seeds,
        equal_samples,
        part,
        reference,
        seed,
        out,
        mdas,
    } = args;
    let out = out.unwrap_or_else(|| default_dir(&scene, "tune"));
    let mdas_params = |p: MdasParams| mdas.params(p, reference.scale, spp, None);
    let grid = if grid.is_empty() {
        mdas::compare::tune::default_grid()
    } else {
        grid
    };
    let spec = mdas::compare::tune::TuneSpec {
        setup: reference.setup(ui, scene, out.clone(), seed, 1, &mdas_params),
        grid,
        seeds,
        equal_samples,
    };
    if let Some(part) = part {
        let record = mdas::compare::tune::tune_part(Gpu::shared()?, &spec, part)?;
        ui.note(format!(
            "wrote part {}/{} (items {}..{} of {}) to {}",
            part.index,
            part.count,
            record.first,
            record.end,
            record.head.budgets.len() + record.configurations.len(),
            out.join(mdas::compare::tune::PART_FILE).display()
        ));
        return ui.json(&record);
    }
    let report = mdas::compare::tune::tune(Gpu::shared()?, &spec)?;
    ui.result(mdas::compare::tune::table(&report));
    ui.note(format!(
        "wrote tune.json, tune.csv and index.html to {}",
        out.display()
    ));
    ui.json(&report)
}
