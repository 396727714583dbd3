//! Image error metrics: relative MSE and MSE of a rendered image against a
//! reference.
//!
//! Images are plain row-major slices of linear RGB pixels, `&[[f32; 3]]`,
//! pixel (i, j) at index `j * width + i` (DESIGN.md raster convention); the
//! metrics here only need the two slices to be the same length, so no width
//! or height is passed.
//!
//! # Definitions
//!
//! For a rendered image `x` and a reference `ref` with `N` pixels,
//!
//! ```text
//! RelMSE(x, ref) = 1/(3N) Σ_pixels Σ_c (x_c − ref_c)² / (ref_c² + ε),   ε = 0.01
//! MSE(x, ref)    = 1/(3N) Σ_pixels Σ_c (x_c − ref_c)²
//! ```
//!
//! which is the relative MSE of the MDAS paper (Meister & Hachisuka 2022) and
//! the project-wide definition in DESIGN.md. Sums are accumulated in `f64`
//! (each term is computed in `f64` from the `f32` inputs), so the result does
//! not depend on summation error at any realistic image size.
//!
//! # Non-finite pixels
//!
//! A pixel of `x` whose any channel is NaN or ±∞ is *non-finite*. Such pixels
//! are counted in [`ErrorStats::nonfinite_pixels`] and **excluded** from both
//! means: `N` above is the number of finite pixels, not the image size. This
//! keeps one stray NaN from turning the whole metric into NaN, while the count
//! makes sure it is reported rather than silently zeroed (DESIGN.md: "Non-finite
//! pixels are counted and reported, never silently zeroed"). A caller that
//! wants a NaN to fail a comparison must check `nonfinite_pixels == 0`. If every
//! pixel is non-finite, both means are `f64::INFINITY`.
//!
//! The *reference* must be finite everywhere: a non-finite reference pixel is an
//! error, since no meaningful relative error can be formed against it.

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
    /// Number of pixels of `x` with at least one non-finite channel (these are
    /// excluded from `relmse` and `mse`).
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

/// Squared error and relative squared error of one pixel, summed over the
/// three channels (not yet divided by 3).
fn pixel_error_sums(x: &[f32; 3], reference: &[f32; 3]) -> (f64, f64) {
    let mut squared = 0.0f64;
    let mut relative = 0.0f64;
    for c in 0..3 {
        let r = f64::from(reference[c]);
        let d = f64::from(x[c]) - r;
        squared += d * d;
        relative += d * d / (r * r + RELMSE_EPSILON);
    }
    (squared, relative)
}

/// RelMSE and MSE of `x` against `reference` (same length, row-major RGB).
///
/// Errors if the lengths differ, the images are empty, or the reference has a
/// non-finite pixel. Non-finite pixels of `x` are counted and excluded from
/// the means (see the module docs).
pub fn compare(x: &[[f32; 3]], reference: &[[f32; 3]]) -> Result<ErrorStats> {
    check_shapes(x, reference)?;

    let mut sum_squared = 0.0f64;
    let mut sum_relative = 0.0f64;
    let mut finite_pixels = 0u64;
    let mut nonfinite_pixels = 0u64;
    for (index, (xp, rp)) in x.iter().zip(reference).enumerate() {
        check_reference_pixel(index, rp)?;
        if !is_finite_pixel(xp) {
            nonfinite_pixels += 1;
            continue;
        }
        let (squared, relative) = pixel_error_sums(xp, rp);
        sum_squared += squared;
        sum_relative += relative;
        finite_pixels += 1;
    }

    let (relmse, mse) = if finite_pixels == 0 {
        (f64::INFINITY, f64::INFINITY)
    } else {
        let terms = 3.0 * finite_pixels as f64;
        (sum_relative / terms, sum_squared / terms)
    };
    Ok(ErrorStats {
        relmse,
        mse,
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
            let (_, relative) = pixel_error_sums(xp, rp);
            Ok((relative / 3.0) as f32)
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
        assert!(close(stats.mse, expected_mse), "{stats:?}");
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

        let per_pixel = relmse_per_pixel(&x, &reference).unwrap();
        assert!(per_pixel[1].is_nan() && per_pixel[2].is_nan());
        assert!(per_pixel[0].is_finite() && per_pixel[3] == 0.0);

        let all_bad = [[f32::NEG_INFINITY, 0.0, 0.0]; 4];
        let stats = compare(&all_bad, &reference).unwrap();
        assert_eq!(stats.nonfinite_pixels, 4);
        assert_eq!(stats.relmse, f64::INFINITY);
        assert_eq!(stats.mse, f64::INFINITY);
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
