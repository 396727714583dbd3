//! Wavefront OBJ meshes for `[[shape]] type = "mesh"`, read with tobj.
//!
//! Vertex positions, vertex normals and faces are used: polygons are
//! fan-triangulated (tobj), points and lines are ignored, and face winding
//! is kept as written, so the OBJ's counter-clockwise faces keep their
//! geometric normals (and emit on that side). Vertex normals (`vn`) become
//! the mesh's shading normals ([`TriMesh::normals`]; a vertex used with two
//! normals is split in two); every face must give them at every corner or
//! none do. Texture coordinates are not used.
//!
//! * [`load_obj`]: the whole file as one mesh (a shape whose scene-file
//!   `material` overrides the OBJ's).
//! * [`load_obj_parts`]: one part per object or group and material, in
//!   file order, with the materials of its `mtllib` files (MTL `Kd` →
//!   albedo, `Ke` → emission; textures are reported, not used).

use super::shapes::TriMesh;
use glam::Vec3;
use std::path::{Path, PathBuf};

/// The largest MTL file read.
pub const MAX_MTL_BYTES: u64 = 1 << 26;

/// One material of an OBJ's material library.
#[derive(Clone, Debug, PartialEq)]
pub struct ObjMaterial {
    pub name: String,
    /// `Kd`, if given.
    pub diffuse: Option<Vec3>,
    /// `Ke`, if given.
    pub emission: Option<Vec3>,
    /// The texture maps it names (`map_Kd` and the others), ignored.
    pub textures: Vec<String>,
}

/// One object or group of an OBJ with one material.
#[derive(Clone, Debug, PartialEq)]
pub struct ObjPart {
    /// The object or group name (tobj's model name; may repeat when an
    /// object changes material).
    pub name: String,
    pub mesh: TriMesh,
    /// Index into [`ObjFile::materials`]; `None` for faces without a
    /// `usemtl`.
    pub material: Option<usize>,
}

/// An OBJ read with its materials.
#[derive(Clone, Debug, PartialEq)]
pub struct ObjFile {
    pub parts: Vec<ObjPart>,
    pub materials: Vec<ObjMaterial>,
    /// The MTL files read (what a cached render also depends on).
    pub mtl_files: Vec<PathBuf>,
}

/// Runs a third-party parser (tobj is not fuzzed against every input) so
/// that a panic in it comes back as an error value, its message, and
/// prints nothing: the process's panic hook is wrapped once to stay
/// silent for panics raised inside `f` on this thread, and prints every
/// other panic as before.
pub(crate) fn without_panics<T>(f: impl FnOnce() -> T) -> Result<T, String> {
    use std::cell::Cell;
    thread_local! {
        static QUIET: Cell<bool> = const { Cell::new(false) };
    }
    static HOOK: std::sync::Once = std::sync::Once::new();
    HOOK.call_once(|| {
        let previous = std::panic::take_hook();
        std::panic::set_hook(Box::new(move |info| {
            if !QUIET.with(Cell::get) {
                previous(info);
            }
        }));
    });
    let was = QUIET.with(|q| q.replace(true));
    let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(f));
    QUIET.with(|q| q.set(was));
    result.map_err(|payload| {
        payload
            .downcast_ref::<&str>()
            .map(|m| m.to_string())
            .or_else(|| payload.downcast_ref::<String>().cloned())
            .unwrap_or_else(|| "a panic without a message".to_string())
    })
}

/// Why tobj's MTL parser failed on `bytes`: the first line that makes it
/// fail alone, inside a material of its own (MTL statements do not refer
/// to one another), or a sentence without a line when none does alone.
fn mtl_panic(bytes: &[u8]) -> String {
    let text = String::from_utf8_lossy(bytes);
    for (i, line) in text.lines().enumerate() {
        let probe = format!("newmtl probe\n{line}\n");
        if without_panics(|| tobj::load_mtl_buf(&mut probe.as_bytes())).is_err() {
            let shown: String = line.trim().chars().take(80).collect();
            return format!("line {}: the MTL parser cannot read '{shown}'", i + 1);
        }
    }
    "the MTL parser failed on this file (on no single line)".to_string()
}

