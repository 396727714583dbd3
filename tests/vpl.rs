//! Virtual point lights by instant radiosity (`src/lights/vpl.rs`,
//! `wgsl/lights/vpl.wgsl`) against physics:
//!
//! * flux conservation in a closed box of albedo ρ: every path hits a wall
//!   at every bounce, so bounce k's VPLs carry exactly `ρ^(k+1)·Φ` in all
//!   (their on-axis intensities times π) — no variance, f32 rounding only
//!   (and the rare path that slips through a seam between walls, counted);
//! * cosine-distributed emission: the first hits of paths from a small
//!   downward-facing square lamp on a large floor at depth h lie within radius
//!   R of the point below with probability `R²/(R² + h²)` — chi-square over
//!   equiprobable rings;
//! * determinism per seed, dark VPLs for escaping paths, and a `many_light`
//!   render with VPLs that stays finite and brighter than without;
//! * unbiasedness of unclamped instant radiosity: direct light plus
//!   one-bounce VPLs has the image mean of a one-bounce path tracer, over
//!   VPL seeds.

mod common;

use common::gpu;
use glam::Vec3;
use mdas::accel::GpuScene;
use mdas::gpu::Profiler;
use mdas::integrand::{IntegrandSpec, ManyLight, ManyLightSpec};
use mdas::integrator::{Halton, Integrator};
use mdas::lights::scene_lights::light_prims;
use mdas::lights::vpl::{self, VplGenerator, VplSpec};
use mdas::lights::{luminance, LightPrim, KIND_VPL};
use mdas::scene_file::{self, SceneFile};
use std::path::Path;
use std::sync::Arc;

mod stats;

fn parse(text: &str) -> SceneFile {
    scene_file::parse(text, Path::new("vpl-test.toml")).unwrap()
}

/// A closed box [0, 2]³ of albedo `rho` (six inward quads) with one point
/// light of intensity `i` at (1, 1, 1).
fn closed_box(rho: f32, i: f32) -> String {
    let q = |name: &str, c: [[f32; 3]; 4]| {
        format!(
            "[[shape]]\ntype = \"quad\"\nname = \"{name}\"\nmaterial = \"wall\"\ncorners = {c:?}\n"
        )
    };
    let mut s = format!(
        "[film]\nwidth = 8\nheight = 8\n[camera]\nposition = [1, 1, 0.5]\nlook_at = [1, 1, 2]\nup = [0, 1, 0]\nfov_y = 60\n\
         [[material]]\nname = \"wall\"\nalbedo = [{rho}, {rho}, {rho}]\n\
         [[light]]\ntype = \"point\"\nposition = [1, 1, 1]\nintensity = [{i}, {i}, {i}]\n"
    );
    // Normals (c1 − c0) × (c2 − c0) face into the box.
    s += &q(
        "floor",
        [[0., 0., 0.], [0., 0., 2.], [2., 0., 2.], [2., 0., 0.]],
    );
    s += &q(
        "ceiling",
        [[0., 2., 0.], [2., 2., 0.], [2., 2., 2.], [0., 2., 2.]],
    );
    s += &q(
        "back",
        [[0., 0., 2.], [0., 2., 2.], [2., 2., 2.], [2., 0., 2.]],
    );
    s += &q(
        "front",
        [[0., 0., 0.], [2., 0., 0.], [2., 2., 0.], [0., 2., 0.]],
    );
    s += &q(
        "left",
        [[0., 0., 0.], [0., 2., 0.], [0., 2., 2.], [0., 0., 2.]],
    );
    s += &q(
        "right",
        [[2., 0., 0.], [2., 0., 2.], [2., 2., 2.], [2., 2., 0.]],
    );
    s + "[integrand]\ntype = \"many_light\"\n"
}

fn generate(scene: &SceneFile, spec: &VplSpec) -> Vec<LightPrim> {
    let film = scene.scene.film;
    let gpu_scene = GpuScene::new(gpu(), &scene.scene, film).unwrap();
    let lights = light_prims(&scene.scene, 0.0);
    let sources = vpl::sources(&scene.scene, &lights);
    VplGenerator::new(gpu())
        .unwrap()
        .generate(
            gpu(),
            &gpu_scene,
            &sources,
            vpl::scene_sphere(&scene.scene, 0.0),
            spec,
            0.0,
            &mut Profiler::new(gpu()),
        )
        .unwrap()
}

