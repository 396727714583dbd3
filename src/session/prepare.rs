//! A scene prepared for one film: the film at `--scale`, the MDAS grid
//! scaled with it, the integrand built on the GPU (with overrides of its
//! table), and the sequences of `render --frames`.

use crate::accel::voxel::{Visibility, VisibilityKind};
use crate::accel::GpuScene;
use crate::film::Film;
use crate::gpu::Gpu;
use crate::integrand::{
    AmbientOcclusion, AreaLight, DepthOfField, Integrand, ManyLight, MotionBlur, PathTracing,
};
use crate::integrand::{IntegrandSpec, ManyLightSpec};
use crate::integrator::mdas::MdasParams;
use crate::lights::registry::SamplerKind;
use crate::lights::sampler::CutSampling;
use crate::lights::tree::cut::MAX_CUT;
use crate::scene_file::SceneFile;
use anyhow::{bail, Result};
use std::path::Path;
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
    /// `--cut-size`: the light-cut size of a `many_light` integrand.
    pub cut_size: Option<u32>,
    /// `--cut-sampling`: how its kinds with cuts sample the cut.
    pub cut_sampling: Option<CutSampling>,
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
        if self.sampler.is_none()
            && self.frame.is_none()
            && self.cut_size.is_none()
            && self.cut_sampling.is_none()
        {
            return Ok(spec.clone());
        }
        if let Some(size) = self.cut_size {
            if !(1..=MAX_CUT).contains(&size) {
                bail!("--cut-size must be in 1..={MAX_CUT}, got {size}");
            }
        }
        match spec {
            IntegrandSpec::ManyLight(m) => {
                let mut m = m.at_frame(self.frame.unwrap_or(0));
                m.sampler = self.sampler.unwrap_or(m.sampler);
                m.cut_size = self.cut_size.unwrap_or(m.cut_size);
                m.cut_sampling = self.cut_sampling.unwrap_or(m.cut_sampling);
                Ok(IntegrandSpec::ManyLight(m))
            }
            other if self.cut_size.is_some() || self.cut_sampling.is_some() => bail!(
                "--cut-size and --cut-sampling apply only to the many_light integrand, but {} uses '{}'",
                scene.display(),
                other.type_name()
            ),
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
        if let IntegrandSpec::ManyLight(m) = spec {
            if let Some(f) = self.frame.filter(|&f| m.at_frame(f) != *m) {
                key += &format!("|frame={f}");
            }
            if let Some(n) = self.cut_size.filter(|&n| n != m.cut_size) {
                key += &format!("|cut_size={n}");
            }
            if let Some(c) = self.cut_sampling.filter(|&c| c != m.cut_sampling) {
                key += &format!("|cut_sampling={c}");
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
/// use mdas::{session, gpu::Gpu, integrator::{Halton, Integrator, Mdas}};
/// # fn main() -> anyhow::Result<()> {
/// let gpu = Gpu::shared()?;
/// let scale = 0.125; // 32×32 of the Cornell box's 256×256
/// let prepared = session::prepare(gpu, "scenes/cornell.toml".as_ref(), scale)?;
/// let integrand = prepared.integrand.as_ref();
/// let halton = Halton::new(8, 0).render(gpu, integrand)?;
/// let params = session::mdas_params_at_scale(prepared.scene.mdas, scale);
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
