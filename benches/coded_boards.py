#!/usr/bin/env python3
"""``synthcam detect`` beside the reference detectors on coded-board renders (issue 17).

ChArUco: OpenCV's ``cv2.aruco.CharucoDetector``. AprilGrid: Kalibr's own tag detector (the ETH
AprilTags 2 library Kalibr builds, ``pip install apriltags2-ethz``, module ``apriltags_eth``;
Kalibr then refines each tag corner with ``cv::cornerSubPix(winSize 2 x 2)``, as
``GridCalibrationTargetAprilgrid::computeObservation`` does: both the raw and the refined corners
are scored) and OpenCV's ``ArucoDetector`` with ``markerBorderBits = 2`` and sub-pixel corner
refinement. Reference tools only: neither is ever a dependency of the synthcam crate. Requires
numpy and opencv-python-headless >= 4.7; ``apriltags_eth`` is optional (skipped with a note).

Usage
-----
    synthcam dataset assets/specs/charuco_full_1280.toml -o /tmp/ch/full
    synthcam dataset assets/specs/charuco_partial_1280.toml -o /tmp/ch/partial
    python3 benches/coded_boards.py --images /tmp/ch/full/images /tmp/ch/partial/images \
        --target charuco:11x8:DICT_5X5_100:0.733 [--repeat 3] [--json out.json]
    python3 benches/coded_boards.py --images /tmp/ag/full/images /tmp/ag/partial/images \
        --target aprilgrid:6x6:tag36h11:0.3

Truth: ``<stem>.json`` beside each image (``synthcam`` truth labels: ``features[i].id`` is
OpenCV's ChArUco corner id, or the AprilGrid point id 4 k + c of corner c (Kalibr's order) of
tag k; ``pixel_px`` its exact projection). Per detector and over all images:

* recall: detected corners with the right id / corners inside the image by >= ``--border`` px
  (3) and in front of the camera;
* wrong ids: detected corners farther than ``--wrong-px`` (2 px) from the truth of their id
  (also counted when the id is not on the board);
* RMS / max error of the rest against the truth;
* time: per-image median over ``--repeat`` runs of the detection call alone (the references on
  the decoded uint8 array with ``cv2.setNumThreads(1)``; synthcam's own ``time_ms`` with
  ``RAYON_NUM_THREADS=1``), then the median over images.
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


def dictionary(name):
    """OpenCV's dictionary of a synthcam / Kalibr name (DICT_5X5_100, 5X5_100, tag36h11)."""
    if name.lower().startswith("tag"):
        name = "APRILTAG_" + name[3:]
    name = name if name.upper().startswith("DICT_") else "DICT_" + name
    for attr in dir(cv2.aruco):
        if attr.upper() == name.upper():
            return cv2.aruco.getPredefinedDictionary(getattr(cv2.aruco, attr))
    sys.exit(f"unknown dictionary {name}")


def parse_target(t):
    """(kind, size, dictionary, ratio or spacing, legacy) of a synthcam target string."""
    parts = t.split(":")
    if parts[0] not in ("charuco", "aprilgrid") or len(parts) < 4:
        sys.exit(f"--target must be charuco:NXxNY:DICT:RATIO[:legacy] or aprilgrid:NXxNY:tag36h11:SPACING, got {t}")
    nx, ny = (int(v) for v in parts[1].lower().split("x"))
    return parts[0], (nx, ny), dictionary(parts[2]), float(parts[3]), "legacy" in parts[4:]


def images_of(paths):
    out = []
    for p in map(Path, paths):
        out += sorted(p.glob("*.png")) if p.is_dir() else [p]
    return out


def truth_of(img):
    t = json.loads(img.with_suffix(".json").read_text())
    return {f["id"]: (np.array(f["pixel_px"]), f["in_front"]) for f in t["features"]}, (t["camera"]["width"], t["camera"]["height"])


def timed(images, repeat, detect):
    """{image: (list of (id, point), median ms)} of `detect(grey) -> [(id, point)]`."""
    cv2.setNumThreads(1)
    out = {}
    for p in images:
        g = cv2.imread(str(p), cv2.IMREAD_GRAYSCALE)
        times = []
        for _ in range(repeat):
            t0 = time.perf_counter()
            pts = detect(g)
            times.append((time.perf_counter() - t0) * 1e3)
        out[str(p)] = (pts, statistics.median(times))
    return out


