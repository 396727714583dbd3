use super::*;
use crate::film::Film;
use glam::Vec3;

const MINIMAL: &str = "[film]\nwidth = 4\nheight = 3\n[camera]\nposition = [0, 0, 5]\nlook_at = [0, 0, 0]\nup = [0, 1, 0]\nfov_y = 40\n";

fn err(text: &str) -> String {
    parse(text, Path::new("t.toml")).unwrap_err().to_string()
}

#[test]
fn minimal_scene_gets_defaults() {
    let s = parse(MINIMAL, Path::new("t.toml")).unwrap();
    assert_eq!(
        s.scene.film,
        Film {
            width: 4,
            height: 3
        }
    );
    assert_eq!(s.scene.camera.focus_distance, 5.0);
    assert_eq!(
        (s.scene.camera.shutter_open, s.scene.camera.shutter_close),
        (0.0, 1.0)
    );
    assert_eq!(s.mdas, MdasParams::for_film(s.scene.film));
    assert_eq!(s.integrand, IntegrandSpec::AreaLight);
    assert_eq!(s.scene.background, Vec3::ZERO);
}

#[test]
fn line_and_column_count_characters() {
    let text = format!("{MINIMAL}background = [\"é\", 0, 0]\n");
    let e = err(&text);
    assert!(e.starts_with("t.toml:9:"), "{e}");
    let e = err(&MINIMAL.replace("fov_y = 40", "fov_y = 180"));
    assert!(
        e.starts_with("t.toml:8:9: fov_y must be in (0, 180)"),
        "{e}"
    );
}

#[test]
fn scale_accepts_number_or_vector() {
    let base = format!("{MINIMAL}[[material]]\nname = \"m\"\nalbedo = [0.5, 0.5, 0.5]\n[[shape]]\ntype = \"box\"\nmaterial = \"m\"\nmin = [0, 0, 0]\nmax = [1, 1, 1]\n");
    let s = parse(
        &format!("{base}transform = {{ scale = 2 }}\n"),
        Path::new("t.toml"),
    )
    .unwrap();
    assert!(
        (s.scene.meshes[0]
            .positions
            .iter()
            .map(|p| p.x)
            .fold(0.0, f32::max)
            - 2.0)
            .abs()
            < 1e-6
    );
    let s = parse(
        &format!(
            "{base}transform = {{ scale = [1, 3, 1], rotate_y = 90, translate = [0, 1, 0] }}\n"
        ),
        Path::new("t.toml"),
    )
    .unwrap();
    let max_y = s.scene.meshes[0]
        .positions
        .iter()
        .map(|p| p.y)
        .fold(0.0, f32::max);
    assert!((max_y - 4.0).abs() < 1e-6);
    let e = err(&format!("{base}transform = {{ scale = [1, 2] }}\n"));
    assert!(
        e.contains("expected an array of 3 numbers, found 2 elements"),
        "{e}"
    );
    let e = err(&format!("{base}transform = {{ scale = 0 }}\n"));
    assert!(e.contains("scale must be nonzero"), "{e}");
    let e = err(&format!("{base}transform = {{ scale = 1e-30 }}\n"));
    assert!(
        e.contains("entirely degenerate") && e.contains("after transform"),
        "{e}"
    );
}

/// The `[mdas]` table is checked by the integrator's validator, once: a
/// value the integrator would refuse is refused on load, at its key, and
/// a conflict with a default is reported at the table.
#[test]
fn mdas_table_uses_the_integrators_limits() {
    let e = err(&format!(
        "{MINIMAL}[mdas]\nspp = 4\nmax_samples_per_leaf = 1\n"
    ));
    assert!(
        e.starts_with("t.toml:11:24: max_samples_per_leaf = 1: must be in 2..=14"),
        "{e}"
    );
    let e = err(&format!("{MINIMAL}[mdas]\nmax_samples_per_leaf = 15\n"));
    assert!(
        e.starts_with("t.toml:10:24: max_samples_per_leaf = 15"),
        "{e}"
    );
    // l = 6 > the default m = 4: the key that is written is blamed.
    let e = err(&format!("{MINIMAL}[mdas]\ninitial_samples_per_cell = 6\n"));
    assert!(
        e.starts_with(
            "t.toml:10:28: initial_samples_per_cell = 6: must be in 1..=max_samples_per_leaf (4)"
        ),
        "{e}"
    );
    let e = err(&format!(
        "{MINIMAL}[mdas]\nbits_per_dim = 6\nextra_image_bits = 8\n"
    ));
    assert!(e.starts_with("t.toml:11:20: extra_image_bits = 8"), "{e}");
    let e = err(&format!("{MINIMAL}[mdas]\nalpha = 100\n"));
    assert!(
        e.starts_with("t.toml:10:9: alpha = 100: must be a number in [0, 64]"),
        "{e}"
    );
    let e = err(&format!("{MINIMAL}[mdas]\ncandidates = 0\n"));
    assert!(e.starts_with("t.toml:10:14: candidates = 0"), "{e}");
    // Every value the parser accepts, the integrator accepts.
    let ok = parse(
        &format!("{MINIMAL}[mdas]\nmax_samples_per_leaf = 14\ninitial_samples_per_cell = 14\ncandidates = 64\nalpha = 64\n"),
        Path::new("t.toml"),
    )
    .unwrap();
    crate::integrator::mdas::params::validate(&ok.mdas).unwrap();
}

