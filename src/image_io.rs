//! Reading and writing images: linear float EXR and sRGB PNG, written
//! atomically.
//!
//! Conventions (docs/conventions.md, "Raster" and "Output"):
//!
//! - Images are row-major slices of linear RGB pixels, `&[[f32; 3]]`; pixel
//!   (i, j) (i = column from the left, j = row from the top) is at index
//!   `j * width + i`. The first row of the EXR and PNG files is the top row,
//!   so files open the right way up in any viewer.
//! - **EXR** holds linear radiance as 32-bit float R, G, B channels (ZIP
//!   compressed scanlines, lossless), written and read back bit-exactly.
//!   Non-finite values are stored as they are: an EXR is data, and hiding a
//!   NaN there would hide a bug.
//! - **PNG** is for eyes: 8-bit sRGB, each channel clamped to [0, 1] and
//!   encoded with the piecewise sRGB transfer function (OETF) of IEC 61966-2-1
//!   (see [`linear_to_srgb`]); NaN becomes 0 in the PNG only.
//! - Every file is written through [`crate::atomic`]: into a temporary file
//!   in the target's directory, then renamed over the target, so a reader
//!   never sees a half-written image and a failed write leaves the old file
//!   (or no file) in place. [`stage_exr`] and [`stage_png`] add a file to a
//!   unit of files that land together (an EXR and its PNG).

use std::path::Path;

use anyhow::{anyhow, bail, Result};

pub use crate::atomic::write_atomic;
use crate::atomic::AtomicWrites;

/// Checks `rgb.len() == width * height` and a non-zero size.
fn check_dimensions(path: &Path, width: u32, height: u32, rgb: &[[f32; 3]]) -> Result<usize> {
    if width == 0 || height == 0 {
        bail!(
            "cannot write {}: image size {width}x{height} is empty",
            path.display()
        );
    }
    let pixels = (width as usize)
        .checked_mul(height as usize)
        .ok_or_else(|| {
            anyhow!(
                "cannot write {}: image size {width}x{height} overflows",
                path.display()
            )
        })?;
    if rgb.len() != pixels {
        bail!(
            "cannot write {}: {width}x{height} needs {pixels} pixels but {} were given",
            path.display(),
            rgb.len()
        );
    }
    Ok(pixels)
}

/// The value of a custom EXR header attribute (see [`write_exr_with`]).
#[derive(Clone, Debug, PartialEq)]
pub enum ExrAttribute {
    Text(String),
    F64(f64),
    I32(i32),
}

impl std::fmt::Display for ExrAttribute {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            ExrAttribute::Text(t) => f.write_str(t),
            ExrAttribute::F64(v) => write!(f, "{v}"),
            ExrAttribute::I32(v) => write!(f, "{v}"),
        }
    }
}

/// Writes a linear RGB float32 EXR (row-major, top row first), atomically.
pub fn write_exr(path: &Path, width: u32, height: u32, rgb: &[[f32; 3]]) -> Result<()> {
    write_exr_with(path, width, height, rgb, &[])
}

/// [`write_exr`] with custom header attributes (name, value) in the
/// layer's header — how a render records its method, spp, seed and time
/// (`exrheader` or any EXR viewer shows them). The software attribute
/// names this crate and its version. Names must be non-empty ASCII.
pub fn write_exr_with(
    path: &Path,
    width: u32,
    height: u32,
    rgb: &[[f32; 3]],
    attributes: &[(&str, ExrAttribute)],
) -> Result<()> {
    let mut writes = AtomicWrites::new();
    stage_exr(&mut writes, path, width, height, rgb, attributes)?;
    writes.commit()
}

