"""render + detect from Python against the truth labels (independent: the truth is the exact
f64 projection of each corner, the detector sees only the pixels)."""

import struct
import threading
import time
import zlib

import numpy as np
import pytest


import synthcam

tomllib = pytest.importorskip("tomllib", reason="skipped: tomllib needs Python 3.11")


def corner_errors(found, truth):
    """Each corner's distance to its exact truth pixel."""
    truth_px = np.array([f["pixel_px"] for f in truth["features"]])
    assert found["points_px"].shape == truth_px.shape
    return np.linalg.norm(found["points_px"] - truth_px, axis=1)


def test_distorted_board_corners_within_0_015_px(board_scene_text):
    image, truth = synthcam.render(board_scene_text)
    assert image.shape == (1024, 1280) and image.dtype == np.uint8
    found = synthcam.detect(image, "chessboard:11x8")
    assert found["found"]
    errors = corner_errors(found, truth)
    rms, worst = float(np.sqrt((errors**2).mean())), float(errors.max())
    print(f"88 corners, RMS error vs truth {rms:.4f} px, max {worst:.4f} px")
    assert rms <= 0.015
    assert worst <= 0.05


def test_scene_as_dict_renders_the_same_pixels(board_scene_text):
    image_text, _ = synthcam.render(board_scene_text)
    scene = tomllib.loads(board_scene_text)
    image_dict, truth = synthcam.render(scene)
    assert np.array_equal(image_text, image_dict)
    # The target may also be given as the scene itself.
    assert synthcam.detect(image_dict, scene)["found"]
    assert truth["camera"]["dist"][0] == pytest.approx(-0.25)


def test_render_releases_the_gil(board_scene_text):
    """A Python thread keeps counting while the GPU renders (it could not if the GIL were held)."""
    synthcam.render(board_scene_text)  # open the GPU and compile first
    count, stop = [0], threading.Event()

    def spin():
        while not stop.is_set():
            count[0] += 1

    worker = threading.Thread(target=spin)
    worker.start()
    time.sleep(0.05)
    before = count[0]
    t0 = time.perf_counter()
    synthcam.render(board_scene_text)
    elapsed = time.perf_counter() - t0
    during = count[0] - before
    stop.set()
    worker.join()
    print(f"render {elapsed * 1e3:.0f} ms, other thread counted {during} meanwhile")
    assert during > 1000


def test_depth_and_mask(board_scene_text):
    depth, mask = synthcam.render_depth_mask(board_scene_text)
    assert depth.shape == mask.shape == (1024, 1280)
    assert depth.dtype == np.float32 and mask.dtype == np.uint16
    on_board = mask == 1
    assert on_board.mean() > 0.3
    # The board is 0.5-1.0 m away.
    assert 0.4 < float(np.nanmin(depth[on_board])) and float(np.nanmax(depth[on_board])) < 1.2


def test_bad_input_is_a_clear_error(board_scene_text):
    with pytest.raises(synthcam.SynthcamError, match="scene"):
        synthcam.render("[camera]\nwidth = -3\n")
    with pytest.raises(TypeError):
        synthcam.render(42)
    with pytest.raises(TypeError, match="2-D"):
        synthcam.detect(np.zeros((4, 4, 3), np.uint8), "chessboard:9x6")
    with pytest.raises(ValueError, match="unknown target"):
        synthcam.detect(np.zeros((8, 8), np.uint8), "hexboard:3")
    blank = synthcam.detect(np.full((64, 64), 128, np.uint8), "chessboard:9x6")
    assert not blank["found"] and blank["points_px"].shape == (0, 2) and blank["note"]


def test_a_background_image_behind_the_board(board_scene_text, tmp_path):
    """A plane image (a file, read beside the scene's base folder) behind the board: pixels beside
    the board take the image's levels, the board's corners stay where the truth says, and the
    mask marks the background (65535) at its plane's depth."""
    wall = np.zeros((64, 128), np.uint8)
    wall[:, 64:] = 200
    def png(a):
        raw = b"".join(b"\x00" + row.tobytes() for row in a)
        chunk = lambda t, d: struct.pack(">I", len(d)) + t + d + struct.pack(">I", zlib.crc32(t + d) & 0xFFFFFFFF)
        ihdr = struct.pack(">IIBBBBB", a.shape[1], a.shape[0], 8, 0, 0, 0, 0)
        return b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + chunk(b"IDAT", zlib.compress(raw)) + chunk(b"IEND", b"")

    (tmp_path / "wall.png").write_bytes(png(wall))
    text = board_scene_text + '\n[background]\nkind = "plane"\nimage = "wall.png"\nt_m = [0.0, 0.0, 3.0]\nsize_m = [8.0, 4.0]\n'
    image, truth = synthcam.render(text, base_dir=str(tmp_path))
    levels = set(np.unique(image[0, :]).tolist())
    assert {0, 200} <= levels, levels
    found = synthcam.detect(image, "chessboard:11x8")
    assert found["found"] and float(corner_errors(found, truth).max()) <= 0.05
    depth, mask = synthcam.render_depth_mask(text, base_dir=str(tmp_path))
    assert mask[0, 0] == 65535 and abs(float(depth[0, 0]) - 3.0) < 1e-4


def test_a_known_camera_places_the_s_path(root):
    """``detect(..., camera=)``: the scene's camera as a scene-file dict or as a camera file's text."""
    text = (root / "assets" / "scenes" / "course_s_path.toml").read_text()
    image, _ = synthcam.render(text)
    plain = synthcam.detect(image, "s-path")
    camera = {"width": 1280, "height": 1024, "fx": 1500.0, "fy": 1500.0, "cx": 640.0, "cy": 512.0}
    opencv = ("%YAML:1.0\n---\nimage_width: 1280\nimage_height: 1024\ncamera_matrix: !!opencv-matrix\n   rows: 3\n   cols: 3\n"
              "   dt: d\n   data: [ 1500., 0., 640., 0., 1500., 512., 0., 0., 1. ]\ndistortion_coefficients: !!opencv-matrix\n"
              "   rows: 1\n   cols: 5\n   dt: d\n   data: [ 0., 0., 0., 0., 0. ]\n")
    for cam in (camera, opencv):
        known = synthcam.detect(image, "s-path", camera=cam)
        assert list(known["indices"]) == list(range(101)) == list(plain["indices"])
        np.testing.assert_array_equal(known["points_px"], plain["points_px"])
    with pytest.raises(synthcam.SynthcamError, match="image size"):
        synthcam.detect(image, "s-path", camera=dict(camera, width=640, height=480))
    with pytest.raises(synthcam.SynthcamError, match="camera"):
        synthcam.detect(image, "s-path", camera="not a camera")
