"""calibrate from Python on detected corners of rendered views, against the scene's true camera."""

import numpy as np
import pytest

import synthcam

tomllib = pytest.importorskip("tomllib", reason="skipped: tomllib needs Python 3.11")

# Views of the board, rotated about its centre, 1 m in front of the camera.
RVECS = [(0.45, 0.0, 0.0), (-0.45, 0.0, 0.0), (0.0, 0.45, 0.0), (0.0, -0.45, 0.0), (0.35, 0.35, 0.3), (-0.35, 0.3, -0.3)]


rodrigues = synthcam.rotation_from_rvec

CENTRE = np.array([0.3, 0.225, 0.0])  # middle of the 11 x 8 inner corners, 50 mm apart, in the target frame


def views(board_scene_text):
    scene = tomllib.loads(board_scene_text)
    centre = CENTRE
    for rvec in RVECS:
        t = np.array([0.0, 0.0, 1.0]) - rodrigues(rvec) @ centre
        scene["pose"] = {"rvec": list(rvec), "t_m": t.tolist()}
        scene["render"]["noise_sigma"] = 1.0
        yield scene


def test_calibration_recovers_the_rendered_camera(board_scene_text):
    detections = []
    for scene in views(board_scene_text):
        image, _ = synthcam.render(scene)
        detections.append(synthcam.detect(image, "chessboard:11x8"))
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
    # The poses, in metres (square_m 0.05 given): the calibration's board frame is the scene's
    # target frame (origin at the board's outer corner), so each view's pose is the scene's.
    for rvec, view, typed in zip(RVECS, r["views"], r.views):
        t_true = np.array([0.0, 0.0, 1.0]) - rodrigues(rvec) @ CENTRE
        assert np.abs(np.array(view["tvec"]) - t_true).max() < 0.002
        assert np.abs(np.array(view["rvec"]) - np.array(rvec)).max() < 0.002
        # the typed result: the same pose as a Pose (R from the rvec the dict holds)
        assert np.abs(typed.cam_from_target.t_m - t_true).max() < 0.002
        assert np.abs(typed.cam_from_target.R - rodrigues(rvec)).max() < 0.002
    assert isinstance(r, synthcam.Calibration) and r.K.shape == (3, 3) and r.dist.shape == (5,)
    # No corner of a clean render is an outlier; the views leave nothing undetermined; the
    # projection is surer where the views saw the board than outside.
    assert r.outliers_dropped == 0 and all(v.outliers == [] for v in r.views) and r.undetermined == []
    assert 0.0 < r.uncertainty_inside_px < r.uncertainty_outside_px
    # Three corners moved 3 px: flagged by their index in the detection (untrusted corners, left
    # out, do not shift it), and dropped.
    bad = [dict(d) for d in detections]
    for i, j in [(0, 7), (2, 40), (2, 41)]:  # not among the corners the detector marks untrusted
        pts = np.array(bad[i]["points_px"], dtype=float)
        pts[j] += 3.0
        bad[i]["points_px"] = pts
    rb = synthcam.calibrate(bad, "chessboard:11x8", 0.05, (1280, 1024))
    assert [v.outliers for v in rb.views][:3] == [[7], [], [40, 41]] and rb.outliers_dropped == 3
    assert rb.rms_px < 0.05 < rb["rms_before_rejection_px"]
    kept = synthcam.calibrate(bad, "chessboard:11x8", 0.05, (1280, 1024), outlier_threshold=None)
    assert kept.outliers_dropped == 0 and kept.rms_px > 0.05


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
