"""Pose helpers: `facing` places the board's centre on the optical axis (checked on the renderer's
truth), `pose` builds the `[pose]` table, `rotation_from_rvec` is Rodrigues' formula."""

import numpy as np
import pytest

import synthcam

tomllib = pytest.importorskip("tomllib", reason="skipped: tomllib needs Python 3.11")


def test_rotation_from_rvec_known_values():
    # a quarter turn about z sends x to y (right-handed)
    r = synthcam.rotation_from_rvec([0.0, 0.0, np.pi / 2])
    assert np.allclose(r @ [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], atol=1e-15)
    assert np.allclose(synthcam.rotation_from_rvec([0.0, 0.0, 0.0]), np.eye(3))
    with pytest.raises(ValueError, match="finite"):
        synthcam.rotation_from_rvec([np.nan, 0.0, 0.0])


def test_facing_puts_the_board_centre_on_the_axis(board_scene_text):
    scene = tomllib.loads(board_scene_text)
    del scene["pose"]
    scene["facing"] = synthcam.facing(0.9, tilt_x_deg=25.0, roll_deg=10.0)
    _, truth = synthcam.render(scene)
    pts = np.array([f["point_target_m"] for f in truth["features"]])
    pose = truth["cam_from_target"]
    centre_cam = np.array(pose["R"]) @ pts.mean(axis=0) + np.array(pose["t_m"])
    assert np.allclose(centre_cam, [0.0, 0.0, 0.9], atol=1e-9)
    # tilted 25 degrees: the board's normal (target z) is 25 degrees off the optical axis
    assert np.degrees(np.arccos(np.array(pose["R"])[2, 2])) == pytest.approx(25.0, abs=1e-9)


def test_pose_and_facing_reject_nonsense(board_scene_text):
    with pytest.raises(ValueError, match="positive"):
        synthcam.facing(0.0)
    with pytest.raises(ValueError, match="not both"):
        synthcam.pose([0, 0, 1], R=np.eye(3), rvec=[0, 0, 0])
    with pytest.raises(ValueError, match="3 x 3"):
        synthcam.pose([0, 0, 1], R=np.eye(2))
    assert synthcam.pose([0, 0, 1], R=np.eye(3)) == {"R": np.eye(3).tolist(), "t_m": [0.0, 0.0, 1.0]}
    scene = tomllib.loads(board_scene_text)
    scene["facing"] = synthcam.facing(0.9)  # and the file's [pose]: one too many
    with pytest.raises(synthcam.SynthcamError, match="not both"):
        synthcam.render(scene)


def test_pose_rvec_inverts_rodrigues_at_known_rotations():
    # a quarter turn about z, a half turn about x (the branch near pi), and a tiny turn
    quarter = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    assert np.allclose(synthcam.Pose(quarter, np.zeros(3)).rvec, [0.0, 0.0, np.pi / 2], atol=1e-12)
    half = np.diag([1.0, -1.0, -1.0])
    assert np.allclose(np.abs(synthcam.Pose(half, np.zeros(3)).rvec), [np.pi, 0.0, 0.0], atol=1e-12)
    for rvec in ([1e-9, 0.0, 0.0], [0.3, -0.2, 0.1], [2.0, 1.0, -0.5]):
        p = synthcam.Pose.from_rvec(rvec, [1.0, 2.0, 3.0])
        assert np.allclose(p.rvec, rvec, atol=1e-12)
        assert np.allclose((p @ p.inverse()).matrix(), np.eye(4), atol=1e-12)
        assert np.allclose(p.apply([[0.0, 0.0, 0.0]]), [[1.0, 2.0, 3.0]])


def test_results_are_typed_and_answer_as_dicts(board_scene_text):
    image, truth = synthcam.render(board_scene_text)
    found = synthcam.detect(image, "chessboard:11x8")
    assert isinstance(truth, synthcam.Truth) and isinstance(found, synthcam.Detection)
    assert found.found and found.points_px.shape == (88, 2) and found["points_px"].shape == (88, 2)
    assert truth.pixels_px.shape == (88, 2) and truth.points_target_m.shape == (88, 3) and truth.visible.all()
    assert np.sqrt(((found.points_px - truth.pixels_px) ** 2).sum(1).mean()) < 0.02
    assert found.position_sigma_px is not None and np.isfinite(found.position_sigma_px).all()
    # the truth's pose maps every feature's target point to the camera ray of its pixel's depth
    cam = truth.cam_from_target.apply(truth.points_target_m)
    assert np.allclose(cam[:, 2], [f["depth_m"] for f in truth.features], atol=1e-9)
