//! A Mitsuba plugin's properties: the typed children of an element
//! (`<float>`, `<integer>`, `<boolean>`, `<string>`, `<rgb>`,
//! `<spectrum>`, `<point>`, `<vector>`, `<transform>`), `$name`
//! substitution in attribute values, and the transform operations
//! (`translate`, `rotate`, `scale`, `matrix`, `lookat`), composed as
//! Mitsuba does: each operation applies after the ones before it.

use super::{Doc, Result, MAX_EXPANDED_BYTES};
use crate::scene_file::SceneError;
use glam::{DMat3, DMat4, DVec3, DVec4, Vec3};
use roxmltree::Node;
use std::collections::HashMap;

/// A property's value as written.
#[derive(Clone, Debug)]
pub(super) enum Value {
    Float(f64),
    Integer(i64),
    Boolean(bool),
    Str(String),
    /// `<rgb>` and constant `<spectrum>`.
    Color(DVec3),
    /// `<point>` and `<vector>`.
    Vector(DVec3),
    Transform(DMat4),
}

impl Value {
    fn type_name(&self) -> &'static str {
        match self {
            Value::Float(_) => "float",
            Value::Integer(_) => "integer",
            Value::Boolean(_) => "boolean",
            Value::Str(_) => "string",
            Value::Color(_) => "rgb",
            Value::Vector(_) => "point",
            Value::Transform(_) => "transform",
        }
    }
}

/// The tags that are properties (the rest of a plugin's children are
/// nested plugins or references).
pub(super) const PROPERTY_TAGS: [&str; 9] = [
    "float",
    "integer",
    "boolean",
    "string",
    "rgb",
    "spectrum",
    "point",
    "vector",
    "transform",
];

impl<'a, 'i> Doc<'a, 'i> {
    /// Attribute `name` of `node` with `$name` parameters substituted, or
    /// `None` if the attribute is absent.
    pub(super) fn attr(&self, node: Node<'a, 'i>, name: &str) -> Result<Option<String>> {
        let Some(raw) = node.attribute(name) else {
            return Ok(None);
        };
        if !raw.contains('$') {
            return Ok(Some(raw.to_string()));
        }
        // The pieces first, so the length is known (and checked against
        // the budget) before anything is allocated: `<default>`s that
        // expand each other grow geometrically (a 1 KB file asked for
        // 17 GB).
        let mut pieces: Vec<&str> = Vec::new();
        let mut rest = raw;
        while let Some(i) = rest.find('$') {
            pieces.push(&rest[..i]);
            let after = &rest[i + 1..];
            let len = after
                .find(|c: char| !(c.is_ascii_alphanumeric() || c == '_'))
                .unwrap_or(after.len());
            let key = &after[..len];
            match self.defaults.get(key) {
                Some(v) if !key.is_empty() => pieces.push(v),
                _ => {
                    let mut known: Vec<&str> = self.defaults.keys().map(String::as_str).collect();
                    known.sort_unstable();
                    return Err(self.attr_error(
                        node,
                        name,
                        format!(
                            "'${key}' names no parameter (a <default name=\"{key}\" value=\"…\"/> defines one; defined: {})",
                            if known.is_empty() { "none".into() } else { known.join(", ") }
                        ),
                    ));
                }
            }
            rest = &after[len..];
        }
        pieces.push(rest);
        let len: u64 = pieces.iter().map(|p| p.len() as u64).sum();
        let used = self.expanded.get();
        if used + len > MAX_EXPANDED_BYTES {
            return Err(self.attr_error(
                node,
                name,
                format!(
                    "$parameter substitution would make {} bytes of attribute text in all (this value: {len}): beyond the limit of {} MiB",
                    used + len,
                    MAX_EXPANDED_BYTES >> 20
                ),
            ));
        }
        self.expanded.set(used + len);
        Ok(Some(pieces.concat()))
    }

    /// A required attribute.
    pub(super) fn need_attr(&self, node: Node<'a, 'i>, name: &str) -> Result<String> {
        self.attr(node, name)?.ok_or_else(|| {
            self.node_error(
                node,
                format!("<{}> needs a '{name}' attribute", node.tag_name().name()),
            )
        })
    }

    /// The numbers of attribute `name`, separated by commas or white space.
    pub(super) fn numbers(&self, node: Node<'a, 'i>, name: &str, text: &str) -> Result<Vec<f64>> {
        text.split(|c: char| c == ',' || c.is_whitespace())
            .filter(|s| !s.is_empty())
            .map(|s| match s.parse::<f64>() {
                Ok(v) if v.is_finite() => Ok(v),
                Ok(_) => Err(self.attr_error(node, name, format!("'{s}' is not a finite number"))),
                Err(_) => Err(self.attr_error(node, name, format!("'{s}' is not a number"))),
            })
            .collect()
    }

