//! `synthcam dataset`: sharded runs are byte-identical to the unsharded run, runs resume, merge
//! verifies, and bad specs or failing writes give a typed error, a non-zero exit and no partial file.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use crate::common::{bin, images};

const TINY: &str = include_str!("../../assets/specs/tiny.toml");

fn tmp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("synthcam-ds-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).expect("tmp");
    d
}

fn write_spec(dir: &Path, text: &str) -> PathBuf {
    let p = dir.join("spec-in.toml");
    std::fs::write(&p, text).expect("write spec");
    p
}

fn run(args: &[&str]) -> Output {
    Command::new(bin()).arg("dataset").args(args).output().expect("run")
}

fn s(p: &Path) -> &str {
    p.to_str().expect("utf-8 path")
}

fn ok(o: &Output) -> String {
    let stdout = String::from_utf8_lossy(&o.stdout).into_owned();
    assert!(o.status.success(), "failed: {}\n{stdout}", String::from_utf8_lossy(&o.stderr));
    stdout
}

#[test]
fn four_shards_are_byte_identical_to_the_unsharded_run() {
    let root = tmp("shards");
    let spec = write_spec(&root, TINY);
    let (one, four) = (root.join("one"), root.join("four"));
    let t0 = std::time::Instant::now();
    ok(&run(&[s(&spec), "-o", s(&one), "--jobs", "2"]));
    eprintln!("200 images unsharded: {:.2} s", t0.elapsed().as_secs_f64());
    for i in 0..4 {
        let shard = format!("{i}/4");
        let jobs = if i % 2 == 0 { "1" } else { "2" };
        ok(&run(&[s(&spec), "-o", s(&four), "--shard", &shard, "--jobs", jobs]));
    }
    // Before merging the four shards hold no complete manifest.
    assert!(!four.join("manifest.jsonl").exists());
    ok(&run(&["merge", s(&four)]));
    let (a, b) = (images(&one), images(&four));
    assert_eq!(a.len(), 400, "200 PNG + 200 JSON");
    assert_eq!(a.keys().collect::<Vec<_>>(), b.keys().collect::<Vec<_>>());
    for (name, bytes) in &a {
        assert!(bytes == &b[name], "{name} differs between the unsharded and the sharded run");
    }
    let ma = std::fs::read_to_string(one.join("manifest.jsonl")).expect("manifest");
    let mb = std::fs::read_to_string(four.join("manifest.jsonl")).expect("manifest");
    assert_eq!(ma.lines().count(), 200);
    assert_eq!(ma, mb);
    // Merging a complete unsharded folder verifies it and leaves its manifest byte-identical.
    ok(&run(&["merge", s(&one)]));
    assert_eq!(std::fs::read_to_string(one.join("manifest.jsonl")).expect("manifest"), ma);
    assert_eq!(std::fs::read_to_string(four.join("spec.toml")).expect("spec copy"), TINY);
    let _ = std::fs::remove_dir_all(&root);
}

#[test]
fn a_run_resumes_and_redoes_damaged_images() {
    let root = tmp("resume");
    let spec = write_spec(&root, &TINY.replace("count = 200", "count = 24"));
    let out = root.join("out");
    ok(&run(&[s(&spec), "-o", s(&out)]));
    let first = images(&out);
    let manifest = std::fs::read_to_string(out.join("manifest.jsonl")).expect("manifest");
    let img = out.join("images");
    std::fs::remove_file(img.join("000003.png")).expect("rm");
    std::fs::remove_file(img.join("000005.json")).expect("rm");
    let png9 = &first["000009.png"];
    std::fs::write(img.join("000009.png"), &png9[..png9.len() / 2]).expect("truncate");
    std::fs::write(img.join(".000007.png.tmp99999"), b"partial").expect("plant tmp");
    let stdout = ok(&run(&[s(&spec), "-o", s(&out), "--jobs", "2"]));
    assert!(stdout.contains("24 images (21 kept, 3 rendered, 1 leftover temp files removed)"), "{stdout}");
    assert_eq!(images(&out), first, "resumed files differ from the first run (or a temp file is left)");
    assert_eq!(std::fs::read_to_string(out.join("manifest.jsonl")).expect("manifest"), manifest);
    // A third run keeps everything.
    let stdout = ok(&run(&[s(&spec), "-o", s(&out)]));
    assert!(stdout.contains("(24 kept, 0 rendered"), "{stdout}");
    // A different spec into the same folder is refused.
    let other = write_spec(&root, &TINY.replace("count = 200", "count = 25"));
    let o = run(&[s(&other), "-o", s(&out)]);
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("differs from this spec"));
    let _ = std::fs::remove_dir_all(&root);
}