#[test]
fn closed_box_conserves_flux_bounce_by_bounce() {
    let (rho, i) = (0.5f32, 3.0f32);
    let scene = parse(&closed_box(rho, i));
    let spec = VplSpec {
        paths: 4096,
        bounces: 4,
        seed: 7,
        clamp: 0.0,
    };
    let vpls = generate(&scene, &spec);
    assert_eq!(vpls.len(), 4096 * 4);
    let phi = 4.0 * std::f64::consts::PI * i as f64;
    for k in 0..4usize {
        let mut sum = 0.0f64;
        let mut alive = 0usize;
        for (slot, v) in vpls.iter().enumerate() {
            assert_eq!(v.kind, KIND_VPL);
            if slot % 4 != k || v.emission == [0.0; 3] {
                continue;
            }
            alive += 1;
            let p = Vec3::from(v.p0);
            let n = Vec3::from(v.p1);
            assert!(
                p.min_element() > -1e-3 && p.max_element() < 2.0 + 1e-3,
                "VPL outside the box: {p}"
            );
            assert!((n.length() - 1.0).abs() < 1e-4, "normal {n}");
            // The normal faces into the box (toward its centre).
            assert!(n.dot(Vec3::ONE - p) > 0.0, "normal {n} at {p}");
            sum += luminance(Vec3::from(v.emission)) as f64 * std::f64::consts::PI;
        }
        // A ray may slip out through a seam between two walls (f32
        // traversal): such a path's VPLs are dark from there on. At most
        // 0.1% may; the others carry exactly their share.
        assert!(
            alive * 1000 >= 999 * 4096,
            "bounce {k}: {alive} of 4096 paths left"
        );
        let want = (rho as f64).powi(k as i32 + 1) * phi * alive as f64 / 4096.0;
        assert!(
            (sum - want).abs() <= 1e-5 * want,
            "bounce {k}: VPL flux {sum}, expected ρ^{} Φ·{alive}/4096 = {want}",
            k + 1
        );
    }
}

/// A small emissive square (two triangles) facing down at height `h` above
/// a large floor (albedo 1), nothing else.
fn triangle_over_floor(h: f32) -> String {
    format!(
        "[film]\nwidth = 8\nheight = 8\n[camera]\nposition = [0, 5, -10]\nlook_at = [0, 0, 0]\nup = [0, 1, 0]\nfov_y = 40\n\
         [[material]]\nname = \"floor\"\nalbedo = [1, 1, 1]\n\
         [[material]]\nname = \"lamp\"\nalbedo = [0, 0, 0]\nemission = [2, 2, 2]\n\
         [[shape]]\ntype = \"quad\"\nname = \"floor\"\nmaterial = \"floor\"\ncorners = [[-1e4, 0, -1e4], [-1e4, 0, 1e4], [1e4, 0, 1e4], [1e4, 0, -1e4]]\n\
         [[shape]]\ntype = \"quad\"\nname = \"lamp\"\nmaterial = \"lamp\"\ncorners = [[-0.001, {h}, -0.001], [0.001, {h}, -0.001], [0.001, {h}, 0.001], [-0.001, {h}, 0.001]]\n\
         [integrand]\ntype = \"many_light\"\n"
    )
}