    fn number(&self, node: Node<'a, 'i>, name: &str) -> Result<Option<f64>> {
        let Some(text) = self.attr(node, name)? else {
            return Ok(None);
        };
        match self.numbers(node, name, &text)?[..] {
            [v] => Ok(Some(v)),
            _ => Err(self.attr_error(node, name, format!("'{text}' is not one number"))),
        }
    }

    /// Three numbers from `x`, `y`, `z` attributes (each defaulting to
    /// `default`) or from `value` ("x, y, z", or one number for all three
    /// where `one_for_all`).
    fn xyz(&self, node: Node<'a, 'i>, default: f64, one_for_all: bool) -> Result<DVec3> {
        if let Some(text) = self.attr(node, "value")? {
            return match self.numbers(node, "value", &text)?[..] {
                [x, y, z] => Ok(DVec3::new(x, y, z)),
                [v] if one_for_all => Ok(DVec3::splat(v)),
                _ => Err(self.attr_error(node, "value", format!("'{text}' is not three numbers"))),
            };
        }
        let c = |a| Ok::<_, SceneError>(self.number(node, a)?.unwrap_or(default));
        Ok(DVec3::new(c("x")?, c("y")?, c("z")?))
    }

    /// The value of a property element.
    fn value(&self, node: Node<'a, 'i>) -> Result<Value> {
        let tag = node.tag_name().name();
        let one = |v: Option<f64>| {
            v.ok_or_else(|| self.node_error(node, format!("<{tag}> needs a 'value'")))
        };
        Ok(match tag {
            "float" => Value::Float(one(self.number(node, "value")?)?),
            "integer" => {
                let text = self.need_attr(node, "value")?;
                Value::Integer(text.trim().parse().map_err(|_| {
                    self.attr_error(node, "value", format!("'{text}' is not an integer"))
                })?)
            }
            "boolean" => match self.need_attr(node, "value")?.trim() {
                "true" => Value::Boolean(true),
                "false" => Value::Boolean(false),
                other => {
                    return Err(self.attr_error(
                        node,
                        "value",
                        format!("'{other}' is not a boolean (true or false)"),
                    ))
                }
            },
            "string" => Value::Str(self.need_attr(node, "value")?),
            "rgb" => {
                let text = self.need_attr(node, "value")?;
                match self.numbers(node, "value", &text)?[..] {
                    [r, g, b] => Value::Color(DVec3::new(r, g, b)),
                    [v] => Value::Color(DVec3::splat(v)),
                    _ => {
                        return Err(self.attr_error(
                            node,
                            "value",
                            format!("'{text}' is not an RGB colour (three numbers, or one)"),
                        ))
                    }
                }
            }
            "spectrum" => {
                let text = self.need_attr(node, "value")?;
                match self.numbers(node, "value", &text) {
                    Ok(v) if v.len() == 1 => Value::Color(DVec3::splat(v[0])),
                    _ => {
                        return Err(self.attr_error(
                            node,
                            "value",
                            "only a constant <spectrum value=\"x\"> is supported (mdas renders in linear RGB: use <rgb>)",
                        ))
                    }
                }
            }
            "point" | "vector" => Value::Vector(self.xyz(node, 0.0, false)?),
            "transform" => Value::Transform(self.transform(node)?),
            _ => unreachable!("PROPERTY_TAGS lists the tags value() reads"),
        })
    }

