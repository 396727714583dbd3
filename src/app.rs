//! What the CLI does, as library functions (so tests can call them):
//! setting up a scene on the GPU, rendering, references with a cache, and
//! writing outputs.

use crate::accel::voxel::{Visibility, VisibilityKind};
use crate::accel::GpuScene;
use crate::film::Film;
use crate::gpu::Gpu;
use crate::image_io;
use crate::integrand::{
    AmbientOcclusion, AreaLight, DepthOfField, Integrand, ManyLight, MotionBlur, PathTracing,
};
use crate::integrand::{IntegrandSpec, ManyLightSpec};
use crate::integrator::mdas::MdasParams;
use crate::integrator::{Halton, Integrator, Render};
use crate::lights::sampler::SamplerKind;
use crate::scene_file::SceneFile;
use anyhow::{bail, Context, Result};
use sha2::{Digest, Sha256};
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// The film of a `--scale F` render: each side scaled and rounded, at
/// least one pixel. The camera is unchanged, so pixels cover more of the
/// scene.
pub fn scaled_film(film: Film, scale: f32) -> Result<Film> {
    if !(scale.is_finite() && scale > 0.0 && scale <= 16.0) {
        bail!("--scale must be in (0, 16], got {scale}");
    }
    let side = |n: u32| ((n as f64 * scale as f64).round() as u32).max(1);
    Ok(Film {
        width: side(film.width),
        height: side(film.height),
    })
}

/// The scene's MDAS parameters for a `--scale F` render. The initial grid
/// has 2^e cells per film axis (e = `extra_image_bits`) whatever the film
/// size, so at a reduced scale e is lowered by round(log2(1/F)) (at least
/// 0) to keep the same number of initial cells per pixel. An automatic
/// grid (`auto_grid`) is left as it is: each render chooses it for its own
/// film.
pub fn mdas_params_at_scale(params: MdasParams, scale: f32) -> MdasParams {
    if params.auto_grid {
        return params;
    }
    let reduce = (1.0 / scale as f64).log2().round().max(0.0) as u32;
    MdasParams {
        extra_image_bits: params.extra_image_bits.saturating_sub(reduce),
        ..params
    }
}

/// Builds the scene's GPU representation and its integrand over `film`.
/// Shadow rays use `file.visibility`.
pub fn integrand_for(gpu: &Gpu, file: &SceneFile, film: Film) -> Result<Box<dyn Integrand>> {
    let gpu_scene = Arc::new(GpuScene::with_visibility(
        gpu,
        &file.scene,
        film,
        file.visibility,
    )?);
    integrand_on(gpu, file, gpu_scene, film)
}

/// The integrand of `file.integrand` over an already uploaded scene
/// (`gpu_scene` must be `file.scene`'s upload for `film`), so several integrands
/// (e.g. one per light sampler) can share one BVH.
pub fn integrand_on(
    gpu: &Gpu,
    file: &SceneFile,
    gpu_scene: Arc<GpuScene>,
    film: Film,
) -> Result<Box<dyn Integrand>> {
    Ok(match &file.integrand {
        IntegrandSpec::AreaLight => Box::new(AreaLight::new(gpu_scene, film)),
        IntegrandSpec::DepthOfField => Box::new(DepthOfField::new(gpu_scene, film)),
        IntegrandSpec::MotionBlur => Box::new(MotionBlur::new(gpu_scene, film)),
        IntegrandSpec::PathTracing { max_bounces } => {
            Box::new(PathTracing::new(gpu_scene, film, *max_bounces)?)
        }
        IntegrandSpec::AmbientOcclusion { radius } => {
            Box::new(AmbientOcclusion::new(gpu_scene, film, *radius)?)
        }
        IntegrandSpec::ManyLight(spec) => {
            Box::new(ManyLight::new(gpu, &file.scene, gpu_scene, film, spec)?)
        }
    })
}

/// The light sampler of a `many_light` integrand, `None` for other types.
pub fn light_sampler(spec: &IntegrandSpec) -> Option<SamplerKind> {
    match spec {
        IntegrandSpec::ManyLight(m) => Some(m.sampler),
        _ => None,
    }
}

/// Command-line overrides of a scene's `[integrand]` table.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct IntegrandOverrides {
    /// `--sampler`: the light sampler of a `many_light` integrand.
    pub sampler: Option<SamplerKind>,
    /// `--visibility`: how shadow rays are answered (voxel parameters from
    /// the scene's `voxel_*` keys).
    pub visibility: Option<VisibilityKind>,
    /// `--frames`: frame f of the sequence a `many_light` integrand's table
    /// starts ([`ManyLightSpec::at_frame`]).
    pub frame: Option<u32>,
}

