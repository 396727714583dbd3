//! LDR-FLIP (Andersson et al. 2020) after NVIDIA's reference implementation.
//! The definition, input convention and non-finite rule are documented in the
//! parent module ([`crate::metrics`]); this file holds the implementation.
//!
//! Layout: each image is turned into planes (one `Vec<f32>` per channel,
//! row-major). Every convolution is separable, as in the reference, and done
//! as a horizontal pass followed by a vertical pass, each a correlation with
//! clamp-to-edge indices whose inner loops run over contiguous rows (so they
//! vectorise). Every kernel is even or odd, so each pass adds mirrored
//! samples before multiplying. Weights and sums are `f64`, the planes between
//! passes `f32`; the per-pixel colour conversions, HyAB, compression and the
//! final combination are `f64`.

use anyhow::{bail, Result};

use super::{check_reference_pixel, is_finite_pixel};

/// Default viewing condition of the reference implementation: a 0.7 m wide
/// monitor with 3840 pixels across, seen from 0.7 m, i.e.
/// `0.7 · (3840 / 0.7) · π / 180` = 67.0206… pixels per degree of visual angle.
/// (NVIDIA's FLIP tools compute it from these three numbers; the `nv-flip`
/// Rust wrapper rounds it to 67.0.)
pub const DEFAULT_PIXELS_PER_DEGREE: f64 = 0.7 * (3840.0 / 0.7) * std::f64::consts::PI / 180.0;

/// Largest accepted `pixels_per_degree`: the filter radii grow linearly with
/// it (CSF radius ≈ 0.135·ppd pixels), and beyond this they would only cost
/// memory and time (a display at 10⁴ pixels per degree is far beyond any
/// real one).
const MAX_PIXELS_PER_DEGREE: f64 = 1e4;

/// Per-pixel FLIP error of a test image against a reference, and its mean.
/// See the module docs of [`crate::metrics`] for the definition.
#[derive(Clone, Debug, PartialEq)]
pub struct FlipMap {
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// FLIP error per pixel, row-major like the inputs, each value in [0, 1].
    /// A non-finite test pixel gets the maximal error 1.0 here (so it stands
    /// out in a heat map) but is excluded from [`FlipMap::mean`].
    pub per_pixel: Vec<f32>,
    /// Mean FLIP over the finite pixels of the test image, accumulated in
    /// `f64` from the values before their rounding to `f32` in `per_pixel`;
    /// `f64::INFINITY` if no test pixel is finite (the convention of
    /// [`crate::metrics::ErrorStats`]).
    pub mean: f64,
    /// Number of pixels of the test image with at least one non-finite
    /// channel. They enter the spatial filters (and so affect their
    /// neighbours) as they would appear in our PNGs: NaN → 0, ±∞ clamped to
    /// 1 or 0; their own map value is 1.0 and they are excluded from `mean`.
    pub nonfinite_pixels: u64,
}

// Constants of the reference implementation (`FLIPConstants` and
// `GaussianConstants` in `sharedflip.h`).
const Q_C: f64 = 0.7;
const P_C: f64 = 0.4;
const P_T: f64 = 0.95;
const FEATURE_WIDTH: f64 = 0.082; // w, in degrees
const Q_F: f64 = 0.5;
// The feature power q_f is applied as a square root.
const _: () = assert!(Q_F == 0.5);

/// Contrast-sensitivity function of one YCxCz channel: the sum of two
/// Gaussians `a·√(π/b)·exp(−π²r²/b)` with `r` in degrees.
#[derive(Clone, Copy)]
struct Csf {
    a1: f64,
    b1: f64,
    a2: f64,
    b2: f64,
}

/// Y, Cx, Cz, in that order.
const CSF: [Csf; 3] = [
    Csf {
        a1: 1.0,
        b1: 0.0047,
        a2: 0.0,
        b2: 1.0e-5,
    },
    Csf {
        a1: 1.0,
        b1: 0.0053,
        a2: 0.0,
        b2: 1.0e-5,
    },
    Csf {
        a1: 34.1,
        b1: 0.04,
        a2: 13.5,
        b2: 0.025,
    },
];