    /// A `<transform>`'s operations composed: each one applies after the
    /// ones before it (M = op · M).
    fn transform(&self, node: Node<'a, 'i>) -> Result<DMat4> {
        let mut m = DMat4::IDENTITY;
        for op in node.children().filter(|c| c.is_element()) {
            let tag = op.tag_name().name();
            let step = match tag {
                "translate" => DMat4::from_translation(self.xyz(op, 0.0, false)?),
                "scale" => {
                    let s = self.xyz(op, 1.0, true)?;
                    DMat4::from_scale(s)
                }
                "rotate" => {
                    let axis = self.xyz(op, 0.0, false)?;
                    let angle = self.number(op, "angle")?.ok_or_else(|| {
                        self.node_error(op, "<rotate> needs an 'angle' (degrees)")
                    })?;
                    let Some(axis) = axis.try_normalize() else {
                        return Err(self.node_error(
                            op,
                            "<rotate> needs a non-zero axis (x, y, z attributes or value)",
                        ));
                    };
                    DMat4::from_mat3(DMat3::from_axis_angle(axis, angle.to_radians()))
                }
                "matrix" => {
                    let text = self.need_attr(op, "value")?;
                    let v = self.numbers(op, "value", &text)?;
                    match v.len() {
                        16 => {
                            let row = |r: usize| DVec4::new(v[4 * r], v[4 * r + 1], v[4 * r + 2], v[4 * r + 3]);
                            if row(3) != DVec4::W {
                                return Err(self.attr_error(
                                    op,
                                    "value",
                                    "the matrix's last row must be 0 0 0 1 (projective transforms are not supported)",
                                ));
                            }
                            DMat4::from_cols(row(0), row(1), row(2), row(3)).transpose()
                        }
                        9 => DMat4::from_mat3(
                            DMat3::from_cols_slice(&v).transpose(),
                        ),
                        n => {
                            return Err(self.attr_error(
                                op,
                                "value",
                                format!("a matrix has 16 (or 9) numbers, row by row; found {n}"),
                            ))
                        }
                    }
                }
                "lookat" => self.lookat(op)?,
                other => {
                    return Err(self.node_error(
                        op,
                        format!("unknown transform operation <{other}> (supported: translate, rotate, scale, matrix, lookat)"),
                    ))
                }
            };
            m = step * m;
        }
        Ok(m)
    }

    /// Mitsuba's look-at frame: columns left = normalize(up × dir),
    /// up' = dir × left, dir, and the origin.
    fn lookat(&self, op: Node<'a, 'i>) -> Result<DMat4> {
        let point = |name: &str| -> Result<DVec3> {
            let text = self.need_attr(op, name)?;
            match self.numbers(op, name, &text)?[..] {
                [x, y, z] => Ok(DVec3::new(x, y, z)),
                _ => Err(self.attr_error(op, name, format!("'{text}' is not three numbers"))),
            }
        };
        let (origin, target, up) = (point("origin")?, point("target")?, point("up")?);
        let Some(dir) = (target - origin).try_normalize() else {
            return Err(self.attr_error(op, "target", "the look-at target equals its origin"));
        };
        let Some(left) = up.cross(dir).try_normalize() else {
            return Err(self.attr_error(
                op,
                "up",
                "the look-at 'up' is parallel to the view direction (or zero)",
            ));
        };
        let new_up = dir.cross(left);
        Ok(DMat4::from_cols(
            left.extend(0.0),
            new_up.extend(0.0),
            dir.extend(0.0),
            origin.extend(1.0),
        ))
    }
}

/// A plugin's properties, taken one by one by its reader; [`Props::finish`]
/// refuses any left over, so nothing in a file is silently ignored.
pub(super) struct Props<'a, 'i> {
    /// (name, element, value, taken)
    items: Vec<(String, Node<'a, 'i>, Value, bool)>,
}

impl<'a, 'i> Props<'a, 'i> {
    /// The property children of `node` (duplicate names are an error).
    pub(super) fn read(doc: &Doc<'a, 'i>, node: Node<'a, 'i>) -> Result<Props<'a, 'i>> {
        let mut items: Vec<(String, Node, Value, bool)> = Vec::new();
        let mut seen: HashMap<String, Node> = HashMap::new();
        for child in node.children().filter(|c| c.is_element()) {
            if !PROPERTY_TAGS.contains(&child.tag_name().name()) {
                continue;
            }
            let name = doc.need_attr(child, "name")?;
            if let Some(first) = seen.insert(name.clone(), child) {
                let p = doc.position(first);
                return Err(doc.attr_error(
                    child,
                    "name",
                    format!(
                        "property '{name}' is given twice (first at line {}, column {})",
                        p.0, p.1
                    ),
                ));
            }
            let value = doc.value(child)?;
            items.push((name, child, value, false));
        }
        Ok(Props { items })
    }

    fn take(&mut self, name: &str) -> Option<(Node<'a, 'i>, Value)> {
        let item = self.items.iter_mut().find(|i| i.0 == name && !i.3)?;
        item.3 = true;
        Some((item.1, item.2.clone()))
    }

    /// Property `name` as the `want` that `read` takes from its value
    /// (`None` from `read`: a value of another type, an error).
    fn typed<T>(
        &mut self,
        doc: &Doc<'a, 'i>,
        name: &str,
        want: &str,
        read: impl Fn(Value) -> Option<T>,
    ) -> Result<Option<(T, Node<'a, 'i>)>> {
        let Some((node, value)) = self.take(name) else {
            return Ok(None);
        };
        let type_name = value.type_name();
        match read(value) {
            Some(v) => Ok(Some((v, node))),
            None => Err(doc.node_error(
                node,
                format!("property '{name}' is a {type_name}, expected {want}"),
            )),
        }
    }

