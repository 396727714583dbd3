//! References in parts (issue 52 item 3): `mdas reference --part I/N`
//! renders the I-th share of a reference's samples — samples
//! ⌊(I − 1)·spp/N⌋ .. ⌊I·spp/N⌋ of every pixel's Halton sequence, with the
//! same per-pixel shifts ([`Halton::with_first_sample`]) — and writes it
//! with a record of what it is; `mdas merge` checks that the parts belong
//! together and cover the samples once, and writes the reference cache
//! entry the whole render would have written: each pixel the mean of all
//! its samples (Σ share·mean / spp in f64), the same image as one
//! process's within f32 rounding (the sums are grouped differently), and a
//! cache hit for `compare` and `reference` afterwards.
//!
//! A part whose render had non-finite samples is refused: its pixels'
//! means would weigh their finite samples only, and the merge could not
//! be exact.

use super::outputs::render_attributes;
use super::prepare::*;
use super::reference::{
    check_entry, pixels_sha256, plan, reference_cache_path_keyed, reference_record_path,
    write_entry, Plan, ReferenceSpec,
};
use crate::film::Film;
use crate::gpu::Gpu;
use crate::image_io;
use crate::integrator::{Halton, Integrator};
use crate::scene_file::SceneFile;
use anyhow::{bail, Context, Result};
use std::ops::Range;
use std::path::{Path, PathBuf};

/// The format tag of a part's record.
const PART_FORMAT: &str = "mdas reference part 1";

/// Part `index` (1-based) of `count`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Part {
    pub index: u32,
    pub count: u32,
}

impl std::str::FromStr for Part {
    type Err = String;

    /// `I/N`, 1 ≤ I ≤ N.
    fn from_str(s: &str) -> Result<Part, String> {
        let bad = || format!("'{s}' is not a part I/N with 1 ≤ I ≤ N");
        let (i, n) = s.split_once('/').ok_or_else(bad)?;
        let (index, count) = (
            i.trim().parse::<u32>().map_err(|_| bad())?,
            n.trim().parse::<u32>().map_err(|_| bad())?,
        );
        if index == 0 || index > count {
            return Err(bad());
        }
        Ok(Part { index, count })
    }
}

impl Part {
    /// This part's sample indices of a reference of `spp` samples.
    pub fn range(&self, spp: u32) -> Range<u32> {
        let at = |k: u32| (spp as u64 * k as u64 / self.count as u64) as u32;
        at(self.index - 1)..at(self.index)
    }
}

/// Which part to render and where it goes.
#[derive(Clone, Copy, Debug)]
pub struct PartJob<'a> {
    pub part: Part,
    /// The reference cache the merge will write to (the part names its
    /// entry; nothing is written there now).
    pub cache_dir: &'a Path,
    /// The part's EXR; its record goes beside it as `.json`.
    pub out: &'a Path,
}

/// The checks of a part that need no render, made before any GPU work
/// (issue 67, hostile inputs class 6): `part.count` parts of an `spp`
/// reference each get a sample, and `out` is an EXR path whose PNG and
/// record (`.json`) are other files, all three writable. `-o p.png`
/// rendered for the whole part and then failed, its EXR and PNG being
/// one file.
pub fn check_part(part: Part, spp: u32, out: &Path) -> Result<()> {
    if part.count > spp {
        bail!(
            "{} parts of a {}-spp reference: every part needs a sample (at most {} parts)",
            part.count,
            spp,
            spp
        );
    }
    let is_exr = out
        .extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.eq_ignore_ascii_case("exr"));
    if !is_exr {
        bail!(
            "a reference part (--part {}/{}) is an EXR with an sRGB .png and its .json record beside it: -o must end in .exr, found {}",
            part.index,
            part.count,
            out.display()
        );
    }
    check_entry(out)
}

