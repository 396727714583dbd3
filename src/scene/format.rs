//! The TOML scene file: parsing, validation and tessellation into a
//! [`Scene`]. The full reference, with a table per section, is
//! `docs/scene-format.md`; in short:
//!
//! ```text
//! background = [0, 0, 0]                 # radiance of missed rays
//! [film]      width = 256, height = 256  # 1..=16384 each, ≤ 2^26 pixels
//! [camera]    position, look_at, up, fov_y (degrees, full vertical),
//!             aperture_radius = 0, focus_distance = |look_at − position|,
//!             shutter_open = 0, shutter_close = 1
//! [[material]] name, albedo ∈ [0,1]³, emission ≥ 0 (= 0),
//!              checker = { albedo2, scale }
//! [[shape]]   type = quad | triangle | box | sphere | disk | mesh | lathe
//!             | heightfield | blob, material = "name", name,
//!             transform = { translate, rotate_y, scale },
//!             motion = [{ time, translate, rotate = [ax, ay, az, deg] }, …]
//! [[light]]   type = point (position, intensity) | directional (direction,
//!             irradiance) | quad (corners, radiance → emissive mesh "light{n}")
//! [[light_set]] type = box (count, min, max) | surface (count, offset)
//!             | grid (min, max, resolution, y); intensity, seed,
//!             intensity_jitter, color_jitter, orbit_radius, orbit_speed
//! [integrand] type = area_light | depth_of_field | motion_blur
//!             | path (max_bounces = 1) | ambient_occlusion (radius)
//!             | many_light (sampler, cut_size, block, interleave, time, frame)
//! [mdas]      bits_per_dim, extra_image_bits, initial_samples_per_cell,
//!             scale_factor, alpha, candidates, max_samples_per_leaf, spp, seed
//! ```
//!
//! Every error — TOML syntax, unknown keys, wrong types, NaN/Inf, values
//! out of range, unknown material names, unreadable mesh files — is a
//! [`SceneError`] whose message starts with `file:line:column:` pointing at
//! the offending value. Nothing here panics on any input.
//!
//! Shapes are tessellated by [`super::shapes`] (OBJ files by
//! [`super::obj`]), then `transform` (scale, then rotate about y, then
//! translate) is applied to the vertices. With `motion`, the mesh keeps
//! these object-space vertices and the keyframes move it over time.

use super::shapes::{self, TriMesh};
use super::{
    Camera, Checker, Film, IntegrandSpec, Keyframe, Light, ManyLightSpec, Material, MdasParams,
    Mesh, PointLightSet, Scene, SetLight, MANY_LIGHT_SAMPLERS,
};
use glam::{Affine3A, Quat, Vec2, Vec3};
use serde::de::{self, Deserializer, SeqAccess, Visitor};
use serde::Deserialize;
use std::collections::HashMap;
use std::fmt;
use std::ops::{Range, RangeInclusive};
use std::path::{Path, PathBuf};
use toml::Spanned;

/// Largest film side, in pixels.
pub const MAX_FILM_SIDE: i64 = 16384;
/// Largest film area, in pixels.
pub const MAX_FILM_PIXELS: i64 = 1 << 26;
/// Largest number of triangles one shape may tessellate to.
pub const MAX_SHAPE_TRIANGLES: u64 = 1 << 25;
/// Largest number of point lights all `[[light_set]]`s together may generate.
pub const MAX_SET_LIGHTS: u64 = 1 << 24;
/// Largest `cut_size` of the `many_light` integrand.
pub const MAX_CUT_SIZE: u32 = 64;

/// Why a scene could not be loaded.
#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    /// The scene file itself could not be read.
    #[error("cannot read {}: {error}", path.display())]
    Io {
        path: PathBuf,
        error: std::io::Error,
    },
    /// Anything wrong inside the file; `line` and `column` are 1-based and
    /// point at the offending value (or key, or table).
    #[error("{}:{line}:{column}: {message}", file.display())]
    Invalid {
        file: PathBuf,
        line: usize,
        column: usize,
        message: String,
    },
}

impl SceneError {
    /// (line, column), 1-based, for errors inside the file.
    pub fn position(&self) -> Option<(usize, usize)> {
        match self {
            SceneError::Io { .. } => None,
            SceneError::Invalid { line, column, .. } => Some((*line, *column)),
        }
    }
}

/// The largest scene file read (scene files are a few KiB; meshes live in
/// their own files).
pub const MAX_SCENE_BYTES: u64 = 16 << 20;

/// Read and load a scene file.
pub fn load(path: &Path) -> Result<Scene, SceneError> {
    let io = |error| SceneError::Io {
        path: path.to_path_buf(),
        error,
    };
    let bytes = super::read_input(path, MAX_SCENE_BYTES).map_err(io)?;
    let text = String::from_utf8(bytes).map_err(|_| {
        io(std::io::Error::new(
            std::io::ErrorKind::InvalidData,
            "not UTF-8 text",
        ))
    })?;
    parse(&text, path)
}

/// Load a scene from TOML text. `file_name` names the file in messages,
/// and relative mesh paths are resolved against its directory.
pub fn parse(text: &str, file_name: &Path) -> Result<Scene, SceneError> {
    let ctx = Ctx {
        text,
        file: file_name,
    };
    let raw: RawScene = toml::from_str(text).map_err(|e| ctx.toml_error(&e))?;
    ctx.scene(raw)
}

// ---------------------------------------------------------------------
// Value types with their own checks at deserialization time (the TOML
// deserializer attaches the value's span to their errors).

type S<T> = Spanned<T>;

/// A finite number that fits an f32; integers are accepted.
#[derive(Clone, Copy, Debug)]
struct Num(f32);

impl Num {
    fn finite<E: de::Error>(v: f64) -> Result<Num, E> {
        let x = v as f32;
        if !v.is_finite() {
            // TOML spells them nan, inf, -inf.
            Err(E::custom(format!(
                "expected a finite number, found {}",
                v.to_string().to_lowercase()
            )))
        } else if !x.is_finite() {
            Err(E::custom(format!("number {v:e} is out of range")))
        } else {
            Ok(Num(x))
        }
    }
}

impl<'de> Deserialize<'de> for Num {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = Num;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("a number")
            }
            fn visit_f64<E: de::Error>(self, v: f64) -> Result<Num, E> {
                Num::finite(v)
            }
            fn visit_i64<E: de::Error>(self, v: i64) -> Result<Num, E> {
                Num::finite(v as f64)
            }
            fn visit_u64<E: de::Error>(self, v: u64) -> Result<Num, E> {
                Num::finite(v as f64)
            }
        }
        d.deserialize_any(V)
    }
}

/// Read a sequence of numbers, counting (not keeping) any beyond `max`.
fn numbers<'de, A: SeqAccess<'de>>(mut seq: A, max: usize) -> Result<(Vec<f32>, usize), A::Error> {
    let mut values = Vec::new();
    let mut count = 0;
    while count < max {
        match seq.next_element::<Num>()? {
            Some(Num(x)) => values.push(x),
            None => return Ok((values, count)),
        }
        count += 1;
    }
    while seq.next_element::<de::IgnoredAny>()?.is_some() {
        count += 1;
    }
    Ok((values, count))
}

/// `[x, y, z]`: exactly three finite numbers.
#[derive(Clone, Copy, Debug)]
struct V3(Vec3);