/// D65 white point and its reciprocal, as given (separately rounded) in the
/// reference implementation's `color.h`.
const WHITE: [f64; 3] = [0.950428545, 1.0, 1.088900371];
const INV_WHITE: [f64; 3] = [1.052156925, 1.0, 0.918357670];

/// Linear (sRGB primaries) RGB → XYZ, the exact fractions of the reference.
const RGB_TO_XYZ: [[f64; 3]; 3] = [
    [
        10135552.0 / 24577794.0,
        8788810.0 / 24577794.0,
        4435075.0 / 24577794.0,
    ],
    [
        2613072.0 / 12288897.0,
        8788810.0 / 12288897.0,
        887015.0 / 12288897.0,
    ],
    [
        1425312.0 / 73733382.0,
        8788810.0 / 73733382.0,
        70074185.0 / 73733382.0,
    ],
];

/// XYZ → linear RGB as given in the reference (its rounded inverse).
const XYZ_TO_RGB: [[f64; 3]; 3] = [
    [3.241003275, -1.537398934, -0.498615861],
    [-0.969224334, 1.875930071, 0.041554224],
    [0.055639423, -0.204011202, 1.057148933],
];

fn mat_mul(m: &[[f64; 3]; 3], v: [f64; 3]) -> [f64; 3] {
    m.map(|row| row[0] * v[0] + row[1] * v[1] + row[2] * v[2])
}

fn linear_rgb_to_ycxcz(rgb: [f64; 3]) -> [f64; 3] {
    let xyz = mat_mul(&RGB_TO_XYZ, rgb);
    let [x, y, z] = [0, 1, 2].map(|c| xyz[c] * INV_WHITE[c]);
    [116.0 * y - 16.0, 500.0 * (x - y), 200.0 * (y - z)]
}

fn ycxcz_to_linear_rgb(ycxcz: [f64; 3]) -> [f64; 3] {
    let y = (ycxcz[0] + 16.0) / 116.0;
    let x = y + ycxcz[1] / 500.0;
    let z = y - ycxcz[2] / 200.0;
    let xyz = [x, y, z];
    mat_mul(&XYZ_TO_RGB, [0, 1, 2].map(|c| xyz[c] * WHITE[c]))
}

/// Cube root of a positive normal `x`, to within a few ulp: a bit-level
/// estimate of x^(−1/3) (relative error < 3.5 %) refined by four Newton steps
/// `r ← r·(4 − x·r³)/3` (quadratic convergence, no division), then x·r².
/// About ten times faster than `f64::cbrt`, which dominated the per-pixel
/// cost of FLIP (six cube roots per pixel).
#[inline(always)]
fn cbrt_positive(x: f64) -> f64 {
    let mut r = f64::from_bits(0x553E_F1A9_FBE7_6C00 - x.to_bits() / 3);
    for _ in 0..4 {
        r *= (4.0 - x * r * r * r) * (1.0 / 3.0);
    }
    x * r * r
}

fn linear_rgb_to_cielab(rgb: [f64; 3]) -> [f64; 3] {
    const DELTA: f64 = 6.0 / 29.0;
    const DELTA_CUBED: f64 = DELTA * DELTA * DELTA;
    let xyz = mat_mul(&RGB_TO_XYZ, rgb);
    // Both branches for all three channels, then a select: straight-line
    // code that the compiler interleaves (the cube roots dominate).
    let mut f = [0.0f64; 3];
    for c in 0..3 {
        let t = xyz[c] * INV_WHITE[c];
        let root = cbrt_positive(t.max(DELTA_CUBED));
        f[c] = if t > DELTA_CUBED {
            root
        } else {
            t / (3.0 * DELTA * DELTA) + 4.0 / 29.0
        };
    }
    let [fx, fy, fz] = f;
    [116.0 * fy - 16.0, 500.0 * (fx - fy), 200.0 * (fy - fz)]
}

/// Hunt adjustment: chroma scaled by 0.01·L.
fn hunt(lab: [f64; 3]) -> [f64; 3] {
    [lab[0], 0.01 * lab[0] * lab[1], 0.01 * lab[0] * lab[2]]
}

fn hyab(p: [f64; 3], q: [f64; 3]) -> f64 {
    (p[0] - q[0]).abs() + ((p[1] - q[1]).powi(2) + (p[2] - q[2]).powi(2)).sqrt()
}

