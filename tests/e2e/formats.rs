//! Dataset formats (issue 20, part 2): `synthcam dataset --format` and `synthcam export` write
//! COCO keypoints, WebDataset shards and ROS 2 bags in MCAP; each is read back here with an
//! independent reader (serde_json, the tar crate, the mcap crate and a CDR reader written below)
//! and compared with the truth JSON files and PNGs of the dataset, not with the writers.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use nalgebra::{Isometry3, Matrix3, Quaternion, Rotation3, Translation3, UnitQuaternion, Vector3};
use serde_json::Value;

use crate::common::bin;

fn tmp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("synthcam-formats-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).expect("tmp");
    d
}

fn synthcam(args: &[&str], paths: &[&Path]) -> Output {
    let mut c = Command::new(bin());
    c.args(args);
    for p in paths {
        c.arg(p);
    }
    c.output().expect("run synthcam")
}

fn ok(o: &Output) -> String {
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    String::from_utf8_lossy(&o.stdout).into_owned()
}

fn failed(o: &Output, needle: &str) {
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success(), "expected a failure, stdout: {}", String::from_utf8_lossy(&o.stdout));
    assert!(err.contains(needle), "stderr lacks `{needle}`: {err}");
}

/// A `count`-image tiny chessboard dataset, written with `--format formats`.
fn tiny(root: &Path, count: u32, formats: &str) -> PathBuf {
    let spec = root.join("tiny.toml");
    std::fs::write(&spec, include_str!("../../assets/specs/tiny.toml").replace("count = 200", &format!("count = {count}"))).expect("spec");
    let dir = root.join("tiny");
    ok(&synthcam(&["dataset", "-o"], &[&dir, &spec]));
    if !formats.is_empty() {
        ok(&synthcam(&["export", "--format", formats], &[&dir]));
    }
    dir
}

fn truth(dir: &Path, k: u64) -> Value {
    serde_json::from_slice(&std::fs::read(dir.join(format!("images/{k:06}.json"))).expect("truth")).expect("json")
}

fn f(v: &Value) -> f64 {
    v.as_f64().expect("number")
}

#[test]
fn coco_keypoints_are_the_truth_pixels() {
    let root = tmp("coco");
    let dir = tiny(&root, 5, "coco");
    let coco: Value = serde_json::from_slice(&std::fs::read(dir.join("coco.json")).unwrap()).unwrap();
    assert_eq!(f(&coco["info"]["pixel_centre_offset_px"]), 0.5);
    assert!(coco["info"]["pixel_convention"].as_str().unwrap().contains("(0, 0)"));
    let images = coco["images"].as_array().unwrap();
    let anns = coco["annotations"].as_array().unwrap();
    assert_eq!((images.len(), anns.len()), (5, 5));
    let cat = &coco["categories"][0];
    assert_eq!(cat["name"], "chessboard");
    let mut max_err: f64 = 0.0;
    for (k, (img, ann)) in images.iter().zip(anns).enumerate() {
        let t = truth(&dir, k as u64);
        assert_eq!(img["file_name"], format!("images/{k:06}.png"));
        assert_eq!((&img["width"], &img["height"]), (&t["camera"]["width"], &t["camera"]["height"]));
        assert_eq!(ann["image_id"], img["id"]);
        let kp = ann["keypoints"].as_array().unwrap();
        let feats = t["features"].as_array().unwrap();
        assert_eq!(kp.len(), 3 * feats.len());
        assert_eq!(cat["keypoints"].as_array().unwrap().len(), feats.len());
        let mut labelled = 0;
        for (i, ft) in feats.iter().enumerate() {
            let v = kp[3 * i + 2].as_u64().unwrap();
            let expect = if ft["visible"] == true {
                2
            } else if ft["in_image"] == true {
                1
            } else {
                0
            };
            assert_eq!(v, expect, "image {k} feature {i}");
            if v > 0 {
                labelled += 1;
                max_err = max_err.max((f(&kp[3 * i]) - f(&ft["pixel_px"][0])).abs()).max((f(&kp[3 * i + 1]) - f(&ft["pixel_px"][1])).abs());
            }
        }
        assert_eq!(ann["num_keypoints"].as_u64().unwrap(), labelled);
        let b: Vec<f64> = ann["bbox"].as_array().unwrap().iter().map(f).collect();
        let xs: Vec<f64> = feats.iter().map(|ft| f(&ft["pixel_px"][0])).collect();
        assert_eq!(b[0], xs.iter().copied().fold(f64::INFINITY, f64::min));
        assert!((f(&ann["area"]) - b[2] * b[3]).abs() < 1e-9);
    }
    assert_eq!(max_err, 0.0, "keypoints differ from the truth by {max_err} px");
    println!("coco: 5 images, keypoints max |error| {max_err} px");
}

