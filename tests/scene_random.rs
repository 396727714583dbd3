//! Random scenes (`mdas scene random`, src/scene_gen.rs): every
//! integrand's scenes load for many seeds, with the integrand asked for and
//! no `[mdas]` table; the same seed gives the same text; the camera sees
//! the objects; the variety the generator promises is there; and the CLI
//! writes files atomically and refuses special files. CPU only.

use glam::Vec3;
use mdas::accel::{BuiltScene, Ray};
use mdas::integrand::IntegrandSpec;
use mdas::integrator::mdas::MdasParams;
use mdas::lights::scene_lights::light_count;
use mdas::scene::motion::transform_at;
use mdas::scene::{Mesh, Scene};
use mdas::scene_file::{self, SceneFile};
use mdas::scene_gen::{random_scene, GenIntegrand, GenOptions, GENERATOR_VERSION};
use std::collections::HashSet;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

const SEEDS: u64 = 24;

fn load(kind: GenIntegrand, seed: u64, opts: &GenOptions) -> (String, SceneFile) {
    let text = random_scene(kind, seed, opts);
    let file = format!("random-{kind}-{seed}.toml");
    match scene_file::parse(&text, Path::new(&file)) {
        Ok(scene) => (text, scene),
        Err(e) => panic!("{kind} seed {seed} does not load: {e}\n{text}"),
    }
}

/// Every kind's scenes for seeds 0..SEEDS at the default film.
fn all_scenes() -> Vec<(GenIntegrand, u64, String, SceneFile)> {
    let opts = GenOptions::default();
    GenIntegrand::ALL
        .into_iter()
        .flat_map(|kind| (0..SEEDS).map(move |seed| (kind, seed)))
        .map(|(kind, seed)| {
            let (text, scene) = load(kind, seed, &opts);
            (kind, seed, text, scene)
        })
        .collect()
}

/// A mesh's vertices in world space at scene time `time`.
fn world(mesh: &Mesh, time: f32) -> Vec<Vec3> {
    if mesh.motion.is_empty() {
        return mesh.positions.clone();
    }
    let rigid = transform_at(&mesh.motion, time);
    mesh.positions
        .iter()
        .map(|&p| rigid.apply_point(p))
        .collect()
}

