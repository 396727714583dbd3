//! `mdas compare`: MDAS against Halton and pixel-adaptive Halton at equal
//! time (or light samplers against each other with `--samplers`).

use super::*;

#[derive(clap::Args)]
pub(crate) struct CompareArgs {
    /// Scene file: TOML, or a Mitsuba 3 XML file (.xml; the subset in docs/scene-format.md).
    pub(crate) scene: PathBuf,
    /// MDAS samples per pixel (average, may be fractional; default: the
    /// scene's [mdas] spp). Its measured time is the equal-time target.
    #[arg(long, conflicts_with = "time_ms")]
    pub(crate) spp: Option<f32>,
    /// Instead of MDAS's time at --spp, give both methods (with
    /// --samplers: every method) this budget (milliseconds; every spp
    /// is searched).
    #[arg(long)]
    pub(crate) time_ms: Option<f64>,
    /// Light sampler of the compared renders of a many_light scene,
    /// overriding its [integrand] sampler (an error for other
    /// integrands); the reference keeps the scene's own.
    #[arg(long, value_name = "NAME", conflicts_with = "samplers")]
    pub(crate) sampler: Option<SamplerKind>,
    /// How the compared renders' shadow rays are answered, overriding the
    /// scene's [integrand] visibility: bvh or voxel (approximate; its
    /// bias then shows against the reference, which always uses the BVH).
    #[arg(long, value_name = "BACKEND", conflicts_with = "samplers")]
    pub(crate) visibility: Option<VisibilityKind>,
    // --cut-size and --cut-sampling apply to every compared render (with
    // --samplers, every sampler); the reference keeps the scene's own table,
    // which every unbiased sampler converges to.
    #[command(flatten)]
    pub(crate) cuts: CutArgs,
    // The help lists the registry's kinds (lights::registry::REGISTRY).
    #[arg(long, value_name = "NAMES", value_delimiter = ',', help = format!(
        "Compare these light samplers (comma-separated: {}) under Halton at equal time; \
         MDAS with `tree` sets the target (or --time-ms). The scene's integrand must be \
         many_light",
        SamplerKind::names()
    ))]
    pub(crate) samplers: Option<Vec<SamplerKind>>,
    /// Seeds per method (MDAS from its seed on, Halton from --seed on,
    /// skipping the reference's; default 3): the report gives each
    /// method's mean RelMSE with a 95% interval, its bias and variance, and
    /// the ratio's interval. With --samplers (default 1): each sampler's
    /// two bracketing budgets over the seeds, its mean RelMSE, MSE and
    /// MSE/uniform at the target time with 95% intervals, and at the
    /// budget nearer the target its relative bias per channel and its MSE
    /// split into bias² and variance.
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=64))]
    pub(crate) seeds: Option<u32>,
    /// Inset of the figure, as x,y,w,h in film pixels (repeatable; default:
    /// two insets where the methods' errors differ most).
    #[arg(long, value_name = "X,Y,W,H", value_parser = parse_crop, conflicts_with = "samplers")]
    pub(crate) crop: Vec<mdas::compare::figure::Crop>,
    /// Also render MDAS-uniform (α = 0, one candidate: MDAS's grid and
    /// reconstruction without value-driven sampling) at MDAS's spp and
    /// seeds, and report what adaptivity buys (RelMSE MDAS/MDAS-uniform).
    #[arg(long, conflicts_with = "samplers")]
    pub(crate) uniform: bool,
    /// The methods compared, comma-separated: halton and mdas always;
    /// adaptive (pixel-adaptive Halton with Blender Cycles' rule, `render
    /// --integrator adaptive`'s defaults: threshold 0.01, 64 samples
    /// before the first check) with its own equal-time budget and at equal
    /// samples, unless left out (`--methods halton,mdas`).
    #[arg(
        long,
        value_name = "NAMES",
        value_delimiter = ',',
        default_value = "halton,mdas,adaptive",
        conflicts_with = "samplers"
    )]
    pub(crate) methods: Vec<IntegratorKind>,
    /// Compare on each frame of a many_light scene's sequence: A..B (B
    /// excluded) or A..=B, frame f at scene time `time + f ·
    /// frame_duration` (as `render --frames`). Each frame gets its own
    /// reference and a full comparison in OUT/frame-NNNN/; OUT/frames.csv
    /// and the printed summary give each method's means over the frames.
    #[arg(long, value_name = "A..B", value_parser = FrameRange::parse)]
    pub(crate) frames: Option<FrameRange>,
    #[command(flatten)]
    pub(crate) common: ExperimentArgs,
}

