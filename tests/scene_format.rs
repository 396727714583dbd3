//! Scene-file loader: the shipped scenes, the known-answer scene's exact
//! content, and the error messages (file:line:column) for bad files.

use glam::{Quat, Vec3};
use mdas::integrand::IntegrandSpec;
use mdas::scene::{Light, Mesh};
use mdas::scene_file;
use mdas::scene_file::SceneError;
use std::path::Path;

mod scene_text;
use scene_text::*;

fn normals(m: &Mesh) -> Vec<Vec3> {
    m.indices
        .iter()
        .map(|&[a, b, c]| {
            let [a, b, c] = [a, b, c].map(|i| m.positions[i as usize]);
            (b - a).cross(c - a).normalize()
        })
        .collect()
}

fn area(m: &Mesh) -> f32 {
    m.indices
        .iter()
        .map(|&[a, b, c]| {
            let [a, b, c] = [a, b, c].map(|i| m.positions[i as usize]);
            0.5 * (b - a).cross(c - a).length()
        })
        .sum()
}

#[test]
fn area_light_plane_is_exactly_the_known_answer_scene() {
    let s = scene_file::load(&scene_path("area_light_plane.toml")).unwrap();
    assert_eq!((s.scene.film.width, s.scene.film.height), (128, 96));
    let c = s.scene.camera;
    assert_eq!(
        (c.position, c.look_at, c.up),
        (Vec3::new(0.0, 0.5, 4.0), Vec3::ZERO, Vec3::Y)
    );
    assert_eq!((c.fov_y, c.aperture_radius), (45.0, 0.0));
    assert_eq!(s.scene.background, Vec3::ZERO);
    assert_eq!(s.integrand, IntegrandSpec::AreaLight);
    assert!(
        s.scene.lights.is_empty(),
        "the area light is a mesh, not a delta light"
    );
    let m = s.mdas;
    assert_eq!(
        (
            m.scale_factor,
            m.bits_per_dim,
            m.extra_image_bits,
            m.alpha,
            m.spp
        ),
        (1.0, 1, 5, 0.25, 16.0)
    );

    assert_eq!(s.scene.meshes.len(), 2);
    let (plane, light) = (&s.scene.meshes[0], &s.scene.meshes[1]);

    assert_eq!(plane.indices.len(), 2);
    assert!(
        normals(plane).iter().all(|n| n.abs_diff_eq(Vec3::Y, 1e-6)),
        "plane must face +y"
    );
    assert!(plane
        .positions
        .iter()
        .all(|p| p.y == 0.0 && p.x.abs() == 10.0 && p.z.abs() == 10.0));
    assert_eq!(area(plane), 400.0);
    let plane_material = &s.scene.materials[plane.material as usize];
    assert_eq!(
        (plane_material.albedo, plane_material.emission),
        (Vec3::splat(0.5), Vec3::ZERO)
    );
    assert!(plane_material.checker.is_none());

    assert_eq!(light.name, "light0");
    assert_eq!(light.indices.len(), 2);
    assert!(
        normals(light)
            .iter()
            .all(|n| n.abs_diff_eq(Vec3::NEG_Y, 1e-6)),
        "light must face -y"
    );
    assert!(light
        .positions
        .iter()
        .all(|p| p.y == 2.0 && p.x.abs() == 0.5 && p.z.abs() == 0.5));
    assert_eq!(area(light), 1.0);
    let light_material = &s.scene.materials[light.material as usize];
    assert_eq!(
        (light_material.albedo, light_material.emission),
        (Vec3::ZERO, Vec3::splat(10.0))
    );
    assert!(s.scene.meshes.iter().all(|m| m.motion.is_empty()));
}

#[test]
fn cornell_box_loads_with_closed_outward_blocks_and_the_ceiling_light() {
    let s = scene_file::load(&scene_path("cornell.toml")).unwrap();
    assert_eq!((s.scene.film.width, s.scene.film.height), (256, 256));
    assert_eq!(s.integrand, IntegrandSpec::AreaLight);
    // The defaults of an untuned scene, with the grid chosen for 256×256
    // at 8 spp: cells of a pixel, 6 samples each (5/6 of the budget); α = 2
    // with the paced selection.
    let m = s.mdas;
    assert!(m.auto_grid);
    assert_eq!(
        (
            m.bits_per_dim,
            m.extra_image_bits,
            m.initial_samples_per_cell,
            m.max_samples_per_leaf,
            m.alpha,
            m.pace,
            m.spp
        ),
        (0, 8, 6, 7, 2.0, 0.5, 8.0)
    );
    // 5 walls + 2 blocks + the light.
    assert_eq!(s.scene.meshes.len(), 8);
    assert_eq!(s.scene.triangle_count(), 5 * 2 + 2 * 12 + 2);
    let room_center = Vec3::splat(2.775);
    for wall in &s.scene.meshes[..5] {
        let [a, b, c] = wall.indices[0].map(|i| wall.positions[i as usize]);
        let n = (b - a).cross(c - a);
        assert!(
            n.dot(room_center - a) > 0.0,
            "{} must face into the room",
            wall.name
        );
    }
    for block in &s.scene.meshes[5..7] {
        let center = block.positions.iter().copied().sum::<Vec3>() / block.positions.len() as f32;
        for (t, n) in normals(block).iter().enumerate() {
            let a = block.positions[block.indices[t][0] as usize];
            assert!(
                n.dot(a - center) > 0.0,
                "{} normals must point outward",
                block.name
            );
        }
        assert!(block
            .positions
            .iter()
            .all(|p| p.min_element() >= 0.0 && p.max_element() < 5.55));
    }
    let light = &s.scene.meshes[7];
    assert!(normals(light)
        .iter()
        .all(|n| n.abs_diff_eq(Vec3::NEG_Y, 1e-6)));
    assert_eq!(
        s.scene.materials[light.material as usize].emission,
        Vec3::new(17.0, 12.0, 4.0)
    );
    let albedo = |name: &str| {
        s.scene
            .materials
            .iter()
            .find(|m| m.name == name)
            .unwrap()
            .albedo
    };
    assert_eq!(albedo("red"), Vec3::new(0.65, 0.05, 0.05));
    assert_eq!(albedo("green"), Vec3::new(0.12, 0.45, 0.15));
}

