//! Pixel drawing for the compare figure: an opaque RGBA canvas in the
//! byte layout of a tiny-skia pixmap (so the text layer can be rendered
//! onto it by resvg afterwards), nearest-neighbour blits and integer box
//! downscaling. resvg is built here without `raster-images`, so embedded
//! PNGs in SVG would not be drawn: every raster part is composed here.

use super::Crop;

/// An opaque RGBA8 image, row-major, top row first.
pub(super) struct Canvas {
    pub width: u32,
    pub height: u32,
    pub data: Vec<u8>,
}

impl Canvas {
    /// A `width`×`height` canvas filled with `colour`.
    pub fn new(width: u32, height: u32, colour: [u8; 3]) -> Canvas {
        let [r, g, b] = colour;
        let data = [r, g, b, 255].repeat(width as usize * height as usize);
        Canvas {
            width,
            height,
            data,
        }
    }

    /// Sets one pixel; positions outside the canvas are ignored.
    pub fn put(&mut self, x: u32, y: u32, c: [u8; 3]) {
        if x < self.width && y < self.height {
            let i = 4 * (y as usize * self.width as usize + x as usize);
            self.data[i..i + 3].copy_from_slice(&c);
        }
    }

    /// The colour of one pixel (tests).
    #[cfg(test)]
    pub fn get(&self, x: u32, y: u32) -> [u8; 3] {
        let i = 4 * (y as usize * self.width as usize + x as usize);
        [self.data[i], self.data[i + 1], self.data[i + 2]]
    }

    /// Fills `w`×`h` pixels at (`x`, `y`) with `f(i, j)` (i, j relative to
    /// the rectangle); the part outside the canvas is skipped.
    pub fn paint(&mut self, r: Crop, f: impl Fn(u32, u32) -> [u8; 3]) {
        let x1 = r.x.saturating_add(r.w).min(self.width);
        let y1 = r.y.saturating_add(r.h).min(self.height);
        for y in r.y..y1 {
            for x in r.x..x1 {
                self.put(x, y, f(x - r.x, y - r.y));
            }
        }
    }

    /// Fills a rectangle with one colour.
    pub fn fill(&mut self, r: Crop, c: [u8; 3]) {
        self.paint(r, |_, _| c);
    }

    /// Draws the border of `r`, `t` pixels thick, inside `r`.
    pub fn outline(&mut self, r: Crop, t: u32, c: [u8; 3]) {
        let t = t.min(r.w).min(r.h);
        let (x1, y1) = (r.x + r.w, r.y + r.h);
        self.fill(Crop { h: t, ..r }, c);
        self.fill(
            Crop {
                y: y1 - t,
                h: t,
                ..r
            },
            c,
        );
        self.fill(Crop { w: t, ..r }, c);
        self.fill(
            Crop {
                x: x1 - t,
                w: t,
                ..r
            },
            c,
        );
    }

    /// Draws `src` (`sw` columns, row-major) at (`x`, `y`), each source
    /// pixel an `up`×`up` block (nearest neighbour).
    pub fn blit(&mut self, x: u32, y: u32, src: &[[u8; 3]], sw: u32, up: u32) {
        let sh = (src.len() / sw.max(1) as usize) as u32;
        let r = Crop {
            x,
            y,
            w: sw * up,
            h: sh * up,
        };
        self.paint(r, |i, j| src[((j / up) * sw + i / up) as usize]);
    }

    /// The canvas as RGB8 bytes (dropping the opaque alpha).
    pub fn into_rgb(self) -> Vec<u8> {
        self.data
            .chunks_exact(4)
            .flat_map(|p| [p[0], p[1], p[2]])
            .collect()
    }
}

/// Downscales a `w`×`h` image by an integer factor `down` with a box
/// filter: each output pixel is the mean of the (up to) `down`×`down`
/// input pixels it covers (partial boxes at the right and bottom edges
/// average what they cover). A NaN in a box makes that output NaN (a
/// broken pixel stays visible). Returns the pixels and the new size.
pub(super) fn box_mean<const N: usize>(
    w: u32,
    h: u32,
    down: u32,
    px: impl Fn(usize) -> [f32; N],
) -> (Vec<[f32; N]>, u32, u32) {
    let (ow, oh) = (w.div_ceil(down), h.div_ceil(down));
    let mut out = Vec::with_capacity(ow as usize * oh as usize);
    for oy in 0..oh {
        for ox in 0..ow {
            let mut sum = [0f64; N];
            let mut n = 0u32;
            for y in oy * down..((oy + 1) * down).min(h) {
                for x in ox * down..((ox + 1) * down).min(w) {
                    let p = px(y as usize * w as usize + x as usize);
                    for (s, v) in sum.iter_mut().zip(p) {
                        *s += f64::from(v);
                    }
                    n += 1;
                }
            }
            out.push(sum.map(|s| (s / f64::from(n)) as f32));
        }
    }
    (out, ow, oh)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn canvas_and_box_mean() {
        let mut c = Canvas::new(6, 5, [255; 3]);
        c.blit(1, 1, &[[1, 1, 1], [2, 2, 2]], 2, 2);
        assert_eq!(c.get(1, 1), [1; 3]);
        assert_eq!(c.get(2, 2), [1; 3]);
        assert_eq!(c.get(3, 2), [2; 3]);
        assert_eq!(c.get(5, 1), [255; 3]);
        c.outline(
            Crop {
                x: 0,
                y: 0,
                w: 6,
                h: 5,
            },
            1,
            [9; 3],
        );
        assert_eq!(c.get(5, 4), [9; 3]);
        assert_eq!(c.get(3, 2), [2; 3]);
        c.put(99, 99, [0; 3]);
        assert_eq!(c.into_rgb().len(), 6 * 5 * 3);

        let v = [1.0f32, 3.0, 5.0, 2.0, 4.0, f32::NAN];
        let (m, w, h) = box_mean(3, 2, 2, |i| [v[i]]);
        assert_eq!((w, h), (2, 1));
        assert_eq!(m[0], [2.5]);
        assert!(m[1][0].is_nan());
    }
}
