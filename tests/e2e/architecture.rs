//! Layering rules, enforced by reading the sources: only `render` names wgpu; only `dataset` and
//! the CLI touch the filesystem; pure modules do not import the layers above them.

use std::path::Path;

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

#[test]
fn layering_rules_hold() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut files = Vec::new();
    rust_files(&src, &mut files);
    let pure = ["math", "camera", "target", "robot", "scene", "detect", "calib", "pnp", "handeye", "servo"];
    let order = ["math", "camera", "target", "robot", "scene", "detect", "calib", "pnp", "handeye", "servo", "render", "dataset", "cli"];
    for f in files {
        let text = std::fs::read_to_string(&f).expect("read");
        let m = module_of(&f, &src);
        let code: String = text.lines().filter(|l| !l.trim_start().starts_with("//")).collect::<Vec<_>>().join("\n");
        if m != "render" {
            assert!(!code.contains("wgpu::"), "{} names wgpu", f.display());
        }
        // Test modules (`tests.rs`) may read reference data.
        let is_test_module = f.file_name().is_some_and(|n| n == "tests.rs");
        if !["dataset", "cli", "main"].contains(&m.as_str()) && !is_test_module {
            for needle in ["std::fs", "File::create", "File::open"] {
                let body = code.split("#[cfg(test)]").next().unwrap_or("");
                assert!(!body.contains(needle), "{} uses {needle}", f.display());
            }
        }
        if let Some(rank) = pure.iter().position(|p| *p == m) {
            for higher in &order[rank + 1..] {
                assert!(!code.contains(&format!("crate::{higher}")), "{} (layer {m}) imports crate::{higher}", f.display());
            }
        }
    }
}