/// The largest OBJ file read (a 10M-triangle mesh is about 500 MB).
pub const MAX_OBJ_BYTES: u64 = 1 << 30;

/// Read and triangulate an OBJ file as one mesh (materials ignored), of
/// at most `max_triangles` triangles (the scene's budget left, counted
/// before the faces are parsed). The error is a sentence naming the file,
/// for the scene loader to place at the `file` key.
pub fn load_obj(path: &Path, max_triangles: u64) -> Result<TriMesh, String> {
    let bytes = read_obj(path, max_triangles)?;
    parse_obj(&bytes).map_err(|e| format!("mesh file '{}': {e}", path.display()))
}

/// The file's text, refused if its faces would make more than
/// `max_triangles` triangles (counted before they are parsed).
fn read_obj(path: &Path, max_triangles: u64) -> Result<Vec<u8>, String> {
    let bytes = super::read_input(path, MAX_OBJ_BYTES)
        .map(plain_lines)
        .map_err(|e| format!("cannot read mesh file '{}': {e}", path.display()))?;
    let triangles = face_triangles(&bytes);
    if triangles > max_triangles {
        return Err(format!(
            "mesh file '{}': {}",
            path.display(),
            super::too_many_triangles("its faces make", triangles, max_triangles)
        ));
    }
    Ok(bytes)
}

/// The triangles an OBJ's `f` lines make (a polygon of k vertices makes
/// k − 2), counted from the text before it is parsed: the scene's budget
/// is checked before the work (issue 67, hostile inputs class 1).
fn face_triangles(bytes: &[u8]) -> u64 {
    bytes
        .split(|&b| b == b'\n')
        .map(|line| {
            let mut tokens = line
                .split(|b| b.is_ascii_whitespace())
                .filter(|t| !t.is_empty());
            match tokens.next() {
                Some(b"f") => tokens.count().saturating_sub(2) as u64,
                _ => 0,
            }
        })
        .sum()
}

/// The text as the OBJ and MTL parser expects it (issue 54 item 8): a
/// leading UTF-8 byte-order mark dropped (it made the first line's `v`
/// unknown, and a face far below failed on a missing vertex), and lone
/// CR line ends (classic Mac OS) turned into LF (the whole file read as
/// one line). Lines keep their numbers.
fn plain_lines(mut bytes: Vec<u8>) -> Vec<u8> {
    if bytes.starts_with(&[0xef, 0xbb, 0xbf]) {
        bytes.drain(..3);
    }
    for i in 0..bytes.len() {
        if bytes[i] == b'\r' && bytes.get(i + 1) != Some(&b'\n') {
            bytes[i] = b'\n';
        }
    }
    bytes
}

