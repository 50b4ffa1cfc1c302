"""Dataset formats read back by their own ecosystems' readers.

Runs the `synthcam` binary (env SYNTHCAM_BIN, default <repo>/target/release/synthcam) to make a
small chessboard dataset, a small robot-mode dataset and a short servo run, exports them, and
loads the results with pycocotools (COCO keypoints), webdataset (tar shards) and mcap +
mcap-ros2-support (ROS 2 bags), comparing with the truth JSON files and the specs' cameras.

    pip install pycocotools webdataset mcap mcap-ros2-support pytest numpy
"""

import glob
import json
import os
import subprocess
import time
from collections import Counter
from pathlib import Path

import numpy as np
import pytest

REPO = Path(__file__).resolve().parents[2]
BIN = os.environ.get("SYNTHCAM_BIN", str(REPO / "target" / "release" / "synthcam"))
TIMINGS = {}


def synthcam(*args, check=True):
    t0 = time.perf_counter()
    r = subprocess.run([BIN, *map(str, args)], capture_output=True, text=True)
    TIMINGS[" ".join(map(str, args[:2]))] = time.perf_counter() - t0
    if check:
        assert r.returncode == 0, r.stderr
    return r


def spec_text(name, replacements):
    text = (REPO / "assets" / "specs" / name).read_text()
    for a, b in replacements:
        assert a in text, a
        text = text.replace(a, b)
    return text


@pytest.fixture(scope="module")
def tiny(tmp_path_factory):
    root = tmp_path_factory.mktemp("tiny")
    spec = root / "tiny.toml"
    spec.write_text(spec_text("tiny.toml", [("count = 200", "count = 12")]))
    out = root / "ds"
    synthcam("dataset", spec, "-o", out, "--format", "coco,webdataset")
    synthcam("export", out, "--format", "webdataset", "--shard-bytes", "100000", "-o", root / "small")
    return out, root / "small"


ROBOT = [
    ("count = 50", "count = 4"),
    ("width = 1280", "width = 640"),
    ("height = 1024", "height = 512"),
    ("fx = 1500.0", "fx = 750.0"),
    ("fy = 1500.0", "fy = 750.0"),
    ("cx = 640.0", "cx = 320.0"),
    ("cy = 512.0", "cy = 256.0\ndist = [-0.05, 0.01, 0.0005, -0.0003, 0.002]"),
]


@pytest.fixture(scope="module")
def robot(tmp_path_factory):
    root = tmp_path_factory.mktemp("robot")
    spec = root / "robot.toml"
    spec.write_text(spec_text("s_path_robot.toml", ROBOT))
    out = root / "ds"
    synthcam("dataset", spec, "-o", out)
    synthcam("export", out, "--format", "mcap,rosbag2")
    return out


def truth(ds, k):
    return json.loads((ds / "images" / f"{k:06d}.json").read_text())


def test_coco_loads_with_pycocotools_and_keypoints_are_the_truth(tiny):
    from pycocotools.coco import COCO

    ds, _ = tiny
    coco = COCO(str(ds / "coco.json"))
    assert len(coco.getImgIds()) == 12
    assert coco.dataset["info"]["pixel_centre_offset_px"] == 0.5
    cat = coco.loadCats(coco.getCatIds())[0]
    max_err, labelled = 0.0, 0
    for img in coco.loadImgs(coco.getImgIds()):
        t = truth(ds, img["id"])
        assert (img["width"], img["height"]) == (t["camera"]["width"], t["camera"]["height"])
        assert (ds / img["file_name"]).is_file()
        (ann,) = coco.loadAnns(coco.getAnnIds(imgIds=[img["id"]]))
        kp = np.array(ann["keypoints"], dtype=float).reshape(-1, 3)
        assert len(kp) == len(t["features"]) == len(cat["keypoints"])
        for row, f in zip(kp, t["features"]):
            v = 2 if f["visible"] else (1 if f["in_image"] else 0)
            assert row[2] == v
            if v:
                labelled += 1
                max_err = max(max_err, float(np.abs(row[:2] - np.array(f["pixel_px"])).max()))
        assert ann["num_keypoints"] == int((kp[:, 2] > 0).sum())
    assert max_err <= 1e-9
    print(f"coco: 12 images, {labelled} labelled keypoints, max |error| {max_err} px")


def check_samples(ds, samples):
    keys = sorted(s["__key__"] for s in samples)
    assert keys == [f"{k:06d}" for k in range(12)]
    for s in samples:
        k = int(s["__key__"])
        assert s["png"] == (ds / "images" / f"{k:06d}.png").read_bytes()
        assert json.loads(s["json"]) == truth(ds, k)