/// Renders `job.part` of the reference of `scene` (loaded from
/// `scene_path`) and writes it to `job.out` with an sRGB PNG and its
/// record beside it.
pub fn reference_part(
    gpu: &Gpu,
    scene: SceneFile,
    scene_path: &Path,
    spec: ReferenceSpec,
    overrides: super::IntegrandOverrides,
    job: PartJob,
    progress: Option<crate::integrator::halton::Progress>,
) -> Result<(Film, Vec<String>)> {
    let PartJob {
        part,
        cache_dir,
        out,
    } = job;
    check_part(part, spec.spp, out)?;
    let Plan {
        overrides,
        extra,
        path,
        mut warnings,
        notes,
    } = plan(&scene, scene_path, spec, overrides, cache_dir)?;
    warnings.extend(notes);
    let range = part.range(spec.spp);
    let prepared = prepare_loaded(gpu, scene, scene_path, spec.scale, overrides)?;
    let mut halton = Halton::new(range.end - range.start, spec.seed).with_first_sample(range.start);
    if let Some(p) = progress {
        halton = halton.with_progress(p);
    }
    let render = halton.render(gpu, prepared.integrand.as_ref())?;
    if render.nonfinite > 0 {
        bail!(
            "part {}/{} had {} non-finite samples: its pixel means weigh only their finite samples, so the parts could not be merged exactly (render the reference in one process)",
            part.index,
            part.count,
            render.nonfinite
        );
    }
    let entry = path
        .file_name()
        .and_then(|n| n.to_str())
        .context("the cache entry has no file name")?;
    let record = serde_json::json!({
        "format": PART_FORMAT,
        "cache_entry": entry,
        "cache_key_extra": extra,
        "scene": scene_path.display().to_string(),
        "width": render.film.width,
        "height": render.film.height,
        "spp": spec.spp,
        "seed": spec.seed,
        "scale": spec.scale,
        "part": part.index,
        "parts": part.count,
        "first": range.start,
        "end": range.end,
        "version": env!("CARGO_PKG_VERSION"),
        "pixels_sha256": pixels_sha256(&render.image),
        "time_ms": render.times.total(),
        "provenance": crate::provenance::Provenance::new(
            gpu,
            scene_path,
            prepared.integrand.as_ref(),
            None,
        )?,
    });
    let attributes = render_attributes("halton", spec.seed, &render, scene_path);
    // As a cache entry: the EXR, a PNG for eyes and the record, as one unit.
    write_entry(out, render.film, &render.image, &attributes, &record)?;
    Ok((render.film, warnings))
}

/// The positions in `parts` (each part's index I of `count`, 1 ≤ I ≤
/// `count`, and its file) of parts 1..=`count` in order; an error names a
/// part given twice (both files) or the parts missing. Every merge of
/// parts (references here, sweeps and searches in `compare::merge`)
/// orders its parts through it.
pub fn in_order(count: u32, parts: &[(u32, &Path)]) -> Result<Vec<usize>> {
    // Nothing is sized by `count`, which a record gives (u32::MAX made a
    // 64 GiB table): only by the parts given.
    let mut by_index: std::collections::BTreeMap<u32, usize> = Default::default();
    for (k, &(i, file)) in parts.iter().enumerate() {
        if i == 0 || i > count {
            bail!("{}: its part {i}/{count} is not a part", file.display());
        }
        if let Some(&other) = by_index.get(&i) {
            bail!(
                "part {i}/{count} is given twice: {} and {}",
                parts[other].1.display(),
                file.display()
            );
        }
        by_index.insert(i, k);
    }
    if by_index.len() as u64 != u64::from(count) {
        // At most this many are named; each is found within the given
        // parts' indices and as many more.
        const NAMED: usize = 16;
        let missing: Vec<String> = (1..=count)
            .filter(|i| !by_index.contains_key(i))
            .take(NAMED)
            .map(|i| format!("{i}/{count}"))
            .collect();
        let left = u64::from(count) - by_index.len() as u64;
        let more = if left > missing.len() as u64 {
            format!(" and {} more", left - missing.len() as u64)
        } else {
            String::new()
        };
        bail!("parts {}{more} are missing", missing.join(", "));
    }
    Ok(by_index.into_values().collect())
}

/// One part as read back for a merge.
struct ReadPart {
    file: PathBuf,
    record: serde_json::Value,
    index: u32,
    range: Range<u32>,
}

