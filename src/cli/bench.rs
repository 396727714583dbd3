//! `mdas bench`: MDAS against Halton at equal samples, phase by phase.

use super::*;

#[derive(clap::Args)]
pub(crate) struct BenchArgs {
    /// Scene files: TOML, or Mitsuba 3 XML (.xml; the subset in docs/scene-format.md).
    #[arg(required = true)]
    pub(crate) scenes: Vec<PathBuf>,
    /// Render at this fraction of each scene's film size.
    #[arg(long, default_value_t = 0.25)]
    pub(crate) scale: f32,
    /// Samples per pixel for both methods (default: the scene's [mdas]
    /// spp, which must then be a whole number).
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..))]
    pub(crate) spp: Option<u32>,
    /// Timed rounds (one MDAS and one Halton render each) after the warm-up.
    #[arg(long, default_value_t = 3, value_parser = clap::value_parser!(u32).range(1..))]
    pub(crate) repeats: u32,
    /// Also write the figures as JSON to this file (`--json` prints them).
    #[arg(long, value_name = "FILE")]
    pub(crate) json_out: Option<PathBuf>,
}

pub(crate) fn run(args: BenchArgs, ui: Ui) -> Result<()> {
    let BenchArgs {
        scenes,
        scale,
        spp,
        repeats,
        json_out,
    } = args;
    // Before any GPU work: every scene is a readable file (not only the
    // first), and --json-out can be written and names none of them (nor
    // a directory, a FIFO or a device).
    for scene in &scenes {
        match std::fs::metadata(scene) {
            Ok(meta) if meta.is_file() => mdas::atomic::note_input(scene),
            Ok(_) => bail!("cannot read {}: not a regular file", scene.display()),
            Err(e) => bail!("cannot read {}: {e}", scene.display()),
        }
    }
    if let Some(path) = &json_out {
        ensure_parent(path)?;
        mdas::atomic::check_writable(path)?;
    }
    let gpu = Gpu::shared()?;
    ui.note(format!("adapter {}", gpu.info.name));
    let mut rows = Vec::new();
    for scene in &scenes {
        ui.note(format!(
            "{}: warm-up, then {repeats} interleaved rounds",
            scene.display()
        ));
        rows.push(mdas::compare::phases::bench_scene(
            gpu, scene, scale, spp, repeats,
        )?);
    }
    ui.result(mdas::compare::phases::table(&rows));
    if let Some(path) = &json_out {
        let text = serde_json::to_string_pretty(&rows)?;
        image_io::write_atomic(path, |tmp| Ok(std::fs::write(tmp, &text)?))?;
        ui.note(format!("wrote {}", path.display()));
    }
    ui.json(&rows)
}