/// Filtered YCxCz → clamped linear RGB → Hunt-adjusted CIELAB.
fn filtered_ycxcz_to_hunt_lab(ycxcz: [f64; 3]) -> [f64; 3] {
    let rgb = ycxcz_to_linear_rgb(ycxcz).map(|v| v.clamp(0.0, 1.0));
    hunt(linear_rgb_to_cielab(rgb))
}

/// c_max: (HyAB of Hunt-adjusted green and blue)^q_c, the largest colour
/// difference in the reference implementation's normalisation.
fn max_color_distance() -> f64 {
    let green = hunt(linear_rgb_to_cielab([0.0, 1.0, 0.0]));
    let blue = hunt(linear_rgb_to_cielab([0.0, 0.0, 1.0]));
    hyab(green, blue).powf(Q_C)
}

/// One linear channel as FLIP sees it (see the module docs): clamped to
/// [0, 1], NaN → 0, like the PNG.
fn png_channel(v: f32) -> f64 {
    if v.is_nan() {
        0.0
    } else {
        f64::from(v).clamp(0.0, 1.0)
    }
}

/// Radius in pixels of the CSF filters: three standard deviations of the
/// widest Gaussian (largest b), as in `calculateSpatialFilterRadius`.
fn spatial_filter_radius(ppd: f64) -> usize {
    let max_b = CSF
        .iter()
        .flat_map(|csf| [csf.b1, csf.b2])
        .fold(0.0f64, f64::max);
    let pi_sq = std::f64::consts::PI * std::f64::consts::PI;
    (3.0 * (max_b / (2.0 * pi_sq)).sqrt() * ppd).ceil() as usize
}

/// The 1-D kernels whose separable (outer-product) application gives the 2-D
/// CSF filter of one channel. Each Gaussian `a·√(π/b)·exp(−π²r²/b)` of the sum
/// is split into two factors `√(a·√(π/b))·exp(−π²x²/b)`; both kernels are
/// divided by `√(S₁² + S₂²)` (Sₖ the sum of kernel k) so that the 2-D filter
/// sums to 1. A Gaussian with a = 0 is dropped. For one Gaussian this is the
/// plain normalised Gaussian the reference uses for Y and Cx; for two it is
/// the reference's Cz construction (`setSpatialFilters`).
fn csf_kernels(csf: Csf, ppd: f64, radius: usize) -> Vec<Kernel> {
    let pi = std::f64::consts::PI;
    let raw: Vec<Vec<f64>> = [(csf.a1, csf.b1), (csf.a2, csf.b2)]
        .into_iter()
        .filter(|&(a, _)| a != 0.0)
        .map(|(a, b)| {
            let scale = (a * (pi / b).sqrt()).sqrt();
            (0..=2 * radius)
                .map(|k| {
                    let x = (k as f64 - radius as f64) / ppd;
                    scale * (-pi * pi * x * x / b).exp()
                })
                .collect()
        })
        .collect();
    let norm = raw
        .iter()
        .map(|kernel| kernel.iter().sum::<f64>().powi(2))
        .sum::<f64>()
        .sqrt();
    raw.into_iter()
        .map(|kernel| Kernel::from_full(&kernel.iter().map(|w| w / norm).collect::<Vec<_>>()))
        .collect()
}

/// The Gaussian, first-derivative and second-derivative kernels of the feature
/// detectors (`setFeatureFilter`): σ = 0.5·w·ppd pixels, radius ceil(3σ); the
/// Gaussian normalised to sum 1, the positive and negative weights of each
/// derivative normalised to sum to +1 and −1 respectively.
struct FeatureKernels {
    gaussian: Kernel,
    first: Kernel,
    second: Kernel,
}