impl IntegrandOverrides {
    /// Only the light sampler.
    pub fn sampler(kind: SamplerKind) -> IntegrandOverrides {
        IntegrandOverrides {
            sampler: Some(kind),
            ..IntegrandOverrides::default()
        }
    }

    /// The visibility `file` renders with under these overrides.
    pub fn visibility(&self, file: &SceneFile) -> Visibility {
        self.visibility
            .map_or(file.visibility, |kind| kind.with(file.voxel))
    }

    /// What the visibility override adds to a reference's cache key:
    /// nothing when it leaves the scene's visibility as it is.
    pub fn visibility_key(&self, file: &SceneFile) -> String {
        let v = self.visibility(file);
        if v == file.visibility {
            return String::new();
        }
        match v {
            Visibility::Bvh => "|visibility=bvh".into(),
            Visibility::Voxel(p) => format!(
                "|visibility=voxel({},{},{})",
                p.directions, p.resolution, p.skip
            ),
        }
    }

    /// `spec` with the overrides applied. A sampler or frame override on
    /// an integrand other than `many_light` is an error; `scene` names the
    /// scene in messages.
    /// The sampler and frame overrides only;
    /// [`IntegrandOverrides::visibility`] gives the visibility.
    pub fn apply(&self, spec: &IntegrandSpec, scene: &Path) -> Result<IntegrandSpec> {
        if self.sampler.is_none() && self.frame.is_none() {
            return Ok(spec.clone());
        }
        match spec {
            IntegrandSpec::ManyLight(m) => {
                let mut m = m.at_frame(self.frame.unwrap_or(0));
                m.sampler = self.sampler.unwrap_or(m.sampler);
                Ok(IntegrandSpec::ManyLight(m))
            }
            other => match self.sampler {
                Some(kind) => bail!(
                    "--sampler {kind} applies only to the many_light integrand, but {} uses '{}' (light samplers: {})",
                    scene.display(),
                    other.type_name(),
                    SamplerKind::names()
                ),
                None => bail!(
                    "frame sequences need a many_light scene (its lights, light tree and cuts \
                     are made again every frame), but {} uses '{}'",
                    scene.display(),
                    other.type_name()
                ),
            },
        }
    }

    /// What the overrides add to a reference's cache key: nothing when
    /// they leave `spec` (the scene file's own table) as it is.
    pub fn cache_key(&self, spec: &IntegrandSpec) -> Result<String> {
        let mut key = match (self.sampler, light_sampler(spec)) {
            (Some(kind), Some(own)) if kind != own => format!("|sampler={kind}"),
            _ => String::new(),
        };
        if let (Some(f), IntegrandSpec::ManyLight(m)) = (self.frame, spec) {
            if m.at_frame(f) != *m {
                key += &format!("|frame={f}");
            }
        }
        Ok(key)
    }
}

/// A loaded scene with its integrand, ready to render at one film size.
pub struct Prepared {
    /// The scene file, its `integrand` with the overrides applied.
    pub scene: SceneFile,
    pub film: Film,
    pub integrand: Box<dyn Integrand>,
}

/// Loads the scene file at `scene_path` (errors at `file:line:col`),
/// builds its acceleration structure and lights on `gpu` and returns its
/// integrand at `scale` × the scene's film (the camera unchanged). The
/// scene's `[mdas]` table is in `Prepared::scene.mdas`, written for the
/// full film: [`mdas_params_at_scale`] adapts it.
///
/// ```
/// use mdas::{app, gpu::Gpu, integrator::{Halton, Integrator, Mdas}};
/// # fn main() -> anyhow::Result<()> {
/// let gpu = Gpu::shared()?;
/// let scale = 0.125; // 32×32 of the Cornell box's 256×256
/// let prepared = app::prepare(gpu, "scenes/cornell.toml".as_ref(), scale)?;
/// let integrand = prepared.integrand.as_ref();
/// let halton = Halton::new(8, 0).render(gpu, integrand)?;
/// let params = app::mdas_params_at_scale(prepared.scene.mdas, scale);
/// // The scene's initial grid holds 8 spp; MDAS adapts above it.
/// let mdas = Mdas::new(mdas::integrator::mdas::MdasParams { spp: 12.0, ..params })?
///     .render(gpu, integrand)?;
/// assert_eq!(halton.samples, 32 * 32 * 8);
/// assert_eq!(mdas.samples, 32 * 32 * 12); // MDAS's budget is met exactly
/// # Ok(())
/// # }
/// ```
pub fn prepare(gpu: &Gpu, scene_path: &Path, scale: f32) -> Result<Prepared> {
    prepare_with(gpu, scene_path, scale, IntegrandOverrides::default())
}