def test_webdataset_yields_every_sample(tiny):
    import webdataset as wds

    ds, small = tiny
    shards = sorted(glob.glob(str(ds / "webdataset" / "shard-*.tar")))
    assert [Path(p).name for p in shards] == ["shard-000000.tar"]
    check_samples(ds, list(wds.WebDataset(shards, shardshuffle=False)))
    many = sorted(glob.glob(str(small / "shard-*.tar")))
    assert len(many) >= 3
    check_samples(ds, list(wds.WebDataset(many, shardshuffle=False)))
    print(f"webdataset: 12 samples from 1 shard; 12 from {len(many)} shards at --shard-bytes 100000")


def read_bag(path):
    """Messages by topic, decoded by mcap-ros2-support from the bag's own ros2msg schemas."""
    from types import SimpleNamespace

    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory

    by_topic = {}
    with open(path, "rb") as f:
        for _, channel, message, ros_msg in make_reader(f, decoder_factories=[DecoderFactory()]).iter_decoded_messages():
            by_topic.setdefault(channel.topic, []).append(SimpleNamespace(channel=channel, message=message, ros_msg=ros_msg, log_time_ns=message.log_time))
    return by_topic


def check_camera_info(msg, cam):
    assert (msg.width, msg.height) == (cam["width"], cam["height"])
    assert msg.distortion_model == "plumb_bob"
    k = [cam["fx"], cam.get("skew", 0.0), cam["cx"], 0, cam["fy"], cam["cy"], 0, 0, 1]
    assert np.allclose(msg.k, k, rtol=0, atol=1e-12)
    d = (cam.get("dist") or []) + [0.0] * 5
    assert np.allclose(msg.d, d[:5], rtol=0, atol=1e-12)
    assert msg.header.frame_id == "cam0"


