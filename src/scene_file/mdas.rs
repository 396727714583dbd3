//! `[mdas]`: [`MdasParams`]. A key left out takes its value from
//! [`MdasParams::for_film`] of the scene's film (so does a missing table);
//! a table that gives none of `bits_per_dim`, `extra_image_bits` and
//! `initial_samples_per_cell` leaves the initial grid to each render
//! (`auto_grid`, [`crate::integrator::mdas::config::auto_grid`]).
//! Only types are checked here (integers ≥ 0,
//! finite numbers); the ranges are the integrator's own
//! ([`crate::integrator::mdas::config::validate`]), and its error is
//! positioned at the key it names (at the table when that key was left at
//! its default).

use super::ctx::{Ctx, Result};
use super::raw::*;
use super::values::{Num, S};
use super::*;
use crate::film::Film;
use crate::integrator::mdas::config;
use std::ops::Range;

impl Ctx<'_> {
    pub(super) fn mdas(&self, table: &S<RawMdas>, film: Film) -> Result<MdasParams> {
        let m = table.get_ref();
        let number =
            |v: &Option<S<Num>>, default: f32| v.as_ref().map_or(default, |v| v.get_ref().0);
        // The defaults, with the automatic grid chosen at the table's spp.
        let d = MdasParams::for_film(film);
        let d = MdasParams {
            spp: number(&m.spp, d.spp),
            ..d
        }
        .resolved(film);
        // Before an automatic grid raises it to l + 1: a table that fixes
        // the grid keeps the plain default, and a missing l stays within it.
        let max_samples_per_leaf = self.u32(
            &m.max_samples_per_leaf,
            "max_samples_per_leaf",
            0,
            MdasParams::default().max_samples_per_leaf,
        )?;
        let params = MdasParams {
            bits_per_dim: self.u32(&m.bits_per_dim, "bits_per_dim", 0, d.bits_per_dim)?,
            extra_image_bits: self.u32(
                &m.extra_image_bits,
                "extra_image_bits",
                0,
                d.extra_image_bits,
            )?,
            initial_samples_per_cell: self.u32(
                &m.initial_samples_per_cell,
                "initial_samples_per_cell",
                0,
                d.initial_samples_per_cell.min(max_samples_per_leaf.max(1)),
            )?,
            scale_factor: number(&m.scale_factor, d.scale_factor),
            alpha: number(&m.alpha, d.alpha),
            candidates: self.u32(&m.candidates, "candidates", 0, d.candidates)?,
            max_samples_per_leaf,
            epsilon: number(&m.epsilon, d.epsilon),
            split: match &m.split {
                None => d.split,
                Some(v) => v
                    .get_ref()
                    .parse::<config::SplitRule>()
                    .map_err(|e| self.error(v.span(), e))?,
            },
            reconstruction: match &m.reconstruction {
                None => d.reconstruction,
                Some(v) => v
                    .get_ref()
                    .parse::<config::Reconstruction>()
                    .map_err(|e| self.error(v.span(), e))?,
            },
            pixel_prior: number(&m.pixel_prior, d.pixel_prior),
            pace: number(&m.pace, d.pace),
            spp: number(&m.spp, d.spp),
            seed: self.u32(&m.seed, "seed", 0, d.seed)?,
            auto_grid: m.bits_per_dim.is_none()
                && m.extra_image_bits.is_none()
                && m.initial_samples_per_cell.is_none(),
        };
        // The values as written are checked; an automatic grid (none of its
        // keys written) is checked with one sample per cell, since its l
        // is chosen per render and raises m to l + 1 if need be.
        let written = if params.auto_grid {
            MdasParams {
                initial_samples_per_cell: 1,
                ..params
            }
        } else {
            params
        };
        config::validate(&written).map_err(|e| {
            let span = self.mdas_key_span(m, e.key).unwrap_or_else(|| table.span());
            self.error(span, e.to_string())
        })?;
        // A table that sets the budget or the leaf size but not the grid:
        // the grid shown is the one chosen for them (renders choose again
        // at their own film and budget).
        Ok(params.resolved(film))
    }

    /// Where `key` is written in the table, if it is.
    fn mdas_key_span(&self, m: &RawMdas, key: &str) -> Option<Range<usize>> {
        let int = |v: &Option<S<i64>>| v.as_ref().map(|v| v.span());
        let num = |v: &Option<S<Num>>| v.as_ref().map(|v| v.span());
        match key {
            "bits_per_dim" => int(&m.bits_per_dim),
            "extra_image_bits" => int(&m.extra_image_bits),
            "initial_samples_per_cell" => int(&m.initial_samples_per_cell),
            "candidates" => int(&m.candidates),
            "max_samples_per_leaf" => int(&m.max_samples_per_leaf),
            "seed" => int(&m.seed),
            "scale_factor" => num(&m.scale_factor),
            "alpha" => num(&m.alpha),
            "epsilon" => num(&m.epsilon),
            "pixel_prior" => num(&m.pixel_prior),
            "pace" => num(&m.pace),
            "spp" => num(&m.spp),
            _ => None,
        }
    }
}
