//! The page writer on synthetic output directories, one per record kind:
//! what it embeds decodes to what the files hold (images within half
//! precision, maps and plot byte for byte, the record as parsed), and a
//! directory it cannot show is refused with nothing written.

use super::encode::unbase64;
use super::*;
use half::f16;
use std::path::PathBuf;

fn scratch(tag: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("mdas-viewer-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// A film of `w`×`h` with values across the half range: zero, a
/// subnormal half, ordinary values, one above the largest half, NaN.
fn pixels(w: u32, h: u32, seed: f32) -> Vec<[f32; 3]> {
    (0..w * h)
        .map(|i| {
            let t = i as f32 + seed;
            match i % 7 {
                0 => [0.0, 1e-7 * (1.0 + seed), 3e-5],
                1 => [1.0, 0.5, 0.25],
                2 => [70000.0, 2.0 + seed, 1e-3],
                3 => [f32::NAN, 0.1, 0.9],
                _ => [0.01 * t, 0.37 * t.sin().abs(), 12.5 / (1.0 + t)],
            }
        })
        .collect()
}

/// The text of the element `<script ... id="ID">`.
fn element<'a>(html: &'a str, id: &str) -> &'a str {
    let open = format!("id=\"{id}\">");
    let start = html.find(&open).unwrap_or_else(|| panic!("no #{id}")) + open.len();
    let end = start + html[start..].find("</script>").unwrap();
    &html[start..end]
}

fn json_of(html: &str, id: &str) -> Value {
    serde_json::from_str(element(html, id)).unwrap()
}

/// Decodes `#mdas-image-N` and checks it against `want` within half
/// precision (relative 2⁻¹¹ for normal halves, 2⁻²⁵ absolute below,
/// +∞ above 65504, NaN kept).
fn check_image(html: &str, index: usize, want: &[[f32; 3]]) {
    let bytes = unbase64(element(html, &format!("mdas-image-{index}")));
    assert_eq!(bytes.len(), want.len() * 6);
    for (i, p) in want.iter().enumerate() {
        for (c, &v) in p.iter().enumerate() {
            let k = 6 * i + 2 * c;
            let got = f16::from_bits(u16::from_le_bytes([bytes[k], bytes[k + 1]])).to_f32();
            if v.is_nan() {
                assert!(got.is_nan(), "pixel {i} channel {c}: {got} for NaN");
            } else if v > 65504.0 {
                assert_eq!(got, f32::INFINITY);
            } else {
                let bound = (v.abs() * 2f32.powi(-11)).max(2f32.powi(-25));
                assert!(
                    (got - v).abs() <= bound,
                    "pixel {i} channel {c}: {got} for {v}"
                );
            }
        }
    }
}

fn write_json(path: &Path, value: &Value) {
    std::fs::write(path, serde_json::to_string_pretty(value).unwrap()).unwrap();
}

/// A `compare` directory: reference, MDAS and Halton images, their maps.
fn compare_dir(tag: &str, w: u32, h: u32) -> (PathBuf, Vec<Vec<[f32; 3]>>) {
    let dir = scratch(tag);
    let images: Vec<_> = (0..3).map(|k| pixels(w, h, k as f32)).collect();
    for (name, px) in ["reference", "mdas", "halton"].iter().zip(&images) {
        image_io::write_exr(&dir.join(format!("{name}.exr")), w, h, px).unwrap();
    }
    let grey = vec![[0.5; 3]; (w * h) as usize];
    for map in [
        "relmse-mdas",
        "relmse-halton",
        "flip-mdas",
        "flip-halton",
        "density-mdas",
    ] {
        image_io::write_png(&dir.join(format!("{map}.png")), w, h, &grey).unwrap();
    }
    let mut files = serde_json::Map::new();
    for name in ["reference", "mdas", "halton"] {
        files.insert(name.into(), json!(format!("{name}.exr")));
    }
    for map in [
        "relmse-mdas",
        "relmse-halton",
        "flip-mdas",
        "flip-halton",
        "density-mdas",
    ] {
        files.insert(map.replace('-', "_") + "_png", json!(format!("{map}.png")));
    }
    write_json(
        &dir.join("report.json"),
        &json!({
            "scene": "scenes/<cornell>.toml",
            "scale": 0.25,
            "film": {"width": w, "height": h},
            "version": "0.1.0",
            "reference": {"spp": 4096, "path": "x.exr", "cached": true},
            "methods": [
                {"name": "mdas", "spp": 8.0, "relmse": 1e-3, "relmse_ci95": [5e-4, 2e-3],
                 "image_flip": 0.02, "time_ms": {"total": 58.0}, "image": "mdas.exr"},
                {"name": "halton", "spp": 14.0, "relmse": 5e-4, "relmse_ci95": [1e-4, 8e-4],
                 "image_flip": 0.01, "time_ms": {"total": 55.0}, "image": "halton.exr"}
            ],
            "equal_time": {"mode": "mdas", "relmse_ratio": 2.0, "relmse_ratio_ci95": [1.5, 3.0]},
            "maps": {"relmse_range": [1e-6, 10.0], "flip_range": [0.0, 1.0], "density_range": [6.0, 16.0]},
            "files": files,
            "provenance": {"command_line": ["mdas", "compare"], "version": "0.1.0"}
        }),
    );
    (dir, images)
}

