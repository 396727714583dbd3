//! `mdas compare --samplers` (light samplers under Halton at equal time,
//! MDAS+tree setting the target) and `--sampler` overrides, on the tiny
//! many-light scene `scenes/tests/many_lights_small.toml`: every file is
//! written, report.json agrees with the files, bad input fails before
//! anything is written.

mod common;
mod report_checks;

use common::gpu;
use mdas::compare::{compare_samplers, Budget, SamplersSpec, Setup};
use mdas::image_io::{self, read_exr};
use mdas::integrator::mdas::MdasParams;
use mdas::lights::registry::SamplerKind;
use report_checks::{check_method, close};
use serde_json::Value;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

const SCENE: &str = "scenes/tests/many_lights_small.toml";

fn temp_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("mdas-samplers-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    dir
}

fn cache_dir() -> PathBuf {
    std::env::temp_dir().join(format!("mdas-samplers-cache-{}", std::process::id()))
}

/// MDAS at 2 spp (the least its initial grid allows here): a short target.
fn params(p: MdasParams) -> MdasParams {
    MdasParams { spp: 2.0, ..p }
}

fn spec<'a>(
    scene: &str,
    out: &Path,
    samplers: Vec<SamplerKind>,
    params: &'a dyn Fn(MdasParams) -> MdasParams,
) -> SamplersSpec<'a> {
    SamplersSpec {
        setup: Setup {
            scene: PathBuf::from(scene),
            scale: 1.0,
            ref_spp: 64,
            ref_seed: 1,
            cache_dir: cache_dir(),
            halton_seed: 0,
            repeats: 1,
            out: out.to_path_buf(),
            progress: false,
            mdas_params: params,
            frame: None,
        },
        budget: Budget::MdasSpp,
        max_spp: 1 << 12,
        samplers,
        seeds: 1,
        overrides: Default::default(),
    }
}

