//! Records the git commit the crate is built from as `MDAS_GIT_COMMIT`,
//! for the provenance `mdas compare` writes into report.json — only when
//! the crate's own directory is the top of a git work tree (a checkout of
//! this repository). A crate built from a package unpacked inside another
//! repository (a vendored dependency, a registry source in a project's
//! tree) would otherwise name that repository's commit.

use std::path::{Path, PathBuf};
use std::process::Command;

fn git(dir: &Path, args: &[&str]) -> Option<String> {
    Command::new("git")
        .arg("-C")
        .arg(dir)
        .args(args)
        .output()
        .ok()
        .filter(|o| o.status.success())
        .map(|o| String::from_utf8_lossy(&o.stdout).trim().to_string())
        .filter(|s| !s.is_empty())
}

fn main() {
    println!("cargo:rerun-if-changed=.git/HEAD");
    println!("cargo:rerun-if-changed=.git/packed-refs");
    if let Ok(head) = std::fs::read_to_string(".git/HEAD") {
        if let Some(reference) = head.strip_prefix("ref: ") {
            println!("cargo:rerun-if-changed=.git/{}", reference.trim());
        }
    }
    let manifest = PathBuf::from(std::env::var_os("CARGO_MANIFEST_DIR").unwrap_or_default());
    let canonical = |p: &Path| std::fs::canonicalize(p).ok();
    let own_checkout = git(&manifest, &["rev-parse", "--show-toplevel"]).is_some_and(|top| {
        canonical(Path::new(&top)).is_some() && canonical(Path::new(&top)) == canonical(&manifest)
    });
    if !own_checkout {
        return;
    }
    if let Some(commit) = git(&manifest, &["rev-parse", "HEAD"]) {
        println!("cargo:rustc-env=MDAS_GIT_COMMIT={commit}");
    }
}
