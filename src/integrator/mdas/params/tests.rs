//! The registry against its struct, its ranges and the docs.

use super::*;

/// Every field of [`MdasParams`] but `auto_grid` has one row, and each
/// row reads and writes its own field.
#[test]
fn the_registry_covers_every_field_once() {
    let json = serde_json::to_value(MdasParams::default()).unwrap();
    let mut fields: Vec<&str> = json
        .as_object()
        .unwrap()
        .keys()
        .map(|k| k.as_str())
        .collect();
    fields.retain(|&k| k != "auto_grid");
    fields.sort_unstable();
    let mut keys: Vec<&str> = PARAMS.iter().map(|p| p.key).collect();
    keys.sort_unstable();
    assert_eq!(fields, keys);
    for param in &PARAMS {
        let mut p = MdasParams::default();
        // A valid value other than the default, just inside the range.
        let v = match (param.kind, param.max) {
            (Kind::Rule(names), _) => ((param.get(&p) as usize + 1) % names.len()) as f64,
            (_, Closed(hi)) => hi,
            (_, _) => param.get(&p) + 3.0,
        };
        param.check(v).unwrap();
        param.set(&mut p, v);
        assert_eq!(param.get(&p), v, "{}", param.key);
        let json_after = serde_json::to_value(p).unwrap();
        for (k, before) in json.as_object().unwrap() {
            let changed = json_after[k] != *before;
            let expected = k == param.key || (k == "auto_grid" && param.grid);
            assert_eq!(
                changed,
                expected && k != "auto_grid",
                "{} changed {k}",
                param.key
            );
        }
    }
}

/// Each end of each range: the value on it passes as the end says, the
/// value beyond it fails, with the key named.
#[test]
fn validate_enforces_every_range() {
    let base = MdasParams {
        max_samples_per_leaf: MAX_SAMPLES_PER_LEAF,
        bits_per_dim: 0,
        extra_image_bits: 0,
        ..MdasParams::default()
    };
    validate(&base).unwrap();
    for param in &PARAMS {
        for (end, step) in [(param.min, -1.0), (param.max, 1.0)] {
            let (at, inside) = match end {
                Closed(x) => (x, true),
                Open(x) => (x, false),
                Unbounded => continue,
            };
            let mut p = base;
            param.set(&mut p, at);
            assert_eq!(validate(&p).is_ok(), inside, "{} = {at}", param.key);
            let beyond = if param.kind == Kind::Int {
                at + step
            } else {
                at + step * at.abs().max(1.0) * 1e-3
            };
            if param.kind == Kind::Int && !(0.0..=f64::from(u32::MAX)).contains(&beyond) {
                continue; // not a u32: the readers refuse it
            }
            param.set(&mut p, beyond);
            let e = validate(&p).unwrap_err();
            assert_eq!(e.key, param.key, "{} = {beyond}: {e}", param.key);
        }
    }
    let e = validate(&MdasParams {
        spp: f32::NAN,
        ..base
    })
    .unwrap_err();
    assert_eq!(e.key, "spp");
}

/// `docs/scene-format.md`'s `[mdas]` table lists the registry's keys,
/// each with its range and its default as the registry writes them.
#[test]
fn the_scene_format_docs_match_the_registry() {
    let docs = include_str!("../../../../docs/scene-format.md");
    let section = &docs[docs.find("## `[mdas]`").unwrap()..];
    let section = &section[..section[3..].find("\n## ").map_or(section.len(), |i| i + 3)];
    let rows: Vec<Vec<String>> = section
        .lines()
        .filter(|l| l.starts_with("| `"))
        .map(|l| {
            l.trim_matches('|')
                .split(" | ")
                .map(|c| c.trim().replace('`', ""))
                .collect()
        })
        .collect();
    let keys: Vec<&str> = rows.iter().map(|r| r[0].as_str()).collect();
    let registry: Vec<&str> = PARAMS.iter().map(|p| p.key).collect();
    assert_eq!(keys, registry, "the docs' rows, in the registry's order");
    for (row, param) in rows.iter().zip(&PARAMS) {
        let (range, default) = (&row[1], &row[2]);
        match param.kind {
            Kind::Rule(names) => {
                for n in names {
                    assert!(
                        range.contains(&format!("\"{n}\"")),
                        "{}: {range}",
                        param.key
                    );
                }
                assert_eq!(
                    default.trim_matches('"'),
                    param.default_text(),
                    "{}",
                    param.key
                );
            }
            _ => {
                assert!(
                    range.starts_with(&param.range_text()),
                    "{}: '{range}' against '{}'",
                    param.key,
                    param.range_text()
                );
                assert!(
                    default.starts_with(&param.default_text()),
                    "{}: '{default}' against '{}'",
                    param.key,
                    param.default_text()
                );
            }
        }
    }
}

/// A scene without a table: the registry's defaults, the grid chosen
/// per render.
#[test]
fn for_film_takes_the_registrys_defaults() {
    let film = Film {
        width: 128,
        height: 96,
    };
    let p = MdasParams::for_film(film);
    assert!(p.auto_grid);
    assert_eq!((p.alpha, p.pace), (AUTO_ALPHA, AUTO_PACE));
    assert_eq!(
        (p.reconstruction, p.pixel_prior),
        (Reconstruction::Shrinkage, 0.0)
    );
    let (e, l) = auto_grid(film, p.spp);
    assert_eq!(
        (
            p.bits_per_dim,
            p.extra_image_bits,
            p.initial_samples_per_cell
        ),
        (0, e, l)
    );
}

#[test]
fn values_parse_and_print_by_kind() {
    let split = param("split").unwrap();
    assert_eq!(split.parse("trimmed"), Ok(2.0));
    assert_eq!(
        split.parse("median").unwrap_err(),
        "unknown split rule 'median', expected 'extent', 'contrast' or 'trimmed'"
    );
    assert_eq!(split.format(1.0), "contrast");
    let alpha = param("alpha").unwrap();
    assert!(alpha.parse("nan").is_err());
    assert_eq!(alpha.toml(0.1f32 as f64).to_string(), "0.1");
    assert_eq!(param("epsilon").unwrap().range_text(), "number in (0, 1e6]");
    assert_eq!(
        param("scale_factor").unwrap().check(0.0).unwrap_err(),
        "must be a positive number"
    );
    assert_eq!(
        param("candidates").unwrap().check(0.0).unwrap_err(),
        "must be in 1..=64"
    );
    assert_eq!(param("bits_per_dim").unwrap().flag(), "--bits-per-dim");
}
