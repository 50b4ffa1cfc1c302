"""`synthcam servo|sim|dataset --rerun FILE.rrd` (the Rust command line, built with
`--features rerun`) read back with rerun-sdk's reader (`synthcam.rerun_log.RecordedRun`) and
checked against the run's own JSON trace, the truth files and the PNGs.

Skips (saying why) when rerun-sdk is missing or when the binary (env SYNTHCAM_BIN, default
<repo>/target/release/synthcam) was built without the `rerun` feature, as the default build and
CI's are.
"""

import json
import os
import subprocess
from pathlib import Path

import numpy as np
import pytest

REPO = Path(__file__).resolve().parents[2]
BIN = os.environ.get("SYNTHCAM_BIN", str(REPO / "target" / "release" / "synthcam"))
OFFSET = 0.5  # rerun's pixel centres: OpenCV's + 0.5

pytest.importorskip("rerun", reason="skipped: rerun-sdk is not installed (pip install rerun-sdk)")
from synthcam.rerun_log import RecordedRun, Recorder  # noqa: E402

# Every entity of the Python recorder, and the true pose error curves.
RUN_ENTITIES = set(Recorder.ENTITIES) | {"error/pose_mm", "error/pose_deg", "joints/q0"}


def run_cli(*args):
    """The binary's result; skips the test on a binary built without the `rerun` feature."""
    r = subprocess.run([BIN, *map(str, args)], capture_output=True, text=True, cwd=REPO)
    if r.returncode != 0 and "built without rerun support" in r.stderr:
        pytest.skip("skipped: the synthcam binary was built without the `rerun` feature (cargo build --release --features rerun)")
    return r


def synthcam(*args):
    r = run_cli(*args)
    assert r.returncode == 0, r.stderr
    return r


def dataset_recording(tmp_path, spec_name, count_line, count):
    """`dataset SPEC --rerun` on a copy of assets/specs/SPEC with `count` images: (folder, run)."""
    spec = tmp_path / spec_name
    spec.write_text((REPO / "assets" / "specs" / spec_name).read_text().replace(count_line, f"count = {count}"))
    out, rrd = tmp_path / "ds", tmp_path / "ds.rrd"
    synthcam("dataset", spec, "-o", out, "--rerun", rrd)
    return out, RecordedRun(rrd)


def assert_truth_points(run, entity, truth_json, k):
    """The recording's true points at step k are the truth file's visible features (+ OFFSET)."""
    truth = json.loads(truth_json.read_text())
    pts = run.value(entity, "Points2D:positions", k)
    assert np.allclose(pts, np.array([f["pixel_px"] for f in truth["features"] if f["visible"]]) + OFFSET, atol=1e-4)


def test_sim_recording_holds_every_step_of_the_trace(tmp_path):
    rrd, js = tmp_path / "sim.rrd", tmp_path / "sim.json"
    synthcam("sim", "assets/scenarios/ur5e_chessboard.toml", "--law", "ibvs", "--views", "3", "--json", js, "--rerun", rrd)
    steps = json.loads(js.read_text())["trace"]["steps"]
    run = RecordedRun(rrd)
    assert RUN_ENTITIES <= set(run.entities) and "command/qdot0" in run.entities, run.entities
    assert run.frames == list(range(len(steps)))
    assert run.image(0).shape == (1200, 1920)
    for k, s in enumerate(steps):
        for i, q in enumerate(s["q_rad"]):
            assert float(run.value(f"joints/q{i}", "Scalars:scalars", k)[0]) == pytest.approx(q, abs=1e-12)
        assert int(run.value("features/detected", "Scalars:scalars", k)[0]) == s["features"]
        assert float(run.value("error/pose_mm", "Scalars:scalars", k)[0]) == pytest.approx(s["goal_error_mm_deg"][0], rel=1e-12)
    # detected features lie on their true projections (a whole board, sub-pixel)
    last = len(steps) - 1
    det = run.value("world/camera/image/detected", "Points2D:positions", last)
    ids = run.value("world/camera/image/detected", "Points2D:keypoint_ids", last)
    tru = dict(zip(run.value("world/camera/image/truth", "Points2D:keypoint_ids", last).tolist(), run.value("world/camera/image/truth", "Points2D:positions", last)))
    err = np.array([np.linalg.norm(p - tru[i]) for p, i in zip(det, ids.tolist())])
    assert len(err) == steps[-1]["features"] and err.max() < 0.5, err.max()
    print(f"sim --rerun: {run.bytes} bytes, {len(run.entities)} entities, {len(run.frames)} frames; detected vs truth max {err.max():.4f} px")


def test_servo_recording_matches_the_trace(tmp_path):
    out, rrd = tmp_path / "servo", tmp_path / "servo.rrd"
    synthcam("servo", "--law", "ibvs", "--steps", "6", "--no-compare", "--no-stop", "--true-handeye", "-o", out, "--rerun", rrd)
    trace = json.loads((out / "trace.json").read_text())
    run = RecordedRun(rrd)
    assert RUN_ENTITIES <= set(run.entities), run.entities
    assert run.frames == [s["step"] for s in trace["steps"]]
    steps, rms = run.scalars("error/pixel_rms_px")
    want = {s["step"]: s["pixel_rms_px"] for s in trace["steps"]}
    assert all(rms[j] == pytest.approx(want[int(k)], rel=1e-9) for j, k in enumerate(steps))
    for s in trace["steps"]:
        pts = run.value("world/camera/image/detected", "Points2D:positions", s["step"])
        f = np.array(s["features_px"])
        assert np.allclose(pts, f[:, 1:] + OFFSET, atol=1e-4)
        assert run.value("world/camera/image/detected", "Points2D:keypoint_ids", s["step"]).tolist() == f[:, 0].astype(int).tolist()
    desired = run.value("world/camera/image/desired", "Points2D:positions")  # static
    assert np.allclose(desired, np.array([d for d in trace["desired_px"] if d is not None]) + OFFSET, atol=1e-4)
    print(f"servo --rerun: {run.bytes} bytes, {len(run.frames)} frames")


def test_dataset_recording_holds_images_and_truth(tmp_path):
    out, run = dataset_recording(tmp_path, "tiny.toml", "count = 200", 5)
    assert {"world/camera", "world/camera/image", "world/camera/image/truth", "world/target/features", "camera_info"} <= set(run.entities)
    assert run.frames == list(range(5))
    from PIL import Image

    for k in range(5):
        png = np.asarray(Image.open(out / "images" / f"{k:06d}.png"))
        assert np.array_equal(run.image(k), png)
        assert_truth_points(run, "world/camera/image/truth", out / "images" / f"{k:06d}.json", k)


def test_unwritable_recording_fails_and_leaves_nothing(tmp_path):
    bad = tmp_path / "missing" / "x.rrd"
    (tmp_path / "missing").write_text("a file, not a folder")
    r = run_cli("sim", "assets/scenarios/ur5e_chessboard.toml", "--views", "0", "--steps", "2", "--rerun", bad)
    assert r.returncode != 0 and "x.rrd" in r.stderr, r.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["missing"]


def test_rig_dataset_recording_has_each_camera(tmp_path):
    out, run = dataset_recording(tmp_path, "stereo_rig_1280.toml", "count = 20", 2)
    for name in ("left", "right"):
        entity = f"world/{name}/image"
        assert run.steps(entity, "EncodedImage:blob") == [0, 1], run.entities
        assert f"world/{name}/image/truth" in run.entities and f"world/{name}" in run.entities
        for k in range(2):
            assert_truth_points(run, f"world/{name}/image/truth", out / "images" / name / f"{k:06d}.json", k)
