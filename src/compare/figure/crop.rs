//! Inset rectangles of the compare figure: [`Crop`] (parsed from the
//! command line's `--crop x,y,w,h` and validated against the film) and
//! [`auto_insets`], the automatic placement at the largest error
//! difference between two methods.

use anyhow::{anyhow, bail, Result};
use std::fmt;
use std::str::FromStr;

/// A pixel rectangle: column `x` and row `y` of its top-left pixel (row 0
/// at the top), `w` columns by `h` rows. Crops are in film pixels; the
/// figure's [`FigureInfo`](super::FigureInfo) uses the same type for
/// rectangles in figure pixels.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Crop {
    pub x: u32,
    pub y: u32,
    pub w: u32,
    pub h: u32,
}

impl Crop {
    /// Parses `"x,y,w,h"` (four non-negative integers, spaces around them
    /// allowed). The error names the text and the bad part. Sizes are
    /// checked against a film by [`Crop::validate`], not here.
    pub fn parse(s: &str) -> Result<Crop> {
        let parts: Vec<&str> = s.split(',').map(str::trim).collect();
        if parts.len() != 4 {
            bail!(
                "crop '{s}': expected x,y,w,h (four non-negative integers separated by commas), found {} part{}",
                parts.len(),
                if parts.len() == 1 { "" } else { "s" }
            );
        }
        let mut v = [0u32; 4];
        for ((slot, part), name) in v.iter_mut().zip(&parts).zip(["x", "y", "w", "h"]) {
            *slot = part.parse().map_err(|_| {
                anyhow!("crop '{s}': {name} = '{part}' is not a non-negative integer")
            })?;
        }
        Ok(Crop {
            x: v[0],
            y: v[1],
            w: v[2],
            h: v[3],
        })
    }

    /// Checks that the crop is non-empty and lies inside a `width`×`height`
    /// film; the error names the crop and the film size.
    pub fn validate(&self, width: u32, height: u32) -> Result<()> {
        if self.w == 0 || self.h == 0 {
            bail!("crop {self}: its width and height must be at least 1 pixel");
        }
        let (right, bottom) = (
            u64::from(self.x) + u64::from(self.w),
            u64::from(self.y) + u64::from(self.h),
        );
        if right > u64::from(width) || bottom > u64::from(height) {
            bail!(
                "crop {self} lies outside the {width}×{height} film (it needs x + w ≤ {width} and y + h ≤ {height}; here x + w = {right}, y + h = {bottom})"
            );
        }
        Ok(())
    }

    /// Whether the two rectangles share a pixel.
    pub fn overlaps(&self, other: &Crop) -> bool {
        let (ax1, ay1) = (
            u64::from(self.x) + u64::from(self.w),
            u64::from(self.y) + u64::from(self.h),
        );
        let (bx1, by1) = (
            u64::from(other.x) + u64::from(other.w),
            u64::from(other.y) + u64::from(other.h),
        );
        u64::from(self.x) < bx1
            && u64::from(other.x) < ax1
            && u64::from(self.y) < by1
            && u64::from(other.y) < ay1
    }
}

/// `x,y,w,h`, the form [`Crop::parse`] reads.
impl fmt::Display for Crop {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{},{},{},{}", self.x, self.y, self.w, self.h)
    }
}

/// [`Crop::parse`], so clap can parse `--crop` values directly.
impl FromStr for Crop {
    type Err = anyhow::Error;
    fn from_str(s: &str) -> Result<Crop> {
        Crop::parse(s)
    }
}

/// The default side of automatic insets: max(8, min(w, h) / 6), but no
/// larger than the film.
pub fn default_inset_size(width: u32, height: u32) -> u32 {
    let m = width.min(height);
    (m / 6).max(8).min(m).max(1)
}

/// Up to `count` square insets of side `size` (clamped to 1 ..= min(w, h))
/// where two per-pixel error maps differ most.
///
/// |a − b| is summed over every `size`×`size` window (a summed-area table
/// in f64; pixels where the difference is not finite, e.g. a NaN in
/// either map, count as 0). Windows are then picked greedily: the largest
/// sum first, then the largest among the windows at least `size` pixels
/// away from every picked one (where none is left that far, among those
/// that merely do not overlap them), and so on: window sums are smooth, so
/// without the distance the second inset would mostly sit right next to
/// the first. Ties go to the smallest index `y·w + x` of the top-left
/// corner, so the result is deterministic; with identical maps it is the
/// top-left corner, then the window `2·size` to its right. Fewer than
/// `count` crops come back only when no further window fits.
///
/// # Panics
/// If `relmse_a` or `relmse_b` does not hold `width * height` values.
pub fn auto_insets(
    relmse_a: &[f32],
    relmse_b: &[f32],
    width: u32,
    height: u32,
    count: usize,
    size: u32,
) -> Vec<Crop> {
    let (w, h) = (width as usize, height as usize);
    assert_eq!(relmse_a.len(), w * h, "auto_insets: first map size");
    assert_eq!(relmse_b.len(), w * h, "auto_insets: second map size");
    if w == 0 || h == 0 || count == 0 {
        return Vec::new();
    }
    let s = (size as usize).clamp(1, w.min(h));
    // sat[(y) * (w + 1) + x] = sum over rows < y, columns < x.
    let stride = w + 1;
    let mut sat = vec![0f64; stride * (h + 1)];
    for y in 0..h {
        let mut row = 0f64;
        for x in 0..w {
            let d = f64::from(relmse_a[y * w + x]) - f64::from(relmse_b[y * w + x]);
            if d.is_finite() {
                row += d.abs();
            }
            sat[(y + 1) * stride + x + 1] = sat[y * stride + x + 1] + row;
        }
    }
    let (nx, ny) = (w - s + 1, h - s + 1);
    let sums: Vec<f64> = (0..ny * nx)
        .map(|i| {
            let (x, y) = (i % nx, i / nx);
            sat[(y + s) * stride + x + s] - sat[y * stride + x + s] - sat[(y + s) * stride + x]
                + sat[y * stride + x]
        })
        .collect();
    let mut picked: Vec<Crop> = Vec::with_capacity(count);
    while picked.len() < count {
        let best = [s as u32, 0].into_iter().find_map(|gap| {
            let mut best: Option<(f64, Crop)> = None;
            for (i, &sum) in sums.iter().enumerate() {
                let c = Crop {
                    x: (i % nx) as u32,
                    y: (i / nx) as u32,
                    w: s as u32,
                    h: s as u32,
                };
                if best.is_some_and(|(b, _)| sum <= b)
                    || picked.iter().any(|p| grown(p, gap).overlaps(&c))
                {
                    continue;
                }
                best = Some((sum, c));
            }
            best
        });
        match best {
            Some((_, c)) => picked.push(c),
            None => break,
        }
    }
    picked
}

