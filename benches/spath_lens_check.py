#!/usr/bin/env python3
"""How well a whole view's S-path labelling fits one camera, with and without a radial lens term.

Usage (on the folders `benches/spath_independent.py` writes):
    python3 benches/spath_lens_check.py OUT/caps/B_04.det.json [more .det.json ...]

For each detection JSON (its `.truth.json` beside it), the reported labelling and the true one
(each reported point given the index of the exact centroid nearest it) are fitted, over all of
the view's reported dots, by a normalised DLT (Hartley and Zisserman, 7.1) and by a DLT after the
one-parameter division model about the image centre (Fitzgibbon, "Simultaneous linear estimation
of multiple view geometry and lens distortion", CVPR 2001), its parameter swept on a grid.
Prints both reprojection RMS values (px) per labelling: a labelling with a stretch one index off
fits the whole view worse than the right one, and the division model brings the right one to the
noise level where the lens has barrel distortion. Analysis only: not a gate.
"""
import json
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from spath_independent import s_path  # noqa: E402

CENTRE = np.array([640.0, 512.0])
LAMBDAS = np.linspace(-4e-7, 4e-7, 81)


def dlt_rms(world, image):
    """Reprojection RMS (px) of the normalised DLT fitted to the correspondences."""
    mu, mx = image.mean(0), world.mean(0)
    su = np.sqrt(2) / np.mean(np.linalg.norm(image - mu, axis=1))
    sx = np.sqrt(3) / np.mean(np.linalg.norm(world - mx, axis=1))
    un, xn = (image - mu) * su, (world - mx) * sx
    rows = []
    for x, (a, b) in zip(xn, un):
        xh = np.r_[x, 1.0]
        rows += [np.r_[xh, np.zeros(4), -a * xh], np.r_[np.zeros(4), xh, -b * xh]]
    p = np.linalg.svd(np.array(rows))[2][-1].reshape(3, 4)
    y = (p @ np.c_[xn, np.ones(len(xn))].T).T
    return float(np.sqrt(((y[:, :2] / y[:, 2:3] - un) ** 2).sum(1).mean()) / su)


def division_rms(world, image):
    """The least DLT RMS over the division model's grid, and its parameter."""
    d = image - CENTRE
    r2 = (d ** 2).sum(1)
    return min((dlt_rms(world, CENTRE + d / (1 + lam * r2)[:, None]), lam) for lam in LAMBDAS)


def main():
    path = np.asarray(s_path())
    for det_file in map(Path, sys.argv[1:]):
        det = json.loads(det_file.read_text())["images"][0]
        truth = json.loads(det_file.with_name(det_file.name.replace(".det.json", ".truth.json").replace(".det_camera.json", ".truth.json")).read_text())
        if not det["found"]:
            print(f"{det_file}: not found")
            continue
        image = np.array(det["points_px"])
        centres = np.array([c if c else [1e9, 1e9] for c in truth["centroid_px"]])
        true_idx = np.array([int(np.argmin(np.hypot(*(centres - p).T))) for p in image])
        wrong = int((np.array(det["indices"]) != true_idx).sum())
        print(f"{det_file}: {len(image)} dots, {wrong} at a wrong index")
        for name, idx in [("reported", np.array(det["indices"])), ("truth", true_idx)]:
            rms, lam = division_rms(path[idx], image)
            print(f"  {name:8s} DLT {dlt_rms(path[idx], image):.3f} px, DLT + division {rms:.3f} px (lambda {lam:.2e})")


if __name__ == "__main__":
    main()