fn read_part(file: &Path) -> Result<ReadPart> {
    let record_path = reference_record_path(file);
    // A regular file only: a FIFO would block the read.
    let bytes = crate::scene::read_input(&record_path, 64 << 20);
    let text = bytes.and_then(|b| {
        String::from_utf8(b).map_err(|e| std::io::Error::new(std::io::ErrorKind::InvalidData, e))
    });
    let text = text.with_context(|| {
        format!(
            "{}: not a reference part (its record {} cannot be read)",
            file.display(),
            record_path.display()
        )
    })?;
    let record: serde_json::Value = serde_json::from_str(&text)
        .with_context(|| format!("{}: its record is not valid JSON", record_path.display()))?;
    if record["format"] != PART_FORMAT {
        bail!(
            "{}: not a reference part (its record is not one of `mdas reference --part`)",
            file.display()
        );
    }
    let num = |key: &str| -> Result<u32> {
        record[key]
            .as_u64()
            .and_then(|v| u32::try_from(v).ok())
            .with_context(|| format!("{}: its record has no valid '{key}'", record_path.display()))
    };
    let (index, count, spp) = (num("part")?, num("parts")?, num("spp")?);
    let part = Part { index, count };
    let range = num("first")?..num("end")?;
    if index == 0 || index > count || count > spp || part.range(spp) != range {
        bail!(
            "{}: its record's samples {}..{} are not part {index}/{count} of {spp}",
            file.display(),
            range.start,
            range.end
        );
    }
    // What the merge sizes and writes from the record is checked before
    // anything is allocated or written (issue 67, hostile inputs class 5).
    num("seed")?;
    let (width, height) = (num("width")?, num("height")?);
    if width == 0 || height == 0 || u64::from(width) * u64::from(height) > image_io::MAX_EXR_PIXELS
    {
        bail!(
            "{}: its record's 'width' × 'height' {width}×{height} is no film a reference can have (at least 1×1, at most {} pixels)",
            record_path.display(),
            image_io::MAX_EXR_PIXELS
        );
    }
    let scale = record["scale"].as_f64().unwrap_or(f64::NAN);
    if !(scale > 0.0 && scale <= 16.0) {
        bail!(
            "{}: its record's 'scale' {} is not a film scale (in (0, 16])",
            record_path.display(),
            record["scale"]
        );
    }
    check_entry_name(&record_path, &record)?;
    Ok(ReadPart {
        file: file.to_path_buf(),
        record,
        index,
        range,
    })
}

/// That a part's record names its cache entry as `mdas reference` names
/// one: `{stem}-{24 hex digits}.exr`, a plain file name in the cache whose
/// stem is the record's scene's (or `scene`, for a scene path that is not
/// UTF-8). A record naming `../x.exr`, `/x.exr` or another kind of file of
/// the cache (`x.json`, `x.png`, a name without `.exr`, whose PNG and
/// record beside it would replace other files) is refused.
fn check_entry_name(record_path: &Path, record: &serde_json::Value) -> Result<()> {
    let entry = record["cache_entry"].as_str().unwrap_or("");
    let scene = record["scene"].as_str().unwrap_or("");
    let stem = Path::new(scene).file_stem().and_then(|s| s.to_str());
    let valid = entry
        .strip_suffix(".exr")
        .and_then(|e| e.rsplit_once('-'))
        .is_some_and(|(s, hex)| {
            (Some(s) == stem || s == "scene")
                && !s.contains(['/', '\\'])
                && hex.len() == 24
                && hex
                    .bytes()
                    .all(|b| b.is_ascii_digit() || (b'a'..=b'f').contains(&b))
        });
    if !valid || Path::new(entry).file_name().and_then(|n| n.to_str()) != Some(entry) {
        bail!(
            "{}: its record's 'cache_entry' {} is not the name of a reference cache entry of {scene:?} ({{scene stem}}-{{24 hex digits}}.exr, a file name in the cache)",
            record_path.display(),
            record["cache_entry"]
        );
    }
    Ok(())
}