/// `c` grown by `g` pixels on each side (not below 0).
fn grown(c: &Crop, g: u32) -> Crop {
    let (x, y) = (c.x.saturating_sub(g), c.y.saturating_sub(g));
    Crop {
        x,
        y,
        w: c.x - x + c.w.saturating_add(g),
        h: c.y - y + c.h.saturating_add(g),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn crop_parse_and_validate() {
        let c = Crop::parse(" 3, 4,10 ,12").unwrap();
        assert_eq!(
            c,
            Crop {
                x: 3,
                y: 4,
                w: 10,
                h: 12
            }
        );
        assert_eq!(c.to_string(), "3,4,10,12");
        assert_eq!("3,4,10,12".parse::<Crop>().unwrap(), c);
        let e = Crop::parse("3,4,10").unwrap_err().to_string();
        assert!(e.contains("'3,4,10'") && e.contains("x,y,w,h"), "{e}");
        let e = Crop::parse("1,b,3,4").unwrap_err().to_string();
        assert!(e.contains("'1,b,3,4'") && e.contains("y = 'b'"), "{e}");
        assert!(Crop::parse("1,2,-3,4").is_err());
        assert!(Crop::parse("").is_err());

        c.validate(13, 16).unwrap();
        let e = c.validate(12, 16).unwrap_err().to_string();
        assert!(
            e.contains("crop 3,4,10,12") && e.contains("12×16 film"),
            "{e}"
        );
        let e = Crop::parse("0,0,0,4")
            .unwrap()
            .validate(8, 8)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("crop 0,0,0,4") && e.contains("at least 1"),
            "{e}"
        );
        // No overflow near u32::MAX.
        let far = Crop {
            x: u32::MAX,
            y: 0,
            w: u32::MAX,
            h: 1,
        };
        assert!(far.validate(u32::MAX, 1).is_err());
        assert!(c.overlaps(&Crop {
            x: 12,
            y: 15,
            w: 1,
            h: 1
        }));
        assert!(!c.overlaps(&Crop {
            x: 13,
            y: 4,
            w: 1,
            h: 1
        }));
        assert_eq!(default_inset_size(32, 32), 8);
        assert_eq!(default_inset_size(600, 300), 50);
        assert_eq!(default_inset_size(4, 100), 4);
    }

    fn c(x: u32, y: u32, w: u32, h: u32) -> Crop {
        Crop { x, y, w, h }
    }

    /// Maps that differ only in one block: that block comes first; the
    /// second inset keeps its distance; NaN is ignored; ties go to the
    /// smallest index.
    #[test]
    fn auto_insets_find_the_differing_block() {
        let (w, h) = (64u32, 40u32);
        let a = vec![0.01f32; (w * h) as usize];
        let mut b = a.clone();
        for y in 20..28 {
            for x in 37..45 {
                b[(y * w + x) as usize] = 0.5;
            }
        }
        // A NaN far from the block must not attract (or poison) a window.
        b[(5 * w + 5) as usize] = f32::NAN;
        let crops = auto_insets(&a, &b, w, h, 2, 8);
        assert_eq!(crops, [c(37, 20, 8, 8), c(0, 0, 8, 8)]);
        // Second: every window away from the block sums to 0 (the NaN
        // counts as 0), so the tie goes to the smallest index. Identical
        // maps: top-left, then one inset width further right.
        let same = auto_insets(&a, &a, w, h, 2, 8);
        assert_eq!(same, [c(0, 0, 8, 8), c(16, 0, 8, 8)]);
        // No room for the distance: next to each other.
        let two = auto_insets(&[0.0; 32], &[1.0; 32], 8, 4, 2, 4);
        assert_eq!(two, [c(0, 0, 4, 4), c(4, 0, 4, 4)]);
        // Size clamped to the film; no room for a second one.
        let one = auto_insets(&[0.0; 16], &[1.0; 16], 4, 4, 2, 100);
        assert_eq!(one, [c(0, 0, 4, 4)]);
    }
}
