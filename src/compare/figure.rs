//! `figure.png` of `mdas compare`: a paper-style comparison figure.
//!
//! **Layout** (one column per image, three or more, [`MARGIN`] around,
//! [`GAP`] between columns):
//!
//! - a title line (the caller's: scene, film, equal-time ratio);
//! - row 1: reference | MDAS | Halton (| pixel-adaptive Halton), each with
//!   its label above and the
//!   caller's caption below, tone-mapped exactly as our PNGs
//!   ([`image_io::linear_to_srgb8`] per channel), with the inset rectangles
//!   outlined in their colours ([`CROP_COLOURS`]);
//! - under each image, its insets: the same crops of every image, zoomed
//!   (nearest neighbour, an integer factor where they fit) into square
//!   slots, two per row, each framed in its crop's colour;
//! - row 2: RelMSE of MDAS | RelMSE of Halton (| RelMSE of adaptive) |
//!   MDAS sample density, as many maps as images (viridis, log scale, NaN magenta as in [`heatmap`]), with the crops
//!   outlined too, and under each a colour bar (the viridis gradient over
//!   the map's log range, ticks and labels at the decades, the ends
//!   labelled with their values where they are not decades, the unit
//!   below), then the caller's caption.
//!
//! **Scale** ([`panel_scale`]): films are upscaled with nearest neighbour
//! by the smallest integer that makes a panel at least [`MIN_PANEL`] px
//! wide, as long as neither side exceeds [`MAX_PANEL`]; films larger than
//! that are box-filtered down by the smallest integer that fits (means of
//! linear radiance and of map values; a NaN in a box stays NaN). Columns
//! are at least [`MIN_PANEL`] wide, a narrower panel is centred. Insets
//! always use the film's own pixels.
//!
//! **Rendering**: the raster parts (panels, insets, outlines, colour bars,
//! ticks) are composed in an RGBA canvas (`figure/raster.rs`); the text is an SVG
//! of `<text>` elements only, rendered by resvg on top with the embedded
//! DejaVu Sans (`plot::font_options`). (resvg is built without
//! `raster-images`, so it could not draw embedded PNGs.) The PNG is written
//! atomically ([`image_io::write_atomic`]).

mod crop;
mod raster;

pub use crop::{auto_insets, default_inset_size, Crop};

use super::{heatmap, plot};
use crate::image_io;
use anyhow::{anyhow, bail, Context, Result};
use raster::{box_mean, Canvas};
use std::fmt::Write;
use std::path::Path;

/// Smallest panel width the upscaling aims at (and smallest column width).
pub const MIN_PANEL: u32 = 384;
/// Largest panel side; larger films are downscaled.
pub const MAX_PANEL: u32 = 1024;
/// Outer margin of the figure.
pub const MARGIN: u32 = 16;
/// Horizontal gap between columns.
pub const GAP: u32 = 16;
const TITLE_H: u32 = 34;
const HEADER_H: u32 = 22;
const CAPTION_PAD: u32 = 4;
const LINE_H: u32 = 16;
const INSET_GAP: u32 = 8;
const INSET_BORDER: u32 = 2;
const ROW_GAP: u32 = 12;
const BAR_TOP: u32 = 8;
const BAR_PAD: u32 = 14;
const BAR_H: u32 = 14;
const TICK: u32 = 4;
const BAR_TEXT_H: u32 = 30;
const OUTLINE: u32 = 2;
/// Fewest columns a figure has (reference and two methods).
pub const MIN_COLUMNS: usize = 3;
/// Number of automatic insets.
pub const AUTO_INSETS: usize = 2;
/// Most crops a figure takes (one colour each).
pub const MAX_CROPS: usize = 6;

/// Fails unless `crops` (`--crop`) fit a `width`×`height` film: at most
/// [`MAX_CROPS`], each non-empty and inside (`mdas compare` checks this
/// before any render).
pub fn check_crops(crops: &[Crop], width: u32, height: u32) -> Result<()> {
    if crops.len() > MAX_CROPS {
        bail!(
            "{} crops given, at most {MAX_CROPS} fit the figure",
            crops.len()
        );
    }
    for c in crops {
        c.validate(width, height)?;
    }
    Ok(())
}
/// Outline colours of the crops, in order.
pub const CROP_COLOURS: [[u8; 3]; MAX_CROPS] = [
    [228, 26, 28],
    [0, 174, 239],
    [255, 127, 0],
    [255, 255, 255],
    [77, 175, 74],
    [0, 0, 0],
];
const BACKGROUND: [u8; 3] = [255, 255, 255];
const INK: [u8; 3] = [17, 17, 17];
const FRAME: [u8; 3] = [120, 120, 120];