/// Read an OBJ file with the materials of its `mtllib` files (paths
/// relative to the OBJ's directory). Errors: as [`load_obj`]'s, and an
/// unreadable or invalid material library, or a `usemtl` that names no
/// material of it (with its line).
pub fn load_obj_parts(path: &Path, max_triangles: u64) -> Result<ObjFile, String> {
    let in_file = |e: String| format!("mesh file '{}': {e}", path.display());
    let bytes = read_obj(path, max_triangles)?;
    let dir = path.parent().unwrap_or(Path::new("")).to_path_buf();
    let mtl_files = std::cell::RefCell::new(Vec::new());
    let mtl_error = std::cell::RefCell::new(None);
    let loader = |name: &Path| -> tobj::MTLLoadResult {
        let file = dir.join(name);
        mtl_files.borrow_mut().push(file.clone());
        let read = super::read_input(&file, MAX_MTL_BYTES)
            .map(plain_lines)
            .map_err(|e| format!("cannot read material library '{}': {e}", file.display()))
            .and_then(|b| {
                without_panics(|| tobj::load_mtl_buf(&mut &b[..]))
                    .map_err(|_| {
                        format!(
                            "invalid material library '{}': {}",
                            file.display(),
                            mtl_panic(&b)
                        )
                    })?
                    .map_err(|e| format!("invalid material library '{}': {e}", file.display()))
            });
        read.map_err(|e| {
            mtl_error.borrow_mut().get_or_insert(e);
            tobj::LoadError::OpenFileFailed
        })
    };
    let (models, materials, normals) = parse_models(&bytes, loader).map_err(in_file)?;
    if let Some(e) = mtl_error.into_inner() {
        return Err(in_file(e));
    }
    let materials: Vec<ObjMaterial> = materials
        .map_err(|e| in_file(format!("invalid material library: {e}")))?
        .into_iter()
        .map(|m| {
            let textures = [
                &m.ambient_texture,
                &m.diffuse_texture,
                &m.specular_texture,
                &m.normal_texture,
                &m.shininess_texture,
                &m.dissolve_texture,
            ]
            .into_iter()
            .flatten()
            .cloned()
            .collect();
            ObjMaterial {
                name: m.name,
                diffuse: m.diffuse.map(Vec3::from),
                emission: m.emissive.map(Vec3::from),
                textures,
            }
        })
        .collect();
    // tobj leaves a `usemtl` of an unknown name without a material: say so.
    if let Ok(text) = std::str::from_utf8(&bytes) {
        for (n, line) in text.lines().enumerate() {
            let mut fields = line.split_whitespace();
            if fields.next() == Some("usemtl") {
                let name = line.trim_start()["usemtl".len()..].trim();
                if !materials.iter().any(|m| m.name == name) {
                    return Err(in_file(format!(
                        "line {}: usemtl '{name}' names no material of its material library",
                        n + 1
                    )));
                }
            }
        }
    }
    let mut parts = Vec::with_capacity(models.len());
    for model in &models {
        let mut mesh = TriMesh::default();
        append_model(&mut mesh, model, normals).map_err(in_file)?;
        if !mesh.indices.is_empty() {
            parts.push(ObjPart {
                name: model.name.clone(),
                mesh,
                material: model.mesh.material_id,
            });
        }
    }
    if parts.is_empty() {
        return Err(in_file("it contains no faces".into()));
    }
    Ok(ObjFile {
        parts,
        materials,
        mtl_files: mtl_files.into_inner(),
    })
}

/// Whether an OBJ index (1-based, or negative: relative to the last) names
/// one of the `defined` records before it.
fn index_valid(index: &str, defined: i64) -> bool {
    match index.parse::<i64>() {
        Ok(i) if i > 0 => i <= defined,
        Ok(i) if i < 0 => -i <= defined,
        _ => false,
    }
}

