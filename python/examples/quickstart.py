"""Render a distorted chessboard, detect its corners and print their error against the truth.

    python python/examples/quickstart.py      (from the repository root)
"""
import numpy as np
import synthcam

scene = open("assets/scenes/chessboard_k1.toml").read()  # k1 = -0.25, 12 x 9 squares, tilted 40 deg
image, truth = synthcam.render(scene)
found = synthcam.detect(image, "chessboard:11x8")
err = found.points_px - truth.pixels_px  # (88, 2) each: typed results with NumPy arrays
print(f"{len(err)} corners, RMS error vs truth {np.sqrt((err ** 2).sum(1).mean()):.4f} px on {synthcam.adapter()}")
