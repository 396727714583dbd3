//! The session layer's unit tests.

use super::prepare::*;
use super::reference::*;
use crate::film::Film;
use crate::integrand::IntegrandSpec;
use crate::integrator::mdas::MdasParams;
use crate::lights::registry::SamplerKind;
use crate::scene_file::SceneFile;
use std::path::Path;

#[test]
fn scaled_mdas_grid_keeps_cells_per_pixel() {
    let p = MdasParams {
        extra_image_bits: 8,
        ..Default::default()
    };
    assert_eq!(mdas_params_at_scale(p, 1.0).extra_image_bits, 8);
    assert_eq!(mdas_params_at_scale(p, 0.5).extra_image_bits, 7);
    assert_eq!(mdas_params_at_scale(p, 1.0 / 16.0).extra_image_bits, 4);
    assert_eq!(mdas_params_at_scale(p, 1.0 / 1024.0).extra_image_bits, 0);
    assert_eq!(mdas_params_at_scale(p, 2.0).extra_image_bits, 8);
}

#[test]
fn frame_overrides_move_the_table_and_key_the_reference() {
    use crate::integrand::ManyLightSpec;
    let m = ManyLightSpec {
        time: 1.0,
        frame_duration: 0.5,
        sampler: SamplerKind::Sst,
        ..ManyLightSpec::default()
    };
    let spec = IntegrandSpec::ManyLight(m.clone());
    let at = |frame| IntegrandOverrides {
        frame: Some(frame),
        ..IntegrandOverrides::default()
    };
    let path = Path::new("s.toml");
    assert_eq!(
        at(3).apply(&spec, path).unwrap(),
        IntegrandSpec::ManyLight(m.at_frame(3))
    );
    assert_eq!(at(3).cache_key(&spec).unwrap(), "|frame=3");
    // Frame 0 is the scene's own table: the same cache entry.
    assert_eq!(at(0).cache_key(&spec).unwrap(), "");
    let both = IntegrandOverrides {
        sampler: Some(SamplerKind::Tree),
        ..at(2)
    };
    assert_eq!(both.cache_key(&spec).unwrap(), "|sampler=tree|frame=2");
    // A biased sampler's reference uses tree at the same frame.
    assert_eq!(reference_overrides(&spec, at(2)).0, both);
    let other = IntegrandSpec::PathTracing { max_bounces: 1 };
    let e = at(1).apply(&other, path).unwrap_err().to_string();
    assert!(e.contains("frame sequences need a many_light scene"), "{e}");
}

#[test]
fn cut_overrides_change_the_table_and_key_the_reference() {
    use crate::integrand::ManyLightSpec;
    use crate::lights::sampler::CutSampling;
    let m = ManyLightSpec::default();
    let spec = IntegrandSpec::ManyLight(m.clone());
    let path = Path::new("s.toml");
    let o = IntegrandOverrides {
        cut_size: Some(32),
        cut_sampling: Some(CutSampling::Mixture),
        ..IntegrandOverrides::default()
    };
    assert_eq!(
        o.apply(&spec, path).unwrap(),
        IntegrandSpec::ManyLight(ManyLightSpec {
            cut_size: 32,
            cut_sampling: CutSampling::Mixture,
            ..m.clone()
        })
    );
    assert_eq!(
        o.cache_key(&spec).unwrap(),
        "|cut_size=32|cut_sampling=mixture"
    );
    // The scene's own values: the same cache entry.
    let same = IntegrandOverrides {
        cut_size: Some(m.cut_size),
        cut_sampling: Some(m.cut_sampling),
        ..IntegrandOverrides::default()
    };
    assert_eq!(same.cache_key(&spec).unwrap(), "");
    let e = IntegrandOverrides {
        cut_size: Some(65),
        ..IntegrandOverrides::default()
    }
    .apply(&spec, path)
    .unwrap_err()
    .to_string();
    assert!(e.contains("--cut-size must be in 1..=64, got 65"), "{e}");
    let other = IntegrandSpec::PathTracing { max_bounces: 1 };
    let e = o.apply(&other, path).unwrap_err().to_string();
    assert!(e.contains("apply only to the many_light integrand"), "{e}");
}

