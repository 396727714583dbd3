//! The files of `mdas compare` (step 5 of `experiment`): the reference,
//! MDAS, Halton and pixel-adaptive Halton images (EXR with method, spp, seed and time in the
//! header, and PNG), per-pixel RelMSE heat maps (log scale) and FLIP maps
//! (linear), the MDAS and adaptive sample-density maps, and `figure.png` — images side
//! by side with insets where the methods' errors differ most (or the
//! `--crop`s), captions with each method's RelMSE interval and FLIP, and
//! the maps with colour bars. `report.json` is written last, by the caller.

use super::figure;
use super::heatmap;
use super::inputs::{ReferenceSource, Subject};
use super::seeds::SeedStats;
use super::CompareSpec;
use crate::film::Film;
use crate::image_io;
use crate::integrator::Render;
use crate::metrics;
use crate::session;
use anyhow::Result;
use std::collections::BTreeMap;
use std::path::Path;

/// The linear range of FLIP maps (FLIP is in [0, 1]).
pub const FLIP_RANGE: (f32, f32) = (0.0, 1.0);

/// What the files are made of.
pub(crate) struct CompareOutputs<'a> {
    pub spec: &'a CompareSpec<'a>,
    /// Where the files go (the run's staging directory).
    pub out: &'a Path,
    pub film: Film,
    /// The integrand's name, its reference and where that came from.
    pub subject: &'a Subject<'a>,
    /// MDAS's written run (its first seed), and its statistics.
    pub mdas: &'a Render,
    pub mdas_seed: u32,
    pub mdas_spp: f64,
    pub mdas_stats: &'a SeedStats,
    /// MDAS's initial-grid samples (the rest were placed adaptively).
    pub initial_samples: u64,
    /// Halton's written run (its first seed), and its statistics.
    pub halton: &'a Render,
    pub halton_spp: u32,
    pub halton_stats: &'a SeedStats,
    /// MDAS-uniform's written run (`compare --uniform`).
    pub uniform: Option<&'a Render>,
    /// Pixel-adaptive Halton's written run (the third method).
    pub adaptive: Option<ThirdOutput<'a>>,
    /// MDAS's samples per pixel.
    pub density: &'a [f32],
    pub target_ms: f64,
    /// The equal-time RelMSE ratio MDAS/Halton and its interval.
    pub ratio: f64,
    pub ratio_ci95: [f64; 2],
}

/// Pixel-adaptive Halton's written run: the image at the budget compared
/// at equal time (its first seed), and its samples per pixel.
pub(crate) struct ThirdOutput<'a> {
    pub render: &'a Render,
    pub seed: u32,
    pub spp: u32,
    /// Samples per pixel spent, mean over its seeds.
    pub spp_used: f64,
    pub stats: &'a SeedStats,
    pub counts: &'a [f32],
}

/// What was written: `files` (report key → file name), the mean FLIP of
/// MDAS's, Halton's and adaptive's images (as many as were written), and
/// the MDAS density map's log range.
pub(crate) struct Written {
    pub files: BTreeMap<String, String>,
    pub flips: Vec<f64>,
    pub density_range: (f32, f32),
}

