//! Writing scene text to a temporary file and loading it as the CLI does;
//! asserting where a bad scene's error points. Shared by the scene-file
//! tests.
#![allow(dead_code)]

use mdas::scene_file;
use mdas::scene_file::SceneError;
use mdas::scene_file::SceneFile;
use std::path::{Path, PathBuf};

pub fn scene_path(rel: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("scenes")
        .join(rel)
}

/// Write `text` to a fresh file in a per-test temp directory and load it
/// through the public `load`, as the CLI does.
pub fn load_text(test: &str, text: &str) -> (PathBuf, Result<SceneFile, SceneError>) {
    let exe = std::env::current_exe().unwrap();
    let binary = exe.file_stem().unwrap().to_string_lossy();
    let dir = std::env::temp_dir().join(format!("mdas-{binary}-{}-{test}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("scene.toml");
    std::fs::write(&path, text).unwrap();
    let result = scene_file::load(&path);
    (path, result)
}

/// A scene that must load.
pub fn ok(test: &str, text: &str) -> SceneFile {
    let (_, r) = load_text(test, text);
    r.unwrap()
}

/// The error message of a scene that must fail, checked to start with
/// `file:line:column: `.
pub fn error_at(test: &str, text: &str, line: usize, column: usize) -> String {
    let (path, result) = load_text(test, text);
    let e = result.expect_err("scene should be rejected");
    let message = e.to_string();
    let prefix = format!("{}:{line}:{column}: ", path.display());
    assert!(
        message.starts_with(&prefix),
        "expected prefix {prefix:?}, got {message:?}"
    );
    assert_eq!(e.position(), Some((line, column)));
    message[prefix.len()..].to_string()
}

/// A valid scene without shapes, 11 lines; tests append to it.
pub const BASE: &str = "\
[film]
width = 8
height = 6
[camera]
position = [0, 1, 5]
look_at = [0, 0, 0]
up = [0, 1, 0]
fov_y = 40
[[material]]
name = \"white\"
albedo = [0.5, 0.5, 0.5]
";

/// Hands `check` every truncation of `text` (at char boundaries) and
/// `corruptions` copies with 1–3 bytes replaced by TOML-ish characters
/// (xorshift stream from `seed`; copies that are no longer UTF-8 are
/// skipped), for "no input may panic" tests.
pub fn for_each_corruption(text: &str, seed: u64, corruptions: u32, mut check: impl FnMut(&str)) {
    for end in (0..text.len()).filter(|&i| text.is_char_boundary(i)) {
        check(&text[..end]);
    }
    let mut state = seed;
    let mut next = || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        state
    };
    let replacements = b"0-9.e[]{}=\"\n #nai,";
    for _ in 0..corruptions {
        let mut bytes = text.as_bytes().to_vec();
        for _ in 0..1 + next() % 3 {
            let at = (next() % bytes.len() as u64) as usize;
            bytes[at] = replacements[(next() % replacements.len() as u64) as usize];
        }
        if let Ok(corrupt) = String::from_utf8(bytes) {
            check(&corrupt);
        }
    }
}
