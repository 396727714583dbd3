//! What a comparison runs on: the shared [`Setup`] of `compare`, `sweep`
//! and `tune`, [`CompareSpec`], the [`Subject`] (an integrand and its
//! reference) and where that reference came from, with the checks that
//! need no render.

use super::progress::bar;
use crate::gpu::Gpu;
use crate::integrand::Integrand;
use crate::integrator::mdas::MdasParams;
use crate::session::{self, IntegrandOverrides, ReferenceSpec};
use anyhow::{bail, Result};
use std::path::{Path, PathBuf};

/// What fixes the time both methods get.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Budget {
    /// MDAS at its `[mdas]` spp (after overrides); the target is its time.
    MdasSpp,
    /// Both methods at this many milliseconds.
    TimeMs(f64),
}

/// What `compare` and `sweep` share: the scene, its reference, how runs
/// are timed, where outputs go and how the `[mdas]` table becomes
/// parameters.
pub struct Setup<'a> {
    pub scene: PathBuf,
    pub scale: f32,
    pub ref_spp: u32,
    pub ref_seed: u32,
    pub cache_dir: PathBuf,
    pub halton_seed: u32,
    pub repeats: u32,
    pub out: PathBuf,
    /// Show progress bars on stderr.
    pub progress: bool,
    /// The scene's `[mdas]` table → the parameters to run (scaling to
    /// `--scale`, CLI overrides).
    pub mdas_params: &'a dyn Fn(MdasParams) -> MdasParams,
    /// Frame f of a `many_light` scene's sequence (`compare --frames`;
    /// [`crate::integrand::ManyLightSpec::at_frame`]), for the compared
    /// renders and the reference alike; `None`: the scene's own table.
    pub frame: Option<u32>,
}

impl Setup<'_> {
    /// Checks that need no GPU work.
    pub fn check(&self) -> Result<()> {
        if self.repeats == 0 {
            bail!("--repeats must be at least 1");
        }
        check_seeds(self.halton_seed, self.ref_seed)
    }

    /// The subject of a run on the setup's scene file: its integrand, the
    /// MDAS parameters and the Halton reference [`Setup::reference`]
    /// returned (image, path, whether cached); no light sampler named.
    pub(crate) fn scene_subject<'s>(
        &'s self,
        integrand: &'s dyn Integrand,
        mdas: MdasParams,
        reference: &'s [[f32; 3]],
        path: PathBuf,
        cached: bool,
    ) -> Subject<'s> {
        Subject {
            name: self.scene.display().to_string(),
            scene_file: Some(&self.scene),
            integrand,
            mdas,
            reference,
            reference_source: ReferenceSource::Halton {
                spp: self.ref_spp,
                path,
                cached,
            },
            sampler: None,
            reference_sampler: None,
            visibility: None,
        }
    }

    /// The reference image (cached), its path and whether it was cached.
    pub fn reference(&self, gpu: &Gpu) -> Result<(Vec<[f32; 3]>, PathBuf, bool)> {
        let spec = ReferenceSpec {
            spp: self.ref_spp,
            scale: self.scale,
            seed: self.ref_seed,
        };
        load_reference(
            gpu,
            &self.scene,
            spec,
            IntegrandOverrides {
                frame: self.frame,
                ..IntegrandOverrides::default()
            },
            &self.cache_dir,
            self.progress,
        )
    }
}

impl<'a> Setup<'a> {
    /// A setup for [`super::compare_integrand`]: `name` in place of a scene file,
    /// Halton seed 0 (the reference seed,
    /// [`crate::session::DEFAULT_REFERENCE_SEED`], is kept apart from it), 3
    /// timed repeats, no progress bars, and `mdas_params` (usually the
    /// identity). The fields are public: change what you need.
    pub fn new(
        name: &str,
        out: PathBuf,
        mdas_params: &'a dyn Fn(MdasParams) -> MdasParams,
    ) -> Setup<'a> {
        Setup {
            scene: PathBuf::from(name),
            scale: 1.0,
            ref_spp: 0,
            ref_seed: crate::session::DEFAULT_REFERENCE_SEED,
            cache_dir: PathBuf::new(),
            halton_seed: 0,
            repeats: 3,
            out,
            progress: false,
            mdas_params,
            frame: None,
        }
    }
}

/// Inputs of [`super::compare()`].
pub struct CompareSpec<'a> {
    pub setup: Setup<'a>,
    pub budget: Budget,
    /// Upper end of the spp searches.
    pub max_spp: u32,
    /// Seeds per method (`--seeds`, [`super::intervals`]).
    pub seeds: u32,
    /// Insets of `figure.png` (`--crop`); empty: the two places where the
    /// methods' errors differ most.
    pub crops: Vec<super::figure::Crop>,
    /// Also MDAS-uniform (α = 0, one candidate) at MDAS's spp and seeds
    /// (`--uniform`, [`intervals::uniform_over_seeds`]).
    pub uniform: bool,
    /// Also pixel-adaptive Halton, the third method ([`super::adaptive`]),
    /// at equal time and at equal samples; `--methods halton,mdas` leaves
    /// it out.
    pub adaptive: bool,
}