/// A shard's name and its files (name, bytes).
type ShardFiles = (String, Vec<(String, Vec<u8>)>);

/// Every (name, bytes) of every shard of `dir`, shard by shard.
fn shards(dir: &Path) -> Vec<ShardFiles> {
    let mut names: Vec<_> = std::fs::read_dir(dir).unwrap().flatten().map(|e| e.file_name().to_string_lossy().into_owned()).collect();
    names.sort();
    names
        .into_iter()
        .map(|n| {
            let bytes = std::fs::read(dir.join(&n)).unwrap();
            let mut a = tar::Archive::new(bytes.as_slice());
            let files = a
                .entries()
                .unwrap()
                .map(|e| {
                    let mut e = e.unwrap();
                    let mut b = Vec::new();
                    std::io::Read::read_to_end(&mut e, &mut b).unwrap();
                    (e.path().unwrap().display().to_string(), b)
                })
                .collect();
            (n, files)
        })
        .collect()
}

#[test]
fn webdataset_shards_hold_every_image_and_truth() {
    let root = tmp("wds");
    let dir = tiny(&root, 6, "webdataset");
    let one = shards(&dir.join("webdataset"));
    assert_eq!(one.len(), 1);
    assert_eq!(one[0].0, "shard-000000.tar");
    let mut expect = BTreeMap::new();
    for k in 0..6u64 {
        for ext in ["png", "json"] {
            expect.insert(format!("{k:06}.{ext}"), std::fs::read(dir.join(format!("images/{k:06}.{ext}"))).unwrap());
        }
    }
    let got: BTreeMap<String, Vec<u8>> = one[0].1.iter().cloned().collect();
    assert_eq!(got, expect);
    // Small shards: split between samples, never inside one, every file exactly once.
    let out = root.join("small");
    let o = synthcam(&["export", "--format", "webdataset", "--shard-bytes", "60000", "-o"], &[&out, &dir]);
    ok(&o);
    let many = shards(&out);
    assert!(many.len() >= 3, "{} shards", many.len());
    let mut all = BTreeMap::new();
    for (name, files) in &many {
        let stems: std::collections::BTreeSet<&str> = files.iter().map(|(n, _)| &n[..6]).collect();
        for s in &stems {
            assert_eq!(files.iter().filter(|(n, _)| n.starts_with(s)).count(), 2, "{name}: sample {s} split");
        }
        all.extend(files.iter().cloned());
    }
    assert_eq!(all, expect);
    println!("webdataset: 6 samples in 1 shard; {} shards at --shard-bytes 60000", many.len());
}

/// Little-endian CDR reader (alignment counted after the 4-byte encapsulation header).
pub(crate) struct Cdr<'a>(&'a [u8], usize);

impl<'a> Cdr<'a> {
    pub(crate) fn new(b: &'a [u8]) -> Self {
        assert_eq!(&b[..4], &[0, 1, 0, 0], "CDR_LE encapsulation");
        Cdr(b, 4)
    }
    fn take(&mut self, n: usize, align: usize) -> &'a [u8] {
        self.1 += (align - (self.1 - 4) % align) % align;
        let s = &self.0[self.1..self.1 + n];
        self.1 += n;
        s
    }
    pub(crate) fn u32(&mut self) -> u32 {
        u32::from_le_bytes(self.take(4, 4).try_into().unwrap())
    }
    pub(crate) fn f64(&mut self) -> f64 {
        f64::from_le_bytes(self.take(8, 8).try_into().unwrap())
    }
    pub(crate) fn string(&mut self) -> String {
        let n = self.u32() as usize;
        let b = self.take(n, 1);
        assert_eq!(b[n - 1], 0);
        String::from_utf8(b[..n - 1].to_vec()).unwrap()
    }
    pub(crate) fn header(&mut self) -> (u32, u32, String) {
        (self.u32(), self.u32(), self.string())
    }
}