fn mdas_bin(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_mdas"))
        .args(args)
        .output()
        .expect("run mdas")
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

#[test]
fn compare_samplers_writes_a_consistent_report() {
    use SamplerKind::*;
    let out = temp_dir("ok");
    let report = compare_samplers(
        gpu(),
        &spec(SCENE, &out, vec![Uniform, Power, Tree], &params),
    )
    .unwrap();
    assert_eq!(report.methods.len(), 4);

    let json: Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap()).unwrap();
    // Every image is written and listed, and every listed file exists.
    let files = json["files"].as_object().unwrap();
    for stem in [
        "reference",
        "mdas-tree",
        "halton-uniform",
        "halton-power",
        "halton-tree",
        "relmse-mdas-tree",
        "relmse-halton-uniform",
        "relmse-halton-power",
        "relmse-halton-tree",
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
    assert!(!out.join("density-mdas.exr").exists());
    assert!(json["maps"].get("density_range").is_none());
    assert_eq!(json["reference"]["sampler"], "tree");

    // Methods: mdas+tree, then halton+<sampler> in the order listed.
    let methods = json["methods"].as_array().unwrap();
    let names: Vec<&str> = methods
        .iter()
        .map(|m| m["name"].as_str().unwrap())
        .collect();
    assert_eq!(
        names,
        ["mdas+tree", "halton+uniform", "halton+power", "halton+tree"]
    );
    let (w, h, reference) = read_exr(&out.join("reference.exr")).unwrap();
    assert_eq!((w, h), (48, 32));
    for m in methods {
        let name = m["name"].as_str().unwrap();
        let image_name = m["image"].as_str().unwrap();
        assert_eq!(image_name, format!("{}.exr", name.replace('+', "-")));
        // RelMSE, MSE, heat map and phase sum against the written files.
        check_method(&out, m, &reference);
        assert!(
            m["nonfinite"].as_u64() == Some(0),
            "{name} non-finite samples"
        );
    }
    assert_eq!(methods[0]["samples"].as_u64(), Some(48 * 32 * 2));

    // Equal time: MDAS+tree's total is the target; the ratio is against
    // halton+tree; each sampler's search brackets the target and its
    // values are interpolated between the bracketing runs.
    let eq = &json["equal_time"];
    let target = eq["target_ms"].as_f64().unwrap();
    assert_eq!(eq["mode"], "mdas");
    assert_eq!(target, methods[0]["time_ms"]["total"].as_f64().unwrap());
    assert_eq!(eq["baseline"], "halton+tree");
    let samplers = eq["samplers"].as_array().unwrap();
    let listed: Vec<&str> = samplers
        .iter()
        .map(|s| s["sampler"].as_str().unwrap())
        .collect();
    assert_eq!(listed, ["uniform", "power", "tree"]);
    let uniform_mse = samplers[0]["mse"].as_f64().unwrap();
    for (s, m) in samplers.iter().zip(&methods[1..]) {
        assert_eq!(s["method"], m["name"]);
        let search = &s["search"];
        let (lo, hi) = (&search["lo"], &search["hi"]);
        let (lo_spp, hi_spp) = (lo["spp"].as_u64().unwrap(), hi["spp"].as_u64().unwrap());
        let (lo_t, hi_t) = (
            lo["time_ms"].as_f64().unwrap(),
            hi["time_ms"].as_f64().unwrap(),
        );
        for key in ["relmse", "mse"] {
            let v = s[key].as_f64().unwrap();
            assert_eq!(v, search[key].as_f64().unwrap(), "{key}");
            let (a, b) = (lo[key].as_f64().unwrap(), hi[key].as_f64().unwrap());
            assert!(
                a.min(b) * (1.0 - 1e-12) <= v && v <= a.max(b) * (1.0 + 1e-12),
                "{key} {v} outside [{a}, {b}]"
            );
        }
        if search["bracketed"].as_bool().unwrap() && lo_spp < hi_spp {
            assert!(
                lo_t <= target && target <= hi_t,
                "{lo_t} ≤ {target} ≤ {hi_t}"
            );
            assert!(
                hi_spp - lo_spp <= (lo_spp / 32).max(1),
                "{lo_spp}..{hi_spp}"
            );
        }
        // The written image is the nearer bracketing run's.
        let run = if search["image_run"] == "lo" { lo } else { hi };
        assert_eq!(run["spp"].as_f64(), m["spp"].as_f64());
        let vs = s["mse_vs_uniform"].as_f64().unwrap();
        assert!(close(vs, s["mse"].as_f64().unwrap() / uniform_mse, 1e-12));
        assert!(s.get("seeds").is_none(), "one seed: no seed block");
    }
    assert_eq!(eq["halton"]["relmse"], samplers[2]["relmse"]);
    let ratio = eq["mdas_relmse"].as_f64().unwrap() / eq["halton_relmse"].as_f64().unwrap();
    assert!(close(eq["relmse_ratio"].as_f64().unwrap(), ratio, 1e-12));
    assert_eq!(eq["mdas_relmse"].as_f64(), methods[0]["relmse"].as_f64());

    // The table names every method.
    let table = mdas::compare::report::table(&report);
    for n in names {
        assert!(table.contains(n), "{n} not in:\n{table}");
    }
    std::fs::remove_dir_all(&out).ok();
}

fn assert_fails_without_output(spec: &SamplersSpec, expect: &str) {
    let err = format!("{:#}", compare_samplers(gpu(), spec).unwrap_err());
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
fn bad_sampler_comparisons_fail_before_writing_anything() {
    use SamplerKind::*;
    // Not a many_light scene.
    let out = temp_dir("not-many-light");
    assert_fails_without_output(
        &spec(
            "scenes/area_light_plane.toml",
            &out,
            vec![Uniform, Tree],
            &params,
        ),
        "many_light",
    );
    // No sampler, or one twice.
    let out = temp_dir("empty");
    assert_fails_without_output(&spec(SCENE, &out, vec![], &params), "at least one");
    let out = temp_dir("twice");
    assert_fails_without_output(&spec(SCENE, &out, vec![Power, Power], &params), "twice");
    // A time budget that is no time.
    let out = temp_dir("bad-time");
    let mut s = spec(SCENE, &out, vec![Power], &params);
    s.budget = Budget::TimeMs(-1.0);
    assert_fails_without_output(&s, "--time-ms");
    // MDAS below its initial sample count.
    let out = temp_dir("bad-spp");
    let tiny = |p: MdasParams| MdasParams { spp: 0.01, ..p };
    assert_fails_without_output(&spec(SCENE, &out, vec![Power], &tiny), "initial samples");
}

#[test]
fn cli_compare_samplers_rejects_bad_names_and_scenes() {
    let out = temp_dir("cli-bad");
    let cache = cache_dir();
    let run = |scene: &str, samplers: &str| {
        mdas_bin(&[
            "compare",
            scene,
            "--samplers",
            samplers,
            "--ref-spp",
            "16",
            "--repeats",
            "1",
            "--cache",
            cache.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ])
    };
    for (scene, samplers, expect) in [
        (SCENE, "uniform,bogus", "unknown light sampler 'bogus'"),
        ("scenes/area_light_plane.toml", "uniform,tree", "many_light"),
    ] {
        let o = run(scene, samplers);
        let err = stderr(&o);
        assert!(!o.status.success(), "{samplers} should fail: {err}");
        assert!(err.contains(expect), "expected '{expect}' in: {err}");
        assert!(!err.contains("panicked"), "{err}");
        assert!(!out.exists(), "{} left behind", out.display());
    }
    // The unknown-name message lists the valid names.
    let err = stderr(&run(SCENE, "bogus"));
    assert!(err.contains(&SamplerKind::names()), "{err}");
    // --sampler and --samplers do not go together.
    let o = mdas_bin(&["compare", SCENE, "--sampler", "tree", "--samplers", "power"]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("cannot be used with"), "{}", stderr(&o));
}

#[test]
fn cli_render_with_a_sampler_override() {
    let dir = temp_dir("render");
    std::fs::create_dir_all(&dir).unwrap();
    let out = dir.join("power.exr");
    let o = mdas_bin(&[
        "render",
        SCENE,
        "--sampler",
        "power",
        "--spp",
        "4",
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "stderr: {}", stderr(&o));
    assert!(stderr(&o).contains("sampler power"), "{}", stderr(&o));
    let (w, h, image) = read_exr(&out).unwrap();
    assert_eq!((w, h), (48, 32));
    assert!(image.iter().any(|p| p[0] > 0.0), "the lit plane is visible");

    // Not a many_light scene: a clear error, no file.
    let bad = dir.join("bad.exr");
    let o = mdas_bin(&[
        "render",
        "scenes/area_light_plane.toml",
        "--sampler",
        "power",
        "-o",
        bad.to_str().unwrap(),
    ]);
    let err = stderr(&o);
    assert!(!o.status.success());
    assert!(
        err.contains("--sampler power applies only to the many_light integrand")
            && err.contains("area_light"),
        "{err}"
    );
    assert!(!bad.exists() && !bad.with_extension("png").exists());
    // An unknown name lists the valid ones.
    let o = mdas_bin(&[
        "render",
        SCENE,
        "--sampler",
        "bogus",
        "-o",
        bad.to_str().unwrap(),
    ]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains(&SamplerKind::names()), "{}", stderr(&o));
    std::fs::remove_dir_all(&dir).ok();
}

/// Issue 18 item 7: a damaged cache entry is never used. Each damage
/// (truncated, empty, garbage, a right-sized image of zeros, a missing
/// record) makes the next call render the reference again, say why, and
/// restore the same image bit for bit (Halton is deterministic); an entry
/// that is a directory is an error naming it, not a silent failure.
#[test]
fn damaged_reference_cache_entries_are_rebuilt() {
    let cache = temp_dir("ref-cache-damage");
    let spec = mdas::session::ReferenceSpec {
        spp: 2,
        scale: 0.25,
        seed: 0,
    };
    let path = Path::new(SCENE);
    let get = || mdas::session::reference(gpu(), path, spec, &cache, None);
    let first = get().unwrap();
    assert_eq!(first.cache, mdas::session::CacheUse::Rendered);
    assert!(get().unwrap().cached());
    let exr = first.path.clone();
    let record = mdas::session::reference_record_path(&exr);
    let (w, h) = (first.film.width, first.film.height);
    let bytes = std::fs::read(&exr).unwrap();
    type Damage<'a> = Box<dyn Fn() + 'a>;
    let damages: Vec<(&str, Damage, &str)> = vec![
        (
            "truncated",
            Box::new(|| std::fs::write(&exr, &bytes[..bytes.len() / 2]).unwrap()),
            "cannot read",
        ),
        (
            "empty",
            Box::new(|| std::fs::write(&exr, b"").unwrap()),
            "cannot read",
        ),
        (
            "garbage",
            Box::new(|| std::fs::write(&exr, vec![0x5a; 4096]).unwrap()),
            "cannot read",
        ),
        (
            "zeros",
            Box::new(|| {
                image_io::write_exr(&exr, w, h, &vec![[0.0; 3]; (w * h) as usize]).unwrap()
            }),
            "checksum",
        ),
        (
            "no record",
            Box::new(|| std::fs::remove_file(&record).unwrap()),
            "record",
        ),
    ];
    for (name, damage, why) in &damages {
        damage();
        let again = get().unwrap();
        match &again.cache {
            mdas::session::CacheUse::Rebuilt(reason) => {
                assert!(reason.contains(why), "{name}: {reason}")
            }
            other => panic!("{name}: {other:?}"),
        }
        assert_eq!(again.image, first.image, "{name}");
        assert!(get().unwrap().cached(), "{name}: repaired");
    }
    std::fs::remove_file(&exr).unwrap();
    std::fs::create_dir(&exr).unwrap();
    let e = format!("{:#}", get().unwrap_err());
    assert!(e.contains("is a directory"), "{e}");
    std::fs::remove_dir_all(&cache).ok();
}

#[test]
fn reference_sampler_override_is_part_of_the_cache_key() {
    let cache = temp_dir("ref-cache");
    let spec = mdas::session::ReferenceSpec {
        spp: 4,
        scale: 0.5,
        seed: 0,
    };
    let path = Path::new(SCENE);
    let with = |k: Option<SamplerKind>| {
        mdas::session::reference_with(
            gpu(),
            path,
            spec,
            mdas::session::IntegrandOverrides {
                sampler: k,
                ..Default::default()
            },
            &cache,
            None,
        )
        .unwrap()
    };
    let own = with(None).path;
    assert_eq!(
        own,
        mdas::session::reference_cache_path(&cache, path, spec).unwrap()
    );
    // The scene's own sampler named explicitly: the same cache entry.
    let same = with(Some(SamplerKind::Tree));
    assert_eq!(same.path, own);
    assert!(same.cached());
    // Another sampler: its own entry.
    let other = with(Some(SamplerKind::Power));
    assert_ne!(other.path, own);
    assert!(!other.cached());
    // Overrides on a scene whose integrand has no light sampler fail, even
    // when that scene's reference is already in the cache.
    let plane = Path::new("scenes/area_light_plane.toml");
    mdas::session::reference(gpu(), plane, spec, &cache, None).unwrap();
    let err = mdas::session::reference_with(
        gpu(),
        Path::new("scenes/area_light_plane.toml"),
        spec,
        mdas::session::IntegrandOverrides::sampler(SamplerKind::Power),
        &cache,
        None,
    )
    .unwrap_err();
    assert!(format!("{err:#}").contains("many_light"));
    std::fs::remove_dir_all(&cache).ok();
}

#[test]
fn compare_with_a_sampler_override_reports_it() {
    let out = temp_dir("override");
    let spec = mdas::compare::CompareSpec {
        setup: spec(SCENE, &out, vec![], &params).setup,
        budget: Budget::MdasSpp,
        max_spp: 1 << 12,
        seeds: 1,
        crops: vec![],
        uniform: false,
        adaptive: false,
    };
    let report = mdas::compare::compare_with(
        gpu(),
        &spec,
        mdas::session::IntegrandOverrides::sampler(SamplerKind::Power),
    )
    .unwrap();
    let json: Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap()).unwrap();
    assert_eq!(json["sampler"], "power");
    // The reference keeps the scene's own sampler.
    assert_eq!(json["reference"]["sampler"], "tree");
    assert_eq!(report.methods[1].name, "halton");
    assert!(json["equal_time"].get("samplers").is_none());
    assert!(out.join("density-mdas.exr").is_file());
    // Overrides on other integrands fail before anything is written.
    let bad = temp_dir("override-bad");
    let mut bad_spec = spec;
    bad_spec.setup.scene = PathBuf::from("scenes/area_light_plane.toml");
    bad_spec.setup.out = bad.clone();
    let err = mdas::compare::compare_with(
        gpu(),
        &bad_spec,
        mdas::session::IntegrandOverrides::sampler(SamplerKind::Power),
    )
    .unwrap_err();
    assert!(format!("{err:#}").contains("many_light"));
    assert!(!bad.exists());
    std::fs::remove_dir_all(&out).ok();
}

/// `--seeds 3`: each sampler's bracketing budgets over Halton's seeds 0, 2
/// and 3 (1 is the reference's), checked against renders of the CLI with
/// those seeds: the means at lo and hi, interpolated log–log in time at
/// the target, are the report's; the intervals hold them; MSE/uniform is
/// the ratio of the two samplers' means.
#[test]
fn compare_samplers_over_seeds_matches_renders_with_each_seed() {
    use SamplerKind::*;
    let out = temp_dir("seeds");
    let spec = SamplersSpec {
        seeds: 3,
        ..spec(SCENE, &out, vec![Uniform, Tree], &params)
    };
    let report = compare_samplers(gpu(), &spec).unwrap();
    let json: Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap()).unwrap();
    let eq = &json["equal_time"];
    let target = eq["target_ms"].as_f64().unwrap();
    let reference = out.join("reference.exr");
    let (_, _, reference_image) = read_exr(&reference).unwrap();
    // The MSE of the render of `sampler` at `spp` with `seed`; its image
    // stays in `seed-<seed>.exr`.
    let mse_of = |sampler: &str, spp: u64, seed: u32| -> f64 {
        let o = mdas_bin(&[
            "--json",
            "render",
            SCENE,
            "--integrator",
            "halton",
            "--spp",
            &spp.to_string(),
            "--seed",
            &seed.to_string(),
            "--sampler",
            sampler,
            "--reference",
            reference.to_str().unwrap(),
            "-o",
            out.join(format!("seed-{seed}.exr")).to_str().unwrap(),
        ]);
        assert!(o.status.success(), "{}", stderr(&o));
        let v: Value = serde_json::from_slice(&o.stdout).unwrap();
        v["error"]["mse"].as_f64().unwrap()
    };
    let mut means = Vec::new();
    for s in eq["samplers"].as_array().unwrap() {
        let name = s["sampler"].as_str().unwrap();
        let seeds = &s["seeds"];
        assert_eq!(seeds["count"], 3, "{name}");
        let (lo, hi) = (&s["search"]["lo"], &s["search"]["hi"]);
        let mean_at = |run: &Value| {
            let spp = run["spp"].as_u64().unwrap();
            [0, 2, 3].iter().map(|&k| mse_of(name, spp, k)).sum::<f64>() / 3.0
        };
        // The bias and the MSE split are taken at the budget nearer the
        // target: that bracket is rendered last, so the seeds' images it
        // leaves in `seed-<k>.exr` are the ones to take statistics of.
        let bias_spp = seeds["bias_spp"].as_u64().unwrap();
        let near_is_lo = bias_spp == lo["spp"].as_u64().unwrap();
        if !near_is_lo {
            assert_eq!(bias_spp, hi["spp"].as_u64().unwrap(), "{name}");
        }
        let (m_lo, m_hi, m_near) = if near_is_lo {
            let m_hi = mean_at(hi);
            let m_lo = mean_at(lo);
            (m_lo, m_hi, m_lo)
        } else {
            let m_lo = mean_at(lo);
            let m_hi = mean_at(hi);
            (m_lo, m_hi, m_hi)
        };
        let images: Vec<Vec<[f32; 3]>> = [0, 2, 3]
            .iter()
            .map(|&k| read_exr(&out.join(format!("seed-{k}.exr"))).unwrap().2)
            .collect();
        let views: Vec<&[[f32; 3]]> = images.iter().map(Vec::as_slice).collect();
        let want = mdas::compare::seeds::SeedStats::new(&views, &reference_image).unwrap();
        for c in 0..3 {
            let b = seeds["relative_bias"][c].as_f64().unwrap();
            assert!(
                close(b, want.relative_bias[c], 1e-9),
                "{name}: bias {b} against {}",
                want.relative_bias[c]
            );
            let ci = &seeds["relative_bias_ci95"][c];
            let (a, z) = (ci[0].as_f64().unwrap(), ci[1].as_f64().unwrap());
            assert!(a <= b && b <= z, "{name}: bias {b} outside [{a}, {z}]");
        }
        let split = seeds["mse_bias2"].as_f64().unwrap() + seeds["mse_variance"].as_f64().unwrap();
        assert!(
            close(split, m_near, 1e-6),
            "{name}: bias² + variance {split} against MSE {m_near}"
        );
        let want = mdas::compare::equal_time::interpolate_log_log(
            target,
            (lo["time_ms"].as_f64().unwrap(), m_lo),
            (hi["time_ms"].as_f64().unwrap(), m_hi),
        );
        let mse = seeds["mse"].as_f64().unwrap();
        assert!(close(mse, want, 1e-9), "{name}: mse {mse} against {want}");
        for key in ["relmse", "mse"] {
            let v = seeds[key].as_f64().unwrap();
            let ci = &seeds[format!("{key}_ci95")];
            let (a, b) = (ci[0].as_f64().unwrap(), ci[1].as_f64().unwrap());
            assert!(a <= v && v <= b, "{name} {key}: {v} outside [{a}, {b}]");
        }
        means.push(mse);
    }
    let samplers = eq["samplers"].as_array().unwrap();
    let vs = samplers[1]["seeds"]["mse_vs_uniform"].as_f64().unwrap();
    assert!(close(vs, means[1] / means[0], 1e-12));
    let own = &samplers[0]["seeds"];
    assert_eq!(own["mse_vs_uniform"].as_f64(), Some(1.0));
    assert_eq!(own["mse_vs_uniform_ci95"], serde_json::json!([1.0, 1.0]));
    let ci = &samplers[1]["seeds"]["mse_vs_uniform_ci95"];
    let (a, b) = (ci[0].as_f64().unwrap(), ci[1].as_f64().unwrap());
    assert!(a <= vs && vs <= b, "MSE/uniform {vs} outside [{a}, {b}]");
    let table = mdas::compare::report::table(&report);
    assert!(table.contains("over 3 seeds"), "{table}");
    assert!(table.contains("bias over 3 seeds"), "{table}");
    std::fs::remove_dir_all(&out).ok();
}