/// Each `[integrand] type` name parses to the spec whose `type_name` is
/// that name: one list of names, the parser's, agrees with the owner's.
#[test]
fn integrand_type_names_round_trip() {
    for (name, keys) in raw::INTEGRAND_TYPES {
        let required = if keys.contains(&"radius") {
            "radius = 1\n"
        } else {
            ""
        };
        let text = format!("{MINIMAL}[integrand]\ntype = \"{name}\"\n{required}");
        let file = parse(&text, Path::new("t.toml")).unwrap();
        assert_eq!(file.integrand.type_name(), name);
    }
}

/// Issue 18 item 9: absurd magnitudes are refused at their key (a keyframe
/// at 3e38 crashed the BVH builder, an aperture of 1e30 made every ray
/// miss, an orbit speed of 3e38 gave NaN light positions on the GPU).
#[test]
fn absurd_magnitudes_are_refused_where_they_are_written() {
    let quad = "[[material]]\nname = \"m\"\nalbedo = [0.5, 0.5, 0.5]\n[[shape]]\ntype = \"quad\"\nmaterial = \"m\"\ncorners = [[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]]\n";
    let keyframes = "motion = [{ time = 0 }, { time = 1, translate = [3e38, 0, 0] }]\n";
    let e = err(&format!("{MINIMAL}{quad}{keyframes}"));
    assert!(
        e.starts_with("t.toml:16:49:") && e.contains("translate must be within ±1e9"),
        "{e}"
    );
    let e = err(&MINIMAL.replace("fov_y = 40", "fov_y = 40\naperture_radius = 1e30"));
    assert!(
        e.starts_with("t.toml:9:19:") && e.contains("aperture_radius"),
        "{e}"
    );
    let e = err(&MINIMAL.replace("[0, 0, 5]", "[0, 0, 5e12]"));
    assert!(e.contains("camera position must be within"), "{e}");
    let set = "[[light_set]]\ntype = \"box\"\ncount = 4\nmin = [0, 0, 0]\nmax = [1, 1, 1]\nintensity = [1, 1, 1]\norbit_radius = 1\n";
    let e = err(&format!("{MINIMAL}{set}orbit_speed = 3e38\n"));
    assert!(
        e.contains("orbit_speed must be within ±1e4, found 3e38"),
        "{e}"
    );
    assert!(parse(
        &format!("{MINIMAL}{set}orbit_speed = -1e4\n"),
        Path::new("t.toml")
    )
    .is_ok());
    let e = err(&format!("{MINIMAL}{quad}transform = {{ scale = 1e30 }}\n"));
    assert!(e.contains("beyond ±1e9"), "{e}");
    // Lights: positions and set boxes within ±1e9, emission at most 1e20
    // (sums over 2^24 jittered lights stay finite).
    let point = |p: &str, i: &str| {
        format!("[[light]]\ntype = \"point\"\nposition = {p}\nintensity = {i}\n")
    };
    let e = err(&format!("{MINIMAL}{}", point("[0, 1e12, 0]", "[1, 1, 1]")));
    assert!(e.contains("position must be within ±1e9"), "{e}");
    let e = err(&format!("{MINIMAL}{}", point("[0, 1, 0]", "[3e38, 1, 1]")));
    assert!(e.contains("intensity must be at most 1e20"), "{e}");
    let far_set = set.replace("max = [1, 1, 1]", "max = [1e30, 1, 1]");
    let e = err(&format!("{MINIMAL}{far_set}"));
    assert!(
        e.contains("a light of this set lies at") && e.contains("beyond ±1e9"),
        "{e}"
    );
}

