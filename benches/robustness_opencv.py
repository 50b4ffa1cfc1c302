#!/usr/bin/env python3
"""OpenCV's chessboard detectors on the images of ``synthcam experiment robustness``.

A benchmark / reference tool only: OpenCV is never a dependency of the synthcam crate.
Requires Python 3 with numpy and opencv-python-headless
(``pip install opencv-python-headless numpy``); no network access.

Usage
-----
    synthcam experiment robustness -o /tmp/robustness        # writes /tmp/robustness/images/
    python3 benches/robustness_opencv.py /tmp/robustness

Input: ``OUT/images/<effect>/<level>_<view>.png`` with the sidecar ``<level>_<view>.truth.json``
that the experiment writes: ``grid`` = [cols, rows] inner corners, ``truth_px`` = the truth the
detectors are compared with, in the target's order (rolling-shutter truth under a rolling
shutter, the mid-exposure projection under motion blur, ``pixel_px`` otherwise; null where it
does not exist), and ``synthcam`` = synthcam's own result on the same image.

Detectors:

* ``classic``: ``findChessboardCorners(flags=ADAPTIVE_THRESH|NORMALIZE_IMAGE)`` then
  ``cornerSubPix(winSize=(5,5), zeroZone=(-1,-1), EPS|MAX_ITER, 30, 0.001)``.
* ``sb``: ``findChessboardCornersSB(flags=ACCURACY|EXHAUSTIVE)``.

Matching (as the Rust side, ``synthcam::sim::robustness::match_errors``): the corners in the
detector's order against the truth under every symmetry of the grid (identity, the two mirrors,
the half turn; the transposes too for square grids), the one with the smallest RMS counts. A
board with another number of corners counts as not detected.

Output: ``OUT/opencv.csv`` (one line per image and detector) and ``OUT/table_with_opencv.md``
(per effect and level: detection rate and mean over the detections of the per-image RMS error
for synthcam, OpenCV classic and OpenCV SB). Pixel convention: OpenCV's (centre of the top-left
pixel is (0, 0)), the same as synthcam's truth.
"""

from __future__ import annotations

import csv
import json
import math
import sys
import time
from collections import defaultdict
from pathlib import Path

try:
    import cv2
    import numpy as np
except ImportError as exc:  # pragma: no cover - environment problem
    sys.exit(f"error: {exc}; install with `pip install opencv-python-headless numpy`")

DETECTORS = ("classic", "sb")
SUBPIX_CRITERIA = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_MAX_ITER, 30, 0.001)
EFFECT_ORDER = ("blur", "defocus", "noise", "motion-blur", "jpeg", "rolling-shutter", "gradient", "highlight", "clutter", "shadow")


def grid_symmetries(cols: int, rows: int) -> list[np.ndarray]:
    """Index permutations of a row-major cols x rows grid onto itself."""
    r, c = np.divmod(np.arange(rows * cols), cols)
    out = []
    for fr, fc in ((False, False), (True, True), (False, True), (True, False)):
        rr = rows - 1 - r if fr else r
        cc = cols - 1 - c if fc else c
        out.append(rr * cols + cc)
        if cols == rows:
            out.append(cc * cols + rr)
    return out


def match_errors(found: np.ndarray, truth: np.ndarray, cols: int, rows: int) -> np.ndarray | None:
    """Per-corner errors under the best grid symmetry (finite truth only); None on a count mismatch."""
    if found is None or len(found) != len(truth) or len(truth) != cols * rows:
        return None
    ok = np.isfinite(truth).all(axis=1)
    best = None
    for perm in grid_symmetries(cols, rows):
        e = np.linalg.norm(found[perm] - truth, axis=1)[ok]
        if best is None or np.sqrt(np.mean(e**2)) < np.sqrt(np.mean(best**2)):
            best = e
    return best


def detect(name: str, img: np.ndarray, cols: int, rows: int) -> np.ndarray | None:
    """Corners (N x 2, detector order) or None."""
    if name == "classic":
        ok, corners = cv2.findChessboardCorners(img, (cols, rows), flags=cv2.CALIB_CB_ADAPTIVE_THRESH | cv2.CALIB_CB_NORMALIZE_IMAGE)
        if not ok:
            return None
        corners = cv2.cornerSubPix(img, corners, (5, 5), (-1, -1), SUBPIX_CRITERIA)
    else:
        ok, corners = cv2.findChessboardCornersSB(img, (cols, rows), flags=cv2.CALIB_CB_ACCURACY | cv2.CALIB_CB_EXHAUSTIVE)
        if not ok:
            return None
    return corners.reshape(-1, 2).astype(np.float64)


