//! Scenes: the CPU-side description of what is rendered.
//!
//! A [`Scene`] is loaded from a TOML file (format documented in
//! [`format`](mod@format) and `docs/scene-format.md`) and holds everything in world space
//! (right-handed, +y up, linear RGB; see `shared/DESIGN.md`):
//! the film, the camera, materials, triangle meshes (every shape is
//! tessellated to triangles on load), per-mesh rigid motion over the
//! shutter, analytic lights (point, directional), procedurally generated
//! and animated point-light sets (`[[light_set]]`, [`PointLightSet`]) and
//! the integrand and MDAS parameter tables. Area lights are emissive
//! triangles: a `[[light]] type = "quad"` becomes a one-sided emissive quad
//! mesh. `crate::lights::scene_lights` turns all of them into the
//! many-light list of one frame.

pub mod format;
pub mod obj;
pub mod shapes;

use glam::{Quat, Vec3};
use std::path::Path;

pub use format::{load, parse, SceneError};

/// Film resolution in pixels. Pixel (i, j) covers [i, i+1) × [j, j+1),
/// i = column from the left, j = row from the top.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Film {
    pub width: u32,
    pub height: u32,
}

/// Pinhole or thin-lens camera (DESIGN.md "Camera").
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    pub position: Vec3,
    pub look_at: Vec3,
    pub up: Vec3,
    /// Full vertical field of view, degrees.
    pub fov_y: f32,
    /// Lens radius in world units; 0 = pinhole.
    pub aperture_radius: f32,
    /// Distance of the plane of focus along the view axis.
    pub focus_distance: f32,
    /// Scene time at shutter open / close; sample time t ∈ [0, 1) maps to
    /// `shutter_open + t·(shutter_close − shutter_open)`.
    pub shutter_open: f32,
    pub shutter_close: f32,
}

/// Procedural checker texture modulating albedo: the cell of world point
/// p is floor(p / scale) per axis (x, y and z); cells whose three indices
/// sum to an even number use the material's albedo, odd ones `albedo2`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Checker {
    pub albedo2: Vec3,
    /// Cell size in world units.
    pub scale: f32,
}

/// Lambertian material with optional one-sided emission (emitted toward
/// the side the geometric normal faces) and optional checker texture.
#[derive(Clone, Debug, PartialEq)]
pub struct Material {
    pub name: String,
    pub albedo: Vec3,
    pub emission: Vec3,
    pub checker: Option<Checker>,
}

/// One rigid-motion keyframe: at scene time `time` the mesh is rotated by
/// `rotation` (about the object-space origin) and then translated by
/// `translation`. Between keyframes translation is interpolated linearly
/// and rotation by slerp; before the first / after the last keyframe the
/// end keyframe holds.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Keyframe {
    pub time: f32,
    pub translation: Vec3,
    pub rotation: Quat,
}

/// A triangle mesh with one material. Vertices are in world space for
/// static meshes and in object space when `motion` is non-empty.
#[derive(Clone, Debug, PartialEq)]
pub struct Mesh {
    pub name: String,
    pub positions: Vec<Vec3>,
    /// Counter-clockwise triangles: geometric normal (v1 − v0) × (v2 − v0).
    pub indices: Vec<[u32; 3]>,
    pub material: u32,
    /// Keyframes sorted by time; empty = static.
    pub motion: Vec<Keyframe>,
}

/// Analytic (delta) lights. Area lights are emissive meshes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Light {
    /// Contributes I·cosθ/d² to irradiance.
    Point { position: Vec3, intensity: Vec3 },
    /// Light travelling along `direction` (normalized); gives irradiance E
    /// on a surface facing it.
    Directional { direction: Vec3, irradiance: Vec3 },
}

/// Which integrand renders the scene, with its parameters (scene file
/// `[integrand] type = …`; dimension orders in `crate::integrand`).
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

/// Sampler names accepted by `[integrand] type = "many_light"`, `sampler`
/// (`crate::lights::sampler::SamplerKind` parses the same names).
pub const MANY_LIGHT_SAMPLERS: [&str; 6] = [
    "uniform",
    "power",
    "tree_nocut",
    "tree",
    "unbalanced",
    "unbalanced_nocut",
];

/// Parameters of the `many_light` integrand (scene file `[integrand]`).
#[derive(Clone, Debug, PartialEq)]
pub struct ManyLightSpec {
    /// One of [`MANY_LIGHT_SAMPLERS`] (checked on load).
    pub sampler: String,
    /// Light-cut size, 1..=64.
    pub cut_size: u32,
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
}

