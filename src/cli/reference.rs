//! `mdas reference`: a high-spp Halton reference, cached.

use super::*;

#[derive(clap::Args)]
pub(crate) struct ReferenceArgs {
    /// Scene file: TOML, or a Mitsuba 3 XML file (.xml; the subset in docs/scene-format.md).
    pub(crate) scene: PathBuf,
    /// Samples per pixel of the reference (at least 1).
    #[arg(long, default_value_t = 65536, value_parser = clap::value_parser!(u32).range(1..))]
    pub(crate) spp: u32,
    /// Render at this fraction of the scene's film size (same camera).
    #[arg(long, default_value_t = 1.0)]
    pub(crate) scale: f32,
    /// Seed of the reference's random shifts. The default is the one
    /// `compare`, `sweep` and `tune` look up (their --ref-seed), so they
    /// find this reference in the cache.
    #[arg(long, default_value_t = mdas::session::DEFAULT_REFERENCE_SEED)]
    pub(crate) seed: u32,
    /// Cache directory; references are keyed by a hash of the scene file (less its `[mdas]` table and comments) and these parameters.
    #[arg(long, default_value = ".cache/references")]
    pub(crate) cache: PathBuf,
    /// Also copy the reference to this path: X.exr (and an sRGB X.png beside
    /// it) or X.png only.
    #[arg(short, long)]
    pub(crate) output: Option<PathBuf>,
    /// Light sampler of a many_light scene, overriding its [integrand]
    /// sampler (an error for other integrands). Every sampler converges
    /// to the same image; a sampler other than the scene's is part of
    /// the cache key. `mdas compare` always uses the scene's own.
    #[arg(long, value_name = "NAME")]
    pub(crate) sampler: Option<SamplerKind>,
    /// How shadow rays are answered: bvh or voxel. References use the BVH
    /// unless this says voxel (then it is part of the cache key); a scene
    /// whose [integrand] asks for voxel visibility gets a BVH reference.
    #[arg(long, value_name = "BACKEND")]
    pub(crate) visibility: Option<VisibilityKind>,
    /// Render only part I of N: samples ⌊(I−1)·spp/N⌋ up to ⌊I·spp/N⌋ of
    /// every pixel, written to -o (required, an .exr) with an sRGB .png
    /// and a record (-o's .json) beside it, not to the cache; `mdas merge`
    /// joins the N parts into the cache entry the whole reference would
    /// have (scripts/slurm/).
    #[arg(long, value_name = "I/N", requires = "output")]
    pub(crate) part: Option<session::parts::Part>,
}

#[derive(clap::Args)]
pub(crate) struct MergeArgs {
    /// The parts of one run: a reference's EXR files (written by `mdas
    /// reference --part I/N -o`, each with its .json record beside it), or
    /// the output directories (or their sweep-part.json / tune-part.json)
    /// of `mdas sweep --part I/N` or `mdas tune --part I/N`.
    #[arg(required = true)]
    pub(crate) parts: Vec<PathBuf>,
    /// Cache directory to write a merged reference into (as `mdas
    /// reference --cache`).
    #[arg(long, default_value = ".cache/references")]
    pub(crate) cache: PathBuf,
    /// A reference: also copy the merged reference to this path, X.exr
    /// (and an sRGB X.png beside it) or X.png only. A sweep or tune: the
    /// output directory of the merged run (required).
    #[arg(short, long)]
    pub(crate) output: Option<PathBuf>,
}

/// `mdas merge`.
pub(crate) fn merge(args: MergeArgs, ui: Ui) -> Result<()> {
    let MergeArgs {
        parts,
        cache,
        output,
    } = args;
    use mdas::compare::merge::PartKind;
    match PartKind::of_all(&parts)? {
        PartKind::Reference => {}
        kind => {
            let Some(out) = output else {
                bail!("merging {kind:?} parts needs -o, the merged run's output directory");
            };
            if kind == PartKind::Sweep {
                let result = mdas::compare::merge::merge_sweep(&parts, &out)?;
                ui.result(mdas::compare::sweep::csv(&result.rows));
                ui.note(format!(
                    "merged {} parts: wrote sweep.csv, sweep.json, sweep.svg, sweep.png and index.html to {}",
                    parts.len(),
                    out.display()
                ));
                return ui.json(&result);
            }
            let report = mdas::compare::merge::merge_tune(&parts, &out)?;
            ui.result(mdas::compare::tune::table(&report));
            ui.note(format!(
                "merged {} parts: wrote tune.json, tune.csv and index.html to {}",
                parts.len(),
                out.display()
            ));
            return ui.json(&report);
        }
    }
    if let Some(out) = &output {
        check_output(out)?;
        let inputs: Vec<&Path> = parts.iter().map(PathBuf::as_path).collect();
        check_not_input(out, &inputs)?;
    }
    let (path, film, image) = session::parts::merge_parts(&parts, &cache)?;
    ui.result(format!(
        "reference {}×{} merged from {} parts: {}\n",
        film.width,
        film.height,
        parts.len(),
        path.display()
    ));
    let mut files = vec![path.display().to_string()];
    if let Some(out) = output {
        files.extend(
            session::write_outputs(&out, film, &image)?
                .iter()
                .map(|f| f.display().to_string()),
        );
    }
    ui.json(&serde_json::json!({
        "path": path.display().to_string(),
        "width": film.width,
        "height": film.height,
        "parts": parts.len(),
        "files": files,
    }))
}

