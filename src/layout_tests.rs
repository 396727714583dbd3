//! The crate's layout, checked: no import cycle between two files of
//! `src/` (issue 50).
//!
//! A file depends on another when its code (comments and its `#[cfg(test)]`
//! module left out) names a path `crate::a::b…`, `super::…` or, in the
//! binary's files, `mdas::…` whose longest prefix that is a module is the
//! other file's. A module's own children are not its dependencies: a parent
//! declares them, and a child that names `super::` depends on its parent.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// A module's crate (the library or the `mdas` binary) and path.
type ModPath = (bool, Vec<String>);

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.is_dir() {
            rust_files(&path, out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
}

/// The module of a file under `src/`: `a/b.rs` and `a/b/mod.rs` are
/// `a::b`; `lib.rs` the library's root, `main.rs` and `cli/…` the binary's.
fn module_of(rel: &Path) -> ModPath {
    let mut parts: Vec<String> = rel
        .with_extension("")
        .iter()
        .map(|p| p.to_string_lossy().into_owned())
        .collect();
    if matches!(
        parts.last().map(String::as_str),
        Some("mod" | "lib" | "main")
    ) {
        parts.pop();
    }
    let binary = rel == Path::new("main.rs") || rel.starts_with("cli");
    (!binary, parts)
}

/// The code of a file without comments and without its test module.
fn code(text: &str) -> String {
    let mut out = String::new();
    let mut lines = text.lines().peekable();
    while let Some(line) = lines.next() {
        if line.trim() == "#[cfg(test)]"
            && lines
                .peek()
                .is_some_and(|next| next.trim_start().starts_with("mod "))
        {
            break;
        }
        let line = line.split("//").next().unwrap_or("");
        out.push_str(line);
        out.push('\n');
    }
    out
}

/// The paths a file names: `crate::…`, `super::…` (resolved against its
/// module) and `mdas::…`, as module paths of the crate they name.
fn named_paths(code: &str, me: &ModPath) -> Vec<ModPath> {
    let bytes = code.as_bytes();
    let word = |c: u8| c.is_ascii_alphanumeric() || c == b'_';
    let mut out = Vec::new();
    let mut i = 0;
    while i < bytes.len() {
        if !word(bytes[i]) || (i > 0 && (word(bytes[i - 1]) || bytes[i - 1] == b':')) {
            i += 1;
            continue;
        }
        let start = i;
        let mut segments = Vec::new();
        loop {
            let s = i;
            while i < bytes.len() && word(bytes[i]) {
                i += 1;
            }
            segments.push(&code[s..i]);
            if code[i..].starts_with("::")
                && code[i + 2..].starts_with(|c: char| c.is_alphanumeric() || c == '_')
            {
                i += 2;
            } else {
                break;
            }
        }
        // `use a::*` names module a (the `*` is dropped when resolving).
        if code[i..].starts_with("::*") {
            segments.push("*");
            i += 3;
        }
        // `use a::{b, c::{d, e}}`: each leaf of the group is a path.
        let mut leaves: Vec<Vec<&str>> = vec![segments.clone()];
        if code[i..].starts_with("::{") {
            let open = i + 2;
            let close = matching_brace(code, open);
            leaves = expand(&code[open + 1..close])
                .into_iter()
                .map(|tail| segments.iter().copied().chain(tail).collect())
                .collect();
            i = close + 1;
        }
        if i == start {
            i += 1;
            continue;
        }
        for segments in leaves {
            if segments.len() < 2 {
                continue;
            }
            if let Some(path) = resolve(&segments, me) {
                out.push(path);
            }
        }
    }
    out
}

/// The byte index of the `}` that closes the `{` at `open`.
fn matching_brace(code: &str, open: usize) -> usize {
    let mut depth = 0;
    for (k, c) in code[open..].char_indices() {
        match c {
            '{' => depth += 1,
            '}' => {
                depth -= 1;
                if depth == 0 {
                    return open + k;
                }
            }
            _ => {}
        }
    }
    code.len() - 1
}

/// The paths of a `use` group's body (`b, c::{d, e}, f as g, self, *`),
/// relative to the group; `self` and `*` name the prefix itself.
fn expand(body: &str) -> Vec<Vec<&str>> {
    let mut out = Vec::new();
    let (mut depth, mut from) = (0, 0);
    let mut items = Vec::new();
    for (k, c) in body.char_indices() {
        match c {
            '{' => depth += 1,
            '}' => depth -= 1,
            ',' if depth == 0 => {
                items.push(&body[from..k]);
                from = k + 1;
            }
            _ => {}
        }
    }
    items.push(&body[from..]);
    for item in items {
        let item = item.trim();
        let item = item.split(" as ").next().unwrap_or("").trim();
        if item.is_empty() || item == "self" || item == "*" {
            out.push(Vec::new());
        } else if let Some(brace) = item.find("::{") {
            let head: Vec<&str> = item[..brace].split("::").map(str::trim).collect();
            let inner = &item[brace + 3..item.rfind('}').unwrap_or(item.len())];
            for tail in expand(inner) {
                out.push(head.iter().copied().chain(tail).collect());
            }
        } else {
            out.push(item.split("::").map(str::trim).collect());
        }
    }
    out
}

/// `segments` as a module path of the crate it names, if it starts with
/// `crate`, `super` or (in the binary) `mdas`.
fn resolve(segments: &[&str], me: &ModPath) -> Option<ModPath> {
    {
        let (library, mut base, rest) = match segments[0] {
            "crate" => (me.0, Vec::new(), &segments[1..]),
            "mdas" if !me.0 => (true, Vec::new(), &segments[1..]),
            "super" => {
                let mut base = me.1.clone();
                let mut rest = segments;
                while rest.first() == Some(&"super") {
                    base.pop();
                    rest = &rest[1..];
                }
                (me.0, base, rest)
            }
            _ => return None,
        };
        base.extend(rest.iter().map(|s| s.to_string()));
        Some((library, base))
    }
}

/// Each file of `src/` (relative) and the files it depends on.
fn file_graph() -> BTreeMap<String, BTreeSet<String>> {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut files = Vec::new();
    rust_files(&src, &mut files);
    let modules: BTreeMap<ModPath, String> = files
        .iter()
        .map(|f| {
            let rel = f.strip_prefix(&src).unwrap();
            (module_of(rel), rel.display().to_string())
        })
        .collect();
    let mut edges: BTreeMap<&str, BTreeSet<&str>> = BTreeMap::new();
    for (module, file) in &modules {
        let text = std::fs::read_to_string(src.join(file)).unwrap();
        let deps = edges.entry(file).or_default();
        for (library, mut path) in named_paths(&code(&text), module) {
            // The longest prefix that is a module.
            while !path.is_empty() && !modules.contains_key(&(library, path.clone())) {
                path.pop();
            }
            if let Some(target) = modules.get(&(library, path)) {
                if target != file {
                    deps.insert(target);
                }
            }
        }
    }
    edges
        .into_iter()
        .map(|(k, v)| (k.to_string(), v.into_iter().map(str::to_string).collect()))
        .collect()
}

/// Files in a cycle: the strongly connected components of more than one.
fn cycles(graph: &BTreeMap<String, BTreeSet<String>>) -> Vec<Vec<&str>> {
    let edges: BTreeMap<&str, BTreeSet<&str>> = graph
        .iter()
        .map(|(k, v)| (k.as_str(), v.iter().map(String::as_str).collect()))
        .collect();
    strongly_connected(&edges)
        .into_iter()
        .filter(|c| c.len() > 1)
        .collect()
}

#[test]
fn no_import_cycle_between_files() {
    let edges = file_graph();
    let cycles = cycles(&edges);
    assert!(
        cycles.is_empty(),
        "files that import each other, directly or through others: {cycles:#?}"
    );
    // The check sees edges at all (a parser that found none would pass).
    assert!(edges["integrator/mdas/config.rs"].contains("integrator/mdas/params.rs"));
    assert!(edges["cli/render.rs"].contains("cli/mod.rs"));
}

/// The library's top-level modules (`lights`, `integrand`, …) form
/// layers too: no two import each other, through any of their files.
#[test]
fn no_import_cycle_between_top_level_modules() {
    let top = |file: &str| -> Option<String> {
        let first = file.split('/').next()?;
        let first = first.strip_suffix(".rs").unwrap_or(first);
        (!matches!(first, "lib" | "main" | "cli" | "layout_tests")).then(|| first.to_string())
    };
    let mut modules: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    for (file, deps) in file_graph() {
        let Some(from) = top(&file) else { continue };
        let entry = modules.entry(from.clone()).or_default();
        entry.extend(deps.iter().filter_map(|d| top(d)).filter(|d| *d != from));
    }
    let cycles = cycles(&modules);
    assert!(
        cycles.is_empty(),
        "top-level modules that import each other: {cycles:#?}"
    );
    assert!(modules["integrator"].contains("gpu"));
}

/// Tarjan's strongly connected components.
fn strongly_connected<'a>(edges: &BTreeMap<&'a str, BTreeSet<&'a str>>) -> Vec<Vec<&'a str>> {
    struct State<'a> {
        index: BTreeMap<&'a str, usize>,
        low: BTreeMap<&'a str, usize>,
        stack: Vec<&'a str>,
        on_stack: BTreeSet<&'a str>,
        out: Vec<Vec<&'a str>>,
    }
    fn visit<'a>(v: &'a str, edges: &BTreeMap<&'a str, BTreeSet<&'a str>>, s: &mut State<'a>) {
        let n = s.index.len();
        s.index.insert(v, n);
        s.low.insert(v, n);
        s.stack.push(v);
        s.on_stack.insert(v);
        for &w in edges.get(v).into_iter().flatten() {
            if !s.index.contains_key(w) {
                visit(w, edges, s);
                let low = s.low[v].min(s.low[w]);
                s.low.insert(v, low);
            } else if s.on_stack.contains(w) {
                let low = s.low[v].min(s.index[w]);
                s.low.insert(v, low);
            }
        }
        if s.low[v] == s.index[v] {
            let mut component = Vec::new();
            while let Some(w) = s.stack.pop() {
                s.on_stack.remove(w);
                component.push(w);
                if w == v {
                    break;
                }
            }
            component.sort_unstable();
            s.out.push(component);
        }
    }
    let mut s = State {
        index: BTreeMap::new(),
        low: BTreeMap::new(),
        stack: Vec::new(),
        on_stack: BTreeSet::new(),
        out: Vec::new(),
    };
    for &v in edges.keys() {
        if !s.index.contains_key(v) {
            visit(v, edges, &mut s);
        }
    }
    s.out
}

