//! What a scene file's `[integrand]` table asks for: the integrand and its
//! parameters, before any GPU work ([`crate::session::integrand_for`] builds
//! it). The table is parsed by [`crate::scene_file`]; the limits it checks
//! come from the integrand modules (e.g. [`super::path::max_bounces_limit`]).

use crate::lights::lgh::LghParams;
use crate::lights::registry::SamplerKind;
use crate::lights::sampler::{CutSampling, Structure};
use crate::lights::substitute::SubstituteParams;
use crate::lights::vpl::VplSpec;

/// Which integrand renders the scene, with its parameters (scene file
/// `[integrand] type = …`; dimension orders in the integrand modules).
#[derive(Clone, Debug, PartialEq)]
pub enum IntegrandSpec {
    /// `area_light`: area-light direct lighting (4D: film + 2 light dims).
    AreaLight,
    /// `depth_of_field`: thin lens (4D: film + 2 lens dims), point and
    /// directional lights with shadow rays.
    DepthOfField,
    /// `motion_blur`: (3D: film + shutter time), point and directional
    /// lights with shadow rays, rays traced at their time.
    MotionBlur,
    /// `path`: path tracing with next-event estimation and `max_bounces`
    /// indirect bounces (2 + 2m dims, or 4 + 4m with area lights).
    PathTracing { max_bounces: u32 },
    /// `ambient_occlusion`: cosine-weighted unoccluded fraction within
    /// `radius` world units (4D: film + 2 hemisphere dims).
    AmbientOcclusion { radius: f32 },
    /// `many_light`: direct lighting from every light of the scene (point
    /// lights, light sets, emissive triangles) through a many-light sampler.
    ManyLight(ManyLightSpec),
}

impl IntegrandSpec {
    /// The scene-file name of an integrand type (`[integrand] type`).
    pub fn type_name(&self) -> &'static str {
        match self {
            IntegrandSpec::AreaLight => "area_light",
            IntegrandSpec::DepthOfField => "depth_of_field",
            IntegrandSpec::MotionBlur => "motion_blur",
            IntegrandSpec::PathTracing { .. } => "path",
            IntegrandSpec::AmbientOcclusion { .. } => "ambient_occlusion",
            IntegrandSpec::ManyLight(_) => "many_light",
        }
    }
}

/// What in a scene can give light to an integrand (see
/// [`IntegrandSpec::light_warnings`]).
struct Emitters {
    /// Triangles with non-zero emission.
    emissive_triangles: usize,
    /// Point and directional lights with non-zero intensity.
    analytic: usize,
    /// Lights of `[[light_set]]`s with non-zero intensity.
    set_lights: usize,
    background: bool,
}

impl Emitters {
    fn of(scene: &crate::scene::Scene) -> Emitters {
        use crate::scene::Light;
        let lit = |v: glam::Vec3| v.cmpgt(glam::Vec3::ZERO).any();
        Emitters {
            emissive_triangles: scene
                .meshes
                .iter()
                .filter(|m| {
                    let material = scene.materials.get(m.material as usize);
                    material.is_some_and(|mat| lit(mat.emission))
                })
                .map(|m| m.indices.len())
                .sum(),
            analytic: scene
                .lights
                .iter()
                .filter(|l| match l {
                    Light::Point { intensity, .. } => lit(*intensity),
                    Light::Directional { irradiance, .. } => lit(*irradiance),
                })
                .count(),
            set_lights: scene
                .point_light_sets
                .iter()
                .flat_map(|s| &s.lights)
                .filter(|l| lit(l.intensity))
                .count(),
            background: lit(scene.background),
        }
    }
}

impl IntegrandSpec {
    /// Sentences warning that this integrand can see no light in `scene`
    /// (the image would be black, or only the background, without a word
    /// otherwise). Empty when some light reaches it.
    pub fn light_warnings(&self, scene: &crate::scene::Scene) -> Vec<String> {
        let e = Emitters::of(scene);
        let name = self.type_name();
        let ignored = |what: &[(usize, &str)]| -> String {
            let parts: Vec<String> = what
                .iter()
                .filter(|(n, _)| *n > 0)
                .map(|(n, w)| format!("{n} {w}"))
                .collect();
            if parts.is_empty() {
                String::new()
            } else {
                format!(" (its {} are not used by {name})", parts.join(" and "))
            }
        };
        let warning = match self {
            IntegrandSpec::AreaLight if e.emissive_triangles == 0 => Some(format!(
                "the {name} integrand samples emissive surfaces and the scene has none{}: \
                 surfaces are lit by nothing",
                ignored(&[
                    (e.analytic, "point/directional lights"),
                    (e.set_lights, "light-set lights")
                ])
            )),
            IntegrandSpec::DepthOfField | IntegrandSpec::MotionBlur if e.analytic == 0 => {
                Some(format!(
                    "the {name} integrand lights surfaces with point and directional lights \
                     and the scene has none{}: only emission seen directly and the background \
                     show",
                    ignored(&[(e.set_lights, "light-set lights")])
                ))
            }
            IntegrandSpec::PathTracing { .. }
                if e.emissive_triangles + e.analytic == 0 && !e.background =>
            {
                Some(format!(
                    "nothing the {name} integrand samples emits light (no emissive surface, \
                     point or directional light, and a black background){}",
                    ignored(&[(e.set_lights, "light-set lights")])
                ))
            }
            IntegrandSpec::ManyLight(_)
                if e.emissive_triangles + e.analytic + e.set_lights == 0 =>
            {
                Some(format!(
                    "the {name} integrand has no light to sample: the scene has no emissive \
                     surface, point light or light set with non-zero intensity"
                ))
            }
            _ => None,
        };
        warning.into_iter().collect()
    }
}

