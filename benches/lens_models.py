#!/usr/bin/env python3
"""Issue 16 acceptance, per lens model: render 20 views, detect, calibrate with synthcam and with
OpenCV on the same corners, and compare both with the truth.

Usage (from the repository root, after `cargo build --release`):
    python3 benches/lens_models.py [--models opencv5,fisheye,...] [--count 20] [--repeat 5] [--cross-validate 5] [--cover] [--seed S]

Per model: a dataset spec (1280 x 1024, noise sigma 2) is written and rendered with
`synthcam dataset`; `synthcam detect` finds the 11 x 8 inner corners (recall and corner error
against the truth JSON are printed); `synthcam calibrate --model M` calibrates from those
detections; OpenCV calibrates the same corners (opencv*: `cv2.calibrateCamera` with
CALIB_RATIONAL_MODEL / THIN_PRISM / TILTED as the model needs; fisheye:
`cv2.fisheye.calibrate` with RECOMPUTE_EXTRINSIC | FIX_SKEW; double-sphere: OpenCV has no such
model); synthcam with `--keep-outliers`, so both minimise the same sum over every corner. Printed: intrinsics errors against the truth, the sum of squared residuals (both
recomputed here by reprojecting each result with OpenCV's projection), and the median times
(synthcam: its `time_ms`, calibration alone; OpenCV: the call, 1 thread).
OpenCV is a benchmark tool only, never a dependency of the crate.
"""
import argparse, json, os, statistics, subprocess, sys, tempfile, time

import numpy as np
import cv2

CAMS = {
    "opencv5": ("f = 900", {"fx": 900.0, "fy": 902.0, "dist": [-0.3, 0.12, 1e-3, -5e-4, -0.02]}),
    "opencv8": ("rational", {"fx": 900.0, "fy": 902.0, "dist": [0.1, -0.05, 1e-3, -5e-4, 0.01, 0.4, -0.02, 0.01]}),
    "opencv12": ("thin prism", {"fx": 900.0, "fy": 902.0, "dist": [0.1, -0.05, 1e-3, -5e-4, 0.01, 0.4, -0.02, 0.01, 1e-3, -1e-4, 5e-4, 2e-4]}),
    "opencv14": ("tilted", {"fx": 900.0, "fy": 902.0, "dist": [0.1, -0.05, 1e-3, -5e-4, 0.01, 0.4, -0.02, 0.01, 1e-3, -1e-4, 5e-4, 2e-4, 0.01, -0.008]}),
    "fisheye": ("Kannala-Brandt", {"fx": 400.0, "fy": 401.0, "model": "fisheye", "dist": [0.05, -0.01, 0.002, -0.0005]}),
    "double-sphere": ("Double Sphere", {"fx": 350.0, "fy": 351.0, "model": "double-sphere", "xi": -0.2, "alpha": 0.6}),
}
CV_FLAGS = {"opencv5": 0, "opencv8": cv2.CALIB_RATIONAL_MODEL, "opencv12": cv2.CALIB_RATIONAL_MODEL | cv2.CALIB_THIN_PRISM_MODEL,
            "opencv14": cv2.CALIB_RATIONAL_MODEL | cv2.CALIB_THIN_PRISM_MODEL | cv2.CALIB_TILTED_MODEL}
COLS, ROWS, SQUARE = 11, 8, 0.03


def toml_value(v):
    if isinstance(v, str):
        return f'"{v}"'
    if isinstance(v, list):
        return "[" + ", ".join(repr(float(x)) for x in v) + "]"
    return repr(v)