/// [`prepare`] with `[integrand]` overrides (`--sampler`).
pub fn prepare_with(
    gpu: &Gpu,
    scene_path: &Path,
    scale: f32,
    overrides: IntegrandOverrides,
) -> Result<Prepared> {
    let scene = SceneFile::load(scene_path)?;
    prepare_loaded(gpu, scene, scene_path, scale, overrides)
}

/// [`prepare_with`] for a scene already loaded from `scene_path`.
pub fn prepare_loaded(
    gpu: &Gpu,
    mut scene: SceneFile,
    scene_path: &Path,
    scale: f32,
    overrides: IntegrandOverrides,
) -> Result<Prepared> {
    scene.integrand = overrides.apply(&scene.integrand, scene_path)?;
    scene.visibility = overrides.visibility(&scene);
    let film = scaled_film(scene.scene.film, scale)?;
    let integrand = integrand_for(gpu, &scene, film)?;
    Ok(Prepared {
        scene,
        film,
        integrand,
    })
}

/// A `many_light` scene ready to render as a sequence of frames
/// ([`ManyLight::set_frame`]).
pub struct Sequence {
    /// The scene file, its `integrand` with the overrides applied.
    pub scene: SceneFile,
    pub film: Film,
    /// The `[integrand]` table of frame 0 (frame f is `spec.at_frame(f)`).
    pub spec: ManyLightSpec,
    /// Set up at the first frame asked for.
    pub integrand: ManyLight,
}

/// [`prepare_loaded`] for a frame sequence of a `many_light` scene, set up
/// at frame `first`; an error for other integrand types.
pub fn prepare_sequence(
    gpu: &Gpu,
    mut scene: SceneFile,
    scene_path: &Path,
    scale: f32,
    overrides: IntegrandOverrides,
    first: u32,
) -> Result<Sequence> {
    scene.integrand = overrides.apply(&scene.integrand, scene_path)?;
    scene.visibility = overrides.visibility(&scene);
    let IntegrandSpec::ManyLight(spec) = scene.integrand.clone() else {
        bail!(
            "{}: frame sequences need a many_light scene (its lights, light tree and cuts are \
             made again every frame); this scene's integrand is {}",
            scene_path.display(),
            scene.integrand.type_name()
        );
    };
    let film = scaled_film(scene.scene.film, scale)?;
    let gpu_scene = Arc::new(GpuScene::with_visibility(
        gpu,
        &scene.scene,
        film,
        scene.visibility,
    )?);
    let integrand = ManyLight::new_at_frame(gpu, &scene.scene, gpu_scene, film, &spec, first)?;
    Ok(Sequence {
        scene,
        film,
        spec,
        integrand,
    })
}

/// The files an output path stands for: `X.exr` (any case) is the EXR
/// with `X.png` written beside it; `X.png` is the PNG alone. Anything else
/// is an error.
pub fn output_files(path: &Path) -> Result<(Option<PathBuf>, PathBuf)> {
    let extension = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    match extension.as_deref() {
        Some("exr") => Ok((Some(path.to_path_buf()), path.with_extension("png"))),
        Some("png") => Ok((None, path.to_path_buf())),
        _ => bail!(
            "output '{}' must end in .exr (linear EXR, with an sRGB .png written beside it) or .png (the PNG only)",
            path.display()
        ),
    }
}

/// Writes the files [`output_files`] names (as one unit: both or neither,
/// `crate::atomic`) and returns
/// their paths, EXR first.
pub fn write_outputs(path: &Path, render_film: Film, image: &[[f32; 3]]) -> Result<Vec<PathBuf>> {
    write_outputs_with(path, render_film, image, &[])
}

/// [`write_outputs`] with header attributes in the EXR (see
/// `image_io::write_exr_with`; the PNG carries none).
pub fn write_outputs_with(
    path: &Path,
    render_film: Film,
    image: &[[f32; 3]],
    attributes: &[(&str, image_io::ExrAttribute)],
) -> Result<Vec<PathBuf>> {
    let (exr, png) = output_files(path)?;
    let (w, h) = (render_film.width, render_film.height);
    let mut writes = crate::atomic::AtomicWrites::new();
    let mut written = Vec::new();
    if let Some(exr) = exr {
        image_io::stage_exr(&mut writes, &exr, w, h, image, attributes)?;
        written.push(exr);
    }
    image_io::stage_png(&mut writes, &png, w, h, image)?;
    written.push(png);
    writes.commit()?;
    Ok(written)
}