/// Writes every file but `report.json` into `o.out`.
pub(crate) fn write_outputs(o: &CompareOutputs) -> Result<Written> {
    let (spec, film, reference, density) = (o.spec, o.film, o.subject.reference, o.density);
    let (mdas_render, halton_render) = (o.mdas, o.halton);
    let (w, h) = (film.width, film.height);
    let mut files = Files::new(o.out, film);
    files.image(
        "reference",
        "reference",
        reference,
        &match &o.subject.reference_source {
            ReferenceSource::Halton { spp, .. } => reference_attributes(*spp, spec.setup.ref_seed),
            ReferenceSource::Exact(how) => vec![(
                "method",
                image_io::ExrAttribute::Text(format!("exact: {how}")),
            )],
        },
    )?;
    let scene_path = Path::new(&o.subject.name);
    files.image(
        "mdas",
        "mdas",
        &mdas_render.image,
        &session::render_attributes("mdas", o.mdas_seed, mdas_render, scene_path),
    )?;
    files.image(
        "halton",
        "halton",
        &halton_render.image,
        &session::render_attributes("halton", spec.setup.halton_seed, halton_render, scene_path),
    )?;
    if let Some(a) = &o.adaptive {
        let name = super::adaptive::NAME;
        files.image(
            name,
            name,
            &a.render.image,
            &session::render_attributes(name, a.seed, a.render, scene_path),
        )?;
    }
    if let Some(u) = o.uniform {
        files.image(
            "mdas_uniform",
            "mdas-uniform",
            &u.image,
            &session::render_attributes("mdas-uniform", o.mdas_seed, u, scene_path),
        )?;
        files.relmse_map("mdas_uniform", "mdas-uniform", &u.image, reference)?;
    }
    let mut relmse_maps = Vec::new();
    let mut flips = Vec::new();
    let third = o
        .adaptive
        .as_ref()
        .map(|a| (super::adaptive::NAME, a.render));
    for (key, render) in [("mdas", mdas_render), ("halton", halton_render)]
        .into_iter()
        .chain(third)
    {
        relmse_maps.push(files.relmse_map(key, key, &render.image, reference)?);
        let flip = metrics::flip(
            &render.image,
            reference,
            w,
            h,
            metrics::DEFAULT_PIXELS_PER_DEGREE,
        )?;
        let name = format!("flip-{key}");
        heatmap::write_map_linear(&o.out.join(&name), w, h, &flip.per_pixel, FLIP_RANGE)?;
        files.insert(&format!("flip_{key}"), &name);
        flips.push(flip.mean);
    }
    let density_range = heatmap::density_range(density);
    heatmap::write_map(&o.out.join("density-mdas"), w, h, density, density_range)?;
    files.insert("density_mdas", "density-mdas");
    if let Some(a) = &o.adaptive {
        let range = heatmap::density_range(a.counts);
        heatmap::write_map(&o.out.join("density-adaptive"), w, h, a.counts, range)?;
        files.insert("density_adaptive", "density-adaptive");
    }

    // The figure: images, insets, maps with colour bars.
    let total = mdas_render.samples;
    let adaptive = total.saturating_sub(o.initial_samples);
    let (lo, hi) = density
        .iter()
        .filter(|d| d.is_finite())
        .fold((f32::INFINITY, f32::NEG_INFINITY), |(a, b), &d| {
            (a.min(d), b.max(d))
        });
    let mut density_caption = if adaptive == 0 {
        format!("{total} samples, none adaptive:\nthe budget is MDAS's initial grid")
    } else {
        format!(
            "{adaptive} of {total} samples adaptive ({:.0}%)",
            100.0 * adaptive as f64 / total.max(1) as f64
        )
    };
    if lo == hi {
        density_caption += &format!(
            "\nuniform: every pixel holds {lo:.2} samples,\nno adaptation visible in film space"
        );
    }
    let caption = |name: &str, spp: f64, s: &super::seeds::SeedStats, flip: f64| {
        format!(
            "{name} {spp:.1} spp · {} seeds\nRelMSE {:.3e} [{:.3e}, {:.3e}] · FLIP {flip:.3}",
            s.seeds, s.relmse, s.relmse_ci95[0], s.relmse_ci95[1]
        )
    };
    let stem = scene_path
        .file_stem()
        .map_or_else(String::new, |s| s.to_string_lossy().into_owned());
    let (ratio, ratio_ci95) = (o.ratio, o.ratio_ci95);
    let title = format!(
        "{stem} · {w}×{h} · equal time {:.1} ms · RelMSE MDAS/Halton {ratio:.3} [{:.3}, {:.3}]",
        o.target_ms, ratio_ci95[0], ratio_ci95[1]
    );
    let mut images = vec![
        figure::ImagePanel {
            label: "Reference",
            pixels: reference,
            caption: match &o.subject.reference_source {
                ReferenceSource::Halton { spp, .. } => format!("Halton {spp} spp"),
                ReferenceSource::Exact(how) => how.clone(),
            },
        },
        figure::ImagePanel {
            label: "MDAS",
            pixels: &mdas_render.image,
            caption: caption("MDAS", o.mdas_spp, o.mdas_stats, flips[0]),
        },
        figure::ImagePanel {
            label: "Halton",
            pixels: &halton_render.image,
            caption: caption("Halton", f64::from(o.halton_spp), o.halton_stats, flips[1]),
        },
    ];
    let relmse_map = |i: usize, label: &'static str| figure::MapPanel {
        label,
        values: &relmse_maps[i],
        range: heatmap::RELMSE_RANGE,
        unit: "RelMSE",
        caption: "per pixel, the image above".into(),
    };
    let mut maps = vec![
        relmse_map(0, "RelMSE, MDAS"),
        relmse_map(1, "RelMSE, Halton"),
    ];
    if let Some(a) = &o.adaptive {
        images.push(figure::ImagePanel {
            label: "Pixel-adaptive Halton",
            pixels: &a.render.image,
            caption: caption(
                &format!("Adaptive, budget {}: spent", a.spp),
                a.spp_used,
                a.stats,
                flips[2],
            ),
        });
        maps.push(relmse_map(2, "RelMSE, adaptive"));
    }
    maps.push(figure::MapPanel {
        label: "MDAS sample density",
        values: density,
        range: density_range,
        unit: "spp",
        caption: density_caption,
    });
    figure::write_figure(
        &o.out.join("figure.png"),
        &figure::FigureInput {
            width: w,
            height: h,
            title,
            images,
            maps,
            crops: spec.crops.clone(),
        },
    )?;
    files.list.insert("figure".into(), "figure.png".into());
    Ok(Written {
        files: files.list,
        flips,
        density_range,
    })
}

