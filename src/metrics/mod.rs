//! Image error metrics of a rendered image against a reference: relative MSE,
//! MSE and MAE ([`compare`], [`relmse_per_pixel`]) and the perceptual FLIP
//! difference ([`flip()`]).
//!
//! Images are plain row-major slices of linear RGB pixels, `&[[f32; 3]]`,
//! pixel (i, j) at index `j * width + i` (docs/conventions.md "Raster"). The
//! per-pixel metrics only need the two slices to be the same length, so no
//! width or height is passed to them; FLIP filters the image spatially and
//! therefore takes `width` and `height`.
//!
//! # Definitions
//!
//! For a rendered image `x` and a reference `ref` with `N` pixels,
//!
//! ```text
//! RelMSE(x, ref) = 1/(3N) Σ_pixels Σ_c (x_c − ref_c)² / (ref_c² + ε),   ε = 0.01
//! MSE(x, ref)    = 1/(3N) Σ_pixels Σ_c (x_c − ref_c)²
//! MAE(x, ref)    = 1/(3N) Σ_pixels Σ_c |x_c − ref_c|
//! ```
//!
//! RelMSE is the relative MSE of the MDAS paper (Meister & Hachisuka 2022)
//! and the project-wide definition in docs/conventions.md "RelMSE". All three
//! are computed on the linear values as they are (no clamping, no tone
//! mapping). Sums are accumulated in `f64` (each term is computed in `f64`
//! from the `f32` inputs), so the results do not depend on summation error at
//! any realistic image size.
//!
//! # Non-finite pixels
//!
//! A pixel of `x` whose any channel is NaN or ±∞ is *non-finite*. Such pixels
//! are counted in [`ErrorStats::nonfinite_pixels`] and **excluded** from the
//! means: `N` above is the number of finite pixels, not the image size. This
//! keeps one stray NaN from turning the whole metric into NaN, while the count
//! makes sure it is reported rather than silently zeroed (docs/conventions.md
//! "RelMSE": non-finite pixels are counted and reported, never silently
//! zeroed). A caller that wants a NaN to fail a comparison must check
//! `nonfinite_pixels == 0`. If every
//! pixel is non-finite, all three means are `f64::INFINITY`. [`flip()`] follows
//! the same rule for its mean (see [`FlipMap`] for how such pixels enter its
//! spatial filters and its per-pixel map).
//!
//! The *reference* must be finite everywhere: a non-finite reference pixel is an
//! error, since no meaningful relative error can be formed against it.
//!
//! # FLIP
//!
//! [`flip()`] is **LDR-FLIP** (Andersson, Nilsson, Akenine-Möller, Oskarsson,
//! Åström and Fairchild, "FLIP: A Difference Evaluator for Alternating
//! Images", HPG 2020), following NVIDIA's reference implementation (the C++
//! `FLIP::image::FLIP` of github.com/NVlabs/flip, as vendored in the
//! `nv-flip-sys` 0.1.1 crate) step by step and with its constants. HDR-FLIP
//! (exposure brackets and tone mapping) is **not** implemented.
//!
//! *Input.* FLIP is applied to the images as they appear in our PNGs
//! (`image_io::write_png`): each linear channel is clamped to [0, 1] (NaN → 0,
//! +∞ → 1, −∞ → 0) and sRGB-encoded with [`crate::image_io::linear_to_srgb`];
//! that sRGB image in [0, 1] is FLIP's input. Unlike the PNG it is not
//! quantised to 8 bits. FLIP's first step decodes sRGB back to linear RGB; as
//! decode ∘ encode is the identity on [0, 1] (up to rounding), the
//! implementation uses the clamped linear values directly.
//!
//! *Colour pipeline*, per image: linear RGB → CIE XYZ (D65) → YCxCz (the
//! opponent space of the paper: `Y = 116·y/y_w − 16`, `Cx = 500·(x/x_w −
//! y/y_w)`, `Cz = 200·(y/y_w − z/z_w)`); each channel is convolved with the
//! contrast-sensitivity filter of the paper, a sum of two Gaussians
//! `a₁·√(π/b₁)·exp(−π²r²/b₁) + a₂·√(π/b₂)·exp(−π²r²/b₂)` with `r` in degrees
//! (pixel distance / `pixels_per_degree`), with (a₁, b₁, a₂, b₂) = (1, 0.0047,
//! 0, 1e−5) for Y, (1, 0.0053, 0, 1e−5) for Cx and (34.1, 0.04, 13.5, 0.025)
//! for Cz, sampled on a square of radius `ceil(3·√(max b / (2π²))·ppd)`
//! pixels and normalised to unit sum (separably, as the reference does). The
//! filtered YCxCz is taken back to linear RGB, clamped to [0, 1], converted to
//! CIELAB (D65) and Hunt-adjusted (`a ← 0.01·L·a`, `b ← 0.01·L·b`). The colour
//! difference of the two images is the HyAB distance
//! `|L₁ − L₂| + √((a₁ − a₂)² + (b₁ − b₂)²)`, raised to `q_c = 0.7`, and
//! compressed to [0, 1] with `c_max` = (HyAB of Hunt-adjusted pure green and
//! pure blue)^q_c, `p_c = 0.4`, `p_t = 0.95`:
//!
//! ```text
//! ΔE_c = p_t · d / (p_c c_max)                                    if d < p_c c_max
//!        p_t + (d − p_c c_max) / (c_max − p_c c_max) · (1 − p_t)    otherwise
//! ```
//!
//! *Feature pipeline*, on the unfiltered achromatic channel normalised to
//! [0, 1] (`(Y + 16)/116`): with `σ = 0.5 · 0.082 · ppd` pixels and a kernel
//! of radius `ceil(3σ)`, the image is correlated with the first and second
//! derivatives of a Gaussian in x and in y (the Gaussian itself normalised to
//! unit sum, the positive and the negative weights of each derivative
//! normalised to sum to +1 and −1). Edge strength is `|(G_x', G_y')|`, point
//! strength `|(G_x'', G_y'')|`, and
//!
//! ```text
//! ΔE_f = (max(|edge₁ − edge₂|, |point₁ − point₂|) / √2)^q_f,   q_f = 0.5
//! ΔE   = ΔE_c^(1 − ΔE_f)                         (per pixel, in [0, 1])
//! ```
//!
//! All filters are applied with clamp-to-edge borders, as in the reference.
//! The reported value is the mean of ΔE over the finite pixels of the test
//! image. ΔE is symmetric in its two arguments, in the reference
//! implementation as here; only the checks differ (the reference must be
//! finite). [`DEFAULT_PIXELS_PER_DEGREE`] is the reference implementation's
//! default viewing condition.
//!
//! *Precision.* The reference implementation computes everything in `f32`;
//! here filter weights and sums and all per-pixel arithmetic are `f64` (the
//! planes between filter passes are `f32`). On the known-answer pairs of the
//! tests the result agrees with the same C++ built in double precision to
//! 4e−8 in the mean and 7e−7 per pixel, and with the reference itself
//! (`nv-flip` 0.1.2) to 5e−5. The latter differences are the reference's
//! `f32` rounding, amplified by the square root in ΔE_f where two feature
//! strengths are nearly equal: on a flat image its derivative filters leave a
//! residual of about 1e−8, which raises ΔE by up to 5e−5, while here the
//! residual is at the level of `f64` rounding (edges exactly zero), so flat
//! images give the colour pipeline's closed form (a test checks it to 1e−6).