/// [`write_exr_with`] as one file of a unit: written and flushed now, in
/// place when `writes` is committed.
pub fn stage_exr(
    writes: &mut AtomicWrites,
    path: &Path,
    width: u32,
    height: u32,
    rgb: &[[f32; 3]],
    attributes: &[(&str, ExrAttribute)],
) -> Result<()> {
    use exr::meta::attribute::{AttributeValue, Text};
    use exr::prelude::*;

    check_dimensions(path, width, height, rgb)?;
    let w = width as usize;
    let channels = SpecificChannels::rgb(|Vec2(x, y): Vec2<usize>| {
        let [r, g, b] = rgb[y * w + x];
        (r, g, b)
    });
    let text = |t: &str| {
        Text::new_or_none(t)
            .ok_or_else(|| anyhow!("cannot write {}: '{t}' is not an EXR text", path.display()))
    };
    let mut layer_attributes = LayerAttributes {
        software_name: Some(text(concat!("mdas ", env!("CARGO_PKG_VERSION")))?),
        ..LayerAttributes::default()
    };
    for (name, value) in attributes {
        if name.is_empty() {
            bail!("cannot write {}: an attribute has no name", path.display());
        }
        let value = match value {
            // A text value is any bytes (size-prefixed): its UTF-8, so
            // that any scene path or label is stored (exr's `Text::new`
            // takes Latin-1 only, and a path beyond it failed the write
            // after the render; issue 67, hostile inputs class 3).
            ExrAttribute::Text(t) => AttributeValue::Text(Text::from_slice_unchecked(t.as_bytes())),
            ExrAttribute::F64(v) => AttributeValue::F64(*v),
            ExrAttribute::I32(v) => AttributeValue::I32(*v),
        };
        layer_attributes.other.insert(text(name)?, value);
    }
    let image = Image::from_layer(Layer::new(
        (w, height as usize),
        layer_attributes,
        Encoding::SMALL_LOSSLESS,
        channels,
    ));
    writes.stage(path, |temp| {
        image
            .write()
            .to_file(temp)
            .map_err(|e| anyhow!("EXR encoding failed: {e}"))
    })
}

/// The most pixels [`read_exr`] accepts: 2^28 (16384 × 16384, 3 GiB as f32
/// RGB). Only a render above 8× the film of the largest scene is bigger:
/// it is written, but cannot be read back as a reference.
pub const MAX_EXR_PIXELS: u64 = 1 << 28;

/// Refuses to read anything but a regular file (a FIFO given as
/// `--reference`, or found at a cache entry's path, would block the read
/// forever), and notes the file as an input of the run
/// ([`crate::atomic::note_input`]: no output may replace it).
fn check_readable(path: &Path) -> Result<()> {
    let meta =
        std::fs::metadata(path).map_err(|e| anyhow!("cannot read {}: {e}", path.display()))?;
    if !meta.is_file() {
        bail!(
            "cannot read {}: not a regular file (a directory, FIFO, socket or device)",
            path.display()
        );
    }
    crate::atomic::note_input(path);
    Ok(())
}

/// Reads the R, G, B channels of the first RGB layer of an EXR file (any
/// sample type, converted to f32) as `(width, height, pixels)`, row-major with
/// the top row first. Other channels (alpha, ...) are ignored.
pub fn read_exr(path: &Path) -> Result<(u32, u32, Vec<[f32; 3]>)> {
    use exr::prelude::*;

    check_readable(path)?;
    // The header first: a forged data window must not make the pixel
    // buffer below ask for more memory than any image here can need (an
    // allocation failure aborts the process).
    let meta = exr::meta::MetaData::read_from_file(path, false)
        .map_err(|e| anyhow!("cannot read {}: {e}", path.display()))?;
    for header in meta.headers.iter() {
        let size = header.layer_size;
        if size.width() as u64 * size.height() as u64 > MAX_EXR_PIXELS {
            bail!(
                "cannot read {}: its header claims {}×{} pixels, more than the {MAX_EXR_PIXELS} an image may have here (a damaged or forged file?)",
                path.display(),
                size.width(),
                size.height()
            );
        }
    }

    struct Pixels {
        width: usize,
        data: Vec<[f32; 3]>,
    }

    let image = read()
        .no_deep_data()
        .largest_resolution_level()
        .rgb_channels(
            |resolution: Vec2<usize>, _channels: &RgbChannels| Pixels {
                width: resolution.width(),
                data: vec![[0.0; 3]; resolution.area()],
            },
            |pixels: &mut Pixels, position: Vec2<usize>, (r, g, b): (f32, f32, f32)| {
                pixels.data[position.y() * pixels.width + position.x()] = [r, g, b];
            },
        )
        .first_valid_layer()
        .all_attributes()
        .from_file(path)
        .map_err(|e| anyhow!("cannot read {}: {e}", path.display()))?;

    let size = image.layer_data.size;
    let width = u32::try_from(size.width()).map_err(|_| {
        anyhow!(
            "cannot read {}: width {} too large",
            path.display(),
            size.width()
        )
    })?;
    let height = u32::try_from(size.height()).map_err(|_| {
        anyhow!(
            "cannot read {}: height {} too large",
            path.display(),
            size.height()
        )
    })?;
    Ok((width, height, image.layer_data.channel_data.pixels.data))
}