impl Default for ManyLightSpec {
    fn default() -> Self {
        ManyLightSpec {
            sampler: "tree".into(),
            cut_size: 8,
            block: 8,
            interleave: 1,
            time: 0.0,
            frame: 0,
        }
    }
}

/// One light of a [`PointLightSet`]: an isotropic point light.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SetLight {
    /// Centre of the light's orbit (its position when the set does not
    /// orbit), world space.
    pub base: Vec3,
    /// Orbit phase φ, radians in [0, 2π).
    pub phase: f32,
    /// Radiant intensity I (RGB, W/sr), jitter applied.
    pub intensity: Vec3,
}

/// Point lights generated by one `[[light_set]]` (docs/scene-format.md),
/// in generation order. Light i at scene time t is at
/// `base_i + orbit_radius · (cos(φ_i + orbit_speed·t), 0, sin(φ_i + orbit_speed·t))`.
#[derive(Clone, Debug, PartialEq)]
pub struct PointLightSet {
    pub lights: Vec<SetLight>,
    /// World units; 0 = static.
    pub orbit_radius: f32,
    /// Radians per scene time unit.
    pub orbit_speed: f32,
}

impl PointLightSet {
    /// Position of `light` (one of this set's) at scene time `time`.
    pub fn position(&self, light: &SetLight, time: f32) -> Vec3 {
        if self.orbit_radius == 0.0 {
            return light.base;
        }
        let angle = light.phase + self.orbit_speed * time;
        light.base + self.orbit_radius * Vec3::new(angle.cos(), 0.0, angle.sin())
    }

    pub fn len(&self) -> usize {
        self.lights.len()
    }

    pub fn is_empty(&self) -> bool {
        self.lights.is_empty()
    }
}

/// Parameters of the MDAS integrator (paper §5.1); defaults per the paper.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MdasParams {
    pub bits_per_dim: u32,
    pub extra_image_bits: u32,
    pub initial_samples_per_cell: u32,
    pub scale_factor: f32,
    pub alpha: f32,
    pub candidates: u32,
    pub max_samples_per_leaf: u32,
    pub spp: f32,
    pub seed: u32,
}

impl Default for MdasParams {
    fn default() -> Self {
        MdasParams {
            bits_per_dim: 1,
            extra_image_bits: 8,
            initial_samples_per_cell: 1,
            scale_factor: 1.0,
            alpha: 0.25,
            candidates: 4,
            max_samples_per_leaf: 4,
            spp: 8.0,
            seed: 0,
        }
    }
}

#[derive(Clone, Debug, PartialEq)]
pub struct Scene {
    pub film: Film,
    pub camera: Camera,
    /// Radiance of rays that hit nothing.
    pub background: Vec3,
    pub materials: Vec<Material>,
    pub meshes: Vec<Mesh>,
    pub lights: Vec<Light>,
    /// `[[light_set]]`s in file order (used by the `many_light` integrand).
    pub point_light_sets: Vec<PointLightSet>,
    pub integrand: IntegrandSpec,
    pub mdas: MdasParams,
}

impl Scene {
    /// Load and validate a scene file; see [`format`](mod@format).
    pub fn load(path: &Path) -> Result<Scene, SceneError> {
        format::load(path)
    }

    pub fn triangle_count(&self) -> usize {
        self.meshes.iter().map(|m| m.indices.len()).sum()
    }
}

/// Reads an input file of at most `limit` bytes: devices, pipes and
/// directories are refused (a scene naming /dev/zero must not hang or
/// grow without bound), and so is a larger file, with its size and the
/// limit in the message.
pub(crate) fn read_input(path: &std::path::Path, limit: u64) -> std::io::Result<Vec<u8>> {
    use std::io::{Error, ErrorKind, Read};
    let metadata = std::fs::metadata(path)?;
    if !metadata.is_file() {
        return Err(Error::new(ErrorKind::InvalidInput, "not a regular file"));
    }
    let too_large = |size: u64| {
        Error::new(
            ErrorKind::InvalidData,
            format!("{size} bytes, more than the {limit} read from such a file"),
        )
    };
    if metadata.len() > limit {
        return Err(too_large(metadata.len()));
    }
    // The file may grow between the check and the read: read one byte past
    // the limit at most.
    let mut bytes = Vec::with_capacity(metadata.len() as usize);
    std::fs::File::open(path)?
        .take(limit + 1)
        .read_to_end(&mut bytes)?;
    if bytes.len() as u64 > limit {
        return Err(too_large(bytes.len() as u64));
    }
    Ok(bytes)
}