fn feature_kernels(ppd: f64) -> FeatureKernels {
    let sigma = 0.5 * FEATURE_WIDTH * ppd;
    let radius = (3.0 * sigma).ceil() as i64;
    let xs = -radius..=radius;
    let gaussian: Vec<f64> = xs
        .clone()
        .map(|x| (-((x * x) as f64) / (2.0 * sigma * sigma)).exp())
        .collect();
    let first: Vec<f64> = xs
        .clone()
        .zip(&gaussian)
        .map(|(x, g)| -(x as f64) * g)
        .collect();
    let second: Vec<f64> = xs
        .zip(&gaussian)
        .map(|(x, g)| ((x * x) as f64 / (sigma * sigma) - 1.0) * g)
        .collect();

    let sum = gaussian.iter().sum::<f64>();
    let normalise_signed = |kernel: &[f64]| -> Kernel {
        let positive: f64 = kernel.iter().filter(|&&w| w > 0.0).sum();
        let negative: f64 = -kernel.iter().filter(|&&w| w < 0.0).sum::<f64>();
        let normalised = kernel
            .iter()
            .map(|&w| match w {
                w if w > 0.0 => w / positive,
                w if w < 0.0 => w / negative,
                _ => 0.0,
            })
            .collect::<Vec<_>>();
        Kernel::from_full(&normalised)
    };
    FeatureKernels {
        gaussian: Kernel::from_full(&gaussian.iter().map(|&g| g / sum).collect::<Vec<_>>()),
        first: normalise_signed(&first),
        second: normalise_signed(&second),
    }
}

/// A 1-D correlation kernel of radius r that is even (w(−d) = w(d)) or odd
/// (w(−d) = −w(d)), stored as its weights w(0), …, w(r). Every FLIP kernel is
/// one or the other (Gaussians and second derivatives even, first
/// derivatives odd), which halves the multiplications of each pass.
struct Kernel {
    taps: Vec<f64>,
    odd: bool,
}

impl Kernel {
    /// From the weights at offsets −r..=r, keeping those at 0..=r. Panics if
    /// the weights are neither even nor odd; they are so by construction, up
    /// to the rounding of the reference's separate normalisation of positive
    /// and negative weights (a few ulp), which this makes exact.
    fn from_full(full: &[f64]) -> Kernel {
        let radius = full.len() / 2;
        let scale = full.iter().fold(0.0f64, |m, w| m.max(w.abs()));
        let mirrored = |sign: f64| {
            (0..radius).all(|k| (full[k] - sign * full[2 * radius - k]).abs() <= 1e-12 * scale)
        };
        let odd = if mirrored(1.0) {
            false
        } else if mirrored(-1.0) && full[radius] == 0.0 {
            true
        } else {
            panic!("FLIP kernel is neither even nor odd: {full:?}")
        };
        Kernel {
            taps: full[radius..].to_vec(),
            odd,
        }
    }

    fn radius(&self) -> usize {
        self.taps.len() - 1
    }

    /// Weight at offset d ∈ −r..=r.
    #[cfg(test)]
    fn weight(&self, d: isize) -> f64 {
        let w = self.taps[d.unsigned_abs()];
        if d < 0 && self.odd {
            -w
        } else {
            w
        }
    }

    /// `sum[x] += Σ_d w(d) · at(d)[x]` over d ∈ −r..=r, where `at(d)` is the
    /// row of samples at offset d.
    fn accumulate<'a>(&self, sum: &mut [f64], at: impl Fn(isize) -> &'a [f32]) {
        if !self.odd {
            let w0 = self.taps[0];
            for (s, &v) in sum.iter_mut().zip(at(0)) {
                *s += w0 * f64::from(v);
            }
        }
        let sign = if self.odd { -1.0 } else { 1.0 };
        for (d, &w) in self.taps.iter().enumerate().skip(1) {
            let (plus, minus) = (at(d as isize), at(-(d as isize)));
            for ((s, &p), &m) in sum.iter_mut().zip(plus).zip(minus) {
                *s += w * (f64::from(p) + sign * f64::from(m));
            }
        }
    }
}

/// `dst[y][x] = Σ_d w(d) · src[y][clamp(x + d)]` (correlation along rows,
/// clamp-to-edge), accumulated in `f64`.
fn correlate_rows(src: &[f32], width: usize, kernel: &Kernel, dst: &mut [f32]) {
    let radius = kernel.radius();
    let mut padded = vec![0.0f32; width + 2 * radius];
    let mut sum = vec![0.0f64; width];
    for (row_in, row_out) in src.chunks_exact(width).zip(dst.chunks_exact_mut(width)) {
        for (j, p) in padded.iter_mut().enumerate() {
            *p = row_in[j.saturating_sub(radius).min(width - 1)];
        }
        sum.fill(0.0);
        kernel.accumulate(&mut sum, |d| {
            let start = (radius as isize + d) as usize;
            &padded[start..start + width]
        });
        for (out, &s) in row_out.iter_mut().zip(&sum) {
            *out = s as f32;
        }
    }
}