/// A film shown as an image panel.
pub struct ImagePanel<'a> {
    /// Shown above the panel ("Reference", "MDAS", "Halton").
    pub label: &'a str,
    /// Linear RGB, row-major, `width * height` pixels.
    pub pixels: &'a [[f32; 3]],
    /// Shown below the panel; `\n` starts a new line.
    pub caption: String,
}

/// A per-pixel map shown in viridis on a log scale with a colour bar.
pub struct MapPanel<'a> {
    /// Shown above the panel ("RelMSE MDAS", …).
    pub label: &'a str,
    /// Row-major, `width * height` values (NaN drawn magenta).
    pub values: &'a [f32],
    /// Log range (lo, hi), 0 < lo < hi: [`heatmap::RELMSE_RANGE`] or
    /// [`heatmap::density_range`].
    pub range: (f32, f32),
    /// Unit under the colour bar ("RelMSE", "spp").
    pub unit: &'a str,
    /// Shown below the colour bar; `\n` starts a new line.
    pub caption: String,
}

/// Everything the figure shows.
pub struct FigureInput<'a> {
    /// Film size in pixels.
    pub width: u32,
    pub height: u32,
    /// The line at the top.
    pub title: String,
    /// Reference, MDAS, Halton (and pixel-adaptive Halton): one column
    /// each, at least [`MIN_COLUMNS`].
    pub images: Vec<ImagePanel<'a>>,
    /// RelMSE of MDAS, RelMSE of Halton (RelMSE of adaptive), MDAS sample
    /// density: as many as `images`, the first two pick the automatic
    /// insets.
    pub maps: Vec<MapPanel<'a>>,
    /// Inset rectangles in film pixels (at most [`MAX_CROPS`]); empty:
    /// [`AUTO_INSETS`] automatic ones from the first two maps
    /// ([`auto_insets`] with [`default_inset_size`]).
    pub crops: Vec<Crop>,
}

/// What was drawn, and where (rectangles in figure pixels).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct FigureInfo {
    /// Figure size.
    pub width: u32,
    pub height: u32,
    /// The insets' rectangles in film pixels (given or automatic).
    pub crops: Vec<Crop>,
    /// Nearest-neighbour upscaling factor of the panels (1 if downscaled).
    pub upscale: u32,
    /// Box downscaling factor of the panels (1 if not downscaled).
    pub downscale: u32,
    /// Panel size: ceil(film / downscale) · upscale.
    pub panel: (u32, u32),
    /// Number of colour bars drawn (one per column).
    pub colour_bars: usize,
    /// The gradient rectangles of the colour bars.
    pub bar_rects: Vec<Crop>,
    /// The panels: row 1 (images) then row 2 (maps), left to right.
    pub panel_rects: Vec<Crop>,
    /// The insets' zoomed pictures, image by image, crop by crop (without
    /// their frames).
    pub inset_rects: Vec<Crop>,
}

/// (upscale, downscale) of a `width`×`height` film's panels: upscale by
/// the smallest integer that makes them at least [`MIN_PANEL`] wide while
/// no side exceeds [`MAX_PANEL`]; a film larger than [`MAX_PANEL`] is
/// downscaled by the smallest integer that fits.
pub fn panel_scale(width: u32, height: u32) -> (u32, u32) {
    let m = width.max(height).max(1);
    if m > MAX_PANEL {
        (1, m.div_ceil(MAX_PANEL))
    } else {
        let up = MIN_PANEL.div_ceil(width.max(1)).min(MAX_PANEL / m);
        (up.max(1), 1)
    }
}

/// Positions of the figure's parts.
struct Layout {
    up: u32,
    down: u32,
    pw: u32,
    ph: u32,
    col_w: u32,
    inset_cols: u32,
    slot: u32,
    width: u32,
    height: u32,
    panel1: u32,
    caption1: u32,
    insets: u32,
    panel2: u32,
    bar: u32,
    caption2: u32,
}

