//! Known answers for the depth-of-field, motion-blur, ambient-occlusion and
//! path-tracing integrands, rendered with Halton on the GPU (lavapipe is
//! enough; without an adapter these tests fail, never skip).
//!
//! Statistics. Halton with a random per-pixel Cranley–Patterson shift makes
//! every sample uniform over the pixel × [0,1)^(d−2), so a pixel value is
//! an unbiased mean of N samples. Where a sample takes two values a, b
//! (an indicator), its variance is (b − a)²·c(1 − c) for the covered
//! fraction c; we allow 5 standard deviations of independent sampling plus
//! one sample's worth (|b − a|/N) per pixel — randomized Halton points are
//! better stratified than independent ones, so this is conservative. Image
//! means are checked within 5 standard errors estimated from the pixels.

mod common;

use common::gpu;
use mdas::integrand::IntegrandSpec;
use mdas::integrator::{Halton, Integrator, Render};
use mdas::scene_file;
use mdas::scene_file::SceneFile;
use mdas::session;
use std::path::Path;

fn parse(text: &str) -> SceneFile {
    scene_file::parse(text, Path::new("inline.toml")).unwrap()
}

fn render(scene: &SceneFile, spp: u32, seed: u32) -> Render {
    let gpu = gpu();
    let integrand = session::integrand_for(gpu, scene, scene.scene.film).unwrap();
    let r = Halton::new(spp, seed)
        .render(gpu, integrand.as_ref())
        .unwrap();
    assert_eq!(r.nonfinite, 0, "non-finite samples");
    r
}

// ------------------------------------------------------------ depth of field

/// A checkered plane facing the camera at z = 0.05 (checker cells of 0.1,
/// about 2 pixels), lit head-on by a directional light.
fn focus_plane(aperture: f32, focus: f32) -> SceneFile {
    parse(&format!(
        r#"
[film]
width = 64
height = 48
[camera]
position = [0, 0, 5.05]
look_at = [0, 0, 0.05]
up = [0, 1, 0]
fov_y = 30
aperture_radius = {aperture}
focus_distance = {focus}
[[material]]
name = "board"
albedo = [0.8, 0.8, 0.8]
checker = {{ albedo2 = [0.2, 0.2, 0.2], scale = 0.1 }}
[[shape]]
type = "quad"
material = "board"
corners = [[-10, -10, 0.05], [10, -10, 0.05], [10, 10, 0.05], [-10, 10, 0.05]]
[[light]]
type = "directional"
direction = [0, 0, -1]
irradiance = [1, 1, 1]
[integrand]
type = "depth_of_field"
"#
    ))
}

/// Every lens ray through a film point meets the plane of focus where the
/// pinhole ray does, and the shading there does not depend on the lens
/// point (Lambertian, head-on directional light, nothing occludes): the
/// thin-lens image of a plane at the focus distance equals the pinhole
/// image sample for sample, up to rounding of the hit point. Rounding can
/// move a hit across a checker edge (a sample changes by (0.8 − 0.2)/π).
/// The bound on such flips: each ray's hit is off by at most δ = 64 ulps
/// of its length L = 5.05 (≈ 10 f32 operations from the film and lens
/// points to the hit, each within ½ ulp: a 12× margin, for their growth
/// through the division by the ray's z component), so a sample can
/// flip only if its exact hit lies within δ of a checker edge. The edges
/// are the lines x, y ∈ 0.1·ℤ, so that happens on a fraction ≤ 4δ/s of the
/// plane (s = 0.1), and the film points are uniform over the pixels
/// (randomized Halton): the flip count has mean ≤ 4δ/s·N over N samples,
/// and we allow that mean plus 5 of its Poisson standard deviations. The
/// same plane out of focus must differ visibly, so the test cannot pass
/// with the lens ignored.
#[test]
fn plane_at_the_focus_distance_is_as_sharp_as_the_pinhole_image() {
    let spp = 64;
    let pinhole = render(&focus_plane(0.0, 5.0), spp, 1);
    let lens = render(&focus_plane(0.3, 5.0), spp, 1);
    let blurred = render(&focus_plane(0.3, 2.5), spp, 1);
    let flip = 0.6 / std::f32::consts::PI / spp as f32;
    let diff = |a: &Render, b: &Render| -> Vec<f32> {
        a.image
            .iter()
            .zip(&b.image)
            .map(|(x, y)| (x[0] - y[0]).abs())
            .collect()
    };
    let d = diff(&pinhole, &lens);
    let flips: f32 = d.iter().map(|e| (e / flip).round()).sum();
    let total_samples = (d.len() as u32 * spp) as f32;
    let mean_blur = diff(&pinhole, &blurred).iter().sum::<f32>() / d.len() as f32;
    println!(
        "in focus: max |Δ| {:.2e}, ≈{flips} flipped samples of {total_samples}; out of focus: mean |Δ| {mean_blur:.3}",
        d.iter().cloned().fold(0.0, f32::max)
    );
    for (p, e) in d.iter().enumerate() {
        // Whole flips only (plus f32 summation noise).
        assert!(
            (e / flip - (e / flip).round()).abs() < 0.05 || *e < 1e-5,
            "pixel {p}: |Δ| = {e} is not a whole number of checker flips"
        );
    }
    // ulp(L) ≤ L·2⁻²³ = L·f32::EPSILON.
    let delta = 64.0 * 5.05 * f32::EPSILON;
    let mean_flips = 4.0 * delta / 0.1 * total_samples;
    let allowed = mean_flips + 5.0 * mean_flips.sqrt();
    assert!(
        flips <= allowed,
        "{flips} flipped samples (rounding allows {allowed:.0})"
    );
    assert!(
        mean_blur > 0.02,
        "the out-of-focus plane should be blurred (mean |Δ| {mean_blur})"
    );
}

// --------------------------------------------------------------- motion blur

const MB_W: u32 = 64;
const MB_H: u32 = 4;
const MB_BACKGROUND: f64 = 0.25;
const MB_HALF_WIDTH: f64 = 0.3;
/// Unevenly spaced keyframes of the bar's x translation: (time, x).
const MB_KEYS: [(f64, f64); 3] = [(0.0, -1.5), (0.25, 0.0), (1.0, 1.0)];

/// An emissive (L_e = 1, albedo 0) vertical bar 0.6 wide at z = 0 moving
/// along x with piecewise-linear motion over the shutter, in front of a
/// constant background of 0.25; the camera looks down −z from z = 5.
fn moving_bar() -> SceneFile {
    parse(&format!(
        r#"
background = [{b}, {b}, {b}]
[film]
width = {MB_W}
height = {MB_H}
[camera]
position = [0, 0, 5]
look_at = [0, 0, 0]
up = [0, 1, 0]
fov_y = 10
[[material]]
name = "glow"
albedo = [0, 0, 0]
emission = [1, 1, 1]
[[shape]]
type = "quad"
material = "glow"
corners = [[-{h}, -5, 0], [{h}, -5, 0], [{h}, 5, 0], [-{h}, 5, 0]]
motion = [
  {{ time = {t0}, translate = [{x0}, 0, 0] }},
  {{ time = {t1}, translate = [{x1}, 0, 0] }},
  {{ time = {t2}, translate = [{x2}, 0, 0] }},
]
[integrand]
type = "motion_blur"
"#,
        b = MB_BACKGROUND,
        h = MB_HALF_WIDTH,
        t0 = MB_KEYS[0].0,
        x0 = MB_KEYS[0].1,
        t1 = MB_KEYS[1].0,
        x1 = MB_KEYS[1].1,
        t2 = MB_KEYS[2].0,
        x2 = MB_KEYS[2].1,
    ))
}

/// The fraction of (pixel column i's footprint × shutter) the bar covers,
/// exactly: on the plane z = 0 film x maps linearly to world
/// X = 5·tan(fov/2)·aspect·(2x/W − 1), so column i covers [X0, X1].
fn covered_fraction(i: u32) -> f64 {
    let k = 5.0 * (5f64.to_radians()).tan() * (MB_W as f64 / MB_H as f64);
    let x0 = k * (2.0 * i as f64 / MB_W as f64 - 1.0);
    let x1 = k * (2.0 * (i + 1) as f64 / MB_W as f64 - 1.0);
    swept_overlap(x0, x1, 0.0, MB_HALF_WIDTH, &MB_KEYS)
}

