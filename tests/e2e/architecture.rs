//! Layering rules, enforced by reading the sources: only `render` names wgpu; only `dataset`,
//! `report` and the CLI touch the filesystem; no module imports a layer above it.
//!
//! Layers, lowest first: `math` -> `camera` / `target` / `robot` / `mesh` -> `scene` -> `detect` / `calib` /
//! `pnp` / `handeye` / `servo` -> `render` -> `sim` -> `dataset` -> `report` -> `cli`.

use std::path::Path;

/// Every layer, lowest first.
const ORDER: [&str; 16] =
    ["math", "camera", "target", "robot", "mesh", "scene", "detect", "calib", "pnp", "handeye", "servo", "render", "sim", "dataset", "report", "cli"];
/// Layers that may read or write files.
const FILE_LAYERS: [&str; 4] = ["dataset", "report", "cli", "main"];

fn rust_files(dir: &Path, out: &mut Vec<std::path::PathBuf>) {
    for e in std::fs::read_dir(dir).expect("read_dir").flatten() {
        let p = e.path();
        if p.is_dir() {
            rust_files(&p, out);
        } else if p.extension().is_some_and(|x| x == "rs") {
            out.push(p);
        }
    }
}

fn module_of(path: &Path, src: &Path) -> String {
    let rel = path.strip_prefix(src).expect("under src");
    rel.components().next().map(|c| c.as_os_str().to_string_lossy().trim_end_matches(".rs").to_string()).unwrap_or_default()
}

/// The rules broken by `text`, the source of a file of layer `module` (`is_test_module` for
/// `tests.rs` files, which may read reference data).
fn violations(module: &str, text: &str, is_test_module: bool) -> Vec<String> {
    let code: String = text.lines().filter(|l| !l.trim_start().starts_with("//")).collect::<Vec<_>>().join("\n");
    let body = code.split("#[cfg(test)]").next().unwrap_or("");
    let mut out = Vec::new();
    if module != "render" && code.contains("wgpu::") {
        out.push("names wgpu".to_string());
    }
    if !FILE_LAYERS.contains(&module) && !is_test_module {
        for needle in ["std::fs", "File::create", "File::open"] {
            if body.contains(needle) {
                out.push(format!("uses {needle}"));
            }
        }
    }
    if let Some(rank) = ORDER.iter().position(|p| *p == module) {
        for higher in &ORDER[rank + 1..] {
            if code.contains(&format!("crate::{higher}::")) || code.contains(&format!("crate::{higher}}}")) || code.contains(&format!("crate::{higher};")) {
                out.push(format!("(layer {module}) imports crate::{higher}"));
            }
        }
    }
    out
}

#[test]
fn layering_rules_hold() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut files = Vec::new();
    rust_files(&src, &mut files);
    let mut broken = Vec::new();
    for f in files {
        let text = std::fs::read_to_string(&f).expect("read");
        let is_test_module = f.file_name().is_some_and(|n| n == "tests.rs");
        for v in violations(&module_of(&f, &src), &text, is_test_module) {
            broken.push(format!("{}: {v}", f.display()));
        }
    }
    assert!(broken.is_empty(), "layering broken:\n{}", broken.join("\n"));
}

#[test]
fn every_top_level_module_has_a_layer() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    for e in std::fs::read_dir(&src).expect("read_dir").flatten() {
        let name = e.file_name().to_string_lossy().trim_end_matches(".rs").to_string();
        // lib, error and prelude sit above every layer: they re-export or wrap them all
        let known = ORDER.contains(&name.as_str()) || ["lib", "main", "error", "prelude"].contains(&name.as_str());
        assert!(known, "src/{name} is in no layer of tests/e2e/architecture.rs");
    }
}

#[test]
fn the_checker_catches_forbidden_imports() {
    assert_eq!(violations("detect", "use crate::render::Renderer;\n", false), vec!["(layer detect) imports crate::render"]);
    assert_eq!(violations("sim", "use crate::dataset::write_atomic;\n", false), vec!["(layer sim) imports crate::dataset"]);
    assert_eq!(violations("camera", "let t = std::fs::read(p);\n", false), vec!["uses std::fs"]);
    assert_eq!(violations("scene", "let d: wgpu::Device;\n", false), vec!["names wgpu"]);
    assert!(violations("report", "use crate::sim::servo_run::ServoTrace;\nlet t = std::fs::read(p);\n", false).is_empty());
    assert!(violations("detect", "// use crate::render::Renderer;\n", false).is_empty());
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
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut files = Vec::new();
    rust_files(&src, &mut files);
    let (mut broken, mut seen) = (Vec::new(), Vec::new());
    for f in files {
        let text = std::fs::read_to_string(&f).expect("read");
        let rel = f.strip_prefix(&src).expect("under src").to_string_lossy().replace('\\', "/");
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