impl Layout {
    fn new(
        width: u32,
        height: u32,
        columns: u32,
        crops: usize,
        lines1: u32,
        lines2: u32,
    ) -> Layout {
        let (up, down) = panel_scale(width, height);
        let (pw, ph) = (width.div_ceil(down) * up, height.div_ceil(down) * up);
        let col_w = pw.max(MIN_PANEL);
        let inset_cols = crops.clamp(1, 2) as u32;
        let inset_rows = crops.div_ceil(2) as u32;
        let slot = (col_w - (inset_cols - 1) * INSET_GAP) / inset_cols;
        let panel1 = MARGIN + TITLE_H + HEADER_H;
        let caption1 = panel1 + ph;
        let insets = caption1 + CAPTION_PAD + lines1 * LINE_H + INSET_GAP;
        let panel2 = insets + inset_rows * (slot + INSET_GAP) + ROW_GAP + HEADER_H;
        let bar = panel2 + ph + BAR_TOP;
        let caption2 = bar + BAR_H + TICK + BAR_TEXT_H;
        Layout {
            up,
            down,
            pw,
            ph,
            col_w,
            inset_cols,
            slot,
            width: 2 * MARGIN + columns * col_w + (columns - 1) * GAP,
            height: caption2 + CAPTION_PAD + lines2 * LINE_H + MARGIN,
            panel1,
            caption1,
            insets,
            panel2,
            bar,
            caption2,
        }
    }

    fn col_x(&self, i: u32) -> u32 {
        MARGIN + i * (self.col_w + GAP)
    }

    fn panel_x(&self, i: u32) -> u32 {
        self.col_x(i) + (self.col_w - self.pw) / 2
    }

    fn col_centre(&self, i: u32) -> f64 {
        f64::from(self.col_x(i)) + f64::from(self.col_w) / 2.0
    }

    /// The gradient rectangle of column `i`'s colour bar.
    fn bar_rect(&self, i: u32) -> Crop {
        Crop {
            x: self.col_x(i) + BAR_PAD,
            y: self.bar,
            w: self.col_w - 2 * BAR_PAD,
            h: BAR_H,
        }
    }

    /// Where film rectangle `c` lies on panel `(px, py)`, widened by the
    /// outline's thickness and clamped to the panel.
    fn outline_rect(&self, c: Crop, px: u32, py: u32) -> Crop {
        let map = |v: u32, end: bool| {
            let n = u64::from(v) * u64::from(self.up);
            let d = u64::from(self.down);
            (if end { n.div_ceil(d) } else { n / d }) as u32
        };
        let x0 = map(c.x, false).saturating_sub(OUTLINE);
        let y0 = map(c.y, false).saturating_sub(OUTLINE);
        let x1 = (map(c.x + c.w, true) + OUTLINE).min(self.pw);
        let y1 = (map(c.y + c.h, true) + OUTLINE).min(self.ph);
        Crop {
            x: px + x0,
            y: py + y0,
            w: x1 - x0,
            h: y1 - y0,
        }
    }
}

/// Renders the figure and writes it to `path` as a PNG (atomically).
///
/// Errors: a zero film size, fewer than [`MIN_COLUMNS`] images or not as
/// many maps as images, a panel with the wrong number of pixels, a
/// bad map range, a crop outside the film (the message names the crop and
/// the film size), more than [`MAX_CROPS`] crops, or a failed write.
pub fn write_figure(path: &Path, input: &FigureInput) -> Result<FigureInfo> {
    let (image, info) = render_figure(input)?;
    image_io::write_atomic(path, |temp| {
        image
            .save_with_format(temp, image::ImageFormat::Png)
            .map_err(|e| anyhow!("PNG encoding failed: {e}"))
    })?;
    Ok(info)
}