/// Parameters of the `many_light` integrand (scene file `[integrand]`).
#[derive(Clone, Debug, PartialEq)]
pub struct ManyLightSpec {
    /// The light sampler (its names: [`SamplerKind::ALL`]).
    pub sampler: SamplerKind,
    /// Light-cut size, 1..=64: under `cut_sampling = "subtrees"` the
    /// light samples (shadow rays) of one evaluation of the kinds with cuts.
    pub cut_size: u32,
    /// Light samples (shadow rays) of one evaluation of the kinds that
    /// pick one light per evaluation (every kind but `lgh`, and the kinds
    /// with cuts under `cut_sampling = "subtrees"`), 1..=64, default 1:
    /// n picks at the same shading point, averaged, pick j with the
    /// evaluation's numbers rotated as the cut's subtree j
    /// (`ml_subtree_u`). With `cut_size = n` it gives `tree_nocut` the
    /// shadow rays of `tree` at the same camera samples: the paper's
    /// equal-count comparison (BENCHMARKS.md).
    pub light_samples: u32,
    /// How the kinds with cuts estimate from the cut: one light per subtree
    /// (the paper's, the default) or one pick from the cut's mixture.
    pub cut_sampling: CutSampling,
    /// Cut-sharing block size k: k × k pixels share one cut; ≥ 1.
    pub block: u32,
    /// Interleaved sampling (stochastic lightcuts §3.4): each pixel of an
    /// m × m sub-block samples 1/m² of the cut, scaled by m²; 1 = off
    /// (the default). m divides `block`. Biased per pixel (unbiased over a
    /// sub-block of equal lighting): the paper filters the result.
    pub interleave: u32,
    /// Frame time in scene time units: mesh-light keyframes and animated
    /// light sets are evaluated at this time.
    pub time: f32,
    /// Frame number, rotates the per-frame random choices.
    pub frame: u32,
    /// Scene time between two frames of a sequence (`render --frames`):
    /// frame f of a sequence is at `time + f · frame_duration` with frame
    /// number `frame + f` ([`ManyLightSpec::at_frame`]).
    pub frame_duration: f32,
    /// Virtual point lights generated per frame by instant radiosity
    /// (`paths = 0`: none).
    pub vpl: VplSpec,
    /// `sst`'s suitability thresholds (`sst_nu_min`, `sst_sigma_max`).
    pub sst: SubstituteParams,
    /// `lgh`'s levels, α, level 0 and shadow samples (`lgh_levels`,
    /// `lgh_alpha`, `lgh_level0`, `lgh_shadows`).
    pub lgh: LghParams,
}

/// `frame_duration` when a scene file does not set it: 30 frames per
/// scene time unit.
pub const DEFAULT_FRAME_DURATION: f32 = 1.0 / 30.0;

impl ManyLightSpec {
    /// Light samples (shadow rays toward lights) of one evaluation with
    /// sampler `kind`: under `cut_sampling = "subtrees"` the kinds with
    /// cuts draw one per node of the pixel's share of the cut, n/m² on
    /// average over a sub-block (at most: a cut holds fewer nodes when
    /// lights run out); `lgh` traces its shadow samples (plus one toward an
    /// emissive triangle when the scene has them); the others
    /// `light_samples`.
    pub fn light_samples_per_eval(&self, kind: SamplerKind) -> f64 {
        if kind.structure() == Structure::Grid {
            self.lgh.shadow_samples as f64
        } else if kind.uses_cut() && self.cut_sampling == CutSampling::Subtrees {
            self.cut_size as f64 / (self.interleave.max(1) as f64).powi(2)
        } else {
            self.light_samples.max(1) as f64
        }
    }

    /// Frame `f` of a sequence that starts at this spec's frame: time
    /// `time + f · frame_duration`, frame number `frame + f` (wrapping).
    /// `at_frame(0)` is the spec itself.
    pub fn at_frame(&self, f: u32) -> ManyLightSpec {
        ManyLightSpec {
            time: self.time + f as f32 * self.frame_duration,
            frame: self.frame.wrapping_add(f),
            ..self.clone()
        }
    }
}

impl Default for ManyLightSpec {
    fn default() -> Self {
        ManyLightSpec {
            sampler: SamplerKind::Tree,
            cut_size: 8,
            light_samples: 1,
            cut_sampling: CutSampling::Subtrees,
            block: 8,
            interleave: 1,
            time: 0.0,
            frame: 0,
            frame_duration: DEFAULT_FRAME_DURATION,
            vpl: VplSpec::default(),
            sst: SubstituteParams::default(),
            lgh: LghParams::default(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frames_step_time_and_number_from_the_spec() {
        let spec = ManyLightSpec {
            time: 0.5,
            frame: u32::MAX - 1,
            frame_duration: 0.25,
            ..ManyLightSpec::default()
        };
        assert_eq!(spec.at_frame(0), spec);
        let f = spec.at_frame(3);
        assert_eq!((f.time, f.frame), (1.25, 1)); // the number wraps
        assert_eq!(f.frame_duration, 0.25);
        let still = ManyLightSpec {
            frame_duration: 0.0,
            ..spec
        };
        assert_eq!(still.at_frame(7).time, 0.5);
    }
}
