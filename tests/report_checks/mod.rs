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

/// One entry of `methods` in `out/report.json`: its RelMSE and MSE equal
/// those recomputed from its EXR against `reference`, its heat map
/// (`relmse-<image>`) averages to the same RelMSE, and its phase times
/// add up to its positive total. Returns the total (ms).
pub fn check_method(out: &Path, m: &Value, reference: &[[f32; 3]]) -> f64 {
    let name = m["name"].as_str().unwrap();
    let image_name = m["image"].as_str().unwrap();
    let (_, _, image) = read_exr(&out.join(image_name)).unwrap();
    let e = metrics::compare(&image, reference).unwrap();
    let relmse = m["relmse"].as_f64().unwrap();
    assert!(
        close(e.relmse, relmse, 1e-9),
        "{name}: {} vs {relmse}",
        e.relmse
    );
    assert!(close(e.mse, m["mse"].as_f64().unwrap(), 1e-9), "{name} MSE");
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