impl<'a> CompareSpec<'a> {
    /// `mdas compare`'s defaults: spp searches up to 4096, 3 seeds per
    /// method, automatic insets, no MDAS-uniform, pixel-adaptive Halton
    /// as the third method.
    pub fn new(setup: Setup<'a>, budget: Budget) -> CompareSpec<'a> {
        CompareSpec {
            setup,
            budget,
            max_spp: 4096,
            seeds: 3,
            crops: Vec::new(),
            uniform: false,
            adaptive: true,
        }
    }
}

/// What a comparison runs on: an integrand and the image it converges to.
/// `mdas compare` builds one from a scene file; [`super::compare_integrand`]
/// takes one built in code.
pub struct Subject<'a> {
    /// Names it in the report (`scene`) and the EXR headers.
    pub name: String,
    /// The scene file it was built from, whose digest the provenance
    /// records; `None` for an integrand built in code.
    pub scene_file: Option<&'a Path>,
    pub integrand: &'a dyn Integrand,
    /// MDAS's parameters. Under [`Budget::MdasSpp`] their spp sets the
    /// time both methods get; their seed is MDAS's first seed.
    pub mdas: MdasParams,
    /// The image both methods are measured against, row-major RGB of the
    /// integrand's film.
    pub reference: &'a [[f32; 3]],
    pub reference_source: ReferenceSource,
    /// The light sampler of the compared renders and of the reference
    /// (`many_light` scenes), for the report.
    pub sampler: Option<String>,
    pub reference_sampler: Option<String>,
    /// The compared renders' visibility when it is approximate (voxel),
    /// for the report.
    pub visibility: Option<String>,
}

/// Where a comparison's reference came from.
#[derive(Clone, Debug)]
pub enum ReferenceSource {
    /// Halton at `spp` samples per pixel with the setup's `ref_seed`, read
    /// from `path` (`cached`) or rendered there. The report estimates its
    /// own error and flags it when it is not far below the methods'.
    Halton {
        spp: u32,
        path: PathBuf,
        cached: bool,
    },
    /// Computed without sampling (a closed form, a quadrature), described
    /// in words; taken as exact.
    Exact(String),
}

/// A given reference must cover the integrand's film with finite pixels.
pub(crate) fn check_reference(subject: &Subject) -> Result<()> {
    let film = subject.integrand.film();
    let pixels = film.width as usize * film.height as usize;
    if subject.reference.len() != pixels {
        bail!(
            "the reference has {} pixels; the integrand's film is {}×{} = {pixels}",
            subject.reference.len(),
            film.width,
            film.height
        );
    }
    if let Some(i) = subject
        .reference
        .iter()
        .position(|p| p.iter().any(|c| !c.is_finite()))
    {
        bail!("the reference's pixel {i} is not finite");
    }
    Ok(())
}

/// The compared Halton render must not reuse the reference's random
/// shifts: its samples would be the reference's first ones, and its error
/// would look far smaller than it is.
pub fn check_seeds(halton_seed: u32, ref_seed: u32) -> Result<()> {
    if halton_seed == ref_seed {
        bail!("the Halton seed ({halton_seed}) equals the reference seed: the compared render would reuse the reference's samples; pick a different --seed or --ref-seed");
    }
    Ok(())
}

/// The reference image, with a progress bar while it renders.
pub(crate) fn load_reference(
    gpu: &Gpu,
    scene: &Path,
    spec: ReferenceSpec,
    overrides: IntegrandOverrides,
    cache_dir: &Path,
    progress: bool,
) -> Result<(Vec<[f32; 3]>, PathBuf, bool)> {
    let b = bar(
        progress,
        spec.spp as u64,
        "reference {bar:40} {pos}/{len} spp [{elapsed_precise} < {eta}]",
    );
    let b2 = b.clone();
    let reference = session::reference_with(
        gpu,
        scene,
        spec,
        overrides,
        cache_dir,
        Some(Box::new(move |done, _| b2.set_position(done as u64))),
    )?;
    b.finish_and_clear();
    for note in &reference.notes {
        eprintln!("note: {note}");
    }
    if let session::CacheUse::Rebuilt(why) = &reference.cache {
        eprintln!(
            "warning: the cached reference {} was unusable ({why}); rendered it again",
            reference.path.display()
        );
    }
    let cached = reference.cached();
    Ok((reference.image, reference.path, cached))
}
