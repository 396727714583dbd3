//! The plugins of the subset (`mitsuba/mod.rs`): sensor, film, sampler,
//! BSDFs, shapes, emitters and the integrator, and the integrand they
//! make together.

use super::bsdf::{bsdf, Bsdf, DEFAULT_BSDF};
use super::props::{f32v, no_nested, plugin_children, unsupported_texture, Props};
use super::{Doc, Result};
use crate::accel::voxel::{Visibility, VoxelParams};
use crate::film::Film;
use crate::integrand::spec::ManyLightSpec;
use crate::integrand::IntegrandSpec;
use crate::integrator::mdas::MdasParams;
use crate::scene::shapes::{self, TriMesh};
use crate::scene::too_many_triangles;
use crate::scene::{obj, ply, Camera, Light, Material, Mesh, Scene};
use crate::scene_file::shapes::{degenerate, far_vertex};
use crate::scene_file::{SceneError, SceneFile, MAX_COORDINATE, MAX_EMISSION};
use glam::{Affine3A, DVec3, Vec2, Vec3};
use roxmltree::Node;
use std::collections::HashMap;
use std::path::{Path, PathBuf};

/// Segments around (and rings along) a tessellated `sphere` ([`sphere`]),
/// and the segments of a `disk`, whose area falls short of the unit
/// disk's by 1·10⁻⁴.
pub const SPHERE_SEGMENTS: u32 = 128;
pub const SPHERE_RINGS: u32 = 64;
pub const DISK_SEGMENTS: u32 = 256;

/// The sensor as read, with where it was (for later errors).
pub(super) struct Sensor {
    pub(super) camera: Camera,
    pub(super) film: Film,
    pub(super) spp: Option<i64>,
    pub(super) thin_lens: bool,
    pub(super) at: (PathBuf, usize, usize),
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum Method {
    Direct,
    /// Mitsuba's `max_depth`: path segments, 2 = direct lighting.
    Path {
        max_depth: i64,
    },
}

/// Everything read so far, across `<include>`d files.
#[derive(Default)]
pub(super) struct Builder {
    pub(super) version: Option<String>,
    pub(super) inputs: Vec<PathBuf>,
    pub(super) warnings: Vec<String>,
    bsdfs: HashMap<String, Bsdf>,
    /// A material per (albedo, sidedness, emission) in use.
    materials: Vec<Material>,
    meshes: Vec<Mesh>,
    /// Triangles the scene may still take ([`crate::scene::MAX_SCENE_TRIANGLES`] at
    /// first; [`super::parse`] sets it).
    pub(super) triangles_left: u64,
    lights: Vec<Light>,
    sensor: Option<Sensor>,
    integrator: Option<(Method, (PathBuf, usize, usize))>,
}

fn invalid(at: &(PathBuf, usize, usize), message: impl Into<String>) -> SceneError {
    SceneError::Invalid {
        file: at.0.clone(),
        line: at.1,
        column: at.2,
        message: message.into(),
    }
}

impl Builder {
    /// One child of `<scene>` (not `<default>` or `<include>`).
    pub(super) fn top_level<'a, 'i>(&mut self, d: &Doc<'a, 'i>, node: Node<'a, 'i>) -> Result<()> {
        let here = |n: Node| {
            let p = d.position(n);
            (d.file.to_path_buf(), p.0, p.1)
        };
        match node.tag_name().name() {
            "sensor" => {
                if let Some(s) = &self.sensor {
                    return Err(d.node_error(
                        node,
                        format!(
                            "a second <sensor> (the first is at {}:{}:{}; mdas renders one camera)",
                            s.at.0.display(),
                            s.at.1,
                            s.at.2
                        ),
                    ));
                }
                self.sensor = Some(self.sensor(d, node)?);
            }
            "integrator" => {
                if self.integrator.is_some() {
                    return Err(d.node_error(node, "a second <integrator>"));
                }
                self.integrator = Some((integrator(d, node)?, here(node)));
            }
            "bsdf" => {
                let id = d.attr(node, "id")?.ok_or_else(|| {
                    d.node_error(node, "a <bsdf> outside a shape needs an 'id' to be referred to")
                })?;
                let bsdf = bsdf(d, node)?;
                if self.bsdfs.insert(id.clone(), bsdf).is_some() {
                    return Err(d.attr_error(node, "id", format!("a second object with id '{id}'")));
                }
            }
            "shape" => self.shape(d, node)?,
            "emitter" => {
                let light = emitter(d, node)?;
                self.lights.push(light);
            }
            "texture" => return Err(unsupported_texture(d, node)),
            other => {
                return Err(d.node_error(
                    node,
                    format!("<{other}> is not supported here (a <scene> holds: default, include, sensor, integrator, bsdf, shape, emitter)"),
                ))
            }
        }
        Ok(())
    }