#[test]
fn references_of_biased_samplers_use_tree() {
    use crate::integrand::ManyLightSpec;
    let ml = |sampler| {
        IntegrandSpec::ManyLight(ManyLightSpec {
            sampler,
            ..ManyLightSpec::default()
        })
    };
    // The biased kinds, named here rather than taken from
    // `is_biased` (which the test would then only repeat): `sst` and
    // `sst_perfect` stop at substitutes, `lgh` shades with grid lights.
    let biased = ["sst", "sst_perfect", "lgh"];
    for kind in SamplerKind::ALL {
        let (o, note) = reference_overrides(&ml(kind), IntegrandOverrides::default());
        assert_eq!(kind.is_biased(), biased.contains(&kind.name()), "{kind}");
        if biased.contains(&kind.name()) {
            assert_eq!(o.sampler, Some(SamplerKind::Tree), "{kind}");
            assert!(note.unwrap().contains(kind.name()));
        } else {
            assert_eq!((o.sampler, note), (None, None), "{kind}");
        }
        // An explicit --sampler is kept, biased or not.
        let (o, note) = reference_overrides(&ml(kind), IntegrandOverrides::sampler(kind));
        assert_eq!((o.sampler, note), (Some(kind), None));
    }
    let other = IntegrandSpec::PathTracing { max_bounces: 1 };
    assert_eq!(
        reference_overrides(&other, IntegrandOverrides::default()).0,
        IntegrandOverrides::default()
    );
}

#[test]
fn sampler_overrides_apply_to_many_light_only() {
    use crate::integrand::ManyLightSpec;
    let scene = Path::new("s.toml");
    let many = IntegrandSpec::ManyLight(ManyLightSpec::default());
    let power = IntegrandOverrides::sampler(SamplerKind::Power);
    let tree = IntegrandOverrides::sampler(SamplerKind::Tree);
    let none = IntegrandOverrides::default();
    match power.apply(&many, scene).unwrap() {
        IntegrandSpec::ManyLight(m) => assert_eq!(m.sampler, SamplerKind::Power),
        other => panic!("{other:?}"),
    }
    assert_eq!(none.apply(&many, scene).unwrap(), many);
    let err = power
        .apply(&IntegrandSpec::AreaLight, scene)
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("many_light") && err.contains("area_light"),
        "{err}"
    );
    assert_eq!(
        none.apply(&IntegrandSpec::AreaLight, scene).unwrap(),
        IntegrandSpec::AreaLight
    );
    // Only a sampler that changes the scene's adds to the cache key.
    assert_eq!(power.cache_key(&many).unwrap(), "|sampler=power");
    assert_eq!(tree.cache_key(&many).unwrap(), "");
    assert_eq!(none.cache_key(&many).unwrap(), "");
}

#[test]
fn scaled_films_round_and_stay_non_empty() {
    let f = Film {
        width: 128,
        height: 96,
    };
    assert_eq!(
        scaled_film(f, 0.25).unwrap(),
        Film {
            width: 32,
            height: 24
        }
    );
    assert_eq!(
        scaled_film(f, 0.001).unwrap(),
        Film {
            width: 1,
            height: 1
        }
    );
    assert!(scaled_film(f, 0.0).is_err() && scaled_film(f, f32::NAN).is_err());
}

