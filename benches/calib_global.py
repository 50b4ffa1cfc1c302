#!/usr/bin/env python3
"""Issue 39 acceptance on renders: per lens model, N independent render sets (20 views each,
1280 x 1024, noise sigma 2, fresh seeds), detected and calibrated by synthcam; against the truth:

- fit RMS / detection RMS (the detections' RMS distance to the true corners), max over the sets
  (goal <= 1.02: the fit is not above what the true camera explains);
- projection difference to the true lens at every observed corner, after the rotation between
  the two camera frames that minimises it (mrcal's projection_diff), max over the sets (goal <= 0.1 px);
- the share of fx, fy, cx, cy errors within 1 and 2 reported sigmas (goal near 68 / 95 %);
- with --outliers: 1-3 % of the corners moved 1-5 px in the detections JSON: precision and recall
  of `views[i].outliers`, RMS before / after;
- the time of `calibrate` (its `time_ms`), and OpenCV's on the same corners (opencv5, fisheye).

Usage (from the repository root, after `cargo build --release`):
    python3 benches/calib_global.py [--models opencv5,opencv8,opencv14,fisheye,double-sphere] [--sets 20] [--seed 1000] [--outliers]
OpenCV is a benchmark tool only, never a dependency of the crate.
"""
import argparse, json, os, random, statistics, subprocess, sys, tempfile, time

import numpy as np
import cv2
from scipy.optimize import least_squares

sys.path.insert(0, os.path.dirname(__file__))
from lens_models import spec, run, COLS, ROWS, SQUARE  # noqa: E402

MODELS = ["opencv5", "opencv8", "opencv14", "fisheye", "double-sphere"]
# lens_models.py's cameras are for opencv5, opencv8, opencv12, opencv14, fisheye, double-sphere.


def project(cam, p):
    """Pixels of camera-frame points p (N x 3) under a calibration JSON or a truth camera dict."""
    model = cam["model"]
    fx, fy, cx, cy = cam["fx"], cam["fy"], cam["cx"], cam["cy"]
    K = np.array([[fx, cam.get("skew", 0.0), cx], [0, fy, cy], [0, 0, 1.0]])
    if model == "fisheye":
        q, _ = cv2.fisheye.projectPoints(p.reshape(-1, 1, 3), np.zeros(3), np.zeros(3), K, np.array(cam["dist"][:4]))
        return q.reshape(-1, 2)
    if model == "double-sphere":
        xi, alpha = cam["xi"], cam["alpha"]
        d1 = np.linalg.norm(p, axis=1)
        e = xi * d1 + p[:, 2]
        d2 = np.sqrt(p[:, 0] ** 2 + p[:, 1] ** 2 + e ** 2)
        den = alpha * d2 + (1 - alpha) * e
        return np.stack([fx * p[:, 0] / den + cx, fy * p[:, 1] / den + cy], axis=1)
    q, _ = cv2.projectPoints(p, np.zeros(3), np.zeros(3), K, np.array(cam["dist"]))
    return q.reshape(-1, 2)


def as_camera(cal, model):
    K = cal["K"]
    c = {"model": model, "fx": K[0][0], "fy": K[1][1], "cx": K[0][2], "cy": K[1][2], "skew": K[0][1]}
    if model == "double-sphere":
        c.update(xi=cal["xi"], alpha=cal["alpha"])
    else:
        c["dist"] = cal["dist"]
    return c


def truth_camera(t):
    c = dict(t)
    c.setdefault("model", "opencv")
    if c["model"] not in ("fisheye", "double-sphere"):
        c["dist"] = c.get("dist", [0.0] * 5)
    return c


def projection_diff(true_cam, cal_cam, rays, pixels):
    """Max |project_cal(R ray) - true pixel| over the rays, R fitted (scipy least squares)."""
    def res(w):
        R, _ = cv2.Rodrigues(w)
        return (project(cal_cam, rays @ R.T) - pixels).ravel()
    w = least_squares(res, np.zeros(3), x_scale=1e-3).x
    d = res(w).reshape(-1, 2)
    return float(np.linalg.norm(d, axis=1).max())