/// ∫₀¹ |[x0, x1] ∩ [c(t) + offset − half, c(t) + offset + half]| dt / (x1 − x0)
/// for the piecewise-linear path c through `keys` (time, x). The overlap
/// length is piecewise linear in t, with kinks at the keyframes and where
/// an edge crosses x0 or x1, so the trapezoid rule between those
/// breakpoints is exact.
fn swept_overlap(x0: f64, x1: f64, offset: f64, half: f64, keys: &[(f64, f64)]) -> f64 {
    let overlap = |c: f64| ((c + offset + half).min(x1) - (c + offset - half).max(x0)).max(0.0);
    let mut total = 0.0;
    for w in keys.windows(2) {
        let ((ta, ca), (tb, cb)) = (w[0], w[1]);
        let v = (cb - ca) / (tb - ta);
        let mut ts = vec![ta, tb];
        for edge in [x0, x1] {
            for off in [-half, half] {
                let t = ta + (edge - offset - off - ca) / v;
                if t > ta && t < tb {
                    ts.push(t);
                }
            }
        }
        ts.sort_by(f64::total_cmp);
        for s in ts.windows(2) {
            let c = |t: f64| ca + v * (t - ta);
            total += 0.5 * (s[1] - s[0]) * (overlap(c(s[0])) + overlap(c(s[1])));
        }
    }
    total / (x1 - x0)
}

#[test]
fn moving_bar_covers_each_pixel_for_the_exact_fraction_of_the_shutter() {
    let spp = 256;
    let r = render(&moving_bar(), spp, 7);
    let n = spp as f64;
    let (mut worst, mut err_sum, mut var_sum) = (0.0f64, 0.0, 0.0);
    for j in 0..MB_H {
        for i in 0..MB_W {
            let c = covered_fraction(i);
            let exact = MB_BACKGROUND + (1.0 - MB_BACKGROUND) * c;
            let got = r.image[(j * MB_W + i) as usize][0] as f64;
            let sigma = (1.0 - MB_BACKGROUND) * (c * (1.0 - c) / n).sqrt();
            let tol = 5.0 * sigma + (1.0 - MB_BACKGROUND) / n + 1e-5;
            let e = got - exact;
            worst = worst.max(e.abs() / tol);
            err_sum += e;
            var_sum += sigma * sigma;
            assert!(
                e.abs() <= tol,
                "pixel ({i}, {j}): {got} vs exact {exact} (covered {c:.4}), tolerance {tol:.4}"
            );
        }
    }
    let npix = (MB_W * MB_H) as f64;
    let mean_err = err_sum / npix;
    let se = var_sum.sqrt() / npix;
    println!("worst |err|/tol {worst:.3}; mean error {mean_err:.2e} (σ {se:.2e})");
    assert!(
        mean_err.abs() <= 5.0 * se + 1e-5,
        "biased: mean error {mean_err}"
    );
    // The bar sweeps from X = −1.8 to 1.3: the image must contain both
    // untouched and partially covered columns.
    assert!((0..MB_W).any(|i| covered_fraction(i) == 0.0));
    assert!((0..MB_W).any(|i| covered_fraction(i) > 0.1));
}

/// Unevenly spaced keyframes of the wall's x translation: (time, x).
const WALL_KEYS: [(f64, f64); 3] = [(0.0, -2.2), (0.7, -1.5), (1.0, -0.5)];

/// A floor (ρ = 0.5) seen straight down from height 2 (48×4 pixels,
/// fov_y 2.25°: it sees |x| < 0.48), lit by a directional light travelling along (1, −1, 0)
/// (E = 1, cosθ = 1/√2). A wall x = x_w(t), y ∈ [0.5, 1.5], out of the
/// camera's view, moves with the shutter; its shadow on the floor is
/// [x_w + 0.5, x_w + 1.5] at time t.
fn moving_shadow() -> SceneFile {
    parse(&format!(
        r#"
[film]
width = 48
height = 4
[camera]
position = [0, 2, 0]
look_at = [0, 0, 0]
up = [0, 0, -1]
fov_y = 2.25
[[material]]
name = "grey"
albedo = [0.5, 0.5, 0.5]
[[shape]]
type = "quad"
material = "grey"
corners = [[-10, 0, -10], [-10, 0, 10], [10, 0, 10], [10, 0, -10]]
[[shape]]
type = "quad"
material = "grey"
corners = [[0, 0.5, -10], [0, 1.5, -10], [0, 1.5, 10], [0, 0.5, 10]]
motion = [
  {{ time = {t0}, translate = [{x0}, 0, 0] }},
  {{ time = {t1}, translate = [{x1}, 0, 0] }},
  {{ time = {t2}, translate = [{x2}, 0, 0] }},
]
[[light]]
type = "directional"
direction = [1, -1, 0]
irradiance = [1, 1, 1]
[integrand]
type = "motion_blur"
"#,
        t0 = WALL_KEYS[0].0,
        x0 = WALL_KEYS[0].1,
        t1 = WALL_KEYS[1].0,
        x1 = WALL_KEYS[1].1,
        t2 = WALL_KEYS[2].0,
        x2 = WALL_KEYS[2].1,
    ))
}

/// Shadow rays are traced at the sample's time: each pixel's value is
/// ρ/π·E·cosθ times the fraction of (footprint × shutter) the moving
/// shadow leaves lit, computed exactly as for the moving bar.
#[test]
fn moving_shadow_darkens_each_pixel_for_the_exact_fraction_of_the_shutter() {
    let spp = 256;
    let r = render(&moving_shadow(), spp, 9);
    let lit = 0.5 / std::f64::consts::PI * std::f64::consts::FRAC_1_SQRT_2;
    let n = spp as f64;
    let k = 2.0 * (1.125f64.to_radians()).tan() * (48.0 / 4.0);
    let mut shadowed_somewhere = false;
    for i in 0..48u32 {
        let x0 = k * (2.0 * i as f64 / 48.0 - 1.0);
        let x1 = k * (2.0 * (i + 1) as f64 / 48.0 - 1.0);
        let c = swept_overlap(x0, x1, 1.0, 0.5, &WALL_KEYS);
        shadowed_somewhere |= c > 0.05;
        let exact = lit * (1.0 - c);
        let tol = lit * (5.0 * (c * (1.0 - c) / n).sqrt() + 1.0 / n) + 1e-5;
        for j in 0..4u32 {
            let got = r.image[(j * 48 + i) as usize][0] as f64;
            assert!(
                (got - exact).abs() <= tol,
                "pixel ({i}, {j}): {got} vs exact {exact} (shadowed {c:.4}), tolerance {tol:.2e}"
            );
        }
    }
    assert!(shadowed_somewhere);
}

// -------------------------------------------------------- ambient occlusion

/// A floor (y = 0, facing +y) seen straight down from y = 0.5; with
/// `ceiling`, a downward-facing quad at y = 1 covers it.
fn ao_scene(radius: f32, ceiling: bool) -> SceneFile {
    let ceiling = if ceiling {
        r#"
[[shape]]
type = "quad"
material = "grey"
corners = [[-100, 1, -100], [100, 1, -100], [100, 1, 100], [-100, 1, 100]]
"#
    } else {
        ""
    };
    parse(&format!(
        r#"
[film]
width = 32
height = 24
[camera]
position = [0, 0.5, 0]
look_at = [0, 0, 0]
up = [0, 0, -1]
fov_y = 60
[[material]]
name = "grey"
albedo = [0.5, 0.5, 0.5]
[[shape]]
type = "quad"
material = "grey"
corners = [[-100, 0, -100], [-100, 0, 100], [100, 0, 100], [100, 0, -100]]
{ceiling}
[integrand]
type = "ambient_occlusion"
radius = {radius}
"#
    ))
}

