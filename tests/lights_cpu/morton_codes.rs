//! Exact Morton codes and the struct layouts the WGSL reads.

use super::*;

/// Reference quantization through f64 and log2 (an independent path).
pub(crate) fn quantize_reference(c: f32, lo: f32, hi: f32) -> u32 {
    let e = hi - lo;
    if e == 0.0 {
        return 0;
    }
    let big_e = (e as f64).log2().floor() as i32;
    let d = (c - lo) as f64;
    ((d * 2f64.powi(9 - big_e)).floor() as u32).min(1023)
}

#[test]
fn morton_quantization_matches_an_f64_reference() {
    let mut rng = StdRng::seed_from_u64(1);
    let scales = [1e-40f32, 1e-30, 1e-3, 1.0, 7.3, 1e6, 1e30];
    for &scale in &scales {
        for _ in 0..2000 {
            let lo = rng.random_range(-1.0f32..1.0) * scale;
            let hi = lo + rng.random::<f32>() * scale;
            let c = lo + (hi - lo) * rng.random::<f32>();
            let c = c.clamp(lo, hi);
            assert_eq!(
                quantize_axis(c, lo, hi),
                quantize_reference(c, lo, hi),
                "c={c:e} lo={lo:e} hi={hi:e}"
            );
        }
    }
    // Subnormal extents: the exponent comes from the bits.
    for bits in [1u32, 2, 3, 0x1234, 0x7fffff] {
        let e = f32::from_bits(bits);
        assert_eq!(exponent(e), (e as f64).log2().floor() as i32);
        assert_eq!(quantize_axis(e, 0.0, e), quantize_reference(e, 0.0, e));
        assert!(quantize_axis(e, 0.0, e) >= 512);
    }
    // Extents of exactly a power of two reach cell 512, just below it 1023.
    assert_eq!(quantize_axis(8.0, 0.0, 8.0), 512);
    assert_eq!(quantize_axis(7.999_999_5, 0.0, 7.999_999_5), 1023);
}

#[test]
fn morton_codes_of_degenerate_sets() {
    // All lights in the plane y = 2: the y bits are 0.
    let prims: Vec<_> = (0..16)
        .map(|i| LightPrim::point(Vec3::new(i as f32, 2.0, (i * 7 % 5) as f32), Vec3::ONE))
        .collect();
    for c in codes(&prims) {
        assert_eq!(c & 0o2222222222, 0, "y bits of {c:o}");
    }
    // Coincident lights: one code, 0.
    let same = vec![LightPrim::point(Vec3::splat(3.0), Vec3::ONE); 5];
    assert_eq!(codes(&same), vec![0; 5]);
    // Two lights on the x axis: lo → 0, hi → cell 512 of x.
    let two = [
        LightPrim::point(Vec3::ZERO, Vec3::ONE),
        LightPrim::point(Vec3::X, Vec3::ONE),
    ];
    assert_eq!(codes(&two), vec![0, morton30([512, 0, 0])]);
    assert_eq!(morton30([512, 0, 0]), 1 << 29);
    assert!(codes(&[]).is_empty());
}

#[test]
fn struct_sizes_match_the_wgsl_layout() {
    assert_eq!(size_of::<TreeNode>(), 32);
    // 4 × (vec3<f32> + u32): the WGSL struct in wgsl/lights/light_prim.wgsl.
    assert_eq!(size_of::<LightPrim>(), 64);
}
