"""calibrate from Python on detected corners of rendered views, against the scene's true camera."""

import numpy as np
import pytest

import synthcam

tomllib = pytest.importorskip("tomllib", reason="skipped: tomllib needs Python 3.11")

# Views of the board, rotated about its centre, 1 m in front of the camera.
RVECS = [(0.45, 0.0, 0.0), (-0.45, 0.0, 0.0), (0.0, 0.45, 0.0), (0.0, -0.45, 0.0), (0.35, 0.35, 0.3), (-0.35, 0.3, -0.3)]


def rodrigues(rvec):
    r = np.asarray(rvec, float)
    theta = np.linalg.norm(r)
    if theta < 1e-12:
        return np.eye(3)
    k = r / theta
    kx = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + np.sin(theta) * kx + (1 - np.cos(theta)) * kx @ kx


CENTRE = np.array([0.25, 0.175, 0.0])  # middle of the 11 x 8 inner corners, 50 mm apart


def views(board_scene_text):
    scene = tomllib.loads(board_scene_text)
    centre = CENTRE
    for rvec in RVECS:
        t = np.array([0.0, 0.0, 1.0]) - rodrigues(rvec) @ centre
        scene["pose"] = {"rvec": list(rvec), "t_m": t.tolist()}
        scene["render"]["noise_sigma"] = 1.0
        yield scene


def test_calibration_recovers_the_rendered_camera(board_scene_text):
    detections, truths = [], []
    for scene in views(board_scene_text):
        image, truth = synthcam.render(scene)
        detections.append(synthcam.detect(image, "chessboard:11x8"))
        truths.append(truth)
    assert all(d["found"] for d in detections)
    r = synthcam.calibrate(detections, "chessboard:11x8", 0.05, (1280, 1024))
    k, dist = np.array(r["K"]), r["dist"]
    print(f"rms {r['rms_px']:.4f} px; fx {k[0, 0]:.3f} fy {k[1, 1]:.3f} cx {k[0, 2]:.3f} cy {k[1, 2]:.3f}; k1 {dist[0]:.5f}")
    assert r["converged"] and r["used"] == list(range(len(RVECS)))
    assert r["rms_px"] < 0.05
    # The true camera: fx = fy = 1500, (cx, cy) = (639.5, 511.5), k1 = -0.25, the rest 0.
    assert k[0, 0] == pytest.approx(1500.0, abs=1.0) and k[1, 1] == pytest.approx(1500.0, abs=1.0)
    assert k[0, 2] == pytest.approx(639.5, abs=1.0) and k[1, 2] == pytest.approx(511.5, abs=1.0)
    assert dist[0] == pytest.approx(-0.25, abs=0.003)
    assert len(dist) == 5 and r["camera"]["width"] == 1280
    # The poses, in metres (square_m 0.05 given): the calibration's board frame has its origin
    # at the first inner corner, the scene's target frame where the truth says that corner is.
    for rvec, view, truth in zip(RVECS, r["views"], truths):
        t_true = np.array([0.0, 0.0, 1.0]) - rodrigues(rvec) @ CENTRE + rodrigues(rvec) @ np.array(truth["features"][0]["point_target_m"])
        assert np.abs(np.array(view["tvec"]) - t_true).max() < 0.002


def test_calibrate_bad_input():
    det = {"found": True, "points_px": np.zeros((88, 2))}
    with pytest.raises(synthcam.SynthcamError, match="views"):
        synthcam.calibrate([det], "chessboard:11x8", 0.05, (1280, 1024))
    with pytest.raises(ValueError, match="square_m"):
        synthcam.calibrate([det] * 3, "chessboard:11x8", -1.0, (1280, 1024))
    with pytest.raises(ValueError, match="unknown model"):
        synthcam.calibrate([det] * 3, "chessboard:11x8", 0.05, (1280, 1024), model="pinhole9")
    with pytest.raises(synthcam.SynthcamError, match="points"):
        synthcam.calibrate([{"points_px": np.zeros((5, 2))}] * 3, "chessboard:11x8", 0.05, (1280, 1024))
    with pytest.raises(ValueError, match="chessboard"):
        synthcam.calibrate([det] * 3, "dot-grid:3x3", 0.05, (1280, 1024))
