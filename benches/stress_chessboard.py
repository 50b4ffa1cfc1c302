#!/usr/bin/env python3
"""Randomised chessboard stress suite: synthcam's detector vs OpenCV on hard, freshly drawn renders.

A benchmark / reference tool only (Python 3.11, numpy, opencv-python-headless; no network). Every
run draws NEW images with a fresh seed, printed; ``--seed N`` reproduces a run, ``--seed N
--classes C --index I`` one image of it. Image k of class C is drawn from
``random.Random(f"{seed}:{C}:{k}:{attempt}")`` (attempt > 0 after a rejected render).

Usage
-----
    python3 benches/stress_chessboard.py                          # 20 images per class, fresh seed
    python3 benches/stress_chessboard.py --seed 1234 --classes fisheye --index 7 --keep /tmp/fe
    python3 benches/stress_chessboard.py --per-class 50 --gate --json /tmp/s.json --regressions /tmp/r.jsonl

Classes (one table row each). All: 1280x1024, 1280x960 or 1024x768; 9x6, 8x6, 7x5 or 11x8 inner
corners; tilt 0-50 deg about a random in-plane axis; any roll; noise_sigma 0-3; random greys.

* ``barrel``: OpenCV model ``dist = [k1, k2, 0, 0, 0]``, k1 in [-0.45, -0.2], k2 in [0, k1^2 / 2],
  fx large enough that the radial scale d(r_d)/d(r) stays >= 0.3 over the whole image (renders
  break up in blocks where it nears 0, e.g. k2 ~ 9 k1^2 / 20). The inner-corner grid spans
  70-98 % of the image (max of x span / width, y span / height) with its outermost corner 2-15 px
  from one border (pose solved by bisection on distance and lateral offset).
* ``fisheye``: Kannala-Brandt, half field of view 75-95 deg (up to 190 across): one coefficient
  is solved so the polynomial folds there, and synthcam draws the background (grey 0-25) beyond
  the fold: a dark image circle of radius 80-97 % of the half short side. The grid spans 55-90 %
  of the circle's diameter, moved off-centre until the radial scale d(theta_d)/d(theta) at its
  outermost corner is 0.35-0.9 (1 on the axis; squares vanish towards the fold); >= 2 px inside
  the circle.
* ``effects``: a barrel or fisheye view with at least two of: vignetting (``[optics]``),
  over-exposure (``[sensor]`` with the light squares at 1.2-3x full scale: clipped whites, shot
  noise), defocus (thin lens; circle of confusion 0.5-2.5 px at the board centre), JPEG output
  (``[output] encoding = "jpeg"``, quality 60-90).

A board counts only if its truth JSON marks every inner corner visible and >= 2 px inside the
image; otherwise the pose is redrawn. Rendering: every scene of a class is written first (JSON,
which ``synthcam render`` reads like TOML), then rendered ``--jobs`` at a time, one ``render``
call per scene (``render`` takes one scene; ``dataset`` specs have one camera for all images).
The binary is copied at start, so a rebuild during a run does not mix detector versions.

Detectors on the same files: ``synthcam detect FILES --target chessboard:CxR --json`` (per board
and image size, ``RAYON_NUM_THREADS=1``, its ``time_ms``); classic
``findChessboardCorners(ADAPTIVE_THRESH|NORMALIZE_IMAGE)`` + ``cornerSubPix(11x11, EPS|MAX_ITER
30, 0.001)`` timed together; SB ``findChessboardCornersSB(flags=0)``; OpenCV with one thread.

Per class: recall (right boards: found, not wrong); wrong boards (wrong corner count, or a truth
corner > 2 px from its nearest detection, or two sharing one; order ignored); over the right
boards, corners > 0.1 px off, RMS and max error; median ms per image. synthcam's failures
(missed, wrong, or a corner > 0.1 px off) are listed with class, seed, index and parameters;
``--regressions FILE`` appends them as JSON lines with the scene. Exit: 0; 1 on an image not
rendered or read, or a failed ``--gate`` (synthcam recall < max(classic, SB), or a wrong
synthcam board); 2 on bad arguments.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import random
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

try:
    import cv2
    import numpy as np
except ImportError as exc:  # pragma: no cover - environment problem
    sys.exit(f"error: {exc}; install with `pip install opencv-python-headless numpy`")

CLASSES = ("barrel", "fisheye", "effects")
BOARDS = ((9, 6), (8, 6), (7, 5), (11, 8))
SIZES = ((1280, 1024), (1280, 960), (1024, 768))
DETS = ("synthcam", "classic", "sb")
INSIDE_PX, WRONG_PX, OFF_PX = 2.0, 2.0, 0.1
MIN_SLOPE = 0.3  # least radial scale d(r_d)/d(r) of a barrel lens over the image (near 0 the renders break up)
MAX_ATTEMPTS = 6  # renders per image before giving up (pose drawing itself retries freely)


def opencv_fold(k1: float, k2: float, slope: float = 0.0) -> float:
    """First undistorted radius where d/dr of r (1 + k1 r^2 + k2 r^4) falls to `slope` (0: the fold; inf: never)."""
    roots = np.roots([5 * k2, 3 * k1, 1.0 - slope]) if k2 else np.array([-(1 - slope) / (3 * k1)])
    pos = [r.real for r in np.atleast_1d(roots) if abs(r.imag) < 1e-12 and r.real > 0]
    return math.sqrt(min(pos)) if pos else math.inf


def kb_theta_d(k, th):
    t2 = th * th
    return th * (1 + t2 * (k[0] + t2 * (k[1] + t2 * (k[2] + t2 * k[3]))))


def draw_lens(rng: random.Random, kind: str, W: int, H: int) -> dict | None:
    cx, cy = (W - 1) / 2 + rng.uniform(-0.02, 0.02) * W, (H - 1) / 2 + rng.uniform(-0.02, 0.02) * H
    if kind == "barrel":
        k1 = rng.uniform(-0.45, -0.2)
        k2 = rng.uniform(0, 0.5 * k1 * k1)
        rs = opencv_fold(k1, k2, MIN_SLOPE)  # the whole image within radial scale >= MIN_SLOPE
        rd = rs * (1 + k1 * rs**2 + k2 * rs**4) if math.isfinite(rs) else math.inf
        half_diag = max(math.hypot(x - cx, y - cy) for x in (-0.5, W - 0.5) for y in (-0.5, H - 0.5))
        fx = max(W * rng.uniform(0.55, 1.2), half_diag / rd * rng.uniform(1.0, 1.3))
        return {"model": "opencv", "dist": [k1, k2, 0.0, 0.0, 0.0], "fx": fx, "cx": cx, "cy": cy, "fold_r": opencv_fold(k1, k2)}
    th_f = math.radians(rng.uniform(75, 95))
    k = [rng.uniform(-0.03, 0.03), rng.uniform(-0.005, 0.005), 0.0, 0.0]
    p = rng.choice((1, 2, 3))  # the coefficient (k2, k3 or k4) that puts the fold at th_f
    k[p] = 0.0
    rest = 1 + sum((2 * i + 3) * k[i] * th_f ** (2 * i + 2) for i in range(4))
    k[p] = -rest / ((2 * p + 3) * th_f ** (2 * p + 2))
    ts = np.linspace(1e-4, th_f, 2000)
    if np.any(np.diff(kb_theta_d(k, ts)) <= 0) or kb_theta_d(k, th_f) <= 0:
        return None
    rc = rng.uniform(0.80, 0.97) * (min(W, H) / 2 - 3)
    return {"model": "fisheye", "dist": k, "fx": rc / kb_theta_d(k, th_f), "cx": cx, "cy": cy,
            "fold_theta": th_f, "circle_px": rc, "fov_deg": 2 * math.degrees(th_f)}


def kb_slope(k, P):
    """Least d(theta_d)/d(theta) over the points: radial compression, 1 at the centre."""
    t2 = np.arctan2(np.hypot(P[:, 0], P[:, 1]), P[:, 2]) ** 2
    return float((1 + t2 * (3 * k[0] + t2 * (5 * k[1] + t2 * (7 * k[2] + t2 * 9 * k[3])))).min())


def project(lens: dict, P: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Pixels (OpenCV convention) and validity (in front, inside the one-to-one region)."""
    X, Y, Z = P[:, 0], P[:, 1], P[:, 2]
    if lens["model"] == "opencv":
        k1, k2 = lens["dist"][:2]
        with np.errstate(all="ignore"):
            x, y = X / Z, Y / Z
        r2 = x * x + y * y
        ok, s = (Z > 1e-9) & (np.sqrt(r2) < lens["fold_r"]), 1 + k1 * r2 + k2 * r2 * r2
        xd, yd = x * s, y * s
    else:
        a = np.hypot(X, Y)
        th = np.arctan2(a, Z)
        with np.errstate(all="ignore"):
            sc = np.where(a > 1e-12, kb_theta_d(lens["dist"], th) / np.maximum(a, 1e-300), 1 / np.maximum(Z, 1e-300))
        ok = th < lens["fold_theta"]
        xd, yd = X * sc, Y * sc
    return np.stack([lens["fx"] * xd + lens["cx"], lens["fx"] * yd + lens["cy"]], 1), ok


