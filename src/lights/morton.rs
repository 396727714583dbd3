//! 30-bit Morton codes of light centroids, exact on the CPU and the GPU
//! (real-time stochastic lightcuts §3.1: lights are sorted by the Morton
//! code of their position before the perfect tree is built over them).
//!
//! # The quantization rule (see `src/lights/mod.rs`)
//!
//! Per axis, with global centroid bounds `[lo, hi]` and extent `e = hi − lo`
//! (one correctly rounded f32 subtraction):
//!
//! * `e == 0` → `q = 0`;
//! * else `E` = the binary exponent of `e` (`e = m·2^E`, `m ∈ [1, 2)`),
//!   read from the bits of `e` (a subnormal `e` has `E = −149 + ⌊log2(mantissa bits)⌋`),
//!   and `q = min(floor((c − lo)·2^(9−E)), 1023)`.
//!
//! `c − lo` is one correctly rounded subtraction, and the multiplication by
//! a power of two is exact as long as the result neither overflows nor
//! falls below the normal range — and a result below 2^−126 floors to 0
//! either way. Since `c − lo ≤ e < 2^(E+1)`, the product is below 2^10.
//!
//! # The power of two
//!
//! `k = 9 − E` ranges over `[−118, 158]` (`E ∈ [−149, 127]`; `E = 128` for an
//! infinite extent gives `k = −119`). f32 powers of two are normal only for
//! exponents in `[−126, 127]`, so for `k > 127` the scale is applied as two
//! exact multiplications, first by `2^127` and then by `2^(k − 127)`
//! ([`scale_pow2`]); the first product stays below `2^(E+1+127) ≤ 2^10`
//! and both are exact. Every `k` in range is built from its bits
//! (`(k + 127) << 23`), never with `powf`.
//!
//! **The WGSL side must do the same**: take `E` from `bitcast<u32>(e)`
//! (exponent field − 127, or `31 − countLeadingZeros(mantissa) − 149` when
//! the field is 0), and multiply by `bitcast<f32>(u32(k + 127) << 23)`,
//! split as `d * 0x1p127f * 2^(k−127)` when `k > 127` (WGSL's `ldexp` is
//! undefined for exponents above 128, and a literal power of two built from
//! bits avoids relying on it). Clamp with `min(floor(x), 1023.0)` before
//! converting to `u32`. Caveat: WGSL allows flushing subnormals to zero, so
//! the CPU and GPU codes agree bit for bit only when the per-axis extents
//! and offsets are normal numbers (any scene whose lights are not all
//! within ~1e−38 of each other on an axis).

use super::LightPrim;

/// Number of quantization cells per axis (10 bits).
pub const CELLS: u32 = 1024;

/// Binary exponent `E` of a positive finite or infinite `e` (`e = m·2^E`,
/// `m ∈ [1, 2)`), exactly, subnormals included.
pub fn exponent(e: f32) -> i32 {
    let bits = e.to_bits() & 0x7fff_ffff;
    let field = (bits >> 23) as i32;
    if field == 0 {
        // Subnormal: e = mant · 2^−149.
        let mant = bits & 0x007f_ffff;
        31 - mant.leading_zeros() as i32 - 149
    } else {
        field - 127
    }
}

/// `2^k` as an f32, exactly, for `k ∈ [−126, 127]`.
fn pow2(k: i32) -> f32 {
    debug_assert!((-126..=127).contains(&k));
    f32::from_bits(((k + 127) as u32) << 23)
}

/// `d · 2^k` with exact power-of-two factors, split in two for `k > 127`
/// (`k` must lie in `[−126, 254]`).
pub fn scale_pow2(d: f32, k: i32) -> f32 {
    if k > 127 {
        d * pow2(127) * pow2(k - 127)
    } else {
        d * pow2(k)
    }
}

/// Quantizes centroid coordinate `c` on an axis with centroid bounds
/// `[lo, hi]` to `0..=1023` (module docs).
pub fn quantize_axis(c: f32, lo: f32, hi: f32) -> u32 {
    let e = hi - lo;
    if e == 0.0 {
        return 0;
    }
    let k = 9 - exponent(e);
    let x = scale_pow2(c - lo, k).floor().min((CELLS - 1) as f32);
    // `c ≥ lo`, so x ≥ 0; `as` saturates anyway.
    x as u32
}

