//! A hand-written SVG log–log line plot: decade grid lines with labels,
//! one polyline with markers per series (optional vertical error bars and
//! a text label per point), a legend; and its PNG raster
//! ([`svg_to_png`], resvg with an embedded font, so the PNG looks the same
//! on a machine without system fonts).

use anyhow::{anyhow, Context, Result};
use std::fmt::Write;
use std::sync::OnceLock;

/// One line of the plot: a name, an SVG colour and (x, y) points (x, y > 0;
/// others are dropped), each with an optional error bar [lo, hi] in y
/// (`errors`: empty, or one per point) and label (`labels`: empty, or one
/// per point, drawn beside the marker).
#[derive(Default)]
pub struct Series<'a> {
    pub name: &'a str,
    pub colour: &'a str,
    pub points: Vec<(f64, f64)>,
    pub errors: Vec<[f64; 2]>,
    pub labels: Vec<String>,
}

/// A drawable point: its position, error bar and label.
struct Point<'s> {
    x: f64,
    y: f64,
    error: Option<[f64; 2]>,
    label: Option<&'s str>,
}

fn drawable(x: f64, y: f64) -> bool {
    x > 0.0 && y > 0.0 && x.is_finite() && y.is_finite()
}

impl Series<'_> {
    /// The drawable points (error bars cut to their positive, finite part).
    fn drawn(&self) -> Vec<Point<'_>> {
        (0..self.points.len())
            .filter(|&i| drawable(self.points[i].0, self.points[i].1))
            .map(|i| {
                let (x, y) = self.points[i];
                let error = self.errors.get(i).map(|&[lo, hi]| {
                    let lo = if lo > 0.0 && lo.is_finite() {
                        lo.min(y)
                    } else {
                        y
                    };
                    let hi = if hi.is_finite() { hi.max(y) } else { y };
                    [lo, hi]
                });
                Point {
                    x,
                    y,
                    error,
                    label: self.labels.get(i).map(String::as_str),
                }
            })
            .collect()
    }
}

const W: f64 = 720.0;
const H: f64 = 480.0;
const LEFT: f64 = 80.0;
const RIGHT: f64 = 20.0;
const TOP: f64 = 40.0;
const BOTTOM: f64 = 60.0;

/// Decades spanning [lo, hi] (at least one).
fn decades(lo: f64, hi: f64) -> (i32, i32) {
    let a = lo.log10().floor() as i32;
    let b = (hi.log10().ceil() as i32).max(a + 1);
    (a, b)
}

fn label(e: i32) -> String {
    if (-3..=4).contains(&e) {
        format!("{}", 10f64.powi(e))
    } else {
        format!("1e{e}")
    }
}

