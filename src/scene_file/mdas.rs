//! `[mdas]`: [`MdasParams`]. The keys, their kinds and their ranges are
//! the integrator's registry's ([`crate::integrator::mdas::PARAMS`]). A key
//! left out takes its value from [`MdasParams::for_film`] of the scene's
//! film (so does a missing table); a table that gives none of
//! `bits_per_dim`, `extra_image_bits` and `initial_samples_per_cell`
//! leaves the initial grid to each render (`auto_grid`,
//! [`crate::integrator::mdas::params::auto_grid`]).
//! Only kinds are checked here (whole numbers that fit a u32, finite
//! numbers, a rule's names); the ranges are the integrator's own
//! ([`crate::integrator::mdas::validate`]), and its error is positioned at
//! the key it names (at the table when that key was left at its default).

use super::ctx::{Ctx, Result};
use super::raw::*;
use super::values::{Loose, Num, S};
use super::*;
use crate::film::Film;
use crate::integrator::mdas::params::{self, Kind, Param};
use std::ops::Range;

/// One key as written: its row, its value, and where the value stands.
type Written = (&'static Param, f64, Range<usize>);

impl Ctx<'_> {
    pub(super) fn mdas(&self, table: &S<RawMdas>, film: Film) -> Result<MdasParams> {
        let mut entries: Vec<_> = table.get_ref().iter().collect();
        entries.sort_by_key(|(k, _)| k.span().start);
        let mut written: Vec<Written> = Vec::with_capacity(entries.len());
        for (key, value) in entries {
            let Some(param) = params::param(key.get_ref()) else {
                return Err(self.error(
                    key.span(),
                    format!(
                        "unknown field '{}', expected one of {}",
                        key.get_ref(),
                        params::key_list(false)
                    ),
                ));
            };
            written.push((param, self.mdas_value(param, value)?, value.span()));
        }
        let given = |key: &str| written.iter().find(|w| w.0.key == key).map(|w| w.1);
        // The defaults, with the automatic grid chosen at the table's spp.
        let mut d = MdasParams::for_film(film);
        if let Some(spp) = given("spp") {
            d.spp = spp as f32;
        }
        let d = d.resolved(film);
        // m before an automatic grid raises it to l + 1: a table that fixes
        // the grid keeps the plain default, and a missing l stays within it.
        let max_samples_per_leaf = given("max_samples_per_leaf")
            .map_or(MdasParams::default().max_samples_per_leaf, |m| m as u32);
        let mut params = MdasParams {
            max_samples_per_leaf,
            initial_samples_per_cell: d.initial_samples_per_cell.min(max_samples_per_leaf.max(1)),
            ..d
        };
        for &(param, v, _) in &written {
            param.set(&mut params, v);
        }
        // The values as written are checked; an automatic grid (none of its
        // keys written) is checked with one sample per cell, since its l
        // is chosen per render and raises m to l + 1 if need be.
        let checked = if params.auto_grid {
            MdasParams {
                initial_samples_per_cell: 1,
                ..params
            }
        } else {
            params
        };
        crate::integrator::mdas::validate(&checked).map_err(|e| {
            let span = written
                .iter()
                .find(|w| w.0.key == e.key)
                .map_or_else(|| table.span(), |w| w.2.clone());
            self.error(span, e.to_string())
        })?;
        // A table that sets the budget or the leaf size but not the grid:
        // the grid shown is the one chosen for them (renders choose again
        // at their own film and budget).
        Ok(params.resolved(film))
    }

    /// `value` as a value of `param`'s kind (its range is `validate`'s).
    fn mdas_value(&self, param: &Param, value: &S<Loose>) -> Result<f64> {
        let key = param.key;
        let wrong = |expected: &str| {
            self.error(
                value.span(),
                format!(
                    "{key}: invalid type: {}, expected {expected}",
                    value.get_ref().what()
                ),
            )
        };
        match (param.kind, value.get_ref()) {
            (Kind::Int, &Loose::Int(i)) => {
                let i = S::new(value.span(), i);
                Ok(self.int(&i, key, 0..=i64::from(u32::MAX))? as f64)
            }
            (Kind::Int, _) => Err(wrong("an integer")),
            (Kind::Number, &Loose::Int(i)) => Ok(f64::from(i as f32)),
            (Kind::Number, &Loose::Float(x)) => Num::checked(x)
                .map(|n| f64::from(n.0))
                .map_err(|e| self.error(value.span(), e)),
            (Kind::Number, _) => Err(wrong("a number")),
            (Kind::Rule(_), Loose::Str(s)) => {
                param.parse(s).map_err(|e| self.error(value.span(), e))
            }
            (Kind::Rule(_), _) => Err(wrong("a string")),
        }
    }
}

/// A Mitsuba scene's `[mdas]` table: `X.mdas.toml` beside `X.xml`, a TOML
/// file holding only an `[mdas]` table (docs/scene-format.md). Keys it
/// leaves out take the defaults of a TOML scene's table, except `spp`,
/// which defaults to `spp` (the file's `<sampler>` `sample_count`, when it
/// has one). `None` when there is no such file.
pub(super) fn sidecar(
    scene: &Path,
    film: Film,
    spp: Option<f32>,
) -> Result<Option<(MdasParams, PathBuf)>> {
    #[derive(serde::Deserialize)]
    #[serde(deny_unknown_fields)]
    struct Sidecar {
        mdas: Option<S<RawMdas>>,
    }
    let path = scene.with_extension("mdas.toml");
    if !path.exists() {
        return Ok(None);
    }
    let bytes =
        crate::scene::read_input(&path, MAX_SCENE_BYTES).map_err(|error| SceneError::Io {
            path: path.clone(),
            error,
        })?;
    let text = String::from_utf8(bytes).map_err(|_| SceneError::Invalid {
        file: path.clone(),
        line: 1,
        column: 1,
        message: "not UTF-8 text".into(),
    })?;
    let ctx = Ctx {
        text: &text,
        file: &path,
        triangles: Default::default(),
    };
    let raw: Sidecar = toml::from_str(&text).map_err(|e| ctx.toml_error(&e))?;
    let Some(table) = raw.mdas else {
        return Err(ctx.error(
            0..0,
            "this file beside a Mitsuba scene holds no [mdas] table",
        ));
    };
    let mut params = ctx.mdas(&table, film)?;
    let has_spp = table.get_ref().keys().any(|k| k.get_ref() == "spp");
    if let (false, Some(spp)) = (has_spp, spp) {
        params.spp = spp;
        params = params.resolved(film);
        crate::integrator::mdas::validate(&params).map_err(|e| ctx.error(0..0, e.to_string()))?;
    }
    Ok(Some((params, path)))
}
