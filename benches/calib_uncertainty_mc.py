#!/usr/bin/env python3
"""Issue 39 item 3 on renders: the projection sigma `synthcam calibrate` predicts (its
`projection_uncertainty` map) against the spread of the projections of N calibrations from
renders of the same poses with fresh noise.

Usage (from the repository root, after `cargo build --release` and `pip install .` into the Python
that runs this):
    python3 benches/calib_uncertainty_mc.py [--models opencv5,fisheye] [--samples 50] [--views 12] [--seed 11]

The poses: a dataset of `--views` views (`benches/lens_models.py`'s camera and board, seed
`--seed`); its truth gives each view's `cam_from_target`. Each sample renders every pose again
(noise sigma 2, its own noise seed), detects the 11 x 8 corners and calibrates (outlier rejection
on, as a user would). Predicted: sample 0's map on a 5 x 5 grid, whose cell centres are the 9
pixels at 10 / 50 / 90 % of the width and height (and 16 more). Monte Carlo: the point the true
camera sees at pixel q (at infinity) is carried into each board's frame by the true pose and back
by the estimated one, averaged over the views, projected by the estimated camera (the prediction's
own formulation); the spread of that pixel over the samples, worst direction. OpenCV projects
(opencv5: `projectPoints`; fisheye: `fisheye.projectPoints`); it is a benchmark tool only.
"""
import argparse, json, os, subprocess, sys, tempfile

import numpy as np
import cv2
import synthcam

sys.path.insert(0, os.path.dirname(__file__))
from lens_models import spec, COLS, ROWS, SQUARE  # noqa: E402


def true_ray(cam, q):
    K = np.array([[cam["fx"], 0, cam["cx"]], [0, cam["fy"], cam["cy"]], [0, 0, 1.0]])
    pts = np.array([[q]], np.float64)
    # Converged inversions: OpenCV's default 5 iterations stop short at a strongly distorted corner.
    crit = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 200, 1e-14)
    if cam.get("model") == "fisheye":
        u = cv2.fisheye.undistortPoints(pts, K, np.array(cam["dist"][:4]), criteria=crit)
    else:
        u = cv2.undistortPoints(pts, K, np.array(cam["dist"]), None, None, None, crit)
    v = np.array([u[0, 0, 0], u[0, 0, 1], 1.0])
    return v / np.linalg.norm(v)


def project(cal, model, p):
    K, D = np.array(cal["K"]), np.array(cal["dist"])
    if model == "fisheye":
        q, _ = cv2.fisheye.projectPoints(p.reshape(1, 1, 3), np.zeros(3), np.zeros(3), K, D[:4])
    else:
        q, _ = cv2.projectPoints(p.reshape(1, 3), np.zeros(3), np.zeros(3), K, D)
    return q.reshape(2)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--models", default="opencv5,fisheye")
    ap.add_argument("--samples", type=int, default=50)
    ap.add_argument("--views", type=int, default=12)
    ap.add_argument("--seed", type=int, default=11)
    ap.add_argument("--synthcam", default="target/release/synthcam")
    a = ap.parse_args()
    for model in a.models.split(","):
        with tempfile.TemporaryDirectory() as d:
            text, cam = spec(model, a.views, False, a.seed)
            open(os.path.join(d, "spec.toml"), "w").write(text)
            subprocess.run([a.synthcam, "dataset", os.path.join(d, "spec.toml"), "-o", os.path.join(d, "ds")], check=True, capture_output=True)
            truths = [json.load(open(os.path.join(d, "ds", "images", f"{i:06d}.json"))) for i in range(a.views)]
            cam = truths[0]["camera"]
            cam.setdefault("dist", [0.0] * 5)
            target = {"kind": "chessboard", "squares": [COLS + 1, ROWS + 1], "square_m": SQUARE, "margin_m": SQUARE / 2}
            poses = [(np.array(t["cam_from_target"]["R"]), t["cam_from_target"]) for t in truths]
            qs = [(u * 1280 / 5 - 0.5, v * 1024 / 5 - 0.5) for v in (0.5, 2.5, 4.5) for u in (0.5, 2.5, 4.5)]
            spread = {q: [] for q in qs}
            predicted = None
            for k in range(a.samples):
                dets = []
                for i, (_, p) in enumerate(poses):
                    scene = {"camera": cam, "target": target, "pose": {"rvec": p["rvec"], "t_m": p["t_m"]},
                             "render": {"samples": 16, "noise_sigma": 2.0, "seed": 1000 * k + i}}
                    img, _ = synthcam.render(scene)
                    dets.append(synthcam.detect(img, f"chessboard:{COLS}x{ROWS}"))
                if k == 0:
                    j = {"images": [dict(det.raw, file=f"v{i}.png", width=1280, height=1024) for i, det in enumerate(dets)]}
                    for im in j["images"]:
                        im["points_px"] = np.asarray(im["points_px"]).tolist()
                    dj, cj = os.path.join(d, "det.json"), os.path.join(d, "cal.json")
                    json.dump(j, open(dj, "w"))
                    subprocess.run([a.synthcam, "calibrate", dj, "--target", f"chessboard:{COLS}x{ROWS}", "--square", str(SQUARE), "--model", model,
                                    "--uncertainty-grid", "5x5", "--json", cj], check=True, capture_output=True)
                    grid = json.load(open(cj))["projection_uncertainty"]["sigma_px"]
                    # Cell (row, col) = (int(v), int(u)) of the 5 x 5 grid.
                    predicted = {q: float(grid[int(v)][int(u)]) for (u, v), q in zip([(u, v) for v in (0.5, 2.5, 4.5) for u in (0.5, 2.5, 4.5)], qs)}
                cal = synthcam.calibrate(dets, f"chessboard:{COLS}x{ROWS}", SQUARE, (1280, 1024), model=model)
                if len(cal.views) != len(poses):
                    continue
                # An 11 x 8 corner grid looks the same turned 180 degrees about its normal: the detector
                # may number a view's corners from the other end, and that view's estimated board
                # frame is then the true one turned about z.
                flip = np.diag([-1.0, -1.0, 1.0])
                trues = [Rt if np.trace(cv.cam_from_target.R @ Rt.T) > 0 else Rt @ flip for cv, (Rt, _) in zip(cal.views, poses)]
                for q in qs:
                    v = true_ray(cam, q)
                    p = np.mean([cv.cam_from_target.R @ (Rt.T @ v) for cv, Rt in zip(cal.views, trues)], axis=0)
                    spread[q].append(project(cal.raw, model, p))
            print(f"\n## {model}: {a.samples} samples of {a.views} rendered views (seed {a.seed})")
            print("| pixel | predicted px | Monte Carlo px | ratio |\n|---|---|---|---|")
            worst = 0.0
            for q in qs:
                s = np.array(spread[q])
                mc = float(np.sqrt(np.linalg.eigvalsh(np.cov(s.T)).max()))
                r = predicted[q] / mc
                worst = max(worst, abs(r - 1))
                print(f"| ({q[0]:.0f}, {q[1]:.0f}) | {predicted[q]:.4f} | {mc:.4f} | {r:.3f} |")
            print(f"worst |ratio - 1| {worst:.3f} ({len(spread[qs[0]])} calibrations)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
