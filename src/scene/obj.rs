//! Wavefront OBJ meshes for `[[shape]] type = "mesh"`, read with tobj.
//!
//! Only vertex positions and faces are used: polygons are fan-triangulated
//! (tobj), points and lines are ignored, all objects and groups of the file
//! are merged into one mesh, and `mtllib` / `usemtl` are ignored (the
//! scene file assigns the material). Face winding is kept as written, so
//! the OBJ's counter-clockwise faces keep their normals.

use super::shapes::TriMesh;
use glam::Vec3;
use std::path::Path;

/// The largest OBJ file read (a 10M-triangle mesh is about 500 MB).
pub const MAX_OBJ_BYTES: u64 = 1 << 30;

/// Read and triangulate an OBJ file. The error is a sentence naming the
/// file, for the scene loader to place at the `file` key.
pub fn load_obj(path: &Path) -> Result<TriMesh, String> {
    let cannot_read =
        |e: &dyn std::fmt::Display| format!("cannot read mesh file '{}': {e}", path.display());
    let bytes = super::read_input(path, MAX_OBJ_BYTES).map_err(|e| cannot_read(&e))?;
    parse_obj(&bytes).map_err(|e| format!("mesh file '{}': {e}", path.display()))
}

/// Checks the `v` and `f` records line by line, so that the common errors
/// name their line (tobj's errors do not): a vertex without three finite
/// coordinates, a face with fewer than three corners, or a corner that is
/// not an index of a vertex defined before it (1-based, or negative:
/// relative to the last).
fn check_lines(text: &str) -> Result<(), String> {
    let mut vertices: i64 = 0;
    for (n, line) in text.lines().enumerate() {
        let at = |what: String| format!("line {}: {what}", n + 1);
        let mut fields = line.split_whitespace();
        match fields.next() {
            Some("v") => {
                let coords: Vec<&str> = fields.collect();
                let finite = coords
                    .iter()
                    .take(3)
                    .all(|c| c.parse::<f32>().is_ok_and(f32::is_finite));
                if coords.len() < 3 || !finite {
                    return Err(at(format!(
                        "a vertex needs three finite coordinates: '{}'",
                        line.trim()
                    )));
                }
                vertices += 1;
            }
            Some("f") => {
                let corners: Vec<&str> = fields.collect();
                if corners.len() < 3 {
                    return Err(at(format!(
                        "a face needs at least three corners: '{}'",
                        line.trim()
                    )));
                }
                for corner in corners {
                    let index = corner.split('/').next().unwrap_or("");
                    let valid = match index.parse::<i64>() {
                        Ok(i) if i > 0 => i <= vertices,
                        Ok(i) if i < 0 => -i <= vertices,
                        _ => false,
                    };
                    if !valid {
                        return Err(at(format!(
                            "face corner '{corner}' is not one of the {vertices} vertices defined so far"
                        )));
                    }
                }
            }
            _ => {}
        }
    }
    Ok(())
}

/// Parse OBJ text (see [`load_obj`]).
pub fn parse_obj(bytes: &[u8]) -> Result<TriMesh, String> {
    if let Ok(text) = std::str::from_utf8(bytes) {
        check_lines(text)?;
    }
    let options = tobj::LoadOptions {
        triangulate: true,
        ignore_points: true,
        ignore_lines: true,
        ..Default::default()
    };
    // tobj is not fuzzed against every input; a panic in it must still
    // come back as an error value.
    let loaded = std::panic::catch_unwind(|| {
        tobj::load_obj_buf(&mut &bytes[..], &options, |_| {
            Ok((Vec::new(), Default::default()))
        })
    })
    .map_err(|_| "the OBJ parser failed on this file".to_string())?;
    let (models, _materials) = loaded.map_err(|e| format!("invalid OBJ: {e}"))?;

    let mut mesh = TriMesh::default();
    for model in &models {
        let m = &model.mesh;
        let base = mesh.positions.len();
        if m.positions.len() % 3 != 0 || m.indices.len() % 3 != 0 {
            return Err(format!(
                "object '{}' has malformed position or face data",
                model.name
            ));
        }
        for p in m.positions.chunks_exact(3) {
            let p = Vec3::new(p[0], p[1], p[2]);
            if !p.is_finite() {
                return Err(format!(
                    "object '{}' has a non-finite vertex {p}",
                    model.name
                ));
            }
            mesh.positions.push(p);
        }
        let count = m.positions.len() / 3;
        for t in m.indices.chunks_exact(3) {
            if t.iter().any(|&i| i as usize >= count) {
                return Err(format!(
                    "object '{}' has a face index out of range",
                    model.name
                ));
            }
            let offset = |i: u32| {
                u32::try_from(base + i as usize).map_err(|_| "too many vertices".to_string())
            };
            mesh.indices
                .push([offset(t[0])?, offset(t[1])?, offset(t[2])?]);
        }
    }
    if mesh.indices.is_empty() {
        return Err("it contains no faces".into());
    }
    Ok(mesh)
}

#[cfg(test)]
mod tests {
    use super::*;

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
