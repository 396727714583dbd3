//! `mdas compare` and `mdas sweep` end to end on small films: every listed
//! file is written, the report agrees with the files (RelMSE recomputed from
//! the EXRs, phase times summing to the total, equal-time brackets within
//! the search's stated tolerance, the density map summing to MDAS's
//! samples), and bad input fails before anything is written.

mod common;
mod report_checks;

use common::gpu;
use mdas::compare::sweep::{sweep, SweepSpec, CSV_HEADER};
use mdas::compare::{compare, Budget, CompareSpec, Setup};
use mdas::image_io::read_exr;
use mdas::integrator::mdas::MdasParams;
use report_checks::{check_method, close};
use serde_json::Value;
use sha2::Digest;
use std::path::{Path, PathBuf};

fn temp_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("mdas-compare-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    dir
}

/// The CLI's default MDAS parameters at `scale`, with `spp` if given.
fn params_at(scale: f32, spp: Option<f32>) -> impl Fn(MdasParams) -> MdasParams {
    move |p| {
        let p = mdas::session::mdas_params_at_scale(p, scale);
        MdasParams {
            spp: spp.unwrap_or(p.spp),
            ..p
        }
    }
}

fn spec<'a>(
    scene: &str,
    scale: f32,
    out: &Path,
    budget: Budget,
    params: &'a dyn Fn(MdasParams) -> MdasParams,
) -> CompareSpec<'a> {
    CompareSpec {
        setup: setup(scene, scale, out, params),
        budget,
        max_spp: 1 << 12,
        seeds: 2,
        crops: vec![],
        uniform: false,
        adaptive: true,
    }
}

/// Small, fast settings: a 64-spp reference, one timed repeat.
fn setup<'a>(
    scene: &str,
    scale: f32,
    out: &Path,
    params: &'a dyn Fn(MdasParams) -> MdasParams,
) -> Setup<'a> {
    Setup {
        scene: PathBuf::from(scene),
        scale,
        ref_spp: 64,
        ref_seed: 1,
        cache_dir: std::env::temp_dir().join(format!("mdas-compare-cache-{}", std::process::id())),
        halton_seed: 0,
        repeats: 1,
        out: out.to_path_buf(),
        progress: false,
        mdas_params: params,
        frame: None,
    }
}

