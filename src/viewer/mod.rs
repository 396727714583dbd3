//! `index.html`: one self-contained page that shows an output directory of
//! `mdas compare`, `compare --samplers`, `sweep` or `tune` (issue 52), for
//! a browser opened on the file itself — no network, no server, no CDN.
//!
//! **A comparison** (`report.json`): the reference and every method's image,
//! switched by keys and clicks; zoom and pan shared by all of them, down to
//! single pixels drawn nearest-neighbour; exposure in stops applied to the
//! linear values, then clamped and sRGB-encoded (as the PNGs are, at 0
//! stops); the RelMSE, FLIP and density maps as layers over the image they
//! belong to; each method's figures with their 95 % intervals, the
//! equal-time and equal-samples ratios, the flags; a pixel inspector (film
//! coordinates, every image's linear RGB under the cursor); the provenance;
//! the keyboard shortcuts.
//! **A sweep or a tune** (`sweep.json`, `tune.json`): the plot and sortable
//! tables of the record's rows, Halton points, skipped configurations, the
//! best `[mdas]` table and the provenance.
//!
//! **Data.** The record itself sits in the page as JSON; every image is
//! read from its EXR and carried as half floats in base64
//! (`encode`: a browser forbids `fetch` and canvas read-back of a file
//! beside a `file://` page, so the values travel inside it); the map PNGs
//! and `sweep.svg` are carried as they are, in base64. The page's code and
//! style are `page.js` and `page.css` beside this file, written into the
//! page. A directory holds one record: `report.json` is shown before
//! `sweep.json`, and that before `tune.json`.
//!
//! **Test hook** (`page.js`): `window.mdasView` with `ready`, `error`,
//! `loadMs`, `state()` and `filmToClient(x, y)`, the client coordinates of
//! the centre of film pixel (x, y): the canvas `#view` draws film pixel
//! (x, y) over CSS pixels `left + ox + [x, x + 1)·zoom` × `top + oy + [y,
//! y + 1)·zoom`, `(ox, oy)` and `zoom` from `state()`.

mod encode;

use crate::image_io;
use anyhow::{bail, Context, Result};
use serde_json::{json, Value};
use std::path::Path;

/// The page's file name in an output directory.
pub const PAGE: &str = "index.html";

/// The records a page can show, in the order they are looked for.
pub const RECORDS: [&str; 3] = ["report.json", "sweep.json", "tune.json"];

const HTML: &str = include_str!("page.html");
const CSS: &str = include_str!("page.css");
const JS: &str = include_str!("page.js");

/// What a directory holds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    /// `mdas compare`'s `report.json`.
    Compare,
    /// `mdas compare --samplers`'s `report.json` (`equal_time.samplers`).
    Samplers,
    Sweep,
    Tune,
}

impl Kind {
    pub fn name(self) -> &'static str {
        match self {
            Kind::Compare => "compare",
            Kind::Samplers => "samplers",
            Kind::Sweep => "sweep",
            Kind::Tune => "tune",
        }
    }
}

/// Writes `dir/index.html` (atomically) from the record in `dir` and the
/// files it names; returns what it showed. A directory with none of
/// [`RECORDS`] is an error, and nothing is written.
pub fn write_page(dir: &Path) -> Result<Kind> {
    let (kind, file, record) = find_record(dir)?;
    let html = page(dir, kind, file, &record)?;
    image_io::write_atomic(&dir.join(PAGE), |tmp| {
        std::fs::write(tmp, &html).with_context(|| format!("cannot write {}", tmp.display()))
    })?;
    Ok(kind)
}

/// The first record of [`RECORDS`] in `dir`, parsed, and its kind.
pub fn find_record(dir: &Path) -> Result<(Kind, &'static str, Value)> {
    for file in RECORDS {
        let path = dir.join(file);
        if !path.is_file() {
            continue;
        }
        let text = std::fs::read_to_string(&path)
            .with_context(|| format!("cannot read {}", path.display()))?;
        let record: Value = serde_json::from_str(&text)
            .with_context(|| format!("{} is not valid JSON", path.display()))?;
        if !record.is_object() {
            bail!("{} is not a JSON object", path.display());
        }
        let kind = match file {
            "report.json" if record["equal_time"]["samplers"].is_array() => Kind::Samplers,
            "report.json" => Kind::Compare,
            "sweep.json" => Kind::Sweep,
            _ => Kind::Tune,
        };
        return Ok((kind, file, record));
    }
    bail!(
        "{} holds none of {} (the records of mdas compare, sweep and tune); nothing to show",
        dir.display(),
        RECORDS.join(", ")
    )
}

/// A file named by a record: a plain name inside `dir` (a record naming
/// `../x` or `/x` is refused rather than read).
fn named_file(dir: &Path, name: &str) -> Result<std::path::PathBuf> {
    let plain = Path::new(name);
    if name.is_empty() || plain.file_name().and_then(|n| n.to_str()) != Some(name) {
        bail!("the record names {name:?}, which is not a file name in the output directory");
    }
    Ok(dir.join(plain))
}