    fn material(&mut self, bsdf: Bsdf, emission: Vec3, name: String) -> u32 {
        if let Some(i) = self.materials.iter().position(|m| {
            m.albedo == bsdf.albedo
                && m.one_sided == bsdf.one_sided
                && m.uv_checker == bsdf.uv_checker
                && m.emission == emission
        }) {
            return i as u32;
        }
        self.materials.push(Material {
            name,
            albedo: bsdf.albedo,
            emission,
            checker: None,
            one_sided: bsdf.one_sided,
            uv_checker: bsdf.uv_checker,
        });
        self.materials.len() as u32 - 1
    }

    fn shape<'a, 'i>(&mut self, d: &Doc<'a, 'i>, node: Node<'a, 'i>) -> Result<()> {
        let kind = d.need_attr(node, "type")?;
        let what = format!("shape '{kind}'");
        let mut p = Props::read(d, node)?;
        let mut bsdf_used = None;
        let mut radiance = None;
        for child in plugin_children(d, node)? {
            match child.tag_name().name() {
                "bsdf" | "ref" if bsdf_used.is_some() => {
                    return Err(d.node_error(child, "a shape takes one BSDF"))
                }
                "bsdf" => bsdf_used = Some(bsdf(d, child)?),
                "ref" => {
                    let id = d.need_attr(child, "id")?;
                    let Some(b) = self.bsdfs.get(&id) else {
                        let mut known: Vec<&str> = self.bsdfs.keys().map(String::as_str).collect();
                        known.sort_unstable();
                        return Err(d.attr_error(
                            child,
                            "id",
                            format!(
                                "no BSDF has id '{id}' (defined before this point: {})",
                                if known.is_empty() {
                                    "none".into()
                                } else {
                                    known.join(", ")
                                }
                            ),
                        ));
                    };
                    bsdf_used = Some(*b);
                }
                "emitter" => {
                    let t = d.need_attr(child, "type")?;
                    if t != "area" {
                        return Err(d.attr_error(
                            child,
                            "type",
                            format!("a shape's emitter must be 'area', found '{t}'"),
                        ));
                    }
                    if radiance.is_some() {
                        return Err(d.node_error(child, "a shape takes one emitter"));
                    }
                    no_nested(d, child)?;
                    let mut e = Props::read(d, child)?;
                    radiance = Some(emission(d, &mut e, "radiance")?);
                    e.finish(d, "emitter 'area'", &["radiance"])?;
                }
                "texture" => return Err(unsupported_texture(d, child)),
                other => {
                    return Err(d.node_error(
                        child,
                        format!("<{other}> in a shape (supported: bsdf, ref, emitter)"),
                    ))
                }
            }
        }
        let to_world = p.transform(d, "to_world")?.map(|t| t.0);
        let flip = p.boolean(d, "flip_normals")?.unwrap_or(false);
        // An analytic shape's triangles are counted before it is
        // tessellated (a file mesh's as it is read, above).
        let analytic = match kind.as_str() {
            "rectangle" => 2,
            "cube" => 12,
            "disk" => DISK_SEGMENTS as u64,
            "sphere" => shapes::uv_sphere_triangles(SPHERE_SEGMENTS as u64, SPHERE_RINGS as u64),
            _ => 0,
        };
        if analytic > self.triangles_left {
            return Err(d.node_error(
                node,
                too_many_triangles("this shape makes", analytic, self.triangles_left),
            ));
        }
        self.triangles_left -= analytic;
        let mut file_mesh = |p: &mut Props<'a, 'i>,
                             load: fn(&Path, u64) -> std::result::Result<ply::PlyMesh, String>|
         -> Result<(TriMesh, Vec<Vec2>, bool)> {
            let (name, n) = p
                .string(d, "filename")?
                .ok_or_else(|| d.node_error(node, format!("{what} needs 'filename'")))?;
            let path = d.file.parent().unwrap_or(Path::new("")).join(&name);
            self.inputs.push(path.clone());
            let left = self.triangles_left;
            let (mut mesh, uvs) = load(&path, left).map_err(|e| d.attr_error(n, "value", e))?;
            let triangles = mesh.indices.len() as u64;
            if triangles > left {
                return Err(d.attr_error(
                    n,
                    "value",
                    too_many_triangles("its faces make", triangles, left),
                ));
            }
            self.triangles_left -= triangles;
            // As Mitsuba: a file's vertex normals shade unless
            // `face_normals`; a file without them gets smooth ones (made
            // after the transform, as Mitsuba does: the angles change
            // under an uneven scale).
            let face_normals = p.boolean(d, "face_normals")?.unwrap_or(false);
            if face_normals {
                mesh.normals.clear();
            }
            let smooth = !face_normals && mesh.normals.is_empty();
            Ok((mesh, uvs, smooth))
        };
        let mut smooth = false;
        let mut uvs = Vec::new();
        // Mitsuba's meshes keep their winding under a mirroring to_world,
        // its analytic shapes (rectangle, disk, sphere) turn their normal
        // with the inverse transpose, as TriMesh::transform does.
        let (mut mesh, mesh_like, supported): (TriMesh, bool, &[&str]) = match kind.as_str() {
            "rectangle" => {
                // Mitsuba's texture coordinates: ((x + 1)/2, (y + 1)/2).
                uvs = vec![Vec2::ZERO, Vec2::X, Vec2::ONE, Vec2::Y];
                let corners = uvs.iter().map(|uv| (2.0 * *uv - Vec2::ONE).extend(0.0));
                let corners: Vec<Vec3> = corners.collect();
                (
                    shapes::quad([corners[0], corners[1], corners[2], corners[3]]),
                    false,
                    &["to_world", "flip_normals"],
                )
            }
            "cube" => {
                let (m, cube_uvs) = cube();
                uvs = cube_uvs;
                (m, true, &["to_world", "flip_normals"])
            }
            "disk" => (shapes::disk(Vec3::ZERO, Vec3::Z, 1.0, DISK_SEGMENTS), false, &["to_world", "flip_normals"]),
            "sphere" => {
                let center = p.vector(d, "center")?.map_or(DVec3::ZERO, |c| c.0);
                let radius = match p.float(d, "radius")? {
                    None => 1.0,
                    Some((r, _)) if r > 0.0 && r <= MAX_COORDINATE as f64 => r,
                    Some((r, n)) => return Err(d.attr_error(n, "value", format!("radius must be in (0, 10^9], found {r}"))),
                };
                let m = sphere(f32v(center), radius as f32);
                (m, false, &["to_world", "flip_normals", "center", "radius"])
            }
            "obj" | "ply" => {
                // OBJ texture coordinates are not read (a checkerboard on
                // an OBJ is refused below).
                let load: fn(&Path, u64) -> std::result::Result<ply::PlyMesh, String> = if kind == "obj" {
                    |path, max| obj::load_obj(path, max).map(|m| (m, Vec::new()))
                } else {
                    ply::load_ply
                };
                let (m, file_uvs, s) = file_mesh(&mut p, load)?;
                smooth = s;
                uvs = file_uvs;
                (m, true, &["to_world", "flip_normals", "filename", "face_normals"])
            }
            other => {
                return Err(d.attr_error(
                    node,
                    "type",
                    format!("unsupported shape '{other}' (supported: rectangle, cube, sphere, disk, obj, ply)"),
                ))
            }
        };
        p.finish(d, &what, supported)?;
        debug_assert!(
            analytic == 0 || mesh.indices.len() as u64 == analytic,
            "{kind}"
        );
        if let Some(m) = to_world {
            let affine = Affine3A::from_mat4(m.as_mat4());
            mesh.transform(&affine);
            if mesh_like && affine.matrix3.determinant() < 0.0 {
                for tri in &mut mesh.indices {
                    tri.swap(1, 2);
                }
            }
        }
        if flip {
            for tri in &mut mesh.indices {
                tri.swap(1, 2);
            }
            for n in &mut mesh.normals {
                *n = -*n;
            }
        }
        if smooth {
            mesh.normals = angle_weighted_normals(&mesh);
        }
        if let Some(message) =
            far_vertex(&mesh).or_else(|| degenerate(&mesh, &what, to_world.is_some()))
        {
            return Err(d.node_error(node, message));
        }
        let (line, column) = d.position(node);
        let name = d
            .attr(node, "id")?
            .unwrap_or_else(|| format!("{kind}@{line}:{column}"));
        // Mitsuba gives a shape without a BSDF a diffuse 0.5 one, but an
        // emitter without one reflects nothing (checked by rendering).
        let bsdf = match (bsdf_used, radiance) {
            (Some(b), _) => b,
            (None, Some(_)) => Bsdf {
                albedo: Vec3::ZERO,
                one_sided: true,
                uv_checker: None,
            },
            (None, None) => DEFAULT_BSDF,
        };
        let material = self.material(bsdf, radiance.unwrap_or(Vec3::ZERO), name.clone());
        if bsdf.uv_checker.is_some() && uvs.is_empty() {
            return Err(d.node_error(
                node,
                format!("a checkerboard texture needs texture coordinates, and this {kind} has none in mdas (rectangles, cubes and PLY files with u v have them; spheres, disks and OBJ files do not)"),
            ));
        }
        let TriMesh {
            positions,
            indices,
            normals,
        } = mesh;
        self.meshes.push(Mesh {
            name,
            positions,
            indices,
            normals,
            uvs,
            material,
            motion: Vec::new(),
        });
        Ok(())
    }

