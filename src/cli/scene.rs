//! `mdas scene`: scene-file tools. `mdas scene random` writes a random,
//! untuned scene for one integrand ([`mdas::scene_gen`]).

use super::*;
use mdas::scene_gen::{GenIntegrand, GenOptions};

#[derive(clap::Args)]
pub(crate) struct SceneArgs {
    #[command(subcommand)]
    pub(crate) command: SceneCommand,
}

#[derive(Subcommand)]
pub(crate) enum SceneCommand {
    /// Generate a random scene file for an integrand, the same for the
    /// same seed (docs/scene-format.md, "Generated scenes").
    #[command(
        long_about = "Generate a random, valid scene file for an integrand: a ground \
        (plane or heightfield) and 2–40 boxes, spheres, quads, disks and heightfield patches of \
        sizes spanning 20×, some thin (posts, planks, fins, rails), in plain and checkered \
        materials; a camera placed to see them; a black or coloured background; and the lights \
        the integrand takes (area_light: quad lights, large and dim, tiny and bright or in view; \
        depth_of_field and motion_blur: point and directional lights, sometimes one dominant, \
        with a thin lens focused on an object or keyframed motion over the shutter; path: area, \
        point and directional lights or a room lit indirectly, 1–4 bounces; ambient_occlusion: \
        an occlusion radius; many_light: 16–2000 lights of the many-light list). No [mdas] \
        table.\n\n\
        The same --integrand, --seed, --width and --height give the same text, byte for byte, on \
        every machine (a generator of its own, not `rand`; the version in the file's header \
        changes when the output of a seed does). Without -o the TOML goes to stdout; with -o it \
        is written atomically (a temporary file beside it, then a rename), and a path that \
        exists and is not a regular file (a directory, FIFO or device) is refused."
    )]
    Random(RandomArgs),
}

#[derive(clap::Args)]
pub(crate) struct RandomArgs {
    /// The integrand the scene is made for: its [integrand] type and the
    /// lights, lens, motion or radius it takes.
    #[arg(long, value_name = "TYPE", value_parser = integrand_parser())]
    pub(crate) integrand: GenIntegrand,
    /// Seed of the scene: each seed is another scene.
    #[arg(long)]
    pub(crate) seed: u64,
    /// Film width in pixels ([film] width; the camera frames the objects
    /// at width/height).
    #[arg(long, default_value_t = GenOptions::default().width,
          value_parser = clap::value_parser!(u32).range(1..=mdas::scene_file::MAX_FILM_SIDE))]
    pub(crate) width: u32,
    /// Film height in pixels ([film] height).
    #[arg(long, default_value_t = GenOptions::default().height,
          value_parser = clap::value_parser!(u32).range(1..=mdas::scene_file::MAX_FILM_SIDE))]
    pub(crate) height: u32,
    /// Write the scene to FILE (atomically; its directory is created if
    /// needed) instead of stdout.
    #[arg(short, long, value_name = "FILE")]
    pub(crate) output: Option<PathBuf>,
}

/// The integrand names as clap's possible values (listed by `--help`).
fn integrand_parser() -> impl clap::builder::TypedValueParser<Value = GenIntegrand> {
    use clap::builder::TypedValueParser;
    clap::builder::PossibleValuesParser::new(GenIntegrand::names())
        .map(|name| name.parse::<GenIntegrand>().expect("a listed name"))
}

/// What `scene random --json` prints.
#[derive(serde::Serialize)]
struct RandomRecord {
    integrand: &'static str,
    seed: u64,
    width: u32,
    height: u32,
    generator_version: u32,
    /// The file written, or null when the scene went to stdout.
    output: Option<String>,
    /// The scene's text when it was not written to a file.
    toml: Option<String>,
}

pub(crate) fn run(args: SceneArgs, ui: Ui) -> Result<()> {
    match args.command {
        SceneCommand::Random(args) => random(args, ui),
    }
}

fn random(args: RandomArgs, ui: Ui) -> Result<()> {
    let RandomArgs {
        integrand,
        seed,
        width,
        height,
        output,
    } = args;
    if u64::from(width) * u64::from(height) > mdas::scene_file::MAX_FILM_PIXELS as u64 {
        bail!(
            "a {width}×{height} film has more than the {} pixels a scene may have",
            mdas::scene_file::MAX_FILM_PIXELS
        );
    }
    let opts = GenOptions { width, height };
    let text = mdas::scene_gen::random_scene(integrand, seed, &opts);
    if let Some(path) = &output {
        check_scene_output(path)?;
        ensure_parent(path)?;
        mdas::atomic::write_atomic(path, |tmp| Ok(std::fs::write(tmp, text.as_bytes())?))?;
        ui.note(format!(
            "wrote {} ({integrand} scene, seed {seed}, {width}×{height})",
            path.display()
        ));
    } else if !ui.json {
        ui.result(&text);
    }
    ui.json(&RandomRecord {
        integrand: integrand.name(),
        seed,
        width,
        height,
        generator_version: mdas::scene_gen::GENERATOR_VERSION,
        output: output.as_ref().map(|p| p.display().to_string()),
        toml: output.is_none().then_some(text),
    })
}

/// Refuses to replace anything but a regular file (or a link to one): a
/// rename over a directory fails late, and one over a FIFO or a device
/// would silently swap a special file for a scene.
fn check_scene_output(path: &Path) -> Result<()> {
    match std::fs::metadata(path) {
        Ok(meta) if !meta.is_file() => {
            let what = if meta.is_dir() {
                "a directory"
            } else {
                "not a regular file (a FIFO, socket or device)"
            };
            bail!(
                "cannot write {}: it exists and is {what}; choose another -o",
                path.display()
            )
        }
        _ => Ok(()),
    }
}