impl<'de> Deserialize<'de> for V3 {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = V3;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("an array of 3 numbers")
            }
            fn visit_seq<A: SeqAccess<'de>>(self, seq: A) -> Result<V3, A::Error> {
                match numbers(seq, 3)? {
                    (v, 3) => Ok(V3(Vec3::new(v[0], v[1], v[2]))),
                    (_, n) => Err(de::Error::custom(format!(
                        "expected an array of 3 numbers, found {n} element{}",
                        if n == 1 { "" } else { "s" }
                    ))),
                }
            }
        }
        d.deserialize_any(V)
    }
}

/// `scale = s` or `scale = [sx, sy, sz]`.
#[derive(Clone, Copy, Debug)]
struct Scale(Vec3);

impl<'de> Deserialize<'de> for Scale {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = Scale;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("a number or an array of 3 numbers")
            }
            fn visit_f64<E: de::Error>(self, v: f64) -> Result<Scale, E> {
                Num::finite(v).map(|Num(s)| Scale(Vec3::splat(s)))
            }
            fn visit_i64<E: de::Error>(self, v: i64) -> Result<Scale, E> {
                self.visit_f64(v as f64)
            }
            fn visit_u64<E: de::Error>(self, v: u64) -> Result<Scale, E> {
                self.visit_f64(v as f64)
            }
            fn visit_seq<A: SeqAccess<'de>>(self, seq: A) -> Result<Scale, A::Error> {
                V3::deserialize(de::value::SeqAccessDeserializer::new(seq)).map(|v| Scale(v.0))
            }
        }
        d.deserialize_any(V)
    }
}