/// Every sample is exactly 1, so the Halton mean is exactly 1, and MDAS's
/// reconstruction (a normalized weighting of samples) is 1 up to float
/// rounding of its weights.
#[test]
fn ambient_occlusion_of_an_unoccluded_plane_is_exactly_one() {
    let scene = ao_scene(1000.0, false);
    let r = render(&scene, 16, 3);
    for (p, v) in r.image.iter().enumerate() {
        assert_eq!(*v, [1.0; 3], "pixel {p}");
    }
    let integrand = session::integrand_for(gpu(), &scene, scene.scene.film).unwrap();
    let params = mdas::integrator::mdas::MdasParams {
        extra_image_bits: 2,
        spp: 8.0,
        ..Default::default()
    };
    let r = mdas::integrator::Mdas::new(params)
        .and_then(|mut m| m.render(gpu(), integrand.as_ref()))
        .unwrap();
    assert_eq!(r.nonfinite, 0);
    for (p, v) in r.image.iter().enumerate() {
        assert!(
            v.iter().all(|c| (c - 1.0).abs() <= 1e-5),
            "MDAS pixel {p}: {v:?}"
        );
    }
}

/// Under a parallel ceiling at height 1, a cosine-weighted ray at angle θ
/// from the floor's normal hits it at distance 1/cosθ, so within radius
/// r ≥ 1 the unoccluded fraction is P(cosθ < 1/r) = 1/r² (for the
/// cosine-weighted density P(cosθ ≥ c) = 1 − c²); for r < 1 it is exactly
/// 1. The ceiling's finite size (±100) changes this by < 1e-4.
#[test]
fn ambient_occlusion_under_a_ceiling_is_one_over_radius_squared() {
    let r = render(&ao_scene(0.5, true), 16, 3);
    assert!(r.image.iter().all(|v| *v == [1.0; 3]), "radius 0.5 < 1: 1");

    let spp = 256;
    let r = render(&ao_scene(2.0, true), spp, 3);
    let exact = 0.25f64;
    let sigma = (exact * (1.0 - exact) / spp as f64).sqrt();
    let mut sum = 0.0;
    for (p, v) in r.image.iter().enumerate() {
        let e = v[0] as f64 - exact;
        sum += v[0] as f64;
        assert!(
            e.abs() <= 5.0 * sigma + 1.0 / spp as f64,
            "pixel {p}: {} vs {exact}",
            v[0]
        );
    }
    let mean = sum / r.image.len() as f64;
    let se = sigma / (r.image.len() as f64).sqrt();
    println!("AO mean {mean:.5} vs {exact} (σ of the mean {se:.1e})");
    assert!((mean - exact).abs() <= 5.0 * se);
}

// ----------------------------------------------------------- path tracing

/// The inside of a closed sphere of radius 1 (a lathe profile listed top
/// to bottom: normals inward), albedo ρ and emission L_e everywhere,
/// camera at the centre.
fn furnace(rho: f32, le: f32, max_bounces: u32) -> SceneFile {
    parse(&furnace_text(rho, le, max_bounces))
}

fn furnace_text(rho: f32, le: f32, max_bounces: u32) -> String {
    let profile: Vec<String> = (0..=32)
        .map(|k| {
            let phi = std::f64::consts::PI * k as f64 / 32.0;
            let r = if k == 0 || k == 32 { 0.0 } else { phi.sin() };
            format!("[{r}, {}]", phi.cos())
        })
        .collect();
    format!(
        r#"
[film]
width = 32
height = 32
[camera]
position = [0, 0, 0]
look_at = [0, 0, -1]
up = [0, 1, 0]
fov_y = 60
[[material]]
name = "furnace"
albedo = [{rho}, {rho}, {rho}]
emission = [{le}, {le}, {le}]
[[shape]]
type = "lathe"
material = "furnace"
segments = 48
profile = [{}]
[integrand]
type = "path"
max_bounces = {max_bounces}
"#,
        profile.join(", ")
    )
}

/// In a closed surface emitting L_e with albedo ρ everywhere, the
/// radiance after n scattering events is L_e·ρⁿ. Our path counts L_e seen
/// directly, then area-light NEE at x_0 … x_m (one more scattering each:
/// ρ¹ … ρ^{m+1}) and never emission reached by a bounce, so its
/// expectation is L_e·Σ_{k=0..m+1} ρ^k — exactly, for any closed
/// tessellated surface (the irradiance inside a closed uniform emitter is
/// π·L_e everywhere). The pixels are independent estimates of that same
/// value; their mean must be within 5 standard errors (estimated from the
/// pixels' spread) plus 1e-4 for f32 accumulation.
#[test]
fn path_tracer_furnace_converges_to_the_truncated_geometric_series() {
    let (rho, le) = (0.5f64, 1.0f64);
    for m in 1..=3u32 {
        let scene = furnace(rho as f32, le as f32, m);
        assert_eq!(
            scene.integrand,
            IntegrandSpec::PathTracing { max_bounces: m }
        );
        let integrand = session::integrand_for(gpu(), &scene, scene.scene.film).unwrap();
        assert_eq!(integrand.dims(), 4 + 4 * m);
        let r = Halton::new(64, 11)
            .render(gpu(), integrand.as_ref())
            .unwrap();
        assert_eq!(r.nonfinite, 0);
        let exact: f64 = (0..=m + 1).map(|k| le * rho.powi(k as i32)).sum();
        let v: Vec<f64> = r.image.iter().map(|p| p[1] as f64).collect();
        let n = v.len() as f64;
        let mean = v.iter().sum::<f64>() / n;
        let var = v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0);
        let se = (var / n).sqrt();
        println!("m = {m}: mean {mean:.5} vs {exact:.5} (standard error {se:.1e})");
        assert!(
            (mean - exact).abs() <= 5.0 * se + 1e-4,
            "m = {m}: furnace mean {mean} vs L_e·Σρ^k = {exact} (se {se})"
        );
        // One bounce fewer or more would be off by ρ^{m+1}/ρ^{m+2} ≥ 1/32:
        // the test must be able to tell.
        assert!(5.0 * se + 1e-4 < le * rho.powi(m as i32 + 2) / 2.0);
    }
}

#[test]
fn path_dimensions_follow_the_documented_layout() {
    use mdas::integrand::path::{max_bounces_limit, path_dims};
    assert_eq!(path_dims(2, false), 6); // the paper's Cornell box: 6D
    assert_eq!(path_dims(1, false), 4); // Breakfast: 4D
    assert_eq!(path_dims(3, true), 16);
    assert_eq!(max_bounces_limit(false), 7);
    assert_eq!(max_bounces_limit(true), 3);
    // Too many bounces for the dimension budget is a scene-file error
    // pointing at the value.
    let e = scene_file::parse(&furnace_text(0.5, 1.0, 4), Path::new("f.toml"))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("max_bounces must be in 1..=3") && e.starts_with("f.toml:"),
        "{e}"
    );
}

// ------------------------------------------------------------ scene files

fn integrand_error(table: &str) -> String {
    let text = format!(
        "[film]\nwidth = 4\nheight = 4\n[camera]\nposition = [0, 0, 1]\nlook_at = [0, 0, 0]\nup = [0, 1, 0]\nfov_y = 40\n[integrand]\n{table}\n"
    );
    scene_file::parse(&text, Path::new("s.toml"))
        .unwrap_err()
        .to_string()
}

