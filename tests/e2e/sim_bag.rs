//! `synthcam sim --mcap`: an open scenario's loop written as a ROS 2 bag, one frame per step of
//! the run's JSON trace, with the scenario's camera and the arm's transforms at that step;
//! `--rosbag2`: the same bag in a rosbag2 folder with its `metadata.yaml`.

use std::collections::BTreeMap;

use serde_json::Value;
use synthcam::sim::{ScenarioSpec, UR5E_CHESSBOARD};

use crate::common::bin;
use crate::formats::{tf, Cdr};

#[test]
fn sim_loop_bag_holds_every_step_with_its_joints() {
    let dir = std::env::temp_dir().join(format!("synthcam-sim-bag-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let (json, bag, folder) = (dir.join("run.json"), dir.join("run.mcap"), dir.join("run_bag"));
    let o = std::process::Command::new(bin())
        .args(["sim", "assets/scenarios/ur5e_chessboard.toml", "--law", "ibvs", "--views", "3", "--json"])
        .arg(&json)
        .arg("--mcap")
        .arg(&bag)
        .arg("--rosbag2")
        .arg(&folder)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let run: Value = serde_json::from_slice(&std::fs::read(&json).unwrap()).unwrap();
    let steps = run["trace"]["steps"].as_array().unwrap();
    let spec = ScenarioSpec::parse(UR5E_CHESSBOARD).unwrap();
    let (scenario, robot) = (spec.to_scenario().unwrap(), spec.robot.build(&|_| Err("no files".into())).unwrap());
    let k = scenario.camera.intrinsics;
    let mut counts = BTreeMap::new();
    for m in mcap::MessageStream::new(&std::fs::read(&bag).unwrap()).unwrap() {
        let m = m.unwrap();
        let n = counts.entry(m.channel.topic.clone()).or_insert(0usize);
        let step = &steps[*n];
        *n += 1;
        // Stamped at the simulator's frame (hand-eye views came first) x 100 ms.
        assert_eq!(m.log_time, step["frame"].as_u64().unwrap() * 100_000_000);
        let mut c = Cdr::new(&m.data);
        match m.channel.topic.as_str() {
            "/cam0/camera_info" => {
                assert_eq!(c.header().2, "cam0");
                assert_eq!((c.u32(), c.u32()), (scenario.camera.size.height, scenario.camera.size.width));
                let _model = c.string();
                let d: Vec<f64> = (0..c.u32()).map(|_| c.f64()).collect();
                assert_eq!(d[0], -0.2);
                let kk: Vec<f64> = (0..9).map(|_| c.f64()).collect();
                assert_eq!(kk, [k.fx, k.skew, k.cx, 0.0, k.fy, k.cy, 0.0, 0.0, 1.0]);
            }
            "/tf" => {
                let q: Vec<f64> = step["q_rad"].as_array().unwrap().iter().map(|v| v.as_f64().unwrap()).collect();
                let base_tool = tf(&m.data)[&("base".to_string(), "tool0".to_string())];
                let fk = robot.base_from_tool(&q).unwrap();
                assert!((base_tool.to_homogeneous() - fk.to_homogeneous()).abs().max() < 1e-9, "step {}", n);
            }
            "/cam0/image_raw" => {
                assert_eq!(c.header().2, "cam0");
                assert_eq!((c.u32(), c.u32()), (scenario.camera.size.height, scenario.camera.size.width));
            }
            other => panic!("unexpected topic {other}"),
        }
    }
    let each = steps.len();
    assert!(each > 3);
    assert_eq!(counts.values().copied().collect::<Vec<_>>(), vec![each; 3], "{counts:?}");
    // The folder holds the same bag, byte for byte, and metadata that counts it.
    assert_eq!(std::fs::read(folder.join("run_bag_0.mcap")).unwrap(), std::fs::read(&bag).unwrap());
    let meta = std::fs::read_to_string(folder.join("metadata.yaml")).unwrap();
    let last = steps[each - 1]["frame"].as_u64().unwrap() * 100_000_000;
    let first = steps[0]["frame"].as_u64().unwrap() * 100_000_000;
    for line in [
        format!("  message_count: {}\n", 3 * each),
        format!("    nanoseconds: {}\n", last - first),
        format!("    nanoseconds_since_epoch: {first}\n"),
        "    - run_bag_0.mcap\n".into(),
        "        name: /tf\n        type: tf2_msgs/msg/TFMessage\n".into(),
    ] {
        assert!(meta.contains(&line), "{line:?} not in\n{meta}");
    }
    assert_eq!(meta.matches(&format!("      message_count: {each}\n")).count(), 3, "{meta}");
    assert_eq!(std::fs::read_dir(&folder).unwrap().count(), 2, "only the bag and its metadata");
    println!("sim --mcap --rosbag2: {each} steps -> {counts:?}");
}

/// `--rerun`: a build without the `rerun` feature refuses it before the run (non-zero exit, the
/// way to get it, no file); a build with it writes a rerun recording (rerun's `RRF2` stream
/// header) and no temporary file beside it. python/tests/test_rerun_cli.py reads the recordings
/// back with rerun-sdk.
#[test]
fn sim_rerun_recording_or_a_clear_refusal() {
    let dir = std::env::temp_dir().join(format!("synthcam-sim-rrd-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let rrd = dir.join("run.rrd");
    let o = std::process::Command::new(bin())
        .args(["sim", "assets/scenarios/ur5e_chessboard.toml", "--law", "ibvs", "--views", "0", "--steps", "3", "--rerun"])
        .arg(&rrd)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&o.stderr);
    let names: Vec<String> = std::fs::read_dir(&dir).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect();
    if cfg!(feature = "rerun") {
        // Three steps do not converge: the run fails after writing its recording.
        assert!(stderr.contains("did not converge"), "{stderr}");
        assert_eq!(names, ["run.rrd"]);
        assert_eq!(&std::fs::read(&rrd).unwrap()[..4], b"RRF2");
    } else {
        assert!(!o.status.success() && stderr.contains("without rerun support") && stderr.contains("--features rerun"), "{stderr}");
        assert!(names.is_empty(), "{names:?}");
        // Refused before the run: nothing of the run was printed.
        assert!(o.stdout.is_empty(), "{}", String::from_utf8_lossy(&o.stdout));
    }
    let _ = std::fs::remove_dir_all(&dir);
}