def spec(model, count, cover=False, seed=16):
    cam = dict(width=1280, height=1024, cx=639.5, cy=511.5, **CAMS[model][1])
    wide = model in ("fisheye", "double-sphere")
    # --cover: pinhole-model boards spread to the image edges (offsets as for the wide lenses).
    spread = wide or cover
    poses = dict(distance_m=[0.25, 0.6] if wide else [0.45, 0.9], tilt_deg=[0.0, 45.0], roll_deg=[-180.0, 180.0],
                 offset_x_m=[-0.3, 0.3] if spread else [-0.15, 0.15], offset_y_m=[-0.25, 0.25] if spread else [-0.1, 0.1])
    lines = ["version = 1", f"count = {count}", f"seed = {seed}", "", "[camera]"]
    lines += [f"{k} = {toml_value(v)}" for k, v in cam.items()]
    lines += ["", "[target]", 'kind = "chessboard"', "squares = [12, 9]", f"square_m = {SQUARE}", f"margin_m = {SQUARE / 2}",
              "", "[render]", "samples = 16", "noise_sigma = 2.0", "", "[poses]", 'mode = "board"']
    lines += [f"{k} = {toml_value(v)}" for k, v in poses.items()]
    lines += ["full_target_visible = true", "margin_px = 10.0"]
    return "\n".join(lines) + "\n", cam


def run(cmd):
    p = subprocess.run(cmd, capture_output=True, text=True)
    if p.returncode != 0:
        sys.exit(f"{' '.join(cmd)} failed:\n{p.stderr}")
    return p.stdout


def cv_sse(model, objp, corners, K, D, rvecs, tvecs):
    sse = 0.0
    for c, r, t in zip(corners, rvecs, tvecs):
        if model == "fisheye":
            q, _ = cv2.fisheye.projectPoints(objp.reshape(-1, 1, 3), r, t, K, D)
        else:
            q, _ = cv2.projectPoints(objp, r, t, K, D)
        sse += float(((q.reshape(-1, 2) - c.reshape(-1, 2)) ** 2).sum())
    return sse


def opencv(model, objp, corners, size, repeat):
    cv2.setNumThreads(1)
    times, out = [], None
    for _ in range(repeat):
        t0 = time.perf_counter()
        if model == "fisheye":
            flags = cv2.fisheye.CALIB_RECOMPUTE_EXTRINSIC | cv2.fisheye.CALIB_FIX_SKEW
            crit = (cv2.TERM_CRITERIA_COUNT + cv2.TERM_CRITERIA_EPS, 200, 1e-12)
            rms, K, D, rv, tv = cv2.fisheye.calibrate([objp.reshape(-1, 1, 3)] * len(corners), corners, size, None, None, flags=flags, criteria=crit)
        else:
            rms, K, D, rv, tv = cv2.calibrateCamera([objp] * len(corners), corners, size, None, None, flags=CV_FLAGS[model])
        times.append((time.perf_counter() - t0) * 1e3)
        out = (K, D, rv, tv)
    return out, statistics.median(times)


