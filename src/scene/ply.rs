//! PLY meshes (ASCII, binary little- and big-endian) through the
//! `ply-rs-bw` crate: positions `x y z`, shading normals `nx ny nz` when
//! the file has all three (as an OBJ's `vn`, [`super::shapes::TriMesh`]),
//! and the faces' `vertex_indices` (or `vertex_index`) lists, polygons of
//! more than three vertices split into a fan (v0, vᵢ, vᵢ₊₁) as Mitsuba
//! splits quads. Any other element or property (colours, texture
//! coordinates, edges) is read and left out: no integrand uses them.
//! Winding is kept: the geometric normal of a face is
//! (v1 − v0) × (v2 − v0), as everywhere else (docs/conventions.md "Materials").

use super::shapes::TriMesh;
use glam::{Vec2, Vec3};
use ply_rs_bw::parser::{Parser, Reader};
use ply_rs_bw::ply::{ElementDef, Property, PropertyAccess, PropertyAccessResult, PropertyType};
use std::path::Path;

/// The largest PLY file read (as [`super::obj::MAX_OBJ_BYTES`]).
pub const MAX_PLY_BYTES: u64 = 1 << 30;

/// A PLY mesh and its texture coordinates (one per position, or none).
pub type PlyMesh = (TriMesh, Vec<Vec2>);

/// Read a PLY file as one mesh of at most `max_triangles` triangles (the
/// scene's budget left, [`super::MAX_SCENE_TRIANGLES`] at most). The error
/// is a sentence naming the file, for the scene loader to place at the
/// element that named it.
pub fn load_ply(path: &Path, max_triangles: u64) -> Result<PlyMesh, String> {
    let bytes = super::read_input(path, MAX_PLY_BYTES)
        .map_err(|e| format!("cannot read mesh file '{}': {e}", path.display()))?;
    // The parser is a dependency: a panic in it is an error, not a crash
    // (issue 54 item 2).
    super::obj::without_panics(|| parse_ply(&bytes, max_triangles))
        .map_err(|panic| format!("the PLY parser failed ({panic})"))
        .and_then(|r| r)
        .map_err(|e| format!("mesh file '{}': {e}", path.display()))
}

/// One vertex as read: the properties this reader uses.
#[derive(Default)]
struct Vertex {
    p: [f32; 3],
    n: [f32; 3],
    uv: [f32; 2],
}

/// The names a PLY file may give its texture coordinates (Mitsuba's).
const UV_NAMES: [[&str; 2]; 4] = [
    ["u", "v"],
    ["s", "t"],
    ["texture_u", "texture_v"],
    ["texture_s", "texture_t"],
];

fn scalar(p: &Property) -> Option<f64> {
    Some(match *p {
        Property::Char(v) => v as f64,
        Property::UChar(v) => v as f64,
        Property::Short(v) => v as f64,
        Property::UShort(v) => v as f64,
        Property::Int(v) => v as f64,
        Property::UInt(v) => v as f64,
        Property::Float(v) => v as f64,
        Property::Double(v) => v,
        _ => return None,
    })
}

impl PropertyAccess for Vertex {
    fn new() -> Self {
        Vertex::default()
    }

    fn set_property(&mut self, name: &str, property: Property) -> PropertyAccessResult {
        let slot = match name {
            "x" => &mut self.p[0],
            "y" => &mut self.p[1],
            "z" => &mut self.p[2],
            "nx" => &mut self.n[0],
            "ny" => &mut self.n[1],
            "nz" => &mut self.n[2],
            "u" | "s" | "texture_u" | "texture_s" => &mut self.uv[0],
            "v" | "t" | "texture_v" | "texture_t" => &mut self.uv[1],
            _ => return PropertyAccessResult::Ignored,
        };
        match scalar(&property) {
            Some(v) => {
                *slot = v as f32;
                PropertyAccessResult::Set
            }
            None => PropertyAccessResult::UnsupportedType,
        }
    }
}

/// One face as read: its vertex indices, any integer type.
#[derive(Default)]
struct Face {
    indices: Vec<i64>,
}

impl PropertyAccess for Face {
    fn new() -> Self {
        Face::default()
    }