fn iso(t: [f64; 3], q: [f64; 4]) -> Isometry3<f64> {
    Isometry3::from_parts(Translation3::from(Vector3::from(t)), UnitQuaternion::from_quaternion(Quaternion::new(q[3], q[0], q[1], q[2])))
}

/// /tf of one message: (parent, child) -> parent_from_child.
pub(crate) fn tf(data: &[u8]) -> BTreeMap<(String, String), Isometry3<f64>> {
    let mut c = Cdr::new(data);
    (0..c.u32())
        .map(|_| {
            let (_, _, parent) = c.header();
            let child = c.string();
            let v: Vec<f64> = (0..7).map(|_| c.f64()).collect();
            ((parent, child), iso([v[0], v[1], v[2]], [v[3], v[4], v[5], v[6]]))
        })
        .collect()
}

fn check_camera_info(data: &[u8], cam: &Value) {
    let mut c = Cdr::new(data);
    let (_, _, frame) = c.header();
    assert_eq!(frame, "cam0");
    assert_eq!((c.u32(), c.u32()), (cam["height"].as_u64().unwrap() as u32, cam["width"].as_u64().unwrap() as u32));
    assert_eq!(c.string(), "plumb_bob");
    let d: Vec<f64> = (0..c.u32()).map(|_| c.f64()).collect();
    let dist: Vec<f64> = cam["dist"].as_array().unwrap().iter().map(f).collect();
    assert_eq!(d, dist);
    assert_eq!(d, [-0.05, 0.01, 0.0005, -0.0003, 0.002]);
    let k: Vec<f64> = (0..9).map(|_| c.f64()).collect();
    assert_eq!(k, [f(&cam["fx"]), 0.0, f(&cam["cx"]), 0.0, f(&cam["fy"]), f(&cam["cy"]), 0.0, 0.0, 1.0]);
}

fn check_bag(dir: &Path, bytes: &[u8]) -> BTreeMap<String, usize> {
    let mut counts = BTreeMap::new();
    for m in mcap::MessageStream::new(bytes).unwrap() {
        let m = m.unwrap();
        let topic = m.channel.topic.clone();
        let schema = m.channel.schema.as_ref().unwrap();
        assert_eq!((m.channel.message_encoding.as_str(), schema.encoding.as_str()), ("cdr", "ros2msg"));
        let n = counts.entry(topic.clone()).or_insert(0usize);
        let k = *n as u64;
        *n += 1;
        assert_eq!(m.log_time, k * 100_000_000);
        let t = truth(dir, k);
        match topic.as_str() {
            "/cam0/camera_info" => check_camera_info(&m.data, &t["camera"]),
            "/cam0/image_raw" => {
                let png = image::open(dir.join(format!("images/{k:06}.png"))).unwrap().into_luma8();
                assert_eq!(&m.data[m.data.len() - png.as_raw().len()..], png.as_raw().as_slice(), "image {k}");
                let mut c = Cdr::new(&m.data);
                c.header();
                assert_eq!((c.u32(), c.u32(), c.string()), (png.height(), png.width(), "mono8".into()));
            }
            "/tf" => {
                let tfs = tf(&m.data);
                let get = |p: &str, c: &str| tfs[&(p.to_string(), c.to_string())];
                let r = &t["cam_from_target"]["R"];
                let rot = Rotation3::from_matrix(&Matrix3::from_fn(|i, j| f(&r[i][j])));
                let tm = &t["cam_from_target"]["t_m"];
                let truth_pose = Isometry3::from_parts(Translation3::new(f(&tm[0]), f(&tm[1]), f(&tm[2])), UnitQuaternion::from_rotation_matrix(&rot));
                let cam_target = get("cam0", "target");
                assert!((cam_target.to_homogeneous() - truth_pose.to_homogeneous()).abs().max() < 1e-12, "image {k}");
                // The S-path's frame is the world: the chain world -> base -> tool0 -> cam0 ->
                // target closes on the identity.
                let loop_ = get("world", "base") * get("base", "tool0") * get("tool0", "cam0") * cam_target;
                assert!((loop_.to_homogeneous() - Isometry3::identity().to_homogeneous()).abs().max() < 1e-9, "image {k}: {loop_}");
            }
            other => panic!("unexpected topic {other}"),
        }
    }
    counts
}

