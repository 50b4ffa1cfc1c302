#!/usr/bin/env python3
"""Compare OpenCV's chessboard detectors with ``synthcam detect`` on the same images.

A benchmark / reference tool only: OpenCV is never a dependency of the synthcam crate.
Requires Python 3.11 with numpy and opencv-python-headless
(``pip install opencv-python-headless numpy``); no network access at run time.

Usage
-----
    python3 benches/compare_opencv.py --images ../shared/data/opencv_left --pattern 9x6
    python3 benches/compare_opencv.py --images ../scratch/detect_data/board_0*.png \
        --pattern 8x6 --truth --json /tmp/cmp.json
    python3 benches/compare_opencv.py --images DIR --pattern 9x6 \
        --reference ../shared/data/opencv_left/opencv_reference.json

Detectors (flags identical to ``shared/data/opencv_left/opencv_reference.json`` -> ``meta``,
so the numbers are comparable with the stored reference):

* ``classic``: ``findChessboardCorners(flags=ADAPTIVE_THRESH|NORMALIZE_IMAGE)`` followed by
  ``cornerSubPix(winSize=(11,11), zeroZone=(-1,-1), criteria=EPS|MAX_ITER,30,0.001)``; both
  calls are timed together (``--subpix-win`` / ``--subpix-eps`` change the refinement).
* ``sb``: ``findChessboardCornersSB(flags=0)``.
* ``sb_acc``: ``findChessboardCornersSB(flags=NORMALIZE_IMAGE|EXHAUSTIVE|ACCURACY)``.
* ``synthcam``: ``<synthcam> detect <images...> --target chessboard:COLSxROWS --json TMP``;
  its per-image ``time_ms`` (detection on the decoded image, decode excluded) is used.

Timing: every image is decoded once to grey uint8 (``cv2.IMREAD_GRAYSCALE``); each OpenCV
detector then runs ``--repeat`` times on that array with ``time.perf_counter`` around the
call(s) only, and the per-image median is reported. synthcam is a separate process, so it is
run ``--repeat`` times on the same files and the median of its ``time_ms`` is taken per
image. The main pass uses ``cv2.setNumThreads(1)`` (synthcam: ``RAYON_NUM_THREADS=1``); a
second pass with OpenCV's default thread count (and synthcam's default environment)
is timed too unless ``--no-default-threads`` is given; its medians appear in the summary.

Truth (``--truth``): ``<image stem>.json`` beside each image, with ``features[i].pixel_px``
(exact corners, OpenCV pixel convention) and ``grid`` = [cols, rows]. Detected corners are
matched to truth order-agnostically (greedy global nearest-neighbour assignment, one-to-one)
and RMS / max distances are reported per image and over all corners of all found boards.

Consensus: on images where classic and sb_acc (``--consensus-sb``) both found the board and
agree within 0.3 px RMS, synthcam's corners are compared (order-agnostically) with the mean
of the two OpenCV corner sets.

Pixel convention everywhere: OpenCV's (centre of the top-left pixel is (0, 0)).

Exit status: 0 on success; 1 if some image could not be read (it is noted in the table and
the others are still processed); 2 on bad arguments (no images, bad pattern string, ...).
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import re
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

try:
    import cv2
    import numpy as np
except ImportError as exc:  # pragma: no cover - environment problem
    sys.exit(f"error: {exc}; install with `pip install opencv-python-headless numpy`")

IMAGE_SUFFIXES = {".png", ".jpg", ".jpeg"}
OPENCV_DETECTORS = ("classic", "sb", "sb_acc")
ALL_DETECTORS = OPENCV_DETECTORS + ("synthcam",)
LABELS = {"classic": "classic", "sb": "SB", "sb_acc": "SB-acc", "synthcam": "synthcam"}
CONSENSUS_RMS_PX = 0.3


def die(msg: str, code: int = 2) -> None:
    print(f"error: {msg}", file=sys.stderr)
    sys.exit(code)


# ----------------------------------------------------------------------------- inputs


def parse_pattern(text: str) -> tuple[int, int]:
    m = re.fullmatch(r"\s*(\d+)\s*[xX]\s*(\d+)\s*", text)
    if not m:
        raise argparse.ArgumentTypeError(f"bad pattern {text!r}: expected COLSxROWS, e.g. 9x6")
    cols, rows = int(m.group(1)), int(m.group(2))
    if cols < 2 or rows < 2:
        raise argparse.ArgumentTypeError(f"bad pattern {text!r}: need at least 2x2 inner corners")
    return cols, rows


def positive_int(text: str) -> int:
    try:
        v = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not an integer: {text!r}") from None
    if v < 1:
        raise argparse.ArgumentTypeError(f"must be >= 1: {text!r}")
    return v


def expand_images(items: list[str]) -> list[Path]:
    """Files as given (any suffix), folders expanded to their png/jpg files in name order."""
    out: list[Path] = []
    for item in items:
        p = Path(item)
        if p.is_dir():
            out.extend(sorted(q for q in p.iterdir() if q.is_file() and q.suffix.lower() in IMAGE_SUFFIXES))
        else:
            out.append(p)  # missing / unreadable files are reported per file later
    seen: dict[str, Path] = {}
    for p in out:
        if p.name in seen and seen[p.name].resolve() != p.resolve():
            die(f"two inputs share the file name {p.name!r} ({seen[p.name]} and {p}); "
                "synthcam results are matched by file name")
        seen[p.name] = p
    # drop exact duplicates, keep order
    uniq: dict[Path, None] = {}
    for p in out:
        uniq.setdefault(p.resolve(), None)
    return [Path(p) for p in uniq]


def load_truth(image: Path, pattern: tuple[int, int]) -> tuple[np.ndarray | None, str | None]:
    path = image.with_suffix(".json")
    try:
        doc = json.loads(path.read_text())
        grid = tuple(doc["grid"])
        pts = np.array([f["pixel_px"] for f in doc["features"]], dtype=np.float64).reshape(-1, 2)
    except (OSError, ValueError, KeyError, TypeError) as exc:
        return None, f"truth {path.name}: {exc}"
    if grid != pattern:
        return None, f"truth grid {list(grid)} != pattern {list(pattern)}"
    if len(pts) != pattern[0] * pattern[1]:
        return None, f"truth has {len(pts)} corners, pattern needs {pattern[0] * pattern[1]}"
    return pts, None


# ----------------------------------------------------------------------------- geometry


def match_points(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Distances of a one-to-one, order-agnostic matching of `a` to `b`.

    Greedy global nearest-neighbour: all pairs sorted by distance (stable, so deterministic),
    a pair is taken when neither point is used yet. Returns min(len(a), len(b)) distances
    together with the index pairs as an (n, 3) array [dist, ia, ib].
    """
    d = np.sqrt(((a[:, None, :] - b[None, :, :]) ** 2).sum(-1))
    n = min(len(a), len(b))
    used_a = np.zeros(len(a), bool)
    used_b = np.zeros(len(b), bool)
    out = []
    for flat in np.argsort(d, axis=None, kind="stable"):
        i, j = divmod(int(flat), d.shape[1])
        if not used_a[i] and not used_b[j]:
            used_a[i] = used_b[j] = True
            out.append((d[i, j], i, j))
            if len(out) == n:
                break
    return np.array(out, dtype=np.float64).reshape(-1, 3)