def place_board(rng, lens, W, H, cols, rows, sq, fish):
    """Solve a pose meeting the class's fill / border rules; None when this draw cannot."""
    tilt, axis, roll = math.radians(rng.uniform(0, 50)), rng.uniform(0, 2 * math.pi), rng.uniform(-math.pi, math.pi)
    R = cv2.Rodrigues(np.array([math.cos(axis), math.sin(axis), 0.0]) * tilt)[0] @ cv2.Rodrigues(np.array([0, 0, roll]))[0]
    grid = np.array([[(c + 1) * sq, (r + 1) * sq, 0.0] for r in range(rows) for c in range(cols)])
    ctr = np.array([(cols + 1) * sq / 2, (rows + 1) * sq / 2, 0.0])
    pts_b = (grid - ctr) @ R.T
    a0, az = rng.uniform(0, 0.1), rng.uniform(0, 2 * math.pi)
    d0 = np.array([math.sin(a0) * math.cos(az), math.sin(a0) * math.sin(az), math.cos(a0)])
    side = rng.randrange(4)  # the border the grid is pushed against (barrel)
    e = np.array([[-1, 0, 0], [1, 0, 0], [0, -1, 0], [0, 1, 0]][side], float)
    fill = rng.uniform(0.55, 0.9) if fish else rng.uniform(0.7, 0.98)
    gap_want = rng.uniform(0.35, 0.9) if fish else rng.uniform(2, 15)  # fisheye: least radial scale
    diam = 2 * lens.get("circle_px", 0)
    u_lo = 0.0 if fish else -1.5

    def state(D, u):
        d = d0 + u * e
        px, ok = project(lens, P := D * d / np.linalg.norm(d) + pts_b)
        if not ok.all():
            return None
        span = max(np.ptp(px[:, 0]), np.ptp(px[:, 1])) / diam if fish else max(np.ptp(px[:, 0]) / W, np.ptp(px[:, 1]) / H)
        gaps = np.array([px[:, 0].min() + 0.5, W - 0.5 - px[:, 0].max(), px[:, 1].min() + 0.5, H - 0.5 - px[:, 1].max()])
        return px, span, gaps, kb_slope(lens["dist"], P) if fish else gaps[side]

    def bisect(f, lo, hi, n=48):  # f increasing; root of f = 0 (None: not bracketed)
        if not f(lo) <= 0 <= f(hi):
            return None
        for _ in range(n):
            m = 0.5 * (lo + hi)
            lo, hi = (m, hi) if f(m) <= 0 else (lo, m)
        return 0.5 * (lo + hi)

    size, u = sq * max(cols, rows), 0.0
    for _ in range(3):  # alternate: distance for the fill (invalid = too close), offset for the gap / scale
        g = lambda lD: (lambda s: -1e9 if s is None else fill - s[1])(state(math.exp(lD), u))
        if (logD := bisect(g, math.log(size * 0.01), math.log(size * 100))) is None:
            return None
        h = lambda v: (lambda s: 1e9 if s is None else gap_want - s[3])(state(math.exp(logD), v))
        if (u := bisect(h, u_lo, 1.5)) is None:
            return None
    if (st := state(math.exp(logD), u)) is None or st[2].min() < INSIDE_PX + 0.05:
        return None
    px, span, gaps, slope = st
    if fish:
        rim = diam / 2 - np.hypot(px[:, 0] - lens["cx"], px[:, 1] - lens["cy"]).max()
        if rim < INSIDE_PX + 0.05 or not 0.5 <= span <= 1.0 or slope < 0.34:
            return None
    elif not (0.7 <= span <= 1.0 and 2 <= gaps.min() <= 15):
        return None
    t = math.exp(logD) * (d0 + u * e) / np.linalg.norm(d0 + u * e) - R @ ctr
    info = {"tilt_deg": math.degrees(tilt), "roll_deg": math.degrees(roll), "fill": float(span)}
    info.update({"rim_gap_px": float(rim), "radial_scale_min": float(slope)} if fish else {"border_gap_px": float(gaps.min())})
    return R, t, px, info


