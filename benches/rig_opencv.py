#!/usr/bin/env python3
"""Issue 40: `synthcam calibrate --rig` against OpenCV's `stereoCalibrate` on the same corners.

Usage (from the repository root, after `cargo build --release`; synthcam's Python package on
PYTHONPATH for the renders):
    python3 benches/rig_opencv.py [--views 20] [--seed 40]

The issue's stereo scene: two 1280 x 1024 pinholes (5-coefficient lenses), 12 cm baseline, 2
degrees of toe-in, `--views` synchronised views of an 8 x 6 corner chessboard (3 cm squares),
noise sigma 1, rendered and detected by synthcam; views where either camera misses a corner are
dropped. synthcam: `calibrate --rig` on the two detections JSONs. OpenCV: `calibrateCamera` per
camera, then `stereoCalibrate` with CALIB_USE_INTRINSIC_GUESS (nothing fixed: the same parameters
as synthcam's bundle adjustment), 1 thread. Printed: both RMS (OpenCV's is over both cameras'
points, as synthcam's), the extrinsics' errors against the truth and their difference, the
times (synthcam's `time_ms`, the bundle adjustment with its per-camera starts; OpenCV's two
`calibrateCamera` calls and `stereoCalibrate`). OpenCV is a benchmark tool only.
"""
import argparse, json, os, subprocess, sys, tempfile, time

import numpy as np
import cv2
import synthcam

COLS, ROWS, SQUARE = 8, 6, 0.03


def rodrigues(v):
    return cv2.Rodrigues(np.asarray(v, float))[0]


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--views", type=int, default=20)
    ap.add_argument("--seed", type=int, default=40)
    ap.add_argument("--synthcam", default="target/release/synthcam")
    a = ap.parse_args()
    rng = np.random.default_rng(a.seed)
    cams = [dict(width=1280, height=1024, fx=1100.0, fy=1100.0, cx=639.5, cy=511.5, dist=[-0.15, 0.05, 0.0, 0.0, 0.0]),
            dict(width=1280, height=1024, fx=1120.0, fy=1120.0, cx=639.5, cy=511.5, dist=[-0.1, 0.03, 0.0, 0.0, 0.0])]
    R01 = rodrigues([0.0, -np.radians(2.0), 0.0])  # cam0_from_cam1 rotation
    t01 = np.array([0.12, 0.0, 0.0])
    R10, t10 = R01.T, -R01.T @ t01
    target = {"kind": "chessboard", "squares": [COLS + 1, ROWS + 1], "square_m": SQUARE, "margin_m": SQUARE / 2}
    centre = np.array([0.5 * SQUARE * (COLS + 1), 0.5 * SQUARE * (ROWS + 1), 0.0])
    dets = [[], []]
    while len(dets[0]) < a.views:
        rv = np.array([rng.uniform(-0.6, 0.6), rng.uniform(-0.4, 0.4), rng.uniform(-0.2, 0.2)])
        R = rodrigues(rv)
        t = np.array([rng.uniform(-0.02, 0.14), rng.uniform(-0.08, 0.08), rng.uniform(0.45, 0.7)]) - R @ centre
        poses = [(R, t), (R10 @ R, R10 @ t + t10)]
        found = []
        for c, (Rc, tc) in enumerate(poses):
            scene = {"camera": cams[c], "target": target, "pose": {"rvec": cv2.Rodrigues(Rc)[0].ravel().tolist(), "t_m": tc.tolist()},
                     "render": {"samples": 16, "noise_sigma": 1.0, "seed": int(rng.integers(0, 2**62))}}
            img, _ = synthcam.render(scene)
            found.append(synthcam.detect(img, f"chessboard:{COLS}x{ROWS}"))
        if all(d.found and len(d.points_px) == COLS * ROWS and not d.untrusted for d in found):
            for c in range(2):
                dets[c].append(found[c])
    objp = np.array([[(i % COLS + 1) * SQUARE, (i // COLS + 1) * SQUARE, 0.0] for i in range(COLS * ROWS)], np.float32)
    pts = [[np.asarray(d.points_px, np.float32).reshape(-1, 1, 2) for d in dets[c]] for c in range(2)]
    with tempfile.TemporaryDirectory() as d:
        paths = []
        for c, name in enumerate(("left", "right")):
            p = os.path.join(d, f"{name}.json")
            json.dump({"images": [{"file": f"{k:03d}.png", "width": 1280, "height": 1024, "found": True,
                                   "points_px": np.asarray(x.points_px).tolist()} for k, x in enumerate(dets[c])]}, open(p, "w"))
            paths.append(p)
        out = os.path.join(d, "rig.json")
        subprocess.run([a.synthcam, "calibrate", "--rig", *paths, "--target", f"chessboard:{COLS}x{ROWS}", "--square", str(SQUARE),
                        "--keep-outliers", "--json", out], check=True, capture_output=True)
        r = json.load(open(out))
    cv2.setNumThreads(1)
    t0 = time.perf_counter()
    singles = [cv2.calibrateCamera([objp] * len(pts[c]), pts[c], (1280, 1024), None, None) for c in range(2)]
    crit = (cv2.TERM_CRITERIA_COUNT + cv2.TERM_CRITERIA_EPS, 200, 1e-12)
    rms, K0, D0, K1, D1, R, T, E, F = cv2.stereoCalibrate([objp] * len(pts[0]), pts[0], pts[1], singles[0][1], singles[0][2], singles[1][1], singles[1][2],
                                                          (1280, 1024), flags=cv2.CALIB_USE_INTRINSIC_GUESS, criteria=crit)
    cv_ms = (time.perf_counter() - t0) * 1e3
    # OpenCV's R, T: cam1_from_cam0. Its cam0_from_cam1:
    cv_R01, cv_t01 = R.T, (-R.T @ T).ravel()
    sc = r["cameras"][1]["cam0_from_cam"]
    sc_R01, sc_t01 = np.array(sc["R"]), np.array(sc["t_m"])
    ang = lambda A, B: np.degrees(np.arccos(np.clip((np.trace(A.T @ B) - 1) / 2, -1, 1)))
    print(f"{len(dets[0])} synchronised views; rms synthcam {r['rms_px']:.6f} px, OpenCV stereoCalibrate {rms:.6f} px (ratio {r['rms_px'] / rms:.6f})")
    print(f"baseline error vs truth: synthcam {np.linalg.norm(sc_t01 - t01) * 1e3:.4f} mm / {ang(sc_R01, R01):.5f} deg; "
          f"OpenCV {np.linalg.norm(cv_t01 - t01) * 1e3:.4f} mm / {ang(cv_R01, R01):.5f} deg; difference {np.linalg.norm(sc_t01 - cv_t01) * 1e3:.5f} mm")
    print(f"time: synthcam {r['time_ms']:.1f} ms (per-camera starts + bundle adjustment), OpenCV {cv_ms:.1f} ms (2 calibrateCamera + stereoCalibrate)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