/// `dst[y][x] = Σ_terms Σ_d w(d) · src[clamp(y + d)][x]` (correlation along
/// columns, clamp-to-edge, summed over the (src, kernel) terms), accumulated
/// in `f64`.
fn correlate_columns(terms: &[(&[f32], &Kernel)], width: usize, dst: &mut [f32]) {
    let height = dst.len() / width;
    let mut sum = vec![0.0f64; width];
    for (y, row_out) in dst.chunks_exact_mut(width).enumerate() {
        sum.fill(0.0);
        for &(src, kernel) in terms {
            kernel.accumulate(&mut sum, |d| {
                let yy = (y as isize + d).clamp(0, height as isize - 1) as usize;
                &src[yy * width..(yy + 1) * width]
            });
        }
        for (out, &s) in row_out.iter_mut().zip(&sum) {
            *out = s as f32;
        }
    }
}

/// What the final combination needs from one image.
struct Prepared {
    /// CSF-filtered Y, Cx, Cz planes.
    filtered: [Vec<f32>; 3],
    /// Edge strength |(G_x', G_y')| of the normalised achromatic channel.
    edge: Vec<f32>,
    /// Point strength |(G_x'', G_y'')| of the normalised achromatic channel.
    point: Vec<f32>,
}

struct Filters {
    /// Per channel (Y, Cx, Cz): one or two 1-D kernels (see `csf_kernels`).
    csf: [Vec<Kernel>; 3],
    features: FeatureKernels,
}

fn prepare(image: &[[f32; 3]], width: usize, filters: &Filters) -> Prepared {
    let n = image.len();
    // sRGB-in-[0,1] input, decoded: the clamped linear values (module docs).
    let mut planes = [vec![0.0f32; n], vec![0.0f32; n], vec![0.0f32; n]];
    for (i, pixel) in image.iter().enumerate() {
        let ycxcz = linear_rgb_to_ycxcz(pixel.map(png_channel));
        for c in 0..3 {
            planes[c][i] = ycxcz[c] as f32;
        }
    }

    // CSF filtering: per channel, the sum over its one or two separable
    // terms of (rows with kernel, then columns with kernel).
    let filtered = [0, 1, 2].map(|c| {
        let rows: Vec<Vec<f32>> = filters.csf[c]
            .iter()
            .map(|kernel| {
                let mut out = vec![0.0f32; n];
                correlate_rows(&planes[c], width, kernel, &mut out);
                out
            })
            .collect();
        let terms: Vec<(&[f32], &Kernel)> = rows
            .iter()
            .zip(&filters.csf[c])
            .map(|(r, k)| (r.as_slice(), k))
            .collect();
        let mut out = vec![0.0f32; n];
        correlate_columns(&terms, width, &mut out);
        out
    });

    // Feature detection on the unfiltered Y, normalised to [0, 1].
    let [luma, _, _] = planes;
    let luma: Vec<f32> = luma
        .into_iter()
        .map(|y| y * (1.0 / 116.0) + 16.0 / 116.0)
        .collect();
    let FeatureKernels {
        gaussian,
        first,
        second,
    } = &filters.features;
    let rows = |kernel: &Kernel| {
        let mut out = vec![0.0f32; n];
        correlate_rows(&luma, width, kernel, &mut out);
        out
    };
    let (dx_rows, ddx_rows, g_rows) = (rows(first), rows(second), rows(gaussian));
    drop(luma);

    // Edge strength from the x-derivative smoothed in y and the y-derivative
    // of the x-smoothed image; point strength likewise with second
    // derivatives.
    let magnitude = |x_term: (&[f32], &Kernel), y_term: (&[f32], &Kernel)| {
        let mut dx = vec![0.0f32; n];
        let mut dy = vec![0.0f32; n];
        correlate_columns(&[x_term], width, &mut dx);
        correlate_columns(&[y_term], width, &mut dy);
        dx.iter()
            .zip(&dy)
            .map(|(&x, &y)| {
                let (x, y) = (f64::from(x), f64::from(y));
                (x * x + y * y).sqrt() as f32
            })
            .collect::<Vec<f32>>()
    };
    let edge = magnitude((&dx_rows, gaussian), (&g_rows, first));
    let point = magnitude((&ddx_rows, gaussian), (&g_rows, second));

    Prepared {
        filtered,
        edge,
        point,
    }
}