def draw_image(cls: str, seed: int, index: int, attempt: int) -> tuple[dict, dict, np.ndarray]:
    """(scene, params, predicted corners) of image `index` of `cls`; deterministic."""
    rng = random.Random(f"{seed}:{cls}:{index}:{attempt}")
    base = cls if cls != "effects" else rng.choice(("barrel", "fisheye"))
    W, H = rng.choice(SIZES)
    cols, rows = rng.choice(BOARDS)
    sq = 0.03
    for _ in range(10000):
        lens = draw_lens(rng, base, W, H)
        pose = lens and place_board(rng, lens, W, H, cols, rows, sq, base == "fisheye")
        if pose:
            break
    else:
        raise RuntimeError(f"{cls} {index}: no pose met the class's rules in 10000 draws")
    (R, t, px, info), fish, noise = pose, base == "fisheye", rng.uniform(0, 3)
    scene = {
        "camera": {"width": W, "height": H, "fx": lens["fx"], "fy": lens["fx"], "cx": lens["cx"], "cy": lens["cy"],
                   "skew": 0.0, "model": lens["model"], "dist": lens["dist"]},
        "target": {"kind": "chessboard", "squares": [cols + 1, rows + 1], "square_m": sq,
                   "margin_m": sq * rng.uniform(0.25, 1.0), "dark": rng.uniform(5, 45), "light": rng.uniform(190, 245),
                   "background": rng.uniform(0, 25) if fish else rng.uniform(40, 170)},
        "pose": {"rvec": cv2.Rodrigues(R)[0].ravel().tolist(), "t_m": t.tolist()},
        "render": {"samples": 16, "noise_sigma": noise, "seed": rng.randrange(2**31)},
    }
    params = {"class": cls, "lens": base, "size": [W, H], "board": f"{cols}x{rows}", "fx": round(lens["fx"], 1),
              "dist": [round(k, 5) for k in lens["dist"][:4]], "noise_sigma": round(noise, 2),
              **{k: round(v, 2) for k, v in info.items()}}
    params.update({"fov_deg": round(lens["fov_deg"], 1)} if fish else {})
    if cls == "effects":
        fx_on: list = []
        while len(fx_on) < 2:
            fx_on = [e for e in ("vignetting", "overexposure", "defocus", "jpeg") if rng.random() < 0.6]
        optics: dict = {}
        if "vignetting" in fx_on:
            optics.update(vignetting=[rng.uniform(-0.6, -0.1)], natural_falloff=(not fish) and rng.random() < 0.5)
            params["vignetting"] = round(optics["vignetting"][0], 3)
        if "defocus" in fx_on:
            zc = float(np.linalg.norm(t + R @ np.array([(cols + 1) * sq / 2, (rows + 1) * sq / 2, 0])))
            coc, half_ap = rng.uniform(0.5, 2.5), 0.008 / 2.8 / 2  # CoC radius = fx A/2 |1/Z - 1/F|
            if (inv_f := 1 / zc + rng.choice((-1, 1)) * coc / (lens["fx"] * half_ap)) < 0.05:
                inv_f = 1 / zc + coc / (lens["fx"] * half_ap)
            optics.update(f_number=2.8, focal_length_m=0.008, focus_distance_m=1 / inv_f, aperture_samples=16)
            params["coc_px"] = round(coc, 2)
        if optics:
            scene["optics"] = {"natural_falloff": False, **optics}
        if "overexposure" in fx_on:
            sat, light = rng.uniform(1.2, 3.0), scene["target"]["light"]  # light squares at sat x full scale
            scene["sensor"] = {"exposure_s": 0.01, "photons_per_s_at_255": 255 * sat / (0.015 * 0.01 * light / 255),
                               "seed": rng.randrange(2**31)}  # default gain 0.025 DN/e, QE 0.6
            scene["render"]["noise_sigma"] = 0.0  # the sensor's shot and read noise instead
            params.pop("noise_sigma")
            params["overexposure"] = round(sat, 2)
        if "jpeg" in fx_on:
            scene["output"] = {"encoding": "jpeg", "jpeg_quality": rng.randint(60, 90)}
            params["jpeg_quality"] = scene["output"]["jpeg_quality"]
    return scene, params, px