/// Checks report.json in `out` against the files beside it.
fn check_report(out: &Path) -> Value {
    let json: Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap()).unwrap();
    for key in ["scene", "scale", "seed", "adapter", "version", "reference"] {
        assert!(json.get(key).is_some(), "report.json lacks {key}");
    }
    // Provenance: the scene file's hash, the MDAS parameters as run (its
    // budget and first seed are MDAS's method entry's), the integrand.
    let p = &json["provenance"];
    let scene = std::fs::read(json["scene"].as_str().unwrap()).unwrap();
    let digest: String = sha2::Sha256::digest(&scene)
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect();
    assert_eq!(p["scene_sha256"].as_str().unwrap(), digest);
    let mdas = &json["methods"][0];
    assert_eq!(
        p["mdas"]["spp"].as_f64().unwrap(),
        mdas["spp"].as_f64().unwrap()
    );
    assert_eq!(p["mdas"]["seed"], mdas["seeds"][0]);
    assert!(p["dims"].as_u64().unwrap() >= 3 && !p["integrand"].as_str().unwrap().is_empty());
    assert!(!p["command_line"].as_array().unwrap().is_empty());
    let t = p["timestamp_utc"].as_str().unwrap();
    assert!(
        t.len() == 20 && t.ends_with('Z') && t.starts_with("20"),
        "{t}"
    );
    let files = json["files"].as_object().unwrap();
    for stem in [
        "reference",
        "mdas",
        "halton",
        "relmse-mdas",
        "relmse-halton",
        "flip-mdas",
        "flip-halton",
        "density-mdas",
    ] {
        for ext in ["exr", "png"] {
            let name = format!("{stem}.{ext}");
            assert!(out.join(&name).is_file(), "{name} missing");
            assert!(files.values().any(|v| v == &name), "{name} not listed");
        }
    }
    for name in files.values() {
        assert!(
            out.join(name.as_str().unwrap()).is_file(),
            "{name} listed, not written"
        );
    }
    let (w, h, reference) = read_exr(&out.join("reference.exr")).unwrap();
    assert_eq!(
        (w as u64, h as u64),
        (
            json["film"]["width"].as_u64().unwrap(),
            json["film"]["height"].as_u64().unwrap()
        )
    );
    let methods = json["methods"].as_array().unwrap();
    let adaptive = files.contains_key("adaptive");
    assert_eq!(
        methods.len(),
        2 + adaptive as usize + files.contains_key("mdas_uniform") as usize
    );
    for m in methods {
        let name = m["name"].as_str().unwrap();
        // RelMSE, MSE, heat map and phase sum against the written files.
        let total = check_method(out, m, &reference);
        let t = m["time_ms"].as_object().unwrap();
        let phases: Vec<&str> = t.keys().map(String::as_str).collect();
        // MDAS-uniform is MDAS with other parameters: the same phases.
        let expected: &[&str] = if name == "mdas" || name == "mdas-uniform" {
            &[
                "adaptive",
                "error",
                "evaluate",
                "initial",
                "reconstruction",
                "total",
            ]
        } else if name == "adaptive" {
            &["accumulate", "adaptive", "evaluate", "total"]
        } else {
            &["accumulate", "evaluate", "total"]
        };
        assert_eq!(phases, expected, "{name} phases");
        let samples = m["samples"].as_f64().unwrap();
        assert!(close(
            m["samples_per_s"].as_f64().unwrap(),
            samples / (total / 1e3),
            1e-9
        ));
    }
    // Equal time: the Halton search brackets the target within the stated
    // tolerance (hi − lo ≤ max(1, lo/32) spp) and interpolates between them.
    let eq = &json["equal_time"];
    let target = eq["target_ms"].as_f64().unwrap();
    let check_search = |s: &Value| {
        let target = s["target_ms"].as_f64().unwrap();
        let (lo, hi) = (&s["lo"], &s["hi"]);
        let (lo_spp, hi_spp) = (lo["spp"].as_u64().unwrap(), hi["spp"].as_u64().unwrap());
        let (lo_t, hi_t) = (
            lo["time_ms"].as_f64().unwrap(),
            hi["time_ms"].as_f64().unwrap(),
        );
        let r = s["relmse"].as_f64().unwrap();
        let (r_lo, r_hi) = (
            lo["relmse"].as_f64().unwrap(),
            hi["relmse"].as_f64().unwrap(),
        );
        if s["bracketed"].as_bool().unwrap() && lo_spp < hi_spp {
            assert!(
                lo_t <= target && target <= hi_t,
                "{lo_t} ≤ {target} ≤ {hi_t}"
            );
            assert!(
                hi_spp - lo_spp <= (lo_spp / 32).max(1),
                "bracket {lo_spp}..{hi_spp}"
            );
            assert!(r_lo.min(r_hi) * (1.0 - 1e-12) <= r && r <= r_lo.max(r_hi) * (1.0 + 1e-12));
        } else {
            assert!(r == r_lo || r == r_hi);
        }
    };
    check_search(&eq["halton"]);
    let mdas_relmse = eq["mdas_relmse"].as_f64().unwrap();
    match eq["mode"].as_str().unwrap() {
        "mdas" => {
            // The search looked for MDAS's measured time; the target is
            // MDAS's fastest interleaved round.
            let search_target = eq["halton"]["target_ms"].as_f64().unwrap();
            assert_eq!(
                search_target,
                methods[0]["time_ms"]["total"].as_f64().unwrap()
            );
            let mut rounds: Vec<f64> = eq["interleaved"]["mdas_ms"]
                .as_array()
                .unwrap()
                .iter()
                .map(|v| v.as_f64().unwrap())
                .collect();
            rounds.sort_by(f64::total_cmp);
            assert!(rounds.len() >= 9);
            assert_eq!(target, rounds[0]);
            assert_eq!(mdas_relmse, methods[0]["relmse"].as_f64().unwrap());
            // Equal samples and the ratio's interval are reported.
            let q = &eq["equal_samples"];
            assert!(close(
                q["relmse_ratio"].as_f64().unwrap(),
                q["mdas_relmse"].as_f64().unwrap() / q["halton_relmse"].as_f64().unwrap(),
                1e-12
            ));
            let ci = eq["relmse_ratio_ci95"].as_array().unwrap();
            assert!(ci[0].as_f64().unwrap() <= ci[1].as_f64().unwrap());
        }
        _ => check_search(&eq["mdas"]),
    }
    let ratio = mdas_relmse / eq["halton_relmse"].as_f64().unwrap();
    assert!(close(eq["relmse_ratio"].as_f64().unwrap(), ratio, 1e-12));
    if adaptive {
        check_adaptive(out, &json);
        for stem in [
            "adaptive",
            "relmse-adaptive",
            "flip-adaptive",
            "density-adaptive",
        ] {
            for ext in ["exr", "png"] {
                let name = format!("{stem}.{ext}");
                assert!(files.values().any(|v| v == &name), "{name} not listed");
            }
        }
    } else {
        assert!(eq.get("adaptive").is_none() && eq["equal_samples"].get("adaptive").is_none());
    }
    // The figure: a column of panels at least MIN_PANEL wide per image
    // (small films are upscaled), listed with the files.
    assert_eq!(files["figure"], "figure.png");
    let figure = image::open(out.join("figure.png")).unwrap();
    let columns = 3 + adaptive as u32;
    assert!(
        figure.width() >= columns * mdas::compare::figure::MIN_PANEL,
        "figure {}×{}",
        figure.width(),
        figure.height()
    );
    // The density map holds MDAS's samples.
    let (_, _, density) = read_exr(&out.join("density-mdas.exr")).unwrap();
    let total: f64 = density.iter().map(|p| p[0] as f64).sum();
    let samples = methods[0]["samples"].as_f64().unwrap();
    assert!(
        close(total, samples, 1e-4),
        "density sums to {total}, {samples} samples"
    );
    json
}