fn bounds(points: &[Vec3]) -> (Vec3, Vec3) {
    points.iter().fold(
        (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
        |(lo, hi), &p| (lo.min(p), hi.max(p)),
    )
}

fn is_emissive(scene: &Scene, mesh: &Mesh) -> bool {
    scene.materials[mesh.material as usize]
        .emission
        .max_element()
        > 0.0
}

fn area(points: &[Vec3], mesh: &Mesh) -> f32 {
    mesh.indices
        .iter()
        .map(|&[a, b, c]| {
            let [a, b, c] = [a, b, c].map(|i| points[i as usize]);
            0.5 * (b - a).cross(c - a).length()
        })
        .sum()
}

/// The camera's frame as docs/scene-format.md defines it: f, r, u and the
/// tangents of the half fields of view.
struct View {
    eye: Vec3,
    f: Vec3,
    r: Vec3,
    u: Vec3,
    tan_y: f32,
    tan_x: f32,
}

impl View {
    fn of(scene: &Scene) -> View {
        let c = scene.camera;
        let f = (c.look_at - c.position).normalize();
        let r = f.cross(c.up).normalize();
        let u = r.cross(f);
        let tan_y = (c.fov_y.to_radians() / 2.0).tan();
        let aspect = scene.film.width as f32 / scene.film.height as f32;
        View {
            eye: c.position,
            f,
            r,
            u,
            tan_y,
            tan_x: tan_y * aspect,
        }
    }

    /// Normalized device coordinates (x right, y up, the film is
    /// [−1, 1]²) of a point in front of the camera.
    fn ndc(&self, p: Vec3) -> Option<(f32, f32)> {
        let d = p - self.eye;
        let z = d.dot(self.f);
        (z > 0.0).then(|| {
            (
                d.dot(self.r) / (z * self.tan_x),
                d.dot(self.u) / (z * self.tan_y),
            )
        })
    }

    fn ray(&self, nx: f32, ny: f32, time: f32) -> Ray {
        let dir = self.f + self.r * (nx * self.tan_x) + self.u * (ny * self.tan_y);
        Ray {
            origin: self.eye.into(),
            t_max: f32::INFINITY,
            dir: dir.into(),
            time,
        }
    }
}

#[test]
fn every_kind_loads_for_every_seed_with_its_integrand_and_no_mdas_table() {
    for (kind, seed, text, s) in all_scenes() {
        let what = format!("{kind} seed {seed}");
        assert_eq!(s.integrand.type_name(), kind.name(), "{what}");
        assert_eq!(
            (s.scene.film.width, s.scene.film.height),
            (128, 96),
            "{what}"
        );
        assert_eq!(s.mdas, MdasParams::for_film(s.scene.film), "{what}");
        assert!(
            !text.lines().any(|l| l.trim_start().starts_with("[mdas")),
            "{what} has an [mdas] table"
        );
        // The header says what made it and how to make it again.
        let first: Vec<&str> = text.lines().take(2).collect();
        assert!(
            first[0].contains(&format!("scene_gen v{GENERATOR_VERSION}"))
                && first[1].contains(&format!(
                    "mdas scene random --integrand {kind} --seed {seed} --width 128 --height 96"
                )),
            "{what}: header {first:?}"
        );
        // The integrand has light to work with (no "lit by nothing").
        let warnings = s.integrand.light_warnings(&s.scene);
        assert!(warnings.is_empty(), "{what}: {warnings:?}");
        // The renderer accepts the geometry (no piles of coincident
        // triangles, bounded coordinates).
        if let Err(e) = BuiltScene::new(&s.scene) {
            panic!("{what}: {e:#}");
        }
        let objects = s
            .scene
            .meshes
            .iter()
            .filter(|m| m.name.starts_with("obj"))
            .count();
        assert!((2..=40).contains(&objects), "{what}: {objects} objects");
        match (&s.integrand, kind) {
            (IntegrandSpec::PathTracing { max_bounces }, GenIntegrand::Path) => {
                let emissive = s.scene.meshes.iter().any(|m| is_emissive(&s.scene, m));
                let limit = if emissive { 3 } else { 4 };
                assert!((1..=limit).contains(max_bounces), "{what}: {max_bounces}");
            }
            (IntegrandSpec::AmbientOcclusion { radius }, _) => assert!(*radius > 0.0, "{what}"),
            (IntegrandSpec::ManyLight(spec), _) => {
                assert_eq!(spec.sampler.name(), "tree", "{what}: the default sampler");
                let n = light_count(&s.scene);
                assert!((16..=2000).contains(&n), "{what}: {n} lights");
            }
            (IntegrandSpec::DepthOfField, _) => {
                let c = s.scene.camera;
                assert!(c.aperture_radius > 0.0 && c.focus_distance > 0.0, "{what}");
            }
            (IntegrandSpec::MotionBlur, _) => {
                let c = s.scene.camera;
                assert!(c.shutter_close > c.shutter_open, "{what}");
            }
            (IntegrandSpec::AreaLight, _) => {}
            (other, _) => panic!("{what}: unexpected integrand {other:?}"),
        }
    }
}

#[test]
fn the_same_seed_gives_the_same_text_and_seeds_differ() {
    let opts = GenOptions::default();
    for kind in GenIntegrand::ALL {
        let texts: Vec<String> = (0..SEEDS).map(|s| random_scene(kind, s, &opts)).collect();
        for (seed, text) in texts.iter().enumerate() {
            assert_eq!(
                text,
                &random_scene(kind, seed as u64, &opts),
                "{kind} seed {seed}"
            );
        }
        let distinct: HashSet<&String> = texts.iter().collect();
        assert_eq!(distinct.len(), SEEDS as usize, "{kind}: repeated scenes");
    }
    // Another film: written as asked and framed for its aspect ratio.
    let wide = GenOptions {
        width: 320,
        height: 100,
    };
    let (text, s) = load(GenIntegrand::Path, 5, &wide);
    assert_eq!((s.scene.film.width, s.scene.film.height), (320, 100));
    assert_eq!(s.mdas, MdasParams::for_film(s.scene.film));
    assert_ne!(text, random_scene(GenIntegrand::Path, 5, &opts));
    assert_ne!(
        random_scene(GenIntegrand::Path, 5, &opts),
        random_scene(GenIntegrand::AreaLight, 5, &opts),
        "each integrand has its own stream"
    );
}

#[test]
fn the_camera_sees_the_scene() {
    for (kind, seed, _, s) in all_scenes() {
        let what = format!("{kind} seed {seed}");
        let scene = &s.scene;
        let time = scene.camera.shutter_open;
        let view = View::of(scene);
        // The look-at point lies within the shapes' bounds.
        let points: Vec<Vec3> = scene
            .meshes
            .iter()
            .filter(|m| !is_emissive(scene, m))
            .flat_map(|m| world(m, time))
            .collect();
        let (lo, hi) = bounds(&points);
        let at = scene.camera.look_at;
        assert!(
            at.cmpge(lo).all() && at.cmple(hi).all(),
            "{what}: look_at {at} outside the shapes' bounds {lo}..{hi}"
        );
        // Rays through the film centre and most of a 5 × 5 grid hit geometry.
        let built = BuiltScene::new(scene).unwrap();
        assert!(
            built
                .brute_force_closest(&view.ray(0.0, 0.0, time))
                .is_hit(),
            "{what}: the film centre sees nothing"
        );
        let grid = [-0.8, -0.4, 0.0, 0.4, 0.8];
        let hits = grid
            .iter()
            .flat_map(|&x| grid.iter().map(move |&y| (x, y)))
            .filter(|&(x, y)| built.brute_force_closest(&view.ray(x, y, time)).is_hit())
            .count();
        assert!(hits >= 11, "{what}: {hits} of 25 film rays hit geometry");
        // Most objects' centres project inside the film.
        let objects: Vec<Vec3> = scene
            .meshes
            .iter()
            .filter(|m| m.name.starts_with("obj"))
            .map(|m| {
                let (lo, hi) = bounds(&world(m, time));
                (lo + hi) / 2.0
            })
            .collect();
        let inside = objects
            .iter()
            .filter(|&&c| matches!(view.ndc(c), Some((x, y)) if x.abs() <= 1.0 && y.abs() <= 1.0))
            .count();
        assert!(
            2 * inside >= objects.len(),
            "{what}: {inside} of {} object centres in view",
            objects.len()
        );
    }
}

#[test]
fn the_scenes_vary_as_promised() {
    let scenes = all_scenes();
    let of = |k: GenIntegrand| scenes.iter().filter(move |(kind, ..)| *kind == k);

    // area_light: a light the camera sees (its centre in the film, facing
    // the camera, nothing in front of it) and a tiny bright one.
    let (mut in_view, mut tiny, mut several) = (0, 0, 0);
    for (_, seed, _, s) in of(GenIntegrand::AreaLight) {
        let scene = &s.scene;
        let view = View::of(scene);
        let built = BuiltScene::new(scene).unwrap();
        let all: Vec<Vec3> = scene
            .meshes
            .iter()
            .filter(|m| m.name.starts_with("obj"))
            .flat_map(|m| world(m, 0.0))
            .collect();
        let (lo, hi) = bounds(&all);
        let diagonal = (hi - lo).length();
        let lights: Vec<usize> = (0..scene.meshes.len())
            .filter(|&i| is_emissive(scene, &scene.meshes[i]))
            .collect();
        assert!(
            !lights.is_empty(),
            "area_light seed {seed} has no area light"
        );
        several += usize::from(lights.len() > 1);
        let mut seen = false;
        for &i in &lights {
            let mesh = &scene.meshes[i];
            let points = world(mesh, 0.0);
            let radiance = scene.materials[mesh.material as usize].emission;
            if area(&points, mesh) <= 1e-3 * diagonal * diagonal && radiance.max_element() >= 100.0
            {
                tiny += 1;
            }
            let [a, b, c] = mesh.indices[0].map(|v| points[v as usize]);
            let centre = (a + b + c) / 3.0;
            let facing = (b - a).cross(c - a).dot(view.eye - centre) > 0.0;
            let Some((x, y)) = view.ndc(centre) else {
                continue;
            };
            if !facing || x.abs() > 1.0 || y.abs() > 1.0 {
                continue;
            }
            let hit = built.brute_force_closest(&Ray {
                origin: view.eye.into(),
                t_max: 1.01,
                dir: (centre - view.eye).into(),
                time: 0.0,
            });
            if hit.is_hit() && built.source[hit.prim as usize][0] as usize == i {
                seen = true;
            }
        }
        in_view += usize::from(seen);
    }
    assert!(in_view >= 1, "no area_light scene shows its light");
    assert!(tiny >= 1, "no area_light scene has a tiny bright light");
    assert!(several >= 1, "every area_light scene has one light");

    // motion_blur: every scene moves something, most keep something still.
    let mut with_still = 0;
    for (_, seed, _, s) in of(GenIntegrand::MotionBlur) {
        let objects: Vec<&Mesh> = s
            .scene
            .meshes
            .iter()
            .filter(|m| m.name.starts_with("obj"))
            .collect();
        let moving = objects
            .iter()
            .filter(|m| {
                m.motion
                    .windows(2)
                    .any(|k| k[0].translation != k[1].translation || k[0].rotation != k[1].rotation)
            })
            .count();
        assert!(moving >= 1, "motion_blur seed {seed}: nothing moves");
        with_still += usize::from(moving < objects.len());
    }
    assert!(
        with_still >= 12,
        "{with_still} motion_blur scenes keep an object still"
    );

    // depth_of_field: a lens, focused within the objects' depth range.
    for (_, seed, _, s) in of(GenIntegrand::DepthOfField) {
        let scene = &s.scene;
        let view = View::of(scene);
        let depths: Vec<f32> = scene
            .meshes
            .iter()
            .filter(|m| m.name.starts_with("obj"))
            .map(|m| {
                let (lo, hi) = bounds(&m.positions);
                ((lo + hi) / 2.0 - view.eye).dot(view.f)
            })
            .collect();
        let (near, far) = depths
            .iter()
            .fold((f32::INFINITY, 0.0f32), |(n, f), &d| (n.min(d), f.max(d)));
        let c = scene.camera;
        assert!(c.aperture_radius > 0.0, "depth_of_field seed {seed}");
        assert!(
            c.focus_distance >= 0.99 * near.min((c.look_at - c.position).length())
                && c.focus_distance <= 1.01 * far.max((c.look_at - c.position).length()),
            "depth_of_field seed {seed}: focus {} outside the objects' depths {near}..{far}",
            c.focus_distance
        );
    }

    // Across everything: black and coloured backgrounds, few and many
    // objects, thin features, sizes spanning ≥ 10× in most scenes.
    let black = scenes
        .iter()
        .filter(|(.., s)| s.scene.background == Vec3::ZERO)
        .count();
    assert!(
        black >= scenes.len() / 4 && black <= 3 * scenes.len() / 4,
        "{black} of {} backgrounds black",
        scenes.len()
    );
    let counts: Vec<usize> = scenes
        .iter()
        .map(|(.., s)| {
            s.scene
                .meshes
                .iter()
                .filter(|m| m.name.starts_with("obj"))
                .count()
        })
        .collect();
    assert!(counts.iter().any(|&n| n <= 4) && counts.iter().any(|&n| n >= 25));
    let (mut thin, mut spread) = (0, 0);
    for (.., s) in &scenes {
        let sizes: Vec<Vec3> = s
            .scene
            .meshes
            .iter()
            .filter(|m| m.name.starts_with("obj"))
            .map(|m| {
                let (lo, hi) = bounds(&m.positions);
                hi - lo
            })
            .collect();
        thin += usize::from(sizes.iter().any(|e| {
            e.max_element() > 0.0
                && e.min_element() < 0.05 * e.max_element()
                && e.min_element() > 0.0
        }));
        let largest = sizes.iter().map(|e| e.max_element()).fold(0.0, f32::max);
        let smallest = sizes
            .iter()
            .map(|e| e.max_element())
            .fold(f32::INFINITY, f32::min);
        spread += usize::from(largest >= 10.0 * smallest);
    }
    assert!(thin >= scenes.len() / 2, "{thin} scenes with a thin box");
    assert!(
        spread >= scenes.len() / 2,
        "{spread} scenes with sizes spanning 10×"
    );

    // path: bounces and light set-ups vary.
    let bounces: HashSet<u32> = of(GenIntegrand::Path)
        .filter_map(|(.., s)| match s.integrand {
            IntegrandSpec::PathTracing { max_bounces } => Some(max_bounces),
            _ => None,
        })
        .collect();
    assert!(bounces.len() >= 3, "path bounces {bounces:?}");
    let rooms = of(GenIntegrand::Path)
        .filter(|(.., s)| s.scene.meshes.iter().any(|m| m.name == "ceiling"))
        .count();
    assert!(rooms >= 1, "no path scene is a room");

    // many_light: light counts over the whole range.
    let lights: Vec<usize> = of(GenIntegrand::ManyLight)
        .map(|(.., s)| light_count(&s.scene))
        .collect();
    assert!(
        lights.iter().any(|&n| n < 100) && lights.iter().any(|&n| n > 500),
        "{lights:?}"
    );
}

// --- the command line --------------------------------------------------------

fn mdas(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_mdas"))
        .args(args)
        .output()
        .expect("run mdas")
}

/// `mdas scene random --integrand path --seed 3`, then `extra`.
fn path_seed_3(extra: &[&str]) -> Output {
    let mut args = vec!["scene", "random", "--integrand", "path", "--seed", "3"];
    args.extend_from_slice(extra);
    mdas(&args)
}

/// The same with `-o OUT`.
fn path_seed_3_to(out: &str) -> Output {
    path_seed_3(&["-o", out])
}

fn temp_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("mdas-scene-random-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn names(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    names
}

#[test]
fn cli_writes_the_same_file_twice_and_refuses_special_files() {
    let dir = temp_dir("cli");
    let out = dir.join("tmp.toml");
    let o = out.to_str().unwrap();
    let first = path_seed_3_to(o);
    assert!(
        first.status.success(),
        "{}",
        String::from_utf8_lossy(&first.stderr)
    );
    let a = std::fs::read_to_string(&out).unwrap();
    let second = path_seed_3_to(o);
    assert!(second.status.success());
    assert_eq!(a, std::fs::read_to_string(&out).unwrap());
    let expected = random_scene(GenIntegrand::Path, 3, &GenOptions::default());
    assert_eq!(a, expected);
    assert_eq!(names(&dir), ["tmp.toml"], "no temporary file left");

    // Without -o, the same text on stdout.
    let o = path_seed_3(&[]);
    assert!(o.status.success());
    assert_eq!(String::from_utf8(o.stdout).unwrap(), expected);

    // A directory is refused and left alone.
    let sub = dir.join("sub");
    std::fs::create_dir(&sub).unwrap();
    std::fs::write(sub.join("keep"), b"x").unwrap();
    let o = path_seed_3_to(sub.to_str().unwrap());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success() && err.contains("directory"), "{err}");
    assert!(!err.contains("panicked"), "{err}");
    assert_eq!(names(&sub), ["keep"]);

    // So is a FIFO (mkfifo is part of coreutils: its absence fails the
    // test rather than skipping the case).
    let fifo = dir.join("fifo.toml");
    let made = Command::new("mkfifo").arg(&fifo).status();
    assert!(made.is_ok_and(|s| s.success()), "mkfifo failed");
    let o = path_seed_3_to(fifo.to_str().unwrap());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        !o.status.success() && err.contains("not a regular file"),
        "{err}"
    );
    use std::os::unix::fs::FileTypeExt;
    assert!(std::fs::symlink_metadata(&fifo)
        .unwrap()
        .file_type()
        .is_fifo());

    // Bad arguments fail with the names and the limits.
    let o = mdas(&["scene", "random", "--integrand", "pathh", "--seed", "3"]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success() && err.contains("many_light"), "{err}");
    let o = path_seed_3(&["--width", "0"]);
    assert!(!o.status.success());
    let o = path_seed_3(&["--width", "16384", "--height", "16384"]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success() && err.contains("pixels"), "{err}");

    // --json: one document, with the text when there is no -o.
    let o = mdas(&[
        "--json",
        "scene",
        "random",
        "--integrand",
        "many_light",
        "--seed",
        "1",
    ]);
    assert!(o.status.success());
    let doc: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(doc["integrand"], "many_light");
    assert_eq!(
        doc["toml"].as_str().unwrap(),
        random_scene(GenIntegrand::ManyLight, 1, &GenOptions::default())
    );
    std::fs::remove_dir_all(&dir).unwrap();
}