/// That the cache entry a part's record names is the one its scene (at the
/// recorded path, with the meshes it loads now), spp, seed, scale and key
/// give, as `mdas reference` computes it: a record edited to name another
/// entry of the same scene (another spp's, whose lookups would then find
/// these pixels) is refused, and so is a part of a scene or mesh changed
/// since it was rendered. Merge runs where the parts were rendered, as
/// the Slurm scripts do; a scene it cannot load is an error that says so.
fn check_entry_against_scene(part: &ReadPart) -> Result<()> {
    let record = &part.record;
    let version = record["version"].as_str().unwrap_or("");
    if version != env!("CARGO_PKG_VERSION") {
        bail!(
            "{}: a part of mdas {version}'s, and this is mdas {}: merge the parts with the mdas that rendered them (a reference's cache key holds the version)",
            part.file.display(),
            env!("CARGO_PKG_VERSION")
        );
    }
    let scene_path = PathBuf::from(record["scene"].as_str().unwrap_or(""));
    let scene = SceneFile::load(&scene_path).with_context(|| {
        format!(
            "{}: merge checks the part's cache entry against its scene, {}, which does not load here (run merge where the parts were rendered)",
            part.file.display(),
            scene_path.display()
        )
    })?;
    let spec = ReferenceSpec {
        spp: record["spp"].as_u64().unwrap_or(0) as u32,
        scale: record["scale"].as_f64().unwrap_or(f64::NAN) as f32,
        seed: record["seed"].as_u64().unwrap_or(0) as u32,
    };
    let extra = record["cache_key_extra"].as_str().unwrap_or("");
    let want = reference_cache_path_keyed(Path::new(""), &scene_path, &scene.inputs, spec, extra)?;
    let entry = record["cache_entry"].as_str().unwrap_or("");
    if want.as_os_str() != entry {
        bail!(
            "{}: its record names the cache entry {entry}, but its scene {} with spp {}, seed {}, scale {} and its key gives {}: the record was edited, or the scene or a mesh it loads changed since the part was rendered",
            part.file.display(),
            scene_path.display(),
            spec.spp,
            spec.seed,
            spec.scale,
            want.display()
        );
    }
    Ok(())
}

