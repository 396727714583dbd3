//! `mdas render --frames A..B`: a sequence of a dynamic many-light scene,
//! as real-time stochastic lightcuts runs it (the paper averages its
//! timings over 512 frames). One `ManyLight` and one integrator serve every
//! frame: per frame the lights are recomputed at the frame time (VPLs
//! traced again), the light structure is built again and the cut pre-pass
//! runs again ([`mdas::integrand::ManyLight::set_frame`]); shaders,
//! pipelines and, for the GPU-built kinds, buffers are reused. Each frame
//! is written as it finishes (`X.NNNN.exr` and `.png`, atomically), and
//! `X.frames.csv` is rewritten after every frame, so an interrupted run
//! keeps the frames it finished and their times.

use super::render::{check_sampling, integrator_for, warn_image, RenderArgs};
use super::*;
use anyhow::Context;
use mdas::gpu::profiler::PhaseTimes;

/// The output of frame `f` for `-o X.ext`: `X.NNNN.ext` (at least four
/// digits).
pub(crate) fn numbered(output: &Path, f: u32) -> PathBuf {
    let stem = output
        .file_stem()
        .and_then(|s| s.to_str())
        .unwrap_or("frame");
    let ext = output.extension().and_then(|s| s.to_str()).unwrap_or("exr");
    output.with_file_name(format!("{stem}.{f:04}.{ext}"))
}

/// The per-frame times beside `-o X.ext`: `X.frames.csv`.
pub(crate) fn times_path(output: &Path) -> PathBuf {
    let stem = output
        .file_stem()
        .and_then(|s| s.to_str())
        .unwrap_or("frame");
    output.with_file_name(format!("{stem}.frames.csv"))
}

/// One frame's record (`--json`, and a row of the CSV).
#[derive(serde::Serialize)]
struct FrameRecord {
    frame: u32,
    time: f32,
    lights: u32,
    /// The frame's set-up on the GPU: light build, cut pre-pass, VPL
    /// tracing (GPU timestamps; CPU builds on the wall clock).
    setup_ms: f64,
    setup_phases_ms: Vec<(String, f64)>,
    /// The whole set-up on the host's wall clock: the above plus the light
    /// list on the CPU, uploads, the VPL read-back and submission waits
    /// (the first frame's includes the scene's upload and BVH build).
    setup_wall_ms: f64,
    render_ms: f64,
    samples: u64,
    nonfinite_samples: u64,
    files: Vec<String>,
}

/// Mean and median of a column.
#[derive(serde::Serialize)]
struct Summary {
    frames: usize,
    setup_ms_mean: f64,
    setup_ms_median: f64,
    setup_wall_ms_mean: f64,
    render_ms_mean: f64,
    render_ms_median: f64,
}

impl Summary {
    fn of(records: &[FrameRecord]) -> Summary {
        let stats = |f: fn(&FrameRecord) -> f64| {
            let v: Vec<f64> = records.iter().map(f).collect();
            let mean = v.iter().sum::<f64>() / v.len().max(1) as f64;
            (mean, mdas::compare::equal_time::median(&v))
        };
        let (setup_ms_mean, setup_ms_median) = stats(|r| r.setup_ms);
        let (render_ms_mean, render_ms_median) = stats(|r| r.render_ms);
        Summary {
            frames: records.len(),
            setup_ms_mean,
            setup_ms_median,
            setup_wall_ms_mean: stats(|r| r.setup_wall_ms).0,
            render_ms_mean,
            render_ms_median,
        }
    }

    fn line(&self, what: &str) -> String {
        format!(
            "{what} ({} frame{}): set-up mean {:.2} ms (median {:.2}; wall {:.2}), render mean {:.2} ms (median {:.2})\n",
            self.frames,
            if self.frames == 1 { "" } else { "s" },
            self.setup_ms_mean,
            self.setup_ms_median,
            self.setup_wall_ms_mean,
            self.render_ms_mean,
            self.render_ms_median
        )
    }
}