    fn set_property(&mut self, name: &str, property: Property) -> PropertyAccessResult {
        if name != "vertex_indices" && name != "vertex_index" {
            return PropertyAccessResult::Ignored;
        }
        self.indices = match property {
            Property::ListChar(v) => v.into_iter().map(i64::from).collect(),
            Property::ListUChar(v) => v.into_iter().map(i64::from).collect(),
            Property::ListShort(v) => v.into_iter().map(i64::from).collect(),
            Property::ListUShort(v) => v.into_iter().map(i64::from).collect(),
            Property::ListInt(v) => v.into_iter().map(i64::from).collect(),
            Property::ListUInt(v) => v.into_iter().map(i64::from).collect(),
            _ => return PropertyAccessResult::UnsupportedType,
        };
        PropertyAccessResult::Set
    }
}

/// An element this reader does not use (read past, values dropped).
struct Skip;

impl PropertyAccess for Skip {
    fn new() -> Self {
        Skip
    }
}

fn has(def: &ElementDef, name: &str) -> bool {
    def.properties.contains_key(name)
}

/// Parse a PLY file's bytes into a mesh of at most `max_triangles`
/// triangles: the header's face count (each face at least one triangle)
/// is checked before the faces are read, their fans' sum before the mesh
/// is made.
pub fn parse_ply(bytes: &[u8], max_triangles: u64) -> Result<PlyMesh, String> {
    let mut reader = Reader::new(std::io::Cursor::new(bytes));
    let header = Parser::<Skip>::new()
        .read_header(&mut reader)
        .map_err(|e| format!("PLY header: {e}"))?;
    let Some(vertex_def) = header.elements.get("vertex") else {
        return Err("the PLY file has no 'vertex' element".into());
    };
    for axis in ["x", "y", "z"] {
        if !has(vertex_def, axis) {
            return Err(format!("the PLY 'vertex' element has no '{axis}' property"));
        }
    }
    let normal_count = ["nx", "ny", "nz"]
        .iter()
        .filter(|n| has(vertex_def, n))
        .count();
    if normal_count != 0 && normal_count != 3 {
        return Err("the PLY 'vertex' element has some of 'nx', 'ny', 'nz' but not all".into());
    }
    let uv_pairs = UV_NAMES
        .iter()
        .filter(|[u, v]| has(vertex_def, u) || has(vertex_def, v))
        .collect::<Vec<_>>();
    let has_uv = match uv_pairs[..] {
        [] => false,
        [[u, v]] if has(vertex_def, u) && has(vertex_def, v) => true,
        _ => {
            return Err(
                "the PLY 'vertex' element names its texture coordinates inconsistently (one pair of u v, s t, texture_u texture_v or texture_s texture_t)"
                    .into(),
            )
        }
    };
    let Some(face_def) = header.elements.get("face") else {
        return Err("the PLY file has no 'face' element (point clouds are not meshes)".into());
    };
    let index_name = ["vertex_indices", "vertex_index"]
        .into_iter()
        .find(|n| has(face_def, n))
        .ok_or("the PLY 'face' element has no 'vertex_indices' (or 'vertex_index') list")?;
    if !matches!(
        face_def.properties[index_name].data_type,
        PropertyType::List(..)
    ) {
        return Err(format!(
            "the PLY face property '{index_name}' is not a list"
        ));
    }
    if face_def.count as u64 > max_triangles {
        return Err(super::too_many_triangles(
            "its header lists faces that make at least",
            face_def.count as u64,
            max_triangles,
        ));
    }
    if vertex_def.count > u32::MAX as usize {
        return Err(format!(
            "{} vertices, more than a mesh may index (2^32 − 1)",
            vertex_def.count
        ));
    }

    let mut vertices = Vec::new();
    let mut faces = Vec::new();
    for (name, def) in &header.elements {
        let read_error = |e| format!("PLY element '{name}': {e}");
        match name.as_str() {
            "vertex" => {
                vertices = Parser::<Vertex>::new()
                    .read_payload_for_element(&mut reader, def, &header)
                    .map_err(read_error)?
            }
            "face" => {
                faces = Parser::<Face>::new()
                    .read_payload_for_element(&mut reader, def, &header)
                    .map_err(read_error)?
            }
            _ => {
                Parser::<Skip>::new()
                    .read_payload_for_element(&mut reader, def, &header)
                    .map_err(read_error)?;
            }
        }
    }

    let n = vertices.len() as i64;
    let triangles: u64 = faces
        .iter()
        .map(|f| f.indices.len().saturating_sub(2) as u64)
        .sum();
    if triangles > max_triangles {
        return Err(super::too_many_triangles(
            "its faces make",
            triangles,
            max_triangles,
        ));
    }
    let mut indices = Vec::with_capacity(faces.len());
    for (f, face) in faces.iter().enumerate() {
        let idx = &face.indices;
        if idx.len() < 3 {
            return Err(format!(
                "face {f} has {} vertices (a face needs at least 3)",
                idx.len()
            ));
        }
        if let Some(&bad) = idx.iter().find(|&&i| i < 0 || i >= n) {
            return Err(format!(
                "face {f} names vertex {bad}, but the file has {n} vertices (0..{n})"
            ));
        }
        for k in 1..idx.len() - 1 {
            indices.push([idx[0] as u32, idx[k] as u32, idx[k + 1] as u32]);
        }
    }
    if indices.is_empty() {
        return Err("the PLY file has no faces".into());
    }
    if let Some((i, v)) = vertices
        .iter()
        .enumerate()
        .find(|(_, v)| !v.p.iter().all(|c| c.is_finite()))
    {
        return Err(format!(
            "vertex {i} is at ({}, {}, {}): not a finite position",
            v.p[0], v.p[1], v.p[2]
        ));
    }
    let positions = vertices.iter().map(|v| Vec3::from(v.p)).collect();
    // Normals as OBJ's `vn`: normalized, a zero or non-finite one stays
    // zero (the geometric normal shades there).
    let normals = if normal_count == 3 {
        vertices
            .iter()
            .map(|v| {
                let n = Vec3::from(v.n);
                if n.is_finite() {
                    n.normalize_or_zero()
                } else {
                    Vec3::ZERO
                }
            })
            .collect()
    } else {
        Vec::new()
    };
    let uvs = if has_uv {
        vertices.iter().map(|v| Vec2::from(v.uv)).collect()
    } else {
        Vec::new()
    };
    if let Some((i, uv)) = uvs.iter().enumerate().find(|(_, uv)| !uv.is_finite()) {
        return Err(format!(
            "vertex {i} has texture coordinates {uv}: not finite"
        ));
    }
    Ok((
        TriMesh {
            positions,
            indices,
            normals,
        },
        uvs,
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::MAX_SCENE_TRIANGLES;

    const ASCII_QUAD: &str = "ply\nformat ascii 1.0\ncomment a unit quad\nelement vertex 4\n\
        property float x\nproperty float y\nproperty float z\n\
        property float nx\nproperty float ny\nproperty float nz\n\
        property float u\nproperty float v\n\
        element face 1\nproperty list uchar int vertex_indices\nend_header\n\
        0 0 0 0 0 2 0 0\n1 0 0 0 0 1 1 0\n1 1 0 0 0 1 1 1\n0 1 0 0 0 1 0 1\n4 0 1 2 3\n";

    #[test]
    fn an_ascii_quad_is_two_triangles_with_normalized_normals() {
        let (m, uvs) = parse_ply(ASCII_QUAD.as_bytes(), MAX_SCENE_TRIANGLES).unwrap();
        assert_eq!(uvs, vec![Vec2::ZERO, Vec2::X, Vec2::ONE, Vec2::Y]);
        assert_eq!(m.positions.len(), 4);
        assert_eq!(m.indices, vec![[0, 1, 2], [0, 2, 3]]);
        assert_eq!(m.normals[0], Vec3::Z, "(0, 0, 2) is normalized");
        assert_eq!(m.face_normal(0).normalize(), Vec3::Z, "winding kept");
        assert!((m.area() - 1.0).abs() < 1e-9);
    }

    /// The same mesh written binary little- and big-endian, with `double`
    /// positions, a `uint` index list, no normals and an extra element.
    fn binary(big_endian: bool) -> Vec<u8> {
        let format = if big_endian {
            "binary_big_endian"
        } else {
            "binary_little_endian"
        };
        let mut b = format!(
            "ply\nformat {format} 1.0\nelement vertex 3\nproperty double x\nproperty double y\n\
             property double z\nproperty uchar red\nelement face 1\n\
             property list uchar uint vertex_indices\nelement edge 1\nproperty int vertex1\n\
             property int vertex2\nend_header\n"
        )
        .into_bytes();
        let f64b = |v: f64| {
            if big_endian {
                v.to_be_bytes()
            } else {
                v.to_le_bytes()
            }
        };
        let u32b = |v: u32| {
            if big_endian {
                v.to_be_bytes()
            } else {
                v.to_le_bytes()
            }
        };
        for p in [[0.0, 0.0, 0.0], [2.0, 0.0, 0.0], [0.0, 0.0, -2.0]] {
            for c in p {
                b.extend(f64b(c));
            }
            b.push(255);
        }
        b.push(3);
        for i in [0, 1, 2] {
            b.extend(u32b(i));
        }
        for i in [0u32, 1] {
            b.extend(u32b(i));
        }
        b
    }

    #[test]
    fn binary_files_of_both_byte_orders_read_the_same() {
        for big in [false, true] {
            let (m, uvs) = parse_ply(&binary(big), MAX_SCENE_TRIANGLES).unwrap();
            assert!(uvs.is_empty());
            assert_eq!(
                m.positions,
                vec![
                    Vec3::ZERO,
                    Vec3::new(2.0, 0.0, 0.0),
                    Vec3::new(0.0, 0.0, -2.0)
                ]
            );
            assert_eq!(m.indices, vec![[0, 1, 2]]);
            assert!(m.normals.is_empty());
            assert_eq!(m.face_normal(0).normalize(), Vec3::Y);
        }
    }

    #[test]
    fn broken_files_are_errors_that_say_why() {
        let cases: &[(String, &str)] = &[
            ("not a ply".into(), "PLY header"),
            (
                ASCII_QUAD.replace("4 0 1 2 3", "4 0 1 2 9"),
                "names vertex 9",
            ),
            (ASCII_QUAD.replace("4 0 1 2 3", "2 0 1"), "at least 3"),
            (ASCII_QUAD.replace("property float nz\n", ""), "not all"),
            (
                ASCII_QUAD.replace("property float y\n", "property float w\n"),
                "no 'y'",
            ),
            (
                ASCII_QUAD.replace("element face 1", "element face 2"),
                "face",
            ),
            (
                ASCII_QUAD.replace("vertex_indices", "colour_list"),
                "vertex_indices",
            ),
            (
                ASCII_QUAD.replace("property float v\n", "property float t\n"),
                "inconsistently",
            ),
        ];
        for (text, want) in cases {
            let e = parse_ply(text.as_bytes(), MAX_SCENE_TRIANGLES).unwrap_err();
            assert!(e.contains(want), "{e:?} should mention {want:?}");
        }
        let mut nan = binary(false);
        let body = nan.windows(11).position(|w| w == b"end_header\n").unwrap() + 11;
        nan[body..body + 8].copy_from_slice(&f64::NAN.to_le_bytes());
        let e = parse_ply(&nan, MAX_SCENE_TRIANGLES).unwrap_err();
        assert!(e.contains("vertex 0") && e.contains("finite"), "{e}");
        let mut truncated = binary(false);
        truncated.truncate(truncated.len() - 10);
        assert!(parse_ply(&truncated, MAX_SCENE_TRIANGLES).is_err());
    }

    /// The triangle budget is checked before the work (issue 67, hostile
    /// inputs class 1): a header's face count above it is refused before
    /// a face is read (here a header claiming 2^26 faces over a body of
    /// one), and a polygon's fan is counted as its triangles (the quad is
    /// one face and two triangles).
    #[test]
    fn the_triangle_budget_is_checked_before_the_faces_are_read() {
        assert_eq!(
            parse_ply(ASCII_QUAD.as_bytes(), 2).unwrap().0.indices.len(),
            2
        );
        let e = parse_ply(ASCII_QUAD.as_bytes(), 1).unwrap_err();
        assert!(
            e.contains("make 2 triangles, more than the 1 the scene"),
            "{e}"
        );
        let lying = ASCII_QUAD.replace("element face 1", &format!("element face {}", 1u64 << 26));
        let e = parse_ply(lying.as_bytes(), MAX_SCENE_TRIANGLES).unwrap_err();
        assert!(
            e.contains(&format!("at least {} triangles", 1u64 << 26)),
            "{e}"
        );
    }
}