/// Checks the `v`, `vn` and `f` records line by line, so that the common
/// errors name their line (tobj's errors do not): a vertex or normal
/// without three finite coordinates, a face with fewer than three corners,
/// a corner that is not an index of a vertex (or normal) defined before it
/// (1-based, or negative: relative to the last), or faces of which some
/// give normals and some do not. Returns whether the faces give normals.
fn check_lines(text: &str) -> Result<bool, String> {
    let mut vertices: i64 = 0;
    let mut normals: i64 = 0;
    // The first face's line and whether it gave normals.
    let mut first_face: Option<(usize, bool)> = None;
    // The first vertex's line and whether it gave colours.
    let mut first_colors: Option<(usize, bool)> = None;
    for (n, line) in text.lines().enumerate() {
        let at = |what: String| format!("line {}: {what}", n + 1);
        let mut fields = line.split_whitespace();
        match fields.next() {
            Some(record @ ("v" | "vn")) => {
                let coords: Vec<&str> = fields.collect();
                let finite = coords
                    .iter()
                    .take(3)
                    .all(|c| c.parse::<f32>().is_ok_and(f32::is_finite));
                let what = if record == "v" { "vertex" } else { "normal" };
                if coords.len() < 3 || !finite {
                    return Err(at(format!(
                        "a {what} needs three finite coordinates: '{}'",
                        line.trim()
                    )));
                }
                if record == "v" {
                    // tobj reads x y z, x y z w or x y z r g b, and the
                    // colours only when every vertex has them; otherwise
                    // its error names no line (issue 54 item 8).
                    let colored = match coords.len() {
                        3 | 4 => false,
                        6 => true,
                        k => {
                            return Err(at(format!(
                                "a vertex has 3 numbers (x y z), 4 (x y z w) or 6 (x y z r g b), found {k}: '{}'",
                                line.trim()
                            )))
                        }
                    };
                    match first_colors {
                        None => first_colors = Some((n + 1, colored)),
                        Some((first, c)) if c != colored => {
                            return Err(at(format!(
                                "vertex colours must be given for every vertex or none: line {first} {} them and this line {}",
                                if c { "gives" } else { "does not give" },
                                if colored { "does" } else { "does not" }
                            )))
                        }
                        _ => {}
                    }
                    vertices += 1;
                } else {
                    normals += 1;
                }
            }
            Some("f") => {
                let corners: Vec<&str> = fields.collect();
                if corners.len() < 3 {
                    return Err(at(format!(
                        "a face needs at least three corners: '{}'",
                        line.trim()
                    )));
                }
                let mut with_normal = 0;
                for &corner in &corners {
                    let mut indices = corner.split('/');
                    if !index_valid(indices.next().unwrap_or(""), vertices) {
                        return Err(at(format!(
                            "face corner '{corner}' is not one of the {vertices} vertices defined so far"
                        )));
                    }
                    match indices.nth(1) {
                        None | Some("") => {}
                        Some(normal) if index_valid(normal, normals) => with_normal += 1,
                        Some(_) => {
                            return Err(at(format!(
                                "face corner '{corner}' names a normal that is not one of the {normals} defined so far"
                            )))
                        }
                    }
                }
                if with_normal != 0 && with_normal != corners.len() {
                    return Err(at(format!(
                        "some corners of this face give a normal (vn) and some do not: '{}'",
                        line.trim()
                    )));
                }
                let has = with_normal != 0;
                match first_face {
                    None => first_face = Some((n + 1, has)),
                    Some((first, had)) if had != has => {
                        let (yes, no) = if has { (n + 1, first) } else { (first, n + 1) };
                        return Err(at(format!(
                            "the face on line {yes} gives normals (vn) and the face on line {no} does not; \
                             give every face normals or none"
                        )));
                    }
                    Some(_) => {}
                }
            }
            _ => {}
        }
    }
    Ok(first_face.is_some_and(|(_, has)| has))
}

/// What tobj returns: the models and the material library's result; and
/// whether the faces give normals.
type Models = (
    Vec<tobj::Model>,
    Result<Vec<tobj::Material>, tobj::LoadError>,
    bool,
);

/// The line checks, then tobj (a panic inside it comes back as an error).
/// A file that is not UTF-8 is left to tobj, and its normals are not used.
fn parse_models<ML>(bytes: &[u8], material_loader: ML) -> Result<Models, String>
where
    ML: Fn(&Path) -> tobj::MTLLoadResult,
{
    let normals = match std::str::from_utf8(bytes) {
        Ok(text) => check_lines(text)?,
        Err(_) => false,
    };
    let options = tobj::LoadOptions {
        triangulate: true,
        ignore_points: true,
        ignore_lines: true,
        ..Default::default()
    };
    // tobj is not fuzzed against every input; a panic in it must still
    // come back as an error value.
    let loaded = without_panics(|| tobj::load_obj_buf(&mut &bytes[..], &options, material_loader))
        .map_err(|_| "the OBJ parser failed on this file".to_string())?;
    let (models, materials) = loaded.map_err(|e| format!("invalid OBJ: {e}"))?;
    Ok((models, materials, normals))
}