// ---------------------------------------------------------------------
// The file as written. Every validated value is Spanned so errors can
// point at it.

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawScene {
    background: Option<S<V3>>,
    film: S<RawFilm>,
    camera: S<RawCamera>,
    #[serde(default)]
    material: Vec<S<RawMaterial>>,
    #[serde(default)]
    shape: Vec<S<RawShape>>,
    #[serde(default)]
    light: Vec<S<RawLight>>,
    #[serde(default)]
    light_set: Vec<S<RawLightSet>>,
    integrand: Option<S<RawIntegrand>>,
    mdas: Option<S<RawMdas>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawFilm {
    width: S<i64>,
    height: S<i64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawCamera {
    position: S<V3>,
    look_at: S<V3>,
    up: S<V3>,
    fov_y: S<Num>,
    aperture_radius: Option<S<Num>>,
    focus_distance: Option<S<Num>>,
    shutter_open: Option<S<Num>>,
    shutter_close: Option<S<Num>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawMaterial {
    name: S<String>,
    albedo: S<V3>,
    emission: Option<S<V3>>,
    checker: Option<S<RawChecker>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawChecker {
    albedo2: S<V3>,
    scale: S<Num>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawTransform {
    translate: Option<S<V3>>,
    rotate_y: Option<S<Num>>,
    scale: Option<S<Scale>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawKeyframe {
    time: S<Num>,
    translate: Option<S<V3>>,
    rotate: Option<S<Vec<Num>>>,
}

/// One `[[shape]]`: the union of every type's keys; [`Ctx::shape`] checks
/// that only the keys of the given `type` are present.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawShape {
    #[serde(rename = "type")]
    kind: S<String>,
    name: Option<S<String>>,
    material: S<String>,
    transform: Option<S<RawTransform>>,
    motion: Option<S<Vec<S<RawKeyframe>>>>,
    corners: Option<S<Vec<V3>>>,
    vertices: Option<S<Vec<V3>>>,
    min: Option<S<Vec<Num>>>,
    max: Option<S<Vec<Num>>>,
    center: Option<S<V3>>,
    radius: Option<S<Num>>,
    segments: Option<S<i64>>,
    rings: Option<S<i64>>,
    normal: Option<S<V3>>,
    file: Option<S<String>>,
    profile: Option<S<Vec<S<Vec<Num>>>>>,
    resolution: Option<S<Vec<S<i64>>>>,
    base_y: Option<S<Num>>,
    amplitude: Option<S<Num>>,
    frequency: Option<S<Num>>,
    octaves: Option<S<i64>>,
    seed: Option<S<i64>>,
    subdivisions: Option<S<i64>>,
    noise: Option<S<String>>,
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
    fn type_keys(&self) -> Vec<(&'static str, Range<usize>)> {
        present_keys!(self; corners, vertices, min, max, center, radius, segments, rings, normal,
            file, profile, resolution, base_y, amplitude, frequency, octaves, seed, subdivisions, noise)
    }
}

const SHAPE_TYPES: [(&str, &[&str]); 9] = [
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
struct RawLight {
    #[serde(rename = "type")]
    kind: S<String>,
    position: Option<S<V3>>,
    intensity: Option<S<V3>>,
    direction: Option<S<V3>>,
    irradiance: Option<S<V3>>,
    corners: Option<S<Vec<V3>>>,
    radiance: Option<S<V3>>,
}

impl RawLight {
    fn type_keys(&self) -> Vec<(&'static str, Range<usize>)> {
        present_keys!(self; position, intensity, direction, irradiance, corners, radiance)
    }
}

const LIGHT_TYPES: [(&str, &[&str]); 3] = [
    ("point", &["position", "intensity"]),
    ("directional", &["direction", "irradiance"]),
    ("quad", &["corners", "radiance"]),
];

/// One `[[light_set]]`: common keys plus the union of every type's keys
/// ([`RawLightSet::type_keys`], checked against [`LIGHT_SET_TYPES`]).
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawLightSet {
    #[serde(rename = "type")]
    kind: S<String>,
    intensity: Option<S<V3>>,
    seed: Option<S<i64>>,
    intensity_jitter: Option<S<Num>>,
    color_jitter: Option<S<Num>>,
    orbit_radius: Option<S<Num>>,
    orbit_speed: Option<S<Num>>,
    count: Option<S<i64>>,
    min: Option<S<Vec<Num>>>,
    max: Option<S<Vec<Num>>>,
    offset: Option<S<Num>>,
    resolution: Option<S<Vec<S<i64>>>>,
    y: Option<S<Num>>,
}

impl RawLightSet {
    fn type_keys(&self) -> Vec<(&'static str, Range<usize>)> {
        present_keys!(self; count, min, max, offset, resolution, y)
    }
}

const LIGHT_SET_TYPES: [(&str, &[&str]); 3] = [
    ("box", &["count", "min", "max"]),
    ("surface", &["count", "offset"]),
    ("grid", &["min", "max", "resolution", "y"]),
];

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawIntegrand {
    #[serde(rename = "type")]
    kind: S<String>,
    max_bounces: Option<S<i64>>,
    radius: Option<S<Num>>,
    sampler: Option<S<String>>,
    cut_size: Option<S<i64>>,
    block: Option<S<i64>>,
    interleave: Option<S<i64>>,
    time: Option<S<Num>>,
    frame: Option<S<i64>>,
}

impl RawIntegrand {
    fn type_keys(&self) -> Vec<(&'static str, Range<usize>)> {
        present_keys!(self; max_bounces, radius, sampler, cut_size, block, interleave, time, frame)
    }
}

const INTEGRAND_TYPES: [(&str, &[&str]); 6] = [
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
            "block",
            "interleave",
            "time",
            "frame",
        ],
    ),
];

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawMdas {
    bits_per_dim: Option<S<i64>>,
    extra_image_bits: Option<S<i64>>,
    initial_samples_per_cell: Option<S<i64>>,
    scale_factor: Option<S<Num>>,
    alpha: Option<S<Num>>,
    candidates: Option<S<i64>>,
    max_samples_per_leaf: Option<S<i64>>,
    spp: Option<S<Num>>,
    seed: Option<S<i64>>,
}

// ---------------------------------------------------------------------
// Validation and construction.

struct Ctx<'a> {
    text: &'a str,
    file: &'a Path,
}

type Result<T, E = SceneError> = std::result::Result<T, E>;

fn quoted_list(items: &[&str]) -> String {
    items
        .iter()
        .map(|s| format!("'{s}'"))
        .collect::<Vec<_>>()
        .join(", ")
}

impl Ctx<'_> {
    /// 1-based line and column (in characters) of a byte offset.
    fn line_column(&self, offset: usize) -> (usize, usize) {
        let mut offset = offset.min(self.text.len());
        while !self.text.is_char_boundary(offset) {
            offset -= 1;
        }
        let before = &self.text[..offset];
        let line_start = before.rfind('\n').map_or(0, |i| i + 1);
        (
            before.matches('\n').count() + 1,
            before[line_start..].chars().count() + 1,
        )
    }

    fn error(&self, span: Range<usize>, message: impl Into<String>) -> SceneError {
        let (line, column) = self.line_column(span.start);
        SceneError::Invalid {
            file: self.file.to_path_buf(),
            line,
            column,
            message: message.into(),
        }
    }

    fn toml_error(&self, e: &toml::de::Error) -> SceneError {
        let message = e
            .message()
            .trim()
            .replace('`', "'")
            .replace("expected i64", "expected an integer")
            .lines()
            .map(str::trim)
            .filter(|l| !l.is_empty())
            .collect::<Vec<_>>()
            .join("; ");
        self.error(e.span().unwrap_or(0..0), message)
    }

    fn int(&self, v: &S<i64>, key: &str, range: RangeInclusive<i64>) -> Result<i64> {
        let x = *v.get_ref();
        if range.contains(&x) {
            Ok(x)
        } else if x < *range.start() {
            Err(self.error(
                v.span(),
                format!("{key} must be at least {}, found {x}", range.start()),
            ))
        } else {
            Err(self.error(
                v.span(),
                format!("{key} must be at most {}, found {x}", range.end()),
            ))
        }
    }

    fn opt_int(
        &self,
        v: &Option<S<i64>>,
        key: &str,
        range: RangeInclusive<i64>,
        default: i64,
    ) -> Result<i64> {
        v.as_ref().map_or(Ok(default), |v| self.int(v, key, range))
    }

    fn u32(&self, v: &Option<S<i64>>, key: &str, min: u32, default: u32) -> Result<u32> {
        Ok(self.opt_int(v, key, min as i64..=u32::MAX as i64, default as i64)? as u32)
    }

    fn positive(&self, v: &S<Num>, key: &str) -> Result<f32> {
        let x = v.get_ref().0;
        if x > 0.0 {
            Ok(x)
        } else {
            Err(self.error(v.span(), format!("{key} must be > 0, found {x}")))
        }
    }

    fn non_negative(&self, v: &S<Num>, key: &str) -> Result<f32> {
        let x = v.get_ref().0;
        if x >= 0.0 {
            Ok(x)
        } else {
            Err(self.error(v.span(), format!("{key} must be ≥ 0, found {x}")))
        }
    }

    /// An RGB triple with every channel ≥ 0 (radiance, intensity, …).
    fn rgb(&self, v: &S<V3>, key: &str) -> Result<Vec3> {
        let c = v.get_ref().0;
        if c.min_element() >= 0.0 {
            Ok(c)
        } else {
            Err(self.error(
                v.span(),
                format!("{key} must be ≥ 0 in every channel, found {}", fmt3(c)),
            ))
        }
    }

    /// An albedo: every channel in [0, 1].
    fn albedo(&self, v: &S<V3>, key: &str) -> Result<Vec3> {
        let c = v.get_ref().0;
        if c.min_element() >= 0.0 && c.max_element() <= 1.0 {
            Ok(c)
        } else {
            Err(self.error(
                v.span(),
                format!(
                    "{key} must be in [0, 1] in every channel, found {}",
                    fmt3(c)
                ),
            ))
        }
    }

    fn nonzero(&self, v: &S<V3>, key: &str) -> Result<Vec3> {
        let d = v.get_ref().0;
        match d.try_normalize() {
            Some(n) => Ok(n),
            None => Err(self.error(v.span(), format!("{key} must be a nonzero vector"))),
        }
    }

    /// `n` numbers from an array key, e.g. `min = [x, z]`.
    fn array<const N: usize>(&self, v: &S<Vec<Num>>, key: &str, form: &str) -> Result<[f32; N]> {
        let values = v.get_ref();
        if values.len() != N {
            return Err(self.error(
                v.span(),
                format!(
                    "{key} must be {form} ({N} numbers), found {} elements",
                    values.len()
                ),
            ));
        }
        Ok(std::array::from_fn(|i| values[i].0))
    }

    fn points<const N: usize>(&self, v: &S<Vec<V3>>, key: &str) -> Result<[Vec3; N]> {
        let values = v.get_ref();
        if values.len() != N {
            return Err(self.error(
                v.span(),
                format!(
                    "{key} must be an array of {N} points [x, y, z], found {}",
                    values.len()
                ),
            ));
        }
        Ok(std::array::from_fn(|i| values[i].0))
    }

    fn scene(&self, raw: RawScene) -> Result<Scene> {
        let background = match &raw.background {
            Some(b) => self.rgb(b, "background")?,
            None => Vec3::ZERO,
        };
        let film = self.film(raw.film.get_ref())?;
        let camera = self.camera(raw.camera.get_ref())?;

        let mut materials = Vec::with_capacity(raw.material.len());
        let mut by_name: HashMap<&str, u32> = HashMap::new();
        for m in &raw.material {
            let m = m.get_ref();
            let name = m.name.get_ref().as_str();
            if by_name.insert(name, materials.len() as u32).is_some() {
                return Err(
                    self.error(m.name.span(), format!("material '{name}' is defined twice"))
                );
            }
            materials.push(self.material(m)?);
        }

        let mut meshes = Vec::with_capacity(raw.shape.len());
        for (n, s) in raw.shape.iter().enumerate() {
            meshes.push(self.shape(s, n, &by_name)?);
        }

        let mut lights = Vec::new();
        for (n, l) in raw.light.iter().enumerate() {
            match self.light(l)? {
                LightOut::Delta(light) => lights.push(light),
                LightOut::Area { corners, radiance } => {
                    let name = format!("light{n}");
                    let mesh = shapes::quad(corners);
                    meshes.push(Mesh {
                        name: name.clone(),
                        positions: mesh.positions,
                        indices: mesh.indices,
                        material: materials.len() as u32,
                        motion: Vec::new(),
                    });
                    materials.push(Material {
                        name,
                        albedo: Vec3::ZERO,
                        emission: radiance,
                        checker: None,
                    });
                }
            }
        }

        let mut point_light_sets = Vec::with_capacity(raw.light_set.len());
        let mut surfaces: Option<Surfaces> = None;
        let mut set_lights = 0u64;
        for set in &raw.light_set {
            let r = set.get_ref();
            let t = self.check_type("light_set", &r.kind, &r.type_keys(), &LIGHT_SET_TYPES)?;
            if LIGHT_SET_TYPES[t].0 == "surface" && surfaces.is_none() {
                surfaces = Some(Surfaces::new(&meshes, &materials));
            }
            let generated = self.light_set(r, t, surfaces.as_ref(), set_lights)?;
            set_lights += generated.lights.len() as u64;
            point_light_sets.push(generated);
        }

        let integrand = match &raw.integrand {
            None => IntegrandSpec::AreaLight,
            Some(i) => {
                let emissive = meshes
                    .iter()
                    .any(|m| materials[m.material as usize].emission.max_element() > 0.0);
                self.integrand(i.get_ref(), emissive)?
            }
        };
        let mdas = match &raw.mdas {
            Some(m) => self.mdas(m.get_ref())?,
            None => MdasParams::default(),
        };
        Ok(Scene {
            film,
            camera,
            background,
            materials,
            meshes,
            lights,
            point_light_sets,
            integrand,
            mdas,
        })
    }

    fn film(&self, f: &RawFilm) -> Result<Film> {
        let side = |v: &S<i64>, key: &str| {
            let x = *v.get_ref();
            if x <= 0 {
                Err(self.error(v.span(), format!("film {key} must be positive, found {x}")))
            } else if x > MAX_FILM_SIDE {
                Err(self.error(
                    v.span(),
                    format!("film {key} {x} is absurdly large (at most {MAX_FILM_SIDE})"),
                ))
            } else {
                Ok(x)
            }
        };
        let (w, h) = (side(&f.width, "width")?, side(&f.height, "height")?);
        if w * h > MAX_FILM_PIXELS {
            return Err(self.error(
                f.height.span(),
                format!(
                    "film {w}×{h} = {} pixels is absurdly large (at most 2^26 = {MAX_FILM_PIXELS})",
                    w * h
                ),
            ));
        }
        Ok(Film {
            width: w as u32,
            height: h as u32,
        })
    }

    fn camera(&self, c: &RawCamera) -> Result<Camera> {
        let (position, look_at) = (c.position.get_ref().0, c.look_at.get_ref().0);
        let Some(forward) = (look_at - position).try_normalize() else {
            return Err(self.error(c.look_at.span(), "camera look_at must differ from position"));
        };
        let up = self.nonzero(&c.up, "camera up")?;
        if forward.cross(up).length() < 1e-4 {
            return Err(self.error(
                c.up.span(),
                "camera up must not be parallel to the view direction",
            ));
        }
        let fov_y = c.fov_y.get_ref().0;
        if !(fov_y > 0.0 && fov_y < 180.0) {
            return Err(self.error(
                c.fov_y.span(),
                format!("fov_y must be in (0, 180) degrees, found {fov_y}"),
            ));
        }
        let aperture_radius = match &c.aperture_radius {
            Some(a) => self.non_negative(a, "aperture_radius")?,
            None => 0.0,
        };
        let focus_distance = match &c.focus_distance {
            Some(d) => self.positive(d, "focus_distance")?,
            None => (look_at - position).length(),
        };
        let shutter_open = c.shutter_open.as_ref().map_or(0.0, |t| t.get_ref().0);
        let shutter_close = c.shutter_close.as_ref().map_or(1.0, |t| t.get_ref().0);
        if shutter_close <= shutter_open {
            let span = c
                .shutter_close
                .as_ref()
                .or(c.shutter_open.as_ref())
                .map(|t| t.span());
            return Err(self.error(
                span.unwrap_or(0..0),
                format!("shutter_close ({shutter_close}) must be greater than shutter_open ({shutter_open})"),
            ));
        }
        Ok(Camera {
            position,
            look_at,
            up: c.up.get_ref().0,
            fov_y,
            aperture_radius,
            focus_distance,
            shutter_open,
            shutter_close,
        })
    }

    fn material(&self, m: &RawMaterial) -> Result<Material> {
        let checker = match &m.checker {
            Some(c) => {
                let c = c.get_ref();
                Some(Checker {
                    albedo2: self.albedo(&c.albedo2, "checker albedo2")?,
                    scale: self.positive(&c.scale, "checker scale")?,
                })
            }
            None => None,
        };
        Ok(Material {
            name: m.name.get_ref().clone(),
            albedo: self.albedo(&m.albedo, "albedo")?,
            emission: match &m.emission {
                Some(e) => self.rgb(e, "emission")?,
                None => Vec3::ZERO,
            },
            checker,
        })
    }

    /// Check the key set of a typed table against its type's keys; returns
    /// the index of the type in `types`.
    fn check_type(
        &self,
        what: &str,
        kind: &S<String>,
        keys: &[(&'static str, Range<usize>)],
        types: &[(&str, &[&str])],
    ) -> Result<usize> {
        let name = kind.get_ref().as_str();
        let Some(t) = types.iter().position(|(n, _)| *n == name) else {
            let names: Vec<&str> = types.iter().map(|(n, _)| *n).collect();
            return Err(self.error(
                kind.span(),
                format!(
                    "unknown {what} type '{name}', expected one of {}",
                    quoted_list(&names)
                ),
            ));
        };
        let allowed = types[t].1;
        if let Some((key, span)) = keys.iter().find(|(k, _)| !allowed.contains(k)) {
            let keys = if allowed.is_empty() {
                "it takes no other keys".to_string()
            } else {
                format!("its keys: {}", quoted_list(allowed))
            };
            return Err(self.error(
                span.clone(),
                format!("key '{key}' does not apply to a {name} {what} ({keys})"),
            ));
        }
        Ok(t)
    }

    fn need<'v, T>(
        &self,
        v: &'v Option<S<T>>,
        key: &str,
        kind: &S<String>,
        what: &str,
    ) -> Result<&'v S<T>> {
        v.as_ref().ok_or_else(|| {
            self.error(
                kind.span(),
                format!("a {} {what} needs '{key}'", kind.get_ref()),
            )
        })
    }

    fn count_check(&self, triangles: u64, span: Range<usize>, kind: &str) -> Result<()> {
        if triangles > MAX_SHAPE_TRIANGLES {
            return Err(self.error(
                span,
                format!(
                    "this {kind} would have {triangles} triangles: absurdly large (at most {MAX_SHAPE_TRIANGLES} per shape)"
                ),
            ));
        }
        Ok(())
    }

    /// Four planar corners of a quad, in order around it.
    fn quad_corners(&self, v: &S<Vec<V3>>) -> Result<[Vec3; 4]> {
        let c: [Vec3; 4] = self.points(v, "corners")?;
        let n012 = (c[1] - c[0]).cross(c[2] - c[0]);
        let n023 = (c[2] - c[0]).cross(c[3] - c[0]);
        // Newell-style normal of the whole polygon, robust to one
        // degenerate triangle.
        if let Some(n) = (n012 + n023).try_normalize() {
            let center = (c[0] + c[1] + c[2] + c[3]) / 4.0;
            let size = c.iter().map(|p| (*p - center).length()).fold(0.0, f32::max);
            let off = c
                .iter()
                .map(|p| (*p - center).dot(n).abs())
                .fold(0.0, f32::max);
            if off > 1e-4 * size {
                return Err(self.error(
                    v.span(),
                    format!("quad corners must be planar: a corner is {off} off their mean plane"),
                ));
            }
            if n012.dot(n023) < 0.0 {
                return Err(self.error(
                    v.span(),
                    "quad corners must be listed in order around the quad (these make a bow tie)",
                ));
            }
        }
        Ok(c)
    }

    fn shape(&self, s: &S<RawShape>, n: usize, materials: &HashMap<&str, u32>) -> Result<Mesh> {
        let r = s.get_ref();
        let keys = r.type_keys();
        let t = self.check_type("shape", &r.kind, &keys, &SHAPE_TYPES)?;
        let kind = SHAPE_TYPES[t].0;
        let material = match materials.get(r.material.get_ref().as_str()) {
            Some(&m) => m,
            None => {
                let mut known: Vec<&str> = materials.keys().copied().collect();
                known.sort_unstable();
                return Err(self.error(
                    r.material.span(),
                    format!(
                        "unknown material '{}' (defined: {})",
                        r.material.get_ref(),
                        if known.is_empty() {
                            "none".into()
                        } else {
                            quoted_list(&known)
                        }
                    ),
                ));
            }
        };
        // Where "this geometry is degenerate" points.
        let geometry_span = keys.first().map_or(r.kind.span(), |(_, span)| span.clone());
        let center = r.center.as_ref().map_or(Vec3::ZERO, |c| c.get_ref().0);
        let segments = |default| self.opt_int(&r.segments, "segments", 3..=1 << 20, default);

        let mut mesh = match kind {
            "quad" => shapes::quad(
                self.quad_corners(self.need(&r.corners, "corners", &r.kind, "shape")?)?,
            ),
            "triangle" => shapes::triangle(self.points(
                self.need(&r.vertices, "vertices", &r.kind, "shape")?,
                "vertices",
            )?),
            "box" => {
                let min = Vec3::from(self.array::<3>(
                    self.need(&r.min, "min", &r.kind, "shape")?,
                    "min",
                    "[x, y, z]",
                )?);
                let max_v = self.need(&r.max, "max", &r.kind, "shape")?;
                let max = Vec3::from(self.array::<3>(max_v, "max", "[x, y, z]")?);
                if !max.cmpgt(min).all() {
                    return Err(self.error(
                        max_v.span(),
                        "box max must be greater than min in x, y and z",
                    ));
                }
                shapes::cuboid(min, max)
            }
            "sphere" => {
                let radius =
                    self.positive(self.need(&r.radius, "radius", &r.kind, "shape")?, "radius")?;
                let segments = segments(32)?;
                let rings = self.opt_int(&r.rings, "rings", 2..=1 << 20, 16)?;
                let span = r
                    .segments
                    .as_ref()
                    .or(r.rings.as_ref())
                    .map_or(geometry_span.clone(), |v| v.span());
                self.count_check(
                    shapes::uv_sphere_triangles(segments as u64, rings as u64),
                    span,
                    kind,
                )?;
                shapes::uv_sphere(center, radius, segments as u32, rings as u32)
            }
            "disk" => {
                let normal =
                    self.nonzero(self.need(&r.normal, "normal", &r.kind, "shape")?, "normal")?;
                let radius =
                    self.positive(self.need(&r.radius, "radius", &r.kind, "shape")?, "radius")?;
                let segments = segments(32)?;
                let span = r
                    .segments
                    .as_ref()
                    .map_or(geometry_span.clone(), |v| v.span());
                self.count_check(segments as u64, span, kind)?;
                shapes::disk(center, normal, radius, segments as u32)
            }
            "mesh" => {
                let file = self.need(&r.file, "file", &r.kind, "shape")?;
                let dir = self.file.parent().unwrap_or(Path::new(""));
                let path = dir.join(file.get_ref());
                super::obj::load_obj(&path).map_err(|e| self.error(file.span(), e))?
            }
            "lathe" => {
                let profile_v = self.need(&r.profile, "profile", &r.kind, "shape")?;
                let mut profile = Vec::with_capacity(profile_v.get_ref().len());
                for p in profile_v.get_ref() {
                    let [radius, height] =
                        self.array::<2>(p, "profile point", "[radius, height]")?;
                    if radius < 0.0 {
                        return Err(self.error(
                            p.span(),
                            format!("profile radius must be ≥ 0, found {radius}"),
                        ));
                    }
                    profile.push(Vec2::new(radius, height));
                }
                if profile.len() < 2 {
                    return Err(
                        self.error(profile_v.span(), "a lathe profile needs at least 2 points")
                    );
                }
                let segments = segments(32)?;
                let span = r.segments.as_ref().map_or(profile_v.span(), |v| v.span());
                self.count_check(
                    shapes::lathe_triangles(profile.len() as u64, segments as u64),
                    span,
                    kind,
                )?;
                shapes::lathe(&profile, segments as u32, center)
            }
            "heightfield" => {
                let min = Vec2::from(self.array::<2>(
                    self.need(&r.min, "min", &r.kind, "shape")?,
                    "heightfield min",
                    "[x, z]",
                )?);
                let max_v = self.need(&r.max, "max", &r.kind, "shape")?;
                let max = Vec2::from(self.array::<2>(max_v, "heightfield max", "[x, z]")?);
                if !max.cmpgt(min).all() {
                    return Err(self.error(
                        max_v.span(),
                        "heightfield max must be greater than min in x and z",
                    ));
                }
                let res_v = self.need(&r.resolution, "resolution", &r.kind, "shape")?;
                let res = res_v.get_ref();
                if res.len() != 2 {
                    return Err(self.error(
                        res_v.span(),
                        format!("resolution must be [nx, nz], found {} elements", res.len()),
                    ));
                }
                let nx = self.int(&res[0], "resolution nx", 1..=1 << 24)?;
                let nz = self.int(&res[1], "resolution nz", 1..=1 << 24)?;
                self.count_check(
                    shapes::heightfield_triangles(nx as u64, nz as u64),
                    res_v.span(),
                    kind,
                )?;
                let noise = match &r.noise {
                    None => shapes::HeightNoise::Fbm,
                    Some(v) => match v.get_ref().as_str() {
                        "fbm" => shapes::HeightNoise::Fbm,
                        "cells" => shapes::HeightNoise::Cells,
                        other => {
                            return Err(self.error(
                                v.span(),
                                format!("unknown noise '{other}', expected one of 'fbm', 'cells'"),
                            ))
                        }
                    },
                };
                shapes::heightfield(&shapes::Heightfield {
                    min,
                    max,
                    resolution: [nx as u32, nz as u32],
                    base_y: r.base_y.as_ref().map_or(0.0, |v| v.get_ref().0),
                    amplitude: r.amplitude.as_ref().map_or(1.0, |v| v.get_ref().0),
                    frequency: r
                        .frequency
                        .as_ref()
                        .map_or(Ok(1.0), |v| self.positive(v, "frequency"))?,
                    octaves: self.opt_int(&r.octaves, "octaves", 1..=16, 4)? as u32,
                    seed: self.u32(&r.seed, "seed", 0, 0)?,
                    noise,
                })
            }
            "blob" => {
                let radius =
                    self.positive(self.need(&r.radius, "radius", &r.kind, "shape")?, "radius")?;
                let subdivisions = self.opt_int(&r.subdivisions, "subdivisions", 0..=16, 4)? as u32;
                let span = r
                    .subdivisions
                    .as_ref()
                    .map_or(geometry_span.clone(), |v| v.span());
                self.count_check(shapes::icosphere_triangles(subdivisions), span, kind)?;
                let amplitude = match &r.amplitude {
                    Some(v) if !(0.0..1.0).contains(&v.get_ref().0) => {
                        return Err(self.error(
                            v.span(),
                            format!("blob amplitude must be in [0, 1), found {}", v.get_ref().0),
                        ))
                    }
                    Some(v) => v.get_ref().0,
                    None => 0.25,
                };
                let noise = shapes::BlobNoise {
                    amplitude,
                    frequency: r
                        .frequency
                        .as_ref()
                        .map_or(Ok(2.0), |v| self.positive(v, "frequency"))?,
                    octaves: self.opt_int(&r.octaves, "octaves", 1..=16, 4)? as u32,
                    seed: self.u32(&r.seed, "seed", 0, 0)?,
                };
                shapes::blob(center, radius, subdivisions, &noise)
            }
            _ => unreachable!("SHAPE_TYPES and this match list the same types"),
        };

        if let Some(tr) = &r.transform {
            mesh.transform(&self.transform(tr.get_ref())?);
        }
        if !mesh.positions.iter().all(|p| p.is_finite()) {
            let span = r
                .transform
                .as_ref()
                .map_or(geometry_span.clone(), |t| t.span());
            return Err(self.error(span, "vertex positions overflow to infinity"));
        }
        if !mesh.has_area() {
            let why = if r.transform.is_some() {
                " (after transform)"
            } else {
                ""
            };
            return Err(self.error(
                geometry_span,
                format!("this {kind} is entirely degenerate: every triangle has zero area{why}"),
            ));
        }
        let motion = match &r.motion {
            Some(m) => self.motion(m)?,
            None => Vec::new(),
        };
        let TriMesh { positions, indices } = mesh;
        Ok(Mesh {
            name: r
                .name
                .as_ref()
                .map_or_else(|| format!("shape{n}"), |v| v.get_ref().clone()),
            positions,
            indices,
            material,
            motion,
        })
    }

    /// scale, then rotate about +y, then translate.
    fn transform(&self, t: &RawTransform) -> Result<Affine3A> {
        let scale = match &t.scale {
            Some(s) if s.get_ref().0.cmpeq(Vec3::ZERO).any() => {
                return Err(self.error(
                    s.span(),
                    "scale must be nonzero (a zero scale flattens the shape)",
                ))
            }
            Some(s) => s.get_ref().0,
            None => Vec3::ONE,
        };
        let angle = t
            .rotate_y
            .as_ref()
            .map_or(0.0, |a| a.get_ref().0.to_radians());
        let translate = t.translate.as_ref().map_or(Vec3::ZERO, |v| v.get_ref().0);
        Ok(Affine3A::from_scale_rotation_translation(
            scale,
            Quat::from_rotation_y(angle),
            translate,
        ))
    }

    fn motion(&self, m: &S<Vec<S<RawKeyframe>>>) -> Result<Vec<Keyframe>> {
        let frames = m.get_ref();
        if frames.len() < 2 {
            return Err(self.error(
                m.span(),
                format!("motion needs at least 2 keyframes, found {}", frames.len()),
            ));
        }
        let mut out: Vec<Keyframe> = Vec::with_capacity(frames.len());
        for k in frames {
            let k = k.get_ref();
            let time = k.time.get_ref().0;
            if let Some(prev) = out.last() {
                if time <= prev.time {
                    return Err(self.error(
                        k.time.span(),
                        format!(
                            "keyframe times must be strictly increasing: {time} follows {}",
                            prev.time
                        ),
                    ));
                }
            }
            let rotation = match &k.rotate {
                None => Quat::IDENTITY,
                Some(r) => {
                    let [x, y, z, degrees] =
                        self.array::<4>(r, "rotate", "[axis_x, axis_y, axis_z, angle_degrees]")?;
                    let Some(axis) = Vec3::new(x, y, z).try_normalize() else {
                        return Err(self.error(r.span(), "rotate axis must be a nonzero vector"));
                    };
                    Quat::from_axis_angle(axis, degrees.to_radians())
                }
            };
            out.push(Keyframe {
                time,
                translation: k.translate.as_ref().map_or(Vec3::ZERO, |v| v.get_ref().0),
                rotation,
            });
        }
        Ok(out)
    }

    fn light(&self, l: &S<RawLight>) -> Result<LightOut> {
        let r = l.get_ref();
        let t = self.check_type("light", &r.kind, &r.type_keys(), &LIGHT_TYPES)?;
        Ok(match LIGHT_TYPES[t].0 {
            "point" => LightOut::Delta(Light::Point {
                position: self
                    .need(&r.position, "position", &r.kind, "light")?
                    .get_ref()
                    .0,
                intensity: self.rgb(
                    self.need(&r.intensity, "intensity", &r.kind, "light")?,
                    "intensity",
                )?,
            }),
            "directional" => LightOut::Delta(Light::Directional {
                direction: self.nonzero(
                    self.need(&r.direction, "direction", &r.kind, "light")?,
                    "direction",
                )?,
                irradiance: self.rgb(
                    self.need(&r.irradiance, "irradiance", &r.kind, "light")?,
                    "irradiance",
                )?,
            }),
            "quad" => {
                let corners_v = self.need(&r.corners, "corners", &r.kind, "light")?;
                let corners = self.quad_corners(corners_v)?;
                if !shapes::quad(corners).has_area() {
                    return Err(self.error(
                        corners_v.span(),
                        "this quad light is entirely degenerate: it has zero area",
                    ));
                }
                let radiance_v = self.need(&r.radiance, "radiance", &r.kind, "light")?;
                let radiance = self.rgb(radiance_v, "radiance")?;
                if radiance == Vec3::ZERO {
                    return Err(self.error(
                        radiance_v.span(),
                        "a quad light's radiance must not be all 0",
                    ));
                }
                LightOut::Area { corners, radiance }
            }
            _ => unreachable!("LIGHT_TYPES and this match list the same types"),
        })
    }

    /// `emissive`: whether any mesh emits (then the path tracer spends two
    /// more dimensions per vertex on area-light NEE).
    fn integrand(&self, r: &RawIntegrand, emissive: bool) -> Result<IntegrandSpec> {
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
                let sampler = match &r.sampler {
                    None => d.sampler,
                    Some(v) if MANY_LIGHT_SAMPLERS.contains(&v.get_ref().as_str()) => {
                        v.get_ref().clone()
                    }
                    Some(v) => {
                        return Err(self.error(
                            v.span(),
                            format!(
                                "unknown sampler '{}', expected one of {}",
                                v.get_ref(),
                                quoted_list(&MANY_LIGHT_SAMPLERS)
                            ),
                        ))
                    }
                };
                let block = self.u32(&r.block, "block", 1, d.block)?;
                let interleave = self.u32(&r.interleave, "interleave", 1, d.interleave)?;
                if block % interleave != 0 {
                    let span = r.interleave.as_ref().map_or(r.kind.span(), |v| v.span());
                    return Err(self.error(
                        span,
                        format!("interleave = {interleave} must divide block = {block}"),
                    ));
                }
                IntegrandSpec::ManyLight(ManyLightSpec {
                    sampler,
                    cut_size: self.opt_int(
                        &r.cut_size,
                        "cut_size",
                        1..=MAX_CUT_SIZE as i64,
                        d.cut_size as i64,
                    )? as u32,
                    block,
                    interleave,
                    time: r.time.as_ref().map_or(d.time, |v| v.get_ref().0),
                    frame: self.u32(&r.frame, "frame", 0, d.frame)?,
                })
            }
            _ => unreachable!("INTEGRAND_TYPES and this match list the same types"),
        })
    }

    /// A number in [0, 1] (a jitter amount).
    fn unit_interval(&self, v: &Option<S<Num>>, key: &str) -> Result<f32> {
        match v {
            None => Ok(0.0),
            Some(v) if (0.0..=1.0).contains(&v.get_ref().0) => Ok(v.get_ref().0),
            Some(v) => Err(self.error(
                v.span(),
                format!("{key} must be in [0, 1], found {}", v.get_ref().0),
            )),
        }
    }

    /// Generate one `[[light_set]]` (type index `t` into
    /// [`LIGHT_SET_TYPES`]); `before` lights were generated by earlier sets.
    fn light_set(
        &self,
        r: &RawLightSet,
        t: usize,
        surfaces: Option<&Surfaces>,
        before: u64,
    ) -> Result<PointLightSet> {
        let kind = LIGHT_SET_TYPES[t].0;
        let intensity_v = self.need(&r.intensity, "intensity", &r.kind, "light_set")?;
        let intensity = self.rgb(intensity_v, "intensity")?;
        if intensity == Vec3::ZERO {
            return Err(self.error(
                intensity_v.span(),
                "a light set's intensity must not be all 0",
            ));
        }
        let seed = self.u32(&r.seed, "seed", 0, 0)?;
        let intensity_jitter = self.unit_interval(&r.intensity_jitter, "intensity_jitter")?;
        let color_jitter = self.unit_interval(&r.color_jitter, "color_jitter")?;
        let orbit_radius = r
            .orbit_radius
            .as_ref()
            .map_or(Ok(0.0), |v| self.non_negative(v, "orbit_radius"))?;
        let orbit_speed = r.orbit_speed.as_ref().map_or(0.0, |v| v.get_ref().0);

        // The count, checked against the scene-wide limit before allocating.
        let max_count = MAX_SET_LIGHTS as i64;
        let (count, count_span) = match kind {
            "box" | "surface" => {
                let v = self.need(&r.count, "count", &r.kind, "light_set")?;
                (self.int(v, "count", 1..=max_count)? as u64, v.span())
            }
            "grid" => {
                let v = self.need(&r.resolution, "resolution", &r.kind, "light_set")?;
                let res = v.get_ref();
                if res.len() != 2 {
                    return Err(self.error(
                        v.span(),
                        format!("resolution must be [nx, nz], found {} elements", res.len()),
                    ));
                }
                let nx = self.int(&res[0], "resolution nx", 1..=max_count)?;
                let nz = self.int(&res[1], "resolution nz", 1..=max_count)?;
                ((nx * nz) as u64, v.span())
            }
            _ => unreachable!("LIGHT_SET_TYPES and this match list the same types"),
        };
        if before + count > MAX_SET_LIGHTS {
            return Err(self.error(
                count_span,
                format!(
                    "this light set brings the scene's light-set lights to {}: absurdly large (at most 2^24 = {MAX_SET_LIGHTS} in all)",
                    before + count
                ),
            ));
        }

        // Where light i sits (its orbit centre), from its random stream.
        let position: Box<PlaceLight> = match kind {
            "box" => {
                let min_v = self.need(&r.min, "min", &r.kind, "light_set")?;
                let min = Vec3::from(self.array::<3>(min_v, "min", "[x, y, z]")?);
                let max_v = self.need(&r.max, "max", &r.kind, "light_set")?;
                let max = Vec3::from(self.array::<3>(max_v, "max", "[x, y, z]")?);
                if !max.cmpge(min).all() {
                    return Err(self.error(
                        max_v.span(),
                        "light set box max must be ≥ min in x, y and z",
                    ));
                }
                let size = max - min;
                Box::new(move |_, rng| {
                    let u = Vec3::new(rng.f32(), rng.f32(), rng.f32());
                    (min + u * size).min(max)
                })
            }
            "surface" => {
                let surfaces = surfaces.expect("built for surface sets");
                if surfaces.total_area <= 0.0 {
                    return Err(self.error(
                        r.kind.span(),
                        "a surface light set scatters its lights over the scene's non-emissive triangles, and this scene has none (with area)",
                    ));
                }
                let offset = r
                    .offset
                    .as_ref()
                    .map_or(Ok(0.01), |v| self.non_negative(v, "offset"))?;
                Box::new(move |_, rng| surfaces.sample(rng, offset))
            }
            "grid" => {
                let min_v = self.need(&r.min, "min", &r.kind, "light_set")?;
                let min = Vec2::from(self.array::<2>(min_v, "grid min", "[x, z]")?);
                let max_v = self.need(&r.max, "max", &r.kind, "light_set")?;
                let max = Vec2::from(self.array::<2>(max_v, "grid max", "[x, z]")?);
                if !max.cmpgt(min).all() {
                    return Err(self.error(
                        max_v.span(),
                        "light set grid max must be greater than min in x and z",
                    ));
                }
                let y = self.need(&r.y, "y", &r.kind, "light_set")?.get_ref().0;
                let res = r.resolution.as_ref().expect("checked above").get_ref();
                let (nx, nz) = (*res[0].get_ref() as u64, *res[1].get_ref() as u64);
                let cell = (max - min) / Vec2::new(nx as f32, nz as f32);
                Box::new(move |i, _| {
                    let (ix, iz) = (i % nx, i / nx);
                    Vec3::new(
                        min.x + (ix as f32 + 0.5) * cell.x,
                        y,
                        min.y + (iz as f32 + 0.5) * cell.y,
                    )
                })
            }
            _ => unreachable!("LIGHT_SET_TYPES and this match list the same types"),
        };

        let lights = (0..count)
            .map(|i| {
                let mut rng = LightRng::new(seed, i);
                let base = position(i, &mut rng);
                let phase = rng.f32() * std::f32::consts::TAU;
                let scale = 1.0 + intensity_jitter * (2.0 * rng.f32() - 1.0);
                let color = Vec3::new(rng.f32(), rng.f32(), rng.f32());
                let color = Vec3::ONE + color_jitter * (2.0 * color - Vec3::ONE);
                SetLight {
                    base,
                    phase,
                    intensity: intensity * scale * color,
                }
            })
            .collect();
        let set = PointLightSet {
            lights,
            orbit_radius,
            orbit_speed,
        };
        if set.lights.iter().any(|l| !l.base.is_finite()) {
            return Err(self.error(r.kind.span(), "light positions overflow to infinity"));
        }
        Ok(set)
    }

    fn mdas(&self, m: &RawMdas) -> Result<MdasParams> {
        let d = MdasParams::default();
        Ok(MdasParams {
            bits_per_dim: self.u32(&m.bits_per_dim, "bits_per_dim", 0, d.bits_per_dim)?,
            extra_image_bits: self.u32(
                &m.extra_image_bits,
                "extra_image_bits",
                0,
                d.extra_image_bits,
            )?,
            initial_samples_per_cell: self.u32(
                &m.initial_samples_per_cell,
                "initial_samples_per_cell",
                1,
                d.initial_samples_per_cell,
            )?,
            scale_factor: m
                .scale_factor
                .as_ref()
                .map_or(Ok(d.scale_factor), |v| self.positive(v, "scale_factor"))?,
            alpha: m
                .alpha
                .as_ref()
                .map_or(Ok(d.alpha), |v| self.non_negative(v, "alpha"))?,
            candidates: self.u32(&m.candidates, "candidates", 1, d.candidates)?,
            max_samples_per_leaf: self.u32(
                &m.max_samples_per_leaf,
                "max_samples_per_leaf",
                1,
                d.max_samples_per_leaf,
            )?,
            spp: m
                .spp
                .as_ref()
                .map_or(Ok(d.spp), |v| self.positive(v, "spp"))?,
            seed: self.u32(&m.seed, "seed", 0, d.seed)?,
        })
    }
}

