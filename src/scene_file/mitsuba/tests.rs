//! The Mitsuba subset against Mitsuba's conventions, stated as closed
//! forms: the camera frame and field-of-view axes, the shapes' extents and
//! normals, transform order, sidedness, and which integrand a file maps
//! to. (Images are checked against Mitsuba itself by `make crosscheck`.)

use super::super::SceneFile;
use super::parse;
use crate::integrand::IntegrandSpec;
use crate::scene::Light;
use glam::Vec3;
use std::path::Path;

const SENSOR: &str = r#"
  <sensor type="perspective">
    <float name="fov" value="60"/>
    <transform name="to_world"><lookat origin="1, 2, 3" target="1, 2, 0" up="0, 1, 0"/></transform>
    <film type="hdrfilm"><integer name="width" value="40"/><integer name="height" value="20"/><rfilter type="box"/></film>
    <sampler type="independent"><integer name="sample_count" value="12"/></sampler>
  </sensor>"#;

fn scene(body: &str) -> String {
    format!("<scene version=\"3.0.0\">\n<integrator type=\"direct\"/>{SENSOR}\n{body}\n</scene>\n")
}

fn load(text: &str) -> SceneFile {
    parse(text, Path::new("inline.xml")).unwrap_or_else(|e| panic!("{e}\n{text}"))
}

fn error(text: &str) -> String {
    parse(text, Path::new("inline.xml"))
        .unwrap_err()
        .to_string()
}

fn close(a: Vec3, b: Vec3) -> bool {
    (a - b).length() < 1e-5
}