/// Spreads the low 10 bits of `v` to every third bit (bit i → bit 3i).
fn spread3(v: u32) -> u32 {
    let mut x = v & 0x3ff;
    x = (x | (x << 16)) & 0x0300_00ff;
    x = (x | (x << 8)) & 0x0300_f00f;
    x = (x | (x << 4)) & 0x030c_30c3;
    x = (x | (x << 2)) & 0x0924_9249;
    x
}

/// Interleaves three 10-bit cells into a 30-bit code, x in the highest bit
/// of each triple: bit `3i + 2` = x bit i, `3i + 1` = y bit i, `3i` = z bit i.
pub fn morton30(q: [u32; 3]) -> u32 {
    (spread3(q[0]) << 2) | (spread3(q[1]) << 1) | spread3(q[2])
}

/// Global centroid bounds `(lo, hi)` of `prims` (componentwise min/max).
pub fn centroid_bounds(prims: &[LightPrim]) -> ([f32; 3], [f32; 3]) {
    let mut lo = [f32::INFINITY; 3];
    let mut hi = [f32::NEG_INFINITY; 3];
    for p in prims {
        let c = p.centroid().to_array();
        for a in 0..3 {
            lo[a] = lo[a].min(c[a]);
            hi[a] = hi[a].max(c[a]);
        }
    }
    (lo, hi)
}

/// Morton code of every light (global centroid bounds, then the rule).
pub fn codes(prims: &[LightPrim]) -> Vec<u32> {
    let (lo, hi) = centroid_bounds(prims);
    prims
        .iter()
        .map(|p| {
            let c = p.centroid().to_array();
            morton30(std::array::from_fn(|a| quantize_axis(c[a], lo[a], hi[a])))
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exponent_of_normals_and_subnormals() {
        assert_eq!(exponent(1.0), 0);
        assert_eq!(exponent(1.999_999_9), 0);
        assert_eq!(exponent(2.0), 1);
        assert_eq!(exponent(0.75), -1);
        assert_eq!(exponent(f32::MAX), 127);
        assert_eq!(exponent(f32::MIN_POSITIVE), -126);
        assert_eq!(exponent(f32::from_bits(1)), -149);
        assert_eq!(exponent(f32::from_bits(0x0040_0000)), -127);
        assert_eq!(exponent(f32::from_bits(0x0040_0001)), -127);
        assert_eq!(exponent(f32::from_bits(0x003f_ffff)), -128);
        assert_eq!(exponent(f32::INFINITY), 128);
    }

    #[test]
    fn scale_is_exact_across_the_range() {
        assert_eq!(scale_pow2(1.5, 0), 1.5);
        assert_eq!(scale_pow2(1.5, -3), 0.1875);
        assert_eq!(scale_pow2(f32::from_bits(1), 158), 512.0);
        assert_eq!(scale_pow2(f32::from_bits(3), 150), 6.0);
        assert_eq!(scale_pow2(f32::MAX, -118), f32::MAX / 2f32.powi(118));
    }

    #[test]
    fn spread_and_interleave() {
        assert_eq!(morton30([1, 0, 0]), 0b100);
        assert_eq!(morton30([0, 1, 0]), 0b010);
        assert_eq!(morton30([0, 0, 1]), 0b001);
        assert_eq!(morton30([1023, 1023, 1023]), (1 << 30) - 1);
        assert_eq!(morton30([1 << 9, 0, 0]), 1 << 29);
        for v in [0u32, 1, 5, 77, 512, 1023] {
            let s = spread3(v);
            for i in 0..10 {
                assert_eq!((s >> (3 * i)) & 1, (v >> i) & 1);
            }
            assert_eq!(s & !0x0924_9249, 0);
        }
    }

    #[test]
    fn quantize_endpoints() {
        assert_eq!(quantize_axis(3.0, 3.0, 3.0), 0);
        assert_eq!(quantize_axis(0.0, 0.0, 1.0), 0);
        // e = 1 → E = 0, scale 512: the top of the range is cell 512.
        assert_eq!(quantize_axis(1.0, 0.0, 1.0), 512);
        // e just below 2 → E = 0, scale 512 → 1023 (clamped from 1023.99).
        assert_eq!(quantize_axis(1.999_999_9, 0.0, 1.999_999_9), 1023);
        assert_eq!(quantize_axis(0.5, 0.0, 1.0), 256);
        // Subnormal extent: scale 2^158 split in two.
        let hi = f32::from_bits(3);
        assert_eq!(quantize_axis(hi, 0.0, hi), 768);
    }
}
