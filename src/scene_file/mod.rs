//! The TOML scene file: parsing, validation and tessellation. A file
//! becomes a [`SceneFile`]: the [`Scene`] (geometry, camera, lights), the
//! [`IntegrandSpec`] and the [`MdasParams`]. This layer sits above the
//! integrands and the integrator so that each table is validated once, by
//! its owner's own limits: `max_bounces` by
//! [`crate::integrand::path::max_bounces_limit`], sampler names by
//! [`SamplerKind`], the `[mdas]` table by
//! [`crate::integrator::mdas::params::validate`]. The full reference, with a table per section, is
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
//!             | many_light (sampler, cut_size, light_samples, block, interleave, time, frame);
//!             any type: visibility = bvh | voxel, voxel_directions,
//!             voxel_resolution, voxel_skip
//! [mdas]      the keys of crate::integrator::mdas::PARAMS (alpha, pace,
//!             spp, seed, …)
//! ```
//!
//! Every error — TOML syntax, unknown keys, wrong types, NaN/Inf, values
//! out of range, unknown material names, unreadable mesh files — is a
//! [`SceneError`] whose message starts with `file:line:column:` pointing at
//! the offending value. Nothing here panics on any input.
//!
//! Shapes are tessellated by [`crate::scene::shapes`] (OBJ files by
//! [`crate::scene::obj`]), then `transform` (scale, then rotate about y, then
//! translate) is applied to the vertices. With `motion`, the mesh keeps
//! these object-space vertices and the keyframes move it over time.

mod assemble;
mod ctx;
mod integrand;
mod lights;
mod mdas;
mod mitsuba;
mod raw;
mod shapes;
#[cfg(test)]
mod tests;
mod values;

use crate::accel::voxel::{Visibility, VoxelParams};
use crate::integrand::IntegrandSpec;
use crate::integrator::mdas::MdasParams;
#[cfg(doc)]
use crate::lights::registry::SamplerKind;
use crate::scene::Scene;
use ctx::Ctx;
use raw::RawScene;
use std::path::{Path, PathBuf};

/// A loaded scene file: the scene and the two tables that belong to others.
#[derive(Clone, Debug, PartialEq)]
pub struct SceneFile {
    pub scene: Scene,
    /// `[integrand]` (area-light direct lighting when absent).
    pub integrand: IntegrandSpec,
    /// `[integrand] visibility`: how shadow rays are answered (BVH when
    /// absent).
    pub visibility: Visibility,
    /// `[integrand] voxel_*`: the voxel array's parameters, also when
    /// `visibility` is the BVH (for `--visibility voxel`).
    pub voxel: VoxelParams,
    /// `[mdas]` (missing keys from `MdasParams::for_film`).
    pub mdas: MdasParams,
    /// The files the scene loaded besides itself (its OBJ meshes and
    /// their MTL material libraries), in order: what a cached render of it
    /// depends on.
    pub inputs: Vec<std::path::PathBuf>,
    /// What loading ignored and the user should know (textures named by
    /// an OBJ's materials); the CLI prints them.
    pub warnings: Vec<String>,
}

impl SceneFile {
    /// Read and load a scene file; see [`load`].
    pub fn load(path: &Path) -> Result<SceneFile, SceneError> {
        load(path)
    }
}

/// Largest film side, in pixels.
pub const MAX_FILM_SIDE: i64 = 16384;
/// Largest film area, in pixels.
pub const MAX_FILM_PIXELS: i64 = 1 << 26;
pub use crate::scene::MAX_SCENE_TRIANGLES;
/// Largest number of point lights all `[[light_set]]`s together may generate.
pub const MAX_SET_LIGHTS: u64 = 1 << 24;
/// Largest `cut_size` of the `many_light` integrand.
pub const MAX_CUT_SIZE: u32 = 64;
/// Largest magnitude of a world coordinate or length (vertex positions
/// after transform, keyframe translations, camera position, aperture
/// radius, orbit radius): 10^9 world units. Far beyond any scene, and far
/// enough below f32's range that bounding-box areas (a BVH's cost) and
/// ray arithmetic stay finite: a keyframe at 3·10^38 crashed the BVH
/// builder, an aperture of 10^30 made every ray miss.
pub const MAX_COORDINATE: f32 = 1e9;
/// Largest channel of an emitted quantity (intensity, irradiance,
/// radiance, emission): the light tree sums up to 2^24 of them, jittered
/// up to 2×, and must stay finite in f32 (an intensity of 3·10^38
/// overflowed to infinity).
pub const MAX_EMISSION: f32 = 1e20;
/// Largest `orbit_speed` magnitude, radians per scene time unit: the GPU's
/// sin and cos are accurate only for moderate angles (3·10^38 gave NaN
/// light positions).
pub const MAX_ORBIT_SPEED: f32 = 1e4;
/// Largest magnitude of a scene time (keyframe times, `shutter_open`,
/// `shutter_close`, the `many_light` integrand's `time`): 10^6 units.
/// Keyframes at ±3·10^38 interpolated as if static (their span overflows
/// f32), and a light set at time 3·10^38 lit nothing; at 10^6 an orbit of
/// the largest speed still has finite positions, and f32 still tells
/// times 1/16 apart.
pub const MAX_TIME: f32 = 1e6;

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
pub fn load(path: &Path) -> Result<SceneFile, SceneError> {
    let io = |error| SceneError::Io {
        path: path.to_path_buf(),
        error,
    };
    let bytes = crate::scene::read_input(path, MAX_SCENE_BYTES).map_err(io)?;
    let text = String::from_utf8(bytes).map_err(|e| {
        // Where the first bad byte is (issue 54 item 8): the text before it
        // is valid, so its lines and characters can be counted.
        let valid = &e.as_bytes()[..e.utf8_error().valid_up_to()];
        let before = std::str::from_utf8(valid).unwrap_or_default();
        let line_start = before.rfind('\n').map_or(0, |i| i + 1);
        SceneError::Invalid {
            file: path.to_path_buf(),
            line: before.matches('\n').count() + 1,
            column: before[line_start..].chars().count() + 1,
            message:
                "not UTF-8 text: the byte here starts no UTF-8 character (save the file as UTF-8)"
                    .into(),
        }
    })?;
    if path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("xml"))
    {
        return mitsuba::parse(&text, path);
    }
    parse(&text, path)
}

/// Load a Mitsuba 3 scene (XML) from its text; `file_name` as in [`parse`].
pub fn parse_mitsuba(text: &str, file_name: &Path) -> Result<SceneFile, SceneError> {
    mitsuba::parse(text, file_name)
}

/// Load a scene from TOML text. `file_name` names the file in messages,
/// and relative mesh paths are resolved against its directory.
pub fn parse(text: &str, file_name: &Path) -> Result<SceneFile, SceneError> {
    let ctx = Ctx {
        text,
        file: file_name,
        triangles: Default::default(),
    };
    let raw: RawScene = toml::from_str(text).map_err(|e| ctx.toml_error(&e))?;
    ctx.scene_file(raw)
}
