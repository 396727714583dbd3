use super::*;

#[test]
fn cycles_defaults() {
    assert_eq!(cycles_min_spp(0.1), 32);
    assert_eq!(cycles_min_spp(0.01), 64);
    assert_eq!(cycles_min_spp(0.001), 128);
    // Cycles' need_filter: first filter at 0-based sample
    // (min + 1) | (step − 1).
    for min in 0..300u32 {
        assert_eq!(first_check(min, 16), ((min + 1) | 15) + 1, "min {min}");
    }
    assert_eq!(AdaptiveParams::new(8.0, 0).first_check(), 80);
}

#[test]
fn class_a_is_half_of_every_aligned_four() {
    for block in 0..1000u32 {
        let n = (4 * block..4 * block + 4).filter(|&i| class_a(i)).count();
        assert_eq!(n, 2);
    }
    assert!(!class_a(0) && !class_a(1) && class_a(2) && class_a(3));
}

#[test]
fn error_normalises_by_root_intensity_below_one() {
    // Intensity 0.25: √ = 0.5.
    let e = pixel_error([0.25, 0.0, 0.0], [0.2, 0.0, 0.0]);
    assert!((e - 0.05 / 0.5001).abs() < 1e-12);
    // Intensity 4: linear.
    let e = pixel_error([2.0, 1.0, 1.0], [2.0, 1.5, 1.0]);
    assert!((e - 0.5 / 4.0001).abs() < 1e-12);
}

#[test]
fn dilation_is_a_three_by_three_box() {
    let film = Film {
        width: 5,
        height: 4,
    };
    let mut m = vec![false; 20];
    m[0] = true; // corner
    m[2 * 5 + 3] = true; // (3, 2)
    let d = dilate(film, &m);
    let set: Vec<usize> = (0..20).filter(|&i| d[i]).collect();
    assert_eq!(
        set,
        vec![0, 1, 5, 6, 7, 8, 9, 12, 13, 14, 17, 18, 19],
        "{d:?}"
    );
}

#[test]
fn simulation_keeps_the_budget_exactly() {
    let film = Film {
        width: 7,
        height: 5,
    };
    for spp in [1.0, 3.5, 80.0, 81.3, 200.0] {
        let params = AdaptiveParams::new(spp, 0);
        // Never converges: alternating classes differ.
        let s = simulate(&params, film, |_, i| {
            Some(if class_a(i) { [1.0; 3] } else { [0.0; 3] })
        });
        assert_eq!(s.samples, params.budget(35), "spp {spp}");
        let max = *s.counts.iter().max().unwrap();
        let min = *s.counts.iter().min().unwrap();
        assert!(max - min <= 1, "spp {spp}: {min}..{max}");
    }
}
