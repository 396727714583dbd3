//! The `mdas` binary: exit codes, messages and outputs, including bad input
//! (each must fail with a clear message, a non-zero exit, no panic and no
//! output file left behind).

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn mdas(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_mdas"))
        .args(args)
        .output()
        .expect("run mdas")
}

fn temp_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("mdas-cli-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// A copy of area_light_plane.toml with `edit` applied, in `dir`.
fn scene_variant(dir: &Path, name: &str, edit: impl Fn(String) -> String) -> PathBuf {
    let text = std::fs::read_to_string("scenes/area_light_plane.toml").unwrap();
    let path = dir.join(name);
    std::fs::write(&path, edit(text)).unwrap();
    path
}

fn assert_fails_cleanly(args: &[&str], out: &Path, expect: &[&str]) {
    let o = mdas(args);
    let err = stderr(&o);
    assert!(!o.status.success(), "{args:?} should fail; stderr: {err}");
    assert!(!err.contains("panicked"), "{args:?} panicked: {err}");
    for e in expect {
        assert!(err.contains(e), "{args:?}: expected '{e}' in: {err}");
    }
    assert!(!out.exists(), "{args:?} left {} behind", out.display());
    assert!(
        !out.with_extension("png").exists(),
        "{args:?} left a PNG behind"
    );
}

#[test]
fn render_writes_exr_and_png() {
    let dir = temp_dir("ok");
    let out = dir.join("plane.exr");
    let o = mdas(&[
        "render",
        "scenes/area_light_plane.toml",
        "--spp",
        "4",
        "--scale",
        "0.25",
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "stderr: {}", stderr(&o));
    let (w, h, image) = mdas::image_io::read_exr(&out).unwrap();
    assert_eq!((w, h), (32, 24));
    assert!(image.iter().any(|p| p[0] > 0.0), "the lit plane is visible");
    assert!(out.with_extension("png").exists());
    // No temporary files are left in the output directory.
    let names: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(names.len(), 2, "{names:?}");
    // The EXR header says how it was made.
    use mdas::image_io::ExrAttribute;
    let attributes: std::collections::HashMap<String, ExrAttribute> =
        mdas::image_io::read_exr_attributes(&out)
            .unwrap()
            .into_iter()
            .collect();
    assert_eq!(attributes["method"], ExrAttribute::Text("halton".into()));
    assert_eq!(attributes["spp"], ExrAttribute::F64(4.0));
    assert_eq!(attributes["seed"], ExrAttribute::I32(0));
    assert!(matches!(attributes["timeMs"], ExrAttribute::F64(t) if t > 0.0));
}

/// `-o X.png` writes the PNG alone; `--json` prints one record whose
/// fields agree with the file and the render; `--quiet` prints nothing
/// but the result (and under --json, nothing on stderr at all).
#[test]
fn render_png_only_json_and_quiet() {
    let dir = temp_dir("png-json");
    let out = dir.join("plane.png");
    let o = mdas(&[
        "render",
        "scenes/area_light_plane.toml",
        "--spp",
        "2",
        "--scale",
        "0.125",
        "-o",
        out.to_str().unwrap(),
        "--json",
        "--quiet",
    ]);
    assert!(o.status.success(), "stderr: {}", stderr(&o));
    assert_eq!(stderr(&o), "", "--quiet --json leaves stderr empty");
    let names: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .collect();
    assert_eq!(names, vec!["plane.png".to_string()]);
    let png = image::open(&out).unwrap();
    assert_eq!((png.width(), png.height()), (16, 12));
    let record: serde_json::Value =
        serde_json::from_slice(&o.stdout).expect("stdout is one JSON document");
    assert_eq!(record["method"], "halton");
    assert_eq!(
        (record["width"].as_u64(), record["height"].as_u64()),
        (Some(16), Some(12))
    );
    assert_eq!(record["samples"], 16 * 12 * 2);
    assert_eq!(record["spp"], 2.0);
    assert_eq!(record["files"][0], out.to_str().unwrap());
    assert_eq!(record["provenance"]["integrand"], "area_light");
    assert!(record["provenance"].get("mdas").is_none(), "Halton only");
    assert_eq!(
        record["provenance"]["scene_sha256"].as_str().unwrap().len(),
        64
    );

    // Any other extension is refused before any work, naming both forms.
    let bad = dir.join("other.jpg");
    assert_fails_cleanly(
        &[
            "render",
            "scenes/area_light_plane.toml",
            "-o",
            bad.to_str().unwrap(),
        ],
        &bad,
        &["must end in .exr", "or .png"],
    );
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn output_extension_is_case_insensitive() {
    let dir = temp_dir("upper");
    let out = dir.join("plane.EXR");
    let o = mdas(&[
        "render",
        "scenes/area_light_plane.toml",
        "--spp",
        "1",
        "--scale",
        "0.125",
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "stderr: {}", stderr(&o));
    assert!(mdas::image_io::read_exr(&out).is_ok());
    assert!(dir.join("plane.png").exists());
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn render_with_mdas_and_its_overrides() {
    let dir = temp_dir("mdas");
    let out = dir.join("plane.exr");
    let o = mdas(&[
        "render",
        "scenes/area_light_plane.toml",
        "--integrator",
        "mdas",
        "--spp",
        "6.5",
        "--alpha",
        "0.5",
        "--scale",
        "0.25",
        "-o",
        out.to_str().unwrap(),
    ]);
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "stderr: {}", stderr(&o));
    // The result on stdout, the note naming the method on stderr.
    assert!(stdout.contains("(6.50 spp)"), "{stdout}");
    assert!(stderr(&o).contains(", mdas, adapter"), "{}", stderr(&o));
    let (w, h, image) = mdas::image_io::read_exr(&out).unwrap();
    assert_eq!((w, h), (32, 24));
    assert!(image.iter().all(|p| p.iter().all(|c| c.is_finite())));
}

#[test]
fn reference_is_cached() {
    let dir = temp_dir("ref");
    let cache = dir.join("cache");
    let args = [
        "reference",
        "scenes/area_light_plane.toml",
        "--spp",
        "8",
        "--scale",
        "0.125",
        "--cache",
        cache.to_str().unwrap(),
    ];
    let first = mdas(&args);
    assert!(first.status.success(), "stderr: {}", stderr(&first));
    assert!(String::from_utf8_lossy(&first.stdout).contains("rendered"));
    let second = mdas(&args);
    assert!(second.status.success());
    assert!(String::from_utf8_lossy(&second.stdout).contains("cached"));
    // The cache keeps a provenance record beside the EXR, and the EXR's
    // header names the method and budget.
    let third = mdas(&[&args[..], &["--json"]].concat());
    assert!(third.status.success());
    let printed: serde_json::Value = serde_json::from_slice(&third.stdout).unwrap();
    assert_eq!(printed["cached"], true);
    let record: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(printed["record"].as_str().unwrap()).unwrap(),
    )
    .unwrap();
    assert_eq!(record["spp"], 8);
    assert_eq!(record["provenance"]["integrand"], "area_light");
    let exr = std::path::Path::new(printed["path"].as_str().unwrap());
    let attributes = mdas::image_io::read_exr_attributes(exr).unwrap();
    assert!(attributes.contains(&("spp".into(), mdas::image_io::ExrAttribute::F64(8.0))));
}

#[test]
fn info_names_the_adapter() {
    let o = mdas(&["info"]);
    assert!(o.status.success(), "stderr: {}", stderr(&o));
    let s = String::from_utf8_lossy(&o.stdout);
    assert!(s.contains("adapter:") && s.contains("backend:"), "{s}");
    let o = mdas(&["info", "--json"]);
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert!(v["adapter"].as_str().is_some_and(|a| !a.is_empty()), "{v}");
    assert!(v["limits"]["max_storage_buffer_binding_size"].as_u64() > Some(0));
}

#[test]
fn bad_scene_files_fail_with_file_line_and_column() {
    let dir = temp_dir("bad");
    let out = dir.join("out.exr");
    let o = out.to_str().unwrap();
    let cases: Vec<(PathBuf, Vec<&str>)> = vec![
        (
            scene_variant(&dir, "malformed.toml", |t| t.replacen("[film]", "[film", 1)),
            vec!["malformed.toml:"],
        ),
        (
            scene_variant(&dir, "unknown_key.toml", |t| {
                t.replacen("[film]", "[film]\nwidht = 3", 1)
            }),
            vec!["unknown_key.toml:", "widht"],
        ),
        (
            scene_variant(&dir, "nan.toml", |t| {
                t.replacen("fov_y = 45", "fov_y = nan", 1)
            }),
            vec!["nan.toml:"],
        ),
        (
            scene_variant(&dir, "zero_res.toml", |t| {
                t.replacen("width = 128", "width = 0", 1)
            }),
            vec!["zero_res.toml:"],
        ),
        (
            scene_variant(&dir, "neg_res.toml", |t| {
                t.replacen("width = 128", "width = -128", 1)
            }),
            vec!["neg_res.toml:"],
        ),
        (
            scene_variant(&dir, "huge_res.toml", |t| {
                t.replacen("width = 128", "width = 1000000", 1)
            }),
            vec!["huge_res.toml:"],
        ),
        (
            scene_variant(&dir, "neg_radiance.toml", |t| {
                t.replacen("radiance = [10", "radiance = [-10", 1)
            }),
            vec!["neg_radiance.toml:"],
        ),
        (
            scene_variant(&dir, "missing_mesh.toml", |t| {
                t + "\n[[shape]]\ntype = \"mesh\"\nfile = \"does_not_exist.obj\"\nmaterial = \"grey\"\n"
            }),
            vec!["missing_mesh.toml:", "does_not_exist.obj"],
        ),
    ];
    for (scene, expect) in &cases {
        assert_fails_cleanly(
            &["render", scene.to_str().unwrap(), "--spp", "1", "-o", o],
            &out,
            expect,
        );
    }
    assert_fails_cleanly(
        &["render", "scenes/no_such_scene.toml", "-o", o],
        &out,
        &["no_such_scene.toml"],
    );
}

#[test]
fn bad_arguments_fail_cleanly() {
    let dir = temp_dir("args");
    let out = dir.join("out.exr");
    let o = out.to_str().unwrap();
    let scene = "scenes/area_light_plane.toml";
    assert_fails_cleanly(
        &["render", scene, "--scale", "0", "-o", o],
        &out,
        &["scale"],
    );
    assert_fails_cleanly(&["render", scene, "--spp", "0", "-o", o], &out, &["spp"]);
    assert_fails_cleanly(
        &["render", scene, "--spp", "1.5", "-o", o],
        &out,
        &["whole number"],
    );
    // An MDAS budget below its initial grid is refused before any work.
    assert_fails_cleanly(
        &[
            "render",
            scene,
            "--integrator",
            "mdas",
            "--spp",
            "1",
            "--extra-image-bits",
            "9",
            "-o",
            o,
        ],
        &out,
        &["budget", "initial samples"],
    );
    assert_fails_cleanly(&["render", scene, "--spp", "-3", "-o", o], &out, &["-3"]);
    // Parsed as f32, 4294967297 saturated to u32::MAX spp and ran for ever.
    assert_fails_cleanly(
        &["render", scene, "--spp", "4294967297", "-o", o],
        &out,
        &["--spp must be at most 16777216 for Halton"],
    );
    assert_fails_cleanly(
        &[
            "render",
            scene,
            "--scale",
            "0.1",
            "-o",
            dir.join("x.tif").to_str().unwrap(),
        ],
        &out,
        &[".exr", ".png"],
    );
    let unwritable = Path::new("/proc/mdas-cannot-write-here/out.exr");
    assert_fails_cleanly(
        &[
            "render",
            scene,
            "--spp",
            "1",
            "--scale",
            "0.1",
            "-o",
            unwritable.to_str().unwrap(),
        ],
        unwritable,
        &["mdas-cannot-write-here"],
    );
}

#[test]
fn compare_json_goes_to_stdout_and_matches_the_report() {
    let dir = temp_dir("compare");
    let out = dir.join("cmp");
    let cache = dir.join("cache");
    let o = mdas(&[
        "compare",
        "scenes/area_light_plane.toml",
        "--scale",
        "0.125",
        "--spp",
        "4",
        "--ref-spp",
        "16",
        "--repeats",
        "1",
        "--json",
        "--out",
        out.to_str().unwrap(),
        "--cache",
        cache.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "stderr: {}", stderr(&o));
    let printed = String::from_utf8_lossy(&o.stdout);
    let written = std::fs::read_to_string(out.join("report.json")).unwrap();
    assert_eq!(printed.trim(), written.trim());
    // The table goes to stderr with --json.
    assert!(stderr(&o).contains("equal-time RelMSE ratio MDAS/Halton"));
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn compare_bad_input_fails_without_a_report() {
    let dir = temp_dir("compare-bad");
    let out = dir.join("cmp");
    let o = out.to_str().unwrap();
    let run = |args: &[&str], expect: &str| {
        let r = mdas(args);
        let err = stderr(&r);
        assert!(!r.status.success(), "{args:?} should fail");
        assert!(!err.contains("panicked"), "{args:?} panicked: {err}");
        assert!(
            err.contains(expect),
            "{args:?}: expected '{expect}' in: {err}"
        );
        assert!(!out.exists(), "{args:?} left {} behind", out.display());
    };
    run(
        &["compare", "scenes/no_such_scene.toml", "--out", o],
        "no_such_scene",
    );
    run(
        &[
            "compare",
            "scenes/area_light_plane.toml",
            "--scale",
            "0.125",
            "--spp",
            "0.01",
            "--out",
            o,
        ],
        "initial samples",
    );
    run(
        &[
            "compare",
            "scenes/area_light_plane.toml",
            "--spp",
            "4",
            "--time-ms",
            "10",
            "--out",
            o,
        ],
        "cannot be used with",
    );
    run(
        &[
            "compare",
            "scenes/area_light_plane.toml",
            "--max-spp",
            "0",
            "--out",
            o,
        ],
        "0 is not in 1..",
    );
    std::fs::remove_dir_all(&dir).ok();
}

/// A budget search that cannot reach the target (`--max-spp 1` against a
/// 60-second budget) is reported as such on the console, next to the
/// ratio, and in report.json.
#[test]
fn compare_says_when_times_are_not_equal() {
    let dir = temp_dir("compare-unequal");
    let out = dir.join("cmp");
    let o = mdas(&[
        "compare",
        "scenes/area_light_plane.toml",
        "--scale",
        "0.125",
        "--time-ms",
        "60000",
        "--max-spp",
        "1",
        "--ref-spp",
        "16",
        "--repeats",
        "1",
        "--seeds",
        "1",
        "--out",
        out.to_str().unwrap(),
        "--cache",
        dir.join("cache").to_str().unwrap(),
    ]);
    assert!(o.status.success(), "stderr: {}", stderr(&o));
    let text = format!("{}{}", String::from_utf8_lossy(&o.stdout), stderr(&o));
    assert!(
        text.contains("NOT AT EQUAL TIME: Halton's search did not reach 60000.000 ms"),
        "{text}"
    );
    assert!(text.contains("— NOT at equal time"), "{text}");
    let report = std::fs::read_to_string(out.join("report.json")).unwrap();
    assert!(report.contains("\"bracketed\": false"), "{report}");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn bench_prints_a_table_and_writes_json() {
    let dir = temp_dir("bench");
    let json = dir.join("bench.json");
    let o = mdas(&[
        "bench",
        "scenes/area_light_plane.toml",
        "--scale",
        "0.125",
        "--repeats",
        "1",
        "--json-out",
        json.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "stderr: {}", stderr(&o));
    let table = String::from_utf8_lossy(&o.stdout);
    assert!(
        table.contains("| `scenes/area_light_plane.toml` | 16×12 | 16 |"),
        "{table}"
    );
    let rows: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let row = &rows[0];
    // Both methods take spp × pixels samples.
    assert_eq!(row["mdas_samples"], 16 * 12 * 16);
    assert_eq!(row["halton_samples"], 16 * 12 * 16);
    let phases = row["mdas_phases_ms"].as_array().unwrap();
    let names: Vec<&str> = phases.iter().map(|p| p[0].as_str().unwrap()).collect();
    assert_eq!(
        names,
        ["initial", "evaluate", "error", "adaptive", "reconstruction"]
    );
    assert!(phases.iter().all(|p| p[1].as_f64().unwrap() >= 0.0));
    assert!(
        phases[1][1].as_f64().unwrap() > 0.0,
        "evaluate took no time"
    );
    // The adaptive phase's parts add up to it (medians of one render).
    let parts: f64 = row["mdas_adaptive_parts_ms"]
        .as_array()
        .unwrap()
        .iter()
        .map(|p| p[1].as_f64().unwrap())
        .sum();
    let adaptive = phases[3][1].as_f64().unwrap();
    assert!(
        (parts - adaptive).abs() <= 1e-9 * adaptive.max(1.0),
        "{parts} vs {adaptive}"
    );
    assert!(row["mdas_iterations"].as_u64().unwrap() >= 1);
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn bench_refuses_a_fractional_spp() {
    let dir = temp_dir("bench-bad");
    let scene = scene_variant(&dir, "frac.toml", |t| t.replace("spp = 16", "spp = 2.5"));
    let o = mdas(&["bench", scene.to_str().unwrap(), "--scale", "0.125"]);
    let err = stderr(&o);
    assert!(!o.status.success());
    assert!(!err.contains("panicked"), "{err}");
    assert!(err.contains("not a whole number; pass --spp"), "{err}");
    std::fs::remove_dir_all(&dir).ok();
}

/// A scene without an `[mdas]` table renders with MDAS at 1 and 2 spp on a
/// 128×128 film (the defaults derive from the film: at most 1 spp of
/// initial samples).
#[test]
fn mdas_renders_a_scene_without_an_mdas_table() {
    let dir = temp_dir("no-mdas-table");
    let scene = scene_variant(&dir, "plain.toml", |t| {
        let t = t[..t.find("[mdas]").expect("the scene has [mdas]")].to_string();
        t.replacen("height = 96", "height = 128", 1)
    });
    for spp in ["1", "2"] {
        let out = dir.join(format!("plain-{spp}.exr"));
        let o = mdas(&[
            "render",
            scene.to_str().unwrap(),
            "--integrator",
            "mdas",
            "--spp",
            spp,
            "-o",
            out.to_str().unwrap(),
        ]);
        assert!(o.status.success(), "{spp} spp: {}", stderr(&o));
        let (w, h, _) = mdas::image_io::read_exr(&out).unwrap();
        assert_eq!((w, h), (128, 128));
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// `tune` over a small grid: every runnable configuration is ranked with
/// its interval and bias, one that cannot run is listed as skipped, the
/// best is printed as an [mdas] table, and tune.json agrees with stdout.
#[test]
fn tune_ranks_a_grid_and_skips_what_cannot_run() {
    let dir = temp_dir("tune");
    let out = dir.join("tune");
    let o = mdas(&[
        "tune",
        "scenes/area_light_plane.toml",
        "--scale",
        "0.125",
        "--spp",
        "4",
        "--ref-spp",
        "32",
        "--seeds",
        "2",
        "--grid",
        "alpha=0,0.25",
        "--grid",
        "initial_samples_per_cell=1,9",
        "--equal-samples",
        "--json",
        "--quiet",
        "--out",
        out.to_str().unwrap(),
        "--cache",
        dir.join("cache").to_str().unwrap(),
    ]);
    assert!(o.status.success(), "stderr: {}", stderr(&o));
    let report: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let written: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("tune.json")).unwrap()).unwrap();
    assert_eq!(report, written);
    let rows = report["rows"].as_array().unwrap();
    // l = 9 exceeds max_samples_per_leaf (4): two configurations skipped.
    assert_eq!(rows.len(), 2, "{report}");
    assert_eq!(report["skipped"].as_array().unwrap().len(), 2);
    let relmse: Vec<f64> = rows.iter().map(|r| r["relmse"].as_f64().unwrap()).collect();
    assert!(relmse[0] <= relmse[1], "ranked by RelMSE: {relmse:?}");
    for r in rows {
        let ci = r["relmse_ci95"].as_array().unwrap();
        let m = r["relmse"].as_f64().unwrap();
        assert!(ci[0].as_f64().unwrap() <= m && m <= ci[1].as_f64().unwrap());
        assert_eq!(r["params"]["spp"], 4.0);
    }
    assert!(report["best_table"]
        .as_str()
        .unwrap()
        .starts_with("[mdas]\n"));
    let csv = std::fs::read_to_string(out.join("tune.csv")).unwrap();
    assert_eq!(csv.lines().count(), 3);

    // A bad grid key fails before any work, naming the keys.
    let bad = dir.join("bad");
    let o = mdas(&[
        "tune",
        "scenes/area_light_plane.toml",
        "--grid",
        "alfa=1",
        "--out",
        bad.to_str().unwrap(),
    ]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("unknown key 'alfa'"), "{}", stderr(&o));
    assert!(!bad.exists());
    std::fs::remove_dir_all(&dir).ok();
}

/// The reference cache's key covers the meshes a scene loads: editing the
/// OBJ renders a new reference instead of reusing the stale one.
#[test]
fn reference_cache_sees_edited_meshes() {
    let dir = temp_dir("ref-mesh");
    let obj = dir.join("tri.obj");
    std::fs::write(&obj, "v -1 0.5 -1\nv 1 0.5 -1\nv 0 0.5 1\nf 1 3 2\n").unwrap();
    let scene = scene_variant(&dir, "with-mesh.toml", |t| {
        let at = t.find("[[light]]").expect("a light table");
        format!(
            "{}[[shape]]\ntype = \"mesh\"\nmaterial = \"grey\"\nfile = \"tri.obj\"\n\n{}",
            &t[..at],
            &t[at..]
        )
    });
    let cache = dir.join("cache");
    let args = [
        "reference",
        scene.to_str().unwrap(),
        "--spp",
        "4",
        "--scale",
        "0.125",
        "--cache",
        cache.to_str().unwrap(),
    ];
    let run = |expect: &str| {
        let o = mdas(&args);
        assert!(o.status.success(), "stderr: {}", stderr(&o));
        let out = String::from_utf8_lossy(&o.stdout).into_owned();
        assert!(out.contains(expect), "expected '{expect}': {out}");
    };
    run("rendered");
    run("cached");
    // The triangle moves: a new entry, rendered.
    std::fs::write(&obj, "v -1 0.8 -1\nv 1 0.8 -1\nv 0 0.8 1\nf 1 3 2\n").unwrap();
    run("rendered");
    std::fs::remove_dir_all(&dir).ok();
}