#[test]
fn paths_resolve_against_the_file() {
    let me = (true, vec!["lights".to_string(), "cut".to_string()]);
    let found = named_paths(
        "use super::bvh::Cost; let x = crate::integrand::scene_wgsl(); a::b; super::super::gpu::X; use super::*; use crate::scene::{film::{self, Film}, obj as o};",
        &me,
    );
    assert_eq!(
        found,
        vec![
            (true, vec!["lights".into(), "bvh".into(), "Cost".into()]),
            (true, vec!["integrand".into(), "scene_wgsl".into()]),
            (true, vec!["gpu".into(), "X".into()]),
            (true, vec!["lights".into(), "*".into()]),
            (true, vec!["scene".into(), "film".into()]),
            (true, vec!["scene".into(), "film".into(), "Film".into()]),
            (true, vec!["scene".into(), "obj".into()]),
        ]
    );
    assert_eq!(
        code("a // crate::x\n#[cfg(test)]\nmod tests {\n crate::y\n}"),
        "a \n"
    );
}

/// Most lines a file of `src/` may hold (issue 50): beyond it a file holds
/// more than one concern and is split by concern, tests beside it.
const MAX_FILE_LINES: usize = 800;

#[test]
fn no_file_over_the_line_limit() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut files = Vec::new();
    rust_files(&src, &mut files);
    let long: Vec<String> = files
        .iter()
        .filter_map(|f| {
            let lines = std::fs::read_to_string(f).unwrap().lines().count();
            (lines > MAX_FILE_LINES).then(|| format!("{} ({lines} lines)", f.display()))
        })
        .collect();
    assert!(
        long.is_empty(),
        "files over {MAX_FILE_LINES} lines: {long:#?}"
    );
    assert!(files.len() > 100, "src/ was read ({} files)", files.len());
}

