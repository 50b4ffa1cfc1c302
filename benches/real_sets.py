#!/usr/bin/env python3
"""Every real chessboard set in ``../shared/data/`` (listed in ``tests/data/real_sets.toml``):
``synthcam detect`` beside OpenCV's classic and SB detectors, one table row per set.

A benchmark / reference tool only (numpy + opencv-python-headless; OpenCV is never a dependency
of the synthcam crate). The CI gate on the same sets is ``tests/e2e/real_sets.rs``; this script
prints the table for the notes, the files each detector misses, and (``--opencv``) re-measures
OpenCV on this machine instead of quoting the counts the folders' READMEs state.

Usage
-----
    python3 benches/real_sets.py [--opencv] [--sets NAME ...] [--synthcam PATH] [--json OUT]

OpenCV, as in the READMEs: classic = ``findChessboardCorners(ADAPTIVE_THRESH | NORMALIZE_IMAGE)``,
SB = ``findChessboardCornersSB(flags=0)``, grey input, ``cv2.setNumThreads(1)``. synthcam runs
with ``RAYON_NUM_THREADS=1``; times are per-image medians of the detection call alone.
Exit status: 0 when every set meets the gate (synthcam >= max(classic, SB), no board on a
negative), 1 otherwise, 2 on bad arguments or a missing data folder.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
EXTS = {".png", ".jpg", ".jpeg"}


def images(folder: Path) -> list[Path]:
    return sorted(p for p in folder.iterdir() if p.suffix.lower() in EXTS)


def run_synthcam(binary: str, files: list[Path], pattern: list[int]) -> dict[str, tuple[bool, float, list]]:
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "det.json"
        env = dict(os.environ, RAYON_NUM_THREADS="1")
        cmd = [binary, "detect", *map(str, files), "--target", f"chessboard:{pattern[0]}x{pattern[1]}", "--json", str(out)]
        subprocess.run(cmd, check=True, env=env, stdout=subprocess.DEVNULL)
        data = json.loads(out.read_text())
    return {r["file"]: (bool(r["found"]), float(r.get("time_ms", 0.0)), r.get("points_px", [])) for r in data["images"]}


def run_opencv(files: list[Path], pattern: list[int]) -> dict[str, dict[str, tuple[bool, float, list]]]:
    import cv2

    cv2.setNumThreads(1)
    size = (pattern[0], pattern[1])
    res: dict[str, dict[str, tuple[bool, float, list]]] = {"classic": {}, "sb": {}}
    for f in files:
        g = cv2.imread(str(f), cv2.IMREAD_GRAYSCALE | cv2.IMREAD_IGNORE_ORIENTATION)
        t0 = time.perf_counter()
        ok, c = cv2.findChessboardCorners(g, size, flags=cv2.CALIB_CB_ADAPTIVE_THRESH | cv2.CALIB_CB_NORMALIZE_IMAGE)
        t1 = time.perf_counter()
        ok_sb, c_sb = cv2.findChessboardCornersSB(g, size, flags=0)
        t2 = time.perf_counter()
        if ok:
            c = cv2.cornerSubPix(g, c, (5, 5), (-1, -1), (cv2.TERM_CRITERIA_EPS | cv2.TERM_CRITERIA_MAX_ITER, 30, 0.01))
        res["classic"][f.name] = (bool(ok), (t1 - t0) * 1e3, c.reshape(-1, 2).tolist() if ok else [])
        res["sb"][f.name] = (bool(ok_sb), (t2 - t1) * 1e3, c_sb.reshape(-1, 2).tolist() if ok_sb else [])
    return res


def worst_disagreement(a: list, b: list) -> float:
    """Largest distance from a corner of `a` to the nearest corner of `b` (order-agnostic), px."""
    import numpy as np

    pa, pb = np.asarray(a, float), np.asarray(b, float)
    d = np.linalg.norm(pa[:, None, :] - pb[None, :, :], axis=2)
    return float(d.min(axis=1).max())


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--data", default=str(ROOT.parent / "shared" / "data"))
    ap.add_argument("--synthcam", default=os.environ.get("SYNTHCAM_BIN", str(ROOT / "target" / "release" / "synthcam")))
    ap.add_argument("--opencv", action="store_true", help="re-measure OpenCV here (default: the READMEs' counts)")
    ap.add_argument("--sets", nargs="*", help="only these folders")
    ap.add_argument("--json", help="write the rows here")
    a = ap.parse_args()
    data = Path(a.data)
    if not data.is_dir():
        print(f"error: {data} is not a folder", file=sys.stderr)
        return 2
    sets = tomllib.loads((ROOT / "tests" / "data" / "real_sets.toml").read_text())["set"]
    if a.sets:
        sets = [s for s in sets if s["folder"] in a.sets]
    rows, ok_all = [], True
    print("| set | split | images | synthcam | OpenCV classic | OpenCV SB | synthcam ms | worst px vs OpenCV | synthcam misses |")
    print("|---|---|---|---|---|---|---|---|---|")
    for s in sets:
        files = images(data / s["folder"])
        sc = run_synthcam(a.synthcam, files, s["pattern"])
        n_sc = sum(v[0] for v in sc.values())
        worst = "-"
        if a.opencv:
            cv = run_opencv(files, s["pattern"])
            n_cl, n_sb = (sum(v[0] for v in cv[k].values()) for k in ("classic", "sb"))
            # where synthcam and an OpenCV detector both report the board: the worst corner gap
            gaps = [worst_disagreement(sc[n][2], v[2]) for k in ("classic", "sb") for n, v in cv[k].items() if v[0] and sc.get(n, (False,))[0]]
            worst = f"{max(gaps):.2f}" if gaps else "-"
        else:
            n_cl, n_sb = s["classic"], s["sb"]
        neg_hits = [n for n in s.get("negatives", []) if sc.get(n, (False, 0))[0]]
        ok = n_sc >= max(n_cl, n_sb) and not neg_hits
        ok_all &= ok
        misses = [n for n, v in sc.items() if not v[0] and n not in s.get("negatives", [])]
        med = statistics.median(v[1] for v in sc.values())
        print(f"| {s['folder']} | {s['split']} | {len(files)} | {n_sc} | {n_cl} | {n_sb} | {med:.1f} | {worst} | {', '.join(misses) or '-'}{' FAIL' if not ok else ''} |")
        rows.append({"set": s["folder"], "split": s["split"], "images": len(files), "synthcam": n_sc, "classic": n_cl, "sb": n_sb, "synthcam_median_ms": med, "worst_px_vs_opencv": worst, "misses": misses, "negative_hits": neg_hits})
    if a.json:
        Path(a.json).write_text(json.dumps(rows, indent=1))
    return 0 if ok_all else 1


if __name__ == "__main__":
    sys.exit(main())