mod flip;

pub use flip::{flip, FlipMap, DEFAULT_PIXELS_PER_DEGREE};

use anyhow::{bail, Result};

/// The ε in the RelMSE denominator `ref² + ε`, as in the MDAS paper.
pub const RELMSE_EPSILON: f64 = 0.01;

/// Error of an image against a reference. See the module docs for the exact
/// definitions and the treatment of non-finite pixels.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct ErrorStats {
    /// Mean over finite pixels and the three channels of
    /// (x − ref)² / (ref² + 0.01); `f64::INFINITY` if no pixel is finite.
    pub relmse: f64,
    /// Mean over finite pixels and the three channels of (x − ref)²;
    /// `f64::INFINITY` if no pixel is finite.
    pub mse: f64,
    /// Mean over finite pixels and the three channels of |x − ref|;
    /// `f64::INFINITY` if no pixel is finite.
    pub mae: f64,
    /// Number of pixels of `x` with at least one non-finite channel (these are
    /// excluded from `relmse`, `mse` and `mae`).
    pub nonfinite_pixels: u64,
    /// Total number of pixels compared (finite and non-finite).
    pub pixels: u64,
}

/// Checks that the two images can be compared: equal, non-zero length.
fn check_shapes(x: &[[f32; 3]], reference: &[[f32; 3]]) -> Result<()> {
    if x.len() != reference.len() {
        bail!(
            "cannot compare images of different sizes: image has {} pixels, reference has {}",
            x.len(),
            reference.len()
        );
    }
    if x.is_empty() {
        bail!("cannot compare empty images (0 pixels)");
    }
    Ok(())
}

