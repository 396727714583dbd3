//! Tests of the compare figure (CPU only).

use super::*;

/// Films and maps of a `w`×`h` film: a grey gradient reference, MDAS and
/// Halton slightly off it, RelMSE maps that differ in one block at
/// (`w`/2, `h`/4), a density map with a NaN.
struct Films {
    w: u32,
    h: u32,
    images: Vec<Vec<[f32; 3]>>,
    maps: Vec<Vec<f32>>,
}

fn films(w: u32, h: u32) -> Films {
    let n = (w * h) as usize;
    let grey = |k: usize, f: f32| {
        let v = (k % w as usize) as f32 / w as f32 * f;
        [v, v * 0.5, 0.25]
    };
    let reference: Vec<[f32; 3]> = (0..n).map(|k| grey(k, 1.0)).collect();
    let mdas: Vec<[f32; 3]> = (0..n).map(|k| grey(k, 0.9)).collect();
    let halton: Vec<[f32; 3]> = (0..n).map(|k| grey(k, 0.8)).collect();
    let a = vec![1e-3f32; n];
    let mut b = a.clone();
    let s = default_inset_size(w, h);
    for y in h / 4..h / 4 + s {
        for x in w / 2..w / 2 + s {
            b[(y * w + x) as usize] = 0.5;
        }
    }
    let mut density: Vec<f32> = (0..n).map(|k| 2.0 + (k % 7) as f32 * 100.0).collect();
    density[n - 1] = f32::NAN;
    Films {
        w,
        h,
        images: vec![reference, mdas, halton],
        maps: vec![a, b, density],
    }
}

fn input<'a>(f: &'a Films, crops: Vec<Crop>) -> FigureInput<'a> {
    let image = |i: usize, label: &'a str| ImagePanel {
        label,
        pixels: &f.images[i],
        caption: format!("{label} 8.0 spp · RelMSE 1.23e-3 [1.10e-3, 1.37e-3]"),
    };
    FigureInput {
        width: f.w,
        height: f.h,
        title: format!("test scene · {}×{} · equal time 1.00", f.w, f.h),
        images: vec![image(0, "Reference"), image(1, "MDAS"), image(2, "Halton")],
        maps: vec![
            MapPanel {
                label: "RelMSE MDAS",
                values: &f.maps[0],
                range: heatmap::RELMSE_RANGE,
                unit: "RelMSE",
                caption: "mean 1.0e-3".into(),
            },
            MapPanel {
                label: "RelMSE Halton",
                values: &f.maps[1],
                range: heatmap::RELMSE_RANGE,
                unit: "RelMSE",
                caption: "mean 2.0e-3".into(),
            },
            MapPanel {
                label: "MDAS density",
                values: &f.maps[2],
                range: (2.0, 602.0),
                unit: "spp",
                caption: "8.0 spp mean\n75% adaptive".into(),
            },
        ],
        crops,
    }
}

/// The figure size from the layout rules, written out: columns of
/// max(panel, 384) px; one caption line in row 1, two in row 2; two
/// insets side by side in square slots.
fn predicted(pw: u32, ph: u32) -> (u32, u32) {
    let col = pw.max(MIN_PANEL);
    let slot = (col - 8) / 2;
    let width = 16 + col + 16 + col + 16 + col + 16;
    let height = 16
        + 34
        + 22
        + ph
        + (4 + 16)
        + 8
        + (slot + 8)
        + 12
        + 22
        + ph
        + 8
        + 14
        + 4
        + 30
        + (4 + 2 * 16)
        + 16;
    (width, height)
}