def one_set(model, seed, d, bin_, outliers, extra=(), warp=None):
    text, _ = spec(model, 20, False, seed)
    if warp:
        text = text.replace('kind = "chessboard"', f'kind = "chessboard"\nwarp_m = [{warp[0]}, {warp[1]}]')
    open(os.path.join(d, "spec.toml"), "w").write(text)
    ds = os.path.join(d, "ds")
    run([bin_, "dataset", os.path.join(d, "spec.toml"), "-o", ds])
    imgs = os.path.join(ds, "images")
    dj = os.path.join(d, "det.json")
    run([bin_, "detect", imgs, "--target", f"chessboard:{COLS}x{ROWS}", "--json", dj])
    det = json.load(open(dj))
    rays, true_px, errs, moved = [], [], [], set()
    rng = random.Random(seed)
    found = [im for im in det["images"] if im["found"]]
    truth_cam = None
    for vi, im in enumerate(found):
        t = json.load(open(os.path.join(imgs, im["file"].replace(".png", ".json"))))
        truth_cam = truth_camera(t["camera"])
        R, tt = np.array(t["cam_from_target"]["R"]), np.array(t["cam_from_target"]["t_m"])
        feats = t["features"]
        tps = np.array([f["pixel_px"] for f in feats])
        for j, p in enumerate(im["points_px"]):
            # The true corner nearest the detection (the detector's order need not be the truth's ids).
            f = feats[int(np.argmin(np.linalg.norm(tps - np.array(p), axis=1)))]
            tp = np.array(f["pixel_px"])
            errs.append(np.linalg.norm(tp - np.array(p)))
            rays.append(R @ np.array(f["point_target_m"]) + tt)
            true_px.append(tp)
            if outliers and rng.random() < 0.02:
                a, r = rng.uniform(0, 2 * np.pi), rng.uniform(1, 5)
                im["points_px"][j] = [p[0] + r * np.cos(a), p[1] + r * np.sin(a)]
                moved.add((im["file"], j))
    if outliers:
        json.dump(det, open(dj, "w"))
    cj = os.path.join(d, "cal.json")
    run([bin_, "calibrate", dj, "--target", f"chessboard:{COLS}x{ROWS}", "--square", str(SQUARE), "--model", model, "--json", cj, *extra])
    cal = json.load(open(cj))
    det_rms = float(np.sqrt(np.mean(np.square(errs))))
    diff = projection_diff(truth_cam, as_camera(cal, model), np.array(rays), np.array(true_px))
    K = cal["K"]
    err = {"fx": K[0][0] - truth_cam["fx"], "fy": K[1][1] - truth_cam["fy"], "cx": K[0][2] - truth_cam["cx"], "cy": K[1][2] - truth_cam["cy"]}
    # A parameter the views do not determine has a null (infinite) sigma: it counts as outside.
    z = [abs(err[k]) / cal["std"][k] if cal["std"].get(k) else float("inf") for k in err]
    # `views[i].outliers` index the detection's points (untrusted corners left out do not shift them).
    flagged = {(v["file"], j) for v in cal["views"] for j in v["outliers"]}
    out = dict(ratio=cal["rms_px"] / det_rms, diff=diff, z=z, time_ms=cal["time_ms"], rms=cal["rms_px"], det_rms=det_rms,
               rms_before=cal["rejection"]["rms_before_px"], moved=moved, flagged=flagged, restart_improved=cal["search"]["restart_improved"],
               inside=cal["projection_uncertainty"]["worst_inside_px"], warp=cal.get("board_warp_m"), k_err=err)
    if model in ("opencv5", "fisheye"):
        objp = np.array([[c * SQUARE, r * SQUARE, 0.0] for r in range(ROWS) for c in range(COLS)], np.float64)
        corners = [np.array(im["points_px"], np.float64).reshape(-1, 1, 2) for im in found]
        cv2.setNumThreads(1)
        t0 = time.perf_counter()
        try:
            if model == "fisheye":
                crit = (cv2.TERM_CRITERIA_COUNT + cv2.TERM_CRITERIA_EPS, 200, 1e-12)
                cv2.fisheye.calibrate([objp.reshape(-1, 1, 3)] * len(corners), corners, (1280, 1024), None, None,
                                      flags=cv2.fisheye.CALIB_RECOMPUTE_EXTRINSIC | cv2.fisheye.CALIB_FIX_SKEW, criteria=crit)
            else:
                cv2.calibrateCamera([objp] * len(corners), corners, (1280, 1024), None, None)
            out["cv_ms"] = (time.perf_counter() - t0) * 1e3
        except cv2.error as e:
            out["cv_failed"] = str(e).splitlines()[0]
    return out


WARPS = [(0.001, 0.0), (0.0, -0.002), (0.003, 0.0015), (-0.002, 0.001), (0.0025, -0.003)]