/// Pixel-adaptive Halton, the third method: its entry follows Halton's,
/// its equal-time figures are its entry's (the seed mean at the searched
/// budget nearer the target, whose run brackets or converged), its ratios
/// are the quotients of the reported RelMSEs, its written image is
/// `AdaptiveHalton` at that budget and Halton's first seed bit for bit,
/// and its density map holds that render's samples.
fn check_adaptive(out: &Path, json: &Value) {
    let m = &json["methods"][2];
    assert_eq!(m["name"], "adaptive");
    assert_eq!(m["seeds"], json["methods"][1]["seeds"], "Halton's seeds");
    let eq = &json["equal_time"];
    let a = &eq["adaptive"];
    let relmse = a["relmse"].as_f64().unwrap();
    assert_eq!(relmse, m["relmse"].as_f64().unwrap());
    assert_eq!(a["spp"].as_f64(), m["spp"].as_f64());
    assert_eq!(a["spp_used"], m["spp_used"]);
    assert!(close(
        a["adaptive_over_halton"].as_f64().unwrap(),
        relmse / eq["halton_relmse"].as_f64().unwrap(),
        1e-12
    ));
    assert!(close(
        a["mdas_over_adaptive"].as_f64().unwrap(),
        eq["mdas_relmse"].as_f64().unwrap() / relmse,
        1e-12
    ));
    let s = &a["search"];
    let run = &s[s["image_run"].as_str().unwrap()];
    assert_eq!(run["spp"].as_f64(), m["spp"].as_f64());
    assert_eq!(run["samples"], m["samples"]);
    assert_eq!(a["time_ms"], run["time_ms"]);
    // A search that did not bracket the target says why: it converged.
    if s["bracketed"] == false && a.get("converged_spp").is_some() {
        let notes = a["notes"].as_array().unwrap();
        assert!(notes
            .iter()
            .any(|n| n.as_str().unwrap().contains("converged")));
    }
    let q = &eq["equal_samples"];
    let qa = &q["adaptive"];
    assert_eq!(qa["spp"], q["spp"]);
    assert!(close(
        qa["adaptive_over_halton"].as_f64().unwrap(),
        qa["relmse"].as_f64().unwrap() / q["halton_relmse"].as_f64().unwrap(),
        1e-12
    ));
    // Below the first check adaptive renders Halton's samples at the same
    // seeds, summed in another order where the spp is not a multiple of
    // the samples per invocation (pixel values then differ in the last
    // bits: relative 1e-6 bounds float32 sums of a few dozen samples):
    // the same RelMSE, and the paired interval is the point 1.
    let first = a["params"]["first_check"].as_u64().unwrap();
    if q["spp"].as_u64().unwrap() < first {
        let r = qa["relmse"].as_f64().unwrap();
        assert!(close(r, q["halton_relmse"].as_f64().unwrap(), 1e-6));
        let ci: Vec<f64> = qa["adaptive_over_halton_ci95"]
            .as_array()
            .unwrap()
            .iter()
            .map(|v| v.as_f64().unwrap())
            .collect();
        assert!(ci.iter().all(|&c| (c - 1.0).abs() < 1e-6), "{ci:?}");
        assert!(qa["notes"][0]
            .as_str()
            .unwrap()
            .contains("below its first check"));
    }
    // The written image and its sample counts, rendered again.
    let scene = json["scene"].as_str().unwrap();
    let prepared = mdas::session::prepare(
        gpu(),
        Path::new(scene),
        json["scale"].as_f64().unwrap() as f32,
    )
    .unwrap();
    let mut adaptive =
        mdas::integrator::adaptive::AdaptiveHalton::new(mdas::compare::adaptive::params(
            m["spp"].as_f64().unwrap(),
            m["seeds"][0].as_u64().unwrap() as u32,
        ))
        .unwrap();
    let direct =
        mdas::integrator::Integrator::render(&mut adaptive, gpu(), prepared.integrand.as_ref())
            .unwrap();
    let (_, _, written) = read_exr(&out.join("adaptive.exr")).unwrap();
    assert!(
        written == direct.image,
        "adaptive.exr is not AdaptiveHalton's render"
    );
    assert_eq!(m["samples"].as_u64(), Some(direct.samples));
    let (_, _, density) = read_exr(&out.join("density-adaptive.exr")).unwrap();
    let total: f64 = density.iter().map(|p| p[0] as f64).sum();
    assert!(close(total, direct.samples as f64, 1e-6), "{total}");
}