/// Appends one tobj model's finite vertices and in-range faces, and with
/// `normals` its vertex normals (a vertex used with two normals becomes two
/// vertices).
fn append_model(mesh: &mut TriMesh, model: &tobj::Model, normals: bool) -> Result<(), String> {
    let m = &model.mesh;
    let malformed = || {
        format!(
            "object '{}' has malformed position or face data",
            model.name
        )
    };
    if !m.positions.len().is_multiple_of(3) || !m.indices.len().is_multiple_of(3) {
        return Err(malformed());
    }
    let mut positions = Vec::with_capacity(m.positions.len() / 3);
    for p in m.positions.chunks_exact(3) {
        let p = Vec3::new(p[0], p[1], p[2]);
        if !p.is_finite() {
            return Err(format!(
                "object '{}' has a non-finite vertex {p}",
                model.name
            ));
        }
        positions.push(p);
    }
    if m.indices.iter().any(|&i| i as usize >= positions.len()) {
        return Err(format!(
            "object '{}' has a face index out of range",
            model.name
        ));
    }
    let index = |i: usize| u32::try_from(i).map_err(|_| "too many vertices".to_string());
    if !normals {
        if !mesh.normals.is_empty() {
            return Err(malformed());
        }
        let base = mesh.positions.len();
        mesh.positions.extend_from_slice(&positions);
        for t in m.indices.chunks_exact(3) {
            mesh.indices.push([
                index(base + t[0] as usize)?,
                index(base + t[1] as usize)?,
                index(base + t[2] as usize)?,
            ]);
        }
        return Ok(());
    }
    if !m.normals.len().is_multiple_of(3) || m.normal_indices.len() != m.indices.len() {
        return Err(format!("object '{}' has malformed normal data", model.name));
    }
    let vn: Vec<Vec3> = m
        .normals
        .chunks_exact(3)
        .map(|n| Vec3::new(n[0], n[1], n[2]))
        .collect();
    if m.normal_indices.iter().any(|&i| i as usize >= vn.len()) {
        return Err(format!(
            "object '{}' has a normal index out of range",
            model.name
        ));
    }
    mesh.normals.resize(mesh.positions.len(), Vec3::ZERO);
    let mut vertex_of = std::collections::HashMap::new();
    for (t, n) in m
        .indices
        .chunks_exact(3)
        .zip(m.normal_indices.chunks_exact(3))
    {
        let mut tri = [0u32; 3];
        for c in 0..3 {
            let key = (t[c], n[c]);
            tri[c] = match vertex_of.get(&key) {
                Some(&v) => v,
                None => {
                    let v = index(mesh.positions.len())?;
                    mesh.positions.push(positions[t[c] as usize]);
                    mesh.normals.push(vn[n[c] as usize]);
                    vertex_of.insert(key, v);
                    v
                }
            };
        }
        mesh.indices.push(tri);
    }
    Ok(())
}

