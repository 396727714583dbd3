//! High-spp Halton references and their cache: keys from what changes
//! the image (the scene's bytes, film, spp, seed, shading), entries
//! checked on read and rebuilt when unusable.

use super::outputs::*;
use super::prepare::*;
use crate::accel::voxel::VisibilityKind;
use crate::film::Film;
use crate::gpu::Gpu;
use crate::image_io;
use crate::integrand::IntegrandSpec;
use crate::integrator::{Halton, Integrator, Render};
use crate::lights::registry::SamplerKind;
use crate::scene_file::SceneFile;
use anyhow::{bail, Context, Result};
use sha2::{Digest, Sha256};
use std::path::{Path, PathBuf};

/// The seed of a reference unless one is named: `mdas reference` renders
/// with it and `compare`, `sweep` and `tune` look references up with it
/// (`--ref-seed`), so that a reference rendered or merged ahead of time is
/// the one they find. It is not 0, the compared Halton renders' default
/// seed, so that their errors are independent of the reference's.
pub const DEFAULT_REFERENCE_SEED: u32 = 1;

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
pub(super) fn reference_key_text(bytes: &[u8]) -> Vec<u8> {
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
pub(super) fn reference_cache_path_keyed(
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
    // A Mitsuba scene's `X.mdas.toml` holds MDAS's parameters only (as a
    // TOML scene's `[mdas]` table, which the key leaves out too).
    let mdas_only = |p: &Path| p.to_string_lossy().ends_with(".mdas.toml");
    for input in inputs.iter().filter(|p| !mdas_only(p)) {
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

/// Most bytes read from a cache entry's record (a merged entry's, which
/// holds its parts' records, is a few kilobytes per part).
const MAX_ENTRY_RECORD_BYTES: u64 = 64 << 20;

/// A cache entry, if it is whole: its EXR reads, has the film's size, is
/// finite, and its pixels hash to the record's `pixels_sha256` (a
/// truncated, garbled, zeroed or half-written entry fails one of these).
///
/// Neither file is opened unless it is a regular file (issue 67, hostile
/// inputs class 4): opening a FIFO for reading blocks until a writer
/// comes, and a FIFO at the record's path hung `mdas reference`.
fn read_cache_entry(path: &Path, film: Film) -> Result<Vec<[f32; 3]>> {
    let record_path = reference_record_path(path);
    for (what, file) in [("image", path), ("record", record_path.as_path())] {
        match std::fs::metadata(file) {
            Ok(meta) if !meta.is_file() => bail!(
                "its {what} {} is not a regular file (a directory, FIFO, socket or device)",
                file.display()
            ),
            Ok(_) => {}
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
                bail!("its {what} {} is missing", file.display())
            }
            Err(e) => bail!("cannot read its {what} {}: {e}", file.display()),
        }
    }
    let record: serde_json::Value = {
        // Bounded, and refused unless a regular file (checked again at the
        // open: the file may have been replaced since).
        let bytes = crate::scene::read_input(&record_path, MAX_ENTRY_RECORD_BYTES)
            .with_context(|| format!("its record {} cannot be read", record_path.display()))?;
        serde_json::from_slice(&bytes).context("its record is not valid JSON")?
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
    reference_of_loaded(gpu, scene, scene_path, spec, overrides, cache_dir, progress)
}

/// [`reference_with`] on a scene file already loaded from `scene_path`
/// (`mdas reference -o` loads it first, to check its output against the
/// meshes and material libraries the scene reads before any GPU work).
pub fn reference_of_loaded(
    gpu: &Gpu,
    scene: SceneFile,
    scene_path: &Path,
    spec: ReferenceSpec,
    overrides: IntegrandOverrides,
    cache_dir: &Path,
    progress: Option<crate::integrator::halton::Progress>,
) -> Result<Reference> {
    let Plan {
        overrides,
        extra,
        path,
        warnings,
        notes,
    } = plan(&scene, scene_path, spec, overrides, cache_dir)?;
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
    // The entry is written after the render: refuse now what its write
    // would refuse then (a damaged entry read above is ours to replace).
    for file in entry_files(&path) {
        crate::atomic::release_input(&file);
    }
    check_entry(&path)?;
    let prepared = prepare_loaded(gpu, scene, scene_path, spec.scale, overrides)?;
    let mut halton = Halton::new(spec.spp, spec.seed);
    if let Some(p) = progress {
        halton = halton.with_progress(p);
    }
    let render = halton.render(gpu, prepared.integrand.as_ref())?;
    check_finite(&render)?;
    let attributes = render_attributes("halton", spec.seed, &render, scene_path);
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
    write_entry(&path, render.film, &render.image, &attributes, &record)?;
    Ok(Reference {
        film: render.film,
        image: render.image,
        path,
        cache,
        warnings,
        notes,
    })
}

/// What a reference of `scene` under `overrides` is made with and where it
/// is cached ([`reference_of_loaded`], and the parts of
/// [`super::parts`]).
pub(super) struct Plan {
    pub(super) overrides: IntegrandOverrides,
    /// The cache key's part beyond the scene and the spec.
    pub(super) extra: String,
    /// The cache entry (EXR).
    pub(super) path: PathBuf,
    pub(super) warnings: Vec<String>,
    pub(super) notes: Vec<String>,
}

pub(super) fn plan(
    scene: &SceneFile,
    scene_path: &Path,
    spec: ReferenceSpec,
    overrides: IntegrandOverrides,
    cache_dir: &Path,
) -> Result<Plan> {
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
        + &overrides.visibility_key(scene)
        + shading_key(scene);
    let path = reference_cache_path_keyed(cache_dir, scene_path, &scene.inputs, spec, &extra)?;
    if path.is_dir() {
        bail!(
            "the reference cache entry {} is a directory; remove it",
            path.display()
        );
    }
    Ok(Plan {
        overrides,
        extra,
        path,
        warnings,
        notes,
    })
}

/// Writes a reference cache entry — the EXR, an sRGB PNG beside it and its
/// JSON `record` — as one unit (the record lands with the images: an
/// entry is never seen without it).
pub(super) fn write_entry(
    path: &Path,
    film: Film,
    image: &[[f32; 3]],
    attributes: &[(&str, image_io::ExrAttribute)],
    record: &serde_json::Value,
) -> Result<()> {
    let text = serde_json::to_string_pretty(record)?;
    let (w, h) = (film.width, film.height);
    let mut writes = crate::atomic::AtomicWrites::new();
    // A damaged entry read above is this cache's to replace.
    for file in entry_files(path) {
        crate::atomic::release_input(&file);
    }
    let [exr, png, json] = entry_files(path);
    image_io::stage_exr(&mut writes, &exr, w, h, image, attributes)?;
    image_io::stage_png(&mut writes, &png, w, h, image)?;
    writes.stage(&json, |t| {
        std::fs::write(t, text.as_bytes()).map_err(Into::into)
    })?;
    writes.commit()?;
    Ok(())
}

/// The files [`write_entry`] writes for an entry at `path`: the EXR, its
/// PNG and its record.
pub(super) fn entry_files(path: &Path) -> [PathBuf; 3] {
    [
        path.to_path_buf(),
        path.with_extension("png"),
        reference_record_path(path),
    ]
}

/// What [`write_entry`] would refuse after the render, checked before it
/// (issue 67, hostile inputs class 6): `path` must be an EXR path (so that
/// its PNG and record are other files) and each of the three files
/// writable (`crate::atomic::check_writable`).
pub(super) fn check_entry(path: &Path) -> Result<()> {
    let is_exr = path
        .extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.eq_ignore_ascii_case("exr"));
    if !is_exr {
        bail!(
            "{} must end in .exr: it is written as an EXR with an sRGB .png and its .json record beside it",
            path.display()
        );
    }
    for file in entry_files(path) {
        crate::atomic::check_writable(&file)?;
    }
    Ok(())
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