/// Where generated light i sits (its orbit centre), given its random stream.
type PlaceLight<'a> = dyn Fn(u64, &mut LightRng) -> Vec3 + 'a;

/// Deterministic random numbers of one generated light: a splitmix64
/// stream keyed by (seed, light index), so light i is the same whatever
/// the count and whatever other sets the scene has.
struct LightRng(u64);

fn mix64(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

impl LightRng {
    fn new(seed: u32, index: u64) -> LightRng {
        LightRng(mix64(
            ((seed as u64) << 32 | 0x5EED) ^ mix64(index ^ 0x632B_E59B_D9B4_E019),
        ))
    }

    fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        mix64(self.0)
    }

    /// Uniform in [0, 1), 24 bits.
    fn f32(&mut self) -> f32 {
        (self.next_u64() >> 40) as f32 * (1.0 / (1u64 << 24) as f32)
    }

    /// Uniform in [0, 1), 53 bits.
    fn f64(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }
}

/// The scene's non-emissive triangles at scene time 0 (world space, moving
/// meshes placed by their keyframes as the BVH places them), with an
/// area-proportional CDF, for `surface` light sets.
struct Surfaces {
    triangles: Vec<[Vec3; 3]>,
    /// Inclusive prefix sums of the triangle areas.
    cdf: Vec<f64>,
    total_area: f64,
}