#[test]
fn integrand_tables_parse_with_their_parameters_and_reject_mistakes() {
    let ok = |table: &str| {
        let text = format!(
            "[film]\nwidth = 4\nheight = 4\n[camera]\nposition = [0, 0, 1]\nlook_at = [0, 0, 0]\nup = [0, 1, 0]\nfov_y = 40\n[integrand]\n{table}\n"
        );
        scene_file::parse(&text, Path::new("s.toml"))
            .unwrap()
            .integrand
    };
    assert_eq!(ok("type = \"depth_of_field\""), IntegrandSpec::DepthOfField);
    assert_eq!(ok("type = \"motion_blur\""), IntegrandSpec::MotionBlur);
    assert_eq!(
        ok("type = \"path\""),
        IntegrandSpec::PathTracing { max_bounces: 1 }
    );
    assert_eq!(
        ok("type = \"path\"\nmax_bounces = 7"),
        IntegrandSpec::PathTracing { max_bounces: 7 }
    );
    assert_eq!(
        ok("type = \"ambient_occlusion\"\nradius = 0.5"),
        IntegrandSpec::AmbientOcclusion { radius: 0.5 }
    );

    let e = integrand_error("type = \"pathtracer\"");
    assert!(
        e.starts_with("s.toml:10:8: unknown integrand type 'pathtracer'"),
        "{e}"
    );
    assert!(
        e.contains("'path'") && e.contains("'ambient_occlusion'"),
        "{e}"
    );
    let e = integrand_error("type = \"path\"\nmax_bounces = 8");
    assert!(
        e.starts_with("s.toml:11:15: max_bounces must be in 1..=7"),
        "{e}"
    );
    let e = integrand_error("type = \"path\"\nmax_bounces = 0");
    assert!(e.contains("max_bounces must be in 1..=7"), "{e}");
    let e = integrand_error("type = \"ambient_occlusion\"");
    assert!(
        e.contains("a ambient_occlusion integrand needs 'radius'"),
        "{e}"
    );
    let e = integrand_error("type = \"ambient_occlusion\"\nradius = -1");
    assert!(e.contains("radius must be > 0"), "{e}");
    let e = integrand_error("type = \"depth_of_field\"\nradius = 1");
    assert!(
        e.starts_with("s.toml:11:10: key 'radius' does not apply to a depth_of_field integrand (it takes no other keys)"),
        "{e}"
    );
    let e = integrand_error("type = \"path\"\nmax_bounces = 1.5");
    assert!(e.starts_with("s.toml:11:"), "{e}");
}

// ------------------------------------------------------------- delta lights

/// A grey plane (ρ = 0.5) seen straight down from height 2, lit by a
/// directional light at cosθ = 0.8 (E = 1) and a point light (I = 1) at
/// height 1; nothing occludes either light.
fn lit_plane(integrand: &str) -> SceneFile {
    parse(&format!(
        r#"
[film]
width = 16
height = 12
[camera]
position = [0, 2, 0]
look_at = [0, 0, 0]
up = [0, 0, -1]
fov_y = 60
[[material]]
name = "grey"
albedo = [0.5, 0.5, 0.5]
[[shape]]
type = "quad"
material = "grey"
corners = [[-10, 0, -10], [-10, 0, 10], [10, 0, 10], [10, 0, -10]]
[[light]]
type = "directional"
direction = [0.6, -0.8, 0]
irradiance = [1, 1, 1]
[[light]]
type = "point"
position = [0.3, 1, 0.2]
intensity = [1, 1, 1]
[integrand]
{integrand}
"#
    ))
}

/// ρ/π·(E·cosθ_d + I·cosθ_p/d²) at the plane point under film point (x, y),
/// with the point light seen from `lift(p)` above the plane point p (0:
/// the physical value; the renderer aims its shadow rays from an origin
/// offset along the normal, see [`ray_offset`]).
fn lit_plane_radiance(x: f64, y: f64, lift: impl Fn(f64, f64) -> f64) -> f64 {
    // Camera at (0, 2, 0) looking down −y with up hint −z: f = −y,
    // r = f × up = (−y) × (−z) = +x, u = r × f = −z.
    let t = (30f64).to_radians().tan();
    let (nx, ny) = (2.0 * x / 16.0 - 1.0, 1.0 - 2.0 * y / 12.0);
    let (px, pz) = (2.0 * nx * t * (16.0 / 12.0), -2.0 * ny * t);
    let (dx, dy, dz) = (0.3 - px, 1.0 - lift(px, pz), 0.2 - pz);
    let d2 = dx * dx + dy * dy + dz * dz;
    0.5 / std::f64::consts::PI * (0.8 + dy / d2.sqrt() / d2)
}

/// The height of a shadow ray's origin above the plane point (px, 0, pz):
/// `offset_origin` in wgsl/shared/shading.wgsl moves it RAY_EPSILON = 1e-4
/// times max(1, |x|, |y|, |z|) along the normal.
fn ray_offset(px: f64, pz: f64) -> f64 {
    1e-4 * px.abs().max(pz.abs()).max(1.0)
}

/// Depth of field (pinhole here), motion blur and the path tracer (one
/// bounce: bounce rays leave the open plane and see a black background)
/// all reduce to the same direct lighting, a smooth function of the film
/// point alone. So each pixel's Halton estimate is a deterministic
/// quadrature: the mean of the closed form at the pixel's 64 Halton film
/// points (the sequence's definition, `common::halton_point`), computed
/// here in f64. No statistics enter. The renderer's one modelled
/// departure from the physics is the shadow rays' origin offset (the
/// point light seen from [`ray_offset`] above the plane): it moves the
/// quadrature by at most ≈ 1e-4 relative here, checked below 5e-4. With
/// it, the render must equal the quadrature up to f32 rounding: about 20
/// operations from the film point to the shaded value, each within 2⁻²⁴
/// relative (≈ 1.2·10⁻⁶ together), the points' own error (≤ 2⁻²² of a
/// pixel, times a relative gradient below 1 per pixel) and the
/// compensated sum; 1e-5 relative allows 8 times that.
///
/// The test has power: a cosine dropped or taken from the wrong normal,
/// or a wrong falloff, moves pixels by per cent, and the quadrature's own
/// error against the pixel means (asserted to be over 10 times the bound)
/// is visible too, so an integrator that placed its points by another
/// rule would fail.
#[test]
fn point_and_directional_lights_shade_a_plane_exactly() {
    const SPP: u32 = 64;
    const SEED: u32 = 5;
    const ROUNDING: f64 = 1e-5;
    let (w, h) = (16u32, 12u32);
    // Per pixel: the quadrature of the closed form with the offset origin
    // (what the renderer computes) and without (the physics), and the
    // pixel mean on a 32×32 midpoint grid.
    let (mut model, mut physics, mut pixel_mean) = (Vec::new(), Vec::new(), Vec::new());
    for j in 0..h {
        for i in 0..w {
            let pixel = j * w + i;
            let (mut q_model, mut q) = (0.0, 0.0);
            for k in 0..SPP {
                let x = i as f64 + common::halton_point(0, k, pixel, SEED);
                let y = j as f64 + common::halton_point(1, k, pixel, SEED);
                q_model += lit_plane_radiance(x, y, ray_offset) / SPP as f64;
                q += lit_plane_radiance(x, y, |_, _| 0.0) / SPP as f64;
            }
            model.push(q_model);
            physics.push(q);
            let n = 32;
            let mean = (0..n * n)
                .map(|k| {
                    let x = i as f64 + ((k % n) as f64 + 0.5) / n as f64;
                    let y = j as f64 + ((k / n) as f64 + 0.5) / n as f64;
                    lit_plane_radiance(x, y, |_, _| 0.0)
                })
                .sum::<f64>()
                / (n * n) as f64;
            pixel_mean.push(mean);
        }
    }
    let worst_rel = |a: &[f64], b: &[f64]| {
        a.iter()
            .zip(b)
            .map(|(x, y)| ((x - y) / y).abs())
            .fold(0.0, f64::max)
    };
    let offset = worst_rel(&model, &physics);
    let quadrature_error = worst_rel(&physics, &pixel_mean);
    assert!(
        offset < 5e-4,
        "the ray offset moves the quadrature by {offset}"
    );
    assert!(
        quadrature_error > 10.0 * ROUNDING,
        "the quadrature's error {quadrature_error} is too small to tell the points apart"
    );
    for integrand in [
        "type = \"depth_of_field\"",
        "type = \"motion_blur\"",
        "type = \"path\"\nmax_bounces = 1",
    ] {
        let r = render(&lit_plane(integrand), SPP, SEED);
        let rendered: Vec<f64> = r.image.iter().map(|v| v[0] as f64).collect();
        let worst = worst_rel(&rendered, &model);
        println!(
            "{integrand}: worst |render − quadrature| {worst:.1e} relative (bound \
             {ROUNDING:.0e}; the offset {offset:.1e}; the quadrature against the \
             pixel means {quadrature_error:.1e})"
        );
        assert!(worst <= ROUNDING, "{integrand}: relative error {worst}");
    }
}

