//! Checks of one `report.json` method entry against the files written
//! beside it, shared by the compare tests.
#![allow(dead_code)]

use mdas::image_io::read_exr;
use mdas::metrics;
use serde_json::Value;
use std::path::Path;

/// `a` and `b` agree to `rel` relative to the larger.
pub fn close(a: f64, b: f64, rel: f64) -> bool {
    (a - b).abs() <= rel * a.abs().max(b.abs()).max(1e-30)
}

/// One entry of `methods` in `out/report.json`: its `image_relmse` and
/// `image_mse` equal those recomputed from its EXR against `reference`,
/// its heat map (`relmse-<image>`) averages to the same RelMSE, its
/// `relmse` is the mean of `relmse_per_seed` (the image's seed first)
/// when several seeds were rendered, else the image's own, the MSE split
/// adds up, and its phase times add up to its positive total. Returns the
/// total (ms).
pub fn check_method(out: &Path, m: &Value, reference: &[[f32; 3]]) -> f64 {
    let name = m["name"].as_str().unwrap();
    let image_name = m["image"].as_str().unwrap();
    let (_, _, image) = read_exr(&out.join(image_name)).unwrap();
    let e = metrics::compare(&image, reference).unwrap();
    let relmse = m["image_relmse"].as_f64().unwrap();
    assert!(
        close(e.relmse, relmse, 1e-9),
        "{name}: {} vs {relmse}",
        e.relmse
    );
    assert!(
        close(e.mse, m["image_mse"].as_f64().unwrap(), 1e-9),
        "{name} MSE"
    );
    assert!(
        close(e.mae, m["image_mae"].as_f64().unwrap(), 1e-9),
        "{name} MAE"
    );
    // FLIP (`mdas compare`, not `--samplers`): the report's mean is the
    // written image's, and its map averages to it over finite pixels.
    if let Some(flip) = m.get("image_flip") {
        let (w, h, _) = read_exr(&out.join(image_name)).unwrap();
        let f = metrics::flip(&image, reference, w, h, metrics::DEFAULT_PIXELS_PER_DEGREE).unwrap();
        assert!(close(f.mean, flip.as_f64().unwrap(), 1e-9), "{name} FLIP");
        let (_, _, map) = read_exr(&out.join(format!("flip-{image_name}"))).unwrap();
        let mean = map.iter().map(|p| p[0] as f64).sum::<f64>() / map.len() as f64;
        if f.nonfinite_pixels == 0 {
            assert!(
                close(mean, f.mean, 1e-5),
                "{name}: FLIP map {mean} vs {}",
                f.mean
            );
        }
        assert!((0.0..=1.0).contains(&f.mean));
    }
    // The EXR header names the method (and the budget it ran).
    let attributes = mdas::image_io::read_exr_attributes(&out.join(image_name)).unwrap();
    let method = attributes
        .iter()
        .find(|(n, _)| n == "method")
        .map(|(_, v)| v.to_string());
    assert!(
        method.is_some_and(|v| name.starts_with(v.as_str())),
        "{name}: EXR attributes {attributes:?}"
    );
    match m.get("relmse_per_seed") {
        Some(per_seed) => {
            let v: Vec<f64> = per_seed
                .as_array()
                .unwrap()
                .iter()
                .map(|x| x.as_f64().unwrap())
                .collect();
            assert_eq!(
                v.len(),
                m["seeds"].as_array().unwrap().len(),
                "{name} seeds"
            );
            assert!(
                close(v[0], relmse, 1e-9),
                "{name}: first seed is the image's"
            );
            let mean = v.iter().sum::<f64>() / v.len() as f64;
            assert!(
                close(m["relmse"].as_f64().unwrap(), mean, 1e-12),
                "{name} mean"
            );
            let ci = m["relmse_ci95"].as_array().unwrap();
            assert!(ci[0].as_f64().unwrap() <= mean && mean <= ci[1].as_f64().unwrap());
            let (b2, var) = (
                m["mse_bias2"].as_f64().unwrap(),
                m["mse_variance"].as_f64().unwrap(),
            );
            // Between seeds the renders differ, so the variance term is
            // positive (b2 may be 0 only for an exact estimator).
            assert!(v.len() < 2 || var > 0.0, "{name}: zero variance over seeds");
            assert!(
                close(b2 + var, m["mse"].as_f64().unwrap(), 1e-9),
                "{name} split"
            );
        }
        None => assert_eq!(m["relmse"].as_f64().unwrap(), relmse, "{name}"),
    }
    let (_, _, map) = read_exr(&out.join(format!("relmse-{image_name}"))).unwrap();
    let mean = map.iter().map(|p| p[0] as f64).sum::<f64>() / map.len() as f64;
    assert!(
        close(mean, relmse, 1e-5),
        "{name}: heat map mean {mean} vs {relmse}"
    );
    let t = m["time_ms"].as_object().unwrap();
    let sum: f64 = t
        .iter()
        .filter(|(k, _)| k.as_str() != "total")
        .map(|(_, v)| v.as_f64().unwrap())
        .sum();
    let total = t["total"].as_f64().unwrap();
    assert!(
        total > 0.0 && close(sum, total, 1e-9),
        "{name}: Σ {sum} vs {total}"
    );
    total
}