def as_float(v) -> float:
    return float("nan") if v is None else float(v)


def run(out: Path) -> list[dict]:
    sidecars = sorted((out / "images").glob("*/*.truth.json"))
    if not sidecars:
        sys.exit(f"error: no images/*/*.truth.json under {out} (run `synthcam experiment robustness -o {out}` first)")
    rows_out = []
    for k, side in enumerate(sidecars):
        meta = json.loads(side.read_text())
        png = side.with_name(side.name.replace(".truth.json", ".png"))
        img = cv2.imread(str(png), cv2.IMREAD_GRAYSCALE)
        if img is None:
            print(f"warning: cannot read {png}", file=sys.stderr)
            continue
        cols, rows = meta["grid"]
        truth = np.array([[as_float(x), as_float(y)] for x, y in meta["truth_px"]], dtype=np.float64)
        base = {key: meta[key] for key in ("effect", "level_index", "level", "view")}
        base["strength"] = as_float(meta["strength"])
        ours = meta["synthcam"]
        rows_out.append({**base, "detector": "synthcam", "detected": int(ours["detected"]), "rms_px": as_float(ours["rms_px"]), "max_px": as_float(ours["max_px"]), "time_ms": float("nan")})
        for name in DETECTORS:
            t0 = time.perf_counter()
            found = detect(name, img, cols, rows)
            dt = 1e3 * (time.perf_counter() - t0)
            e = match_errors(found, truth, cols, rows)
            det = e is not None and len(e) > 0
            rms = float(np.sqrt(np.mean(e**2))) if det else float("nan")
            mx = float(e.max()) if det else float("nan")
            rows_out.append({**base, "detector": name, "detected": int(det), "rms_px": rms, "max_px": mx, "time_ms": dt})
        if (k + 1) % 30 == 0:
            print(f"{k + 1}/{len(sidecars)} images", file=sys.stderr)
    return rows_out


def fmt(v: float, digits: int) -> str:
    return "-" if v is None or math.isnan(v) else f"{v:.{digits}f}"


def write_csv(path: Path, rows: list[dict]) -> None:
    fields = ["effect", "level_index", "level", "view", "strength", "detector", "detected", "rms_px", "max_px", "time_ms"]
    with path.open("w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=fields)
        w.writeheader()
        for r in rows:
            w.writerow({k: (fmt(r[k], 6) if isinstance(r[k], float) else r[k]) for k in fields})


def table(rows: list[dict]) -> str:
    groups: dict = defaultdict(list)
    for r in rows:
        groups[(r["effect"], r["level_index"], r["level"])].append(r)
    order = sorted(groups, key=lambda g: (EFFECT_ORDER.index(g[0]) if g[0] in EFFECT_ORDER else 99, g[0], g[1]))
    head = "| effect | level | strength | synthcam det % | synthcam RMS px | classic det % | classic RMS px | SB det % | SB RMS px |"
    lines = [head, "|" + "---|" * 9]
    for key in order:
        sel = groups[key]
        strength = np.mean([r["strength"] for r in sel if r["detector"] == "synthcam"])
        cells = []
        for det in ("synthcam",) + DETECTORS:
            d = [r for r in sel if r["detector"] == det]
            found = [r["rms_px"] for r in d if r["detected"]]
            rate = 100.0 * len(found) / max(len(d), 1)
            cells += [f"{rate:.0f}", fmt(float(np.mean(found)) if found else float("nan"), 4)]
        lines.append(f"| {key[0]} | {key[2]} | {fmt(float(strength), 3)} | " + " | ".join(cells) + " |")
    times = {det: [r["time_ms"] for r in rows if r["detector"] == det] for det in DETECTORS}
    lines.append("")
    lines.append("Median OpenCV time per image: " + ", ".join(f"{d} {np.median(t):.1f} ms" for d, t in times.items() if t) + ".")
    return "\n".join(lines) + "\n"


def main() -> int:
    if len(sys.argv) != 2 or sys.argv[1] in ("-h", "--help"):
        print(__doc__)
        return 2
    out = Path(sys.argv[1])
    t0 = time.perf_counter()
    rows = run(out)
    write_csv(out / "opencv.csv", rows)
    md = table(rows)
    (out / "table_with_opencv.md").write_text(md)
    print(md)
    print(f"wrote {out / 'opencv.csv'} and {out / 'table_with_opencv.md'} ({time.perf_counter() - t0:.1f} s)", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
