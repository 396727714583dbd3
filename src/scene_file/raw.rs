//! The file's tables as deserialized, before validation.

use super::values::*;
use serde::Deserialize;
use std::ops::Range;

// The file as written. Every validated value is Spanned so errors can
// point at it.

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawScene {
    pub(super) background: Option<S<V3>>,
    pub(super) film: S<RawFilm>,
    pub(super) camera: S<RawCamera>,
    #[serde(default)]
    pub(super) material: Vec<S<RawMaterial>>,
    #[serde(default)]
    pub(super) shape: Vec<S<RawShape>>,
    #[serde(default)]
    pub(super) light: Vec<S<RawLight>>,
    #[serde(default)]
    pub(super) light_set: Vec<S<RawLightSet>>,
    pub(super) integrand: Option<S<RawIntegrand>>,
    pub(super) mdas: Option<S<RawMdas>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawFilm {
    pub(super) width: S<i64>,
    pub(super) height: S<i64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawCamera {
    pub(super) position: S<V3>,
    pub(super) look_at: S<V3>,
    pub(super) up: S<V3>,
    pub(super) fov_y: S<Num>,
    pub(super) aperture_radius: Option<S<Num>>,
    pub(super) focus_distance: Option<S<Num>>,
    pub(super) shutter_open: Option<S<Num>>,
    pub(super) shutter_close: Option<S<Num>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawMaterial {
    pub(super) name: S<String>,
    pub(super) albedo: S<V3>,
    pub(super) emission: Option<S<V3>>,
    pub(super) checker: Option<S<RawChecker>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawChecker {
    pub(super) albedo2: S<V3>,
    pub(super) scale: S<Num>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawTransform {
    pub(super) translate: Option<S<V3>>,
    pub(super) rotate_y: Option<S<Num>>,
    pub(super) scale: Option<S<Scale>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawKeyframe {
    pub(super) time: S<Num>,
    pub(super) translate: Option<S<V3>>,
    pub(super) rotate: Option<S<Vec<Num>>>,
}

/// One `[[shape]]`: the union of every type's keys; [`Ctx::shape`] checks
/// that only the keys of the given `type` are present.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawShape {
    #[serde(rename = "type")]
    pub(super) kind: S<String>,
    pub(super) name: Option<S<String>>,
    /// Required except for `mesh`, where it overrides the OBJ's materials.
    pub(super) material: Option<S<String>>,
    pub(super) transform: Option<S<RawTransform>>,
    pub(super) motion: Option<S<Vec<S<RawKeyframe>>>>,
    pub(super) corners: Option<S<Vec<V3>>>,
    pub(super) vertices: Option<S<Vec<V3>>>,
    pub(super) min: Option<S<Vec<Num>>>,
    pub(super) max: Option<S<Vec<Num>>>,
    pub(super) center: Option<S<V3>>,
    pub(super) radius: Option<S<Num>>,
    pub(super) segments: Option<S<i64>>,
    pub(super) rings: Option<S<i64>>,
    pub(super) normal: Option<S<V3>>,
    pub(super) file: Option<S<String>>,
    pub(super) profile: Option<S<Vec<S<Vec<Num>>>>>,
    pub(super) resolution: Option<S<Vec<S<i64>>>>,
    pub(super) base_y: Option<S<Num>>,
    pub(super) amplitude: Option<S<Num>>,
    pub(super) frequency: Option<S<Num>>,
    pub(super) octaves: Option<S<i64>>,
    pub(super) seed: Option<S<i64>>,
    pub(super) subdivisions: Option<S<i64>>,
    pub(super) noise: Option<S<String>>,
}

/// (key, span) of each `Some` field among the listed ones.
macro_rules! present_keys {
    ($raw:expr; $($field:ident),*) => {{
        let mut keys: Vec<(&'static str, Range<usize>)> = Vec::new();
        $( if let Some(v) = &$raw.$field { keys.push((stringify!($field), v.span())); } )*
        keys
    }};
}

impl RawShape {
    pub(super) fn type_keys(&self) -> Vec<(&'static str, Range<usize>)> {
        present_keys!(self; corners, vertices, min, max, center, radius, segments, rings, normal,
            file, profile, resolution, base_y, amplitude, frequency, octaves, seed, subdivisions, noise)
    }
}

pub(super) const SHAPE_TYPES: [(&str, &[&str]); 9] = [
    ("quad", &["corners"]),
    ("triangle", &["vertices"]),
    ("box", &["min", "max"]),
    ("sphere", &["center", "radius", "segments", "rings"]),
    ("disk", &["center", "normal", "radius", "segments"]),
    ("mesh", &["file"]),
    ("lathe", &["profile", "segments", "center"]),
    (
        "heightfield",
        &[
            "min",
            "max",
            "resolution",
            "base_y",
            "amplitude",
            "frequency",
            "octaves",
            "seed",
            "noise",
        ],
    ),
    (
        "blob",
        &[
            "center",
            "radius",
            "subdivisions",
            "amplitude",
            "frequency",
            "octaves",
            "seed",
        ],
    ),
];

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawLight {
    #[serde(rename = "type")]
    pub(super) kind: S<String>,
    pub(super) position: Option<S<V3>>,
    pub(super) intensity: Option<S<V3>>,
    pub(super) direction: Option<S<V3>>,
    pub(super) irradiance: Option<S<V3>>,
    pub(super) corners: Option<S<Vec<V3>>>,
    pub(super) radiance: Option<S<V3>>,
}

impl RawLight {
    pub(super) fn type_keys(&self) -> Vec<(&'static str, Range<usize>)> {
        present_keys!(self; position, intensity, direction, irradiance, corners, radiance)
    }
}

pub(super) const LIGHT_TYPES: [(&str, &[&str]); 3] = [
    ("point", &["position", "intensity"]),
    ("directional", &["direction", "irradiance"]),
    ("quad", &["corners", "radiance"]),
];

/// One `[[light_set]]`: common keys plus the union of every type's keys
/// ([`RawLightSet::type_keys`], checked against [`LIGHT_SET_TYPES`]).
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawLightSet {
    #[serde(rename = "type")]
    pub(super) kind: S<String>,
    pub(super) intensity: Option<S<V3>>,
    pub(super) seed: Option<S<i64>>,
    pub(super) intensity_jitter: Option<S<Num>>,
    pub(super) color_jitter: Option<S<Num>>,
    pub(super) orbit_radius: Option<S<Num>>,
    pub(super) orbit_speed: Option<S<Num>>,
    pub(super) count: Option<S<i64>>,
    pub(super) min: Option<S<Vec<Num>>>,
    pub(super) max: Option<S<Vec<Num>>>,
    pub(super) offset: Option<S<Num>>,
    pub(super) resolution: Option<S<Vec<S<i64>>>>,
    pub(super) y: Option<S<Num>>,
}

impl RawLightSet {
    pub(super) fn type_keys(&self) -> Vec<(&'static str, Range<usize>)> {
        present_keys!(self; count, min, max, offset, resolution, y)
    }
}

pub(super) const LIGHT_SET_TYPES: [(&str, &[&str]); 3] = [
    ("box", &["count", "min", "max"]),
    ("surface", &["count", "offset"]),
    ("grid", &["min", "max", "resolution", "y"]),
];

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawIntegrand {
    #[serde(rename = "type")]
    pub(super) kind: S<String>,
    pub(super) max_bounces: Option<S<i64>>,
    pub(super) radius: Option<S<Num>>,
    pub(super) sampler: Option<S<String>>,
    pub(super) cut_size: Option<S<i64>>,
    pub(super) light_samples: Option<S<i64>>,
    pub(super) cut_sampling: Option<S<String>>,
    pub(super) block: Option<S<i64>>,
    pub(super) interleave: Option<S<i64>>,
    pub(super) time: Option<S<Num>>,
    pub(super) frame: Option<S<i64>>,
    pub(super) frame_duration: Option<S<Num>>,
    pub(super) vpls: Option<S<i64>>,
    pub(super) vpl_bounces: Option<S<i64>>,
    pub(super) vpl_seed: Option<S<i64>>,
    pub(super) vpl_clamp: Option<S<Num>>,
    pub(super) sst_nu_min: Option<S<Num>>,
    pub(super) sst_sigma_max: Option<S<Num>>,
    pub(super) lgh_levels: Option<S<i64>>,
    pub(super) lgh_alpha: Option<S<Num>>,
    pub(super) lgh_level0: Option<S<bool>>,
    pub(super) lgh_shadows: Option<S<i64>>,
    pub(super) lgh_clamp: Option<S<Num>>,
    // Visibility keys apply to every type (not in `type_keys`).
    pub(super) visibility: Option<S<String>>,
    pub(super) voxel_directions: Option<S<i64>>,
    pub(super) voxel_resolution: Option<S<i64>>,
    pub(super) voxel_skip: Option<S<i64>>,
}

impl RawIntegrand {
    pub(super) fn type_keys(&self) -> Vec<(&'static str, Range<usize>)> {
        present_keys!(self; max_bounces, radius, sampler, cut_size, light_samples, cut_sampling, block, interleave, time, frame,
            frame_duration,
            vpls, vpl_bounces, vpl_seed, vpl_clamp, sst_nu_min, sst_sigma_max, lgh_levels,
            lgh_alpha, lgh_level0, lgh_shadows, lgh_clamp)
    }
}

pub(super) const INTEGRAND_TYPES: [(&str, &[&str]); 6] = [
    ("area_light", &[]),
    ("depth_of_field", &[]),
    ("motion_blur", &[]),
    ("path", &["max_bounces"]),
    ("ambient_occlusion", &["radius"]),
    (
        "many_light",
        &[
            "sampler",
            "cut_size",
            "light_samples",
            "cut_sampling",
            "block",
            "interleave",
            "time",
            "frame",
            "frame_duration",
            "vpls",
            "vpl_bounces",
            "vpl_seed",
            "vpl_clamp",
            "sst_nu_min",
            "sst_sigma_max",
            "lgh_levels",
            "lgh_alpha",
            "lgh_level0",
            "lgh_shadows",
            "lgh_clamp",
        ],
    ),
];

/// `[mdas]`: keys and values as written; the keys, their kinds and their
/// ranges are the integrator's registry's (`mdas.rs`).
pub(super) type RawMdas = std::collections::BTreeMap<S<String>, S<Loose>>;
