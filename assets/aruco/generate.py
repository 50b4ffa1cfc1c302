#!/usr/bin/env python3
"""Writes the ArUco / AprilTag code tables synthcam embeds (crates/core/src/target/aruco.rs).

Source: OpenCV's predefined dictionaries (modules/objdetect/src/aruco/predefined_dictionaries.hpp,
Apache-2.0; the AprilTag families there come from the AprilTag library, BSD-2-Clause), read through
opencv-python's cv2.aruco. Each smaller OpenCV dictionary (DICT_4X4_50 ...) is a prefix of the
largest of its size, so one file per table: `NAME.bits`, for each marker id in order its n x n
inner bits row-major (1 = white), packed most significant bit first into ceil(n*n / 8) bytes,
taken from cv2.aruco.generateImageMarker at one pixel per bit.

    python3 assets/aruco/generate.py      # rewrites assets/aruco/*.bits
"""
import os

import cv2
import numpy as np

TABLES = ["DICT_4X4_1000", "DICT_5X5_1000", "DICT_6X6_1000", "DICT_7X7_1000", "DICT_ARUCO_ORIGINAL",
          "DICT_APRILTAG_16h5", "DICT_APRILTAG_25h9", "DICT_APRILTAG_36h10", "DICT_APRILTAG_36h11",
          "DICT_ARUCO_MIP_36h12"]


def main():
    here = os.path.dirname(os.path.abspath(__file__))
    for name in TABLES:
        d = cv2.aruco.getPredefinedDictionary(getattr(cv2.aruco, name))
        n = d.markerSize
        out = bytearray()
        for i in range(d.bytesList.shape[0]):
            img = cv2.aruco.generateImageMarker(d, i, n + 2)
            bits = (img[1:-1, 1:-1] > 127).astype(np.uint8).ravel()
            out += np.packbits(bits).tobytes()
        with open(os.path.join(here, name + ".bits"), "wb") as f:
            f.write(out)
        print(name, n, d.bytesList.shape[0], len(out), "bytes")


if __name__ == "__main__":
    main()