/// Checks that a reference pixel is finite; `index` is used in the message.
fn check_reference_pixel(index: usize, pixel: &[f32; 3]) -> Result<()> {
    if pixel.iter().all(|c| c.is_finite()) {
        Ok(())
    } else {
        bail!(
            "reference pixel {index} is not finite ({:?}); references must be finite everywhere",
            pixel
        )
    }
}

fn is_finite_pixel(pixel: &[f32; 3]) -> bool {
    pixel.iter().all(|c| c.is_finite())
}

/// Per-pixel error sums over the three channels (not yet divided by 3).
struct PixelErrorSums {
    squared: f64,
    relative: f64,
    absolute: f64,
}

/// Squared, relative squared and absolute error of one pixel, summed over the
/// three channels (not yet divided by 3).
fn pixel_error_sums(x: &[f32; 3], reference: &[f32; 3]) -> PixelErrorSums {
    let mut sums = PixelErrorSums {
        squared: 0.0,
        relative: 0.0,
        absolute: 0.0,
    };
    for c in 0..3 {
        let r = f64::from(reference[c]);
        let d = f64::from(x[c]) - r;
        sums.squared += d * d;
        sums.relative += d * d / (r * r + RELMSE_EPSILON);
        sums.absolute += d.abs();
    }
    sums
}

/// RelMSE, MSE and MAE of `x` against `reference` (same length, row-major RGB).
///
/// Errors if the lengths differ, the images are empty, or the reference has a
/// non-finite pixel. Non-finite pixels of `x` are counted and excluded from
/// the means (see the module docs).
pub fn compare(x: &[[f32; 3]], reference: &[[f32; 3]]) -> Result<ErrorStats> {
    check_shapes(x, reference)?;

    let mut sum_squared = 0.0f64;
    let mut sum_relative = 0.0f64;
    let mut sum_absolute = 0.0f64;
    let mut finite_pixels = 0u64;
    let mut nonfinite_pixels = 0u64;
    for (index, (xp, rp)) in x.iter().zip(reference).enumerate() {
        check_reference_pixel(index, rp)?;
        if !is_finite_pixel(xp) {
            nonfinite_pixels += 1;
            continue;
        }
        let sums = pixel_error_sums(xp, rp);
        sum_squared += sums.squared;
        sum_relative += sums.relative;
        sum_absolute += sums.absolute;
        finite_pixels += 1;
    }

    let (relmse, mse, mae) = if finite_pixels == 0 {
        (f64::INFINITY, f64::INFINITY, f64::INFINITY)
    } else {
        let terms = 3.0 * finite_pixels as f64;
        (
            sum_relative / terms,
            sum_squared / terms,
            sum_absolute / terms,
        )
    };
    Ok(ErrorStats {
        relmse,
        mse,
        mae,
        nonfinite_pixels,
        pixels: x.len() as u64,
    })
}

