//! Known answer: `scenes/area_light_plane.toml` rendered with Halton against
//! its closed form (Lambert's polygon formula averaged over each pixel's
//! footprint, `mdas::analytic`).
//!
//! The bound. The area-light estimator of a pixel is a mean of N samples of
//! f = ρ/π·L·cosθ_x·cosθ_y/d²·(A/p) over the pixel footprint × the light.
//! By Popoviciu's inequality an N-sample Monte Carlo mean has variance at
//! most (f_max − f_min)²/(4N), where [f_min, f_max] is f's range over that
//! domain (f_min = 0 for pixels whose footprint leaves the plane). The
//! estimator is unbiased (a random toroidal shift makes every Halton point
//! uniform), so E[RelMSE] ≤ B(N) = mean_p (range_p²/4N)/(ref_p² + 0.01).
//! Halton points are better stratified than independent ones, so the
//! observed RelMSE is far below B(N); an error in a cosine, a π, the area
//! pdf or the pixel mapping biases every pixel and overshoots B(256) ≈ 7e-4.
//! The range is found on a grid of 5×5 footprint points × 9×9 light points
//! and widened by 50 % to cover extrema between grid points (f is smooth
//! on each pixel that sees only the plane).

mod common;

use common::{gpu, image_bits};
use mdas::integrator::{Halton, Integrator};
use mdas::metrics;
use mdas::session;
use std::path::Path;

const SCENE: &str = "scenes/area_light_plane.toml";
const W: u32 = 128;
const H: u32 = 96;

/// The integrand's value for film point (x, y) and light point (lx, lz),
/// or None when the camera ray misses the plane.
fn integrand(x: f64, y: f64, lx: f64, lz: f64) -> Option<f64> {
    let pos = [0.0, 0.5, 4.0];
    let f = normalize([0.0 - pos[0], 0.0 - pos[1], 0.0 - pos[2]]);
    let r = normalize(cross(f, [0.0, 1.0, 0.0]));
    let u = cross(r, f);
    let t = (45f64.to_radians() / 2.0).tan();
    let (nx, ny) = (2.0 * x / W as f64 - 1.0, 1.0 - 2.0 * y / H as f64);
    let d: Vec<f64> = (0..3)
        .map(|k| f[k] + nx * t * (W as f64 / H as f64) * r[k] + ny * t * u[k])
        .collect();
    if d[1] >= 0.0 {
        return None;
    }
    let s = -pos[1] / d[1];
    let p = [pos[0] + s * d[0], 0.0, pos[2] + s * d[2]];
    if p[0].abs() > 10.0 || p[2].abs() > 10.0 {
        return None;
    }
    let w = [lx - p[0], 2.0, lz - p[2]];
    let d2 = w[0] * w[0] + w[1] * w[1] + w[2] * w[2];
    let cos = 2.0 / d2.sqrt(); // both cosines: the plane and light normals are ±y
    Some(0.5 / std::f64::consts::PI * 10.0 * cos * cos / d2 * 1.0)
}

fn normalize(v: [f64; 3]) -> [f64; 3] {
    let l = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    [v[0] / l, v[1] / l, v[2] / l]
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// (f_min, f_max) of the integrand over pixel (i, j) × the light, widened.
fn range(i: u32, j: u32) -> f64 {
    let (mut lo, mut hi) = (f64::INFINITY, 0.0f64);
    for a in 0..5 {
        for b in 0..5 {
            let (x, y) = (i as f64 + a as f64 / 4.0, j as f64 + b as f64 / 4.0);
            for c in 0..9 {
                for e in 0..9 {
                    match integrand(x, y, -0.5 + c as f64 / 8.0, -0.5 + e as f64 / 8.0) {
                        Some(v) => {
                            lo = lo.min(v);
                            hi = hi.max(v);
                        }
                        None => lo = 0.0,
                    }
                }
            }
        }
    }
    if hi == 0.0 {
        return 0.0;
    }
    1.5 * (hi - lo.min(hi))
}

#[test]
fn area_light_plane_converges_to_the_closed_form_within_the_variance_bound() {
    let gpu = gpu();
    let prepared = session::prepare(gpu, Path::new(SCENE), 1.0).unwrap();
    assert_eq!((prepared.film.width, prepared.film.height), (W, H));
    let exact = mdas::analytic::area_light_plane_image(W, H);
    let ranges: Vec<f64> = (0..H)
        .flat_map(|j| (0..W).map(move |i| range(i, j)))
        .collect();

    let mut previous = f64::INFINITY;
    for spp in [16u32, 64, 256] {
        let render = Halton::new(spp, 1)
            .render(gpu, prepared.integrand.as_ref())
            .unwrap();
        assert_eq!(render.nonfinite, 0);
        let e = metrics::compare(&render.image, &exact).unwrap();
        let n = spp as f64;
        let bound: f64 = ranges
            .iter()
            .zip(&exact)
            .map(|(r, x)| (r * r / (4.0 * n)) / ((x[0] as f64).powi(2) + 0.01))
            .sum::<f64>()
            / ranges.len() as f64;
        println!(
            "spp {spp}: RelMSE {:.3e} (bound {bound:.3e}), MSE {:.3e}",
            e.relmse, e.mse
        );
        assert!(
            e.relmse <= bound,
            "spp {spp}: RelMSE {} above the bound {bound}",
            e.relmse
        );
        assert!(
            e.relmse < previous,
            "RelMSE must fall with spp: {} then {}",
            previous,
            e.relmse
        );
        previous = e.relmse;

        // Bias check on the image mean: the mean of npix independent pixel
        // errors has standard deviation ≤ sqrt(Σ var_p)/npix; allow 5σ.
        let npix = ranges.len() as f64;
        let mean_err: f64 = render
            .image
            .iter()
            .zip(&exact)
            .map(|(a, b)| (a[0] - b[0]) as f64)
            .sum::<f64>()
            / npix;
        let sigma = ranges.iter().map(|r| r * r / (4.0 * n)).sum::<f64>().sqrt() / npix;
        assert!(
            mean_err.abs() <= 5.0 * sigma,
            "spp {spp}: mean error {mean_err} vs 5σ = {}",
            5.0 * sigma
        );
    }
}

#[test]
fn halton_render_of_a_scene_is_deterministic() {
    let gpu = gpu();
    let prepared = session::prepare(gpu, Path::new(SCENE), 0.25).unwrap();
    let a = Halton::new(8, 3)
        .render(gpu, prepared.integrand.as_ref())
        .unwrap();
    let b = Halton::new(8, 3)
        .render(gpu, prepared.integrand.as_ref())
        .unwrap();
    assert_eq!((a.film.width, a.film.height), (32, 24));
    assert_eq!(image_bits(&a), image_bits(&b));
}