#[test]
fn first_hits_follow_the_cosine_law() {
    let h = 1.0f32;
    let scene = parse(&triangle_over_floor(h));
    let paths = 20_000u32;
    let vpls = generate(
        &scene,
        &VplSpec {
            paths,
            bounces: 1,
            seed: 3,
            clamp: 0.0,
        },
    );
    // Ten equiprobable rings: P(r ≤ R) = R²/(R² + h²), so ring j ends at
    // R_j = h·sqrt(q/(1 − q)), q = j/10. Paths that miss the 2e4-wide floor
    // (r > 1e4: probability ~1e-8) would show up as dark VPLs.
    let bins = 10usize;
    let mut counts = vec![0u64; bins];
    for v in &vpls {
        let p = Vec3::from(v.p0);
        assert!(luminance(Vec3::from(v.emission)) > 0.0, "a dark VPL at {p}");
        assert!(p.y.abs() < 1e-3, "first hit off the floor: {p}");
        let r2 = p.x * p.x + p.z * p.z;
        let q = r2 as f64 / (r2 as f64 + (h * h) as f64);
        counts[((q * bins as f64) as usize).min(bins - 1)] += 1;
    }
    let expected = vec![paths as f64 / bins as f64; bins];
    let chi2: f64 = counts
        .iter()
        .zip(&expected)
        .map(|(&o, &e)| (o as f64 - e).powi(2) / e)
        .sum();
    // 9 degrees of freedom; significance 1e-3.
    let p = stats::gamma_q(4.5, chi2 / 2.0);
    assert!(p > 1e-3, "chi² = {chi2} (p = {p}), counts {counts:?}");
    // Every path carries Φ/paths = π·L·area/paths; reflected by albedo 1,
    // each VPL's on-axis intensity is that over π.
    let area: f32 = light_prims(&scene.scene, 0.0)
        .iter()
        .map(|l| l.area())
        .sum();
    let want = 2.0 * area / paths as f32;
    for v in vpls.iter().take(50) {
        assert!(
            (v.emission[0] - want).abs() <= 1e-4 * want,
            "{} vs {want}",
            v.emission[0]
        );
    }
}

#[test]
fn vpls_are_deterministic_per_seed_and_dark_when_paths_escape() {
    // An open scene: most paths from the lamp escape past the floor's edge
    // after the first bounce.
    let scene = parse(&triangle_over_floor(1.0).replace("1e4", "2"));
    let spec = VplSpec {
        paths: 3000,
        bounces: 3,
        seed: 11,
        clamp: 0.0,
    };
    let a = generate(&scene, &spec);
    let b = generate(&scene, &spec);
    assert!(a == b, "same seed, different VPLs");
    let c = generate(&scene, &VplSpec { seed: 12, ..spec });
    assert!(a != c, "another seed gave the same VPLs");
    let dark = a.iter().filter(|v| v.emission == [0.0; 3]).count();
    assert!(dark > 1000, "only {dark} dark VPLs in an open scene");
    for v in a.iter().filter(|v| v.emission == [0.0; 3]) {
        assert!(Vec3::from(v.p0).is_finite());
    }
    // No source with flux: every VPL dark, none lost.
    let black =
        parse(&triangle_over_floor(1.0).replace("emission = [2, 2, 2]", "emission = [0, 0, 0]"));
    let d = generate(&black, &spec);
    assert_eq!(d.len(), 9000);
    assert!(d.iter().all(|v| v.emission == [0.0; 3]));
}

#[test]
fn many_light_renders_with_vpls() {
    let text = closed_box(0.5, 3.0).replace(
        "[integrand]\ntype = \"many_light\"\n",
        "[integrand]\ntype = \"many_light\"\nsampler = \"tree_cone\"\nvpls = 2000\nvpl_bounces = 2\nvpl_clamp = 0.1\n",
    );
    let scene = parse(&text);
    let IntegrandSpec::ManyLight(spec) = scene.integrand.clone() else {
        panic!("many_light")
    };
    assert_eq!(
        spec.vpl,
        VplSpec {
            paths: 2000,
            bounces: 2,
            seed: 0,
            clamp: 0.1
        }
    );
    let film = scene.scene.film;
    let render = |spec: &ManyLightSpec| {
        let gs = Arc::new(GpuScene::new(gpu(), &scene.scene, film).unwrap());
        let ml = ManyLight::new(gpu(), &scene.scene, gs, film, spec).unwrap();
        assert_eq!(ml.light_count(), 1 + spec.vpl.count());
        let r = Halton::new(64, 1).render(gpu(), &ml).unwrap();
        assert_eq!(r.nonfinite, 0);
        r.image
            .iter()
            .map(|p| luminance(Vec3::from(*p)) as f64)
            .sum::<f64>()
    };
    let with = render(&spec);
    let without = render(&ManyLightSpec {
        vpl: VplSpec::default(),
        ..spec.clone()
    });
    // Indirect light in a closed box of albedo 1/2 adds about as much as
    // the direct light (ρ + ρ² of it with two bounces): at least a third.
    assert!(with > 1.33 * without, "with VPLs {with}, without {without}");
}