// ------------------------------------- asymmetric known answer (issue 20)

/// A tilted emissive quad lighting a tilted receiver, seen by a camera
/// that sees neither the emitter nor the receiver's edges. No two of the
/// three normals (receiver, emitter, view) are parallel, so an estimator
/// that takes the emitter's cosine from the receiver's normal, takes |cos|
/// or forgets a cosine is off by tens of per cent. `flip` reverses the
/// emitter's winding: it then faces away and the image must be exactly 0.
const TILTED_RECEIVER_NORMAL: [f64; 3] = [0.25, 1.0, 0.15];

/// The emitter's corners, counter-clockwise seen from below-behind (its
/// normal (v1 − v0) × (v2 − v0) points down and toward −z, at the
/// receiver in front of the camera).
fn tilted_emitter(flip: bool) -> [[f64; 3]; 4] {
    let c = [0.5, 2.5, 4.5];
    let (a, b) = ([0.6, 0.1, -0.2], [0.1, -0.45, -0.3]);
    let at = |s: f64, t: f64| [0, 1, 2].map(|k| c[k] + s * a[k] + t * b[k]);
    let corners = [at(-1.0, -1.0), at(1.0, -1.0), at(1.0, 1.0), at(-1.0, 1.0)];
    if flip {
        [corners[0], corners[3], corners[2], corners[1]]
    } else {
        corners
    }
}

fn tilted_scene(integrand: &str, flip: bool) -> SceneFile {
    let v = |p: [f64; 3]| format!("[{}, {}, {}]", p[0], p[1], p[2]);
    let n = glam::DVec3::from(TILTED_RECEIVER_NORMAL).normalize();
    // A 200 × 200 square on the plane n·x = 0, centred at the origin.
    let (u, w) = (
        n.any_orthonormal_pair().0 * 30.0,
        n.any_orthonormal_pair().1 * 30.0,
    );
    let r = |s: f64, t: f64| (s * u + t * w).to_array();
    let receiver = [r(-1.0, -1.0), r(1.0, -1.0), r(1.0, 1.0), r(-1.0, 1.0)];
    let e = tilted_emitter(flip);
    parse(&format!(
        r#"
background = [0, 0, 0]
[film]
width = 16
height = 12
[camera]
position = [0, 1.5, 3]
look_at = [0, 0, -1]
up = [0, 1, 0]
fov_y = 40
[[material]]
name = "grey"
albedo = [0.5, 0.5, 0.5]
[[shape]]
type = "quad"
material = "grey"
corners = [{}, {}, {}, {}]
[[light]]
type = "quad"
corners = [{}, {}, {}, {}]
radiance = [4, 4, 4]
[integrand]
{integrand}
"#,
        v(receiver[0]),
        v(receiver[1]),
        v(receiver[2]),
        v(receiver[3]),
        v(e[0]),
        v(e[1]),
        v(e[2]),
        v(e[3])
    ))
}

/// The exact pixel means of [`tilted_scene`]: ρ/π·E(p) with E by Lambert's
/// polygon formula (`analytic::lambert_polygon_irradiance`, which shares no
/// code with the renderer), averaged over each pixel's footprint on an
/// m×m midpoint grid. Rays follow the pinhole camera of docs/conventions.md.
fn tilted_exact(m: usize) -> Vec<f64> {
    use glam::DVec3;
    let (pos, look) = (DVec3::new(0.0, 1.5, 3.0), DVec3::new(0.0, 0.0, -1.0));
    let f = (look - pos).normalize();
    let r = f.cross(DVec3::Y).normalize();
    let up = r.cross(f);
    let t = 20f64.to_radians().tan();
    let (w, h) = (16.0, 12.0);
    let n = DVec3::from(TILTED_RECEIVER_NORMAL).normalize();
    let emitter: Vec<DVec3> = tilted_emitter(false)
        .iter()
        .map(|&p| DVec3::from(p))
        .collect();
    let radiance = |x: f64, y: f64| {
        let d =
            (f + (2.0 * x / w - 1.0) * t * (w / h) * r + (1.0 - 2.0 * y / h) * t * up).normalize();
        let s = -pos.dot(n) / d.dot(n);
        assert!(s > 0.0, "every view ray meets the receiver");
        let p = pos + s * d;
        assert!(p.length() < 90.0, "and inside its square: {p}");
        0.5 / std::f64::consts::PI * mdas::analytic::lambert_polygon_irradiance(p, n, &emitter, 4.0)
    };
    let pixel = |i: usize, j: usize, m: usize| {
        (0..m * m)
            .map(|k| {
                let x = i as f64 + ((k % m) as f64 + 0.5) / m as f64;
                let y = j as f64 + ((k / m) as f64 + 0.5) / m as f64;
                radiance(x, y)
            })
            .sum::<f64>()
            / (m * m) as f64
    };
    (0..12)
        .flat_map(|j| (0..16).map(move |i| (i, j)))
        .map(|(i, j)| pixel(i, j, m))
        .collect()
}

/// Issue 20 item 3: the asymmetric known answer through every estimator of
/// emissive surfaces: the area-light integrand, the path tracer's NEE (one
/// bounce, which adds nothing: from the plane a bounce ray reaches the
/// black background or the emitter, which reflects nothing and whose own
/// emission the NEE before it counted) and the many-light integrand with every
/// sampler. The back-facing emitter gives exactly 0 through each integrand
/// (many_light with uniform, power, tree_nocut, tree and tree_cone).
///
/// Statistics: per configuration, the means of four quadrants of the image
/// over K = 8 seeds (independent random shifts, so the seed means are
/// i.i.d.); each must lie within t·se of the exact quadrant mean, t the
/// two-sided Student quantile for 7 degrees of freedom at α = 1e-3 split
/// over the 4 × 10 = 40 tests (Bonferroni: α/40 = 2.5e-5, t = 8.1), plus
/// 1e-4 relative for the exact value's quadrature (checked in the test)
/// and f32 accumulation. A cosine taken from the wrong normal moves every
/// quadrant by more than 10 %.
#[test]
fn tilted_emitter_over_tilted_receiver_matches_lambert() {
    // The midpoint rule's error falls as 1/m² where E is smooth (slower
    // across horizon-clipping kinks in the far top row): the quadrant means
    // at m = 16 and 32 must agree within 3e-5, which bounds the error of the
    // m = 32 values well inside the 1e-4 budget below.
    let (exact, coarse) = (tilted_exact(32), tilted_exact(16));
    let quadrant = |img: &dyn Fn(usize) -> f64, q: usize| {
        let (qi, qj) = (q % 2, q / 2);
        let mut sum = 0.0;
        for j in qj * 6..qj * 6 + 6 {
            for i in qi * 8..qi * 8 + 8 {
                sum += img(j * 16 + i);
            }
        }
        sum / 48.0
    };
    let exact_q: Vec<f64> = (0..4).map(|q| quadrant(&|k| exact[k], q)).collect();
    for (q, &e) in exact_q.iter().enumerate() {
        let c = quadrant(&|k| coarse[k], q);
        assert!((c - e).abs() <= 3e-5 * e, "quadrant {q}: {c} {e}");
    }
    // The exact image is asymmetric: its quadrants differ.
    assert!(exact_q.iter().all(|&e| e > 1e-3), "{exact_q:?}");
    let spread = exact_q.iter().copied().fold(0.0, f64::max)
        / exact_q.iter().copied().fold(f64::INFINITY, f64::min);
    assert!(spread > 1.5, "{exact_q:?}");

    let mut configs = vec![
        "type = \"area_light\"".to_string(),
        "type = \"path\"\nmax_bounces = 1".to_string(),
    ];
    // Every sampler (lgh: the triangle is no grid light, so it samples the
    // emitter directly and is unbiased here).
    for kind in mdas::lights::registry::SamplerKind::ALL {
        configs.push(format!(
            "type = \"many_light\"\nsampler = \"{}\"",
            kind.name()
        ));
    }
    assert_eq!(
        configs.len(),
        2 + mdas::lights::registry::SamplerKind::ALL.len()
    );
    const K: u32 = 8;
    const T: f64 = 8.1;
    for integrand in &configs {
        // One integrand (and its pipelines) for all seeds.
        let gpu = gpu();
        let scene = tilted_scene(integrand, false);
        let f = session::integrand_for(gpu, &scene, scene.scene.film).unwrap();
        let seeds: Vec<Vec<f64>> = (0..K)
            .map(|s| {
                let r = Halton::new(64, 100 + s).render(gpu, f.as_ref()).unwrap();
                assert_eq!(r.nonfinite, 0);
                (0..4)
                    .map(|q| quadrant(&|k| r.image[k][0] as f64, q))
                    .collect()
            })
            .collect();
        for q in 0..4 {
            let xs: Vec<f64> = seeds.iter().map(|s| s[q]).collect();
            let mean = xs.iter().sum::<f64>() / K as f64;
            let var = xs.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (K - 1) as f64;
            let se = (var / K as f64).sqrt();
            let e = exact_q[q];
            println!("{integrand:?} quadrant {q}: {mean:.6} exact {e:.6} se {se:.2e}");
            assert!(
                (mean - e).abs() <= T * se + 1e-4 * e,
                "{integrand:?} quadrant {q}: mean {mean} exact {e} se {se}"
            );
        }
    }
    // The back-facing emitter through each estimator of emission: the
    // many-light integrand evaluates a triangle's emission side in one
    // place whatever sampler picked it, so the baselines, a tree and a
    // tree with cones stand for all eight.
    let cones = "type = \"many_light\"\nsampler = \"tree_cone\"".to_string();
    for integrand in configs[..5].iter().chain([&cones]) {
        let dark = render(&tilted_scene(integrand, true), 16, 1);
        assert!(
            dark.image.iter().all(|p| *p == [0.0; 3]),
            "{integrand:?}: a back-facing emitter lit the receiver"
        );
    }
}