/// LDR-FLIP of `test` against `reference` (row-major linear RGB, `width` ×
/// `height`) at `pixels_per_degree` (use [`DEFAULT_PIXELS_PER_DEGREE`] unless
/// the viewing condition is known). See the [`crate::metrics`] module docs for
/// the exact definition and conventions.
///
/// Errors if either slice does not hold `width · height` pixels, the image is
/// empty, `pixels_per_degree` is not in (0, 10⁴] (NaN included), or the
/// reference has a non-finite pixel. Non-finite test pixels are counted, get error 1.0
/// in the map and are excluded from the mean (see [`FlipMap`]).
pub fn flip(
    test: &[[f32; 3]],
    reference: &[[f32; 3]],
    width: u32,
    height: u32,
    pixels_per_degree: f64,
) -> Result<FlipMap> {
    let pixels = (width as usize).checked_mul(height as usize);
    if pixels == Some(0) {
        bail!("cannot compute FLIP of an empty image ({width}x{height})");
    }
    if pixels != Some(test.len()) || pixels != Some(reference.len()) {
        bail!(
            "cannot compute FLIP: a {width}x{height} image needs {} pixels, image has {} and reference has {} (different sizes)",
            u64::from(width) * u64::from(height),
            test.len(),
            reference.len()
        );
    }
    if !(pixels_per_degree > 0.0 && pixels_per_degree <= MAX_PIXELS_PER_DEGREE) {
        bail!("pixels_per_degree must be in (0, {MAX_PIXELS_PER_DEGREE}], got {pixels_per_degree}");
    }
    for (index, pixel) in reference.iter().enumerate() {
        check_reference_pixel(index, pixel)?;
    }

    let radius = spatial_filter_radius(pixels_per_degree);
    let filters = Filters {
        csf: CSF.map(|csf| csf_kernels(csf, pixels_per_degree, radius)),
        features: feature_kernels(pixels_per_degree),
    };
    let width_px = width as usize;
    let prepared_reference = prepare(reference, width_px, &filters);
    let prepared_test = prepare(test, width_px, &filters);

    let c_max = max_color_distance();
    let pc_cmax = P_C * c_max;
    let pixel_at = |p: &Prepared, i: usize| p.filtered.each_ref().map(|c| f64::from(c[i]));

    let mut per_pixel = Vec::with_capacity(test.len());
    let mut sum = 0.0f64;
    let mut nonfinite_pixels = 0u64;
    for (i, test_pixel) in test.iter().enumerate() {
        if !is_finite_pixel(test_pixel) {
            nonfinite_pixels += 1;
            per_pixel.push(1.0);
            continue;
        }
        // Colour difference.
        let lab_reference = filtered_ycxcz_to_hunt_lab(pixel_at(&prepared_reference, i));
        let lab_test = filtered_ycxcz_to_hunt_lab(pixel_at(&prepared_test, i));
        let d = hyab(lab_reference, lab_test).powf(Q_C);
        let color = if d < pc_cmax {
            d * P_T / pc_cmax
        } else {
            P_T + (d - pc_cmax) / (c_max - pc_cmax) * (1.0 - P_T)
        };
        // Feature difference.
        let edge = f64::from(prepared_reference.edge[i]) - f64::from(prepared_test.edge[i]);
        let point = f64::from(prepared_reference.point[i]) - f64::from(prepared_test.point[i]);
        // q_f = 0.5: the power is a square root.
        let feature = (edge.abs().max(point.abs()) / std::f64::consts::SQRT_2).sqrt();

        let value = color.powf(1.0 - feature);
        sum += value;
        per_pixel.push(value as f32);
    }

    let finite_pixels = test.len() as u64 - nonfinite_pixels;
    let mean = if finite_pixels == 0 {
        f64::INFINITY
    } else {
        sum / finite_pixels as f64
    };
    Ok(FlipMap {
        width,
        height,
        per_pixel,
        mean,
        nonfinite_pixels,
    })
}

#[cfg(test)]
mod tests;