/// The EXR header attributes of a render (`image_io::write_exr_with`):
/// `method`, `spp` (samples over pixels), `seed`, `samples`, `timeMs` (the
/// time of all phases), `clock` (`gpu timestamps` or `wall clock`) and
/// `scene` (the scene file as given).
pub fn render_attributes(
    method: &str,
    seed: u32,
    render: &Render,
    scene: &Path,
) -> Vec<(&'static str, image_io::ExrAttribute)> {
    use image_io::ExrAttribute::{Text, F64, I32};
    let pixels = f64::from(render.film.width) * f64::from(render.film.height);
    vec![
        ("method", Text(method.to_string())),
        ("spp", F64(render.samples as f64 / pixels.max(1.0))),
        // Seeds are u32; the header stores i32 bits (2^31 and above wrap).
        ("seed", I32(seed as i32)),
        ("samples", F64(render.samples as f64)),
        ("timeMs", F64(render.times.total())),
        ("clock", Text(render.clock.name().into())),
        ("scene", Text(scene.display().to_string())),
    ]
}

/// Parameters that identify a reference render.
#[derive(Clone, Copy, Debug)]
pub struct ReferenceSpec {
    pub spp: u32,
    pub scale: f32,
    pub seed: u32,
}

/// Cache file of a reference: a hash of the scene file's content less its
/// `[mdas]` table and comments ([`reference_key_text`]), the bytes of every
/// mesh it loads, the parameters and the crate version (an edited
/// OBJ makes a new entry, never a stale hit).
pub fn reference_cache_path(
    cache_dir: &Path,
    scene_path: &Path,
    spec: ReferenceSpec,
) -> Result<PathBuf> {
    let scene = SceneFile::load(scene_path)?;
    reference_cache_path_keyed(
        cache_dir,
        scene_path,
        &scene.inputs,
        spec,
        shading_key(&scene),
    )
}

/// What a scene's shading adds to its references' cache key: references
/// cached before OBJ vertex normals shaded (same crate version) were
/// rendered without them, so a scene with any gets keys of its own and its
/// older entries are never hit.
fn shading_key(scene: &SceneFile) -> &'static str {
    if scene.scene.meshes.iter().any(|m| !m.normals.is_empty()) {
        "|vertex-normals"
    } else {
        ""
    }
}

/// The part of a scene file a reference depends on, for its cache key: the
/// parsed document without its `[mdas]` table (MDAS's parameters never
/// change a Halton reference) and without comments or layout, written back
/// in TOML's canonical form — so tuning a scene's `[mdas]` table or editing
/// its comments keeps its cached references. A file that does not parse
/// (the caller reports that) is keyed by its bytes.
fn reference_key_text(bytes: &[u8]) -> Vec<u8> {
    let parsed = std::str::from_utf8(bytes)
        .ok()
        .and_then(|text| text.parse::<toml::Table>().ok());
    match parsed {
        Some(mut table) => {
            table.remove("mdas");
            toml::to_string(&table).map_or_else(|_| bytes.to_vec(), String::into_bytes)
        }
        None => bytes.to_vec(),
    }
}

/// [`reference_cache_path`] with `extra` (e.g.
/// [`IntegrandOverrides::cache_key`]) hashed in too.
fn reference_cache_path_keyed(
    cache_dir: &Path,
    scene_path: &Path,
    inputs: &[PathBuf],
    spec: ReferenceSpec,
    extra: &str,
) -> Result<PathBuf> {
    let bytes = std::fs::read(scene_path)
        .with_context(|| format!("cannot read {}", scene_path.display()))?;
    let mut h = Sha256::new();
    h.update(reference_key_text(&bytes));
    for input in inputs {
        let bytes =
            std::fs::read(input).with_context(|| format!("cannot read {}", input.display()))?;
        h.update(format!("|input {} bytes|", bytes.len()));
        h.update(&bytes);
    }
    h.update(format!(
        "|spp={}|scale={}|seed={}|halton{extra}|v{}",
        spec.spp,
        spec.scale,
        spec.seed,
        env!("CARGO_PKG_VERSION")
    ));
    let digest = h.finalize();
    let hex: String = digest.iter().take(12).map(|b| format!("{b:02x}")).collect();
    let stem = scene_path
        .file_stem()
        .and_then(|s| s.to_str())
        .unwrap_or("scene");
    Ok(cache_dir.join(format!("{stem}-{hex}.exr")))
}