impl Surfaces {
    fn new(meshes: &[Mesh], materials: &[Material]) -> Surfaces {
        let mut triangles = Vec::new();
        let mut cdf = Vec::new();
        let mut total = 0.0f64;
        for mesh in meshes {
            if materials[mesh.material as usize].emission.max_element() > 0.0 {
                continue;
            }
            let rigid = (!mesh.motion.is_empty()).then(|| {
                crate::accel::motion::transform_at(
                    &crate::accel::motion::normalized_keys(&mesh.motion),
                    0.0,
                )
            });
            for idx in &mesh.indices {
                let v = idx.map(|i| {
                    let p = mesh.positions[i as usize];
                    rigid.map_or(p, |r| r.apply_point(p))
                });
                let area = 0.5 * (v[1] - v[0]).cross(v[2] - v[0]).length() as f64;
                if area > 0.0 && area.is_finite() {
                    total += area;
                    triangles.push(v);
                    cdf.push(total);
                }
            }
        }
        Surfaces {
            triangles,
            cdf,
            total_area: total,
        }
    }

    /// A point uniform by area over the triangles, moved `offset` along
    /// its triangle's geometric normal.
    fn sample(&self, rng: &mut LightRng, offset: f32) -> Vec3 {
        let x = rng.f64() * self.total_area;
        let t = self
            .cdf
            .partition_point(|&c| c <= x)
            .min(self.triangles.len() - 1);
        let [a, b, c] = self.triangles[t];
        let (mut u, mut v) = (rng.f32(), rng.f32());
        if u + v > 1.0 {
            (u, v) = (1.0 - u, 1.0 - v);
        }
        let n = (b - a).cross(c - a).normalize_or_zero();
        a + u * (b - a) + v * (c - a) + offset * n
    }
}

