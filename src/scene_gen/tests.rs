//! The generator's unit tests.

use super::*;

#[test]
fn dmath_matches_the_platform_functions() {
    for i in -50..=50 {
        let x = f64::from(i) * 0.37;
        let (s, c) = dmath::sin_cos(x);
        assert!(
            (s - x.sin()).abs() < 1e-13 && (c - x.cos()).abs() < 1e-13,
            "{x}"
        );
        let e = x / 4.0;
        assert!((dmath::exp(e) / e.exp() - 1.0).abs() < 1e-13, "exp {e}");
        assert!((dmath::atan(x) - x.atan()).abs() < 1e-13, "atan {x}");
        assert!((dmath::atan2(x, 1.3) - x.atan2(1.3)).abs() < 1e-13);
        assert!((dmath::atan2(x, -0.7) - x.atan2(-0.7)).abs() < 1e-13);
        let y = 1.7f64.powi(i / 2) * 1.01;
        assert!((dmath::ln(y) - y.ln()).abs() < 1e-13, "ln {y}");
    }
    assert_eq!(dmath::atan2(0.0, 0.0), 0.0);
    assert!((dmath::atan2(-1.0, 0.0) + std::f64::consts::FRAC_PI_2).abs() < 1e-15);
}

/// SplitMix64's published first outputs for seed 0 (after the mixing
/// of the integrand index, the stream is this function's).
#[test]
fn splitmix64_is_the_reference_stream() {
    let mut r = Rng(0);
    assert_eq!(r.next_u64(), 0xE220_A839_7B1D_CDAF);
    assert_eq!(r.next_u64(), 0x6E78_9E6A_A1B9_65F4);
    for _ in 0..1000 {
        let v = r.unit();
        assert!((0.0..1.0).contains(&v));
        let n = r.int(2, 40);
        assert!((2..=40).contains(&n));
        let l = r.log_int(16, 2000);
        assert!((16..=2000).contains(&l));
    }
}

#[test]
fn numbers_are_short_and_symmetric() {
    assert_eq!(num(1.5), "1.5");
    assert_eq!(num(-2.0), "-2");
    assert_eq!(num(-0.000001), "0");
    assert_eq!(num(0.000015), "0.00002");
    assert_eq!(num(-0.000015), "-0.00002");
    assert_eq!(num(123456.789012), "123456.78901");
}

#[test]
fn names_round_trip() {
    for k in GenIntegrand::ALL {
        assert_eq!(k.name().parse::<GenIntegrand>(), Ok(k));
        assert_eq!(k.to_string(), k.name());
    }
    assert!("pathh"
        .parse::<GenIntegrand>()
        .unwrap_err()
        .contains("many_light"));
}

#[test]
fn every_kind_loads_and_is_deterministic() {
    let opts = GenOptions::default();
    for kind in GenIntegrand::ALL {
        for seed in [0, 1, u64::MAX] {
            let text = random_scene(kind, seed, &opts);
            assert_eq!(text, random_scene(kind, seed, &opts));
            let loaded = crate::scene_file::parse(&text, std::path::Path::new("gen.toml"));
            assert!(
                loaded.is_ok(),
                "{kind} seed {seed}: {}\n{text}",
                loaded.unwrap_err()
            );
        }
    }
}
