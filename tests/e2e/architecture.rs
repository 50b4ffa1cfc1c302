//! Layering rules. The layers are crates (`crates/*`, ARCHITECTURE.md), so the compiler refuses an
//! import of a crate that is not a dependency; these tests keep the dependencies themselves in
//! order (a crate may depend only on crates below it), keep wgpu in the renderer and the
//! filesystem in `io` and the command line, and keep files and functions small.
//!
//! Crates, lowest first: `core` (math, camera, target, robot, mesh) -> `scene` -> `detect` ->
//! `geometry` (calib, pnp, handeye, servo) -> `render` -> `sim` -> `io` (dataset, report) -> the
//! `synthcam` facade and its command line (`src/`).

use std::path::{Path, PathBuf};

/// Every layer crate (`crates/<name>`, package `synthcam-<name>`), lowest first.
const ORDER: [&str; 8] = ["core", "scene", "detect", "geometry", "render", "sim", "course", "io"];
/// Crates (and the facade's `cli` / `main`) that may read or write files.
const FILE_LAYERS: [&str; 3] = ["io", "cli", "main"];

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for e in std::fs::read_dir(dir).expect("read_dir").flatten() {
        let p = e.path();
        if p.is_dir() {
            rust_files(&p, out);
        } else if p.extension().is_some_and(|x| x == "rs") {
            out.push(p);
        }
    }
}

/// Every source file of the workspace but the Python bindings, with its layer: the crate's name
/// under `crates/`, the top-level module (`cli`, `main`, `error`, `prelude`, `lib`) under `src/`.
fn sources() -> Vec<(String, PathBuf)> {
    let mut out = Vec::new();
    for name in ORDER {
        let mut files = Vec::new();
        rust_files(&root().join("crates").join(name).join("src"), &mut files);
        out.extend(files.into_iter().map(|f| (name.to_string(), f)));
    }
    let src = root().join("src");
    let mut files = Vec::new();
    rust_files(&src, &mut files);
    for f in files {
        let rel = f.strip_prefix(&src).expect("under src");
        let top = rel.components().next().map(|c| c.as_os_str().to_string_lossy().trim_end_matches(".rs").to_string()).unwrap_or_default();
        out.push((top, f));
    }
    out
}

/// The rules broken by `text`, the source of a file of layer `layer` (`is_test_module` for
/// `tests.rs` files, which may read reference data).
fn violations(layer: &str, text: &str, is_test_module: bool) -> Vec<String> {
    let code: String = text.lines().filter(|l| !l.trim_start().starts_with("//")).collect::<Vec<_>>().join("\n");
    let body = code.split("#[cfg(test)]").next().unwrap_or("");
    let mut out = Vec::new();
    if layer != "render" && code.contains("wgpu::") {
        out.push("names wgpu".to_string());
    }
    if !FILE_LAYERS.contains(&layer) && !is_test_module {
        for needle in ["std::fs", "File::create", "File::open"] {
            if body.contains(needle) {
                out.push(format!("uses {needle}"));
            }
        }
    }
    out
}

/// The synthcam crates a manifest depends on (`[dependencies]` only: `synthcam-<name>`).
fn layer_dependencies(manifest: &str) -> Vec<String> {
    let deps = manifest.split("[dependencies]").nth(1).unwrap_or("").split("\n[").next().unwrap_or("");
    deps.lines().filter_map(|l| l.trim().strip_prefix("synthcam-")).map(|l| l.chars().take_while(|c| c.is_alphanumeric()).collect()).collect()
}

#[test]
fn layering_rules_hold() {
    let mut broken = Vec::new();
    for (layer, f) in sources() {
        let text = std::fs::read_to_string(&f).expect("read");
        let is_test_module = f.file_name().is_some_and(|n| n == "tests.rs");
        for v in violations(&layer, &text, is_test_module) {
            broken.push(format!("{}: {v}", f.display()));
        }
    }
    assert!(broken.is_empty(), "layering broken:\n{}", broken.join("\n"));
}

#[test]
fn each_crate_depends_only_on_crates_below_it() {
    for (rank, name) in ORDER.iter().enumerate() {
        let manifest = std::fs::read_to_string(root().join("crates").join(name).join("Cargo.toml")).expect("manifest");
        for dep in layer_dependencies(&manifest) {
            let dep_rank = ORDER.iter().position(|o| *o == dep);
            assert!(dep_rank.is_some_and(|r| r < rank), "synthcam-{name} depends on synthcam-{dep}, which is not below it in {ORDER:?}");
        }
    }
}