/// An OBJ scene with its own MTL materials (`scenes/tests/obj_materials.toml`)
/// renders lit by its emissive group alone: finite, with red pixels (the
/// block's `Kd 0.8 0.1 0.1` face toward the camera, lit by the lamp in
/// front of it) and grey ones (the `Kd 0.7` floor, and the lamp's `Ke`
/// where the camera sees its underside).
#[test]
fn obj_scene_is_lit_by_its_mtl_emissive_group() {
    let s = scene_file::load(Path::new("scenes/tests/obj_materials.toml")).unwrap();
    let gpu = gpu();
    let f = session::integrand_for(gpu, &s, s.scene.film).unwrap();
    let r = Halton::new(16, 1).render(gpu, f.as_ref()).unwrap();
    assert_eq!(r.nonfinite, 0);
    let red = r
        .image
        .iter()
        .filter(|p| p[0] > 0.01 && p[0] > 4.0 * p[1])
        .count();
    let grey = r
        .image
        .iter()
        .filter(|p| p[1] > 0.01 && (p[0] - p[1]).abs() < 0.2 * p[1])
        .count();
    assert!(red > 0 && grey > 0, "red {red}, grey {grey} pixels");
}

// --------------------------------------------- shading normals (issue 19)

/// A 4 × 4 square OBJ in the plane y = 0 (faces (c0, c1, c2), (c0, c2, c3),
/// geometric normal +y) with the vertex normals `normals` at its corners,
/// written to a fresh directory; returns the OBJ's path.
fn smooth_square(name: &str, normals: [[f64; 3]; 4]) -> std::path::PathBuf {
    square_obj(name, normals, "f 1//1 2//2 3//3\nf 1//1 3//3 4//4\n")
}

/// The square of [`smooth_square`] with the face lines `faces`.
fn square_obj(name: &str, normals: [[f64; 3]; 4], faces: &str) -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("mdas-smooth-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let mut obj = String::new();
    for c in SQUARE {
        obj += &format!("v {} {} {}\n", c[0], c[1], c[2]);
    }
    for n in normals {
        obj += &format!("vn {} {} {}\n", n[0], n[1], n[2]);
    }
    obj += faces;
    let path = dir.join("square.obj");
    std::fs::write(&path, obj).unwrap();
    path
}

/// Issue 67 item 2: a mesh wound against its vertex normals (common in
/// real assets) has its front where the normals point, as Mitsuba shades
/// it. The square with every normal +y but its faces wound to −y renders
/// bit for bit as the square wound to +y under every integrand (direct
/// light from a quad light facing it out of view, a point and a
/// directional light; depth of
/// field, motion blur, path, ambient occlusion, many-light), and is lit:
/// when the winding decided, its lit side was its back and rendered black.
#[test]
fn a_mesh_wound_against_its_normals_renders_as_the_rewound_mesh() {
    let up = [[0.0, 1.0, 0.0]; 4];
    let along = smooth_square("wound-along", up);
    let against = square_obj("wound-against", up, "f 1//1 3//3 2//2\nf 1//1 4//4 3//3\n");
    let lights = "[[light]]\ntype = \"point\"\nposition = [0.3, 1, 0.2]\nintensity = [1, 1, 1]\n\
                  [[light]]\ntype = \"directional\"\ndirection = [0.3, -1, 0.2]\nirradiance = [0.5, 0.5, 0.5]\n\
                  [[light]]\ntype = \"quad\"\ncorners = [[1, 1.2, -0.25], [1.5, 1.2, -0.25], [1.5, 1.2, 0.25], [1, 1.2, 0.25]]\n\
                  radiance = [2, 2, 2]\n";
    for integrand in [
        "type = \"area_light\"",
        "type = \"depth_of_field\"",
        "type = \"motion_blur\"",
        "type = \"path\"\nmax_bounces = 1",
        "type = \"ambient_occlusion\"\nradius = 1",
        "type = \"many_light\"\nsampler = \"uniform\"",
    ] {
        let [a, b] = [&along, &against].map(|obj| {
            let scene = smooth_scene(obj, 0.0, lights, 0.0, integrand);
            render(&scene, 4, 3)
        });
        let bits = |r: &Render| {
            r.image
                .iter()
                .flat_map(|p| p.map(f32::to_bits))
                .collect::<Vec<_>>()
        };
        assert_eq!(bits(&a), bits(&b), "{integrand}");
        let mean = b.image.iter().map(|p| p[0] as f64).sum::<f64>() / b.image.len() as f64;
        assert!(mean > 0.01, "{integrand}: the square is dark ({mean})");
    }
}

const SQUARE: [[f64; 3]; 4] = [
    [-2.0, 0.0, -2.0],
    [-2.0, 0.0, 2.0],
    [2.0, 0.0, 2.0],
    [2.0, 0.0, -2.0],
];

/// The square seen straight down from height 2 (as `lit_plane`), grey
/// (ρ = 0.5), turned about +y by `turn` degrees with a `motion` that holds
/// the turn over the shutter (so the normals must be rotated on the GPU).
fn smooth_scene(
    obj: &Path,
    turn: f64,
    lights: &str,
    background: f64,
    integrand: &str,
) -> SceneFile {
    parse(&format!(
        r#"
background = [{background}, {background}, {background}]
[film]
width = 16
height = 12
[camera]
position = [0, 2, 0]
look_at = [0, 0, 0]
up = [0, 0, -1]
fov_y = 60
[[material]]
name = "grey"
albedo = [0.5, 0.5, 0.5]
[[shape]]
type = "mesh"
material = "grey"
file = "{}"
motion = [{{ time = 0, rotate = [0, 1, 0, {turn}] }}, {{ time = 1, rotate = [0, 1, 0, {turn}] }}]
{lights}
[integrand]
{integrand}
"#,
        obj.display()
    ))
}