/// The SVG document.
pub fn loglog_svg(title: &str, x_label: &str, y_label: &str, series: &[Series]) -> String {
    let drawn: Vec<Vec<Point>> = series.iter().map(Series::drawn).collect();
    let pts: Vec<(f64, f64)> = drawn
        .iter()
        .flatten()
        .flat_map(|p| {
            let [lo, hi] = p.error.unwrap_or([p.y, p.y]);
            [(p.x, lo), (p.x, hi)]
        })
        .collect();
    let (xmin, xmax) = pts
        .iter()
        .fold((f64::MAX, f64::MIN), |(a, b), p| (a.min(p.0), b.max(p.0)));
    let (ymin, ymax) = pts
        .iter()
        .fold((f64::MAX, f64::MIN), |(a, b), p| (a.min(p.1), b.max(p.1)));
    let ((x0, x1), (y0, y1)) = if pts.is_empty() {
        ((0, 1), (0, 1))
    } else {
        (decades(xmin, xmax), decades(ymin, ymax))
    };
    let (pw, ph) = (W - LEFT - RIGHT, H - TOP - BOTTOM);
    let sx = |x: f64| LEFT + (x.log10() - x0 as f64) / (x1 - x0) as f64 * pw;
    let sy = |y: f64| TOP + ph - (y.log10() - y0 as f64) / (y1 - y0) as f64 * ph;
    let mut s = String::new();
    let _ = writeln!(
        s,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{W}" height="{H}" viewBox="0 0 {W} {H}" font-family="sans-serif" font-size="12">"#
    );
    let _ = writeln!(s, r#"<rect width="{W}" height="{H}" fill="white"/>"#);
    let _ = writeln!(
        s,
        r#"<text x="{}" y="24" text-anchor="middle" font-size="15">{}</text>"#,
        W / 2.0,
        escape(title)
    );
    for e in x0..=x1 {
        let x = sx(10f64.powi(e));
        let _ = writeln!(
            s,
            r##"<line x1="{x:.1}" y1="{TOP}" x2="{x:.1}" y2="{:.1}" stroke="#ddd"/><text x="{x:.1}" y="{:.1}" text-anchor="middle">{}</text>"##,
            TOP + ph,
            TOP + ph + 18.0,
            label(e)
        );
    }
    for e in y0..=y1 {
        let y = sy(10f64.powi(e));
        let _ = writeln!(
            s,
            r##"<line x1="{LEFT}" y1="{y:.1}" x2="{:.1}" y2="{y:.1}" stroke="#ddd"/><text x="{:.1}" y="{:.1}" text-anchor="end">{}</text>"##,
            LEFT + pw,
            LEFT - 6.0,
            y + 4.0,
            label(e)
        );
    }
    let _ = writeln!(
        s,
        r#"<rect x="{LEFT}" y="{TOP}" width="{pw}" height="{ph}" fill="none" stroke="black"/>"#
    );
    let _ = writeln!(
        s,
        r#"<text x="{:.1}" y="{:.1}" text-anchor="middle">{}</text>"#,
        LEFT + pw / 2.0,
        H - 16.0,
        escape(x_label)
    );
    let _ = writeln!(
        s,
        r#"<text x="18" y="{:.1}" text-anchor="middle" transform="rotate(-90 18 {:.1})">{}</text>"#,
        TOP + ph / 2.0,
        TOP + ph / 2.0,
        escape(y_label)
    );
    for (i, (ser, points)) in series.iter().zip(&drawn).enumerate() {
        let p: Vec<(f64, f64)> = points.iter().map(|p| (sx(p.x), sy(p.y))).collect();
        for (point, (x, _)) in points.iter().zip(&p) {
            if let Some([lo, hi]) = point.error {
                let (y0, y1) = (sy(lo), sy(hi));
                let _ = writeln!(
                    s,
                    r#"<path d="M{x:.1},{y0:.1}V{y1:.1}M{:.1},{y0:.1}h8M{:.1},{y1:.1}h8" stroke="{}" stroke-width="1.2" fill="none"/>"#,
                    x - 4.0,
                    x - 4.0,
                    ser.colour
                );
            }
        }
        let path: Vec<String> = p.iter().map(|(x, y)| format!("{x:.1},{y:.1}")).collect();
        let _ = writeln!(
            s,
            r#"<polyline points="{}" fill="none" stroke="{}" stroke-width="2"/>"#,
            path.join(" "),
            ser.colour
        );
        for (point, (x, y)) in points.iter().zip(&p) {
            let _ = writeln!(
                s,
                r#"<circle cx="{x:.1}" cy="{y:.1}" r="3.5" fill="{}"/>"#,
                ser.colour
            );
            if let Some(label) = point.label {
                let _ = writeln!(
                    s,
                    r#"<text x="{:.1}" y="{:.1}" font-size="10" fill="{}">{}</text>"#,
                    x + 6.0,
                    y - 6.0,
                    ser.colour,
                    escape(label)
                );
            }
        }
        let ly = TOP + 18.0 + 18.0 * i as f64;
        let lx = LEFT + pw - 130.0;
        let _ = writeln!(
            s,
            r#"<line x1="{lx:.1}" y1="{ly:.1}" x2="{:.1}" y2="{ly:.1}" stroke="{}" stroke-width="2"/><text x="{:.1}" y="{:.1}">{}</text>"#,
            lx + 24.0,
            ser.colour,
            lx + 30.0,
            ly + 4.0,
            escape(ser.name)
        );
    }
    s.push_str("</svg>\n");
    s
}

/// The font of every rasterized label: DejaVu Sans, shipped in the repository
/// (`assets/fonts/`, Bitstream Vera licence) and embedded in the binary,
/// loaded once per process. Also used by the compare figure.
pub(crate) const FONT: &[u8] = include_bytes!("../../assets/fonts/DejaVuSans.ttf");

/// usvg options whose sans-serif (and default) family is [`FONT`].
pub(crate) fn font_options() -> &'static resvg::usvg::Options<'static> {
    static OPTIONS: OnceLock<resvg::usvg::Options<'static>> = OnceLock::new();
    OPTIONS.get_or_init(|| {
        let mut options = resvg::usvg::Options::default();
        let db = options.fontdb_mut();
        db.load_font_data(FONT.to_vec());
        let family = db
            .faces()
            .next()
            .and_then(|f| f.families.first())
            .map(|(name, _)| name.clone());
        if let Some(family) = family {
            db.set_sans_serif_family(family.clone());
            options.font_family = family;
        }
        options
    })
}

/// Rasterizes an SVG document (as written by [`loglog_svg`]) to PNG bytes
/// at its own size.
pub fn svg_to_png(svg: &str) -> Result<Vec<u8>> {
    let tree = resvg::usvg::Tree::from_str(svg, font_options()).context("parsing the plot SVG")?;
    let size = tree.size().to_int_size();
    let mut pixmap = resvg::tiny_skia::Pixmap::new(size.width(), size.height())
        .ok_or_else(|| anyhow!("plot of size {}×{}", size.width(), size.height()))?;
    resvg::render(
        &tree,
        resvg::tiny_skia::Transform::default(),
        &mut pixmap.as_mut(),
    );
    pixmap.encode_png().context("encoding the plot PNG")
}

/// Text for an SVG document (the plots' and the figure's labels): the
/// markup characters escaped, and every character XML 1.0 does not allow
/// (the controls but tab, line feed and carriage return; U+FFFE, U+FFFF)
/// replaced by U+FFFD. A control character in a scene's file name made
/// the figure's SVG unparsable after the reference had been rendered
/// (issue 67, hostile inputs class 3).
pub(super) fn escape(t: &str) -> String {
    let mut out = String::with_capacity(t.len());
    for c in t.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '\t' | '\n' | '\r' => out.push(c),
            c if c < ' ' || c == '\u{fffe}' || c == '\u{ffff}' => out.push('\u{fffd}'),
            c => out.push(c),
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Issue 67, hostile inputs class 3: any text, control characters
    /// included, makes an SVG that parses.
    #[test]
    fn escaped_text_always_parses() {
        let t = "scene\u{1}\u{1f}<&>\u{ffff} \u{65e5}\t.toml";
        let e = escape(t);
        assert_eq!(
            e,
            "scene\u{fffd}\u{fffd}&lt;&amp;&gt;\u{fffd} \u{65e5}\t.toml"
        );
        let svg = format!(
            r#"<svg xmlns="http://www.w3.org/2000/svg" width="10" height="10"><text x="1" y="9">{e}</text></svg>"#
        );
        assert!(resvg::usvg::Tree::from_str(&svg, font_options()).is_ok());
        let raw = format!(
            r#"<svg xmlns="http://www.w3.org/2000/svg" width="10" height="10"><text x="1" y="9">{}</text></svg>"#,
            "a\u{1}b"
        );
        assert!(
            resvg::usvg::Tree::from_str(&raw, font_options()).is_err(),
            "the control character itself is refused (the test's premise)"
        );
    }

    #[test]
    fn svg_has_series_and_decades() {
        let svg = loglog_svg(
            "t",
            "time (ms)",
            "RelMSE",
            &[Series {
                name: "a<b",
                colour: "red",
                points: vec![(1.0, 0.1), (10.0, 0.01), (0.0, 1.0)],
                errors: vec![[0.05, 0.2], [0.005, 0.02], [0.5, 2.0]],
                labels: vec!["1 spp".into(), "10 spp".into(), "dropped".into()],
            }],
        );
        assert!(svg.starts_with("<svg") && svg.trim_end().ends_with("</svg>"));
        assert_eq!(svg.matches("<circle").count(), 2);
        assert!(svg.contains("a&lt;b"));
        // One error bar and one label per drawn point; the dropped point
        // (x = 0) has neither.
        assert_eq!(svg.matches("stroke-width=\"1.2\"").count(), 2);
        assert!(svg.contains(">1 spp<") && svg.contains(">10 spp<"));
        assert!(!svg.contains("dropped"));
        assert_eq!(decades(1.0, 10.0), (0, 1));
        assert_eq!(decades(0.02, 3.0), (-2, 1));
    }

    /// The PNG has the SVG's size, a white background, the series colour
    /// on its polyline and dark pixels of rasterized text (the embedded
    /// font is found: without it the labels would be missing).
    #[test]
    fn png_raster_of_the_plot() {
        let svg = loglog_svg(
            "title",
            "x",
            "y",
            &[Series {
                name: "s",
                colour: "#ff0000",
                points: vec![(1.0, 1.0), (100.0, 0.01)],
                ..Series::default()
            }],
        );
        let png = svg_to_png(&svg).unwrap();
        let img = image::load_from_memory(&png).unwrap().to_rgba8();
        assert_eq!((img.width(), img.height()), (W as u32, H as u32));
        assert_eq!(img.get_pixel(2, 2).0, [255, 255, 255, 255]);
        let red = img
            .pixels()
            .filter(|p| p[0] > 200 && p[1] < 60 && p[2] < 60)
            .count();
        assert!(red > 200, "{red} red pixels");
        // Title text: dark pixels in the band above the plot frame.
        let title_ink = (0..W as u32)
            .flat_map(|x| (8..30).map(move |y| (x, y)))
            .filter(|&(x, y)| img.get_pixel(x, y)[0] < 128)
            .count();
        assert!(title_ink > 20, "{title_ink} title pixels");
    }
}
