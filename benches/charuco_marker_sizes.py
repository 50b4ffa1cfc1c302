#!/usr/bin/env python3
"""ChArUco recall by marker size: ``synthcam detect`` beside ``cv2.aruco.CharucoDetector`` on
renders of small, tilted boards, scored against the renderer's truth per marker-size bin.

The renders come from ``assets/specs/charuco_small_tilted_1280.toml`` (1280 x 1024, fx 1000,
k1 -0.1, noise 2, boards 0.4-1.3 m away tilted 0-60 degrees: marker sides about 9-60 px) in four
variants: 11 x 8 and 10 x 8 squares, each in OpenCV's current and legacy layout, the spec's
``seed`` replaced by ``--seed`` (plus 0, 1, 2, 3 for the variants) and ``count`` by ``--count``.

Usage
-----
    cargo build --release
    python3 benches/charuco_marker_sizes.py --out /tmp/chs/s201 --seed 201 --render   # tuning set
    python3 benches/charuco_marker_sizes.py --out /tmp/chs/s301 --seed 301 --render   # held out
    python3 benches/charuco_marker_sizes.py --out /tmp/chs/s301 --seed 301            # score again
    python3 benches/charuco_marker_sizes.py --out /tmp/chs/far401 --seed 401 --render --distance-m 1.4 1.9  # small markers

Scoring (as ``coded_boards.py``): a corner is expected when its truth lies in front of the camera
and at least ``--border`` (3) px inside the image; a detection farther than 2 px from its id's
truth is a wrong id; RMS / max over the rest. Each corner's bin is the mean side (perimeter / 4)
of its adjacent markers' truth outlines; each image's bin (time) is the median over its markers.
Times: single-threaded (``cv2.setNumThreads(1)``, ``RAYON_NUM_THREADS=1``), the two detectors in
turn for ``--repeat`` rounds over a variant's images, each image's fastest round kept; the table
gives the summed times of the images in a bin and their ratio.
A last line lists the views where synthcam finds fewer right corners than OpenCV.
"""

import argparse
import json
import re
import subprocess
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import coded_boards as cb  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
SPEC = ROOT / "assets/specs/charuco_small_tilted_1280.toml"
VARIANTS = [("11x8", [11, 8], False), ("11x8_legacy", [11, 8], True), ("10x8", [10, 8], False), ("10x8_legacy", [10, 8], True)]
BINS = [(0, 10), (10, 12), (12, 14), (14, 20), (20, 30), (30, 1e9)]


def bin_name(b):
    lo, hi = b
    return f"<{hi:g}" if lo == 0 else (f">{lo:g}" if hi > 1e8 else f"{lo:g}-{hi:g}")


def bin_of(side):
    return next(b for b in BINS if b[0] <= side < b[1])


def render(out, seed, count, binary, distance_m=None):
    base = SPEC.read_text()
    if distance_m:
        base = re.sub(r"(?m)^distance_m = \[.*\]", f"distance_m = [{distance_m[0]}, {distance_m[1]}]", base)
    for k, (name, squares, legacy) in enumerate(VARIANTS):
        text = re.sub(r"(?m)^seed = \d+", f"seed = {seed + k}", base)
        text = re.sub(r"(?m)^count = \d+", f"count = {count}", text)
        text = re.sub(r"(?m)^squares = \[11, 8\]", f"squares = [{squares[0]}, {squares[1]}]\nlegacy = {'true' if legacy else 'false'}", text)
        d = Path(out) / name
        d.mkdir(parents=True, exist_ok=True)
        (d / "spec_in.toml").write_text(text)
        subprocess.run([binary, "dataset", str(d / "spec_in.toml"), "-o", str(d)], check=True, capture_output=True)


def marker_sides(truth):
    """{marker id: mean side px} of the truth outlines."""
    out = {}
    for m in truth["markers"]:
        c = np.array(m["corners_px"])
        out[m["id"]] = float(np.mean(np.linalg.norm(c - np.roll(c, 1, axis=0), axis=1)))
    return out


def corner_markers(squares, legacy):
    """{corner id: adjacent marker ids} from OpenCV's board layout."""
    import cv2

    board = cv2.aruco.CharucoBoard(tuple(squares), 1.0, 0.733, cv2.aruco.getPredefinedDictionary(cv2.aruco.DICT_5X5_100))
    board.setLegacyPattern(legacy)
    centres = {int(i): np.mean(np.array(p).reshape(4, 3)[:, :2], axis=0) for i, p in zip(np.array(board.getIds()).ravel(), board.getObjPoints())}
    out = {}
    for k, c in enumerate(np.array(board.getChessboardCorners()).reshape(-1, 3)[:, :2]):
        out[k] = [i for i, m in centres.items() if np.all(np.abs(m - c) < 0.75)]
    return out