/// A reference image and where it came from.
#[derive(Clone, Debug)]
pub struct Reference {
    pub film: Film,
    pub image: Vec<[f32; 3]>,
    /// The cache entry (EXR); its record is [`reference_record_path`].
    pub path: PathBuf,
    pub cache: CacheUse,
    /// The scene file's warnings ([`SceneFile::warnings`]) and its
    /// [`IntegrandSpec::light_warnings`] (an integrand that sees no light
    /// renders a black reference).
    pub warnings: Vec<String>,
    /// What the reference used instead of the scene's own choices: `tree`
    /// for a biased light sampler, the BVH for voxel visibility
    /// ([`reference`]).
    pub notes: Vec<String>,
}

/// How a reference was obtained.
#[derive(Clone, Debug, PartialEq)]
pub enum CacheUse {
    /// Read from a valid cache entry.
    Hit,
    /// Rendered: there was no entry.
    Rendered,
    /// Rendered again: the entry was unusable, for this reason.
    Rebuilt(String),
}

impl Reference {
    /// Whether the image came from the cache.
    pub fn cached(&self) -> bool {
        self.cache == CacheUse::Hit
    }
}

/// SHA-256 of an image's pixels (f32 little-endian bytes, row-major),
/// stored in a cache entry's record and checked on every hit.
pub fn pixels_sha256(image: &[[f32; 3]]) -> String {
    let digest = Sha256::digest(bytemuck::cast_slice::<[f32; 3], u8>(image));
    digest.iter().map(|b| format!("{b:02x}")).collect()
}

/// A cache entry, if it is whole: its EXR reads, has the film's size, is
/// finite, and its pixels hash to the record's `pixels_sha256` (a
/// truncated, garbled, zeroed or half-written entry fails one of these).
fn read_cache_entry(path: &Path, film: Film) -> Result<Vec<[f32; 3]>> {
    let record: serde_json::Value = {
        let record_path = reference_record_path(path);
        let text = std::fs::read_to_string(&record_path)
            .with_context(|| format!("its record {} is missing", record_path.display()))?;
        serde_json::from_str(&text).context("its record is not valid JSON")?
    };
    let (w, h, image) = image_io::read_exr(path)?;
    if (w, h) != (film.width, film.height) {
        bail!("it is {w}×{h}, the film {}×{}", film.width, film.height);
    }
    if image.iter().any(|p| !p.iter().all(|c| c.is_finite())) {
        bail!("it has non-finite pixels");
    }
    let stored = record["pixels_sha256"].as_str().unwrap_or("");
    if stored != pixels_sha256(&image) {
        bail!("its pixels do not match the checksum in its record");
    }
    Ok(image)
}

/// The reference image (Halton at `spec.spp`), from the cache or rendered
/// and cached. A cache entry is used only if it is whole
/// ([`CacheUse::Hit`]); an unusable one is rendered again and replaced
/// ([`CacheUse::Rebuilt`] says why).
/// References use the scene file's own `[integrand]` table (`mdas compare`
/// always does, whatever `--sampler` its compared renders use: every
/// unbiased light sampler estimates the same image) — except a biased
/// light sampler (`sst`, `lgh`: [`SamplerKind::is_biased`]), which would
/// hide its own bias: without a `--sampler` override such a scene's
/// reference uses `tree`, and without a `--visibility` override a scene
/// with voxel visibility (approximate) gets a BVH reference
/// ([`Reference::notes`] says so).
pub fn reference(
    gpu: &Gpu,
    scene_path: &Path,
    spec: ReferenceSpec,
    cache_dir: &Path,
    progress: Option<crate::integrator::halton::Progress>,
) -> Result<Reference> {
    reference_with(
        gpu,
        scene_path,
        spec,
        IntegrandOverrides::default(),
        cache_dir,
        progress,
    )
}

/// The overrides a reference of an integrand `spec` renders with: the
/// given ones, or, when they leave the sampler alone and the scene's own
/// light sampler is biased, `tree`, with the note that says so.
pub fn reference_overrides(
    spec: &IntegrandSpec,
    overrides: IntegrandOverrides,
) -> (IntegrandOverrides, Option<String>) {
    match (overrides.sampler, spec) {
        (None, IntegrandSpec::ManyLight(m)) if m.sampler.is_biased() => (
            IntegrandOverrides {
                sampler: Some(SamplerKind::Tree),
                ..overrides
            },
            Some(format!(
                "the scene's light sampler '{}' is biased: its reference uses 'tree'",
                m.sampler
            )),
        ),
        _ => (overrides, None),
    }
}