def render_all(exe: str, jobs: list[tuple[Path, Path]], par: int) -> dict[Path, str]:
    """Run `synthcam render SCENE -o OUT` for every job, `par` at a time; errors by output path."""
    errors, running, queue = {}, [], list(jobs)
    while queue or running:
        while queue and len(running) < par:
            sc, out = queue.pop(0)
            running.append((out, subprocess.Popen([exe, "render", str(sc), "-o", str(out)], stdout=subprocess.DEVNULL,
                                                  stderr=subprocess.PIPE, text=True)))
        out, p = running.pop(0)
        if (err := p.communicate()[1]) is not None and p.returncode != 0:
            errors[out] = " | ".join(err.strip().splitlines()[-2:])
    return errors


def truth_ok(img: Path) -> tuple[np.ndarray | None, str]:
    try:
        doc = json.loads(img.with_suffix(".json").read_text())
        pts = np.array([f["pixel_px"] for f in doc["features"]], float).reshape(-1, 2)
        vis = all(f["visible"] for f in doc["features"])
        W, H = doc["camera"]["width"], doc["camera"]["height"]
    except (OSError, ValueError, KeyError, TypeError) as exc:
        return None, f"truth: {exc}"
    inside = np.minimum.reduce([pts[:, 0] + 0.5, W - 0.5 - pts[:, 0], pts[:, 1] + 0.5, H - 0.5 - pts[:, 1]])
    if not vis or inside.min() < INSIDE_PX:
        return None, f"board not visible (all visible: {vis}, min inside {inside.min():.2f} px)"
    return pts, ""