#[test]
fn robot_dataset_bag_matches_the_truth_and_the_camera() {
    let root = tmp("mcap");
    let spec = root.join("robot.toml");
    let text = include_str!("../../assets/specs/s_path_robot.toml")
        .replace("count = 50", "count = 3")
        .replace("width = 1280", "width = 640")
        .replace("height = 1024", "height = 512")
        .replace("fx = 1500.0", "fx = 750.0")
        .replace("fy = 1500.0", "fy = 750.0")
        .replace("cx = 640.0", "cx = 320.0")
        .replace("cy = 512.0", "cy = 256.0\ndist = [-0.05, 0.01, 0.0005, -0.0003, 0.002]");
    std::fs::write(&spec, text).unwrap();
    let dir = root.join("robot");
    let out = ok(&synthcam(&["dataset", "--format", "mcap,coco", "-o"], &[&dir, &spec]));
    assert!(out.contains("mcap: 3 images"), "{out}");
    let bytes = std::fs::read(dir.join("ros2.mcap")).unwrap();
    let counts = check_bag(&dir, &bytes);
    let expect: BTreeMap<String, usize> = [("/cam0/camera_info", 3), ("/cam0/image_raw", 3), ("/tf", 3)].into_iter().map(|(t, n)| (t.to_string(), n)).collect();
    assert_eq!(counts, expect);
    println!("mcap: {counts:?}, {} bytes", bytes.len());
}

fn leftovers(dir: &Path) -> Vec<String> {
    std::fs::read_dir(dir).unwrap().flatten().map(|e| e.file_name().to_string_lossy().into_owned()).filter(|n| n.contains(".tmp")).collect()
}

#[test]
fn bad_input_fails_cleanly_without_output() {
    let root = tmp("bad");
    let dir = tiny(&root, 3, "");
    failed(&synthcam(&["export", "--format", "coco"], &[&root.join("nope")]), "spec.toml");
    failed(&synthcam(&["export", "--format", "parquet"], &[&dir]), "unknown format `parquet`");
    failed(&synthcam(&["dataset", "merge", "--format", "yolo"], &[&dir]), "unknown format `yolo`");
    // Board views are no time series.
    failed(&synthcam(&["export", "--format", "mcap"], &[&dir]), "mode = \"robot\"");
    assert!(!dir.join("ros2.mcap").exists());
    // A damaged PNG: no shards.
    let png = dir.join("images/000001.png");
    let good = std::fs::read(&png).unwrap();
    let mut bad = good.clone();
    let n = bad.len();
    bad[n / 2] ^= 0xff;
    std::fs::write(&png, &bad).unwrap();
    failed(&synthcam(&["export", "--format", "webdataset"], &[&dir]), "does not match the manifest");
    assert!(!dir.join("webdataset").exists());
    std::fs::write(&png, &good).unwrap();
    // A corrupt truth JSON and an incomplete manifest.
    let json = dir.join("images/000002.json");
    let t = std::fs::read(&json).unwrap();
    std::fs::write(&json, &t[..t.len() / 2]).unwrap();
    failed(&synthcam(&["export", "--format", "coco"], &[&dir]), "truth JSON");
    assert!(!dir.join("coco.json").exists());
    std::fs::write(&json, &t).unwrap();
    let manifest = std::fs::read_to_string(dir.join("manifest.jsonl")).unwrap();
    std::fs::write(dir.join("manifest.jsonl"), manifest.lines().take(2).collect::<Vec<_>>().join("\n")).unwrap();
    failed(&synthcam(&["export", "--format", "coco"], &[&dir]), "1 missing (k = 2)");
    assert!(!dir.join("coco.json").exists());
    assert_eq!(leftovers(&dir), Vec::<String>::new());
    // -o with two formats is refused before anything is written.
    std::fs::write(dir.join("manifest.jsonl"), manifest).unwrap();
    failed(&synthcam(&["export", "--format", "coco,webdataset", "-o"], &[&root.join("x"), &dir]), "one --format");
    assert!(!root.join("x").exists());
    // Repaired, the merge verifies the folder and exports it.
    let out = ok(&synthcam(&["dataset", "merge", "--format", "coco"], &[&dir]));
    assert!(out.contains("coco: 3 images"), "{out}");
    assert!(dir.join("coco.json").is_file());
}
