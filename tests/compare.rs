//! Equal-time machinery: timing medians and Halton budget matching.

mod common;

use common::gpu;
use mdas::app;
use mdas::compare::{halton_at_equal_time, measure};
use mdas::integrator::Halton;
use std::path::Path;

#[test]
fn halton_budget_search_brackets_the_target_time() {
    let gpu = gpu();
    let prepared = app::prepare(gpu, Path::new("scenes/area_light_plane.toml"), 0.25).unwrap();
    let (w, h) = (prepared.film.width, prepared.film.height);
    let reference = mdas::analytic::area_light_plane_image(w, h);
    // Target: the time Halton itself needs at 24 spp.
    let target = measure(gpu, &mut Halton::new(24, 0), prepared.integrand.as_ref(), 3).unwrap();
    let t = target.total_ms();
    let eq = halton_at_equal_time(
        gpu,
        prepared.integrand.as_ref(),
        &reference,
        t,
        0,
        3,
        1 << 16,
    )
    .unwrap();
    let (lo, hi) = (&eq.lo, &eq.hi);
    assert!(lo.spp <= hi.spp);
    // Either a real bracket, or the target is below one sample per pixel.
    if lo.spp < hi.spp {
        assert!(
            lo.measured.total_ms() <= t && t <= hi.measured.total_ms(),
            "{} ≤ {t} ≤ {}",
            lo.measured.total_ms(),
            hi.measured.total_ms()
        );
        let (a, b) = (
            lo.error.relmse.min(hi.error.relmse),
            lo.error.relmse.max(hi.error.relmse),
        );
        assert!(
            a <= eq.relmse && eq.relmse <= b,
            "interpolated {} outside [{a}, {b}]",
            eq.relmse
        );
    }
    // Timing noise on a shared CPU device is large, but the matched budget
    // must be of the right magnitude.
    assert!(
        (4..=144).contains(&lo.spp),
        "matched spp {} for a 24-spp target",
        lo.spp
    );
    assert_eq!(lo.measured.render.samples, (w * h * lo.spp) as u64);
}
