//! `<sensor>` with its `<film>` and `<sampler>`: Mitsuba's camera frame
//! (+z forward, +y up, +x to the image's left) and field-of-view axes
//! turned into mdas's camera (docs/conventions.md "Camera").

use super::plugins::{Builder, Sensor};
use super::props::{f32v, no_nested, plugin_children, Props};
use super::{Doc, Result};
use crate::film::Film;
use crate::scene::Camera;
use crate::scene_file::{MAX_COORDINATE, MAX_FILM_PIXELS, MAX_FILM_SIDE};
use glam::{DMat4, DVec3};
use roxmltree::Node;

/// Mitsuba's default film size.
const DEFAULT_FILM: (i64, i64) = (768, 576);

impl Builder {
    pub(super) fn sensor<'a, 'i>(&mut self, d: &Doc<'a, 'i>, node: Node<'a, 'i>) -> Result<Sensor> {
        let kind = d.need_attr(node, "type")?;
        let thin_lens = match kind.as_str() {
            "perspective" => false,
            "thinlens" => true,
            other => {
                return Err(d.attr_error(
                    node,
                    "type",
                    format!("unsupported sensor '{other}' (supported: perspective, thinlens)"),
                ))
            }
        };
        let mut film = None;
        let mut spp = None;
        for child in plugin_children(d, node)? {
            match child.tag_name().name() {
                "film" => film = Some(self.film(d, child)?),
                "sampler" => spp = Some(sampler(d, child)?),
                other => {
                    return Err(d.node_error(
                        child,
                        format!("<{other}> in a sensor (supported: film, sampler)"),
                    ))
                }
            }
        }
        let film = match film {
            Some(f) => f,
            None => Film {
                width: DEFAULT_FILM.0 as u32,
                height: DEFAULT_FILM.1 as u32,
            },
        };
        let mut p = Props::read(d, node)?;
        let what = format!("sensor '{kind}'");
        let fov_at = node;
        let (fov, fov_node) = p.float(d, "fov")?.ok_or_else(|| {
            d.node_error(
                fov_at,
                format!("{what} needs 'fov' (degrees; focal_length is not supported)"),
            )
        })?;
        if !(fov > 0.0 && fov < 180.0) {
            return Err(d.node_error(
                fov_node,
                format!("fov must be in (0, 180) degrees, found {fov}"),
            ));
        }
        let (w, h) = (film.width as f64, film.height as f64);
        let axis = p.string(d, "fov_axis")?;
        let tan_half = (fov.to_radians() / 2.0).tan();
        let tan_half_y = match axis.as_ref().map_or("x", |a| a.0.as_str()) {
            "x" => tan_half * h / w,
            "y" => tan_half,
            "diagonal" => tan_half * h / (w * w + h * h).sqrt(),
            "smaller" if w < h => tan_half * h / w,
            "smaller" => tan_half,
            "larger" if w > h => tan_half * h / w,
            "larger" => tan_half,
            other => {
                let n = axis.as_ref().map(|a| a.1).unwrap_or(node);
                return Err(d.attr_error(
                    n,
                    "value",
                    format!("fov_axis '{other}' is not one of x, y, diagonal, smaller, larger"),
                ));
            }
        };
        let fov_y = (2.0 * tan_half_y.atan()).to_degrees() as f32;
        // Checked as the f32 the GPU uses: fov 179.99999999 passes the
        // check above in f64 and is 180 in f32, an upside-down image.
        if !crate::scene::fov_y_is_valid(fov_y) {
            return Err(d.node_error(
                fov_node,
                format!(
                    "fov {fov:?} gives a vertical field of view of {fov_y:?} degrees as the f32 \
                     the GPU uses; it must be in (0, 180)"
                ),
            ));
        }

        let m = p.transform(d, "to_world")?;
        let (position, forward, up) = match &m {
            None => (DVec3::ZERO, DVec3::Z, DVec3::Y),
            Some((m, n)) => rigid_frame(d, *n, m)?,
        };
        for clip in ["near_clip", "far_clip"] {
            if p.float(d, clip)?.is_some() {
                self.warnings.push(format!(
                    "{}: the sensor's {clip} has no effect (mdas has no clipping planes)",
                    d.file.display()
                ));
            }
        }
        let shutter_open = p.float(d, "shutter_open")?.map_or(0.0, |v| v.0);
        let shutter_close = p.float(d, "shutter_close")?.map_or(1.0, |v| v.0);
        if shutter_close <= shutter_open || shutter_open.abs().max(shutter_close.abs()) > 1e6 {
            return Err(d.node_error(
                node,
                format!("the shutter ({shutter_open}, {shutter_close}) must open before it closes, within ±10^6"),
            ));
        }
        let (aperture_radius, focus_distance) = if thin_lens {
            let mut need = |key: &str| -> Result<f64> {
                let (v, n) = p.float(d, key)?.ok_or_else(|| {
                    d.node_error(node, format!("a thinlens sensor needs '{key}'"))
                })?;
                if !(v > 0.0 && v <= MAX_COORDINATE as f64) {
                    return Err(d.attr_error(
                        n,
                        "value",
                        format!("{key} must be in (0, 10^9], found {v}"),
                    ));
                }
                Ok(v)
            };
            (need("aperture_radius")?, need("focus_distance")?)
        } else {
            (0.0, 1.0)
        };
        const PERSPECTIVE: [&str; 7] = [
            "fov",
            "fov_axis",
            "to_world",
            "near_clip",
            "far_clip",
            "shutter_open",
            "shutter_close",
        ];
        let mut supported = PERSPECTIVE.to_vec();
        if thin_lens {
            supported.extend(["aperture_radius", "focus_distance"]);
        }
        p.finish(d, &what, &supported)?;
        if position.abs().max_element() > MAX_COORDINATE as f64 {
            return Err(d.node_error(node, "the camera lies beyond ±10^9"));
        }
        let pos = d.position(node);
        Ok(Sensor {
            camera: Camera {
                position: f32v(position),
                look_at: f32v(position + forward),
                up: f32v(up),
                fov_y,
                aperture_radius: aperture_radius as f32,
                focus_distance: focus_distance as f32,
                shutter_open: shutter_open as f32,
                shutter_close: shutter_close as f32,
            },
            film,
            spp: spp.flatten(),
            thin_lens,
            at: (d.file.to_path_buf(), pos.0, pos.1),
        })
    }