/// 32×32 is upscaled ×12 to 384 px panels and 200×100 ×2 to 400×200; the
/// PNG written has the predicted size.
#[test]
fn figure_size_32x32_and_200x100() {
    let dir = std::env::temp_dir().join(format!("mdas-figure-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    for (w, h, up, panel) in [(32, 32, 12, (384, 384)), (200, 100, 2, (400, 200))] {
        let f = films(w, h);
        let path = dir.join(format!("figure-{w}x{h}.png"));
        let info = write_figure(&path, &input(&f, Vec::new())).unwrap();
        assert_eq!((info.upscale, info.downscale, info.panel), (up, 1, panel));
        assert_eq!((info.width, info.height), predicted(panel.0, panel.1));
        let png = image::open(&path).unwrap();
        assert_eq!((png.width(), png.height()), (info.width, info.height));
        assert_eq!(info.crops.len(), 2);
        assert_eq!(info.panel_rects.len(), 6);
        assert_eq!(info.inset_rects.len(), 6);
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Three colour bars: their left ends are viridis(0), right ends
/// viridis(1), framed, with ticks below; text is rasterized (the
/// embedded font is found); NaN in a map is magenta.
#[test]
fn colour_bars_text_and_nan() {
    let f = films(32, 32);
    let (img, info) = render_figure(&input(&f, Vec::new())).unwrap();
    assert_eq!(info.colour_bars, 3);
    assert_eq!(info.bar_rects.len(), 3);
    for bar in &info.bar_rects {
        let y = bar.y + bar.h / 2;
        assert_eq!(img.get_pixel(bar.x, y).0, heatmap::viridis(0.0));
        assert_eq!(img.get_pixel(bar.x + bar.w - 1, y).0, heatmap::viridis(1.0));
        let mid = img.get_pixel(bar.x + bar.w / 2, y).0;
        let t = (bar.w / 2) as f32 / (bar.w - 1) as f32;
        assert_eq!(mid, heatmap::viridis(t), "{bar:?}");
        assert_eq!(img.get_pixel(bar.x - 1, y).0, FRAME);
        // Tick under the left end (a decade of RelMSE, the density's min).
        assert_eq!(img.get_pixel(bar.x, bar.y + bar.h + 1).0, INK);
        // Tick labels: ink in the band under the ticks.
        let ink = (bar.x..bar.x + bar.w)
            .flat_map(|x| (bar.y + bar.h + TICK..bar.y + bar.h + TICK + 14).map(move |y| (x, y)))
            .filter(|&(x, y)| img.get_pixel(x, y)[0] < 128)
            .count();
        assert!(ink > 40, "{ink} label pixels");
    }
    let title_ink = (0..info.width)
        .flat_map(|x| (MARGIN..MARGIN + 30).map(move |y| (x, y)))
        .filter(|&(x, y)| img.get_pixel(x, y)[0] < 128)
        .count();
    assert!(title_ink > 100, "{title_ink} title pixels");
    // Density panel (row 2, column 3): the last film pixel is NaN, drawn
    // magenta (the crops, (16, 8) and (0, 0), are elsewhere).
    let d = info.panel_rects[5];
    let corner = |r: Crop| (r.x + r.w - 5, r.y + r.h - 5);
    let (x, y) = corner(d);
    assert_eq!(img.get_pixel(x, y).0, [255, 0, 255]);
    // RelMSE panel: 1e-3 on the log range.
    let (x, y) = corner(info.panel_rects[3]);
    let c = heatmap::viridis(heatmap::log_position(1e-3, heatmap::RELMSE_RANGE));
    assert_eq!(img.get_pixel(x, y).0, c);
}

/// Automatic insets find the block where the RelMSE maps differ; it is
/// outlined in the first colour on the panels; the inset shows the film's
/// pixels tone-mapped like our PNGs.
#[test]
fn insets_at_the_differing_block() {
    let f = films(32, 32);
    let (img, info) = render_figure(&input(&f, Vec::new())).unwrap();
    assert_eq!(
        info.crops[0],
        Crop {
            x: 16,
            y: 8,
            w: 8,
            h: 8
        }
    );
    assert!(!info.crops[0].overlaps(&info.crops[1]));
    // Outline just outside the crop on the reference panel: 12× upscale.
    let p = info.panel_rects[0];
    let (ox, oy) = (p.x + 16 * 12 - 1, p.y + 8 * 12 + 20);
    assert_eq!(img.get_pixel(ox, oy).0, CROP_COLOURS[0]);
    assert_eq!(img.get_pixel(ox + 1, oy).0, {
        let px = f.images[0][(9 * 32 + 16) as usize];
        px.map(image_io::linear_to_srgb8)
    });
    // Inset 0 of the MDAS image: 8×8 film pixels into a 188-px slot (184
    // inside the frame) → ×23.
    let r = info.inset_rects[2];
    assert_eq!((r.w, r.h), (8 * 23, 8 * 23));
    for (fx, fy) in [(16, 8), (23, 15), (19, 12)] {
        let want = f.images[1][fy * 32 + fx].map(image_io::linear_to_srgb8);
        let (x, y) = (
            r.x + (fx as u32 - 16) * 23 + 11,
            r.y + (fy as u32 - 8) * 23 + 11,
        );
        assert_eq!(img.get_pixel(x, y).0, want, "film pixel ({fx}, {fy})");
    }
    assert_eq!(img.get_pixel(r.x - 1, r.y + 5).0, CROP_COLOURS[0]);
    assert_eq!(
        img.get_pixel(info.inset_rects[3].x - 1, info.inset_rects[3].y)
            .0,
        CROP_COLOURS[1]
    );
}

/// User crops: used as given (three of them: two rows of insets); a crop
/// outside the film, too many crops and wrong sizes are errors naming
/// what is wrong.
#[test]
fn user_crops_and_bad_inputs() {
    let f = films(64, 48);
    let crops = vec![
        Crop {
            x: 0,
            y: 0,
            w: 10,
            h: 20,
        },
        Crop {
            x: 50,
            y: 40,
            w: 14,
            h: 8,
        },
        Crop {
            x: 30,
            y: 5,
            w: 1,
            h: 1,
        },
    ];
    let (img, info) = render_figure(&input(&f, crops.clone())).unwrap();
    assert_eq!(info.crops, crops);
    assert_eq!(info.inset_rects.len(), 9);
    assert_eq!((img.width(), img.height()), (info.width, info.height));
    // Third inset is on a second row of slots.
    assert!(info.inset_rects[2].y > info.inset_rects[0].y + info.inset_rects[0].h);

    let bad = vec![Crop {
        x: 60,
        y: 0,
        w: 8,
        h: 8,
    }];
    let e = format!("{:#}", render_figure(&input(&f, bad)).unwrap_err());
    assert!(
        e.contains("crop 60,0,8,8") && e.contains("64×48 film"),
        "{e}"
    );
    let e = format!(
        "{:#}",
        render_figure(&input(&f, vec![crops[0]; 7])).unwrap_err()
    );
    assert!(e.contains("7 crops"), "{e}");
    let mut i = input(&f, Vec::new());
    i.width = 63;
    let e = render_figure(&i).unwrap_err().to_string();
    assert!(e.contains("Reference") && e.contains("63×48"), "{e}");
    let mut i = input(&f, Vec::new());
    i.maps[2].range = (0.0, 1.0);
    assert!(render_figure(&i).is_err());
    // As many maps as images, at least three of each.
    let mut i = input(&f, Vec::new());
    i.maps.pop();
    let e = render_figure(&i).unwrap_err().to_string();
    assert!(e.contains("3 images and 2 maps"), "{e}");
    let mut i = input(&f, Vec::new());
    i.images.pop();
    i.maps.pop();
    let e = render_figure(&i).unwrap_err().to_string();
    assert!(e.contains("at least 3"), "{e}");
}

/// A fourth method (pixel-adaptive Halton in `compare`) adds a column:
/// one more column of the same width and gap, its image with its insets,
/// its map with its colour bar; the height is unchanged.
#[test]
fn four_columns() {
    let mut f = films(32, 32);
    let n = 32 * 32;
    f.images
        .push((0..n).map(|k| [(k % 32) as f32 / 40.0, 0.1, 0.2]).collect());
    f.maps.insert(2, vec![2e-3f32; n]);
    let mut i = input(&f, Vec::new());
    i.images.push(ImagePanel {
        label: "Adaptive",
        pixels: &f.images[3],
        caption: "Adaptive 8.0 spp".into(),
    });
    i.maps.insert(
        2,
        MapPanel {
            label: "RelMSE Adaptive",
            values: &f.maps[2],
            range: heatmap::RELMSE_RANGE,
            unit: "RelMSE",
            caption: "mean 2.0e-3".into(),
        },
    );
    // input() points its third map at f.maps[2], now adaptive's: point it
    // back at the density.
    i.maps[3].values = &f.maps[3];
    let (img, info) = render_figure(&i).unwrap();
    let (w3, h3) = predicted(384, 384);
    assert_eq!((info.width, info.height), (w3 + 384 + GAP, h3));
    assert_eq!((img.width(), img.height()), (info.width, info.height));
    assert_eq!(info.panel_rects.len(), 8);
    assert_eq!(info.inset_rects.len(), 8);
    assert_eq!(info.colour_bars, 4);
    // The fourth image's panel sits in the fourth column and shows it.
    let p = info.panel_rects[3];
    assert_eq!(p.x, MARGIN + 3 * (384 + GAP));
    let want = f.images[3][5 * 32 + 20].map(image_io::linear_to_srgb8);
    assert_eq!(img.get_pixel(p.x + 20 * 12 + 6, p.y + 5 * 12 + 6).0, want);
}

/// A 2048×1024 film is box-downscaled by 2 to 1024×512 panels; insets
/// keep the film's own resolution.
#[test]
fn large_film_is_downscaled_within_the_cap() {
    assert_eq!(panel_scale(2048, 1024), (1, 2));
    assert_eq!(panel_scale(1024, 1024), (1, 1));
    assert_eq!(panel_scale(1025, 10), (1, 2));
    assert_eq!(panel_scale(10, 1000), (1, 1));
    assert_eq!(panel_scale(300, 300), (2, 1));
    let f = films(2048, 1024);
    let (img, info) = render_figure(&input(&f, Vec::new())).unwrap();
    assert_eq!(
        (info.upscale, info.downscale, info.panel),
        (1, 2, (1024, 512))
    );
    assert!(info.panel.0 <= MAX_PANEL && info.panel.1 <= MAX_PANEL);
    assert_eq!((img.width(), img.height()), predicted(1024, 512));
    // Box mean of two neighbouring film columns (rows are alike), then
    // tone-mapped; away from the crops ((1024, 256) and (0, 0), 170 px).
    let p = info.panel_rects[0];
    let want = {
        let a = f.images[0][10];
        let b = f.images[0][11];
        [0, 1, 2].map(|c| image_io::linear_to_srgb8((a[c] + b[c]) / 2.0))
    };
    assert_eq!(img.get_pixel(p.x + 5, p.y + 300).0, want);
    // Insets of the default size (1024 / 6 = 170 film px) at the film's
    // resolution, zoomed ×2 into a 508-px slot (504 inside the frame).
    assert_eq!(info.crops[0].w, 170);
    assert_eq!(info.inset_rects[0].w, 170 * 2);
}

#[test]
fn ticks_of_the_colour_bars() {
    let t = bar_ticks(heatmap::RELMSE_RANGE, 0.08);
    let labels: Vec<&str> = t.iter().map(|(_, l)| l.as_str()).collect();
    assert_eq!(
        labels,
        ["1e-6", "1e-5", "1e-4", "1e-3", "1e-2", "1e-1", "1", "10"]
    );
    assert!(t[0].0.abs() < 1e-9);
    assert!((t[7].0 - 1.0).abs() < 1e-9);
    let t = bar_ticks((2.31, 1024.0), 0.08);
    let labels: Vec<&str> = t.iter().map(|(_, l)| l.as_str()).collect();
    assert_eq!(labels, ["2.31", "10", "100", "1024"]);
    assert_eq!(format_value(0.5), "0.5");
    assert_eq!(format_value(2.0), "2");
    assert_eq!(format_value(12.34), "12.3");
    assert_eq!(format_value(1024.0), "1024");
    assert_eq!(format_value(2.5e6), "2.50e6");
}
