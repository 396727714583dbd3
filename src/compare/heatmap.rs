//! False-colour maps for `mdas compare`: per-pixel RelMSE heat maps and
//! the MDAS sample-density map, each as an EXR of the raw values (the value
//! in all three channels) and a PNG for eyes.
//!
//! **Colormap**: viridis ([`crate::colormap`]); NaN (a non-finite pixel
//! of the render) is drawn magenta.
//!
//! **Scale**: logarithmic. RelMSE maps use the fixed range
//! [`RELMSE_RANGE`] = 10⁻⁶ … 10¹ so maps of different methods and runs
//! compare directly (values outside are clamped). The density map spans
//! its own [min, max] of the non-zero densities (samples per pixel); both
//! ranges are recorded in `report.json` (`maps`). FLIP maps
//! (`metrics::flip`, values in [0, 1]) use a linear scale over [0, 1]
//! ([`write_map_linear`]).

pub use crate::colormap::viridis;
use crate::image_io;
use anyhow::Result;
use std::path::Path;

/// Fixed log range of RelMSE heat maps.
pub const RELMSE_RANGE: (f32, f32) = (1e-6, 1e1);

/// Position of `v` in [lo, hi] on a log scale (0 at or below lo, 1 at or
/// above hi, NaN for NaN).
pub fn log_position(v: f32, (lo, hi): (f32, f32)) -> f32 {
    if v.is_nan() {
        return f32::NAN;
    }
    if v <= lo {
        return 0.0;
    }
    ((v.ln() - lo.ln()) / (hi.ln() - lo.ln())).clamp(0.0, 1.0)
}

/// Position of `v` in [lo, hi] on a linear scale (clamped; NaN for NaN).
pub fn linear_position(v: f32, (lo, hi): (f32, f32)) -> f32 {
    if v.is_nan() {
        return f32::NAN;
    }
    ((v - lo) / (hi - lo)).clamp(0.0, 1.0)
}

/// Writes `stem.exr` (raw values) and `stem.png` (viridis, log scale over
/// `range`).
pub fn write_map(
    stem: &Path,
    width: u32,
    height: u32,
    values: &[f32],
    range: (f32, f32),
) -> Result<()> {
    write_map_with(stem, width, height, values, |v| log_position(v, range))
}

/// [`write_map`] on a linear scale over `range`.
pub fn write_map_linear(
    stem: &Path,
    width: u32,
    height: u32,
    values: &[f32],
    range: (f32, f32),
) -> Result<()> {
    write_map_with(stem, width, height, values, |v| linear_position(v, range))
}

fn write_map_with(
    stem: &Path,
    width: u32,
    height: u32,
    values: &[f32],
    position: impl Fn(f32) -> f32,
) -> Result<()> {
    let grey: Vec<[f32; 3]> = values.iter().map(|&v| [v; 3]).collect();
    image_io::write_exr(&stem.with_extension("exr"), width, height, &grey)?;
    let bytes: Vec<u8> = values.iter().flat_map(|&v| viridis(position(v))).collect();
    let png = stem.with_extension("png");
    let image = image::RgbImage::from_raw(width, height, bytes)
        .ok_or_else(|| anyhow::anyhow!("{}: wrong pixel count", png.display()))?;
    image_io::write_atomic(&png, |temp| {
        image
            .save_with_format(temp, image::ImageFormat::Png)
            .map_err(|e| anyhow::anyhow!("PNG encoding failed: {e}"))
    })
}

/// The log range of a density map: its smallest and largest non-zero
/// finite values (a decade around 1 if there are none or they are equal).
pub fn density_range(density: &[f32]) -> (f32, f32) {
    let positive = density
        .iter()
        .copied()
        .filter(|d| d.is_finite() && *d > 0.0);
    let (lo, hi) = positive.fold((f32::INFINITY, 0.0f32), |(lo, hi), d| {
        (lo.min(d), hi.max(d))
    });
    if !(lo.is_finite() && hi > lo) {
        let c = if lo.is_finite() { lo } else { 1.0 };
        return (c / 10f32.sqrt(), c * 10f32.sqrt());
    }
    (lo, hi)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn log_positions() {
        let r = (1e-6, 1e1);
        assert_eq!(log_position(1e-9, r), 0.0);
        assert_eq!(log_position(1e3, r), 1.0);
        assert!((log_position(1e-6 * 10f32.powf(3.5), r) - 0.5).abs() < 1e-5);
        assert!(log_position(f32::NAN, r).is_nan());
        assert_eq!(density_range(&[0.0, 2.0, 8.0]), (2.0, 8.0));
    }
}