/// The figure as an image, without writing it (see [`write_figure`]).
pub fn render_figure(input: &FigureInput) -> Result<(image::RgbImage, FigureInfo)> {
    let (w, h) = (input.width, input.height);
    let crops = checked_crops(input)?;
    let lines = |c: &str| c.lines().count().max(1) as u32;
    let lines1 = input.images.iter().map(|p| lines(&p.caption)).max();
    let lines2 = input.maps.iter().map(|p| lines(&p.caption)).max();
    let columns = input.images.len() as u32;
    let l = Layout::new(
        w,
        h,
        columns,
        crops.len(),
        lines1.unwrap_or(1),
        lines2.unwrap_or(1),
    );
    let mut canvas = Canvas::new(l.width, l.height, BACKGROUND);
    let mut text = TextLayer::new(l.width, l.height);
    let fit = f64::from(l.width - 2 * MARGIN);
    text.line(
        f64::from(l.width) / 2.0,
        f64::from(MARGIN) + 22.0,
        18.0,
        fit,
        &input.title,
    );
    let mut info = FigureInfo {
        width: l.width,
        height: l.height,
        crops: crops.clone(),
        upscale: l.up,
        downscale: l.down,
        panel: (l.pw, l.ph),
        colour_bars: 0,
        bar_rects: Vec::new(),
        panel_rects: Vec::new(),
        inset_rects: Vec::new(),
    };
    let col_w = f64::from(l.col_w);
    for (i, p) in (0u32..).zip(&input.images) {
        let full: Vec<[u8; 3]> = p
            .pixels
            .iter()
            .map(|c| c.map(image_io::linear_to_srgb8))
            .collect();
        let panel = if l.down > 1 {
            let (m, _, _) = box_mean(w, h, l.down, |k| p.pixels[k]);
            m.iter().map(|c| c.map(image_io::linear_to_srgb8)).collect()
        } else {
            full.clone()
        };
        let (px, py) = (l.panel_x(i), l.panel1);
        draw_panel(&mut canvas, &l, px, py, &panel, &crops, &mut info);
        text.line(l.col_centre(i), f64::from(py) - 6.0, 14.0, col_w, p.label);
        text.caption(l.col_centre(i), l.caption1, col_w, &p.caption);
        for (k, c) in crops.iter().enumerate() {
            let r = draw_inset(&mut canvas, &l, i, k, *c, w, &full);
            info.inset_rects.push(r);
        }
    }
    for (i, m) in (0u32..).zip(&input.maps) {
        let colour = |v: f32| heatmap::viridis(heatmap::log_position(v, m.range));
        let panel: Vec<[u8; 3]> = if l.down > 1 {
            let (v, _, _) = box_mean(w, h, l.down, |k| [m.values[k]]);
            v.iter().map(|v| colour(v[0])).collect()
        } else {
            m.values.iter().map(|&v| colour(v)).collect()
        };
        let (px, py) = (l.panel_x(i), l.panel2);
        draw_panel(&mut canvas, &l, px, py, &panel, &crops, &mut info);
        text.line(l.col_centre(i), f64::from(py) - 6.0, 14.0, col_w, m.label);
        let bar = l.bar_rect(i);
        draw_colour_bar(&mut canvas, &mut text, bar, m.range, m.unit);
        info.bar_rects.push(bar);
        info.colour_bars += 1;
        text.caption(l.col_centre(i), l.caption2, col_w, &m.caption);
    }
    text.render_onto(&mut canvas)?;
    let (cw, ch) = (canvas.width, canvas.height);
    let image = image::RgbImage::from_raw(cw, ch, canvas.into_rgb())
        .ok_or_else(|| anyhow!("figure of {cw}×{ch}: wrong pixel count"))?;
    Ok((image, info))
}

/// Checks the input's sizes and ranges; the crops to show (given, or
/// automatic).
fn checked_crops(input: &FigureInput) -> Result<Vec<Crop>> {
    let (w, h) = (input.width, input.height);
    if w == 0 || h == 0 {
        bail!("figure of a {w}×{h} film: the film is empty");
    }
    let (images, maps) = (input.images.len(), input.maps.len());
    if images < MIN_COLUMNS || maps != images {
        bail!("figure: {images} images and {maps} maps; it needs as many maps as images, at least {MIN_COLUMNS}");
    }
    let n = w as usize * h as usize;
    for p in &input.images {
        if p.pixels.len() != n {
            bail!(
                "figure: image '{}' has {} pixels, the {w}×{h} film needs {n}",
                p.label,
                p.pixels.len()
            );
        }
    }
    for m in &input.maps {
        if m.values.len() != n {
            bail!(
                "figure: map '{}' has {} values, the {w}×{h} film needs {n}",
                m.label,
                m.values.len()
            );
        }
        let (lo, hi) = m.range;
        if !(lo > 0.0 && hi > lo && hi.is_finite()) {
            bail!(
                "figure: map '{}' has the log range [{lo}, {hi}]; it needs 0 < lo < hi",
                m.label
            );
        }
    }
    check_crops(&input.crops, w, h).context("figure")?;
    Ok(if input.crops.is_empty() {
        let size = default_inset_size(w, h);
        let (a, b) = (input.maps[0].values, input.maps[1].values);
        auto_insets(a, b, w, h, AUTO_INSETS, size)
    } else {
        input.crops.clone()
    })
}

