//! Bad scene files: a clear error naming the field, a non-zero exit, no panic and no output file.

use std::process::Command;

use crate::common::bin;

const GOOD: &str = include_str!("../../assets/scenes/chessboard_k1.toml");

fn run_scene(name: &str, text: &str) -> (bool, String, bool) {
    let dir = std::env::temp_dir().join(format!("synthcam-bad-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("tmp");
    let scene = dir.join("scene.toml");
    std::fs::write(&scene, text).expect("write");
    let out = dir.join("out.png");
    let o = Command::new(bin()).args(["render"]).arg(&scene).arg("-o").arg(&out).output().expect("run");
    let stderr = String::from_utf8_lossy(&o.stderr).into_owned();
    let wrote = out.exists() || out.with_extension("json").exists();
    let _ = std::fs::remove_dir_all(&dir);
    (o.status.success(), stderr, wrote)
}

#[test]
fn bad_scenes_fail_cleanly() {
    let cases: Vec<(&str, String, &str)> = vec![
        ("missing-fx", GOOD.replace("fx = 1500.0\n", ""), "fx"),
        ("nan-fy", GOOD.replace("fy = 1500.0", "fy = nan"), "fy"),
        ("zero-width", GOOD.replace("width = 1280", "width = 0"), "width"),
        ("negative-square", GOOD.replace("square_m = 0.05", "square_m = -0.05"), "square_m"),
        ("behind", GOOD.replace("0.65537279]", "-3.0]"), "behind the camera"),
        ("unknown-kind", GOOD.replace("kind = \"chessboard\"", "kind = \"hexboard\""), "hexboard"),
        ("unknown-field", GOOD.replace("seed = 1", "seed = 1\nsead = 2"), "sead"),
        ("not-a-rotation", GOOD.replace("rvec = [0.6981317007977318, 0.0, 0.0]", "R = [[1, 0, 0], [0, 2, 0], [0, 0, 1]]"), "rotation"),
        ("garbage", "this is { not toml".to_string(), "parse"),
        ("dist-6-values", GOOD.replace("dist = [-0.25, 0.0, 0.0, 0.0, 0.0]", "dist = [-0.25, 0.0, 0.0, 0.0, 0.0, 0.1]"), "dist"),
        ("fisheye-5-values", GOOD.replace("dist = [-0.25, 0.0, 0.0, 0.0, 0.0]", "model = \"fisheye\"\ndist = [0.1, 0.0, 0.0, 0.0, 0.0]"), "dist"),
        ("fisheye-folded", GOOD.replace("dist = [-0.25, 0.0, 0.0, 0.0, 0.0]", "model = \"fisheye\"\ndist = [-2e9, 0.0, 0.0, 0.0]"), "dist"),
        ("ds-alpha", GOOD.replace("dist = [-0.25, 0.0, 0.0, 0.0, 0.0]", "model = \"double-sphere\"\nxi = 0.1\nalpha = 1.5"), "alpha"),
        ("ds-nan-xi", GOOD.replace("dist = [-0.25, 0.0, 0.0, 0.0, 0.0]", "model = \"double-sphere\"\nxi = nan\nalpha = 0.5"), "xi"),
        ("unknown-model", GOOD.replace("dist = [-0.25, 0.0, 0.0, 0.0, 0.0]", "model = \"omni\""), "omni"),
    ];
    for (name, text, needle) in cases {
        let (ok, stderr, wrote) = run_scene(name, &text);
        assert!(!ok, "{name}: exit status 0");
        assert!(!stderr.contains("panicked"), "{name}: panicked: {stderr}");
        assert!(stderr.contains(needle), "{name}: error does not name `{needle}`: {stderr}");
        assert!(!wrote, "{name}: wrote an output file");
    }
}

#[test]
fn missing_scene_file_fails_cleanly() {
    let o = Command::new(bin()).args(["render", "/nonexistent/scene.toml", "-o", "/tmp/never.png"]).output().expect("run");
    assert!(!o.status.success());
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(stderr.contains("/nonexistent/scene.toml"), "{stderr}");
}

#[test]
fn unwritable_output_fails_without_leftovers() {
    let o = Command::new(bin())
        .args(["render", concat!(env!("CARGO_MANIFEST_DIR"), "/assets/scenes/chessboard_k1.toml"), "-o", "/nonexistent-dir/out.png"])
        .output()
        .expect("run");
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("cannot write"));
}