#[test]
fn every_shape_type_loads() {
    let s = scene_file::load(&scene_path("tests/shapes.toml")).unwrap();
    assert_eq!(s.scene.meshes.len(), 8);
    assert_eq!(s.scene.background, Vec3::splat(0.1));
    assert_eq!(
        (
            s.scene.camera.aperture_radius,
            s.scene.camera.focus_distance,
            s.scene.camera.shutter_close
        ),
        (0.05, 11.0, 0.5)
    );
    let checker = s.scene.materials[0].checker.unwrap();
    assert_eq!((checker.albedo2, checker.scale), (Vec3::splat(0.1), 0.5));
    let by_type: Vec<usize> = s.scene.meshes.iter().map(|m| m.indices.len()).collect();
    assert_eq!(by_type[..5], [2, 1, 12, 2 * 48 * 23, 32]);
    assert_eq!(by_type[6], 2 * 64 * 32);
    assert_eq!(by_type[7], 20 * 64);
    assert_eq!(s.scene.meshes[0].name, "shape0");
    // The transformed box: scaled ×2 in y before moving.
    let top = s.scene.meshes[2]
        .positions
        .iter()
        .map(|p| p.y)
        .fold(f32::MIN, f32::max);
    assert_eq!(top, 2.0);
    // The disk faces down.
    assert!(normals(&s.scene.meshes[4])
        .iter()
        .all(|n| n.abs_diff_eq(Vec3::NEG_Y, 1e-5)));
    assert_eq!(
        s.scene.lights,
        vec![
            Light::Point {
                position: Vec3::new(0.0, 6.0, 0.0),
                intensity: Vec3::splat(5.0)
            },
            Light::Directional {
                direction: Vec3::new(1.0, -2.0, 0.0).normalize(),
                irradiance: Vec3::splat(0.5)
            },
        ]
    );
}

#[test]
fn obj_mesh_loads_relative_to_the_scene_file_with_motion() {
    let s = scene_file::load(&scene_path("tests/mesh.toml")).unwrap();
    let m = &s.scene.meshes[0];
    assert_eq!(m.name, "tetra");
    assert_eq!(m.indices.len(), 4);
    assert_eq!(m.positions.len(), 4);
    // Object space = after transform (scale 2, up 1), before motion.
    let center = Vec3::new(0.5, 1.5, 0.5);
    for (t, n) in normals(m).iter().enumerate() {
        let a = m.positions[m.indices[t][0] as usize];
        assert!(
            n.dot(a - center) > 0.0,
            "OBJ winding must be kept (outward)"
        );
    }
    assert!(m.positions.contains(&Vec3::new(0.0, 3.0, 0.0)));
    assert_eq!(m.motion.len(), 3);
    assert_eq!(
        m.motion.iter().map(|k| k.time).collect::<Vec<_>>(),
        [0.0, 0.5, 1.0]
    );
    assert_eq!(m.motion[0].rotation, Quat::IDENTITY);
    assert_eq!(m.motion[1].translation, Vec3::X);
    let expected = Quat::from_rotation_y(std::f32::consts::FRAC_PI_2);
    assert!(m.motion[1].rotation.abs_diff_eq(expected, 1e-6));
    assert!(m.motion[2]
        .rotation
        .abs_diff_eq(Quat::from_rotation_y(std::f32::consts::PI), 1e-6));
}

/// An OBJ without a scene `material` brings its own (issue 19 item 4):
/// one mesh per object or group and material, in file order, named
/// `SHAPE/GROUP`; MTL `Kd` → albedo, `Ke` → emission (the lamp group is an
/// area light); a texture map is a warning naming it; the MTL file is an
/// input of the scene (cache key). With `material` the OBJ is one mesh of
/// it, as before.
#[test]
fn obj_materials_come_from_its_mtl_unless_overridden() {
    let s = scene_file::load(&scene_path("tests/obj_materials.toml")).unwrap();
    let names: Vec<&str> = s.scene.meshes.iter().map(|m| m.name.as_str()).collect();
    assert_eq!(
        names,
        ["room/floor", "room/block", "room/block", "room/lamp"]
    );
    let material = |m: &Mesh| &s.scene.materials[m.material as usize];
    let mats: Vec<&str> = s
        .scene
        .meshes
        .iter()
        .map(|m| material(m).name.as_str())
        .collect();
    assert_eq!(mats, ["room/white", "room/red", "room/white", "room/lamp"]);
    assert_eq!(s.scene.materials.len(), 3, "each OBJ material once");
    let m = |i: usize| material(&s.scene.meshes[i]);
    assert_eq!(m(0).albedo, Vec3::splat(0.7));
    assert_eq!(m(1).albedo, Vec3::new(0.8, 0.1, 0.1));
    assert_eq!((m(3).albedo, m(3).emission), (Vec3::ZERO, Vec3::splat(5.0)));
    assert_eq!(m(0).emission, Vec3::ZERO);
    // Each part keeps only its own vertices, and the lamp faces down.
    assert_eq!(
        s.scene
            .meshes
            .iter()
            .map(|m| m.positions.len())
            .collect::<Vec<_>>(),
        [4, 4, 4, 4]
    );
    assert!(normals(&s.scene.meshes[3]).iter().all(|n| n.y < 0.0));
    assert!(normals(&s.scene.meshes[1]).iter().all(|n| n.z < 0.0));
    assert!(normals(&s.scene.meshes[2]).iter().all(|n| n.z > 0.0));
    assert_eq!(s.warnings.len(), 1, "{:?}", s.warnings);
    assert!(
        s.warnings[0].contains("material 'red' names textures (bricks.png)"),
        "{:?}",
        s.warnings
    );
    let inputs: Vec<String> = s
        .inputs
        .iter()
        .map(|p| p.file_name().unwrap().to_string_lossy().into_owned())
        .collect();
    assert_eq!(inputs, ["two_materials.obj", "two_materials.mtl"]);
    // The emissive group makes the default integrand an area-light one
    // with something to see.
    assert!(matches!(s.integrand, IntegrandSpec::AreaLight));
    assert!(s.integrand.light_warnings(&s.scene).is_empty());

    // With a material: one mesh, the MTL unread.
    let dir = scene_path("tests");
    let text = format!(
        "{BASE}[[shape]]\ntype = \"mesh\"\nmaterial = \"white\"\nfile = \"{}\"\n",
        dir.join("two_materials.obj").display()
    );
    let one = ok("obj-override", &text);
    assert_eq!(one.scene.meshes.len(), 1);
    assert_eq!(one.scene.meshes[0].indices.len(), 8);
    assert_eq!(one.scene.materials.len(), 1);
    assert!(one.warnings.is_empty());
    assert_eq!(one.inputs.len(), 1);
}