def one(model, count, repeat, bin_, d, folds=0, cover=False, seed=16):
    text, cam = spec(model, count, cover, seed)
    sp, ds, dj, cj = (os.path.join(d, n) for n in ("spec.toml", "ds", "det.json", "cal.json"))
    open(sp, "w").write(text)
    run([bin_, "dataset", sp, "-o", ds])
    imgs = os.path.join(ds, "images")
    run([bin_, "detect", imgs, "--target", f"chessboard:{COLS}x{ROWS}", "--json", dj])
    det = json.load(open(dj))
    found = [im for im in det["images"] if im["found"]]
    errs = []
    for im in found:
        truth = json.load(open(os.path.join(imgs, im["file"].replace(".png", ".json"))))
        tp = np.array([f["pixel_px"] for f in truth["features"]])
        for p in im["points_px"]:
            errs.append(np.min(np.linalg.norm(tp - np.array(p), axis=1)))
    errs = np.array(errs)
    print(f"\n## {model} ({CAMS[model][0]})\ndetect: {len(found)}/{len(det['images'])} found, corner error vs truth RMS {np.sqrt((errs ** 2).mean()):.4f} px, max {errs.max():.4f} px")
    st = []
    for _ in range(repeat):
        run([bin_, "calibrate", dj, "--target", f"chessboard:{COLS}x{ROWS}", "--square", str(SQUARE), "--model", model, "--json", cj, "--keep-outliers"])
        st.append(json.load(open(cj))["time_ms"])
    r = json.load(open(cj))
    K = np.array(r["K"])
    n_pts = sum(len(im["points_px"]) for im in found)
    sc_sse = r["rms_px"] ** 2 * n_pts
    e = [K[0, 0] - cam["fx"], K[1, 1] - cam["fy"], K[0, 2] - cam["cx"], K[1, 2] - cam["cy"]]
    det_rms = float(np.sqrt((errs ** 2).mean()))
    print(f"synthcam: fx fy cx cy - truth = {', '.join(f'{v:+.4f}' for v in e)} px; rms {r['rms_px']:.5f} px (fit / detection RMS {r['rms_px'] / det_rms:.3f}), SSE {sc_sse:.7f} px^2; median {statistics.median(st):.2f} ms")
    lens = r.get("dist") or [r["xi"], r["alpha"]]
    print(f"synthcam lens: {', '.join(f'{v:.5f}' for v in lens)}")
    if folds:
        run([bin_, "calibrate", dj, "--target", f"chessboard:{COLS}x{ROWS}", "--square", str(SQUARE), "--model", model, "--cross-validate", str(folds), "--json", cj])
        c = json.load(open(cj))["cross_validation"]
        spread = ", ".join(f"{k} {v:.3f}" for k, v in c["intrinsics_spread"].items() if k in ("fx", "fy", "cx", "cy"))
        print(f"cross-validation, {folds} folds: held-out RMS {c['held_out_rms_px']:.5f} px (fit {c['fit_rms_px']:.5f}); "
              f"projection difference RMS {c['projection_diff_rms_px']:.4f} / max {c['projection_diff_max_px']:.4f} px; spread over folds {spread}")
    if model == "double-sphere":
        print("OpenCV: no Double Sphere model")
        return
    objp = np.array([[c * SQUARE, rr * SQUARE, 0.0] for rr in range(ROWS) for c in range(COLS)], np.float64)
    corners = [np.array(im["points_px"], np.float64).reshape(-1, 1, 2) for im in found]
    (Kc, Dc, rv, tv), cv_ms = opencv(model, objp, corners, (1280, 1024), repeat)
    cv_e = [Kc[0, 0] - cam["fx"], Kc[1, 1] - cam["fy"], Kc[0, 2] - cam["cx"], Kc[1, 2] - cam["cy"]]
    sse = cv_sse(model, objp, corners, Kc, Dc, rv, tv)
    print(f"OpenCV {cv2.__version__}: fx fy cx cy - truth = {', '.join(f'{v:+.4f}' for v in cv_e)} px; SSE {sse:.7f} px^2; median {cv_ms:.2f} ms")
    print(f"SSE synthcam / OpenCV {sc_sse / sse:.9f}; time synthcam / OpenCV {statistics.median(st) / cv_ms:.3f}")


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--models", default=",".join(CAMS))
    ap.add_argument("--count", type=int, default=20)
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--synthcam", default="target/release/synthcam")
    ap.add_argument("--cross-validate", type=int, default=0, metavar="K", help="also cross-validate each calibration over K folds")
    ap.add_argument("--seed", type=int, default=16, help="the dataset's seed (poses, noise)")
    ap.add_argument("--cover", action="store_true", help="pinhole models: boards spread to the image edges (offsets +-0.3 x +-0.25 m)")
    a = ap.parse_args()
    for m in a.models.split(","):
        with tempfile.TemporaryDirectory() as d:
            one(m, a.count, a.repeat, a.synthcam, d, a.cross_validate, a.cover, a.seed)
    return 0


if __name__ == "__main__":
    sys.exit(main())
