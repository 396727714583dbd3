//! Helpers shared by the MDAS test binaries.
#![allow(dead_code)]

use crate::common::{gpu, TestIntegrand};
use mdas::film::Film;
use mdas::integrator::mdas::debug::Snapshot;
use mdas::integrator::mdas::MdasParams;
use mdas::integrator::{Integrator, Mdas, Render};

pub fn params(bits: u32, extra: u32, l: u32, spp: f32, seed: u32) -> MdasParams {
    MdasParams {
        bits_per_dim: bits,
        extra_image_bits: extra,
        initial_samples_per_cell: l,
        scale_factor: 1.0,
        alpha: 0.25,
        candidates: 4,
        max_samples_per_leaf: 4,
        epsilon: mdas::integrator::mdas::params::EPSILON,
        split: mdas::integrator::mdas::SplitRule::Extent,
        reconstruction: mdas::integrator::mdas::Reconstruction::Box,
        pixel_prior: mdas::integrator::mdas::params::PIXEL_PRIOR,
        pace: 0.0,
        initial_offsets: mdas::integrator::mdas::InitialOffsets::Random,
        spp,
        seed,
        auto_grid: false,
    }
}

pub fn render(case: u32, dims: u32, film: Film, p: MdasParams) -> Render {
    let gpu = gpu();
    let integrand = TestIntegrand::new(gpu, case, dims, film);
    Mdas::new(p).unwrap().render(gpu, &integrand).unwrap()
}

pub fn render_observed(case: u32, dims: u32, film: Film, p: MdasParams) -> (Render, Vec<Snapshot>) {
    let gpu = gpu();
    let integrand = TestIntegrand::new(gpu, case, dims, film);
    let mut snaps = Vec::new();
    let r = Mdas::new(p)
        .unwrap()
        .render_observed(gpu, &integrand, &mut |s| snaps.push(s.clone()))
        .unwrap();
    (r, snaps)
}

/// Exact area of the unit pixel (i, j) where 0.8·x + 0.6·y < 7.3 (test
/// case 3): the square clipped by the half-plane.
pub fn edge_pixel_mean(i: u32, j: u32) -> f64 {
    mdas::analytic::half_plane_area([i as f64, j as f64], [1.0, 1.0], [0.8, 0.6], 7.3)
}

pub fn edge_image(film: Film) -> Vec<[f32; 3]> {
    (0..film.height)
        .flat_map(|j| (0..film.width).map(move |i| [edge_pixel_mean(i, j) as f32; 3]))
        .collect()
}

/// The expected [`relmse`] of `n` independent uniform samples per pixel
/// of an integrand whose per-sample variance, in a pixel and channel whose
/// reference value is r, is `variance(r)`: the mean of
/// variance(r)/n / (r² + 0.01). A yardstick in closed form: f = (x, y,
/// u0) has variance 1/12 in every channel (a unit-width uniform); an
/// indicator covering a fraction c of a pixel has c(1 − c).
pub fn independent_sampling_relmse(
    reference: &[[f32; 3]],
    n: f64,
    variance: impl Fn(f64) -> f64,
) -> f64 {
    let sum: f64 = reference
        .iter()
        .flat_map(|r| r.iter().map(|&v| v as f64))
        .map(|v| variance(v) / n / (v * v + 0.01))
        .sum();
    sum / (3 * reference.len()) as f64
}

/// RelMSE of docs/conventions.md: mean of (x − ref)² / (ref² + 0.01).
pub fn relmse(x: &[[f32; 3]], reference: &[[f32; 3]]) -> f64 {
    let mut sum = 0.0;
    for (p, r) in x.iter().zip(reference) {
        for c in 0..3 {
            let (a, b) = (p[c] as f64, r[c] as f64);
            sum += (a - b).powi(2) / (b * b + 0.01);
        }
    }
    sum / (3 * x.len()) as f64
}