def err_stats(dists: np.ndarray) -> dict:
    if len(dists) == 0:
        return {"n": 0, "rms_px": None, "max_px": None}
    return {"n": int(len(dists)), "rms_px": float(np.sqrt(np.mean(dists**2))), "max_px": float(dists.max())}


# ----------------------------------------------------------------------------- OpenCV


def make_opencv_detectors(pattern: tuple[int, int], subpix_win: int, subpix_eps: float) -> dict:
    criteria = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_MAX_ITER, 30, subpix_eps)
    classic_flags = cv2.CALIB_CB_ADAPTIVE_THRESH | cv2.CALIB_CB_NORMALIZE_IMAGE
    sb_acc_flags = cv2.CALIB_CB_NORMALIZE_IMAGE | cv2.CALIB_CB_EXHAUSTIVE | cv2.CALIB_CB_ACCURACY

    def classic(gray):
        ok, corners = cv2.findChessboardCorners(gray, pattern, flags=classic_flags)
        if ok:
            corners = cv2.cornerSubPix(gray, corners, (subpix_win, subpix_win), (-1, -1), criteria)
        return ok, corners

    def sb(gray):
        return cv2.findChessboardCornersSB(gray, pattern, flags=0)

    def sb_acc(gray):
        return cv2.findChessboardCornersSB(gray, pattern, flags=sb_acc_flags)

    desc = {
        "classic": "findChessboardCorners(flags=ADAPTIVE_THRESH|NORMALIZE_IMAGE) + "
        f"cornerSubPix(winSize=({subpix_win},{subpix_win}), zeroZone=(-1,-1), "
        f"criteria=EPS|MAX_ITER,30,{subpix_eps:g})",
        "sb": "findChessboardCornersSB(flags=0)",
        "sb_acc": "findChessboardCornersSB(flags=NORMALIZE_IMAGE|EXHAUSTIVE|ACCURACY)",
    }
    return {"classic": classic, "sb": sb, "sb_acc": sb_acc}, desc


