"""synthcam.rerun_log: a servo run logged to a rerun .rrd file and read back with rerun-sdk's reader."""

import subprocess
import sys

import numpy as np
import pytest

rr = pytest.importorskip("rerun", reason="skipped: rerun-sdk is not installed (pip install rerun-sdk, or pip install 'synthcam[rerun]')")

import synthcam  # noqa: E402
from synthcam.rerun_log import RecordedRun, Recorder, record_servo  # noqa: E402

STEPS = 12


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    """A 12-step IBVS run on "ur5e_chessboard" with frames, its summary and the file read back."""
    path = tmp_path_factory.mktemp("rerun") / "run.rrd"
    summary = record_servo(path, "ur5e_chessboard", steps=STEPS, seed=3)
    if not hasattr(__import__("rerun.chunk").chunk, "RrdReader"):
        pytest.skip(f"skipped: reading back needs rerun.chunk.RrdReader (rerun-sdk 0.41), found {rr.__version__}")
    return path, summary, RecordedRun(path)


def test_the_run_has_every_entity(run):
    path, summary, rec = run
    assert summary["steps"] == STEPS and summary["frames"] == STEPS
    assert summary["bytes"] == path.stat().st_size == rec.bytes > 0
    assert not path.with_name(path.name + ".partial").exists()
    for entity in Recorder.ENTITIES + tuple(f"joints/q{i}" for i in range(6)) + tuple(f"command/qdot{i}" for i in range(6)):
        assert entity in rec.entities, entity
    assert "Pinhole:image_from_camera" in rec.components("world/camera/image")
    assert "Image:buffer" in rec.components("world/camera/image")
    assert "Transform3D:mat3x3" in rec.components("world/camera")


def test_one_step_index_per_step_and_a_frame_at_each(run):
    _, _, rec = run
    assert rec.steps("world/camera/image", "Image:buffer") == list(range(STEPS))
    assert rec.frames == list(range(STEPS))
    for entity in ("world/camera", "world/camera/image/detected", "world/camera/image/truth", "world/camera/image/desired", "joints/q0"):
        component = "Scalars:scalars" if entity.startswith("joints") else rec.components(entity)[-1]
        assert rec.steps(entity, "Transform3D:translation" if entity == "world/camera" else component) == list(range(STEPS)), entity
    # the commands: one after every observation but the last
    assert rec.steps("command/qdot0", "Scalars:scalars") == list(range(STEPS - 1))