def interleaved(images, repeat, opencv, target, binary):
    """{detector: {image: (points, ms)}}: the two detectors run in turn, `repeat` rounds over the
    images (OpenCV in-process, synthcam's CLI once per round), each image's fastest round kept (the
    machine's load varies between rounds; the fastest is the least disturbed)."""
    rounds = {"opencv": [], "synthcam": []}
    for _ in range(repeat):
        rounds["opencv"].append(cb.timed(images, 1, opencv))
        rounds["synthcam"].append(cb.run_synthcam(images, target, 1, binary))
    return {d: {k: (rs[0][k][0], min(r[k][1] for r in rs)) for k in rs[0]} for d, rs in rounds.items()}


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", required=True)
    ap.add_argument("--seed", type=int, required=True)
    ap.add_argument("--count", type=int, default=20)
    ap.add_argument("--render", action="store_true", help="render the four variants first")
    ap.add_argument("--distance-m", type=float, nargs=2, metavar=("NEAR", "FAR"), help="the spec's board distance range replaced (1.4 1.9: markers of about 8-16 px, the smallest bin)")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--border", type=float, default=3.0)
    ap.add_argument("--wrong-px", type=float, default=2.0)
    ap.add_argument("--binary", default=str(ROOT / "target/release/synthcam"))
    ap.add_argument("--json")
    a = ap.parse_args()
    if a.render:
        render(a.out, a.seed, a.count, a.binary, a.distance_m)
    rows = {d: {b: {"expected": 0, "right": 0, "wrong": 0, "errs": []} for b in BINS} for d in ("opencv", "synthcam")}
    times = {d: {b: [] for b in BINS} for d in ("opencv", "synthcam")}
    worse = []
    import cv2

    for name, squares, legacy in VARIANTS:
        images = cb.images_of([Path(a.out) / name / "images"])
        if not images:
            continue
        target = f"charuco:{squares[0]}x{squares[1]}:DICT_5X5_100:0.733" + (":legacy" if legacy else "")
        adj = corner_markers(squares, legacy)
        res = interleaved(images, a.repeat, cb.charuco_opencv(tuple(squares), cb.dictionary("DICT_5X5_100"), 0.733, legacy), target, a.binary)
        for p in images:
            t = json.loads(p.with_suffix(".json").read_text())
            truth, (w, h) = cb.truth_of(p)
            sides = marker_sides(t)
            corner_side = {i: float(np.mean([sides[m] for m in adj[i]])) for i in truth}
            image_bin = bin_of(float(np.median(list(sides.values()))))
            inside = {i for i, (q, front) in truth.items() if front and a.border <= q[0] <= w - 1 - a.border and a.border <= q[1] <= h - 1 - a.border}
            right_by = {}
            for d, r in res.items():
                pts, ms = r[str(p)]
                times[d][image_bin].append(ms)
                for i in inside:
                    rows[d][bin_of(corner_side[i])]["expected"] += 1
                n_right = 0
                for i, q in pts:
                    if i not in truth or np.linalg.norm(q - truth[i][0]) > a.wrong_px:
                        rows[d][bin_of(corner_side.get(i, 0.0))]["wrong"] += 1
                        continue
                    e = rows[d][bin_of(corner_side[i])]
                    e["errs"].append(float(np.linalg.norm(q - truth[i][0])))
                    if i in inside:
                        e["right"] += 1
                        n_right += 1
                right_by[d] = n_right
            if right_by["synthcam"] < right_by["opencv"]:
                worse.append(f"{name}/{p.name}: synthcam {right_by['synthcam']}, opencv {right_by['opencv']} of {len(inside)}")
    print(f"OpenCV {cv2.__version__}; seed {a.seed}; {a.out}")
    print(f"{'marker side px':>14} {'detector':9} {'recall':>8} {'right/expected':>15} {'wrong':>5} {'RMS px':>7} {'max px':>7} {'images':>6} {'sum ms':>8} {'ms/image':>8}")
    summary = {}
    for b in BINS + [None]:
        for d in ("opencv", "synthcam"):
            sel = BINS if b is None else [b]
            exp = sum(rows[d][x]["expected"] for x in sel)
            right = sum(rows[d][x]["right"] for x in sel)
            wrong = sum(rows[d][x]["wrong"] for x in sel)
            errs = np.array([e for x in sel for e in rows[d][x]["errs"]] or [np.nan])
            ts = [t for x in sel for t in times[d][x]]
            r = {
                "recall": right / max(exp, 1),
                "right": right,
                "expected": exp,
                "wrong_ids": wrong,
                "rms_px": float(np.sqrt(np.mean(errs**2))),
                "max_px": float(np.max(errs)),
                "images": len(ts),
                "sum_ms": float(sum(ts)),
            }
            summary[f"{'all' if b is None else bin_name(b)}/{d}"] = r
            label = "all" if b is None else bin_name(b)
            print(
                f"{label:>14} {d:9} {100 * r['recall']:7.2f}% {right:7d}/{exp:<7d} {wrong:5d} {r['rms_px']:7.4f} {r['max_px']:7.4f} {len(ts):6d} {r['sum_ms']:8.1f} {r['sum_ms'] / max(len(ts), 1):8.2f}"
            )
        o, s = summary[f"{'all' if b is None else bin_name(b)}/opencv"], summary[f"{'all' if b is None else bin_name(b)}/synthcam"]
        if o["sum_ms"] > 0:
            print(f"{'':>14} time synthcam / opencv {s['sum_ms'] / o['sum_ms']:.3f}")
    print(f"views where synthcam finds fewer right corners than OpenCV: {len(worse)}" + "".join("\n  " + w for w in worse))
    if a.json:
        Path(a.json).write_text(json.dumps({"seed": a.seed, "opencv_version": cv2.__version__, "rows": summary, "worse_views": worse}, indent=2))


if __name__ == "__main__":
    main()