def time_opencv(fn, gray: np.ndarray, repeat: int) -> tuple[bool, np.ndarray | None, list[float], bool]:
    """Run `fn` `repeat` times; return found, corners (first run), times in ms, deterministic?"""
    times, first, stable = [], None, True
    for _ in range(repeat):
        t0 = time.perf_counter()
        ok, corners = fn(gray)
        t1 = time.perf_counter()
        times.append((t1 - t0) * 1e3)
        res = (bool(ok), None if not ok or corners is None else np.asarray(corners, np.float64).reshape(-1, 2))
        if first is None:
            first = res
        elif res[0] != first[0] or (res[0] and not np.array_equal(res[1], first[1])):
            stable = False
    return first[0], first[1], times, stable


# ----------------------------------------------------------------------------- synthcam


@dataclass
class SynthcamRun:
    ok: bool = False
    note: str = ""
    version: str = ""
    per_image: dict = field(default_factory=dict)  # basename -> {found, points, times, note}


def run_synthcam(binary: str, files: list[Path], pattern: tuple[int, int], runs: int,
                 single_thread: bool) -> SynthcamRun:
    res = SynthcamRun()
    exe = shutil.which(binary) or (binary if Path(binary).is_file() else None)
    repo_rel = Path(__file__).resolve().parent.parent / binary  # default path is relative to the repo root
    if exe is None and not Path(binary).is_absolute() and repo_rel.is_file():
        exe = str(repo_rel)
    if exe is None:
        res.note = f"synthcam binary not found at {binary!r} (build it: cargo build --release); synthcam columns empty"
        return res
    try:
        help_out = subprocess.run([exe, "detect", "--help"], capture_output=True, text=True, timeout=60)
    except OSError as exc:
        res.note = f"cannot run {exe}: {exc}"
        return res
    if help_out.returncode != 0 or "--target" not in help_out.stdout:
        res.note = f"{exe} has no usable `detect` subcommand (rc {help_out.returncode}); synthcam columns empty"
        return res
    ver = subprocess.run([exe, "--version"], capture_output=True, text=True, timeout=60)
    res.version = ver.stdout.strip()
    env = dict(os.environ)
    if single_thread:
        env["RAYON_NUM_THREADS"] = "1"
    names = {p.name for p in files}
    target = f"chessboard:{pattern[0]}x{pattern[1]}"
    with tempfile.TemporaryDirectory(prefix="synthcam_cmp_") as tmp:
        for r in range(runs):
            out = Path(tmp) / f"run{r}.json"
            cmd = [exe, "detect", *map(str, files), "--target", target, "--json", str(out)]
            try:
                proc = subprocess.run(cmd, capture_output=True, text=True, env=env, timeout=1800)
            except (OSError, subprocess.TimeoutExpired) as exc:
                res.note = f"synthcam detect failed: {exc}"
                return res
            try:
                doc = json.loads(out.read_text())
            except (OSError, ValueError) as exc:
                tail = (proc.stderr or proc.stdout).strip().splitlines()[-3:]
                res.note = f"synthcam detect rc {proc.returncode}, no JSON ({exc}): {' | '.join(tail)}"
                return res
            for im in doc.get("images", []):
                name = Path(str(im.get("file", ""))).name
                if name not in names:
                    continue
                pts = np.asarray(im.get("points_px") or [], np.float64).reshape(-1, 2)
                entry = res.per_image.setdefault(name, {"found": bool(im.get("found")), "points": pts,
                                                        "times": [], "note": im.get("note") or im.get("error") or "",
                                                        "stable": True})
                if im.get("time_ms") is not None:
                    entry["times"].append(float(im["time_ms"]))
                if entry["found"] != bool(im.get("found")) or not np.array_equal(entry["points"], pts):
                    entry["stable"] = False
    res.ok = True
    return res