/// The page's text.
fn page(dir: &Path, kind: Kind, file: &str, record: &Value) -> Result<String> {
    let mut data = String::new();
    let mut manifest = json!({
        "kind": kind.name(),
        "record": file,
        "generator": format!("mdas {}", env!("CARGO_PKG_VERSION")),
        "viridis": crate::colormap::VIRIDIS,
    });
    match kind {
        Kind::Compare | Kind::Samplers => images(dir, record, &mut manifest, &mut data)?,
        Kind::Sweep => {
            let svg = dir.join("sweep.svg");
            if svg.is_file() {
                let bytes = std::fs::read(&svg)
                    .with_context(|| format!("cannot read {}", svg.display()))?;
                push_text(&mut data, "mdas-plot", &encode::base64(&bytes));
                manifest["plot"] = json!("sweep.svg");
            }
        }
        Kind::Tune => {}
    }
    let title = format!(
        "{} · {}",
        record["scene"].as_str().unwrap_or("mdas"),
        kind.name()
    );
    let mut html = String::with_capacity(data.len() + HTML.len() + CSS.len() + JS.len() + 4096);
    for (i, part) in HTML.split("<!--mdas:").enumerate() {
        if i == 0 {
            html.push_str(part);
            continue;
        }
        let (slot, rest) = part
            .split_once("-->")
            .expect("page.html's slots are <!--mdas:NAME-->");
        match slot {
            "title" => html.push_str(&escape_html(&title)),
            "style" => html.push_str(CSS),
            "data" => {
                html.push_str(&script_json("mdas-record", record));
                html.push_str(&script_json("mdas-page", &manifest));
                html.push_str(&data);
            }
            "script" => html.push_str(JS),
            other => unreachable!("page.html names an unknown slot {other}"),
        }
        html.push_str(rest);
    }
    Ok(html)
}

/// Reads the reference's and every method's EXR and the map PNGs beside
/// them into `data`, listing them in `manifest` (`film`, `images`, `maps`).
fn images(dir: &Path, record: &Value, manifest: &mut Value, data: &mut String) -> Result<()> {
    let film = (
        record["film"]["width"].as_u64().unwrap_or(0),
        record["film"]["height"].as_u64().unwrap_or(0),
    );
    if film.0 == 0 || film.1 == 0 {
        bail!("the record has no film size (film.width, film.height)");
    }
    let files = &record["files"];
    let listed: Option<Vec<&str>> = files
        .as_object()
        .map(|m| m.values().filter_map(Value::as_str).collect());
    let exists = |name: &str| match &listed {
        Some(names) => names.contains(&name) && dir.join(name).is_file(),
        None => dir.join(name).is_file(),
    };
    // (label, EXR file, index in `methods`)
    let mut shown: Vec<(String, String, Value)> = vec![(
        "reference".into(),
        files["reference"]
            .as_str()
            .unwrap_or("reference.exr")
            .to_string(),
        Value::Null,
    )];
    for (i, m) in record["methods"]
        .as_array()
        .map(Vec::as_slice)
        .unwrap_or_default()
        .iter()
        .enumerate()
    {
        let (Some(name), Some(image)) = (m["name"].as_str(), m["image"].as_str()) else {
            bail!("method {i} of the record has no name or image");
        };
        shown.push((name.to_string(), image.to_string(), json!(i)));
    }
    let mut images = Vec::new();
    let mut maps = Vec::new();
    for (index, (label, file, method)) in shown.into_iter().enumerate() {
        let path = named_file(dir, &file)?;
        let (w, h, pixels) = image_io::read_exr(&path)
            .with_context(|| format!("the page shows {label} from {file}"))?;
        if (u64::from(w), u64::from(h)) != film {
            bail!(
                "{} is {w}×{h}, the record's film {}×{}",
                path.display(),
                film.0,
                film.1
            );
        }
        push_text(
            data,
            &format!("mdas-image-{index}"),
            &encode::base64(&encode::halves(&pixels)),
        );
        let stem = file.strip_suffix(".exr").unwrap_or(&file);
        for layer in ["relmse", "flip", "density"] {
            let png = format!("{layer}-{stem}.png");
            if index == 0 || !exists(&png) {
                continue;
            }
            let path = named_file(dir, &png)?;
            let bytes =
                std::fs::read(&path).with_context(|| format!("cannot read {}", path.display()))?;
            push_text(
                data,
                &format!("mdas-map-{}", maps.len()),
                &encode::base64(&bytes),
            );
            maps.push(json!({"image": index, "layer": layer, "file": png}));
        }
        images.push(json!({"label": label, "file": file, "method": method}));
    }
    manifest["film"] = json!([film.0, film.1]);
    manifest["images"] = json!(images);
    manifest["maps"] = json!(maps);
    Ok(())
}

/// `<script type="application/json" id=ID>` holding `value`.
fn script_json(id: &str, value: &Value) -> String {
    format!(
        "<script type=\"application/json\" id=\"{id}\">{}</script>\n",
        encode::script_json(value)
    )
}

/// `<script type="text/plain" id=ID>` holding base64 `text` (never `<`).
fn push_text(data: &mut String, id: &str, text: &str) {
    data.push_str("<script type=\"text/plain\" id=\"");
    data.push_str(id);
    data.push_str("\">");
    data.push_str(text);
    data.push_str("</script>\n");
}

fn escape_html(text: &str) -> String {
    text.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

#[cfg(test)]
mod tests;