/// Per-pixel RelMSE (mean over the three channels of
/// (x − ref)² / (ref² + 0.01)), for heat maps; same layout as the inputs.
///
/// A non-finite pixel of `x` gives NaN at that position (so it shows up in a
/// heat map instead of being hidden). Errors on the same conditions as
/// [`compare`]: length mismatch, empty images, non-finite reference.
pub fn relmse_per_pixel(x: &[[f32; 3]], reference: &[[f32; 3]]) -> Result<Vec<f32>> {
    check_shapes(x, reference)?;
    x.iter()
        .zip(reference)
        .enumerate()
        .map(|(index, (xp, rp))| {
            check_reference_pixel(index, rp)?;
            if !is_finite_pixel(xp) {
                return Ok(f32::NAN);
            }
            Ok((pixel_error_sums(xp, rp).relative / 3.0) as f32)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: f64, b: f64) -> bool {
        (a - b).abs() <= 1e-12 * b.abs().max(1e-300)
    }

    #[test]
    fn identical_images_have_zero_error() {
        let image: Vec<[f32; 3]> = (0..50)
            .map(|k| [k as f32 * 0.1, 1.0 / (k as f32 + 1.0), 1e4])
            .collect();
        let stats = compare(&image, &image).unwrap();
        assert_eq!(stats.relmse, 0.0);
        assert_eq!(stats.mse, 0.0);
        assert_eq!(stats.mae, 0.0);
        assert_eq!(stats.nonfinite_pixels, 0);
        assert_eq!(stats.pixels, 50);
        assert!(relmse_per_pixel(&image, &image)
            .unwrap()
            .iter()
            .all(|&v| v == 0.0));
    }

    #[test]
    fn hand_computed_case() {
        // Pixel 0: x = (1, 0, 0.5), ref = (0, 0, 1)
        //   squared errors  1, 0, 0.25
        //   relative        1/0.01 = 100, 0, 0.25/1.01
        // Pixel 1: x = (2, 2, 2), ref = (1, 1, 1)
        //   squared errors  1, 1, 1
        //   relative        3 × 1/1.01
        let x = [[1.0, 0.0, 0.5], [2.0, 2.0, 2.0]];
        let reference = [[0.0, 0.0, 1.0], [1.0, 1.0, 1.0]];
        let stats = compare(&x, &reference).unwrap();
        let expected_mse = (1.0 + 0.0 + 0.25 + 3.0) / 6.0;
        let expected_relmse = (100.0 + 0.25 / 1.01 + 3.0 / 1.01) / 6.0;
        // Absolute errors 1, 0, 0.5 and 1, 1, 1.
        let expected_mae = (1.0 + 0.0 + 0.5 + 3.0) / 6.0;
        assert!(close(stats.mse, expected_mse), "{stats:?}");
        assert!(close(stats.mae, expected_mae), "{stats:?}");
        assert!(close(stats.relmse, expected_relmse), "{stats:?}");
        assert_eq!(stats.pixels, 2);

        let per_pixel = relmse_per_pixel(&x, &reference).unwrap();
        assert_eq!(per_pixel.len(), 2);
        assert!((f64::from(per_pixel[0]) - (100.0 + 0.25 / 1.01) / 3.0).abs() < 1e-5);
        assert!((f64::from(per_pixel[1]) - 1.0 / 1.01).abs() < 1e-6);
    }

    #[test]
    fn nonfinite_pixels_are_counted_and_excluded() {
        let reference = [[1.0, 1.0, 1.0]; 4];
        let x = [
            [2.0, 2.0, 2.0],
            [f32::NAN, 1.0, 1.0],
            [1.0, f32::INFINITY, 1.0],
            [1.0, 1.0, 1.0],
        ];
        let stats = compare(&x, &reference).unwrap();
        assert_eq!(stats.nonfinite_pixels, 2);
        assert_eq!(stats.pixels, 4);
        // Means over the two finite pixels only: errors (1,1,1) and (0,0,0).
        assert!(close(stats.mse, 0.5), "{stats:?}");
        assert!(close(stats.relmse, 0.5 / 1.01), "{stats:?}");
        assert!(close(stats.mae, 0.5), "{stats:?}");

        let per_pixel = relmse_per_pixel(&x, &reference).unwrap();
        assert!(per_pixel[1].is_nan() && per_pixel[2].is_nan());
        assert!(per_pixel[0].is_finite() && per_pixel[3] == 0.0);

        let all_bad = [[f32::NEG_INFINITY, 0.0, 0.0]; 4];
        let stats = compare(&all_bad, &reference).unwrap();
        assert_eq!(stats.nonfinite_pixels, 4);
        assert_eq!(stats.relmse, f64::INFINITY);
        assert_eq!(stats.mse, f64::INFINITY);
        assert_eq!(stats.mae, f64::INFINITY);
    }

    #[test]
    fn mae_hand_computed_with_signs_and_large_values() {
        // Errors of both signs must not cancel, and values above 1 (radiance)
        // are used as they are. Pixel 0: x = (3, 0.25, 0), ref = (1, 0.75, 0)
        // → |d| = 2, 0.5, 0. Pixel 1: x = (0, 10, 0.5), ref = (4, 10, 0.25)
        // → |d| = 4, 0, 0.25. MAE = 6.75 / 6.
        let x = [[3.0, 0.25, 0.0], [0.0, 10.0, 0.5]];
        let reference = [[1.0, 0.75, 0.0], [4.0, 10.0, 0.25]];
        let stats = compare(&x, &reference).unwrap();
        assert_eq!(stats.mae, 6.75 / 6.0, "{stats:?}");
        // MSE of the same pair: (4 + 0.25 + 16 + 0.0625) / 6.
        assert_eq!(stats.mse, 20.3125 / 6.0, "{stats:?}");
    }

    #[test]
    fn bad_inputs_are_errors() {
        let a = [[0.0f32; 3]; 3];
        let b = [[0.0f32; 3]; 4];
        let err = compare(&a, &b).unwrap_err().to_string();
        assert!(err.contains("different sizes"), "{err}");
        assert!(relmse_per_pixel(&a, &b).is_err());

        let err = compare(&[], &[]).unwrap_err().to_string();
        assert!(err.contains("empty"), "{err}");

        let mut bad_reference = [[0.5f32; 3]; 3];
        bad_reference[2][1] = f32::NAN;
        let err = compare(&a, &bad_reference).unwrap_err().to_string();
        assert!(err.contains("reference pixel 2"), "{err}");
        assert!(relmse_per_pixel(&a, &bad_reference).is_err());
    }
}