/// `--methods` of `compare` and `sweep`: halton and mdas must be there.
pub(crate) fn check_methods(methods: &[IntegratorKind]) -> Result<()> {
    for required in [IntegratorKind::Halton, IntegratorKind::Mdas] {
        if !methods.contains(&required) {
            anyhow::bail!(
                "--methods must hold halton and mdas (the comparison is built on them); only adaptive may be left out"
            );
        }
    }
    Ok(())
}

fn parse_crop(s: &str) -> Result<mdas::compare::figure::Crop, String> {
    mdas::compare::figure::Crop::parse(s).map_err(|e| format!("{e:#}"))
}

pub(crate) fn run(args: CompareArgs, ui: Ui) -> Result<()> {
    let CompareArgs {
        scene,
        spp,
        time_ms,
        sampler,
        visibility,
        cuts,
        samplers,
        seeds,
        crop,
        uniform,
        methods,
        frames,
        common,
    } = args;
    if samplers.is_none() {
        check_methods(&methods)?;
    }
    let out = common
        .out
        .clone()
        .unwrap_or_else(|| default_dir(&scene, "compare"));
    let mdas_params = |p: MdasParams| {
        common
            .mdas
            .params(p, common.reference.scale, spp, common.seed)
    };
    let budget = time_ms.map_or(
        mdas::compare::Budget::MdasSpp,
        mdas::compare::Budget::TimeMs,
    );
    let compare_at = |frame: Option<u32>, out: PathBuf| -> Result<mdas::compare::Report> {
        let setup = mdas::compare::Setup {
            frame,
            ..common.setup(ui, scene.clone(), out, &mdas_params)
        };
        match &samplers {
            Some(samplers) => mdas::compare::compare_samplers(
                Gpu::shared()?,
                &mdas::compare::SamplersSpec {
                    setup,
                    budget,
                    max_spp: common.max_spp,
                    samplers: samplers.clone(),
                    seeds: seeds.unwrap_or(1),
                    overrides: IntegrandOverrides {
                        cut_size: cuts.cut_size,
                        cut_sampling: cuts.cut_sampling,
                        ..IntegrandOverrides::default()
                    },
                },
            ),
            None => mdas::compare::compare_with(
                Gpu::shared()?,
                &mdas::compare::CompareSpec {
                    setup,
                    budget,
                    max_spp: common.max_spp,
                    seeds: seeds.unwrap_or(3),
                    crops: crop.clone(),
                    uniform,
                    adaptive: methods.contains(&IntegratorKind::Adaptive),
                },
                IntegrandOverrides {
                    sampler,
                    visibility,
                    frame: None,
                    cut_size: cuts.cut_size,
                    cut_sampling: cuts.cut_sampling,
                },
            ),
        }
    };
    if let Some(frames) = frames {
        return compare_frames(frames, &out, compare_at, ui);
    }
    let report = compare_at(None, out.clone())?;
    ui.result(mdas::compare::report::table(&report));
    ui.note(format!(
        "wrote {} files to {}",
        report.files.len(),
        out.display()
    ));
    ui.json(&report)
}

/// A comparison per frame (`compare --frames`).
#[derive(serde::Serialize)]
struct FramesRecord {
    frames: Vec<FrameReport>,
    /// Each method's means over the frames, in the first report's order.
    means: Vec<MethodMeans>,
    /// Geometric mean over the frames of the equal-time RelMSE ratio
    /// (MDAS / Halton; `--samplers`: MDAS / the baseline's).
    relmse_ratio_geomean: f64,
    csv: String,
}

#[derive(serde::Serialize)]
struct FrameReport {
    frame: u32,
    dir: String,
    report: mdas::compare::Report,
}

#[derive(serde::Serialize)]
struct MethodMeans {
    name: String,
    frames: usize,
    spp: f64,
    time_ms: f64,
    relmse: f64,
    mse: f64,
}

