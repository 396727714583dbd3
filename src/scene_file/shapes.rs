//! `[[shape]]`: each type tessellated to a mesh, its transform and motion.

use super::ctx::quoted_list;
use super::ctx::{Ctx, Result};
use super::raw::*;
use super::values::*;
use super::*;
use crate::scene::obj;
use crate::scene::shapes::{self, TriMesh};
use crate::scene::{Keyframe, Material, Mesh};
use glam::{Affine3A, Quat, Vec2, Vec3};
use std::collections::HashMap;

/// The albedo of an MTL material without `Kd` (Blender's and most
/// exporters' default diffuse colour).
pub const OBJ_DEFAULT_ALBEDO: f32 = 0.8;

/// What loading shapes adds besides meshes: the scene's materials (OBJ
/// materials are appended), the files read (OBJ and MTL) and warnings.
pub(super) struct ShapeOutputs {
    pub(super) materials: Vec<Material>,
    pub(super) inputs: Vec<std::path::PathBuf>,
    pub(super) warnings: Vec<String>,
}

/// A vertex beyond ±[`MAX_COORDINATE`] (or not finite), as a sentence.
pub(super) fn far_vertex(mesh: &TriMesh) -> Option<String> {
    let limit = MAX_COORDINATE;
    let p = mesh
        .positions
        .iter()
        .find(|p| !p.is_finite() || p.abs().max_element() > limit)?;
    Some(format!(
        "a vertex lies at {p}, beyond ±{limit:e} (the largest coordinate a scene may use)"
    ))
}

/// Why a `kind` mesh is unusable, as a sentence: no triangle with area, or
/// a pile of coincident triangles ([`shapes::MAX_COINCIDENT_TRIANGLES`]).
pub(super) fn degenerate(mesh: &TriMesh, kind: &str, transformed: bool) -> Option<String> {
    if !mesh.has_area() {
        let why = if transformed {
            " (after transform)"
        } else {
            ""
        };
        return Some(format!(
            "this {kind} is entirely degenerate: every triangle has zero area{why}"
        ));
    }
    shapes::coincident_triangles((0..mesh.indices.len()).map(|t| mesh.triangle(t)))
        .map(|pile| format!("this {kind} is degenerate: {pile}"))
}

/// Splits a merged mesh into its parts (first triangles in `parts`,
/// ascending), each with only the vertices it uses, named `SHAPE/PART`.
fn split_parts(
    mesh: TriMesh,
    parts: &[(String, usize, u32)],
    shape: &str,
    motion: &[Keyframe],
) -> Vec<Mesh> {
    let mut out = Vec::with_capacity(parts.len());
    for (k, (name, first, material)) in parts.iter().enumerate() {
        let end = parts.get(k + 1).map_or(mesh.indices.len(), |p| p.1);
        let tris = &mesh.indices[*first..end];
        let lo = tris.iter().flatten().copied().min().unwrap_or(0);
        let hi = tris.iter().flatten().copied().max().map_or(0, |m| m + 1);
        let normals = if mesh.normals.is_empty() {
            Vec::new()
        } else {
            mesh.normals[lo as usize..hi as usize].to_vec()
        };
        out.push(Mesh {
            name: format!("{shape}/{name}"),
            positions: mesh.positions[lo as usize..hi as usize].to_vec(),
            indices: tris.iter().map(|t| t.map(|i| i - lo)).collect(),
            normals,
            uvs: Vec::new(),
            material: *material,
            motion: motion.to_vec(),
        });
    }
    out
}