enum LightOut {
    Delta(Light),
    Area { corners: [Vec3; 4], radiance: Vec3 },
}

fn fmt3(v: Vec3) -> String {
    format!("[{}, {}, {}]", v.x, v.y, v.z)
}

#[cfg(test)]
mod tests {
    use super::*;

    const MINIMAL: &str = "[film]\nwidth = 4\nheight = 3\n[camera]\nposition = [0, 0, 5]\nlook_at = [0, 0, 0]\nup = [0, 1, 0]\nfov_y = 40\n";

    fn err(text: &str) -> String {
        parse(text, Path::new("t.toml")).unwrap_err().to_string()
    }

    #[test]
    fn minimal_scene_gets_defaults() {
        let s = parse(MINIMAL, Path::new("t.toml")).unwrap();
        assert_eq!(
            s.film,
            Film {
                width: 4,
                height: 3
            }
        );
        assert_eq!(s.camera.focus_distance, 5.0);
        assert_eq!((s.camera.shutter_open, s.camera.shutter_close), (0.0, 1.0));
        assert_eq!(s.mdas, MdasParams::default());
        assert_eq!(s.integrand, IntegrandSpec::AreaLight);
        assert_eq!(s.background, Vec3::ZERO);
    }

    #[test]
    fn line_and_column_count_characters() {
        let text = format!("{MINIMAL}background = [\"é\", 0, 0]\n");
        let e = err(&text);
        assert!(e.starts_with("t.toml:9:"), "{e}");
        let e = err(&MINIMAL.replace("fov_y = 40", "fov_y = 180"));
        assert!(
            e.starts_with("t.toml:8:9: fov_y must be in (0, 180)"),
            "{e}"
        );
    }

