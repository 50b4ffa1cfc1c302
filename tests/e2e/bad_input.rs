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
        ("background-missing-image", format!("{GOOD}\n[background]\nkind = \"panorama\"\nimage = \"/nonexistent/hall.png\"\n"), "background.image"),
        (
            "background-corrupt-image",
            format!("{GOOD}\n[background]\nkind = \"panorama\"\nimage = \"{}\"\n", concat!(env!("CARGO_MANIFEST_DIR"), "/README.md")),
            "background.image",
        ),
        ("background-unknown-procedure", format!("{GOOD}\n[background]\nkind = \"panorama\"\nprocedural = \"forest\"\n"), "forest"),
        ("background-plane-no-size", format!("{GOOD}\n[background]\nkind = \"plane\"\nprocedural = \"clutter\"\nt_m = [0.0, 0.0, 2.0]\n"), "size_m"),
        (
            "background-nan-size",
            format!("{GOOD}\n[background]\nkind = \"plane\"\nprocedural = \"clutter\"\nt_m = [0.0, 0.0, 2.0]\nsize_m = [nan, 1.0]\n"),
            "size_m",
        ),
        ("background-both-sources", format!("{GOOD}\n[background]\nkind = \"panorama\"\nprocedural = \"clutter\"\nimage = \"x.png\"\n"), "background.image"),
        ("background-huge-texture", format!("{GOOD}\n[background]\nkind = \"panorama\"\nprocedural = \"clutter\"\nsize_px = [100000, 10]\n"), "size_px"),
        ("background-folder-in-scene", format!("{GOOD}\n[background]\nkind = \"panorama\"\nprocedural = \"clutter\"\nyaw_deg = [0.0, 90.0]\n"), "yaw_deg"),
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

/// Issue 19: bad meshes and object poses: an error naming the file or field, a non-zero exit, no
/// output (image, truth, depth or mask); degenerate triangles among good ones are skipped with a
/// warning.
#[test]
fn bad_objects_fail_cleanly() {
    let quad = "v 0 0 0\nv 0.1 0 0\nv 0.1 0.1 0\nv 0 0.1 0\n";
    let files: Vec<(&str, Vec<u8>)> = vec![
        ("malformed.obj", b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 x\n".to_vec()),
        ("textured.obj", format!("mtllib textured.mtl\n{quad}vt 0 0\nvt 1 0\nvt 1 1\nusemtl t\nf 1/1 2/2 3/3\n").into_bytes()),
        ("textured.mtl", b"newmtl t\nKd 1 1 1\nmap_Kd broken.png\n".to_vec()),
        ("broken.png", b"\x89PNG this is not an image".to_vec()),
        ("degenerate.obj", format!("{quad}f 1 2 2\nf 1 1 1\nf 1 2 3\n").into_bytes()),
        ("soup.obj", format!("{quad}f 1 2 2\nf 3 3 3\n").into_bytes()),
        ("good.obj", format!("{quad}f 1 2 3\nf 1 3 4\n").into_bytes()),
    ];
    let object = |mesh: &str, t: &str| format!("{GOOD}\n[[object]]\nmesh = \"{mesh}\"\nrvec = [0.0, 0.0, 0.0]\nt_m = {t}\n");
    let cases: Vec<(&str, String, &str)> = vec![
        ("missing-obj", object("nowhere.obj", "[0.0, 0.0, 0.3]"), "nowhere.obj"),
        ("malformed-obj", object("malformed.obj", "[0.0, 0.0, 0.3]"), "malformed.obj"),
        ("bad-texture", object("textured.obj", "[0.0, 0.0, 0.3]"), "broken.png"),
        ("degenerate-soup", object("soup.obj", "[0.0, 0.0, 0.3]"), "soup.obj"),
        ("behind", object("good.obj", "[0.0, 0.0, -0.3]"), "object[0].pose"),
        ("nan-scale", object("good.obj", "[0.0, 0.0, 0.3]\nscale = nan"), "object[0].scale"),
        ("albedo", object("good.obj", "[0.0, 0.0, 0.3]\nalbedo = 300.0"), "object[0].albedo"),
        ("frame-tool", object("good.obj", "[0.0, 0.0, 0.3]\nframe = \"tool\""), "object[0].frame"),
    ];
    let dir = std::env::temp_dir().join(format!("synthcam-bad-objects-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("tmp");
    for (name, bytes) in &files {
        std::fs::write(dir.join(name), bytes).expect("write");
    }
    let run = |name: &str, text: &str| {
        let scene = dir.join(format!("{name}.toml"));
        std::fs::write(&scene, text).expect("write");
        let out = dir.join(format!("{name}.png"));
        let (depth, mask) = (dir.join(format!("{name}.npy")), dir.join(format!("{name}.mask.png")));
        let o = Command::new(bin()).arg("render").arg(&scene).arg("-o").arg(&out).arg("--depth").arg(&depth).arg("--mask").arg(&mask).output().expect("run");
        let wrote = [&out, &out.with_extension("json"), &depth, &mask].iter().any(|p| p.exists());
        (o.status.success(), String::from_utf8_lossy(&o.stderr).into_owned(), wrote)
    };
    for (name, text, needle) in &cases {
        let (ok, stderr, wrote) = run(name, text);
        assert!(!ok, "{name}: exit status 0");
        assert!(!stderr.contains("panicked"), "{name}: panicked: {stderr}");
        assert!(stderr.contains(needle), "{name}: error does not name `{needle}`: {stderr}");
        assert!(!wrote, "{name}: wrote an output file");
    }
    let (ok, stderr, wrote) = run("degenerate", &object("degenerate.obj", "[0.0, 0.0, 0.3]"));
    assert!(ok && wrote, "a mesh with some degenerate triangles renders: {stderr}");
    assert!(stderr.contains("degenerate"), "the skipped triangles are reported: {stderr}");
    let _ = std::fs::remove_dir_all(&dir);
}