/// What an OBJ's materials cannot give is an error at the `file` key: faces
/// before any `usemtl`, a `usemtl` naming no material (with its line), a
/// missing material library, an albedo out of [0, 1], a NaN in Kd or Ke.
/// A shape other than `mesh` still needs `material`.
#[test]
fn obj_material_errors_are_named_at_the_file_key() {
    let (path, _) = load_text("obj-mtl-errors", "");
    let dir = path.parent().unwrap().to_path_buf();
    let write = |name: &str, text: &str| std::fs::write(dir.join(name), text).unwrap();
    write(
        "good.mtl",
        "newmtl a\nKd 0.5 0.5 0.5\nnewmtl bright\nKd 1.5 0 0\n\
         newmtl nan_kd\nKd nan .5 .5\nnewmtl nan_ke\nKd 0.5 0.5 0.5\nKe 0 nan 0\n",
    );
    let quad = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n";
    let scene = |obj: &str| format!("{BASE}[[shape]]\ntype = \"mesh\"\nfile = \"{obj}\"\n");
    for (obj, text, want) in [
        (
            "nomtl.obj",
            format!("mtllib good.mtl\n{quad}f 1 2 3 4\n"),
            "has faces without a material (no usemtl)".to_string(),
        ),
        (
            "unknown.obj",
            format!("mtllib good.mtl\n{quad}usemtl nope\nf 1 2 3 4\n"),
            "line 6: usemtl 'nope' names no material of its material library".to_string(),
        ),
        (
            "nolib.obj",
            format!("mtllib missing.mtl\n{quad}usemtl a\nf 1 2 3 4\n"),
            format!(
                "cannot read material library '{}'",
                dir.join("missing.mtl").display()
            ),
        ),
        (
            "bright.obj",
            format!("mtllib good.mtl\n{quad}usemtl bright\nf 1 2 3 4\n"),
            "material 'bright': Kd must be in [0, 1]".to_string(),
        ),
        // A NaN in any channel (issue 54 item 6), which min/max tests
        // alone let through.
        (
            "nan_kd.obj",
            format!("mtllib good.mtl\n{quad}usemtl nan_kd\nf 1 2 3 4\n"),
            "material 'nan_kd': Kd must be in [0, 1]".to_string(),
        ),
        (
            "nan_ke.obj",
            format!("mtllib good.mtl\n{quad}usemtl nan_ke\nf 1 2 3 4\n"),
            "material 'nan_ke': Ke must be in [0, ".to_string(),
        ),
    ] {
        write(obj, &text);
        let m = error_at("obj-mtl-errors", &scene(obj), 14, 8);
        assert!(m.contains(&want), "{obj}: {m}");
    }
    let m = error_at(
        "quad-no-material",
        &format!("{BASE}[[shape]]\ntype = \"quad\"\ncorners = [[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]]\n"),
        13,
        8,
    );
    assert!(m.contains("a quad shape needs 'material'"), "{m}");
}

/// Vertex normals through the scene loader (issue 19 item 4): with the
/// OBJ's materials each part keeps its own vertices' normals, a
/// `transform` maps them by its inverse transpose (a squashed y-scale
/// tips them toward +y), and with a `material` the merged mesh keeps them
/// too. A file mixing faces with and without normals is an error at the
/// `file` key naming both lines.
#[test]
fn obj_vertex_normals_reach_the_scene_meshes() {
    let (path, _) = load_text("obj-normals", "");
    let dir = path.parent().unwrap().to_path_buf();
    let write = |name: &str, text: &str| std::fs::write(dir.join(name), text).unwrap();
    write(
        "two.mtl",
        "newmtl a\nKd 0.5 0.5 0.5\nnewmtl b\nKd 0.2 0.2 0.2\n",
    );
    write(
        "smooth.obj",
        "mtllib two.mtl\nv 0 0 0\nv 1 0 0\nv 1 0 -1\nv 0 0 -1\n\
         vn 1 1 0\nvn 0 1 0\nvn -1 1 0\n\
         o left\nusemtl a\nf 1//1 2//2 3//2\no right\nusemtl b\nf 1//3 3//3 4//3\n",
    );
    let shape =
        |extra: &str| format!("{BASE}[[shape]]\ntype = \"mesh\"\nfile = \"smooth.obj\"\n{extra}");
    let s = ok("obj-normals", &shape(""));
    let meshes = &s.scene.meshes;
    assert_eq!(meshes.len(), 2);
    let h = std::f32::consts::FRAC_1_SQRT_2;
    for (mesh, want) in meshes.iter().zip([
        vec![Vec3::new(h, h, 0.0), Vec3::Y, Vec3::Y],
        vec![Vec3::new(-h, h, 0.0); 3],
    ]) {
        let got: Vec<Vec3> = mesh.indices[0]
            .iter()
            .map(|&i| mesh.normals[i as usize].normalize())
            .collect();
        assert!(
            got.iter().zip(&want).all(|(g, w)| g.abs_diff_eq(*w, 1e-6)),
            "{}: {got:?}",
            mesh.name
        );
        assert_eq!(mesh.normals.len(), mesh.positions.len());
    }
    // Scaling y by 1/4 makes the 45° normal (1, 1, 0) steeper: (1, 4, 0).
    let squashed = ok(
        "obj-normals",
        &shape("material = \"white\"\ntransform = { scale = [1, 0.25, 1] }\n"),
    );
    let m = &squashed.scene.meshes[0];
    assert_eq!(squashed.scene.meshes.len(), 1);
    let first = m.normals[m.indices[0][0] as usize];
    assert!(
        first.abs_diff_eq(Vec3::new(1.0, 4.0, 0.0).normalize(), 1e-6),
        "{first}"
    );
    write(
        "mixed.obj",
        "v 0 0 0\nv 1 0 0\nv 1 0 -1\nv 0 0 -1\nvn 0 1 0\nf 1//1 2//1 3//1\nf 1 3 4\n",
    );
    let m = error_at(
        "obj-normals",
        &format!("{BASE}[[shape]]\ntype = \"mesh\"\nmaterial = \"white\"\nfile = \"mixed.obj\"\n"),
        15,
        8,
    );
    assert!(
        m.contains("line 7: the face on line 6 gives normals (vn) and the face on line 7 does not"),
        "{m}"
    );
}