# ----------------------------------------------------------------------------- report


def fmt(v, spec=".2f", none="–"):
    return none if v is None else format(v, spec)


def fmt_ms(v):
    """Milliseconds: 2 decimals, or 3 significant digits below 1 ms."""
    return "–" if v is None else (f"{v:.2f}" if v >= 1 else f"{v:.3g}")


def median_or_none(xs):
    xs = [x for x in xs if x is not None]
    return statistics.median(xs) if xs else None


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--images", nargs="+", required=True, metavar="DIR_OR_FILE",
                    help="image files and/or folders (png/jpg; folders in name order)")
    ap.add_argument("--pattern", type=parse_pattern, required=True, help="inner corners COLSxROWS, e.g. 9x6")
    ap.add_argument("--synthcam", default="target/release/synthcam", help="synthcam binary (default: %(default)s)")
    ap.add_argument("--repeat", type=positive_int, default=5, help="runs per detector and image; median taken (default 5)")
    ap.add_argument("--truth", action="store_true", help="read <stem>.json truth beside each image")
    ap.add_argument("--json", metavar="OUT", help="also write all numbers (and corners) here")
    ap.add_argument("--reference", metavar="JSON", help="opencv_reference.json to check OpenCV results against")
    ap.add_argument("--detectors", default=",".join(ALL_DETECTORS),
                    help="comma list out of classic,sb,sb_acc,synthcam (default: all)")
    ap.add_argument("--consensus-sb", choices=("sb", "sb_acc"), default="sb_acc",
                    help="SB variant paired with classic for the consensus check (default sb_acc)")
    ap.add_argument("--subpix-win", type=positive_int, default=11, help="cornerSubPix half window (default 11, as the reference)")
    ap.add_argument("--subpix-eps", type=float, default=0.001, help="cornerSubPix EPS criterion (default 0.001, as the reference)")
    ap.add_argument("--no-default-threads", action="store_true", help="skip the timing pass with OpenCV's default threads")
    ap.add_argument("--calibrate", action="store_true",
                    help="also calibrate: cv2.calibrateCamera on classic's corners vs `synthcam calibrate` on synthcam's")
    args = ap.parse_args(argv)

    dets = [d.strip() for d in args.detectors.split(",") if d.strip()]
    bad = [d for d in dets if d not in ALL_DETECTORS]
    if bad or not dets:
        die(f"unknown detector(s) {bad}; choose from {','.join(ALL_DETECTORS)}")
    cv_dets = [d for d in OPENCV_DETECTORS if d in dets]
    use_sc = "synthcam" in dets
    cols, rows = args.pattern
    files = expand_images(args.images)
    if not files:
        die(f"no images (png/jpg) in {args.images}")

    fns, fn_desc = make_opencv_detectors((cols, rows), args.subpix_win, args.subpix_eps)
    default_threads = cv2.getNumThreads()

    # ---- decode once
    images: dict[str, dict] = {}
    read_errors = 0
    for p in files:
        rec = {"file": str(p), "size": None, "error": None, "truth_note": None, "truth": None, "det": {}}
        gray = cv2.imread(str(p), cv2.IMREAD_GRAYSCALE) if p.is_file() else None
        if gray is None:
            rec["error"] = "missing" if not p.exists() else "unreadable / not an image"
            read_errors += 1
            print(f"error: {p}: {rec['error']}", file=sys.stderr)
        else:
            rec["gray"] = gray
            rec["size"] = (gray.shape[1], gray.shape[0])
            if args.truth:
                rec["truth"], rec["truth_note"] = load_truth(p, (cols, rows))
        images[p.name] = rec
    readable = [p for p in files if images[p.name]["error"] is None]
    if not readable:
        die("none of the images could be read", 1 if files else 2)

    # ---- OpenCV, 1 thread (results + timings), then default threads (timings only)
    cv2.setNumThreads(1)
    for p in readable:
        rec = images[p.name]
        for d in cv_dets:
            found, pts, times, stable = time_opencv(fns[d], rec["gray"], args.repeat)
            rec["det"][d] = {"found": found, "points": pts, "times_ms": times, "median_ms": statistics.median(times),
                             "stable": stable}
    mt_pass = not args.no_default_threads and default_threads != 1
    if mt_pass:
        cv2.setNumThreads(default_threads)
        for p in readable:
            rec = images[p.name]
            for d in cv_dets:
                _, _, times, _ = time_opencv(fns[d], rec["gray"], args.repeat)
                rec["det"][d]["times_ms_mt"] = times
                rec["det"][d]["median_ms_mt"] = statistics.median(times)
    cv2.setNumThreads(default_threads)

    # ---- synthcam
    sc_note, sc_version = "", ""
    if use_sc:
        sc = run_synthcam(args.synthcam, readable, (cols, rows), args.repeat, single_thread=True)
        sc_note, sc_version = sc.note, sc.version
        sc_mt = run_synthcam(args.synthcam, readable, (cols, rows), args.repeat, single_thread=False) \
            if sc.ok and mt_pass else None
        for p in readable:
            e = sc.per_image.get(p.name)
            if not sc.ok:
                continue
            if e is None:
                images[p.name]["det"]["synthcam"] = {"found": False, "points": None, "times_ms": [], "median_ms": None,
                                                     "note": "missing from synthcam JSON", "stable": True}
                continue
            images[p.name]["det"]["synthcam"] = {
                "found": e["found"], "points": e["points"] if e["found"] else None, "times_ms": e["times"],
                "median_ms": median_or_none(e["times"]), "note": e["note"], "stable": e["stable"]}
            if sc_mt is not None and p.name in sc_mt.per_image:
                t = sc_mt.per_image[p.name]["times"]
                images[p.name]["det"]["synthcam"]["times_ms_mt"] = t
                images[p.name]["det"]["synthcam"]["median_ms_mt"] = median_or_none(t)
    shown = cv_dets + (["synthcam"] if use_sc else [])

    # ---- errors vs truth and consensus
    n_corners = cols * rows
    for p in readable:
        rec = images[p.name]
        for d, r in rec["det"].items():
            r["count_ok"] = (not r["found"]) or (r["points"] is not None and len(r["points"]) == n_corners)
            if args.truth and rec["truth"] is not None and r["found"] and r["points"] is not None and len(r["points"]):
                m = match_points(r["points"], rec["truth"])
                r["truth_dists"] = m[:, 0]
                r["truth_err"] = err_stats(m[:, 0])
        c, s, y = rec["det"].get("classic"), rec["det"].get(args.consensus_sb), rec["det"].get("synthcam")
        if c and s and c["found"] and s["found"]:
            m = match_points(s["points"], c["points"])
            agree = err_stats(m[:, 0])
            rec["consensus"] = {"classic_vs_sb": agree, "used": agree["rms_px"] <= CONSENSUS_RMS_PX}
            if rec["consensus"]["used"] and y and y["found"] and y["points"] is not None and len(y["points"]):
                mean = c["points"].copy()
                mean[m[:, 2].astype(int)] = 0.5 * (c["points"][m[:, 2].astype(int)] + s["points"][m[:, 1].astype(int)])
                ym = match_points(y["points"], mean)
                rec["consensus"]["synthcam_vs_mean"] = err_stats(ym[:, 0])
                rec["consensus"]["_dists"] = ym[:, 0]

    # ---- table
    lab = " / ".join(LABELS[d] for d in shown)
    print(f"# synthcam vs OpenCV chessboard detectors — pattern {cols}x{rows}, {len(files)} image(s), repeat {args.repeat}\n")
    print(f"OpenCV {cv2.__version__}, numpy {np.__version__}, Python {platform.python_version()}, "
          f"{platform.machine()}, {os.cpu_count()} CPU(s); OpenCV default threads {default_threads}; "
          f"table times with cv2.setNumThreads(1)" + (" (synthcam with RAYON_NUM_THREADS=1)" if use_sc else "") + ".")
    for d in cv_dets:
        print(f"- {LABELS[d]}: `{fn_desc[d]}`")
    if use_sc:
        print(f"- synthcam: `{args.synthcam} detect … --target chessboard:{cols}x{rows}` "
              f"({sc_version or 'version unknown'}), its per-image time_ms, median of {args.repeat} runs")
        if sc_note:
            print(f"\n> **note:** {sc_note}")
    print()
    head = ["image", "size", f"found ({lab})", f"median ms ({lab})"]
    if args.truth:
        head += [f"{LABELS[d]} err RMS/max px" for d in shown]
    head.append("notes")
    print("| " + " | ".join(head) + " |")
    print("|" + "|".join("---" for _ in head) + "|")
    for p in files:
        rec = images[p.name]
        if rec["error"]:
            row = [p.name, "–", "–", "–"] + (["–"] * len(shown) if args.truth else []) + [f"**read error: {rec['error']}**"]
            print("| " + " | ".join(row) + " |")
            continue
        det = rec["det"]
        found = " / ".join(("–" if d not in det else ("Y" if det[d]["found"] else "n")) for d in shown)
        med = " / ".join(fmt_ms(det[d]["median_ms"]) if d in det else "–" for d in shown)
        row = [p.name, f"{rec['size'][0]}x{rec['size'][1]}", found, med]
        notes = []
        if args.truth:
            for d in shown:
                e = det.get(d, {}).get("truth_err")
                row.append(f"{fmt(e['rms_px'], '.3f')} / {fmt(e['max_px'], '.3f')}" if e else "–")
            if rec["truth_note"]:
                notes.append(rec["truth_note"])
        for d in shown:
            r = det.get(d)
            if r is None:
                continue
            if not r["count_ok"]:
                notes.append(f"{LABELS[d]}: {len(r['points'])} points, expected {n_corners}")
            if not r["stable"]:
                notes.append(f"{LABELS[d]}: results differ between repeats")
            if d == "synthcam" and not r["found"] and r.get("note"):
                notes.append(f"synthcam: {r['note']}")
        cons = rec.get("consensus")
        if cons and cons.get("synthcam_vs_mean"):
            notes.append(f"synthcam vs consensus RMS {cons['synthcam_vs_mean']['rms_px']:.3f} px")
        row.append("; ".join(notes))
        print("| " + " | ".join(row) + " |")

    # ---- summary
    summary: dict = {"detectors": {}}
    print("\n## Summary\n")
    print(("| detector | recall | median of medians ms (1 thread) | "
           + (f"median of medians ms ({default_threads} threads) | " if mt_pass else "")
           + ("images w/ truth | corners | err RMS px | err max px |" if args.truth else "")).rstrip())
    print("|---|---|---|" + ("---|" if mt_pass else "") + ("---|---|---|---|" if args.truth else ""))
    for d in shown:
        rs = [images[p.name]["det"][d] for p in readable if d in images[p.name]["det"]]
        if not rs:
            print(f"| {LABELS[d]} | – | – |" + (" – |" if mt_pass else "") + (" – | – | – | – |" if args.truth else ""))
            continue
        nf = sum(r["found"] for r in rs)
        mm = median_or_none([r["median_ms"] for r in rs])
        mmt = median_or_none([r.get("median_ms_mt") for r in rs])
        s = {"found": nf, "of": len(readable), "median_of_medians_ms_1thread": mm,
             "median_of_medians_ms_default_threads": mmt}
        line = f"| {LABELS[d]} | {nf}/{len(readable)} | {fmt_ms(mm)} |" + (f" {fmt_ms(mmt)} |" if mt_pass else "")
        if args.truth:
            ds = [r["truth_dists"] for r in rs if "truth_dists" in r]
            allv = np.concatenate(ds) if ds else np.zeros(0)
            e = err_stats(allv)
            s["truth"] = {"images": len(ds), **e}
            line += f" {len(ds)} | {e['n']} | {fmt(e['rms_px'], '.4f')} | {fmt(e['max_px'], '.4f')} |"
        summary["detectors"][d] = s
        print(line)
    print()
    if use_sc and "synthcam" in summary["detectors"]:
        ys = summary["detectors"]["synthcam"]["median_of_medians_ms_1thread"]
        if summary["detectors"]["synthcam"]["found"] == 0:
            print("- synthcam found no board: its times below are those of a failed search")
        for d in cv_dets:
            cs = summary["detectors"][d]["median_of_medians_ms_1thread"]
            if ys is not None and cs:
                print(f"- time ratio synthcam / {LABELS[d]} (median of per-image medians, 1 thread): {ys / cs:.3g}")
                summary[f"ratio_synthcam_over_{d}"] = ys / cs
    if "classic" in cv_dets and args.consensus_sb in cv_dets:
        cons = [images[p.name].get("consensus") for p in readable]
        both = [c for c in cons if c]
        used = [c for c in both if c["used"]]
        yd = [c["_dists"] for c in used if "_dists" in c]
        allv = np.concatenate(yd) if yd else np.zeros(0)
        e = err_stats(allv)
        summary["consensus"] = {"sb_variant": args.consensus_sb, "both_found": len(both), "agree_within_px": CONSENSUS_RMS_PX,
                                "agreeing": len(used), "synthcam_found_on_agreeing": len(yd), "synthcam_vs_mean": e}
        line = (f"- consensus (classic & {LABELS[args.consensus_sb]} both found: {len(both)}, "
                f"agree ≤ {CONSENSUS_RMS_PX} px RMS: {len(used)})")
        if any("synthcam" in images[p.name]["det"] for p in readable):
            line += (f": synthcam found on {len(yd)} of them; synthcam vs mean RMS {fmt(e['rms_px'], '.4f')} px, "
                     f"max {fmt(e['max_px'], '.4f')} px over {e['n']} corners")
        print(line)
    if read_errors:
        print(f"- **{read_errors} image(s) could not be read** (see table)")

    # ---- optional calibration, each side on its own detections (square = 1 board unit)
    calib = calibrate_both(args, images, readable, (cols, rows)) if args.calibrate else None

    # ---- optional check against a stored OpenCV reference
    ref_check = check_reference(args.reference, images, readable, cv_dets, args) if args.reference else None

    if args.json:
        dump = {
            "meta": {"opencv_version": cv2.__version__, "numpy_version": np.__version__,
                     "python": platform.python_version(), "machine": platform.machine(), "cpu_count": os.cpu_count(),
                     "opencv_default_threads": default_threads, "repeat": args.repeat, "pattern": [cols, rows],
                     "detectors": {d: fn_desc[d] for d in cv_dets}, "synthcam": args.synthcam,
                     "synthcam_version": sc_version, "synthcam_note": sc_note, "argv": sys.argv,
                     "pixel_convention": "OpenCV: centre of the top-left pixel is (0,0)",
                     "timing": "ms; perf_counter around the OpenCV call(s), decode excluded; synthcam: its time_ms"},
            "summary": summary, "reference_check": ref_check, "calibration": calib, "images": {}}
        for p in files:
            rec = images[p.name]
            out = {"file": rec["file"], "size_wh": rec["size"], "error": rec["error"], "truth_note": rec["truth_note"],
                   "detectors": {}}
            for d, r in rec["det"].items():
                out["detectors"][d] = {k: (v.tolist() if isinstance(v, np.ndarray) else v) for k, v in r.items()
                                       if k != "truth_dists"}
            if rec.get("consensus"):
                out["consensus"] = {k: v for k, v in rec["consensus"].items() if not k.startswith("_")}
            dump["images"][p.name] = out
        try:
            Path(args.json).write_text(json.dumps(dump, indent=1) + "\n")
        except OSError as exc:
            die(f"cannot write {args.json}: {exc}", 1)
        print(f"\nwrote {args.json}")
    return 1 if read_errors else 0