/// What `reference --json` prints.
#[derive(serde::Serialize)]
struct ReferenceRecord {
    scene: String,
    width: u32,
    height: u32,
    spp: u32,
    seed: u32,
    scale: f32,
    path: String,
    cached: bool,
    /// The cache's record beside the EXR (written when rendered).
    record: String,
    files: Vec<String>,
}

pub(crate) fn run(args: ReferenceArgs, ui: Ui) -> Result<()> {
    let ReferenceArgs {
        scene,
        spp,
        scale,
        seed,
        cache,
        output,
        sampler,
        visibility,
        part,
    } = args;
    if let Some(out) = &output {
        check_output(out)?;
        check_not_input(out, &[&scene])?;
        // A part's EXR, PNG and record, refused now rather than after
        // its render (issue 67, hostile inputs class 6).
        if let Some(part) = part {
            session::parts::check_part(part, spp, out)?;
        }
    }
    let loaded = SceneFile::load(&scene)?;
    if let Some(out) = &output {
        // Again, now that the scene's meshes and material libraries have
        // been read: -o must not name any of them either (issue 54 item 1).
        check_output(out)?;
        if let Some(part) = part {
            session::parts::check_part(part, spp, out)?;
        }
    }
    let gpu = Gpu::shared()?;
    let bar = if ui.progress() {
        ProgressBar::new(spp as u64)
    } else {
        ProgressBar::hidden()
    };
    bar.set_style(
        ProgressStyle::with_template(
            "reference {bar:40} {pos}/{len} spp [{elapsed_precise} < {eta}]",
        )
        .expect("valid template"),
    );
    let b = bar.clone();
    let progress: Option<mdas::integrator::halton::Progress> =
        Some(Box::new(move |done, _| b.set_position(done as u64)));
    let spec = ReferenceSpec { spp, scale, seed };
    let overrides = IntegrandOverrides {
        sampler,
        visibility,
        ..IntegrandOverrides::default()
    };
    if let (Some(part), Some(out)) = (part, &output) {
        let (film, warnings) = session::parts::reference_part(
            gpu,
            loaded,
            &scene,
            spec,
            overrides,
            session::parts::PartJob {
                part,
                cache_dir: &cache,
                out,
            },
            progress,
        )?;
        bar.finish_and_clear();
        for w in &warnings {
            eprintln!("warning: {w}");
        }
        let range = part.range(spp);
        ui.result(format!(
            "reference part {}/{} ({}×{}, samples {}..{} of {spp}): {}\n",
            part.index,
            part.count,
            film.width,
            film.height,
            range.start,
            range.end,
            out.display()
        ));
        return ui.json(&serde_json::json!({
            "part": part.index,
            "parts": part.count,
            "first": range.start,
            "end": range.end,
            "path": out.display().to_string(),
            "record": session::reference_record_path(out).display().to_string(),
        }));
    }
    let session::Reference {
        film,
        image,
        path,
        cache: cache_use,
        warnings,
        notes,
    } = session::reference_of_loaded(gpu, loaded, &scene, spec, overrides, &cache, progress)?;
    bar.finish_and_clear();
    for w in warnings.iter().chain(&notes) {
        eprintln!("warning: {w}");
    }
    if let session::CacheUse::Rebuilt(why) = &cache_use {
        eprintln!(
            "warning: the cached reference {} was unusable ({why}); rendered it again",
            path.display()
        );
    }
    let cached = cache_use == session::CacheUse::Hit;
    ui.result(format!(
        "reference {}×{} at {spp} spp: {} ({})\n",
        film.width,
        film.height,
        path.display(),
        if cached { "cached" } else { "rendered" }
    ));
    let mut files = Vec::new();
    if let Some(out) = output {
        // The copy keeps the cache file's header attributes.
        let attributes = image_io::read_exr_attributes(&path)?;
        let attributes: Vec<(&str, image_io::ExrAttribute)> = attributes
            .iter()
            .map(|(n, v)| (n.as_str(), v.clone()))
            .collect();
        files = session::write_outputs_with(&out, film, &image, &attributes)?
            .iter()
            .map(|f| f.display().to_string())
            .collect();
        ui.note(format!("wrote {}", files.join(" and ")));
    }
    ui.json(&ReferenceRecord {
        scene: scene.display().to_string(),
        width: film.width,
        height: film.height,
        spp,
        seed,
        scale,
        path: path.display().to_string(),
        cached,
        record: session::reference_record_path(&path).display().to_string(),
        files,
    })
}