#[test]
fn message_format_names_file_line_column() {
    let text = format!("{BASE}[[material]]\nname = \"red\"\nalbdo = [1, 0, 0]\n");
    let e = scene_file::parse(&text, Path::new("scenes/x.toml"))
        .unwrap_err()
        .to_string();
    assert!(
        e.starts_with(
            "scenes/x.toml:14:1: unknown field 'albdo', expected one of 'name', 'albedo'"
        ),
        "{e}"
    );
}

#[test]
fn unreadable_file_is_an_io_error() {
    let path = scene_path("tests/does-not-exist.toml");
    let e = scene_file::load(&path).unwrap_err();
    assert!(matches!(e, SceneError::Io { .. }));
    assert!(
        e.to_string()
            .starts_with(&format!("cannot read {}: ", path.display())),
        "{e}"
    );
    assert_eq!(e.position(), None);
}

/// Devices, directories and oversized files are refused before reading:
/// a scene path of /dev/zero grew memory without bound.
#[test]
fn devices_directories_and_huge_files_are_refused() {
    for path in [Path::new("/dev/zero"), Path::new("scenes")] {
        let e = scene_file::load(path).unwrap_err();
        assert!(matches!(e, SceneError::Io { .. }), "{e}");
        assert!(e.to_string().ends_with("not a regular file"), "{e}");
    }
    let dir = std::env::temp_dir().join(format!("mdas-huge-scene-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let huge = dir.join("huge.toml");
    let file = std::fs::File::create(&huge).unwrap();
    file.set_len(scene_file::MAX_SCENE_BYTES + 1).unwrap();
    let e = scene_file::load(&huge).unwrap_err().to_string();
    assert!(
        e.contains(&format!(
            "{} bytes, more than the {}",
            scene_file::MAX_SCENE_BYTES + 1,
            scene_file::MAX_SCENE_BYTES
        )),
        "{e}"
    );
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn malformed_toml_points_at_the_syntax_error() {
    let m = error_at(
        "syntax",
        &format!("{BASE}[[shape]\ntype = \"quad\"\n"),
        12,
        9,
    );
    assert!(m.contains("']'"), "{m}");
    let m = error_at("syntax2", "[film]\nwidth = 8\nheight = = 6\n", 3, 10);
    assert!(!m.is_empty());
}

#[test]
fn unknown_keys_are_named_with_their_line() {
    let m = error_at("unknown-top", &format!("{BASE}resolution = 3\n"), 12, 1);
    assert!(m.contains("unknown field 'resolution'"), "{m}");
    let m = error_at(
        "unknown-camera",
        &BASE.replace("fov_y = 40", "fov_y = 40\nfocal = 3"),
        9,
        1,
    );
    assert!(m.contains("unknown field 'focal'"), "{m}");
    let text = format!(
        "{BASE}[[shape]]\ntype = \"sphere\"\nmaterial = \"white\"\nradius = 1\ncornrs = 2\n"
    );
    let m = error_at("unknown-shape", &text, 16, 1);
    assert!(m.contains("unknown field 'cornrs'"), "{m}");
    // A real key of another shape type is rejected at its value.
    let text = format!(
        "{BASE}[[shape]]\ntype = \"sphere\"\nmaterial = \"white\"\nradius = 1\nfile = \"a.obj\"\n"
    );
    let m = error_at("foreign-key", &text, 16, 8);
    assert!(
        m.contains("key 'file' does not apply to a sphere shape"),
        "{m}"
    );
    let m = error_at(
        "unknown-type",
        &format!("{BASE}[[shape]]\ntype = \"cone\"\nmaterial = \"white\"\n"),
        13,
        8,
    );
    assert!(
        m.contains("unknown shape type 'cone', expected one of 'quad'"),
        "{m}"
    );
    let m = error_at(
        "unknown-integrand",
        &format!("{BASE}[integrand]\ntype = \"pathtracer\"\n"),
        13,
        8,
    );
    assert!(
        m.contains("unknown integrand type 'pathtracer', expected one of 'area_light'"),
        "{m}"
    );
    let m = error_at("unknown-mdas", &format!("{BASE}[mdas]\nsp = 4\n"), 13, 1);
    assert!(m.contains("unknown field 'sp'"), "{m}");
    // ε must be positive; the error stands at its key.
    let m = error_at(
        "mdas-epsilon",
        &format!("{BASE}[mdas]\nalpha = 0.5\nepsilon = 0\n"),
        14,
        11,
    );
    assert!(m.contains("epsilon = 0: must be a number in (0,"), "{m}");
    let (_, ok) = load_text(
        "mdas-epsilon-ok",
        &format!("{BASE}[mdas]\nepsilon = 0.5\nsplit = \"contrast\"\n"),
    );
    let ok = ok.unwrap().mdas;
    assert_eq!(ok.epsilon, 0.5);
    assert_eq!(ok.split, mdas::integrator::mdas::SplitRule::Contrast);
    let m = error_at(
        "mdas-split",
        &format!("{BASE}[mdas]\nsplit = \"median\"\n"),
        13,
        9,
    );
    assert!(m.contains("unknown split rule 'median'"), "{m}");
    let (_, ok) = load_text(
        "mdas-split-trimmed",
        &format!("{BASE}[mdas]\nsplit = \"trimmed\"\n"),
    );
    assert_eq!(
        ok.unwrap().mdas.split,
        mdas::integrator::mdas::SplitRule::Trimmed
    );
    let (_, ok) = load_text(
        "mdas-reconstruction-ok",
        &format!("{BASE}[mdas]\nreconstruction = \"pixel\"\npixel_prior = 0\n"),
    );
    let ok = ok.unwrap().mdas;
    assert_eq!(
        ok.reconstruction,
        mdas::integrator::mdas::Reconstruction::Pixel
    );
    assert_eq!(ok.pixel_prior, 0.0);
    let m = error_at(
        "mdas-reconstruction",
        &format!("{BASE}[mdas]\nreconstruction = \"gauss\"\n"),
        13,
        18,
    );
    assert!(m.contains("unknown reconstruction 'gauss'"), "{m}");
    let m = error_at(
        "mdas-pixel-prior",
        &format!("{BASE}[mdas]\nreconstruction = \"pixel\"\npixel_prior = -1\n"),
        14,
        15,
    );
    assert!(
        m.contains("pixel_prior = -1: must be a number in [0,"),
        "{m}"
    );
    // The paced selection's share: [0, 1], 0 the paper's rule; a table
    // without the key takes the default of a scene without a table.
    let m = error_at(
        "mdas-pace",
        &format!("{BASE}[mdas]\nalpha = 1\npace = 1.5\n"),
        14,
        8,
    );
    assert!(m.contains("pace = 1.5: must be a number in [0, 1]"), "{m}");
    let (_, ok) = load_text("mdas-pace-ok", &format!("{BASE}[mdas]\npace = 0\n"));
    assert_eq!(ok.unwrap().mdas.pace, 0.0);
    let (_, ok) = load_text("mdas-pace-default", &format!("{BASE}[mdas]\nalpha = 1\n"));
    assert_eq!(
        ok.unwrap().mdas.pace,
        mdas::integrator::mdas::params::AUTO_PACE
    );
}

#[test]
fn missing_mesh_file_is_named_at_the_file_key() {
    let text =
        format!("{BASE}[[shape]]\ntype = \"mesh\"\nmaterial = \"white\"\nfile = \"missing.obj\"\n");
    let (path, _) = load_text("missing-mesh", "");
    let m = error_at("missing-mesh", &text, 15, 8);
    let expected = path.parent().unwrap().join("missing.obj");
    assert!(
        m.starts_with(&format!("cannot read mesh file '{}'", expected.display())),
        "{m}"
    );
}

#[test]
fn nan_and_inf_are_rejected_where_they_stand() {
    let m = error_at("nan", &BASE.replace("fov_y = 40", "fov_y = nan"), 8, 9);
    assert!(m.contains("finite") && m.contains("nan"), "{m}");
    let m = error_at("inf", &BASE.replace("[0, 1, 5]", "[0, -inf, 5]"), 5, 16);
    assert!(m.contains("finite") && m.contains("-inf"), "{m}");
    let text = format!("{BASE}[mdas]\nalpha = inf\n");
    let m = error_at("inf-mdas", &text, 13, 9);
    assert!(m.contains("finite"), "{m}");
    let m = error_at(
        "f32-overflow",
        &BASE.replace("fov_y = 40", "fov_y = 1e39"),
        8,
        9,
    );
    assert!(m.contains("out of range"), "{m}");
}

#[test]
fn film_resolution_must_be_positive_and_sane() {
    let m = error_at("zero", &BASE.replace("width = 8", "width = 0"), 2, 9);
    assert!(m.contains("film width must be positive"), "{m}");
    let m = error_at(
        "negative",
        &BASE.replace("height = 6", "height = -6"),
        3,
        10,
    );
    assert!(m.contains("film height must be positive"), "{m}");
    let m = error_at(
        "huge-side",
        &BASE.replace("width = 8", "width = 100000"),
        2,
        9,
    );
    assert!(m.contains("absurdly large"), "{m}");
    let text = BASE
        .replace("width = 8", "width = 16384")
        .replace("height = 6", "height = 16384");
    let m = error_at("huge-area", &text, 3, 10);
    assert!(
        m.contains("absurdly large") && m.contains("268435456 pixels"),
        "{m}"
    );
    let m = error_at(
        "float-width",
        &BASE.replace("width = 8", "width = 8.5"),
        2,
        9,
    );
    assert!(m.contains("expected an integer"), "{m}");
    let m = error_at(
        "no-film",
        &BASE.replace("[film]\nwidth = 8\nheight = 6\n", ""),
        1,
        1,
    );
    assert!(m.contains("missing field 'film'"), "{m}");
}

#[test]
fn negative_or_zero_radiance_is_rejected() {
    let light =
        "[[light]]\ntype = \"quad\"\ncorners = [[0, 2, 0], [1, 2, 0], [1, 2, 1], [0, 2, 1]]\n";
    let m = error_at(
        "neg-radiance",
        &format!("{BASE}{light}radiance = [1, -0.5, 1]\n"),
        15,
        12,
    );
    assert!(m.contains("radiance must be ≥ 0"), "{m}");
    let m = error_at(
        "zero-radiance",
        &format!("{BASE}{light}radiance = [0, 0, 0]\n"),
        15,
        12,
    );
    assert!(m.contains("must not be all 0"), "{m}");
    let text = format!(
        "{BASE}[[light]]\ntype = \"point\"\nposition = [0, 1, 0]\nintensity = [-1, 0, 0]\n"
    );
    let m = error_at("neg-intensity", &text, 15, 13);
    assert!(m.contains("intensity must be ≥ 0"), "{m}");
    let m = error_at(
        "neg-albedo",
        &BASE.replace("[0.5, 0.5, 0.5]", "[0.5, -0.1, 0.5]"),
        11,
        10,
    );
    assert!(m.contains("albedo must be in [0, 1]"), "{m}");
    let m = error_at(
        "big-albedo",
        &BASE.replace("[0.5, 0.5, 0.5]", "[0.5, 1.5, 0.5]"),
        11,
        10,
    );
    assert!(m.contains("albedo must be in [0, 1]"), "{m}");
}

#[test]
fn unknown_material_is_reported_at_the_reference() {
    let text = format!("{BASE}[[shape]]\ntype = \"triangle\"\nmaterial = \"whtie\"\nvertices = [[0, 0, 0], [1, 0, 0], [0, 1, 0]]\n");
    let m = error_at("unknown-material", &text, 14, 12);
    assert_eq!(m, "unknown material 'whtie' (defined: 'white')");
    let text = format!("{BASE}[[material]]\nname = \"white\"\nalbedo = [1, 1, 1]\n");
    let m = error_at("duplicate-material", &text, 13, 8);
    assert!(m.contains("material 'white' is defined twice"), "{m}");
}

#[test]
fn motion_keyframes_parse_and_must_increase() {
    let shape = format!("{BASE}[[shape]]\ntype = \"sphere\"\nmaterial = \"white\"\nradius = 1\n");
    let (_, ok) = load_text(
        "motion-ok",
        &format!("{shape}motion = [{{ time = 0 }}, {{ time = 1, translate = [0, 2, 0], rotate = [1, 0, 0, 90] }}]\n"),
    );
    let s = ok.unwrap();
    let motion = &s.scene.meshes[0].motion;
    assert_eq!(motion.len(), 2);
    assert_eq!(
        (motion[0].time, motion[0].translation, motion[0].rotation),
        (0.0, Vec3::ZERO, Quat::IDENTITY)
    );
    assert_eq!(
        (motion[1].time, motion[1].translation),
        (1.0, Vec3::new(0.0, 2.0, 0.0))
    );
    assert!(motion[1]
        .rotation
        .abs_diff_eq(Quat::from_rotation_x(std::f32::consts::FRAC_PI_2), 1e-6));
    // Object space: the sphere stays at the origin; motion moves it.
    let centroid = s.scene.meshes[0].positions.iter().copied().sum::<Vec3>()
        / s.scene.meshes[0].positions.len() as f32;
    assert!(centroid.length() < 1e-5);

    let text = format!(
        "{shape}motion = [\n  {{ time = 0.0 }},\n  {{ time = 0.7 }},\n  {{ time = 0.5 }},\n]\n"
    );
    let m = error_at("motion-unsorted", &text, 19, 12);
    assert!(m.contains("strictly increasing: 0.5 follows 0.7"), "{m}");
    let m = error_at(
        "motion-equal",
        &format!("{shape}motion = [{{ time = 0.5 }}, {{ time = 0.5 }}]\n"),
        16,
        36,
    );
    assert!(m.contains("strictly increasing"), "{m}");
    let m = error_at(
        "motion-one",
        &format!("{shape}motion = [{{ time = 0.5 }}]\n"),
        16,
        10,
    );
    assert!(m.contains("at least 2 keyframes"), "{m}");
    let text =
        format!("{shape}motion = [{{ time = 0 }}, {{ time = 1, rotate = [0, 0, 0, 90] }}]\n");
    let m = error_at("motion-axis", &text, 16, 46);
    assert!(m.contains("rotate axis must be a nonzero vector"), "{m}");
}

#[test]
fn degenerate_and_invalid_geometry_is_rejected() {
    let quad = |corners: &str| {
        format!("{BASE}[[shape]]\ntype = \"quad\"\nmaterial = \"white\"\ncorners = {corners}\n")
    };
    let m = error_at(
        "coincident",
        &quad("[[1, 1, 1], [1, 1, 1], [1, 1, 1], [1, 1, 1]]"),
        15,
        11,
    );
    assert!(m.contains("entirely degenerate"), "{m}");
    let m = error_at(
        "nonplanar",
        &quad("[[0, 0, 0], [1, 0, 0], [1, 1, 1], [0, 1, 0]]"),
        15,
        11,
    );
    assert!(m.contains("planar"), "{m}");
    let m = error_at(
        "three-corners",
        &quad("[[0, 0, 0], [1, 0, 0], [1, 1, 0]]"),
        15,
        11,
    );
    assert!(m.contains("4 points"), "{m}");
    let sphere = format!("{BASE}[[shape]]\ntype = \"sphere\"\nmaterial = \"white\"\n");
    let m = error_at("radius0", &format!("{sphere}radius = 0\n"), 15, 10);
    assert!(m.contains("radius must be > 0"), "{m}");
    let m = error_at("no-radius", &sphere, 13, 8);
    assert!(m.contains("a sphere shape needs 'radius'"), "{m}");
    let m = error_at(
        "segments",
        &format!("{sphere}radius = 1\nsegments = 2\n"),
        16,
        12,
    );
    assert!(m.contains("segments must be at least 3"), "{m}");
    let blob = format!("{BASE}[[shape]]\ntype = \"blob\"\nmaterial = \"white\"\nradius = 1\n");
    let m = error_at("blob-huge", &format!("{blob}subdivisions = 11\n"), 16, 16);
    assert!(m.contains("absurdly large"), "{m}");
    let box_ = format!("{BASE}[[shape]]\ntype = \"box\"\nmaterial = \"white\"\nmin = [0, 0, 0]\n");
    let m = error_at("flat-box", &format!("{box_}max = [1, 0, 1]\n"), 16, 7);
    assert!(m.contains("box max must be greater than min"), "{m}");
    let text = format!("{box_}max = [1, 1, 1]\ntransform = {{ scale = [1, 0, 1] }}\n");
    let m = error_at("zero-scale", &text, 17, 23);
    assert!(m.contains("scale must be nonzero"), "{m}");
}

/// A light or light set given a key of another type is refused at that
/// key, with the type's own keys named.
#[test]
fn keys_of_another_light_type_are_refused_at_the_key() {
    let text = format!(
        "{BASE}[[light]]\ntype = \"point\"\nposition = [0, 1, 0]\nintensity = [1, 1, 1]\n\
         radiance = [1, 1, 1]\n"
    );
    let m = error_at("point-radiance", &text, 16, 12);
    assert!(
        m.contains("key 'radiance' does not apply to a point light")
            && m.contains("'position', 'intensity'"),
        "{m}"
    );
    let text = format!(
        "{BASE}[[light_set]]\ntype = \"surface\"\ncount = 4\noffset = 0.1\nresolution = [2, 2]\n"
    );
    let m = error_at("surface-resolution", &text, 16, 14);
    assert!(
        m.contains("key 'resolution' does not apply to a surface light_set"),
        "{m}"
    );
}

/// A value of the wrong type or length names what was expected: a number,
/// an array of exactly 3 numbers (every element counted, numbers or not,
/// and the count said in words), a number or 3 numbers for a scale.
#[test]
fn wrong_value_types_and_lengths_say_what_was_expected() {
    let m = error_at(
        "num-type",
        &BASE.replace("fov_y = 40", "fov_y = \"wide\""),
        8,
        9,
    );
    assert!(m.contains("expected a number"), "{m}");
    let position = |value: &str| BASE.replace("[0, 1, 5]", value);
    let m = error_at("v3-type", &position("\"far\""), 5, 12);
    assert!(m.contains("expected an array of 3 numbers"), "{m}");
    let m = error_at("v3-five", &position("[0, 1, 5, 6, 7]"), 5, 12);
    assert!(
        m.contains("expected an array of 3 numbers, found 5 elements"),
        "{m}"
    );
    // Elements beyond the third are counted, not read as numbers.
    let m = error_at("v3-tail", &position("[0, 1, 5, \"x\"]"), 5, 12);
    assert!(
        m.contains("expected an array of 3 numbers, found 4 elements"),
        "{m}"
    );
    let m = error_at("v3-one", &position("[0]"), 5, 12);
    assert!(
        m.contains("expected an array of 3 numbers, found 1 element") && !m.contains("elements"),
        "{m}"
    );
    let text = format!(
        "{BASE}[[shape]]\ntype = \"box\"\nmaterial = \"white\"\nmin = [0, 0, 0]\n\
         max = [1, 1, 1]\ntransform = {{ scale = \"big\" }}\n"
    );
    let m = error_at("scale-type", &text, 17, 23);
    assert!(
        m.contains("expected a number or an array of 3 numbers"),
        "{m}"
    );
}

#[test]
fn camera_must_be_well_posed() {
    let m = error_at("look-at", &BASE.replace("[0, 0, 0]", "[0, 1, 5]"), 6, 11);
    assert!(m.contains("look_at must differ from position"), "{m}");
    let m = error_at(
        "up",
        &BASE.replace("up = [0, 1, 0]", "up = [0, -2, -10]"),
        7,
        6,
    );
    assert!(m.contains("parallel"), "{m}");
    let m = error_at("fov", &BASE.replace("fov_y = 40", "fov_y = 0"), 8, 9);
    assert!(m.contains("fov_y must be in (0, 180)"), "{m}");
    let text = BASE.replace(
        "fov_y = 40",
        "fov_y = 40\nshutter_open = 0.5\nshutter_close = 0.5",
    );
    let m = error_at("shutter", &text, 10, 17);
    assert!(m.contains("shutter_close"), "{m}");
}

/// No input may panic: every truncation of a real scene and a batch of
/// byte-level corruptions must come back as Ok or Err.
#[test]
fn corrupted_scenes_never_panic() {
    let text = std::fs::read_to_string(scene_path("tests/shapes.toml")).unwrap();
    let file = scene_path("tests/shapes.toml");
    for_each_corruption(&text, 0x2545_F491_4F6C_DD1D, 2000, |t| {
        let _ = scene_file::parse(t, &file);
    });
}

/// The three many-light scenes carry the `many_light` integrand with their
/// stated parameters, and their light sets the stated shape.
#[test]
fn many_light_scenes_parse_their_integrand_and_light_sets() {
    use mdas::integrand::ManyLightSpec;
    use mdas::lights::registry::SamplerKind;
    let spec = |file: &str| scene_file::load(&scene_path(file)).unwrap();
    let s = spec("cornell_lights.toml");
    assert_eq!(
        s.integrand,
        IntegrandSpec::ManyLight(ManyLightSpec {
            sampler: SamplerKind::Tree,
            cut_size: 8,
            light_samples: 1,
            cut_sampling: Default::default(),
            block: 8,
            interleave: 1,
            time: 0.5,
            frame: 0,
            frame_duration: 4.0 / 512.0,
            vpl: Default::default(),
            sst: Default::default(),
            lgh: Default::default(),
        })
    );
    assert!(s.scene.point_light_sets.is_empty());
    // The Cornell box walls and blocks are cornell.toml's.
    let cornell = spec("cornell.toml");
    for (a, b) in s.scene.meshes[..7].iter().zip(&cornell.scene.meshes[..7]) {
        assert_eq!(a, b);
    }
    for (file, count, orbit) in [
        ("tests/vpl_atrium_points.toml", 100_000, 0.0),
        ("lights_1m.toml", 1_000_000, 0.05),
    ] {
        let s = spec(file);
        assert_eq!(
            s.integrand,
            IntegrandSpec::ManyLight(ManyLightSpec {
                cut_size: 16,
                ..ManyLightSpec::default()
            }),
            "{file}"
        );
        assert_eq!(s.scene.point_light_sets.len(), 1, "{file}");
        assert_eq!(s.scene.point_light_sets[0].len(), count, "{file}");
        assert_eq!(s.scene.point_light_sets[0].orbit_radius, orbit, "{file}");
        assert!(s.scene.lights.is_empty(), "{file}");
        assert!(
            s.scene.materials.iter().all(|m| m.emission == Vec3::ZERO),
            "{file}: lit by its light set only"
        );
    }
}

/// A surface light set scatters its lights over the scene's non-emissive
/// triangles, each moved `offset` along its triangle's normal: over one
/// floor quad (y = 0, normal +y) every light sits at y = offset, inside
/// the quad's extent, for the given offset and for the default (0.01).
#[test]
fn surface_light_set_lifts_its_lights_by_the_offset() {
    let floor = "[[shape]]\ntype = \"quad\"\nmaterial = \"white\"\n\
                 corners = [[-1, 0, -1], [-1, 0, 1], [1, 0, 1], [1, 0, -1]]\n";
    for (offset_line, offset) in [("offset = 0.25\n", 0.25f32), ("", 0.01)] {
        let text = format!(
            "{BASE}{floor}[[light_set]]\ntype = \"surface\"\ncount = 64\n{offset_line}intensity = [1, 1, 1]\n"
        );
        let (_, r) = load_text("light-set-surface", &text);
        let s = r.unwrap();
        let set = &s.scene.point_light_sets[0];
        assert_eq!(set.len(), 64);
        for l in &set.lights {
            // The quad lies in y = 0 exactly, so y is offset · 1 exactly.
            assert_eq!(l.base.y, offset, "{offset_line:?}: {:?}", l.base);
            assert!(
                l.base.x.abs() <= 1.0 && l.base.z.abs() <= 1.0,
                "{:?}",
                l.base
            );
        }
    }
    // A negative offset is refused at its value.
    let text =
        format!("{BASE}{floor}[[light_set]]\ntype = \"surface\"\ncount = 4\noffset = -0.1\nintensity = [1, 1, 1]\n");
    let m = error_at("surface-negative-offset", &text, 19, 10);
    assert!(m.contains("offset must be ≥ 0, found -0.1"), "{m}");
}

#[test]
fn light_set_keys_parse_into_the_set() {
    let text = format!(
        "{BASE}[[light_set]]\ntype = \"grid\"\nmin = [-1, -2]\nmax = [1, 2]\nresolution = [2, 4]\ny = 3\nintensity = [1, 2, 3]\norbit_radius = 0.5\norbit_speed = -2\nseed = 4\n"
    );
    let (_, r) = load_text("light-set-grid", &text);
    let s = r.unwrap();
    let set = &s.scene.point_light_sets[0];
    assert_eq!(
        (set.len(), set.orbit_radius, set.orbit_speed),
        (8, 0.5, -2.0)
    );
    // x fastest, cell centres.
    let bases: Vec<Vec3> = set.lights.iter().map(|l| l.base).collect();
    assert_eq!(bases[0], Vec3::new(-0.5, 3.0, -1.5));
    assert_eq!(bases[1], Vec3::new(0.5, 3.0, -1.5));
    assert_eq!(bases[2], Vec3::new(-0.5, 3.0, -0.5));
    assert_eq!(bases[7], Vec3::new(0.5, 3.0, 1.5));
    // No jitter: every light has the set's intensity.
    assert!(set
        .lights
        .iter()
        .all(|l| l.intensity == Vec3::new(1.0, 2.0, 3.0)));
    // position(t) = base + r·(cos(φ + ωt), 0, sin(φ + ωt)).
    let l = set.lights[5];
    let a = l.phase - 2.0 * 0.75;
    assert!(set
        .position(&l, 0.75)
        .abs_diff_eq(l.base + 0.5 * Vec3::new(a.cos(), 0.0, a.sin()), 1e-6));
    // Without an orbit the light stays at its base.
    let text = text.replace("orbit_radius = 0.5\n", "");
    let (_, r) = load_text("light-set-static", &text);
    let s = r.unwrap();
    let l = s.scene.point_light_sets[0].lights[5];
    assert_eq!(s.scene.point_light_sets[0].position(&l, 9.0), l.base);
    // Unknown top-level keys name light_set among the expected ones.
    let m = error_at("light-sets", &format!("{BASE}[[light_sets]]\n"), 12, 3);
    assert!(
        m.contains("unknown field 'light_sets'") && m.contains("'light_set'"),
        "{m}"
    );
}

/// Issue 54 item 5: accepted values that rendered black are refused at
/// their key: keyframe times and shutter times beyond ±MAX_TIME, a
/// focus distance beyond MAX_COORDINATE, a many-light scene time beyond
/// ±MAX_TIME and `sst_nu_min = 0`. The largest accepted values render
/// lit (tried by hand on 2026-12-07: a time of 10^6 on `moving_lights`,
/// a focus distance of 10^9 on a generated thin-lens scene, neither with
/// the all-black warning).
#[test]
fn values_that_rendered_black_are_refused_at_their_key() {
    let shape = format!("{BASE}[[shape]]\ntype = \"sphere\"\nmaterial = \"white\"\nradius = 1\n");
    let m = error_at(
        "keyframe-time",
        &format!("{shape}motion = [{{ time = -3e38 }}, {{ time = 3e38 }}]\n"),
        16,
        20,
    );
    assert!(m.contains("time must be within ±1e6"), "{m}");
    let camera = |line: &str| BASE.replace("fov_y = 40\n", &format!("fov_y = 40\n{line}\n"));
    let m = error_at("focus-far", &camera("focus_distance = 1e20"), 9, 18);
    assert!(m.contains("focus_distance must be within ±1e9"), "{m}");
    let m = error_at("shutter-far", &camera("shutter_close = 3e38"), 9, 17);
    assert!(m.contains("shutter_close must be within ±1e6"), "{m}");
    let many = |line: &str| format!("{BASE}[integrand]\ntype = \"many_light\"\n{line}\n");
    let m = error_at("light-time", &many("time = 3e38"), 14, 8);
    assert!(m.contains("time must be within ±1e6"), "{m}");
    let m = error_at("nu-min-zero", &many("sst_nu_min = 0"), 14, 14);
    assert!(m.contains("sst_nu_min must be in (0, 1]"), "{m}");
    // Item 8: a heightfield's amplitude that throws its vertices beyond
    // the coordinate bound is named at its own key, not at `min`.
    let field = format!(
        "{BASE}[[shape]]\ntype = \"heightfield\"\nmaterial = \"white\"\nmin = [-1, -1]\nmax = [1, 1]\nresolution = [4, 4]\namplitude = 1e20\n"
    );
    let m = error_at("field-amplitude", &field, 18, 13);
    assert!(m.contains("amplitude must be within ±1e9"), "{m}");
}

/// Issue 54 item 8: a scene file that is not UTF-8 is refused at the first
/// bad byte's line and column (a Latin-1 "é" in a comment on line 4,
/// after "# caf": column 6), not only with the file's name.
#[test]
fn a_file_that_is_not_utf8_is_refused_where_it_stops_being_text() {
    let dir = std::env::temp_dir().join(format!("mdas-scene-format-{}-latin1", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("scene.toml");
    std::fs::write(&path, b"[film]\nwidth = 8\nheight = 6\n# caf\xe9\n").unwrap();
    let e = scene_file::load(&path).expect_err("not UTF-8");
    assert_eq!(e.position(), Some((4, 6)), "{e}");
    assert!(e.to_string().contains("not UTF-8 text"), "{e}");
    std::fs::remove_dir_all(&dir).ok();
}