def test_image_and_pinhole_are_the_cameras(run):
    _, _, rec = run
    cam = synthcam.Sim("ur5e_chessboard").info["camera"]
    image = rec.image(STEPS // 2)
    assert image.shape == (cam["height"], cam["width"]) and image.dtype == np.uint8 and image.std() > 0
    np.testing.assert_array_equal(rec.value("world/camera/image", "Pinhole:resolution").reshape(-1), [cam["width"], cam["height"]])
    # rerun stores the 3 x 3 column-major; the principal point moves to rerun's pixel-corner convention
    K = rec.value("world/camera/image", "Pinhole:image_from_camera").reshape(3, 3).T
    o = Recorder.PIXEL_OFFSET
    np.testing.assert_allclose(K, [[cam["fx"], 0, cam["cx"] + o], [0, cam["fy"], cam["cy"] + o], [0, 0, 1]], rtol=1e-6)
    assert "distortion" in str(rec.value("camera_info", "TextDocument:text"))


def test_logged_points_and_poses_are_the_observations(tmp_path):
    """Log two observations by hand: the file's points and poses are theirs (float32, +0.5 px)."""
    sim = synthcam.Sim("ur5e_chessboard")
    path = tmp_path / "two.rrd"
    goal = sim.observe_goal()
    observations = []
    with Recorder(path, sim.info) as rec:
        rec.log_goal(goal)
        for k in range(2):
            obs = sim.observe(image=False)
            observations.append(obs)
            rec.log(k, obs)
            sim.command([0.05, 0.0, 0.0, 0.0, 0.0, 0.0], 0.1)
    back = RecordedRun(path)
    assert back.frames == []  # image=False: no frame
    o = Recorder.PIXEL_OFFSET
    for k, obs in enumerate(observations):
        detected = back.value("world/camera/image/detected", "Points2D:positions", k)
        np.testing.assert_array_equal(detected, (obs.pixels_px + o).astype(np.float32))
        np.testing.assert_array_equal(back.value("world/camera/image/detected", "Points2D:keypoint_ids", k), obs.ids)
        seen = np.flatnonzero(np.isfinite(obs.truth_px[:, 0]))
        np.testing.assert_array_equal(back.value("world/camera/image/truth", "Points2D:keypoint_ids", k), seen)
        np.testing.assert_allclose(back.value("world/camera/image/truth", "Points2D:positions", k), obs.truth_px[seen] + o, atol=1e-4, rtol=0)
        np.testing.assert_allclose(back.value("world/camera/image/desired", "Points2D:positions", k), goal.pixels_px + o, atol=1e-4, rtol=0)
        w_c = obs.world_from_cam.matrix()
        np.testing.assert_allclose(back.value("world/camera", "Transform3D:translation", k).reshape(3), w_c[:3, 3], atol=1e-6)
        np.testing.assert_allclose(back.value("world/camera", "Transform3D:mat3x3", k).reshape(3, 3).T, w_c[:3, :3], atol=1e-6)
        w_t = w_c @ obs.cam_from_target.matrix()
        np.testing.assert_allclose(back.value("world/target", "Transform3D:translation", k).reshape(3), w_t[:3, 3], atol=1e-6)
        steps, q = back.scalars("joints/q0")
        assert q[k] == pytest.approx(obs.q_rad[0])
    w_g = goal.world_from_cam.matrix()
    np.testing.assert_allclose(back.value("world/goal_camera", "Transform3D:translation").reshape(3), w_g[:3, 3], atol=1e-6)


def test_the_error_curve_decreases(run):
    _, summary, rec = run
    steps, rms = rec.scalars("error/pixel_rms_px")
    assert list(steps) == list(range(STEPS))
    assert rms[0] == pytest.approx(summary["initial_rms_px"]) and rms[-1] == pytest.approx(summary["final_rms_px"])
    assert np.all(np.diff(rms) < 0), rms
    assert rms[-1] < 0.1 * rms[0], rms
    _, det = rec.scalars("error/detection_rms_px")
    assert np.all(det < 1.0), det  # the detector against the truth, sub-pixel


@pytest.mark.parametrize("where", ["missing_dir", "a_directory", "under_a_file"])
def test_an_unwritable_path_is_a_clear_error_and_leaves_nothing(tmp_path, where):
    info = synthcam.Sim("ur5e_chessboard").info
    (tmp_path / "file").write_text("x")
    path = {"missing_dir": tmp_path / "missing" / "run.rrd", "a_directory": tmp_path, "under_a_file": tmp_path / "file" / "run.rrd"}[where]
    before = sorted(p.name for p in tmp_path.iterdir())
    with pytest.raises(OSError, match="cannot write the rerun recording"):
        Recorder(path, info)
    with pytest.raises(OSError, match="cannot write the rerun recording"):
        record_servo(path, steps=2)
    assert sorted(p.name for p in tmp_path.iterdir()) == before


def test_a_failed_run_leaves_no_file(tmp_path):
    sim = synthcam.Sim("ur5e_chessboard")
    path = tmp_path / "failed.rrd"
    with pytest.raises(RuntimeError, match="boom"):
        with Recorder(path, sim.info) as rec:
            rec.log(0, sim.observe())
            raise RuntimeError("boom")
    assert list(tmp_path.iterdir()) == []
    with pytest.raises(ValueError, match="steps"):
        record_servo(path, steps=0)
    with pytest.raises(ValueError, match="closed"):
        rec.log(1, sim.observe())


def test_the_command_line_prints_the_summary(tmp_path):
    import json

    out = tmp_path / "cli.rrd"
    r = subprocess.run(
        [sys.executable, "-m", "synthcam.rerun_log", "--steps", "3", "--no-image", "-o", str(out)], capture_output=True, text=True, timeout=300
    )
    assert r.returncode == 0, r.stderr
    summary = json.loads(r.stdout)
    assert summary["steps"] == 3 and summary["frames"] == 0 and summary["bytes"] == out.stat().st_size
    assert summary["final_rms_px"] < summary["initial_rms_px"]


def test_synthcam_imports_without_rerun():
    """``import synthcam`` and ``synthcam.rerun_log`` work without rerun-sdk; a Recorder says what to install."""
    code = (
        "import sys; sys.modules['rerun'] = None\n"
        "import synthcam, synthcam.rerun_log as m\n"
        "try:\n"
        "    m.Recorder('x.rrd', {'camera': {}})\n"
        "except ImportError as e:\n"
        "    print(e)\n"
    )
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    assert "pip install rerun-sdk" in r.stdout
