//! `synthcam bench --report`: the table of issue 42 (every kind of scene at 1280 x 1024 and 3x,
//! dataset images/s, servo steps/s, the adapter's name), the images it keeps, and the comparison of
//! one run's images with another's: here GL llvmpipe's with Vulkan lavapipe's, which must be
//! identical (as a GPU's are checked against lavapipe's by `benches/gpu.sh`).

use serde_json::Value;

use crate::common::bin;

fn report(dir: &std::path::Path, extra: &[&str]) -> std::process::Output {
    std::process::Command::new(bin()).args(["bench", "--report", "--frames", "1", "--servo-steps", "3", "--out"]).arg(dir).args(extra).output().expect("runs")
}

#[test]
fn the_report_times_every_scene_and_compares_backends() {
    let root = std::env::temp_dir().join(format!("synthcam-bench-report-test-{}", std::process::id()));
    let (vk, gl) = (root.join("vulkan"), root.join("gl"));
    let _ = std::fs::remove_dir_all(&root);
    let o = report(&vk, &["--backend", "vulkan"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let json: Value = serde_json::from_slice(&std::fs::read(vk.join("report.json")).expect("report.json")).expect("json");
    let rows = json["rows"].as_array().expect("rows");
    assert_eq!(rows.len(), 12, "5 scenes at two sizes, 2 effects scenes");
    for row in rows {
        let (w, h) = (row["width"].as_u64().unwrap(), row["height"].as_u64().unwrap());
        assert!((w, h) == (1280, 1024) || (w, h) == (3840, 3072), "{row}");
        assert!(row["frames_per_s"].as_f64().unwrap() > 0.0);
        let png = image::open(vk.join(format!("{}_{w}x{h}.png", row["scene"].as_str().unwrap()))).expect("the scene's image");
        assert_eq!((u64::from(png.width()), u64::from(png.height())), (w, h));
    }
    assert!(json["adapter"].as_str().unwrap().contains("Vulkan"));
    assert!(json["dataset_images_per_s"].as_f64().unwrap() > 0.0 && json["servo_steps_per_s"].as_f64().unwrap() > 0.0);
    assert_eq!(json["servo_steps"], 4, "steps 0..=3");
    let table = String::from_utf8_lossy(&o.stdout);
    assert!(table.contains("| s_path | 3840 x 3072 |") && table.contains("images/s") && table.contains("steps/s"), "{table}");
    // GL against Vulkan: every image identical.
    let o = report(&gl, &["--backend", "gl", "--compare", vk.to_str().unwrap()]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let json: Value = serde_json::from_slice(&std::fs::read(gl.join("report.json")).expect("report.json")).expect("json");
    for row in json["rows"].as_array().unwrap() {
        assert_eq!(row["vs_reference"][0], 0, "GL differs from Vulkan: {row}");
    }
    // A reference folder that is not there is a clear error.
    let o = report(&root.join("x"), &["--compare", root.join("missing").to_str().unwrap()]);
    assert!(!o.status.success() && String::from_utf8_lossy(&o.stderr).contains("reference"), "{}", String::from_utf8_lossy(&o.stderr));
    let _ = std::fs::remove_dir_all(&root);
}
