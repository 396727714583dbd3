//! `mdas sweep`: RelMSE against time over a range of budgets.

use super::*;

#[derive(clap::Args)]
pub(crate) struct SweepArgs {
    /// Scene file (TOML).
    pub(crate) scene: PathBuf,
    /// Budgets, samples per pixel, for both methods (MDAS budgets below
    /// its initial sample count are skipped).
    #[arg(long, value_delimiter = ',', default_value = "1,2,4,8,16,32")]
    pub(crate) spps: Vec<u32>,
    #[command(flatten)]
    pub(crate) common: ExperimentArgs,
}

pub(crate) fn run(args: SweepArgs) -> Result<()> {
    let SweepArgs {
        scene,
        spps,
        common,
    } = args;
    let out = common
        .out
        .clone()
        .unwrap_or_else(|| default_dir(&scene, "sweep"));
    let mdas_params = |p: MdasParams| common.mdas.params(p, common.scale, None, common.seed);
    let spec = mdas::compare::sweep::SweepSpec {
        setup: common.setup(scene, out.clone(), &mdas_params),
        spps,
    };
    let result = mdas::compare::sweep::sweep(Gpu::shared()?, &spec)?;
    print!("{}", mdas::compare::sweep::csv(&result.rows));
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