/// The files of one output directory, as `report.json` lists them (key →
/// file name), each written atomically.
pub(crate) struct Files<'a> {
    out: &'a Path,
    film: Film,
    pub list: BTreeMap<String, String>,
}

impl<'a> Files<'a> {
    pub fn new(out: &'a Path, film: Film) -> Files<'a> {
        Files {
            out,
            film,
            list: BTreeMap::new(),
        }
    }

    /// Lists `NAME.exr` as `KEY` and `NAME.png` as `KEY_png`.
    pub fn insert(&mut self, key: &str, name: &str) {
        self.list.insert(key.to_string(), format!("{name}.exr"));
        self.list
            .insert(format!("{key}_png"), format!("{name}.png"));
    }

    /// Writes `NAME.exr` (with `attributes` in its header) and `NAME.png`.
    pub fn image(
        &mut self,
        key: &str,
        name: &str,
        pixels: &[[f32; 3]],
        attributes: &[(&str, image_io::ExrAttribute)],
    ) -> Result<()> {
        let exr = self.out.join(format!("{name}.exr"));
        session::write_outputs_with(&exr, self.film, pixels, attributes)?;
        self.insert(key, name);
        Ok(())
    }

    /// Writes the per-pixel RelMSE of `pixels` as `relmse-NAME` (log
    /// scale over `heatmap::RELMSE_RANGE`), listed as `relmse_KEY`, and
    /// returns it.
    pub fn relmse_map(
        &mut self,
        key: &str,
        name: &str,
        pixels: &[[f32; 3]],
        reference: &[[f32; 3]],
    ) -> Result<Vec<f32>> {
        let per_pixel = metrics::relmse_per_pixel(pixels, reference)?;
        let stem = format!("relmse-{name}");
        let (w, h) = (self.film.width, self.film.height);
        heatmap::write_map(
            &self.out.join(&stem),
            w,
            h,
            &per_pixel,
            heatmap::RELMSE_RANGE,
        )?;
        self.insert(&format!("relmse_{key}"), &stem);
        Ok(per_pixel)
    }
}

/// The EXR header attributes of a Halton reference at `spp` and `seed`.
pub(crate) fn reference_attributes(
    spp: u32,
    seed: u32,
) -> Vec<(&'static str, image_io::ExrAttribute)> {
    use image_io::ExrAttribute::{Text, F64, I32};
    vec![
        ("method", Text("halton".into())),
        ("spp", F64(f64::from(spp))),
        ("seed", I32(seed as i32)),
    ]
}