def run_opencv(gray: np.ndarray, pattern: tuple[int, int]) -> dict:
    crit = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_MAX_ITER, 30, 0.001)
    t0 = time.perf_counter()
    ok, c = cv2.findChessboardCorners(gray, pattern, flags=cv2.CALIB_CB_ADAPTIVE_THRESH | cv2.CALIB_CB_NORMALIZE_IMAGE)
    if ok:
        c = cv2.cornerSubPix(gray, c, (11, 11), (-1, -1), crit)
    t1 = time.perf_counter()
    ok2, c2 = cv2.findChessboardCornersSB(gray, pattern, flags=0)
    t2 = time.perf_counter()
    pts = lambda ok, c: np.asarray(c, float).reshape(-1, 2) if ok and c is not None else None
    return {"classic": {"points": pts(ok, c), "ms": (t1 - t0) * 1e3}, "sb": {"points": pts(ok2, c2), "ms": (t2 - t1) * 1e3}}


def run_synthcam(exe: str, files: list[Path], pattern: tuple[int, int], tmp: Path) -> dict:
    out = tmp / f"det_{pattern[0]}x{pattern[1]}_{len(files)}_{files[0].stem}.json"
    env = dict(os.environ, RAYON_NUM_THREADS="1")
    out.unlink(missing_ok=True)
    p = subprocess.run([exe, "detect", *map(str, files), "--target", f"chessboard:{pattern[0]}x{pattern[1]}", "--json", str(out)],
                       capture_output=True, text=True, env=env)
    try:
        doc = json.loads(out.read_text())
    except (OSError, ValueError):
        return {f.name: {"points": None, "ms": None, "error": f"detect rc {p.returncode}: {p.stderr.strip()[-300:]}"} for f in files}
    res = {}
    for im in doc.get("images", []):
        pts = np.asarray(im.get("points_px") or [], float).reshape(-1, 2)
        res[Path(im["file"]).name] = {"points": pts if im.get("found") else None, "ms": im.get("time_ms"),
                                      "error": im.get("error"), "note": im.get("note"), "untrusted": im.get("untrusted", [])}
    return res