#[test]
fn a_comparison_page_carries_every_image_map_and_the_record() {
    let (dir, images) = compare_dir("compare", 5, 3);
    assert_eq!(write_page(&dir).unwrap(), Kind::Compare);
    let html = std::fs::read_to_string(dir.join(PAGE)).unwrap();
    assert!(!html.contains("<!--mdas:"), "a slot was left unfilled");
    // The scene name is escaped in the title and in the record.
    assert!(html.contains("<title>scenes/&lt;cornell&gt;.toml · compare</title>"));
    let record: Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("report.json")).unwrap()).unwrap();
    assert_eq!(json_of(&html, "mdas-record"), record);

    let page = json_of(&html, "mdas-page");
    assert_eq!(page["kind"], "compare");
    assert_eq!(page["film"], json!([5, 3]));
    let labels: Vec<&str> = page["images"]
        .as_array()
        .unwrap()
        .iter()
        .map(|i| i["label"].as_str().unwrap())
        .collect();
    assert_eq!(labels, ["reference", "mdas", "halton"]);
    assert_eq!(page["images"][0]["method"], Value::Null);
    assert_eq!(page["images"][2]["method"], 1);
    for (i, want) in images.iter().enumerate() {
        check_image(&html, i, want);
    }
    // Maps: per method, none for the reference; density for MDAS only.
    let maps: Vec<(u64, &str)> = page["maps"]
        .as_array()
        .unwrap()
        .iter()
        .map(|m| (m["image"].as_u64().unwrap(), m["layer"].as_str().unwrap()))
        .collect();
    assert_eq!(
        maps,
        [
            (1, "relmse"),
            (1, "flip"),
            (1, "density"),
            (2, "relmse"),
            (2, "flip")
        ]
    );
    for (j, m) in page["maps"].as_array().unwrap().iter().enumerate() {
        let png = std::fs::read(dir.join(m["file"].as_str().unwrap())).unwrap();
        assert_eq!(unbase64(element(&html, &format!("mdas-map-{j}"))), png);
    }
    // Written again over itself, the page is the same.
    write_page(&dir).unwrap();
    assert_eq!(std::fs::read_to_string(dir.join(PAGE)).unwrap(), html);
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_samplers_page_finds_its_images_by_the_method_names() {
    let dir = scratch("samplers");
    let (w, h) = (4, 2);
    let names = ["reference", "mdas-tree", "halton-uniform", "halton-tree"];
    let images: Vec<_> = (0..4).map(|k| pixels(w, h, k as f32)).collect();
    for (name, px) in names.iter().zip(&images) {
        image_io::write_exr(&dir.join(format!("{name}.exr")), w, h, px).unwrap();
    }
    for name in &names[1..] {
        image_io::write_png(&dir.join(format!("relmse-{name}.png")), w, h, &images[0]).unwrap();
    }
    // No `files` list: the maps are found beside the images.
    write_json(
        &dir.join("report.json"),
        &json!({
            "scene": "s.toml", "scale": 1.0, "film": {"width": w, "height": h},
            "reference": {"spp": 64},
            "methods": [
                {"name": "mdas+tree", "image": "mdas-tree.exr"},
                {"name": "halton+uniform", "image": "halton-uniform.exr"},
                {"name": "halton+tree", "image": "halton-tree.exr"}
            ],
            "equal_time": {"samplers": [{"sampler": "uniform", "method": "halton+uniform"}]},
            "maps": {"relmse_range": [1e-6, 10.0]}
        }),
    );
    assert_eq!(write_page(&dir).unwrap(), Kind::Samplers);
    let html = std::fs::read_to_string(dir.join(PAGE)).unwrap();
    let page = json_of(&html, "mdas-page");
    assert_eq!(page["kind"], "samplers");
    assert_eq!(page["images"][1]["label"], "mdas+tree");
    assert_eq!(page["maps"].as_array().unwrap().len(), 3);
    assert_eq!(page["maps"][2]["file"], "relmse-halton-tree.png");
    for (i, want) in images.iter().enumerate() {
        check_image(&html, i, want);
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn sweep_and_tune_pages_carry_their_records() {
    let dir = scratch("sweep");
    let svg = "<?xml version=\"1.0\"?><svg xmlns=\"http://www.w3.org/2000/svg\"></svg>";
    std::fs::write(dir.join("sweep.svg"), svg).unwrap();
    let sweep = json!({"scene": "s.toml", "scale": 0.5, "reference_spp": 256,
        "rows": [{"method": "mdas", "spp": 8, "relmse": 0.1, "relmse_ci95": [0.05, 0.2]}],
        "mdas_skipped": [1], "provenance": {"command_line": ["mdas", "sweep"]}});
    write_json(&dir.join("sweep.json"), &sweep);
    assert_eq!(write_page(&dir).unwrap(), Kind::Sweep);
    let html = std::fs::read_to_string(dir.join(PAGE)).unwrap();
    assert_eq!(json_of(&html, "mdas-record"), sweep);
    assert_eq!(json_of(&html, "mdas-page")["plot"], "sweep.svg");
    assert_eq!(unbase64(element(&html, "mdas-plot")), svg.as_bytes());
    assert!(!html.contains("id=\"mdas-image-"));

    let tune = json!({"scene": "s.toml", "rows": [], "halton": [], "skipped": [["alpha=9", "out of range"]],
        "best_table": "[mdas]\nalpha = 1\n</script>"});
    let dir2 = scratch("tune");
    write_json(&dir2.join("tune.json"), &tune);
    assert_eq!(write_page(&dir2).unwrap(), Kind::Tune);
    let html = std::fs::read_to_string(dir2.join(PAGE)).unwrap();
    assert_eq!(json_of(&html, "mdas-record"), tune);
    // A sweep beside a tune is shown first.
    std::fs::copy(dir2.join("tune.json"), dir.join("tune.json")).unwrap();
    assert_eq!(find_record(&dir).unwrap().0, Kind::Sweep);
    std::fs::remove_dir_all(&dir).unwrap();
    std::fs::remove_dir_all(&dir2).unwrap();
}

#[test]
fn a_directory_it_cannot_show_is_refused_and_nothing_is_written() {
    let listing = |dir: &Path| {
        let mut names: Vec<String> = std::fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        names.sort();
        names
    };
    // No record.
    let dir = scratch("empty");
    std::fs::write(dir.join("notes.txt"), "x").unwrap();
    let e = write_page(&dir).unwrap_err().to_string();
    assert!(e.contains("report.json, sweep.json, tune.json"), "{e}");
    assert_eq!(listing(&dir), ["notes.txt"]);
    std::fs::remove_dir_all(&dir).unwrap();

    // A record naming a file outside the directory.
    let (dir, _) = compare_dir("outside", 2, 2);
    let path = dir.join("report.json");
    let mut record: Value = serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
    record["methods"][0]["image"] = json!("../mdas.exr");
    write_json(&path, &record);
    let before = listing(&dir);
    let e = format!("{:#}", write_page(&dir).unwrap_err());
    assert!(e.contains("not a file name"), "{e}");
    assert_eq!(listing(&dir), before);

    // An image of another size than the film; a missing image; bad JSON.
    record["methods"][0]["image"] = json!("mdas.exr");
    image_io::write_exr(&dir.join("mdas.exr"), 3, 2, &pixels(3, 2, 0.0)).unwrap();
    write_json(&path, &record);
    let e = format!("{:#}", write_page(&dir).unwrap_err());
    assert!(e.contains("3×2, the record's film 2×2"), "{e}");
    std::fs::remove_file(dir.join("mdas.exr")).unwrap();
    let e = format!("{:#}", write_page(&dir).unwrap_err());
    assert!(e.contains("mdas.exr"), "{e}");
    std::fs::write(&path, "{").unwrap();
    let e = format!("{:#}", write_page(&dir).unwrap_err());
    assert!(e.contains("not valid JSON"), "{e}");
    assert!(!dir.join(PAGE).exists());
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn the_assets_cannot_end_their_elements() {
    assert!(!JS.to_ascii_lowercase().contains("</script"));
    assert!(!CSS.to_ascii_lowercase().contains("</style"));
    let slots: Vec<&str> = HTML
        .split("<!--mdas:")
        .skip(1)
        .map(|s| s.split_once("-->").unwrap().0)
        .collect();
    assert_eq!(slots, ["title", "style", "title", "data", "script"]);
}