/// Issue 18 item 9: an integrand that can see no light says so before
/// rendering a black image; one that can see a light says nothing.
#[test]
fn integrands_that_see_no_light_are_named() {
    let quad = "[[material]]\nname = \"m\"\nalbedo = [0.5, 0.5, 0.5]\n[[shape]]\ntype = \"quad\"\nmaterial = \"m\"\ncorners = [[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]]\n";
    let point = "[[light]]\ntype = \"point\"\nposition = [0, 2, 0]\nintensity = [1, 1, 1]\n";
    let dark_point = "[[light]]\ntype = \"point\"\nposition = [0, 2, 0]\nintensity = [0, 0, 0]\n";
    let area = "[[light]]\ntype = \"quad\"\ncorners = [[0, 2, 0], [1, 2, 0], [1, 2, 1], [0, 2, 1]]\nradiance = [1, 1, 1]\n";
    let set = "[[light_set]]\ntype = \"box\"\ncount = 4\nmin = [0, 1, 0]\nmax = [1, 2, 1]\nintensity = [1, 1, 1]\n";
    let warnings = |lights: &str, integrand: &str| {
        let radius = if integrand == "ambient_occlusion" {
            "radius = 1\n"
        } else {
            ""
        };
        let text = format!("{MINIMAL}{quad}{lights}[integrand]\ntype = \"{integrand}\"\n{radius}");
        let s = parse(&text, Path::new("t.toml")).unwrap();
        s.integrand.light_warnings(&s.scene)
    };
    let one = |lights: &str, integrand: &str, needle: &str| {
        let w = warnings(lights, integrand);
        assert!(
            w.len() == 1 && w[0].contains(needle),
            "{integrand} with {lights:?}: {w:?}"
        );
    };
    one("", "many_light", "no light to sample");
    one(dark_point, "many_light", "no light to sample");
    one(point, "area_light", "1 point/directional lights");
    one(set, "area_light", "4 light-set lights");
    one(area, "depth_of_field", "point and directional lights");
    one(set, "motion_blur", "light-set lights");
    one(
        set,
        "path",
        "nothing the path integrand samples emits light",
    );
    for (lights, integrand) in [
        (point, "many_light"),
        (set, "many_light"),
        (area, "many_light"),
        (area, "area_light"),
        (point, "depth_of_field"),
        (point, "path"),
        (area, "path"),
        ("", "ambient_occlusion"),
    ] {
        assert_eq!(
            warnings(lights, integrand),
            Vec::<String>::new(),
            "{integrand}"
        );
    }
}

/// Issue 18 item 10: a bow tie whose two halves' normals cancel exactly
/// (no Newell normal) is still a bow tie, for shapes and quad lights.
#[test]
fn symmetric_bow_tie_quads_are_refused() {
    let bow = "[[0, 0, 0], [1, 1, 0], [1, 0, 0], [0, 1, 0]]";
    let shape = format!("[[material]]\nname = \"m\"\nalbedo = [0.5, 0.5, 0.5]\n[[shape]]\ntype = \"quad\"\nmaterial = \"m\"\ncorners = {bow}\n");
    let e = err(&format!("{MINIMAL}{shape}"));
    assert!(e.contains("bow tie"), "{e}");
    let light = format!("[[light]]\ntype = \"quad\"\ncorners = {bow}\nradiance = [1, 1, 1]\n");
    let e = err(&format!("{MINIMAL}{light}"));
    assert!(e.contains("bow tie"), "{e}");
}

/// `visibility` and the `voxel_*` keys apply to every integrand type; bad
/// values are refused at their key.
#[test]
fn visibility_keys_parse_for_every_type_and_are_checked() {
    use crate::accel::voxel::{Visibility, VoxelParams};
    let s = parse(MINIMAL, Path::new("t.toml")).unwrap();
    assert_eq!(
        (s.visibility, s.voxel),
        (Visibility::Bvh, VoxelParams::default())
    );
    for (name, keys) in raw::INTEGRAND_TYPES {
        let required = if keys.contains(&"radius") {
            "radius = 1\n"
        } else {
            ""
        };
        let text = format!(
            "{MINIMAL}[integrand]\ntype = \"{name}\"\n{required}visibility = \"voxel\"\nvoxel_directions = 12\nvoxel_resolution = 96\nvoxel_skip = 0\n"
        );
        let file = parse(&text, Path::new("t.toml")).unwrap();
        let p = VoxelParams {
            directions: 12,
            resolution: 96,
            skip: 0,
        };
        assert_eq!(
            (file.visibility, file.voxel),
            (Visibility::Voxel(p), p),
            "{name}"
        );
        // The keys without `visibility = "voxel"` keep the BVH (and the
        // parameters, for --visibility voxel).
        let text = text.replace("visibility = \"voxel\"\n", "");
        let file = parse(&text, Path::new("t.toml")).unwrap();
        assert_eq!(
            (file.visibility, file.voxel),
            (Visibility::Bvh, p),
            "{name}"
        );
    }
    let table = format!("{MINIMAL}[integrand]\ntype = \"area_light\"\n");
    for (line, expected) in [
        (
            "visibility = \"rays\"",
            "t.toml:11:14: unknown visibility 'rays'",
        ),
        (
            "voxel_directions = 0",
            "t.toml:11:20: voxel_directions must be at least 1",
        ),
        (
            "voxel_directions = 181",
            "t.toml:11:20: voxel_directions must be at most 180",
        ),
        (
            "voxel_resolution = 48",
            "t.toml:11:20: voxel_resolution must be a multiple of 32",
        ),
        (
            "voxel_resolution = 2048",
            "t.toml:11:20: voxel_resolution must be at most 1024",
        ),
        (
            "voxel_skip = 17",
            "t.toml:11:14: voxel_skip must be at most 16",
        ),
    ] {
        let e = err(&format!("{table}{line}\n"));
        assert!(e.starts_with(expected), "{line}: {e}");
    }
}