type V3 = [f64; 3];
fn dot(a: V3, b: V3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
fn unit(a: V3) -> V3 {
    let l = dot(a, a).sqrt();
    a.map(|x| x / l)
}
/// Rotation about +y by `deg` degrees, counter-clockwise seen from +y.
fn turn_y(a: V3, deg: f64) -> V3 {
    let (s, c) = deg.to_radians().sin_cos();
    [c * a[0] + s * a[2], a[1], -s * a[0] + c * a[2]]
}

/// The shading normal at world point p of the turned square: p taken to
/// the object space, its barycentrics in the triangle holding it, the unit
/// corner normals interpolated, normalized and turned back.
fn smooth_normal(p: V3, normals: [V3; 4], turn: f64) -> V3 {
    let q = turn_y(p, -turn);
    let n = normals.map(unit);
    for [a, b, c] in [[0, 1, 2], [0, 2, 3]] {
        // Barycentrics in the xz plane.
        let (pa, pb, pc) = (SQUARE[a], SQUARE[b], SQUARE[c]);
        let det = (pb[0] - pa[0]) * (pc[2] - pa[2]) - (pc[0] - pa[0]) * (pb[2] - pa[2]);
        let u = ((q[0] - pa[0]) * (pc[2] - pa[2]) - (pc[0] - pa[0]) * (q[2] - pa[2])) / det;
        let v = ((pb[0] - pa[0]) * (q[2] - pa[2]) - (q[0] - pa[0]) * (pb[2] - pa[2])) / det;
        if u >= 0.0 && v >= 0.0 && u + v <= 1.0 {
            let m = [0, 1, 2].map(|k| n[a][k] * (1.0 - u - v) + n[b][k] * u + n[c][k] * v);
            return turn_y(unit(m), turn);
        }
    }
    panic!("{p:?} is not on the square");
}

/// The Lambertian cosine with a shading normal: max(ns·wi, 0), and 0 for
/// light from behind the geometric surface (normal +y).
fn cos_reflect(ns: V3, wi: V3) -> f64 {
    if wi[1] <= 0.0 {
        0.0
    } else {
        dot(ns, wi).max(0.0)
    }
}

/// The corner normals of the interpolation test: four different tilts, all
/// within 45° of +y.
const CORNER_NORMALS: [V3; 4] = [
    [0.6, 0.8, 0.0],
    [0.0, 0.8, 0.6],
    [-0.3, 0.9, 0.3],
    [0.2, 0.7, -0.5],
];

/// Issue 19 item 4: vertex normals shade. A grey square whose four corners
/// carry different normals is lit by a point light and three directional
/// lights chosen so that the shading cosine differs from the geometric one
/// (light 1), is 0 although the geometric cosine is not (light 2: behind
/// the shading normal) and is positive although the light is behind the
/// geometric surface (light 3: must give 0; `cos_reflect` refuses it, and
/// its shadow ray would meet the square itself). The exact pixel means are
/// ρ/π · Σ_l E_l·cos_reflect(n_s(p), ω_l), n_s interpolated on the CPU
/// (`smooth_normal`), averaged on a 32 × 32 grid per pixel. Renders: depth
/// of field (pinhole), motion blur and the path tracer (its bounce escapes
/// to a black background), the square static and turned 90° by a held
/// `motion` (the GPU must rotate the normals); `many_light` (one point
/// light, so every sample takes it with pmf 1) sees the point light alone.
/// Tolerance: Halton with a per-pixel random shift is an unbiased mean of
/// N = 64 samples of a function whose within-pixel standard deviation σ
/// the grid gives; 5σ/√N (randomized Halton does better) plus 2e-3
/// relative for the shadow-ray origin's 1e-4 offset and f32 arithmetic.
#[test]
fn vertex_normals_shade_with_the_interpolated_normal() {
    let obj = smooth_square("interp", CORNER_NORMALS);
    let point = ([0.3, 1.0, 0.2], 1.0);
    // Directions the light travels (wi = −direction), irradiance 1.
    let directional: [V3; 3] = [[0.6, -0.8, 0.0], [0.3, -0.2, 0.9], [-0.5, 0.05, 0.2]];
    let light_text = |with_directional: bool| {
        let mut t = format!(
            "[[light]]\ntype = \"point\"\nposition = {:?}\nintensity = [{1}, {1}, {1}]\n",
            point.0, point.1
        );
        if with_directional {
            for d in directional {
                t += &format!("[[light]]\ntype = \"directional\"\ndirection = {d:?}\nirradiance = [1, 1, 1]\n");
            }
        }
        t
    };
    let radiance = |x: f64, y: f64, turn: f64, with_directional: bool| {
        let t = (30f64).to_radians().tan();
        let (nx, ny) = (2.0 * x / 16.0 - 1.0, 1.0 - 2.0 * y / 12.0);
        let p = [2.0 * nx * t * (16.0 / 12.0), 0.0, -2.0 * ny * t];
        let ns = smooth_normal(p, CORNER_NORMALS, turn);
        let d = [point.0[0] - p[0], point.0[1], point.0[2] - p[2]];
        let d2 = dot(d, d);
        let mut e = point.1 * cos_reflect(ns, unit(d)) / d2;
        if with_directional {
            e += directional
                .iter()
                .map(|l| cos_reflect(ns, unit(l.map(|x| -x))))
                .sum::<f64>();
        }
        0.5 / std::f64::consts::PI * e
    };
    // The lights do what their comments say at the image centre.
    let centre = smooth_normal([0.0; 3], CORNER_NORMALS, 0.0);
    let wi = directional.map(|l| unit(l.map(|x| -x)));
    assert!((dot(centre, wi[0]) - wi[0][1]).abs() > 0.05);
    assert!(dot(centre, wi[1]) < 0.0 && wi[1][1] > 0.0);
    assert!(dot(centre, wi[2]) > 0.0 && wi[2][1] < 0.0);

    let spp = 64;
    for turn in [0.0, 90.0] {
        for (integrand, with_directional) in [
            ("type = \"depth_of_field\"", true),
            ("type = \"motion_blur\"", true),
            ("type = \"path\"\nmax_bounces = 1", true),
            ("type = \"many_light\"\nsampler = \"uniform\"", false),
        ] {
            let scene = smooth_scene(&obj, turn, &light_text(with_directional), 0.0, integrand);
            let r = render(&scene, spp, 5);
            let (mut worst, mut lit) = (0.0f64, 0);
            for j in 0..12 {
                for i in 0..16 {
                    let n = 32;
                    let values: Vec<f64> = (0..n * n)
                        .map(|k| {
                            let x = i as f64 + ((k % n) as f64 + 0.5) / n as f64;
                            let y = j as f64 + ((k / n) as f64 + 0.5) / n as f64;
                            radiance(x, y, turn, with_directional)
                        })
                        .collect();
                    let mean = values.iter().sum::<f64>() / values.len() as f64;
                    let var = values.iter().map(|v| (v - mean).powi(2)).sum::<f64>()
                        / values.len() as f64;
                    let tol = 5.0 * (var / spp as f64).sqrt() + 2e-3 * mean + 1e-6;
                    let got = r.image[j * 16 + i][0] as f64;
                    worst = worst.max((got - mean).abs() / tol);
                    lit += usize::from(mean > 1e-3);
                }
            }
            println!("turn {turn}, {integrand}: worst error {worst:.2} tolerances");
            assert!(
                worst <= 1.0,
                "turn {turn}, {integrand}: error {worst} tolerances"
            );
            assert!(lit > 100, "{lit} lit pixels");
        }
    }
}

/// Issue 19 item 4: the hemisphere follows the shading normal, and the
/// geometric surface still blocks. A square whose every normal is tilted
/// by θ (cos θ = 0.6) from its geometric normal, nothing above it: of the
/// cosine lobe about n_s, the fraction (1 − cos θ)/2 lies behind the
/// surface (the lune between the two hemispheres holds projected solid
/// angle π·sin²(θ/2)), so ambient occlusion is (1 + cos θ)/2 = 0.8 and a
/// one-bounce path to a white background (L = 1, ρ = 0.5) is ρ·0.8 = 0.4
/// everywhere, not 1 and 0.5 as with flat shading. Each sample is one of
/// two values (a, b); the image mean of N = 16·12·64 samples is within 5
/// standard deviations |b − a|·√(c(1 − c)/N) of the exact mean (c the
/// fraction 0.8; randomized Halton does better than independent samples).
#[test]
fn tilted_vertex_normals_lose_the_lobe_behind_the_surface() {
    let tilt = [0.8, 0.6, 0.0];
    let obj = smooth_square("tilted", [tilt; 4]);
    let c: f64 = (1.0 + 0.6) / 2.0;
    let spp = 64;
    let n = (16 * 12 * spp) as f64;
    for turn in [0.0, 90.0] {
        for (integrand, value) in [
            ("type = \"ambient_occlusion\"\nradius = 1", 1.0),
            ("type = \"path\"\nmax_bounces = 1", 0.5),
        ] {
            let r = render(&smooth_scene(&obj, turn, "", 1.0, integrand), spp as u32, 3);
            let mean = r.image.iter().map(|p| p[0] as f64).sum::<f64>() / r.image.len() as f64;
            let tol = 5.0 * value * (c * (1.0 - c) / n).sqrt();
            println!(
                "turn {turn}, {integrand}: mean {mean:.4}, exact {:.4} ± {tol:.4}",
                value * c
            );
            assert!(
                (mean - value * c).abs() < tol,
                "turn {turn}, {integrand}: mean {mean}"
            );
        }
    }
}

// ------------------------------------------------------------ sidedness

/// Issue 51: a Mitsuba `diffuse` BSDF is one-sided — black from behind —
/// and `twosided` reflects on both sides. Two rectangles side by side at
/// z = 0, seen head-on by a pinhole camera at z = 5 and lit head-on by a
/// directional light of irradiance E travelling along −z, so every pixel
/// inside a rectangle is exactly ρ/π·E (cos = 1, no shadow) or 0. With
/// `facing_camera` the rectangles' front is seen and lit, else (flipped
/// normals) their back.
fn sidedness(facing_camera: bool) -> SceneFile {
    let text = format!(
        r#"<scene version="3.0.0">
  <integrator type="direct"/>
  <sensor type="perspective">
    <float name="fov" value="60"/>
    <transform name="to_world"><lookat origin="0, 0, 5" target="0, 0, 0" up="0, 1, 0"/></transform>
    <film type="hdrfilm"><integer name="width" value="32"/><integer name="height" value="16"/><rfilter type="box"/></film>
  </sensor>
  <emitter type="directional"><vector name="direction" x="0" y="0" z="-1"/><rgb name="irradiance" value="2"/></emitter>
  <shape type="rectangle">
    <boolean name="flip_normals" value="{flip}"/>
    <transform name="to_world"><scale value="1.4"/><translate x="-1.5"/></transform>
    <bsdf type="diffuse"><rgb name="reflectance" value="0.6, 0.3, 0.9"/></bsdf>
  </shape>
  <shape type="rectangle">
    <boolean name="flip_normals" value="{flip}"/>
    <transform name="to_world"><scale value="1.4"/><translate x="1.5"/></transform>
    <bsdf type="twosided"><bsdf type="diffuse"><rgb name="reflectance" value="0.6, 0.3, 0.9"/></bsdf></bsdf>
  </shape>
</scene>
"#,
        flip = !facing_camera
    );
    scene_file::parse_mitsuba(&text, Path::new("sidedness.xml")).unwrap()
}

#[test]
fn a_one_sided_diffuse_surface_is_black_from_behind() {
    let lit = |rho: f32| rho * 2.0 / std::f32::consts::PI;
    let want = [lit(0.6), lit(0.3), lit(0.9)];
    for facing_camera in [true, false] {
        let scene = sidedness(facing_camera);
        assert_eq!(scene.integrand, IntegrandSpec::DepthOfField);
        let r = render(&scene, 4, 0);
        // Pixel rows 6..10 and columns 5..10 (left) and 22..27 (right) lie
        // inside the rectangles (x from ±0.1 to ±2.9 at a half-width of
        // 5·tan 30°·2 = 5.77 world units over 32 pixels).
        for j in 6..10 {
            for (i, one_sided) in (5..10)
                .map(|i| (i, true))
                .chain((22..27).map(|i| (i, false)))
            {
                let got = r.image[(j * 32 + i) as usize];
                let expect = if one_sided && !facing_camera {
                    [0.0; 3]
                } else {
                    want
                };
                for c in 0..3 {
                    assert!(
                        (got[c] - expect[c]).abs() <= 1e-5,
                        "pixel ({i}, {j}), facing camera {facing_camera}, one-sided {one_sided}: {got:?} vs {expect:?}"
                    );
                }
            }
        }
    }
}

/// Issue 51: Mitsuba's `checkerboard` texture in texture space. A 4 × 4
/// rectangle at z = 0 seen head-on and lit head-on by a directional light
/// of irradiance E (as `sidedness`), its reflectance a checkerboard with
/// `to_uv` = scale (3, 2), then translate (0.1, 0.35): at world (x, y) the
/// texture coordinates are ((x/2 + 1)/2, (y/2 + 1)/2), (u', v') = (3u +
/// 0.1, 2v + 0.35), and the pixel is exactly ρ/π·E with ρ = color0 where
/// frac(u') > ½ equals frac(v') > ½, else color1. Checked at every pixel
/// whose footprint lies inside one cell (its four corners agree).
#[test]
fn a_uv_checkerboard_follows_mitsubas_texture_coordinates() {
    let text = r#"<scene version="3.0.0">
  <integrator type="direct"/>
  <sensor type="perspective">
    <float name="fov" value="40"/>
    <transform name="to_world"><lookat origin="0, 0, 5" target="0, 0, 0" up="0, 1, 0"/></transform>
    <film type="hdrfilm"><integer name="width" value="48"/><integer name="height" value="48"/><rfilter type="box"/></film>
  </sensor>
  <emitter type="directional"><vector name="direction" x="0" y="0" z="-1"/><rgb name="irradiance" value="3.14159265"/></emitter>
  <shape type="rectangle">
    <transform name="to_world"><scale value="2"/></transform>
    <bsdf type="diffuse"><texture type="checkerboard" name="reflectance">
      <rgb name="color0" value="0.8, 0.6, 0.4"/><rgb name="color1" value="0.1, 0.2, 0.3"/>
      <transform name="to_uv"><scale x="3" y="2"/><translate x="0.1" y="0.35"/></transform>
    </texture></bsdf>
  </shape>
</scene>
"#;
    let scene = scene_file::parse_mitsuba(text, Path::new("checker.xml")).unwrap();
    let r = render(&scene, 4, 0);
    let half = 5.0 * (20f64).to_radians().tan(); // world half-width at z = 0
    let color0 = |x: f64, y: f64| {
        let (u, v) = ((x / 2.0 + 1.0) / 2.0, (y / 2.0 + 1.0) / 2.0);
        let (u, v) = (3.0 * u + 0.1, 2.0 * v + 0.35);
        (u - u.floor() > 0.5) == (v - v.floor() > 0.5)
    };
    let world = |i: f64, j: f64| (half * (2.0 * i / 48.0 - 1.0), half * (1.0 - 2.0 * j / 48.0));
    let (mut checked, mut seen) = (0, [false; 2]);
    for j in 0..48 {
        for i in 0..48 {
            let corners = [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (1.0, 1.0)]
                .map(|(di, dj)| world(i as f64 + di, j as f64 + dj));
            if corners
                .iter()
                .any(|(x, y)| x.abs() >= 2.0 || y.abs() >= 2.0)
            {
                continue;
            }
            let cells = corners.map(|(x, y)| color0(x, y));
            if cells.iter().any(|c| *c != cells[0]) {
                continue;
            }
            let rho = if cells[0] {
                [0.8, 0.6, 0.4]
            } else {
                [0.1, 0.2, 0.3]
            };
            let got = r.image[j * 48 + i];
            for c in 0..3 {
                assert!(
                    (got[c] as f64 - rho[c]).abs() <= 1e-5,
                    "pixel ({i}, {j}): {got:?}, expected ρ = {rho:?}"
                );
            }
            checked += 1;
            seen[cells[0] as usize] = true;
        }
    }
    assert!(
        checked > 500 && seen == [true, true],
        "{checked} pixels checked"
    );
}