/// The custom attributes of an EXR's first header (those written by
/// [`write_exr_with`], and any other text, number or integer attribute a
/// file carries outside the standard ones), sorted by name.
pub fn read_exr_attributes(path: &Path) -> Result<Vec<(String, ExrAttribute)>> {
    use exr::meta::attribute::AttributeValue;
    check_readable(path)?;
    let meta = exr::meta::MetaData::read_from_file(path, false)
        .map_err(|e| anyhow!("cannot read {}: {e}", path.display()))?;
    let header = meta
        .headers
        .first()
        .ok_or_else(|| anyhow!("cannot read {}: no header", path.display()))?;
    let mut out: Vec<(String, ExrAttribute)> = header
        .own_attributes
        .other
        .iter()
        .filter_map(|(name, value)| {
            let value = match value {
                // UTF-8 as written above; another tool's Latin-1 bytes
                // read as Latin-1.
                AttributeValue::Text(t) => ExrAttribute::Text(
                    String::from_utf8(t.as_slice().to_vec())
                        .unwrap_or_else(|_| t.as_slice().iter().map(|&b| char::from(b)).collect()),
                ),
                AttributeValue::F64(v) => ExrAttribute::F64(*v),
                AttributeValue::F32(v) => ExrAttribute::F64(f64::from(*v)),
                AttributeValue::I32(v) => ExrAttribute::I32(*v),
                _ => return None,
            };
            Some((name.to_string(), value))
        })
        .collect();
    out.sort_by(|a, b| a.0.cmp(&b.0));
    Ok(out)
}

/// The sRGB transfer function (OETF) of IEC 61966-2-1 for a linear value
/// already in [0, 1]:
///
/// ```text
/// v ≤ 0.0031308:  12.92 · v
/// otherwise:      1.055 · v^(1/2.4) − 0.055
/// ```
pub fn linear_to_srgb(linear: f64) -> f64 {
    if linear <= 0.0031308 {
        12.92 * linear
    } else {
        1.055 * linear.powf(1.0 / 2.4) - 0.055
    }
}

/// One linear channel to an 8-bit sRGB code value: NaN → 0, clamp to [0, 1],
/// sRGB-encode, round to nearest.
pub fn linear_to_srgb8(linear: f32) -> u8 {
    let v = if linear.is_nan() {
        0.0
    } else {
        f64::from(linear).clamp(0.0, 1.0)
    };
    (linear_to_srgb(v) * 255.0).round().clamp(0.0, 255.0) as u8
}

/// Writes an 8-bit sRGB PNG for viewing (row-major, top row first), atomically.
/// Values are clamped to [0, 1] and NaN is shown as 0 (black) — only in the PNG.
pub fn write_png(path: &Path, width: u32, height: u32, rgb: &[[f32; 3]]) -> Result<()> {
    let mut writes = AtomicWrites::new();
    stage_png(&mut writes, path, width, height, rgb)?;
    writes.commit()
}