def charuco_opencv(size, dic, ratio, legacy):
    board = cv2.aruco.CharucoBoard(size, 1.0, ratio, dic)
    board.setLegacyPattern(legacy)
    det = cv2.aruco.CharucoDetector(board)

    def detect(g):
        cc, ci, _, _ = det.detectBoard(g)
        return [] if ci is None else list(zip(ci.ravel().tolist(), np.asarray(cc).reshape(-1, 2)))

    return detect


def aprilgrid_opencv(dic):
    """OpenCV's ArucoDetector on Kalibr's 2-bit borders; a printed tag is OpenCV's marker turned
    180 degrees, so OpenCV's corner m is Kalibr's corner [1, 0, 3, 2][m]."""
    prm = cv2.aruco.DetectorParameters()
    prm.markerBorderBits = 2
    prm.cornerRefinementMethod = cv2.aruco.CORNER_REFINE_SUBPIX
    det = cv2.aruco.ArucoDetector(dic, prm)

    def detect(g):
        corners, ids, _ = det.detectMarkers(g)
        if ids is None:
            return []
        return [(4 * int(i) + [1, 0, 3, 2][m], c.reshape(4, 2)[m]) for c, i in zip(corners, ids.ravel()) for m in range(4)]

    return detect


def aprilgrid_kalibr(refine):
    """Kalibr's tag detector (apriltags_eth; corners in Kalibr's order), then, as Kalibr, tags
    with a corner within 4 px of the border dropped and each tag's corners refined by
    cornerSubPix(winSize 2 x 2, 30 iterations, eps 0.1)."""
    import apriltags_eth

    det = apriltags_eth.make_default_detector()
    crit = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_MAX_ITER, 30, 0.1)

    def detect(g):
        out = []
        h, w = g.shape
        for d in det.extract_tags(g):
            c = np.array(d.corners, np.float32).reshape(-1, 1, 2)
            # Kalibr drops tags with a corner within minBorderDistance (4 px) of the image border.
            xy = c.reshape(4, 2)
            if not d.good or (xy < 4).any() or (xy[:, 0] > w - 5).any() or (xy[:, 1] > h - 5).any():
                continue
            if refine:
                c = cv2.cornerSubPix(g, c, (2, 2), (-1, -1), crit)
            out += [(4 * d.id + m, c.reshape(4, 2)[m].astype(float)) for m in range(4)]
        return out

    return detect


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
    kind, size, dic, value, legacy = parse_target(a.target)
    images = images_of(a.images)
    refs = {}
    if kind == "charuco":
        refs["opencv"] = charuco_opencv(size, dic, value, legacy)
    else:
        refs["opencv"] = aprilgrid_opencv(dic)
        try:
            refs["kalibr"] = aprilgrid_kalibr(True)
            refs["kalibr_raw"] = aprilgrid_kalibr(False)
        except ImportError:
            print("note: apriltags_eth (pip install apriltags2-ethz) is not installed: Kalibr's detector skipped")
    rows = {k: score(images, timed(images, a.repeat, f), a.border, a.wrong_px) for k, f in refs.items()}
    rows["synthcam"] = score(images, run_synthcam(images, a.target, a.repeat, a.binary), a.border, a.wrong_px)
    print(f"{len(images)} images, OpenCV {cv2.__version__}")
    print(f"{'detector':10} {'recall':>8} {'right':>6} {'wrong ids':>9} {'RMS px':>8} {'max px':>8} {'ms':>7}")
    for k, r in rows.items():
        print(f"{k:10} {100 * r['recall']:7.2f}% {r['corners_right']:6d} {r['wrong_ids']:9d} {r['rms_px']:8.4f} {r['max_px']:8.4f} {r['median_time_ms']:7.2f}")
    s = rows["synthcam"]
    for k, o in rows.items():
        if k != "synthcam":
            print(f"synthcam / {k}: error RMS {s['rms_px'] / o['rms_px']:.3f}, time {s['median_time_ms'] / o['median_time_ms']:.3f}")
    if a.json:
        Path(a.json).write_text(json.dumps({"images": len(images), "opencv_version": cv2.__version__, "target": a.target, **rows}, indent=2))


if __name__ == "__main__":
    main()