#[test]
fn the_camera_follows_mitsubas_frame_and_fov_axes() {
    let s = load(&scene(""));
    let c = s.scene.camera;
    assert!(close(c.position, Vec3::new(1.0, 2.0, 3.0)));
    assert!(close(
        (c.look_at - c.position).normalize(),
        Vec3::new(0.0, 0.0, -1.0)
    ));
    assert!(close(c.up, Vec3::Y));
    // fov_axis x (the default): tan(fov_y/2) = tan(30°)·H/W.
    let want = (2.0 * (30f64.to_radians().tan() * 20.0 / 40.0).atan()).to_degrees();
    assert!(
        (c.fov_y as f64 - want).abs() < 1e-4,
        "{} vs {want}",
        c.fov_y
    );
    assert_eq!((s.scene.film.width, s.scene.film.height), (40, 20));
    assert_eq!(s.mdas.spp, 12.0, "sample_count is the MDAS budget");
    for (axis, tan_y) in [
        ("y", 30f64.to_radians().tan()),
        ("smaller", 30f64.to_radians().tan()),
        ("larger", 30f64.to_radians().tan() * 0.5),
        (
            "diagonal",
            30f64.to_radians().tan() * 20.0 / (40f64.powi(2) + 20f64.powi(2)).sqrt(),
        ),
    ] {
        let text = scene("").replace(
            r#"<float name="fov" value="60"/>"#,
            &format!(r#"<float name="fov" value="60"/><string name="fov_axis" value="{axis}"/>"#),
        );
        let fov_y = load(&text).scene.camera.fov_y as f64;
        let want = (2.0 * tan_y.atan()).to_degrees();
        assert!((fov_y - want).abs() < 1e-4, "{axis}: {fov_y} vs {want}");
    }
}

/// A fov inside (0, 180) in f64 whose vertical field of view is 180 as
/// the f32 the GPU uses (an upside-down image) is refused at the fov's
/// element, on every axis (issue 67, hostile inputs class 2); so is one
/// whose f32 is 0.
#[test]
fn the_fov_is_checked_as_the_f32_the_gpu_uses() {
    for axis in ["x", "y", "smaller", "larger", "diagonal"] {
        for fov in ["179.99999999", "1e-44"] {
            let text = scene("").replace(
                r#"<float name="fov" value="60"/>"#,
                &format!(
                    r#"<float name="fov" value="{fov}"/><string name="fov_axis" value="{axis}"/>"#
                ),
            );
            let e = error(&text);
            assert!(
                e.starts_with(&format!(
                    "inline.xml:4:5: fov {fov} gives a vertical field of view of "
                )),
                "{axis} {fov}: {e}"
            );
            assert!(e.contains("it must be in (0, 180)"), "{e}");
        }
    }
}

#[test]
fn a_mirrored_or_sheared_camera_is_refused() {
    let mirrored = scene("").replace(
        r#"<lookat origin="1, 2, 3" target="1, 2, 0" up="0, 1, 0"/>"#,
        r#"<scale x="-1"/>"#,
    );
    assert!(error(&mirrored).contains("must be rigid"));
    let rotated = scene("").replace(
        r#"<lookat origin="1, 2, 3" target="1, 2, 0" up="0, 1, 0"/>"#,
        r#"<rotate y="1" angle="90"/><scale value="2"/>"#,
    );
    // A rotation about y by 90° turns +z (the view) into +x.
    let c = load(&rotated).scene.camera;
    assert!(close((c.look_at - c.position).normalize(), Vec3::X));
}

#[test]
fn shapes_have_mitsubas_extent_and_normals() {
    let s = load(&scene(
        r#"<shape type="rectangle"/>
           <shape type="cube"/>
           <shape type="disk"/>
           <shape type="sphere"><point name="center" x="0" y="5" z="0"/><float name="radius" value="2"/></shape>"#,
    ));
    let m = &s.scene.meshes;
    let tri = |k: usize| crate::scene::shapes::TriMesh {
        positions: m[k].positions.clone(),
        indices: m[k].indices.clone(),
        normals: m[k].normals.clone(),
    };
    let rect = tri(0);
    assert!((rect.area() - 4.0).abs() < 1e-6, "rectangle [-1,1]²");
    assert!(close(rect.face_normal(0).normalize(), Vec3::Z), "facing +z");
    let cube = tri(1);
    assert!(
        (cube.signed_volume() - 8.0).abs() < 1e-5,
        "cube [-1,1]³, outward"
    );
    let disk = tri(2);
    assert!(
        (disk.area() / std::f64::consts::PI - 1.0).abs() < 2e-4,
        "unit disk within 2e-4"
    );
    assert!(close(disk.face_normal(0).normalize(), Vec3::Z));
    let sphere = tri(3);
    let want = 4.0 * std::f64::consts::PI * 4.0;
    assert!((sphere.area() / want - 1.0).abs() < 1e-5, "sphere area");
    assert!(sphere.signed_volume() > 0.0, "outward");
    assert!(sphere
        .positions
        .iter()
        .zip(&sphere.normals)
        .all(|(p, n)| close(*n, (*p - Vec3::new(0.0, 5.0, 0.0)).normalize())));
    // Mitsuba's default BSDF: one-sided diffuse, reflectance 0.5.
    let mat = &s.scene.materials[m[0].material as usize];
    assert_eq!(mat.albedo, Vec3::splat(0.5));
    assert!(mat.one_sided);
}

#[test]
fn transforms_compose_in_order_and_matrices_are_row_major() {
    // Translate, then rotate 90° about z: (1,1,0) + (2,0,0) → (3,1,0) → (-1,3,0).
    let s = load(&scene(
        r#"<shape type="rectangle"><transform name="to_world"><translate x="2"/><rotate z="1" angle="90"/></transform></shape>
           <shape type="rectangle"><transform name="to_world"><matrix value="1 0 0 5  0 1 0 6  0 0 1 7  0 0 0 1"/></transform></shape>"#,
    ));
    let p = &s.scene.meshes[0].positions;
    assert!(
        p.iter().any(|v| close(*v, Vec3::new(-1.0, 3.0, 0.0))),
        "{p:?}"
    );
    let q = &s.scene.meshes[1].positions;
    assert!(
        q.iter().any(|v| close(*v, Vec3::new(6.0, 7.0, 7.0))),
        "{q:?}"
    );
}

#[test]
fn sidedness_flip_normals_and_mirrors_follow_mitsuba() {
    let s = load(&scene(
        r#"<bsdf type="twosided" id="two"><bsdf type="diffuse"><rgb name="reflectance" value="0.25, 0.5, 0.75"/></bsdf></bsdf>
           <shape type="rectangle"><ref id="two"/><boolean name="flip_normals" value="true"/></shape>
           <shape type="rectangle"><transform name="to_world"><scale z="-1"/></transform></shape>
           <shape type="cube"><transform name="to_world"><scale x="-1"/></transform></shape>"#,
    ));
    let m = &s.scene.meshes;
    let mat = &s.scene.materials[m[0].material as usize];
    assert!(!mat.one_sided);
    assert_eq!(mat.albedo, Vec3::new(0.25, 0.5, 0.75));
    let normal = |k: usize| {
        let [a, b, c] = m[k].indices[0].map(|i| m[k].positions[i as usize]);
        (b - a).cross(c - a).normalize()
    };
    assert!(close(normal(0), -Vec3::Z), "flip_normals");
    assert!(
        close(normal(1), -Vec3::Z),
        "an analytic shape's normal turns with the inverse transpose"
    );
    // A mesh keeps its winding under a mirror: the mirrored cube's faces
    // point inward (negative volume), as in Mitsuba.
    let cube = crate::scene::shapes::TriMesh::new(m[2].positions.clone(), m[2].indices.clone());
    assert!(cube.signed_volume() < 0.0);
}

#[test]
fn emitters_and_integrators_map_to_the_matching_integrand() {
    let area = r#"<shape type="rectangle"><emitter type="area"><rgb name="radiance" value="2, 3, 4"/></emitter></shape>"#;
    let point = r#"<emitter type="point"><point name="position" x="0" y="4" z="0"/><rgb name="intensity" value="5"/></emitter>"#;
    let sun = r#"<emitter type="directional"><vector name="direction" x="0" y="-2" z="0"/><rgb name="irradiance" value="3"/></emitter>"#;
    let s = load(&scene(area));
    assert_eq!(s.integrand, IntegrandSpec::AreaLight);
    assert_eq!(s.scene.materials[0].emission, Vec3::new(2.0, 3.0, 4.0));
    let s = load(&scene(&format!("{point}{sun}")));
    assert_eq!(s.integrand, IntegrandSpec::DepthOfField);
    assert_eq!(
        s.scene.lights,
        vec![
            Light::Point {
                position: Vec3::new(0.0, 4.0, 0.0),
                intensity: Vec3::splat(5.0)
            },
            Light::Directional {
                direction: -Vec3::Y,
                irradiance: Vec3::splat(3.0)
            }
        ]
    );
    assert!(matches!(
        load(&scene(&format!("{area}{point}"))).integrand,
        IntegrandSpec::ManyLight(_)
    ));
    assert!(error(&scene(&format!("{area}{sun}"))).contains("area and directional"));
    let path = |depth: i64| {
        scene(area).replace(
            r#"<integrator type="direct"/>"#,
            &format!(
                r#"<integrator type="path"><integer name="max_depth" value="{depth}"/></integrator>"#
            ),
        )
    };
    assert_eq!(
        load(&path(4)).integrand,
        IntegrandSpec::PathTracing { max_bounces: 2 }
    );
    assert_eq!(load(&path(2)).integrand, IntegrandSpec::AreaLight);
    assert!(error(&path(9)).contains("at most 3 with area lights"));
    assert!(error(&path(-1)).contains("finite max_depth"));
    let lens = scene(area).replace(
        r#"<sensor type="perspective">"#,
        r#"<sensor type="thinlens"><float name="aperture_radius" value="0.1"/><float name="focus_distance" value="3"/>"#,
    );
    assert!(error(&lens).contains("thinlens sensor with area emitters"));
    let lens = lens.replace(area, point);
    let s = load(&lens);
    assert_eq!(s.integrand, IntegrandSpec::DepthOfField);
    assert_eq!(s.scene.camera.aperture_radius, 0.1);
    assert_eq!(s.scene.camera.focus_distance, 3.0);
}

#[test]
fn defaults_and_includes_are_read_and_errors_point_into_the_right_file() {
    let dir = std::env::temp_dir().join(format!("mdas-mitsuba-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(
        dir.join("common.xml"),
        "<scene version=\"3.0.0\">\n  <bsdf type=\"diffuse\" id=\"red\"><rgb name=\"reflectance\" value=\"$r, 0, 0\"/></bsdf>\n</scene>\n",
    )
    .unwrap();
    let main = scene(
        r#"<default name="r" value="0.7"/><include filename="common.xml"/><shape type="cube"><ref id="red"/></shape>"#,
    );
    let path = dir.join("main.xml");
    std::fs::write(&path, &main).unwrap();
    let s = super::super::load(&path).unwrap();
    assert_eq!(s.scene.materials[0].albedo, Vec3::new(0.7, 0.0, 0.0));
    assert_eq!(s.inputs, vec![dir.join("common.xml")]);
    // The included file's error names it, line and column.
    std::fs::write(
        dir.join("common.xml"),
        "<scene version=\"3.0.0\">\n  <bsdf type=\"diffuse\" id=\"red\"><rgb name=\"reflectance\" value=\"$g, 0, 0\"/></bsdf>\n</scene>\n",
    )
    .unwrap();
    let e = super::super::load(&path).unwrap_err();
    // Line 2, the value's first character (after 63 characters of tags).
    assert_eq!(e.position(), Some((2, 64)), "{e}");
    assert!(
        e.to_string()
            .contains("common.xml:2:64: '$g' names no parameter"),
        "{e}"
    );
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn anything_outside_the_subset_is_an_error_at_its_position() {
    // (body, message, where the error points: the first character of
    // this text in the body)
    let cases: &[(&str, &str, &str)] = &[
        (
            r#"<shape type="cylinder"/>"#,
            "unsupported shape 'cylinder'",
            "cylinder",
        ),
        (
            r#"<emitter type="spot"/>"#,
            "unsupported emitter 'spot'",
            "spot",
        ),
        (
            r#"<shape type="cube"><float name="radius" value="2"/></shape>"#,
            "shape 'cube' has no property 'radius'",
            "radius",
        ),
        (
            r#"<shape type="cube"><bsdf type="diffuse"><rgb name="reflectance" value="1.5"/></bsdf></shape>"#,
            "reflectance must be in [0, 1]",
            "1.5",
        ),
        (
            r#"<shape type="rectangle"><emitter type="area"><rgb name="radiance" value="-1"/></emitter></shape>"#,
            "radiance must be in [0, 1e20]",
            "-1",
        ),
        (
            r#"<shape type="cube"><float name="flip_normals" value="1"/></shape>"#,
            "is a float, expected a <boolean>",
            "<float",
        ),
        (
            r#"<film type="hdrfilm"/>"#,
            "<film> is not supported here",
            "<film",
        ),
    ];
    for (body, want, needle) in cases {
        let text = scene(body);
        let e = parse(&text, Path::new("inline.xml")).unwrap_err();
        assert!(e.to_string().contains(want), "{e} should say {want:?}");
        let (line, line_text) = text
            .lines()
            .enumerate()
            .find(|(_, l)| l.contains(body))
            .unwrap();
        let column = line_text.find(body).unwrap() + body.find(needle).unwrap() + 1;
        assert_eq!(e.position(), Some((line + 1, column)), "{e}");
    }
    assert!(error("<scene version=\"3.0.0\"></scene>").contains("no <sensor>"));
    assert!(
        error(&scene("").replace("<integrator type=\"direct\"/>", "")).contains("no <integrator>")
    );
}

#[test]
fn emitters_without_a_bsdf_reflect_nothing_and_meshes_without_normals_are_smooth() {
    let s = load(&scene(
        r#"<shape type="rectangle"><emitter type="area"/></shape><shape type="cube"/>"#,
    ));
    let m = &s.scene.materials;
    // Mitsuba (3.9.1, by rendering): an emitter without a BSDF is black,
    // a plain shape without one a diffuse 0.5.
    assert_eq!(m[s.scene.meshes[0].material as usize].albedo, Vec3::ZERO);
    assert_eq!(m[s.scene.meshes[0].material as usize].emission, Vec3::ONE);
    assert_eq!(
        m[s.scene.meshes[1].material as usize].albedo,
        Vec3::splat(0.5)
    );

    // A regular octahedron without normals: by symmetry each vertex's
    // angle-weighted normal is radial; with face_normals there are none.
    let dir = std::env::temp_dir().join(format!("mdas-mitsuba-ply-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let v = "1 0 0\n-1 0 0\n0 1 0\n0 -1 0\n0 0 1\n0 0 -1\n";
    let f = "3 0 2 4\n3 2 1 4\n3 1 3 4\n3 3 0 4\n3 2 0 5\n3 1 2 5\n3 3 1 5\n3 0 3 5\n";
    std::fs::write(
        dir.join("octahedron.ply"),
        format!(
            "ply\nformat ascii 1.0\nelement vertex 6\nproperty float x\nproperty float y\nproperty float z\n\
             element face 8\nproperty list uchar int vertex_indices\nend_header\n{v}{f}"
        ),
    )
    .unwrap();
    let shapes = r#"<shape type="ply"><string name="filename" value="octahedron.ply"/>
          <transform name="to_world"><translate x="3"/></transform></shape>
        <shape type="ply"><string name="filename" value="octahedron.ply"/>
          <boolean name="face_normals" value="true"/></shape>"#;
    let path = dir.join("octahedron.xml");
    std::fs::write(&path, scene(shapes)).unwrap();
    let s = super::super::load(&path).unwrap();
    let smooth = &s.scene.meshes[0];
    assert_eq!(smooth.normals.len(), 6);
    for (p, n) in smooth.positions.iter().zip(&smooth.normals) {
        assert!(close(*n, *p - Vec3::new(3.0, 0.0, 0.0)), "{p}: {n}");
    }
    assert!(s.scene.meshes[1].normals.is_empty());
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn an_mdas_table_beside_the_file_sets_mdas_parameters() {
    let dir = std::env::temp_dir().join(format!("mdas-mitsuba-side-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("scene.xml");
    std::fs::write(&path, scene("")).unwrap();
    let side = dir.join("scene.mdas.toml");
    std::fs::write(&side, "[mdas]\nalpha = 3\n").unwrap();
    let s = super::super::load(&path).unwrap();
    assert_eq!(s.mdas.alpha, 3.0);
    assert_eq!(
        s.mdas.spp, 12.0,
        "spp defaults to the sampler's sample_count"
    );
    assert_eq!(s.inputs, vec![side.clone()]);
    std::fs::write(&side, "[mdas]\nspp = 5\nalpha = 3\n").unwrap();
    assert_eq!(super::super::load(&path).unwrap().mdas.spp, 5.0);
    std::fs::write(&side, "[mdas]\nalpha = 3\nbogus = 1\n").unwrap();
    let e = super::super::load(&path).unwrap_err();
    assert!(
        e.to_string()
            .contains("scene.mdas.toml:3:1: unknown field 'bogus'"),
        "{e}"
    );
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn checkerboards_read_mitsubas_texture_and_its_coordinates() {
    let checker = |shape: &str| {
        scene(&format!(
            r#"<shape type="{shape}"><bsdf type="diffuse"><texture type="checkerboard" name="reflectance">
                 <rgb name="color1" value="0.1, 0.2, 0.3"/>
                 <transform name="to_uv"><scale x="3" y="2"/><rotate z="1" angle="90"/><translate x="0.5"/></transform>
               </texture></bsdf></shape>"#
        ))
    };
    let s = load(&checker("rectangle"));
    let m = &s.scene.materials[0];
    assert_eq!(m.albedo, Vec3::splat(0.4), "Mitsuba's color0 default");
    let c = m.uv_checker.unwrap();
    assert_eq!(c.albedo2, Vec3::new(0.1, 0.2, 0.3));
    // Scale, then a quarter turn, then translate: (u, v) → (−2v + 0.5, 3u).
    let close2 = |a: [f32; 3], b: [f32; 3]| a.iter().zip(b).all(|(x, y)| (x - y).abs() < 1e-6);
    assert!(
        close2(c.to_uv[0], [0.0, -2.0, 0.5]) && close2(c.to_uv[1], [3.0, 0.0, 0.0]),
        "{c:?}"
    );
    let mesh = &s.scene.meshes[0];
    assert_eq!(mesh.uvs.len(), 4);
    for (p, uv) in mesh.positions.iter().zip(&mesh.uvs) {
        assert_eq!(
            *uv,
            (p.truncate() + glam::Vec2::ONE) / 2.0,
            "rectangle uv = ((x+1)/2, (y+1)/2)"
        );
    }
    // Mitsuba's cube: 24 vertices, every face's corners (0,1) (1,1) (1,0) (0,0).
    let cube = &load(&checker("cube")).scene.meshes[0];
    assert_eq!(
        (cube.positions.len(), cube.indices.len(), cube.uvs.len()),
        (24, 12, 24)
    );
    for shape in ["sphere", "disk"] {
        assert!(
            error(&checker(shape)).contains("needs texture coordinates"),
            "{shape}"
        );
    }
    let bitmap = scene(
        r#"<shape type="cube"><bsdf type="diffuse"><texture type="bitmap" name="reflectance"/></bsdf></shape>"#,
    );
    assert!(error(&bitmap).contains("unsupported texture 'bitmap'"));
}

/// Amplification is refused before the work, with an error that names the
/// limit (issue 67, hostile inputs class 1): `<default>`s that expand each
/// other (here 16 copies a level: 64 bytes became 17 GB), includes fanned
/// out (each file including the next 20 times: 8,000 documents), and a
/// scene whose shapes pass its triangle budget (checked before the shape
/// that passes it is tessellated; a budget of three spheres here, the
/// real one is `MAX_SCENE_TRIANGLES`). Nested `twosided` wrappers are
/// read in a loop: 20,000 of them load as one two-sided BSDF.
#[test]
fn amplification_is_refused_before_the_work() {
    let mut defaults = String::from(r#"<default name="a0" value="0.5"/>"#);
    for i in 1..8 {
        let value = format!("$a{}", i - 1).repeat(16);
        defaults += &format!(r#"<default name="a{i}" value="{value}"/>"#);
    }
    let e = error(&scene(&defaults));
    assert!(e.contains("beyond the limit of 16 MiB"), "{e}");

    let dir = std::env::temp_dir().join(format!("mdas-fanout-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    for i in 0..4 {
        let body = match i {
            3 => String::new(),
            _ => format!(r#"<include filename="f{}.xml"/>"#, i + 1).repeat(20),
        };
        std::fs::write(
            dir.join(format!("f{i}.xml")),
            format!(r#"<scene version="3.0.0">{body}</scene>"#),
        )
        .unwrap();
    }
    let main = dir.join("main.xml");
    std::fs::write(&main, scene(r#"<include filename="f0.xml"/>"#)).unwrap();
    let e = super::super::load(&main).unwrap_err().to_string();
    assert!(e.contains("more than 256 documents"), "{e}");
    // Two includes of a 9 MiB file pass the 16 MiB of a scene's documents
    // together: the second is refused before it is read.
    let comment = "x".repeat(9 << 20);
    std::fs::write(
        dir.join("big.xml"),
        format!(r#"<scene version="3.0.0"><!-- {comment} --></scene>"#),
    )
    .unwrap();
    std::fs::write(
        &main,
        scene(r#"<include filename="big.xml"/><include filename="big.xml"/>"#),
    )
    .unwrap();
    let e = super::super::load(&main).unwrap_err().to_string();
    assert!(
        e.contains("beyond the limit of 16 MiB for a file and its includes"),
        "{e}"
    );
    std::fs::remove_dir_all(&dir).ok();

    let sphere = crate::scene::shapes::uv_sphere_triangles(
        super::plugins::SPHERE_SEGMENTS as u64,
        super::plugins::SPHERE_RINGS as u64,
    );
    let spheres = |n: usize| scene(&r#"<shape type="sphere"/>"#.repeat(n));
    let path = Path::new("inline.xml");
    let s = super::parse_within(&spheres(3), path, 3 * sphere).unwrap();
    assert_eq!(
        s.scene
            .meshes
            .iter()
            .map(|m| m.indices.len() as u64)
            .sum::<u64>(),
        3 * sphere
    );
    let e = super::parse_within(&spheres(4), path, 3 * sphere)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains(&format!(
            "this shape makes {sphere} triangles, more than the 0 the scene may still take"
        )),
        "{e}"
    );

    let n = 20_000;
    let nested = format!(
        r#"<shape type="cube">{}<bsdf type="diffuse"/>{}</shape>"#,
        r#"<bsdf type="twosided">"#.repeat(n),
        "</bsdf>".repeat(n)
    );
    let s = load(&scene(&nested));
    assert!(!s.scene.materials[0].one_sided);
}