/// [`write_png`] as one file of a unit (see [`stage_exr`]).
pub fn stage_png(
    writes: &mut AtomicWrites,
    path: &Path,
    width: u32,
    height: u32,
    rgb: &[[f32; 3]],
) -> Result<()> {
    check_dimensions(path, width, height, rgb)?;
    let bytes: Vec<u8> = rgb
        .iter()
        .flat_map(|pixel| pixel.map(linear_to_srgb8))
        .collect();
    let image = image::RgbImage::from_raw(width, height, bytes).ok_or_else(|| {
        anyhow!(
            "cannot write {}: pixel buffer has the wrong size",
            path.display()
        )
    })?;
    writes.stage(path, |temp| {
        image
            .save_with_format(temp, image::ImageFormat::Png)
            .map_err(|e| anyhow!("PNG encoding failed: {e}"))
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::fs;
    use std::path::PathBuf;
    use std::sync::atomic::{AtomicU64, Ordering};

    static TEMP_COUNTER: AtomicU64 = AtomicU64::new(0);

    /// A fresh empty directory under the system temp dir, removed on drop.
    struct TestDir(PathBuf);

    impl TestDir {
        fn new(tag: &str) -> TestDir {
            let path = std::env::temp_dir().join(format!(
                "mdas-image-io-{tag}-{}-{}",
                std::process::id(),
                TEMP_COUNTER.fetch_add(1, Ordering::Relaxed)
            ));
            let _ = fs::remove_dir_all(&path);
            fs::create_dir_all(&path).unwrap();
            TestDir(path)
        }

        fn entries(&self) -> Vec<String> {
            let mut names: Vec<String> = fs::read_dir(&self.0)
                .unwrap()
                .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
                .collect();
            names.sort();
            names
        }
    }

    impl Drop for TestDir {
        fn drop(&mut self) {
            let _ = fs::remove_dir_all(&self.0);
        }
    }

    #[test]
    fn exr_round_trip_is_bit_exact() {
        let dir = TestDir::new("exr");
        let (width, height) = (7u32, 5u32);
        let special = [
            0.0f32,
            -0.0,
            1.0,
            f32::MIN_POSITIVE,
            1e-45, // smallest subnormal
            1e-30,
            3.4e38,
            f32::MAX,
            -2.5,
            0.1,
            123456.79,
        ];
        let rgb: Vec<[f32; 3]> = (0..width * height)
            .map(|k| {
                let k = k as usize;
                [
                    special[k % special.len()],
                    special[(k * 7 + 3) % special.len()],
                    k as f32 * 0.37 + 1.0 / (k as f32 + 1.0),
                ]
            })
            .collect();
        let path = dir.0.join("round_trip.exr");
        write_exr(&path, width, height, &rgb).unwrap();
        let (w, h, back) = read_exr(&path).unwrap();
        assert_eq!((w, h), (width, height));
        assert_eq!(back.len(), rgb.len());
        for (k, (a, b)) in rgb.iter().zip(&back).enumerate() {
            for c in 0..3 {
                assert_eq!(a[c].to_bits(), b[c].to_bits(), "pixel {k} channel {c}");
            }
        }
        // No temporary file left next to the output.
        assert_eq!(dir.entries(), vec!["round_trip.exr".to_string()]);
    }

    #[test]
    fn exr_attributes_round_trip() {
        let dir = TestDir::new("exr-attributes");
        let path = dir.0.join("attrs.exr");
        let attributes = [
            ("method", ExrAttribute::Text("mdas".into())),
            // Beyond Latin-1 (issue 67, hostile inputs class 3).
            ("scene", ExrAttribute::Text("scènes/日本/🙂 ☃.toml".into())),
            ("spp", ExrAttribute::F64(7.5)),
            ("seed", ExrAttribute::I32(42)),
        ];
        write_exr_with(&path, 2, 1, &[[1.0; 3], [2.0; 3]], &attributes).unwrap();
        let back = read_exr_attributes(&path).unwrap();
        let mut want: Vec<(String, ExrAttribute)> = attributes
            .iter()
            .map(|(n, v)| (n.to_string(), v.clone()))
            .collect();
        want.sort_by(|a, b| a.0.cmp(&b.0));
        assert_eq!(back, want);
        // The pixels are unaffected.
        assert_eq!(read_exr(&path).unwrap().2, vec![[1.0; 3], [2.0; 3]]);
        // A name exr cannot store is an error, and nothing is written.
        let bad = dir.0.join("bad.exr");
        assert!(write_exr_with(&bad, 1, 1, &[[0.0; 3]], &[("", ExrAttribute::I32(1))]).is_err());
        assert!(!bad.exists());
    }

    #[test]
    fn exr_rows_are_top_first() {
        // A top-row-only marker must come back at index j = 0.
        let dir = TestDir::new("exr-rows");
        let (width, height) = (3u32, 4u32);
        let mut rgb = vec![[0.0f32; 3]; 12];
        rgb[1] = [5.0, 6.0, 7.0]; // pixel (1, 0)
        rgb[2 * 3] = [8.0, 9.0, 10.0]; // pixel (0, 2)
        let path = dir.0.join("rows.exr");
        write_exr(&path, width, height, &rgb).unwrap();
        let (_, _, back) = read_exr(&path).unwrap();
        assert_eq!(back, rgb);
    }

    #[test]
    fn png_is_written_with_the_right_size_and_values() {
        let dir = TestDir::new("png");
        let (width, height) = (4u32, 3u32);
        let mut rgb = vec![[0.5f32; 3]; 12];
        rgb[0] = [f32::NAN, 2.0, -1.0]; // top-left: NaN → 0, clamp high, clamp low
        rgb[11] = [1.0, 0.0, f32::INFINITY];
        let path = dir.0.join("view.png");
        write_png(&path, width, height, &rgb).unwrap();
        let image = image::open(&path).unwrap().to_rgb8();
        assert_eq!(image.dimensions(), (width, height));
        assert_eq!(image.get_pixel(0, 0).0, [0, 255, 0]);
        assert_eq!(image.get_pixel(1, 0).0, [188, 188, 188]);
        assert_eq!(image.get_pixel(3, 2).0, [255, 0, 255]);
        assert_eq!(dir.entries(), vec!["view.png".to_string()]);
    }

    #[test]
    fn srgb_encoding() {
        assert_eq!(linear_to_srgb8(0.0), 0);
        assert_eq!(linear_to_srgb8(1.0), 255);
        assert_eq!(linear_to_srgb8(-3.0), 0);
        assert_eq!(linear_to_srgb8(7.0), 255);
        assert_eq!(linear_to_srgb8(f32::NAN), 0);
        // 0.5 → 1.055·0.5^(1/2.4) − 0.055 = 0.735357 → 187.52 → 188.
        assert!((linear_to_srgb(0.5) - 0.735_356_983).abs() < 1e-8);
        assert_eq!(linear_to_srgb8(0.5), 188);
        // The two pieces meet (to 1e-7) at the breakpoint 0.0031308, where the
        // value is 12.92 · 0.0031308 = 0.040450 → 10.31 → 10.
        let b = 0.0031308f64;
        let linear_piece = 12.92 * b;
        let power_piece = 1.055 * b.powf(1.0 / 2.4) - 0.055;
        assert!((linear_piece - power_piece).abs() < 1e-7);
        assert_eq!(linear_to_srgb(b), linear_piece);
        assert_eq!(linear_to_srgb8(0.0031308), 10);
        // Monotone over the whole range.
        let mut previous = 0u8;
        for k in 0..=1000 {
            let v = linear_to_srgb8(k as f32 / 1000.0);
            assert!(v >= previous);
            previous = v;
        }
    }

    /// A 300-byte file whose header claims 100000 × 100000 pixels is
    /// refused with a message before any pixel buffer is allocated (it
    /// aborted the process with a failed 120 GB allocation).
    #[test]
    fn forged_exr_header_is_refused_before_allocating() {
        let dir = std::env::temp_dir().join(format!("mdas-forged-exr-{}", std::process::id()));
        fs::create_dir_all(&dir).unwrap();
        let path = dir.join("forged.exr");
        write_exr(&path, 2, 2, &[[1.0, 2.0, 3.0]; 4]).unwrap();
        let mut bytes = fs::read(&path).unwrap();
        // dataWindow: name, type, 4-byte size 16, then xMin yMin xMax yMax.
        let key = b"dataWindow\0box2i\0";
        let at = bytes
            .windows(key.len())
            .position(|w| w == key)
            .expect("the header has a data window")
            + key.len()
            + 4;
        for (k, v) in [0i32, 0, 99_999, 99_999].iter().enumerate() {
            bytes[at + 4 * k..at + 4 * k + 4].copy_from_slice(&v.to_le_bytes());
        }
        fs::write(&path, &bytes).unwrap();
        let err = format!("{:#}", read_exr(&path).unwrap_err());
        assert!(err.contains("100000×100000"), "{err}");
        assert!(err.contains("forged.exr"), "{err}");
        fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn atomic_write_failure_leaves_no_temp_file_and_target_untouched() {
        let dir = TestDir::new("atomic");
        let target = dir.0.join("out.exr");
        fs::write(&target, b"old contents").unwrap();

        let mut seen_temp = None;
        let err = write_atomic(&target, |temp| {
            seen_temp = Some(temp.to_path_buf());
            fs::write(temp, b"partial")?;
            bail!("simulated encoder failure")
        })
        .unwrap_err();
        let message = format!("{err:#}");
        assert!(message.contains("cannot write"), "{message}");
        assert!(message.contains("simulated encoder failure"), "{message}");

        let temp = seen_temp.unwrap();
        let temp_name = temp.file_name().unwrap().to_string_lossy().into_owned();
        assert!(temp_name.starts_with(".out.exr."), "{temp_name}");
        assert!(temp_name.ends_with(".tmp.exr"), "{temp_name}");
        assert_eq!(temp.parent(), target.parent());
        assert!(!temp.exists());
        assert_eq!(fs::read(&target).unwrap(), b"old contents");
        assert_eq!(dir.entries(), vec!["out.exr".to_string()]);

        // A writer that panics is cleaned up too (the test prints the
        // panic message; that is expected).
        let result = std::panic::catch_unwind(|| {
            let _ = write_atomic(&target, |temp| {
                fs::write(temp, b"partial").unwrap();
                panic!("writer panicked");
            });
        });
        assert!(result.is_err());
        assert_eq!(dir.entries(), vec!["out.exr".to_string()]);
        assert_eq!(fs::read(&target).unwrap(), b"old contents");

        // A successful write replaces the target.
        write_atomic(&target, |temp| Ok(fs::write(temp, b"new")?)).unwrap();
        assert_eq!(fs::read(&target).unwrap(), b"new");
        assert_eq!(dir.entries(), vec!["out.exr".to_string()]);
    }

    #[test]
    fn missing_directory_and_bad_sizes_are_clear_errors() {
        let dir = TestDir::new("missing");
        let path = dir.0.join("no_such_dir").join("image.exr");
        let rgb = vec![[0.0f32; 3]; 4];
        let message = format!("{:#}", write_exr(&path, 2, 2, &rgb).unwrap_err());
        assert!(message.contains("cannot write"), "{message}");
        assert!(message.contains("does not exist"), "{message}");
        let message = format!(
            "{:#}",
            write_png(&path.with_extension("png"), 2, 2, &rgb).unwrap_err()
        );
        assert!(message.contains("cannot write"), "{message}");

        let ok_path = dir.0.join("image.exr");
        assert!(write_exr(&ok_path, 3, 2, &rgb).is_err());
        assert!(write_exr(&ok_path, 0, 2, &[]).is_err());
        assert!(write_png(&ok_path.with_extension("png"), 2, 3, &rgb).is_err());
        assert!(dir.entries().is_empty());

        let message = format!("{:#}", read_exr(&dir.0.join("absent.exr")).unwrap_err());
        assert!(message.contains("cannot read"), "{message}");
    }
}
