#!/usr/bin/env python3
"""Time OpenCV's calibrateCamera against `synthcam calibrate` on the same corners, in one run.

Usage (from the repository root, after `cargo build --release`):
    python3 benches/calib_opencv.py [--reference ../shared/data/opencv_left/opencv_reference.json] [--repeat 20]

The corners are OpenCV 5.0's `classic` corners stored in the reference file (13 views, 9x6, square 1).
synthcam reads them from a detections JSON written here; its `time_ms` is the calibration alone.
Both keep every point (`--keep-outliers`: OpenCV has no outlier rejection), so the objective is
the same.
Prints both results, the median times and their ratio.
"""
import argparse, json, os, statistics, subprocess, sys, tempfile, time

import numpy as np
import cv2

from compare_opencv import opencv_calibrate


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--reference", default="../shared/data/opencv_left/opencv_reference.json")
    ap.add_argument("--synthcam", default="target/release/synthcam")
    ap.add_argument("--repeat", type=int, default=20)
    a = ap.parse_args()
    if not os.path.exists(a.reference):
        print(f"error: {a.reference} not found", file=sys.stderr)
        return 2
    ref = json.load(open(a.reference))
    files = ref["files"]
    w, h = ref["image_size_wh"]
    cols, rows = ref["board"]["pattern_size_opencv"]
    objp = np.array([[c, r, 0.0] for r in range(rows) for c in range(cols)], np.float32)
    corners = [np.array(ref["per_image"][f]["corners"]["classic"], np.float32).reshape(-1, 1, 2) for f in files]
    rms, K, cv_ms = opencv_calibrate(objp, corners, (w, h), a.repeat)
    print(f"OpenCV {cv2.__version__} calibrateCamera (1 thread): rms {rms:.6f} fx {K[0,0]:.4f} fy {K[1,1]:.4f} cx {K[0,2]:.4f} cy {K[1,2]:.4f}; median {cv_ms:.2f} ms over {a.repeat}")
    det = {"images": [{"file": f, "width": w, "height": h, "found": True, "points_px": ref["per_image"][f]["corners"]["classic"]} for f in files]}
    with tempfile.TemporaryDirectory() as d:
        dj, out = os.path.join(d, "det.json"), os.path.join(d, "cal.json")
        json.dump(det, open(dj, "w"))
        st = []
        for _ in range(a.repeat):
            p = subprocess.run([a.synthcam, "calibrate", dj, "--target", f"chessboard:{cols}x{rows}", "--square", "1", "--json", out, "--keep-outliers"], capture_output=True, text=True)
            if p.returncode != 0:
                print(p.stderr, file=sys.stderr)
                return 1
            st.append(json.load(open(out))["time_ms"])
        r = json.load(open(out))
    sc_ms = statistics.median(st)
    K2 = r["K"]
    print(f"synthcam calibrate: rms {r['rms_px']:.6f} fx {K2[0][0]:.4f} fy {K2[1][1]:.4f} cx {K2[0][2]:.4f} cy {K2[1][2]:.4f}; median {sc_ms:.2f} ms over {a.repeat}")
    print(f"time ratio synthcam / OpenCV: {sc_ms / cv_ms:.3f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