impl Ctx<'_> {
    /// Four planar corners of a quad, in order around it.
    pub(super) fn quad_corners(&self, v: &S<Vec<V3>>) -> Result<[Vec3; 4]> {
        let c: [Vec3; 4] = self.points(v, "corners")?;
        let n012 = (c[1] - c[0]).cross(c[2] - c[0]);
        let n023 = (c[2] - c[0]).cross(c[3] - c[0]);
        // Newell-style normal of the whole polygon, robust to one
        // degenerate triangle; when the two halves' normals cancel (a
        // symmetric bow tie) the first half's.
        let normal = (n012 + n023)
            .try_normalize()
            .or_else(|| n012.try_normalize())
            .or_else(|| n023.try_normalize());
        if let Some(n) = normal {
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

    /// One `[[shape]]` as meshes: one mesh, or for an OBJ without a
    /// `material` key one mesh per object or group and material of the
    /// file, its MTL materials appended to `out.materials` (named
    /// `SHAPE/MATERIAL`).
    pub(super) fn shape(
        &self,
        s: &S<RawShape>,
        n: usize,
        by_name: &HashMap<&str, u32>,
        out: &mut ShapeOutputs,
    ) -> Result<Vec<Mesh>> {
        let r = s.get_ref();
        let keys = r.type_keys();
        let t = self.check_type("shape", &r.kind, &keys, &SHAPE_TYPES)?;
        let kind = SHAPE_TYPES[t].0;
        let material = match &r.material {
            None if kind == "mesh" => None,
            None => {
                return Err(self.error(r.kind.span(), format!("a {kind} shape needs 'material'")))
            }
            Some(m) => Some(match by_name.get(m.get_ref().as_str()) {
                Some(&m) => m,
                None => {
                    let mut known: Vec<&str> = by_name.keys().copied().collect();
                    known.sort_unstable();
                    return Err(self.error(
                        m.span(),
                        format!(
                            "unknown material '{}' (defined: {})",
                            m.get_ref(),
                            if known.is_empty() {
                                "none".into()
                            } else {
                                quoted_list(&known)
                            }
                        ),
                    ));
                }
            }),
        };
        let name = r
            .name
            .as_ref()
            .map_or_else(|| format!("shape{n}"), |v| v.get_ref().clone());
        // An OBJ's parts: (name, first triangle, material) in the merged mesh.
        let mut parts: Vec<(String, usize, u32)> = Vec::new();
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
                out.inputs.push(path.clone());
                let left = self.triangles_left();
                let mesh = if material.is_some() {
                    obj::load_obj(&path, left).map_err(|e| self.error(file.span(), e))?
                } else {
                    let obj =
                        obj::load_obj_parts(&path, left).map_err(|e| self.error(file.span(), e))?;
                    out.inputs.extend(obj.mtl_files.iter().cloned());
                    self.obj_parts(&obj, &path, file, &name, &mut parts, out)?
                };
                self.count_check(mesh.indices.len() as u64, file.span(), kind)?;
                mesh
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
                    // Bounded at their keys like coordinates: a vertex
                    // beyond ±MAX_COORDINATE was reported at `min` when
                    // these made it (issue 54 item 8).
                    base_y: r.base_y.as_ref().map_or(Ok(0.0), |v| {
                        self.bounded(v, "base_y", super::MAX_COORDINATE)
                    })?,
                    amplitude: r.amplitude.as_ref().map_or(Ok(1.0), |v| {
                        self.bounded(v, "amplitude", super::MAX_COORDINATE)
                    })?,
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
        if let Some(message) = far_vertex(&mesh) {
            let span = r
                .transform
                .as_ref()
                .map_or(geometry_span.clone(), |t| t.span());
            return Err(self.error(span, message));
        }
        if let Some(message) = degenerate(&mesh, kind, r.transform.is_some()) {
            return Err(self.error(geometry_span, message));
        }
        let motion = match &r.motion {
            Some(m) => self.motion(m)?,
            None => Vec::new(),
        };
        let Some(material) = material else {
            return Ok(split_parts(mesh, &parts, &name, &motion));
        };
        let TriMesh {
            positions,
            indices,
            normals,
        } = mesh;
        Ok(vec![Mesh {
            name,
            positions,
            indices,
            normals,
            uvs: Vec::new(),
            material,
            motion,
        }])
    }

    /// The parts of an OBJ read with its materials, merged into one mesh
    /// (`parts` gets each part's first triangle and scene material); the
    /// OBJ materials the parts use become scene materials.
    fn obj_parts(
        &self,
        obj: &obj::ObjFile,
        path: &Path,
        file: &S<String>,
        shape: &str,
        parts: &mut Vec<(String, usize, u32)>,
        out: &mut ShapeOutputs,
    ) -> Result<TriMesh> {
        let in_file =
            |e: String| self.error(file.span(), format!("mesh file '{}': {e}", path.display()));
        let mut scene_material: Vec<Option<u32>> = vec![None; obj.materials.len()];
        let mut mesh = TriMesh::default();
        for part in &obj.parts {
            let Some(m) = part.material else {
                return Err(in_file(format!(
                    "object '{}' has faces without a material (no usemtl): give the shape a 'material' or the faces a usemtl",
                    part.name
                )));
            };
            let index = match scene_material[m] {
                Some(i) => i,
                None => {
                    let om = &obj.materials[m];
                    let albedo = om.diffuse.unwrap_or(Vec3::splat(OBJ_DEFAULT_ALBEDO));
                    // is_finite first: glam's min/max_element pass a NaN by.
                    if !(albedo.is_finite()
                        && albedo.min_element() >= 0.0
                        && albedo.max_element() <= 1.0)
                    {
                        return Err(in_file(format!(
                            "material '{}': Kd must be in [0, 1] in every channel, found {albedo}",
                            om.name
                        )));
                    }
                    let emission = om.emission.unwrap_or(Vec3::ZERO);
                    if !(emission.is_finite()
                        && emission.min_element() >= 0.0
                        && emission.max_element() <= MAX_EMISSION)
                    {
                        return Err(in_file(format!(
                            "material '{}': Ke must be in [0, {MAX_EMISSION:e}] in every channel, found {emission}",
                            om.name
                        )));
                    }
                    if !om.textures.is_empty() {
                        out.warnings.push(format!(
                            "mesh file '{}': material '{}' names textures ({}), which mdas ignores",
                            path.display(),
                            om.name,
                            om.textures.join(", ")
                        ));
                    }
                    let i = (out.materials.len()) as u32;
                    out.materials.push(Material {
                        name: format!("{shape}/{}", om.name),
                        albedo,
                        emission,
                        checker: None,
                        one_sided: false,
                        uv_checker: None,
                    });
                    scene_material[m] = Some(i);
                    i
                }
            };
            parts.push((part.name.clone(), mesh.indices.len(), index));
            let base = mesh.positions.len() as u32;
            // Every part of one OBJ has normals or none does (obj.rs).
            mesh.normals.extend_from_slice(&part.mesh.normals);
            mesh.positions.extend_from_slice(&part.mesh.positions);
            mesh.indices
                .extend(part.mesh.indices.iter().map(|t| t.map(|i| i + base)));
        }
        Ok(mesh)
    }

    /// scale, then rotate about +y, then translate.
    pub(super) fn transform(&self, t: &RawTransform) -> Result<Affine3A> {
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

    pub(super) fn motion(&self, m: &S<Vec<S<RawKeyframe>>>) -> Result<Vec<Keyframe>> {
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
            let time = self.bounded(&k.time, "time", super::MAX_TIME)?;
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
            let translation = match &k.translate {
                Some(v) => self.bounded3(v, "translate", super::MAX_COORDINATE)?,
                None => Vec3::ZERO,
            };
            out.push(Keyframe {
                time,
                translation,
                rotation,
            });
        }
        Ok(out)
    }
}