#[test]
fn merge_reports_missing_and_bad_images() {
    let root = tmp("merge");
    let spec = write_spec(&root, &TINY.replace("count = 200", "count = 12"));
    let out = root.join("out");
    for i in [0, 2] {
        ok(&run(&[s(&spec), "-o", s(&out), "--shard", &format!("{i}/3")]));
    }
    let o = run(&["merge", s(&out)]);
    assert!(!o.status.success());
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(stderr.contains("4 missing (k = 1, 4, 7, 10)"), "{stderr}");
    assert!(!out.join("manifest.jsonl").exists());
    ok(&run(&[s(&spec), "-o", s(&out), "--shard", "1/3"]));
    let mut png = std::fs::read(out.join("images/000005.png")).expect("png");
    let n = png.len();
    png[n - 20] ^= 0xff;
    std::fs::write(out.join("images/000005.png"), &png).expect("corrupt");
    let o = run(&["merge", s(&out)]);
    assert!(!o.status.success());
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(stderr.contains("0 missing, 1 bad") && stderr.contains("k = 5: images/000005.png: sha256"), "{stderr}");
    let _ = std::fs::remove_dir_all(&root);
}

#[test]
fn bad_specs_fail_cleanly() {
    let cases: Vec<(&str, String, &str)> = vec![
        ("unknown-field", TINY.replace("margin_px = 4.0", "margin_px = 4.0\nmargn = 1"), "margn"),
        ("unknown-top", TINY.replace("seed = 11", "seed = 11\nsede = 1"), "sede"),
        ("nan-distance", TINY.replace("distance_m = [0.45, 0.7]", "distance_m = [nan, 0.7]"), "poses.distance_m"),
        ("inf-fx", TINY.replace("fx = 300.0", "fx = inf"), "fx"),
        ("inverted", TINY.replace("tilt_deg = [0.0, 35.0]", "tilt_deg = [35.0, 0.0]"), "poses.tilt_deg"),
        ("empty-range", TINY.replace("roll_deg = [-20.0, 20.0]", "roll_deg = []"), "roll_deg"),
        ("count-0", TINY.replace("count = 200", "count = 0"), "count"),
        ("version", TINY.replace("version = 1", "version = 2"), "version"),
        ("no-version", TINY.replace("version = 1\n", ""), "version"),
        ("render-seed", TINY.replace("noise_sigma = 1.0", "noise_sigma = 1.0\nseed = 3"), "render.seed"),
        ("unknown-mode", TINY.replace("mode = \"board\"", "mode = \"orbit\""), "orbit"),
        ("board-on-s-path", TINY.replace("kind = \"chessboard\"\nsquares = [7, 5]\nsquare_m = 0.03", "kind = \"s-path\""), "poses.mode"),
        ("never-fits", TINY.replace("distance_m = [0.45, 0.7]", "distance_m = [0.05, 0.1]"), "full_target_visible"),
        ("unknown-range", format!("{TINY}\n[ranges]\n\"sensor.exposure\" = [0.001, 0.002]\n"), "ranges.sensor.exposure"),
        ("range-without-sensor", format!("{TINY}\n[ranges]\n\"sensor.exposure_s\" = [0.001, 0.002]\n"), "[sensor]"),
        ("range-out-of-bounds", format!("{TINY}\n[sensor]\n[ranges]\n\"sensor.prnu\" = [0.0, 2.0]\n"), "sensor.prnu"),
        ("inverted-range", format!("{TINY}\n[sensor]\n[ranges]\n\"sensor.exposure_s\" = [0.01, 0.001]\n"), "ranges.sensor.exposure_s"),
        ("huge-clutter", format!("{TINY}\n[background]\nkind = \"panorama\"\nprocedural = \"clutter\"\nsize_px = [100000, 100000]\n"), "size_px"),
    ];
    for (name, text, needle) in cases {
        let root = tmp(&format!("bad-{name}"));
        let spec = write_spec(&root, &text);
        let out = root.join("out");
        let o = run(&[s(&spec), "-o", s(&out)]);
        let stderr = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success(), "{name}: exit status 0");
        assert!(!stderr.contains("panicked"), "{name}: panicked: {stderr}");
        assert!(stderr.contains(needle), "{name}: error does not name `{needle}`: {stderr}");
        assert!(!out.exists(), "{name}: wrote the output folder");
        let _ = std::fs::remove_dir_all(&root);
    }
}

