//! `mdas reference`: a high-spp Halton reference, cached.

use super::*;

#[derive(clap::Args)]
pub(crate) struct ReferenceArgs {
    /// Scene file (TOML).
    pub(crate) scene: PathBuf,
    /// Samples per pixel of the reference (at least 1).
    #[arg(long, default_value_t = 65536, value_parser = clap::value_parser!(u32).range(1..))]
    pub(crate) spp: u32,
    /// Render at this fraction of the scene's film size (same camera).
    #[arg(long, default_value_t = 1.0)]
    pub(crate) scale: f32,
    /// Seed of the reference's random shifts.
    #[arg(long, default_value_t = 0)]
    pub(crate) seed: u32,
    /// Cache directory; references are keyed by a hash of the scene file and these parameters.
    #[arg(long, default_value = ".cache/references")]
    pub(crate) cache: PathBuf,
    /// Also copy the reference to this EXR path (and a PNG beside it).
    #[arg(short, long)]
    pub(crate) output: Option<PathBuf>,
    /// Light sampler of a many_light scene, overriding its [integrand]
    /// sampler (an error for other integrands). Every sampler converges
    /// to the same image; a sampler other than the scene's is part of
    /// the cache key. `mdas compare` always uses the scene's own.
    #[arg(long, value_name = "NAME")]
    pub(crate) sampler: Option<SamplerKind>,
}

pub(crate) fn run(args: ReferenceArgs) -> Result<()> {
    let ReferenceArgs {
        scene,
        spp,
        scale,
        seed,
        cache,
        output,
        sampler,
    } = args;
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