    /// The loaded scene and the integrand its integrator and emitters ask
    /// for.
    pub(super) fn finish(mut self, file: &Path) -> Result<SceneFile> {
        let top = (file.to_path_buf(), 1, 1);
        let Some(sensor) = self.sensor else {
            return Err(invalid(
                &top,
                "the scene has no <sensor> (mdas needs a perspective or thinlens camera)",
            ));
        };
        let Some((method, method_at)) = self.integrator else {
            return Err(invalid(
                &top,
                "the scene has no <integrator>: Mitsuba's default (path tracing of unlimited depth) has no fixed-length equivalent here; add <integrator type=\"direct\"/> or <integrator type=\"path\"> with max_depth",
            ));
        };
        let emissive = self
            .meshes
            .iter()
            .any(|m| self.materials[m.material as usize].emission.max_element() > 0.0);
        let directional = self
            .lights
            .iter()
            .any(|l| matches!(l, Light::Directional { .. }));
        let delta = !self.lights.is_empty();
        let lens = |why: &str| {
            invalid(
                &sensor.at,
                format!("a thinlens sensor with {why}: mdas's thin-lens integrand (depth_of_field) lights with point and directional emitters only; use a perspective sensor"),
            )
        };
        let integrand = match method {
            Method::Direct | Method::Path { max_depth: 2 } => {
                if sensor.thin_lens && emissive {
                    return Err(lens("area emitters"));
                }
                match (emissive, delta) {
                    (true, true) if directional => {
                        return Err(invalid(
                            &method_at,
                            "direct lighting from area and directional emitters together: mdas's direct integrands take area lights (area_light), or point and directional lights (depth_of_field), or area and point lights (many_light); use <integrator type=\"path\"> for all of them",
                        ))
                    }
                    (true, true) => IntegrandSpec::ManyLight(ManyLightSpec::default()),
                    (false, true) => IntegrandSpec::DepthOfField,
                    _ => IntegrandSpec::AreaLight,
                }
            }
            Method::Path { max_depth } => {
                if sensor.thin_lens {
                    return Err(lens("path tracing"));
                }
                let limit = crate::integrand::path::max_bounces_limit(emissive) as i64;
                let bounces = max_depth - 2;
                if bounces > limit {
                    return Err(invalid(
                        &method_at,
                        format!(
                            "max_depth {max_depth} is {bounces} indirect bounces; mdas's path integrand takes at most {limit}{} (max_depth ≤ {})",
                            if emissive { " with area lights" } else { "" },
                            limit + 2
                        ),
                    ));
                }
                IntegrandSpec::PathTracing {
                    max_bounces: bounces as u32,
                }
            }
        };
        let spp = sensor.spp.map(|s| s as f32);
        let mut inputs = self.inputs;
        let mdas = match crate::scene_file::mdas::sidecar(file, sensor.film, spp)? {
            Some((params, path)) => {
                inputs.push(path);
                params
            }
            None => {
                let mut mdas = MdasParams::for_film(sensor.film);
                if let Some(spp) = spp {
                    mdas.spp = spp;
                    mdas = mdas.resolved(sensor.film);
                    crate::integrator::mdas::validate(&mdas)
                        .map_err(|e| invalid(&sensor.at, format!("sample_count: {e}")))?;
                }
                mdas
            }
        };
        let mut scene = Scene {
            film: sensor.film,
            camera: sensor.camera,
            background: Vec3::ZERO,
            materials: self.materials,
            meshes: self.meshes,
            lights: self.lights,
            point_light_sets: Vec::new(),
        };
        self.warnings.extend(scene.orient_to_normals());
        Ok(SceneFile {
            scene,
            integrand,
            visibility: Visibility::Bvh,
            voxel: VoxelParams::default(),
            mdas,
            inputs,
            warnings: self.warnings,
        })
    }
}

/// Mitsuba's analytic sphere as triangles: a UV sphere of
/// [`SPHERE_SEGMENTS`] × [`SPHERE_RINGS`] whose radius is scaled so that
/// its area is the sphere's (inscribed, it would fall 5·10⁻⁴ short), so
/// that it emits the same power and — by Cauchy's formula, a convex body's
/// mean projected area is a quarter of its area — shows the same
/// silhouette on average over directions; radial shading normals make it
/// shade smooth, as the analytic sphere.
fn sphere(center: Vec3, radius: f32) -> TriMesh {
    let unit = shapes::uv_sphere(Vec3::ZERO, 1.0, SPHERE_SEGMENTS, SPHERE_RINGS);
    let scale = (4.0 * std::f64::consts::PI / unit.area()).sqrt() as f32;
    TriMesh {
        positions: unit
            .positions
            .iter()
            .map(|p| center + radius * scale * *p)
            .collect(),
        normals: unit.positions.iter().map(|p| p.normalize()).collect(),
        indices: unit.indices,
    }
}

/// Smooth vertex normals as Mitsuba computes them for a mesh file
/// without any: each face's unit normal added to its vertices weighted
/// by the face's angle there (Thürmer and Wüthrich 1998), normalized;
/// a vertex of degenerate faces only keeps a zero normal (the
/// geometric normal shades there).
fn angle_weighted_normals(mesh: &TriMesh) -> Vec<Vec3> {
    let mut sum = vec![Vec3::ZERO; mesh.positions.len()];
    for t in 0..mesh.indices.len() {
        let Some(n) = mesh.face_normal(t).try_normalize() else {
            continue;
        };
        let idx = mesh.indices[t];
        let p = mesh.triangle(t);
        for k in 0..3 {
            let (a, b) = (p[(k + 1) % 3] - p[k], p[(k + 2) % 3] - p[k]);
            let angle = a.angle_between(b);
            if angle.is_finite() {
                sum[idx[k] as usize] += angle * n;
            }
        }
    }
    sum.into_iter().map(Vec3::normalize_or_zero).collect()
}

/// Mitsuba's `cube`: [−1, 1]³ as six faces of four vertices each, every
/// face's corners in Mitsuba's order with texture coordinates (0, 1),
/// (1, 1), (1, 0), (0, 0), and triangles (0, 1, 2), (3, 0, 2) per face
/// (read off Mitsuba 3.9.1's cube: `mi.traverse` of its mesh).
fn cube() -> (TriMesh, Vec<Vec2>) {
    const FACES: [[[f32; 3]; 4]; 6] = [
        [
            [1., -1., -1.],
            [1., -1., 1.],
            [-1., -1., 1.],
            [-1., -1., -1.],
        ],
        [[1., 1., -1.], [-1., 1., -1.], [-1., 1., 1.], [1., 1., 1.]],
        [[1., -1., -1.], [1., 1., -1.], [1., 1., 1.], [1., -1., 1.]],
        [[1., -1., 1.], [1., 1., 1.], [-1., 1., 1.], [-1., -1., 1.]],
        [
            [-1., -1., 1.],
            [-1., 1., 1.],
            [-1., 1., -1.],
            [-1., -1., -1.],
        ],
        [
            [1., 1., -1.],
            [1., -1., -1.],
            [-1., -1., -1.],
            [-1., 1., -1.],
        ],
    ];
    let corner_uvs = [Vec2::Y, Vec2::ONE, Vec2::X, Vec2::ZERO];
    let positions = FACES.iter().flatten().map(|&p| Vec3::from(p)).collect();
    let indices = (0..6u32)
        .flat_map(|f| [[4 * f, 4 * f + 1, 4 * f + 2], [4 * f + 3, 4 * f, 4 * f + 2]])
        .collect();
    let uvs = (0..6).flat_map(|_| corner_uvs).collect();
    (TriMesh::new(positions, indices), uvs)
}

/// An emitted colour: finite, non-negative, at most [`MAX_EMISSION`];
/// Mitsuba's default is 1.
fn emission<'a, 'i>(d: &Doc<'a, 'i>, p: &mut Props<'a, 'i>, key: &str) -> Result<Vec3> {
    match p.color(d, key)? {
        None => Ok(Vec3::ONE),
        Some((c, _)) if c.min_element() >= 0.0 && c.max_element() <= MAX_EMISSION as f64 => {
            Ok(f32v(c))
        }
        Some((c, n)) => Err(d.attr_error(
            n,
            "value",
            format!("{key} must be in [0, 1e20] per channel, found {c}"),
        )),
    }
}

/// `<emitter type="point"|"directional">` outside a shape.
fn emitter<'a, 'i>(d: &Doc<'a, 'i>, node: Node<'a, 'i>) -> Result<Light> {
    let kind = d.need_attr(node, "type")?;
    let mut p = Props::read(d, node)?;
    no_nested(d, node)?;
    let to_world = p.transform(d, "to_world")?.map(|t| t.0);
    let light = match kind.as_str() {
        "point" => {
            let position = match (p.vector(d, "position")?, to_world) {
                (Some(_), Some(_)) => return Err(d.node_error(node, "a point emitter takes 'position' or 'to_world', not both")),
                (Some((v, _)), None) => v,
                (None, Some(m)) => m.transform_point3(DVec3::ZERO),
                (None, None) => DVec3::ZERO,
            };
            if position.abs().max_element() > MAX_COORDINATE as f64 {
                return Err(d.node_error(node, "the point emitter lies beyond ±10^9"));
            }
            let intensity = emission(d, &mut p, "intensity")?;
            p.finish(d, "emitter 'point'", &["position", "to_world", "intensity"])?;
            Light::Point {
                position: f32v(position),
                intensity,
            }
        }
        "directional" => {
            let direction = match (p.vector(d, "direction")?, to_world) {
                (Some(_), Some(_)) => return Err(d.node_error(node, "a directional emitter takes 'direction' or 'to_world', not both")),
                (Some((v, _)), None) => v,
                (None, Some(m)) => m.transform_vector3(DVec3::Z),
                (None, None) => DVec3::Z,
            };
            let Some(direction) = direction.try_normalize() else {
                return Err(d.node_error(node, "the directional emitter's direction is zero"));
            };
            let irradiance = emission(d, &mut p, "irradiance")?;
            p.finish(d, "emitter 'directional'", &["direction", "to_world", "irradiance"])?;
            Light::Directional {
                direction: f32v(direction),
                irradiance,
            }
        }
        "area" => return Err(d.node_error(node, "an area emitter belongs inside the <shape> that emits")),
        "constant" | "envmap" => {
            return Err(d.attr_error(
                node,
                "type",
                format!("unsupported emitter '{kind}': mdas has no environment light (its background is only the radiance of rays that leave the scene, and lights nothing); supported: point, directional, area (in a shape)"),
            ))
        }
        other => {
            return Err(d.attr_error(
                node,
                "type",
                format!("unsupported emitter '{other}' (supported: point, directional, area in a shape)"),
            ))
        }
    };
    Ok(light)
}

/// `<integrator type="direct"|"path">`.
fn integrator<'a, 'i>(d: &Doc<'a, 'i>, node: Node<'a, 'i>) -> Result<Method> {
    let kind = d.need_attr(node, "type")?;
    let mut p = Props::read(d, node)?;
    if p.boolean(d, "hide_emitters")? == Some(true) {
        return Err(d.node_error(
            node,
            "hide_emitters is not supported (mdas's integrands show the emitters they see)",
        ));
    }
    let method = match kind.as_str() {
        "direct" => {
            // Sample counts of Mitsuba's estimator: mdas's direct
            // integrands take one light sample per evaluation, with the
            // same expected value.
            for key in ["emitter_samples", "bsdf_samples", "shading_samples"] {
                p.integer(d, key)?;
            }
            p.finish(
                d,
                "integrator 'direct'",
                &[
                    "emitter_samples",
                    "bsdf_samples",
                    "shading_samples",
                    "hide_emitters",
                ],
            )?;
            Method::Direct
        }
        "path" => {
            let max_depth = match p.integer(d, "max_depth")? {
                None | Some((-1, _)) => {
                    return Err(d.node_error(
                        node,
                        "path tracing needs a finite max_depth (mdas traces fixed-length paths: max_depth − 2 indirect bounces)",
                    ))
                }
                Some((v, n)) if v < 2 => {
                    return Err(d.attr_error(n, "value", format!("max_depth {v}: mdas renders at least direct lighting (max_depth ≥ 2)")))
                }
                Some((v, _)) => v,
            };
            p.integer(d, "rr_depth")?;
            p.finish(
                d,
                "integrator 'path'",
                &["max_depth", "rr_depth", "hide_emitters"],
            )?;
            Method::Path { max_depth }
        }
        other => {
            return Err(d.attr_error(
                node,
                "type",
                format!("unsupported integrator '{other}' (supported: direct, path)"),
            ))
        }
    };
    Ok(method)
}
