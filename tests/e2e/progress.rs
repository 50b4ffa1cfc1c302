//! Progress bars (issue 20): drawn with rate and ETA when stderr is a terminal, absent when it is
//! not. The terminal is a pseudo-terminal from util-linux's `script`; without it the terminal
//! half reports that it skipped.

use std::path::{Path, PathBuf};
use std::process::Command;

use crate::common::bin;

fn tmp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("synthcam-progress-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).expect("tmp");
    d
}

/// A long command line for each bar: (label, arguments).
fn commands(dir: &Path) -> Vec<(&'static str, Vec<String>)> {
    let spec = dir.join("spec.toml");
    std::fs::write(&spec, include_str!("../../assets/specs/tiny.toml").replace("count = 200", "count = 12")).expect("spec");
    let s = |p: &Path| p.display().to_string();
    let strs = |v: &[&str]| v.iter().map(|a| (*a).to_string()).collect::<Vec<_>>();
    vec![
        ("dataset", vec!["dataset".into(), s(&spec), "-o".into(), s(&dir.join("ds"))]),
        // Calibrates on the dataset's images (a bar over their detection).
        ("calibrate", [vec!["calibrate".into(), s(&dir.join("ds").join("images"))], strs(&["--target", "chessboard:6x4", "--square", "0.03"])].concat()),
        ("export", vec!["export".into(), s(&dir.join("ds")), "--format".into(), "webdataset".into()]),
        ("servo", [strs(&["servo", "--law", "ibvs", "--steps", "4", "--no-compare", "--no-stop", "-o"]), vec![s(&dir.join("servo"))]].concat()),
        ("robustness", [strs(&["experiment", "robustness", "--views", "1", "--effects", "blur", "--out"]), vec![s(&dir.join("rob"))]].concat()),
    ]
}

/// Everything the command wrote to stderr, run plainly (stderr a pipe).
fn piped_stderr(args: &[String]) -> String {
    let o = Command::new(bin()).args(args).output().expect("run");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// Everything the command wrote to its terminal, run under `script` (None: no `script`).
fn terminal_output(args: &[String]) -> Option<String> {
    let line = std::iter::once(bin().to_string()).chain(args.iter().cloned()).map(|a| format!("'{a}'")).collect::<Vec<_>>().join(" ");
    let o = Command::new("script").args(["-qec", &line, "/dev/null"]).env_remove("SYNTHCAM_PROGRESS").output().ok()?;
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stdout));
    Some(String::from_utf8_lossy(&o.stdout).into_owned())
}

#[test]
fn bars_show_rate_and_eta_on_a_terminal_and_nothing_in_a_pipe() {
    let dir = tmp("bars");
    for (label, args) in commands(&dir) {
        let err = piped_stderr(&args);
        assert!(!err.contains("ETA"), "{label}: a bar was drawn into a pipe:\n{err}");
        if label == "dataset" {
            // Rendered again, not resumed.
            let _ = std::fs::remove_dir_all(dir.join("ds"));
        }
        let Some(term) = terminal_output(&args) else {
            eprintln!("skipped the terminal half: util-linux `script` is not installed");
            return;
        };
        assert!(term.contains("ETA") && term.contains("/s"), "{label}: no bar with rate and ETA on a terminal:\n{term}");
        eprintln!("{label}: bar drawn on a terminal, none in a pipe");
    }
}