def score(points: np.ndarray | None, truth: np.ndarray, untrusted=()) -> dict:
    """A found board against the truth. Corners the detector flags as untrusted (synthcam's
    ``untrusted``: its own fit cannot place them within 0.1 px) are counted, and left out of the
    wrong-board test and the error figures: a calibration leaves them out too."""
    if points is None:
        return {"found": False}
    if len(points) != len(truth):
        return {"found": True, "wrong": True, "why": f"{len(points)} points, expected {len(truth)}"}
    dd = np.sqrt(((points[:, None] - truth[None]) ** 2).sum(-1))  # order ignored: nearest detection, one-to-one
    nearest = dd.argmin(0)
    if len(set(nearest)) < len(truth):
        return {"found": True, "wrong": True, "why": "two truth corners share their nearest detection"}
    trusted = ~np.isin(nearest, np.asarray(list(untrusted), int))
    d = dd.min(0)[trusted]
    worst = float(d.max()) if len(d) else 0.0
    return {"found": True, "wrong": bool(worst > WRONG_PX), "dists": d, "max": worst, "why": f"corner {worst:.2f} px off",
            "untrusted": int((~trusted).sum())}


def render_class(exe: str, cls: str, seed: int, indices: list[int], root: Path, par: int) -> dict:
    """Scenes of every image first, then the renders; truth-rejected images are redrawn."""
    ims, pending = {}, {i: 0 for i in indices}
    while pending:
        jobs = []
        for i, att in pending.items():
            scene, params, pred = draw_image(cls, seed, i, att)
            stem = root / f"{cls}_{i:04d}"
            [stem.with_suffix(x).unlink(missing_ok=True) for x in (".png", ".jpg")]
            img = stem.with_suffix(".jpg" if scene.get("output", {}).get("encoding") == "jpeg" else ".png")
            stem.with_suffix(".scene.json").write_text(json.dumps(scene, indent=1))
            ims[i] = {"index": i, "attempt": att, "file": img, "scene": scene, "params": params, "pred": pred}
            jobs.append((stem.with_suffix(".scene.json"), img))
        errs, nxt = render_all(exe, jobs, par), {}
        for i in pending:
            rec = ims[i]
            truth, why = (None, errs[rec["file"]]) if rec["file"] in errs else truth_ok(rec["file"])
            if truth is not None:
                rec["truth"] = truth
                if (dev := float(np.abs(truth - rec["pred"]).max())) > 0.05:
                    print(f"warning: {cls} {i}: truth differs from the script's projection by {dev:.3f} px")
            elif rec["attempt"] + 1 < MAX_ATTEMPTS:
                print(f"  redraw {cls} {i} (attempt {rec['attempt']}): {why}")
                nxt[i] = rec["attempt"] + 1
            else:
                rec["error"] = why
                print(f"error: {cls} {i}: gave up after {MAX_ATTEMPTS} attempts: {why}")
        pending = nxt
    return ims


def detect_class(exe: str, ims: dict, root: Path) -> None:
    """All three detectors on every rendered image; results into each record's `det`."""
    groups: dict = {}
    for r in ims.values():
        if "truth" in r:
            groups.setdefault((r["params"]["board"], tuple(r["params"]["size"])), []).append(r)
    for (board, _), rs in groups.items():
        pattern = tuple(int(v) for v in board.split("x"))
        sc = run_synthcam(exe, [r["file"] for r in rs], pattern, root)
        for r in rs:
            r["det"] = {"synthcam": sc.get(r["file"].name, {"points": None, "ms": None, "error": "not in detect's JSON"})}
            gray = cv2.imread(str(r["file"]), cv2.IMREAD_GRAYSCALE)
            if gray is None or r["det"]["synthcam"].get("error"):
                r["error"] = f"unreadable: {r['det']['synthcam'].get('error') or 'cv2.imread failed'}"
                continue
            r["det"].update(run_opencv(gray, pattern))
            for d in DETS:
                r["det"][d].update(score(r["det"][d]["points"], r["truth"], r["det"][d].get("untrusted", ())))