#[test]
fn unwritable_output_fails_cleanly() {
    let root = tmp("unwritable");
    let spec = write_spec(&root, TINY);
    let file = root.join("a-file");
    std::fs::write(&file, b"x").expect("file");
    let o = run(&[s(&spec), "-o", s(&file.join("out"))]);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success());
    assert!(!stderr.contains("panicked"), "{stderr}");
    assert!(stderr.contains("cannot write"), "{stderr}");
    let o = run(&["merge", "/nonexistent-synthcam-dataset"]);
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("spec.toml"));
    let _ = std::fs::remove_dir_all(&root);
}

/// A write that fails half-way (file size limit: EFBIG, like a full disk) stops the run with an
/// error and leaves no temporary or truncated file behind.
#[test]
fn failing_writes_leave_no_partial_files() {
    let root = tmp("efbig");
    let spec = write_spec(&root, TINY);
    let out = root.join("out");
    // 4 KiB: the spec copy fits, the PNGs (about 9 KB) do not.
    let script = format!("trap '' XFSZ; ulimit -f 4; exec {} dataset {} -o {} --jobs 2", bin(), s(&spec), s(&out));
    let o = Command::new("bash").args(["-c", &script]).output().expect("bash");
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success(), "exit 0: {stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
    assert!(stderr.contains("cannot write") && stderr.contains("File too large"), "{stderr}");
    for (name, bytes) in images(&out) {
        assert!(!name.contains(".tmp"), "temporary file {name} left behind");
        if name.ends_with(".png") {
            assert!(image::load_from_memory(&bytes).is_ok(), "{name} is truncated");
        }
    }
    assert!(!out.join("manifest.jsonl").exists());
    let _ = std::fs::remove_dir_all(&root);
}

/// A tiny spec with every camera effect and per-image [ranges], JPEG output.
const TINY_EFFECTS: &str = r#"version = 1
count = 12
seed = 5
[camera]
width = 320
height = 240
fx = 300.0
fy = 300.0
cx = 159.5
cy = 119.5
dist = [-0.1, 0.0, 0.0, 0.0, 0.0]
[target]
kind = "chessboard"
squares = [7, 5]
square_m = 0.03
[poses]
mode = "board"
distance_m = [0.45, 0.7]
tilt_deg = [0.0, 35.0]
full_target_visible = true
margin_px = 4.0
[sensor]
exposure_s = 0.004
[optics]
f_number = 4.0
focal_length_m = 0.008
focus_distance_m = 0.5
aperture_samples = 8
[motion]
line_delay_s = 2e-5
[output]
format = "rgb-gbrg"
demosaic = "malvar"
encoding = "jpeg"
jpeg_quality = 80
[ranges]
"sensor.exposure_s" = [0.002, 0.006]
"motion.twist.1" = [-0.4, 0.4]
"motion.twist.3" = [-0.2, 0.2]
"optics.f_number" = [2.0, 8.0]
"#;