#[test]
fn every_crate_and_top_level_module_has_a_layer() {
    for e in std::fs::read_dir(root().join("crates")).expect("read_dir").flatten() {
        let name = e.file_name().to_string_lossy().to_string();
        assert!(ORDER.contains(&name.as_str()), "crates/{name} is in no layer of tests/e2e/architecture.rs");
    }
    for e in std::fs::read_dir(root().join("src")).expect("read_dir").flatten() {
        let name = e.file_name().to_string_lossy().trim_end_matches(".rs").to_string();
        // the facade: the command line, and lib, error and prelude, which re-export or wrap every layer
        assert!(["lib", "main", "error", "prelude", "cli"].contains(&name.as_str()), "src/{name} belongs in a crate under crates/");
    }
}

#[test]
fn the_checkers_catch_what_they_guard() {
    assert_eq!(violations("core", "let t = std::fs::read(p);\n", false), vec!["uses std::fs"]);
    assert_eq!(violations("scene", "let d: wgpu::Device;\n", false), vec!["names wgpu"]);
    assert!(violations("io", "let t = std::fs::read(p);\n", false).is_empty());
    assert!(violations("detect", "// let d: wgpu::Device;\n", false).is_empty());
    let manifest = "[package]\nname = \"x\"\n\n[dependencies]\nsynthcam-core.workspace = true\nsynthcam-render = { workspace = true }\nimage = 1\n\n[dev-dependencies]\nsynthcam-io = 1\n";
    assert_eq!(layer_dependencies(manifest), vec!["core", "render"]);
}

/// Lines of every function in `text` longer than `max` lines: (name, lines). A function starts
/// at a line `fn name` and ends at the first line with its indentation and a closing brace
/// (the layout rustfmt gives).
fn long_functions(text: &str, max: usize) -> Vec<(String, usize)> {
    let lines: Vec<&str> = text.lines().collect();
    let mut out = Vec::new();
    for (i, l) in lines.iter().enumerate() {
        let t = l.trim_start();
        let indent = &l[..l.len() - t.len()];
        let head = ["pub fn ", "pub(crate) fn ", "pub(super) fn ", "fn ", "const fn ", "pub const fn "].iter().find(|p| t.starts_with(**p));
        if head.is_none() || t.ends_with(';') || t.ends_with('}') {
            continue;
        }
        let name: String = t.split("fn ").nth(1).unwrap_or("").chars().take_while(|c| c.is_alphanumeric() || *c == '_').collect();
        let end = lines[i..].iter().position(|m| *m == format!("{indent}}}")).map_or(0, |k| k + 1);
        if end > max {
            out.push((name, end));
        }
    }
    out
}

/// Functions allowed over 80 lines, with their length when listed (none since 2026-12-02, when
/// `find_dots` and `refine_saddle` were split). The test fails when one grows, when another
/// function passes 80 lines, or when a listed one is split (so that the list stays true).
const LONG_FUNCTIONS: [(&str, &str, usize); 0] = [];

#[test]
fn files_and_functions_stay_small() {
    let (mut broken, mut seen) = (Vec::new(), Vec::new());
    for (_, f) in sources() {
        let text = std::fs::read_to_string(&f).expect("read");
        let rel = f.strip_prefix(root()).expect("under the root").to_string_lossy().replace('\\', "/");
        let n = text.lines().count();
        if n > 400 {
            broken.push(format!("{rel}: {n} lines (at most 400)"));
        }
        for (name, len) in long_functions(&text, 80) {
            match LONG_FUNCTIONS.iter().find(|(file, func, _)| *file == rel && *func == name) {
                Some((_, _, listed)) if len <= *listed => seen.push((rel.clone(), name)),
                Some((_, _, listed)) => broken.push(format!("{rel}: fn {name} grew to {len} lines (listed at {listed})")),
                None => broken.push(format!("{rel}: fn {name} has {len} lines (at most 80)")),
            }
        }
    }
    for (file, func, _) in LONG_FUNCTIONS {
        if !seen.iter().any(|(f, n)| f == file && n == func) {
            broken.push(format!("{file}: fn {func} is no longer over 80 lines: take it off LONG_FUNCTIONS"));
        }
    }
    assert!(broken.is_empty(), "size rules broken:\n{}", broken.join("\n"));
}

#[test]
fn the_size_checker_measures_functions() {
    let body = (0..90).map(|k| format!("    let x{k} = {k};\n")).collect::<String>();
    let text = format!("fn short() {{\n    1;\n}}\n\npub fn long() {{\n{body}}}\n");
    assert_eq!(long_functions(&text, 80), vec![("long".to_string(), 92)]);
    assert!(long_functions("fn f();\nfn g() {}\n", 0).is_empty());
}