/// [`reference`] rendered with `[integrand]` overrides (`mdas reference
/// --sampler`). An override that changes the scene's table is part of the
/// cache key, so such a reference never replaces (or is mistaken for) the
/// scene's own; one that changes nothing shares the scene's cache entry.
pub fn reference_with(
    gpu: &Gpu,
    scene_path: &Path,
    spec: ReferenceSpec,
    overrides: IntegrandOverrides,
    cache_dir: &Path,
    progress: Option<crate::integrator::halton::Progress>,
) -> Result<Reference> {
    let scene = SceneFile::load(scene_path)?;
    let (mut overrides, sampler_note) = reference_overrides(&scene.integrand, overrides);
    let mut notes: Vec<String> = sampler_note.into_iter().collect();
    if overrides.visibility.is_none() && scene.visibility.is_voxel() {
        overrides.visibility = Some(VisibilityKind::Bvh);
        notes
            .push("the scene's voxel visibility is approximate: its reference uses the BVH".into());
    }
    // An override the scene cannot take fails here, cached entry or not.
    let applied = overrides.apply(&scene.integrand, scene_path)?;
    let mut warnings = scene.warnings.clone();
    warnings.extend(applied.light_warnings(&scene.scene));
    let extra = overrides.cache_key(&scene.integrand)?
        + &overrides.visibility_key(&scene)
        + shading_key(&scene);
    let path = reference_cache_path_keyed(cache_dir, scene_path, &scene.inputs, spec, &extra)?;
    if path.is_dir() {
        bail!(
            "the reference cache entry {} is a directory; remove it",
            path.display()
        );
    }
    let film = scaled_film(scene.scene.film, spec.scale)?;
    let mut cache = CacheUse::Rendered;
    if path.exists() {
        match read_cache_entry(&path, film) {
            Ok(image) => {
                return Ok(Reference {
                    film,
                    image,
                    path,
                    cache: CacheUse::Hit,
                    warnings,
                    notes,
                })
            }
            Err(e) => cache = CacheUse::Rebuilt(format!("{e:#}")),
        }
    }
    std::fs::create_dir_all(cache_dir)
        .with_context(|| format!("cannot create cache directory {}", cache_dir.display()))?;
    let prepared = prepare_loaded(gpu, scene, scene_path, spec.scale, overrides)?;
    let mut halton = Halton::new(spec.spp, spec.seed);
    if let Some(p) = progress {
        halton = halton.with_progress(p);
    }
    let render = halton.render(gpu, prepared.integrand.as_ref())?;
    check_finite(&render)?;
    let attributes = render_attributes("halton", spec.seed, &render, scene_path);
    // The record of how it was made, with the pixels' checksum, lands with
    // the images as one unit: an entry is never seen without its record.
    let record = serde_json::json!({
        "pixels_sha256": pixels_sha256(&render.image),
        "width": render.film.width,
        "height": render.film.height,
        "spp": spec.spp,
        "seed": spec.seed,
        "scale": spec.scale,
        "cache_key_extra": extra,
        "time_ms": render.times.total(),
        "provenance": crate::provenance::Provenance::new(
            gpu,
            scene_path,
            prepared.integrand.as_ref(),
            None,
        )?,
    });
    let text = serde_json::to_string_pretty(&record)?;
    let (w, h) = (render.film.width, render.film.height);
    let mut writes = crate::atomic::AtomicWrites::new();
    // A damaged entry read above is this cache's to replace.
    crate::atomic::release_input(&path);
    image_io::stage_exr(&mut writes, &path, w, h, &render.image, &attributes)?;
    image_io::stage_png(
        &mut writes,
        &path.with_extension("png"),
        w,
        h,
        &render.image,
    )?;
    writes.stage(&reference_record_path(&path), |t| {
        std::fs::write(t, text.as_bytes()).map_err(Into::into)
    })?;
    writes.commit()?;
    Ok(Reference {
        film: render.film,
        image: render.image,
        path,
        cache,
        warnings,
        notes,
    })
}

/// The JSON record written beside a cached reference EXR (its provenance:
/// command line, scene hash, adapter, version, time).
pub fn reference_record_path(exr: &Path) -> PathBuf {
    exr.with_extension("json")
}