/// Sampler names live in the registry (`lights::registry::SamplerKind`,
/// issue 50): no string literal of a sampler name in the code of `src/`
/// outside `lights/registry.rs` (test files and modules aside), and no tree
/// kind named in the WGSL, whose tree rules read the predicates generated
/// from `SamplerKind`'s (`gpu_sampler::kinds_wgsl`). The simple pickers
/// (`uniform`, `power`) and `lgh` have code paths of their own there.
#[test]
fn sampler_names_only_in_the_registry() {
    use crate::lights::gpu_sampler::kind_constant;
    use crate::lights::registry::SamplerKind;
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let src = root.join("src");
    let mut files = Vec::new();
    rust_files(&src, &mut files);
    let mut named = Vec::new();
    for f in &files {
        let rel = f.strip_prefix(&src).unwrap();
        if rel == Path::new("lights/registry.rs") || f.ends_with("tests.rs") {
            continue;
        }
        let code = code(&std::fs::read_to_string(f).unwrap());
        for k in SamplerKind::ALL {
            if code.contains(&format!("\"{}\"", k.name())) {
                named.push(format!("{}: \"{}\"", rel.display(), k.name()));
            }
        }
    }
    let mut wgsl = Vec::new();
    let mut stack = vec![root.join("wgsl")];
    while let Some(dir) = stack.pop() {
        for entry in std::fs::read_dir(dir).unwrap() {
            let path = entry.unwrap().path();
            if path.is_dir() {
                stack.push(path);
            } else if path.extension().is_some_and(|e| e == "wgsl") {
                wgsl.push(path);
            }
        }
    }
    let trees: Vec<String> = SamplerKind::ALL
        .into_iter()
        .filter(|k| k.uses_tree())
        .map(kind_constant)
        .collect();
    for f in &wgsl {
        let text = std::fs::read_to_string(f).unwrap();
        for token in text.split(|c: char| !(c.is_ascii_alphanumeric() || c == '_')) {
            if trees.iter().any(|t| t == token) {
                named.push(format!("{}: {token}", f.display()));
            }
        }
    }
    assert!(
        named.is_empty(),
        "sampler kinds named outside the registry: {named:#?}"
    );
    assert!(wgsl.len() > 30, "wgsl/ was read ({} files)", wgsl.len());
}