def opencv_calibrate(objp: np.ndarray, corners: list, size_wh: tuple[int, int], repeat: int):
    """cv2.calibrateCamera with 1 thread, `repeat` times: (rms, K, median ms)."""
    cv2.setNumThreads(1)
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        rms, K, _, _, _ = cv2.calibrateCamera([objp] * len(corners), corners, size_wh, None, None)
        times.append((time.perf_counter() - t0) * 1e3)
    return rms, K, statistics.median(times)


def calibrate_both(args, images: dict, readable: list[Path], pattern: tuple[int, int]) -> dict | None:
    """calibrateCamera (1 thread) on classic's corners vs `synthcam calibrate` on synthcam's corners,
    median times over --repeat; prints a table and returns the numbers."""
    cols, rows = pattern
    objp = np.array([[c, r, 0.0] for r in range(rows) for c in range(cols)], np.float32)
    out: dict = {}
    cv_views = [images[p.name]["det"]["classic"]["points"] for p in readable
                if images[p.name]["det"].get("classic", {}).get("found")]
    if len(cv_views) >= 3:
        h, w = images[readable[0].name]["gray"].shape[:2]
        corners = [np.asarray(v, np.float32).reshape(-1, 1, 2) for v in cv_views]
        rms, K, ms = opencv_calibrate(objp, corners, (w, h), args.repeat)
        out["opencv"] = {"views": len(corners), "rms_px": rms, "fx": K[0, 0], "fy": K[1, 1], "cx": K[0, 2], "cy": K[1, 2],
                         "median_ms": ms}
    sc = [(p, images[p.name]["det"].get("synthcam")) for p in readable]
    sc = [(p, d) for p, d in sc if d and d.get("found")]
    if len(sc) >= 3:
        h, w = images[sc[0][0].name]["gray"].shape[:2]
        det = {"images": [{"file": str(p), "width": w, "height": h, "found": True,
                           "points_px": np.asarray(d["points"]).tolist()} for p, d in sc]}
        with tempfile.TemporaryDirectory(prefix="synthcam_cal_") as tmp:
            dj, res = Path(tmp) / "det.json", Path(tmp) / "cal.json"
            dj.write_text(json.dumps(det))
            times, doc = [], None
            for _ in range(args.repeat):
                proc = subprocess.run([args.synthcam, "calibrate", str(dj), "--target", f"chessboard:{cols}x{rows}",
                                       "--square", "1", "--json", str(res)], capture_output=True, text=True)
                if proc.returncode != 0:
                    print(f"synthcam calibrate failed: {proc.stderr.strip()}")
                    break
                doc = json.loads(res.read_text())
                times.append(doc["time_ms"])
            if doc is not None:
                K = doc["K"]
                out["synthcam"] = {"views": len(sc), "rms_px": doc["rms_px"], "fx": K[0][0], "fy": K[1][1], "cx": K[0][2],
                                   "cy": K[1][2], "median_ms": statistics.median(times)}
    print("\n## Calibration (each on its own corners; 1 thread; median ms)\n")
    print("| | views | RMS px | fx | fy | cx | cy | ms |\n|---|---|---|---|---|---|---|---|")
    for name, r in out.items():
        print(f"| {name} | {r['views']} | {r['rms_px']:.4f} | {r['fx']:.3f} | {r['fy']:.3f} | {r['cx']:.3f} | {r['cy']:.3f} | {r['median_ms']:.2f} |")
    if "opencv" in out and "synthcam" in out:
        out["ratio_synthcam_over_opencv"] = out["synthcam"]["median_ms"] / out["opencv"]["median_ms"]
        print(f"\ntime ratio synthcam / OpenCV calibrateCamera: {out['ratio_synthcam_over_opencv']:.3f}")
    return out