/// References must be finite everywhere.
fn check_finite(render: &Render) -> Result<()> {
    let bad = render.nonfinite_pixels();
    if bad > 0 {
        bail!(
            "reference has {bad} non-finite pixels ({} non-finite samples)",
            render.nonfinite
        );
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scaled_mdas_grid_keeps_cells_per_pixel() {
        let p = MdasParams {
            extra_image_bits: 8,
            ..Default::default()
        };
        assert_eq!(mdas_params_at_scale(p, 1.0).extra_image_bits, 8);
        assert_eq!(mdas_params_at_scale(p, 0.5).extra_image_bits, 7);
        assert_eq!(mdas_params_at_scale(p, 1.0 / 16.0).extra_image_bits, 4);
        assert_eq!(mdas_params_at_scale(p, 1.0 / 1024.0).extra_image_bits, 0);
        assert_eq!(mdas_params_at_scale(p, 2.0).extra_image_bits, 8);
    }

    #[test]
    fn frame_overrides_move_the_table_and_key_the_reference() {
        use crate::integrand::ManyLightSpec;
        let m = ManyLightSpec {
            time: 1.0,
            frame_duration: 0.5,
            sampler: SamplerKind::Sst,
            ..ManyLightSpec::default()
        };
        let spec = IntegrandSpec::ManyLight(m.clone());
        let at = |frame| IntegrandOverrides {
            frame: Some(frame),
            ..IntegrandOverrides::default()
        };
        let path = Path::new("s.toml");
        assert_eq!(
            at(3).apply(&spec, path).unwrap(),
            IntegrandSpec::ManyLight(m.at_frame(3))
        );
        assert_eq!(at(3).cache_key(&spec).unwrap(), "|frame=3");
        // Frame 0 is the scene's own table: the same cache entry.
        assert_eq!(at(0).cache_key(&spec).unwrap(), "");
        let both = IntegrandOverrides {
            sampler: Some(SamplerKind::Tree),
            ..at(2)
        };
        assert_eq!(both.cache_key(&spec).unwrap(), "|sampler=tree|frame=2");
        // A biased sampler's reference uses tree at the same frame.
        assert_eq!(reference_overrides(&spec, at(2)).0, both);
        let other = IntegrandSpec::PathTracing { max_bounces: 1 };
        let e = at(1).apply(&other, path).unwrap_err().to_string();
        assert!(e.contains("frame sequences need a many_light scene"), "{e}");
    }

    #[test]
    fn references_of_biased_samplers_use_tree() {
        use crate::integrand::ManyLightSpec;
        let ml = |sampler| {
            IntegrandSpec::ManyLight(ManyLightSpec {
                sampler,
                ..ManyLightSpec::default()
            })
        };
        // The biased kinds, named here rather than taken from
        // `is_biased` (which the test would then only repeat): `sst` stops
        // at substitutes, `lgh` shades with grid lights.
        let biased = ["sst", "lgh"];
        for kind in SamplerKind::ALL {
            let (o, note) = reference_overrides(&ml(kind), IntegrandOverrides::default());
            assert_eq!(kind.is_biased(), biased.contains(&kind.name()), "{kind}");
            if biased.contains(&kind.name()) {
                assert_eq!(o.sampler, Some(SamplerKind::Tree), "{kind}");
                assert!(note.unwrap().contains(kind.name()));
            } else {
                assert_eq!((o.sampler, note), (None, None), "{kind}");
            }
            // An explicit --sampler is kept, biased or not.
            let (o, note) = reference_overrides(&ml(kind), IntegrandOverrides::sampler(kind));
            assert_eq!((o.sampler, note), (Some(kind), None));
        }
        let other = IntegrandSpec::PathTracing { max_bounces: 1 };
        assert_eq!(
            reference_overrides(&other, IntegrandOverrides::default()).0,
            IntegrandOverrides::default()
        );
    }

    #[test]
    fn sampler_overrides_apply_to_many_light_only() {
        use crate::integrand::ManyLightSpec;
        let scene = Path::new("s.toml");
        let many = IntegrandSpec::ManyLight(ManyLightSpec::default());
        let power = IntegrandOverrides::sampler(SamplerKind::Power);
        let tree = IntegrandOverrides::sampler(SamplerKind::Tree);
        let none = IntegrandOverrides::default();
        match power.apply(&many, scene).unwrap() {
            IntegrandSpec::ManyLight(m) => assert_eq!(m.sampler, SamplerKind::Power),
            other => panic!("{other:?}"),
        }
        assert_eq!(none.apply(&many, scene).unwrap(), many);
        let err = power
            .apply(&IntegrandSpec::AreaLight, scene)
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("many_light") && err.contains("area_light"),
            "{err}"
        );
        assert_eq!(
            none.apply(&IntegrandSpec::AreaLight, scene).unwrap(),
            IntegrandSpec::AreaLight
        );
        // Only a sampler that changes the scene's adds to the cache key.
        assert_eq!(power.cache_key(&many).unwrap(), "|sampler=power");
        assert_eq!(tree.cache_key(&many).unwrap(), "");
        assert_eq!(none.cache_key(&many).unwrap(), "");
    }

    #[test]
    fn scaled_films_round_and_stay_non_empty() {
        let f = Film {
            width: 128,
            height: 96,
        };
        assert_eq!(
            scaled_film(f, 0.25).unwrap(),
            Film {
                width: 32,
                height: 24
            }
        );
        assert_eq!(
            scaled_film(f, 0.001).unwrap(),
            Film {
                width: 1,
                height: 1
            }
        );
        assert!(scaled_film(f, 0.0).is_err() && scaled_film(f, f32::NAN).is_err());
    }

    /// A scene whose OBJ has vertex normals gets a reference key of its own
    /// (references cached before normals shaded are never hit); a scene
    /// without keeps its key.
    #[test]
    fn vertex_normals_key_references_apart() {
        let dir = std::env::temp_dir().join(format!("mdas-app-vn-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let spec = ReferenceSpec {
            spp: 4,
            scale: 1.0,
            seed: 1,
        };
        for (name, obj, smooth) in [
            ("flat", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", false),
            (
                "smooth",
                "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nf 1//1 2//1 3//1\n",
                true,
            ),
        ] {
            std::fs::write(dir.join(format!("{name}.obj")), obj).unwrap();
            let scene = dir.join(format!("{name}.toml"));
            std::fs::write(
                &scene,
                format!(
                    "[film]\nwidth = 4\nheight = 4\n[camera]\nposition = [0, 0, 3]\nlook_at = [0, 0, 0]\n\
                     up = [0, 1, 0]\nfov_y = 40\n[[material]]\nname = \"w\"\nalbedo = [0.5, 0.5, 0.5]\n\
                     [[shape]]\ntype = \"mesh\"\nmaterial = \"w\"\nfile = \"{name}.obj\"\n"
                ),
            )
            .unwrap();
            let loaded = SceneFile::load(&scene).unwrap();
            let old = reference_cache_path_keyed(&dir, &scene, &loaded.inputs, spec, "").unwrap();
            let now = reference_cache_path(&dir, &scene, spec).unwrap();
            assert_eq!(now != old, smooth, "{name}");
        }
    }

    /// Tuning a scene's `[mdas]` table or editing its comments keeps its
    /// reference key; anything a Halton render reads changes it.
    #[test]
    fn reference_keys_ignore_the_mdas_table_and_comments() {
        let dir = std::env::temp_dir().join(format!("mdas-app-key-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let spec = ReferenceSpec {
            spp: 4,
            scale: 1.0,
            seed: 1,
        };
        let base = "[film]\nwidth = 4\nheight = 4\n[camera]\nposition = [0, 0, 3]\n\
                    look_at = [0, 0, 0]\nup = [0, 1, 0]\nfov_y = 40\n[[material]]\nname = \"w\"\n\
                    albedo = [0.5, 0.5, 0.5]\n[[shape]]\ntype = \"quad\"\nmaterial = \"w\"\n\
                    corners = [[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]]\n";
        let key = |name: &str, text: &str| {
            let path = dir.join(format!("{name}.toml"));
            std::fs::write(&path, text).unwrap();
            let key = reference_cache_path(&dir, &path, spec).unwrap();
            // The stem is the file's; the hash is what is compared.
            key.file_name().unwrap().to_str().unwrap()[name.len()..].to_owned()
        };
        let plain = key("plain", base);
        let tuned = key(
            "tuned",
            &format!("# a comment\n{base}[mdas]\nalpha = 0.25\nsplit = \"trimmed\"\nspp = 8\n"),
        );
        let retuned = key("retuned", &format!("{base}\n[mdas]\nalpha = 1\n"));
        let wider = key("wider", &base.replace("width = 4", "width = 8"));
        assert_eq!(plain, tuned);
        assert_eq!(plain, retuned);
        assert_ne!(plain, wider);
        // A file that is not TOML is keyed by its bytes (and does not load).
        assert_ne!(reference_key_text(b"[film"), reference_key_text(b"[film "));
    }
}