/// Merges the parts `files` into the reference cache entry in `cache_dir`
/// they are parts of; returns its path, film and image. Nothing is written
/// unless every part is there once, all belong to the same reference, and
/// every part's image is whole (its size and checksum as recorded).
pub fn merge_parts(files: &[PathBuf], cache_dir: &Path) -> Result<(PathBuf, Film, Vec<[f32; 3]>)> {
    if files.is_empty() {
        bail!("no parts to merge");
    }
    let parts = files
        .iter()
        .map(|f| read_part(f))
        .collect::<Result<Vec<_>>>()?;
    let first = &parts[0];
    // Everything that makes two parts parts of one reference: the cache
    // entry's name hashes the scene, its meshes, the spec and the version.
    const SAME: [&str; 9] = [
        "cache_entry",
        "cache_key_extra",
        "width",
        "height",
        "spp",
        "seed",
        "scale",
        "parts",
        "version",
    ];
    for p in &parts[1..] {
        if let Some(key) = SAME.iter().find(|k| p.record[**k] != first.record[**k]) {
            bail!(
                "{} and {} are parts of different references ({key}: {} against {})",
                first.file.display(),
                p.file.display(),
                first.record[*key],
                p.record[*key]
            );
        }
    }
    let count = first.record["parts"].as_u64().unwrap_or(0) as u32;
    let spp = first.record["spp"].as_u64().unwrap_or(0) as u32;
    let order = in_order(
        count,
        &parts
            .iter()
            .map(|p| (p.index, p.file.as_path()))
            .collect::<Vec<_>>(),
    )?;
    let parts: Vec<&ReadPart> = order.into_iter().map(|k| &parts[k]).collect();
    let film = Film {
        width: first.record["width"].as_u64().unwrap_or(0) as u32,
        height: first.record["height"].as_u64().unwrap_or(0) as u32,
    };
    check_entry_against_scene(first)?;
    let entry = first.record["cache_entry"].as_str().unwrap_or("");
    let path = cache_dir.join(entry);
    if cache_dir.is_dir() {
        // What the write would refuse, refused before the parts are read.
        check_entry(&path)?;
    }
    // Sized once the first part's EXR (whose header read_exr bounds) has
    // shown the record's film to be its own.
    let mut sum: Vec<[f64; 3]> = Vec::new();
    for p in &parts {
        let (w, h, image) =
            image_io::read_exr(&p.file).with_context(|| format!("part {}/{count}", p.index))?;
        if (w, h) != (film.width, film.height) {
            bail!(
                "{} is {w}×{h}, its record says {}×{}",
                p.file.display(),
                film.width,
                film.height
            );
        }
        if Some(pixels_sha256(&image).as_str()) != p.record["pixels_sha256"].as_str() {
            bail!(
                "{}: its pixels do not match the checksum in its record (changed or damaged)",
                p.file.display()
            );
        }
        if sum.is_empty() {
            sum = vec![[0f64; 3]; image.len()];
        }
        let share = (p.range.end - p.range.start) as f64;
        for (s, v) in sum.iter_mut().zip(&image) {
            for c in 0..3 {
                s[c] += share * v[c] as f64;
            }
        }
    }
    let image: Vec<[f32; 3]> = sum
        .iter()
        .map(|s| s.map(|v| (v / spp as f64) as f32))
        .collect();
    std::fs::create_dir_all(cache_dir)
        .with_context(|| format!("cannot create cache directory {}", cache_dir.display()))?;
    let record = serde_json::json!({
        "pixels_sha256": pixels_sha256(&image),
        "width": film.width,
        "height": film.height,
        "spp": spp,
        "seed": first.record["seed"],
        "scale": first.record["scale"],
        "cache_key_extra": first.record["cache_key_extra"],
        "merged_from": parts.iter().map(|p| &p.record).collect::<Vec<_>>(),
    });
    use image_io::ExrAttribute::{Text, F64, I32};
    let seed = first.record["seed"].as_u64().unwrap_or(0) as u32;
    let attributes = [
        ("method", Text("halton".into())),
        ("spp", F64(spp as f64)),
        // As render_attributes: seeds are u32, stored as i32 bits.
        ("seed", I32(seed as i32)),
        ("merged_parts", I32(count as i32)),
    ];
    write_entry(&path, film, &image, &attributes, &record)?;
    Ok((path, film, image))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Nothing is sized by a record's part count (u32::MAX made a 64 GiB
    /// table, issue 67 class 5); the parts missing are named, 16 at most.
    #[test]
    fn parts_are_ordered_without_a_table_of_the_count() {
        let (a, b) = (Path::new("a"), Path::new("b"));
        assert_eq!(in_order(2, &[(2, a), (1, b)]).unwrap(), [1, 0]);
        let e = in_order(u32::MAX, &[(1, a)]).unwrap_err().to_string();
        assert!(e.contains("parts 2/4294967295, 3/4294967295"), "{e}");
        assert!(e.ends_with(" and 4294967278 more are missing"), "{e}");
        let e = in_order(3, &[(1, a)]).unwrap_err().to_string();
        assert_eq!(e, "parts 2/3, 3/3 are missing");
        let e = in_order(3, &[(1, a), (1, b)]).unwrap_err().to_string();
        assert_eq!(e, "part 1/3 is given twice: a and b");
        assert!(in_order(0, &[(1, a)]).is_err());
    }

    #[test]
    fn parts_parse_and_split_the_samples_exactly_once() {
        assert_eq!("2/5".parse::<Part>(), Ok(Part { index: 2, count: 5 }));
        for bad in ["0/4", "5/4", "3", "a/4", "1/0", ""] {
            assert!(bad.parse::<Part>().is_err(), "{bad}");
        }
        for spp in [1, 7, 37, 65536, u32::MAX] {
            for count in [1, 2, 3, 4, 7].into_iter().filter(|&n| n <= spp) {
                let ranges: Vec<_> = (1..=count)
                    .map(|index| Part { index, count }.range(spp))
                    .collect();
                assert_eq!(ranges[0].start, 0);
                assert_eq!(ranges[count as usize - 1].end, spp);
                for w in ranges.windows(2) {
                    assert_eq!(w[0].end, w[1].start, "{spp} in {count}");
                    assert!(w[0].end > w[0].start, "every part has a sample");
                }
            }
        }
    }
}