def check_reference(path: str, images: dict, readable: list[Path], cv_dets: list[str], args) -> dict | None:
    """Compare found flags, corners and median times with opencv_reference.json."""
    try:
        ref = json.loads(Path(path).read_text())
        per = ref["per_image"]
    except (OSError, ValueError, KeyError) as exc:
        print(f"\n> **note:** cannot use reference {path}: {exc}")
        return None
    print(f"\n## Check against {path} (OpenCV {ref.get('meta', {}).get('opencv_version', '?')})\n")
    if args.subpix_win != 11 or args.subpix_eps != 0.001:
        print("> classic refinement differs from the reference's (11x11, 0.001): corner differences expected\n")
    print("| detector | images compared | found agrees | corners max |Δ| px | time ratio this/ref (1 thread, median) |")
    print("|---|---|---|---|---|")
    out = {}
    for d in cv_dets:
        n = agree = 0
        maxd, ratios = 0.0, []
        for p in readable:
            r, e = images[p.name]["det"].get(d), per.get(p.name)
            if r is None or e is None:
                continue
            n += 1
            rc = e.get("corners", {}).get(d)
            agree += (rc is not None) == r["found"]
            if rc is not None and r["found"]:
                maxd = max(maxd, float(match_points(r["points"], np.asarray(rc, np.float64).reshape(-1, 2))[:, 0].max()))
            rt = e.get("time_s_median_1thread", {}).get(d)
            if rt:
                ratios.append(r["median_ms"] / (rt * 1e3))
        ratio = median_or_none(ratios)
        out[d] = {"images": n, "found_agrees": agree, "corners_max_abs_diff_px": maxd, "time_ratio_median": ratio}
        print(f"| {LABELS[d]} | {n} | {agree}/{n} | {maxd:.3g} | {fmt(ratio)} |")
    return out


if __name__ == "__main__":
    sys.exit(main())