#[test]
fn camera_effects_datasets_are_shard_invariant_with_per_image_ranges() {
    let root = tmp("effects");
    let spec = write_spec(&root, TINY_EFFECTS);
    let (one, three) = (root.join("one"), root.join("three"));
    ok(&run(&[s(&spec), "-o", s(&one), "--jobs", "2"]));
    for i in 0..3 {
        ok(&run(&[s(&spec), "-o", s(&three), "--shard", &format!("{i}/3"), "--jobs", "1"]));
    }
    ok(&run(&["merge", s(&three)]));
    let (a, b) = (images(&one), images(&three));
    assert_eq!(a.len(), 24, "12 JPEG + 12 JSON");
    assert!(a.contains_key("000000.jpg"));
    assert_eq!(a, b, "sharded and unsharded effect datasets differ");
    // Each image drew its own effects; the truth records them and the rolling-shutter pixels.
    let exposures: std::collections::BTreeSet<String> = (0..12)
        .map(|k| {
            let t: serde_json::Value = serde_json::from_slice(&a[&format!("{k:06}.json")]).expect("json");
            assert!(t["features"][0]["effects"]["rolling_shutter_px"].is_array());
            t["render"]["sensor"]["exposure_s"].to_string()
        })
        .collect();
    assert_eq!(exposures.len(), 12);
    let _ = std::fs::remove_dir_all(&root);
}

/// A background drawn per image from a folder (two images: a dark and a light uniform one), with a
/// random yaw: two shards are byte-identical to the unsharded run; each image's background is one
/// of the folder's (its corner pixel is the dark or the light level, the noise aside); a
/// procedural background changes between images; a folder without images is a named error.
#[test]
fn backgrounds_drawn_per_image_are_shard_invariant() {
    let root = tmp("backgrounds");
    let folder = root.join("walls");
    std::fs::create_dir_all(&folder).expect("folder");
    for (name, level) in [("dark.png", 30u8), ("light.png", 220u8)] {
        image::GrayImage::from_pixel(64, 32, image::Luma([level])).save(folder.join(name)).expect("png");
    }
    let text =
        TINY.replace("count = 200", "count = 12") + &format!("\n[background]\nkind = \"panorama\"\nfolder = \"{}\"\nyaw_deg = [0.0, 360.0]\n", s(&folder));
    let spec = write_spec(&root, &text);
    let (one, two) = (root.join("one"), root.join("two"));
    ok(&run(&[s(&spec), "-o", s(&one)]));
    for i in 0..2 {
        ok(&run(&[s(&spec), "-o", s(&two), "--shard", &format!("{i}/2")]));
    }
    ok(&run(&["merge", s(&two)]));
    let (a, b) = (images(&one), images(&two));
    assert_eq!(a, b, "sharded and unsharded runs differ");
    let corners: Vec<u8> = (0..12).map(|k| image::open(one.join(format!("images/{k:06}.png"))).expect("png").to_luma8().get_pixel(0, 0)[0]).collect();
    assert!(corners.iter().all(|v| v.abs_diff(30) <= 6 || v.abs_diff(220) <= 6), "{corners:?}");
    assert!(corners.iter().any(|v| *v < 100) && corners.iter().any(|v| *v > 150), "both images drawn: {corners:?}");
    // An empty folder: a named error, nothing written.
    let empty = root.join("empty");
    std::fs::create_dir_all(&empty).expect("empty");
    let bad = write_spec(&root, &text.replace(s(&folder), s(&empty)));
    let o = run(&[s(&bad), "-o", s(&root.join("bad"))]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success() && err.contains("background.folder") && !err.contains("panicked"), "{err}");
    let _ = std::fs::remove_dir_all(&root);
}
