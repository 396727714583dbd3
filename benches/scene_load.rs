//! Scene loading of large meshes (issue 51): a Mitsuba scene holding a
//! 1,000,000-triangle binary PLY (a UV sphere of 1000 × 501 with vertex
//! normals, 25 MB), and the same mesh as an OBJ through a TOML scene, each
//! loaded by `SceneFile::load` (read, parse, transform, the degeneracy
//! checks) — no BVH and no GPU. The files are written to a temporary
//! directory first.
//!
//! Run: `cargo bench --bench scene_load`.

use criterion::{criterion_group, criterion_main, Criterion};
use glam::Vec3;
use mdas::scene::shapes;
use mdas::scene_file::SceneFile;
use std::fmt::Write as _;
use std::path::PathBuf;
use std::time::Duration;

fn write_inputs() -> (PathBuf, PathBuf) {
    let dir = std::env::temp_dir().join(format!("mdas-scene-load-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let mesh = shapes::uv_sphere(Vec3::ZERO, 1.0, 1000, 501);
    assert_eq!(mesh.indices.len(), 1_000_000);
    let mut ply = format!(
        "ply\nformat binary_little_endian 1.0\nelement vertex {}\nproperty float x\nproperty float y\n\
         property float z\nproperty float nx\nproperty float ny\nproperty float nz\nelement face {}\n\
         property list uchar int vertex_indices\nend_header\n",
        mesh.positions.len(),
        mesh.indices.len()
    )
    .into_bytes();
    for p in &mesh.positions {
        for c in p.to_array().into_iter().chain(p.normalize().to_array()) {
            ply.extend(c.to_le_bytes());
        }
    }
    for t in &mesh.indices {
        ply.push(3);
        for i in t {
            ply.extend((*i as i32).to_le_bytes());
        }
    }
    std::fs::write(dir.join("sphere.ply"), ply).unwrap();
    let mut obj = String::new();
    for p in &mesh.positions {
        writeln!(obj, "v {} {} {}", p.x, p.y, p.z).unwrap();
    }
    for p in &mesh.positions {
        let n = p.normalize();
        writeln!(obj, "vn {} {} {}", n.x, n.y, n.z).unwrap();
    }
    for t in &mesh.indices {
        let [a, b, c] = t.map(|i| i + 1);
        writeln!(obj, "f {a}//{a} {b}//{b} {c}//{c}").unwrap();
    }
    std::fs::write(dir.join("sphere.obj"), obj).unwrap();
    let sensor = r#"<sensor type="perspective"><float name="fov" value="40"/>
        <transform name="to_world"><lookat origin="0, 0, 5" target="0, 0, 0" up="0, 1, 0"/></transform>
        <film type="hdrfilm"><integer name="width" value="64"/><integer name="height" value="48"/><rfilter type="box"/></film></sensor>"#;
    let xml = dir.join("sphere.xml");
    std::fs::write(
        &xml,
        format!(
            "<scene version=\"3.0.0\"><integrator type=\"direct\"/>{sensor}\
             <shape type=\"ply\"><string name=\"filename\" value=\"sphere.ply\"/></shape></scene>"
        ),
    )
    .unwrap();
    let toml = dir.join("sphere.toml");
    std::fs::write(
        &toml,
        "[film]\nwidth = 64\nheight = 48\n[camera]\nposition = [0, 0, 5]\nlook_at = [0, 0, 0]\n\
         up = [0, 1, 0]\nfov_y = 30\n[[material]]\nname = \"m\"\nalbedo = [0.5, 0.5, 0.5]\n\
         [[shape]]\ntype = \"mesh\"\nfile = \"sphere.obj\"\nmaterial = \"m\"\n",
    )
    .unwrap();
    (xml, toml)
}

fn scene_load(c: &mut Criterion) {
    let (xml, toml) = write_inputs();
    let mut group = c.benchmark_group("scene_load_1m_triangles");
    group
        .sample_size(10)
        .measurement_time(Duration::from_secs(20));
    group.bench_function("mitsuba_xml_binary_ply", |b| {
        b.iter(|| SceneFile::load(&xml).unwrap())
    });
    group.bench_function("toml_obj", |b| b.iter(|| SceneFile::load(&toml).unwrap()));
    group.finish();
    std::fs::remove_dir_all(xml.parent().unwrap()).ok();
}

criterion_group!(benches, scene_load);
criterion_main!(benches);
