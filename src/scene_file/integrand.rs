//! `[integrand]`: the table handed to [`IntegrandSpec`], limits from the
//! integrand modules.

use super::ctx::{Ctx, Result};
use super::raw::*;
use super::values::{Num, S};
use super::*;
use crate::accel::voxel::{self, Visibility, VoxelParams};
use crate::integrand::ManyLightSpec;
use crate::lights::lgh::{self, LghParams};
use crate::lights::registry::SamplerKind;
use crate::lights::sampler::{CutSampling, Structure};
use crate::lights::substitute::SubstituteParams;
use crate::lights::vpl::{self, VplSpec};

impl Ctx<'_> {
    /// `emissive`: whether any mesh emits (then the path tracer spends two
    /// more dimensions per vertex on area-light NEE).
    pub(super) fn integrand(&self, r: &RawIntegrand, emissive: bool) -> Result<IntegrandSpec> {
        let t = self.check_type("integrand", &r.kind, &r.type_keys(), &INTEGRAND_TYPES)?;
        Ok(match INTEGRAND_TYPES[t].0 {
            "area_light" => IntegrandSpec::AreaLight,
            "depth_of_field" => IntegrandSpec::DepthOfField,
            "motion_blur" => IntegrandSpec::MotionBlur,
            "path" => {
                let limit = crate::integrand::path::max_bounces_limit(emissive);
                let why = if emissive {
                    "with emissive surfaces a path has 4 + 4·max_bounces dimensions, at most 16"
                } else {
                    "a path has 2 + 2·max_bounces dimensions, at most 16"
                };
                let max_bounces = match &r.max_bounces {
                    None => 1,
                    Some(v) => {
                        let x = *v.get_ref();
                        if x < 1 || x > limit as i64 {
                            return Err(self.error(
                                v.span(),
                                format!("max_bounces must be in 1..={limit} ({why}), found {x}"),
                            ));
                        }
                        x as u32
                    }
                };
                IntegrandSpec::PathTracing { max_bounces }
            }
            "ambient_occlusion" => IntegrandSpec::AmbientOcclusion {
                radius: self.positive(
                    self.need(&r.radius, "radius", &r.kind, "integrand")?,
                    "radius",
                )?,
            },
            "many_light" => {
                let d = ManyLightSpec::default();
                let sampler = self.opt_name(
                    &r.sampler,
                    "sampler",
                    &SamplerKind::ALL.map(SamplerKind::name),
                    d.sampler,
                )?;
                let cut_sampling = self.opt_name(
                    &r.cut_sampling,
                    "cut_sampling",
                    &CutSampling::ALL.map(CutSampling::name),
                    d.cut_sampling,
                )?;
                let block = self.u32(&r.block, "block", 1, d.block)?;
                let interleave = self.u32(&r.interleave, "interleave", 1, d.interleave)?;
                if block % interleave != 0 {
                    let span = r.interleave.as_ref().map_or(r.kind.span(), |v| v.span());
                    return Err(self.error(
                        span,
                        format!("interleave = {interleave} must divide block = {block}"),
                    ));
                }
                let light_samples = self.opt_int(
                    &r.light_samples,
                    "light_samples",
                    1..=MAX_CUT_SIZE as i64,
                    d.light_samples as i64,
                )? as u32;
                if let Some(v) = &r.light_samples {
                    let per_subtree = sampler.uses_cut() && cut_sampling == CutSampling::Subtrees;
                    if light_samples != 1 && (per_subtree || sampler.structure() == Structure::Grid)
                    {
                        return Err(self.error(
                            v.span(),
                            format!(
                                "light_samples is for the samplers that pick one light per evaluation; '{}' {}",
                                sampler.name(),
                                if per_subtree {
                                    "draws one per cut subtree (cut_size sets how many)"
                                } else {
                                    "traces lgh_shadows shadow samples"
                                }
                            ),
                        ));
                    }
                }
                IntegrandSpec::ManyLight(ManyLightSpec {
                    sampler,
                    cut_size: self.opt_int(
                        &r.cut_size,
                        "cut_size",
                        1..=MAX_CUT_SIZE as i64,
                        d.cut_size as i64,
                    )? as u32,
                    light_samples,
                    cut_sampling,
                    block,
                    interleave,
                    time: r
                        .time
                        .as_ref()
                        .map_or(Ok(d.time), |v| self.bounded(v, "time", super::MAX_TIME))?,
                    frame: self.u32(&r.frame, "frame", 0, d.frame)?,
                    frame_duration: self.finite_nonneg(
                        &r.frame_duration,
                        "frame_duration",
                        "scene time",
                        d.frame_duration,
                    )?,
                    vpl: self.vpl(r)?,
                    sst: self.sst(r)?,
                    lgh: self.lgh(r)?,
                })
            }
            _ => unreachable!("INTEGRAND_TYPES and this match list the same types"),
        })
    }

    /// The visibility keys of any `[integrand]`: `visibility = "bvh" |
    /// "voxel"` and the voxel array's `voxel_directions` (n of the n × n
    /// array), `voxel_resolution` (a multiple of 32) and `voxel_skip`.
    /// Returns the backend and the voxel parameters (kept with `bvh` too,
    /// for `--visibility voxel`).
    pub(super) fn visibility(&self, r: &RawIntegrand) -> Result<(Visibility, VoxelParams)> {
        let d = VoxelParams::default();
        let voxel = VoxelParams {
            directions: self.opt_int(
                &r.voxel_directions,
                "voxel_directions",
                1..=voxel::MAX_DIRECTIONS as i64,
                d.directions as i64,
            )? as u32,
            resolution: match &r.voxel_resolution {
                None => d.resolution,
                Some(v) => {
                    let x = self.int(v, "voxel_resolution", 32..=voxel::MAX_RESOLUTION as i64)?;
                    if x % 32 != 0 {
                        return Err(self.error(
                            v.span(),
                            format!("voxel_resolution must be a multiple of 32, found {x}"),
                        ));
                    }
                    x as u32
                }
            },
            skip: self.opt_int(&r.voxel_skip, "voxel_skip", 0..=voxel::MAX_SKIP as i64, 1)? as u32,
        };
        let visibility = match &r.visibility {
            None => Visibility::Bvh,
            Some(v) => match v.get_ref().as_str() {
                "bvh" => Visibility::Bvh,
                "voxel" => Visibility::Voxel(voxel),
                other => {
                    return Err(self.error(
                        v.span(),
                        format!("unknown visibility '{other}', expected one of \"bvh\", \"voxel\""),
                    ))
                }
            },
        };
        Ok((visibility, voxel))
    }

    /// The substitute-tree keys of a `many_light` `[integrand]`: ν_min in
    /// [0, 1], σ_max a finite distance ≥ 0.
    fn sst(&self, r: &RawIntegrand) -> Result<SubstituteParams> {
        let d = SubstituteParams::default();
        let num =
            |v: &Option<S<Num>>, name: &str, ok: &dyn Fn(f32) -> bool, what: &str, default: f32| {
                match v {
                    None => Ok(default),
                    Some(v) => {
                        let x = v.get_ref().0;
                        if ok(x) {
                            Ok(x)
                        } else {
                            Err(self.error(v.span(), format!("{name} must be {what}, found {x}")))
                        }
                    }
                }
            };
        Ok(SubstituteParams {
            nu_min: num(
                &r.sst_nu_min,
                "sst_nu_min",
                // 0 rendered black (issue 54 item 5): ν ≥ 0 admits every
                // node, the root included, as a substitute.
                &|x| x > 0.0 && x <= 1.0,
                "in (0, 1]",
                d.nu_min,
            )?,
            sigma_max: num(
                &r.sst_sigma_max,
                "sst_sigma_max",
                &|x| x >= 0.0 && x.is_finite(),
                "a finite distance ≥ 0",
                d.sigma_max,
            )?,
        })
    }

    /// A finite number ≥ 0 (`what` names it in the message), or `default`.
    fn finite_nonneg(
        &self,
        v: &Option<S<Num>>,
        key: &str,
        what: &str,
        default: f32,
    ) -> Result<f32> {
        match v {
            None => Ok(default),
            Some(v) => {
                let x = v.get_ref().0;
                if x >= 0.0 && x.is_finite() {
                    Ok(x)
                } else {
                    Err(self.error(
                        v.span(),
                        format!("{key} must be a finite {what} ≥ 0, found {x}"),
                    ))
                }
            }
        }
    }

    /// The lighting-grid keys of a `many_light` `[integrand]`.
    fn lgh(&self, r: &RawIntegrand) -> Result<LghParams> {
        let d = LghParams::default();
        let alpha = match &r.lgh_alpha {
            None => d.alpha,
            Some(v) => {
                let x = self.positive(v, "lgh_alpha")?;
                if x > lgh::MAX_ALPHA {
                    return Err(self.error(
                        v.span(),
                        format!("lgh_alpha must be at most {}, found {x}", lgh::MAX_ALPHA),
                    ));
                }
                x
            }
        };
        Ok(LghParams {
            levels: self.opt_int(&r.lgh_levels, "lgh_levels", 1..=lgh::MAX_LEVELS as i64, 0)?
                as u32,
            alpha,
            level0: r.lgh_level0.as_ref().map_or(d.level0, |v| *v.get_ref()),
            shadow_samples: self.opt_int(
                &r.lgh_shadows,
                "lgh_shadows",
                0..=lgh::MAX_SHADOW_SAMPLES as i64,
                d.shadow_samples as i64,
            )? as u32,
            clamp: self.finite_nonneg(&r.lgh_clamp, "lgh_clamp", "fraction", d.clamp)?,
        })
    }

    /// The VPL keys of a `many_light` `[integrand]`.
    fn vpl(&self, r: &RawIntegrand) -> Result<VplSpec> {
        let d = VplSpec::default();
        let bounces = self.opt_int(
            &r.vpl_bounces,
            "vpl_bounces",
            1..=vpl::MAX_BOUNCES as i64,
            d.bounces as i64,
        )? as u32;
        let max_paths = (vpl::MAX_VPLS / bounces) as i64;
        let paths = match &r.vpls {
            None => d.paths,
            Some(v) => {
                let x = *v.get_ref();
                if !(0..=max_paths).contains(&x) {
                    return Err(self.error(
                        v.span(),
                        format!(
                            "vpls must be in 0..={max_paths} (at most {} VPLs of {bounces} per path), found {x}",
                            vpl::MAX_VPLS
                        ),
                    ));
                }
                x as u32
            }
        };
        let clamp = self.finite_nonneg(&r.vpl_clamp, "vpl_clamp", "distance", d.clamp)?;
        Ok(VplSpec {
            paths,
            bounces,
            seed: self.u32(&r.vpl_seed, "vpl_seed", 0, d.seed)?,
            clamp,
        })
    }
}