/// Parse OBJ text as one mesh (see [`load_obj`]).
pub fn parse_obj(bytes: &[u8]) -> Result<TriMesh, String> {
    let (models, _materials, normals) =
        parse_models(bytes, |_| Ok((Vec::new(), Default::default())))?;
    let mut mesh = TriMesh::default();
    for model in &models {
        append_model(&mut mesh, model, normals)?;
    }
    if mesh.indices.is_empty() {
        return Err("it contains no faces".into());
    }
    Ok(mesh)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The pre-count of the triangle budget: fans of polygons, other
    /// lines (and `f` inside a word) not counted.
    #[test]
    fn face_triangles_counts_fans() {
        let text =
            b"v 0 0 0\nf 1 2 3\n  f 1/1 2/2 3/3 4/4\r\nfo 1 2 3\nvt 0 0\n#f 1 2 3\nf\t1 2 3 4 5\n";
        assert_eq!(face_triangles(text), 1 + 2 + 3);
    }

    #[test]
    fn quads_are_fan_triangulated_and_objects_merged() {
        let text = "o a\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\no b\nv 0 0 1\nv 1 0 1\nv 0 1 1\nf 5 6 7\n";
        let m = parse_obj(text.as_bytes()).unwrap();
        assert_eq!(m.indices.len(), 3);
        assert_eq!(m.positions.len(), 7);
        for t in 0..3 {
            assert!(m.face_normal(t).z > 0.0);
        }
    }

    /// Issue 54 item 8: a UTF-8 byte-order mark and classic Mac OS line
    /// ends (a lone CR) read as the plain file does; CRLF stays CRLF.
    #[test]
    fn a_byte_order_mark_and_cr_line_ends_read_as_plain_text() {
        let plain = parse_obj(b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
        for bytes in [
            plain_lines(b"\xef\xbb\xbfv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n".to_vec()),
            plain_lines(b"v 0 0 0\rv 1 0 0\rv 0 1 0\rf 1 2 3\r".to_vec()),
            plain_lines(b"v 0 0 0\r\nv 1 0 0\r\nv 0 1 0\r\nf 1 2 3\r\n".to_vec()),
        ] {
            let m = parse_obj(&bytes).unwrap();
            assert_eq!(
                (m.positions.clone(), m.indices.clone()),
                (plain.positions.clone(), plain.indices.clone())
            );
        }
        assert_eq!(plain_lines(b"a\r\nb\rc".to_vec()), b"a\r\nb\nc");
        // Line numbers survive: the bad face is still on line 4.
        let e = parse_obj(&plain_lines(
            b"\xef\xbb\xbfv 0 0 0\rv 1 0 0\rv 0 1 0\rf 1 2 9\r".to_vec(),
        ))
        .unwrap_err();
        assert!(e.contains("line 4: face corner '9'"), "{e}");
    }

    /// The vertex forms tobj reads still load: x y z w, and colours on
    /// every vertex.
    #[test]
    fn homogeneous_and_coloured_vertices_load() {
        for text in [
            "v 0 0 0 1\nv 1 0 0 1\nv 0 1 0 1\nf 1 2 3\n",
            "v 0 0 0 1 0 0\nv 1 0 0 0 1 0\nv 0 1 0 0 0 1\nf 1 2 3\n",
        ] {
            let m = parse_obj(text.as_bytes()).unwrap();
            assert_eq!((m.positions.len(), m.indices.len()), (3, 1), "{text}");
        }
    }

    /// Issue 18 item 10: the common OBJ errors name their line.
    #[test]
    fn bad_records_name_their_line() {
        for (text, line) in [
            (
                "v 0 0 0\nv 1 0 0\nv 1 2\nf 1 2 3\n",
                "line 3: a vertex needs",
            ),
            ("v 0 0 0\nv 1 0 0\nv nan 1 0\n", "line 3: a vertex needs"),
            (
                "v 0 0 0\nv 1 0 0 1 0.5 0.5 0.5\nv 0 1 0\nf 1 2 3\n",
                "line 2: a vertex has 3 numbers (x y z), 4 (x y z w) or 6 (x y z r g b), found 7",
            ),
            (
                "v 0 0 0\nv 1 0 0 0.5 0.5 0.5\nv 0 1 0\nf 1 2 3\n",
                "line 2: vertex colours must be given for every vertex or none",
            ),
            (
                "v 0 0 0\nv 1 0 0\nv 0 1 0\n\nf 1 2 4\n",
                "line 5: face corner '4'",
            ),
            ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2\n", "line 4: a face needs"),
            (
                "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1/1 x 3\n",
                "line 4: face corner 'x'",
            ),
            (
                "v 0 0 0\nv 1 0 0\nv 0 1 0\nf -1 -2 -4\n",
                "line 4: face corner '-4'",
            ),
        ] {
            let e = parse_obj(text.as_bytes()).unwrap_err();
            assert!(e.starts_with(line), "{text:?}: {e}");
        }
        let relative = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf -3 -2 -1\n";
        assert_eq!(parse_obj(relative.as_bytes()).unwrap().indices, [[0, 1, 2]]);
    }

    /// Issue 19: `vn` normals follow their corners. The shared edge's
    /// vertices appear with two normals (one per face), so they are split:
    /// 4 positions become 6 vertices, and each triangle's corners carry the
    /// normals its face named, whatever tobj's own index order.
    #[test]
    fn vertex_normals_follow_their_corners_and_split_shared_vertices() {
        let text = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n\
                    vn 0 0 1\nvn 0.6 0 0.8\nvn 0 0.6 0.8\n\
                    f 1//1 2//1 3//2\nf 1//3 3//3 4//3\n";
        let m = parse_obj(text.as_bytes()).unwrap();
        assert_eq!(m.indices.len(), 2);
        assert_eq!(
            m.positions.len(),
            6,
            "corners 1 and 3 each have two normals"
        );
        assert_eq!(m.normals.len(), m.positions.len());
        let corner = |t: usize, c: usize| {
            let v = m.indices[t][c] as usize;
            (m.positions[v], m.normals[v])
        };
        let (z, x, y) = (
            Vec3::new(0.0, 0.0, 1.0),
            Vec3::new(0.6, 0.0, 0.8),
            Vec3::new(0.0, 0.6, 0.8),
        );
        assert_eq!(corner(0, 0), (Vec3::ZERO, z));
        assert_eq!(corner(0, 1), (Vec3::X, z));
        assert_eq!(corner(0, 2), (Vec3::new(1.0, 1.0, 0.0), x));
        for (c, p) in [Vec3::ZERO, Vec3::new(1.0, 1.0, 0.0), Vec3::Y]
            .into_iter()
            .enumerate()
        {
            assert_eq!(corner(1, c), (p, y));
        }
        // The winding (geometric normal) is the file's, not the normals'.
        assert!(m.face_normal(0).z > 0.0 && m.face_normal(1).z > 0.0);
        // Without vn (a texture index alone included) there are no normals
        // and no split vertices, even when the file defines vn records.
        for text in [
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nf 1/1 2/1 3/1\n",
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nf 1 2 3\n",
        ] {
            let m = parse_obj(text.as_bytes()).unwrap();
            assert!(m.normals.is_empty(), "{text:?}");
            assert_eq!(m.positions.len(), 3);
        }
        // v/vt/vn corners give normals too.
        let m = parse_obj(b"v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvn 0 0 1\nf 1/1/1 2/1/1 3/1/1\n")
            .unwrap();
        assert_eq!(m.normals, vec![Vec3::Z; 3]);
    }

    #[test]
    fn bad_normals_name_their_line() {
        let head = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nvn 0 0 1\n";
        for (tail, error) in [
            (
                "vn 0 inf 1\n",
                "line 6: a normal needs three finite coordinates",
            ),
            (
                "vn 0 1\n",
                "line 6: a normal needs three finite coordinates",
            ),
            (
                "f 1//1 2//2 3//1\n",
                "line 6: face corner '2//2' names a normal",
            ),
            (
                "f 1//1 2 3//1\n",
                "line 6: some corners of this face give a normal",
            ),
            (
                "f 1//1 2//1 3//1\nf 2 4 3\n",
                "line 7: the face on line 6 gives normals (vn) and the face on line 7 does not",
            ),
            (
                "f 2 4 3\nf 1//1 2//1 3//1\n",
                "line 7: the face on line 7 gives normals (vn) and the face on line 6 does not",
            ),
        ] {
            let text = format!("{head}{tail}");
            let e = parse_obj(text.as_bytes()).unwrap_err();
            assert!(e.starts_with(error), "{text:?}: {e}");
        }
    }

    #[test]
    fn bad_input_is_an_error_not_a_panic() {
        for text in [
            "",
            "v 0 0 0\n",
            "f 1 2 3\n",
            "v 0 0 0\nv 1 0 0\nv nan 1 0\nf 1 2 3\n",
            "v 1 2\nf 1 1 1\n",
            "\u{0}\u{1}garbage",
        ] {
            assert!(parse_obj(text.as_bytes()).is_err(), "{text:?}");
        }
    }
}
