//! The parse context (file text and name, for positions) and the value
//! checks shared by every table.

use super::values::*;
use super::SceneError;
use super::MAX_SCENE_TRIANGLES;
use glam::Vec3;
use std::ops::{Range, RangeInclusive};
use std::path::Path;

// Validation and construction.

pub(super) struct Ctx<'a> {
    pub(super) text: &'a str,
    pub(super) file: &'a Path,
    /// Triangles of the shapes checked so far, against
    /// [`MAX_SCENE_TRIANGLES`] ([`Ctx::count_check`]).
    pub(super) triangles: std::cell::Cell<u64>,
}

pub(super) type Result<T, E = SceneError> = std::result::Result<T, E>;

pub(super) fn quoted_list(items: &[&str]) -> String {
    items
        .iter()
        .map(|s| format!("'{s}'"))
        .collect::<Vec<_>>()
        .join(", ")
}

impl Ctx<'_> {
    /// 1-based line and column (in characters) of a byte offset.
    pub(super) fn line_column(&self, offset: usize) -> (usize, usize) {
        let mut offset = offset.min(self.text.len());
        while !self.text.is_char_boundary(offset) {
            offset -= 1;
        }
        let before = &self.text[..offset];
        let line_start = before.rfind('\n').map_or(0, |i| i + 1);
        (
            before.matches('\n').count() + 1,
            before[line_start..].chars().count() + 1,
        )
    }

    pub(super) fn error(&self, span: Range<usize>, message: impl Into<String>) -> SceneError {
        let (line, column) = self.line_column(span.start);
        SceneError::Invalid {
            file: self.file.to_path_buf(),
            line,
            column,
            message: message.into(),
        }
    }

    pub(super) fn toml_error(&self, e: &toml::de::Error) -> SceneError {
        let message = e
            .message()
            .trim()
            .replace('`', "'")
            .replace("expected i64", "expected an integer")
            .lines()
            .map(str::trim)
            .filter(|l| !l.is_empty())
            .collect::<Vec<_>>()
            .join("; ");
        self.error(e.span().unwrap_or(0..0), message)
    }

    pub(super) fn int(&self, v: &S<i64>, key: &str, range: RangeInclusive<i64>) -> Result<i64> {
        let x = *v.get_ref();
        if range.contains(&x) {
            Ok(x)
        } else if x < *range.start() {
            Err(self.error(
                v.span(),
                format!("{key} must be at least {}, found {x}", range.start()),
            ))
        } else {
            Err(self.error(
                v.span(),
                format!("{key} must be at most {}, found {x}", range.end()),
            ))
        }
    }

    pub(super) fn opt_int(
        &self,
        v: &Option<S<i64>>,
        key: &str,
        range: RangeInclusive<i64>,
        default: i64,
    ) -> Result<i64> {
        v.as_ref().map_or(Ok(default), |v| self.int(v, key, range))
    }

    /// An optional name among `names` for `key`, parsed to its value;
    /// `default` when absent. An unknown name is an error at its position
    /// that lists the names.
    pub(super) fn opt_name<T: std::str::FromStr>(
        &self,
        v: &Option<S<String>>,
        key: &str,
        names: &[&str],
        default: T,
    ) -> Result<T> {
        let Some(v) = v else { return Ok(default) };
        v.get_ref().parse::<T>().map_err(|_| {
            self.error(
                v.span(),
                format!(
                    "unknown {key} '{}', expected one of {}",
                    v.get_ref(),
                    quoted_list(names)
                ),
            )
        })
    }

    pub(super) fn u32(&self, v: &Option<S<i64>>, key: &str, min: u32, default: u32) -> Result<u32> {
        Ok(self.opt_int(v, key, min as i64..=u32::MAX as i64, default as i64)? as u32)
    }

    pub(super) fn positive(&self, v: &S<Num>, key: &str) -> Result<f32> {
        let x = v.get_ref().0;
        if x > 0.0 {
            Ok(x)
        } else {
            Err(self.error(v.span(), format!("{key} must be > 0, found {x}")))
        }
    }

    /// A number with magnitude at most `max` (see [`super::MAX_COORDINATE`]).
    pub(super) fn bounded(&self, v: &S<Num>, key: &str, max: f32) -> Result<f32> {
        let x = v.get_ref().0;
        if x.abs() <= max {
            Ok(x)
        } else {
            Err(self.error(
                v.span(),
                format!("{key} must be within ±{max:e}, found {x:e}"),
            ))
        }
    }

    /// A point or vector with every coordinate within ±`max`.
    pub(super) fn bounded3(&self, v: &S<V3>, key: &str, max: f32) -> Result<Vec3> {
        let c = v.get_ref().0;
        if c.abs().max_element() <= max {
            Ok(c)
        } else {
            Err(self.error(
                v.span(),
                format!(
                    "{key} must be within ±{max:e} in every coordinate, found [{:e}, {:e}, {:e}]",
                    c.x, c.y, c.z
                ),
            ))
        }
    }

    pub(super) fn non_negative(&self, v: &S<Num>, key: &str) -> Result<f32> {
        let x = v.get_ref().0;
        if x >= 0.0 {
            Ok(x)
        } else {
            Err(self.error(v.span(), format!("{key} must be ≥ 0, found {x}")))
        }
    }

    /// An RGB triple with every channel ≥ 0 (radiance, intensity, …).
    pub(super) fn rgb(&self, v: &S<V3>, key: &str) -> Result<Vec3> {
        let c = v.get_ref().0;
        let max = super::MAX_EMISSION;
        if c.max_element() > max {
            return Err(self.error(
                v.span(),
                format!(
                    "{key} must be at most {max:e} in every channel, found {}",
                    fmt3(c)
                ),
            ));
        }
        if c.min_element() >= 0.0 {
            Ok(c)
        } else {
            Err(self.error(
                v.span(),
                format!("{key} must be ≥ 0 in every channel, found {}", fmt3(c)),
            ))
        }
    }

    /// An albedo: every channel in [0, 1].
    pub(super) fn albedo(&self, v: &S<V3>, key: &str) -> Result<Vec3> {
        let c = v.get_ref().0;
        if c.min_element() >= 0.0 && c.max_element() <= 1.0 {
            Ok(c)
        } else {
            Err(self.error(
                v.span(),
                format!(
                    "{key} must be in [0, 1] in every channel, found {}",
                    fmt3(c)
                ),
            ))
        }
    }

    pub(super) fn nonzero(&self, v: &S<V3>, key: &str) -> Result<Vec3> {
        let d = v.get_ref().0;
        match d.try_normalize() {
            Some(n) => Ok(n),
            None => Err(self.error(v.span(), format!("{key} must be a nonzero vector"))),
        }
    }

    /// `n` numbers from an array key, e.g. `min = [x, z]`.
    pub(super) fn array<const N: usize>(
        &self,
        v: &S<Vec<Num>>,
        key: &str,
        form: &str,
    ) -> Result<[f32; N]> {
        let values = v.get_ref();
        if values.len() != N {
            return Err(self.error(
                v.span(),
                format!(
                    "{key} must be {form} ({N} numbers), found {} elements",
                    values.len()
                ),
            ));
        }
        Ok(std::array::from_fn(|i| values[i].0))
    }

    pub(super) fn points<const N: usize>(&self, v: &S<Vec<V3>>, key: &str) -> Result<[Vec3; N]> {
        let values = v.get_ref();
        if values.len() != N {
            return Err(self.error(
                v.span(),
                format!(
                    "{key} must be an array of {N} points [x, y, z], found {}",
                    values.len()
                ),
            ));
        }
        Ok(std::array::from_fn(|i| values[i].0))
    }

    /// Check the key set of a typed table against its type's keys; returns
    /// the index of the type in `types`.
    pub(super) fn check_type(
        &self,
        what: &str,
        kind: &S<String>,
        keys: &[(&'static str, Range<usize>)],
        types: &[(&str, &[&str])],
    ) -> Result<usize> {
        let name = kind.get_ref().as_str();
        let Some(t) = types.iter().position(|(n, _)| *n == name) else {
            let names: Vec<&str> = types.iter().map(|(n, _)| *n).collect();
            return Err(self.error(
                kind.span(),
                format!(
                    "unknown {what} type '{name}', expected one of {}",
                    quoted_list(&names)
                ),
            ));
        };
        let allowed = types[t].1;
        if let Some((key, span)) = keys.iter().find(|(k, _)| !allowed.contains(k)) {
            let keys = if allowed.is_empty() {
                "it takes no other keys".to_string()
            } else {
                format!("its keys: {}", quoted_list(allowed))
            };
            return Err(self.error(
                span.clone(),
                format!("key '{key}' does not apply to a {name} {what} ({keys})"),
            ));
        }
        Ok(t)
    }

    pub(super) fn need<'v, T>(
        &self,
        v: &'v Option<S<T>>,
        key: &str,
        kind: &S<String>,
        what: &str,
    ) -> Result<&'v S<T>> {
        v.as_ref().ok_or_else(|| {
            self.error(
                kind.span(),
                format!("a {} {what} needs '{key}'", kind.get_ref()),
            )
        })
    }

    /// Counts a shape's triangles into the scene's, before it is made:
    /// an error if the scene would hold more than [`MAX_SCENE_TRIANGLES`].
    pub(super) fn count_check(&self, triangles: u64, span: Range<usize>, kind: &str) -> Result<()> {
        let total = self.triangles.get().saturating_add(triangles);
        if total > MAX_SCENE_TRIANGLES {
            return Err(self.error(
                span,
                format!(
                    "this {kind} would have {triangles} triangles, bringing the scene to {total}: absurdly large (at most {MAX_SCENE_TRIANGLES} in a scene)"
                ),
            ));
        }
        self.triangles.set(total);
        Ok(())
    }

    /// Triangles the scene may still take.
    pub(super) fn triangles_left(&self) -> u64 {
        MAX_SCENE_TRIANGLES - self.triangles.get()
    }
}