/// Blits a panel (already at the film's downscaled size) and outlines the
/// crops on it.
fn draw_panel(
    canvas: &mut Canvas,
    l: &Layout,
    px: u32,
    py: u32,
    pixels: &[[u8; 3]],
    crops: &[Crop],
    info: &mut FigureInfo,
) {
    canvas.blit(px, py, pixels, l.pw / l.up, l.up);
    for (c, colour) in crops.iter().zip(CROP_COLOURS) {
        canvas.outline(l.outline_rect(*c, px, py), OUTLINE, colour);
    }
    info.panel_rects.push(Crop {
        x: px,
        y: py,
        w: l.pw,
        h: l.ph,
    });
}

/// Draws inset `k` (film rectangle `c`) of image column `i` from the
/// film's own colours `full` (`w` columns); returns the picture's rectangle.
fn draw_inset(
    canvas: &mut Canvas,
    l: &Layout,
    i: u32,
    k: usize,
    c: Crop,
    w: u32,
    full: &[[u8; 3]],
) -> Crop {
    let (row, col) = (k as u32 / l.inset_cols, k as u32 % l.inset_cols);
    let slot_x = l.col_x(i) + col * (l.slot + INSET_GAP);
    let slot_y = l.insets + row * (l.slot + INSET_GAP);
    let avail = l.slot - 2 * INSET_BORDER;
    let s = (f64::from(avail) / f64::from(c.w)).min(f64::from(avail) / f64::from(c.h));
    let s = if s >= 1.0 { s.floor() } else { s };
    let iw = ((f64::from(c.w) * s).round() as u32).clamp(1, avail);
    let ih = ((f64::from(c.h) * s).round() as u32).clamp(1, avail);
    let r = Crop {
        x: slot_x + (l.slot - iw) / 2,
        y: slot_y + (l.slot - ih) / 2,
        w: iw,
        h: ih,
    };
    canvas.paint(r, |a, b| {
        let fx = c.x + (u64::from(a) * u64::from(c.w) / u64::from(iw)) as u32;
        let fy = c.y + (u64::from(b) * u64::from(c.h) / u64::from(ih)) as u32;
        full[fy as usize * w as usize + fx as usize]
    });
    let frame = Crop {
        x: r.x - INSET_BORDER,
        y: r.y - INSET_BORDER,
        w: iw + 2 * INSET_BORDER,
        h: ih + 2 * INSET_BORDER,
    };
    canvas.outline(frame, INSET_BORDER, CROP_COLOURS[k % MAX_CROPS]);
    r
}

/// Draws a colour bar: the viridis gradient over `bar` (left end exactly
/// viridis(0), right end viridis(1)), a grey frame around it, ticks below
/// at [`bar_ticks`] with their labels, and the unit.
fn draw_colour_bar(
    canvas: &mut Canvas,
    text: &mut TextLayer,
    bar: Crop,
    range: (f32, f32),
    unit: &str,
) {
    let frame = Crop {
        x: bar.x - 1,
        y: bar.y - 1,
        w: bar.w + 2,
        h: bar.h + 2,
    };
    canvas.outline(frame, 1, FRAME);
    let last = (bar.w - 1).max(1) as f32;
    canvas.paint(bar, |i, _| heatmap::viridis(i as f32 / last));
    let min_gap = 30.0 / f64::from(bar.w);
    let label_y = f64::from(bar.y + bar.h + TICK) + 11.0;
    for (t, label) in bar_ticks(range, min_gap) {
        let x = bar.x + (t * f64::from(bar.w - 1)).round() as u32;
        canvas.fill(
            Crop {
                x,
                y: bar.y + bar.h,
                w: 1,
                h: TICK,
            },
            INK,
        );
        text.line(f64::from(x) + 0.5, label_y, 10.0, 60.0, &label);
    }
    let centre = f64::from(bar.x) + f64::from(bar.w) / 2.0;
    let unit = format!("{unit} (log scale)");
    text.line(centre, label_y + 15.0, 11.0, f64::from(bar.w), &unit);
}