#[test]
fn compare_area_light_plane_writes_a_consistent_report() {
    let out = temp_dir("plane");
    let params = params_at(0.25, Some(4.0));
    let report = compare(
        gpu(),
        &CompareSpec {
            uniform: true,
            ..spec(
                "scenes/area_light_plane.toml",
                0.25,
                &out,
                Budget::MdasSpp,
                &params,
            )
        },
    )
    .unwrap();
    let json = check_report(&out);
    assert_eq!(json["methods"][0]["samples"].as_u64(), Some(32 * 24 * 4));
    assert_eq!(json["reference"]["spp"].as_u64(), Some(64));
    assert_eq!(report.methods[1].name, "halton");
    assert_eq!(report.methods[2].name, "adaptive");
    // --uniform: MDAS-uniform at MDAS's budget and seeds, and the ratio
    // of what adaptivity buys.
    let u = &json["methods"][3];
    assert_eq!(u["name"], "mdas-uniform");
    assert_eq!(u["samples"], json["methods"][0]["samples"]);
    assert_eq!(u["seeds"], json["methods"][0]["seeds"]);
    let q = &json["equal_time"]["equal_samples"];
    let ratio = q["adaptivity_ratio"].as_f64().unwrap();
    assert!(close(
        ratio,
        json["methods"][0]["relmse"].as_f64().unwrap() / u["relmse"].as_f64().unwrap(),
        1e-12
    ));
    // Its image is MDAS at the same budget and first seed with α = 0 and
    // one candidate, bit for bit (the scene's α = ¼ and four candidates
    // give another image).
    let prepared =
        mdas::session::prepare(gpu(), Path::new("scenes/area_light_plane.toml"), 0.25).unwrap();
    let p = params(prepared.scene.mdas);
    assert!(p.alpha > 0.0 && p.candidates > 1);
    let mut uniform = mdas::integrator::Mdas::new(MdasParams {
        alpha: 0.0,
        candidates: 1,
        ..p
    })
    .unwrap();
    let direct =
        mdas::integrator::Integrator::render(&mut uniform, gpu(), prepared.integrand.as_ref())
            .unwrap()
            .image;
    let (_, _, written) = read_exr(&out.join("mdas-uniform.exr")).unwrap();
    assert!(
        written == direct,
        "mdas-uniform.exr is not MDAS at α = 0, one candidate"
    );
    // Called as a library (where the parameters' seed need not be the
    // first of the seeds), it renders with the first of the seeds it is
    // given: here the same image, although the parameters say another seed.
    let (run, stats) = mdas::compare::intervals::uniform_over_seeds(
        gpu(),
        MdasParams {
            seed: p.seed.wrapping_add(17),
            ..p
        },
        &[p.seed, p.seed.wrapping_add(1)],
        1,
        prepared.integrand.as_ref(),
        &direct,
        &indicatif::ProgressBar::hidden(),
    )
    .unwrap();
    assert!(
        run.measured.render.image == direct,
        "uniform_over_seeds did not render its first seed"
    );
    assert_eq!((run.spp, stats.seeds), (4, 2));
    std::fs::remove_dir_all(&out).ok();
}