/// Mean luminance of an image.
fn image_mean(image: &[[f32; 3]]) -> f64 {
    image
        .iter()
        .map(|p| luminance(Vec3::from(*p)) as f64)
        .sum::<f64>()
        / image.len() as f64
}

fn mean_and_se(xs: &[f64]) -> (f64, f64) {
    let n = xs.len() as f64;
    let m = xs.iter().sum::<f64>() / n;
    let var = xs.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (n - 1.0);
    (m, (var / n).sqrt())
}

/// Instant radiosity without a clamp is unbiased over VPL sets: in the
/// closed box, direct light plus one-bounce VPLs (`vpl_bounces = 1`,
/// `vpl_clamp = 0`) has the same expected image as a path tracer with one
/// indirect bounce. The image means over 8 VPL seeds and over 4 path-tracer
/// seeds agree within 6 standard errors of their difference (seed-to-seed
/// spread; t with ≥ 3 dof at 6 is p < 0.01 even for the heavy tails of
/// unclamped VPLs).
#[test]
fn unclamped_vpls_converge_to_one_bounce_path_tracing() {
    let text = closed_box(0.5, 3.0).replace(
        "[integrand]\ntype = \"many_light\"\n",
        "[integrand]\ntype = \"many_light\"\nsampler = \"tree_cone\"\nvpls = 4000\n",
    );
    let scene = parse(&text);
    let IntegrandSpec::ManyLight(spec) = scene.integrand.clone() else {
        panic!("many_light")
    };
    let film = scene.scene.film;
    let gs = Arc::new(GpuScene::new(gpu(), &scene.scene, film).unwrap());
    let vpl: Vec<f64> = (0..8u32)
        .map(|seed| {
            let spec = ManyLightSpec {
                vpl: VplSpec { seed, ..spec.vpl },
                ..spec.clone()
            };
            let ml = ManyLight::new(gpu(), &scene.scene, gs.clone(), film, &spec).unwrap();
            let r = Halton::new(256, seed + 1).render(gpu(), &ml).unwrap();
            assert_eq!(r.nonfinite, 0);
            image_mean(&r.image)
        })
        .collect();
    let pt = mdas::integrand::PathTracing::new(gs.clone(), film, 1).unwrap();
    let path: Vec<f64> = (0..4u32)
        .map(|seed| {
            image_mean(
                &Halton::new(1024, seed + 1)
                    .render(gpu(), &pt)
                    .unwrap()
                    .image,
            )
        })
        .collect();
    let (mv, sv) = mean_and_se(&vpl);
    let (mp, sp) = mean_and_se(&path);
    let bound = 6.0 * (sv * sv + sp * sp).sqrt();
    eprintln!("VPL mean {mv} ± {sv}, path tracing {mp} ± {sp}");
    assert!(
        (mv - mp).abs() <= bound,
        "VPLs {mv} ± {sv} against path tracing {mp} ± {sp}: differ by more than {bound}"
    );
    // And the test can tell: the direct light alone is far below (measured:
    // VPLs 0.403 ± 0.009, path tracing 0.4133, direct 0.282).
    let direct = ManyLight::new(
        gpu(),
        &scene.scene,
        gs,
        film,
        &ManyLightSpec {
            vpl: VplSpec::default(),
            ..spec
        },
    )
    .unwrap();
    let d = image_mean(&Halton::new(256, 1).render(gpu(), &direct).unwrap().image);
    assert!(
        mp - d > 2.0 * bound,
        "direct {d}, with one bounce {mp}, bound {bound}"
    );
}
