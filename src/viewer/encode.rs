//! How the page carries its data: linear RGB as IEEE half floats
//! (little-endian, R G B per pixel, rows top first) in base64, files
//! (the map PNGs, `sweep.svg`) in base64, and JSON that may sit inside a
//! `<script>` element.
//!
//! Six bytes per pixel are exactly eight base64 characters, so pixel `i`
//! of an image is characters `8i .. 8i + 8` of its text: the page reads
//! one pixel of every image under the cursor without decoding the rest.
//! A half keeps 11 significant bits (relative rounding error ≤ 2⁻¹¹ for
//! values in [6.1·10⁻⁵, 65504]; absolute ≤ 2⁻²⁵ below); larger values
//! become +∞, NaN stays NaN.

use half::f16;

const ALPHABET: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";

/// Standard base64 (RFC 4648, with `=` padding).
pub fn base64(bytes: &[u8]) -> String {
    let mut out = String::with_capacity(bytes.len().div_ceil(3) * 4);
    for chunk in bytes.chunks(3) {
        let b = [
            chunk[0],
            chunk.get(1).copied().unwrap_or(0),
            chunk.get(2).copied().unwrap_or(0),
        ];
        let n = (u32::from(b[0]) << 16) | (u32::from(b[1]) << 8) | u32::from(b[2]);
        for (k, shift) in [18, 12, 6, 0].into_iter().enumerate() {
            if k <= chunk.len() {
                out.push(ALPHABET[(n >> shift) as usize & 63] as char);
            } else {
                out.push('=');
            }
        }
    }
    out
}

/// The pixels as half floats, little-endian, R G B per pixel.
pub fn halves(pixels: &[[f32; 3]]) -> Vec<u8> {
    let mut out = Vec::with_capacity(pixels.len() * 6);
    for p in pixels {
        for c in p {
            out.extend_from_slice(&f16::from_f32(*c).to_bits().to_le_bytes());
        }
    }
    out
}

/// JSON text that can stand inside `<script type="application/json">`:
/// every `<` (which JSON has only inside strings) written `\u003c`, so
/// no `</script>` or `<!--` can end or confuse the element.
pub fn script_json(value: &serde_json::Value) -> String {
    serde_json::to_string(value)
        .expect("a JSON value serialises")
        .replace('<', "\\u003c")
}

/// The inverse of [`base64`], for the tests.
#[cfg(test)]
pub(crate) fn unbase64(text: &str) -> Vec<u8> {
    let value = |c: u8| ALPHABET.iter().position(|&a| a == c).unwrap() as u32;
    let mut out = Vec::new();
    for chunk in text.as_bytes().chunks(4) {
        let pad = chunk.iter().filter(|&&c| c == b'=').count();
        let n = chunk
            .iter()
            .map(|&c| if c == b'=' { 0 } else { value(c) })
            .fold(0, |n, v| (n << 6) | v);
        out.extend_from_slice(&n.to_be_bytes()[1..4 - pad]);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn base64_known_answers() {
        // RFC 4648 §10.
        for (plain, coded) in [
            ("", ""),
            ("f", "Zg=="),
            ("fo", "Zm8="),
            ("foo", "Zm9v"),
            ("foob", "Zm9vYg=="),
            ("fooba", "Zm9vYmE="),
            ("foobar", "Zm9vYmFy"),
        ] {
            assert_eq!(base64(plain.as_bytes()), coded);
            assert_eq!(unbase64(coded), plain.as_bytes());
        }
        let all: Vec<u8> = (0..=255).collect();
        assert_eq!(unbase64(&base64(&all)), all);
    }

    #[test]
    fn a_pixel_is_eight_characters() {
        let pixels = [[1.0, 0.5, 0.25], [0.1, 2.0, 1e-3], [65504.0, 1e6, 0.0]];
        let text = base64(&halves(&pixels));
        assert_eq!(text.len(), 8 * pixels.len());
        for (i, p) in pixels.iter().enumerate() {
            let bytes = unbase64(&text[8 * i..8 * i + 8]);
            let got: Vec<f32> = bytes
                .chunks(2)
                .map(|b| f16::from_bits(u16::from_le_bytes([b[0], b[1]])).to_f32())
                .collect();
            for c in 0..3 {
                let want = p[c];
                if want > 65504.0 {
                    assert_eq!(got[c], f32::INFINITY);
                } else {
                    assert!((got[c] - want).abs() <= want.abs() * 2f32.powi(-11));
                }
            }
        }
    }

    #[test]
    fn json_cannot_close_its_script() {
        let v = serde_json::json!({"a": "</script><!-- x"});
        let text = script_json(&v);
        assert!(!text.contains('<'));
        assert_eq!(serde_json::from_str::<serde_json::Value>(&text).unwrap(), v);
    }
}