/// Ticks of a colour bar over the log range `(lo, hi)`: (position in
/// [0, 1], label) for each decade inside the range, and for each end that
/// is not a decade (labelled with its value); a decade closer than
/// `min_gap` to such an end is dropped so labels do not collide.
fn bar_ticks((lo, hi): (f32, f32), min_gap: f64) -> Vec<(f64, String)> {
    const EPS: f64 = 1e-4;
    let (a, b) = (f64::from(lo).log10(), f64::from(hi).log10());
    let pos = |l: f64| (l - a) / (b - a);
    let is_decade = |l: f64| (l - l.round()).abs() < EPS;
    let mut ends = Vec::new();
    for (l, v) in [(a, lo), (b, hi)] {
        if !is_decade(l) {
            ends.push((pos(l).clamp(0.0, 1.0), format_value(v)));
        }
    }
    let mut ticks: Vec<(f64, String)> = ((a - EPS).ceil() as i32..=(b + EPS).floor() as i32)
        .map(|e| (pos(f64::from(e)).clamp(0.0, 1.0), decade_label(e)))
        .filter(|(t, _)| ends.iter().all(|(u, _)| (t - u).abs() >= min_gap))
        .collect();
    ticks.extend(ends);
    ticks.sort_by(|x, y| x.0.total_cmp(&y.0));
    ticks
}

/// 10^e as a label: "1", "10", "100", "1000", else "1e{e}".
fn decade_label(e: i32) -> String {
    if (0..=3).contains(&e) {
        format!("{}", 10u32.pow(e as u32))
    } else {
        format!("1e{e}")
    }
}

/// A range end: three significant digits (trailing zeros dropped),
/// scientific outside 0.01 … 1e5.
fn format_value(v: f32) -> String {
    let v = f64::from(v);
    let s = match v.abs() {
        a if !(1e-2..1e5).contains(&a) => return format!("{v:.2e}"),
        a if a >= 100.0 => return format!("{v:.0}"),
        a if a >= 10.0 => format!("{v:.1}"),
        a if a >= 1.0 => format!("{v:.2}"),
        _ => format!("{v:.3}"),
    };
    s.trim_end_matches('0').trim_end_matches('.').to_string()
}

/// The text of the figure: an SVG of `<text>` elements on a transparent
/// background, rendered onto the canvas at the end.
struct TextLayer {
    svg: String,
}

impl TextLayer {
    fn new(width: u32, height: u32) -> TextLayer {
        TextLayer {
            svg: format!(
                r#"<svg xmlns="http://www.w3.org/2000/svg" width="{width}" height="{height}" viewBox="0 0 {width} {height}" font-family="sans-serif" fill="rgb({},{},{})">"#,
                INK[0], INK[1], INK[2]
            ),
        }
    }

    /// One line centred at `x`, baseline `y`; the font shrinks (down to 7
    /// px) when the line would be wider than `fit` (estimated 0.6 em per
    /// character).
    fn line(&mut self, x: f64, y: f64, size: f64, fit: f64, t: &str) {
        let est = 0.6 * size * t.chars().count() as f64;
        let size = if est > fit {
            (size * fit / est).max(7.0)
        } else {
            size
        };
        let _ = write!(
            self.svg,
            r#"<text x="{x:.1}" y="{y:.1}" font-size="{size:.1}" text-anchor="middle">{}</text>"#,
            plot::escape(t)
        );
    }

    /// A caption block whose band starts at `top`, one line per `\n`.
    fn caption(&mut self, x: f64, top: u32, fit: f64, t: &str) {
        for (k, line) in (0u32..).zip(t.lines()) {
            let y = f64::from(top + CAPTION_PAD + k * LINE_H) + 12.0;
            self.line(x, y, 12.0, fit, line);
        }
    }

    /// Renders the text onto `canvas` (opaque, so premultiplied RGBA is
    /// plain RGBA).
    fn render_onto(mut self, canvas: &mut Canvas) -> Result<()> {
        use resvg::tiny_skia::{IntSize, Pixmap, Transform};
        self.svg.push_str("</svg>\n");
        let tree = resvg::usvg::Tree::from_str(&self.svg, plot::font_options())
            .context("parsing the figure's text SVG")?;
        let size = IntSize::from_wh(canvas.width, canvas.height)
            .ok_or_else(|| anyhow!("figure of {}×{}", canvas.width, canvas.height))?;
        let mut pixmap = Pixmap::from_vec(std::mem::take(&mut canvas.data), size)
            .ok_or_else(|| anyhow!("figure canvas of the wrong size"))?;
        resvg::render(&tree, Transform::default(), &mut pixmap.as_mut());
        canvas.data = pixmap.take();
        Ok(())
    }
}

#[cfg(test)]
mod tests;