def warp_bench(a):
    """5 boards (sags of WARPS, metres), one render set each per model: the warp recovered by
    --board-warp, and fx, fy, cx, cy errors with and without it."""
    print("| model | board | rendered sag mm | recovered mm | |K error| max px, with --board-warp | without |")
    print("|---|---|---|---|---|---|")
    for m in a.models.split(","):
        for i, w in enumerate(WARPS):
            with tempfile.TemporaryDirectory() as d:
                r = one_set(m, a.seed + i, d, a.synthcam, False, ("--board-warp",), w)
            with tempfile.TemporaryDirectory() as d:
                flat = one_set(m, a.seed + i, d, a.synthcam, False, (), w)
            kw = max(abs(v) for v in r["k_err"].values())
            kf = max(abs(v) for v in flat["k_err"].values())
            print(f"| {m} | {i} | {w[0] * 1e3:.1f}, {w[1] * 1e3:.1f} | {r['warp'][0] * 1e3:.3f}, {r['warp'][1] * 1e3:.3f} | {kw:.3f} | {kf:.3f} |", flush=True)
    return 0


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--models", default=",".join(MODELS))
    ap.add_argument("--sets", type=int, default=20)
    ap.add_argument("--seed", type=int, default=1000, help="first set's seed (set k: seed + k)")
    ap.add_argument("--outliers", action="store_true", help="move 2 %% of the corners 1-5 px before calibrating")
    ap.add_argument("--synthcam", default="target/release/synthcam")
    ap.add_argument("--threshold", type=float, help="calibrate's --outlier-threshold")
    ap.add_argument("--warp", action="store_true", help="board warp instead: 5 boards with sags of 1-3 mm, calibrated with and without --board-warp")
    a = ap.parse_args()
    if a.warp:
        return warp_bench(a)
    extra = ("--outlier-threshold", str(a.threshold)) if a.threshold else ()
    print(f"sets {a.sets}, seeds {a.seed}..{a.seed + a.sets - 1}{', 2 % corners moved 1-5 px' if a.outliers else ''}")
    print("| model | fit/detection RMS max | projection diff max px | within 1 sigma | within 2 sigma | restarts lower | worst sigma inside px (median) | calibrate ms (median) | OpenCV ms (median) |")
    print("|---|---|---|---|---|---|---|---|---|")
    for m in a.models.split(","):
        rs = []
        for k in range(a.sets):
            with tempfile.TemporaryDirectory() as d:
                rs.append(one_set(m, a.seed + k, d, a.synthcam, a.outliers, extra))
        z = [v for r in rs for v in r["z"]]
        cv = [r["cv_ms"] for r in rs if "cv_ms" in r]
        cv_failed = sum("cv_failed" in r for r in rs)
        print(f"| {m} | {max(r['ratio'] for r in rs):.4f} | {max(r['diff'] for r in rs):.4f} | {100 * np.mean(np.array(z) <= 1):.0f} % | "
              f"{100 * np.mean(np.array(z) <= 2):.0f} % | {sum(r['restart_improved'] for r in rs)} | {statistics.median(r['inside'] or float('nan') for r in rs):.4f} | "
              f"{statistics.median(r['time_ms'] for r in rs):.1f} | {statistics.median(cv):.1f}{f' ({cv_failed} sets: OpenCV error)' if cv_failed else ''} |" if cv else
              f"| {m} | {max(r['ratio'] for r in rs):.4f} | {max(r['diff'] for r in rs):.4f} | {100 * np.mean(np.array(z) <= 1):.0f} % | "
              f"{100 * np.mean(np.array(z) <= 2):.0f} % | {sum(r['restart_improved'] for r in rs)} | {statistics.median(r['inside'] or float('nan') for r in rs):.4f} | "
              f"{statistics.median(r['time_ms'] for r in rs):.1f} | - |", flush=True)
        if a.outliers:
            moved = sum(len(r["moved"]) for r in rs)
            flagged = sum(len(r["flagged"]) for r in rs)
            hit = sum(len(r["moved"] & r["flagged"]) for r in rs)
            print(f"  outliers {m}: moved {moved}, flagged {flagged}, precision {hit / max(flagged, 1):.3f}, recall {hit / max(moved, 1):.3f}; "
                  f"RMS before max {max(r['rms_before'] for r in rs):.4f} px, after max {max(r['rms'] for r in rs):.4f} px", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
