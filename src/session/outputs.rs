//! Output paths and images: what `-o X.exr` / `-o X.png` stand for, and
//! the images written to them (atomically) with their provenance.

use crate::film::Film;
use crate::image_io;
use crate::integrator::Render;
use anyhow::{bail, Result};
use std::path::{Path, PathBuf};

/// The files an output path stands for: `X.exr` (any case) is the EXR
/// with `X.png` written beside it; `X.png` is the PNG alone. Anything else
/// is an error.
pub fn output_files(path: &Path) -> Result<(Option<PathBuf>, PathBuf)> {
    let extension = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    match extension.as_deref() {
        Some("exr") => Ok((Some(path.to_path_buf()), path.with_extension("png"))),
        Some("png") => Ok((None, path.to_path_buf())),
        _ => bail!(
            "output '{}' must end in .exr (linear EXR, with an sRGB .png written beside it) or .png (the PNG only)",
            path.display()
        ),
    }
}

/// Writes the files [`output_files`] names (as one unit: both or neither,
/// `crate::atomic`) and returns
/// their paths, EXR first.
pub fn write_outputs(path: &Path, render_film: Film, image: &[[f32; 3]]) -> Result<Vec<PathBuf>> {
    write_outputs_with(path, render_film, image, &[])
}

/// [`write_outputs`] with header attributes in the EXR (see
/// `image_io::write_exr_with`; the PNG carries none).
pub fn write_outputs_with(
    path: &Path,
    render_film: Film,
    image: &[[f32; 3]],
    attributes: &[(&str, image_io::ExrAttribute)],
) -> Result<Vec<PathBuf>> {
    let mut writes = crate::atomic::AtomicWrites::new();
    let written = stage_outputs(&mut writes, path, render_film, image, attributes)?;
    writes.commit()?;
    Ok(written)
}

/// Stages the files [`output_files`] names into `writes`, a unit the
/// caller may add to (a frame sequence adds its times table, so that a
/// frame's images and the table listing them appear together or not at
/// all) and commits; returns their paths, EXR first.
pub fn stage_outputs(
    writes: &mut crate::atomic::AtomicWrites,
    path: &Path,
    render_film: Film,
    image: &[[f32; 3]],
    attributes: &[(&str, image_io::ExrAttribute)],
) -> Result<Vec<PathBuf>> {
    let (exr, png) = output_files(path)?;
    let (w, h) = (render_film.width, render_film.height);
    let mut written = Vec::new();
    if let Some(exr) = exr {
        image_io::stage_exr(writes, &exr, w, h, image, attributes)?;
        written.push(exr);
    }
    image_io::stage_png(writes, &png, w, h, image)?;
    written.push(png);
    Ok(written)
}

/// The EXR header attributes of a render (`image_io::write_exr_with`):
/// `method`, `spp` (samples over pixels), `seed`, `samples`, `timeMs` (the
/// time of all phases), `clock` (`gpu timestamps` or `wall clock`) and
/// `scene` (the scene file as given).
pub fn render_attributes(
    method: &str,
    seed: u32,
    render: &Render,
    scene: &Path,
) -> Vec<(&'static str, image_io::ExrAttribute)> {
    use image_io::ExrAttribute::{Text, F64, I32};
    let pixels = f64::from(render.film.width) * f64::from(render.film.height);
    vec![
        ("method", Text(method.to_string())),
        ("spp", F64(render.samples as f64 / pixels.max(1.0))),
        // Seeds are u32; the header stores i32 bits (2^31 and above wrap).
        ("seed", I32(seed as i32)),
        ("samples", F64(render.samples as f64)),
        ("timeMs", F64(render.times.total())),
        ("clock", Text(render.clock.name().into())),
        ("scene", Text(scene.display().to_string())),
    ]
}