/// Runs `compare_at` on every frame (its output in `out/frame-NNNN`, as
/// one unit each: a failed frame leaves the finished ones), then writes
/// `out/frames.csv` and prints each method's means.
fn compare_frames(
    frames: FrameRange,
    out: &Path,
    compare_at: impl Fn(Option<u32>, PathBuf) -> Result<mdas::compare::Report>,
    ui: Ui,
) -> Result<()> {
    std::fs::create_dir_all(out)
        .map_err(|e| anyhow::anyhow!("cannot create {}: {e}", out.display()))?;
    let csv = out.join("frames.csv");
    mdas::atomic::check_writable(&csv)?;
    let frame_dir = |f: u32| out.join(format!("frame-{f:04}"));
    // Every frame's directory, before the first frame renders (issue 67,
    // hostile inputs class 6): the entries of `out` named as one of the
    // frames' (a range may hold billions of frames; `out` holds few).
    let mut taken: Vec<u32> = std::fs::read_dir(out)
        .map_err(|e| anyhow::anyhow!("cannot list {}: {e}", out.display()))?
        .filter_map(|e| {
            let name = e.ok()?.file_name().into_string().ok()?;
            let f: u32 = name.strip_prefix("frame-")?.parse().ok()?;
            let ours = name == format!("frame-{f:04}")
                && f >= frames.start
                && u64::from(f) < u64::from(frames.start) + u64::from(frames.count);
            ours.then_some(f)
        })
        .collect();
    taken.sort_unstable();
    for f in taken {
        mdas::atomic::check_dir_target(&frame_dir(f))?;
    }
    let mut done: Vec<FrameReport> = Vec::new();
    for f in frames.iter() {
        let dir = frame_dir(f);
        ui.note(format!("frame {f} → {}", dir.display()));
        let report = compare_at(Some(f), dir.clone())?;
        ui.result(format!(
            "frame {f}\n{}",
            mdas::compare::report::table(&report)
        ));
        done.push(FrameReport {
            frame: f,
            dir: dir.display().to_string(),
            report,
        });
        let text = frames_csv(&done);
        mdas::atomic::write_atomic(&csv, |p| Ok(std::fs::write(p, text.as_bytes())?))?;
    }
    let means = method_means(&done);
    let ratios: Vec<f64> = done
        .iter()
        .map(|d| d.report.equal_time.relmse_ratio)
        .collect();
    let relmse_ratio_geomean =
        (ratios.iter().map(|r| r.ln()).sum::<f64>() / ratios.len() as f64).exp();
    let mut table = format!(
        "means over {} frame{} of each method's reported run (Halton: the bracketing run nearer \
         to equal time):\n{:<24} {:>10} {:>12} {:>14} {:>14}\n",
        done.len(),
        if done.len() == 1 { "" } else { "s" },
        "method",
        "spp",
        "time ms",
        "RelMSE",
        "MSE"
    );
    for m in &means {
        table += &format!(
            "{:<24} {:>10.2} {:>12.2} {:>14.6e} {:>14.6e}\n",
            m.name, m.spp, m.time_ms, m.relmse, m.mse
        );
    }
    table += &format!(
        "equal-time RelMSE ratio, geometric mean over the frames: {relmse_ratio_geomean:.3}\n"
    );
    ui.result(table);
    ui.note(format!(
        "wrote {} frame comparisons and {}",
        done.len(),
        csv.display()
    ));
    ui.json(&FramesRecord {
        frames: done,
        means,
        relmse_ratio_geomean,
        csv: csv.display().to_string(),
    })
}

/// One row per frame and method.
fn frames_csv(done: &[FrameReport]) -> String {
    let rows = done.iter().flat_map(|d| {
        d.report.methods.iter().map(move |m| {
            vec![
                d.frame.to_string(),
                m.name.clone(),
                m.spp.to_string(),
                m.time_ms
                    .get("total")
                    .copied()
                    .unwrap_or(f64::NAN)
                    .to_string(),
                m.relmse.to_string(),
                m.mse.to_string(),
                d.report.equal_time.relmse_ratio.to_string(),
            ]
        })
    });
    mdas::compare::csv_table::csv_text("frame,method,spp,time_ms,relmse,mse,relmse_ratio", rows)
}

/// Each method's means over the frames that have it.
fn method_means(done: &[FrameReport]) -> Vec<MethodMeans> {
    let mut names: Vec<String> = Vec::new();
    for d in done {
        for m in &d.report.methods {
            if !names.contains(&m.name) {
                names.push(m.name.clone());
            }
        }
    }
    names
        .into_iter()
        .map(|name| {
            let runs: Vec<_> = done
                .iter()
                .flat_map(|d| d.report.methods.iter().filter(|m| m.name == name))
                .collect();
            let n = runs.len() as f64;
            let mean = |f: &dyn Fn(&mdas::compare::report::MethodReport) -> f64| {
                runs.iter().map(|m| f(m)).sum::<f64>() / n
            };
            MethodMeans {
                frames: runs.len(),
                spp: mean(&|m| m.spp),
                time_ms: mean(&|m| m.time_ms.get("total").copied().unwrap_or(f64::NAN)),
                relmse: mean(&|m| m.relmse),
                mse: mean(&|m| m.mse),
                name,
            }
        })
        .collect()
}
