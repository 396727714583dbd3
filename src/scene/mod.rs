//! Scenes: the CPU-side description of what is rendered.
//!
//! A [`Scene`] is loaded from a TOML file by [`crate::scene_file`] (format
//! in `docs/scene-format.md`) and holds everything in world space
//! (right-handed, +y up, linear RGB; see `docs/conventions.md`):
//! the film, the camera, materials, triangle meshes (every shape is
//! tessellated to triangles on load), per-mesh rigid motion over the
//! shutter ([`motion`]), analytic lights (point, directional) and
//! procedurally generated, animated point-light sets (`[[light_set]]`,
//! [`PointLightSet`]). The integrand and MDAS tables of the same file
//! belong to their owners (`crate::integrand::IntegrandSpec`,
//! `crate::integrator::mdas::MdasParams`). Area lights are emissive
//! triangles: a `[[light]] type = "quad"` becomes a one-sided emissive quad
//! mesh. `crate::lights::scene_lights` turns all of them into the
//! many-light list of one frame.

pub mod motion;
pub mod noise;
pub mod obj;
pub mod ply;
pub mod shapes;

use crate::film::Film;
use glam::{Quat, Vec2, Vec3};

/// Pinhole or thin-lens camera (docs/conventions.md "Camera").
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

impl Camera {
    /// tan(fov_y/2), in f32 as the GPU's camera uniforms carry it
    /// ([`tan_half_fov_y`]).
    pub fn tan_half_fov_y(&self) -> f32 {
        tan_half_fov_y(self.fov_y)
    }
}

/// tan of half the vertical field of view `fov_y` (degrees), computed in
/// f32: the value the GPU's primary rays use (`cam_tan_half_fov_y`).
pub fn tan_half_fov_y(fov_y: f32) -> f32 {
    (fov_y.to_radians() * 0.5).tan()
}

/// Whether a camera can use `fov_y` (degrees, already an f32): strictly
/// inside (0, 180) and with tan(fov_y/2) in f32 positive, finite and
/// normal. A value that is inside the interval in f64 may not be in f32
/// (179.99999999 is 180 as an f32, whose tan(fov_y/2) is negative: the
/// image upside down), and one whose tangent is subnormal is flushed to 0
/// by a GPU.
pub fn fov_y_is_valid(fov_y: f32) -> bool {
    let t = tan_half_fov_y(fov_y);
    fov_y > 0.0 && fov_y < 180.0 && t > 0.0 && t.is_normal()
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

/// Mitsuba's `checkerboard` texture as a material's albedo: at texture
/// coordinates (u, v) (the mesh's [`Mesh::uvs`]), (u', v') =
/// `to_uv`·(u, v, 1), and the albedo is the material's where
/// (frac(u') > ½) = (frac(v') > ½), `albedo2` elsewhere.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct UvChecker {
    pub albedo2: Vec3,
    /// Rows of the 2×3 affine map from (u, v, 1).
    pub to_uv: [[f32; 3]; 2],
}

/// Lambertian material with optional one-sided emission (emitted toward
/// the side the geometric normal faces) and optional checker texture.
/// Reflection is two-sided unless `one_sided`.
#[derive(Clone, Debug, PartialEq)]
pub struct Material {
    pub name: String,
    pub albedo: Vec3,
    pub emission: Vec3,
    pub checker: Option<Checker>,
    /// A checkerboard in texture space (Mitsuba scenes), instead of
    /// `checker`.
    pub uv_checker: Option<UvChecker>,
    /// The back side reflects nothing, as a Mitsuba `diffuse` BSDF not
    /// wrapped in `twosided`: seen from behind its shading normal (the
    /// geometric one without vertex normals), as in Mitsuba's shading
    /// frame. False for every material of a TOML scene.
    pub one_sided: bool,
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
    /// Shading normals, one per position, or empty (see
    /// [`shapes::TriMesh::normals`]).
    pub normals: Vec<Vec3>,
    /// Texture coordinates, one per position, or empty: what a material's
    /// UV checkerboard ([`UvChecker`]) reads (a Mitsuba scene's rectangles,
    /// cubes and PLY files with `u v`).
    pub uvs: Vec<Vec2>,
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
}

impl Scene {
    pub fn triangle_count(&self) -> usize {
        self.meshes.iter().map(|m| m.indices.len()).sum()
    }

    /// Winds every mesh's faces to agree with its shading normals
    /// ([`Mesh::orient_to_normals`]); one warning per mesh that needed it.
    pub fn orient_to_normals(&mut self) -> Vec<String> {
        self.meshes
            .iter_mut()
            .filter_map(|m| {
                let turned = m.orient_to_normals();
                (turned > 0).then(|| {
                    format!(
                        "mesh '{}': {turned} of its {} triangles were wound against their vertex normals; \
                         they face the side the normals point to, as Mitsuba shades such a mesh",
                        m.name,
                        m.indices.len()
                    )
                })
            })
            .collect()
    }
}

impl Mesh {
    /// Winds each triangle so that its geometric normal (v1 − v0) × (v2 −
    /// v0) points to the side its corners' shading normals do (their sum):
    /// a mesh with vertex normals has its front where they point. Mitsuba
    /// shades such a mesh by its normals whatever its winding (its
    /// one-sided BSDFs and area emitters test the shading frame), and real
    /// assets are often wound against them; the geometric normal decides
    /// here which side emits, which side a one-sided reflection and a
    /// shadow ray leave from, and a face wound against its normals
    /// rendered black (issue 67). A triangle without normals, with a zero
    /// area or whose normals sum to zero is left as it is. Returns how
    /// many were turned.
    pub fn orient_to_normals(&mut self) -> usize {
        if self.normals.len() != self.positions.len() {
            return 0;
        }
        let mut turned = 0;
        for tri in &mut self.indices {
            let [a, b, c] = tri.map(|i| i as usize);
            let ng = (self.positions[b] - self.positions[a])
                .cross(self.positions[c] - self.positions[a]);
            let ns = self.normals[a] + self.normals[b] + self.normals[c];
            if ng.dot(ns) < 0.0 {
                tri.swap(1, 2);
                turned += 1;
            }
        }
        turned
    }
}

/// Largest number of triangles a scene may hold, all its shapes together
/// (one shape included). Checked before a shape is tessellated or a mesh
/// file's faces are read: a few thousand small spheres made tens of
/// millions of triangles and aborted, a PLY file above the limit ran for
/// minutes.
pub const MAX_SCENE_TRIANGLES: u64 = 1 << 25;

/// The error for a shape that would take `triangles` triangles when the
/// scene may take `left` more; `what` begins the sentence ("its faces
/// make").
pub(crate) fn too_many_triangles(what: &str, triangles: u64, left: u64) -> String {
    format!(
        "{what} {triangles} triangles, more than the {left} the scene may still take (at most {MAX_SCENE_TRIANGLES} in a scene)"
    )
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
    crate::atomic::note_input(path);
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