/// What `render --frames --json` prints.
#[derive(serde::Serialize)]
struct SequenceRecord {
    scene: String,
    method: &'static str,
    sampler: String,
    width: u32,
    height: u32,
    seed: u32,
    frame_duration: f32,
    frames: Vec<FrameRecord>,
    all: Summary,
    /// Every frame but the first, whose set-up and render include the
    /// shader compilation of a CPU driver; absent for one frame.
    #[serde(skip_serializing_if = "Option::is_none")]
    after_first: Option<Summary>,
    times_csv: String,
    provenance: mdas::provenance::Provenance,
}

/// The CSV of the frames so far: one row per frame, the set-up phases as
/// columns (the union over the frames, in order of appearance).
fn times_csv(records: &[FrameRecord]) -> String {
    let mut phases: Vec<&str> = Vec::new();
    for r in records {
        for (n, _) in &r.setup_phases_ms {
            if !phases.contains(&n.as_str()) {
                phases.push(n);
            }
        }
    }
    let mut header = String::from(
        "frame,time,lights,setup_ms,setup_wall_ms,render_ms,samples,nonfinite_samples",
    );
    for p in &phases {
        header += &format!(",{p}_ms");
    }
    let rows = records.iter().map(|r| {
        let mut row = vec![
            r.frame.to_string(),
            r.time.to_string(),
            r.lights.to_string(),
            format!("{:.4}", r.setup_ms),
            format!("{:.4}", r.setup_wall_ms),
            format!("{:.4}", r.render_ms),
            r.samples.to_string(),
            r.nonfinite_samples.to_string(),
        ];
        for p in &phases {
            let t = r.setup_phases_ms.iter().find(|(n, _)| n == p).map(|x| x.1);
            row.push(t.map_or_else(String::new, |t| format!("{t:.4}")));
        }
        row
    });
    mdas::compare::csv_table::csv_text(&header, rows)
}