    #[test]
    fn scale_accepts_number_or_vector() {
        let base = format!("{MINIMAL}[[material]]\nname = \"m\"\nalbedo = [0.5, 0.5, 0.5]\n[[shape]]\ntype = \"box\"\nmaterial = \"m\"\nmin = [0, 0, 0]\nmax = [1, 1, 1]\n");
        let s = parse(
            &format!("{base}transform = {{ scale = 2 }}\n"),
            Path::new("t.toml"),
        )
        .unwrap();
        assert!(
            (s.meshes[0]
                .positions
                .iter()
                .map(|p| p.x)
                .fold(0.0, f32::max)
                - 2.0)
                .abs()
                < 1e-6
        );
        let s = parse(
            &format!(
                "{base}transform = {{ scale = [1, 3, 1], rotate_y = 90, translate = [0, 1, 0] }}\n"
            ),
            Path::new("t.toml"),
        )
        .unwrap();
        let max_y = s.meshes[0]
            .positions
            .iter()
            .map(|p| p.y)
            .fold(0.0, f32::max);
        assert!((max_y - 4.0).abs() < 1e-6);
        let e = err(&format!("{base}transform = {{ scale = [1, 2] }}\n"));
        assert!(
            e.contains("expected an array of 3 numbers, found 2 elements"),
            "{e}"
        );
        let e = err(&format!("{base}transform = {{ scale = 0 }}\n"));
        assert!(e.contains("scale must be nonzero"), "{e}");
        let e = err(&format!("{base}transform = {{ scale = 1e-30 }}\n"));
        assert!(
            e.contains("entirely degenerate") && e.contains("after transform"),
            "{e}"
        );
    }
}
