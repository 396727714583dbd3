//! `mdas compare` from the library: load a scene file, compare MDAS with
//! Halton at equal time against a cached Halton reference, write the
//! report, images and figure, and print the table.
//!
//! ```text
//! cargo run --release --example compare_scene [SCENE] [OUT_DIR] [SCALE] [REF_SPP]
//! ```
//!
//! Defaults: `scenes/cornell.toml`, `out/compare_scene`, a quarter of the
//! film and a 4,096-spp reference (`make run`'s comparison). The reference
//! is cached under `.cache/references/` like the CLI's, so a second run
//! reuses it.

use anyhow::{Context, Result};
use mdas::compare::{compare, report, Budget, CompareSpec, Setup};
use mdas::gpu::Gpu;
use mdas::session::mdas_params_at_scale;
use std::path::PathBuf;

fn main() -> Result<()> {
    let mut args = std::env::args().skip(1);
    let scene = PathBuf::from(args.next().unwrap_or_else(|| "scenes/cornell.toml".into()));
    let out = PathBuf::from(args.next().unwrap_or_else(|| "out/compare_scene".into()));
    let scale: f32 = match args.next() {
        Some(s) => s.parse().context("SCALE must be a number")?,
        None => 0.25,
    };
    let ref_spp: u32 = match args.next() {
        Some(s) => s.parse().context("REF_SPP must be a whole number")?,
        None => 4096,
    };

    let gpu = Gpu::shared()?;
    // The scene's `[mdas]` table is written for its full film: at a smaller
    // scale the initial grid loses film bits as the CLI's `--scale` does.
    let at_scale = move |p| mdas_params_at_scale(p, scale);
    let setup = Setup {
        scene,
        scale,
        ref_spp,
        ref_seed: 1,
        cache_dir: PathBuf::from(".cache/references"),
        halton_seed: 0,
        repeats: 3,
        out: out.clone(),
        progress: true,
        mdas_params: &at_scale,
        frame: None,
    };
    let report = compare(gpu, &CompareSpec::new(setup, Budget::MdasSpp))?;
    print!("{}", report::table(&report));
    println!(
        "wrote {}/ (figure.png, report.json, images and heat maps)",
        out.display()
    );
    Ok(())
}