/// A scene whose OBJ has vertex normals gets a reference key of its own
/// (references cached before normals shaded are never hit); a scene
/// without keeps its key.
#[test]
fn vertex_normals_key_references_apart() {
    let dir = std::env::temp_dir().join(format!("mdas-app-vn-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let spec = ReferenceSpec {
        spp: 4,
        scale: 1.0,
        seed: 1,
    };
    for (name, obj, smooth) in [
        ("flat", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", false),
        (
            "smooth",
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nf 1//1 2//1 3//1\n",
            true,
        ),
    ] {
        std::fs::write(dir.join(format!("{name}.obj")), obj).unwrap();
        let scene = dir.join(format!("{name}.toml"));
        std::fs::write(
            &scene,
            format!(
                "[film]\nwidth = 4\nheight = 4\n[camera]\nposition = [0, 0, 3]\nlook_at = [0, 0, 0]\n\
                 up = [0, 1, 0]\nfov_y = 40\n[[material]]\nname = \"w\"\nalbedo = [0.5, 0.5, 0.5]\n\
                 [[shape]]\ntype = \"mesh\"\nmaterial = \"w\"\nfile = \"{name}.obj\"\n"
            ),
        )
        .unwrap();
        let loaded = SceneFile::load(&scene).unwrap();
        let old = reference_cache_path_keyed(&dir, &scene, &loaded.inputs, spec, "").unwrap();
        let now = reference_cache_path(&dir, &scene, spec).unwrap();
        assert_eq!(now != old, smooth, "{name}");
    }
}

/// Tuning a scene's `[mdas]` table or editing its comments keeps its
/// reference key; anything a Halton render reads changes it.
#[test]
fn reference_keys_ignore_the_mdas_table_and_comments() {
    let dir = std::env::temp_dir().join(format!("mdas-app-key-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let spec = ReferenceSpec {
        spp: 4,
        scale: 1.0,
        seed: 1,
    };
    let base = "[film]\nwidth = 4\nheight = 4\n[camera]\nposition = [0, 0, 3]\n\
                look_at = [0, 0, 0]\nup = [0, 1, 0]\nfov_y = 40\n[[material]]\nname = \"w\"\n\
                albedo = [0.5, 0.5, 0.5]\n[[shape]]\ntype = \"quad\"\nmaterial = \"w\"\n\
                corners = [[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]]\n";
    let key = |name: &str, text: &str| {
        let path = dir.join(format!("{name}.toml"));
        std::fs::write(&path, text).unwrap();
        let key = reference_cache_path(&dir, &path, spec).unwrap();
        // The stem is the file's; the hash is what is compared.
        key.file_name().unwrap().to_str().unwrap()[name.len()..].to_owned()
    };
    let plain = key("plain", base);
    let tuned = key(
        "tuned",
        &format!("# a comment\n{base}[mdas]\nalpha = 0.25\nsplit = \"trimmed\"\nspp = 8\n"),
    );
    let retuned = key("retuned", &format!("{base}\n[mdas]\nalpha = 1\n"));
    let wider = key("wider", &base.replace("width = 4", "width = 8"));
    assert_eq!(plain, tuned);
    assert_eq!(plain, retuned);
    assert_ne!(plain, wider);
    // A file that is not TOML is keyed by its bytes (and does not load).
    assert_ne!(reference_key_text(b"[film"), reference_key_text(b"[film "));
}

/// A Mitsuba scene's `[mdas]` table beside it (`X.mdas.toml`) changes
/// MDAS only: editing it keeps the scene's reference cache key, as editing
/// a TOML scene's `[mdas]` table does; editing an included file does not.
#[test]
fn a_mitsuba_scenes_mdas_table_is_not_in_its_reference_key() {
    let dir = std::env::temp_dir().join(format!("mdas-side-key-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let scene = dir.join("s.xml");
    std::fs::write(
        &scene,
        "<scene version=\"3.0.0\"><integrator type=\"direct\"/>\
         <sensor type=\"perspective\"><float name=\"fov\" value=\"40\"/></sensor>\
         <include filename=\"inc.xml\"/></scene>",
    )
    .unwrap();
    std::fs::write(
        dir.join("inc.xml"),
        "<scene version=\"3.0.0\"><shape type=\"cube\"/></scene>",
    )
    .unwrap();
    let spec = ReferenceSpec {
        spp: 4,
        scale: 1.0,
        seed: 0,
    };
    let key = || reference_cache_path(&dir, &scene, spec).unwrap();
    let plain = key();
    std::fs::write(dir.join("s.mdas.toml"), "[mdas]\nalpha = 3\n").unwrap();
    assert_eq!(key(), plain, "the [mdas] sidecar is not part of the key");
    std::fs::write(
        dir.join("inc.xml"),
        "<scene version=\"3.0.0\"><shape type=\"rectangle\"/></scene>",
    )
    .unwrap();
    assert_ne!(key(), plain, "an included file is");
    std::fs::remove_dir_all(&dir).ok();
}
