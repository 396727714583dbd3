//! `<bsdf>`: Mitsuba's `diffuse` (one-sided) and `twosided`, and the one
//! texture mdas reads, a `checkerboard` reflectance in texture space.

use super::props::{f32v, no_nested, plugin_children, unsupported_texture, Props};
use super::{Doc, Result};
use crate::scene::UvChecker;
use glam::{DMat4, DVec3, Vec3};
use roxmltree::Node;

/// A BSDF of the subset: Lambertian, one- or two-sided.
#[derive(Clone, Copy, Debug)]
pub(super) struct Bsdf {
    /// The reflectance (a checkerboard's `color0`).
    pub(super) albedo: Vec3,
    pub(super) one_sided: bool,
    pub(super) uv_checker: Option<UvChecker>,
}

/// Mitsuba's BSDF of a shape without one: `diffuse`, reflectance 0.5.
pub(super) const DEFAULT_BSDF: Bsdf = Bsdf {
    albedo: Vec3::splat(0.5),
    one_sided: true,
    uv_checker: None,
};

/// `<bsdf type="diffuse">` (one-sided, as Mitsuba's) or a `twosided`
/// wrapping one.
pub(super) fn bsdf<'a, 'i>(d: &Doc<'a, 'i>, node: Node<'a, 'i>) -> Result<Bsdf> {
    let kind = d.need_attr(node, "type")?;
    match kind.as_str() {
        "diffuse" => {
            let nested = plugin_children(d, node)?;
            let texture = match nested[..] {
                [] => None,
                [t] if t.tag_name().name() == "texture" => Some(t),
                _ => return Err(d.node_error(nested[0], "a diffuse BSDF takes one <texture> at most")),
            };
            let mut p = Props::read(d, node)?;
            let reflectance = |c: DVec3, n: Node<'a, 'i>| {
                if c.min_element() >= 0.0 && c.max_element() <= 1.0 {
                    Ok(c)
                } else {
                    Err(d.attr_error(n, "value", format!("reflectance must be in [0, 1] per channel, found {c}")))
                }
            };
            let (albedo, uv_checker) = match (p.color(d, "reflectance")?, texture) {
                (Some(_), Some(t)) => return Err(d.node_error(t, "the reflectance is given twice (a value and a texture)")),
                (None, None) => (DVec3::splat(0.5), None),
                (Some((c, n)), None) => (reflectance(c, n)?, None),
                (None, Some(t)) => {
                    if d.attr(t, "name")?.as_deref() != Some("reflectance") {
                        return Err(d.attr_error(t, "name", "a diffuse BSDF's texture must be its 'reflectance'"));
                    }
                    if d.need_attr(t, "type")? != "checkerboard" {
                        return Err(unsupported_texture(d, t));
                    }
                    no_nested(d, t)?;
                    let mut tp = Props::read(d, t)?;
                    let mut color = |key: &str, default: f64| -> Result<DVec3> {
                        match tp.color(d, key)? {
                            None => Ok(DVec3::splat(default)),
                            Some((c, n)) => reflectance(c, n),
                        }
                    };
                    // Mitsuba's defaults: color0 0.4, color1 0.2.
                    let (c0, c1) = (color("color0", 0.4)?, color("color1", 0.2)?);
                    let m = tp.transform(d, "to_uv")?.map_or(DMat4::IDENTITY, |m| m.0);
                    tp.finish(d, "texture 'checkerboard'", &["color0", "color1", "to_uv"])?;
                    // (u, v) as the point (u, v, 0): the 2×3 affine part.
                    let row = |r: usize| [m.col(0)[r] as f32, m.col(1)[r] as f32, m.col(3)[r] as f32];
                    (
                        c0,
                        Some(UvChecker {
                            albedo2: f32v(c1),
                            to_uv: [row(0), row(1)],
                        }),
                    )
                }
            };
            p.finish(d, "bsdf 'diffuse'", &["reflectance"])?;
            Ok(Bsdf {
                albedo: f32v(albedo),
                one_sided: true,
                uv_checker,
            })
        }
        "twosided" => {
            // A twosided inside a twosided is two-sided still. The wrappers
            // are walked in a loop, not by recursion: 100 000 nested ones
            // overflowed the stack.
            let mut wrapper = node;
            loop {
                Props::read(d, wrapper)?.finish(d, "bsdf 'twosided'", &[])?;
                let inner = plugin_children(d, wrapper)?;
                let b = match inner[..] {
                    [b] if b.tag_name().name() == "bsdf" => b,
                    _ => return Err(d.node_error(wrapper, "a twosided BSDF wraps exactly one <bsdf>")),
                };
                if d.need_attr(b, "type")? != "twosided" {
                    return Ok(Bsdf {
                        one_sided: false,
                        ..bsdf(d, b)?
                    });
                }
                wrapper = b;
            }
        }
        other => Err(d.attr_error(
            node,
            "type",
            format!("unsupported BSDF '{other}' (supported: diffuse, twosided; mdas's materials are Lambertian)"),
        )),
    }
}