    fn film<'a, 'i>(&mut self, d: &Doc<'a, 'i>, node: Node<'a, 'i>) -> Result<Film> {
        let kind = d.need_attr(node, "type")?;
        if kind != "hdrfilm" {
            return Err(d.attr_error(
                node,
                "type",
                format!("unsupported film '{kind}' (supported: hdrfilm)"),
            ));
        }
        let mut box_filter = false;
        for child in plugin_children(d, node)? {
            if child.tag_name().name() != "rfilter" {
                return Err(d.node_error(child, "only an <rfilter> may be nested in a film"));
            }
            no_nested(d, child)?;
            box_filter = d.need_attr(child, "type")? == "box";
            if box_filter {
                Props::read(d, child)?.finish(d, "rfilter 'box'", &[])?;
            }
            // Another filter's properties are not read: the filter is
            // replaced by the box (with the warning below).
        }
        if !box_filter {
            self.warnings.push(format!(
                "{}: mdas's pixels are box-filtered (the mean over the pixel, docs/conventions.md); this film's reconstruction filter is not a box (Mitsuba's default is a Gaussian), so edges differ from Mitsuba's and means agree",
                d.file.display()
            ));
        }
        let mut p = Props::read(d, node)?;
        let mut side = |key: &str, default: i64| -> Result<i64> {
            match p.integer(d, key)? {
                None => Ok(default),
                Some((v, n)) if v <= 0 || v > MAX_FILM_SIDE => Err(d.attr_error(
                    n,
                    "value",
                    format!("film {key} must be in 1..={MAX_FILM_SIDE}, found {v}"),
                )),
                Some((v, _)) => Ok(v),
            }
        };
        let (w, h) = (
            side("width", DEFAULT_FILM.0)?,
            side("height", DEFAULT_FILM.1)?,
        );
        if w * h > MAX_FILM_PIXELS {
            return Err(d.node_error(
                node,
                format!("film {w}×{h} is absurdly large (at most 2^26 pixels)"),
            ));
        }
        // Formats of the written file: mdas writes RGB EXR and PNG.
        p.string(d, "pixel_format")?;
        p.string(d, "component_format")?;
        p.boolean(d, "sample_border")?;
        p.finish(
            d,
            "film 'hdrfilm'",
            &[
                "width",
                "height",
                "pixel_format",
                "component_format",
                "sample_border",
            ],
        )?;
        Ok(Film {
            width: w as u32,
            height: h as u32,
        })
    }
}

/// Position, unit forward and unit up of a sensor's `to_world`, which must
/// be rigid (a rotation, a translation and a uniform scale): Mitsuba's
/// camera looks along +z with +y up and +x to the left of the image.
fn rigid_frame(d: &Doc, n: Node, m: &DMat4) -> Result<(DVec3, DVec3, DVec3)> {
    let left = m.transform_vector3(DVec3::X);
    let up = m.transform_vector3(DVec3::Y);
    let forward = m.transform_vector3(DVec3::Z);
    let s = forward.length();
    let rigid = s > 0.0
        && [left, up]
            .iter()
            .all(|v| (v.length() - s).abs() <= 1e-4 * s)
        && left.dot(up).abs() <= 1e-4 * s * s
        && left.dot(forward).abs() <= 1e-4 * s * s
        && up.dot(forward).abs() <= 1e-4 * s * s
        && (up.cross(forward) / (s * s) - left / s).length() <= 1e-3;
    if !rigid {
        return Err(d.node_error(
            n,
            "the sensor's to_world must be rigid (lookat, rotate, translate, a uniform scale): mirrored, sheared or unevenly scaled cameras are not supported",
        ));
    }
    Ok((m.transform_point3(DVec3::ZERO), forward / s, up / s))
}

/// `<sampler>`: its `sample_count` (any sampler type: mdas compares its own
/// sampling methods).
fn sampler<'a, 'i>(d: &Doc<'a, 'i>, node: Node<'a, 'i>) -> Result<Option<i64>> {
    const TYPES: [&str; 5] = [
        "independent",
        "stratified",
        "multijitter",
        "orthogonal",
        "ldsampler",
    ];
    let kind = d.need_attr(node, "type")?;
    no_nested(d, node)?;
    if !TYPES.contains(&kind.as_str()) {
        return Err(d.attr_error(node, "type", format!("unknown sampler '{kind}'")));
    }
    let mut p = Props::read(d, node)?;
    let spp = match p.integer(d, "sample_count")? {
        None => None,
        Some((v, _)) if (1..=1 << 24).contains(&v) => Some(v),
        Some((v, n)) => {
            return Err(d.attr_error(
                n,
                "value",
                format!("sample_count must be in 1..=2^24, found {v}"),
            ))
        }
    };
    p.integer(d, "seed")?;
    p.boolean(d, "jitter")?;
    p.finish(
        d,
        &format!("sampler '{kind}'"),
        &["sample_count", "seed", "jitter"],
    )?;
    Ok(spp)
}
