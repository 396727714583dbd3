//! Mitsuba 3 scene files (XML): the subset a diffuse direct-lighting,
//! path-tracing or thin-lens scene uses, read into the same [`SceneFile`]
//! as a TOML scene. The reference is `docs/scene-format.md` ("Mitsuba 3
//! scenes"); in short:
//!
//! ```text
//! <scene version="3.x">   <default name value/>, $name in any attribute,
//!                         <include filename/> (relative to the file)
//! <sensor type="perspective"|"thinlens">  fov, fov_axis, to_world (rigid),
//!     near_clip, far_clip (no effect), shutter_open, shutter_close,
//!     aperture_radius, focus_distance; <film type="hdrfilm"> width,
//!     height, <rfilter>; <sampler> sample_count (the MDAS budget)
//! <bsdf type="diffuse"|"twosided">  reflectance; id, <ref id/>
//! <shape type="rectangle"|"cube"|"sphere"|"disk"|"obj"|"ply">  to_world,
//!     flip_normals, face_normals, filename, center, radius; a nested
//!     <bsdf> or <ref>, and <emitter type="area"> radiance
//! <emitter type="point"|"directional">  position / direction / to_world,
//!     intensity / irradiance
//! <integrator type="direct"|"path">  max_depth (path: 2..)
//! ```
//!
//! Anything else — another plugin, a texture, an unknown property — is an
//! error naming it, its line and column, and what is supported; the
//! conventions (camera frame, fov axis, sidedness, units) are Mitsuba's.
//! Where mdas cannot render what the file asks (an environment emitter, a
//! thin lens with area lights), the error says so rather than render
//! something else.

mod bsdf;
mod plugins;
mod props;
mod sensor;
#[cfg(test)]
mod tests;

use super::{SceneError, SceneFile};
use roxmltree::{Document, Node};
use std::cell::Cell;
use std::collections::HashMap;
use std::path::{Path, PathBuf};

pub(super) type Result<T> = std::result::Result<T, SceneError>;

/// The most nested `<include>`s (a cycle is refused before this).
pub const MAX_INCLUDE_DEPTH: usize = 16;
/// The most documents one scene reads, itself and its includes together:
/// each file including the next a thousand times ran without end.
pub const MAX_DOCUMENTS: usize = 256;
/// The most bytes one scene's documents hold together (each is also
/// within [`super::MAX_SCENE_BYTES`]).
pub const MAX_DOCUMENT_BYTES: u64 = super::MAX_SCENE_BYTES;
/// The most attribute text `$parameter` substitution makes in one scene,
/// checked before the text is made.
pub const MAX_EXPANDED_BYTES: u64 = super::MAX_SCENE_BYTES;

/// What a scene has used of the budgets above, over all its documents.
#[derive(Default)]
pub(super) struct Budget {
    /// Attribute bytes made by substitution.
    pub(super) expanded: Cell<u64>,
    /// Documents read, and their bytes.
    documents: Cell<usize>,
    bytes: Cell<u64>,
}

/// One parsed XML document and the `<default>` parameters in force.
pub(super) struct Doc<'a, 'i> {
    pub(super) file: &'a Path,
    pub(super) doc: &'a Document<'i>,
    pub(super) defaults: &'a HashMap<String, String>,
    /// Attribute bytes made by `$parameter` substitution so far (all
    /// documents), against [`MAX_EXPANDED_BYTES`].
    pub(super) expanded: &'a Cell<u64>,
}

impl<'a, 'i> Doc<'a, 'i> {
    /// (line, column), 1-based, of a node's start.
    pub(super) fn position(&self, node: Node) -> (usize, usize) {
        let p = self.doc.text_pos_at(node.range().start);
        (p.row as usize, p.col as usize)
    }

    fn at(&self, pos: usize, message: impl Into<String>) -> SceneError {
        let p = self.doc.text_pos_at(pos);
        SceneError::Invalid {
            file: self.file.to_path_buf(),
            line: p.row as usize,
            column: p.col as usize,
            message: message.into(),
        }
    }

    /// An error at an element.
    pub(super) fn node_error(&self, node: Node, message: impl Into<String>) -> SceneError {
        self.at(node.range().start, message)
    }

    /// An error at an attribute's value (at the element without it).
    pub(super) fn attr_error(
        &self,
        node: Node,
        attr: &str,
        message: impl Into<String>,
    ) -> SceneError {
        match node.attribute_node(attr) {
            Some(a) => self.at(a.range_value().start, message),
            None => self.node_error(node, message),
        }
    }
}

/// Load a Mitsuba scene from its text; `file` names it in messages and
/// resolves relative paths.
pub(super) fn parse(text: &str, file: &Path) -> Result<SceneFile> {
    parse_within(text, file, crate::scene::MAX_SCENE_TRIANGLES)
}

/// [`parse`] with a scene of at most `max_triangles` triangles (tests
/// reach the budget with a few shapes).
fn parse_within(text: &str, file: &Path, max_triangles: u64) -> Result<SceneFile> {
    let mut builder = plugins::Builder::default();
    builder.triangles_left = max_triangles;
    let mut stack: Vec<PathBuf> = file.canonicalize().into_iter().collect();
    let budget = Budget {
        documents: Cell::new(1),
        bytes: Cell::new(text.len() as u64),
        ..Budget::default()
    };
    read_document(
        text,
        file,
        &HashMap::new(),
        &mut builder,
        (&mut stack, &budget),
        true,
    )?;
    builder.finish(file)
}