#[test]
fn compare_cornell_writes_every_file() {
    let out = temp_dir("cornell");
    // 16 spp: MDAS adapts (and reports its error and adaptive phases);
    // its automatic grid leaves at least 1/6 of any budget to adaptive samples.
    let params = params_at(0.125, Some(16.0));
    // `--methods halton,mdas`: pixel-adaptive Halton left out.
    compare(
        gpu(),
        &CompareSpec {
            adaptive: false,
            ..spec("scenes/cornell.toml", 0.125, &out, Budget::MdasSpp, &params)
        },
    )
    .unwrap();
    let json = check_report(&out);
    assert_eq!(json["methods"].as_array().unwrap().len(), 2);
    assert!(!out.join("adaptive.exr").exists());
    std::fs::remove_dir_all(&out).ok();
}

#[test]
fn compare_at_a_time_budget_searches_both_methods() {
    let out = temp_dir("budget");
    let params = params_at(0.25, None);
    // A budget safely above MDAS's smallest render on this (shared, noisy)
    // adapter: ten times its measured time (three was not enough while a
    // build shared the two cores: the search then measured the initial
    // samples at 3.7× the first measurement, 2026-12-07).
    let prepared =
        mdas::session::prepare(gpu(), Path::new("scenes/area_light_plane.toml"), 0.25).unwrap();
    let integrand = prepared.integrand.as_ref();
    let p = params(prepared.scene.mdas);
    let min_spp = mdas::compare::experiment::mdas_min_spp(p, integrand).unwrap();
    let mut smallest = mdas::integrator::Mdas::new(MdasParams {
        spp: min_spp as f32,
        ..p
    })
    .unwrap();
    let t = mdas::compare::measure(gpu(), &mut smallest, integrand, 1)
        .unwrap()
        .total_ms();
    compare(
        gpu(),
        &spec(
            "scenes/area_light_plane.toml",
            0.25,
            &out,
            Budget::TimeMs(10.0 * t),
            &params,
        ),
    )
    .unwrap();
    let json = check_report(&out);
    assert_eq!(json["equal_time"]["mode"], "budget");
    assert!(json["equal_time"]["mdas"].is_object());
    std::fs::remove_dir_all(&out).ok();
}

fn assert_fails_without_output(spec: &CompareSpec, expect: &str) {
    let err = format!("{:#}", compare(gpu(), spec).unwrap_err());
    assert!(err.contains(expect), "expected '{expect}' in: {err}");
    assert!(
        !spec.setup.out.join("report.json").exists(),
        "partial report"
    );
    assert!(
        !spec.setup.out.exists(),
        "{} left behind",
        spec.setup.out.display()
    );
}