def summarise(good: list[dict]) -> dict:
    summ = {"images": len(good)}
    for d in DETS:
        res = [r["det"][d] for r in good]
        right = [x for x in res if x["found"] and not x["wrong"]]
        dists = np.concatenate([x["dists"] for x in right]) if right else np.zeros(0)
        ms = [x["ms"] for x in res if x["ms"] is not None]
        summ[d] = {"found": len(right), "wrong": sum(bool(x.get("wrong")) for x in res),  # found: right boards only
                   "corners_off": int((dists > OFF_PX).sum()), "corners": int(len(dists)),
                   "untrusted": sum(x.get("untrusted", 0) for x in right),
                   "rms_px": float(np.sqrt((dists**2).mean())) if len(dists) else None,
                   "max_px": float(dists.max()) if len(dists) else None, "median_ms": statistics.median(ms) if ms else None}
    return summ


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--per-class", type=int, default=20, help="images per class (default 20)")
    ap.add_argument("--classes", default=",".join(CLASSES), help=f"comma list out of {','.join(CLASSES)} (default all)")
    ap.add_argument("--seed", type=int, help="reproduce a run (default: a fresh random seed, printed)")
    ap.add_argument("--index", help="comma list of image indices to run (default: 0..per-class-1)")
    ap.add_argument("--keep", metavar="DIR", help="write images, truth and scenes here (default: a temp dir, removed)")
    ap.add_argument("--synthcam", default=os.environ.get("SYNTHCAM_BIN") or "target/release/synthcam",
                    help="synthcam binary (default $SYNTHCAM_BIN or target/release/synthcam)")
    ap.add_argument("--jobs", type=int, default=2, help="renders at a time (default 2)")
    ap.add_argument("--json", metavar="OUT", help="also write every number here")
    ap.add_argument("--regressions", metavar="FILE", help="append synthcam's failing images here as JSON lines")
    ap.add_argument("--gate", action="store_true", help="exit 1 unless synthcam recall >= max(classic, SB) and 0 wrong boards")
    args = ap.parse_args(argv)
    classes = [c.strip() for c in args.classes.split(",") if c.strip()]
    if not classes or any(c not in CLASSES for c in classes):
        ap.error(f"--classes: expected a comma list out of {', '.join(CLASSES)}, got {args.classes!r}")
    if args.per_class < 1 or args.jobs < 1:
        ap.error("--per-class and --jobs must be >= 1")
    try:
        indices = sorted({int(i) for i in args.index.split(",")}) if args.index else list(range(args.per_class))
    except ValueError:
        ap.error(f"--index: expected a comma list of integers, got {args.index!r}")
    exe = shutil.which(args.synthcam) or args.synthcam
    if not Path(exe).is_file():
        repo = Path(__file__).resolve().parent.parent / args.synthcam
        exe = str(repo) if repo.is_file() else ap.error(f"synthcam binary not found: {args.synthcam!r} (cargo build --release)")
    seed = args.seed if args.seed is not None else random.SystemRandom().randrange(2**31)
    cv2.setNumThreads(1)
    built = time.strftime("%Y-%m-%d %H:%M:%S", time.localtime(Path(exe).stat().st_mtime))
    bin_dir = tempfile.TemporaryDirectory(prefix="synthcam_bin_")  # one binary for the whole run, even if rebuilt meanwhile
    exe = shutil.copy2(exe, Path(bin_dir.name) / "synthcam")
    version = subprocess.run([exe, "--version"], capture_output=True, text=True).stdout.strip() + f" (binary built {built})"
    which = f"--index {','.join(map(str, indices))}" if args.index else f"--per-class {args.per_class}"
    print(f"# chessboard stress: seed {seed}  (reproduce: --seed {seed} --classes {','.join(classes)} {which})")
    print(f"{version}; OpenCV {cv2.__version__}; {len(indices)} image(s) per class")
    t_start, phase, results, failures, unreadable = time.perf_counter(), {"render_s": 0.0, "detect_s": 0.0}, {}, [], 0
    tmp_ctx = None if args.keep else tempfile.TemporaryDirectory(prefix="synthcam_stress_")
    (root := Path(args.keep or tmp_ctx.name)).mkdir(parents=True, exist_ok=True)
    for cls in classes:
        t0 = time.perf_counter()
        ims = render_class(exe, cls, seed, indices, root, args.jobs)
        t1 = time.perf_counter()
        detect_class(exe, ims, root)
        phase["render_s"] += t1 - t0
        phase["detect_s"] += time.perf_counter() - t1
        good = [r for r in sorted(ims.values(), key=lambda r: r["index"]) if "error" not in r]
        unreadable += len(ims) - len(good)
        results[cls] = {"summary": {**summarise(good), "errors": len(ims) - len(good)}, "images": [
            {"index": r["index"], "attempt": r["attempt"], "params": r["params"], "error": r.get("error"),
             "det": {d: {k: (v.tolist() if isinstance(v, np.ndarray) else v) for k, v in r["det"][d].items() if k != "dists"}
                     for d in DETS} if "error" not in r else None} for r in sorted(ims.values(), key=lambda r: r["index"])]}
        for r in good:
            s = r["det"]["synthcam"]
            why = (f"missed{': ' + s['note'] if s.get('note') else ''}" if not s["found"] else f"wrong board ({s['why']})"
                   if s["wrong"] else f"corner {s['max']:.3f} px off" if s["max"] > OFF_PX else "")
            if why:
                others = ", ".join(f"{d.replace('sb', 'SB')} " + ("no" if not x["found"] else "wrong" if x["wrong"] else "found")
                                   for d, x in r["det"].items() if d != "synthcam")
                failures.append({"class": cls, "seed": seed, "index": r["index"], "attempt": r["attempt"], "reason": why,
                                 "others": others, "params": r["params"], "scene": r["scene"]})
    wall = time.perf_counter() - t_start

    f3 = lambda v, spec=".3f": "–" if v is None else format(v, spec)
    trio = lambda s, fmt: " / ".join(fmt(s[d]) for d in DETS)
    print("\n| class | images | recall synthcam / classic / SB | wrong boards | corners > 0.1 px | untrusted (synthcam) | RMS px | max px | median ms / image |")
    print("|---|---|---|---|---|---|---|---|---|")
    gate_fail = []
    for cls, res in results.items():
        s, n = res["summary"], res["summary"]["images"]
        print(f"| {cls} | {n}" + (f" (+{s['errors']} errors)" if s["errors"] else "") + " | "
              + trio(s, lambda x: f"{x['found']}/{n}") + " | " + trio(s, lambda x: str(x["wrong"])) + " | "
              + trio(s, lambda x: f"{x['corners_off']}/{x['corners']}") + f" | {s['synthcam']['untrusted']} | " + trio(s, lambda x: f3(x["rms_px"])) + " | "
              + trio(s, lambda x: f3(x["max_px"])) + " | " + trio(s, lambda x: f3(x["median_ms"], ".1f")) + " |")
        if n and s["synthcam"]["found"] < max(s["classic"]["found"], s["sb"]["found"]):
            gate_fail.append(f"{cls}: synthcam recall {s['synthcam']['found']}/{n} < max(classic {s['classic']['found']}, "
                             f"SB {s['sb']['found']})")
        if s["synthcam"]["wrong"]:
            gate_fail.append(f"{cls}: synthcam found {s['synthcam']['wrong']} wrong board(s)")
    print(f"\nseed {seed}; wall {wall:.1f} s (render {phase['render_s']:.1f} s, detect {phase['detect_s']:.1f} s); OpenCV 1 "
          "thread, synthcam RAYON_NUM_THREADS=1 (its time_ms); corner errors over found boards that are not wrong")
    if failures:
        print(f"\n## synthcam failures ({len(failures)}): class, seed, index: reason [classic, SB] parameters\n")
        for f in failures:
            print(f"- {f['class']} seed {f['seed']} index {f['index']}: {f['reason']} [{f['others']}] "
                  + json.dumps({k: v for k, v in f["params"].items() if k != "class"}))
    if args.regressions and failures:
        with open(args.regressions, "a") as fh:
            fh.writelines(json.dumps(f) + "\n" for f in failures)
        print(f"\nappended {len(failures)} case(s) to {args.regressions}")
    if args.json:
        Path(args.json).write_text(json.dumps({"seed": seed, "argv": sys.argv, "synthcam": version, "opencv": cv2.__version__,
                                               "wall_s": wall, **phase, "classes": results, "gate_failures": gate_fail,
                                               "failures": [{k: v for k, v in f.items() if k != "scene"} for f in failures]}, indent=1))
        print(f"wrote {args.json}")
    if args.keep:
        print(f"images, truth and scenes kept in {root}")
    elif tmp_ctx:
        tmp_ctx.cleanup()
    bin_dir.cleanup()
    if args.gate:
        print("\ngate: " + ("PASS" if not gate_fail else "FAIL\n" + "\n".join(f"  - {g}" for g in gate_fail)))
    if unreadable:
        print(f"\n{unreadable} image(s) could not be rendered or read")
    return 1 if unreadable or (args.gate and gate_fail) else 0


if __name__ == "__main__":
    sys.exit(main())