    /// A number (`<float>` or `<integer>`).
    pub(super) fn float(
        &mut self,
        doc: &Doc<'a, 'i>,
        name: &str,
    ) -> Result<Option<(f64, Node<'a, 'i>)>> {
        self.typed(doc, name, "a <float>", |v| match v {
            Value::Float(x) => Some(x),
            Value::Integer(i) => Some(i as f64),
            _ => None,
        })
    }

    pub(super) fn integer(
        &mut self,
        doc: &Doc<'a, 'i>,
        name: &str,
    ) -> Result<Option<(i64, Node<'a, 'i>)>> {
        self.typed(doc, name, "an <integer>", |v| match v {
            Value::Integer(i) => Some(i),
            _ => None,
        })
    }

    pub(super) fn boolean(&mut self, doc: &Doc<'a, 'i>, name: &str) -> Result<Option<bool>> {
        let b = self.typed(doc, name, "a <boolean>", |v| match v {
            Value::Boolean(b) => Some(b),
            _ => None,
        })?;
        Ok(b.map(|b| b.0))
    }

    pub(super) fn string(
        &mut self,
        doc: &Doc<'a, 'i>,
        name: &str,
    ) -> Result<Option<(String, Node<'a, 'i>)>> {
        self.typed(doc, name, "a <string>", |v| match v {
            Value::Str(s) => Some(s),
            _ => None,
        })
    }

    /// A colour: `<rgb>`, a constant `<spectrum>`, or a `<float>` (grey).
    pub(super) fn color(
        &mut self,
        doc: &Doc<'a, 'i>,
        name: &str,
    ) -> Result<Option<(DVec3, Node<'a, 'i>)>> {
        self.typed(doc, name, "an <rgb>", |v| match v {
            Value::Color(c) => Some(c),
            Value::Float(x) => Some(DVec3::splat(x)),
            _ => None,
        })
    }

    pub(super) fn vector(
        &mut self,
        doc: &Doc<'a, 'i>,
        name: &str,
    ) -> Result<Option<(DVec3, Node<'a, 'i>)>> {
        self.typed(doc, name, "a <point> or <vector>", |v| match v {
            Value::Vector(p) => Some(p),
            _ => None,
        })
    }

    pub(super) fn transform(
        &mut self,
        doc: &Doc<'a, 'i>,
        name: &str,
    ) -> Result<Option<(DMat4, Node<'a, 'i>)>> {
        self.typed(doc, name, "a <transform>", |v| match v {
            Value::Transform(m) => Some(m),
            _ => None,
        })
    }

    /// Refuses the properties nobody took: `what` names the plugin
    /// ("sensor 'perspective'"), `supported` its properties.
    pub(super) fn finish(self, doc: &Doc<'a, 'i>, what: &str, supported: &[&str]) -> Result<()> {
        match self.items.iter().find(|i| !i.3) {
            None => Ok(()),
            Some((name, node, ..)) => Err(doc.attr_error(
                *node,
                "name",
                format!(
                    "{what} has no property '{name}' that mdas supports (supported: {})",
                    if supported.is_empty() {
                        "none".into()
                    } else {
                        supported.join(", ")
                    }
                ),
            )),
        }
    }
}

/// f64 to f32 for a scene value.
pub(super) fn f32v(v: DVec3) -> Vec3 {
    v.as_vec3()
}

/// The element children of a plugin that are not properties.
pub(super) fn plugin_children<'a, 'i>(
    _d: &Doc<'a, 'i>,
    node: Node<'a, 'i>,
) -> Result<Vec<Node<'a, 'i>>> {
    Ok(node
        .children()
        .filter(|c| c.is_element() && !PROPERTY_TAGS.contains(&c.tag_name().name()))
        .collect())
}

/// Refuses a nested object where a plugin takes none (a texture for an
/// emitter's radiance, say): it would otherwise be ignored.
pub(super) fn no_nested(d: &Doc, node: Node) -> Result<()> {
    match plugin_children(d, node)?.first() {
        None => Ok(()),
        Some(c) if c.tag_name().name() == "texture" => Err(unsupported_texture(d, *c)),
        Some(c) => Err(d.node_error(
            *c,
            format!(
                "<{}> in a <{}> that takes no nested objects",
                c.tag_name().name(),
                node.tag_name().name()
            ),
        )),
    }
}

/// The error for a texture mdas does not read.
pub(super) fn unsupported_texture(d: &Doc, node: Node) -> SceneError {
    let kind = node.attribute("type").unwrap_or("?");
    d.node_error(
        node,
        format!("unsupported texture '{kind}' here (mdas reads one texture: a 'checkerboard' as a diffuse BSDF's reflectance)"),
    )
}