fn xml_error(file: &Path, e: &roxmltree::Error) -> SceneError {
    let p = e.pos();
    SceneError::Invalid {
        file: file.to_path_buf(),
        line: p.row as usize,
        column: p.col as usize,
        message: format!("XML: {e}"),
    }
}

/// Reads one document's `<scene>` into `builder`: its `<default>`s first
/// (they hold for the whole document and the files it includes), then
/// every other element in order.
fn read_document(
    text: &str,
    file: &Path,
    inherited: &HashMap<String, String>,
    builder: &mut plugins::Builder,
    (stack, budget): (&mut Vec<PathBuf>, &Budget),
    top: bool,
) -> Result<()> {
    let options = roxmltree::ParsingOptions {
        allow_dtd: false,
        nodes_limit: 1 << 22,
        ..Default::default()
    };
    let doc = Document::parse_with_options(text, options).map_err(|e| xml_error(file, &e))?;
    let root = doc.root_element();
    let mut defaults = inherited.clone();
    {
        let d = Doc {
            file,
            doc: &doc,
            defaults: &defaults,
            expanded: &budget.expanded,
        };
        if root.tag_name().name() != "scene" {
            return Err(d.node_error(
                root,
                format!(
                    "the root element is <{}>, not <scene>",
                    root.tag_name().name()
                ),
            ));
        }
        if top {
            builder.version = d.attr(root, "version")?;
        }
    }
    for node in root
        .children()
        .filter(|c| c.is_element() && c.has_tag_name("default"))
    {
        let d = Doc {
            file,
            doc: &doc,
            defaults: &defaults,
            expanded: &budget.expanded,
        };
        let name = d.need_attr(node, "name")?;
        let value = d.need_attr(node, "value")?;
        // The first definition holds, as Mitsuba's (a value given by the
        // including file or the command line wins over a default).
        defaults.entry(name).or_insert(value);
    }
    let d = Doc {
        file,
        doc: &doc,
        defaults: &defaults,
        expanded: &budget.expanded,
    };
    for node in root.children().filter(|c| c.is_element()) {
        match node.tag_name().name() {
            "default" => {}
            "include" => {
                let name = d.need_attr(node, "filename")?;
                let path = file.parent().unwrap_or(Path::new("")).join(&name);
                if stack.len() >= MAX_INCLUDE_DEPTH {
                    return Err(d.attr_error(
                        node,
                        "filename",
                        format!("includes nest deeper than {MAX_INCLUDE_DEPTH} files"),
                    ));
                }
                let canonical = path.canonicalize().map_err(|e| {
                    d.attr_error(
                        node,
                        "filename",
                        format!("cannot read '{}': {e}", path.display()),
                    )
                })?;
                if stack.contains(&canonical) {
                    let chain: Vec<String> = stack
                        .iter()
                        .chain([&canonical])
                        .map(|p| {
                            p.file_name()
                                .unwrap_or_default()
                                .to_string_lossy()
                                .into_owned()
                        })
                        .collect();
                    return Err(d.attr_error(
                        node,
                        "filename",
                        format!("an include cycle: {}", chain.join(" → ")),
                    ));
                }
                if budget.documents.get() >= MAX_DOCUMENTS {
                    return Err(d.attr_error(
                        node,
                        "filename",
                        format!("this include would make the scene read more than {MAX_DOCUMENTS} documents (the file and its includes, each include counted every time it is read)"),
                    ));
                }
                let too_many_bytes = |total: u64| {
                    d.attr_error(
                        node,
                        "filename",
                        format!(
                            "this include brings the scene's documents to {total} bytes: beyond the limit of {} MiB for a file and its includes together",
                            MAX_DOCUMENT_BYTES >> 20
                        ),
                    )
                };
                let size = std::fs::metadata(&path).map_or(0, |m| m.len());
                if budget.bytes.get() + size > MAX_DOCUMENT_BYTES {
                    return Err(too_many_bytes(budget.bytes.get() + size));
                }
                let bytes =
                    crate::scene::read_input(&path, super::MAX_SCENE_BYTES).map_err(|e| {
                        d.attr_error(
                            node,
                            "filename",
                            format!("cannot read '{}': {e}", path.display()),
                        )
                    })?;
                // (The file may have grown since its size was read.)
                let total = budget.bytes.get() + bytes.len() as u64;
                if total > MAX_DOCUMENT_BYTES {
                    return Err(too_many_bytes(total));
                }
                budget.bytes.set(total);
                budget.documents.set(budget.documents.get() + 1);
                let included = String::from_utf8(bytes).map_err(|_| {
                    d.attr_error(
                        node,
                        "filename",
                        format!("'{}' is not UTF-8 text", path.display()),
                    )
                })?;
                builder.inputs.push(path.clone());
                stack.push(canonical);
                read_document(&included, &path, &defaults, builder, (stack, budget), false)?;
                stack.pop();
            }
            _ => builder.top_level(&d, node)?,
        }
    }
    Ok(())
}