#[test]
fn line_column_counts_characters_and_steps_back_inside_one() {
    // Bytes: `a = "é"` is a 0, space 1, = 2, space 3, " 4, é 5–6, " 7,
    // newline 8; then b 9, é 10–11, space 12, = 13, space 14, 1 15.
    let ctx = Ctx {
        text: "a = \"é\"\nbé = 1",
        file: Path::new("t.toml"),
        triangles: Default::default(),
    };
    assert_eq!(ctx.line_column(0), (1, 1));
    assert_eq!(ctx.line_column(5), (1, 6));
    // An offset inside a character stands for that character.
    assert_eq!(ctx.line_column(6), (1, 6));
    assert_eq!(ctx.line_column(7), (1, 7));
    assert_eq!(ctx.line_column(9), (2, 1));
    assert_eq!(ctx.line_column(11), (2, 2));
    assert_eq!(ctx.line_column(12), (2, 3));
    // Past the end: the end.
    assert_eq!(ctx.line_column(100), (2, 7));
}

/// The limits are inclusive: emission of exactly `MAX_EMISSION` and a
/// scene of exactly `MAX_SCENE_TRIANGLES` triangles are accepted, one
/// step beyond is refused.
#[test]
fn limits_accept_their_own_value() {
    let point = |i: &str| {
        format!("{MINIMAL}[[light]]\ntype = \"point\"\nposition = [0, 1, 0]\nintensity = {i}\n")
    };
    assert!(parse(&point("[1e20, 1e20, 1e20]"), Path::new("t.toml")).is_ok());
    // 1.0000001e20 rounds to the next f32 above 1e20 (the ulp there is
    // 2^43 ≈ 8.8e12).
    let e = err(&point("[1.0000001e20, 1, 1]"));
    assert!(e.contains("intensity must be at most 1e20"), "{e}");
    let ctx = Ctx {
        text: "x",
        file: Path::new("t.toml"),
        triangles: Default::default(),
    };
    assert!(ctx.count_check(MAX_SCENE_TRIANGLES, 0..1, "mesh").is_ok());
    let e = ctx.count_check(1, 0..1, "mesh").unwrap_err().to_string();
    assert!(e.contains("absurdly large"), "{e}");
    // The budget is the scene's: two shapes of half the limit fit, a
    // third triangle does not.
    let ctx = Ctx {
        text: "x",
        file: Path::new("t.toml"),
        triangles: Default::default(),
    };
    assert!(ctx
        .count_check(MAX_SCENE_TRIANGLES / 2, 0..1, "sphere")
        .is_ok());
    assert!(ctx
        .count_check(MAX_SCENE_TRIANGLES / 2, 0..1, "sphere")
        .is_ok());
    let e = ctx.count_check(1, 0..1, "disk").unwrap_err().to_string();
    assert!(
        e.contains(&format!("at most {MAX_SCENE_TRIANGLES} in a scene")),
        "{e}"
    );
}

/// A field of view inside (0, 180) in f64 but 180 as the f32 the GPU uses
/// is refused at its position, not rendered upside down (issue 67, hostile
/// inputs class 2); so is one whose tan(fov_y/2) is 0 in f32.
#[test]
fn fov_y_is_checked_as_the_f32_the_gpu_uses() {
    assert_eq!(179.99999999f64 as f32, 180.0);
    let e = err(&MINIMAL.replace("fov_y = 40", "fov_y = 179.99999999"));
    assert!(
        e.starts_with("t.toml:8:9: fov_y must be in (0, 180) degrees, found 179.99999999, which is 180.0 as the f32"),
        "{e}"
    );
    let e = err(&MINIMAL.replace("fov_y = 40", "fov_y = 1e-45"));
    assert!(
        e.starts_with("t.toml:8:9: fov_y must be in (0, 180)"),
        "{e}"
    );
    // The largest f32 below 180 still gives a positive tangent.
    let s = parse(
        &MINIMAL.replace("fov_y = 40", "fov_y = 179.99998"),
        Path::new("t.toml"),
    )
    .unwrap();
    assert!(s.scene.camera.tan_half_fov_y() > 1e6);
}