#[test]
fn bad_input_fails_before_writing_anything() {
    let params = params_at(0.25, None);
    // Unknown scene.
    let out = temp_dir("bad-scene");
    assert_fails_without_output(
        &spec(
            "scenes/no_such_scene.toml",
            0.25,
            &out,
            Budget::MdasSpp,
            &params,
        ),
        "no_such_scene",
    );
    // MDAS budget below its initial sample count.
    let tiny = params_at(0.25, Some(0.01));
    let out = temp_dir("bad-spp");
    assert_fails_without_output(
        &spec(
            "scenes/area_light_plane.toml",
            0.25,
            &out,
            Budget::MdasSpp,
            &tiny,
        ),
        "initial samples",
    );
    // A time budget below MDAS's initial samples' time (found by rendering,
    // still before any file).
    let out = temp_dir("bad-time");
    assert_fails_without_output(
        &spec(
            "scenes/area_light_plane.toml",
            0.25,
            &out,
            Budget::TimeMs(1e-6),
            &params,
        ),
        "below the time MDAS needs",
    );
    // A Halton seed equal to the reference's.
    let out = temp_dir("bad-seed");
    let mut same_seed = spec(
        "scenes/area_light_plane.toml",
        0.25,
        &out,
        Budget::MdasSpp,
        &params,
    );
    same_seed.setup.halton_seed = same_seed.setup.ref_seed;
    assert_fails_without_output(&same_seed, "equals the reference seed");
    // An output directory that cannot be created (its parent is a file).
    let file = temp_dir("bad-out-file");
    std::fs::write(&file, b"not a directory").unwrap();
    let out = file.join("out");
    assert_fails_without_output(
        &spec(
            "scenes/area_light_plane.toml",
            0.25,
            &out,
            Budget::MdasSpp,
            &params,
        ),
        "cannot create output directory",
    );
    std::fs::remove_file(&file).ok();
}

#[test]
fn sweep_writes_csv_and_svg() {
    let out = temp_dir("sweep");
    let params = params_at(0.25, None);
    let result = sweep(
        gpu(),
        &SweepSpec {
            setup: setup("scenes/area_light_plane.toml", 0.25, &out, &params),
            spps: vec![1, 2, 4],
            seeds: 2,
            adaptive: true,
        },
    )
    .unwrap();
    let csv = std::fs::read_to_string(out.join("sweep.csv")).unwrap();
    let lines: Vec<&str> = csv.lines().collect();
    assert_eq!(lines[0], CSV_HEADER);
    assert_eq!(lines.len(), 1 + result.rows.len());
    let halton: Vec<_> = result
        .rows
        .iter()
        .filter(|r| r.method == "halton")
        .collect();
    assert_eq!(halton.len(), 3);
    // Pixel-adaptive Halton at every budget, after Halton's rows.
    let adaptive: Vec<_> = result
        .rows
        .iter()
        .filter(|r| r.method == "adaptive")
        .collect();
    assert_eq!(
        adaptive.iter().map(|r| r.spp).collect::<Vec<_>>(),
        [1, 2, 4]
    );
    assert!(result
        .rows
        .ends_with(&adaptive.into_iter().cloned().collect::<Vec<_>>()));
    assert_eq!(
        result.rows.iter().filter(|r| r.method == "mdas").count() + result.mdas_skipped.len(),
        3
    );
    assert!(result
        .rows
        .iter()
        .all(|r| r.time_ms > 0.0 && r.relmse > 0.0));
    // Two seeds per point, Halton's skipping the reference's; each mean
    // inside its interval.
    for r in &result.rows {
        assert_eq!(r.seeds.len(), 2);
        assert!(
            r.relmse_ci95[0] <= r.relmse && r.relmse <= r.relmse_ci95[1],
            "{r:?}"
        );
        if r.method == "halton" || r.method == "adaptive" {
            assert_eq!(r.seeds, vec![0, 2], "seed 1 is the reference's");
        }
    }
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("sweep.json")).unwrap()).unwrap();
    assert_eq!(json["rows"].as_array().unwrap().len(), result.rows.len());
    assert_eq!(json["provenance"]["integrand"], "area_light");
    let svg = std::fs::read_to_string(out.join("sweep.svg")).unwrap();
    assert!(
        svg.starts_with("<svg")
            && svg.contains("Halton")
            && svg.contains("MDAS")
            && svg.contains("adaptive")
    );
    assert_eq!(svg.matches("<circle").count(), result.rows.len());
    // An error bar and an spp label per point.
    assert_eq!(
        svg.matches("stroke-width=\"1.2\"").count(),
        result.rows.len()
    );
    assert!(svg.contains(">4 spp<"));
    let png = image::open(out.join("sweep.png")).unwrap();
    assert_eq!((png.width(), png.height()), (720, 480));
    std::fs::remove_dir_all(&out).ok();
}