def transforms(msg):
    out = {}
    for t in msg.transforms:
        tr, q = t.transform.translation, t.transform.rotation
        x, y, z, w = q.x, q.y, q.z, q.w
        r = np.array(
            [
                [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
            ]
        )
        m = np.eye(4)
        m[:3, :3], m[:3, 3] = r, [tr.x, tr.y, tr.z]
        out[(t.header.frame_id, t.child_frame_id)] = m
    return out


def test_robot_dataset_bag_reads_with_mcap_ros2(robot):
    bag = read_bag(robot / "ros2.mcap")
    counts = {t: len(m) for t, m in bag.items()}
    assert counts == {"/cam0/image_raw": 4, "/cam0/camera_info": 4, "/tf": 4}
    cam = truth(robot, 0)["camera"]
    for m in bag["/cam0/camera_info"]:
        check_camera_info(m.ros_msg, cam)
    for k, m in enumerate(bag["/cam0/image_raw"]):
        img = m.ros_msg
        assert (img.encoding, img.width, img.height, img.step) == ("mono8", 640, 512, 640)
        assert len(img.data) == 640 * 512
        assert m.log_time_ns == k * 100_000_000
    for k, m in enumerate(bag["/tf"]):
        tf = transforms(m.ros_msg)
        t = truth(robot, k)["cam_from_target"]
        cam_target = tf[("cam0", "target")]
        assert np.allclose(cam_target[:3, :3], t["R"], atol=1e-12) and np.allclose(cam_target[:3, 3], t["t_m"], atol=1e-12)
        chain = tf[("world", "base")] @ tf[("base", "tool0")] @ tf[("tool0", "cam0")] @ cam_target
        assert np.allclose(chain, np.eye(4), atol=1e-9)
    print(f"mcap (robot dataset): {counts}, CameraInfo K/D/size match the spec")


def test_servo_bag_reads_with_mcap_ros2(tmp_path):
    out = tmp_path / "servo"
    synthcam("servo", "--law", "pbvs", "--steps", "4", "--no-compare", "--no-stop", "--true-handeye", "-o", out, "--mcap", out / "run.mcap")
    bag = read_bag(out / "run.mcap")
    trace = json.loads((out / "trace.json").read_text())
    counts = {t: len(m) for t, m in bag.items()}
    assert counts["/cam0/image_raw"] == counts["/cam0/camera_info"] == counts["/tf"] >= 4
    info = bag["/cam0/camera_info"][0].ros_msg
    img = bag["/cam0/image_raw"][0].ros_msg
    assert (img.width, img.height) == (info.width, info.height)
    assert len(img.data) == img.step * img.height
    steps = {s["step"]: s for s in trace["steps"]}
    for m in bag["/tf"]:
        step = m.log_time_ns // 100_000_000
        tf = transforms(m.ros_msg)
        world_cam = tf[("world", "base")] @ tf[("base", "tool0")] @ tf[("tool0", "cam0")]
        assert np.allclose(world_cam[:3, 3], steps[step]["cam_position_m"], atol=1e-9)
        assert ("world", "target") in tf
    print(f"mcap (servo): {counts}")


def rosbags_reader(folder):
    """rosbags' AnyReader on a rosbag2 folder, with ROS 2 Humble's message types."""
    pytest.importorskip("rosbags", reason="skipped: rosbags is not installed (pip install rosbags)")
    from rosbags.highlevel import AnyReader
    from rosbags.typesys import Stores, get_typestore

    return AnyReader([folder], default_typestore=get_typestore(Stores.ROS2_HUMBLE))


def test_rosbag2_folders_open_with_rosbags(robot, tmp_path):
    """`export --format rosbag2` and `servo --rosbag2`: folders that rosbags' AnyReader opens; the
    messages are the single-file bag's, the metadata counts them."""
    folder = robot / "rosbag2"
    assert sorted(p.name for p in folder.iterdir()) == ["metadata.yaml", "rosbag2_0.mcap"]
    assert (folder / "rosbag2_0.mcap").read_bytes() == (robot / "ros2.mcap").read_bytes()
    with rosbags_reader(folder) as reader:
        counts = {c.topic: c.msgcount for c in reader.connections}
        assert counts == {"/cam0/image_raw": 4, "/cam0/camera_info": 4, "/tf": 4}
        assert (reader.start_time, reader.duration) == (0, 3 * 100_000_000 + 1)
        cam = truth(robot, 0)["camera"]
        images = [c for c in reader.connections if c.topic == "/cam0/image_raw"]
        for k, (conn, stamp, raw) in enumerate(reader.messages(connections=images)):
            img = reader.deserialize(raw, conn.msgtype)
            assert (img.width, img.height, img.encoding, stamp) == (cam["width"], cam["height"], "mono8", k * 100_000_000)
            assert img.data.shape == (img.step * img.height,) and img.data.std() > 10  # a rendered board, not a blank
        infos = [c for c in reader.connections if c.topic == "/cam0/camera_info"]
        for conn, _, raw in reader.messages(connections=infos):
            check_camera_info(reader.deserialize(raw, conn.msgtype), cam)
    out = tmp_path / "servo"
    synthcam("servo", "--law", "pbvs", "--steps", "3", "--no-compare", "--no-stop", "--true-handeye", "-o", out, "--rosbag2", out / "bag")
    with rosbags_reader(out / "bag") as reader:
        counts = {c.topic: c.msgcount for c in reader.connections}
        assert counts["/cam0/image_raw"] == counts["/tf"] == sum(1 for _ in reader.messages()) // 3 >= 3
    # a folder that is not a bag is not overwritten
    (tmp_path / "keep").mkdir()
    (tmp_path / "keep" / "mine.txt").write_text("x")
    r = synthcam("export", robot, "--format", "rosbag2", "-o", tmp_path / "keep", check=False)
    assert r.returncode != 0 and "not a rosbag2 folder" in r.stderr
    assert sorted(p.name for p in (tmp_path / "keep").iterdir()) == ["mine.txt"]
    # nor one that has a metadata.yaml beside other files
    (tmp_path / "keep" / "metadata.yaml").write_text("x")
    r = synthcam("export", robot, "--format", "rosbag2", "-o", tmp_path / "keep", check=False)
    assert r.returncode != 0 and "not a rosbag2 folder" in r.stderr
    assert sorted(p.name for p in (tmp_path / "keep").iterdir()) == ["metadata.yaml", "mine.txt"]
    # an earlier export there is replaced
    synthcam("export", robot, "--format", "rosbag2", "-o", tmp_path / "again")
    synthcam("export", robot, "--format", "rosbag2", "-o", tmp_path / "again")
    assert sorted(p.name for p in (tmp_path / "again").iterdir()) == ["again_0.mcap", "metadata.yaml"]
    print(f"rosbag2: rosbags AnyReader reads {counts} from the servo folder and the dataset's 4 frames")


def test_bad_input_fails_without_output(tiny, tmp_path):
    ds, _ = tiny
    r = synthcam("export", tmp_path / "missing", "--format", "coco", check=False)
    assert r.returncode != 0 and "spec.toml" in r.stderr
    r = synthcam("export", ds, "--format", "mcap", "-o", tmp_path / "x.mcap", check=False)
    assert r.returncode != 0 and 'mode = "robot"' in r.stderr
    assert not (tmp_path / "x.mcap").exists()
    r = synthcam("export", ds, "--format", "hdf5", check=False)
    assert r.returncode != 0 and "unknown format" in r.stderr


def test_zz_report_timings():
    print("timings (s):", {k: round(v, 2) for k, v in TIMINGS.items()})
