#!/usr/bin/env python3
"""``synthcam detect`` beside OpenCV's ``cv2.aruco.CharucoDetector`` on ChArUco renders (issue 17).

A benchmark / reference tool only: OpenCV is never a dependency of the synthcam crate.
Requires numpy and opencv-python-headless >= 4.7 (``pip install opencv-python-headless numpy``).

Usage
-----
    synthcam dataset assets/specs/charuco_full_1280.toml -o /tmp/ch/full
    synthcam dataset assets/specs/charuco_partial_1280.toml -o /tmp/ch/partial
    python3 benches/charuco_opencv.py --images /tmp/ch/full/images /tmp/ch/partial/images \
        --target charuco:11x8:DICT_5X5_100:0.733 [--repeat 3] [--json out.json]

Truth: ``<stem>.json`` beside each image (``synthcam`` truth labels: ``features[i].id`` is
OpenCV's ChArUco corner id, ``pixel_px`` its exact projection). Per detector and over all images:

* recall: detected corners with the right id / corners inside the image by >= ``--border`` px
  (3) and in front of the camera;
* wrong ids: detected corners farther than ``--wrong-px`` (2 px) from the truth of their id
  (also counted when the id is not on the board);
* RMS / max error of the rest against the truth;
* time: per-image median over ``--repeat`` runs of the detection call alone (OpenCV on the decoded
  uint8 array with ``cv2.setNumThreads(1)``; synthcam's own ``time_ms`` with
  ``RAYON_NUM_THREADS=1``), then the median over images.

OpenCV runs with its defaults (``CharucoParameters``: ``minMarkers=2``, no refinement of the
markers beyond ``DetectorParameters``' defaults) on the same board
(``CharucoBoard(size, 1, ratio, dictionary)``, ``setLegacyPattern`` as given).
"""

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import cv2
import numpy as np

ROOT = Path(__file__).resolve().parent.parent


def parse_target(t):
    parts = t.split(":")
    if parts[0] != "charuco" or len(parts) < 4:
        sys.exit(f"--target must be charuco:NXxNY:DICT:RATIO[:legacy], got {t}")
    nx, ny = (int(v) for v in parts[1].lower().split("x"))
    name = parts[2] if parts[2].upper().startswith("DICT_") else "DICT_" + parts[2]
    return (nx, ny), getattr(cv2.aruco, name.upper().replace("APRILTAG_", "APRILTAG_")), float(parts[3]), "legacy" in parts[4:]


def images_of(paths):
    out = []
    for p in map(Path, paths):
        out += sorted(p.glob("*.png")) if p.is_dir() else [p]
    return out


def truth_of(img):
    t = json.loads(img.with_suffix(".json").read_text())
    return {f["id"]: (np.array(f["pixel_px"]), f["in_front"]) for f in t["features"]}, (t["camera"]["width"], t["camera"]["height"])


def run_opencv(images, board, repeat):
    cv2.setNumThreads(1)
    det = cv2.aruco.CharucoDetector(board)
    out = {}
    for p in images:
        g = cv2.imread(str(p), cv2.IMREAD_GRAYSCALE)
        times = []
        for _ in range(repeat):
            t0 = time.perf_counter()
            cc, ci, _, _ = det.detectBoard(g)
            times.append((time.perf_counter() - t0) * 1e3)
        pts = [] if ci is None else list(zip(ci.ravel().tolist(), np.asarray(cc).reshape(-1, 2)))
        out[str(p)] = (pts, statistics.median(times))
    return out


def run_synthcam(images, target, repeat, binary):
    env = dict(os.environ, RAYON_NUM_THREADS="1")
    runs = []
    for _ in range(repeat):
        with tempfile.TemporaryDirectory() as d:
            js = Path(d) / "det.json"
            subprocess.run([binary, "detect", *map(str, images), "--target", target, "--json", str(js), "--any-size"], check=True, env=env, capture_output=True)
            # synthcam lists the images in the order given, named by file name only.
            runs.append(json.loads(js.read_text())["images"])
    out = {}
    for k, p in enumerate(images):
        im = runs[0][k]
        assert im["file"] == p.name, (im["file"], p)
        pts = list(zip(im.get("ids", []), (np.array(q) for q in im.get("points_px", []))))
        out[str(p)] = (pts, statistics.median(r[k]["time_ms"] for r in runs))
    return out


def score(images, results, border, wrong_px):
    expected = hit = wrong = 0
    errs, times = [], []
    for p in images:
        truth, (w, h) = truth_of(p)
        inside = {i for i, (q, front) in truth.items() if front and border <= q[0] <= w - 1 - border and border <= q[1] <= h - 1 - border}
        expected += len(inside)
        pts, ms = results[str(p)]
        times.append(ms)
        for i, q in pts:
            if i not in truth or np.linalg.norm(q - truth[i][0]) > wrong_px:
                wrong += 1
                continue
            errs.append(np.linalg.norm(q - truth[i][0]))
            hit += i in inside
    e = np.array(errs) if errs else np.array([np.nan])
    return {
        "recall": hit / max(expected, 1),
        "corners_expected": expected,
        "corners_right": len(errs),
        "wrong_ids": wrong,
        "rms_px": float(np.sqrt(np.mean(e**2))),
        "max_px": float(np.max(e)),
        "median_time_ms": statistics.median(times),
    }


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--images", nargs="+", required=True)
    ap.add_argument("--target", required=True)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--border", type=float, default=3.0)
    ap.add_argument("--wrong-px", type=float, default=2.0)
    ap.add_argument("--binary", default=str(ROOT / "target/release/synthcam"))
    ap.add_argument("--json")
    a = ap.parse_args()
    size, dict_id, ratio, legacy = parse_target(a.target)
    board = cv2.aruco.CharucoBoard(size, 1.0, ratio, cv2.aruco.getPredefinedDictionary(dict_id))
    board.setLegacyPattern(legacy)
    images = images_of(a.images)
    rows = {
        "opencv": score(images, run_opencv(images, board, a.repeat), a.border, a.wrong_px),
        "synthcam": score(images, run_synthcam(images, a.target, a.repeat, a.binary), a.border, a.wrong_px),
    }
    print(f"{len(images)} images, OpenCV {cv2.__version__}")
    print(f"{'detector':10} {'recall':>8} {'right':>6} {'wrong ids':>9} {'RMS px':>8} {'max px':>8} {'ms':>7}")
    for k, r in rows.items():
        print(f"{k:10} {100 * r['recall']:7.2f}% {r['corners_right']:6d} {r['wrong_ids']:9d} {r['rms_px']:8.4f} {r['max_px']:8.4f} {r['median_time_ms']:7.2f}")
    o, s = rows["opencv"], rows["synthcam"]
    print(f"synthcam / OpenCV: error RMS {s['rms_px'] / o['rms_px']:.3f}, time {s['median_time_ms'] / o['median_time_ms']:.3f}")
    if a.json:
        Path(a.json).write_text(json.dumps({"images": len(images), "opencv_version": cv2.__version__, "target": a.target, **rows}, indent=2))


if __name__ == "__main__":
    main()