/// `mdas render --frames`.
pub(crate) fn run(args: RenderArgs, ui: Ui) -> Result<()> {
    // Fail on bad input before any GPU work.
    check_sampling(args.integrator, args.spp, &args.mdas)?;
    let RenderArgs {
        scene,
        integrator,
        spp,
        seed,
        output,
        scale,
        reference,
        sampler,
        visibility,
        cuts,
        warmup,
        frames,
        frame_duration,
        mdas,
    } = args;
    // render::run has checked the sampling flags (check_sampling).
    let frames = frames.expect("frames::run is called with --frames");
    if reference.is_some() {
        bail!("--reference measures one image; render the frame alone to measure it, or leave --reference out with --frames");
    }
    if let Some(t) = frame_duration {
        if !(t.is_finite() && t >= 0.0) {
            bail!("--frame-duration must be a finite scene time ≥ 0, got {t}");
        }
    }
    let output = output.unwrap_or_else(|| default_output(&scene, integrator.name()));
    let csv = times_path(&output);
    for f in [frames.start, frames.start + (frames.count - 1)] {
        check_output(&numbered(&output, f))?;
        check_not_input(&numbered(&output, f), &[scene.as_path()])?;
    }
    mdas::atomic::check_writable(&csv)?;

    let mut loaded = SceneFile::load(&scene)?;
    warn_unlit(&loaded);
    // Again, now that the scene's meshes and material libraries have been
    // read: no frame may replace one of them either.
    for f in [frames.start, frames.start + (frames.count - 1)] {
        check_output(&numbered(&output, f))?;
    }
    if let (Some(t), mdas::integrand::IntegrandSpec::ManyLight(spec)) =
        (frame_duration, &mut loaded.integrand)
    {
        spec.frame_duration = t;
    }
    let gpu = Gpu::shared()?;
    let overrides = IntegrandOverrides {
        sampler,
        visibility,
        frame: None,
        cut_size: cuts.cut_size,
        cut_sampling: cuts.cut_sampling,
    };
    // The first frame's set-up is inside the scene upload: timed with it.
    let start = std::time::Instant::now();
    let mut seq = session::prepare_sequence(gpu, loaded, &scene, scale, overrides, frames.start)?;
    let first_wall_ms = start.elapsed().as_secs_f64() * 1e3;
    let film = seq.film;
    let params = mdas.params(seq.scene.mdas, scale, spp, seed);
    let (mut integrator_box, seed) = integrator_for(integrator, spp, seed, params, None)?;
    ui.note(format!(
        "{}: {}×{} px, {} lights, sampler {}, {} frame{} from {} (scene time {} + f·{}), {}, adapter {}",
        scene.display(),
        film.width,
        film.height,
        seq.integrand.light_count(),
        seq.spec.sampler,
        frames.count,
        if frames.count == 1 { "" } else { "s" },
        frames.start,
        seq.spec.time,
        seq.spec.frame_duration,
        integrator.name(),
        gpu.info.name
    ));
    if warmup {
        integrator_box.render(gpu, &seq.integrand)?;
    }
    let bar = ui.delayed_bar(
        u64::from(frames.count),
        "frames {bar:40} {pos}/{len} [{elapsed_precise} < {eta}]",
    );
    let mut records: Vec<FrameRecord> = Vec::new();
    for (i, f) in frames.iter().enumerate() {
        let start = std::time::Instant::now();
        if i > 0 {
            seq.integrand.set_frame(gpu, &seq.scene.scene, f)?;
        }
        let setup_wall_ms = if i > 0 {
            start.elapsed().as_secs_f64() * 1e3
        } else {
            first_wall_ms
        };
        let setup: PhaseTimes = seq.integrand.setup_times().clone();
        let render = integrator_box.render(gpu, &seq.integrand)?;
        warn_image(&render);
        let time = seq.spec.at_frame(f).time;
        let mut attributes =
            session::render_attributes(integrator_box.name(), seed, &render, &scene);
        attributes.push(("frame", image_io::ExrAttribute::I32(f as i32)));
        attributes.push(("frameTime", image_io::ExrAttribute::F64(f64::from(time))));
        attributes.push(("setupMs", image_io::ExrAttribute::F64(setup.total())));
        let path = numbered(&output, f);
        // The frame's images and the times table that lists them, as one
        // unit: a failed write (a full disk) leaves the frames before it
        // and their table, and names the frame.
        let mut writes = mdas::atomic::AtomicWrites::new();
        let files = session::stage_outputs(&mut writes, &path, film, &render.image, &attributes)
            .with_context(|| format!("frame {f}: its images were not written"))?;
        let record = FrameRecord {
            frame: f,
            time,
            lights: seq.integrand.light_count(),
            setup_ms: setup.total(),
            setup_phases_ms: setup.0.clone(),
            setup_wall_ms,
            render_ms: render.times.total(),
            samples: render.samples,
            nonfinite_samples: render.nonfinite,
            files: files.iter().map(|p| p.display().to_string()).collect(),
        };
        ui.result(format!(
            "frame {f:>5}  t {time:<10.6}  set-up {:>9.2} ms ({}; wall {:.2} ms)  render {:>9.2} ms  {} samples\n",
            record.setup_ms,
            setup
                .0
                .iter()
                .map(|(n, t)| format!("{n} {t:.2}"))
                .collect::<Vec<_>>()
                .join(", "),
            record.setup_wall_ms,
            record.render_ms,
            record.samples
        ));
        records.push(record);
        let text = times_csv(&records);
        writes
            .stage(&csv, |p| Ok(std::fs::write(p, text.as_bytes())?))
            .and_then(|()| writes.commit())
            .with_context(|| {
                format!(
                    "frame {f}: its images and {} were not written",
                    csv.display()
                )
            })?;
        bar.advance(i as u64 + 1);
    }
    bar.finish();
    let all = Summary::of(&records);
    ui.result(all.line("all"));
    let after_first = (records.len() > 1).then(|| Summary::of(&records[1..]));
    if let Some(s) = &after_first {
        ui.result(s.line("after the first"));
    }
    if gpu.info.device_type == wgpu::DeviceType::Cpu {
        ui.note("(this CPU driver compiles pipelines at their first dispatch: the first frame's times include it)");
    }
    ui.note(format!(
        "wrote {} … {} (with PNGs) and {}",
        numbered(&output, frames.start).display(),
        numbered(&output, frames.start + (frames.count - 1)).display(),
        csv.display()
    ));
    ui.json(&SequenceRecord {
        scene: scene.display().to_string(),
        method: integrator_box.name(),
        sampler: seq.spec.sampler.to_string(),
        width: film.width,
        height: film.height,
        seed,
        frame_duration: seq.spec.frame_duration,
        frames: records,
        all,
        after_first,
        times_csv: csv.display().to_string(),
        provenance: mdas::provenance::Provenance::new(
            gpu,
            &scene,
            &seq.integrand,
            (integrator == IntegratorKind::Mdas).then_some(params),
        )?,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frame_ranges_parse_exclusive_and_inclusive() {
        let r = |start, count| Ok(FrameRange { start, count });
        assert_eq!(FrameRange::parse("0..512"), r(0, 512));
        assert_eq!(FrameRange::parse("3..4"), r(3, 1));
        assert_eq!(FrameRange::parse("3..=4"), r(3, 2));
        assert_eq!(FrameRange::parse("7..=7"), r(7, 1));
        assert_eq!(FrameRange::parse(" 2 .. 5 "), r(2, 3));
        assert_eq!(
            FrameRange::parse("0..=4294967295"),
            Err("'0..=4294967295' holds more than 2^32 − 1 frames".to_string())
        );
        assert_eq!(FrameRange::parse("4294967295..=4294967295"), r(u32::MAX, 1));
        for bad in ["5..5", "6..2", "6..=5"] {
            assert!(
                FrameRange::parse(bad)
                    .unwrap_err()
                    .contains("holds no frame"),
                "{bad}"
            );
        }
        for bad in ["5", "a..3", "1..b", "-1..3", "1.5..3", ""] {
            assert!(FrameRange::parse(bad).is_err(), "{bad}");
        }
        let frames: Vec<u32> = FrameRange::parse("2..=4").unwrap().iter().collect();
        assert_eq!(frames, [2, 3, 4]);
    }

    #[test]
    fn frame_outputs_are_numbered_beside_the_output() {
        let o = Path::new("out/cornell_lights-mdas.exr");
        assert_eq!(
            numbered(o, 7),
            Path::new("out/cornell_lights-mdas.0007.exr")
        );
        assert_eq!(
            numbered(o, 12345),
            Path::new("out/cornell_lights-mdas.12345.exr")
        );
        assert_eq!(numbered(Path::new("a.png"), 0), Path::new("a.0000.png"));
        assert_eq!(
            times_path(o),
            Path::new("out/cornell_lights-mdas.frames.csv")
        );
    }

    #[test]
    fn the_times_csv_has_a_column_per_phase() {
        let record = |frame, phases: &[(&str, f64)]| FrameRecord {
            frame,
            time: frame as f32 * 0.5,
            lights: 10,
            setup_ms: phases.iter().map(|p| p.1).sum(),
            setup_phases_ms: phases.iter().map(|(n, t)| (n.to_string(), *t)).collect(),
            setup_wall_ms: 3.0,
            render_ms: 2.0,
            samples: 64,
            nonfinite_samples: 0,
            files: vec![],
        };
        let csv = times_csv(&[
            record(0, &[("light_tree.sort", 1.0), ("many_light.cuts", 0.5)]),
            record(1, &[("many_light.cuts", 0.25), ("many_light.vpl", 2.0)]),
        ]);
        assert_eq!(
            csv,
            "frame,time,lights,setup_ms,setup_wall_ms,render_ms,samples,nonfinite_samples,light_tree.sort_ms,many_light.cuts_ms,many_light.vpl_ms\n\
             0,0,10,1.5000,3.0000,2.0000,64,0,1.0000,0.5000,\n\
             1,0.5,10,2.2500,3.0000,2.0000,64,0,,0.2500,2.0000\n"
        );
        let s = Summary::of(&[
            record(0, &[("a", 1.0)]),
            record(1, &[("a", 3.0)]),
            record(2, &[("a", 8.0)]),
        ]);
        assert_eq!((s.setup_ms_mean, s.setup_ms_median), (4.0, 3.0));
    }
}
